"""Active-set contact solvers with warm starts (chapter 07): block principal pivoting and box friction.

A pivoting method guesses which contacts carry force (the *active set* F) and solves one linear system
on it. For the frictionless LCP  w = A f + b ≥ 0, f ≥ 0, fᵀw = 0  the guess F gives

    A_FF f_F = −b_F,   f_i = 0 (i ∉ F),   w = A f + b,

and the guess is right when f_F ≥ 0 and w_i ≥ 0 off F. Block principal pivoting (Júdice & Pires 1994;
Kim & Park's NNLS variant) exchanges *every* infeasible index at once — f_i < 0 leaves F, w_i < 0 enters
F — so a good first guess needs one solve: between two time steps of a resting scene the active set does
not change, and the previous step's set (``active=``) is the answer (no pivots while contacts persist).
When the number of infeasible indices stops falling for three rounds, one index at a time is exchanged
(Murty's rule), and after ``max_iter`` exchanges the solver stops and says so ("max_iter").

Redundant contacts (four corners on a face: A_FF singular but consistent) are solved by a proximal
step: (A_FF + ρI) Δ = −(A_FF f_F + b_F) repeated ``refine`` times converges to a solution next to the
start (the minimum-norm one from f = 0), with ρ = ``rho_rel`` · max Aᵢᵢ; the Cholesky factor of
A_FF + ρI is kept and reused while F does not change (across exchanges and across calls, ``cache``).

Box friction (:func:`box_friction_active_set`): z = [fᵢ, tᵢ₁, tᵢ₂] per contact with fᵢ ≥ 0 ⊥ w_fᵢ ≥ 0
and tᵢⱼ ∈ [−μfᵢ, μfᵢ], w_tᵢⱼ = 0 inside, w ≤ 0 at +μfᵢ, w ≥ 0 at −μfᵢ (the friction pyramid aligned
with the tangents; the readable solver is :func:`pbanim.lcp.solve.pgs_box_friction`). Each tangent is
in one of three states — sticking (w = 0), sliding at +μf or at −μf (t replaced by ±μf) — and each
normal active or not; one guess gives one square linear system (not symmetric once something slides).

=========  =================  =========  ======================================================
symbol     code               shape      meaning
=========  =================  =========  ======================================================
F          ``free``           (m,) bool  active set: contacts with a force
ρ          ``rho``            scalar     proximal regularization of the sub-solve
s          ``state``          (m, 3) int 0 off / 1 on (normal); 0 stick, +1 / −1 at ±μf (tangents)
μ          ``mu``             (m,)       friction coefficient
=========  =================  =========  ======================================================

Limiting cases: b ≥ 0 → F = ∅, f = 0 in one round; A positive definite and the right F given → one
solve, zero exchanges; μ = 0 → the tangents stay at zero and the normal problem is the frictionless LCP.

References: J. J. Júdice, F. M. Pires, "A block principal pivoting algorithm for large-scale strictly
monotone linear complementarity problems", Comput. Oper. Res. 21 (1994); K. G. Murty, *Linear
Complementarity, Linear and Nonlinear Programming* (1988), ch. 8; J. Kim, H. Park, "Fast nonnegative
matrix factorization: an active-set-like method", SIAM J. Sci. Comput. 33 (2011).
"""

from __future__ import annotations

from typing import Any

import numpy as np
from scipy.linalg.lapack import dgetrf, dgetrs, dpotrf, dpotrs

from ..errors import InvalidInput
from ..results import natural_map_residual

__all__ = ["bpp", "dual_active_set", "box_friction_active_set", "box_friction_residual"]

_SQRT_EPS = float(np.sqrt(np.finfo(float).eps))


def _factor(K: np.ndarray, sym: bool):
    """A factor of the square matrix K by LAPACK directly (Cholesky when ``sym`` and K is positive
    definite, LU otherwise): the scipy.linalg wrappers cost ~5 µs per call, more than the work below m ~ 30."""
    if sym:
        L, info = dpotrf(K, lower=1, clean=0)
        if info == 0:
            return "cho", L
    lu, piv, info = dgetrf(K)
    if info < 0:                                       # an illegal argument: a bug, not a singular matrix
        raise np.linalg.LinAlgError(f"LU factorization failed (LAPACK info {info})")
    return "lu", (lu, piv)


