"""Checks of ch06_impulses (collision impulses) and ch07_lcp (the contact LCP by projected Gauss–Seidel).

ch06 — in a copy of :mod:`pbanim.collision.impulse` the student writes the relative contact velocity
u = (v_a + ω_a × r_a) − (v_b + ω_b × r_b), the collision matrix K = (1/m_a + 1/m_b) E − [r_a]× I_a⁻¹ [r_a]×
− [r_b]× I_b⁻¹ [r_b]×, the application of an impulse to both bodies, and Newton's law
j = −(1 + ε) v⁻_rel / nᵀK n along n (with Coulomb friction when μ > 0).

ch07 — in a copy of :mod:`pbanim.lcp.solve` the student writes projected Gauss–Seidel for
w = A f + b ≥ 0, f ≥ 0, fᵀw = 0: fᵢ ← max(0, fᵢ − ω wᵢ / Aᵢᵢ), sweep after sweep, until the natural-map
residual ‖f − max(0, f − w)‖∞ is below the threshold.

=====================  ===================================================================  ======
check                  oracle                                                               id
=====================  ===================================================================  ======
particle_bounce        a particle hitting the ground leaves at −ε v⁻ (j = (1 + ε) m |v⁻|)     D1
collision_matrix       K of a ball on the ground: diag(1 + mR²/I, 1 + mR²/I, 1)/m              D3
oblique_spheres        two smooth spheres: only the normal velocities change, exactly          D3
falling_rod            rod landing on one end: j = −(1+ε)u·n / (1/m + (r×n)·I⁻¹(r×n))          D3
single_contact         a 1×1 LCP: f = max(0, −b/a)                                           D8
box_on_plane           four resting corners carry Σf = m g with no net torque                  D4
random_lcps            random positive definite LCPs: natural-map residual ≤ threshold and   D8
                       f equal to Lemke's (the solution is unique)
=====================  ===================================================================  ======

Limiting cases: ε = 0 is a plastic impact (the contact stops), ε = 1 keeps the normal speed; b ≥ 0
means no contact is pushed, so f = 0.
"""

from __future__ import annotations

import numpy as np

from .registry import CheckFailed, Mutant, array, at_most, attr, check, close

CH06_CHECKS: list = []
CH07_CHECKS: list = []


def _contacts(a, b, point, normal):
    from ..collision.shapes import Contacts

    return Contacts(a=a, b=b, point=point, normal=normal, depth=np.zeros(len(a)))


@check(CH06_CHECKS, "particle_bounce", 20, "a particle bounces off the ground with −ε times its speed", "D1",
       regions=("contact_impulse",))
def particle_bounce(mod):
    for eps, m, v in ((0.5, 1.0, -2.0), (0.8, 2.0, -3.0), (0.0, 0.5, -1.0)):
        J, _ = attr(mod, "contact_impulse")(np.eye(3) / m, np.array([0.7, 0.0, v]), np.array([0.0, 0.0, 1.0]), eps)
        J = array("contact_impulse(...)[0]", J, (3,))
        close(f"impulse for ε = {eps}, m = {m}, v⁻ = {v}", J, [0.0, 0.0, -(1 + eps) * m * v], rtol=1e-14, unit="N·s",
              why="j = −(1 + ε) v⁻_rel / nᵀKn along n, K = E/m")
    return "j = (1 + ε) m |v⁻| for three cases"


@check(CH06_CHECKS, "collision_matrix", 20, "the collision matrix of a ball on the ground", "D3",
       regions=("collision_matrix",))
