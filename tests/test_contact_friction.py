"""Friction: polyhedral cones, velocity-level time stepping, incline, Painlevé (ORACLES D6, D7)."""

import numpy as np
import pytest

from pbanim.contact import (TimeStepping, acceleration_lcp_check, assemble_rigid, friction_directions,
                            make_contacts)
from pbanim.errors import InconsistentContact
from pbanim.models.contact import box_on_incline, incline_expected, painleve_B, painleve_rod
from pbanim.particles import Gravity, ParticleSystem
from pbanim.scene import Scene

H = 1e-3


def _run_incline(angle, mu, facets=4, tangent=None, t_end=0.1):
    sc = box_on_incline(angle, mu)
    ts = TimeStepping(sc.system, sc.detect, sc.forces, friction=mu, facets=facets, tangent=tangent)
    res = ts.simulate(t_end, H, record_every=10)
    v = res.y[7:10] / 1.0                      # P / m with m = 1
    vd = v.T @ sc.exact["downhill"]
    accel = (vd[-1] - vd[-3]) / (res.t[-1] - res.t[-3])
    friction = ts.last_info["friction_impulse"][0, :3] / H
    return sc, res, vd, accel, friction


@pytest.mark.parametrize("angle, mu", [(0.3, 0.5), (np.arctan(0.5) - 1e-3, 0.5), (0.6, 0.5), (0.6, 0.2),
                                       (np.arctan(0.5) + 1e-3, 0.5)])
def test_incline_stick_slip(angle, mu):
    # ORACLES D6: static iff tan θ ≤ μ, friction force m g sin θ up the slope; else a = g (sin θ − μ cos θ).
    # A 4-facet pyramid with a generator along the slope is exact there.
    # measured: static |v| ≤ 7.8e-15 m/s; friction error ≤ 2.6e-12 N; sliding |a − a_exact| ≤ 1.9e-13 m/s²;
    # depth ≤ 9.6e-16 m; residual ≤ 4.3e-13.  bounds 1e-12, 1e-9, 1e-9, 1e-12, 1e-10
    sc, res, vd, accel, friction = _run_incline(angle, mu)
    ex = incline_expected(angle, mu)
    assert ex["static"] == (np.tan(angle) <= mu)
    if ex["static"]:
        assert np.abs(vd).max() < 1e-12
        assert abs(-friction @ sc.exact["downhill"] - ex["friction_per_mass"]) < 1e-9
    else:
        assert abs(accel - ex["acceleration"]) < 1e-9
        assert abs(-friction @ sc.exact["downhill"] - ex["friction_per_mass"]) < 1e-9
    assert res.diagnostics["max_penetration"].max() < 1e-12
    assert res.diagnostics["contact_residual"].max() < 1e-10


@pytest.mark.parametrize("facets, mu_factor", [(4, np.cos(np.pi / 4)), (8, 1.0), (16, 1.0)])
def test_pyramid_anisotropy_along_diagonal(facets, mu_factor):
    # ORACLES D6: sliding at 45° to the generators, a 4-facet pyramid has μ_eff = μ cos(π/4) (its edge), an
    # 8- or 16-facet one has a generator there (μ_eff = μ): a = g (sin θ − μ_eff cos θ).  measured ≤ 1.9e-13,
    # bound 1e-9
    angle, mu = 0.6, 0.3
    sc = box_on_incline(angle, mu)
    dh, n = sc.exact["downhill"], sc.exact["normal"]
    tangent = np.cos(np.pi / 4) * dh + np.sin(np.pi / 4) * np.cross(n, dh)
    _, _, _, accel, _ = _run_incline(angle, mu, facets, tangent)
    assert abs(accel - 9.81 * (np.sin(angle) - mu * mu_factor * np.cos(angle))) < 1e-9


def test_friction_directions_unit_tangent():
    # k unit directions in the contact plane, evenly spaced: Σ dⱼ = 0 and dⱼ·n = 0
    n = np.array([[0.0, 0.6, 0.8], [1.0, 0.0, 0.0]])
    d = friction_directions(n, 6)
    np.testing.assert_allclose(np.linalg.norm(d, axis=2), 1.0, atol=1e-15)
    np.testing.assert_allclose(np.einsum("mkj,mj->mk", d, n), 0.0, atol=1e-15)
    np.testing.assert_allclose(d.sum(axis=1), 0.0, atol=1e-14)
    with pytest.raises(ValueError, match="facets must be an integer >= 2 and <= 64, got 1"):
        friction_directions(n, 1)