def _solve(factor, r: np.ndarray) -> np.ndarray:
    kind, fac = factor
    if kind == "cho":
        return dpotrs(fac, r, lower=1)[0]
    return dgetrs(fac[0], fac[1], r)[0]


def _prox_solve(M: np.ndarray, rhs: np.ndarray, rho: float, refine: int, factor=None, sym: bool = True):
    """x with M x = rhs (M possibly singular but consistent): proximal refinement with (M + ρI)⁻¹,
    at most ``refine`` corrections, stopped as soon as the residual is at roundoff. Returns (x, factor)
    so that the factor can be reused."""
    if factor is None:
        K = M.copy()
        K.flat[::K.shape[0] + 1] += rho
        factor = _factor(K, sym)
    x = _solve(factor, rhs)
    stop = 1e-14 * max(1.0, abs(rhs).max())
    for _ in range(int(refine)):
        r = rhs - M @ x
        if abs(r).max() <= stop:
            break
        x += _solve(factor, r)
    return x, factor


def bpp(A: np.ndarray, b: np.ndarray, *, tol: float = 1e-10, warm_start=None, active=None,
        max_iter: int | None = None, rho_rel: float = 1e-10, refine: int = 3, cache: dict | None = None,
        handoff: bool = False, **_: Any) -> tuple[np.ndarray, str, int]:
    """Block principal pivoting for the LCP with a symmetric positive semidefinite A (frictionless contact).

    ``active`` (bool (m,)) or ``warm_start`` (its support) is the first guess of F, default {bᵢ < 0}.
    Returns ``(f, status, exchanges)``, status "solved" or "max_iter" (at most ``max_iter`` rounds,
    default 3m + 10, each one factorization); with ``handoff`` it stops with "degenerate" at the first
    sign that exchanges may cycle — a wrong guess whose A_FF is singular (a Cholesky pivot² below
    10⁻⁸ max Aᵢᵢ: redundant contacts) or a round that does not reduce the number of infeasible
    indices — so that a caller can hand the problem to :func:`dual_active_set`, the method for those. ``cache`` (a dict, optional) keeps the last F and its
    factor for the next call and receives ``"active"`` and ``"factorizations"``.
    """
    m = b.size
    if m == 0:
        return np.zeros(0), "solved", 0
    if active is not None:
        free = np.asarray(active, dtype=bool).copy()
        if free.shape != (m,):
            raise InvalidInput(f"active must be a bool array of shape ({m},), got shape {free.shape}")
    elif warm_start is not None:
        free = np.asarray(warm_start, dtype=float) > 0
    else:
        free = b < 0
    cap = 3 * m + 10 if max_iter is None else int(max_iter)
    dmax = max(float(A.diagonal().max()), np.finfo(float).tiny)
    rho, singular, singular_rel = rho_rel * dmax, False, 1e-8
    thr = 0.1 * tol * max(1.0, float(abs(b).max()))
    cache = {} if cache is None else cache
    nbest, patience, nfact = m + 1, 3, 0
    f = np.zeros(m)
    for it in range(cap + 1):
        F = np.flatnonzero(free)
        f = np.zeros(m)
        if F.size:
            same = cache.get("A") is A and np.array_equal(cache.get("F"), F)
            fac = cache["factor"] if same else None
            f[F], fac = _prox_solve(A[F[:, None], F], -b[F], rho, refine, fac)
            nfact += not same
            cache.update(F=F, factor=fac, A=A)
            # a pivot at the level of ρ: A_FF is singular (redundant contacts), where exchanges can cycle
            singular = fac[0] == "cho" and float(fac[1].diagonal().min()) ** 2 < singular_rel * dmax
        w = A @ f + b
        bad = np.where(free, f, w) < -thr           # a negative force in F, or a negative w outside F
        nbad = int(np.count_nonzero(bad))
        if nbad == 0 or it == cap:
            break
        if handoff and (singular or nbad >= nbest):
            break
        if nbad < nbest:
            nbest, patience = nbad, 3
        elif patience > 0:
            patience -= 1
        else:                                        # Murty's rule: the largest infeasible index alone
            i = int(np.flatnonzero(bad)[-1])
            bad = np.zeros(m, dtype=bool)
            bad[i] = True
        free ^= bad
    cache.update(active=free.copy(), factorizations=cache.get("factorizations", 0) + nfact)
    status = "solved" if nbad == 0 else "max_iter" if it == cap else "degenerate"
    return np.maximum(f, 0.0), status, it


