"""``pbanim.solve``: the integration driver (fixed steps, adaptive Dormand–Prince, events, batch, scipy).

See :mod:`pbanim.ode` for the lecture. This module holds the loops:

* fixed steps run through the one driver, :mod:`pbanim.ode.driver` (its step rule: N = ⌈(t_f − t₀)/h⌉
  steps, the last one shortened to land on t_f); events and ``t_eval`` output are its hooks; with
  neither (and an explicit method) :func:`~pbanim.ode.driver.drive_lean` stores the states into one
  preallocated array and checks finiteness once per block of steps;
* the adaptive loops are the methods' own (``Method.run``): the explicit pairs in
  :mod:`pbanim.ode.adaptive`, RODAS4 in :mod:`pbanim.ode.rosenbrock`, Radau IIA in
  :mod:`pbanim.ode.radau`; event location in :mod:`pbanim.ode.events`; ``method="scipy:<name>"`` hands the same call to ``scipy.integrate.solve_ivp``.
"""

from __future__ import annotations

import time
from typing import Callable, Sequence

import numpy as np

from ..contracts import Array, Choice, Either, Func, Int, Opt, Real, Seq, contract
from ..errors import InvalidInput, SimulationDiverged
from .driver import check_finite, drive, drive_lean, step_grid
from .events import OK_MESSAGE, TERMINATED, crossings, handle_events, make_events, make_result, start_output
from .methods import Method, get_method
from .signature import JAC
from ..results import SimResult

__all__ = ["solve", "SCIPY_METHODS"]

SCIPY_METHODS = ("RK23", "RK45", "DOP853", "Radau", "BDF", "LSODA")


# ---------------------------------------------------------------------------------------------------
# validation
# ---------------------------------------------------------------------------------------------------
def _check_inputs(fun, t_span, y0, h, rtol, atol, max_steps, split, t_eval):
    """What the contract of :func:`solve` cannot say alone: conditions between arguments."""
    t0, tf = (float(v) for v in t_span)
    if t0 == tf:
        raise InvalidInput(f"solve: t_span must be two different times, got {(t0, tf)!r}")
    y = np.array(y0, dtype=float)       # a copy: the run never writes into the caller's array
    n = y.shape[-1]
    if np.ndim(atol) and np.shape(atol)[-1] != n:
        raise InvalidInput(f"solve: atol must be one number or one per component of y0 ({n}), got shape "
                           f"{np.shape(atol)}")
    if split is not None and not (0 <= int(split) <= n):
        raise InvalidInput(f"split must be between 0 and n = {n} (number of position components), got {split}")
    if t_eval is not None:
        t_eval = np.asarray(t_eval, dtype=float).ravel()
        d = np.sign(tf - t0)
        lo, hi = min(t0, tf), max(t0, tf)
        if np.any(t_eval < lo) or np.any(t_eval > hi) or np.any(d * np.diff(t_eval) < 0):
            raise InvalidInput(f"t_eval must be sorted in the direction of integration and lie within t_span "
                             f"{(t0, tf)}, got {t_eval[:5]}{'...' if t_eval.size > 5 else ''}")
    return t0, tf, y, h, t_eval


def _check_f0(fun, t0, y):
    f0 = np.asarray(fun(t0, y))
    if f0.shape != y.shape:
        raise InvalidInput(f"fun(t, y) must return an array of the shape of y0 {y.shape}, got {f0.shape}"
                         + ("; in batch mode fun receives (K, n) arrays" if y.ndim == 2 else ""))
    if not np.all(np.isfinite(f0)):
        raise SimulationDiverged(t0, 0, "derivative f(t0, y0)", "fun returned a non-finite value at the start")
    return f0


# ---------------------------------------------------------------------------------------------------
# the public driver
# ---------------------------------------------------------------------------------------------------
def _method_names():
    from .methods import METHODS
    return list(METHODS) + [f"scipy:{m}" for m in SCIPY_METHODS]


@contract(fun=Func(), t_span=Array((2,)), y0=Array(("n",), batch="first"), method=Choice(_method_names),
          h=Opt(Real(gt=0)), rtol=Real(gt=0), atol=Either(Real(ge=0), Array(("n",), ge=0)), jac=Opt(JAC),
          t_eval=Opt(Array((None,))), events=Opt(Either(Func(), Seq(Func(), min_len=1))), max_steps=Int(ge=1),
          split=Opt(Int(ge=0)))
