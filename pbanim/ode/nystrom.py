"""Runge–Kutta–Nyström methods (``dprkn6``, ``dprkn8``, ``dprkn12``): fixed steps and the adaptive loop.

Which problems
--------------
y = [q, v] with ``split`` = n/2 position components and a right-hand side of the mechanical form

    f(t, [q, v]) = [v, g(t, q)]:    q̇ = v,   v̇ = g(t, q)   (no dependence on v),

the form of every conservative particle system of the course (springs, gravity, n-body). The methods
use f as it is — the same function, evaluated once per stage, as every other method — and read only
its acceleration half; the velocity it is handed at a stage is the step's v₀ (g ignores it). Before
the first step the loop checks both assumptions on y₀ (q̇ = v to roundoff, and g unchanged when v is
perturbed: one extra evaluation of f) and refuses another problem by name, since a Nyström method
would silently answer a damped or rotating system wrong.

Why (what accuracy costs)
-------------------------
The position part of a Nyström stage is integrated twice, so it needs one order condition per tree of
the second-order theory only: DPRKN12 is of order 12 with 17 evaluations per step, DPRKN8 of order 8
with 8 (FSAL), DPRKN6 of order 6 with 5. On Kepler and the Pleiades this halves the evaluations of f
that DOP853 needs at 10⁻⁸ and below (``pbanim bench ode``).

The adaptive loop
-----------------
err = RMS([ê_q, ê_v] / (atol + rtol·max(|y₀|, |y₁|))) with the pair's embedded estimates
(:mod:`pbanim.ode.nystrom_tables`); Gustafsson's predictive step-size controller with k = p̂ + 1
(:meth:`pbanim.ode.control.Controller.predictive`: the error's growth from one accepted step to the next
shortens the step into a close encounter before it is rejected); the step cap and the underflow check
of every adaptive loop. Each stage is one matrix–vector product (see :func:`solve_nystrom`). ``t_eval`` and events
use the quintic Hermite interpolant through (q, v, g) at both ends of a step,

    q(t + θh) = H₀q₀ + H₁hv₀ + H₂h²g₀ + H₃q₁ + H₄hv₁ + H₅h²g₁,   v = dq/dt,

exact for quintic motion: a local error O(h⁶) in q and O(h⁵) in v, below the method's order (good for
plots and event location; for t_eval points at full accuracy, end the run there). It needs no extra
evaluation: g₁ is the next step's first stage.

Notation: as in :mod:`pbanim.ode.nystrom_tables`; θ = (t* − t)/h.

Reference: Hairer, Nørsett & Wanner, *Solving ODEs I*, §II.14 (Nyström methods, their order conditions
and the Pleiades comparison).
"""

from __future__ import annotations

import math
import time

import numpy as np

from .control import EPS10, Controller, check_real, emit_step, initial_step, step_end, step_failure
from .events import OK_MESSAGE, TERMINATED, make_result, start_output
from .nystrom_tables import NYSTROM, NystromPair
from ..errors import InvalidInput

__all__ = ["nystrom_step", "solve_nystrom", "hermite5", "check_nystrom_problem", "coefficient_stack", "NYSTROM",
           "dprkn6_step", "dprkn8_step", "dprkn12_step"]

# Gustafsson's predictive controller (Controller.predictive): on Kepler and the Pleiades, where the error grows
# steeply into every close encounter, it needs 5–25 % fewer evaluations of f than the I controller at equal error
# (26 of 28 problem/pair/level points; within 1 % at the other two), and fewer than the PI controller; rejected
# steps are 10–30 % of the accepted ones, against 14–43 % with the I controller
_CTRL = {name: Controller(p.embedded_order + 1.0, 1.0 / (p.embedded_order + 1.0), 0.0, fac_min=0.333, fac_max=6.0)
         for name, p in NYSTROM.items()}


def _positions(y: np.ndarray, split: int | None, name: str) -> int:
    n = y.shape[-1]
    d = n // 2 if split is None else int(split)
    if y.ndim != 1:
        raise InvalidInput(f"method {name!r} integrates one trajectory (y0 of shape (n,)), got shape {y.shape}")
    if n % 2 or 2 * d != n:
        raise InvalidInput(f"method {name!r} needs y = [q, v] with as many velocities as positions (split = n/2), "
                           f"got n = {n}, split = {split}")
    return d


