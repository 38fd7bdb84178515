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
import scipy.linalg as sla

from ..errors import InvalidInput
from ..results import natural_map_residual

__all__ = ["bpp", "box_friction_active_set", "box_friction_residual"]


def _prox_solve(M: np.ndarray, rhs: np.ndarray, rho: float, refine: int, factor=None, sym: bool = True):
    """x with M x = rhs (M possibly singular but consistent): proximal refinement with (M + ρI)⁻¹.
    Returns (x, factor) so that the factor can be reused."""
    if factor is None:
        K = M.copy()
        K[np.diag_indices_from(K)] += rho
        factor = ("cho", sla.cho_factor(K, check_finite=False)) if sym else ("lu", sla.lu_factor(K, check_finite=False))
    kind, fac = factor
    solve = (lambda r: sla.cho_solve(fac, r, check_finite=False)) if kind == "cho" else \
        (lambda r: sla.lu_solve(fac, r, check_finite=False))
    x = solve(rhs)
    for _ in range(int(refine)):
        x = x + solve(rhs - M @ x)
    return x, factor


def bpp(A: np.ndarray, b: np.ndarray, *, tol: float = 1e-10, warm_start=None, active=None,
        max_iter: int | None = None, rho_rel: float = 1e-10, refine: int = 3, cache: dict | None = None,
        **_: Any) -> tuple[np.ndarray, str, int]:
    """Block principal pivoting for the LCP with a symmetric positive semidefinite A (frictionless contact).

    ``active`` (bool (m,)) or ``warm_start`` (its support) is the first guess of F, default {bᵢ < 0}.
    Returns ``(f, status, exchanges)``, status "solved" or "max_iter" (at most ``max_iter`` rounds,
    default 3m + 10, each one factorization). ``cache`` (a dict, optional) keeps the last F and its
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
    rho = rho_rel * max(float(np.max(np.diag(A))), np.finfo(float).tiny)
    thr = 0.1 * tol * max(1.0, float(np.max(np.abs(b))))
    cache = {} if cache is None else cache
    nbest, patience, nfact = m + 1, 3, 0
    f = np.zeros(m)
    for it in range(cap + 1):
        F = np.flatnonzero(free)
        f = np.zeros(m)
        if F.size:
            same = cache.get("F") is not None and np.array_equal(cache["F"], F) and cache.get("A") is A
            fac = cache["factor"] if same else None
            AFF = A[np.ix_(F, F)]
            f[F], fac = _prox_solve(AFF, -b[F], rho, refine, fac)
            nfact += not same
            cache.update(F=F, factor=fac, A=A)
        w = A[:, F] @ f[F] + b
        bad = (free & (f < -thr)) | (~free & (w < -thr))
        nbad = int(np.count_nonzero(bad))
        if nbad == 0 or it == cap:
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
    return np.maximum(f, 0.0), ("solved" if nbad == 0 else "max_iter"), it


def box_friction_residual(z: np.ndarray, w: np.ndarray, mu) -> float:
    """Largest violation of the box-friction conditions (normal: natural map; tangent: w at a bound with
    the wrong sign, w ≠ 0 inside, |t| above μf)."""
    f, t = z[0::3], np.stack([z[1::3], z[2::3]], axis=1)
    wn, wt = w[0::3], np.stack([w[1::3], w[2::3]], axis=1)
    lim = (np.asarray(mu, dtype=float) * np.maximum(f, 0.0))[:, None]
    over = np.maximum(np.abs(t) - lim, 0.0)
    # natural map of the box: t − clip(t − w, −μf, μf)
    nat = np.abs(t - np.clip(t - wt, -lim, lim))
    r_n = natural_map_residual(f, wn) if f.size else 0.0
    return float(max(r_n, np.max(nat, initial=0.0), np.max(over, initial=0.0)))


def box_friction_active_set(A: np.ndarray, b: np.ndarray, mu, *, state=None, max_iter: int = 30,
                            tol: float = 1e-10, rho_rel: float = 1e-10, refine: int = 3) -> tuple:
    """Active-set solve of the box-friction problem (see the module docstring).

    ``state`` (m, 3) ints from the previous step (contact persistence) is the first guess; default: every
    contact with b_f < 0 on and sticking. Returns ``(z, residual, rounds, state)``; ``rounds`` ≤
    ``max_iter`` and ``residual`` is :func:`box_friction_residual` (the caller compares it to its tolerance).
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
    for it in range(1, int(max_iter) + 1):
        on = s[:, 0] == 1
        # unknowns: f of active contacts, t of their sticking tangents; sliding t = ±μ f (column map P)
        cols_f = 3 * np.flatnonzero(on)
        stick = on[:, None] & (s[:, 1:] == 0)
        ci, cj = np.nonzero(stick)
        cols_t = 3 * ci + 1 + cj
        unk = np.concatenate([cols_f, cols_t])
        P = np.zeros((n, unk.size))
        P[cols_f, np.arange(cols_f.size)] = 1.0
        P[cols_t, cols_f.size + np.arange(cols_t.size)] = 1.0
        si, sj = np.nonzero(on[:, None] & (s[:, 1:] != 0))
        k_f = np.searchsorted(cols_f, 3 * si)
        P[3 * si + 1 + sj, k_f] = s[si, 1 + sj] * mu[si]
        z = np.zeros(n)
        if unk.size:
            M = A[unk] @ P
            x, _ = _prox_solve(M, -b[unk], rho, refine, sym=not si.size)
            z = P @ x
        w = A @ z + b
        f, t = z[0::3], np.stack([z[1::3], z[2::3]], axis=1)
        wn, wt = w[0::3], np.stack([w[1::3], w[2::3]], axis=1)
        lim = (mu * f)[:, None]
        new = s.copy()
        new[:, 0] = np.where(on, f >= -thr, wn < -thr)
        tan = s[:, 1:]
        nt = np.where(tan == 0, np.where(t > lim + thr, 1, np.where(t < -lim - thr, -1, 0)),
                      np.where((tan == 1) & (wt > thr), 0, np.where((tan == -1) & (wt < -thr), 0, tan)))
        new[:, 1:] = np.where(new[:, :1] == 1, nt, 0)
        if np.array_equal(new, s):
            break
        s = new
    return z, box_friction_residual(z, w, mu), it, s
