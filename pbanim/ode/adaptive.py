"""The adaptive loops of the explicit pairs: Dormand–Prince 5(4) (``"dopri5"``), DOP853, Verner 7(6).

Error control (Hairer, Nørsett & Wanner, *Solving ODEs I*, §II.4): the embedded fourth-order formula gives
err = ‖h Σ eᵢkᵢ / (atol + rtol·max(|y₀|, |y₁|))‖_RMS (in batch mode the worst trajectory's); a step is
accepted iff err ≤ 1 and the next one is h·min(10, max(0.2, 0.9·err^(−1/5))) (no growth right after a
rejection). The first stage of a step is the last of the previous one (FSAL). A step below 10ε|t| is a
step-size underflow: the run returns status −1 with a message instead of hanging; so does ``max_steps``.
Same controller as scipy's RK45, hence the same steps (a test checks it).

The high-order pairs (:func:`solve_pair`, methods ``"dop853"`` and ``"vern7"`` of
:mod:`pbanim.ode.high_order`) run one leaner loop: the stages live in one preallocated (stages, n)
array K, the coefficients are scaled by h once per step (h·A, h·b, h·e in one array), each stage sum
h Σⱼ aᵢⱼkⱼ is one ``np.dot`` written into a preallocated stage-point buffer (then y₀ is added: the
summation order of the readable loop), the error estimates of a step are one matrix product E·K, the
step size comes from the PI controller (:mod:`pbanim.ode.control`), and the only per-step checks are the
step cap and the finiteness of the error (a NaN error rejects the step). Dormand–Prince 5(4) uses the
same buffers. fun still receives a fresh array at every stage (one allocation, no copy: y₀ is added
into a new array), so a fun that keeps its y, as a student's logging fun may, sees it unchanged. Per evaluation of f this loop adds ≈ 1.7 µs
on Kepler (scipy's DOP853: 3.0 µs; ORACLES A13 checks it against the readable stage loop).
``t_eval`` and events use the pair's continuous extension, built only for the steps that need it, so
they never shorten a step (ORACLES A10).
"""

from __future__ import annotations

import math
import time

import numpy as np

from dataclasses import dataclass
from typing import Callable

from .control import EPS10, Controller, check_real, emit_step, initial_step, step_end, step_failure
from .events import OK_MESSAGE, TERMINATED, crossings, handle_events, make_result, start_output
from .high_order import (DOP853, DOP853_A_EXTRA, DOP853_C_EXTRA, DOP853_E3, DOP853_E5, VERN7, VERN7_A_EXTRA,
                         VERN7_C_EXTRA, dop853_dense, dop853_eval, vern7_dense, vern7_eval)
from .tableau import Tableau, make_rk_step
from .signature import STEP, finite_step
from ..contracts import contract
from ..results import SimResult

__all__ = ["solve_adaptive", "solve_pair", "Pair", "PAIRS", "DOPRI5", "dopri5_step"]

_F = lambda a, b: a / b  # noqa: E731  (readable rational coefficients)

# Dormand & Prince (1980), the 5(4) pair with the FSAL property (last row of A = B)
DOPRI5 = Tableau(
    "dopri5",
    np.array([
        [0, 0, 0, 0, 0, 0, 0],
        [_F(1, 5), 0, 0, 0, 0, 0, 0],
        [_F(3, 40), _F(9, 40), 0, 0, 0, 0, 0],
        [_F(44, 45), _F(-56, 15), _F(32, 9), 0, 0, 0, 0],
        [_F(19372, 6561), _F(-25360, 2187), _F(64448, 6561), _F(-212, 729), 0, 0, 0],
        [_F(9017, 3168), _F(-355, 33), _F(46732, 5247), _F(49, 176), _F(-5103, 18656), 0, 0],
        [_F(35, 384), 0, _F(500, 1113), _F(125, 192), _F(-2187, 6784), _F(11, 84), 0]]),
    np.array([_F(35, 384), 0, _F(500, 1113), _F(125, 192), _F(-2187, 6784), _F(11, 84), 0]),
    np.array([0, _F(1, 5), _F(3, 10), _F(4, 5), _F(8, 9), 1, 1]), 5,
    E=np.array([_F(35, 384) - _F(5179, 57600), 0, _F(500, 1113) - _F(7571, 16695),
                _F(125, 192) - _F(393, 640), _F(-2187, 6784) + _F(92097, 339200),
                _F(11, 84) - _F(187, 2100), _F(-1, 40)]), embedded_order=4)
_step5 = make_rk_step(DOPRI5)