def dual_active_set(A: np.ndarray, b: np.ndarray, *, tol: float = 1e-10, max_iter: int | None = None,
                    dep_tol: float = 1e-9, start=None, **_: Any) -> tuple[np.ndarray, str, int]:
    """Goldfarb–Idnani dual active set for the frictionless contact LCP with a PSD, possibly singular A.

    With A = G Gᵀ the LCP is the optimality condition of the projection  min ½‖v‖²  s.t.  G v + b ≥ 0
    (v = Gᵀ f, f the multipliers, w = G v + b). The method keeps the multipliers f ≥ 0 and a set S of
    contacts held at wᵢ = 0 whose rows are linearly independent, and adds the most violated contact p
    (w_p < 0) by raising f_p by t while S stays at w = 0:

        Δf_S = −r t,   r = A_SS⁻¹ A_Sp,   Δw_p = z t,   z = A_pp − A_pSᵀ r  (= ‖projected row‖²).

    The full step t = −w_p / z makes w_p = 0 and p joins S; if a multiplier of S would go negative first
    (t = f_j / r_j), j leaves S and p is tried again. A contact whose row depends on S (z ≈ 0: a
    redundant corner) never joins S, so A_SS stays nonsingular — no least squares, no cycling on
    rank-deficient stacks. Only G's products enter, so everything is written with A; A_SS⁻¹ is kept
    and updated by rank-one formulas (O(|S|²) per change). Each round adds or removes one index;
    at most ``max_iter`` rounds (default 3m + 10); "solved" is certified (natural-map residual of the
    answer ≤ tol·max(1, ‖b‖∞), else "inaccurate"). ``start`` (bool (m,), optional) is a guess of S: its
    contacts with negative forces are dropped (a few re-solves) until f_S ≥ 0, and the method starts from
    there when A_SS is well conditioned (from S = ∅ otherwise). Returns ``(f, status, rounds)``, status "solved",
    "infeasible" (w_p < 0 cannot be raised: b is not in the feasible range), "stalled" (the same, but with
    w_p at roundoff level, √ε (|b_p| + Σ|rⱼ||bⱼ|): the held rows are too close to dependent to tell; measured
    once in 160 random redundant problems, m ≤ 300), "inaccurate" or "max_iter"; the caller certifies.

    References: D. Goldfarb, A. Idnani, "A numerically stable dual method for solving strictly convex
    quadratic programs", Math. Programming 27 (1983).

    >>> f, status, rounds = dual_active_set(np.array([[1.0, 1.0], [1.0, 1.0]]), np.array([-1.0, -1.0]))
    >>> f.tolist(), status      # two redundant contacts: one carries the load, w = 0 on both
    ([1.0, 0.0], 'solved')
    """
    m = b.size
    cap = 3 * m + 10 if max_iter is None else int(max_iter)
    thr = 0.1 * tol * max(1.0, float(np.abs(b).max(initial=0.0)))
    S = np.zeros(m, dtype=np.intp)       # S[:k]: the held set, in insertion order
    Hinv = np.zeros((m, m))              # A_SS⁻¹ in the leading k × k block
    rows = np.zeros((m, m))              # rows[i] = A[S[i]] (A symmetric: w = f_S @ rows + b)
    fS = np.zeros(m)
    w = np.array(b, dtype=float)
    k, p, fp, status, it, fresh = 0, -1, 0.0, "max_iter", 0, False
    if start is not None and m:          # a valid start: S held, f_S = −A_SS⁻¹ b_S ≥ 0, A_SS well conditioned
        S0 = np.flatnonzero(np.asarray(start, dtype=bool))
        for _ in range(min(S0.size, 8)):
            if not S0.size:
                break
            kind, L = _factor(A[S0[:, None], S0], True)
            if kind != "cho" or float(L.diagonal().min()) ** 2 <= dep_tol * float(A.diagonal()[S0].max()):
                S0 = S0[:0]              # singular: start from nothing (the method's own start)
                break
            x = _solve((kind, L), -b[S0])
            if x.min() >= 0:
                k = S0.size
                S[:k], fS[:k], rows[:k] = S0, x, A[S0]
                Hinv[:k, :k] = _solve((kind, L), np.eye(k))
                w = x @ rows[:k] + b
                break
            S0 = S0[x > 0]
    for it in range(cap + 1):
        if p < 0:                        # the most violated contact
            p = int(w.argmin()) if m else 0
            if m == 0 or w[p] >= -thr:
                p = -1
                status = "solved"
                break
            fp, ap = 0.0, A[p]
        if it == cap:
            break
        t_add, t_drop, j = np.inf, np.inf, -1
        z = ap[p]
        if k:
            a_Sp = rows[:k, p]
            r = Hinv[:k, :k] @ a_Sp
            z = ap[p] - a_Sp @ r
            rmax = r.max()
            if rmax > 0:
                pos = (r > 1e-14 * rmax).nonzero()[0]
                ratio = fS[pos] / r[pos]
                jj = int(ratio.argmin())
                j, t_drop = int(pos[jj]), float(ratio[jj])
        if z > dep_tol * ap[p]:
            t_add = -w[p] / z
        if t_add == np.inf and t_drop == np.inf:
            if k and not fresh:          # first rule out roundoff: A_SS⁻¹ afresh, and the round again
                Hinv[:k, :k] = _solve(_factor(rows[:k, S[:k]], True), np.eye(k))
                fresh = True
                continue
            # w_p < 0 and nothing can raise it: b is out of the feasible range — or, when the shortfall is at
            # roundoff level, the held rows are too close to dependent to resolve it (a degenerate set)
            cancel = abs(b[p]) + (float(np.abs(r) @ np.abs(b[S[:k]])) if k else 0.0)   # w_p = b_p − Σ rⱼ bⱼ
            status = "stalled" if -w[p] <= _SQRT_EPS * cancel else "infeasible"
            break
        fresh = False
        if t_add <= t_drop:              # full step: w_p = 0, p joins S
            if k:
                fS[:k] -= t_add * r
                u = r / z
                Hinv[:k, :k] += r[:, None] * u
                Hinv[:k, k] = Hinv[k, :k] = -u
            Hinv[k, k] = 1.0 / z
            fS[k], S[k], rows[k] = fp + t_add, p, ap
            k, p = k + 1, -1
            w = fS[:k] @ rows[:k] + b
        else:                            # partial step: f_j reaches 0, S[j] leaves
            fS[:k] -= t_drop * r
            fp += t_drop
            h = Hinv[:k, j].copy()
            Hinv[:k, :k] -= h[:, None] * (h / h[j])
            for arr in (S, fS, rows):
                arr[j:k - 1] = arr[j + 1:k]
            Hinv[j:k - 1, :k] = Hinv[j + 1:k, :k]
            Hinv[:k, j:k - 1] = Hinv[:k, j + 1:k]
            k -= 1
            w = fS[:k] @ rows[:k] + fp * ap + b
    f = np.zeros(m)
    f[S[:k]] = fS[:k]
    if p >= 0:
        f[p] = fp
    f = np.maximum(f, 0.0)
    if status == "solved" and natural_map_residual(f, w) > 10 * thr:      # w = A f + b, kept exact each round
        status = "inaccurate"             # roundoff in the updated A_SS⁻¹ left w_S off zero: the caller decides
    return f, status, it


