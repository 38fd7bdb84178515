"""Colored Gauss–Seidel for box friction without the Delassus matrix: sweeps on the bodies' velocities
(chapter 07, large scenes; issue 28 point 4).

A pile of 1000 spheres has some 3000 contacts, 9000 rows: a dense A = J W Jᵀ would hold 8·10⁷ numbers,
nearly all zero (Aᵢⱼ ≠ 0 only where contacts i and j share a body). The sweep of
:func:`pbanim.lcp.colored.pgs_box_friction_colored` needs only two things from A: its diagonal, and w = A z + b
kept up to date. With the generalized velocities u = ũ + W Jᵀ z carried along,

    w_r = J_r u + β_r,                 (b = J ũ + β: A z + b = J (ũ + W Jᵀ z) + β)
    z_r ← proj(z_r − w_r / A_rr),      A_rr = J_r W J_rᵀ = G_a,r·W_a G_a,r + G_b,r·W_b G_b,r,
    u_a ← u_a + W_a G_a,r Δz_r,   u_b ← u_b − W_b G_b,r Δz_r,

which costs O(1) per row and O(m) per sweep, and stores O(m) numbers. The rows of one color share no moving
body, so they are updated at once exactly as the colored sweep does (the world's W block is zero: its u stays
zero, however many rows of a color touch it). In exact arithmetic the iterates are those of the colored sweep
on A (same order, same projections); in floating point they agree to roundoff (``tests/test_lcp_rows.py``,
ORACLES D16).

=========  ===============  ===========  ==================================================
symbol     code             shape        meaning
=========  ===============  ===========  ==================================================
z          ``z``            (3m,)        impulses [f₁, τ₁₁, τ₁₂, f₂, …]
G_a, G_b   ``Ga, Gb``       (3m, d)      row r is G_a,r on body a_r and −G_b,r on b_r
W          ``Wb``           (n, d, d)    inverse-mass blocks (the world's zero)
ũ, u       ``u_free, u``    (n, d)       free and current generalized velocities
β          ``bias``         (3m,)        s⁺/h on the normal rows, 0 on the tangents
=========  ===============  ===========  ==================================================

Limiting cases: no contact shares a body → one color, one sweep is exact for each decoupled contact's
normal row; μ = 0 → the tangential rows stay zero.

References: E. Catto, "Iterative dynamics with temporal coherence", GDC 2005 (sequential impulses on
velocities); R. Tonge et al., SIGGRAPH 2012 (graph coloring of contact solves).
"""

from __future__ import annotations

import numpy as np

from .box import _box_residual, _scale, _warm_impulses
from ..contracts import Array, Int, Opt, Real, Seq, contract
from ..errors import InvalidInput

__all__ = ["pgs_box_friction_rows", "delassus_diagonal"]

_BLOCKS = Array(("n", "d", "d"))


@contract(a=Array(("r",), ge=0), b=Array(("r",), ge=0), Ga=Array(("r", "d")), Gb=Array(("r", "d")), Wb=_BLOCKS)
def delassus_diagonal(a, b, Ga, Gb, Wb) -> np.ndarray:
    """A_rr = G_a,r·W_a G_a,r + G_b,r·W_b G_b,r for every row r (the diagonal of J W Jᵀ, a ≠ b).

    >>> Wb = np.array([0.5, 0.0])[:, None, None] * np.eye(3)
    >>> delassus_diagonal(np.array([0]), np.array([1]), np.array([[0.0, 0, 1]]), np.array([[0.0, 0, 1]]), Wb)
    array([0.5])
    """
    a, b = np.asarray(a, dtype=np.intp), np.asarray(b, dtype=np.intp)
    WGa = np.einsum("rij,rj->ri", Wb[a], Ga)
    WGb = np.einsum("rij,rj->ri", Wb[b], Gb)
    return np.einsum("ri,ri->r", Ga, WGa) + np.einsum("ri,ri->r", Gb, WGb)


def _rows(env) -> int:
    return np.size(env.values["bias"])


@contract(a=Array((_rows,), ge=0, empty=True), b=Array((_rows,), ge=0, empty=True), Ga=Array((_rows, "d"), empty=True),
          Gb=Array((_rows, "d"), empty=True), Wb=_BLOCKS, u_free=Array(("n", "d")), bias=Array((None,), empty=True),
          mu=Array((None,), ge=0, scalar=True, empty=True), colors=Seq(Array((None,), ge=0, empty=True)),
          max_iter=Int(ge=1), tol=Real(gt=0, lt=1), warm_start=Opt(Array((_rows,), empty=True)))