def solve(fun: Callable, t_span: Sequence[float], y0, *, method: str = "rk4", h: float | None = None,
          rtol: float = 1e-6, atol: float = 1e-9, jac=None, t_eval=None, events=None, max_steps: int = 100000,
          split: int | None = None) -> SimResult:
    """Integrate ẏ = f(t, y) over ``t_span`` from ``y0``, in the shape of ``scipy.integrate.solve_ivp``.

    Parameters
    ----------
    fun : callable ``fun(t, y) -> dy/dt``
        Same shape in and out: (n,), or (K, n) in batch mode.
    t_span : (t0, t_end)
    y0 : array, shape (n,) or (K, n)
        A 2-D ``y0`` integrates K initial conditions at once (batch mode: no Python loop over K; the
        adaptive method uses one step size for all, controlled by the worst trajectory).
    method : str
        A name in :data:`pbanim.ode.METHODS`, or ``"scipy:RK45"`` (any solve_ivp method) to delegate to
        scipy (then ``h`` is passed as ``max_step``).
    h : float
        Step of a fixed-step method (required); first step of an adaptive method (optional).
    rtol, atol : float
        Tolerances of the adaptive method.
    jac : callable ``jac(t, y)`` or matrix, optional
        ∂f/∂y (dense or scipy.sparse) for the implicit methods (``rodas4``, ``radau5`` ...); else
        forward differences. A right-hand side with ``fun.autonomous = True`` saves Rosenbrock's ∂f/∂t.
    t_eval : array, optional
        Output times (reached by partial steps of the method); default: every step.
    events : callable or list of callables ``event(t, y)``, optional
        Attributes ``terminal`` (bool or count) and ``direction`` as in scipy. Not in batch mode.
    max_steps : int
        Most steps (fixed: ValueError up front; adaptive: status −1).
    split : int, optional
        Number of position components at the front of y for split methods (default n // 2).

    Returns
    -------
    SimResult
        ``t``, ``y`` (n, n_points) or (K, n, n_points), ``t_events``, ``y_events``, ``nfev``, ``status``
        (0 done, 1 terminal event, −1 failed), ``message``, ``wall_time`` ...

    Raises
    ------
    ValueError
        Bad arguments (h ≤ 0, non-finite y0, wrong shapes, unknown method).
    SimulationDiverged
        A fixed-step run produced a non-finite state (names the time, step and quantity).

    Examples
    --------
    >>> r = solve(lambda t, y: -y, (0.0, 1.0), [1.0], method="rk4", h=0.01)
    >>> bool(abs(r.y[0, -1] - np.exp(-1.0)) < 1e-9), r.status
    (True, 0)
    >>> r = solve(lambda t, y: -y, (0.0, 1.0), [1.0], method="dopri5", rtol=1e-8, atol=1e-12)
    >>> bool(abs(r.y[0, -1] - np.exp(-1.0)) < 1e-8)
    True
    """
    t0, tf, y, h, t_eval = _check_inputs(fun, t_span, y0, h, rtol, atol, max_steps, split, t_eval)
    evs = make_events(events)
    if isinstance(method, str) and method.startswith("scipy:"):
        return _solve_scipy(fun, t0, tf, y, method[6:], h, rtol, atol, jac, t_eval, events, int(max_steps))
    m = get_method(method)
    if evs and y.ndim == 2:
        raise InvalidInput("events are not supported in batch mode (y0 of shape (K, n)); loop over the "
                         "initial conditions or drop events")
    f0 = _check_f0(fun, t0, y)
    if m.adaptive:
        return m.run(fun, t0, tf, y, f0, m, h, rtol, atol, t_eval, evs, int(max_steps), split, jac)
    if h is None:
        raise InvalidInput(f"h must be given for the fixed-step method {m.name!r} (e.g. h=1e-3), got None")
    return _solve_fixed(fun, t0, tf, y, m, h, jac, t_eval, evs, int(max_steps), split)


