"""Small dense complementarity problems of collision impulses (chapter 06, part of :mod:`pbanim.collision`).

The simultaneous impulses solve the LCP  w = A f + b ≥ 0,  f ≥ 0,  fᵀw = 0  with the Delassus matrix
A = J W Jᵀ (W = M⁻¹): row i of J maps body velocities to the relative velocity of contact i along its
direction. Frictionless: one row per contact along n. With friction, the pyramidal-cone LCP of Stewart &
Trinkle (1996) adds d edge directions per contact and a sliding speed λ per contact:

    [w_n]   [A_nn  A_nD  0 ] [f]   [b_n ]
    [w_D] = [A_Dn  A_DD  E ] [β] + [D u⁻]   ≥ 0,  ⊥ (f, β, λ) ≥ 0.
    [ ζ ]   [ μ𝟙   −Eᵀ   0 ] [λ]   [ 0  ]

Solvers (written here, no dependency on :mod:`pbanim.contact`): Lemke's complementary pivoting with a
lexicographic ratio test, and enumeration of active sets (the readable O(2ᵐ) check).

References: Cottle, Pang & Stone, *The Linear Complementarity Problem* (1992) §4.4 (Lemke);
Stewart & Trinkle, IJNME 39 (1996); Anitescu & Potra, Nonlinear Dynamics 14 (1997).
"""

from __future__ import annotations

from itertools import combinations

import numpy as np

from .shapes import Contacts
from ..errors import ConvergenceError, InfeasibleContact

__all__ = ["solve_lcp_small"]


def solve_lcp_small(A, b, method: str = "lemke", max_iter: int | None = None, tol: float = 1e-12):
    """Solve w = A f + b ≥ 0, f ≥ 0, fᵀw = 0 for a small dense A (collision impulses).

    ``"lemke"``: Lemke's complementary pivoting on the tableau [𝟙, −A, −e | b], with the lexicographic
    ratio test against cycling (terminates for the positive semidefinite A = J W Jᵀ of a feasible
    contact problem). ``"enumerate"``: try every active
    set S, f_S = −A_SS⁺ b_S (least squares), the readable O(2ᵐ) check for m ≤ 12.
    Returns ``(f, iterations)``; raises :class:`InfeasibleContact` on ray termination.

    >>> f, it = solve_lcp_small(np.array([[2.0, -1.0], [-1.0, 2.0]]), np.array([-2.0, 0.0]))
    >>> f.round(12)
    array([1.33333333, 0.66666667])
    """
    A, b = np.asarray(A, float), np.asarray(b, float)
    m = len(b)
    if m == 0 or np.all(b >= 0):
        return np.zeros(m), 0
    scale = max(1.0, float(np.abs(A).max()), float(np.abs(b).max()))
    if method == "enumerate":
        if m > 12:
            raise ValueError(f"method='enumerate' is for m <= 12 contacts, got m = {m}; use 'lemke'")
        for k in range(1, m + 1):
            for S in combinations(range(m), k):
                S = list(S)
                f = np.zeros(m)
                f[S] = np.linalg.lstsq(A[np.ix_(S, S)], -b[S], rcond=None)[0]
                w = A @ f + b
                if f.min() >= -tol * scale and w.min() >= -1e-9 * scale:
                    return np.maximum(f, 0.0), k
        raise InfeasibleContact("enumerate", "no active set", detail="no complementary solution found")
    if method != "lemke":
        raise ValueError(f"LCP method must be 'lemke' or 'enumerate', got {method!r}")
    T = np.hstack([np.eye(m), -A, -np.ones((m, 1)), b[:, None]])
    basis = list(range(m))
    z0 = 2 * m

    def pivot(r: int, col: int) -> None:
        T[r] /= T[r, col]
        others = np.arange(m) != r
        T[others] -= np.outer(T[others, col], T[r])

    r = int(np.argmin(b))
    pivot(r, z0)
    leaving, basis[r] = basis[r], z0
    for it in range(1, (max_iter or 50 * (m + 1)) + 1):
        entering = leaving + m if leaving < m else leaving - m
        col = T[:, entering]
        ok = col > tol * scale
        if not ok.any():
            raise InfeasibleContact("lemke", "ray termination", detail=f"after {it} pivots")
        ratios = np.where(ok, T[:, -1] / np.where(ok, col, 1.0), np.inf)
        rmin = ratios.min()
        ties = np.flatnonzero(ratios <= rmin + 1e-12 * max(1.0, abs(rmin)))
        r = next((int(i) for i in ties if basis[i] == z0), -1)     # let z0 leave when it can
        if r < 0:      # lexicographic rule on the rows of B⁻¹ (the tableau's w columns): no cycling
            cand = ties
            for j in range(m):
                if len(cand) == 1:
                    break
                v = T[cand, j] / col[cand]
                cand = cand[v <= v.min() + 1e-12 * max(1.0, abs(v.min()))]
            r = int(cand[0])
        pivot(r, entering)
        leaving, basis[r] = basis[r], entering
        if leaving == z0:
            f = np.zeros(m)
            for i, var in enumerate(basis):
                if m <= var < 2 * m:
                    f[var - m] = max(T[i, -1], 0.0)
            return f, it
    raise ConvergenceError("lemke", it, float("nan"), tol, detail="pivot cap reached (cycling?)")


