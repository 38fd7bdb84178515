"""Lecture chapters: ``chNN_topic.py`` modules whose figures are registered with ``pbanim.plotting.figure``.

The chapters sit above the package (they use only its public names) and nothing in ``pbanim`` below the
command line imports them: ``pbanim figures`` calls :func:`load`, which imports the chapter modules (their
``@figure`` decorators register the figures with :mod:`pbanim.plotting`) and returns their figures.
"""

from __future__ import annotations

import importlib
import pkgutil

__all__ = ["names", "load"]


def names() -> list[str]:
    """The chapter modules, sorted: ``["ch01_particles", "ch02_ode", …]``."""
    return sorted(m.name for m in pkgutil.iter_modules(__path__) if m.name.startswith("ch"))


def load(selected: list[str] | None = None) -> dict:
    """Import the chapters (all, or those whose name starts with an entry of ``selected``, e.g. ``"ch02"``)
    and return their figures ``{key: FigureSpec}``, sorted by key; an unknown entry raises ``ValueError``."""
    from pbanim.plotting import figures_of

    mods = names()
    if selected:
        unknown = [s for s in selected if not any(n.startswith(s) for n in mods)]
        if unknown:
            raise ValueError(f"unknown chapter(s) {unknown}; available: {[n[:4] for n in mods]}")
        mods = [n for n in mods if any(n.startswith(s) for s in selected)]
    for n in mods:
        importlib.import_module(f"{__name__}.{n}")
    return figures_of({n[:4] for n in mods})
