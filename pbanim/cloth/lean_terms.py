"""The lean twin of the large steps' element terms of the Baraff–Witkin cloth: f_e, K_e, D_e of every bend hinge
and every triangle in a few batched products (``Cloth._all`` with ``exact=False``).

Bend. The readable path (:meth:`pbanim.cloth.bend.BendCondition.evaluate` and
:func:`pbanim.cloth.conditions.element_terms`) builds ∇²θ (E, 9, 9) in the edge coordinates z = (e, a, b) from
a dozen (E, 9, 9) temporaries, maps it to the particles, Lᵀ∇²θ L (E, 12, 12), by two batched matrix products,
and then forms K_e = −(k GGᵀ + s ∂²C/∂x²) (s = k C + k_d Ċ, one component) and D_e = −k_d GGᵀ by einsums. Here
the same K_e is written in z,

    K_z = −(k g gᵀ + s ∇²θ),      K_e = Lᵀ K_z L,      D_e = Lᵀ D_z L,   D_z = −k_d g gᵀ,

and s ∇²θ (the formula of :mod:`pbanim.cloth.bend`) is split into what it is made of: four dense rank-one
terms u vᵀ (k g gᵀ, ∇S ∇Ccᵀ, ∇Cc ∇Sᵀ, ∇θ (2S∇S + 2Cc∇Cc)ᵀ: one batched product (E, 9, 4) @ (E, 4, 9)), the
terms of ∇|e| = (ê, 0, 0) on the row and the column block e, the outer products of the blocks of ∇²Cc,
multiples of I₃ on seven blocks and the skew blocks of ∇²T, added on block views. L = [[−1, 1, 0, 0],
[−1, 0, 1, 0], [−1, 0, 0, 1]] ⊗ I₃, so Lᵀ K_z L needs no product: the blocks of particles 1–3 are those of
K_z, those of particle 0 minus the sums of their rows and columns; :func:`bend_data` does not form the
(E, 12, 12) blocks at all: a fixed sparse map (nnz × 81E, four ±1 per entry of K_z) puts Lᵀ K_z L on the
pattern's data in one product.

Triangles. Stretch is a weighted spring on w_u (and w_v), shear a w_u·w_v, so their Hessians are Kronecker
products (:mod:`pbanim.cloth.conditions`) and the symmetric K_e of the large steps is

    K_e = −(Σ_m k_m G_m G_mᵀ + cu cuᵀ ⊗ α_u P_u + cv cvᵀ ⊗ α_v P_v + (cu cvᵀ + cv cuᵀ) ⊗ β 𝟙),

α = a s⁺/|w| (s clamped at 0), P = 𝟙 − ŵŵᵀ, β = a s: a batched product and three broadcasts instead of the
(E, 3, 9, 9) Hessians and their einsum (:func:`triangle_terms`).

The same numbers up to the order of the sums: equal to the readable terms to roundoff (ORACLES J14: within
64 ε of the largest entry of each array; the triangles' f_e bit for bit). ``cloth.lean_path = False`` or
``cloth.lean_terms = False`` takes the readable path; the exact K_e (with the unsymmetric damping term) is
always the readable one.

Limiting cases: as in :mod:`pbanim.cloth.bend` and :mod:`pbanim.cloth.conditions` (a degenerate hinge or
triangle gives NaN, named by the callers' checks).

References: Baraff & Witkin, "Large steps in cloth simulation", SIGGRAPH 1998, §4.2, §4.3, §5.2; Tamstorf &
Grinspun, "Discrete bending forces and their Jacobians", Graphical Models 75, 2013.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp

from .bend import _outer, _skew, _hinge_gradient
from .conditions import Conditions

__all__: list[str] = []      # internal: the lean twin of Cloth._all's bend and triangle terms


def _z_terms(cond, x, v):
    """(f_e (E, 12), K_z (E, 9, 9), D_z (E, 9, 9) or None): the symmetric K_e = Lᵀ K_z L, D_e = Lᵀ D_z L."""
    el = cond.elements
    E = len(el)
    h = _hinge_gradient(x[el])                                   # θ, ∇θ and their pieces (the readable ones)
    e, a, b, ee, ea, eb, ab, T, r = h.e, h.a, h.b, h.ee, h.ea, h.eb, h.ab, h.T, h.r
    S, Cc, theta = h.S, h.Cc, h.theta
    ehat, gT, gS, gC, R, g = h.ehat, h.gT, h.gS, h.gC, h.R, h.g
    k, kd = cond.k[:, 0], cond.kd[:, 0]
    damped = bool(np.any(kd))
    vz = (v[el[:, 1:]] - v[el[:, :1]]).reshape(E, 9)           # L v: the edge-coordinate velocities
    C = theta - cond.theta0
    s = k * C
    if damped:
        s = s + kd * np.einsum("ei,ei->e", g, vz)
    G = np.empty((E, 12))
    G[:, 3:] = g
    G[:, :3] = -(g[:, 0:3] + g[:, 3:6] + g[:, 6:9])
    fe = -s[:, None] * G
    with np.errstate(divide="ignore", invalid="ignore"):
        sR = s / R                                              # s ∇²θ = sR (Cc ∇²S − S ∇²Cc + …)
        sC, sS = sR * Cc, sR * S
        tr = sC * T / r                                         # Cc T ∇²|e| = (Cc T / r)(I − êêᵀ) on (e, e)
        # the dense u vᵀ terms: k g gᵀ + sR (∇S ∇Ccᵀ − ∇Cc ∇Sᵀ − ∇θ (2S∇S + 2Cc∇Cc)ᵀ)
        U, V = np.empty((E, 9, 4)), np.empty((E, 4, 9))
        U[:, :, 0], V[:, 0] = k[:, None] * g, g
        U[:, :, 1], V[:, 1] = sR[:, None] * gS, gC
        U[:, :, 2], V[:, 2] = -sR[:, None] * gC, gS
        U[:, :, 3], V[:, 3] = -sR[:, None] * g, 2.0 * (S[:, None] * gS + Cc[:, None] * gC)
        Kz = np.matmul(U, V)                                    # (E, 9, 9)
        # sC (∇T ∇|e|ᵀ + ∇|e| ∇Tᵀ): ∇|e| = (ê, 0, 0) reaches the column and the row block e
        Kz[:, :, 0:3] += (sC[:, None] * gT)[:, :, None] * ehat[:, None, :]
        Kz[:, 0:3, :] += (sC[:, None] * ehat)[:, :, None] * gT[:, None, :]
        B = Kz.reshape(E, 3, 3, 3, 3)                           # (E, row block, 3, column block, 3) over (e, a, b)
        ee_, ab_ = B[:, 0, :, 0, :], B[:, 1, :, 2, :]
        ee_ -= (tr[:, None] * ehat)[:, :, None] * ehat[:, None, :]
        # −S ∇²Cc, the outer products of its blocks (and their transposes below the diagonal)
        m = -sS[:, None, None]
        ee_ += m * (_outer(a, b) + _outer(b, a))
        eaB = m * (_outer(b, e) - 2.0 * _outer(e, b))
        ebB = m * (_outer(a, e) - 2.0 * _outer(e, a))
        abB = m * _outer(e, e)
        B[:, 0, :, 1, :] += eaB
        B[:, 1, :, 0, :] += eaB.transpose(0, 2, 1)
        B[:, 0, :, 2, :] += ebB
        B[:, 2, :, 0, :] += ebB.transpose(0, 2, 1)
        ab_ += abB
        B[:, 2, :, 1, :] += abB.transpose(0, 2, 1)
        # multiples of I₃: Cc T ∇²|e| and the (…)I parts of −S ∇²Cc; skew blocks: Cc r ∇²T
        idx = np.arange(3)
        for (i, j), c in (((0, 0), tr + 2.0 * sS * ab), ((0, 1), -sS * eb), ((1, 0), -sS * eb),
                          ((0, 2), -sS * ea), ((2, 0), -sS * ea), ((1, 2), sS * ee), ((2, 1), sS * ee)):
            B[:, i, idx, j, idx] += c[:, None]
        cr = (sC * r)[:, None, None]
        Ka, Kb, Ke = cr * _skew(a), cr * _skew(b), cr * _skew(e)
        B[:, 0, :, 1, :] += Kb
        B[:, 0, :, 2, :] -= Ka
        B[:, 1, :, 0, :] -= Kb
        B[:, 1, :, 2, :] += Ke
        B[:, 2, :, 0, :] += Ka
        B[:, 2, :, 1, :] -= Ke
    Kz = np.negative(Kz)                                       # K_z = −(k g gᵀ + s ∇²θ)
    Dz = None
    if damped:
        Dz = (-kd[:, None] * g)[:, :, None] * g[:, None, :]
    return fe, Kz, Dz


def _expand(Z):
    """Lᵀ Z L (E, 12, 12) of blocks Z (E, 9, 9) in the edge coordinates (module docstring)."""
    E = len(Z)
    Z = Z.reshape(E, 3, 3, 3, 3)
    X = np.empty((E, 4, 3, 4, 3))
    X[:, 1:, :, 1:, :] = Z
    col = Z.sum(axis=3)                                         # (E, 3, 3, 3): Σ over the column blocks
    X[:, 1:, :, 0, :] = -col
    X[:, 0, :, 1:, :] = -Z.sum(axis=1)
    X[:, 0, :, 0, :] = col.sum(axis=1)
    return X.reshape(E, 12, 12)


def bend_terms(cond, x, v, exact=True):
    """(f_e (E, 12), K_e (E, 12, 12), D_e (E, 12, 12) or None) of the :class:`BendCondition` ``cond`` at x, v
    (N, 3): its :meth:`terms` with Jacobians (module docstring); the exact K_e of a damped hinge (with its
    unsymmetric term k_d G (∂²C/∂x² v)ᵀ) is the readable one."""
    if exact and np.any(cond.kd):
        return Conditions.terms(cond, x, v, True, True)
    fe, Kz, Dz = _z_terms(cond, x, v)
    return fe, _expand(Kz), None if Dz is None else _expand(Dz)


def _scatter(cond, maps, nnz):
    """The fixed sparse map (nnz × 81E) from the blocks K_z (E, 9, 9) to the pattern's data of Lᵀ K_z L: entry
    (i, j) of K_z goes to the particle pairs (p, q), p ∈ {0, I + 1}, q ∈ {0, J + 1} (I, J its blocks) with
    the sign L_Ip L_Jq (−1 for particle 0). Built once per condition and pattern."""
    key = (id(maps), nnz)
    cached = cond.__dict__.get("_lean_scatter")
    if cached is not None and cached[0] == key:
        return cached[1]
    E = len(cond)
    pos = maps.reshape(E, 4, 3, 4, 3)
    I, ci, J, cj = np.meshgrid(np.arange(3), np.arange(3), np.arange(3), np.arange(3), indexing="ij")
    rows, vals = [], []
    for p0 in (False, True):
        for q0 in (False, True):
            p = np.zeros_like(I) if p0 else I + 1
            q = np.zeros_like(J) if q0 else J + 1
            rows.append(pos[:, p, ci, q, cj].reshape(E, 81))
            vals.append(np.full(81 * E, (-1.0 if p0 else 1.0) * (-1.0 if q0 else 1.0)))
    cols = np.tile(np.arange(81 * E).reshape(E, 81), 4)
    P = sp.csr_matrix((np.concatenate(vals), (np.concatenate([r.ravel() for r in rows]),
                                              np.concatenate([cols[:, 81 * k:81 * (k + 1)].ravel()
                                                              for k in range(4)]))), shape=(nnz, 81 * E))
    cond.__dict__["_lean_scatter"] = (key, P)
    return P


def bend_data(cond, x, v, maps, nnz):
    """(f_e (E, 12), K.data, D.data or None) of the bend condition alone on a pattern of ``nnz`` entries whose
    data positions of the element blocks are ``maps`` (E·144,): the symmetric K of the large steps (no
    unsymmetric damping term), Lᵀ K_z L scattered by one fixed sparse product (:func:`_scatter`)."""
    fe, Kz, Dz = _z_terms(cond, x, v)
    P = _scatter(cond, maps, nnz)
    return fe, P @ Kz.ravel(), None if Dz is None else P @ Dz.ravel()


def triangle_terms(cond, x, v):
    """(f_e (E, 9), K_e (E, 9, 9), D_e (E, 9, 9) or None) of the :class:`TriangleCondition` ``cond`` at x, v
    (N, 3): its :meth:`terms` with the symmetric K_e of the large steps (``exact=False``), whose Hessians are
    Kronecker products (module docstring): K_e = −(Σ_m k_m G_m G_mᵀ + cu cuᵀ ⊗ α_u P_u + cv cvᵀ ⊗ α_v P_v
    + (cu cvᵀ + cv cuᵀ) ⊗ β 𝟙), α = a s⁺/|w| (stretch, s clamped at 0), β = a s (shear)."""
    el, cu, cv, a = cond.elements, cond.cu, cond.cv, cond.area
    X = x[el]
    wu = np.einsum("ei,eij->ej", cu, X)
    wv = np.einsum("ei,eij->ej", cv, X)
    E = len(el)
    lu, lv = np.sqrt(np.einsum("ij,ij->i", wu, wu)), np.sqrt(np.einsum("ij,ij->i", wv, wv))
    with np.errstate(divide="ignore", invalid="ignore"):
        hu, hv = wu / lu[:, None], wv / lv[:, None]
    G = np.empty((E, 3, 9))
    G[:, 0] = ((a[:, None] * cu)[:, :, None] * hu[:, None, :]).reshape(E, 9)
    G[:, 1] = ((a[:, None] * cv)[:, :, None] * hv[:, None, :]).reshape(E, 9)
    G[:, 2] = (a[:, None, None] * (cu[:, :, None] * wv[:, None, :] + cv[:, :, None] * wu[:, None, :])).reshape(E, 9)
    C = np.stack([a * (lu - 1.0), a * (lv - 1.0), a * np.einsum("ij,ij->i", wu, wv)], axis=1)
    k, kd = cond.k, cond.kd
    Ve = v.reshape(-1)[cond.dofs]
    s = k * C
    damped = bool(np.any(kd))
    if damped:
        s = s + kd * np.einsum("emq,eq->em", G, Ve)
    fe = -np.einsum("em,emq->eq", s, G)
    K = np.matmul((G * k[:, :, None]).transpose(0, 2, 1), G).reshape(E, 3, 3, 3, 3)   # (e, i, k, j, l)
    with np.errstate(divide="ignore", invalid="ignore"):
        for c, h, length, sm in ((cu, hu, lu, s[:, 0]), (cv, hv, lv, s[:, 1])):
            alpha = a * np.maximum(sm, 0.0) / length
            P = -h[:, :, None] * h[:, None, :]
            P[:, [0, 1, 2], [0, 1, 2]] += 1.0
            cc = (alpha[:, None] * c)[:, :, None] * c[:, None, :]
            K += cc[:, :, None, :, None] * P[:, None, :, None, :]
    sym = (a * s[:, 2])[:, None, None] * (cu[:, :, None] * cv[:, None, :] + cv[:, :, None] * cu[:, None, :])
    for i in range(3):
        K[:, :, i, :, i] += sym
    np.negative(K, out=K)
    De = None
    if damped:
        De = np.matmul((G * -kd[:, :, None]).transpose(0, 2, 1), G)
    return fe, K.reshape(E, 9, 9), De
