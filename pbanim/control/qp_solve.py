"""The pieces of the control QP that are not tasks: contact rows and the call to a QP solver (chapter 08).

**Contact rows.** A contact point pⱼ on the ground must not accelerate: with the ground's normal n and
tangent t,

    n·(Jⱼ q̈ + J̇ⱼ q̇) = 0,     t·(Jⱼ q̈ + J̇ⱼ q̇) = 0.

A foot flat on the ground has two points (heel, toe) and so four rows, but only three degrees of
freedom: the rows are dependent. Their right-hand sides are consistent only to first order (a foot that
turns at ω has a_toe − a_heel = α × d − ω² d, and ω² d has a part along the foot that zero accelerations
at both points cannot absorb), so dependent rows are dropped rather than kept: QR with column pivoting
of J_cᵀ ranks the rows, and the first rank(J_c) of them are kept (:func:`contact_rows`). The forces stay
one (fₙ, fₜ) pair per point: the QP chooses how the load is shared.

**Priorities.** :func:`keep_level` adds a solved level's optimum to the equalities without making them
dependent (the rows already fixed are left out).

**The solver call.** :func:`solve_qp` solves

    min ½ xᵀ Q x + gᵀ x   s.t.  A_eq x = b_eq,   l ≤ C x ≤ u,   lb ≤ x ≤ ub

with proxsuite's dense ProxQP called directly (``backend="proxqp"``, ``native=True``: its own box
constraints, as :func:`pbanim.lcp.solve_lcp` does), or through ``qpsolvers.solve_problem`` for any
installed backend (two-sided rows become one-sided G x ≤ h rows). It returns the solver's answer and
status as they are; :meth:`pbanim.control.qp.QPController.solve` judges them by residuals.

Notation: Jⱼ the (2, nv) Jacobian of contact point j, J_c the stacked rows n·Jⱼ, t·Jⱼ (2m, nv), x the QP's
unknowns (q̈, τ, f).

Limiting cases: one point in contact keeps both its rows; two points on one flat foot keep three rows;
no contact gives an empty block.

References: G. H. Golub and C. F. Van Loan, *Matrix Computations*, §5.4.1 (QR with column pivoting);
A. Bambade et al., "PROX-QP: Yet another quadratic programming solver for robotics and beyond", RSS 2022;
S. Caron et al., qpsolvers (one interface to many QP solvers).
"""

from __future__ import annotations

import numpy as np
from scipy.linalg.lapack import dgeqp3

__all__ = ["contact_rows", "keep_level", "solve_qp"]


def contact_rows(J: np.ndarray, Jb: np.ndarray, ground, rank_tol: float = 1e-9) -> tuple:
    """(J_c (2m, nv), J̇_c q̇ (2m,), kept rows) from the contact points' Jacobians J (m, 2, nv) and biases
    J̇q̇ (m, 2): rows n·Jⱼ and t·Jⱼ interleaved per point, and the sorted indices of a full-rank subset of
    them (QR with column pivoting of J_cᵀ, LAPACK's dgeqp3; rank where |Rᵢᵢ| > rank_tol |R₀₀|)."""
    m, nv = J.shape[0], J.shape[2]
    if m == 0:
        return np.zeros((0, nv)), np.zeros(0), np.zeros(0, dtype=int)
    Jnt = np.empty((2 * m, nv))
    Jnt[0::2] = np.einsum("c,mcv->mv", ground.normal, J)
    Jnt[1::2] = np.einsum("c,mcv->mv", ground.tangent, J)
    bnt = np.empty(2 * m)
    bnt[0::2], bnt[1::2] = Jb @ ground.normal, Jb @ ground.tangent
    qr, jpvt, _, _, info = dgeqp3(np.asfortranarray(Jnt.T))
    if info != 0:                                                  # LAPACK refused the matrix: keep no row
        return Jnt, bnt, np.zeros(0, dtype=int)
    d = np.abs(np.diag(qr))
    rank = int(np.sum(d > rank_tol * max(d[0], 1e-300)))
    return Jnt, bnt, np.sort(jpvt[:rank] - 1)                      # LAPACK's pivots count from 1


