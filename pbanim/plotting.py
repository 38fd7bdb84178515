"""One plotting style and the figure registry (every chapter).

A chapter (``chapters/chNN_topic.py``) registers each figure with :func:`figure`. A figure is a
function that computes, plots and *returns its data* (a dict), so ``tests/test_chapters.py`` checks the
numbers, never the pixels (this module never imports the chapters: ``pbanim figures``, the command line,
finds and imports them, and their figures register themselves here)::

    @figure("ch01", "projectile_drag", "Projectile with and without drag vs exact")
    def projectile_drag(ctx):
        ...                       # compute (smaller problem when ctx.quick)
        fig, ax = ctx.subplots()
        ...
        ctx.save(fig)             # figures/ch01_projectile_drag.png, deterministic bytes
        return {"max_err": err}

matplotlib is imported here lazily, the first time a figure is drawn: ``import pbanim`` never loads it.
Output is deterministic: Agg backend, fixed DPI, metadata scrubbed, fixed seeds (``ctx.rng``).

Formats and styles (``pbanim figures … --format svg --dpi 200 --style slides``):

==========  ================================================================================
option      effect
==========  ================================================================================
format      ``png`` (default), ``svg`` or ``pdf`` for stills (vector output for slides and papers);
            animations are always GIFs
dpi         resolution of PNG stills (default 110) and GIFs (default 60 paper, 100 slides)
style       ``paper`` (default: 9 pt text, thin lines) or ``slides`` (16 pt text, 2.5 pt lines,
            bigger markers: readable from the back of a lecture hall; also applied to GIFs)
==========  ================================================================================

Every style places legends with ``loc="best"`` (the spot that covers the fewest data points) unless a
figure says otherwise, and :func:`axes_without_units` lists axes whose label has no unit in
parentheses or brackets (``"t (s)"``, ``"E [J]"``; dimensionless axes say ``"(1)"`` or ``"(–)"``).
"""

from __future__ import annotations

import os as _os
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable

import numpy as np

from .contracts import Choice, Either, Flag, Func, Int, Obj, Opt, PathLike, Real, Seq, Text, contract

__all__ = ["figure", "FIGURES", "FigureSpec", "FigureContext", "figures_of", "run_figure", "run_figures",
           "write_index", "pyplot", "STYLES", "FORMATS", "axes_without_units"]

DPI = 110
STYLE = {
    "figure.figsize": (6.4, 4.2),
    "axes.grid": True,
    "grid.alpha": 0.3,
    "axes.spines.top": False,
    "axes.spines.right": False,
    "font.size": 9,
    "legend.fontsize": 8,
    "legend.frameon": False,
    "lines.linewidth": 1.4,
    "savefig.bbox": "tight",
    "svg.hashsalt": "pbanim",
    "svg.fonttype": "none",
    "pdf.compression": 6,
    "path.simplify": False,
    "legend.loc": "best",
}
SLIDES = {**STYLE, "figure.figsize": (8.0, 5.0), "font.size": 16, "axes.titlesize": 17, "axes.labelsize": 16,
          "xtick.labelsize": 14, "ytick.labelsize": 14, "legend.fontsize": 13, "lines.linewidth": 2.5,
          "lines.markersize": 8, "axes.linewidth": 1.2, "grid.linewidth": 0.8}
STYLES = {"paper": STYLE, "slides": SLIDES}
FORMATS = ("png", "svg", "pdf")
GIF_DPI = {"paper": 60, "slides": 100}


_NAME = Text(nonempty=True)
_FIG = Obj("matplotlib.figure:Figure", what="a matplotlib Figure")
FORMAT = Choice(FORMATS)
STYLE_NAME = Choice(STYLES)
DPI_RANGE = Opt(Real(ge=10, le=1200))


_COST = Real(ge=0, le=1e6)


