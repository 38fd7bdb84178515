"""The body protocol of rigid bodies: what impulses, contacts and constraints ask of them (chapter 05).

A rigid body i has the generalized velocity uᵢ = (vᵢ, ωᵢ) and, in world axes, the inverse-mass block
Wᵢ = diag(E/mᵢ, I⁻¹_world,i) (zero for a static body). A point p moving with body i has

    ṗ = vᵢ + ωᵢ × (p − xᵢ),

an impulse j applied at p changes the momenta by Pᵢ += j, Lᵢ += (p − xᵢ) × j, and the response of the
point along a direction n to a unit impulse along n is nᵀ W n = 1/mᵢ + (r × n)·I⁻¹_world (r × n), r = p − xᵢ.
Body index −1 is the static world: the arrays are padded with one row of W = 0, I⁻¹ = 0, x = 0, R = E,
v = ω = 0, so no formula special-cases it (:class:`pbanim.bodies.Bodies` describes the protocol).

:class:`RigidBodyProtocol` holds these members; :class:`pbanim.rigid.RigidBodies` inherits them (the state,
the dynamics and the diagnostics live in :mod:`pbanim.rigid.bodies`). Every member runs over all m
points at once (``np.add.at`` sums the impulses of repeated indices).
"""

from __future__ import annotations

import numpy as np

from ..bodies import Bodies
from ..contracts import Array, contract
from ..errors import InvalidInput
from ..geometry import cross
from .domain import BodyIndices, RigidState, certifier
from .quat import quat_to_matrix

__all__ = ["RigidBodyProtocol"]

_Y = RigidState("self")                   # one state of this system
_IDX = BodyIndices("self.N", world=True, symbol="m", empty=True)
_POINTS = Array(("m", 3), empty=True)


def _matvec(A: np.ndarray, x: np.ndarray) -> np.ndarray:
    """A x for stacks A (..., 3, 3), x (..., 3)."""
    return np.matmul(A, x[..., None])[..., 0]


def _matTvec(A: np.ndarray, x: np.ndarray) -> np.ndarray:
    """Aᵀ x for stacks A (..., 3, 3), x (..., 3)."""
    return np.matmul(x[..., None, :], A)[..., 0, :]



class RigidBodyProtocol(Bodies):
    """The body-protocol members of :class:`pbanim.rigid.RigidBodies` (see the module docstring)."""

    # u = (v, ω), Wᵢ = diag(E/mᵢ, I⁻¹_world,i); zero for static bodies
    kind = "rigid"
    dof = 6

    @contract(y=_Y)
    def generalized_velocity(self, y: np.ndarray) -> np.ndarray:
        return np.hstack(self.velocities(y))

    @contract(y=_Y)
    def inverse_mass_blocks(self, y: np.ndarray) -> np.ndarray:
        Wb = np.zeros((self.N, 6, 6))
        Wb[:, :3, :3] = self.inv_mass[:, None, None] * np.eye(3)
        Wb[:, 3:, 3:] = self.inv_inertia_world(y) * self._dyn[:, :, None]
        return Wb

    def _padded(self, y: np.ndarray):
        """x, R, v, ω with one static world row appended (index −1: x = 0, R = E, v = ω = 0)."""
        x, q, _, _ = self.unpack(y)
        v, w = self.velocities(y)
        z = np.zeros((1, 3))
        return (np.concatenate([x, z]), np.concatenate([quat_to_matrix(q), np.eye(3)[None]]),
                np.concatenate([v, z]), np.concatenate([w, z]))

    def _index(self, body_idx) -> np.ndarray:
        idx = np.asarray(body_idx, dtype=np.intp)
        if idx.size and (idx.min() < -1 or idx.max() >= self.N):
            raise InvalidInput(f"body_idx must lie in [-1, {self.N - 1}] (-1 = static world), got {idx}")
        return np.where(idx < 0, self.N, idx)

    @contract(y=_Y, body_idx=_IDX, points_body=_POINTS, returns=certifier("RigidBodies.world_points: x + R r"))
    def world_points(self, y: np.ndarray, body_idx, points_body) -> np.ndarray:
        """p = x + R r for body-frame points r (m, 3) of bodies ``body_idx`` (m,) (−1: r is a world point)."""
        i = self._index(body_idx)
        xp, Rp, _, _ = self._padded(y)
        return xp[i] + _matvec(Rp[i], np.asarray(points_body, dtype=float))

    @contract(y=_Y, body_idx=_IDX, points_world=_POINTS, returns=certifier("RigidBodies.point_velocity: v + ω × (p − x)"))
    def point_velocity(self, y: np.ndarray, body_idx, points_world) -> np.ndarray:
        """ṗ = v + ω × (p − x) of world points (m, 3) moving with bodies ``body_idx`` (m,); 0 for −1."""
        i = self._index(body_idx)
        xp, _, vp, wp = self._padded(y)
        p = np.asarray(points_world, dtype=float)
        return vp[i] + cross(wp[i], p - xp[i])

    @contract(y=_Y, body_idx=_IDX, points_world=_POINTS, directions=_POINTS, returns=certifier("RigidBodies.effective_inverse_mass: nᵀ W n"))
    def effective_inverse_mass(self, y: np.ndarray, body_idx, points_world, directions) -> np.ndarray:
        """nᵀ W n = 1/m + (r × n)·I⁻¹_world (r × n) per contact (m,) — the impulse response along n."""
        i = self._index(body_idx)
        xp = np.concatenate([self.unpack(y)[0], np.zeros((1, 3))])
        Rp = np.concatenate([self.rotations(y), np.eye(3)[None]])
        n = np.asarray(directions, dtype=float)
        rn = cross(np.asarray(points_world, dtype=float) - xp[i], n)
        u = _matTvec(Rp[i], rn)
        return self.inv_mass_padded[i] + np.einsum("mi,mi->m", u, _matvec(self.inv_I_body_padded[i], u))

    @contract(y=_Y, body_idx=_IDX, points_world=_POINTS, impulses=_POINTS, returns=certifier("RigidBodies.apply_impulses: the new momenta"))
    def apply_impulses(self, y: np.ndarray, body_idx, points_world, impulses) -> np.ndarray:
        """A new state with P += j and L += (p − x) × j for each impulse j (m, 3) at world point p (m, 3).

        Repeated indices accumulate (``np.add.at``); impulses on the world (−1) or a static body are
        absorbed (they change nothing).
        """
        i = self._index(body_idx)
        j = np.asarray(impulses, dtype=float).reshape(-1, 3)
        p = np.asarray(points_world, dtype=float).reshape(-1, 3)
        y_new = np.array(y, dtype=float, copy=True)
        x, _, P, L = self.unpack(y_new)
        xp = np.concatenate([x, np.zeros((1, 3))])
        dP = np.zeros((self.N + 1, 3))
        dL = np.zeros((self.N + 1, 3))
        np.add.at(dP, i, j)
        np.add.at(dL, i, cross(p - xp[i], j))
        P += dP[:-1] * self._dyn
        L += dL[:-1] * self._dyn
        return y_new

