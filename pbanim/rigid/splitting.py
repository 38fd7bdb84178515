"""Velocity Verlet for rigid bodies: kick, drift with an exact-axis free rotation, kick (chapter 05).

Generic velocity Verlet on Baraff's state y = [x, q, P, L] is only first order: its drift moves q by
h·q̇ = h·½(0, ω) ⊗ q with ω = R(q) I⁻¹_body R(q)ᵀ L frozen at the start of the step, an explicit Euler
step on the quaternion. The rigid-body Verlet of :class:`~pbanim.rigid.RigidScene` (``method="verlet"``)
splits the Hamiltonian H = T_trans + T_rot + V instead (Dullweber, Leimkuhler & McLachlan 1997;
Hairer, Lubich & Wanner, GNI §VII.5):

    P ← P + ½h F,   L ← L + ½h τ                                 (kick with the forces at (t, y))
    x ← x + h P/m                                                (free translation, exact)
    free rotation for h: R₁(½h) R₂(½h) R₃(h) R₂(½h) R₁(½h)       (each Rᵢ exact, see below)
    P ← P + ½h F,   L ← L + ½h τ                                 (kick with the forces at (t + h, y))

The free rotation T_rot = Σᵢ Πᵢ²/(2Iᵢ), Π = Rₚᵀ L the angular momentum in principal axes, is the sum of
three integrable parts: the flow of Πᵢ²/(2Iᵢ) for time τ turns the body about its i-th principal axis by
θ = τ Πᵢ/Iᵢ (q ← q ⊗ (cos ½θ, sin ½θ aᵢ) with aᵢ the axis in body coordinates; world L is unchanged).
The symmetric composition is second order, symplectic, and keeps |L| and |q| = 1 to roundoff; the whole
step is second order (measured in ``tests/test_edges.py``, ORACLES A3, C1).
"""

from __future__ import annotations

import numpy as np

from .bodies import RigidBodies
from .quat import quat_multiply, quat_to_matrix

__all__ = ["rigid_verlet_step", "free_rotation"]

_SEQUENCE = ((0, 0.5), (1, 0.5), (2, 1.0), (1, 0.5), (0, 0.5))


def _principal(system: RigidBodies):
    """Principal moments (N, 3) and axes (N, 3, 3) (columns, body coordinates), computed once."""
    cached = getattr(system, "_principal_cache", None)
    if cached is None:
        lam, axes = np.linalg.eigh(system.I_body)
        axes[:, :, 2] *= np.sign(np.linalg.det(axes))[:, None]     # a right-handed frame (det = +1)
        cached = system._principal_cache = (lam, axes)
    return cached


def free_rotation(system: RigidBodies, q: np.ndarray, L: np.ndarray, h: float) -> np.ndarray:
    """Orientations (N, 4) after torque-free rotation for time h with world angular momenta L (N, 3)."""
    lam, axes = _principal(system)
    Pi = np.einsum("nji,nj->ni", axes, np.einsum("nji,nj->ni", quat_to_matrix(q), L))   # Aᵀ Rᵀ L
    dyn = ~system.static
    for i, frac in _SEQUENCE:
        theta = np.where(dyn, frac * h * Pi[:, i] / lam[:, i], 0.0)
        c, s = np.cos(0.5 * theta), np.sin(0.5 * theta)
        rot = np.concatenate([c[:, None], s[:, None] * axes[:, :, i]], axis=1)
        q = quat_multiply(q, rot)
        j, k = (i + 1) % 3, (i + 2) % 3     # Π seen from the turned body: rotated by −θ about axis i
        cj, ck = np.cos(theta), np.sin(theta)
        Pi[:, j], Pi[:, k] = cj * Pi[:, j] + ck * Pi[:, k], -ck * Pi[:, j] + cj * Pi[:, k]
    return q


def rigid_verlet_step(system: RigidBodies, forces, t: float, y: np.ndarray, h: float,
                      counter: list | None = None) -> np.ndarray:
    """One kick–drift–kick step (see the module docstring); ``forces(t, y) -> Q (N, 6)``."""
    x, q, P, L = (a.copy() for a in system.unpack(y))
    Q = forces(t, y)
    P += 0.5 * h * Q[:, :3]
    L += 0.5 * h * Q[:, 3:]
    x += h * system.inv_mass[:, None] * P
    q = free_rotation(system, q, L, h)
    y1 = system.pack(x, q, P, L)
    Q1 = forces(t + h, y1)
    P += 0.5 * h * Q1[:, :3]
    L += 0.5 * h * Q1[:, 3:]
    if counter is not None:
        counter[0] += 2
    return system.pack(x, q, P, L)
