"""Checks of ch10_impact_gradient (∂S/∂u through an impact: the saltation jump) — chapter 10.

In a copy of :mod:`pbanim.design.impact` the student writes how the sensitivities Φ = ∂y/∂u (carried as
the rows of T = Φᵀ) jump at an impact. The impulse itself (chapter 6) and the tangents of the contact
quantities are given; the student writes

    the event time        δτ = −δg / ġ,   T_s = T + δτ f⁻           (apply_impact.event_time)
    the impulse's tangent δj = −(δε v_rel + (1 + ε) δv_rel + j δk) / k,
                          δP⁺ = δP + δj n + j δn,  δL⁺ = δL + δj c + j δc   (apply_impact.impulse_derivative)
    the flow after        T⁺ = T₁ − δτ f⁺                           (saltation_post)

so that Φ⁺ = G (Φ⁻ + f⁻ δτ) + G_u − f⁺ δτ (the module's docstring). The checks call the student's
functions at the instant of impact — no integration, so every number is a closed form (ORACLES H1):

=======================  ==================================================================  ======
check                    oracle                                                              id
=======================  ==================================================================  ======
saltation_matrix         a ball hitting the floor: Φ⁺ = 𝟙 except (h, v) ↦                     H1
                         S = [[−ε, 0], [−(1+ε)g/v⁻, −ε]] (in momenta: P = m v)
apex_derivatives         S between the exact free-fall maps: dh₁/dh₀ = ε² at the apex,          H1
                         dz(T)/dh₀ = −ε + (1+ε)(T − t₁)/t₁ (at fixed T after the bounce)
restitution_derivative   the ε column: dP⁺/dε = −m v⁻; dh₁/dε = 2εh₀, dz(T)/dε = g t₁ (T − t₁)   H1
sphere_pair              two spheres head-on (same gravity): the relative gap and speed jump     H1
                         by −ε 𝟙, the centre of mass passes unchanged
=======================  ==================================================================  ======

The pair's closed form is H1's derivation with the gravity terms cancelling. In relative coordinates
(d, w) along the line of centres the flow is f = (w, 0) before and after, the jump is G = diag(1, −ε),
∇g = (1, 0) and ġ = w⁻, so S = G + (f⁺ − G f⁻) ∇gᵀ / ġ = diag(1, −ε) + (−(1 + ε), 0)ᵀ(1, 0) = −ε 𝟙;
the centre of mass feels no net impulse and passes unchanged.

Limiting cases: ε = 1 keeps the speed and S = [[−1, 0], [−2g/v⁻, −1]]; dropping the event-time terms
gives diag(1, −ε) for the ball (δh passes through), which the first two checks refuse.
"""

from __future__ import annotations

import numpy as np

from .registry import CheckFailed, Mutant, array, attr, check, close

CHECKS: list = []
G = 9.81


def _model(masses, inertia, p: int):
    """Free flight of spheres of ``masses`` and scalar ``inertia`` under gravity, no mass parameters."""
    from ..design.flight import FlightModel

    m = np.asarray(masses, dtype=float)
    N = m.size
    Iinv = np.tile(1.0 / np.asarray(inertia, dtype=float)[:, None], (1, 3))
    return FlightModel(N, 1.0 / m, m, Iinv, np.array([0.0, 0.0, -G]), np.zeros((p, N)), np.zeros((p, N)),
                       np.zeros((p, N, 3)))


def _jump(mod, scene, y, eps, masses, inertia):
    """Φ⁺ (13N × 13N + 1: the state columns, then the ε column) from the student's functions."""
    from ..design.impact import Features

    N = len(masses)
    n = 13 * N
    p = n + 1
    T = np.vstack([np.eye(n), np.zeros((1, n))])
    deps = np.zeros(p)
    deps[-1] = 1.0
    model = _model(masses, inertia, p)
    feat = Features(scene)
    normals = np.array([[0.0, 0.0, 1.0]] * len(scene.planes)).reshape(-1, 3)     # the floor's normal
    k = feat.n_plane if len(feat.pairs) else 0
    out = attr(mod, "apply_impact")(model, feat, k, 0.0, y, T, normals, np.zeros((p, len(scene.planes), 3)),
                                    eps, deps)
    if not isinstance(out, tuple) or len(out) != 4:
        raise CheckFailed(f"apply_impact must return (y⁺, T⁺, Impact, δτ), got {type(out).__name__}")
    y1, T1, _, dtau = out
    T1 = array("apply_impact(...)[1] (T⁺ before the flow term)", T1, (p, n))
    dtau = array("apply_impact(...)[3] (δτ)", dtau, (p,))
    Tp = array("saltation_post(...)", attr(mod, "saltation_post")(model, np.asarray(y1, float), T1, dtau), (p, n))
    return Tp.T


