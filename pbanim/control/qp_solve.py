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

In 3-D a point has three rows (n, t₁, t₂) and the cone is the four-sided pyramid |fₜₖ| ≤ μ fₙ
(:func:`friction_pyramid`, the planar cone's two rows per tangent).

**Joint limits.** A coordinate θ with limits [θ_min, θ_max] must stay inside them: with the acceleration
held for a horizon T (≥ the step), θ + T θ̇ + ½ T² θ̈ ∈ [θ_min, θ_max] gives box bounds on θ̈

    2 (θ_min − θ − T θ̇) / T²  ≤  θ̈  ≤  2 (θ_max − θ − T θ̇) / T²            (:func:`joint_limit_bounds`)

(inequalities of the QP, in every level of a prioritized solve: a task never buys its acceleration with
a joint past its limit). Near a limit and moving toward it the bound asks for braking; T sets how hard.

**Priorities.** :func:`keep_level` adds a solved level's optimum to the equalities without making them
dependent (the rows already fixed are left out).

**The solver call.** :func:`solve_qp` solves

    min ½ xᵀ Q x + gᵀ x   s.t.  A_eq x = b_eq,   l ≤ C x ≤ u,   lb ≤ x ≤ ub

with proxsuite's dense ProxQP called directly (``backend="proxqp"``, ``native=True``: its own box
constraints, as :func:`pbanim.lcp.solve_lcp` does), or through ``qpsolvers.solve_problem`` for any
installed backend (two-sided rows and finite bounds become one-sided G x ≤ h rows; ``max_iter`` goes to
the backend's own iteration cap, :data:`ITERATION_OPTION`). It returns the solver's answer and
status as they are, and a backend that raises (a solver error, a problem it refuses) as a non-finite
answer with the error in its status; :meth:`pbanim.control.qp.QPController.solve` judges every answer
by residuals, so a failure comes back flagged "infeasible", never as numbers.

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

from ..errors import InvalidInput

__all__ = ["backends", "check_backend", "contact_rows", "friction_pyramid", "limit_settings", "settings", "joint_limit_bounds", "keep_level", "kkt_residual", "solve_qp", "MAX_DATUM"]

# the option capping each backend's iterations (the controller's max_iter is passed to it: HiGHS's QP solver,
# uncapped by default, ran for minutes on a prioritized level); a backend not listed keeps its own cap
ITERATION_OPTION = {"proxqp": "max_iter", "osqp": "max_iter", "scs": "max_iters", "piqp": "max_iter", "qpalm": "max_iter",
                    "clarabel": "max_iter", "ecos": "max_iters", "highs": "qp_iteration_limit", "daqp": "iter_limit",
                    "cvxopt": "maxiters"}
MAX_DATUM = 1e150                  # the largest |entry| of a QP's data whose square double precision holds


def backends() -> list:
    """The backends a controller can use: "proxqp" (proxsuite called directly), then every solver qpsolvers
    finds installed (none when qpsolvers is not installed). Imports qpsolvers when first asked."""
    try:
        import qpsolvers
    except ImportError:
        return ["proxqp"]
    return ["proxqp"] + [b for b in qpsolvers.available_solvers if b != "proxqp"]


def check_backend(backend: str, native: bool) -> str:
    """``backend`` when it can be called (proxsuite for the native route, else an installed qpsolvers solver),
    or :class:`InvalidInput` saying what to install."""
    if backend == "proxqp" and native:
        try:
            import proxsuite  # noqa: F401  (lazy: only a controller that solves needs it)
        except ImportError:
            raise InvalidInput("backend 'proxqp' (native) needs proxsuite: pip install proxsuite") from None
        return backend
    try:
        import qpsolvers
    except ImportError:
        raise InvalidInput(f"backend {backend!r} needs qpsolvers: pip install qpsolvers") from None
    if backend not in qpsolvers.available_solvers:
        raise InvalidInput(f"backend must be an installed qpsolvers solver, one of {qpsolvers.available_solvers}, "
                           f"got {backend!r}")
    return backend


def contact_rows(J: np.ndarray, Jb: np.ndarray, ground, rank_tol: float = 1e-9) -> tuple:
    """(J_c (2m, nv), J̇_c q̇ (2m,), kept rows) from the contact points' Jacobians J (m, 2, nv) and biases
    J̇q̇ (m, 2): rows n·Jⱼ and t·Jⱼ interleaved per point, and the sorted indices of a full-rank subset of
    them (QR with column pivoting of J_cᵀ, LAPACK's dgeqp3; rank where |Rᵢᵢ| > rank_tol |R₀₀|).
    In 3-D (a ``ground`` with ``tangents`` t₁, t₂; J (m, 3, nv)): three rows n, t₁, t₂ per point (3m)."""
    m, nv = J.shape[0], J.shape[2]
    dirs = (ground.normal,) + tuple(ground.tangents if hasattr(ground, "tangents") else (ground.tangent,))  # n, t…
    d = len(dirs)
    if m == 0:
        return np.zeros((0, nv)), np.zeros(0), np.zeros(0, dtype=int)
    Jnt, bnt = np.empty((d * m, nv)), np.empty(d * m)
    for k, a in enumerate(dirs):
        Jnt[k::d] = np.einsum("c,mcv->mv", a, J)
        bnt[k::d] = Jb @ a
    qr, jpvt, _, _, info = dgeqp3(np.asfortranarray(Jnt.T))
    if info != 0:                                                  # LAPACK refused the matrix: keep no row
        return Jnt, bnt, np.zeros(0, dtype=int)
    d = np.abs(np.diag(qr))
    rank = int(np.sum(d > rank_tol * max(d[0], 1e-300)))
    return Jnt, bnt, np.sort(jpvt[:rank] - 1)                      # LAPACK's pivots count from 1


def friction_pyramid(m: int, dirs: int, mu: float, first: int, N: int) -> np.ndarray:
    """The cone rows G x ≤ 0 of m points whose forces (fₙ, fₜ…) of ``dirs`` entries each start at column
    ``first`` of x (N columns): ±fₜₖ − μ fₙ ≤ 0 per tangent k (exact in the plane, dirs = 2; the
    four-sided pyramid |fₜ₁|, |fₜ₂| ≤ μ fₙ in 3-D, dirs = 3)."""
    G = np.zeros((2 * (dirs - 1) * m, N))
    r = 0
    for j in range(m):
        cn = first + dirs * j
        for k in range(1, dirs):
            G[r, [cn, cn + k]] = -mu, 1.0
            G[r + 1, [cn, cn + k]] = -mu, -1.0
            r += 2
    return G


def settings(ctrl, torque_limits: np.ndarray, min_normal, contact_tol, contact_speed, regularization, task_tol,
             feasibility_tol, backend, native, eps_abs, max_iter) -> None:
    """Set a controller's contact, regularization, tolerance and solver settings (the planar and the 3-D one)."""
    ctrl.torque_limits = torque_limits
    ctrl.min_normal, ctrl.contact_tol, ctrl.contact_speed = float(min_normal), float(contact_tol), float(contact_speed)
    ctrl.eps, ctrl.task_tol = float(regularization), float(task_tol)
    ctrl.feasibility_tol, ctrl.eps_abs, ctrl.max_iter = float(feasibility_tol), float(eps_abs), int(max_iter)
    ctrl.native = bool(native)
    ctrl.backend = check_backend(backend, ctrl.native)


def limit_settings(ctrl, joint_limits, horizon: float, joints: dict) -> None:
    """Set ``limit_index`` (velocity indices), ``limit_lo``, ``limit_hi`` and ``limit_horizon`` of a controller
    from name → (θ_min, θ_max); :class:`InvalidInput` for a name not in ``joints`` or θ_min > θ_max."""
    lim = dict(joint_limits or {})
    unknown = sorted(set(lim) - set(joints))
    if unknown or any(not lo <= hi for lo, hi in lim.values()):
        raise InvalidInput(f"{type(ctrl).__name__}: joint_limits must name joints of {sorted(joints)} with "
                           f"θ_min ≤ θ_max; got unknown {unknown} in {lim}")
    ctrl.limit_index, ctrl.limit_horizon = np.array([joints[nm] for nm in lim], dtype=int), float(horizon)
    ctrl.limit_lo, ctrl.limit_hi = (np.array([b[k] for b in lim.values()], dtype=float) for k in (0, 1))


def joint_limit_bounds(q: np.ndarray, qd: np.ndarray, index: np.ndarray, lo: np.ndarray, hi: np.ndarray,
                       horizon: float) -> tuple[np.ndarray, np.ndarray]:
    """(lower, upper) bounds on q̈[index] that keep θ + T θ̇ + ½ T² θ̈ inside [lo, hi] (module docstring)."""
    th, thd, k = q[index], qd[index], 2.0 / (horizon * horizon)
    return k * (lo - th - horizon * thd), k * (hi - th - horizon * thd)


def keep_level(Aeq: np.ndarray, beq: np.ndarray, Ak: np.ndarray, x: np.ndarray,
               rank_tol: float = 1e-9) -> tuple[np.ndarray, np.ndarray]:
    """The equalities with a solved level's optimum kept: [A_eq; T A_k] x = [b_eq; T A_k x*].

    A_k x = A_k x* describes the level's optimal set, but some of its rows may already be fixed by A_eq
    (dependent rows whose right-hand sides agree only to the solver's tolerance, which a QP solver can
    take for infeasibility). So only the part of A_k that acts in the null space Z of A_eq is added: with
    A_k Z = U Σ Vᵀ, T = U_rᵀ for the r singular values above ``rank_tol`` ‖A_k‖; the rows left out are
    combinations of A_eq's and hold with it. The stacked equalities stay of full row rank.
    """
    T, _ = _level_rows(Aeq, Ak, rank_tol)
    if T is None:
        return Aeq, beq
    return np.vstack([Aeq, T]), np.concatenate([beq, T @ x])


def _level_rows(Aeq: np.ndarray, Ak: np.ndarray, rank_tol: float = 1e-9, Z: np.ndarray | None = None) -> tuple:
    """(T, Z): T of :func:`keep_level` (its rows T A_k x = T A_k x* to add), or None when A_k Z has no singular value
    above ``rank_tol`` ‖A_k‖₂ (then A_k x is the same at every x of A_eq x = b_eq, the level's objective is constant
    there and every feasible point is its optimum); Z the null space of A_eq (given: not computed again). T depends
    on A_eq and A_k alone, not on the level's answer. A_k Z of Frobenius norm below ½ rank_tol ‖A_k‖_F / √min(shape)
    has rank 0 without its SVD (s₁ ≤ ‖·‖_F, ‖A_k‖₂ ≥ ‖A_k‖_F / √rank)."""
    if Z is None:
        _, s, Vt = np.linalg.svd(Aeq)
        r = int(np.sum(s > rank_tol * max(s[0], 1e-300))) if s.size else 0
        Z = Vt[r:].T
    if Z.shape[1] == 0 or not Ak.size:
        return None, Z
    AZ = Ak @ Z
    if np.sqrt(np.sum(AZ * AZ)) <= 0.5 * rank_tol * np.sqrt(np.sum(Ak * Ak) / min(Ak.shape)):
        return None, Z
    U, sk, _ = np.linalg.svd(AZ, full_matrices=False)
    rk = int(np.sum(sk > rank_tol * max(np.linalg.norm(Ak, 2), 1e-300)))
    if rk == 0:
        return None, Z
    return U[:, :rk].T @ Ak, Z


def solve_qp(Q, g, *, Aeq, beq, C, l, u, lb, ub, scale=None, x0=None, backend: str = "proxqp", native: bool = True,
             eps_abs: float = 1e-9, max_iter: int = 2000, equilibrate: bool = False,
             primal_inf: float | None = None) -> tuple[np.ndarray, str, int, float]:
    """(x, solver status, iterations, KKT residual) of the QP above; x may be non-finite when the solver gives
    up. The KKT residual (:func:`kkt_residual`, from the solver's multipliers, in the scaled variables) says
    how far x is from the optimum; inf when the backend gives no multipliers or fails.

    Data beyond :data:`MAX_DATUM` in magnitude are not sent to the solver (ProxQP stalls on them for
    max_iter × 1500 inner iterations, minutes, where squares overflow): x is NaN and the status says why,
    as for a backend that raises. The caller judges x by its residuals either way.

    ``scale``: D > 0 per unknown; the solver sees x̃ = D⁻¹x (torques and forces of hundreds of newtons
    next to accelerations of a few m/s² otherwise mislead ProxQP's infeasibility test). ``x0``: a
    starting point (a feasible one, e.g. the level above's answer, is used as a warm start).

    ``equilibrate``: each row of A_eq and of C divided by its largest |entry| (after ``scale``), its sides
    alike: the same constraints, rows of one size. Equations of motion of entries ~M g next to contact rows
    of entries ~1 otherwise make ProxQP call a feasible problem primal infeasible (measured on the 3-D
    biped's landing, :mod:`pbanim.control.qp_biped3d`: an LP phase 1 finds it feasible with zero violation).
    ``primal_inf``: ProxQP's threshold of its primal-infeasibility certificate (``eps_primal_inf``, 1e-4 by
    default: a relative size of Aᵀδy + Cᵀδz to the multipliers' step δy, δz below which it stops and calls the
    problem infeasible); None keeps ProxQP's default and its one-call ``dense.solve``.
    """
    big = max(_largest(a) for a in (Q, g, Aeq, beq, C, l, u, lb, ub))
    if not big <= MAX_DATUM:
        return (np.full(Q.shape[0], np.nan), f"not solved: the QP's data reach {big:.3g}, beyond {MAX_DATUM:g} (their "
                f"squares overflow double precision and the solver stalls; lower the gains, weights or targets)", 0,
                np.inf)
    try:
        if equilibrate:
            D = np.ones(Q.shape[0]) if scale is None else np.asarray(scale, dtype=float)
            (sa, beq), (sc, l, u) = _row_scales(Aeq * D, beq), _row_scales(C * D, l, u)
            Aeq, C = sa[:, None] * Aeq, sc[:, None] * C
        return _solve(Q, g, Aeq, beq, C, l, u, lb, ub, scale, x0, backend, native, eps_abs, max_iter, primal_inf)
    except Exception as exc:  # noqa: BLE001 - any backend failure is an answer the caller flags by residuals
        return np.full(Q.shape[0], np.nan), f"backend {backend} failed: {type(exc).__name__}: {str(exc)[:200]}", 0, \
            np.inf


def kkt_residual(Q, g, A, b, x, y, rows) -> float:
    """How far (x, y, z) is from the optimality conditions of min ½xᵀQx + gᵀx s.t. A x = b, l ≤ M x ≤ u
    (``rows``: (M, l, u, z) blocks, M None for the identity (bounds on x); z > 0 on an active upper side, z < 0
    on a lower one), relative to
    the size of their terms: the larger of

        ‖Q x + g + Aᵀy + Σ Mᵀz‖∞ / (1 + the largest term)                    (stationarity)
        |xᵀQx + gᵀx + bᵀy + Σ (u·z⁺ + l·z⁻)| / (1 + Σ |each term|)          (the duality gap)

    where a multiplier on an infinite side adds to the gap (it is not dual feasible). With the primal
    residuals, which the controller checks itself, these certify x optimal; inf when a multiplier is
    missing. Cost: a few products of the QP's size."""
    if y is None or any(z is None for *_, z in rows) or not np.all(np.isfinite(x)):
        return np.inf
    y = np.asarray(y, dtype=float)
    terms = [Q @ x, g, A.T @ y] + [np.asarray(z, dtype=float) if M is None else M.T @ np.asarray(z, dtype=float)
                                   for M, _, _, z in rows]
    stat = np.abs(sum(terms)).max(initial=0.0) / (1.0 + max(np.abs(t).max(initial=0.0) for t in terms))
    parts, stray = [float(x @ terms[0]), float(g @ x), float(b @ y)], 0.0
    for M, lo, hi, z in rows:
        zp, zm = np.maximum(z, 0.0), np.minimum(z, 0.0)
        fu, fl = np.isfinite(hi), np.isfinite(lo)
        parts += [float(hi[fu] @ zp[fu]), float(lo[fl] @ zm[fl])]
        stray += float(zp[~fu].sum() - zm[~fl].sum())
    gap = (abs(sum(parts)) + stray) / (1.0 + sum(abs(p) for p in parts))
    out = max(float(stat), float(gap))
    return out if out == out else np.inf


def _row_scales(A: np.ndarray, *sides) -> tuple:
    """(s, sides…): s = 1 / the largest |entry| of each row of A (1 for an all-zero row), the sides times s."""
    big = np.abs(A).max(axis=1, initial=0.0)
    s = 1.0 / np.where(big > 0, big, 1.0)
    return (s,) + tuple(s * np.asarray(b, dtype=float) for b in sides)


def _largest(a: np.ndarray) -> float:
    """The largest finite |entry| of a (infinite bounds are no data), NaN when an entry is NaN."""
    a = np.asarray(a, dtype=float)
    if not a.size:
        return 0.0
    big = float(np.abs(a).max())
    if big < np.inf:                             # every entry finite (a NaN propagates, an inf is ∞): the answer
        return big
    m = np.abs(a[np.isfinite(a) | np.isnan(a)])
    return float(m.max()) if m.size else 0.0


def _solve(Q, g, Aeq, beq, C, l, u, lb, ub, scale, x0, backend, native, eps_abs, max_iter, primal_inf=None):
    """The backend call of :func:`solve_qp` (which turns its exceptions into a flagged answer)."""
    D = np.ones(Q.shape[0]) if scale is None else np.asarray(scale, dtype=float)
    Qs, gs, As, Cs = D[:, None] * Q * D, D * g, Aeq * D, C * D
    lbs, ubs = lb / D, ub / D
    xs0 = None if x0 is None or not np.all(np.isfinite(x0)) else np.asarray(x0) / D
    if backend == "proxqp" and native:
        import proxsuite  # lazy: only a controller that solves loads it

        if primal_inf is None:
            kw = {} if xs0 is None else {"x": xs0, "initial_guess": proxsuite.proxqp.InitialGuess.WARM_START}
            r = proxsuite.proxqp.dense.solve(Qs, gs, As, beq, Cs, l, u, l_box=lbs, u_box=ubs, eps_abs=eps_abs,
                                             eps_rel=0.0, max_iter=max_iter, **kw)
        else:                                      # the QP object: its settings hold eps_primal_inf
            qp = proxsuite.proxqp.dense.QP(Qs.shape[0], As.shape[0], Cs.shape[0], True)
            st = qp.settings
            st.eps_abs, st.eps_rel, st.max_iter, st.eps_primal_inf = eps_abs, 0.0, max_iter, primal_inf
            if xs0 is not None:
                st.initial_guess = proxsuite.proxqp.InitialGuess.WARM_START
            qp.init(Qs, gs, As, beq, Cs, l, u, lbs, ubs)
            qp.solve() if xs0 is None else qp.solve(xs0, None, None)
            r = qp.results
        xs, z, m = np.array(r.x, dtype=float), np.array(r.z, dtype=float), Cs.shape[0]
        kkt = kkt_residual(Qs, gs, As, beq, xs, r.y, [(Cs, l, u, z[:m]), (None, lbs, ubs, z[m:])])
        return D * xs, str(r.info.status).split(".")[-1], int(r.info.iter), kkt
    import qpsolvers  # lazy, as above

    # every one-sided row with a finite side, the finite bounds among them (some backends, e.g. ECOS, refuse
    # an infinite entry in h or in the bounds they turn into rows)
    up, lo, bu, bl, eye = np.isfinite(u), np.isfinite(l), np.isfinite(ubs), np.isfinite(lbs), np.eye(Q.shape[0])
    G = np.vstack([Cs[up], -Cs[lo], eye[bu], -eye[bl]])
    h = np.concatenate([u[up], -l[lo], ubs[bu], -lbs[bl]])
    kw = {"eps_abs": eps_abs, "eps_rel": 0.0} if backend == "proxqp" else {}
    if backend in ITERATION_OPTION:
        kw[ITERATION_OPTION[backend]] = max_iter
    prob = qpsolvers.Problem(Qs, gs, G if G.shape[0] else None, h if G.shape[0] else None, As, beq)
    sol = qpsolvers.solve_problem(prob, solver=backend, initvals=xs0, **kw)
    xs = np.full(Q.shape[0], np.nan) if sol.x is None else np.asarray(sol.x, dtype=float)
    info = sol.extras.get("info") if isinstance(sol.extras, dict) else None
    status = str(getattr(info, "status", "found" if sol.found else "not_found")).split(".")[-1]
    y = np.zeros(0) if As.shape[0] == 0 else sol.y
    z = np.zeros(0) if G.shape[0] == 0 else sol.z
    kkt = kkt_residual(Qs, gs, As, beq, xs, y, [(G, np.full(h.size, -np.inf), h, z)])
    return D * xs, status, int(getattr(info, "iter", 0) or 0), kkt
