"""Checks of assignments ch03_constraints (multipliers with Baumgarte) and ch04_reduced (a reduced pendulum).

Chapter 03: the student writes the right-hand side and the solve of Witkin's multiplier system

    J W Jᵀ λ = c − J W Q,     c = −J̇q̇ − k_s C − k_d Ċ,     Q_C = Jᵀλ,   q̈ = W (Q + Q_C),

so that the constraint obeys C̈ = −k_s C − k_d Ċ (Baumgarte) — and C̈ = 0 without feedback.

Chapter 04: the student writes the reduced equations (JᵀMJ) ü = Jᵀ(Q − M b), b = J̇u̇, and the
constraint force Q_C = M q̈ − Q of a chart q = q(u).

=======================  ==================================================================  ======
check                    oracle                                                              id
=======================  ==================================================================  ======
bead_tension             −λR = m(v²/R + g cos θ) for a bead on a circle, at several states   B1
constraint_acceleration  J q̈ + J̇q̇ = −k_s C − k_d Ċ on a random chain, q̈ = W(Q + Jᵀλ)        B5
baumgarte_decay          C(t) = (C₀ + (Ċ₀ + ω C₀) t) e^(−ωt) for critical gains (ζ = 1)      B2
bead_energy              no feedback: E constant, C ≈ 0 over 1 s (RK4)                       B1
pendulum_accel           θ̈ = −(g/L) sin θ                                                    B7
pendulum_period          T = 4√(L/g) K(sin²(θ₀/2)) at θ₀ = 2 rad                              A5
pendulum_tension         Q_C = −m(Lθ̇² + g cos θ) x̂ (the rod pulls towards the pivot)         B1
double_pendulum_energy   E constant to 1e-8 relative over 2 s (RK4, h = 1 ms)                 B7
=======================  ==================================================================  ======

Limiting cases: k_s = k_d = 0 removes the feedback (bead_energy); a single pendulum has Jᵀ b = 0, so
only the double pendulum sees a missing J̇u̇ term — that is why it carries the most points.
"""

from __future__ import annotations

import numpy as np

from .registry import CheckFailed, Mutant, array, at_most, attr, check, close

CH03_CHECKS: list = []
CH04_CHECKS: list = []
G = 9.81


def _bead(R=1.5, m=2.0, theta=0.0, omega=0.0):
    from ..particles import ParticleSystem

    x = R * np.array([np.sin(theta), -np.cos(theta)])
    v = R * omega * np.array([np.cos(theta), np.sin(theta)])
    return ParticleSystem([x], [v], masses=m)


@check(CH03_CHECKS, "bead_tension", 25, "the multiplier of a bead on a circle is its tension m(v²/R + g cos θ)",
       "B1", regions=("solve_multipliers",))
def bead_tension(mod):
    from ..constraints.kinds import OnCircle

    R, m = 1.5, 2.0
    solve = attr(mod, "solve_multipliers")
    for theta, omega in ((0.0, 2.0), (0.7, -1.0), (2.0, 0.5)):
        ps = _bead(R, m, theta, omega)
        sol = solve([OnCircle([0], [0.0, 0.0], R)], ps, ps.state(), [[0.0, -m * G]])
        lam = array("solve_multipliers(...).lam", getattr(sol, "lam", None), (1,))
        close(f"tension −λR at θ = {theta}, θ̇ = {omega}", -lam[0] * R, m * (R * omega**2 + G * np.cos(theta)),
              rtol=1e-12, unit="N", why="T = m(v²/R + g cos θ); the term v²/R comes from J̇q̇")
    return "−λR = m(v²/R + g cos θ) at three states (rtol 1e-12)"


@check(CH03_CHECKS, "constraint_acceleration", 25, "the solve makes C̈ = −k_s C − k_d Ċ exactly", "B5",
       regions=("solve_multipliers",))
def constraint_acceleration(mod):
    from ..constraints.assembly import ConstraintSet
    from ..constraints.kinds import Distance
    from ..particles import ParticleSystem

    rng = np.random.default_rng(3)
    x = np.cumsum(rng.normal(size=(3, 2)), axis=0)
    ps = ParticleSystem(x, rng.normal(size=(3, 2)), masses=[1.0, 2.0, 0.5])
    rods = [Distance([[0, -1], [0, 1], [1, 2]], lengths=[0.9, 1.1, 1.0], anchors=[0.0, 0.0])]
    Q = rng.normal(size=(3, 2))
    ks, kd = 40.0, 9.0
    sol = attr(mod, "solve_multipliers")(rods, ps, ps.state(), Q, ks=ks, kd=kd)
    qdd = array("solve_multipliers(...).qdd", getattr(sol, "qdd", None), (6,))
    lam = array("solve_multipliers(...).lam", getattr(sol, "lam", None), (3,))
    cset = ConstraintSet(rods, 3, 2, ps.W, ps.x0)
    asm = cset.assemble(*ps.unpack(ps.state()), pairs=False)
    target = -ks * asm.C - kd * asm.Cdot
    close("C̈ = J q̈ + J̇q̇ vs −k_s C − k_d Ċ", asm.J @ qdd + asm.Jdv, target, atol=1e-10, rtol=1e-12,
          why="c = −J̇q̇ − k_s C − k_d Ċ (mind the signs: the feedback must pull C back to 0)")
    close("q̈ vs W (Q + Jᵀλ)", qdd, ps._Wflat * (Q.ravel() + asm.J.T @ lam), atol=1e-10, rtol=1e-12)
    return "C̈ = −k_s C − k_d Ċ and q̈ = W(Q + Jᵀλ) on a 3-rod chain"


