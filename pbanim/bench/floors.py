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
both sides in alternating rounds (the machine's load drifts), medians per step, in the process's CPU time
(``time.process_time``: on a shared machine a run of a millisecond or two timed by the wall clock takes
whatever other processes' time slices fell inside it; measured at load 15 on two cores, the cradle's quartiles
spanned 1.2–6.9x by the wall clock).

The interpreter's floor. What a small step costs is mostly calls: each side's function calls per step are
counted by ``sys.setprofile`` (Python functions; C functions and methods called by name — ``np.sqrt``,
``np.empty_like``, ``Q.fill``; numpy's operators ``+ * @ []`` are not calls to the profiler and are not
counted), and the cost of one empty Python call and of one numpy call on a 2-vector is measured in the
same run. The table prints pbanim's *call floor* (its Python calls × the one, plus its C calls × the
other: what the counted calls would cost if they did no work; a lower bound, operators left out) and that
floor over the hand loop's time. A floor ratio near or above 2 says that CPython's per-call cost bounds
the row at this number of calls: only fewer calls (a leaner plan) can meet the goal, not faster arithmetic.
"""

from __future__ import annotations

import importlib
import pkgutil
import sys
import time
from dataclasses import dataclass, field
from typing import Callable

import numpy as np

from . import Goal, Report, Table

__all__ = ["Floor", "call_costs", "count_calls", "floors", "time_floor", "run"]


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
            start = time.process_time()
            fn()
            out.append((time.process_time() - start) / fl.steps * 1e6)
    ratios = np.array(tp) / np.array(th)
    return {"pbanim_us": float(np.median(tp)), "hand_us": float(np.median(th)), "ratio": float(np.median(ratios)),
            "q1": float(np.percentile(ratios, 25)), "q3": float(np.percentile(ratios, 75)), "diff": diff}



def count_calls(fn: Callable[[], object]) -> tuple[int, int]:
    """(Python calls, C calls) made by one call of ``fn`` (``sys.setprofile`` events; the profiler's own
    entry excluded)."""
    n = [0, 0]

    def prof(frame, event, arg):
        if event == "call":
            n[0] += 1
        elif event == "c_call":
            n[1] += 1
    old = sys.getprofile()
    sys.setprofile(prof)
    try:
        fn()
    finally:
        sys.setprofile(old)
    return n[0], max(0, n[1] - 1)          # the setprofile(old) call itself is seen as a C call


def call_costs(repeats: int = 5, number: int = 20000) -> tuple[float, float]:
    """µs of one empty Python call and of one numpy call (a product of two 2-vectors): medians of runs."""
    def empty():
        return None
    a, b = np.ones(2), np.ones(2)
    mul = np.multiply
    tp, tc = [], []
    for _ in range(repeats):
        start = time.process_time()
        for _ in range(number):
            empty()
        tp.append(time.process_time() - start)
        start = time.process_time()
        for _ in range(number):
            mul(a, b)
        tc.append(time.process_time() - start)
        start = time.process_time()
        for _ in range(number):
            pass
        loop = time.process_time() - start
        tp[-1] -= loop
        tc[-1] -= loop
    return float(np.median(tp)) / number * 1e6, float(np.median(tc)) / number * 1e6

def run(quick: bool = False) -> Report:
    rep = Report("floors")
    rows = []
    for make in floors():
        fl = make()                        # quick: fewer rounds (a row's runs have their own number of steps)
        r = time_floor(fl, 3 if quick else 9)
        py_call, c_call = call_costs()
        (pp, pc), (hp, hc) = count_calls(fl.pbanim), count_calls(fl.hand)
        per = lambda n: n / fl.steps                                    # noqa: E731
        floor_us = per(pp) * py_call + per(pc) * c_call
        rows.append([fl.kind, fl.scene, fl.method, fl.steps, r["pbanim_us"], r["hand_us"], r["ratio"],
                     f"{r['q1']:.2f}–{r['q3']:.2f}", f"{per(pp):.0f}+{per(pc):.0f}", f"{per(hp):.0f}+{per(hc):.0f}",
                     floor_us, floor_us / r["hand_us"], r["diff"]])
        agree = r["diff"] <= fl.tol
        bound = floor_us / r["hand_us"]
        rep.goals.append(Goal(f"floor-{fl.kind}", r["ratio"] if agree else float("nan"), 2.0, "<=", "x",
                              f"{fl.scene}, {fl.method}: pbanim / hand loop, quartiles {r['q1']:.2f}–{r['q3']:.2f}"
                              + ("" if agree else f"; the final states differ by {r['diff']:.2e} > {fl.tol:g}: "
                                 "not equal work")
                              + (f"; CPython's call floor alone is {bound:.2f}x the hand loop "
                                 f"({per(pp):.0f} Python + {per(pc):.0f} C calls a step)" if bound >= 1.5 else "")))
        if fl.limit_us is not None:
            rep.goals.append(Goal(f"floor-{fl.kind}-us", r["pbanim_us"], fl.limit_us, "<=", " µs",
                                  f"{fl.scene}: pbanim µs per step"))
        rep.notes += fl.notes
    py_call, c_call = call_costs()
    rep.tables.insert(0, Table("A small scene's step against a hand-written loop of the same step (µs per step, "
                               "medians of alternating rounds; calls per step: Python + C)",
                               ["kind", "scene", "method", "steps", "pbanim", "hand loop", "ratio", "quartiles",
                                "pbanim calls", "hand calls", "call floor", "floor / hand", "|Δ final| (rel.)"],
                               rows))
    rep.notes.append(f"call floor = pbanim's Python calls x {py_call:.3f} µs + its C calls x {c_call:.3f} µs (one empty "
                     "Python call, one numpy product of 2-vectors, measured in this run): what its counted calls "
                     "cost if they did no work (operators + * @ [] not counted: a lower bound); 'floor / hand' >= 2 "
                     "means CPython's per-call cost bounds the row at this number of calls")
    return rep