@contract(chapter=_NAME, name=_NAME, title=Text(), func=Func(), cost=_COST, group=Text())
@dataclass(frozen=True)
class FigureSpec:
    """A registered figure. ``cost``: roughly its seconds in a full run (the costly ones start first when
    figures run in parallel); ``group``: figures of one group share a computation (a cached run) and run
    one after the other in one process."""

    chapter: str
    name: str
    title: str
    func: Callable[["FigureContext"], dict]
    cost: float = 1.0
    group: str = ""

    @property
    def key(self) -> str:
        return f"{self.chapter}_{self.name}"


FIGURES: dict[str, FigureSpec] = {}


@contract(chapter=_NAME, name=_NAME, title=Text(), cost=_COST, group=Text())
def figure(chapter: str, name: str, title: str, *, cost: float = 1.0, group: str = "") -> Callable:
    """Register a figure function ``f(ctx) -> dict`` under ``chapter_name`` (``cost`` and ``group``: see
    :class:`FigureSpec`; they only schedule :func:`run_figures`, never change what a figure computes)."""

    def deco(func: Callable) -> Callable:
        spec = FigureSpec(chapter, name, title, func, float(cost), group)
        FIGURES[spec.key] = spec
        func.spec = spec  # type: ignore[attr-defined]
        return func

    return deco


def pyplot():
    """matplotlib.pyplot on the Agg backend with the pbanim style (lazy import)."""
    import matplotlib

    matplotlib.use("Agg", force=True)
    import matplotlib.pyplot as plt

    plt.rcParams.update(STYLE)
    return plt


@dataclass
class FigureContext:
    """What a figure function gets: the mode, where to write, a seeded RNG, and savers."""

    spec: FigureSpec
    out_dir: Path | None
    quick: bool = False
    rng: np.random.Generator = field(default_factory=lambda: np.random.default_rng(12345))
    files: list[Path] = field(default_factory=list)
    fmt: str = "png"
    dpi: float | None = None
    style: str = "paper"
    issues: list[str] = field(default_factory=list)     # axes without units (see axes_without_units)

    def __post_init__(self) -> None:
        if self.out_dir is not None:
            self.out_dir = Path(self.out_dir)

    def subplots(self, *args, **kwargs):
        plt = pyplot()
        plt.rcParams.update(STYLES[self.style])
        return plt.subplots(*args, **kwargs)

    def _path(self, suffix: str, ext: str) -> Path | None:
        if self.out_dir is None:
            return None
        self.out_dir.mkdir(parents=True, exist_ok=True)
        return self.out_dir / f"{self.spec.key}{suffix}.{ext}"

    @contract(fig=_FIG, suffix=Text())
    def save(self, fig, suffix: str = "") -> Path | None:
        """Save ``fig`` in the context's format with scrubbed metadata (same code → same bytes), then close it."""
        path = self._path(suffix, self.fmt)
        if fig.get_suptitle() == "" and len(fig.axes) > 1:
            fig.suptitle(self.spec.title)
        elif len(fig.axes) == 1 and not fig.axes[0].get_title():
            fig.axes[0].set_title(self.spec.title)
        self.issues += [f"{self.spec.key}{suffix}: {m} has no unit" for m in axes_without_units(fig)]
        if path is not None:
            meta = {"Software": None} if self.fmt == "png" else (
                {"Creator": None, "Producer": None, "CreationDate": None} if self.fmt == "pdf" else {"Creator": None, "Date": None})
            fig.savefig(path, dpi=self.dpi or DPI, metadata=meta, format=self.fmt)
            self.files.append(path)
        pyplot().close(fig)
        return path

    @contract(fig=_FIG, update=Func(), frames=Int(ge=1, le=10_000), fps=Int(ge=1, le=100), suffix=Text())
    def save_gif(self, fig, update: Callable[[int], Any], frames: int, fps: int = 20, suffix: str = "") -> Path | None:
        """Write an animated GIF by calling ``update(i)`` for each frame (the frames of matplotlib's Pillow
        writer, bit for bit: each frame is rendered once, where ``FuncAnimation.save`` renders it twice)."""
        path = self._path(suffix, "gif")
        if path is not None:
            _write_gif(fig, update, frames, fps, self.dpi or GIF_DPI[self.style], path)
            self.files.append(path)
        pyplot().close(fig)
        return path


