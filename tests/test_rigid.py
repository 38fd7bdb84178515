"""Rigid-body dynamics (chapter 05): Baraff's state, inertia tensors, effects, quaternions, oracles C1–C3, G3."""

import numpy as np
import pytest
from hypothesis import given, strategies as st

import pbanim
import pbanim.testing
from pbanim.errors import SimulationDiverged
from pbanim.models.rigid import t_handle, torque_free_body
from pbanim.ode import METHODS
from pbanim.rigid import (AngularDrag, LinearDrag, PointForce, RigidBodies, RigidGravity, RigidScene, RigidSprings,
                          box_inertia, box_mesh, capsule_inertia, cylinder_inertia, dexpinv, icosphere_mesh,
                          matrix_to_quat, mesh_mass_properties, parallel_axis, principal_axes, quat_exp,
                          quat_from_axis_angle, quat_multiply, quat_to_matrix, sphere_inertia, validate_inertia)
from pbanim.scene import Scene

EPS = np.finfo(float).eps


def random_bodies(rng, N=5, static=None):
    """N bodies with random SPD inertia (rotated boxes), poses and velocities."""
    ext = rng.uniform(0.5, 2.0, (N, 3))
    m = rng.uniform(0.5, 3.0, N)
    Rb = quat_to_matrix(rng.normal(size=(N, 4)))
    I = np.stack([R @ box_inertia(mi, e) @ R.T for R, mi, e in zip(Rb, m, ext)])
    st_ = np.zeros(N, bool) if static is None else static
    return RigidBodies(m, I, positions=rng.normal(size=(N, 3)), orientations=rng.normal(size=(N, 4)),
                       velocities=np.where(st_[:, None], 0, rng.normal(size=(N, 3))),
                       angular_velocities=np.where(st_[:, None], 0, rng.normal(size=(N, 3))), static=st_)


# ---------------------------------------------------------------------------------------------------
# the interface others code against (state layout, derived quantities, world index −1, impulses)
# ---------------------------------------------------------------------------------------------------
def test_state_layout_and_unpack_views():
    # y = [x (N,3), q (N,4), P (N,3), L (N,3)], split = 7N; unpack returns views (writes go through)
    rng = np.random.default_rng(0)
    rb = random_bodies(rng, 4)
    y = rb.state()
    assert y.shape == (52,) and rb.split == 28
    x, q, P, L = rb.unpack(y)
    assert x.shape == (4, 3) and q.shape == (4, 4) and P.shape == (4, 3) and L.shape == (4, 3)
    np.testing.assert_array_equal(y[:12], x.ravel())
    np.testing.assert_array_equal(y[12:28], q.ravel())
    np.testing.assert_array_equal(y[28:40], P.ravel())
    np.testing.assert_array_equal(y[40:], L.ravel())
    L[2, 1] = 7.0
    assert y[40 + 7] == 7.0
    np.testing.assert_array_equal(rb.pack(*rb.unpack(y)), y)
    assert np.allclose(np.linalg.norm(q, axis=1), 1.0)  # orientations normalized on construction


def test_derived_quantities_match_definitions():
    # v = P/m, I⁻¹_world = R I⁻¹_body Rᵀ, ω = I⁻¹_world L; constructor stored P = m v, L = I_world ω
    rng = np.random.default_rng(1)
    N = 6
    m = rng.uniform(1, 2, N)
    w = rng.normal(size=(N, 3))
    v = rng.normal(size=(N, 3))
    rb = RigidBodies(m, box_inertia(1.0, [1.0, 2.0, 3.0]), orientations=rng.normal(size=(N, 4)),
                     velocities=v, angular_velocities=w)
    y = rb.state()
    v2, w2 = rb.velocities(y)
    np.testing.assert_allclose(v2, v, rtol=1e-14)
    np.testing.assert_allclose(w2, w, rtol=1e-12, atol=1e-14)
    R = rb.quat_to_matrix(rb.unpack(y)[1])
    Iinv = rb.inv_inertia_world(y)
    np.testing.assert_allclose(Iinv, R @ rb.inv_I_body @ np.swapaxes(R, 1, 2), rtol=1e-14)
    np.testing.assert_allclose(np.linalg.inv(Iinv), R @ rb.I_body @ np.swapaxes(R, 1, 2), rtol=1e-12)
    np.testing.assert_allclose(np.einsum("nij,nj->ni", R, rb.body_angular_velocity(y)), w, rtol=1e-12, atol=1e-14)


@given(st.lists(st.floats(-3, 3), min_size=4, max_size=4).filter(lambda q: np.linalg.norm(q) > 1e-3),
       st.floats(0.01, 100.0))
def test_quat_to_matrix_is_a_rotation_for_any_norm(q, scale):
    # R is built from q/|q|: orthogonal with det +1 whatever the stored norm (ORACLES C3)
    R = quat_to_matrix(scale * np.array(q))
    np.testing.assert_allclose(R @ R.T, np.eye(3), atol=1e-14)
    assert abs(np.linalg.det(R) - 1) < 1e-14
    np.testing.assert_allclose(R, quat_to_matrix(np.array(q)), atol=1e-15)
    Rq = quat_to_matrix(matrix_to_quat(R))
    np.testing.assert_allclose(Rq, R, atol=1e-14)   # matrix → quaternion → matrix round trip


def test_quaternion_product_composes_rotations():
    # R(a ⊗ b) = R(a) R(b); exp(½θ) is the rotation by |θ| about θ
    rng = np.random.default_rng(2)
    a, b = rng.normal(size=(2, 10, 4))
    np.testing.assert_allclose(quat_to_matrix(quat_multiply(a, b)), quat_to_matrix(a) @ quat_to_matrix(b),
                               atol=1e-14)
    th = rng.normal(size=(10, 3))
    ang = np.linalg.norm(th, axis=1)
    np.testing.assert_allclose(quat_exp(th), quat_from_axis_angle(th, ang), atol=1e-15)


def test_point_velocity_is_the_time_derivative_of_a_body_point():
    # ṗ = v + ω × (p − x): compare with a centred difference of p(t) = x + R r along the exact flow
    rng = np.random.default_rng(3)
    rb = random_bodies(rng, 3)
    y = rb.state()
    r = rng.normal(size=(3, 3))
    idx = np.array([0, 1, 2])
    f = lambda yy: rb.world_points(yy, idx, r)  # noqa: E731
    dy = rb.derivative(y, rb.zero_forces())
    h = 1e-6
    fd = (f(y + h * dy) - f(y - h * dy)) / (2 * h)
    np.testing.assert_allclose(rb.point_velocity(y, idx, f(y)), fd, rtol=1e-7, atol=1e-8)  # measured 3e-10


def test_world_index_minus_one_is_static():
    # body −1: zero velocity, zero inverse mass, impulses on it are absorbed
    rb = random_bodies(np.random.default_rng(4), 2)
    y = rb.state()
    p = np.array([[1.0, 2.0, 3.0]])
    np.testing.assert_array_equal(rb.point_velocity(y, [-1], p), 0.0)
    assert rb.effective_inverse_mass(y, [-1], p, [[0.0, 0.0, 1.0]])[0] == 0.0
    np.testing.assert_array_equal(rb.apply_impulses(y, [-1], p, [[5.0, 0, 0]]), y)
    assert rb.inv_mass_padded.shape == (3,) and rb.inv_mass_padded[-1] == 0.0
    assert np.all(rb.inv_I_body_padded[-1] == 0.0)