@check(CH03_CHECKS, "baumgarte_decay", 30, "Baumgarte feedback pulls a violated constraint back as a critically "
       "damped oscillator", "B2", regions=("Constraints._solve",))
def baumgarte_decay(mod):
    from ..constraints.kinds import OnCircle
    from ..particles import Gravity, ParticleSystem
    from ..scene import Scene

    R, wb = 1.0, 8.0
    ps = ParticleSystem([[1.05 * R * np.sin(0.6), -1.05 * R * np.cos(0.6)]], [[1.0, 0.5]], masses=1.0)
    eff = attr(mod, "Constraints")([OnCircle([0], [0.0, 0.0], R)], stabilization="baumgarte",
                                   natural_frequency=wb, damping_ratio=1.0)
    res = Scene(ps, [Gravity(), eff]).simulate(1.5, 0.002, "rk4")
    x, v = res.y[:2], res.y[2:4]
    C = 0.5 * (np.sum(x * x, 0) - R * R)
    C0, Cd0 = C[0], float(x[:, 0] @ v[:, 0])
    exact = (C0 + (Cd0 + wb * C0) * res.t) * np.exp(-wb * res.t)
    # measured 8.5e-11 for the reference (RK4, h = 2 ms): bound 5e-10 (C in m²)
    err = close("C(t) vs (C₀ + (Ċ₀ + ωC₀)t)e^(−ωt)", C, exact, atol=5e-10, unit="m²",
                why="C̈ = −ω²C − 2ωĊ for k_s = ω², k_d = 2ω")
    return f"C(t) follows the critically damped closed form (max error {err:.1e} m²)"


@check(CH03_CHECKS, "bead_energy", 20, "without feedback a bead keeps its energy and its circle", "B1",
       public=False, regions=("Constraints._solve",))
def bead_energy(mod):
    from ..constraints.kinds import OnCircle
    from ..particles import Gravity
    from ..scene import Scene

    R, m = 1.5, 2.0
    ps = _bead(R, m, np.pi / 2, 0.0)
    res = Scene(ps, [Gravity(), attr(mod, "Constraints")([OnCircle([0], [0.0, 0.0], R)])]).simulate(1.0, 0.002, "rk4")
    x, v = res.y[:2], res.y[2:4]
    E = 0.5 * m * np.sum(v * v, 0) + m * G * x[1]
    dE = float(np.max(np.abs(E - E[0]))) / (m * G * R)
    # measured 3.6e-10 (energy) and 3.4e-10 m² (C) for the reference: bounds 2e-9
    at_most("relative energy drift over 1 s", dE, 2e-9, why="the constraint force does no work")
    at_most("max |C| over 1 s", float(np.max(np.abs(0.5 * (np.sum(x * x, 0) - R * R)))), 2e-9, unit="m²",
            why="C̈ = 0 keeps C = 0 when C₀ = Ċ₀ = 0; a missing J̇q̇ lets the bead fly off")
    return f"energy drift {dE:.1e}, |C| ≤ 2e-9 m² over 1 s"


CH03_MUTANTS = (
    Mutant("baumgarte_sign", "sign error in the Baumgarte term (+k_s C)",
           (("c = -asm.Jdv - ks * asm.C - kd * asm.Cdot", "c = -asm.Jdv + ks * asm.C - kd * asm.Cdot"),),
           ("constraint_acceleration", "baumgarte_decay")),
    Mutant("missing_jdot", "the J̇q̇ term is missing from the right-hand side",
           (("c = -asm.Jdv - ks * asm.C - kd * asm.Cdot", "c = - ks * asm.C - kd * asm.Cdot"),),
           ("bead_tension", "constraint_acceleration", "baumgarte_decay", "bead_energy")),
)


# --------------------------------------------------------------------------------------------------
# chapter 04: a pendulum in reduced coordinates
# --------------------------------------------------------------------------------------------------
def _pendulum(mod, L=1.5, m=2.0, theta0=0.3, omega0=0.0):
    from ..particles import Gravity

    q = lambda u: L * np.array([np.sin(u[0]), -np.cos(u[0])])            # noqa: E731
    J = lambda u: L * np.array([[np.cos(u[0])], [np.sin(u[0])]])          # noqa: E731
    Jd = lambda u, ud: L * ud[0] ** 2 * np.array([-np.sin(u[0]), np.cos(u[0])])  # noqa: E731
    return attr(mod, "ReducedSystem")(q, J, Jd, masses=m, dim=2, forces=[Gravity([0.0, -G])], u0=[theta0],
                                      udot0=[omega0])


