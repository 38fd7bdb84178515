"""Wrong answers at the edges, each pinned by a test that failed before its fix (issue 13, point 3)."""

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from pbanim import solve


def test_exponential_euler_is_second_order_on_a_forced_stiff_spring():
    # ORACLES A3: x'' = −ω²x − cx' + F cos Ωt depends on t; without the ∂f/∂t term the step is order 1
    # (measured slope 1.0 before the fix); with it, order 2 (measured local slopes 2.45, 2.29, 2.17 → 2)
    w, c, F, W = 50.0, 1.0, 10.0, 3.0
    f = lambda t, y: np.array([y[1], -w * w * y[0] - c * y[1] + F * np.cos(W * t)])  # noqa: E731
    J = lambda t, y: np.array([[0.0, 1.0], [-w * w, -c]])  # noqa: E731
    ref = solve_ivp(f, (0, 1), [1.0, 0.0], rtol=1e-13, atol=1e-13, method="DOP853").y[:, -1]
    hs = 0.01 / 2.0 ** np.arange(5)
    err = [np.max(np.abs(solve(f, (0, 1), [1.0, 0.0], method="exponential_euler", h=h, jac=J).y[:, -1] - ref))
           for h in hs]
    slopes = np.diff(np.log(err)) / np.diff(np.log(hs))
    assert abs(slopes[-1] - 2.0) < 0.25 and np.all(slopes > 1.9)
    # autonomous problems are unchanged: exact on a linear spring at any step (ORACLES A1)
    g = lambda t, y: np.array([y[1], -y[0]])  # noqa: E731
    r = solve(g, (0, np.pi), [1.0, 0.0], method="exponential_euler", h=np.pi, jac=lambda t, y: [[0, 1.0], [-1.0, 0]])
    np.testing.assert_allclose(r.y[:, -1], [-1.0, 0.0], atol=1e-13)


def test_constraint_multiplier_is_right_from_t0_and_nothing_leaks_between_runs():
    # ORACLES B1: a bead at the bottom of a circle with speed v under gravity has tension m(v²/R + g).
    # Before the fix the λ recorded at t0 ignored gravity (the applied-force cache was empty: λ = −m v²/R),
    # and a second run started from the first run's last applied force.
    from pbanim.constraints import Constraints, OnCircle
    from pbanim.particles import Gravity, ParticleSystem
    from pbanim.scene import Scene

    m, v, R, g = 2.0, 2.0, 1.0, 9.81
    ps = ParticleSystem([[0.0, -R]], [[v, 0.0]], masses=m)
    cons = Constraints([OnCircle([0], [0.0, 0.0], R)], stabilization="projection")
    scene = Scene(ps, [Gravity([0.0, -g]), cons])
    first = scene.simulate(0.01, 1e-3, "rk4")
    lam0 = -float(first.diagnostics["lam"][0][0])
    assert lam0 == pytest.approx(m * (v * v / R + g), rel=1e-12)
    again = scene.simulate(0.01, 1e-3, "rk4")
    np.testing.assert_array_equal(np.asarray(again.diagnostics["lam"]), np.asarray(first.diagnostics["lam"]))


def test_model_cache_keys_cover_the_initial_state():
    # before the fix the ReducedSystem cache omitted u0, u̇0: the second model got the first one's state
    from pbanim.models.reduced import simple_pendulum

    a, b = simple_pendulum(0.3), simple_pendulum(0.9, omega0=0.5)
    np.testing.assert_array_equal(a.reduced().state(), [0.3, 0.0])
    np.testing.assert_array_equal(b.reduced().state(), [0.9, 0.5])
    np.testing.assert_array_equal(a.reduced().state(), [0.3, 0.0])
    assert a.reduced() is a.reduced()          # still cached per model


