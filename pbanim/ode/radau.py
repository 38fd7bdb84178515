"""Radau IIA of order 5: the implicit collocation method for stiff problems (method ``"radau5"``).

Three collocation points c = ((4 − √6)/10, (4 + √6)/10, 1); the stage increments Zᵢ = Yᵢ − y₀ solve

    Z = h (A ⊗ I) F(Z),   Fᵢ = f(t₀ + cᵢh, y₀ + Zᵢ),        y₁ = y₀ + Z₃      (stiffly accurate).

Order 5, L-stable (R(z) → 0 as z → −∞), stage order 3. Simplified Newton with J frozen solves the
3n-dimensional system through the eigenvalues of A⁻¹: one real γ and a complex pair α ± iβ. With
W = (T⁻¹ ⊗ I)Z the Newton matrix becomes block diagonal, one real n × n system and one complex one,

    (γ/h I − J) ΔW₁ = r₁,     ((α − iβ)/h I − J)(ΔW₂ + iΔW₃) = r₂ + i r₃,

each factored once (:func:`pbanim.ode.implicit.factor`) and reused for every Newton iteration and for
later steps: J is re-evaluated only when Newton contracted slowly (rate θ > 10⁻³) or a step failed,
and h (hence the factorizations) is kept when the controller proposes a change within [1, 1.2].
Newton starts from the previous step's collocation polynomial, extrapolated.

For n ≤ 12 (dense J) the adaptive loop does not solve the two systems separately: the real 3n × 3n
matrix M = (Λ ⊗ I)/h − I₃ ⊗ J (:func:`block_inverse`, the complex system in real form) is inverted once
per (J, h), and with FW = [F; W] one Newton correction is the single product ΔW = [M⁻¹(T⁻¹ ⊗ I),
−M⁻¹(Λ/h ⊗ I)]·FW; the stage points y₀ + Zᵢ go to a reused buffer (fun must copy a y it keeps).

Error estimate (an embedded order-3 formula with a free weight γ₀ = 1/γ on f(t₀, y₀), filtered
through the real factorization so it stays bounded for stiff components):

    err = (γ/h I − J)⁻¹ (f(t₀, y₀) + (γ/h) Σᵢ eᵢ Zᵢ),   eᵢ from Σⱼ(Aᵀe)ⱼ cⱼᵏ = −γ₀·[k = 0], k = 0, 1, 2.

Step size: h_new = h·fac·err^(−1/4) with fac = 0.9·(2k_max + 1)/(2k_max + k) (fewer Newton iterations,
larger steps) and Gustafsson's predictive correction. Dense output: the collocation polynomial
y(t₀ + θh) = y₀ + Σₖ₌₁³ qₖθᵏ through (cᵢ, Zᵢ).

Notation
--------
=======  =============  ==============================================
symbol   code           meaning
=======  =============  ==============================================
A, c     ``A``, ``C``   Radau IIA coefficients (closed forms in √6)
T, Λ     ``T``, ``LAM``  A⁻¹ = T Λ T⁻¹, Λ = [[γ,0,0],[0,α,β],[0,−β,α]]
e        ``E``          error weights (derived here from the order conditions)
θ, η     ``rate, eta``  Newton contraction, η = θ/(1 − θ)
=======  =============  ==============================================

Limiting cases: J = 0 leaves fixed-point iteration of an implicit RK method; a linear f converges in
one Newton iteration (the exact J); hλ → −∞ gives y₁ → 0 (L-stable, ORACLES A11).

References: Hairer & Wanner, *Solving ODEs II*, §IV.5 (Radau IIA), §IV.8 (implementation: simplified
Newton, transformation to a real and a complex system, error estimate, step control — RADAU5);
Butcher, "On the implementation of implicit Runge–Kutta methods", BIT 16 (1976); Gustafsson,
"Control-theoretic techniques for stepsize selection in implicit Runge–Kutta methods", ACM TOMS 20 (1994).
"""

from __future__ import annotations

import math
import time