def collision_matrix(mod):
    ImpulseBodies = attr(mod, "ImpulseBodies")
    m, R = 2.0, 0.5
    I = 0.4 * m * R * R
    b = ImpulseBodies.make([[0, 0, R]], [[0, 0, 0]], 1 / m, inv_I=np.eye(3) / I)
    K = array("collision_matrix(bodies, contacts)", attr(mod, "collision_matrix")(b, _contacts([0], [-1], [[0, 0, 0]],
                                                                                               [[0, 0, 1]])), (1, 3, 3))
    t = 1 / m + R * R / I
    close("K of a solid ball at its lowest point", K[0], np.diag([t, t, 1 / m]), rtol=1e-14, unit="1/kg",
          why="K = E/m − [r]× I⁻¹ [r]×, r = (0, 0, −R)")
    return "K = diag(1/m + R²/I, 1/m + R²/I, 1/m)"


@check(CH06_CHECKS, "oblique_spheres", 30, "smooth spheres exchange only normal momentum (Newton's law along n)",
       "D3", public=False, regions=("contact_velocity", "contact_impulse", "apply_impulses"))
def oblique_spheres(mod):
    from ..models.collision import oblique_spheres as model

    s = model(restitution=0.6)
    b = attr(mod, "ImpulseBodies").make([[0, 0, 0], [1.0, 0, 0]], [s.v1, s.v2], [1 / s.m1, 1 / s.m2])
    res = attr(mod, "resolve_collisions")(b, _contacts([0], [1], [[0.5, 0, 0]], [-s.n]), 0.6)
    v1, v2 = s.after()
    close("velocities after the impact", array("ImpulseResult.v", res.v, (2, 3)), [v1, v2], rtol=1e-13, unit="m/s",
          why="only (v₂ − v₁)·n changes, to −ε times its value; momentum is conserved")
    return "post-impact velocities exact (rtol 1e-13)"


@check(CH06_CHECKS, "falling_rod", 30, "a rod landing on one end: impulse and spin from the collision matrix", "D3",
       regions=("contact_velocity", "collision_matrix", "contact_impulse", "apply_impulses"))
def falling_rod(mod):
    from ..models.collision import falling_rod as model

    rod = model()
    R = rod.rotation()
    Iinv = R @ np.linalg.inv(rod.inertia) @ R.T
    b = attr(mod, "ImpulseBodies").make([rod.centre()], [rod.v], 1 / rod.mass, omega=[rod.omega], inv_I=Iinv)
    res = attr(mod, "resolve_collisions")(b, _contacts([0], [-1], [rod.contact_point()], [[0, 0, 1.0]]),
                                          rod.restitution)
    j = rod.impulse()
    close("normal impulse", array("ImpulseResult.normal_impulse", res.normal_impulse, (1,)), [j], rtol=1e-12, unit="N·s")
    r = rod.contact_point() - rod.centre()
    close("ω after the impact", res.omega, [rod.omega + Iinv @ np.cross(r, [0, 0, j])], rtol=1e-12, unit="rad/s",
          why="Δω = I⁻¹ (r × J)")
    return f"j = {j:.6f} N·s and the new spin exact"


CH06_MUTANTS = (
    Mutant("restitution_sign", "ε with the wrong sign: j = −(1 − ε) v⁻_rel / nᵀKn",
           (("return (-(1 + restitution) * vn / float(n @ K @ n)) * n, False",
             "return (-(1 - restitution) * vn / float(n @ K @ n)) * n, False"),),
           ("particle_bounce", "oblique_spheres", "falling_rod")),
    Mutant("lever_sign", "the rotational part of K added instead of subtracted (−[r]×I⁻¹[r]× is PSD)",
           (("return lin - Sa @ bodies.inv_I[c.a] @ Sa - Sb @ bodies.inv_I[c.b] @ Sb",
             "return lin + Sa @ bodies.inv_I[c.a] @ Sa + Sb @ bodies.inv_I[c.b] @ Sb"),),
           ("collision_matrix", "falling_rod")),
)


# --------------------------------------------------------------------------------------------------
# ch07: projected Gauss–Seidel
# --------------------------------------------------------------------------------------------------
def _pgs(mod, A, b):
    sol = attr(mod, "solve_lcp")(A, b, "pgs", raise_on_failure=False, max_iter=2000)
    return array("solve_lcp(A, b, 'pgs').f", sol.f, (len(b),)), sol


