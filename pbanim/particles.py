"""Particle systems (chapter 01) — seed: ParticleSystem and Gravity; the full module adds drag,
damped springs, user forces, force Jacobians and diagnostics on top of these contracts.

State layout: y = [x.ravel(), v.ravel()], x and v of shape (N, dim); generalized force Q of shape (N, dim);
ẋ = v, v̇ = W Q with W = M⁻¹ = diag(1/mᵢ).
"""

from __future__ import annotations

import numpy as np

from .scene import Effect

__all__ = ["ParticleSystem", "Gravity"]


class ParticleSystem:
    """N point masses in 2-D or 3-D (the mechanical-system protocol of :mod:`pbanim.scene`)."""

    def __init__(self, positions, velocities=None, masses=1.0) -> None:
        x = np.array(positions, dtype=float, ndmin=2)
        if x.ndim != 2 or x.shape[1] not in (2, 3):
            raise ValueError(f"positions must have shape (N, 2) or (N, 3), got {x.shape}")
        v = np.zeros_like(x) if velocities is None else np.array(velocities, dtype=float, ndmin=2)
        if v.shape != x.shape:
            raise ValueError(f"velocities must have the shape of positions {x.shape}, got {v.shape}")
        m = np.broadcast_to(np.asarray(masses, dtype=float), (x.shape[0],)).copy()
        if not np.all(np.isfinite(x)) or not np.all(np.isfinite(v)):
            raise ValueError("positions and velocities must be finite (got NaN or Inf)")
        if np.any(~np.isfinite(m)) or np.any(m <= 0):
            bad = m[~(np.isfinite(m) & (m > 0))][0]
            raise ValueError(f"mass must be positive, got {bad}")
        self.x0, self.v0, self.m = x, v, m
        self.N, self.dim = x.shape
        self.split = self.N * self.dim
        self.W = 1.0 / m

    def state(self) -> np.ndarray:
        return np.concatenate([self.x0.ravel(), self.v0.ravel()])

    def unpack(self, y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Views x, v of shape (N, dim) into a flat state y."""
        return y[: self.split].reshape(self.N, self.dim), y[self.split:].reshape(self.N, self.dim)

    def zero_forces(self) -> np.ndarray:
        return np.zeros((self.N, self.dim))

    def derivative(self, y: np.ndarray, Q: np.ndarray) -> np.ndarray:
        dy = np.empty_like(y)
        dy[: self.split] = y[self.split:]
        dy[self.split:] = (Q * self.W[:, None]).ravel()
        return dy

    def kinetic_energy(self, y: np.ndarray) -> float:
        _, v = self.unpack(y)
        return float(0.5 * np.sum(self.m[:, None] * v * v))

    def linear_momentum(self, y: np.ndarray) -> np.ndarray:
        _, v = self.unpack(y)
        return self.m @ v

    def angular_momentum(self, y: np.ndarray) -> np.ndarray:
        x, v = self.unpack(y)
        p = self.m[:, None] * v
        if self.dim == 2:
            return np.array([np.sum(x[:, 0] * p[:, 1] - x[:, 1] * p[:, 0])])
        return np.cross(x, p).sum(axis=0)


class Gravity(Effect):
    """Uniform gravity: Qᵢ += mᵢ g; potential V = −Σ mᵢ g·xᵢ."""

    name = "gravity"
    phase = "force"

    def __init__(self, g=None) -> None:
        self.g_in = g

    def bind(self, system) -> None:
        dim = system.dim
        g = np.array([0.0, -9.81] if dim == 2 else [0.0, 0.0, -9.81]) if self.g_in is None else np.asarray(self.g_in, float)
        if g.shape != (dim,):
            raise ValueError(f"g must have shape ({dim},) for a {dim}-D system, got {g.shape}")
        self.g, self.system = g, system
        self._mg = system.m[:, None] * g

    def apply(self, t, y, Q) -> None:
        Q += self._mg

    def potential_energy(self, y) -> float:
        x, _ = self.system.unpack(y)
        return float(-np.sum(self._mg * x))
