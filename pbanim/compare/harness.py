"""The harness: every scene × every engine × every step, one row each, against the exact answer.

For each scene s, engine e and step h the harness runs the engine's translation of s, checks that the
engine starts where the scene says (positions to 1e-6 m: a wrong translation fails here, not silently
later), scores the trace against the closed form and records the wall time of the stepping alone:

    row(s, e, h) = (error_s(trace), other metrics, wall time, µs per step, status)

A row never raises. Its ``status`` says what happened:

================  ==========================================================================
status            meaning
================  ==========================================================================
ok                the engine ran; ``error`` is its error against the exact answer
not installed     the engine's Python package is absent (the ``peers`` extra): nothing ran
unsupported       the scene asks for something the engine cannot express; ``reason`` says what
diverged          the engine returned NaN or infinity (first time in ``reason``)
failed            the engine raised, or started somewhere else than the scene (``reason``)
================  ==========================================================================

An unknown scene or engine name is bad input (:class:`~pbanim.errors.InvalidInput`, with the closest
names) and is refused before anything runs. Across the steps of one (scene, engine) the fitted slope of
log error vs log h is the engine's observed order on that scene (:func:`pbanim.testing.order_fit`).

Limiting cases: no engine installed but pbanim → one ``ok`` row per step and scene, and peer rows
``not installed``; a scene with one step gives no order (``nan``).

References: A. Boeing, T. Bräunl, GRAPHITE 2007 (one scene, many engines, measured error and cost).
"""

from __future__ import annotations

import difflib
import importlib.util
import math
import time
from dataclasses import asdict, dataclass, field
from typing import Callable

import numpy as np

from .spec import Trace, Unsupported
from ..errors import InvalidInput, SimulationDiverged

__all__ = ["ENGINES", "Engine", "Row", "Comparison", "run_compare", "check_names", "have", "versions"]

START_TOL = 1e-6          # m: an engine must start at the scene's positions


def have(module: str | None) -> bool:
    """True when the optional package ``module`` can be imported (no import done); None: always there."""
    if module is None:
        return True
    try:
        return importlib.util.find_spec(module) is not None
    except (ImportError, ValueError):            # a blocked or half-removed package counts as absent
        return False


@dataclass(frozen=True)
class Engine:
    name: str
    module: str | None          # the Python package it needs (None: pbanim itself)
    run: Callable[..., Trace]


def _native(*a, **k):
    from .native import run_native
    return run_native(*a, **k)


def _bullet(*a, **k):
    from .peer_bullet import run_bullet
    return run_bullet(*a, **k)


def _mujoco(*a, **k):
    from .peer_mujoco import run_mujoco
    return run_mujoco(*a, **k)


ENGINES: dict[str, Engine] = {"pbanim": Engine("pbanim", None, _native),
                              "pybullet": Engine("pybullet", "pybullet", _bullet),
                              "mujoco": Engine("mujoco", "mujoco", _mujoco)}


def check_names(kind: str, names, known) -> list[str]:
    """``names`` as a list of known names, or :class:`InvalidInput` naming the first unknown one and the
    closest known ones. An engine name may carry an option after a colon (``mujoco:RK4``)."""
    if isinstance(names, str) or not all(isinstance(n, str) for n in names):
        raise InvalidInput(f"{kind}s must be a list of names, got {names!r}")
    out = []
    for n in names:
        base = n.split(":", 1)[0] if kind == "engine" else n
        if base not in known:
            near = difflib.get_close_matches(base, list(known), n=3, cutoff=0.4)
            hint = f" (did you mean {', '.join(repr(x) for x in near)}?)" if near else ""
            raise InvalidInput(f"unknown {kind} {n!r}{hint}; known {kind}s: {', '.join(known)}")
        if n not in out:
            out.append(n)
    return out


def versions() -> dict[str, str]:
    """Installed versions of pbanim and the peers ("not installed" when absent)."""
    from importlib.metadata import PackageNotFoundError, version

    out = {}
    for name in ("pbanim", "pybullet", "mujoco", "numpy"):
        try:
            out[name] = version(name)
        except PackageNotFoundError:
            out[name] = "not installed"
    return out


@dataclass
class Row:
    scene: str
    engine: str
    h: float
    status: str
    reason: str = ""
    error: float = math.nan
    metrics: dict = field(default_factory=dict)
    wall: float = math.nan
    steps: int = 0
    settings: str = ""

    @property
    def us_per_step(self) -> float:
        return 1e6 * self.wall / self.steps if self.steps else math.nan

    def to_json(self) -> dict:
        d = asdict(self)
        d["us_per_step"] = self.us_per_step
        return {k: (None if isinstance(v, float) and not math.isfinite(v) else v) for k, v in d.items()}