@check(CH04_CHECKS, "pendulum_accel", 20, "a pendulum's reduced equation is θ̈ = −(g/L) sin θ", "B7",
       regions=("ReducedSystem._solve",))
def pendulum_accel(mod):
    L = 1.5
    red = _pendulum(mod, L)
    for th in (0.3, 1.2, 2.5):
        dy = array("ReducedSystem.rhs(t, [θ, θ̇])", red.rhs(0.0, np.array([th, 0.7])), (2,))
        close(f"θ̈ at θ = {th}", dy[1], -G / L * np.sin(th), rtol=1e-13, unit="rad/s²",
              why="(JᵀMJ) ü = Jᵀ(Q − M b): mL² θ̈ = −mgL sin θ")
    return "θ̈ = −(g/L) sin θ at three angles (rtol 1e-13)"


@check(CH04_CHECKS, "pendulum_period", 25, "the period at large amplitude is 4√(L/g) K(sin²(θ₀/2))", "A5",
       public=False, regions=("ReducedSystem._solve",))
def pendulum_period(mod):
    from ..models.reduced import pendulum_period as exact_period

    L, th0, h = 1.5, 2.0, 0.002
    T = exact_period(th0, L, G)
    res = _pendulum(mod, L, theta0=th0).simulate(0.6 * T, h, "rk4")
    w = res.y[1]
    k = np.flatnonzero((w[:-1] < 0) & (w[1:] >= 0))
    if k.size == 0:
        raise CheckFailed(f"θ̇ never returns to 0 within 0.6 T = {0.6 * T:.3f} s; expected the swing to turn at T/2")
    i = k[0]
    t_half = res.t[i] - w[i] * (res.t[i + 1] - res.t[i]) / (w[i + 1] - w[i])
    # measured 6.7e-10 s for the reference (RK4 h = 2 ms, θ̇ interpolated linearly): bound 5e-9 s
    err = close("period from the turning point of θ̇", 2 * t_half, T, atol=5e-9, unit="s")
    return f"T = {2 * t_half:.5f} s vs exact {T:.5f} s (error {err:.1e} s)"


@check(CH04_CHECKS, "pendulum_tension", 20, "the chart's constraint force is the rod tension towards the pivot",
       "B1", regions=("ReducedSystem.constraint_force",))
def pendulum_tension(mod):
    L, m = 1.5, 2.0
    red = _pendulum(mod, L, m)
    for th, om in ((0.0, 2.0), (1.0, -0.5), (2.4, 1.5)):
        QC = array("ReducedSystem.constraint_force(t, y)", red.constraint_force(0.0, np.array([th, om])), (1, 2))
        xhat = np.array([np.sin(th), -np.cos(th)])
        close(f"Q_C at θ = {th}, θ̇ = {om}", QC[0], -m * (L * om**2 + G * np.cos(th)) * xhat, rtol=1e-12, unit="N",
              why="Q_C = M q̈ − Q with q̈ = J ü + J̇u̇")
    return "Q_C = −m(Lθ̇² + g cos θ) x̂ at three states (rtol 1e-12)"


@check(CH04_CHECKS, "double_pendulum_energy", 35, "a double pendulum keeps its energy (needs the J̇u̇ term)", "B7",
       regions=("ReducedSystem._solve",))
def double_pendulum_energy(mod):
    from ..models.reduced import n_link_chart
    from ..particles import Gravity

    q, J, Jd = n_link_chart([1.0, 0.8])
    red = attr(mod, "ReducedSystem")(q, J, Jd, masses=[1.0, 2.0], dim=2, forces=[Gravity([0.0, -G])],
                                     u0=[1.0, 1.5], udot0=[0.0, 0.0])
    res = red.simulate(2.0, 0.001, "rk4")
    E = np.array([red.energy(res.y[:, k]) for k in range(0, res.y.shape[1], 50)])
    dE = float(np.max(np.abs(E - E[0]))) / (3.0 * G * 1.8)
    # measured 3.7e-12 for the reference (RK4, h = 1 ms, 2 s): bound 3e-11 relative to Σm g ΣL
    at_most("energy drift of the double pendulum / (Σm g ΣL)", dE, 3e-11,
            why="(JᵀMJ) ü = Jᵀ(Q − M J̇u̇): dropping J̇u̇ breaks energy conservation")
    return f"relative energy drift {dE:.1e} over 2 s"


CH04_MUTANTS = (
    Mutant("missing_jdot", "the J̇u̇ (velocity-product) term is missing: (JᵀMJ) ü = JᵀQ",
           (("r = J.T @ (Q - self.m * b)", "r = J.T @ Q"),), ("double_pendulum_energy",)),
    Mutant("unweighted_mass", "the generalized mass forgets the masses: JᵀJ instead of JᵀMJ",
           (("A = J.T @ mJ", "A = J.T @ J"),), ("pendulum_accel", "pendulum_period", "pendulum_tension",
                                                 "double_pendulum_energy")),
)