def _write_gif(fig, update: Callable[[int], Any], frames: int, fps: int, dpi: float, path: Path) -> None:
    """The GIF that ``FuncAnimation(fig, update, frames).save(path, PillowWriter(fps), dpi)`` writes: the same
    first call ``update(0)`` (its initial draw), then per frame ``update(i)``, one Agg render at ``dpi`` and
    the RGBA buffer (RGB when opaque), saved by Pillow with the same options."""
    from PIL import Image
    from matplotlib.backends.backend_agg import FigureCanvasAgg

    canvas = FigureCanvasAgg(fig) if not isinstance(fig.canvas, FigureCanvasAgg) else fig.canvas
    images = []
    old_dpi = fig.dpi
    update(0)
    try:
        fig.dpi = dpi
        for i in range(frames):
            update(i)
            canvas.draw()
            buf = canvas.buffer_rgba()
            im = Image.frombuffer("RGBA", (buf.shape[1], buf.shape[0]), buf, "raw", "RGBA", 0, 1)
            images.append(im.copy() if im.getextrema()[3][0] < 255 else im.convert("RGB"))
    finally:
        fig.dpi = old_dpi
    images[0].save(path, save_all=True, append_images=images[1:], duration=int(1000 / fps), loop=0)


@contract(chapters=Opt(Either(Seq(Text()), Obj(set, frozenset, what="a set of chapter names"))))
def figures_of(chapters: set[str] | list[str] | None = None) -> dict[str, FigureSpec]:
    """The registered figures (all, or those of the given chapters ``chNN``), sorted by key.

    Figures are registered when their chapter module is imported; finding and importing the chapters is
    the caller's job (``pbanim figures`` does it in :mod:`pbanim.cli`), so this module never imports them.
    """
    wanted = None if chapters is None else set(chapters)
    return {k: s for k, s in sorted(FIGURES.items()) if wanted is None or s.chapter in wanted}


@contract(spec=Obj(FigureSpec), out_dir=Opt(PathLike()), quick=Flag(), fmt=FORMAT, dpi=DPI_RANGE, style=STYLE_NAME,
          issues=Opt(Obj(list, what="a list (it receives one line per axis without a unit)")))
def run_figure(spec: FigureSpec, out_dir: Path | None, quick: bool = False, *, fmt: str = "png",
               dpi: float | None = None, style: str = "paper", issues: list | None = None) -> tuple[dict, list[Path]]:
    """Run one figure with a fresh seeded context; return (data, files written).

    ``fmt`` in :data:`FORMATS`, ``dpi`` in [10, 1200] (None: the style's default), ``style`` in
    :data:`STYLES`; ``issues``, when given, receives one line per axis without a unit.
    """
    from .errors import InvalidInput

    out_dir = None if out_dir is None else Path(out_dir)
    plt = pyplot()
    with plt.rc_context(STYLES[style]):
        ctx = FigureContext(spec=spec, out_dir=out_dir, quick=quick, fmt=fmt, dpi=dpi, style=style)
        data = spec.func(ctx)
    if issues is not None:
        issues.extend(ctx.issues)
    if not isinstance(data, dict):
        raise InvalidInput(f"run_figure: spec must be a figure whose function returns a dict of its data; "
                           f"{spec.key} returned a {type(data).__name__}")
    return data, ctx.files


def _run_group(specs: list, out_dir, quick: bool, fmt: str, dpi, style: str) -> list:
    """Run one group's figures here, in order: [(key, files, seconds, issues, CPU s, (pid, wall start, end))]."""
    done = []
    for spec in specs:
        issues: list[str] = []
        start, cpu, began = time.perf_counter(), time.process_time(), time.time()
        try:
            _, files = run_figure(spec, out_dir, quick, fmt=fmt, dpi=dpi, style=style, issues=issues)
        except Exception as exc:
            exc.add_note(f"(while drawing the figure {spec.key})")
            raise
        done.append((spec.key, files, time.perf_counter() - start, issues, time.process_time() - cpu,
                     (_os.getpid(), began, time.time())))
    return done