def test_lagrangian_options_are_part_of_a_given_cache_key():
    import sympy as sp

    from pbanim.reduced import lagrangian as lg

    th = sp.Symbol("th")
    pts = [(1.0, [sp.sin(th), -sp.cos(th)])]
    s1 = lg.lagrangian_system([th], pts, gravity=[0.0, -9.81], key=("pendulum",))
    s2 = lg.lagrangian_system([th], pts, gravity=[0.0, -1.62], key=("pendulum",))   # the Moon
    y = np.array([0.5, 0.0])
    assert s1.accelerations(0.0, y)[0] == pytest.approx(-9.81 * np.sin(0.5), rel=1e-13)
    assert s2.accelerations(0.0, y)[0] == pytest.approx(-1.62 * np.sin(0.5), rel=1e-13)


@pytest.mark.parametrize("first", ["near", "far"])
def test_chart_check_does_not_depend_on_build_order(first):
    # ORACLES B6: bead on a circle in the x chart, M = mR²/(R² − x²). Two models of one structure with
    # different x0: each one's chart check is referenced at its own x0, whichever was built first
    # (before the fix the first model evaluated fixed the reference of both).
    from pbanim.models.reduced import _VIEWS, bead_x_chart
    from pbanim.reduced import lagrangian as lg

    lg.clear_cache()
    _VIEWS.clear()
    near, far = bead_x_chart(x0=0.9), bead_x_chart(x0=0.0)
    order = (near, far) if first == "near" else (far, near)
    systems = {id(m): m.lagrangian() for m in order}
    M = near.lagrangian().mass_matrix([0.95])
    # referenced at x0: κ = M(0.95)/M(x0) = (R² − x0²)/(R² − 0.95²)
    assert systems[id(near)].guard.condition(M) == pytest.approx((1 - 0.81) / (1 - 0.9025), rel=1e-12)
    assert systems[id(far)].guard.condition(M) == pytest.approx(1 / (1 - 0.9025), rel=1e-12)


def test_order_checks_refuse_nan_and_report_what_they_drop():
    # ORACLES A3. Before the fix a diverged run (NaN errors at the large steps) was silently dropped and
    # the two remaining points "passed" a second-order check
    from pbanim.errors import InvalidInput
    from pbanim.testing import assert_order, fitted_order, order_fit

    hs = np.array([0.4, 0.2, 0.1, 0.05])
    with pytest.raises(InvalidInput, match=r"errors must be a float array .* got \[nan, nan, 0.001, 0.00025\]; it has NaN"):
        assert_order(hs, [np.nan, np.nan, 1e-3, 2.5e-4], 2)
    with pytest.raises(InvalidInput, match="same length"):
        fitted_order(hs, [1e-3, 2.5e-4])
    with pytest.raises(InvalidInput, match=r"hs must be a float array .*entries > 0.* got \[0.1, -0.05\]"):
        fitted_order([0.1, -0.05], [1e-3, 2.5e-4])
    fit = order_fit(hs, [0.5, 4e-3, 1e-3, 2.5e-4])
    assert fit.order == pytest.approx(2.0, abs=1e-12)
    assert fit.dropped == ((0.4, 0.5, "above the window"),)
    with pytest.raises(AssertionError, match=r"dropped h=0.4: 0.5 \(above the window\)"):
        assert_order(hs, [0.5, 4e-3, 1e-3, 2.5e-4], 1)


def test_contact_solution_owns_its_arrays():
    # before the fix the solution aliased the caller's A and b: editing either changed the certificate
    from pbanim.lcp import solve_lcp

    A = np.array([[2.0, 1.0], [1.0, 2.0]])
    b = np.array([-1.0, -1.0])
    sol = solve_lcp(A, b, "lemke")
    r0 = sol.residual
    A *= 10.0
    b[:] = 5.0
    assert sol.residual == r0 == pytest.approx(0.0, abs=1e-14)
    np.testing.assert_allclose(sol.w, 0.0, atol=1e-14)
    sol.f[:] = 0.0                                  # and changing the solution leaves the caller's arrays
    np.testing.assert_array_equal(b, [5.0, 5.0])