import numpy as np

from .control import check_real, emit_step, initial_step, rms, step_end, step_failure
from .events import OK_MESSAGE, TERMINATED, make_result, start_output
from .implicit import SMALL, factor, jacobian, stage_solver
from .signature import STEP, finite_step
from ..contracts import Int, Real, contract
from ..errors import ConvergenceError, InvalidInput, as_float, as_floats
from ..results import SimResult

__all__ = ["A", "C", "T", "TINV", "LAM", "E", "radau5_step", "solve_radau", "block_inverse"]

_S6 = np.sqrt(6.0)
C = np.array([(4 - _S6) / 10, (4 + _S6) / 10, 1.0])
A = np.array([[(88 - 7 * _S6) / 360, (296 - 169 * _S6) / 1800, (-2 + 3 * _S6) / 225],
              [(296 + 169 * _S6) / 1800, (88 + 7 * _S6) / 360, (-2 - 3 * _S6) / 225],
              [(16 - _S6) / 36, (16 + _S6) / 36, 1 / 9]])


def _transformation():
    """T with T⁻¹A⁻¹T = [[γ, 0, 0], [0, α, β], [0, −β, α]] (real Schur-like form of A⁻¹), from its eigenvectors."""
    Ainv = np.linalg.inv(A)
    w, V = np.linalg.eig(Ainv)
    r = int(np.argmin(np.abs(w.imag)))
    c = int(np.argmax(w.imag))
    T = np.column_stack([V[:, r].real, V[:, c].real, V[:, c].imag])
    Tinv = np.linalg.inv(T)
    return T, Tinv, Tinv @ Ainv @ T


T, TINV, LAM = _transformation()
_GAMMA, _ALPHA, _BETA = LAM[0, 0], LAM[1, 1], LAM[1, 2]
# the embedded weights: v = Aᵀe with Σv = −γ₀, Σvc = 0, Σvc² = 0 (γ₀ = 1/γ): the embedded formula has order 3
_V = np.linalg.solve(np.vstack([np.ones(3), C, C ** 2]), np.array([-1.0 / _GAMMA, 0.0, 0.0]))
E = np.linalg.solve(A.T, _V)
_VINV = np.linalg.inv(np.column_stack([C, C ** 2, C ** 3]))     # Z(cᵢ) = Σₖ qₖ cᵢᵏ  →  q = V⁻¹Z
_P123 = np.array([1.0, 2.0, 3.0])
_EPS = float(np.finfo(float).eps)
_maxred = np.maximum.reduce     # np.max without its Python wrapper (the same reduction)


def _solvers(hd, J):
    """The real and the complex solver of one step size: (γ/h I − J)⁻¹ and ((α − iβ)/h I − J)⁻¹."""
    return factor(_GAMMA / hd, J), factor(complex(_ALPHA, -_BETA) / hd, J)


def _lin(M, X):
    """M X over the stage axis: a matrix product for (3, n) stages, a tensordot for batches (3, K, n)."""
    return M @ X if X.ndim == 2 else np.tensordot(M, X, axes=1)


def _newton_update(F, W, hd, solve_r, solve_c):
    """One simplified-Newton correction ΔW from the stage derivatives F (3, …) and the current W."""
    G = _lin(TINV, F)
    r0 = G[0] - (_GAMMA / hd) * W[0]
    r1 = G[1] - (_ALPHA * W[1] + _BETA * W[2]) / hd
    r2 = G[2] - (_ALPHA * W[2] - _BETA * W[1]) / hd
    u = solve_c(r1 + 1j * r2)
    return np.stack([solve_r(r0), u.real, u.imag])


