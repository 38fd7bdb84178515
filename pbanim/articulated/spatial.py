"""Spatial algebra: 6-D motion and force vectors, Plücker transforms, spatial inertia (chapter 08).

Featherstone's notation (*Rigid Body Dynamics Algorithms*, 2008, ch. 2): a motion vector is
v̂ = (ω, v) — angular part first, v the velocity of the point at the frame's origin — and a force vector
f̂ = (n, f), the moment about the origin and the force. Every array here may carry leading batch axes.

==========================  =============================================================================
symbol                      code
==========================  =============================================================================
E, r                        the coordinate transform from frame A to B: B's axes are E·(A's), B's origin is
                            at r in A coordinates, so a point p_A has coordinates E (p_A − r) in B
ᴮX_A = [[E, 0], [−E r×, E]] :func:`plucker` (motion vectors); forces use ᴮX*_A = ᴮX_A⁻ᵀ = [[E, −E r×], [0, E]]
v̂×  = [[ω×, 0], [v×, ω×]]   :func:`crm` (motion cross product)
v̂×* = −(v̂×)ᵀ                :func:`crf` (force cross product)
I = [[I_c + m c×c×ᵀ, m c×], :func:`spatial_inertia` (mass m, centre of mass c, rotational inertia I_c about
     [m c×ᵀ, m 1]]          the centre of mass, all in the body's frame)
==========================  =============================================================================

A public call (from outside the package) takes one transform, one vector, one inertia (``rotation``: one
angle or a batch of them), checked by its contract; inside the package every function here also broadcasts
over leading batch axes.

Facts the tests check: X(E, r) X(E, r)⁻¹ = 1; (ᴮX_A v̂)·(ᴮX*_A f̂) = v̂·f̂ (power is frame-independent);
v̂×v̂ = 0; ½ v̂ᵀ I v̂ equals ½ m |v_c|² + ½ ωᵀ I_c ω.
"""

from __future__ import annotations

import numpy as np

from ..contracts import Array, Either, Real, contract, finite_result
from ..geometry import skew
from ..rigid.admissible import Inertia
from ..rigid.domain import Rotation
from .specs import UnitAxis

__all__ = ["skew", "rotation", "plucker", "plucker_inverse", "force_transform", "crm", "crf",
           "spatial_inertia", "transform_inertia"]


_MOTION = Array((6,), batch="first")


@contract(axis=UnitAxis(), angle=Either(Real(), Array((None,))))
def rotation(axis: np.ndarray, angle) -> np.ndarray:
    """The rotation matrix by ``angle`` about the unit ``axis`` (Rodrigues), batched over ``angle``.

    >>> np.round(rotation(np.array([0.0, 0.0, 1.0]), np.pi / 2) @ [1.0, 0.0, 0.0], 12)
    array([0., 1., 0.])
    """
    a = np.asarray(axis, dtype=float)
    th = np.asarray(angle, dtype=float)[..., None, None]
    K = skew(a)
    return np.eye(3) + np.sin(th) * K + (1.0 - np.cos(th)) * (K @ K)


@contract(E=Rotation(), r=Array((3,)), returns=finite_result)
def plucker(E: np.ndarray, r: np.ndarray) -> np.ndarray:
    """ᴮX_A = [[E, 0], [−E r×, E]] (..., 6, 6) for motion vectors."""
    E = np.asarray(E, dtype=float)
    r = np.asarray(r, dtype=float)
    shape = np.broadcast_shapes(E.shape[:-2], r.shape[:-1])
    X = np.zeros(shape + (6, 6))
    X[..., :3, :3] = E
    X[..., 3:, 3:] = E
    X[..., 3:, :3] = -E @ skew(r)
    return X


@contract(X=Array((6, 6), batch="first"))
def plucker_inverse(X: np.ndarray) -> np.ndarray:
    """ᴬX_B = [[Eᵀ, 0], [r× Eᵀ, Eᵀ]] from ᴮX_A, blockwise (no 6×6 inverse)."""
    out = np.zeros_like(X)
    Et = np.swapaxes(X[..., :3, :3], -1, -2)
    out[..., :3, :3] = Et
    out[..., 3:, 3:] = Et
    out[..., 3:, :3] = np.swapaxes(X[..., 3:, :3], -1, -2)
    return out


def force_transform(X: np.ndarray) -> np.ndarray:
    """ᴮX*_A = ᴮX_A⁻ᵀ = [[E, −E r×], [0, E]] from the motion transform."""
    out = np.zeros_like(X)
    out[..., :3, :3] = X[..., :3, :3]
    out[..., 3:, 3:] = X[..., 3:, 3:]
    out[..., :3, 3:] = X[..., 3:, :3]
    return out


@contract(v=_MOTION)
def crm(v: np.ndarray) -> np.ndarray:
    """v̂× = [[ω×, 0], [v×, ω×]] (..., 6, 6)."""
    v = np.asarray(v, dtype=float)
    W, V = skew(v[..., :3]), skew(v[..., 3:])
    out = np.zeros(v.shape[:-1] + (6, 6))
    out[..., :3, :3] = W
    out[..., 3:, 3:] = W
    out[..., 3:, :3] = V
    return out


@contract(v=_MOTION)
def crf(v: np.ndarray) -> np.ndarray:
    """v̂×* = −(v̂×)ᵀ (..., 6, 6)."""
    return -np.swapaxes(crm(v), -1, -2)


@contract(mass=Real(ge=0), com=Array((3,)), I_com=Inertia(definite=False), returns=finite_result)
def spatial_inertia(mass, com, I_com) -> np.ndarray:
    """[[I_c + m c×c×ᵀ, m c×], [m c×ᵀ, m 1]] (..., 6, 6) about the frame's origin.

    >>> I = spatial_inertia(2.0, [0.0, 0.0, 0.0], np.eye(3)); I[:3, :3].trace(), I[3, 3]
    (np.float64(3.0), np.float64(2.0))
    """
    m = np.asarray(mass, dtype=float)[..., None, None]
    C = skew(np.asarray(com, dtype=float))
    out = np.zeros(np.broadcast_shapes(m.shape[:-2], C.shape[:-2]) + (6, 6))
    out[..., :3, :3] = np.asarray(I_com, dtype=float) + m * (C @ np.swapaxes(C, -1, -2))
    out[..., :3, 3:] = m * C
    out[..., 3:, :3] = m * np.swapaxes(C, -1, -2)
    out[..., 3:, 3:] = m * np.eye(3)
    return out


def transform_inertia(X: np.ndarray, I: np.ndarray) -> np.ndarray:
    """ᴬI = ᴮX_Aᵀ ᴮI ᴮX_A: a spatial inertia given in B expressed in A."""
    return np.swapaxes(X, -1, -2) @ I @ X