def _rigid_pair():
    from pbanim.rigid import RigidBodies, RigidGravity, RigidSprings

    rng = np.random.default_rng(4)
    Rp = np.linalg.qr(rng.normal(size=(3, 3)))[0]
    rb = RigidBodies([1.0, 2.0], [Rp @ np.diag([1.0, 2.0, 3.0]) @ Rp.T, np.diag([2.0, 2.5, 1.0])],
                     positions=[[0.0, 0.0, 0.0], [1.0, 0.2, 0.0]], orientations=rng.normal(size=(2, 4)),
                     velocities=rng.normal(size=(2, 3)), angular_velocities=rng.normal(size=(2, 3)))
    return rb, [RigidGravity(), RigidSprings([0], [[0.1, 0, 0]], [1], [[0, 0.2, 0]], 40.0, 0.0)]  # separable H


def test_rigid_verlet_is_second_order():
    # ORACLES C1 (torque-free ω(t) in closed form, body with a non-principal inertia tensor) and A3 (a
    # pair of bodies with gravity and a spring, against RK4 at h/8: it differs from RK4 at h/64 by 3e-11, the
    # errors measured are ≥ 4e-4, the slopes agree to 1e-6, and it costs 6 s instead of 46). Before the fix "verlet" on rigid
    # bodies drifted q by an explicit Euler step: measured slopes 1.00 (torque-free) and 1.003, 1.002
    # (pair); after: 2.00007, 2.00002, 2.000004 and 2.002, 2.0006
    from pbanim.models.rigid import torque_free_body
    from pbanim.rigid import RigidBodies, RigidScene

    I, w0, T = np.array([1.0, 2.0, 3.0]), np.array([0.3, 1.0, 0.2]), 2.0
    Rp = np.linalg.qr(np.random.default_rng(0).normal(size=(3, 3)))[0]
    exact = torque_free_body(I, w0).omega(T)
    hs = np.array([0.04, 0.02, 0.01, 0.005])
    err = []
    for h in hs:
        rb = RigidBodies(1.0, Rp @ np.diag(I) @ Rp.T, angular_velocities=[Rp @ w0])
        y = RigidScene(rb, []).simulate(T, h, "verlet").y[:, -1]
        err.append(np.max(np.abs(Rp.T @ rb.body_angular_velocity(y)[0] - exact)))
    slopes = np.diff(np.log(err)) / np.diff(np.log(hs))
    assert np.all(np.abs(slopes - 2.0) < 0.05), slopes          # measured 2.00007, 2.00002, 2.000004

    rb, eff = _rigid_pair()
    ref = RigidScene(rb, eff).simulate(1.0, 0.005 / 8, "rk4").y[:, -1]
    hs = np.array([0.02, 0.01, 0.005])
    err = [np.max(np.abs(RigidScene(rb, eff).simulate(1.0, h, "verlet").y[:, -1] - ref)) for h in hs]
    slopes = np.diff(np.log(err)) / np.diff(np.log(hs))
    assert np.all(np.abs(slopes - 2.0) < 0.15), slopes


def test_rigid_verlet_keeps_angular_momentum_and_unit_quaternions():
    # torque-free: the splitting keeps world L exactly (no torque kick) and |q| = 1 to roundoff with
    # quaternions="none" (no renormalization stage)
    from pbanim.rigid import RigidBodies, RigidScene

    rb = RigidBodies(1.0, [1.0, 2.0, 3.0], orientations=[[0.3, 0.1, -0.5, 0.8]], angular_velocities=[[0.3, 4.0, 0.2]])
    res = RigidScene(rb, [], quaternions="none").simulate(5.0, 0.01, "verlet")
    np.testing.assert_array_equal(res.y[10:13, -1], res.y[10:13, 0])
    assert np.max(res.diagnostics["quat_norm_error"]) < 1e-13


def test_scipy_route_keeps_the_cap_and_refuses_nan_output_times():
    # before the fix the scipy route ran an astronomical h with no cap, and a NaN in t_eval gave an empty
    # "successful" result
    from pbanim.errors import StepLimitExceeded

    with pytest.raises(StepLimitExceeded, match="needs 1000000000 steps over t_span, more than max_steps = 100000"):
        solve(lambda t, y: -y, (0, 1), [1.0], method="scipy:RK45", h=1e-9)
    r = solve(lambda t, y: -y, (0, 1e6), [1.0], method="scipy:RK45", rtol=1e-13, atol=1e-16, max_steps=100)
    assert r.status == -1 and "stopped after 2000 evaluations" in r.message and not r.success
    for method in ("rk4", "dopri5", "scipy:RK45"):
        with pytest.raises(ValueError, match=r"t_eval must be a float array .* got \[0.5, nan\]; it has NaN"):
            solve(lambda t, y: -y, (0, 1), [1.0], method=method, h=0.1, t_eval=[0.5, np.nan])