def nystrom_step(pair: NystromPair | str, fun, t: float, y: np.ndarray, h: float, split: int | None = None,
                 jac=None) -> np.ndarray:
    """One Nyström step, the readable loop over the stages (the adaptive loop is tested against it).

    A fixed-step run (``solve(..., h=...)`` of a scene, ``Method.step``) has no start-up to check the
    problem's form in, so every step checks it (:func:`check_nystrom_problem`: one extra evaluation of f)
    and refuses a damped or non-mechanical right-hand side by name instead of answering it wrong.

    >>> f = lambda t, y: np.array([y[1], -9.81])          # free fall: exact for every Nyström pair
    >>> y1 = nystrom_step("dprkn8", f, 0.0, np.array([10.0, 0.0]), 1.0)
    >>> bool(np.allclose(y1, [10.0 - 9.81 / 2, -9.81], rtol=1e-15))
    True
    """
    p = NYSTROM[pair] if isinstance(pair, str) else pair
    y = np.asarray(y, dtype=float)
    d = _positions(y, split, p.name)
    q, v = y[:d], y[d:]
    f0 = np.asarray(fun(t, y), dtype=float)
    check_nystrom_problem(fun, t, y, f0, d, p.name)
    G = [f0[d:]]                                      # stage 0: Q₀ = q (c₀ = 0)
    for i in range(1, p.stages):
        Q = q + p.C[i] * h * v
        for j in range(i):
            Q = Q + h * h * p.A[i, j] * G[j]
        G.append(np.asarray(fun(t + p.C[i] * h, np.concatenate([Q, v])), dtype=float)[d:])
    q1, v1 = q + h * v, v.copy()
    for i in range(p.stages):
        q1 = q1 + h * h * p.B[i] * G[i]
        v1 = v1 + h * p.BP[i] * G[i]
    return np.concatenate([q1, v1])


def _step_fn(name):
    def step(fun, t, y, h, split=None, jac=None):
        return nystrom_step(NYSTROM[name], fun, t, y, h, split)
    step.__name__ = f"{name}_step"
    step.__doc__ = f"One fixed step of the Nyström pair {name!r} (order {NYSTROM[name].order}; adaptive: ``solve``)."
    return step


dprkn6_step, dprkn8_step, dprkn12_step = (_step_fn(k) for k in ("dprkn6", "dprkn8", "dprkn12"))


def check_nystrom_problem(fun, t0: float, y: np.ndarray, f0: np.ndarray, d: int, name: str) -> int:
    """Refuse a right-hand side that is not [v, g(t, q)] at y₀ (see the module docstring); returns the one
    evaluation of f it spends."""
    q, v = y[:d], y[d:]
    if not (np.abs(f0[:d] - v) <= 1e-13 * np.abs(v) + 1e-300).all():
        raise InvalidInput(f"method {name!r} needs f(t, [q, v])[:split] = v (a mechanical system q̇ = v), but at "
                           f"t0 it differs from v by up to {float(np.max(np.abs(f0[:d] - v))):.3g}; use dop853")
    dv = 1e-3 * (1.0 + np.abs(v))
    g1 = np.asarray(fun(t0, np.concatenate([q, v + dv])), dtype=float)[d:]
    change = float(np.max(np.abs(g1 - f0[d:]))) if d else 0.0
    if not change <= 1e-12 * max(1.0, float(np.max(np.abs(f0[d:])))):
        raise InvalidInput(f"method {name!r} needs an acceleration that does not depend on the velocity, but "
                           f"perturbing v by 1e-3(1 + |v|) changed f(t0, y0)[split:] by {change:.3g} (damping, "
                           "gyroscopic or velocity-dependent forces); use dop853")
    return 1