def _run_one(sc, engine: str, h: float, quick: bool, curves: dict | None) -> Row:
    name, _, option = engine.partition(":")
    eng = ENGINES[name]
    row = Row(sc.spec.name, engine, h, "ok")
    if not have(eng.module):
        row.status, row.reason = "not installed", f"{eng.module} not installed (pip install 'pbanim[peers]')"
        return row
    try:
        tr = eng.run(sc.spec, h, sc.spec.time(quick), option or None)
    except Unsupported as exc:
        row.status, row.reason = "unsupported", exc.reason
        return row
    except SimulationDiverged as exc:
        row.status, row.reason = "diverged", str(exc)
        return row
    except Exception as exc:                      # an engine crash is a row, not the end of the run
        row.status, row.reason = "failed", f"{type(exc).__name__}: {str(exc)[:200]}"
        return row
    row.wall, row.steps, row.settings = float(tr.wall), int(tr.steps), tr.settings
    bad = tr.first_nonfinite()
    if bad is not None:
        row.status, row.reason = "diverged", f"non-finite state at t = {bad:.4g} s"
        return row
    start = np.array([b.x for b in sc.spec.bodies])
    off = float(np.max(np.abs(tr.x[0] - start)))
    if off > START_TOL:
        row.status, row.reason = "failed", f"starts {off:.3g} m away from the scene (translation error)"
        return row
    m = sc.score(tr)
    row.error = float(m.pop("error"))
    row.metrics = {k: float(v) for k, v in m.items()}
    if not math.isfinite(row.error):
        row.status, row.reason = "diverged", "the error is not finite"
    if curves is not None:
        curves[(sc.spec.name, engine, h)] = (tr.t, np.asarray(sc.observable(tr), float))
    return row


@dataclass
class Comparison:
    """All rows of one run, the scenes they belong to, and (on request) the plotted curves."""

    rows: list
    scenes: dict
    quick: bool
    versions: dict
    date: str
    curves: dict = field(default_factory=dict)

    def rows_of(self, scene: str, engine: str | None = None) -> list:
        return [r for r in self.rows if r.scene == scene and (engine is None or r.engine == engine)]

    def order(self, scene: str, engine: str) -> float:
        """Fitted slope of log error vs log h over the ok rows (nan with fewer than two usable points)."""
        from ..testing import order_fit

        rows = [r for r in self.rows_of(scene, engine) if r.status == "ok" and r.error > 0]
        if len({r.h for r in rows}) < 2:
            return math.nan
        try:
            return float(order_fit([r.h for r in rows], [r.error for r in rows], window=(1e-13, 1e3)).order)
        except InvalidInput:
            return math.nan

    def summary(self) -> list[dict]:
        """One line per (scene, engine): the finest step's error and cost, and the observed order."""
        out = []
        for name, sc in self.scenes.items():
            for engine in dict.fromkeys(r.engine for r in self.rows_of(name)):
                rows = self.rows_of(name, engine)
                fine = min(rows, key=lambda r: r.h)
                out.append({"scene": name, "engine": engine, "h": fine.h, "error": fine.error,
                            "error_name": sc.error_name, "us_per_step": fine.us_per_step,
                            "order": self.order(name, engine), "status": fine.status, "reason": fine.reason})
        return out

    def to_markdown(self) -> str:
        from .report import markdown
        return markdown(self)

    def to_json(self) -> dict:
        from .report import as_json
        return as_json(self)


def run_compare(scenes=None, engines=None, *, quick: bool = False, steps=None, keep_curves: bool = False,
                progress: Callable[[str], None] | None = None) -> Comparison:
    """Run ``scenes`` (names of :data:`~pbanim.compare.scenes.SCENES`, default all) in ``engines``
    (default all of :data:`ENGINES`) at each scene's steps (``quick``: its short sweep and duration, or
    ``steps`` for every scene). Never raises for an engine's failure; see the module docstring."""
    from .scenes import SCENES

    names = check_names("scene", list(SCENES) if scenes is None else scenes, SCENES)
    engs = check_names("engine", list(ENGINES) if engines is None else engines, ENGINES)
    if steps is not None:
        hs = np.atleast_1d(np.asarray(steps, dtype=float))
        if hs.size == 0 or not np.all(np.isfinite(hs) & (hs > 0)):
            raise InvalidInput(f"steps must be positive finite step sizes (s), got {steps!r}")
    built = {n: SCENES[n]() for n in names}
    sweeps = {n: tuple(hs) if steps is not None else (sc.spec.quick_steps if quick else sc.spec.steps)
              for n, sc in built.items()}
    for n, sweep in sweeps.items():
        if max(sweep) > built[n].spec.time(quick):
            raise InvalidInput(f"step h = {max(sweep):g} s is longer than scene {n!r} ({built[n].spec.time(quick):g} s)")
    rows, curves = [], {} if keep_curves else None
    for n, sc in built.items():
        for h in sweeps[n]:
            for e in engs:
                row = _run_one(sc, e, float(h), quick, curves)
                rows.append(row)
                if progress is not None:
                    progress(f"{n:14s} {e:16s} h = {h:<8g} {row.status}"
                             + (f"  error {row.error:.3g}" if row.status == "ok" else f"  ({row.reason})"))
    return Comparison(rows, built, quick, versions(), time.strftime("%Y-%m-%d"), curves or {})
