"""The lean twin of one body's free-flight derivative f(y) (chapter 10; part of :mod:`pbanim.design`): the
state-only RK4 step of S(t, u) (:func:`pbanim.design.flight.plain_step`, the finite differences' and the event
location's step) on Python floats.

For N = 1 :func:`pbanim.design.flight.flight_rhs` is a handful of products on 13 numbers, and numpy's
per-call cost dominates it (the quaternion's matrix, two 3 × 3 products by ``einsum``, q̇ = ½ Ξ(q) ω, three
``concatenate``). The lean f takes the same products in the same order on floats:

    R = R(q) with s = 2/|q|²,   L_b = Rᵀ L,   ω = R (I⁻¹ ∘ L_b),   q̇ = ½ (−ω·v, s_q ω + ω × v),
    ẋ = W P,   Ṗ = m g,   L̇ = 0,

where numpy's own summation orders are copied, so the result is the readable f bit for bit on the builds
that sum as this one does (|q|² = (w² + y²) + (x² + z²), the pairs of its two-lane loop; R (I⁻¹ ∘ L_b) row by
row as (a₀ + a₂) + a₁; Rᵀ L and ω·v left to right). Where a build sums otherwise the two differ by a few ulps
(the test's bound, ORACLES H10). A derivative that overflows is returned as the readable f returns it inside
the package (the same inf and NaN entries), for the run's finiteness check to name.

==========  ==============  ========  ===========================================
symbol      code            shape     meaning
==========  ==============  ========  ===========================================
y           ``y``           (13,)     [x, q, P, L] of the one body
W, m        ``W, m``        scalars   inverse mass, mass
I⁻¹         ``I0, I1, I2``  scalars   inverse principal moments (body frame)
==========  ==============  ========  ===========================================

Limiting cases: L = 0 gives ω = 0 and q̇ = 0; a cube (equal I⁻¹) has ω = I⁻¹ L.

References: Baraff, SIGGRAPH 1997 notes (q̇ = ½ ω q, the state layout); Popović et al. SIGGRAPH 2000 §4.
"""

from __future__ import annotations

import numpy as np

__all__: list = []


def one_body_rhs(model):
    """f(t, y) of :func:`~pbanim.design.flight.flight_rhs` for a one-body model on floats (module docstring),
    made once per model and kept on it; None when the model has more than one body."""
    if model.N != 1:
        return None
    f = model.__dict__.get("_lean_rhs")
    if f is None:
        f = model.__dict__["_lean_rhs"] = _make_rhs(model)
    return f


def _rotation(w, x, y, z):
    """R(q) row-major on floats, the products of :func:`pbanim.rigid.quat_to_matrix` with |q|² summed as numpy sums
    the four squares ((w² + y²) + (x² + z²), pairwise), so that the runs are bit for bit the readable ones."""
    s = 2.0 / ((w * w + y * y) + (x * x + z * z))
    xx, yy, zz = s * x * x, s * y * y, s * z * z
    xy, xz, yz = s * x * y, s * x * z, s * y * z
    wx, wy, wz = s * w * x, s * w * y, s * w * z
    return (1.0 - yy - zz, xy - wz, xz + wy, xy + wz, 1.0 - xx - zz, yz - wx, xz - wy, yz + wx, 1.0 - xx - yy)


def _make_rhs(model):
    W, m = float(model.W[0]), float(model.m[0])
    I0, I1, I2 = (float(v) for v in model.Iinv[0])
    g0, g1, g2 = (m * float(v) for v in model.g)

    def f(t, y):
        x0, x1, x2, w, x, yy, z, P0, P1, P2, L0, L1, L2 = y.tolist()
        R00, R01, R02, R10, R11, R12, R20, R21, R22 = _rotation(w, x, yy, z)
        c0 = I0 * (R00 * L0 + R10 * L1 + R20 * L2)
        c1 = I1 * (R01 * L0 + R11 * L1 + R21 * L2)
        c2 = I2 * (R02 * L0 + R12 * L1 + R22 * L2)
        o0 = (R00 * c0 + R02 * c2) + R01 * c1
        o1 = (R10 * c0 + R12 * c2) + R11 * c1
        o2 = (R20 * c0 + R22 * c2) + R21 * c1
        out = [W * P0, W * P1, W * P2, 0.5 * -(o0 * x + o1 * yy + o2 * z), 0.5 * (w * o0 + (o1 * z - o2 * yy)),
               0.5 * (w * o1 + (o2 * x - o0 * z)), 0.5 * (w * o2 + (o0 * yy - o1 * x)), g0, g1, g2, 0.0, 0.0, 0.0]
        return np.array(out)

    return f


