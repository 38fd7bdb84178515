"""The one fixed-step driver: every fixed-step simulation of the package runs through it (chapter 02).

A fixed-step run from t₀ to t_end with step h is the loop of the lecture,

    for k = 0 … N−1:   y_{k+1} = Φ_h(t_k, y_k)      (the method's step, then what happens between steps)

and every chapter runs it the same way: :func:`pbanim.solve` with a fixed-step method, the particle and
rigid-body scenes (:meth:`pbanim.scene.Scene.simulate`), the collision time-of-impact loop, contact time
stepping and the reduced-coordinate runs all build a :class:`StepGrid` and call :func:`drive` (or
:func:`drive_lean`, its hook-free form that stores the recorded states straight into one preallocated array:
what :meth:`pbanim.scene.Scene.simulate` runs when no diagnostics are read during the run).

The step rule (one rule, every chapter)
---------------------------------------
span = |t_end − t₀|, N = max(1, ⌈span/h − 10⁻⁹⌉). Steps 0 … N−2 have size h, the last one ends exactly at
t_end: h_last = (t_end − t₀) − (N − 1)h ∈ (0, h(1 + 10⁻⁹)] (and exactly h when that is h up to 10⁻⁹·h). The times are t_k = t₀ + k·h for k < N and
t_N = t_end exactly. When span/h is a whole number (to within 10⁻⁹, so 1.0/0.1 counts as 10), every
step is h; otherwise the last step is shortened, never lengthened, and never skipped. So the same ``t_span``
and ``h`` give the same number of steps and the same final time in every chapter.

The cap and the check
---------------------
``max_steps`` (default :data:`MAX_STEPS`) is checked when the grid is built, before any step runs: a run
that would need more steps raises :class:`~pbanim.errors.StepLimitExceeded` naming h, the span and N. After
each step (every ``check_every`` steps and always at the last) :func:`check_finite` raises
:class:`~pbanim.errors.SimulationDiverged` naming the start time of the step, its index and the quantity,
so a diverging run stops with an error instead of filling the result with NaN.

Hooks (what happens between steps)
----------------------------------
``drive(advance, grid, y0, hooks=[...], record=...)``: after ``advance(t, y, h)`` each hook is called as
``hook(k, t, y, t1, y1, h)`` and returns ``None`` (nothing changed) or ``(t1, y1, stop)``: a new end time
and state (an event located inside the step, an impulse applied at the time of impact, a chart switched,
a contact solve) and whether the run ends there (a terminal event). ``record(t1, y1)`` is called every
``record_every`` steps, at the last step and at a stop: recording states and diagnostics is a hook too.
"""

from __future__ import annotations

import math
import operator
from dataclasses import dataclass
from typing import Callable, Sequence

import numpy as np

from ..contracts import Array, Int, Real, Text, contract
from ..errors import InvalidInput, SimulationDiverged, StepLimitExceeded, as_float, check_count

__all__ = ["MAX_STEPS", "StepGrid", "step_grid", "fixed_steps", "check_finite", "drive", "drive_lean"]

#: Default cap on the number of fixed steps of one run (about 80 MB of states for a 1-D problem).
MAX_STEPS = 10_000_000
_SLACK = 1e-9          # a span within 1e-9·h of a whole number of steps takes that number
_BLOCK = 64            # drive_lean checks finiteness once per this many stored states


@dataclass(frozen=True)
class StepGrid:
    """The steps of one fixed-step run: N steps, all of size h but the last (h_last), ending at t_end.

    >>> g = step_grid(0.0, 1.0, 0.3)
    >>> g.n_steps, round(g.h_last, 12), g.time(4)
    (4, 0.1, 1.0)
    """

    t0: float
    t_end: float
    h: float           # signed step (negative for a backward run)
    n_steps: int
    h_last: float      # signed size of the last step

    def time(self, k: int) -> float:
        """t_k: t₀ + k·h for k < N, exactly t_end for k = N."""
        return self.t_end if k >= self.n_steps else self.t0 + k * self.h

    def size(self, k: int) -> float:
        """The (signed) size of step k."""
        return self.h_last if k == self.n_steps - 1 else self.h

    def times(self) -> np.ndarray:
        """All N + 1 grid times t₀ … t_end."""
        ts = self.t0 + self.h * np.arange(self.n_steps + 1)
        ts[-1] = self.t_end
        return ts


