"""Checks of assignment ch01_particles: force objects and the symplectic-Euler particle step.

The student writes, in a copy of :mod:`pbanim.particles.system`, the derivative ẏ = [v, W Q], the force
objects gravity (Qᵢ += mᵢ g, V = −Σ mᵢ g·xᵢ) and drag (Qᵢ += −k_d vᵢ), and the in-place symplectic Euler
step ``kick_drift`` (v₁ = v₀ + h W Q, x₁ = x₀ + h v₁). Each check builds its particles with the
student's classes and compares with a closed form:

===================  ========================================================================  ======
check                oracle                                                                    id
===================  ========================================================================  ======
gravity_force        Q = m g for each particle (2-D and 3-D, unequal masses)                    A8
gravity_potential    V = −Σ mᵢ g·xᵢ                                                             A8
drag_force           Q = −k_d v (one coefficient and one per particle)                          A7
derivative           ẏ = [v, Q/m] for an arbitrary force                                       A8
free_fall_drag       x(t), v(t) of a projectile with linear drag (RK4, error O(h⁴))             A8
symplectic_step      one step equals the closed-form kick–drift map; H̃ = E − ½hω²m x v is      A1
                     conserved to roundoff on the oscillator (explicit Euler gains 1 + h²ω²)
===================  ========================================================================  ======

Limiting cases: k_d → 0 reduces the drag closed form to free fall (checked at k_d = 0.5 kg/s, where
the two differ by metres); h → 0 makes symplectic and explicit Euler agree, so the step check uses
hω = 0.2, where one step already separates them by 4 %.
"""

from __future__ import annotations

import numpy as np

from .registry import Mutant, array, at_most, attr, check, close

CHECKS: list = []
G2 = np.array([0.0, -9.81])


@check(CHECKS, "gravity_force", 15, "uniform gravity pulls each particle with m g", "A8",
       regions=("Gravity.apply",))
def gravity_force(mod):
    from ..scene import Scene

    m = np.array([1.0, 2.0, 3.5])
    for dim, g in ((2, [0.0, -10.0]), (3, [1.0, 0.0, -9.81])):
        ps = attr(mod, "ParticleSystem")(np.arange(3 * dim, dtype=float).reshape(3, dim), masses=m)
        Q = Scene(ps, [attr(mod, "Gravity")(g)]).applied_forces(0.0, ps.state())
        close(f"Gravity.apply: Q in {dim}-D", Q, m[:, None] * np.asarray(g), rtol=1e-15, unit="N",
              why="each particle feels mᵢ g")
    return "Q = m g in 2-D and 3-D (exact)"


@check(CHECKS, "gravity_potential", 10, "gravity's potential V = −Σ m g·x (energy bookkeeping)", "A8",
       regions=("Gravity.potential_energy",))
def gravity_potential(mod):
    ps = attr(mod, "ParticleSystem")([[0.0, 1.0], [2.0, -3.0]], masses=[2.0, 0.5])
    grav = attr(mod, "Gravity")([0.0, -10.0])
    grav.bind(ps)
    V = grav.potential_energy(ps.state())
    close("Gravity.potential_energy", V, -(2.0 * -10.0 * 1.0 + 0.5 * -10.0 * -3.0), rtol=1e-14, unit="J",
          why="V = −Σ mᵢ g·xᵢ")
    return f"V = {float(V):g} J (exact)"


@check(CHECKS, "drag_force", 10, "viscous drag opposes velocity, Q = −k_d v", "A7", regions=("Drag.apply",))
def drag_force(mod):
    from ..scene import Scene

    v = np.array([[1.0, -2.0], [0.5, 3.0], [-4.0, 0.0]])
    for kd in (0.3, [0.1, 0.2, 0.7]):
        ps = attr(mod, "ParticleSystem")(np.zeros((3, 2)), v, masses=2.0)
        Q = Scene(ps, [attr(mod, "Drag")(kd)]).applied_forces(0.0, ps.state())
        close(f"Drag.apply with k_d = {kd}", Q, -np.asarray(kd, float).reshape(-1, 1) * v, rtol=1e-15, unit="N",
              why="Q = −k_d v (it must oppose the velocity)")
    return "Q = −k_d v, scalar and per-particle k_d (exact)"


@check(CHECKS, "derivative", 15, "Newton's law as a first-order system: ẋ = v, v̇ = Q/m", "A8",
       regions=("ParticleSystem.derivative",))
