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
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable

import numpy as np

__all__ = ["figure", "FIGURES", "FigureSpec", "FigureContext", "figures_of", "run_figure", "write_index",
           "pyplot"]

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
    "path.simplify": False,
}


@dataclass(frozen=True)
class FigureSpec:
    chapter: str
    name: str
    title: str
    func: Callable[["FigureContext"], dict]

    @property
    def key(self) -> str:
        return f"{self.chapter}_{self.name}"


FIGURES: dict[str, FigureSpec] = {}


def figure(chapter: str, name: str, title: str) -> Callable:
    """Register a figure function ``f(ctx) -> dict`` under ``chapter_name``."""

    def deco(func: Callable) -> Callable:
        spec = FigureSpec(chapter, name, title, func)
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

    def subplots(self, *args, **kwargs):
        return pyplot().subplots(*args, **kwargs)

    def _path(self, suffix: str, ext: str) -> Path | None:
        if self.out_dir is None:
            return None
        self.out_dir.mkdir(parents=True, exist_ok=True)
        return self.out_dir / f"{self.spec.key}{suffix}.{ext}"

    def save(self, fig, suffix: str = "") -> Path | None:
        """Save ``fig`` as PNG with scrubbed metadata (same code → same bytes), then close it."""
        path = self._path(suffix, "png")
        if fig.get_suptitle() == "" and len(fig.axes) > 1:
            fig.suptitle(self.spec.title)
        elif len(fig.axes) == 1 and not fig.axes[0].get_title():
            fig.axes[0].set_title(self.spec.title)
        if path is not None:
            fig.savefig(path, dpi=DPI, metadata={"Software": None})
            self.files.append(path)
        pyplot().close(fig)
        return path

    def save_gif(self, fig, update: Callable[[int], Any], frames: int, fps: int = 20, suffix: str = "") -> Path | None:
        """Write an animated GIF by calling ``update(i)`` for each frame (Pillow writer)."""
        path = self._path(suffix, "gif")
        if path is not None:
            from matplotlib.animation import FuncAnimation, PillowWriter

            anim = FuncAnimation(fig, update, frames=frames, blit=False)
            anim.save(path, writer=PillowWriter(fps=fps), dpi=60)
            self.files.append(path)
        pyplot().close(fig)
        return path


def figures_of(chapters: set[str] | list[str] | None = None) -> dict[str, FigureSpec]:
    """The registered figures (all, or those of the given chapters ``chNN``), sorted by key.

    Figures are registered when their chapter module is imported; finding and importing the chapters is
    the caller's job (``pbanim figures`` does it in :mod:`pbanim.cli`), so this module never imports them.
    """
    wanted = None if chapters is None else set(chapters)
    return {k: s for k, s in sorted(FIGURES.items()) if wanted is None or s.chapter in wanted}


def run_figure(spec: FigureSpec, out_dir: Path | None, quick: bool = False) -> tuple[dict, list[Path]]:
    """Run one figure with a fresh seeded context; return (data, files written)."""
    plt = pyplot()
    with plt.rc_context(STYLE):
        ctx = FigureContext(spec=spec, out_dir=out_dir, quick=quick)
        data = spec.func(ctx)
    if not isinstance(data, dict):
        raise TypeError(f"figure {spec.key} must return a dict of its data, got {type(data).__name__}")
    return data, ctx.files


def write_index(specs: dict[str, FigureSpec], out_dir: Path, files: dict[str, list[Path]]) -> Path:
    """figures/README.md: one line per figure (chapter, file, what it shows)."""
    lines = ["# Figures", "", "Generated by `pbanim figures`; do not edit by hand.", "",
             "| chapter | figure | shows |", "| --- | --- | --- |"]
    for key, spec in specs.items():
        fl = files.get(key) or []
        links = ", ".join(f"[{p.name}]({p.name})" for p in fl) or "—"
        title = spec.title.replace("|", "\\|")  # a pipe inside a cell would split the table
        lines.append(f"| {spec.chapter} | {links} | {title} |")
    path = out_dir / "README.md"
    path.write_text("\n".join(lines) + "\n")
    return path
