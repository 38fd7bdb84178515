"""Small vector helpers shared by the rigid-body, collision and contact lectures (chapters 05–07).

Chapter 05 writes the angular part of every rigid-body formula with the cross product and its matrix,

    a × b = [a]× b,        [a]× = [[ 0, −a₃,  a₂],
                                   [ a₃,  0, −a₁],
                                   [−a₂,  a₁,  0]],

(ṗ = v + ω × r, L̇ = τ = r × F, the collision matrix K = (1/m) 𝟙 − [r]× I⁻¹ [r]× of chapter 06).
Chapters 06–07 split a contact impulse or force into its normal part along the unit normal n and a
tangential part in the contact plane, spanned by an orthonormal pair (t₁, t₂) with t₂ = n × t₁, so that
(t₁, t₂, n) is a right-handed frame. A polyhedral friction cone has k edges evenly spaced in that plane,

    dⱼ = cos(2πj/k) t₁ + sin(2πj/k) t₂,      j = 0 … k−1.

t₁ is a reference direction projected on the contact plane: the x axis, or y when the normal is near x
(|n₁| ≥ 0.9), or a direction given by the caller. Every module builds its frames here, so the collision
impulses (:mod:`pbanim.collision`) and the contact time-stepping (:mod:`pbanim.contact`) use the same
tangents, in the same order and with the same signs.

============  =================  ============  ==============================================
symbol        code               shape         meaning
============  =================  ============  ==============================================
a, b          ``a, b``           (..., 3)      vectors (broadcast against each other)
[a]×          ``skew(a)``        (..., 3, 3)   cross-product matrix: [a]× b = a × b
n             ``normal``         (m, 3)        unit contact normals
t₁, t₂        ``tangent_basis``  (m, 3) each   orthonormal tangents, t₂ = n × t₁
dⱼ            ``cone_edges``     (m, k, 3)     friction-cone edge directions
============  =================  ============  ==============================================

Limiting cases: [a]× a = 0 and [a]×ᵀ = −[a]×; n = ±z gives t₁ = x and t₂ = ±y; k = 4 gives the edges
±t₁, ±t₂. This module imports only numpy (layer 0: the LCP core may use it too).

References: D. Baraff, "An introduction to physically based modeling: rigid body simulation I",
SIGGRAPH 1997 course notes (the star operator); D. E. Stewart, J. C. Trinkle, IJNME 39 (1996)
(polyhedral friction cones).
"""

from __future__ import annotations

import numpy as np
from .contracts import Array, Int, Opt, contract
from .errors import InvalidInput

__all__ = ["cross", "skew", "tangent_basis", "cone_edges"]


@contract(a=Array((3,), batch="first"), b=Array((3,), batch="first"))
def cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """a × b for (..., 3) arrays, broadcasting (explicit components: cheaper than np.cross on small rows).

    >>> cross(np.array([1.0, 0.0, 0.0]), np.array([0.0, 1.0, 0.0]))
    array([0., 0., 1.])
    """
    a = np.asarray(a, dtype=float)
    b = np.asarray(b, dtype=float)
    out = np.empty(np.broadcast_shapes(a.shape, b.shape))
    out[..., 0] = a[..., 1] * b[..., 2] - a[..., 2] * b[..., 1]
    out[..., 1] = a[..., 2] * b[..., 0] - a[..., 0] * b[..., 2]
    out[..., 2] = a[..., 0] * b[..., 1] - a[..., 1] * b[..., 0]
    return out


@contract(v=Array((3,), batch="first"))
def skew(v: np.ndarray) -> np.ndarray:
    """The cross-product matrix [v]× (..., 3, 3) with [v]× u = v × u.

    >>> skew([1.0, 2.0, 3.0]) @ [4.0, 5.0, 6.0]
    array([-3.,  6., -3.])
    """
    v = np.asarray(v, dtype=float)
    S = np.zeros(v.shape[:-1] + (3, 3))
    S[..., 0, 1], S[..., 0, 2] = -v[..., 2], v[..., 1]
    S[..., 1, 0], S[..., 1, 2] = v[..., 2], -v[..., 0]
    S[..., 2, 0], S[..., 2, 1] = -v[..., 1], v[..., 0]
    return S


@contract(normal=Array((3,), batch="first"), reference=Opt(Array((3,), batch="first")))
def tangent_basis(normal, reference=None) -> tuple[np.ndarray, np.ndarray]:
    """Orthonormal tangents (t₁, t₂), each (m, 3), of unit normals n (m, 3), with t₂ = n × t₁.

    t₁ is ``reference`` (one vector, or one per normal; default the x axis, or y where |n₁| ≥ 0.9)
    minus its normal component, normalized. Raises ``ValueError`` if the reference is parallel to a
    normal.

    >>> t1, t2 = tangent_basis([[0.0, 0.0, 1.0], [1.0, 0.0, 0.0]])
    >>> t1, t2
    (array([[1., 0., 0.],
           [0., 1., 0.]]), array([[0., 1., 0.],
           [0., 0., 1.]]))
    """
    n = np.array(normal, dtype=float, ndmin=2)
    if not np.all(np.abs(np.einsum("ij,ij->i", n, n) - 1.0) <= 1e-9):
        raise InvalidInput(f"tangent_basis: normal must hold unit vectors, got lengths "
                           f"{np.sqrt(np.einsum('ij,ij->i', n, n))[:5]}")
    if reference is not None and np.ndim(reference) == 2 and len(reference) not in (1, len(n)):
        raise InvalidInput(f"tangent_basis: reference must be one vector or one per normal ({len(n)}), got "
                           f"shape {np.shape(reference)}")
    if reference is None:
        ref = np.where(np.abs(n[:, :1]) < 0.9, np.array([[1.0, 0.0, 0.0]]), np.array([[0.0, 1.0, 0.0]]))
    else:
        ref = np.broadcast_to(np.asarray(reference, dtype=float), n.shape)
    t1 = ref - np.einsum("ij,ij->i", ref, n)[:, None] * n
    norm = np.linalg.norm(t1, axis=1)
    if np.any(norm < 1e-12):
        raise InvalidInput("tangent must not be parallel to a contact normal")
    t1 /= norm[:, None]
    return t1, cross(n, t1)


@contract(normal=Array((3,), batch="first"), k=Int(ge=1, le=10_000), reference=Opt(Array((3,), batch="first")))
def cone_edges(normal, k: int, reference=None) -> np.ndarray:
    """k unit edge directions per contact, shape (m, k, 3): dⱼ = cos(2πj/k) t₁ + sin(2πj/k) t₂.

    (t₁, t₂) is :func:`tangent_basis` of ``normal`` and ``reference``.

    Three edges around n = −x (t₁ = y, t₂ = −x × y = −z):

    >>> cone_edges([[-1.0, 0.0, 0.0]], 3).round(6)[0]
    array([[ 0.      ,  1.      ,  0.      ],
           [ 0.      , -0.5     , -0.866025],
           [-0.      , -0.5     ,  0.866025]])
    """
    t1, t2 = tangent_basis(normal, reference)
    ang = 2 * np.pi * np.arange(int(k)) / int(k)
    return np.cos(ang)[None, :, None] * t1[:, None, :] + np.sin(ang)[None, :, None] * t2[:, None, :]