# ---------------------------------------------------------------------------------------------------
# fixed-step runs: clients of the one driver (pbanim.ode.driver)
# ---------------------------------------------------------------------------------------------------
def _solve_fixed(fun, t0, tf, y, m: Method, h, jac, t_eval, evs, max_steps, split) -> SimResult:
    grid = step_grid(t0, tf, h, max_steps=max_steps, backward=True)
    step = m.step
    per = getattr(step, "nfev", None)
    if t_eval is None and not evs and per is not None:
        start = time.perf_counter()
        Y = drive_lean(lambda t, yy, hk: step(fun, t, yy, hk, split), grid, y)
        wall = time.perf_counter() - start
        return make_result(grid.times(), Y, 1 + per * grid.n_steps, 0, 0, OK_MESSAGE, wall, m.name, [],
                           grid.n_steps)
    counter = [1, 0]  # f(t0, y0) was evaluated by the shape check

    def f(t, yy):
        counter[0] += 1
        return fun(t, yy)

    f.autonomous = getattr(fun, "autonomous", False)   # a declared time-independent f stays declared

    jf = jac
    if callable(jac):
        def jf(t, yy):
            counter[1] += 1
            return jac(t, yy)
    ts, Ys, ie = start_output(t0, y, t_eval)
    g_old = [float(e.fn(t0, y)) for e in evs]
    hs = grid.h

    def partial(t, yy):
        return lambda s: step(f, t, yy, s, split, jf)

    def on_events(k, t, yy, t1, y1, hk):
        nonlocal g_old
        found = crossings(evs, g_old, t, yy, t1, y1, hk, partial(t, yy))
        stop = handle_events(evs, found) if found else None
        if stop is not None:
            t1, y1 = stop
        g_old = [float(e.fn(t1, y1)) for e in evs]
        return None if stop is None else (t1, y1, True)

    def on_output(k, t, yy, t1, y1, hk):
        nonlocal ie
        if t_eval is None:
            ts.append(t1), Ys.append(y1)
            return None
        while ie < len(t_eval) and (t_eval[ie] - t1) * hs <= 0:
            te = t_eval[ie]
            ts.append(te), Ys.append(y1 if te == t1 else partial(t, yy)(te - t))
            ie += 1
        return None

    start = time.perf_counter()
    with np.errstate(over="ignore", invalid="ignore"):
        _, _, steps, stopped = drive(lambda t, yy, hk: step(f, t, yy, hk, split, jf), grid, y,
                                     hooks=([on_events] if evs else []) + [on_output], quantity="state y")
    wall = time.perf_counter() - start
    Y = np.array(Ys) if Ys else np.empty((0,) + y.shape)
    status, message = (1, TERMINATED) if stopped else (0, OK_MESSAGE)
    return make_result(ts, Y, counter[0], counter[1], status, message, wall, m.name, evs, steps)


# ---------------------------------------------------------------------------------------------------
# delegation to scipy
# ---------------------------------------------------------------------------------------------------
class _EvaluationCap(Exception):
    """Raised inside the wrapped fun when scipy's run passes the evaluation cap (caught below)."""


def _solve_scipy(fun, t0, tf, y, name, h, rtol, atol, jac, t_eval, events, max_steps) -> SimResult:
    """Hand the call to ``scipy.integrate.solve_ivp`` under pbanim's cap and finiteness check.

    The cap: with ``h`` (scipy's ``max_step``) a run needing more than ``max_steps`` steps is refused up
    front (:class:`~pbanim.errors.StepLimitExceeded`); whatever the step, the run stops with status −1
    after 20·max_steps evaluations of f (more than any scipy method spends on max_steps steps). A
    non-finite state in the output raises :class:`SimulationDiverged` naming its time.
    """
    from scipy.integrate import solve_ivp

    if name not in SCIPY_METHODS:
        raise InvalidInput(f"method must be 'scipy:' + one of {list(SCIPY_METHODS)}, got 'scipy:{name}'")
    if y.ndim != 1:
        raise InvalidInput("batch mode (y0 of shape (K, n)) needs a pbanim method, not scipy:" + name)
    if t_eval is not None and np.any(np.diff(t_eval) == 0):
        raise InvalidInput(f"t_eval must not repeat a time for scipy:{name} (scipy needs strictly sorted "
                           f"times), got {t_eval[:5]}{'...' if t_eval.size > 5 else ''}")
    opts = {}
    if h is not None:
        step_grid(t0, tf, h, max_steps=max_steps, backward=True)      # refuses an astronomical run
        opts["max_step"] = h
    if jac is not None and name in ("Radau", "BDF", "LSODA"):
        opts["jac"] = jac
    cap, count = 20 * max_steps, [0]

    def capped(t, yy):
        count[0] += 1
        if count[0] > cap:
            raise _EvaluationCap
        return fun(t, yy)

    start = time.perf_counter()
    try:
        r = solve_ivp(capped, (t0, tf), y, method=name, t_eval=t_eval, events=events, rtol=rtol, atol=atol,
                      **opts)
    except _EvaluationCap:
        return SimResult(t=np.array([t0]), y=y[:, None].copy(), nfev=cap, status=-1,
                         message=f"scipy:{name} stopped after {cap} evaluations of f (20·max_steps, "
                                 f"max_steps = {max_steps}); raise max_steps or loosen rtol",
                         wall_time=time.perf_counter() - start, method="scipy:" + name)
    wall = time.perf_counter() - start
    bad = ~np.all(np.isfinite(r.y), axis=0) if r.y.size else np.zeros(0, bool)
    if bad.any():
        k = int(np.flatnonzero(bad)[0])
        check_finite(r.y[:, k], float(r.t[max(k - 1, 0)]), k, "state y")
    return SimResult(t=r.t, y=r.y, nfev=r.nfev, njev=r.njev, nlu=r.nlu, status=r.status, message=r.message,
                     wall_time=wall, method="scipy:" + name, t_events=r.t_events, y_events=r.y_events,
                     nsteps=max(0, len(r.t) - 1) if t_eval is None else 0)
