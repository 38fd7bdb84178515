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
from scipy import sparse

from .box import _box_residual, _scale, _warm_impulses
from ..contracts import Array, Int, Opt, Real, Seq, contract
from ..errors import InvalidInput
from ..sparse_kernel import product_of   # scipy's kernel bound once: A @ x bit for bit

__all__ = ["pgs_box_friction_rows", "pgs_normal_rows", "delassus_diagonal"]

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


def _color_plan(colors, m):
    """Contacts in color order: the permutation, each color's [start, end) in it, and the contacts no color
    holds (kept at their first iterate, still in the residual)."""
    groups = [np.asarray(K, dtype=np.intp).ravel() for K in colors]
    if any(np.any(K >= m) for K in groups):
        raise InvalidInput(f"colors must hold contact indices below m = {m}")
    perm = np.concatenate(groups) if groups else np.zeros(0, np.intp)
    if perm.size and np.bincount(perm, minlength=m).max() > 1:
        raise InvalidInput("colors must not hold a contact twice (a partition of the contacts)")
    rest = np.setdiff1d(np.arange(m), perm, assume_unique=True)
    bounds = np.cumsum([0] + [K.size for K in groups])
    return np.concatenate([perm, rest]), list(zip(bounds[:-1], bounds[1:]))


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

    Work per sweep: per color, one sparse product J_K u (its 3k rows, 2d numbers each), the three row updates
    as numpy operations on the color's k contacts, one sparse product u += (W Jᵀ)_K Δz_K; the contacts are
    kept in color order so that a color is a contiguous slice (no gather or scatter in the sweep).
    """
    a, b = np.asarray(a, dtype=np.intp), np.asarray(b, dtype=np.intp)
    n = a.size
    if n % 3 or b.size != n:
        raise InvalidInput(f"pgs_box_friction_rows needs 3 rows per contact (normal, two tangents), got {n} rows")
    m = n // 3
    mu = np.broadcast_to(np.asarray(mu, dtype=float), (m,))
    perm, spans = _color_plan(colors, m)
    nb, d = np.shape(u_free)
    Ga, Gb = np.asarray(Ga, dtype=float), np.asarray(Gb, dtype=float)
    WGa = (Wb[a] @ Ga[:, :, None])[:, :, 0]
    WGb = (Wb[b] @ Gb[:, :, None])[:, :, 0]
    ga3, gb3, wga3, wgb3 = (M.reshape(m, 3, d)[perm] for M in (Ga, Gb, WGa, WGb))     # in color order
    C = lambda j, k: np.einsum("cd,cd->c", ga3[:, j], wga3[:, k]) + np.einsum("cd,cd->c", gb3[:, j], wgb3[:, k])  # noqa: E731
    diag = np.stack([C(0, 0), C(1, 1), C(2, 2)], axis=1)                           # A's diagonal, (m, 3)
    if np.any(diag <= 0):
        raise InvalidInput("pgs_box_friction_rows needs rows with a positive diagonal J W Jᵀ (a moving body)")
    inv = 1.0 / diag
    c10, c20, c21 = C(1, 0), C(2, 0), C(2, 1)                                      # A's diagonal-block couplings
    ac, bc = a[0::3][perm], b[0::3][perm]
    J, plan, (dataM, cols, ptr) = _color_matrices(ac, bc, ga3, gb3, wga3, wgb3, spans, nb, d)
    zp = _warm_impulses(None if warm_start is None else np.reshape(warm_start, (m, 3))[perm].ravel(), n, mu[perm])
    z3, mup = zp.reshape(m, 3), mu[perm]
    beta = np.reshape(bias, (m, 3))[perm]
    betaf = beta.ravel()
    u = np.array(u_free, dtype=float).ravel()
    Ju = np.empty(n)
    thresh = tol * _scale(J(u, Ju) + betaf)
    if np.any(zp):
        u += _transpose_product(dataM, cols, ptr, zp, nb * d)
    # per color, its slices of the contact arrays, as views bound once (the sweep below only reads them)
    views = [(JK, MK, np.empty(3 * (e - s)), beta[s:e], z3[s:e], inv[s:e, 0], inv[s:e, 1],
              inv[s:e, 2], mup[s:e], c10[s:e], c20[s:e], c21[s:e], np.empty((e - s, 3))) for (s, e, JK, MK) in plan]
    du = np.empty(nb * d)
    sweeps, res = 0, np.inf
    for sweeps in range(1, int(max_iter) + 1):
        for JK, MK, wK, bK, old, i0, i1, i2, muK, k10, k20, k21, dz in views:
            # w of the color's rows from u; then normal, t₁, t₂ in turn, each w moved by the updates before it
            # through A's diagonal block (the rows of one contact share its two bodies): the row-by-row sweep
            w = JK(u, wK).reshape(-1, 3)
            w += bK
            f = np.maximum(old[:, 0] - w[:, 0] * i0, 0.0)
            d0 = np.subtract(f, old[:, 0], out=dz[:, 0])
            lim = muK * f
            t1 = np.minimum(np.maximum(old[:, 1] - (w[:, 1] + k10 * d0) * i1, -lim), lim)
            d1 = np.subtract(t1, old[:, 1], out=dz[:, 1])
            t2 = np.minimum(np.maximum(old[:, 2] - (w[:, 2] + k20 * d0 + k21 * d1) * i2, -lim), lim)
            np.subtract(t2, old[:, 2], out=dz[:, 2])
            old += dz
            u += MK(dz.ravel(), du)
        res = _box_residual(zp, J(u, Ju) + betaf, mup)
        if res <= thresh:
            break
    z = np.empty(n)
    z.reshape(m, 3)[perm] = z3
    return z, res, sweeps, u.reshape(nb, d)


@contract(a=Array((_rows,), ge=0, empty=True), b=Array((_rows,), ge=0, empty=True), Ga=Array((_rows, "d"), empty=True),
          Gb=Array((_rows, "d"), empty=True), Wb=_BLOCKS, bias=Array((None,), empty=True),
          colors=Seq(Array((None,), ge=0, empty=True)), max_iter=Int(ge=1), tol=Real(gt=0))
def pgs_normal_rows(a, b, Ga, Gb, Wb, bias, colors, *, max_iter: int = 100, tol: float = 1e-8) -> tuple:
    """Colored projected Gauss–Seidel on one row per contact (the normals), from v = 0, on the bodies' velocities:

        0 ≤ pᵢ ⊥ wᵢ = J_i v + βᵢ ≥ 0,   v = W Jᵀ p,

    the sweep of :func:`pgs_box_friction_rows` without its tangents (the same color plan and sparse products).
    It serves the position correction of large contact scenes (:mod:`pbanim.contact.split`): β is a predicted
    separation over h and v a pseudo-velocity. ``tol`` is absolute, in β's units: stops when the natural-map
    residual max |min(pᵢ, wᵢ)| ≤ tol. Returns (p, residual, sweeps, v (n, d)); no row with β < 0: p = 0 at once.

    >>> Wb = np.array([1.0, 0.0])[:, None, None] * np.eye(3)      # one unit mass on the ground (the world's W = 0)
    >>> p, res, sweeps, v = pgs_normal_rows([0], [1], [[0.0, 0, 1]], [[0.0, 0, 1]], Wb, [-0.5], [[0]])
    >>> float(p[0]), v[0].tolist(), sweeps                          # pushed out at 0.5 m/s: w = 0
    (0.5, [0.0, 0.0, 0.5], 1)
    """
    a, b = np.asarray(a, dtype=np.intp), np.asarray(b, dtype=np.intp)
    m = a.size
    nb, d = Wb.shape[0], np.shape(Ga)[1]
    beta = np.asarray(bias, dtype=float)
    if beta.shape != (m,):
        raise InvalidInput(f"pgs_normal_rows needs one bias per row ({m}), got shape {beta.shape}")
    v = np.zeros(nb * d)
    if not np.any(beta < 0):
        return np.zeros(m), 0.0, 0, v.reshape(nb, d)
    perm, spans = _color_plan(colors, m)
    Ga, Gb = np.asarray(Ga, dtype=float), np.asarray(Gb, dtype=float)
    WGa = (Wb[a] @ Ga[:, :, None])[:, :, 0]
    WGb = (Wb[b] @ Gb[:, :, None])[:, :, 0]
    ga, gb, wga, wgb = (M[perm][:, None, :] for M in (Ga, Gb, WGa, WGb))
    diag = (np.einsum("cd,cd->c", ga[:, 0], wga[:, 0]) + np.einsum("cd,cd->c", gb[:, 0], wgb[:, 0]))
    if np.any(diag <= 0):
        raise InvalidInput("pgs_normal_rows needs rows with a positive diagonal J W Jᵀ (a moving body)")
    J, plan, _ = _color_matrices(a[perm], b[perm], ga, gb, wga, wgb, spans, nb, d)
    inv, bp, pp, Jv = 1.0 / diag, beta[perm], np.zeros(m), np.empty(m)
    views = [(JK, MK, np.empty(e - s), bp[s:e], pp[s:e], inv[s:e], np.empty(e - s))
             for (s, e, JK, MK) in plan]
    dv = np.empty(nb * d)
    sweeps, res = 0, np.inf
    for sweeps in range(1, int(max_iter) + 1):
        for JK, MK, wK, bK, pK, iK, dp in views:
            w = JK(v, wK)
            w += bK
            np.subtract(np.maximum(pK - w * iK, 0.0), pK, out=dp)
            pK += dp
            v += MK(dp, dv)
        res = float(np.max(np.abs(np.minimum(pp, J(v, Jv) + bp)), initial=0.0))
        if res <= tol:
            break
    p = np.empty(m)
    p[perm] = pp
    return p, res, sweeps, v.reshape(nb, d)


def _color_matrices(ac, bc, ga, gb, wga, wgb, spans, nb, d):
    """J and W Jᵀ as sparse matrices on u (nb·d,), the contacts in color order with k rows each (ga, gb, wga,
    wgb of shape (m, k, d)): row r of contact c holds G_a,r at a's d columns, −G_b,r at b's. Returns x ↦ J x,
    per color (start, end, x ↦ J_K x, x ↦ (W Jᵀ)_K x: :func:`pbanim.sparse_kernel.product_of` of the color's CSR
    and CSC slices), and the arrays of W Jᵀ (for the warm start's product)."""
    m, k = ga.shape[:2]
    w2 = 2 * d
    cols = np.repeat(np.concatenate([ac[:, None] * d + np.arange(d), bc[:, None] * d + np.arange(d)], axis=1), k, axis=0)
    dataJ = np.concatenate([ga, -gb], axis=2).reshape(-1)
    dataM = np.concatenate([wga, -wgb], axis=2).reshape(-1)
    itype = np.int32 if max(nb * d, k * m * w2) < 2 ** 31 else np.int64      # scipy's own index type: no copies
    cols, ptr = cols.reshape(-1).astype(itype), np.arange(0, k * m * w2 + 1, w2, dtype=itype)
    J = product_of("csr", (dataJ, cols, ptr), (k * m, nb * d))
    plan = []
    for s, e in spans:
        lo, hi, loc = k * s * w2, k * e * w2, ptr[:k * (e - s) + 1]
        JK = product_of("csr", (dataJ[lo:hi], cols[lo:hi], loc), (k * (e - s), nb * d))
        MK = product_of("csc", (dataM[lo:hi], cols[lo:hi], loc), (nb * d, k * (e - s)))
        plan.append((s, e, JK, MK))
    return J, plan, (dataM, cols, ptr)


def _transpose_product(dataM, cols, ptr, z, size):
    """(W Jᵀ) z for all rows (the warm start's velocities)."""
    return sparse.csc_matrix((dataM, cols, ptr), shape=(size, z.size)) @ z