@contract(**STEP, returns=finite_step)
def dopri5_step(fun, t, y, h, split=None, jac=None):
    """One fixed step of the fifth-order Dormand–Prince formula (no error control; see :func:`pbanim.solve`)."""
    return _step5(fun, t, y, h)


dopri5_step.nfev = 7
dopri5_step.tableau = DOPRI5

_DP_C = DOPRI5.C
_DP_W = np.vstack([DOPRI5.A, DOPRI5.B, DOPRI5.E])      # stage rows, b (= the last stage row, FSAL), e


_initial_step = initial_step


def solve_adaptive(fun, t0, tf, y, f0, m, h, rtol, atol, t_eval, evs, max_steps, split, jac=None) -> SimResult:
    """Run Dormand–Prince 5(4) with error control from (t0, y) to tf (arguments validated by ``solve``)."""
    check_real(m.name, y, f0)
    direction = 1.0 if tf > t0 else -1.0
    shape = y.shape
    batch = y.ndim == 2
    nfev = 1
    if h is None:
        h = _initial_step(fun, t0, y, f0, direction, rtol, atol, 5)
        nfev += 1
    h = min(abs(h), abs(tf - t0))
    size = y.size
    K, Ks, Wh, Yb, Ybs = stage_buffers(_DP_W, 7, y, f0)      # K = [k₀ … k₆]
    stages = [(Wh[i, :i], K[:i], Yb[i], Ybs[i], float(_DP_C[i])) for i in range(1, 6)]
    cb, ce, K6 = Wh[7, :6], Wh[8], K[:6]
    step5 = _step5
    ts, Ys, ie = start_output(t0, y, t_eval)
    g_old = [float(e.fn(t0, y)) for e in evs]
    t = t0
    status, message = 0, OK_MESSAGE
    nacc = nrej = 0
    last_rejected = False
    nonfinite_at = None  # time of the last step rejected because a stage or the error estimate was not finite
    yf = y.ravel()
    ay0, sc = np.abs(yf), np.empty(size)
    start = time.perf_counter()
    with np.errstate(over="ignore", invalid="ignore", divide="ignore"):
        while (tf - t) * direction > 0:
            failure = step_failure(nacc, nrej, max_steps, t, tf, h, nonfinite_at,
                                   "the solution may blow up or the problem is stiff: try an implicit method or scipy:Radau")
            if failure:
                status, message = -1, failure
                break
            if (t + direction * h - tf) * direction > 0:
                h = abs(tf - t)
            hd = direction * h
            np.multiply(_DP_W, hd, out=Wh)
            i = 1
            for row, Ki, yi, yarg, c in stages:           # stage points 1 … 5, each one dot into its buffer
                row.dot(Ki, out=yi)
                Ks[i] = fun(t + c * hd, np.add(yi, yf).reshape(shape))     # a fresh array: fun may keep it
                i += 1
            y1f = cb.dot(K6)  # FSAL: the 7th stage point is the fifth-order solution
            y1f += yf
            Ks[6] = fun(t + hd, y1f.reshape(shape))
            nfev += 6
            ay1 = np.abs(y1f)
            np.maximum(ay0, ay1, out=sc)
            sc *= rtol
            sc += atol
            ee = ce.dot(K)
            ee /= sc
            if batch:
                err = float(np.sqrt(np.max(np.mean((ee.reshape(shape)) ** 2, axis=1))))
            else:
                e2 = float(ee.dot(ee)) / size
                err = math.sqrt(e2) if e2 >= 0 else e2              # NaN stays NaN
            if not err <= 1.0:  # also catches NaN: reject and shrink
                if not math.isfinite(err):
                    fac, nonfinite_at = 0.2, t
                else:
                    fac, nonfinite_at = max(0.2, 0.9 * err ** -0.2), None
                h *= fac
                nrej += 1
                last_rejected = True
                continue
            t1 = step_end(t, hd, tf, direction)
            y1 = y1f.reshape(shape)
            nacc += 1
            stop = None
            if evs or t_eval is not None:
                partial = lambda s, t=t, y=yf.reshape(shape): step5(fun, t, y, s)  # noqa: E731
                if evs:
                    found = crossings(evs, g_old, t, yf.reshape(shape), t1, y1, hd, partial)
                    stop = handle_events(evs, found) if found else None
                    if stop is not None:
                        t1, y1 = stop
                    g_old = [float(e.fn(t1, y1)) for e in evs]
                if t_eval is not None:
                    while ie < len(t_eval) and (t_eval[ie] - t1) * direction <= 0:
                        te = t_eval[ie]
                        ts.append(te), Ys.append(y1.copy() if te == t1 else partial(te - t))
                        nfev += 0 if te == t1 else 7
                        ie += 1
            if t_eval is None:
                ts.append(t1), Ys.append(y1)
            t = t1
            if stop is not None:
                status, message = 1, TERMINATED
                break
            yf, ay0 = y1f, ay1
            K[0] = K[6]
            fac = 10.0 if err == 0 else min(10.0, max(0.2, 0.9 * err ** -0.2))
            if last_rejected:
                fac = min(1.0, fac)
            last_rejected = False
            h *= fac
    wall = time.perf_counter() - start
    Y = np.array(Ys) if Ys else np.empty((0,) + shape)
    return make_result(ts, Y, nfev, 0, status, message, wall, m.name, evs, nacc, nrej)


