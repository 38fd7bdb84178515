"""Unit quaternions for rigid-body orientation (chapter 05, part of :mod:`pbanim.rigid`).

A rotation by angle θ about the unit axis a is the unit quaternion q = (cos θ/2, sin θ/2 · a), stored
scalar-first ``(w, x, y, z)``. The Hamilton product of a = (a₀, **a**) and b = (b₀, **b**) is

    a ⊗ b = (a₀ b₀ − **a**·**b**,  a₀ **b** + b₀ **a** + **a** × **b**),

and a body turning with world-frame angular velocity ω obeys q̇ = ½ (0, ω) ⊗ q (Baraff 1997, §4).
The rotation matrix of q is built from q/|q|, so a drifting norm never shears or scales a body:

    R(q) = I + 2 w [v]× + 2 [v]×²   for |q| = 1, v = (x, y, z).

The exponential map sends a rotation vector θ (angle |θ| about θ/|θ|) to exp(½θ) = (cos |θ|/2,
sin(|θ|/2) θ/|θ|); stepping q ← exp(½ h ω) ⊗ q keeps |q| = 1 to roundoff (Lie–Euler).

===============  ===============  ===========
symbol           code             shape
===============  ===============  ===========
q                ``quat``         (..., 4)
R                ``R``            (..., 3, 3)
ω, θ             ``omega, theta`` (..., 3)
===============  ===============  ===========

Limiting cases: q and −q give the same R (double cover); θ → 0 uses the series sin(a/2)/a → ½ − a²/48.

References: K. Shoemake, "Animating rotation with quaternion curves", SIGGRAPH 1985; D. Baraff,
"An introduction to physically based modeling: rigid body simulation I", SIGGRAPH 1997 course notes;
Hairer, Lubich & Wanner, *Geometric Numerical Integration*, 2nd ed., §IV.8 (Lie-group methods).
"""

from __future__ import annotations

import numpy as np

from ..contracts import Array, contract
from ..geometry import skew  # [v]× lives in pbanim.geometry (shared with collisions); re-exported here
from ..errors import InvalidInput
from .domain import Rotation, Vectors, certifier, row_norms

__all__ = ["quat_multiply", "quat_conjugate", "quat_normalize", "quat_to_matrix", "matrix_to_quat",
           "quat_from_axis_angle", "quat_exp", "quat_rotate", "skew"]


_QUATS = Array((4,), batch="first")
_NONZERO = Vectors(4, batch="first", nonzero=True, what="quaternions (w, x, y, z):")
_VECS = Array((3,), batch="first")


def _batches(where: str, names: tuple, *arrays) -> InvalidInput:
    """The error for two batches of different lengths (one of each, or one and a batch, broadcast)."""
    shapes = " and ".join(f"{n} {np.shape(a)}" for n, a in zip(names, arrays))
    return InvalidInput(f"{where}: {' and '.join(names)} must be one each, or batches of one length, got {shapes}")


