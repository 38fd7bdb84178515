"""Shared pieces of the integration loops: result assembly, divergence errors, event location.

An event is a callable g(t, y) with optional attributes ``terminal`` (bool or a count) and ``direction``
(as in scipy). After each step the sign of every g is compared with its value at the step start: a change
(g₀ < 0 ≤ g₁ upward, g₀ > 0 ≥ g₁ downward, filtered by ``direction``) is located by Brent's method on the
method's own partial step, τ ↦ g(t + τ, Φ_τ(y)), to |Δτ| ≤ 1e-14·max(1, |t|) — for a method exact on the
motion (RK4 on free fall) that is the exact time of impact. A value exactly zero at the step start does not
fire again, so restarting from an event state (after a bounce) is safe.

References: Brent, *Algorithms for Minimization without Derivatives* (1973), ch. 4; Hairer, Nørsett &
Wanner, *Solving ODEs I*, §II.6 (dense output and event location).
"""

from __future__ import annotations

import numpy as np
from scipy.optimize import brentq

from ..errors import InvalidInput
from ..results import SimResult

__all__ = ["Event", "make_events", "make_result", "crossings", "handle_events", "OK_MESSAGE",
           "TERMINATED"]

OK_MESSAGE = "The solver successfully reached the end of the integration interval."
TERMINATED = "A termination event occurred."


class Event:
    """An event function with its scipy-style attributes and the crossings recorded so far."""

    __slots__ = ("fn", "terminal", "direction", "count", "times", "states")

    def __init__(self, fn):
        if not callable(fn):
            raise InvalidInput(f"events must be callables event(t, y), got {type(fn).__name__}")
        self.fn = fn
        term = getattr(fn, "terminal", False)
        self.terminal = int(term) if not isinstance(term, bool) else (1 if term else 0)
        self.direction = float(getattr(fn, "direction", 0.0))
        self.count = 0
        self.times: list = []
        self.states: list = []


def make_events(events) -> list[Event]:
    """Normalize ``events`` (None, one callable or a list) to a list of :class:`Event`."""
    if events is None:
        return []
    if callable(events):
        events = [events]
    return [Event(e) for e in events]


def start_output(t0: float, y: np.ndarray, t_eval) -> tuple[list, list, int]:
    """Output lists at the start of a run: (times, states, index of the next ``t_eval`` point).

    Without ``t_eval`` every step is recorded, starting with (t0, y0); with it, only the requested times.
    """
    ts, Ys, ie = ([], [], 0) if t_eval is not None else ([t0], [y.copy()], 0)
    if t_eval is not None:
        while ie < len(t_eval) and t_eval[ie] == t0:
            ts.append(t0)
            Ys.append(y.copy())
            ie += 1
    return ts, Ys, ie


def make_result(ts, Y, nfev, njev, status, message, wall, m, evs, nsteps, nrej=0, nlu=0) -> SimResult:
    """The :class:`SimResult` of a run: states stacked along time → y of shape (n, n_points) or (K, n, n_points)."""
    Y = np.asarray(Y)
    y = np.ascontiguousarray(np.moveaxis(Y, 0, -1)) if Y.size else Y
    return SimResult(t=np.asarray(ts, dtype=float), y=y, nfev=int(nfev), njev=int(njev), nlu=int(nlu),
                     status=status, message=message, wall_time=wall, method=m,
                     t_events=[np.array(e.times, dtype=float) for e in evs] if evs else None,
                     y_events=[np.array(e.states, dtype=float).reshape(len(e.times), Y.shape[-1]) for e in evs] if evs else None,
                     nsteps=int(nsteps), nrejected=int(nrej))


def crossings(evs, g_old, t, y, t1, y1, hk, partial):
    """Events crossed in [t, t1]: a list of (t*, y*, event) in time order, each located by Brent's method.

    ``partial(τ)`` is the method's step of size τ from (t, y); ``hk`` the signed step; ``g_old`` the event
    values at (t, y).
    """
    found = []
    for e, g0 in zip(evs, g_old):
        g1 = float(e.fn(t1, y1))
        up = g0 < 0.0 <= g1
        down = g0 > 0.0 >= g1
        if (up and e.direction >= 0) or (down and e.direction <= 0):
            if g1 == 0.0:
                tau = hk
            else:
                tau = brentq(lambda s: float(e.fn(t + s, partial(s))), 0.0, hk,
                             xtol=1e-14 * max(1.0, abs(t)), rtol=4 * np.finfo(float).eps, maxiter=200)
            ys = y1 if tau == hk else partial(tau)
            found.append((t + tau, ys, e))
    found.sort(key=lambda x: x[0] * np.sign(hk))
    return found


def handle_events(evs, found):
    """Record crossings; return (t*, y*) of the first terminal one that fires, else None."""
    for ts, ys, e in found:
        e.times.append(ts)
        e.states.append(np.array(ys, copy=True))
        e.count += 1
        if e.terminal and e.count >= e.terminal:
            return ts, ys
    return None