@check(CH07_CHECKS, "single_contact", 30, "one contact: f = max(0, −b/a) — push only when it would sink", "D8",
       regions=("pgs",))
def single_contact(mod):
    for a, b in ((2.0, -3.0), (0.5, 1.0), (4.0, 0.0)):
        f, _ = _pgs(mod, [[a]], [b])
        close(f"f for a = {a}, b = {b}", f, [max(0.0, -b / a)], atol=1e-12, unit="N")
    return "f = max(0, −b/a) in three cases"


@check(CH07_CHECKS, "box_on_plane", 30, "a box resting on four corners: Σf = m g and no net torque", "D4",
       public=False, regions=("pgs",))
def box_on_plane(mod):
    m, g = 3.0, 9.81
    hx, hy, hz = 0.4, 0.3, 0.2
    I = m / 12 * np.array([hy * hy * 4 + hz * hz * 4, hx * hx * 4 + hz * hz * 4, hx * hx * 4 + hy * hy * 4])
    r = np.array([[sx * hx, sy * hy, -hz] for sx in (-1, 1) for sy in (-1, 1)])
    n = np.array([0.0, 0.0, 1.0])
    Jn = np.hstack([np.tile(n, (4, 1)), np.cross(r, n)])            # rows [nᵀ, (r × n)ᵀ]
    W = np.diag(np.concatenate([np.full(3, 1 / m), 1 / I]))
    A = Jn @ W @ Jn.T
    b = Jn @ (W @ np.array([0, 0, -m * g, 0, 0, 0]))
    f, _ = _pgs(mod, A, b)
    if np.any(f < -1e-12):
        raise CheckFailed(f"negative contact forces {np.round(f, 6).tolist()}: contacts can push, never pull")
    close("Σf", f.sum(), m * g, rtol=1e-8, unit="N", why="the corners carry the weight")
    close("net torque Σ r × f n", (np.cross(r, n) * f[:, None]).sum(0), np.zeros(3), atol=1e-8 * m * g, unit="N·m")
    return f"Σf = {f.sum():.6f} N = m g, no net torque"


@check(CH07_CHECKS, "random_lcps", 40, "random positive definite LCPs are solved to the certificate", "D8",
       regions=("pgs",))
def random_lcps(mod):
    from ..lcp import lemke
    from ..results import natural_map_residual

    rng = np.random.default_rng(11)
    worst = 0.0
    for k in range(6):
        n = 3 + k
        G = rng.normal(size=(n, n))
        A = G @ G.T + n * np.eye(n)
        b = rng.normal(size=n)
        f, sol = _pgs(mod, A, b)
        res = natural_map_residual(f, A @ f + b)
        worst = max(worst, res)
        # PGS tol 1e-10 relative to max(1, |b|∞): bound 1e-8
        at_most(f"natural-map residual of problem {k} (m = {n})", res, 1e-8,
                why="w = Af + b ≥ 0, f ≥ 0, fᵀw = 0 (clamp every fᵢ at 0)")
        ref = lemke(A, b)[0]
        close(f"f of problem {k} vs Lemke (unique for A ≻ 0)", f, ref, atol=1e-8, unit="N")
    return f"6 problems, worst residual {worst:.1e}"


CH07_MUTANTS = (
    Mutant("no_projection", "Gauss–Seidel without the projection: fᵢ is never clamped at 0",
           (("f[i] = fi if fi > 0.0 else 0.0", "f[i] = fi"),), ("random_lcps",)),
    Mutant("update_sign", "the update climbs: fᵢ ← fᵢ + ω wᵢ/Aᵢᵢ",
           (("fi = f[i] - omega * (rows[i] @ f + b[i]) / diag[i]", "fi = f[i] + omega * (rows[i] @ f + b[i]) / diag[i]"),),
           ("single_contact", "box_on_plane", "random_lcps")),
)