def test_particle_sliding_friction_decelerates_at_mu_g():
    # a particle sliding on the ground decelerates at μ g until it stops, then stays at rest (stick)
    ps = ParticleSystem([[0.0, 0.0, 0.0]], [[1.0, 0.0, 0.0]], masses=2.0)
    floor = lambda y: make_contacts([0], [-1], [y[:3]], [[0.0, 0.0, 1.0]], [-y[2]])  # noqa: E731
    res = TimeStepping(ps, floor, [Gravity()], friction=0.25).simulate(0.6, H)
    v = res.y[3]
    t_stop = 1.0 / (0.25 * 9.81)
    k = int(0.2 / H)
    assert abs((v[k] - v[0]) / res.t[k] + 0.25 * 9.81) < 1e-9     # measured 4e-13
    assert np.all(v >= -1e-15) and np.all(np.abs(v[res.t > t_stop + H]) < 1e-15)


def test_painleve_B_threshold():
    # ORACLES D7: min_θ B(θ) < 0 iff μ > 4/3 (B(arctan 2) = 0 at μ = 4/3)
    th = np.linspace(1e-3, np.pi / 2 - 1e-3, 20001)
    assert painleve_B(th, 4 / 3 - 1e-6).min() > 0
    assert painleve_B(th, 4 / 3 + 1e-6).min() < 0
    assert abs(painleve_B(np.arctan(2.0), 4 / 3)) < 1e-15


@pytest.mark.parametrize("mu, theta", [(2.0, np.arctan(2.0)), (1.0, np.arctan(2.0)), (0.5, 0.4), (1.5, 1.0)])
def test_painleve_acceleration_lcp_is_B_over_m(mu, theta):
    # ORACLES D7: for the sliding rod end, the assembled acceleration-level LCP is d̈ = (B(θ)/m) N − g
    # (friction −μN opposing the slip).  measured 2e-16, bound 1e-12
    sc = painleve_rod(theta, mu, mass=2.0)
    bodies = sc.system
    y = bodies.state()
    Q = Scene(bodies, sc.forces).forces(0.0, y)
    prob = assemble_rigid(bodies, y, sc.detect(y), Q, friction=mu)
    assert abs(prob.A[0, 0] - painleve_B(theta, mu) / 2.0) < 1e-12
    assert abs(prob.b[0] + 9.81) < 1e-12
    if painleve_B(theta, mu) > 0:   # consistent: N = m g / B
        sol = acceleration_lcp_check(bodies, y, sc.detect(y), Q, friction=mu)
        assert abs(sol.f[0] - 9.81 * 2.0 / painleve_B(theta, mu)) < 1e-10
    else:                           # ORACLES D7: inconsistent → named error
        with pytest.raises(InconsistentContact, match="inconsistent.*use the velocity-level scheme"):
            acceleration_lcp_check(bodies, y, sc.detect(y), Q, friction=mu)


def test_painleve_velocity_level_solves_it():
    # ORACLES D7: where the acceleration level is inconsistent (μ = 2, tan θ = 2, B = −0.8), the
    # Stewart–Trinkle step always has a certified solution: an impulsive normal reaction (≫ m g h) stops the
    # slip in one step ("tangential impact"), energy only decreases, no penetration.
    # measured: first impulse 0.31 N s vs m g h = 0.0098; slip after 1 step 4e-4 m/s; depth 0
    sc = painleve_rod(np.arctan(2.0), 2.0)
    bodies = sc.system
    ts = TimeStepping(bodies, sc.detect, sc.forces, friction=2.0, facets=4)
    y = bodies.state()
    energy = lambda yy: bodies.kinetic_energy(yy) + 9.81 * bodies.unpack(yy)[0][0, 2]  # noqa: E731
    E = [energy(y)]
    for k in range(100):
        y = ts.step(k * H, y, H)
        E.append(energy(y))
        if k == 0:
            assert ts.last.f[0] > 10 * 9.81 * H
            c = sc.detect(y)
            slip = bodies.point_velocity(y, c.a, c.point)[0, 0]
            assert abs(slip) < 1e-2
        assert ts.last is None or ts.last.success
        assert sc.detect(y).depth.max(initial=0.0) < 1e-9
    assert np.all(np.diff(E) <= 1e-12)