# ---------------------------------------------------------------------------------------------------
# the high-order pairs: one lean loop, PI control, dense output
# ---------------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class Pair:
    """An embedded pair as data: tableau, error weights (rows of ``E``), controller, continuous extension.

    ``a_extra``/``c_extra`` are the stages after the method's own: the first is f(t + h, y₁) (the first
    stage of the next step), the rest feed only the dense output ``dense(y0, y1, K, h) -> F`` evaluated
    by ``evaluate(y0, F, θ)``. ``combine`` (DOP853) mixes the order-5 and order-3 estimates.
    """

    tableau: Tableau
    E: np.ndarray
    controller: Controller
    a_extra: np.ndarray
    c_extra: np.ndarray
    dense: Callable
    evaluate: Callable
    combine: bool = False


PAIRS = {
    "dop853": Pair(DOP853, np.stack([DOP853_E5, DOP853_E3]), Controller.pi(8.0, fac_min=0.333, fac_max=6.0),
                   DOP853_A_EXTRA, DOP853_C_EXTRA, dop853_dense, dop853_eval, combine=True),
    "vern7": Pair(VERN7, VERN7.E[None, :], Controller.pi(7.0, fac_min=0.333, fac_max=6.0),
                  VERN7_A_EXTRA, VERN7_C_EXTRA, vern7_dense, vern7_eval),
}


def stage_buffers(W, s, y, f0, extra=0):
    """Preallocated storage of an explicit pair, so that every stage sum is one ``np.dot`` into a buffer.

    K ((s + extra, size)) holds the stages k₀, k₁, … (K[0] = f0); Wh (W's shape) is refilled with h·W once
    per step (``np.multiply(W, h, out=Wh)``), so h Σⱼ<ᵢ aᵢⱼkⱼ = Wh[i, :i]·K[:i]; the rows of W after the
    s stage rows are b and the error weights. Y ((s, size)) receives the stage points y₀ + h Σⱼ aᵢⱼkⱼ
    (the increment first, then y₀: the summation order of the readable loop). Returns
    (K, Ks, Wh, Y, Ys): Ks and Ys are K and Y shaped like y (views: fun sees (n,) or (K, n)).
    """
    shape, size = y.shape, y.size
    dtype = np.result_type(y, f0, float)
    K = np.empty((s + extra, size), dtype)
    K[0] = f0.ravel()
    Y = np.empty((s, size), dtype)
    return K, K.reshape((len(K),) + shape), np.empty(W.shape), Y, Y.reshape((s,) + shape)


