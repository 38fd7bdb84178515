"""Floor rows of chapter 01: one particle on a spring, symplectic Euler (``pbanim bench floors``)."""

from __future__ import annotations

import numpy as np

from .floors import Floor

__all__ = ["FLOORS"]

K, M, H, N_STEPS = 20.0, 0.5, 1e-3, 2000
X0, V0 = np.array([1.0, 0.0]), np.array([0.0, 0.5])


def one_particle_spring() -> Floor:
    """A 0.5 kg particle on a 20 N/m spring to the origin in 2-D: v₁ = v + h(−k x)/m, x₁ = x + h v₁."""
    from ..particles import AnchorSprings, ParticleSystem
    from ..scene import Scene

    scene = Scene(ParticleSystem([X0], [V0], masses=M), [AnchorSprings([0], [[0.0, 0.0]], K)])

    def pbanim():
        return scene.simulate(N_STEPS * H, H, "symplectic_euler", diagnostics=False).y[:, -1]

    def hand():
        x, v = X0.copy(), V0.copy()
        for _ in range(N_STEPS):
            v = v + H * (-K * x) / M
            x = x + H * v
        return np.concatenate([x, v])

    return Floor("particles", "one particle on a spring (2-D)", "symplectic_euler", N_STEPS, pbanim, hand)


FLOORS = [one_particle_spring]