@contract(specs=Obj(dict, what="a dict {key: FigureSpec}"), out_dir=Opt(PathLike()), quick=Flag(), fmt=FORMAT,
          dpi=DPI_RANGE, style=STYLE_NAME, jobs=Opt(Int(ge=1, le=256)), progress=Opt(Func()),
          initializer=Opt(Func()), cpu=Opt(Obj(dict, what="a dict (it receives {key: CPU seconds})")),
          timeline=Opt(Obj(dict, what="a dict (it receives {key: (process id, start, end)})")))
def run_figures(specs: dict[str, FigureSpec], out_dir: Path | None, quick: bool = False, *, fmt: str = "png",
                dpi: float | None = None, style: str = "paper", jobs: int | None = None,
                progress: Callable[[str], Any] | None = None, initializer: Callable[[], Any] | None = None,
                cpu: dict | None = None, timeline: dict | None = None) -> tuple[dict, dict, list]:
    """Run several figures on ``jobs`` worker processes (None: one per core; 1: here, in the order given).

    Returns ({key: files}, {key: seconds}, issues), keys in the order of ``specs``. ``progress`` gets one line
    per figure as it finishes: ``[i/n] key: files (wall seconds; cpu: this process's CPU seconds, which a
    loaded machine inflates far less than the wall time)``. The costliest groups start first (longest
    processing time first, by :attr:`FigureSpec.cost`); a group (:attr:`FigureSpec.group`) runs in one process.
    Every figure runs in a fresh seeded context (:func:`run_figure`), so the files are those of a serial run.
    ``initializer``: called once in each worker before its first figure (a module-level function: workers are
    fresh interpreters); the command line hands in one that limits BLAS to one thread, as in the benchmarks.
    A figure that fails stops the run: the figures not yet started are cancelled and its error is raised.
    ``cpu`` receives {key: CPU seconds in its process} (for the ``cost`` hints); ``timeline`` {key: (process id,
    start, end)} on the wall clock.
    """
    from .errors import InvalidInput

    for key, spec in specs.items():
        if not isinstance(spec, FigureSpec):
            raise InvalidInput(f"run_figures: specs must map keys to FigureSpec objects, got "
                               f"{type(spec).__name__} for {key!r}")
    groups: dict[str, list] = {}
    for key, spec in sorted(specs.items()):
        groups.setdefault(spec.group or key, []).append(spec)
    order = sorted(groups.values(), key=lambda g: (-sum(s.cost for s in g), g[0].key))
    if jobs is None:
        jobs = len(_os.sched_getaffinity(0)) if hasattr(_os, "sched_getaffinity") else (_os.cpu_count() or 1)
    jobs = min(jobs, len(order))
    files, seconds, issues, cpu, timeline = {}, {}, {}, ({} if cpu is None else cpu), {} if timeline is None else timeline

    def finished(results) -> None:
        for key, written, secs, found, cpu_s, when in results:
            files[key], seconds[key], issues[key] = written, secs, found
            cpu[key], timeline[key] = cpu_s, when
            if progress is not None:
                names = ", ".join(p.name for p in written) or "(no file)"
                progress(f"[{len(files)}/{len(specs)}] {key}: {names} ({secs:.1f}s; cpu {cpu_s:.1f}s)")

    args = (None if out_dir is None else Path(out_dir), quick, fmt, dpi, style)
    if jobs <= 1:
        for group in (groups[k] for k in dict.fromkeys(s.group or k for k, s in specs.items())):
            finished(_run_group(group, *args))
    else:
        import multiprocessing
        from concurrent.futures import FIRST_COMPLETED, ProcessPoolExecutor, wait

        # spawn: a fresh interpreter per worker (no state inherited from this process, the same on every OS)
        pool = ProcessPoolExecutor(jobs, multiprocessing.get_context("spawn"), initializer=initializer)
        try:
            pending = [pool.submit(_run_group, group, *args) for group in order]
            while pending:
                done, _ = wait(pending, return_when=FIRST_COMPLETED)
                pending = [f for f in pending if f not in done]
                for fut in done:
                    finished(fut.result())        # a figure's error is raised here
        finally:
            pool.shutdown(wait=True, cancel_futures=True)
    return {k: files[k] for k in specs}, {k: seconds[k] for k in specs}, [m for k in specs for m in issues[k]]


