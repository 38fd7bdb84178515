"""Rosenbrock methods: one Jacobian and one LU per step, no Newton iteration (method ``"rodas4"``).

A Rosenbrock method linearizes the implicit Runge–Kutta stages once per step. With J = ∂f/∂y(t₀, y₀),
the stage increments Uᵢ solve linear systems that all share one matrix (Hairer–Wanner's form):

    (1/(hγ) I − J) Uᵢ = f(t₀ + αᵢh, y₀ + Σⱼ<ᵢ aᵢⱼUⱼ) + Σⱼ<ᵢ (cᵢⱼ/h) Uⱼ + hγᵢ ∂f/∂t,     i = 1 … s,
    y₁ = y₀ + Σᵢ mᵢUᵢ,          local error estimate ê = Σᵢ eᵢUᵢ.

So a step costs s evaluations of f, one Jacobian and one factorization, whatever the stiffness, and
the order is exact only with the exact J (the method is not a W-method): J is evaluated anew at every
accepted step and reused only when a rejected step is retried from the same point (then only the
factorization is redone, for the new h).

The adaptive loop keeps U₁ … U₆ in one buffer and forms each stage point and each coupling sum as one
``np.dot`` into a reused buffer (fun must copy a y it keeps); ORACLES A13 checks it against
:func:`rodas4_step`.

RODAS4 (Hairer & Wanner): s = 6, order 4, embedded order 3, γ = 1/4, L-stable and stiffly accurate
(y₁ is the last stage, ê = U₆), so it keeps its order on the stiff limit of singular perturbation
problems (Van der Pol with μ = 1000, Robertson's kinetics) and damps the fast modes completely.
The continuous extension is the cubic Hermite interpolant through (y₀, f₀) and (y₁, f₁) (f₁ is the
next step's first stage, so it costs nothing): order 3, enough for ``t_eval`` and events.

Notation
--------
=========  ===================  ===========================================
symbol     code                 meaning
=========  ===================  ===========================================
γ          ``GAMMA``            diagonal coefficient; the shift is 1/(hγ)
αᵢ, γᵢ     ``ALPHA``, ``GSUM``  stage times; weights of ∂f/∂t
aᵢⱼ, cᵢⱼ   ``A``, ``CC``        stage arguments; coupling of the stages
mᵢ, eᵢ     ``M``, ``E``         solution and error weights
=========  ===================  ===========================================

Linear invariants (total momentum, ORACLES A7) are kept to roundoff only with the exact J: aᵀf = 0 for
all y gives aᵀJ = 0, hence aᵀUᵢ = 0; a forward-difference J has aᵀJ ~ ε|f|/δ ≈ 10⁻⁸|f| and leaks that
into every stage, so pass ``jac`` when such an invariant matters.

Limiting cases: J = 0 and cᵢⱼ = 0 would give an explicit Runge–Kutta method; on y' = λy with
hλ → −∞ the stability function R(hλ) → 0 (L-stable: a stiff spring's fast mode is removed in one step,
ORACLES A11).

References: Hairer & Wanner, *Solving ODEs II* (2nd ed. 1996), §IV.7 (Rosenbrock methods; RODAS, whose
published coefficients in the transformed variables Uᵢ are the ones above); Rosenbrock, "Some general implicit processes
for the numerical solution of differential equations", Comput. J. 5 (1963).
"""

from __future__ import annotations

import math
import time

import numpy as np

from .control import Controller, check_real, emit_step, initial_step, rms, step_end, step_failure
from .events import OK_MESSAGE, TERMINATED, make_result, start_output
from .implicit import factor, jacobian, stage_solver, time_derivative
from .signature import STEP, finite_step
from ..contracts import contract
from ..errors import InvalidInput
from ..results import SimResult

__all__ = ["rodas4_step", "solve_rosenbrock", "hermite", "GAMMA", "ALPHA", "GSUM", "A", "CC", "M", "E"]

