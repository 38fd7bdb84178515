"""Floor rows of chapter 03: a pendulum and a short chain by Witkin's multipliers (``pbanim bench floors``).

Each row runs :meth:`pbanim.scene.Scene.simulate` (``diagnostics=False``) on particles under gravity held by
:class:`~pbanim.constraints.Distance` rods through :class:`~pbanim.constraints.Constraints` with Baumgarte
feedback, RK4, and a loop written here by hand from the lecture's equations as a student would write it in
numpy, on dense arrays:

    d = x_b − x_a (a rod's ends; an anchored end is a fixed point),  C = ½(|d|² − L²),  Ċ = d·ḋ,  J̇q̇ = |ḋ|²,
    J: −dᵀ at a, +dᵀ at b,   (J W Jᵀ) λ = −J̇q̇ − J W Q − k_s C − k_d Ċ   (``np.linalg.solve``),
    q̈ = W (Q + Jᵀ λ),

with the four stages of RK4 on (q, q̇) written out. Same method, same equations, same start, same number of
steps; the bench checks that the final states agree to roundoff. pbanim's solve also takes the one
refinement step of the readable solvers (the hand loop does not): a little more work on its side.

========  ==========================  ===========================================
symbol    code                        meaning
========  ==========================  ===========================================
q, q̇      ``q``, ``qd``               positions and velocities, flat (n = N·dim)
W         ``W``                       inverse masses per coordinate
C, Ċ      ``C``, ``Cdot``             ½(|d|² − L²) per rod and its rate d·ḋ
k_s, k_d  ``KS``, ``KD``              Baumgarte gains: ω², 2ω (critical damping)
========  ==========================  ===========================================

Rows: a pendulum (one rod to the origin), a chain of 3 rods and one of 6 (m rows: the dense solve's
m × m Cholesky grows with the chain, the hand loop's ``np.linalg.solve`` with it).
"""

from __future__ import annotations

import numpy as np

from .floors import Floor

__all__ = ["FLOORS", "chain", "chain6", "pendulum"]

H, STEPS, OMEGA, G = 1e-3, 1000, 10.0, np.array([0.0, -9.81])
KS, KD = OMEGA ** 2, 2.0 * OMEGA            # critically damped Baumgarte feedback (ζ = 1)


def _row(n_links: int, name: str) -> Floor:
    """A chain of ``n_links`` rods of 0.5 m hanging from the origin, released 60° from the vertical."""
    from ..constraints import Constraints, Distance
    from ..particles import Gravity, ParticleSystem
    from ..scene import Scene

    N, dim = n_links, 2
    u = np.array([np.sin(np.pi / 3), -np.cos(np.pi / 3)])
    X0 = 0.5 * np.arange(1, N + 1)[:, None] * u
    V0 = np.zeros((N, dim))
    masses = 1.0 + 0.5 * np.arange(N)
    pairs = np.array([[0, -1]] + [[i, i - 1] for i in range(1, N)])
    eff = Constraints([Distance(pairs, anchors=[0.0, 0.0])], stabilization="baumgarte", ks=KS, kd=KD)
    scene = Scene(ParticleSystem(X0, V0, masses), [Gravity(G), eff])

    def pbanim():
        return scene.simulate(STEPS * H, H, "rk4", diagnostics=False).y[:, -1]

    a, b = pairs[:, 0], pairs[:, 1]              # b = −1: the anchor, the last row of [x; anchor]
    m, n, rows = len(pairs), N * dim, np.arange(len(pairs))
    L2 = 0.25 * np.ones(m)
    W = np.repeat(1.0 / masses, dim)
    Q = (masses[:, None] * G).ravel()
    anchor, still = np.zeros((1, dim)), np.zeros((1, dim))

    def accel(q, qd):
        P, V = np.vstack([q.reshape(N, dim), anchor]), np.vstack([qd.reshape(N, dim), still])
        d, w = P[b] - P[a], V[b] - V[a]
        C, Cdot, Jdv = 0.5 * ((d * d).sum(axis=1) - L2), (d * w).sum(axis=1), (w * w).sum(axis=1)
        J = np.zeros((m, N + 1, dim))
        J[rows, a] = -d
        J[rows, b] = d
        J = J[:, :N].reshape(m, n)
        lam = np.linalg.solve((J * W) @ J.T, -Jdv - J @ (W * Q) - KS * C - KD * Cdot)
        return W * (Q + J.T @ lam)

    def hand():
        q, qd = X0.ravel().copy(), V0.ravel().copy()
        h2 = H / 2
        for _ in range(STEPS):
            a1 = accel(q, qd)
            q2, v2 = q + h2 * qd, qd + h2 * a1
            a2 = accel(q2, v2)
            q3, v3 = q + h2 * v2, qd + h2 * a2
            a3 = accel(q3, v3)
            q4, v4 = q + H * v3, qd + H * a3
            a4 = accel(q4, v4)
            q = q + H / 6 * (qd + 2 * v2 + 2 * v3 + v4)
            qd = qd + H / 6 * (a1 + 2 * a2 + 2 * a3 + a4)
        return np.concatenate([q, qd])

    return Floor("constraints", name, "rk4", STEPS, pbanim, hand)


def pendulum() -> Floor:
    """One particle on a rod to the origin (a pendulum as a constrained particle), Baumgarte, RK4."""
    return _row(1, "pendulum: 1 rod, Baumgarte (2-D)")


def chain() -> Floor:
    """Three particles on three rods hanging from the origin, Baumgarte, RK4."""
    return _row(3, "chain: 3 rods, Baumgarte (2-D)")


def chain6() -> Floor:
    """Six particles on six rods hanging from the origin, Baumgarte, RK4."""
    return _row(6, "chain: 6 rods, Baumgarte (2-D)")


FLOORS = [pendulum, chain, chain6]
