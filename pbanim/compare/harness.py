"""The harness: every scene × every engine × every step, one row each, against the exact answer.

For each scene s, engine e and step h the harness runs the engine's translation of s, checks that the
engine starts where the scene says (positions to 1e-6 m: a wrong translation fails here, not silently
later), scores the trace against the closed form and records the wall time of the stepping alone:

    row(s, e, h) = (error_s(trace), other metrics, wall time, µs per step, s per simulated s, status)

The cost of the same motion is the cost per *simulated second*, (wall time / steps) / h: an engine that is
cheap per step but needs small steps pays for them there. Beside each scene's sweep the harness runs every
engine at the peers' own default steps (:data:`OWN_STEPS`: PyBullet's 1/240 s, MuJoCo's 2 ms), so each
engine is also seen at the step a user of a peer would take; those rows say ``sweep = False`` and stay out
of the fitted order and of the finest-step summary.

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
``not installed``; a scene with one step gives no order (``None``: not measured).

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
from ..contracts import Array, Choice, Flag, Func, Obj, Opt, Real, Seq, Spec, Text, contract
from ..errors import InvalidInput, SimulationDiverged

__all__ = ["ENGINES", "Engine", "Row", "Comparison", "run_compare", "check_names", "have", "versions", "OWN_STEPS"]

START_TOL = 1e-6          # m: an engine must start at the scene's positions
MAX_RUN_STEPS = 10**6     # steps of one (scene, engine, h) run: refused before anything runs beyond it
# each peer's default time step: PyBullet's setTimeStep (1/240 s), MuJoCo's mjOption.timestep (0.002 s)
OWN_STEPS = {"pybullet": 1.0 / 240.0, "mujoco": 0.002}


@contract(module=Opt(Text(nonempty=True)))
def have(module: str | None) -> bool:
    """True when the optional package ``module`` can be imported (no import done); None: always there."""
    if module is None:
        return True
    try:
        return importlib.util.find_spec(module) is not None
    except (ImportError, ValueError):            # a blocked or half-removed package counts as absent
        return False


@contract(name=Text(nonempty=True), module=Opt(Text(nonempty=True)), run=Func())
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


@contract(kind=Choice(("scene", "engine")), names=Seq(Text()),
          known=Obj(dict, list, tuple, set, frozenset, what="a collection of names"))
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


class Names(Spec):
    """A list of names of a registry (scenes, engines), checked by :func:`check_names` (the one check of
    names: the contract and the internal callers, the command line among them, both use it)."""

    def __init__(self, kind: str, known) -> None:
        self.kind, self.known = kind, known

    def describe(self) -> str:
        return f"a list of names of {self.kind}s"

    def check(self, name, value, env):
        try:
            return check_names(self.kind, value, self.known())
        except InvalidInput as exc:
            raise env.fail(name, self.describe(), value, str(exc)) from None

    def example(self, env):
        return [next(iter(self.known()))]

    def bad(self, env):
        return [("None", None), ("a string", next(iter(self.known()))), ("an unknown name", ["no-such-name"]),
                ("a number", [1.0])]


class Among(Spec):
    """A name among those of a collection another argument holds (``"self.scenes"``): the vocabulary's
    Choice reads a fixed registry, this one reads the object the method is called on."""

    def __init__(self, ref: str, what: str) -> None:
        # the reference is kept as ``size``: the contract machinery reads ``size`` and ``shape`` to see that a
        # spec depends on other arguments (it then binds them all, self included)
        self.size, self.what = ref, what

    def describe(self) -> str:
        return f"one of the {self.what}"

    def check(self, name, value, env):
        known = list(env.resolve(self.size))
        if not isinstance(value, str) or value not in known:
            raise env.fail(name, f"one of the {self.what} {known}", value)
        return value

    def example(self, env):
        return list(env.resolve(self.size))[0]

    def bad(self, env):
        return [("an unknown name", "no-such-name"), ("None", None), ("a number", 1.0)]


def _scenes():
    from .scenes import SCENES
    return SCENES


SCENE_NAMES = Names("scene", _scenes)
ENGINE_NAMES = Names("engine", lambda: ENGINES)
STEPS = Array((None,), gt=0, scalar=True)


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
    sweep: bool = True          # False: a row at a peer's own step (OWN_STEPS), outside the scene's sweep

    @property
    def us_per_step(self) -> float:
        return 1e6 * self.wall / self.steps if self.steps else math.nan

    @property
    def s_per_sim_s(self) -> float:
        """Wall seconds per simulated second: the cost per step over h (below 1: faster than real time)."""
        return self.wall / self.steps / self.h if self.steps else math.nan

    def to_json(self) -> dict:
        d = asdict(self)
        d["us_per_step"] = self.us_per_step
        d["s_per_sim_s"] = self.s_per_sim_s
        return {k: (None if isinstance(v, float) and not math.isfinite(v) else v) for k, v in d.items()}


def _run_one(sc, engine: str, h: float, quick: bool, curves: dict | None, sweep: bool = True) -> Row:
    name, _, option = engine.partition(":")
    eng = ENGINES[name]
    row = Row(sc.spec.name, engine, h, "ok", sweep=sweep)
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
    if curves is not None and sweep:
        curves[(sc.spec.name, engine, h)] = (tr.t, np.asarray(sc.observable(tr), float))
    return row


_SCENE = Among("self.scenes", "scenes of this comparison")
_ENGINE = Among("self.engines", "engines of this comparison")


@dataclass
class Comparison:
    """All rows of one run, the scenes they belong to, and (on request) the plotted curves."""

    rows: list
    scenes: dict
    quick: bool
    versions: dict
    date: str
    curves: dict = field(default_factory=dict)

    @property
    def engines(self) -> list:
        """The engines of the rows, in their order."""
        return list(dict.fromkeys(r.engine for r in self.rows))

    @contract(scene=_SCENE, engine=Opt(_ENGINE), sweep=Opt(Flag()))
    def rows_of(self, scene: str, engine: str | None = None, sweep: bool | None = None) -> list:
        """The rows of one scene (and one engine; ``sweep``: True the sweep's rows only, False the rows at the
        peers' own steps only, None both)."""
        return [r for r in self.rows if r.scene == scene and (engine is None or r.engine == engine)
                and (sweep is None or r.sweep == sweep)]

    @contract(scene=_SCENE, engine=_ENGINE)
    def order(self, scene: str, engine: str) -> float | None:
        """Fitted slope of log error vs log h over the ok rows; None (not measured) with fewer than two usable
        points or errors at roundoff (an exact engine has no order to fit)."""
        from ..testing import order_fit

        rows = [r for r in self.rows_of(scene, engine, True) if r.status == "ok" and r.error > 0]
        if len({r.h for r in rows}) < 2:
            return None
        try:
            return float(order_fit([r.h for r in rows], [r.error for r in rows], window=(1e-13, 1e3)).order)
        except InvalidInput:
            return None

    def summary(self) -> list[dict]:
        """One line per (scene, engine): the finest step's error, cost per step and per simulated second, the
        observed order, and ``own``: {peer: {h, error, s_per_sim_s, status}} at each peer's own step (the
        rows at h = :data:`OWN_STEPS`, in or beside the sweep; empty when none ran)."""
        out = []
        for name, sc in self.scenes.items():
            for engine in dict.fromkeys(r.engine for r in self.rows_of(name)):
                rows = self.rows_of(name, engine)
                fine = min(self.rows_of(name, engine, True) or rows, key=lambda r: r.h)
                own = {}
                for peer, h in OWN_STEPS.items():
                    at = [r for r in rows if math.isclose(r.h, h, rel_tol=1e-9)]
                    if at:
                        own[peer] = {"h": at[0].h, "error": at[0].error, "s_per_sim_s": at[0].s_per_sim_s,
                                     "status": at[0].status}
                out.append({"scene": name, "engine": engine, "h": fine.h, "error": fine.error,
                            "error_name": sc.error_name, "us_per_step": fine.us_per_step,
                            "s_per_sim_s": fine.s_per_sim_s, "order": self.order(name, engine),
                            "status": fine.status, "reason": fine.reason, "own": own})
        return out

    def to_markdown(self) -> str:
        from .report import markdown
        return markdown(self)

    def to_json(self) -> dict:
        from .report import as_json
        return as_json(self)


@contract(scenes=Opt(SCENE_NAMES), engines=Opt(ENGINE_NAMES), quick=Flag(), steps=Opt(STEPS), keep_curves=Flag(),
          progress=Opt(Func()), own_steps=Flag(), stop_below=Opt(Real(ge=0)))
def run_compare(scenes=None, engines=None, *, quick: bool = False, steps=None, keep_curves: bool = False,
                progress: Callable[[str], None] | None = None, own_steps: bool = True,
                stop_below: float | None = None) -> Comparison:
    """Run ``scenes`` (names of :data:`~pbanim.compare.scenes.SCENES`, default all) in ``engines``
    (default all of :data:`ENGINES`) at each scene's steps (``quick``: its short sweep and duration, or
    ``steps`` for every scene). ``own_steps`` (when ``steps`` is not given): every engine also runs at the
    peers' own steps (:data:`OWN_STEPS`) that the sweep lacks, in rows with ``sweep = False``. Never raises
    for an engine's failure; see the module docstring. A run of more than :data:`MAX_RUN_STEPS` steps is
    refused before anything runs. ``stop_below``: an engine whose error at a step of a scene's sweep is at or
    below it skips that sweep's finer steps (a plot whose error axis stops there shows nothing more: the
    sweep is capped at the accuracy shown; the skipped rows are absent, not failed)."""
    from .scenes import SCENES

    names = list(SCENES) if scenes is None else list(scenes)
    engs = list(ENGINES) if engines is None else list(engines)
    if steps is not None:
        hs = np.atleast_1d(np.asarray(steps, dtype=float))
    built = {n: SCENES[n]() for n in names}
    sweeps = {n: tuple(hs) if steps is not None else (sc.spec.quick_steps if quick else sc.spec.steps)
              for n, sc in built.items()}
    for n, sweep in sweeps.items():
        span = built[n].spec.time(quick)
        if max(sweep) > span:
            raise InvalidInput(f"step h = {max(sweep):g} s is longer than scene {n!r} ({span:g} s)")
        if span / min(sweep) > MAX_RUN_STEPS:
            raise InvalidInput(f"steps: h = {min(sweep):g} s needs {span / min(sweep):.3g} steps for scene {n!r} "
                               f"({span:g} s), more than {MAX_RUN_STEPS}; choose a larger step")
    rows, curves = [], {} if keep_curves else None
    extra = {n: [h for h in OWN_STEPS.values() if own_steps and steps is None and h <= built[n].spec.time(quick)
                 and not any(math.isclose(h, s, rel_tol=1e-9) for s in sweep)] for n, sweep in sweeps.items()}
    for n, sc in built.items():
        floored = {}                           # engine → the step of its sweep where it reached stop_below
        for h, in_sweep in [(h, True) for h in sweeps[n]] + [(h, False) for h in extra[n]]:
            for e in engs:
                if in_sweep and h < floored.get(e, 0.0):
                    continue
                row = _run_one(sc, e, float(h), quick, curves, in_sweep)
                rows.append(row)
                if stop_below is not None and row.status == "ok" and row.error <= stop_below:
                    floored[e] = min(floored.get(e, np.inf), float(h))
                if progress is not None:
                    progress(f"{n:14s} {e:16s} h = {h:<8.4g} {row.status}"
                             + (f"  error {row.error:.3g}" if row.status == "ok" else f"  ({row.reason})"))
    return Comparison(rows, built, quick, versions(), time.strftime("%Y-%m-%d"), curves or {})