def hermite5(q0, v0, g0, q1, v1, g1, h: float, theta: float) -> tuple[np.ndarray, np.ndarray]:
    """(q, v) at t + θh on the quintic through (q, v, g) at both ends of a step of size h."""
    s = theta
    s2, s3 = s * s, s * s * s
    s4, s5 = s3 * s, s3 * s2
    H = (1 - 10 * s3 + 15 * s4 - 6 * s5, s - 6 * s3 + 8 * s4 - 3 * s5, 0.5 * (s2 - 3 * s3 + 3 * s4 - s5),
         10 * s3 - 15 * s4 + 6 * s5, -4 * s3 + 7 * s4 - 3 * s5, 0.5 * (s3 - 2 * s4 + s5))
    D = (-30 * s2 + 60 * s3 - 30 * s4, 1 - 18 * s2 + 32 * s3 - 15 * s4, 0.5 * (2 * s - 9 * s2 + 12 * s3 - 5 * s4),
         30 * s2 - 60 * s3 + 30 * s4, -12 * s2 + 28 * s3 - 15 * s4, 0.5 * (3 * s2 - 8 * s3 + 5 * s4))
    terms = (q0, h * v0, h * h * g0, q1, h * v1, h * h * g1)
    q = sum(c * x for c, x in zip(H, terms))
    v = sum(c * x for c, x in zip(D, terms)) / h
    return q, v


def coefficient_stack(p: NystromPair) -> np.ndarray:
    """(3, s + 3, s + 2) matrices T₀, T₁, T₂ with M(h) = T₀ + hT₁ + h²T₂ the rows of one step (see
    :func:`solve_nystrom`): stage i (rows 0 … s − 2) [1, cᵢh, h²aᵢ₀ …], then q₁ [1, h, h²b̄], ê_q [0, 0, h²ẽ̄],
    v₁ [0, 1, hb], ê_v [0, 0, hẽ]."""
    s = p.stages
    T = np.zeros((3, s + 3, s + 2))
    T[0, :s - 1, 0] = 1.0
    T[1, :s - 1, 1] = p.C[1:]
    T[2, :s - 1, 2:] = p.A[1:]
    r = s - 1
    T[0, r, 0], T[1, r, 1], T[2, r, 2:] = 1.0, 1.0, p.B
    T[2, r + 1, 2:] = p.EB
    T[0, r + 2, 1], T[1, r + 2, 2:] = 1.0, p.BP
    T[1, r + 3, 2:] = p.EBP
    return T


_STACKS = {name: coefficient_stack(p) for name, p in NYSTROM.items()}


