"""Rigid-body dynamics (chapter 05): Baraff's state, inertia tensors, effects, quaternions, oracles C1–C3, G3."""

import numpy as np
import pytest
from hypothesis import given, strategies as st

import pbanim
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
def tight_run(scene, t_end, t_eval, rtol=1e-12):
    """A tight adaptive Dormand–Prince run of a scene's rhs (pbanim.solve, "scipy:DOP853")."""
    solve = getattr(pbanim, "solve", None)
    if solve is None:  # pragma: no cover - until pbanim.solve lands
        from scipy.integrate import solve_ivp
        res = solve_ivp(scene.rhs, (0.0, t_end), scene.system.state(), method="DOP853", rtol=rtol, atol=rtol,
                        t_eval=t_eval)
    else:
        res = solve(scene.rhs, (0.0, t_end), scene.system.state(), method="scipy:DOP853", rtol=rtol,
                    atol=rtol, t_eval=t_eval)
    assert res.success, res.message
    return res


@pytest.mark.parametrize("omega0", [(1.0, 0.1, 2.0), (-3.0, 0.5, 0.2), (0.3, -2.0, 1.0)],
                         ids=["M2>2TI2", "M2<2TI2", "near-separatrix"])
def test_torque_free_omega_matches_jacobi_elliptic_solution(omega0):
    # ORACLES C1: body ω(t) = (A₁cn, ±A₂sn, ±A₃dn)(λt + u₀ | m) (Landau–Lifshitz §37), both energy cases
    I = (1.0, 2.0, 3.0) if omega0[1] != -2.0 else (1.0, 2.5, 3.0)
    body = torque_free_body(I, omega0)
    rb = body.bodies(orientation=[0.3, 0.5, -0.2, 0.8], mass=2.0)
    scene = RigidScene(rb)
    t = np.linspace(0.0, 10.0, 41)
    res = tight_run(scene, 10.0, t)
    w_sim = np.array([rb.body_angular_velocity(y)[0] for y in res.y.T])
    err = np.abs(w_sim - body.omega(t)).max()
    assert err < 1e-8, err  # measured 8e-11 .. 2e-10 at rtol = atol = 1e-12; bound 1e-8 (the issue's)
    T = np.array([rb.kinetic_energy(y) for y in res.y.T])
    L = np.array([rb.angular_momentum(y) for y in res.y.T])
    assert abs(T[0] - body.energy) < 1e-14 * body.energy
    assert np.abs(T - T[0]).max() < 1e-9 * T[0]   # measured 6e-11 abs; T conserved to the tolerance
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


@pytest.mark.parametrize("name", sorted(METHODS))
def test_angular_momentum_exact_without_torque_for_every_method(name):
    # with Baraff's state L̇ = τ = 0, so every integrator keeps world L exactly (gravity exerts no torque)
    body = torque_free_body((1.0, 2.0, 3.0), (1.0, 0.1, 2.0))
    rb = body.bodies(orientation=[1.0, 0.2, 0.3, 0.1], velocity=(1.0, 0.0, 2.0))
    res = RigidScene(rb, [RigidGravity()]).simulate(0.5, 0.01, method=name)
    L = np.array([rb.unpack(y)[3] for y in res.y.T])
    assert np.abs(L - L[0]).max() <= 4 * EPS * np.abs(L[0]).max()  # measured 0 (explicit), bound 4ε|L|


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
    assert np.abs(off).max() < 3 * delta * 6.0     # measured 1.3δ·spin (axis 0), 1.2δ·spin (axis 2)
    assert np.abs(w[:, axis] - 6.0).max() < 1e-4   # measured 4e-6


