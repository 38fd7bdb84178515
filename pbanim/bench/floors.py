"""``pbanim bench floors``: a small scene's step against a hand-written loop of the same step (issue 28, point 1).

Students run small scenes thousands of steps at a time; what they pay there is the interpreter's per-call
cost, not arithmetic. For each scene kind of the lectures, a row times pbanim's run of n steps against a
hand-written loop of **the same method on the same equations**, written in the benchmark beside it (no
diagnostics, no validation, no dispatch: plain numpy or plain floats, as a student would write it), from the
same initial state, and prints the ratio and the largest difference of the final states (the two must
agree to roundoff: equal work). Goal per row: pbanim ≤ 2× the hand loop; for the single rigid body also
≤ 50 µs a step.

Rows are :class:`Floor` records gathered from the modules ``pbanim/bench/_floor_*.py`` (one per chapter);
each module defines ``FLOORS``, a list of zero-argument functions returning a :class:`Floor`. Timing:
both sides in alternating rounds (the machine's load drifts), medians per step.
"""

from __future__ import annotations

import importlib
import pkgutil
import time
from dataclasses import dataclass, field
from typing import Callable

import numpy as np

from . import Goal, Report, Table

__all__ = ["Floor", "floors", "time_floor", "run"]


@dataclass
class Floor:
    """One row: ``pbanim()`` and ``hand()`` each run ``steps`` steps from the same start and return the final
    state (flat float arrays compared entrywise); ``limit_us``: an absolute goal per step, if any."""

    kind: str
    scene: str
    method: str
    steps: int
    pbanim: Callable[[], np.ndarray]
    hand: Callable[[], np.ndarray]
    limit_us: float | None = None
    tol: float = 1e-9            # |Δ final state| allowed, relative to the state's scale (roundoff of n steps)
    notes: list = field(default_factory=list)


def floors() -> list:
    """Every row factory of the ``_floor_*`` modules, in module order."""
    import pbanim.bench as pkg

    out = []
    for m in sorted(pkgutil.iter_modules(pkg.__path__), key=lambda m: m.name):
        if m.name.startswith("_floor_"):
            out += list(importlib.import_module(f"pbanim.bench.{m.name}").FLOORS)
    return out


def time_floor(fl: Floor, rounds: int = 7) -> dict:
    """Per-step medians of both sides in alternating rounds, their ratio, and the final-state difference."""
    a, b = fl.pbanim(), fl.hand()          # warm-up, and the equal-work check
    scale = max(1.0, float(np.max(np.abs(b))))
    diff = float(np.max(np.abs(np.asarray(a, float) - np.asarray(b, float)))) / scale
    tp, th = [], []
    for _ in range(rounds):
        for fn, out in ((fl.pbanim, tp), (fl.hand, th)):
            start = time.perf_counter()
            fn()
            out.append((time.perf_counter() - start) / fl.steps * 1e6)
    ratios = np.array(tp) / np.array(th)
    return {"pbanim_us": float(np.median(tp)), "hand_us": float(np.median(th)), "ratio": float(np.median(ratios)),
            "q1": float(np.percentile(ratios, 25)), "q3": float(np.percentile(ratios, 75)), "diff": diff}


def run(quick: bool = False) -> Report:
    rep = Report("floors")
    rows = []
    for make in floors():
        fl = make()
        if quick:
            fl.steps = max(1, fl.steps // 10)
        r = time_floor(fl, 3 if quick else 9)
        rows.append([fl.kind, fl.scene, fl.method, fl.steps, r["pbanim_us"], r["hand_us"], r["ratio"],
                     f"{r['q1']:.2f}–{r['q3']:.2f}", r["diff"]])
        agree = r["diff"] <= fl.tol
        rep.goals.append(Goal(f"floor-{fl.kind}", r["ratio"] if agree else float("nan"), 2.0, "<=", "x",
                              f"{fl.scene}, {fl.method}: pbanim / hand loop, quartiles {r['q1']:.2f}–{r['q3']:.2f}"
                              + ("" if agree else f"; the final states differ by {r['diff']:.2e} > {fl.tol:g}: "
                                 "not equal work")))
        if fl.limit_us is not None:
            rep.goals.append(Goal(f"floor-{fl.kind}-us", r["pbanim_us"], fl.limit_us, "<=", " µs",
                                  f"{fl.scene}: pbanim µs per step"))
        rep.notes += fl.notes
    rep.tables.insert(0, Table("A small scene's step against a hand-written loop of the same step (µs per step, "
                               "medians of alternating rounds)",
                               ["kind", "scene", "method", "steps", "pbanim", "hand loop", "ratio", "quartiles",
                                "|Δ final| (rel.)"], rows))
    return rep
