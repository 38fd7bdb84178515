"""The adaptive Dormand–Prince 5(4) loop of :func:`pbanim.solve` (method ``"dopri5"``).

Error control (Hairer, Nørsett & Wanner, *Solving ODEs I*, §II.4): the embedded fourth-order formula gives
err = ‖h Σ eᵢkᵢ / (atol + rtol·max(|y₀|, |y₁|))‖_RMS (in batch mode the worst trajectory's); a step is
accepted iff err ≤ 1 and the next one is h·min(10, max(0.2, 0.9·err^(−1/5))) (no growth right after a
rejection). The first stage of a step is the last of the previous one (FSAL). A step below 10ε|t| is a
step-size underflow: the run returns status −1 with a message instead of hanging; so does ``max_steps``.
Same controller as scipy's RK45, hence the same steps (a test checks it).
"""

from __future__ import annotations

import time

import numpy as np

from .events import OK_MESSAGE, TERMINATED, crossings, handle_events, make_result, start_output
from .methods import TABLEAUX, _RK_STEPS
from ..results import SimResult

__all__ = ["solve_adaptive"]

_DP = TABLEAUX["dopri5"]
_DP_ROWS = [_DP.A[i, :i].copy() for i in range(7)]
_DP_C = _DP.C
_DP_E = _DP.E


def _initial_step(fun, t0, y, f0, direction, rtol, atol, order=5):
    """Starting step from the sizes of y, f and a difference quotient of f (Hairer–Nørsett–Wanner I, §II.4)."""
    sc = atol + rtol * np.abs(y)
    d0 = np.sqrt(np.mean((y / sc) ** 2))
    d1 = np.sqrt(np.mean((f0 / sc) ** 2))
    h0 = 1e-6 if d0 < 1e-5 or d1 < 1e-5 else 0.01 * d0 / d1
    f1 = fun(t0 + direction * h0, y + direction * h0 * f0)
    d2 = np.sqrt(np.mean(((f1 - f0) / sc) ** 2)) / h0
    h1 = max(1e-6, h0 * 1e-3) if max(d1, d2) <= 1e-15 else (0.01 / max(d1, d2)) ** (1.0 / (order + 1))
    return min(100 * h0, h1)


def solve_adaptive(fun, t0, tf, y, f0, m, h, rtol, atol, t_eval, evs, max_steps, split) -> SimResult:
    """Run Dormand–Prince 5(4) with error control from (t0, y) to tf (arguments validated by ``solve``)."""
    direction = 1.0 if tf > t0 else -1.0
    shape = y.shape
    batch = y.ndim == 2
    nfev = 1
    if h is None:
        h = _initial_step(fun, t0, y, f0, direction, rtol, atol)
        nfev += 1
    h = min(abs(h), abs(tf - t0))
    rows, C, E = _DP_ROWS, _DP_C, _DP_E
    size = y.size
    Kf = np.empty((7, size))
    Kf[0] = f0.ravel()
    step5 = _RK_STEPS["dopri5"]
    ts, Ys, ie = start_output(t0, y, t_eval)
    g_old = [float(e.fn(t0, y)) for e in evs]
    t = t0
    status, message = 0, OK_MESSAGE
    nacc = nrej = 0
    last_rejected = False
    nonfinite_at = None  # time of the last step rejected because a stage or the error estimate was not finite
    eps10 = 10 * np.finfo(float).eps
    yf = y.ravel()
    start = time.perf_counter()
    with np.errstate(over="ignore", invalid="ignore", divide="ignore"):
        while (tf - t) * direction > 0:
            if nacc + nrej >= max_steps:
                status, message = -1, (f"failed: max_steps = {max_steps} steps reached at t = {t:.6g} before "
                                       f"t_end = {tf:.6g}; raise max_steps or loosen rtol/atol")
                break
            if h < eps10 * max(abs(t), 1e-300) or h < 1e-300:
                cause = ("fun returned non-finite values (NaN or inf) for every trial step from t = "
                         f"{nonfinite_at:.6g}: the solution blows up there or fun is undefined at the stage "
                         "points" if nonfinite_at is not None else
                         "the solution may blow up or the problem is stiff: try an implicit method or scipy:Radau")
                status, message = -1, f"failed: step size underflow at t = {t:.6g} (h = {h:.3e} < 10ε|t|); {cause}"
                break
            if (t + direction * h - tf) * direction > 0:
                h = abs(tf - t)
            hd = direction * h
            for i in range(1, 7):
                yi = yf + np.dot(hd * rows[i][:i], Kf[:i])
                Kf[i] = fun(t + C[i] * hd, yi.reshape(shape)).ravel()
            y1f = yi  # FSAL: the 7th stage point is the fifth-order solution
            nfev += 6
            sc = atol + rtol * np.maximum(np.abs(yf), np.abs(y1f))
            ee = np.dot(hd * E, Kf) / sc
            if batch:
                err = float(np.sqrt(np.max(np.mean((ee.reshape(shape)) ** 2, axis=1))))
            else:
                err = float(np.sqrt(np.dot(ee, ee) / size))
            if not err <= 1.0:  # also catches NaN: reject and shrink
                if not np.isfinite(err):
                    fac, nonfinite_at = 0.2, t
                else:
                    fac, nonfinite_at = max(0.2, 0.9 * err ** -0.2), None
                h *= fac
                nrej += 1
                last_rejected = True
                continue
            t1 = t + hd
            if (t1 - tf) * direction > 0 or abs(t1 - tf) <= eps10 * abs(tf):
                t1 = tf
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
            yf = y1f
            Kf[0] = Kf[6]
            fac = 10.0 if err == 0 else min(10.0, max(0.2, 0.9 * err ** -0.2))
            if last_rejected:
                fac = min(1.0, fac)
            last_rejected = False
            h *= fac
    wall = time.perf_counter() - start
    Y = np.array(Ys) if Ys else np.empty((0,) + shape)
    return make_result(ts, Y, nfev, 0, status, message, wall, m.name, evs, nacc, nrej)