def test_apply_impulses_matches_per_contact_loop_and_accumulates():
    # P += j, L += (p − x) × j; repeated indices accumulate (vectorized np.add.at vs a readable loop)
    rng = np.random.default_rng(5)
    rb = random_bodies(rng, 3)
    y = rb.state()
    idx = np.array([0, 2, 0, -1, 2, 0])
    p = rng.normal(size=(6, 3))
    j = rng.normal(size=(6, 3))
    y_fast = rb.apply_impulses(y, idx, p, j)
    y_loop = y.copy()
    x, _, P, L = rb.unpack(y_loop)
    for i, pi, ji in zip(idx, p, j):
        if i >= 0:
            P[i] += ji
            L[i] += np.cross(pi - x[i], ji)
    np.testing.assert_allclose(y_fast, y_loop, rtol=1e-14, atol=1e-14)
    assert not np.shares_memory(y_fast, y)


def test_equal_and_opposite_impulses_conserve_momenta():
    # an impulse pair ±j at one point between bodies 0 and 1 leaves Σ P and Σ (x × P + L) unchanged
    rng = np.random.default_rng(6)
    rb = random_bodies(rng, 2)
    y = rb.state()
    p = rng.normal(size=3)
    j = rng.normal(size=3)
    y1 = rb.apply_impulses(y, [0, 1], [p, p], [j, -j])
    np.testing.assert_allclose(rb.linear_momentum(y1), rb.linear_momentum(y), atol=1e-14)
    np.testing.assert_allclose(rb.angular_momentum(y1), rb.angular_momentum(y), atol=1e-13)


def test_effective_inverse_mass_is_the_impulse_response():
    # n·Δṗ for a unit impulse n at p equals 1/m + (r × n)·I⁻¹(r × n) (ORACLES D3 denominator)
    rng = np.random.default_rng(7)
    rb = random_bodies(rng, 4)
    y = rb.state()
    idx = np.arange(4)
    p = rb.unpack(y)[0] + rng.normal(size=(4, 3))
    n = rng.normal(size=(4, 3))
    n /= np.linalg.norm(n, axis=1, keepdims=True)
    y1 = rb.apply_impulses(y, idx, p, n)
    resp = np.sum((rb.point_velocity(y1, idx, p) - rb.point_velocity(y, idx, p)) * n, axis=1)
    np.testing.assert_allclose(rb.effective_inverse_mass(y, idx, p, n), resp, rtol=1e-12)


def test_static_bodies_never_move():
    # W = 0, I⁻¹ = 0: a static body under gravity, springs and impulses keeps its state
    rng = np.random.default_rng(8)
    rb = random_bodies(rng, 3, static=np.array([False, True, False]))
    assert rb.inv_mass[1] == 0 and np.all(rb.inv_I_body[1] == 0) and rb.mass[1] == np.inf
    scene = RigidScene(rb, [RigidGravity(), RigidSprings([0], [[0, 0, 0]], [1], [[0.3, 0, 0]], 50.0, 1.0)])
    res = scene.simulate(0.2, 0.01, method="rk4")
    s0, s1 = rb.unpack(res.y[:, 0]), rb.unpack(res.y[:, -1])
    for a0, a1 in zip(s0, s1):
        np.testing.assert_array_equal(a1[1], a0[1])
    y1 = rb.apply_impulses(res.y[:, -1], [1], [[0, 0, 0]], [[1.0, 2, 3]])
    np.testing.assert_array_equal(y1, res.y[:, -1])
    static2 = RigidBodies([1.0, np.inf], [1.0, 1.0, 1.0])   # mass = inf also means static
    assert static2.static.tolist() == [False, True]


def test_vectorized_derivative_equals_readable_per_body_loop():
    # the vectorized ẏ (no Python loop over bodies) equals Baraff's per-body pseudo-code
    rng = np.random.default_rng(9)
    rb = random_bodies(rng, 7, static=np.array([0, 0, 1, 0, 0, 0, 0], bool))
    y = rb.state()
    rb.unpack(y)[1][:] *= 1.3  # a drifted quaternion norm is handled the same way
    Q = rng.normal(size=(7, 6))
    np.testing.assert_allclose(rb.derivative(y, Q), rb.derivative_readable(y, Q), rtol=1e-13, atol=1e-15)


# ---------------------------------------------------------------------------------------------------
# ORACLES C1: torque-free asymmetric body against the Jacobi elliptic closed form
# ---------------------------------------------------------------------------------------------------
def tight_run(scene, t_end, t_eval, rtol=1e-12, method="scipy:DOP853"):
    """A tight adaptive run of a scene's rhs with pbanim.solve (Dormand–Prince 8(5,3) via scipy, or dopri5)."""
    res = pbanim.solve(scene.rhs, (0.0, t_end), scene.system.state(), method=method, rtol=rtol, atol=rtol,
                       t_eval=t_eval)
    assert res.success, res.message
    return res


@pytest.mark.parametrize("omega0,method", [((1.0, 0.1, 2.0), "scipy:DOP853"), ((-3.0, 0.5, 0.2), "scipy:DOP853"),
                                           ((0.3, -2.0, 1.0), "scipy:DOP853"), ((1.0, 0.1, 2.0), "dopri5")],
                         ids=["M2>2TI2", "M2<2TI2", "near-separatrix", "M2>2TI2-dopri5"])
def test_torque_free_omega_matches_jacobi_elliptic_solution(omega0, method):
    # ORACLES C1: body ω(t) = (A₁cn, ±A₂sn, ±A₃dn)(λt + u₀ | m) (Landau–Lifshitz §37), both energy cases
    I = (1.0, 2.0, 3.0) if omega0[1] != -2.0 else (1.0, 2.5, 3.0)
    body = torque_free_body(I, omega0)
    rb = body.bodies(orientation=[0.3, 0.5, -0.2, 0.8], mass=2.0)
    scene = RigidScene(rb)
    t = np.linspace(0.0, 10.0, 41)
    res = tight_run(scene, 10.0, t, method=method)
    w_sim = np.array([rb.body_angular_velocity(y)[0] for y in res.y.T])
    err = np.abs(w_sim - body.omega(t)).max()
    assert err < 1e-8, err  # measured 1.3e-11 / 8.4e-11 / 2.3e-10 (DOP853), 2.6e-10 (dopri5); bound 1e-8 (the issue's)
    T = np.array([rb.kinetic_energy(y) for y in res.y.T])
    L = np.array([rb.angular_momentum(y) for y in res.y.T])
    assert abs(T[0] - body.energy) < 1e-14 * body.energy
    assert np.abs(T - T[0]).max() < 1e-10 * T[0]  # measured 3e-12 .. 2e-11 rel; T conserved to the tolerance
    assert np.all(L == L[0])                       # world L exact: Baraff's state, no torque


