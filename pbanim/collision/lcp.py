"""Small dense complementarity problems of collision impulses (chapter 06, part of :mod:`pbanim.collision`).

The simultaneous impulses solve the LCP  w = A f + b ≥ 0,  f ≥ 0,  fᵀw = 0  with the Delassus matrix
A = J W Jᵀ (W = M⁻¹): row i of J maps body velocities to the relative velocity of contact i along its
direction. Frictionless: one row per contact along n. With friction, the pyramidal-cone LCP of Stewart &
Trinkle (1996) adds d edge directions per contact and a sliding speed λ per contact:

    [w_n]   [A_nn  A_nD  0 ] [f]   [b_n ]
    [w_D] = [A_Dn  A_DD  E ] [β] + [D u⁻]   ≥ 0,  ⊥ (f, β, λ) ≥ 0.
    [ ζ ]   [ μ𝟙   −Eᵀ   0 ] [λ]   [ 0  ]

Nothing is solved or assembled here twice: the matrix is :func:`pbanim.lcp.delassus` on the contact
rows [d, r × d] with the blocks W = diag(1/m 𝟙, I⁻¹), the tangents are :func:`pbanim.geometry.cone_edges`
(the frame the contact chapter's friction cones use), and the solvers are the LCP core's: Lemke's
complementary pivoting with a lexicographic ratio test (:func:`pbanim.lcp.solve_lcp`, which also
polishes the answer on its active set and certifies it by the natural-map residual), and enumeration of
active sets (:func:`pbanim.lcp.enumerate_active_sets`, the readable O(2ᵐ) check).

References: Cottle, Pang & Stone, *The Linear Complementarity Problem* (1992) §4.4 (Lemke);
Stewart & Trinkle, IJNME 39 (1996); Anitescu & Potra, Nonlinear Dynamics 14 (1997).
"""

from __future__ import annotations

import numpy as np

from .shapes import Contacts
from ..contracts import Array, Choice, Int, Opt, Real, contract
from ..errors import ConvergenceError, InfeasibleContact
from ..geometry import cone_edges
from ..lcp import delassus, enumerate_active_sets, solve_lcp
from ..results import natural_map_residual

__all__ = ["solve_lcp_small"]


@contract(A=Array(("m", "m"), empty=True), b=Array(("m",), empty=True), method=Choice(("lemke", "enumerate")), max_iter=Opt(Int(ge=1)),
          tol=Real(gt=0, lt=1))
def solve_lcp_small(A, b, method: str = "lemke", max_iter: int | None = None, tol: float = 1e-12):
    """Solve w = A f + b ≥ 0, f ≥ 0, fᵀw = 0 for a small dense A (collision impulses).

    ``"lemke"``: :func:`pbanim.lcp.solve_lcp` with ``solver="lemke"`` (complementary pivoting with the
    lexicographic ratio test against cycling; terminates for the positive semidefinite A = J W Jᵀ of a
    feasible contact problem), accepted when its natural-map residual is at most
    :func:`pbanim.lcp.residual_threshold` with ``tol``. ``"enumerate"``: try every active set S,
    f_S = −A_SS⁺ b_S (least squares), the readable O(2ᵐ) check for m ≤ 12 (``tol``: the sign tolerance).
    ``max_iter`` caps Lemke's pivots (default 50 (m + 1) + 1000).
    Returns ``(f, iterations)``; raises :class:`InfeasibleContact` on ray termination or an answer that
    does not certify, :class:`ConvergenceError` at the pivot cap.

    >>> f, it = solve_lcp_small(np.array([[2.0, -1.0], [-1.0, 2.0]]), np.array([-2.0, 0.0]))
    >>> f.round(12)
    array([1.33333333, 0.66666667])
    """
    A, b = np.asarray(A, float), np.asarray(b, float)
    m = len(b)
    if m == 0 or np.all(b >= 0):
        return np.zeros(m), 0
    if method == "enumerate":
        f, status, size = enumerate_active_sets(A, b, tol=tol)
        if status != "solved":
            raise InfeasibleContact("enumerate", status, detail="no complementary solution found")
        return f, size
    sol = solve_lcp(A, b, "lemke", tol=tol, raise_on_failure=False, max_iter=max_iter)
    if sol.status == "max_iter":
        raise ConvergenceError("lemke", sol.iterations, sol.residual, tol, detail="pivot cap reached (cycling?)")
    if not sol.success:
        raise InfeasibleContact("lemke", "ray termination" if sol.status == "ray" else sol.status, sol.residual,
                                detail=f"after {sol.iterations} pivots")
    return sol.f, sol.iterations


def _delassus(bodies, c: Contacts, rows: np.ndarray, dirs: np.ndarray) -> np.ndarray:
    """A = G W Gᵀ for impulse rows along ``dirs`` (k, 3) at contacts ``rows`` (k,) (J W Jᵀ, not formed)."""
    ra, rb = c.point[rows] - bodies.x[c.a[rows]], c.point[rows] - bodies.x[c.b[rows]]
    Wb = np.zeros((len(bodies.inv_mass), 6, 6))
    Wb[:, :3, :3] = bodies.inv_mass[:, None, None] * np.eye(3)
    Wb[:, 3:, 3:] = bodies.inv_I
    ia, ib = c.a[rows], c.b[rows]
    return delassus(ia, ib, np.hstack([dirs, np.cross(ra, dirs)]), np.hstack([dirs, np.cross(rb, dirs)]), Wb)


def _normal_lcp(bodies, c: Contacts) -> np.ndarray:
    """A = [n_iᵀ K_ij n_j] for all contact pairs sharing a body (the Delassus matrix J W Jᵀ)."""
    return _delassus(bodies, c, np.arange(c.m), c.normal)


def _friction_lcp(bodies, c: Contacts, u0: np.ndarray, b_n: np.ndarray, mu: float, lcp: str, d: int = 8):
    """Normal and friction impulses together: the pyramidal-cone LCP (Stewart & Trinkle 1996).

    Unknowns f (m) normal, β (m·d) along the d cone edges, λ (m) sliding speeds:
    w_n = A_nn f + A_nD β + b_n ⊥ f;  w_D = A_Dn f + A_DD β + E λ + D u⁻ ⊥ β;  μ f − Eᵀβ ⊥ λ.
    """
    m = c.m
    dirs_t = cone_edges(c.normal, d).reshape(-1, 3)
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
        z, its = solve_lcp_small(M, q, method=lcp, tol=1e-8)
    except InfeasibleContact as exc:
        raise InfeasibleContact(exc.solver, exc.status, exc.residual,
                                detail="friction LCP; use friction_model='staggered'") from None
    f, beta, lam = z[:m], z[m:k], z[k:]
    J = f[:, None] * c.normal + np.add.reduceat(beta[:, None] * dirs_t, np.arange(0, m * d, d), axis=0)
    residual = natural_map_residual(z, M @ z + q)
    return f, J, (f > 0) & (lam <= 1e-12 * max(1.0, float(np.abs(u0).max()))), its, residual