@contract(a=_QUATS, b=_QUATS, returns=certifier("quat_multiply: a ⊗ b"))
def quat_multiply(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Hamilton product a ⊗ b of quaternions of shape (..., 4) (broadcasting).

    >>> i, j = np.array([0.0, 1, 0, 0]), np.array([0.0, 0, 1, 0])
    >>> quat_multiply(i, j)          # i j = k
    array([0., 0., 0., 1.])
    """
    a = np.asarray(a, dtype=float)
    b = np.asarray(b, dtype=float)
    a0, a1, a2, a3 = a[..., 0], a[..., 1], a[..., 2], a[..., 3]
    b0, b1, b2, b3 = b[..., 0], b[..., 1], b[..., 2], b[..., 3]
    try:
        return np.stack([a0 * b0 - a1 * b1 - a2 * b2 - a3 * b3,
                         a0 * b1 + a1 * b0 + a2 * b3 - a3 * b2,
                         a0 * b2 - a1 * b3 + a2 * b0 + a3 * b1,
                         a0 * b3 + a1 * b2 - a2 * b1 + a3 * b0], axis=-1)
    except ValueError:
        raise _batches("quat_multiply", ("a", "b"), a, b) from None


@contract(q=_QUATS)
def quat_conjugate(q: np.ndarray) -> np.ndarray:
    """(w, −x, −y, −z): the inverse of a unit quaternion."""
    q = np.asarray(q, dtype=float)
    return q * np.array([1.0, -1.0, -1.0, -1.0])


@contract(q=_NONZERO)
def quat_normalize(q: np.ndarray) -> np.ndarray:
    """q/|q| along the last axis (any finite non-zero q, 10⁻³⁰⁰ or 10³⁰⁰ too); raises
    :class:`~pbanim.errors.InvalidInput` for a zero or non-finite quaternion.

    >>> quat_normalize([2.0, 0, 0, 0])
    array([1., 0., 0., 0.])
    >>> quat_normalize([3e300, 0, 4e300, 0])
    array([0.6, 0. , 0.8, 0. ])
    """
    return normalized(q, "q", "quat_normalize")


def normalized(q, name: str, where: str) -> np.ndarray:
    """q/|q| for quaternions (..., 4), or InvalidInput naming ``name`` when one is zero or not finite (for
    the callers inside pbanim, which skip the contract)."""
    q = np.asarray(q, dtype=float)
    n = row_norms(q)[..., None]
    if not (np.isfinite(n).all() and (n > 0).all()):
        raise InvalidInput(f"{where}: {name} must be finite non-zero quaternions (w, x, y, z), got norms "
                           f"{n.ravel()}")
    return q / n


@contract(quat=_NONZERO)
def quat_to_matrix(quat: np.ndarray) -> np.ndarray:
    """Rotation matrices R (..., 3, 3) of the *unit* quaternions q/|q| (scalar-first).

    Uses s = 2/|q|², so R is orthogonal even when the stored q has drifted off the unit sphere (a q whose
    |q|² would overflow or underflow is scaled first). A zero q is refused by name; a NaN q (a diverging
    run, inside pbanim) gives a NaN R, which the stepping loop names.

    >>> R = quat_to_matrix([np.cos(np.pi / 4), 0, 0, np.sin(np.pi / 4)])   # 90° about z
    >>> np.round(R @ [1.0, 0, 0], 12) + 0.0
    array([0., 1., 0.])
    >>> np.allclose(quat_to_matrix([2.0, 0, 0, 0]), np.eye(3))             # norm does not matter
    True
    """
    q = np.asarray(quat, dtype=float)
    n2 = np.einsum("...i,...i->...", q, q)          # (einsum raises no overflow warning)
    if q.size == 4 and 1e-290 < n2.item() < 1e290:
        return _matrix_of_one(q, n2.item())
    if not (n2.min() > 1e-290 and n2.max() < 1e290):     # also NaN: scale each q to max |qᵢ| = 1
        if (np.abs(q).max(axis=-1) == 0).any():
            raise InvalidInput(f"quat_to_matrix: quat must be non-zero quaternions (w, x, y, z), got a zero one "
                               f"among {q.shape[:-1] or 'one'}")
        with np.errstate(invalid="ignore"):
            q = q / np.abs(q).max(axis=-1, keepdims=True)
    return _matrices(q)


def _matrices(q: np.ndarray) -> np.ndarray:
    """:func:`quat_to_matrix` for quaternions whose |q|² neither overflows nor underflows (the states of a
    run: unit up to drift): the formula alone, no range test — what the step loop calls."""
    n2 = np.einsum("...i,...i->...", q, q)
    if q.size == 4:
        return _matrix_of_one(q, n2.item())
    w, x, y, z = q[..., 0], q[..., 1], q[..., 2], q[..., 3]
    s = 2.0 / n2
    xx, yy, zz = s * x * x, s * y * y, s * z * z
    xy, xz, yz = s * x * y, s * x * z, s * y * z
    wx, wy, wz = s * w * x, s * w * y, s * w * z
    R = np.empty(q.shape[:-1] + (3, 3))
    R[..., 0, 0] = 1.0 - yy - zz
    R[..., 0, 1] = xy - wz
    R[..., 0, 2] = xz + wy
    R[..., 1, 0] = xy + wz
    R[..., 1, 1] = 1.0 - xx - zz
    R[..., 1, 2] = yz - wx
    R[..., 2, 0] = xz - wy
    R[..., 2, 1] = yz + wx
    R[..., 2, 2] = 1.0 - xx - yy
    return R


def _matrix_of_one(q: np.ndarray, n2: float) -> np.ndarray:
    """:func:`_matrices` of one quaternion (shape (4,), (1, 4), ...) on Python floats: the same products in
    the same order, so the same bits, at a quarter of the cost of nine array assignments (one body's step)."""
    w, x, y, z = q.ravel().tolist()
    s = 2.0 / n2
    xx, yy, zz = s * x * x, s * y * y, s * z * z
    xy, xz, yz = s * x * y, s * x * z, s * y * z
    wx, wy, wz = s * w * x, s * w * y, s * w * z
    return np.array([[1.0 - yy - zz, xy - wz, xz + wy], [xy + wz, 1.0 - xx - zz, yz - wx],
                     [xz - wy, yz + wx, 1.0 - xx - yy]]).reshape(q.shape[:-1] + (3, 3))


@contract(R=Rotation(batch="first"))
def matrix_to_quat(R: np.ndarray) -> np.ndarray:
    """Unit quaternion (w ≥ 0) of rotation matrices R (..., 3, 3), vectorized.

    Of the four expressions 4w² = 1 + tr R, 4x² = 1 + 2R₀₀ − tr R, ... the largest is used for the
    square root and the others follow from off-diagonal sums/differences (no cancellation; Shepperd 1978).

    >>> q = quat_from_axis_angle([1.0, 2.0, 2.0], 0.7)
    >>> np.allclose(matrix_to_quat(quat_to_matrix(q)), q)
    True
    """
    R = np.asarray(R, dtype=float)
    shape = R.shape[:-2]
    R = R.reshape(-1, 3, 3)
    r00, r11, r22 = R[:, 0, 0], R[:, 1, 1], R[:, 2, 2]
    tr = r00 + r11 + r22
    cand = np.stack([1 + tr, 1 + 2 * r00 - tr, 1 + 2 * r11 - tr, 1 + 2 * r22 - tr], axis=1)  # 4w², 4x², 4y², 4z²
    k = np.argmax(cand, axis=1)
    d21, d02, d10 = R[:, 2, 1] - R[:, 1, 2], R[:, 0, 2] - R[:, 2, 0], R[:, 1, 0] - R[:, 0, 1]   # 4w·(x, y, z)
    s01, s02, s12 = R[:, 0, 1] + R[:, 1, 0], R[:, 0, 2] + R[:, 2, 0], R[:, 1, 2] + R[:, 2, 1]   # 4xy, 4xz, 4yz
    # row j: 4·c_j·(w, x, y, z) for the branch c_j ∈ (w, x, y, z)
    rows = np.stack([np.stack([cand[:, 0], d21, d02, d10], axis=1),
                     np.stack([d21, cand[:, 1], s01, s02], axis=1),
                     np.stack([d02, s01, cand[:, 2], s12], axis=1),
                     np.stack([d10, s02, s12, cand[:, 3]], axis=1)], axis=1)
    idx = np.arange(len(k))
    q = rows[idx, k] / (2.0 * np.sqrt(np.maximum(cand[idx, k], np.finfo(float).tiny)))[:, None]
    q *= np.where(q[:, :1] < 0, -1.0, 1.0)
    return q.reshape(shape + (4,))


@contract(axis=Vectors(3, batch="first", nonzero=True), angle=Array((None,), scalar=True))
def quat_from_axis_angle(axis, angle) -> np.ndarray:
    """Unit quaternion of a rotation by ``angle`` (rad) about ``axis`` (normalized here); a batch of axes
    (K, 3) and/or of angles (K,) gives (K, 4).

    >>> quat_from_axis_angle([0, 0, 2.0], np.pi)
    array([6.123234e-17, 0.000000e+00, 0.000000e+00, 1.000000e+00])
    """
    axis = np.asarray(axis, dtype=float)
    n = row_norms(axis)[..., None]
    if np.any(n == 0):
        raise InvalidInput(f"quat_from_axis_angle: axis must be a non-zero vector, got {axis}")
    half = 0.5 * np.asarray(angle, dtype=float)[..., None]
    u = axis / n
    try:
        shape = np.broadcast_shapes(half.shape[:-1], u.shape[:-1])
    except ValueError:
        raise _batches("quat_from_axis_angle", ("axis", "angle"), axis, half[..., 0]) from None
    return np.concatenate([np.broadcast_to(np.cos(half), shape + (1,)),
                           np.broadcast_to(np.sin(half) * u, shape + (3,))], axis=-1)


@contract(theta=_VECS)
def quat_exp(theta: np.ndarray) -> np.ndarray:
    """exp(½θ): the unit quaternion of the rotation vector θ (..., 3); exact unit norm.

    >>> np.allclose(quat_exp([0.0, 0.0, np.pi / 2]), quat_from_axis_angle([0, 0, 1], np.pi / 2))
    True
    >>> quat_exp([0.0, 0.0, 0.0])
    array([1., 0., 0., 0.])
    """
    th = np.asarray(theta, dtype=float)
    a = row_norms(th)[..., None]
    small = a < 1e-4
    a_safe = np.where(small, 1.0, a)
    a_small = np.where(small, a, 0.0)
    # sin(a/2)/a, with its series ½ − a²/48 + a⁴/3840 where a is tiny
    sinc = np.where(small, 0.5 - a_small * a_small / 48.0 + a_small ** 4 / 3840.0, np.sin(0.5 * a_safe) / a_safe)
    q = np.concatenate([np.cos(0.5 * a), sinc * th], axis=-1)
    return q / np.sqrt(np.sum(q * q, axis=-1, keepdims=True))


@contract(quat=_NONZERO, v=_VECS, returns=certifier("quat_rotate: R(q) v"))
def quat_rotate(quat: np.ndarray, v: np.ndarray) -> np.ndarray:
    """R(q) v for quaternions (..., 4) and vectors (..., 3) (one each, or batches of one length).

    >>> np.round(quat_rotate(quat_from_axis_angle([0, 0, 1.0], np.pi / 2), [1.0, 0, 0]), 12) + 0.0
    array([0., 1., 0.])
    """
    v = np.asarray(v, dtype=float)
    try:
        return np.einsum("...ij,...j->...i", quat_to_matrix(quat), v)
    except ValueError:
        raise _batches("quat_rotate", ("quat", "v"), quat, v) from None
