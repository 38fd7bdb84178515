"""The cloth forces one element at a time: the readable version of the vectorized kinds (lecture 12, §2).

Every element adds f_i = −k (∂C/∂x_i) C − k_d (∂C/∂x_i) Ċ to its particles (Baraff & Witkin 1998, eq. (7)
and (11)); here each kind's C and ∂C/∂x are written out for one element, as on the slides, and the elements
are visited in a Python loop. :mod:`pbanim.cloth.conditions` and :mod:`pbanim.cloth.bend` compute the same
forces for all elements at once (and the Jacobians, which this file does not); the tests check that both
give one force to roundoff (ORACLES J1).

* spring (a, b):  d = x_a − x_b,  C = |d| − r,  ∂C/∂x_a = d̂ = −∂C/∂x_b;
* triangle (0, 1, 2) with rest uv: [w_u w_v] = [x₁ − x₀, x₂ − x₀][[Δu₁, Δu₂], [Δv₁, Δv₂]]⁻¹, a = rest area,
  stretch C = a(|w_u| − 1), a(|w_v| − 1) with ∂C/∂x_i = a (∂w/∂x_i) ŵ, shear C = a w_u·w_v with
  ∂C/∂x_i = a (∂w_u/∂x_i w_v + ∂w_v/∂x_i w_u), where ∂w/∂x_i is the scalar weight of x_i in w;
* hinge (edge 0–1, opposite 2 and 3): θ from the normals, and Bridson, Marino & Fedkiw's gradient
  (SCA 2003, §4.1): with E = x₁ − x₀, N₁ = (x₂ − x₀) × (x₂ − x₁), N₂ = (x₃ − x₁) × (x₃ − x₀),
  ∂θ/∂x₂ = −|E| N₁/|N₁|², ∂θ/∂x₃ = −|E| N₂/|N₂|², and the edge's two gradients from the projections of the
  opposite vertices on E (in :func:`bend_gradient`); the four sum to zero.

Notation: ``C`` the condition values (m,), ``G`` = ∂C/∂x per vertex (m, nv, 3), ``k``, ``kd`` the stiffness
and damping of the element's components, Ċ = Σ_i G_i·v_i. Limiting cases: at the rest shape every C = 0
and the loop returns gravity alone; a rigid translation or rotation of (x, v) leaves C and Ċ unchanged.

References: D. Baraff, A. Witkin, "Large steps in cloth simulation", SIGGRAPH 1998, §4; R. Bridson,
S. Marino, R. Fedkiw, "Simulation of clothing with folds and wrinkles", SCA 2003.
"""

from __future__ import annotations

import math

import numpy as np

from ..contracts import Array, Obj, contract, finite_result

__all__ = ["condition_forces_loop", "bend_gradient", "spring_gradient", "triangle_gradient"]


def spring_gradient(xa, xb, rest):
    """C and [∂C/∂x_a, ∂C/∂x_b] of one spring."""
    d = xa - xb
    length = math.sqrt(float(d @ d))
    dhat = d / length
    return np.array([length - rest]), np.array([[dhat, -dhat]])


def triangle_gradient(X, uv):
    """C = a(|w_u| − 1, |w_v| − 1, w_u·w_v) and ∂C/∂x (3 components × 3 vertices × 3) of one triangle."""
    du1, du2 = uv[1, 0] - uv[0, 0], uv[2, 0] - uv[0, 0]
    dv1, dv2 = uv[1, 1] - uv[0, 1], uv[2, 1] - uv[0, 1]
    det = du1 * dv2 - du2 * dv1
    area = 0.5 * abs(det)
    Binv = np.array([[dv2, -du2], [-dv1, du1]]) / det            # [[Δu₁, Δu₂], [Δv₁, Δv₂]]⁻¹
    dx = np.column_stack([X[1] - X[0], X[2] - X[0]])
    wu, wv = dx @ Binv[:, 0], dx @ Binv[:, 1]
    # weight of each vertex in w_u and w_v: x₁ enters Δx₁, x₂ enters Δx₂, x₀ both with a minus sign
    cu = [-(Binv[0, 0] + Binv[1, 0]), Binv[0, 0], Binv[1, 0]]
    cv = [-(Binv[0, 1] + Binv[1, 1]), Binv[0, 1], Binv[1, 1]]
    lu, lv = np.linalg.norm(wu), np.linalg.norm(wv)
    C = np.array([area * (lu - 1.0), area * (lv - 1.0), area * (wu @ wv)])
    G = np.zeros((3, 3, 3))
    for i in range(3):
        G[0, i] = area * cu[i] * wu / lu
        G[1, i] = area * cv[i] * wv / lv
        G[2, i] = area * (cu[i] * wv + cv[i] * wu)
    return C, G


def bend_gradient(X):
    """θ and ∂θ/∂x (4 × 3) of one hinge (edge X[0]–X[1], opposite X[2], X[3]), Bridson et al.'s closed form."""
    E = X[1] - X[0]
    elen = np.linalg.norm(E)
    n1 = np.cross(X[2] - X[0], X[2] - X[1])
    n2 = np.cross(X[3] - X[1], X[3] - X[0])
    m1, m2 = n1 / (n1 @ n1), n2 / (n2 @ n2)
    c = (m1 / np.linalg.norm(m1)) @ (m2 / np.linalg.norm(m2))
    s = np.cross(m1 / np.linalg.norm(m1), m2 / np.linalg.norm(m2)) @ (E / elen)
    theta = math.atan2(s, c)
    g2, g3 = -elen * m1, -elen * m2
    # the edge's vertices: each opposite vertex's normal term weighted by where it projects on the edge
    s2, s3 = (X[2] - X[0]) @ E / elen ** 2, (X[3] - X[0]) @ E / elen ** 2
    g1 = s2 * (elen * m1) + s3 * (elen * m2)
    g0 = -(g1 + g2 + g3)
    return theta, np.array([g0, g1, g2, g3])


@contract(cloth=Obj("pbanim.cloth.model:Cloth"), y=Array(("cloth.n_state",)), returns=finite_result)
def condition_forces_loop(cloth, y) -> np.ndarray:
    """f (N, 3) of a cloth, element by element (gravity included); equal to :meth:`Cloth.forces`."""
    x, v = cloth.system.unpack(y)
    f = (cloth.sheet.masses[:, None] * cloth.gravity).copy()
    with np.errstate(all="ignore"):
        for cond in cloth.conditions:
            for e, el in enumerate(cond.elements):
                if cond.nv == 2:
                    C, G = spring_gradient(x[el[0]], x[el[1]], cond.rest[e])
                elif cond.nv == 3:
                    C, G = triangle_gradient(x[el], cloth.sheet.uv[el])
                else:
                    theta, g = bend_gradient(x[el])
                    C, G = np.array([theta - cond.theta0[e]]), g[None]
                Cdot = np.einsum("mij,ij->m", G, v[el])
                for m in range(len(C)):
                    f[el] -= (cond.k[e, m] * C[m] + cond.kd[e, m] * Cdot[m]) * G[m]
    return f