def test_timestepping_rejects_bad_input():
    # G3: named errors
    sc = box_on_incline(0.3, 0.5)
    with pytest.raises(ValueError, match=r"friction must be a float array .*entries >= 0.*, got -0.1"):
        TimeStepping(sc.system, sc.detect, sc.forces, friction=-0.1)
    with pytest.raises(ValueError, match="solver must be 'lemke' with friction > 0"):
        TimeStepping(sc.system, sc.detect, sc.forces, friction=0.5, solver="pgs")
    with pytest.raises(ValueError, match="erp must be a finite number > 0 and <= 1, got 0.0"):
        TimeStepping(sc.system, sc.detect, sc.forces, erp=0.0)
    with pytest.raises(ValueError, match="detect must be a callable"):
        TimeStepping(sc.system, 3, sc.forces)
    with pytest.raises(ValueError, match="angle must be in"):
        box_on_incline(2.0, 0.5)
    with pytest.raises(ValueError, match="h must be a finite number > 0, got -1.0"):
        TimeStepping(sc.system, sc.detect, sc.forces).simulate(1.0, -1.0)


def _gravity(sc, y):
    return Scene(sc.system, sc.forces).forces(0.0, y)


def test_painleve_scene_effect_raises_inconsistent():
    # ORACLES D7 in a scene: the acceleration-level effect with sliding friction μ = 2 on the rod at tan θ = 2
    # (B = −0.8 < 0, b = −g < 0) finds no forces and raises InconsistentContact; with μ = 1 (B > 0) it runs
    from pbanim.contact import RestingContact
    from pbanim.scene import Scene

    sc = painleve_rod(np.arctan(2.0), 2.0)
    scene = Scene(sc.system, sc.forces + [RestingContact(sc.detect, "lemke", friction=2.0)])
    with pytest.raises(InconsistentContact, match="inconsistent.*lemke status ray"):
        scene.simulate(0.01, H)
    ok = painleve_rod(np.arctan(2.0), 1.0)
    eff = RestingContact(ok.detect, "lemke", friction=1.0)
    ok_scene = Scene(ok.system, ok.forces + [eff])
    y = ok.system.state()
    sol = eff.solve(0.0, y, ok_scene.forces(0.0, y) * 0 + _gravity(ok, y))[0]
    assert sol.success and abs(sol.f[0] - 9.81 / painleve_B(np.arctan(2.0), 1.0)) < 1e-10   # N = m g / B
    ok_scene.simulate(0.01, H)                                                              # and it runs
    with pytest.raises(ValueError, match="solver must be 'lemke' or 'dantzig' with friction"):
        RestingContact(sc.detect, "qp", friction=0.5)


def test_models_and_effects_reject_bad_input():
    # G3: the remaining rejected inputs of the models and the effects, type and message
    from pbanim.contact import RestingContact
    from pbanim.models.contact import box_on_plane, box_stack, murty_lcp, sphere_pour

    with pytest.raises(ValueError, match="n must be a positive integer, got 0"):
        murty_lcp(0)
    with pytest.raises(ValueError, match="mass must be positive, got -1.0"):
        box_on_plane(-1.0)
    with pytest.raises(ValueError, match="n must be a positive integer, got 0"):
        box_stack(0)
    with pytest.raises(ValueError, match="n must be a positive integer, got 2.5"):
        sphere_pour(2.5)
    with pytest.raises(ValueError, match="mass must be positive, got 0.0"):
        painleve_rod(mass=0.0)
    sc = box_on_plane()
    with pytest.raises(ValueError, match="friction must be a finite number >= 0, got -1.0"):
        RestingContact(sc.detect, "lemke", friction=-1.0)
    ps2 = ParticleSystem([[0.0, 0.0]])
    with pytest.raises(ValueError, match="friction in RestingContact needs a RigidBodies system"):
        RestingContact(sc.detect, "lemke", friction=0.5).bind(ps2)
    with pytest.raises(ValueError, match="TimeStepping needs 3-D particles, got dim = 2"):
        TimeStepping(ps2, sc.detect)
    with pytest.raises(ValueError, match="tangent must not be parallel to a contact normal"):
        friction_directions([[0.0, 0.0, 1.0]], 4, tangent=[0.0, 0.0, 2.0])