def test_closed_form_satisfies_euler_equations_and_invariants():
    # the oracle itself: Iω̇ + ω × Iω = 0 (centred differences), T and |L| constant, period 4K(m)/λ
    for w0 in [(1.0, 0.1, 2.0), (-3.0, 0.5, 0.2)]:
        b = torque_free_body((1.0, 2.0, 3.0), w0)
        t = np.linspace(0, 7, 200)
        h = 1e-5
        w = b.omega(t)
        wd = (b.omega(t + h) - b.omega(t - h)) / (2 * h)
        I = b.moments
        resid = I * wd + np.cross(w, I * w)
        assert np.abs(resid).max() < 1e-8  # measured 2e-10 (FD truncation)
        np.testing.assert_allclose(0.5 * np.sum(I * w * w, axis=1), b.energy, rtol=1e-13)
        np.testing.assert_allclose(np.sum((I * w) ** 2, axis=1), b.L2, rtol=1e-13)
        np.testing.assert_allclose(b.omega(b.period), b.omega(0.0), atol=1e-12)
        assert not np.allclose(b.omega(b.period / 2), b.omega(0.0), atol=1e-3)


def test_exact_principal_axis_spins_are_steady():
    # a spin about any single principal axis is a relative equilibrium of Euler's equations: ω(t) = ω(0),
    # including the (unstable) middle axis, where the elliptic formulas degenerate (m = 1, u₀ = K(1) = ∞)
    for w0 in [(1.5, 0, 0), (0, -2.0, 0), (0, 0, 0.7)]:
        b = torque_free_body((1.0, 2.0, 3.0), w0)
        assert b.case == "steady" and b.period == np.inf
        np.testing.assert_array_equal(b.omega([0.0, 3.0, 100.0]), np.tile(w0, (3, 1)))
        rb = b.bodies(orientation=[0.7, 0.1, 0.2, 0.3])
        res = RigidScene(rb).simulate(1.0, 0.05, method="rk4", diagnostics=False)
        np.testing.assert_allclose(rb.body_angular_velocity(res.y[:, -1])[0], w0, atol=5e-15)  # measured 5e-16


@pytest.mark.parametrize("name", sorted(n for n, m in METHODS.items() if not m.nystrom))
def test_angular_momentum_exact_without_torque_for_every_method(name):
    # with Baraff's state L̇ = τ = 0, so every integrator keeps world L exactly (gravity exerts no torque)
    body = torque_free_body((1.0, 2.0, 3.0), (1.0, 0.1, 2.0))
    rb = body.bodies(orientation=[1.0, 0.2, 0.3, 0.1], velocity=(1.0, 0.0, 2.0))
    res = RigidScene(rb, [RigidGravity()]).simulate(0.5, 0.01, method=name)
    L = np.array([rb.unpack(y)[3] for y in res.y.T])
    assert np.abs(L - L[0]).max() <= 4 * EPS * np.abs(L[0]).max()  # measured 0 (explicit), bound 4ε|L|


@pytest.mark.parametrize("name", sorted(n for n, m in METHODS.items() if m.nystrom))
def test_nystrom_methods_refuse_a_rigid_body(name):
    # a rigid body's state is not [q, v] with q̇ = v (quaternion, momentum): the Nyström pairs say so by name
    body = torque_free_body((1.0, 2.0, 3.0), (1.0, 0.1, 2.0))
    rb = body.bodies(orientation=[1.0, 0.2, 0.3, 0.1], velocity=(1.0, 0.0, 2.0))
    with pytest.raises(pbanim.errors.InvalidInput, match=name):
        RigidScene(rb, [RigidGravity()]).simulate(0.5, 0.01, method=name)


# ---------------------------------------------------------------------------------------------------
# ORACLES C2: intermediate-axis instability (T-handle)
# ---------------------------------------------------------------------------------------------------
@pytest.mark.parametrize("axis", [0, 2])
def test_spin_about_min_and_max_axes_is_stable(axis):
    # ORACLES C2: a perturbation δ of a spin about the min or max axis stays of order δ forever
    delta = 1e-3
    th = t_handle(spin=6.0, perturbation=delta, axis=axis)
    rb = th.body.bodies()
    res = RigidScene(rb).simulate(20.0, 0.01, method="rk4", record_every=5, diagnostics=False)
    w = np.array([rb.body_angular_velocity(y)[0] for y in res.y.T])
    off = np.delete(w, axis, axis=1)
    assert np.abs(off).max() < 10 * delta * 6.0    # measured 2.3δ·spin (axis 0), 1.4δ·spin (axis 2)
    assert np.abs(w[:, axis] - 6.0).max() < 1e-4   # measured 1.2e-5 (axis 0), 7.6e-7 (axis 2) ~ δ²·spin


def test_intermediate_axis_flips_periodically_with_T_and_L_conserved():
    # ORACLES C2: the middle-axis spin ω₂ reverses every half period 2K(m)/λ; T and |L| stay constant
    th = t_handle(spin=6.0, perturbation=1e-3, axis=1)
    b = th.body
    rb = b.bodies()
    t_end = 2.2 * b.period
    res = RigidScene(rb).simulate(t_end, 0.01, method="rk4")
    w2 = np.array([rb.body_angular_velocity(y)[0, 1] for y in res.y.T])
    flips = res.t[1:][np.sign(w2[1:]) != np.sign(w2[:-1])]
    exact = b.omega(res.t)[:, 1]
    flips_exact = res.t[1:][np.sign(exact[1:]) != np.sign(exact[:-1])]
    assert len(flips) == len(flips_exact) == 4
    assert np.abs(flips - flips_exact).max() < 0.1    # measured 0.02 s (h = 0.01 s; half period 5.75 s)
    np.testing.assert_allclose(np.diff(flips), b.period / 2, rtol=0.01)   # measured 0.22 %
    assert w2.max() > 0.99 * 6.0 and w2.min() < -0.99 * 6.0  # a full reversal, not a wobble
    T = res.diagnostics["kinetic"]
    L = np.linalg.norm(res.diagnostics["angular_momentum"], axis=1)
    assert np.abs(T - T[0]).max() < 3e-7 * T[0]        # measured 3.2e-8 rel (RK4, h = 0.01 s)
    assert np.abs(L - L[0]).max() <= 4 * EPS * L[0]    # |L| exact (no torque)


# ---------------------------------------------------------------------------------------------------
# ORACLES C3: quaternion drift, renormalization, exponential map
# ---------------------------------------------------------------------------------------------------
def test_explicit_euler_quaternion_norm_grows_exactly():
    # ORACLES C3: q_{n+1} = (1 + ½h(0, ω)) q_n ⇒ |q_n| = (1 + h²|ω|²/4)^(n/2); a sphere keeps |ω| constant
    w = np.array([0.4, -1.2, 2.0])
    rb = RigidBodies(1.0, sphere_inertia(1.0, 0.5), angular_velocities=[w])
    h, n = 0.02, 500
    res = RigidScene(rb, quaternions="none").simulate(n * h, h, method="euler", diagnostics=False)
    norms = np.linalg.norm(res.y[3:7], axis=0)
    exact = (1 + h * h * (w @ w) / 4) ** (np.arange(n + 1) / 2)
    assert abs(exact[-1] - 1) > 0.1                    # the drift is visible (|q_500| = 1.15)
    np.testing.assert_allclose(norms, exact, rtol=1e-13)  # measured 2.6e-14 rel (500 roundings); bound 1e-13