def step_grid(t0: float, t_end: float, h: float, *, max_steps: int = MAX_STEPS,
              backward: bool = False, record_every: int = 1) -> StepGrid:
    """Validate a fixed-step run and return its :class:`StepGrid` (the one step rule; see the module).

    Raises ``ValueError`` naming the argument for a non-positive or non-finite ``h``, a non-finite ``t0``
    or ``t_end``, ``t_end`` not after ``t0`` (unless ``backward``), ``record_every`` < 1 or ``max_steps`` < 1,
    and :class:`~pbanim.errors.StepLimitExceeded` when the run needs more than ``max_steps`` steps.
    """
    h = as_float("h", h)
    if not math.isfinite(h) or h <= 0:
        raise InvalidInput(f"h must be a positive finite step, got {h}")
    t0, t_end = as_float("t0", t0), as_float("t_end", t_end)
    if not math.isfinite(t0):
        raise InvalidInput(f"t0 must be a finite time, got {t0}")
    if not math.isfinite(t_end) or t_end == t0 or (t_end < t0 and not backward):
        raise InvalidInput(f"t_end must be a finite time {'different from' if backward else 'after'} "
                         f"t0 = {t0}, got {t_end}")
    record_every = check_count("record_every", record_every)
    max_steps = check_count("max_steps", max_steps)
    span = abs(t_end - t0)
    ratio = span / h
    if not math.isfinite(ratio):
        raise StepLimitExceeded(h, span, ratio, int(max_steps))
    n = max(1, math.ceil(ratio - _SLACK))
    if n > max_steps:
        raise StepLimitExceeded(h, span, n, int(max_steps))
    hs = math.copysign(h, t_end - t0)
    h_last = (t_end - t0) - (n - 1) * hs
    if abs(h_last - hs) <= _SLACK * h:   # a whole number of steps: the last is h itself, not h ± roundoff
        h_last = hs
    return StepGrid(t0, t_end, hs, n, h_last)


@contract(t0=Real(), t_end=Real(), h=Real(gt=0), record_every=Int(ge=1))
def fixed_steps(t0: float, t_end: float, h: float, record_every: int = 1) -> tuple[float, int]:
    """Validate a fixed-step run and return (h, number of steps) by the driver's one step rule.

    Kept for course material that called it (also as ``pbanim.scene.fixed_steps``); new code builds a
    :class:`StepGrid` with :func:`step_grid`, which also gives the shortened last step.

    >>> fixed_steps(0.0, 1.0, 0.1)
    (0.1, 10)
    """
    grid = step_grid(t0, t_end, h, record_every=record_every)
    return grid.h, grid.n_steps


@contract(y=Array(None, nan=True, empty=True), t=Real(), step=Int(ge=-1), quantity=Text())
def check_finite(y: np.ndarray, t: float, step: int, quantity: str = "state") -> None:
    """Raise :class:`SimulationDiverged` if ``y`` has a NaN or Inf (one BLAS pass, no temporaries).

    ``t`` is the start time of step ``step`` that produced ``y``; ``quantity`` names what was checked.
    """
    flat = np.ravel(y)
    with np.errstate(over="ignore", invalid="ignore"):
        ok = np.isfinite(flat @ flat)
    if not ok:
        bad = np.flatnonzero(~np.isfinite(flat))
        detail = f"first bad component {int(bad[0])}" if bad.size else "norm overflowed"
        raise SimulationDiverged(t, step, quantity, detail)


#: states up to this size take :func:`check_finite_quick` in :func:`drive`
_SMALL_CHECK = 32


def check_finite_quick(y, t: float, step: int, quantity: str = "state", max_size: int = _SMALL_CHECK) -> None:
    """:func:`check_finite` for a small float64 state (at most ``max_size`` entries), without its
    ``np.errstate`` context (most of its cost); a step loop outside :func:`drive` calls it too.

    |y|² is summed over Python floats, which overflow to inf and carry NaN without a warning. A sum at most
    1e307 is finite however BLAS orders and rounds it (n ≤ max_size terms, relative rounding ≤ nε): the state
    passes as the readable check passes it; anything else (and a larger or non-float state) gets the
    readable check itself (its contract included), so a failure raises what :func:`check_finite` raises."""
    if type(y) is np.ndarray and y.dtype == np.float64 and y.size <= max_size:
        v = y.ravel().tolist()
        s = sum(map(operator.mul, v, v))
        if s <= 1e307:            # False for NaN and inf
            return
    check_finite(y, t, step, quantity)


Hook = Callable[[int, float, np.ndarray, float, np.ndarray, float], "tuple | None"]