def _ball(eps, m, h0, R=0.1):
    """The scene, the state at the impact (gap 0, v⁻ = −g t₁) and t₁ for a ball dropped from gap h₀."""
    from ..collision import Plane, Sphere
    from ..design.scene import DesignBody, DesignScene

    scene = DesignScene([DesignBody(Sphere(R), mass=m, position=[0, 0, R + h0])], [Plane([0, 0, 1])],
                        gravity=[0, 0, -G], restitution=eps)
    t1 = np.sqrt(2 * h0 / G)
    y = np.zeros(13)
    y[2], y[3], y[9] = R, 1.0, -m * G * t1
    return scene, y, t1, 0.4 * m * R * R


def _flight(t: float, m: float) -> np.ndarray:
    """The exact free-fall map of (z, P_z) over a time t: z += t P_z/m (gravity adds no sensitivity)."""
    return np.array([[1.0, t / m], [0.0, 1.0]])


def _ball_jump(mod, eps, m, h0):
    scene, y, t1, inertia = _ball(eps, m, h0)
    return _jump(mod, scene, y, eps, [m], [inertia]), t1


@check(CHECKS, "saltation_matrix", 35, "a ball hits the floor: (h, v) jump by S = [[−ε, 0], [−(1+ε)g/v⁻, −ε]]",
       "H1", regions=("apply_impact.event_time", "apply_impact.impulse_derivative", "saltation_post"))
def saltation_matrix(mod):
    worst = 0.0
    for eps, m, h0 in ((0.7, 1.0, 1.0), (0.4, 2.5, 0.3)):
        Phi, t1 = _ball_jump(mod, eps, m, h0)
        vminus = -G * t1
        want = np.eye(13)
        want[2, 2], want[2, 9] = -eps, 0.0
        want[9, 2], want[9, 9] = -(1 + eps) * G / vminus * m, -eps           # momentum row: P = m v
        # H1's tolerance 1e-12 (relative to the largest entry, ≤ 30 here); the reference: measured 1.8e-15 absolute
        worst = max(worst, close(f"Φ⁺ = ∂y⁺/∂y⁻ (ε = {eps}, m = {m} kg, h₀ = {h0} m)", Phi[:, :13], want,
                                 atol=1e-12 * np.abs(want).max(),
                                 why="S on (z, P_z), identity elsewhere; without δτ the jump would be diag(1, −ε)"))
    return f"S exact for two drops (worst {worst:.1e})"


@check(CHECKS, "apex_derivatives", 25, "between the free-fall maps: dh₁/dh₀ = ε² at the apex, dz(T)/dh₀", "H1",
       public=False, regions=("apply_impact.event_time", "apply_impact.impulse_derivative", "saltation_post"))
def apex_derivatives(mod):
    for eps, m, h0, T in ((0.7, 1.0, 1.0, 1.0), (0.5, 3.0, 0.8, 0.9)):
        Phi, t1 = _ball_jump(mod, eps, m, h0)
        S = Phi[np.ix_([2, 9], [2, 9])]                                      # (z, P_z) block
        apex = t1 + eps * t1                                                 # v⁺ = εg t₁ rises for εt₁
        d_apex = _flight(apex - t1, m) @ S @ _flight(t1, m)
        close(f"dh₁/dh₀ at the apex (ε = {eps})", d_apex[0, 0], eps ** 2, atol=1e-12,
              why="the apex height after the bounce is ε² h₀")
        s = T - t1
        d_T = _flight(s, m) @ S @ _flight(t1, m)
        # z(T) = εg t₁ s − g s²/2 with s = T − t₁, t₁ = √(2h₀/g), dt₁/dh₀ = 1/(g t₁): dz/dh₀ = −ε + (1+ε) s/t₁
        close(f"dz(T)/dh₀ at T = {T} s (ε = {eps})", d_T[0, 0], -eps + (1 + eps) * s / t1, atol=1e-12)
    return "dh₁/dh₀ = ε² and dz(T)/dh₀ exact"