@contract(**STEP, returns=finite_step, tol=Real(gt=0), max_iter=Int(ge=1, le=10_000))
def radau5_step(fun, t, y, h, split=None, jac=None, tol=1e-13, max_iter=50):
    """One fixed Radau IIA(5) step: simplified Newton with J at (t, y) until ‖ΔZ‖∞ ≤ tol·(1 + ‖Z‖∞).

    Raises :class:`~pbanim.errors.ConvergenceError` when Newton does not converge in ``max_iter``.

    >>> y = radau5_step(lambda t, y: -y, 0.0, np.array([1.0]), 0.5)   # R(z) = Padé (2, 3) of e^z
    >>> float(abs(y[0] - np.exp(-0.5)))                                 # = |R(−0.5) − e^(−0.5)|
    1.2220914...e-06
    """
    y = np.asarray(y, dtype=float)
    f = fun(t, y)
    J = jacobian(fun, t, y, f, jac)
    with np.errstate(over="ignore", divide="ignore"):
        solve_r = stage_solver(_GAMMA / h, J, t, h)
        solve_c = stage_solver(complex(_ALPHA, -_BETA) / h, J, t, h)
    Z = np.zeros((3,) + y.shape)
    W = np.zeros_like(Z)
    F = np.empty_like(Z)
    res = np.inf
    for it in range(1, max_iter + 1):
        for i in range(3):
            F[i] = fun(t + C[i] * h, y + Z[i])
        dW = _newton_update(F, W, h, solve_r, solve_c)
        W += dW
        Z = _lin(T, W)
        res = float(_maxred(np.abs(_lin(T, dW)), axis=None)) / (1.0 + float(_maxred(np.abs(Z), axis=None)))
        if not np.isfinite(res):
            break
        if res <= tol:
            return y + Z[2]
    raise ConvergenceError("Newton (Radau IIA stages)", it, res, tol, f"at t = {t:.6g}, h = {h:.3g}; reduce the step h")


radau5_step.nfev = 9


def block_inverse(hd, J):
    """The inverse of the real 3n × 3n Newton matrix in W coordinates, block diagonal:

    diag(γ/h I − J, [[α/h I − J, β/h I], [−β/h I, α/h I − J]])   (the complex system written in real form).
    Its top-left block is (γ/h I − J)⁻¹, the solver of the error estimate. (The adaptive loop builds the
    same matrix as (Λ ⊗ I)/h − I₃ ⊗ J; a test checks that the two agree.)
    """
    hd = as_float("hd", hd)
    if not (math.isfinite(hd) and hd != 0.0):
        raise InvalidInput(f"hd must be a finite nonzero step, got {hd}")
    J = as_floats("J", J)
    if J.ndim != 2 or J.shape[0] != J.shape[1] or J.size == 0:
        raise InvalidInput(f"J must be a square (n, n) matrix, got shape {J.shape}")
    if not np.all(np.isfinite(J)):
        raise InvalidInput("J must be finite, got NaN or inf entries")
    n = J.shape[0]
    M = np.zeros((3 * n, 3 * n))
    i = np.arange(n)
    for b in range(3):
        M[b * n:(b + 1) * n, b * n:(b + 1) * n] = -J
    M[i, i] += _GAMMA / hd
    M[n + i, n + i] += _ALPHA / hd
    M[2 * n + i, 2 * n + i] += _ALPHA / hd
    M[n + i, 2 * n + i] = _BETA / hd
    M[2 * n + i, n + i] = -_BETA / hd
    return np.linalg.inv(M)