def drive(advance: Callable[[float, np.ndarray, float], np.ndarray], grid: StepGrid, y0: np.ndarray, *,
          hooks: Sequence[Hook] = (), record: Callable[[float, np.ndarray], None] | None = None,
          record_every: int = 1, check_every: int = 1, quantity: str = "state") -> tuple:
    """Run the steps of ``grid`` from ``y0``: y₁ = advance(t, y, h), then the hooks, the check, the record.

    Returns ``(t, y, steps, stopped)``: the time and state reached, the number of steps taken and whether
    a hook stopped the run early. ``y0`` itself is neither checked nor recorded (the caller does both once).
    """
    n = grid.n_steps
    t0, hs, t_end = grid.t0, grid.h, grid.t_end
    t, y = t0, y0
    k, stopped = -1, False
    for k in range(n):
        last = k == n - 1
        h = grid.h_last if last else hs
        t1 = t_end if last else t0 + (k + 1) * hs
        y1 = advance(t, y, h)
        due = last or (k + 1) % check_every == 0
        if due:
            check_finite_quick(y1, t, k, quantity)
        for hook in hooks:
            out = hook(k, t, y, t1, y1, h)
            if out is not None:
                t1, y1, stop = out
                stopped = stopped or stop
        if hooks and (due or stopped):
            check_finite_quick(y1, t, k, quantity)
        if record is not None and (last or stopped or (k + 1) % record_every == 0):
            record(t1, y1)
        t, y = t1, y1
        if stopped:
            break
    return t, y, k + 1, stopped


def drive_lean(advance: Callable[[float, np.ndarray, float], np.ndarray], grid: StepGrid,
               y0: np.ndarray, quantity: str = "state y", *, record_every: int = 1,
               check_every: int | None = None) -> np.ndarray:
    """:func:`drive` without hooks, storing the recorded states into one preallocated array.

    Returns Y of shape (R + 1,) + y0.shape: y0, then the state after every ``record_every``-th step and after
    the last (R = ⌈N / record_every⌉, at the times ``grid.times()[::record_every]`` and t_end). The loop does
    the step, the check and the store and nothing else. ``check_every=None`` (every state recorded):
    finiteness (:func:`check_finite`'s: |y|² finite) is checked once per block of stored states and a bad
    block is searched for the first bad step, which is named as :func:`drive` names it (the steps after it
    in the block have run on a non-finite state: for steps that cannot raise on one). An integer: the state
    is checked (one dot product) every ``check_every`` steps and after the last, as :func:`drive` checks
    it. ``advance`` returns a new state, which the driver copies when it keeps it.
    """
    n, t0, hs = grid.n_steps, grid.t0, grid.h
    r = int(record_every)
    R = -(-n // r)
    Y = np.empty((R + 1,) + np.shape(y0), dtype=np.result_type(y0, float))
    Y[0] = y = y0
    with np.errstate(over="ignore", invalid="ignore"):
        if r == 1 and check_every is None:
            k0 = 0
            for k in range(n - 1):
                y = advance(t0 + k * hs, y, hs)
                Y[k + 1] = y
                if k - k0 == _BLOCK:
                    if not _finite_rows(Y[k0 + 1:k + 2]).all():
                        _raise_first_bad(Y, k0, k + 1, grid, quantity)
                    k0 = k + 1
            Y[n] = advance(grid.time(n - 1), y, grid.h_last)
            if not _finite_rows(Y[k0 + 1:]).all():
                _raise_first_bad(Y, k0, n, grid, quantity)
            return Y
        c, last, k = int(check_every or 1), n - 1, 0
        for i in range(1, R + 1):
            stop = min(i * r, n)
            while k < stop:
                t = t0 + k * hs
                y = advance(t, y, hs if k != last else grid.h_last)
                k += 1
                if k % c == 0 or k == n:
                    flat = y if y.ndim == 1 else y.reshape(-1)
                    if not math.isfinite(flat @ flat):
                        check_finite(y, t, k - 1, quantity)
            Y[i] = y
    return Y


def _finite_rows(seg: np.ndarray) -> np.ndarray:
    """Per stored state, whether it passes :func:`check_finite` (|y|² finite: no NaN, no Inf, no overflow)."""
    seg = seg.reshape(len(seg), -1)
    with np.errstate(over="ignore", invalid="ignore"):
        return np.isfinite(np.einsum("ij,ij->i", seg, seg))


def _raise_first_bad(Y, k0, k1, grid, quantity):
    i = int(np.flatnonzero(~_finite_rows(Y[k0 + 1:k1 + 1]))[0])
    k = k0 + i  # the step that went from Y[k] (finite) to Y[k + 1] (not)
    check_finite(Y[k + 1], grid.time(k), k, quantity)