def solve_nystrom(fun, t0, tf, y, f0, m, h, rtol, atol, t_eval, evs, max_steps, split, jac=None):
    """Run the Nyström pair ``m.name`` with error control from (t0, y) to tf (validated by ``solve``).

    One contiguous window W of shape (s + 2, 2d) with rows [q, v], [v, 0], [G₀, 0], [G₁, 0], …: the stage
    state [Qᵢ, v] = [q, v] + cᵢh [v, 0] + h² Σⱼ aᵢⱼ[Gⱼ, 0] is one matrix–vector product (a fresh array for
    fun), and the four sums of a step end (q₁, ê_q, v₁, ê_v) are one matrix product. Every coefficient of
    a step is one product too: M(h) = [1, h, h²] · (T₀, T₁, T₂) (:func:`coefficient_stack`).
    """
    check_real(m.name, y, f0)
    p, ctrl = NYSTROM[m.name], _CTRL[m.name]
    d = _positions(y, split, m.name)
    nfev = 1 + check_nystrom_problem(fun, t0, y, f0, d, m.name)
    s, n = p.stages, y.size
    direction = 1.0 if tf > t0 else -1.0
    if h is None:
        h = initial_step(fun, t0, y, f0, direction, rtol, atol, p.embedded_order)
        nfev += 1
    h = min(abs(h), abs(tf - t0))
    win = np.zeros((s + 2, 2 * d))               # [q, v], [v, 0], [Gⱼ, 0]
    Gs, v_row = win[2:, :d], win[1, :d]
    Gs[0] = f0[d:]
    T = _STACKS[m.name]
    T2 = T.reshape(3, -1)
    M = np.empty(T.shape[1:])
    Mflat, hv = M.reshape(-1), np.ones(3)
    stages = [(M[i - 1, :i + 2], win[:i + 2], Gs[i], float(p.C[i])) for i in range(1, s)]
    E_rows = M[s - 1:]
    iy = np.concatenate([np.arange(d), 4 * d + np.arange(d)])        # q₁ and v₁ in the flat (4, 2d) result
    ie_ = np.concatenate([2 * d + np.arange(d), 6 * d + np.arange(d)])  # ê_q and ê_v
    ts, Ys, ie = start_output(t0, y, t_eval)
    g_old = [float(e.fn(t0, y)) for e in evs]
    t, yf = t0, y.copy()
    ay0, sc = np.abs(yf), np.empty(n)
    status, message = 0, OK_MESSAGE
    nacc = nrej = 0
    rejected, nonfinite_at = False, None
    h_acc = err_acc = None                        # the last accepted step and its error (predictive control)
    mul, add, sqrt, factor = np.multiply, np.add, math.sqrt, ctrl.factor   # (ndarray.dot: no dispatch layer)
    predict = ctrl.predictive
    start = time.perf_counter()
    with np.errstate(over="ignore", invalid="ignore", divide="ignore"):
        while (tf - t) * direction > 0:
            if nacc + nrej >= max_steps or h < EPS10 * abs(t) or h < 1e-300:
                status, message = -1, step_failure(nacc, nrej, max_steps, t, tf, h, nonfinite_at,
                                                   "the solution may blow up or the problem is stiff: try "
                                                   "method='radau5'")
                break
            if (t + direction * h - tf) * direction > 0:
                h = abs(tf - t)
            hd = direction * h
            hv[1], hv[2] = hd, hd * hd
            hv.dot(T2, out=Mflat)                     # this step's coefficients
            win[0] = yf
            v_row[:] = yf[d:]
            for row, Wi, Gi, c in stages:             # [Qᵢ, v] = window · row, Gᵢ = g(t + cᵢh, Qᵢ)
                Gi[:] = fun(t + c * hd, row.dot(Wi))[d:]
            nfev += s - 1
            S = E_rows.dot(win).ravel()
            y1f = S[iy]
            ay1 = np.abs(y1f)
            np.maximum(ay0, ay1, out=sc)
            mul(sc, rtol, out=sc)
            add(sc, atol, out=sc)
            ee = S[ie_]
            ee /= sc
            s0 = float(ee.dot(ee)) / n
            err = sqrt(s0) if s0 >= 0 else s0        # NaN stays NaN
            if not err <= 1.0:                        # also NaN: reject and shrink
                nonfinite_at = None if math.isfinite(err) else t
                h *= factor(err, 1.0, True)
                nrej += 1
                rejected = True
                continue
            t1 = step_end(t, hd, tf, direction)
            nacc += 1
            if p.fsal:
                g1 = Gs[s - 1]                        # g(t + h, q₁): a view, copied into Gs[0] below
            else:
                g1 = fun(t1, y1f)[d:]                  # y1f is never written again: fun may keep it
                nfev += 1
            stop = False
            if evs or t_eval is not None:
                g0, g1 = Gs[0].copy(), np.array(g1, copy=True)

                def dense(sv, y0f=yf, g0=g0, g1=g1, y1=y1f, hd=hd):
                    qq, vv = hermite5(y0f[:d], y0f[d:], g0, y1[:d], y1[d:], g1, hd, sv / hd)
                    return np.concatenate((qq, vv))

                stop, t1, y1f, g_old, ie = emit_step(evs, g_old, t, yf, t1, y1f, hd, dense, t_eval, ie, ts, Ys,
                                                     direction)
            else:
                ts.append(t1), Ys.append(y1f)
            t = t1
            if stop:
                status, message = 1, TERMINATED
                break
            yf, ay0 = y1f, ay1
            Gs[0] = g1
            fac = predict(err, err_acc, h / h_acc if h_acc else 1.0, rejected)
            h_acc, err_acc = h, max(err, 1e-10)
            h *= fac
            rejected = False
    wall = time.perf_counter() - start
    Y = np.array(Ys) if Ys else np.empty((0, n))
    return make_result(ts, Y, nfev, 0, status, message, wall, m.name, evs, nacc, nrej)