@pytest.mark.parametrize("solver", ["qp", "lemke", "dantzig", "pgs"])
def test_separating_contacts_give_zero_force_on_every_route(solver):
    # ORACLES D8: every contact separating (b > 0) has the unique answer f = 0. Before the fix the QP
    # route left f ~ 1e-9 after its polish stopped early and reported the problem infeasible (measured on
    # 3 of 4 random rank-deficient problems of 10–25 contacts)
    from pbanim.lcp import solve_lcp

    rng = np.random.default_rng(0)
    for _ in range(20):
        m = int(rng.integers(1, 30))
        J = rng.normal(size=(m, max(1, m // 2)))
        sol = solve_lcp(J @ J.T, rng.uniform(0.1, 2.0, m), solver)
        assert sol.success and np.all(sol.f == 0.0)
    empty = solve_lcp(np.zeros((0, 0)), np.zeros(0), solver)         # no contacts at all
    assert empty.success and empty.f.shape == (0,)


def test_qp_refuses_a_non_symmetric_matrix_even_without_validation():
    # before the fix validate=False handed a non-symmetric A to the QP backend, which ran for minutes
    from pbanim.errors import InvalidInput
    from pbanim.lcp import solve_lcp

    with pytest.raises(InvalidInput, match="A must be symmetric for solver='qp'"):
        solve_lcp(np.array([[1.0, 2.0], [0.0, 1.0]]), np.array([-1.0, -1.0]), "qp", validate=False)


def _random_impact(rng):
    from pbanim.collision import Contacts
    from pbanim.collision.impulse import ImpulseBodies

    n, m = int(rng.integers(2, 6)), int(rng.integers(2, 6))
    x, v, w = rng.normal(size=(n, 3)), rng.normal(size=(n, 3)), rng.normal(size=(n, 3))
    inv_m = rng.uniform(0.2, 2.0, n)
    inv_I = np.stack([np.diag(rng.uniform(0.5, 2.0, 3)) for _ in range(n)])
    a = rng.integers(0, n, m)
    b = rng.integers(-1, n, m)
    b = np.where(b == a, -1, b)
    nrm = rng.normal(size=(m, 3))
    nrm /= np.linalg.norm(nrm, axis=1)[:, None]
    c = Contacts(a=a, b=b, point=x[a] + 0.3 * rng.normal(size=(m, 3)), normal=nrm, depth=np.zeros(m))

    def energy(B):
        return 0.5 * np.sum(v_w(B, inv_m, inv_I))

    def v_w(B, im, iI):
        I = np.linalg.inv(iI)
        return np.concatenate([(B.v[:-1] ** 2).sum(1) / im, np.einsum("ni,nij,nj->n", B.omega[:-1], I, B.omega[:-1])])

    return ImpulseBodies.make(x, v, inv_m, w, inv_I), c, energy


@pytest.mark.parametrize("eps", [0.0, 0.3, 0.9, 1.0])
def test_simultaneous_impulses_never_create_energy(eps):
    # ORACLES D2/D3: an impact can only dissipate, T⁺ ≤ T⁻ for every ε in [0, 1]. Before the fix the
    # simultaneous Newton LCP (b = v⁻ + ε min(v⁻, 0)) gained up to +772 % on random multi-contact scenes
    # (ε = 0.9); compression then Poisson restitution gives ΔT = −½(1 − ε²) f_cᵀAf_c ≤ 0
    from pbanim.collision.impulse import resolve_collisions
    from pbanim.errors import PbanimError

    rng = np.random.default_rng(1)
    checked = 0
    for _ in range(300):
        B, c, energy = _random_impact(rng)
        T0 = energy(B)
        try:
            resolve_collisions(B, c, eps, mode="simultaneous")
        except PbanimError:
            continue
        checked += 1
        assert energy(B) <= T0 * (1 + 1e-12) + 1e-14
    assert checked > 250
    # the cradle keeps its simultaneous answer and, at ε = 1, its energy (ORACLES D2)
    from pbanim.collision import Contacts
    from pbanim.collision.impulse import ImpulseBodies

    cradle = ImpulseBodies.make(x=[[0, 0, 0], [2, 0, 0], [4, 0, 0]], v=[[1, 0, 0], [0, 0, 0], [0, 0, 0]], inv_mass=1.0)
    c = Contacts(a=[1, 2], b=[0, 1], point=[[1, 0, 0], [3, 0, 0]], normal=[[1, 0, 0]] * 2, depth=[0, 0])
    v = resolve_collisions(cradle, c, 1.0, mode="simultaneous").v[:, 0]
    np.testing.assert_allclose(v, [-1 / 3, 2 / 3, 2 / 3], atol=1e-14)


def test_spinning_sphere_on_a_plane_feels_its_weight_only():
    # ORACLES D4: a sphere resting on the ground, spinning about a horizontal axis, is pushed up by exactly
    # m g: the contact point slides over the sphere, its centre does not accelerate. Before the fix the
    # material-point term ω × (ω × r) made b = −g + R|ω⊥|² = +7.19 m/s²: f = 0, the sphere "lifts off"
    # (measured f = 0 N instead of 19.62 N here)
    from pbanim.collision import Plane
    from pbanim.collision.narrow import sphere_plane
    from pbanim.contact import assemble_rigid, assemble_rigid_loop
    from pbanim.lcp import solve_lcp
    from pbanim.rigid import RigidBodies

    m, R, g = 2.0, 0.5, 9.81
    rb = RigidBodies(m, 0.4 * m * R * R * np.ones(3), positions=[[0.0, 0.0, R]], velocities=[[1.0, 0.0, 0.0]],
                     angular_velocities=[[3.0, 5.0, 2.0]])
    y = rb.state()
    c = sphere_plane(rb.unpack(y)[0], R, Plane([0, 0, 1]), a=[0])
    Q = np.zeros((1, 6))
    Q[0, 2] = -m * g
    prob = assemble_rigid(rb, y, c, Q)
    f = solve_lcp(prob.A, prob.b, "lemke").f
    assert f[0] == pytest.approx(m * g, rel=1e-12)
    A, b = assemble_rigid_loop(rb, y, c, Q)
    np.testing.assert_allclose(b, prob.b, rtol=1e-13, atol=1e-13)
    np.testing.assert_allclose(A, prob.A, rtol=1e-13, atol=1e-13)


def test_rounded_contact_terms_agree_between_readable_and_vectorized():
    # two spinning spheres touching and a sphere on a tumbling box face: both assembly codes agree
    from pbanim.collision import Contacts
    from pbanim.contact import assemble_rigid, assemble_rigid_loop
    from pbanim.rigid import RigidBodies

    rng = np.random.default_rng(2)
    rb = RigidBodies([1.0, 2.0, 3.0], [np.diag([1.0, 1.0, 1.0]), np.diag([2.0, 2.0, 2.0]), np.diag([1.0, 2.0, 2.5])],
                     positions=[[0, 0, 0], [1.0, 0, 0], [0, 0, -2.0]], velocities=rng.normal(size=(3, 3)),
                     angular_velocities=rng.normal(size=(3, 3)))
    c = Contacts(a=[1, 0], b=[0, 2], point=[[0.5, 0, 0], [0, 0, -0.5]], normal=[[1.0, 0, 0], [0, 0, 1.0]],
                 depth=[0, 0], radius=[0.5, 0.5], radius_b=[0.5, 0.0])
    Q = rng.normal(size=(3, 6))
    prob = assemble_rigid(rb, rb.state(), c, Q)
    A, b = assemble_rigid_loop(rb, rb.state(), c, Q)
    np.testing.assert_allclose(b, prob.b, rtol=1e-12, atol=1e-12)
