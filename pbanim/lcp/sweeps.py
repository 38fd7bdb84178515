"""The sweeps of projected Gauss–Seidel: the readable row loop, and by wavefronts a level of rows at a time
(chapter 07).

The readable sweep (:func:`pbanim.lcp.solve.pgs_sweeps`, beside the assignment's :func:`~pbanim.lcp.solve.pgs`) visits the rows i = 1 … m in order,

    fᵢ ← max(0, fᵢ − ω (Aᵢ·f + bᵢ) / Aᵢᵢ),

so row i reads the *new* fⱼ of the rows j < i and the *old* fⱼ of the rows j > i. Only the rows coupled to
i (Aᵢⱼ ≠ 0 or Aⱼᵢ ≠ 0: contacts sharing a body) matter. Give each row a level

    ℓ(i) = 1 + max{ ℓ(j) : j < i, j coupled to i }     (1 when there is none),

then two coupled rows j < i have ℓ(j) < ℓ(i): updating the levels in increasing order, all the rows of a
level at once (a matrix–vector product A_L f), every row reads exactly the values it reads in the
readable order — the same iterates, the products A_L f summed in another order (equal to roundoff). The
level of a row depends on A's sparsity only, so the plan is made once per matrix; a sphere pile of 400
contacts has about 50 levels, so a sweep is 50 small products instead of 400 row products in Python.

=========  ===============  ===========  ==================================================
symbol     code             shape        meaning
=========  ===============  ===========  ==================================================
f          ``f``            (m,)         impulses (updated in place)
ℓ(i)       ``level``        (m,)         the wavefront of row i
L          ``rows``         (m_L,)       the rows of one level, in increasing order
ω          ``omega``        scalar       relaxation (1: Gauss–Seidel)
=========  ===============  ===========  ==================================================

Limiting cases: a diagonal A → one level, one sweep is a Jacobi step and is exact; a dense A (every pair
coupled) → m levels of one row, the readable sweep.

References: J. H. Saltz, "Aggregation methods for solving sparse triangular systems on multiprocessors",
SIAM J. Sci. Stat. Comput. 11 (1990) (level scheduling); K. G. Murty (1988), ch. 9 (PGS).
"""

from __future__ import annotations

import numpy as np

from .pivoting import _EPS1000

__all__ = ["wavefront_levels", "pgs_sweeps_wavefront", "WAVEFRONT_FROM"]

#: from this many rows :func:`pbanim.lcp.solve.pgs` and :func:`~pbanim.lcp.lean_solve.lean_pgs` sweep by wavefronts
#: (below, the plan's O(m²) coupling scan costs about what the row loop saves)
WAVEFRONT_FROM = 48


def wavefront_levels(A: np.ndarray) -> np.ndarray:
    """ℓ(i) for every row of A (see the module docstring), ints ≥ 1; one pass over the rows in order.

    >>> A = np.array([[2.0, 1.0, 0.0], [1.0, 2.0, 0.0], [0.0, 0.0, 2.0]])
    >>> wavefront_levels(A).tolist()           # rows 0, 1 coupled; row 2 free
    [1, 2, 1]
    """
    m = A.shape[0]
    coupled = A != 0
    coupled |= coupled.T
    ii, jj = np.nonzero(coupled)                             # sorted by i
    below = jj < ii
    ii, jj = ii[below], jj[below]                            # the coupled pairs j < i
    level = [1] * m
    for i, j in zip(ii.tolist(), jj.tolist()):               # one pass over the pairs (nnz of the lower part)
        if level[j] >= level[i]:
            level[i] = level[j] + 1
    return np.array(level, dtype=np.intp)


def _plan(A, b, diag, omega):
    """The rows in level order (``order``) and per level the slice [s, e) of the rows in that order with
    M_L = E_L − ω D_L⁻¹ A_L (columns in level order; E_L picks the rows themselves) and c_L = ω D_L⁻¹ b_L, so that
    the update of a level is f_L ← max(0, M_L f − c_L): the readable fᵢ − ω(Aᵢ·f + bᵢ)/Aᵢᵢ with the division
    distributed (Mᵢᵢ = 1 − ω, exactly 0 for Gauss–Seidel, where the readable form cancels fᵢ − fᵢ)."""
    level = wavefront_levels(A)
    order = np.argsort(level, kind="stable")                 # rows of a level stay in increasing order
    cuts = np.concatenate([[0], np.flatnonzero(np.diff(level[order])) + 1, [order.size]]).tolist()
    M = A[np.ix_(order, order)]
    M *= -omega
    M /= diag[order][:, None]
    M.ravel()[::order.size + 1] += 1.0
    c = omega * b[order] / diag[order]
    return order, [(s, e, M[s:e], c[s:e]) for s, e in zip(cuts[:-1], cuts[1:])]


def pgs_sweeps_wavefront(A, b, f, diag, absA, tol_b: float, max_iter: int, omega: float = 1.0):
    """:func:`pbanim.lcp.solve.pgs_sweeps` by wavefronts: the same arguments, the same stop test after each
    sweep, the same result tuple (f, status, sweeps, residual, threshold); f updated in place. The iterates
    are the readable ones to roundoff (the products summed in another order, the division by Aᵢᵢ distributed
    over them; ORACLES D21)."""
    order, plan = _plan(A, b, diag, omega)
    fp = f[order]                                            # f in level order
    res = thresh = float("inf")
    status, done = "max_iter", max_iter
    # after a sweep f ≥ 0, so max(|A| f) ≤ max row sum of |A| · max f: a residual above the threshold that bound
    # gives cannot pass the stop test, and the product |A| f is made only when it can (or at the last sweep,
    # whose threshold is returned); the margin 1e-8 covers the roundoff of both sides
    rmax = float(absA.sum(axis=1).max()) * (1.0 + 1e-8)
    for sweep in range(1, max_iter + 1):
        for s, e, ML, cL in plan:
            w = ML @ fp
            w -= cL
            np.maximum(w, 0.0, out=fp[s:e])
        f[order] = fp
        res = float(np.abs(f - np.maximum(0.0, f - (A @ f + b))).max())
        if sweep < max_iter and res > tol_b + _EPS1000 * (rmax * float(fp.max())):
            continue
        thresh = tol_b + _EPS1000 * float(np.max(absA @ f))
        if res <= thresh:
            status, done = "converged", sweep
            break
    return f, status, done, res, thresh