@check(CHECKS, "restitution_derivative", 25, "the ε column: dP⁺/dε = −m v⁻, dh₁/dε = 2εh₀, dz(T)/dε = g t₁(T − t₁)",
       "H1", regions=("apply_impact.impulse_derivative",))
def restitution_derivative(mod):
    for eps, m, h0, T in ((0.7, 1.0, 1.0, 1.0), (0.3, 2.0, 0.5, 0.7)):
        Phi, t1 = _ball_jump(mod, eps, m, h0)
        col = Phi[:, 13]
        want = np.zeros(13)
        want[9] = m * G * t1
        close(f"∂y⁺/∂ε (ε = {eps}, m = {m} kg)", col, want, atol=1e-12 * m * G * t1, unit="",
              why="j = −(1 + ε) v⁻ m: only P_z moves, by −m v⁻ per unit ε")
        apex = t1 + eps * t1
        close(f"dh₁/dε at the apex (ε = {eps})", (apex - t1) / m * col[9] + col[2], 2 * eps * h0, atol=1e-12,
              why="h₁ = ε² h₀")
        close(f"dz(T)/dε at T = {T} s", (T - t1) / m * col[9] + col[2], G * t1 * (T - t1), atol=1e-12)
    return "the ε column exact"


@check(CHECKS, "sphere_pair", 15, "two spheres head-on: relative gap and speed jump by −ε, the centre of mass passes",
       "H1", public=False, regions=("apply_impact.event_time", "apply_impact.impulse_derivative", "saltation_post"))
def sphere_pair(mod):
    from ..collision import Sphere
    from ..design.scene import DesignBody, DesignScene

    eps, ma, mb, ra, rb = 0.6, 1.0, 3.0, 0.2, 0.3
    scene = DesignScene([DesignBody(Sphere(ra), mass=ma, position=[0, 0, 5]),
                         DesignBody(Sphere(rb), mass=mb, position=[ra + rb + 1.0, 0, 5])], [],
                        gravity=[0, 0, -G], restitution=eps, body_collisions=True)
    y = np.zeros(26)
    y[0:3], y[3:6] = [0, 0, 5.0], [ra + rb, 0, 5.0]
    y[6], y[10] = 1.0, 1.0
    y[14:17], y[17:20] = ma * np.array([2.0, 0, -1.0]), mb * np.array([-1.0, 0, -1.0])
    Phi = _jump(mod, scene, y, eps, [ma, mb], [0.4 * ma * ra * ra, 0.4 * mb * rb * rb])
    # coordinates along the line of centres (x): d = x_a − x_b, w = v_a − v_b, X, V of the centre of mass
    M = ma + mb
    to = np.array([[1, -1, 0, 0], [0, 0, 1 / ma, -1 / mb], [ma / M, mb / M, 0, 0], [0, 0, 1 / M, 1 / M]])
    idx = [0, 3, 14, 17]                                                     # x_a, x_b, P_a, P_b along x
    S = to @ Phi[np.ix_(idx, idx)] @ np.linalg.inv(to)
    close("the jump of (d, w, X, V) along the line of centres", S, np.diag([-eps, -eps, 1.0, 1.0]), atol=1e-12,
          why="relative gap and speed: −ε 𝟙 (no relative acceleration); centre of mass: unchanged")
    return "relative block −ε 𝟙, centre of mass 𝟙"


MUTANTS = (
    Mutant("no_event_time", "the event-time term dropped: δτ = 0 (the jump becomes diag(1, −ε))",
           (("dtau = -dg / gdot if locate else np.zeros(p)", "dtau = np.zeros(p)"),),
           ("saltation_matrix", "apex_derivatives", "sphere_pair")),
    Mutant("no_flow_after", "half the saltation: the −f⁺δτ term after the jump forgotten",
           (("return T1 - dtau[:, None] * flight_rhs(model, y1)[None]", "return T1"),),
           ("saltation_matrix", "apex_derivatives", "sphere_pair")),
    Mutant("restitution_sign", "δj with ε's term of the wrong sign: δj = −(−δε v_rel + …)/k",
           (("dj = -(de * vrel + (1.0 + eps) * dvrel + j * dk) / kk", "dj = -(-de * vrel + (1.0 + eps) * dvrel + j * dk) / kk"),),
           ("restitution_derivative",)),
)