def derivative(mod):
    from ..particles import UserForce
    from ..scene import Scene

    rng = np.random.default_rng(7)
    x, v, m = rng.normal(size=(4, 3)), rng.normal(size=(4, 3)), np.array([1.0, 2.0, 0.5, 4.0])
    ps = attr(mod, "ParticleSystem")(x, v, masses=m)
    F = rng.normal(size=(4, 3))
    dy = Scene(ps, [UserForce(lambda t, xx, vv: F)]).rhs(0.0, ps.state())
    close("ParticleSystem.derivative", dy, np.concatenate([v.ravel(), (F / m[:, None]).ravel()]), rtol=1e-15,
          why="ẏ = [v, W Q] on the flat state [x.ravel(), v.ravel()]")
    return "ẏ = [v, Q/m] (exact)"


@check(CHECKS, "free_fall_drag", 20, "a projectile with linear drag follows the exponential closed form", "A8",
       public=False, regions=("Gravity.apply", "Drag.apply", "ParticleSystem.derivative"))
def free_fall_drag(mod):
    from ..scene import Scene

    m, k, v0, h, T = 2.0, 0.5, np.array([10.0, 10.0]), 0.01, 2.0
    ps = attr(mod, "ParticleSystem")([[0.0, 0.0]], [v0], masses=m)
    res = Scene(ps, [attr(mod, "Gravity")(G2), attr(mod, "Drag")(k)]).simulate(T, h, "rk4")
    vT = m * G2 / k
    e = np.exp(-k * res.t / m)[:, None]
    x_ex = vT * res.t[:, None] + (v0 - vT) * (m / k) * (1 - e)
    # measured 1.9e-11 m for the reference (RK4, h = 0.01 s): bound 1e-10 m
    err = close("position x(t) vs the drag closed form", res.y[:2].T, x_ex, atol=1e-10, unit="m",
                why="x = v_T t + (v₀ − v_T)(m/k)(1 − e^(−kt/m)), v_T = m g / k")
    return f"max |x − x_exact| = {err:.1e} m over {T} s (tolerance 1e-10 m)"


@check(CHECKS, "symplectic_step", 30, "symplectic Euler: kick then drift; keeps H̃ = E − ½hω²m x v exactly", "A1",
       regions=("ParticleSystem.kick_drift",))
def symplectic_step(mod):
    from ..particles import AnchorSprings
    from ..scene import Scene

    m, k, h = 2.0, 8.0, 0.1                       # ω = 2 rad/s, hω = 0.2
    w2 = k / m
    ps = attr(mod, "ParticleSystem")([[1.0, 0.0]], [[0.0, 0.5]], masses=m)
    y0 = ps.state()
    out = np.zeros_like(y0)
    Q = -k * y0[:2].reshape(1, 2)
    res = ps.kick_drift(y0, Q.copy(), h, out)
    y1 = array("kick_drift(...) return value", res if res is not None else out, y0.shape)
    v1 = y0[2:] - h * w2 * y0[:2]
    close("one kick_drift step", y1, np.concatenate([y0[:2] + h * v1, v1]), rtol=1e-14,
          why="v₁ = v₀ + h W Q, then x₁ = x₀ + h v₁ (the new velocity: explicit Euler uses v₀)")
    res = Scene(ps, [AnchorSprings([0], [[0.0, 0.0]], k)]).simulate(20.0, h, "symplectic_euler")
    x, v = res.y[:2], res.y[2:4]
    Ht = 0.5 * m * np.sum(v * v, 0) + 0.5 * k * np.sum(x * x, 0) - 0.5 * h * k * np.sum(x * v, 0)
    drift = float(np.max(np.abs(Ht - Ht[0])) / Ht[0])
    # measured 8.4e-16 (4 ε) for the reference over 200 steps: bound 5e-15
    at_most("relative drift of H̃ = E − ½ h k x·v over 200 steps", drift, 5e-15,
            why="symplectic Euler conserves H̃ exactly on the oscillator (ORACLES A1)")
    return f"one step exact; H̃ drift {drift:.1e} over 200 steps (tolerance 5e-15)"


MUTANTS = (
    Mutant("explicit_euler", "explicit Euler where symplectic Euler was asked: the drift uses the old v",
           (("np.multiply(vo, h, out=a)", "np.multiply(y[s + i: s + j], h, out=a)"),), ("symplectic_step",)),
    Mutant("gravity_without_mass", "gravity adds g instead of m g",
           (("        Q += self._mg\n", "        Q += self.g\n"),), ("gravity_force", "free_fall_drag")),
    Mutant("drag_sign", "drag pushes along the velocity (+k_d v)",
           (("Q -= self._k0 * v", "Q += self._k0 * v"), ("Qf -= self._kdflat", "Qf += self._kdflat"),
            ("Q -= self.kd[:, None] * v", "Q += self.kd[:, None] * v")), ("drag_force", "free_fall_drag")),
)