GAMMA = 0.25
ALPHA = np.array([0.0, 0.386, 0.21, 0.63, 1.0, 1.0])
GSUM = np.array([0.25, -0.1043, 0.1035, -0.0362, 0.0, 0.0])
A = np.zeros((6, 6))
A[1, 0] = 1.544
A[2, :2] = [0.9466785280815826, 0.2557011698983284]
A[3, :3] = [3.314825187068521, 2.896124015972201, 0.9986419139977817]
A[4, :4] = [1.221224509226641, 6.019134481288629, 12.53708332932087, -0.687886036105895]
A[5, :5] = [1.221224509226641, 6.019134481288629, 12.53708332932087, -0.687886036105895, 1.0]
CC = np.zeros((6, 6))
CC[1, 0] = -5.6688
CC[2, :2] = [-2.430093356833875, -0.2063599157091915]
CC[3, :3] = [-0.1073529058151375, -9.594562251023355, -20.47028614809616]
CC[4, :4] = [7.496443313967647, -10.24680431464352, -33.99990352819905, 11.7089089320616]
CC[5, :5] = [8.083246795921522, -7.981132988064893, -31.52159432874371, 16.31930543123136, -6.058818238834054]
M = np.array([1.221224509226641, 6.019134481288629, 12.53708332932087, -0.687886036105895, 1.0, 1.0])
E = np.array([0.0, 0.0, 0.0, 0.0, 0.0, 1.0])


def _stages(fun, t, y, f, hd, solve, ft, U):
    """The six stage increments Uᵢ of one step into the preallocated U (5 new evaluations of f)."""
    lin = (lambda c, X: c @ X) if U.ndim == 2 else (lambda c, X: np.tensordot(c, X, axes=1))  # noqa: E731
    r = f if ft is None else f + (hd * GSUM[0]) * ft
    U[0] = solve(r)
    for i in range(1, 6):
        r = fun(t + ALPHA[i] * hd, y + lin(A[i, :i], U[:i])) + lin(CC[i, :i] / hd, U[:i])
        if ft is not None and GSUM[i] != 0.0:
            r = r + (hd * GSUM[i]) * ft
        U[i] = solve(r)
    return y + lin(M, U)


@contract(**STEP, returns=finite_step)
def rodas4_step(fun, t, y, h, split=None, jac=None):
    """One fixed RODAS4 step (order 4, L-stable) with J from ``jac`` or forward differences.

    Works on a batch y of shape (K, n) too (one factorization per trajectory).

    >>> y = rodas4_step(lambda t, y: -1e6 * y, 0.0, np.array([1.0]), 1.0)   # hλ = −10⁶: damped at once
    >>> bool(abs(y[0]) < 1e-5)
    True
    """
    y = np.asarray(y, dtype=float)
    f = fun(t, y)
    J = jacobian(fun, t, y, f, jac)
    with np.errstate(over="ignore", divide="ignore"):
        solve = stage_solver(1.0 / (h * GAMMA), J, t, h)
    ft = time_derivative(fun, t, y, f)
    return _stages(fun, t, y, f, h, solve, ft, np.empty((6,) + y.shape))


rodas4_step.nfev = 6


def hermite(y0, f0, y1, f1, h, theta):
    """Cubic Hermite interpolant through (y₀, f₀) at θ = 0 and (y₁, f₁) at θ = 1 (step h), at θ."""
    d = y1 - y0
    return y0 + theta * d + theta * (theta - 1.0) * ((1.0 - 2.0 * theta) * d + (theta - 1.0) * h * f0
                                                     + theta * h * f1)