def solve_pair(fun, t0, tf, y, f0, m, h, rtol, atol, t_eval, evs, max_steps, split, jac=None) -> SimResult:
    """Run a high-order pair of :data:`PAIRS` with PI control from (t0, y) to tf (validated by ``solve``)."""
    check_real(m.name, y, f0)
    pair = PAIRS[m.name]
    tab, ctrl = pair.tableau, pair.controller
    s, n_extra = tab.stages, len(pair.c_extra)
    direction = 1.0 if tf > t0 else -1.0
    shape, batch, size = y.shape, y.ndim == 2, y.size
    nfev = [1]
    if h is None:
        h = initial_step(fun, t0, y, f0, direction, rtol, atol, tab.embedded_order)
        nfev[0] += 1
    h = min(abs(h), abs(tf - t0))
    E, combine, nE = pair.E, pair.combine, len(pair.E)
    W = np.vstack([tab.A, tab.B, E])
    K, Ks, Wh, Yb, Ybs = stage_buffers(W, s, y, f0, n_extra)   # K: every stage, dense-output ones included
    rowsXi = [(Wh[i, :i], K[:i], Yb[i], Ybs[i], float(tab.C[i])) for i in range(1, s)]
    cb, ce, Kall = Wh[s], Wh[s + 1:], K[:s]
    A_x, C_x = pair.a_extra, pair.c_extra
    ts, Ys, ie = start_output(t0, y, t_eval)
    g_old = [float(e.fn(t0, y)) for e in evs]
    t, yf = t0, y.ravel().copy()
    ay0, sc = np.abs(yf), np.empty(size)
    status, message = 0, OK_MESSAGE
    nacc = nrej = 0
    rejected, err_prev, nonfinite_at = False, 1.0, None
    unflat = (lambda v: v.reshape(shape)) if batch else (lambda v: v)  # noqa: E731
    mul, sqrt, factor = np.multiply, math.sqrt, ctrl.factor   # products as ndarray.dot: no dispatch layer
    start = time.perf_counter()
    with np.errstate(over="ignore", invalid="ignore", divide="ignore"):
        while (tf - t) * direction > 0:
            if nacc + nrej >= max_steps or h < EPS10 * abs(t) or h < 1e-300:
                status, message = -1, step_failure(nacc, nrej, max_steps, t, tf, h, nonfinite_at,
                                                   "the solution may blow up or the problem is stiff: try "
                                                   "method='radau5' or 'rodas4'")
                break
            if (t + direction * h - tf) * direction > 0:
                h = abs(tf - t)
            hd = direction * h
            mul(W, hd, out=Wh)
            i = 1
            for row, Ki, yi, yarg, c in rowsXi:            # stage i: yᵢ = y₀ + h Σⱼ<ᵢ aᵢⱼkⱼ, kᵢ = f(t + cᵢh, yᵢ)
                row.dot(Ki, out=yi)
                Ks[i] = fun(t + c * hd, np.add(yi, yf).reshape(shape))     # a fresh array: fun may keep it
                i += 1
            nfev[0] += s - 1
            y1f = cb.dot(Kall)
            y1f += yf
            ay1 = np.abs(y1f)
            np.maximum(ay0, ay1, out=sc)
            sc *= rtol
            sc += atol
            ee = ce.dot(Kall)
            ee /= sc
            if batch:
                sq = np.mean(ee.reshape(nE, shape[0], shape[1]) ** 2, axis=2)   # (estimates, K)
                err = sq[0] / np.sqrt(sq[0] + 0.01 * sq[1]) if combine else np.sqrt(sq[0])
                err = float(np.max(err))
            else:
                e0 = ee[0]
                s0 = float(e0.dot(e0)) / size
                if combine and s0 > 0:
                    e1 = ee[1]
                    err = s0 / sqrt(s0 + 0.01 * float(e1.dot(e1)) / size)
                else:
                    err = sqrt(s0) if s0 >= 0 else s0          # NaN stays NaN
            if not err <= 1.0:                                  # also NaN: reject and shrink
                nonfinite_at = None if math.isfinite(err) else t
                h *= factor(err, err_prev, True)
                nrej += 1
                rejected = True
                continue
            t1 = step_end(t, hd, tf, direction)
            y1 = unflat(y1f)
            nacc += 1
            Ks[s] = fun(t1, y1)                                 # f(t + h, y₁): the next step's first stage
            nfev[0] += 1
            stop = False
            if evs or t_eval is not None:
                dense = _dense_output(fun, pair, K, s, t, yf, y1f, hd, unflat, A_x, C_x, nfev)
                stop, t1, y1, g_old, ie = emit_step(evs, g_old, t, unflat(yf), t1, y1, hd, dense, t_eval, ie,
                                                    ts, Ys, direction)
            else:
                ts.append(t1), Ys.append(y1)
            t = t1
            if stop:
                status, message = 1, TERMINATED
                break
            yf, ay0 = y1f, ay1
            K[0] = K[s]
            h *= factor(err, err_prev, rejected)
            err_prev, rejected = max(err, 1e-4), False
    wall = time.perf_counter() - start
    Y = np.array(Ys) if Ys else np.empty((0,) + shape)
    return make_result(ts, Y, nfev[0], 0, status, message, wall, m.name, evs, nacc, nrej)


def _dense_output(fun, pair, K, s, t, yf, y1f, hd, unflat, A_x, C_x, nfev):
    """The continuous extension of one accepted step, its extra stages evaluated on first use."""
    coef = []

    def at(sv):
        if not coef:
            for r in range(1, len(C_x)):
                i = s + r
                K[i] = fun(t + C_x[r] * hd, unflat(yf + np.dot(A_x[r, :i] * hd, K[:i]))).ravel()
            nfev[0] += len(C_x) - 1
            coef.append(pair.dense(yf, y1f, K.copy(), hd))
        return unflat(pair.evaluate(yf, coef[0], sv / hd))

    return at