def test_explicit_euler_drift_per_step_for_an_asymmetric_body():
    # ORACLES C3 step by step: |q_{n+1}|/|q_n| = √(1 + h²|ω_n|²/4) with ω_n the current ω
    rb = torque_free_body((1.0, 2.0, 3.0), (1.0, 0.1, 2.0)).bodies()
    h = 0.05
    scene = RigidScene(rb, quaternions="none")
    y = rb.state()
    for _ in range(50):
        w = rb.velocities(y)[1][0]
        y1 = scene.step(0.0, y, h, method="euler")
        ratio = np.linalg.norm(rb.unpack(y1)[1]) / np.linalg.norm(rb.unpack(y)[1])
        assert abs(ratio - np.sqrt(1 + h * h * (w @ w) / 4)) < 4 * EPS
        y = y1


@pytest.mark.parametrize("method", ["euler", "rk4"])
def test_renormalization_keeps_unit_quaternions(method):
    # ORACLES C3: with the post-step stage, ||q| − 1| < 10ε at every step (default RigidScene)
    rb = torque_free_body((1.0, 2.0, 3.0), (1.0, 0.1, 2.0)).bodies()
    scene = RigidScene(rb)
    assert scene.pipeline[-1] == "renormalize"
    res = scene.simulate(5.0, 0.05, method=method)
    assert res.diagnostics["quat_norm_error"].max() < 10 * EPS   # measured 1ε


def test_exponential_map_keeps_unit_norm_and_converges_at_the_method_order():
    # RKMK: q ← exp(½θ) ⊗ q_n keeps |q| = 1 with no projection; RK4 on the group is 4th order in ω(t)
    body = torque_free_body((1.0, 2.0, 3.0), (1.0, 0.1, 2.0))
    rb = body.bodies(orientation=[0.3, 0.5, -0.2, 0.8])
    scene = RigidScene(rb, quaternions="exponential")
    assert scene.pipeline == ("integrate[exp_map]",)
    hs = np.array([0.1, 0.05, 0.025])
    errs = []
    for h in hs:
        res = scene.simulate(4.0, h, method="rk4", diagnostics=False)
        errs.append(np.abs(rb.body_angular_velocity(res.y[:, -1])[0] - body.omega(4.0)[0]).max())
        qn = np.linalg.norm(res.y[3:7], axis=0)
        assert np.abs(qn - 1).max() < 5e-14   # measured 1.1e-15 .. 5.3e-15 (roundoff random walk over 40..160 steps)
    pbanim.testing.assert_order(hs, errs, 4.0)
    euler = scene.simulate(4.0, 0.05, method="euler")     # Lie–Euler: first order but |q| stays 1
    assert euler.diagnostics["quat_norm_error"].max() < 2e-14  # measured 1.8e-15 (80 steps)


def test_exponential_map_and_renormalization_agree_under_forces_and_torques():
    # with gravity, body-point springs (one to the world) and angular drag, RK4 + exp map and RK4 +
    # renormalization are two 4th-order discretizations of one flow: their gap shrinks as h⁴
    rng = np.random.default_rng(14)
    rb = random_bodies(rng, 3)

    def effects():
        return [RigidGravity(), AngularDrag(0.05),
                RigidSprings([0, 1], [[0.2, 0, 0], [0, 0.3, 0]], [1, -1], [[0, 0.1, 0], [0, 0, 1.0]], 10.0, 0.3, 0.5)]

    hs = np.array([0.04, 0.02, 0.01])
    gaps = []
    for h in hs:
        a = RigidScene(rb, effects()).simulate(0.8, h, "rk4", diagnostics=False).y[:, -1]
        b = RigidScene(rb, effects(), quaternions="exponential").simulate(0.8, h, "rk4", diagnostics=False).y[:, -1]
        gaps.append(np.abs(rb.rotations(a) - rb.rotations(b)).max() + np.abs(a[:9] - b[:9]).max())
    pbanim.testing.assert_order(hs, gaps, 4.0)   # measured gaps 9.0e-7, 5.8e-8, 3.6e-9: slope 3.98


def test_dexpinv_inverts_the_exponential_differential():
    # d/dt exp(θ(t)) exp(θ)ᵀ = [ω]× with θ̇ = dexp⁻¹_θ(ω): check by a centred difference of R(θ(t))
    rng = np.random.default_rng(10)
    for _ in range(5):
        th, w = rng.normal(size=3), rng.normal(size=3)
        thd = dexpinv(th, w)
        h = 1e-6
        Rp, Rm, R0 = (quat_to_matrix(quat_exp(th + s * h * thd)) for s in (1, -1, 0))
        W = (Rp - Rm) / (2 * h) @ R0.T
        np.testing.assert_allclose([W[2, 1], W[0, 2], W[1, 0]], w, atol=1e-8)  # measured 1e-10


# ---------------------------------------------------------------------------------------------------
# translation: free fall of a spinning body, forces, springs, drag
# ---------------------------------------------------------------------------------------------------
def test_spinning_body_in_free_fall_has_exact_parabola_and_constant_L():
    # ORACLES A8 + C1: COM x(t) = x₀ + v₀t + ½gt² (RK4 exact on quadratics); gravity exerts no torque
    g = np.array([0.0, 0.0, -9.81])
    rb = RigidBodies(3.0, box_inertia(3.0, [0.2, 0.5, 1.0]), positions=[[1.0, 2.0, 10.0]],
                     velocities=[[2.0, -1.0, 5.0]], angular_velocities=[[3.0, 0.2, 1.0]])
    res = RigidScene(rb, [RigidGravity(g)]).simulate(2.0, 0.01, method="rk4")
    x = res.y[:3].T
    t = res.t[:, None]
    exact = np.array([1.0, 2.0, 10.0]) + np.array([2.0, -1.0, 5.0]) * t + 0.5 * g * t * t
    assert np.abs(x - exact).max() < 1e-13   # measured 1.9e-14 m
    L = res.y[10:13]
    assert np.all(L == L[:, :1])                           # stored L: exact
    Lc = res.diagnostics["angular_momentum_com"]
    assert np.abs(Lc - Lc[0]).max() < 1e-13 * np.abs(Lc[0]).max()  # about the moving COM: roundoff in c
    E = res.diagnostics["energy"]
    assert np.abs(E - E[0]).max() < 1e-10 * abs(E[0])  # translational part exact; rotational O(h⁴): measured 1.5e-11