def solve_radau(fun, t0, tf, y, f0, m, h, rtol, atol, t_eval, evs, max_steps, split, jac=None) -> SimResult:
    """Adaptive Radau IIA(5) from (t0, y) to tf with Jacobian and factorization reuse (see the module).

    Small dense systems (n ≤ ``SMALL``) run one matrix–vector product per Newton iteration: with
    FW = [F; W] (flattened), ΔW = [P, −Q]·FW where P = M⁻¹(T⁻¹ ⊗ I), Q = M⁻¹(Λ/h ⊗ I) and M⁻¹ is
    :func:`block_inverse`; larger or sparse systems solve the real and the complex system separately.
    """
    check_real(m.name, y, f0)
    if y.ndim != 1:
        raise InvalidInput(f"method {m.name!r} needs y0 of shape (n,); batch mode (K, n) runs with the "
                           "explicit methods (e.g. 'dop853') or a loop over the initial conditions")
    direction = 1.0 if tf > t0 else -1.0
    n, max_iter, safety = y.size, 7, 0.9
    newton_tol = max(10 * _EPS / rtol, min(0.03, rtol ** 0.5))
    nfev, njev, nlu = 1, 0, 0
    if h is None:
        h = initial_step(fun, t0, y, f0, direction, rtol, atol, 3)
        nfev += 1
    h = min(abs(h), abs(tf - t0))
    ts, Ys, ie = start_output(t0, y, t_eval)
    g_old = [float(e.fn(t0, y)) for e in evs]
    t, f = t0, f0
    J = jacobian(fun, t, y, f, jac)
    njev, nfev = njev + 1, nfev + (n if jac is None else 0)
    small = isinstance(J, np.ndarray) and n <= SMALL
    fresh, solvers, h_lu = True, None, None
    Q = None                     # the last accepted step's collocation polynomial (for Newton's start)
    h_acc, err_acc, eta = None, None, 1.0
    status, message = 0, OK_MESSAGE
    nacc = nrej = 0
    rejected, first = False, True
    FW = np.zeros(6 * n)                         # [F₁ F₂ F₃ W₁ W₂ W₃], flattened
    F3, W3, Wf = FW[:3 * n].reshape(3, n), FW[3 * n:].reshape(3, n), FW[3 * n:]
    sc3 = np.empty((3, n))
    if small:                                   # M = (Λ ⊗ I)/h − I₃ ⊗ J is block_inverse's matrix (small n only:
        KLAM = np.kron(LAM, np.eye(n))          # dense 3n × 3n, 40 GB at n = 24 564)
        KTL = np.hstack([np.kron(TINV, np.eye(n)), -KLAM])
    KJ, J_kron = None, None
    c0, c1 = float(C[0]), float(C[1])
    dot, absolute, size3 = np.dot, np.abs, 3.0 * n
    start = time.perf_counter()
    with np.errstate(over="ignore", invalid="ignore", divide="ignore"):
        while (tf - t) * direction > 0:
            failure = step_failure(nacc, nrej, max_steps, t, tf, h, None,
                                   "Newton fails at every step size: the solution may blow up or jac may be wrong")
            if failure:
                status, message = -1, failure
                break
            if (t + direction * h - tf) * direction > 0:
                h = abs(tf - t)
            hd = direction * h
            if solvers is None or h_lu != hd:
                try:
                    if small:
                        if J_kron is not J:
                            KJ, J_kron = np.kron(np.eye(3), J), J
                        Minv = np.linalg.inv(KLAM * (1.0 / hd) - KJ)
                        PQ = dot(Minv, KTL)
                        PQ[:, 3 * n:] *= 1.0 / hd
                        solvers, h_lu = (Minv[:n, :n].copy().dot, None), hd
                    else:
                        solvers, h_lu = _solvers(hd, J), hd
                    nlu += 2
                except np.linalg.LinAlgError:
                    h, solvers, nrej = 0.5 * h, None, nrej + 1
                    continue
            solve_r, solve_c = solvers
            if Q is None:
                Z = np.zeros((3, n))
            else:                                 # the last collocation polynomial, extrapolated
                x = 1.0 + C * (hd / Q[1])
                Z = dot(x[:, None] ** _P123 - 1.0, Q[0])
            dot(TINV, Z, out=W3)
            ay = absolute(y)
            sc3[:] = atol + rtol * ay
            eta = max(eta, _EPS) ** 0.8
            converged, norm_old, rate, it = False, None, 0.0, 0
            for it in range(1, max_iter + 1):
                Yb = Z + y                   # fresh stage points each iteration: fun may keep them
                F3[0] = fun(t + c0 * hd, Yb[0])
                F3[1] = fun(t + c1 * hd, Yb[1])
                F3[2] = fun(t + hd, Yb[2])
                nfev += 3
                dW = PQ.dot(FW) if small else _newton_update(F3, W3, hd, solve_r, solve_c).ravel()
                q = dW.reshape(3, n) / sc3
                q = q.ravel()
                norm = math.sqrt(float(dot(q, q)) / size3)
                if not math.isfinite(norm):
                    break
                if norm_old is not None:
                    rate = norm / norm_old
                    if rate >= 1.0 or rate ** (max_iter - it) / (1.0 - rate) * norm > newton_tol:
                        break
                    eta = rate / (1.0 - rate)
                Wf += dW
                Z = dot(T, W3)
                if norm == 0.0 or eta * norm <= newton_tol:
                    converged = True
                    break
                norm_old = norm
            if not converged:                    # Newton failed: halve h, refresh J if it is old
                h *= 0.5
                Q, solvers, nrej, rejected = None, None, nrej + 1, True
                if not fresh:
                    J, fresh = jacobian(fun, t, y, f, jac), True
                    njev, nfev = njev + 1, nfev + (n if jac is None else 0)
                continue
            y1 = y + Z[2]
            ez = dot(E, Z)
            ez *= _GAMMA / hd
            err_vec = solve_r(f + ez)
            sc = np.maximum(ay, absolute(y1))
            sc *= rtol
            sc += atol
            err = rms(err_vec / sc)
            if err >= 1.0 and (first or rejected):        # a second, better filtered estimate
                err_vec = solve_r(fun(t, y + err_vec) + ez)
                nfev += 1
                err = rms(err_vec / sc)
            fac = min(safety, safety * (2 * max_iter + 1) / (2 * max_iter + it))
            factor_i = fac * err ** -0.25 if err > 0 else 8.0
            if not err < 1.0:                     # rejected (also NaN)
                h *= max(0.2, min(factor_i, 1.0)) if math.isfinite(err) else 0.2
                nrej, rejected = nrej + 1, True
                if not fresh:
                    J, fresh, solvers = jacobian(fun, t, y, f, jac), True, None
                    njev, nfev = njev + 1, nfev + (n if jac is None else 0)
                continue
            t1 = step_end(t, hd, tf, direction)
            nacc += 1
            q = dot(_VINV, Z)                    # collocation polynomial of this step
            stop = False
            if evs or t_eval is not None:
                dense = (lambda s, y=y, q=q, hd=hd: y + np.dot((s / hd) ** np.arange(1, 4), q))
                stop, t1, y1, g_old, ie = emit_step(evs, g_old, t, y, t1, y1, hd, dense, t_eval, ie, ts, Ys,
                                                    direction)
            else:
                ts.append(t1), Ys.append(y1)
            t = t1
            if stop:
                status, message = 1, TERMINATED
                break
            factor_new = min(8.0, max(0.2, factor_i))
            if h_acc is not None:                 # Gustafsson's predictive controller
                gus = min(8.0, max(0.2, safety * (h / h_acc) * (err_acc / max(err, 1e-12) ** 2) ** 0.25))
                factor_new = min(factor_new, gus)
            h_acc, err_acc = h, max(1e-2, err)
            y = y1
            f = fun(t, y)
            nfev += 1
            Q = (q, hd)
            if rejected:
                factor_new = min(1.0, factor_new)
            keep_h = 1.0 <= factor_new <= 1.2
            if rate > 1e-3 and (tf - t) * direction > 0:       # slow Newton: a new Jacobian
                J, fresh, solvers = jacobian(fun, t, y, f, jac), True, None
                njev, nfev = njev + 1, nfev + (n if jac is None else 0)
            else:
                fresh = False
            if not keep_h or solvers is None:
                h *= 1.0 if keep_h else factor_new
            rejected, first = False, False
    wall = time.perf_counter() - start
    Y = np.array(Ys) if Ys else np.empty((0,) + y.shape)
    return make_result(ts, Y, nfev, njev, status, message, wall, m.name, evs, nacc, nrej, nlu)
