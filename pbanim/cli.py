"""Command line: ``pbanim figures | bench | list``.

    pbanim figures [chNN ...] [--quick] [--out DIR]   regenerate lecture figures (one progress line each)
    pbanim bench NAME [--quick] [--json FILE]          run a benchmark family; ends with its goal lines
    pbanim list [figures|bench]                         what can be run
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path


def _default_out() -> Path:
    # figures/ at the repository root (beside pbanim/), the place the README points to
    return Path(__file__).resolve().parent.parent / "figures"


def load_chapters(selected: list[str] | None = None) -> dict:
    """Import the lecture chapters (all, or those in ``selected``, e.g. ``["ch02"]``) and return their figures.

    The command line is the top of the package, so it is the one place that imports the ``chapters``
    package (outside ``pbanim``); :mod:`pbanim.plotting` only holds the figures they register.
    """
    try:
        import chapters
    except ImportError as exc:  # pragma: no cover - installation problem
        raise RuntimeError("the 'chapters' package is not importable; install pbanim with "
                           "`pip install -e .` from the repository root") from exc
    return chapters.load(selected)


def cmd_figures(args) -> int:
    from .plotting import run_figure, write_index

    specs = load_chapters(args.chapters or None)
    out = Path(args.out) if args.out else _default_out()
    files = {}
    total = time.perf_counter()
    for i, (key, spec) in enumerate(specs.items(), 1):
        start = time.perf_counter()
        _, written = run_figure(spec, out, quick=args.quick)
        files[key] = written
        names = ", ".join(p.name for p in written) or "(no file)"
        print(f"[{i}/{len(specs)}] {key}: {names} ({time.perf_counter() - start:.1f}s)", flush=True)
    if not args.chapters:
        write_index(specs, out, files)
    print(f"{len(specs)} figures in {time.perf_counter() - total:.1f}s -> {out}")
    return 0


def cmd_bench(args) -> int:
    from .bench import format_report, run_bench, write_json

    rep = run_bench(args.name, quick=args.quick)
    print(format_report(rep), flush=True)
    if args.json:
        write_json(rep, args.json)
    return 0


def cmd_list(args) -> int:
    if args.what in ("figures", "all"):
        for key, spec in load_chapters().items():
            print(f"{key:40s} {spec.title}")
    if args.what in ("bench", "all"):
        from .bench import available

        for name in available():
            print(f"bench {name}")
    return 0


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(prog="pbanim", description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    sub = p.add_subparsers(dest="cmd", required=True)
    f = sub.add_parser("figures", help="regenerate lecture figures")
    f.add_argument("chapters", nargs="*", help="chapters to run, e.g. ch01 ch03 (default: all)")
    f.add_argument("--quick", action="store_true", help="small problems (the CI mode)")
    f.add_argument("--out", help="output folder (default: figures/ in the repository)")
    f.set_defaults(func=cmd_figures)
    b = sub.add_parser("bench", help="run a benchmark family")
    b.add_argument("name")
    b.add_argument("--quick", action="store_true")
    b.add_argument("--json", help="write rows and goal lines to this file")
    b.set_defaults(func=cmd_bench)
    ls = sub.add_parser("list", help="list figures and benchmarks")
    ls.add_argument("what", nargs="?", default="all", choices=["figures", "bench", "all"])
    ls.set_defaults(func=cmd_list)
    args = p.parse_args(argv)
    try:
        return args.func(args)
    except ValueError as exc:
        print(f"pbanim: error: {exc}", file=sys.stderr)
        return 2


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
