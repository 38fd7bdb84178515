"""Command line: ``pbanim figures | bench | compare | list | assignment | grade | notebook``.

    pbanim figures [chNN | chNN_name ...] [--quick] [--out DIR]     regenerate lecture figures (chapters or
           [--format png|svg|pdf] [--dpi N] [--style paper|slides]  single figures; one progress line each,
           [--jobs N]                                      on N processes, default one per core; slowest named)
    pbanim bench NAME [--quick] [--json FILE]          run a benchmark family; ends with its goal lines
    pbanim compare [SCENE ...] [--engines a,b] [--quick] [--markdown F] [--json F]
                                                       the same scenes in pbanim, PyBullet, MuJoCo vs the exact answer
    pbanim list [figures|bench|assignments]            what can be run, one line each
    pbanim assignment list | make NAME DIR             assignments cut from the reference (pbanim.course)
    pbanim grade NAME PATH [--json F] [--markdown F]   the autograder
    pbanim notebook chNN DIR                           a chapter as a Jupyter notebook
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

from .contracts import call_checked   # what the command line passes comes from the user: checked


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


def select_figures(names: list[str] | None) -> dict:
    """The figures named by ``names``: chapters (``ch03``, ``ch03_constraints``) and single figures
    (``ch03_drift``), in the order given, without repeats; all figures when empty. An unknown name raises
    ``ValueError`` with the closest names."""
    import difflib

    import chapters

    if not names:
        return load_chapters()
    mods = chapters.names()
    out: dict = {}
    for n in names:
        if any(m.startswith(n) for m in mods) and len(n) >= 4:
            out.update(load_chapters([n]))
            continue
        specs = load_chapters([n[:4]]) if any(m.startswith(n[:4]) for m in mods) and len(n) > 4 else {}
        if n in specs:
            out[n] = specs[n]
            continue
        pool = list(load_chapters()) + [m[:4] for m in mods]
        near = difflib.get_close_matches(n, pool, n=3, cutoff=0.5)
        hint = f" (did you mean {', '.join(repr(x) for x in near)}?)" if near else ""
        raise ValueError(f"unknown chapter or figure {n!r}{hint}; `pbanim list figures` shows them all")
    return out


def checked_by(keys) -> dict[str, list[str]]:
    """{figure key: ["tests/test_x.py::test_y", ...]}: the tests whose source names the key in quotes
    (the ``figure_data("key")`` checks); empty when the tests are not beside the package."""
    import ast

    tests = Path(__file__).resolve().parent.parent / "tests"
    found: dict[str, list[str]] = {k: [] for k in keys}
    for path in sorted(tests.glob("test_*.py")) if tests.is_dir() else []:
        if path.name == "test_chapters.py":
            continue
        text = path.read_text(encoding="utf-8")
        if not any(f'"{k}"' in text for k in keys):
            continue
        for node in ast.walk(ast.parse(text)):
            if isinstance(node, ast.FunctionDef) and node.name.startswith("test"):
                body = ast.get_source_segment(text, node) or ""
                for k in keys:
                    if f'"{k}"' in body:
                        found[k].append(f"tests/{path.name}::{node.name}")
    return found


def _chapter_files() -> dict[str, Path]:
    """{"chNN_topic": path of chapters/chNN_topic.py} for ``pbanim notebook`` (found here, where the
    chapters may be imported)."""
    import chapters

    root = Path(chapters.__file__).parent
    return {n: root / f"{n}.py" for n in chapters.names()}


def cmd_figures(args) -> int:
    from .bench import one_blas_thread
    from .plotting import run_figures, write_index

    with one_blas_thread():               # the figures that time solvers get the benchmarks' conditions
        return _figures(args, run_figures, write_index)


_WORKER: list = []


def _one_blas_thread_for_life() -> None:
    """A figure worker's initializer: one BLAS thread until the worker exits (every BLAS the figures load,
    numpy's and scipy's, is loaded first), so two workers on two cores never oversubscribe them."""
    import scipy.linalg  # noqa: F401  (scipy's BLAS loaded before the limit is applied)

    from .bench import one_blas_thread

    _WORKER.append(one_blas_thread())      # applied now, kept until the worker exits


def _figures(args, run_figures, write_index) -> int:
    specs = select_figures(args.chapters or None)
    out = Path(args.out) if args.out else _default_out()
    total, cpu, timeline = time.perf_counter(), {}, {}
    files, seconds, issues = call_checked(run_figures, specs, out, quick=args.quick, fmt=args.format, dpi=args.dpi,
                                          style=args.style, jobs=args.jobs, progress=lambda line: print(line, flush=True),
                                          initializer=_one_blas_thread_for_life, cpu=cpu, timeline=timeline)
    for line in issues:
        print(f"warning: {line}")
    if not args.chapters:
        write_index(specs, out, files, checked_by(list(specs)))
    wall = time.perf_counter() - total
    print(f"{len(specs)} figures in {wall:.1f}s ({sum(seconds.values()):.1f}s of figure time, "
          f"{sum(cpu.values()):.1f}s CPU) -> {out}")
    if len(specs) > 1:
        slow = sorted(seconds, key=lambda k: -seconds[k])[:5]
        print("slowest: " + ", ".join(f"{k} {seconds[k]:.1f}s" for k in slow))
        # CPU seconds: what a loaded machine inflates least, the numbers for the figures' cost= hints
        print("slowest by CPU: " + ", ".join(f"{k} {cpu[k]:.1f}s (hint {specs[k].cost:g})"
                                             for k in sorted(cpu, key=lambda k: -cpu[k])[:10]))
        line = workers_line(timeline)
        if line:
            print(line)
    return 0


def workers_line(timeline: dict) -> str:
    """How the figures shared the workers, from ``{key: (process id, start, end)}`` (wall clock): each worker's
    busy seconds, and the idle tail — how long the last worker ran alone after the others had finished (its
    last figure named). "" with one worker. When the longest figure exceeds an even share of the work, the
    tail cannot be balanced away and the line says so."""
    busy: dict = {}
    last: dict = {}
    for key, (pid, start, end) in timeline.items():
        busy[pid] = busy.get(pid, 0.0) + (end - start)
        if pid not in last or end > last[pid][0]:
            last[pid] = (end, key, end - start)
    if len(last) < 2:
        return ""
    order = sorted(last, key=lambda p: last[p][0])
    end, key, secs = last[order[-1]]
    tail = end - last[order[-2]][0]
    longest = max(b - a for _, a, b in timeline.values())
    share = sum(busy.values()) / len(busy)
    note = (f"; the longest figure ({longest:.0f}s) exceeds an even share ({share:.0f}s): no schedule balances it"
            if longest > share else "")
    return (f"workers: busy {', '.join(f'{busy[p]:.0f}s' for p in order)}; the last ran alone for the final "
            f"{tail:.1f}s (its last figure: {key}, {secs:.1f}s){note}")


def cmd_bench(args) -> int:
    from .bench import format_report, run_bench, write_json

    rep = run_bench(args.name, quick=args.quick)
    print(format_report(rep), flush=True)
    if args.json:
        write_json(rep, args.json)
    return 0


def bench_lines() -> list[str]:
    """One line per benchmark family: its name and the first line of its module docstring (read from the
    source, not imported: listing stays fast and never loads a peer engine)."""
    import ast
    import importlib.util
    import re

    from .bench import available

    out = []
    for name in available():
        spec = importlib.util.find_spec(f"pbanim.bench.{name}")
        doc = ""
        if spec is not None and spec.origin:
            doc = ast.get_docstring(ast.parse(Path(spec.origin).read_text(encoding="utf-8"))) or ""
        para = " ".join(doc.strip().split("\n\n")[0].split())
        para = re.sub(r"^(Benchmarks?\s+)?``pbanim bench \w+``\s*[:—-]\s*", "", para)
        first = re.split(r"(?<=[.;])\s", para)[0].rstrip(".;") if para else "(no description)"
        first = first[:1].upper() + first[1:]
        out.append(f"{name:16s} {first if len(first) <= 100 else first[:99] + '…'}")
    return out


def cmd_list(args) -> int:
    if args.what in ("figures", "all"):
        for key, spec in load_chapters().items():
            print(f"figure {key:36s} {spec.title}")
    if args.what in ("bench", "all"):
        for line in bench_lines():
            print(f"bench  {line}")
    if args.what in ("assignments", "all"):
        from .course.commands import assignment_lines

        for line in assignment_lines():
            print(f"assignment {line}")
    return 0


def cmd_compare(args) -> int:
    """``pbanim compare [SCENE ...] [--engines a,b] [--quick] [--steps h ...] [--markdown F] [--json F]``:
    the scenes of chapter 11 in pbanim and the peer engines, one progress line per run, then the tables."""
    from .compare import run_compare, write

    engines = [e for e in (args.engines or "").split(",") if e] or None
    cmp = call_checked(run_compare, args.scenes or None, engines, quick=args.quick, steps=args.steps,
                      progress=lambda line: print(line, flush=True))
    print()
    print(cmp.to_markdown(), flush=True)
    for path in write(cmp, args.markdown, args.json):
        print(f"wrote {path}")
    return 0


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(prog="pbanim", description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    sub = p.add_subparsers(dest="cmd", required=True)
    f = sub.add_parser("figures", help="regenerate lecture figures")
    f.add_argument("chapters", nargs="*", metavar="NAME",
                   help="chapters (ch01, ch03_constraints) or single figures (ch03_drift); default: all")
    f.add_argument("--quick", action="store_true", help="small problems (the CI mode)")
    f.add_argument("--out", help="output folder (default: figures/ in the repository)")
    f.add_argument("--format", default="png", choices=["png", "svg", "pdf"], help="file format of stills")
    f.add_argument("--dpi", type=float, help="resolution of PNGs and GIFs (default 110; GIFs 60, slides 100)")
    f.add_argument("--style", default="paper", choices=["paper", "slides"],
                   help="slides: large fonts and thick lines, also in GIFs")
    f.add_argument("--jobs", "-j", type=int, metavar="N",
                   help="worker processes (default: one per core; 1: one after the other in this process)")
    f.set_defaults(func=cmd_figures)
    b = sub.add_parser("bench", help="run a benchmark family", formatter_class=argparse.RawDescriptionHelpFormatter,
                       epilog="benchmark families:\n" + "\n".join(f"  {line}" for line in bench_lines()))
    b.add_argument("name", help="benchmark family (listed below)")
    b.add_argument("--quick", action="store_true")
    b.add_argument("--json", help="write rows and goal lines to this file")
    b.set_defaults(func=cmd_bench)
    ls = sub.add_parser("list", help="list figures and benchmarks")
    ls.add_argument("what", nargs="?", default="all", choices=["figures", "bench", "assignments", "all"])
    ls.set_defaults(func=cmd_list)
    cp = sub.add_parser("compare", help="the same scenes in pbanim, PyBullet and MuJoCo vs the exact answer")
    cp.add_argument("scenes", nargs="*", metavar="SCENE", help="scenes (default: all; see pbanim.compare.SCENES)")
    cp.add_argument("--engines", help="comma-separated engines, an option after a colon (pbanim,mujoco:RK4); "
                                      "default: pbanim,pybullet,mujoco")
    cp.add_argument("--quick", action="store_true", help="short runs and a two-step sweep (the CI mode)")
    cp.add_argument("--steps", type=float, nargs="+", metavar="H", help="step sizes (s) for every scene")
    cp.add_argument("--markdown", help="write the markdown tables to this file")
    cp.add_argument("--json", help="write the rows as JSON to this file")
    cp.set_defaults(func=cmd_compare)
    from .course.commands import add_course_commands

    add_course_commands(sub, _chapter_files)
    args = p.parse_args(argv)
    try:
        return args.func(args)
    except ValueError as exc:
        print(f"pbanim: error: {exc}", file=sys.stderr)
        return 2


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