def keep_level(Aeq: np.ndarray, beq: np.ndarray, Ak: np.ndarray, x: np.ndarray,
               rank_tol: float = 1e-9) -> tuple[np.ndarray, np.ndarray]:
    """The equalities with a solved level's optimum kept: [A_eq; T A_k] x = [b_eq; T A_k x*].

    A_k x = A_k x* describes the level's optimal set, but some of its rows may already be fixed by A_eq
    (dependent rows whose right-hand sides agree only to the solver's tolerance, which a QP solver can
    take for infeasibility). So only the part of A_k that acts in the null space Z of A_eq is added: with
    A_k Z = U Σ Vᵀ, T = U_rᵀ for the r singular values above ``rank_tol`` ‖A_k‖; the rows left out are
    combinations of A_eq's and hold with it. The stacked equalities stay of full row rank.
    """
    _, s, Vt = np.linalg.svd(Aeq)
    r = int(np.sum(s > rank_tol * max(s[0], 1e-300))) if s.size else 0
    Z = Vt[r:].T
    if Z.shape[1] == 0 or not Ak.size:
        return Aeq, beq
    U, sk, _ = np.linalg.svd(Ak @ Z, full_matrices=False)
    rk = int(np.sum(sk > rank_tol * max(np.linalg.norm(Ak, 2), 1e-300)))
    if rk == 0:
        return Aeq, beq
    T = U[:, :rk].T @ Ak
    return np.vstack([Aeq, T]), np.concatenate([beq, T @ x])


def solve_qp(Q, g, *, Aeq, beq, C, l, u, lb, ub, scale=None, x0=None, backend: str = "proxqp", native: bool = True,
             eps_abs: float = 1e-9, max_iter: int = 2000) -> tuple[np.ndarray, str, int]:
    """(x, solver status, iterations) of the QP above; x may be non-finite when the solver gives up.

    ``scale``: D > 0 per unknown; the solver sees x̃ = D⁻¹x (torques and forces of hundreds of newtons
    next to accelerations of a few m/s² otherwise mislead ProxQP's infeasibility test). ``x0``: a
    starting point (a feasible one, e.g. the level above's answer, is used as a warm start).
    """
    D = np.ones(Q.shape[0]) if scale is None else np.asarray(scale, dtype=float)
    Qs, gs, As, Cs = D[:, None] * Q * D, D * g, Aeq * D, C * D
    lbs, ubs = lb / D, ub / D
    xs0 = None if x0 is None or not np.all(np.isfinite(x0)) else np.asarray(x0) / D
    if backend == "proxqp" and native:
        import proxsuite  # lazy: only a controller that solves loads it

        kw = {} if xs0 is None else {"x": xs0, "initial_guess": proxsuite.proxqp.InitialGuess.WARM_START}
        r = proxsuite.proxqp.dense.solve(Qs, gs, As, beq, Cs, l, u, l_box=lbs, u_box=ubs, eps_abs=eps_abs, eps_rel=0.0,
                                         max_iter=max_iter, **kw)
        return D * np.array(r.x, dtype=float), str(r.info.status).split(".")[-1], int(r.info.iter)
    import qpsolvers  # lazy, as above

    up, lo = np.isfinite(u), np.isfinite(l)
    G = np.vstack([Cs[up], -Cs[lo]])
    h = np.concatenate([u[up], -l[lo]])
    kw = {"eps_abs": eps_abs, "eps_rel": 0.0, "max_iter": max_iter} if backend == "proxqp" else {}
    prob = qpsolvers.Problem(Qs, gs, G if G.shape[0] else None, h if G.shape[0] else None, As, beq, lbs, ubs)
    sol = qpsolvers.solve_problem(prob, solver=backend, initvals=xs0, **kw)
    x = np.full(Q.shape[0], np.nan) if sol.x is None else D * np.asarray(sol.x, dtype=float)
    info = sol.extras.get("info") if isinstance(sol.extras, dict) else None
    status = str(getattr(info, "status", "found" if sol.found else "not_found")).split(".")[-1]
    return x, status, int(getattr(info, "iter", 0) or 0)