def test_point_force_applies_force_and_torque_at_the_rotated_point():
    # a force f at body point r adds F = f and τ = (R r) × f; a callable force sees (t, y)
    rb = RigidBodies([1.0, 2.0], [1.0, 2.0, 3.0], orientations=[[1, 0, 0, 0], quat_from_axis_angle([0, 0, 1], 0.5)])
    r = np.array([[0.0, 0, 0], [1.0, 0, 0]])
    f = lambda t, y: np.array([[1.0, 0, 0], [0.0, 0.0, 2.0 * (1 + t)]])  # noqa: E731
    scene = RigidScene(rb, [PointForce([0, 1], r, f)])
    Q = scene.forces(1.0, rb.state())
    R = quat_to_matrix(quat_from_axis_angle([0, 0, 1], 0.5))
    np.testing.assert_allclose(Q[0], [1.0, 0, 0, 0, 0, 0])
    np.testing.assert_allclose(Q[1], np.concatenate([[0, 0, 4.0], np.cross(R @ r[1], [0, 0, 4.0])]), atol=1e-15)


def test_springs_between_bodies_conserve_momenta_and_energy():
    # internal spring forces: Σ P exact (ORACLES A7), Σ(x×P + L) to roundoff, energy O(h⁴) with k_d = 0
    rng = np.random.default_rng(11)
    rb = random_bodies(rng, 3)
    springs = RigidSprings([0, 1, 2], rng.normal(size=(3, 3)) * 0.3, [1, 2, 0], rng.normal(size=(3, 3)) * 0.3,
                           stiffness=20.0, damping=0.0, rest_length=0.5)
    res = RigidScene(rb, [springs]).simulate(2.0, 0.005, method="rk4")
    P, L, E = (res.diagnostics[k] for k in ("momentum", "angular_momentum", "energy"))
    assert np.abs(P - P[0]).max() < 1e-13    # linear invariant: measured 9e-15
    # Σ x×P + L is a quadratic invariant: RK4 keeps it to O(h⁴) only (a symplectic method would keep it)
    assert np.abs(L - L[0]).max() < 1e-7 * np.abs(L[0]).max()   # measured 1.8e-8 rel
    assert np.abs(E - E[0]).max() < 1e-6 * abs(E[0])            # measured 1.3e-7 rel
    damped = RigidScene(rb, [RigidSprings([0], [[0.1, 0, 0]], [1], [[0, 0.1, 0]], 20.0, 2.0, 0.5)])
    Ed = damped.simulate(2.0, 0.005, method="rk4").diagnostics["energy"]
    assert np.all(np.diff(Ed) <= 1e-12 * abs(Ed[0]))   # dissipative spring: energy never grows


def test_spring_to_world_gives_harmonic_oscillation():
    # a point mass on a spring to a world point: x(t) = x₀ cos(√(k/m) t) (body −1 = static world)
    k, m = 4.0, 1.0
    pm = RigidBodies.point_masses([[0.5, 0.0, 0.0]], masses=m)
    scene = RigidScene(pm, [RigidSprings([0], [[0, 0, 0]], [-1], [[0.0, 0.0, 0.0]], k, 0.0, rest_length=0.0)])
    res = scene.simulate(3.0, 0.005, method="rk4", diagnostics=False)
    exact = 0.5 * np.cos(np.sqrt(k / m) * res.t)
    assert np.abs(res.y[0] - exact).max() < 1e-9   # RK4 h⁴ error: measured 2.0e-10
    assert np.all(res.y[10:13] == 0)                # no torque on a point body: rotation inert


def test_springs_to_particles_match_the_particle_system():
    # particles as point bodies on rigid springs move exactly like pbanim.particles with DampedSprings
    from pbanim.particles import ParticleSystem
    from pbanim.particles.springs import DampedSprings

    x0 = np.array([[0.0, 0, 0], [1.2, 0.1, 0], [0.3, 1.1, 0.2]])
    v0 = np.array([[0.0, 0.1, 0], [0.0, 0, 0.3], [-0.2, 0, 0]])
    m = np.array([1.0, 2.0, 0.5])
    pairs = np.array([[0, 1], [1, 2], [2, 0]])
    ps = ParticleSystem(x0, v0, m)
    ref = Scene(ps, [DampedSprings(pairs, 30.0, 0.5, 1.0)]).simulate(1.0, 0.005, method="rk4")
    pm = RigidBodies.point_masses(x0, v0, m)
    z = np.zeros((3, 3))
    rig = RigidScene(pm, [RigidSprings(pairs[:, 0], z, pairs[:, 1], z, 30.0, 0.5, 1.0)]).simulate(1.0, 0.005, "rk4")
    np.testing.assert_allclose(rig.y[:9], ref.y[:9], atol=1e-12)   # measured 4e-16


def test_linear_and_angular_drag_decay_exponentially():
    # F = −c v ⇒ v(t) = v₀ e^(−ct/m); τ = −c ω on a sphere ⇒ ω(t) = ω₀ e^(−ct/I)
    m, I = 2.0, sphere_inertia(2.0, 0.5)[0, 0]
    rb = RigidBodies(m, sphere_inertia(m, 0.5), velocities=[[1.0, -2.0, 0.5]], angular_velocities=[[0.0, 3.0, 1.0]])
    res = RigidScene(rb, [LinearDrag(0.6), AngularDrag(0.1)]).simulate(2.0, 0.01, method="rk4")
    v = res.y[7:10] / m
    w = res.y[10:13] / I
    np.testing.assert_allclose(v, np.outer([1.0, -2.0, 0.5], np.exp(-0.6 * res.t / m)), atol=3e-12)  # measured 4.4e-13
    np.testing.assert_allclose(w, np.outer([0.0, 3.0, 1.0], np.exp(-0.1 * res.t / I)), atol=3e-11)  # measured 5.8e-12


def test_gravity_potential_and_diagnostics_relations():
    # V = −Σ m g·x; T = T_trans + T_rot; L_origin = L_com + M c × V_com (König's theorem for L)
    rng = np.random.default_rng(12)
    rb = random_bodies(rng, 4)
    y = rb.state()
    scene = RigidScene(rb, [RigidGravity()])
    d = scene.diagnostics(0.0, y)
    x = rb.unpack(y)[0]
    assert np.isclose(d["potential"], 9.81 * rb.mass @ x[:, 2], rtol=1e-14)
    assert np.isclose(d["kinetic"], d["kinetic_translational"] + d["kinetic_rotational"], rtol=1e-14)
    c = rb.center_of_mass(y)
    Pt = rb.linear_momentum(y)
    np.testing.assert_allclose(d["angular_momentum"], d["angular_momentum_com"] + np.cross(c, Pt), atol=1e-13)
    v, w = rb.velocities(y)
    Iw = np.linalg.inv(rb.inv_inertia_world(y))
    T_def = 0.5 * np.sum(rb.mass[:, None] * v * v) + 0.5 * np.einsum("ni,nij,nj->", w, Iw, w)
    assert np.isclose(d["kinetic"], T_def, rtol=1e-12)