def pgs_box_friction_rows(a, b, Ga, Gb, Wb, u_free, bias, mu, colors, *, max_iter: int = 300, tol: float = 1e-8,
                          warm_start=None) -> tuple:
    """Colored projected Gauss–Seidel for box friction on the bodies' velocities (module docstring).

    Rows come in threes per contact (normal, t₁, t₂; both ends the same bodies); ``a``, ``b`` are padded body
    indices (the world's block of ``Wb`` zero), ``colors`` a partition of the contacts into sets that share no
    moving body (:func:`pbanim.lcp.colored.colors_by_bodies`). Returns (z, residual, sweeps, u): the box-friction
    residual of w = J u + β (the conditions of :func:`pbanim.lcp.solve.pgs_box_friction`), and u = ũ + W Jᵀ z,
    the velocities after the impulses. Stops when the residual ≤ tol·max(1, ‖b‖∞), b = J ũ + β.
    """
    a, b = np.asarray(a, dtype=np.intp), np.asarray(b, dtype=np.intp)
    n = a.size
    if n % 3 or b.size != n:
        raise InvalidInput(f"pgs_box_friction_rows needs 3 rows per contact (normal, two tangents), got {n} rows")
    m = n // 3
    mu = np.broadcast_to(np.asarray(mu, dtype=float), (m,))
    if any(np.any(np.asarray(K) >= m) for K in colors):
        raise InvalidInput(f"colors must hold contact indices below m = {m}")
    WGa = np.einsum("rij,rj->ri", Wb[a], Ga)
    WGb = np.einsum("rij,rj->ri", Wb[b], Gb)
    d = Ga.shape[1]
    ga3, gb3, wga3, wgb3 = (M.reshape(m, 3, d) for M in (Ga, Gb, WGa, WGb))
    C = np.einsum("cjd,ckd->cjk", ga3, wga3) + np.einsum("cjd,ckd->cjk", gb3, wgb3)   # A's 3 × 3 diagonal blocks
    diag = C[:, [0, 1, 2], [0, 1, 2]].ravel()
    if np.any(diag <= 0):
        raise InvalidInput("pgs_box_friction_rows needs rows with a positive diagonal J W Jᵀ (a moving body)")
    inv3 = (1.0 / diag).reshape(m, 3)
    z = _warm_impulses(warm_start, n, mu)
    u = np.array(u_free, dtype=float)
    Jv = lambda uu: np.einsum("ri,ri->r", Ga, uu[a]) - np.einsum("ri,ri->r", Gb, uu[b])  # noqa: E731
    thresh = tol * _scale(Jv(u) + bias)
    if np.any(z):
        np.add.at(u, a, WGa * z[:, None])
        np.add.at(u, b, -WGb * z[:, None])
    z3, bias3, ac, bc = z.reshape(m, 3), np.reshape(bias, (m, 3)), a[0::3], b[0::3]
    # per color, gathered once: both ends of its contacts (a then b: a live body appears once in a color), their
    # rows ±G and ±W G, A's diagonal-block couplings, 1/A_rr, β and μ; dz a buffer for the color's updates
    plan = []
    for K in colors:
        K = np.asarray(K, dtype=np.intp)
        k = K.size
        G2 = np.concatenate([ga3[K], -gb3[K]])                                  # (2k, 3, d): a's rows, then b's
        W2T = np.ascontiguousarray(np.swapaxes(np.concatenate([wga3[K], -wgb3[K]]), 1, 2))   # (2k, d, 3)
        plan.append((K, k, np.concatenate([ac[K], bc[K]]), G2, W2T, C[K, 1, 0], C[K, 2, 0], C[K, 2, 1],
                     inv3[K, 0], inv3[K, 1], inv3[K, 2], bias3[K], mu[K], np.empty((2 * k, 3, 1))))
    for sweep in range(1, int(max_iter) + 1):
        for K, k, ends, G2, W2T, c10, c20, c21, i0, i1, i2, beta, muK, dz in plan:
            # w of the color's three rows from u; then normal, t₁, t₂ in turn, each w moved by the updates before
            # it through A's diagonal block (the rows of one contact share its two bodies): the row-by-row sweep
            w2 = G2 @ u[ends][:, :, None]
            w = w2[:k, :, 0] + w2[k:, :, 0] + beta
            old = z3[K]
            f = np.maximum(old[:, 0] - w[:, 0] * i0, 0.0)
            dz[:k, 0, 0] = d0 = f - old[:, 0]
            lim = muK * f
            t1 = np.minimum(np.maximum(old[:, 1] - (w[:, 1] + c10 * d0) * i1, -lim), lim)
            dz[:k, 1, 0] = d1 = t1 - old[:, 1]
            t2 = np.minimum(np.maximum(old[:, 2] - (w[:, 2] + c20 * d0 + c21 * d1) * i2, -lim), lim)
            dz[:k, 2, 0] = t2 - old[:, 2]
            dz[k:] = dz[:k]
            z3[K] = old + dz[:k, :, 0]
            u[ends] += (W2T @ dz)[:, :, 0]
        res = _box_residual(z, Jv(u) + bias, mu)
        if res <= thresh:
            return z, res, sweep, u
    return z, _box_residual(z, Jv(u) + bias, mu), int(max_iter), u