def one_body_gaps(feat, model, normals):
    """(gaps(y), rates(y, G)) of one body's plane features on floats, or None (more bodies, a sphere pair):

    gaps: g_f = n_f·(x + R s_f − o_f) − r_f, :func:`pbanim.design.impact.gaps` with numpy's orders copied (R s_f
    and the dot product each summed as (a₀ + a₂) + a₁), bit for bit on the builds that sum as this one does;
    rates: ġ_f = n_f·(v + ω × R s_f), ω = R I⁻¹ Rᵀ L, the first half of :func:`pbanim.design.rest.gap_rates`
    (the body's own acceleration G is not read: ġ does not depend on it) to a few ulps — its only reader is
    the event search's decision whether a gap dips inside a step (ORACLES H10)."""
    if model.N != 1 or len(feat.pairs) or feat.n_plane == 0:
        return None
    rows = []
    for k in range(feat.n_plane):
        n = [float(v) for v in normals[feat.plane[k]]]
        o = [float(v) for v in feat.anchors[feat.plane[k]]]
        rows.append((*[float(v) for v in feat.off[k]], *n, *o, float(feat.rad[k])))
    W = float(model.W[0])
    I0, I1, I2 = (float(v) for v in model.Iinv[0])

    def frame(y):
        x0, x1, x2, w, x, yy, z = y[:7].tolist()
        return x0, x1, x2, _rotation(w, x, yy, z)

    def gaps(y):
        x0, x1, x2, (R00, R01, R02, R10, R11, R12, R20, R21, R22) = frame(y)
        out = []
        for s0, s1, s2, n0, n1, n2, o0, o1, o2, r in rows:
            d0 = x0 + ((R00 * s0 + R02 * s2) + R01 * s1) - o0
            d1 = x1 + ((R10 * s0 + R12 * s2) + R11 * s1) - o1
            d2 = x2 + ((R20 * s0 + R22 * s2) + R21 * s1) - o2
            out.append((n0 * d0 + n2 * d2) + n1 * d1 - r)
        return np.array(out)

    def rates(y):
        _, _, _, (R00, R01, R02, R10, R11, R12, R20, R21, R22) = frame(y)
        P0, P1, P2, L0, L1, L2 = y[7:13].tolist()
        b0 = I0 * (R00 * L0 + R10 * L1 + R20 * L2)           # ω = R (I⁻¹ ∘ Rᵀ L)
        b1 = I1 * (R01 * L0 + R11 * L1 + R21 * L2)
        b2 = I2 * (R02 * L0 + R12 * L1 + R22 * L2)
        w0, w1, w2 = R00 * b0 + R01 * b1 + R02 * b2, R10 * b0 + R11 * b1 + R12 * b2, R20 * b0 + R21 * b1 + R22 * b2
        v0, v1, v2 = W * P0, W * P1, W * P2
        out = []
        for s0, s1, s2, n0, n1, n2, *_ in rows:
            a0, a1, a2 = R00 * s0 + R01 * s1 + R02 * s2, R10 * s0 + R11 * s1 + R12 * s2, R20 * s0 + R21 * s1 + R22 * s2
            out.append(n0 * (v0 + w1 * a2 - w2 * a1) + n1 * (v1 + w2 * a0 - w0 * a2) + n2 * (v2 + w0 * a1 - w1 * a0))
        return np.array(out)

    return gaps, rates