# ---------------------------------------------------------------------------------------------------
# inertia tensors: primitives against closed forms and meshes (divergence theorem), parallel axis
# ---------------------------------------------------------------------------------------------------
def revolved_mesh(profile, n):
    """Closed surface of revolution about z from a profile [(r₀=0, z₀), (r₁, z₁), ..., (r_K=0, z_K)]."""
    prof = np.asarray(profile, dtype=float)
    phi = 2 * np.pi * np.arange(n) / n
    rings = [np.column_stack([r * np.cos(phi), r * np.sin(phi), np.full(n, z)]) for r, z in prof[1:-1]]
    V = np.vstack([[0, 0, prof[0, 1]], *rings, [0, 0, prof[-1, 1]]])
    top = len(V) - 1
    ring = lambda j, i: 1 + j * n + (i % n)  # noqa: E731
    F = [[0, ring(0, i + 1), ring(0, i)] for i in range(n)]
    for j in range(len(rings) - 1):
        for i in range(n):
            F += [[ring(j, i), ring(j, i + 1), ring(j + 1, i + 1)], [ring(j, i), ring(j + 1, i + 1), ring(j + 1, i)]]
    F += [[top, ring(len(rings) - 1, i), ring(len(rings) - 1, i + 1)] for i in range(n)]
    return V, np.array(F)


def test_box_mesh_matches_closed_form_after_rotation_and_translation():
    # divergence theorem on 12 triangles is exact for a box: I_mesh = R I_box Rᵀ, c = translation
    v, f = box_mesh([1.0, 2.0, 3.0])
    R = quat_to_matrix([0.9, 0.2, -0.3, 0.4])
    mp = mesh_mass_properties(v @ R.T + [1.0, -2.0, 3.0], f, density=2.0)
    assert np.isclose(mp.volume, 6.0, rtol=1e-14) and np.isclose(mp.mass, 12.0, rtol=1e-14)
    np.testing.assert_allclose(mp.com, [1.0, -2.0, 3.0], atol=1e-14)
    np.testing.assert_allclose(mp.inertia, R @ box_inertia(12.0, [1.0, 2.0, 3.0]) @ R.T, atol=1e-12)


def test_icosphere_inertia_converges_to_two_fifths_m_r_squared():
    # an inscribed icosphere: I/(m r²) → 2/5, error ÷4 per subdivision (O(edge²)), isotropic tensor
    errs = []
    for s in (2, 3, 4):
        v, f = icosphere_mesh(1.5, s)
        mp = mesh_mass_properties(v, f, mass=2.0)
        I = mp.inertia
        assert np.abs(I - I[0, 0] * np.eye(3)).max() < 1e-12  # icosahedral symmetry ⇒ isotropic tensor
        errs.append(abs(I[0, 0] - 0.4 * 2.0 * 1.5 ** 2) / (0.4 * 2.0 * 1.5 ** 2))
    assert errs[-1] < 1e-2                              # measured 2.9e-3 at 5120 faces
    assert 3.5 < errs[0] / errs[1] < 4.5 and 3.5 < errs[1] / errs[2] < 4.5   # measured 3.94, 3.99