@contract(fig=_FIG)
def axes_without_units(fig) -> list[str]:
    """Labels of the axes of ``fig`` that have no unit: "axes 0 x: 'time'" (empty list: all have one).

    A unit is anything in parentheses or brackets at the end of the label; an empty label counts as
    missing (an axis of a 3-D plot or an image may be exempted by turning it off), unless the axis is
    shared with another axes whose label has a unit (``sharex`` columns, ``twinx`` pairs).
    """
    import re

    def has_unit(label: str) -> bool:
        return bool(re.search(r"[(\[][^()\[\]]*[)\]]\s*$", label.strip()))

    missing = []
    for k, ax in enumerate(fig.axes):
        if not ax.axison:
            continue
        for which, label in (("x", ax.get_xlabel()), ("y", ax.get_ylabel())):
            if has_unit(label):
                continue
            if not label.strip() and getattr(ax, "_colorbar", None) is not None:
                continue                                          # a colorbar's short side carries no label
            shared = ax.get_shared_x_axes() if which == "x" else ax.get_shared_y_axes()
            twins = [o for o in fig.axes if o is not ax and shared.joined(ax, o)]
            if not label.strip() and any(has_unit(o.get_xlabel() if which == "x" else o.get_ylabel()) for o in twins):
                continue
            missing.append(f"axes {k} {which}: {label!r}")
    return missing


@contract(specs=Obj(dict, what="a dict {key: FigureSpec}"), out_dir=PathLike(),
          files=Obj(dict, what="a dict {key: list of paths}"), checked_by=Opt(Obj(dict, what="a dict {key: test ids}")))
def write_index(specs: dict[str, FigureSpec], out_dir: Path, files: dict[str, list[Path]],
                checked_by: dict[str, list[str]] | None = None) -> Path:
    """figures/README.md: one entry per figure — its file, a caption (what it shows), and the tests that
    check its data (``checked_by[key]``: "tests/test_x.py::test_name", found by the command line)."""
    from .errors import InvalidInput

    lines = ["# Figures", "", "Generated by `pbanim figures`; do not edit by hand. Each figure's data is checked "
             "by the tests named in its caption (they run every figure in quick mode).", "",
             "| chapter | figure | caption | data checked by |", "| --- | --- | --- | --- |"]
    esc = lambda text: str(text).replace("|", "\\|")  # noqa: E731 - a pipe inside a cell would split the table
    for key, spec in specs.items():
        if not isinstance(spec, FigureSpec):
            raise InvalidInput(f"write_index: specs must map keys to FigureSpec objects, got {type(spec).__name__} "
                               f"for {key!r}")
        fl = files.get(key) or []
        links = ", ".join(f"[{p.name}]({p.name})" for p in fl) or "—"
        tests = (checked_by or {}).get(key) or []
        by = ", ".join(f"`{t}`" for t in tests) or "—"
        lines.append(f"| {spec.chapter} | {links} | {esc(_caption(spec))} | {esc(by)} |")
    path = Path(out_dir) / "README.md"
    path.write_text("\n".join(lines) + "\n")
    return path


def _caption(spec: FigureSpec) -> str:
    """The title, then what the figure shows: its entry ``* ``name``: …`` in the chapter's module docstring,
    else the first paragraph of the figure function's docstring."""
    import re
    import sys

    mod_doc = getattr(sys.modules.get(spec.func.__module__), "__doc__", None) or ""
    m = re.search(rf"^\* ``{re.escape(spec.name)}``:\s*(.+?)(?=^\* |\n\n|\Z)", mod_doc, flags=re.M | re.S)
    doc = m.group(1) if m else (spec.func.__doc__ or "").strip().split("\n\n")[0]
    text = " ".join(doc.split())
    title = spec.title.rstrip(".")
    return f"{title}. {text[:1].upper() + text[1:]}" if text else f"{title}."
