"""Floor rows of chapters 01–02: particles under springs and gravity (``pbanim bench floors``).

Each row runs :meth:`pbanim.scene.Scene.simulate` (``diagnostics=False``: only the states) and a loop
written here by hand, from the lecture's equations, as a student would write it in numpy: same method, same
equations, same start, same number of steps; both return the final state y = [x, v] and the bench checks
that they agree to roundoff (equal work).

* one particle on a spring, symplectic Euler (2-D): v₁ = v + h(−k x)/m, x₁ = x + h v₁ (pbanim steps a
  scene this small on floats, the readable kick and drift operation for operation: :mod:`pbanim.particles.lean`;
  a structure-preserving method keeps its own arithmetic, never the linear map);
* two particles on one damped spring, symplectic Euler (2-D): not linear, f = −[k_s(l − r) + k_d l̇] d̂
  written out (pbanim: the same float plan, the spring's force as :class:`~pbanim.particles.DampedSprings`
  rounds it);
* four particles, five damped springs (a square and one diagonal) and gravity, RK4 (2-D): the springs'
  f = −[k_s(l − r) + k_d l̇] d̂ gathered and scattered with the signed incidence matrix B (S × N) —
  d = B x, Q = m g + Bᵀ f — and the four stages of RK4 on (x, v) written out.

The diagnostics that a run computes when asked cost a row of their own in ``pbanim bench particles``.
"""

from __future__ import annotations

import numpy as np

from .floors import Floor

__all__ = ["FLOORS", "damped_pair", "one_particle_spring", "springs_rk4"]

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

    return Floor("particles", "one particle on a spring (2-D)", "symplectic_euler", N_STEPS, pbanim, hand,
                 notes=["one particle on a spring and the damped pair: pbanim's float plan (pbanim.particles.lean, "
                        "chosen once per scene), the readable kick and drift on Python floats, one force evaluation "
                        "per step; symplectic Euler never takes the linear map y1 = S y + s (its invariant H~ holds "
                        "for the method's own arithmetic, ORACLES A1)"])


# two particles joined by one damped spring (not linear: the float plan, one force evaluation per step)
PAIR_X, PAIR_V, PAIR_M = np.array([[0.0, 0.0], [1.2, 0.0]]), np.array([[0.0, 0.3], [0.0, -0.6]]), np.array([1.0, 0.5])


def damped_pair() -> Floor:
    """Two particles on one damped spring (rest 1 m), symplectic Euler: v₁ = v + h W Q(x, v), x₁ = x + h v₁."""
    from ..particles import DampedSprings, ParticleSystem
    from ..scene import Scene

    scene = Scene(ParticleSystem(PAIR_X, PAIR_V, PAIR_M), [DampedSprings([[0, 1]], KS, KD, rest_length=1.0)])
    W = 1.0 / PAIR_M[:, None]

    def pbanim():
        return scene.simulate(N_STEPS * H, H, "symplectic_euler", diagnostics=False).y[:, -1]

    def accel(x, v):
        d, w = x[0] - x[1], v[0] - v[1]
        length = np.sqrt(d @ d)
        f = -(KS * (length - 1.0) + KD * (w @ d) / length) / length * d
        return W * np.array([f, -f])

    def hand():
        x, v = PAIR_X.copy(), PAIR_V.copy()
        for _ in range(N_STEPS):
            v = v + H * accel(x, v)
            x = x + H * v
        return np.concatenate([x.ravel(), v.ravel()])

    return Floor("particles", "2 particles, 1 damped spring (2-D)", "symplectic_euler", N_STEPS, pbanim, hand)


# four particles: a unit square with one diagonal, tumbling under gravity
SQ_X = np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]])
SQ_V = np.array([[0.0, 0.0], [0.5, 0.0], [0.0, -0.3], [0.2, 0.1]])
SQ_M = np.array([1.0, 2.0, 1.5, 1.0])
SQ_PAIRS = np.array([[0, 1], [1, 2], [2, 3], [3, 0], [0, 2]])
KS, KD, G, SQ_STEPS = 50.0, 0.5, np.array([0.0, -9.81]), 1000


def springs_rk4() -> Floor:
    """Four particles, five damped springs (rest lengths from the start) and gravity, RK4, h = 1 ms."""
    from ..particles import DampedSprings, Gravity, ParticleSystem
    from ..scene import Scene

    springs = DampedSprings(SQ_PAIRS, KS, KD)
    scene = Scene(ParticleSystem(SQ_X, SQ_V, SQ_M), [Gravity(G), springs])
    a, b = SQ_PAIRS[:, 0], SQ_PAIRS[:, 1]
    rest = np.linalg.norm(SQ_X[a] - SQ_X[b], axis=1)
    B = np.zeros((len(SQ_PAIRS), len(SQ_X)))
    B[np.arange(len(a)), a], B[np.arange(len(b)), b] = 1.0, -1.0
    Bt, mg, m = B.T.copy(), SQ_M[:, None] * G, SQ_M[:, None]

    def pbanim():
        return scene.simulate(SQ_STEPS * H, H, "rk4", diagnostics=False).y[:, -1]

    def accel(x, v):
        d = B @ x                                        # x_a − x_b
        length = np.sqrt((d * d).sum(axis=1))
        ldot = ((B @ v) * d).sum(axis=1) / length
        f = -((KS * (length - rest) + KD * ldot) / length)[:, None] * d
        return (mg + Bt @ f) / m

    def hand():
        x, v = SQ_X.copy(), SQ_V.copy()
        h2 = H / 2
        for _ in range(SQ_STEPS):
            a1 = accel(x, v)
            x2, v2 = x + h2 * v, v + h2 * a1
            a2 = accel(x2, v2)
            x3, v3 = x + h2 * v2, v + h2 * a2
            a3 = accel(x3, v3)
            x4, v4 = x + H * v3, v + H * a3
            a4 = accel(x4, v4)
            x = x + H / 6 * (v + 2 * v2 + 2 * v3 + v4)
            v = v + H / 6 * (a1 + 2 * a2 + 2 * a3 + a4)
        return np.concatenate([x.ravel(), v.ravel()])

    return Floor("particles", "4 particles, 5 damped springs, gravity (2-D)", "rk4", SQ_STEPS, pbanim, hand)


FLOORS = [one_particle_spring, damped_pair, springs_rk4]