def test_intermediate_axis_flips_periodically_with_T_and_L_conserved():
    # ORACLES C2: the middle-axis spin ω₂ reverses every half period 2K(m)/λ; T and |L| stay constant
    th = t_handle(spin=6.0, perturbation=1e-3, axis=1)
    b = th.body
    rb = b.bodies()
    t_end = 2.2 * b.period
    res = RigidScene(rb).simulate(t_end, 0.005, method="rk4", record_every=2)
    w2 = np.array([rb.body_angular_velocity(y)[0, 1] for y in res.y.T])
    flips = res.t[1:][np.sign(w2[1:]) != np.sign(w2[:-1])]
    exact = b.omega(res.t)[:, 1]
    flips_exact = res.t[1:][np.sign(exact[1:]) != np.sign(exact[:-1])]
    assert len(flips) == len(flips_exact) == 4
    assert np.abs(flips - flips_exact).max() < 0.05   # measured 3e-4 s (period 11.5 s)
    np.testing.assert_allclose(np.diff(flips), b.period / 2, rtol=0.01)
    assert w2.max() > 0.99 * 6.0 and w2.min() < -0.99 * 6.0  # a full reversal, not a wobble
    T = res.diagnostics["kinetic"]
    L = np.linalg.norm(res.diagnostics["angular_momentum"], axis=1)
    assert np.abs(T - T[0]).max() < 1e-7 * T[0]        # measured 4e-9 rel (RK4, h = 5 ms)
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
    assert abs(exact[-1] - 1) > 0.2                    # the drift is visible (|q_500| = 1.24)
    np.testing.assert_allclose(norms, exact, rtol=1e-13)  # measured 7e-15 rel; bound 1e-13


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
    assert res.diagnostics["quat_norm_error"].max() < 10 * EPS   # measured 2.2e-16


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
        assert np.abs(qn - 1).max() < 1e-14   # measured 4.4e-16 after 160 steps (roundoff random walk)
    pbanim.testing.assert_order(hs, errs, 4.0)
    euler = scene.simulate(4.0, 0.05, method="euler")     # Lie–Euler: first order but |q| stays 1
    assert euler.diagnostics["quat_norm_error"].max() < 1e-14


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
    assert np.abs(x - exact).max() < 1e-12   # measured 7e-15 m; bound 1e-12
    L = res.diagnostics["angular_momentum_com"]
    assert np.all(L == L[0])
    E = res.diagnostics["energy"]
    assert np.abs(E - E[0]).max() < 1e-7 * abs(E[0])  # translational part exact; rotational O(h⁴) — measured 3e-10


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
    res = RigidScene(rb, [springs]).simulate(2.0, 0.002, method="rk4")
    P, L, E = (res.diagnostics[k] for k in ("momentum", "angular_momentum", "energy"))
    assert np.abs(P - P[0]).max() < 1e-12    # measured 2e-15
    assert np.abs(L - L[0]).max() < 1e-11    # measured 3e-14
    assert np.abs(E - E[0]).max() < 1e-6 * abs(E[0])   # measured 3e-9 rel
    damped = RigidScene(rb, [RigidSprings([0], [[0.1, 0, 0]], [1], [[0, 0.1, 0]], 20.0, 2.0, 0.5)])
    Ed = damped.simulate(2.0, 0.002, method="rk4").diagnostics["energy"]
    assert np.all(np.diff(Ed) <= 1e-12 * abs(Ed[0]))   # dissipative spring: energy never grows


def test_spring_to_world_gives_harmonic_oscillation():
    # a point mass on a spring to a world point: x(t) = x₀ cos(√(k/m) t) (body −1 = static world)
    k, m = 4.0, 1.0
    pm = RigidBodies.point_masses([[0.5, 0.0, 0.0]], masses=m)
    scene = RigidScene(pm, [RigidSprings([0], [[0, 0, 0]], [-1], [[0.0, 0.0, 0.0]], k, 0.0, rest_length=0.0)])
    res = scene.simulate(3.0, 0.001, method="rk4")
    exact = 0.5 * np.cos(np.sqrt(k / m) * res.t)
    assert np.abs(res.y[0] - exact).max() < 1e-12   # measured 2e-14 (RK4 h⁴ error)
    assert np.all(res.y[10:13] == 0)                # no torque on a point body: rotation inert


def test_springs_to_particles_match_the_particle_system():
    # particles as point bodies on rigid springs move exactly like pbanim.particles with DampedSprings
    from pbanim.particles import ParticleSystem
    from pbanim.particles_springs import DampedSprings

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
    np.testing.assert_allclose(v, np.outer([1.0, -2.0, 0.5], np.exp(-0.6 * res.t / m)), atol=1e-10)
    np.testing.assert_allclose(w, np.outer([0.0, 3.0, 1.0], np.exp(-0.1 * res.t / I)), atol=1e-9)  # measured 2e-11


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