def test_cylinder_and_capsule_meshes_converge_to_closed_forms():
    # revolved polygons (n around, n/4 per quarter arc) converge at O(1/n²) to the closed forms
    r, h, m = 0.4, 1.3, 3.0

    def capsule_profile(k):
        a = np.linspace(-np.pi / 2, 0, k)
        return [(0, -h / 2 - r)] + [(r * np.cos(t), -h / 2 + r * np.sin(t)) for t in a[1:]] + \
            [(r * np.cos(t), h / 2 + r * np.sin(t)) for t in -a[::-1][:-1]] + [(0, h / 2 + r)]

    for make, exact in ((lambda n: [(0, -h / 2), (r, -h / 2), (r, h / 2), (0, h / 2)], cylinder_inertia(m, r, h)),
                        (lambda n: capsule_profile(n // 4 + 1), capsule_inertia(m, r, h))):
        e = []
        for n in (64, 128):
            v, f = revolved_mesh(make(n), n)
            e.append(np.abs(mesh_mass_properties(v, f, mass=m).inertia - exact).max() / exact.max())
        assert e[1] < 1e-3 and 3.0 < e[0] / e[1] < 5.0   # measured cylinder 1.8e-4, capsule 2.9e-4; ratios 4.0


def test_parallel_axis_matches_a_two_body_mesh():
    # two disjoint boxes as one (two-component) closed mesh = Σ parallel_axis(I_c, m, c_i − c)
    v, f = box_mesh([1.0, 0.5, 0.5])
    c1, c2 = np.array([-1.0, 0.3, 0.0]), np.array([1.5, 0.0, 0.4])
    mp = mesh_mass_properties(np.vstack([v + c1, v + c2]), np.vstack([f, f + 8]), density=1.0)
    m1 = 0.25
    c = (c1 + c2) / 2
    composite = parallel_axis(box_inertia(m1, [1.0, 0.5, 0.5]), m1, c1 - c) + \
        parallel_axis(box_inertia(m1, [1.0, 0.5, 0.5]), m1, c2 - c)
    np.testing.assert_allclose(mp.com, c, atol=1e-15)
    np.testing.assert_allclose(mp.inertia, composite, atol=1e-14)


def test_primitive_closed_forms_and_limits():
    # hand values: box m/12(b²+c²...), sphere 2/5mr², cylinder ½mr² & m(3r²+h²)/12, capsule → sphere at h = 0,
    # a thin disc reaches the lamina equality I₁ + I₂ = I₃; principal_axes returns a proper rotation
    np.testing.assert_allclose(np.diag(box_inertia(6.0, [1.0, 1.0, 2.0])), [2.5, 2.5, 1.0])
    np.testing.assert_allclose(sphere_inertia(5.0, 2.0), 8.0 * np.eye(3))
    np.testing.assert_allclose(np.diag(cylinder_inertia(2.0, 1.0, 3.0, axis=0)), [1.0, 2.0, 2.0])
    np.testing.assert_allclose(capsule_inertia(3.0, 0.7, 0.0), sphere_inertia(3.0, 0.7), rtol=1e-15)
    disc = cylinder_inertia(1.0, 1.0, 1e-9)
    d = np.sort(np.diag(disc))
    assert abs(d[0] + d[1] - d[2]) < 1e-15 and validate_inertia(disc) is not None
    rng = np.random.default_rng(13)
    A0 = quat_to_matrix(rng.normal(size=4))
    I = A0 @ np.diag([1.0, 2.0, 2.5]) @ A0.T
    mom, A = principal_axes(I)
    np.testing.assert_allclose(mom, [1.0, 2.0, 2.5], rtol=1e-14)
    np.testing.assert_allclose(A @ np.diag(mom) @ A.T, I, atol=1e-14)
    assert np.isclose(np.linalg.det(A), 1.0)


# ---------------------------------------------------------------------------------------------------
# ORACLES G3: bad inputs get named errors; divergence stops with SimulationDiverged
# ---------------------------------------------------------------------------------------------------
BAD = [
    (lambda: RigidBodies(-1.0, [1.0, 1.0, 1.0]), "RigidBodies.__init__: mass must be a float array of shape (any,) "
     "(not NaN, entries > 0, or one number for all, not empty), got -1.0"),
    (lambda: RigidBodies(np.nan, [1.0, 1.0, 1.0]), "mass must be a float array of shape (any,) (not NaN, entries > 0"),
    (lambda: RigidBodies(1.0, [[1.0, 0.5, 0], [0, 1.0, 0], [0, 0, 1.0]]),
     "got [[1.0, 0.5, 0], [0, 1.0, 0], [0, 0, 1.0]]; it is not symmetric (max |I - I^T| = 0.5)"),
    (lambda: RigidBodies(1.0, [1.0, -1.0, 1.0]), "got [1.0, -1.0, 1.0]; principal moments [-1.  1.  1.] are not all > 0"),
    (lambda: RigidBodies(1.0, [1.0, 1.0, 3.0]), "inertia must be an inertia tensor of shape (3, 3) or (K, 3, 3), or "
     "principal moments (3,) or (K, 3): finite, symmetric, positive definite, with principal moments I1 + I2 >= I3, got "
     "[1.0, 1.0, 3.0]; principal moments [1. 1. 3.] violate the triangle inequality I1 + I2 >= I3 (1 + 1 < 3)"),
    (lambda: RigidBodies([1.0, 1.0], [[1.0, 1.0, 3.0], [1, 1, 1]]),
     "; tensor 0: principal moments [1. 1. 3.] violate the triangle inequality"),
    (lambda: RigidBodies(1.0, np.ones((2, 2))), "RigidBodies.__init__: inertia must be an inertia tensor of shape (3, 3)"),
    (lambda: RigidBodies(1.0, [1.0, 1.0, 1.0], orientations=[[0.0, 0, 0, 0]]),
     "RigidBodies.__init__: orientations must be a float array of shape (4,) (finite, or a batch of them (extra first "
     "axis), not empty), non-zero, got [[0.0, 0, 0, 0]]; row 0 is zero"),
    (lambda: RigidBodies(1.0, [1.0, 1.0, 1.0], positions=[[np.nan, 0, 0]]),
     "positions must be a float array of shape (3,) (finite, or a batch of them (extra first axis), not empty), got "
     "[[nan, 0, 0]]; it has NaN or inf entries"),
    (lambda: RigidBodies([1.0, 2.0], [1.0, 1.0, 1.0], positions=np.zeros((3, 3))), "must have shape"),
    (lambda: RigidBodies(np.inf, [1.0, 1.0, 1.0], velocities=[[1.0, 0, 0]]), "static bodies cannot move"),
    (lambda: box_inertia(1.0, [1.0, -2.0, 1.0]), "box_inertia: extents must be a float array of shape (3,) (finite, "
     "entries > 0, not empty), got [1.0, -2.0, 1.0]"),
    (lambda: sphere_inertia(0.0, 1.0), "sphere_inertia: mass must be a finite number > 0, got 0.0"),
    (lambda: cylinder_inertia(1.0, 1.0, 1.0, axis=3), "cylinder_inertia: axis must be an index in 0 … 2, got 3"),
    (lambda: capsule_inertia(1.0, 1.0, -0.5), "capsule_inertia: height must be a finite number >= 0, got -0.5"),
    (lambda: mesh_mass_properties(*box_mesh([1.0, 1, 1])[:1], box_mesh([1.0, 1, 1])[1][:-1]), "mesh must be closed"),
    (lambda: mesh_mass_properties(box_mesh([1.0, 1, 1])[0], box_mesh([1.0, 1, 1])[1][:, ::-1]),
     "mesh volume must be positive"),
    (lambda: mesh_mass_properties(box_mesh([1.0, 1, 1])[0], np.vstack([box_mesh([1.0, 1, 1])[1]] * 2)),
     "faces must be consistently oriented"),
    (lambda: RigidSprings([0], [[0, 0, 0]], [1], [[0, 0, 0]], stiffness=-1.0),
     "RigidSprings.__init__: stiffness must be a float array of shape (k,) (k = 1) (finite, entries >= 0, or one number "
     "for all, not empty), got -1.0"),
    (lambda: RigidSprings([0, 1], [[0, 0, 0]], [1], [[0, 0, 0]], 1.0), "point_a must be a float array of shape (k, 3) "
     "(k = 2) (finite, not empty), got [[0, 0, 0]]; shape (1, 3)"),
    (lambda: RigidGravity([0.0, -9.81]), "RigidGravity.__init__: g must be a float array of shape (3,) (finite, not "
     "empty), got [0.0, -9.81]; shape (2,)"),
    (lambda: RigidScene(RigidBodies(1.0, [1.0, 1, 1]), quaternions="euler"),
     "RigidScene.__init__: quaternions must be one of 'renormalize', 'exponential', 'none', got 'euler'"),
    (lambda: RigidScene(RigidBodies(1.0, [1.0, 1, 1]), [PointForce([-1], [[0, 0, 0]], [[1, 0, 0]])]),
     "PointForce.__init__: bodies must be an integer array of shape (k,) of body indices in 0 … N − 1, not empty, got "
     "[-1]; entries range over [-1, -1]"),
    (lambda: RigidScene(RigidBodies(1.0, [1.0, 1, 1]), [PointForce([1], [[0, 0, 0]], [[1, 0, 0]])]),
     "PointForce: bodies must lie in [0, 0] (forces on the world do nothing), got [1]"),
    (lambda: RigidBodies(1.0, [1.0, 1, 1]).point_velocity(RigidBodies(1.0, [1.0, 1, 1]).state(), [3], [[0, 0, 0]]),
     "RigidBodyProtocol.point_velocity: body_idx must be an integer array of shape (m,) of body indices in -1 … self.N − 1 "
     "(−1: the static world), got [3]; entries range over [3, 3], N = 1"),
    (lambda: RigidScene(RigidBodies(1.0, [1.0, 1, 1]), [LinearDrag(-0.1)]),
     "LinearDrag.__init__: coefficient must be a float array of shape (any,) (finite, entries >= 0, or one number for "
     "all, not empty), got -0.1"),
    (lambda: RigidScene(RigidBodies(1.0, [1.0, 1, 1]), [LinearDrag([0.1, 0.2])]),
     "LinearDrag: coefficient must be a number or have shape (1,) (one per body), got shape (2,)"),
    (lambda: RigidScene(RigidBodies(1.0, [1.0, 1, 1]), [RigidSprings([0], [[0, 0, 0]], [2], [[0, 0, 1]], 1.0)]),
     "RigidSprings: body_b must lie in [-1, 0] (-1: the static world), got [2]"),
    (lambda: torque_free_body((2.0, 1.0, 3.0), (1.0, 0, 0)), "moments must be 3 strictly ascending"),
    (lambda: torque_free_body((1.0, 2.0, 3.0), (0.0, 0, 0)), "omega0 must be a finite non-zero 3-vector"),
    (lambda: RigidScene(RigidBodies(1.0, [1.0, 1, 1])).simulate(1.0, -0.1),
     "RigidScene.simulate: h must be a finite number > 0, got -0.1"),
]


@pytest.mark.parametrize("make,message", BAD, ids=[m[:40] for _, m in BAD])
def test_bad_inputs_raise_named_value_errors(make, message):
    # ORACLES G3: each rejected input is a ValueError whose message names the value and the fix
    with pytest.raises(ValueError) as info:
        make()
    assert message in str(info.value)


def test_rigid_effects_reject_particle_systems():
    # rigid effects bind only to RigidBodies (a clear error, not a broadcasting failure)
    from pbanim.particles import ParticleSystem

    with pytest.raises(ValueError, match="RigidGravity acts on RigidBodies, got ParticleSystem"):
        Scene(ParticleSystem([[0.0, 0.0, 0.0]]), [RigidGravity()])


def test_nan_states_stop_with_simulation_diverged():
    # ORACLES G3: a NaN start state is refused by name (y0), and a run that blows up (explicit Euler on a
    # stiff spring) raises SimulationDiverged
    rb = RigidBodies.point_masses([[1.0, 0, 0]])
    y0 = rb.state()
    rb.unpack(y0)[3][0, 1] = np.nan
    with pytest.raises(pbanim.errors.InvalidInput, match=r"RigidScene.simulate: y0 must be .*got .*; it has NaN or "
                                                         r"inf entries"):
        RigidScene(rb).simulate(1.0, 0.1, method="rk4", y0=y0)
    stiff = RigidScene(rb, [RigidSprings([0], [[0, 0, 0]], [-1], [[0, 0, 0]], 1e6, 0.0, 0.0)])
    with pytest.raises(SimulationDiverged) as info:
        stiff.simulate(200.0, 0.01, method="euler", diagnostics=False)   # hω = 10: |growth| = √101 per step
    assert info.value.step > 0
    with pytest.raises(SimulationDiverged):
        RigidScene(rb, [RigidSprings([0], [[0, 0, 0]], [-1], [[0, 0, 0]], 1e6, 0.0, 0.0)],
                   quaternions="exponential").simulate(200.0, 0.01, method="euler", diagnostics=False)


# ---------------------------------------------------------------------------------------------------
# chapter 05 figures (quick mode data, physics not pixels) and the benchmark smoke run
# ---------------------------------------------------------------------------------------------------
def test_figure_tumbling_omega(figure_data):
    # ORACLES C1 in the figure: RK4 (h = 0.05) tracks the elliptic-function ω(t); L exact, T to O(h⁴)
    d = figure_data("ch05_tumbling_omega")
    assert d["max_err"] < 1e-3   # measured 1.4e-4 rad/s over 3 periods (RK4, h = 0.05 s)
    assert np.abs(d["omega_sim"] - d["omega_exact"]).max() == pytest.approx(d["max_err"])
    assert np.abs(d["energy"] / d["energy"][0] - 1).max() < 1e-5   # measured 2.3e-6
    L = d["angular_momentum"]
    assert np.all(L == L[0])


def test_figure_polhode(figure_data):
    # polhodes lie on the momentum sphere and the energy ellipsoid (closed form to roundoff; RK4 to O(h⁴))
    d = figure_data("ch05_polhode")
    assert d["sphere_err"].max() < 1e-12 and d["ellipsoid_err"].max() < 1e-12   # measured 1.3e-14
    Ls = d["L_sim"]
    assert np.abs(np.linalg.norm(Ls, axis=1) - d["L_mag"]).max() < 1e-13       # |L| exact, measured 7e-16
    assert np.abs(np.sum(Ls ** 2 / d["moments"], axis=1) / d["energy_sim"] - 1).max() < 1e-6  # measured 1.8e-7
    assert len(d["curves"]) >= 12


def test_figure_t_handle_flip(figure_data):
    # ORACLES C2 in the figure: flips every half period 2K(m)/λ; T and |L| conserved; other axes stable
    d = figure_data("ch05_t_handle_flip")
    assert len(d["flips"]) >= 2
    np.testing.assert_allclose(np.diff(d["flips"]), d["period"] / 2, rtol=0.01)   # measured 0.2 %
    assert np.abs(d["kinetic"] / d["kinetic"][0] - 1).max() < 3e-7                  # measured 3.2e-8
    assert np.abs(d["L_norm"] / d["L_norm"][0] - 1).max() <= 4 * EPS
    assert np.all(d["stable_offaxis_max"] < 10 * d["perturbation"] * d["spin"])     # measured 2.3δ·spin
    assert d["omega"][:, 1].min() < -0.99 * d["spin"] < 0.99 * d["spin"] < d["omega"][:, 1].max()


def test_figure_quat_drift(figure_data):
    # ORACLES C3 in the figure: Euler follows its exact law; RK4 drifts less; renormalize / exp map at ε
    d = figure_data("ch05_quat_drift")
    dr = d["drift"]
    np.testing.assert_allclose(dr["euler"][1:], d["euler_law"][1:] - 1, rtol=1e-12)   # measured 2.8e-14
    assert dr["euler"][-1] > dr["midpoint"][-1] > dr["rk4"][-1] > 1e-9
    # |q|² is a quadratic invariant of q̇ = ½(0, ω)⊗q: implicit midpoint keeps it (to its Newton tolerance)
    assert dr["implicit_midpoint"].max() < 3e-14   # measured 2.9e-15 over 200 steps
    assert dr["rk4+renormalize"].max() < 10 * EPS
    assert dr["rk4+exponential"].max() < 5e-14   # measured 6e-15 after 200 steps


def test_figure_work_precision(figure_data):
    # errors shrink with h at each method's order (Euler ~1, RK4 ~4) under every quaternion policy
    rows = figure_data("ch05_work_precision")["rows"]
    assert {"euler+renormalize", "rk4+none", "rk4+exponential"} <= set(rows)
    for key, r in rows.items():
        order = 4 if key.startswith("rk4") else 1
        ratios = r["error"][:-1] / r["error"][1:]
        assert np.all(ratios > 2 ** order * 0.6) and np.all(ratios < 2 ** order * 1.5), (key, ratios)
        assert np.all(r["wall_time"] > 0) and np.all(np.diff(r["nfev"]) > 0)
    # renormalization does not change RK4's ω error (the projection is second order); the exp map is close
    np.testing.assert_allclose(rows["rk4+renormalize"]["error"], rows["rk4+none"]["error"], rtol=1e-3)
    np.testing.assert_allclose(rows["rk4+exponential"]["error"], rows["rk4+renormalize"]["error"], rtol=0.3)


def test_figure_tumbling_box(figure_data):
    # the animated box: ≤ 60 frames, unit quaternions, T and L conserved, and its middle axis flips over
    d = figure_data("ch05_tumbling_box")
    assert 3 <= d["frames"] <= 60 and len(d["t"]) == d["frames"]
    assert np.abs(d["quat_norm"] - 1).max() < 10 * EPS
    assert np.abs(d["energy"] / d["energy"][0] - 1).max() < 1e-6   # measured 1.7e-8
    assert np.all(d["L"] == d["L"][0])
    yy = d["body_y_axis_world"][:, 1]
    assert yy[0] > 0.99 and yy.min() < -0.9                        # intermediate axis turned over


def test_bench_rigid_quick_smoke():
    # the benchmark runs and every goal has a finite measurement (no timing assertions)
    from pbanim.bench import format_report
    from pbanim.bench.rigid import run

    rep = run(quick=True)
    assert {g.id for g in rep.goals} == {"rigid-rk4-vs-handwritten", "rigid-vectorized-vs-loop",
                                         "rigid-baselines-agree"}
    assert all(np.isfinite(g.measured) for g in rep.goals)
    assert "goal rigid-rk4-vs-handwritten:" in format_report(rep)