def solve_rosenbrock(fun, t0, tf, y, f0, m, h, rtol, atol, t_eval, evs, max_steps, split, jac=None) -> SimResult:
    """Adaptive RODAS4 from (t0, y) to tf: PI control on ê = U₆, J per step, reused on rejection."""
    check_real(m.name, y, f0)
    if y.ndim != 1:
        raise InvalidInput(f"method {m.name!r} needs y0 of shape (n,); batch mode (K, n) runs with the "
                           "explicit methods (e.g. 'dop853') or a loop over the initial conditions")
    ctrl = Controller.pi(4.0, fac_min=0.2, fac_max=6.0)
    direction = 1.0 if tf > t0 else -1.0
    nfev, njev, nlu = 1, 0, 0
    if h is None:
        h = initial_step(fun, t0, y, f0, direction, rtol, atol, 3)
        nfev += 1
    h = min(abs(h), abs(tf - t0))
    n = y.size
    # U₁ … U₆ in one buffer: stage point i is y + A[i, :i]·U[:i], the coupling Σⱼ(cᵢⱼ/h)Uⱼ is CCh[i, :i]·U[:i]
    U, Yb, tmp, CCh = np.empty((6, n)), np.empty((6, n)), np.empty(n), np.empty((6, 6))
    stages = [(A[i, :i], U[:i], CCh[i, :i], Yb[i], float(ALPHA[i]), float(GSUM[i])) for i in range(1, 6)]
    ts, Ys, ie = start_output(t0, y, t_eval)
    g_old = [float(e.fn(t0, y)) for e in evs]
    t, f = t0, f0
    J, ft = jacobian(fun, t, y, f, jac), time_derivative(fun, t, y, f)
    njev += 1
    nfev += (n if jac is None else 0) + (ft is not None)
    status, message = 0, OK_MESSAGE
    nacc = nrej = 0
    rejected, err_prev, nonfinite_at = False, 1.0, None
    dot, factor_ = np.dot, ctrl.factor
    start = time.perf_counter()
    with np.errstate(over="ignore", invalid="ignore", divide="ignore"):
        while (tf - t) * direction > 0:
            failure = step_failure(nacc, nrej, max_steps, t, tf, h, nonfinite_at, "the solution may blow up")
            if failure:
                status, message = -1, failure
                break
            if (t + direction * h - tf) * direction > 0:
                h = abs(tf - t)
            hd = direction * h
            try:
                solve = factor(1.0 / (hd * GAMMA), J)
                nlu += 1
                U[0] = solve(f if ft is None else f + (hd * GSUM[0]) * ft)
                np.divide(CC, hd, out=CCh)
                i = 1
                for a_row, Ua, c_row, yi, alpha, gsum in stages:
                    dot(a_row, Ua, out=yi)
                    dot(c_row, Ua, out=tmp)
                    tmp += fun(t + alpha * hd, np.add(yi, y))      # a fresh array: fun may keep it
                    if ft is not None and gsum != 0.0:
                        tmp += (hd * gsum) * ft
                    U[i] = solve(tmp)
                    i += 1
                y1 = dot(M, U)
                y1 += y
                nfev += 5
                sc = np.maximum(np.abs(y), np.abs(y1))
                sc *= rtol
                sc += atol
                err = rms(U[5] / sc)
            except np.linalg.LinAlgError:
                err = np.inf
            if not err <= 1.0:
                nonfinite_at = None if math.isfinite(err) else t
                h *= factor_(err, err_prev, True)
                nrej += 1
                rejected = True
                continue
            t1 = step_end(t, hd, tf, direction)
            nacc += 1
            f1 = fun(t1, y1)
            nfev += 1
            stop = False
            if evs or t_eval is not None:
                dense = (lambda s, t=t, y=y, f=f, y1=y1, f1=f1, hd=hd:
                         hermite(y, f, y1, f1, hd, s / hd))
                stop, t1, y1, g_old, ie = emit_step(evs, g_old, t, y, t1, y1, hd, dense, t_eval, ie, ts, Ys,
                                                    direction)
            else:
                ts.append(t1), Ys.append(y1)
            t = t1
            if stop:
                status, message = 1, TERMINATED
                break
            y, f = y1, f1
            if (tf - t) * direction > 0:
                J, ft = jacobian(fun, t, y, f, jac), time_derivative(fun, t, y, f)
                njev += 1
                nfev += (n if jac is None else 0) + (ft is not None)
            h *= factor_(err, err_prev, rejected)
            err_prev, rejected = max(err, 1e-4), False
    wall = time.perf_counter() - start
    Y = np.array(Ys) if Ys else np.empty((0,) + y.shape)
    return make_result(ts, Y, nfev, njev, status, message, wall, m.name, evs, nacc, nrej, nlu)