def box_friction_residual(z: np.ndarray, w: np.ndarray, mu) -> float:
    """Largest violation of the box-friction conditions (normal: natural map; tangent: w at a bound with
    the wrong sign, w ≠ 0 inside, |t| above μf)."""
    f, t = z[0::3], z.reshape(-1, 3)[:, 1:]              # the tangent pairs (m, 2), a view
    wn, wt = w[0::3], w.reshape(-1, 3)[:, 1:]
    lim = (np.asarray(mu, dtype=float) * np.maximum(f, 0.0))[:, None]
    over = np.maximum(np.abs(t) - lim, 0.0)
    # natural map of the box: t − clip(t − w, −μf, μf)
    nat = np.abs(t - np.clip(t - wt, -lim, lim))
    r_n = natural_map_residual(f, wn) if f.size else 0.0
    return float(max(r_n, np.max(nat, initial=0.0), np.max(over, initial=0.0)))


def box_friction_active_set(A: np.ndarray, b: np.ndarray, mu, *, state=None, max_iter: int = 30,
                            tol: float = 1e-10, rho_rel: float = 1e-10, refine: int = 3,
                            patience: int = 3) -> tuple:
    """Active-set solve of the box-friction problem (see the module docstring).

    ``state`` (m, 3) ints from the previous step (contact persistence) is the first guess; default: every
    contact with b_f < 0 on and sticking. Returns ``(z, residual, rounds, state)``; ``rounds`` ≤
    ``max_iter`` and ``residual`` is :func:`box_friction_residual` (the caller compares it to its tolerance).
    The problem is not monotone once contacts slide (the bounds ±μf move with f), and in dense piles the
    exchanges can wander or cycle: when ``patience`` rounds in a row do not improve on the best residual
    so far, the solve stops early (rather than spending its whole ``max_iter`` budget) and the residual
    says so.
    """
    n = b.size
    if n % 3:
        raise InvalidInput(f"box friction needs 3 rows per contact (normal, two tangents), got {n}")
    m = n // 3
    mu = np.broadcast_to(np.asarray(mu, dtype=float), (m,))
    if state is None:
        s = np.zeros((m, 3), dtype=int)
        s[:, 0] = b[0::3] < 0
    else:
        s = np.array(state, dtype=int)
        if s.shape != (m, 3):
            raise InvalidInput(f"state must have shape ({m}, 3), got {s.shape}")
    rho = rho_rel * max(float(np.max(np.diag(A))), np.finfo(float).tiny)
    thr = 0.1 * tol * max(1.0, float(np.max(np.abs(b))))
    z = np.zeros(n)
    w = b.copy()
    best, worse = np.inf, 0
    res = None                              # the residual of the current (z, w) once computed: returned as is
    for it in range(1, int(max_iter) + 1):
        res = None
        on = s[:, 0] == 1
        # unknowns: f of active contacts, t of their sticking tangents; sliding t = ±μ f (column map P)
        cols_f = 3 * np.flatnonzero(on)
        stick = on[:, None] & (s[:, 1:] == 0)
        ci, cj = np.nonzero(stick)
        cols_t = 3 * ci + 1 + cj
        unk = np.concatenate([cols_f, cols_t])
        si, sj = np.nonzero(on[:, None] & (s[:, 1:] != 0))
        z = np.zeros(n)
        if unk.size and not si.size:         # nothing slides: P selects, the system is A's principal block
            z[unk], _ = _prox_solve(A[unk[:, None], unk], -b[unk], rho, refine)
        elif unk.size:
            P = np.zeros((n, unk.size))
            P[cols_f, np.arange(cols_f.size)] = 1.0
            P[cols_t, cols_f.size + np.arange(cols_t.size)] = 1.0
            P[3 * si + 1 + sj, np.searchsorted(cols_f, 3 * si)] = s[si, 1 + sj] * mu[si]
            x, _ = _prox_solve(A[unk] @ P, -b[unk], rho, refine, sym=False)
            z = P @ x
        w = A @ z + b
        f, t = z[0::3], z.reshape(m, 3)[:, 1:]
        wn, wt = w[0::3], w.reshape(m, 3)[:, 1:]
        lim = (mu * f)[:, None]
        new = s.copy()
        new[:, 0] = np.where(on, f >= -thr, wn < -thr)
        tan = s[:, 1:]
        nt = np.where(tan == 0, np.where(t > lim + thr, 1, np.where(t < -lim - thr, -1, 0)),
                      np.where((tan == 1) & (wt > thr), 0, np.where((tan == -1) & (wt < -thr), 0, tan)))
        new[:, 1:] = np.where(new[:, :1] == 1, nt, 0)
        if np.array_equal(new, s):
            break
        res = box_friction_residual(z, w, mu)
        if res < best:
            best, worse = res, 0
        else:                                # the guesses stopped improving the answer: it may cycle
            worse += 1
            if worse >= patience:
                break
        s = new
    return z, box_friction_residual(z, w, mu) if res is None else res, it, s