def _delassus(bodies, c: Contacts, rows: np.ndarray, dirs: np.ndarray) -> np.ndarray:
    """A = G W Gᵀ for impulse rows along ``dirs`` (k, 3) at contacts ``rows`` (k,) (J W Jᵀ, not formed)."""
    ra, rb = c.point - bodies.x[c.a], c.point - bodies.x[c.b]
    ia, ib = c.a[rows], c.b[rows]
    ends = [(ia, dirs, np.cross(ra[rows], dirs)), (ib, -dirs, -np.cross(rb[rows], dirs))]
    A = np.zeros((len(rows), len(rows)))
    for bi, li, ai in ends:
        for bj, lj, aj in ends:
            same = bi[:, None] == bj[None, :]
            lin = bodies.inv_mass[bi][:, None] * (li @ lj.T)
            ang = np.einsum("ik,ikl,jl->ij", ai, bodies.inv_I[bi], aj)
            A += np.where(same, lin + ang, 0.0)
    return A


def _normal_lcp(bodies, c: Contacts) -> np.ndarray:
    """A = [n_iᵀ K_ij n_j] for all contact pairs sharing a body (the Delassus matrix J W Jᵀ)."""
    return _delassus(bodies, c, np.arange(c.m), c.normal)


def _tangents(n: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Orthonormal tangents t1, t2 (m, 3) of unit normals n (m, 3)."""
    a = np.where(np.abs(n[:, :1]) < 0.9, [[1.0, 0.0, 0.0]], [[0.0, 1.0, 0.0]])
    t1 = np.cross(n, a)
    t1 /= np.linalg.norm(t1, axis=1)[:, None]
    return t1, np.cross(n, t1)


def _friction_lcp(bodies, c: Contacts, u0: np.ndarray, b_n: np.ndarray, mu: float, lcp: str, d: int = 8):
    """Normal and friction impulses together: the pyramidal-cone LCP (Stewart & Trinkle 1996).

    Unknowns f (m) normal, β (m·d) along the d cone edges, λ (m) sliding speeds:
    w_n = A_nn f + A_nD β + b_n ⊥ f;  w_D = A_Dn f + A_DD β + E λ + D u⁻ ⊥ β;  μ f − Eᵀβ ⊥ λ.
    """
    m = c.m
    t1, t2 = _tangents(c.normal)
    th = 2 * np.pi * np.arange(d) / d
    dirs_t = (np.cos(th)[None, :, None] * t1[:, None, :] + np.sin(th)[None, :, None] * t2[:, None, :]).reshape(-1, 3)
    rows_t = np.repeat(np.arange(m), d)
    A = _delassus(bodies, c, np.concatenate([np.arange(m), rows_t]), np.concatenate([c.normal, dirs_t]))
    E = np.zeros((m * d, m))
    E[np.arange(m * d), rows_t] = 1.0
    k = m + m * d
    M = np.zeros((k + m, k + m))
    M[:k, :k] = A
    M[m:k, k:] = E
    M[k:, :m] = mu * np.eye(m)
    M[k:, m:k] = -E.T
    q = np.concatenate([b_n, np.einsum("ij,ij->i", dirs_t, u0[rows_t]), np.zeros(m)])
    try:
        z, its = solve_lcp_small(M, q, method=lcp)
    except (InfeasibleContact, ConvergenceError):      # a degenerate tiny pivot: retry accepting it
        z, its = solve_lcp_small(M, q, method=lcp, tol=1e-15)
    f, beta, lam = z[:m], z[m:k], z[k:]
    J = f[:, None] * c.normal + np.add.reduceat(beta[:, None] * dirs_t, np.arange(0, m * d, d), axis=0)
    w = M @ z + q
    residual = float(np.max(np.abs(z - np.maximum(0.0, z - w))))
    if residual > 1e-8 * max(1.0, float(np.abs(q).max())):
        raise InfeasibleContact("lemke", "inaccurate", residual, detail="friction LCP; use friction_model='staggered'")
    return f, J, (f > 0) & (lam <= 1e-12 * max(1.0, float(np.abs(u0).max()))), its, residual
