"""pbanim.particles: force objects, Jacobians, diagnostics, models and the ch01 figures.

Each test names the physics it checks and the oracle (ORACLES.md at the top of the repository).
"""

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from pbanim.errors import InvalidInput, SimulationDiverged
from pbanim.models.particles import hanging_net, projectile_drag_model, two_body_spring_model
from pbanim.ode import METHODS
from pbanim.particles import (AnchorSprings, DampedSprings, Drag, Gravity, ParticleSystem, UserForce,
                              spring_forces_loop)
from pbanim.scene import Effect, Scene
from pbanim.testing import assert_order, check_grad

FIXED_STEP = sorted(name for name, m in METHODS.items() if not m.adaptive)


def random_network(seed, N=6, dim=3, density=0.5, damping=True):
    """Random particles joined by random damped springs (rest lengths off the current lengths)."""
    rng = np.random.default_rng(seed)
    x = rng.normal(size=(N, dim))
    v = rng.normal(size=(N, dim))
    m = rng.uniform(0.5, 2.0, N)
    pairs = np.array([(i, j) for i in range(N) for j in range(i + 1, N) if rng.random() < density] or [(0, 1)])
    S = len(pairs)
    springs = DampedSprings(pairs, stiffness=rng.uniform(1.0, 10.0, S),
                            damping=rng.uniform(0.0, 0.5, S) if damping else 0.0,
                            rest_length=rng.uniform(0.5, 1.5, S))
    return ParticleSystem(x, v, m), springs


# -- closed forms ---------------------------------------------------------------------------------

def test_drag_closed_form_rk4():
    # one particle, gravity + drag: v(t) = v_T + (v0 - v_T) e^(-k t/m), v_T = m g / k (issue 2, ch01)
    model = projectile_drag_model(mass=2.0, drag=0.7, velocity=(10.0, 8.0))
    res = model.scene().simulate(2.0, 0.01, "rk4")
    ex = model.exact(res.t)
    err_v = np.abs(res.y[2:].T - ex["v"]).max()
    err_x = np.abs(res.y[:2].T - ex["x"]).max()
    # measured 1.6e-11 (v) at h = 0.01 (error of order h^4 ~ 1e-8 times a small constant); bound 1e-10
    assert err_v < 1e-10 and err_x < 1e-10, (err_v, err_x)
    # terminal velocity: after 20 time constants the particle falls at v_T
    late = model.exact(np.array([40.0 * model.params["tau"]]))["v"][0]
    assert np.allclose(late, model.params["v_terminal"], rtol=1e-12)


def test_drag_closed_form_order_symplectic_euler():
    # the same closed form, approached at first order by symplectic Euler (ORACLES A3 fitted slope)
    model = projectile_drag_model(mass=2.0, drag=0.7, velocity=(10.0, 8.0))
    hs = np.array([0.004, 0.002, 0.001])
    errs = []
    for h in hs:
        res = model.scene().simulate(2.0, h, "symplectic_euler", diagnostics=False)
        errs.append(np.abs(res.y[2:].T - model.exact(res.t)["v"]).max())
    assert_order(hs, errs, 1.0, tol=0.1)  # measured slope 1.0004


def test_free_fall_exact_for_rk4():
    # ORACLES A8: RK4 is exact for a constant force (k = 0 model is free fall)
    model = projectile_drag_model(drag=0.0, velocity=(3.0, 4.0))
    res = model.scene().simulate(2.0, 0.1, "rk4")
    err = np.abs(res.y[:2].T - model.exact(res.t)["x"]).max()
    assert err < 1e-13  # measured 5.3e-15 (roundoff of 20 steps), bound 1e-13


def test_two_body_spring_frequency():
    # two masses on a spring oscillate at omega = sqrt(k (m1 + m2) / (m1 m2)) (issue 2, ch01)
    m1, m2, k = 1.0, 3.0, 10.0
    model = two_body_spring_model(m1=m1, m2=m2, stiffness=k, rest_length=1.0, amplitude=0.2)
    omega = np.sqrt(k * (m1 + m2) / (m1 * m2))
    T = 2 * np.pi / omega
    res = model.scene().simulate(5 * T, T / 200, "rk4")
    length = np.linalg.norm(res.y[0:2] - res.y[2:4], axis=0)
    # measured frequency: zero crossings of l - r, linearly interpolated
    u = length - 1.0
    i = np.flatnonzero(np.sign(u[:-1]) != np.sign(u[1:]))
    tc = res.t[i] - u[i] * (res.t[i + 1] - res.t[i]) / (u[i + 1] - u[i])
    period = 2 * np.mean(np.diff(tc))
    # measured rel error 2e-6 (linear interpolation of the crossings), bound 2e-5; a period from m1 or
    # m2 alone would be off by 15 % or more
    assert abs(period / T - 1) < 2e-5, period / T
    assert np.abs(length - model.exact(res.t)["length"]).max() < 1e-7  # measured 2.8e-8
    # centre of mass fixed, momentum zero to roundoff (ORACLES A7)
    assert np.abs(res.diagnostics["momentum"]).max() < 1e-14  # measured 1.8e-15


# -- momentum and energy on random spring networks ------------------------------------------------

@pytest.mark.parametrize("method", FIXED_STEP)
@given(seed=st.integers(0, 10**6), dim=st.sampled_from([2, 3]))
def test_spring_network_conserves_momentum(method, seed, dim):
    # ORACLES A7: internal spring forces obey Newton's third law, so every method (linear in the force)
    # keeps P = sum m v constant to roundoff; symplectic methods also keep L (central forces)
    ps, springs = random_network(seed, N=5, dim=dim)
    res = Scene(ps, [springs]).simulate(0.2 if METHODS[method].implicit else 0.5, 0.01, method)
    P = res.diagnostics["momentum"]
    scale = np.sum(ps.m[:, None] * np.abs(ps.v0)) + 1.0
    assert np.abs(P - P[0]).max() < 5e-15 * scale  # measured <= 8.5e-16 x scale (20 networks), bound 5e-15
    if METHODS[method].symplectic:
        L = res.diagnostics["angular_momentum"]
        # measured <= 1.1e-14 relative (symplectic Euler), bound 1e-13
        assert np.abs(L - L[0]).max() < 1e-13 * (np.abs(L[0]).max() + 1.0)


@pytest.mark.parametrize("method", sorted(name for name, m in METHODS.items() if m.adaptive and not m.nystrom))
@given(seed=st.integers(0, 10**6))
def test_spring_network_conserves_momentum_adaptive(method, seed):
    # ORACLES A7 for adaptive methods, through pbanim.solve on the scene's right-hand side (the Nyström pairs
    # refuse the damped springs by name: tests/test_ode_nystrom.py)
    from pbanim import solve

    ps, springs = random_network(seed, N=5, dim=3)
    scene = Scene(ps, [springs])
    res = solve(scene.rhs, (0.0, 0.5), ps.state(), method=method, rtol=1e-8, atol=1e-10, jac=scene.jac)
    assert res.success
    P = np.array([ps.linear_momentum(res.y[:, k]) for k in range(res.y.shape[1])])
    scale = np.sum(ps.m[:, None] * np.abs(ps.v0)) + 1.0
    assert np.abs(P - P[0]).max() < 5e-15 * scale  # as for the fixed-step methods


@pytest.mark.parametrize("method, bound", [("symplectic_euler", 0.2), ("verlet", 0.03)])
@given(seed=st.integers(0, 10**6))
def test_spring_network_energy_bounded_symplectic(method, bound, seed):
    # symplectic methods keep the energy of an undamped spring network within O(h^p) of E0, with no
    # drift (backward error analysis, Hairer-Lubich-Wanner IX). Over 25 seeds, t = 10 s, h = 0.01:
    # max rel deviation measured 3.4e-2 (symplectic Euler, bound 0.2) and 6.2e-3 (Verlet, bound 0.03);
    # explicit Euler on the same networks deviates by 0.29 ... 30, so the bound can fail
    ps, springs = random_network(seed, N=5, dim=2, damping=False)
    res = Scene(ps, [springs]).simulate(6.0, 0.01, method, record_every=5)
    E = res.diagnostics["energy"]
    dev = np.abs(E - E[0]) / abs(E[0])
    assert dev.max() < bound, dev.max()


# -- vectorized vs readable loop, scatter variants ------------------------------------------------

@given(seed=st.integers(0, 10**6), dim=st.sampled_from([2, 3]))
def test_vectorized_springs_match_loop(seed, dim):
    # the vectorized force equals the readable one-spring-at-a-time version (DESIGN 3.8)
    ps, springs = random_network(seed, N=7, dim=dim)
    scene = Scene(ps, [springs])
    y = ps.state()
    x, v = ps.unpack(y)
    Q_loop = spring_forces_loop(x, v, springs.pairs, springs.ks, springs.kd, springs.rest)
    Q_vec = scene.forces(0.0, y)
    assert np.abs(Q_vec - Q_loop).max() <= 1e-13 * (np.abs(Q_loop).max() + 1)
    Q_at = ps.zero_forces()
    springs.apply_add_at(0.0, y, Q_at)
    Q_inc = springs.incidence().T @ springs.spring_forces(y)
    assert np.allclose(Q_at, Q_vec, rtol=0, atol=1e-13) and np.allclose(Q_inc, Q_vec, rtol=0, atol=1e-13)
    # Newton's third law, summed: internal forces have zero resultant (ORACLES A7)
    assert np.abs(Q_vec.sum(axis=0)).max() < 1e-13 * (np.abs(Q_vec).max() + 1)



@given(seed=st.integers(0, 10**6), dim=st.sampled_from([2, 3]))
def test_dense_incidence_springs_equal_the_gather_scatter_path(seed, dim):
    # ORACLES A7, A16: a few springs (S·N ≤ DENSE_MAX) gather d = B x, ḋ = B v and scatter Q += Bᵀ f with the
    # dense signed incidence matrix; the same forces as np.take and bincount (the path of larger networks):
    # d exact, each Q_i the same terms summed in another order (measured ≤ 1 ulp; bound 8 ulp of max |Q|)
    ps, springs = random_network(seed, N=7, dim=dim)
    Scene(ps, [springs])
    assert springs._B is not None
    y = ps.state()
    Q_dense = ps.zero_forces()
    springs.apply(0.0, y, Q_dense)
    f_dense = springs.spring_forces(y)
    springs._B = springs._Bt = None
    Q_sparse = ps.zero_forces()
    springs.apply(0.0, y, Q_sparse)
    np.testing.assert_array_equal(f_dense, springs.spring_forces(y))
    assert np.abs(Q_dense - Q_sparse).max() <= 8 * np.finfo(float).eps * np.abs(Q_sparse).max()


def test_effects_add_into_strided_force_views():
    # the protocol says "add into Q in place": a non-contiguous Q view must receive the same forces
    ps, springs = random_network(11, N=6, dim=3)
    drag = Drag(np.linspace(0.1, 0.6, 6))
    Scene(ps, [springs, drag])
    y = ps.state()
    Q = ps.zero_forces()
    big = np.zeros((6, 6))
    view = big[:, ::2]
    for e in (springs, drag):
        e.apply(0.0, y, Q)
        e.apply(0.0, y, view)
    assert np.array_equal(view, Q) and np.abs(Q).max() > 0


def test_spring_force_direction_and_energy():
    # a stretched spring pulls its ends together with |f| = k (l - r); V = 1/2 k (l - r)^2
    ps = ParticleSystem([[0.0, 0.0, 0.0], [0.0, 3.0, 4.0]])
    springs = DampedSprings([[0, 1]], stiffness=2.0, rest_length=4.0)
    Q = Scene(ps, [springs]).forces(0.0, ps.state())
    assert np.allclose(Q[0], 2.0 * (5.0 - 4.0) * np.array([0, 3, 4]) / 5.0)
    assert np.allclose(Q[1], -Q[0])
    assert springs.potential_energy(ps.state()) == pytest.approx(0.5 * 2.0 * 1.0)
    # default rest length = initial length: a net at rest feels no force
    springs0 = DampedSprings([[0, 1]], stiffness=2.0)
    assert np.abs(Scene(ps, [springs0]).forces(0.0, ps.state())).max() < 1e-15


def test_spring_damping_only_damps_stretching():
    # k_d acts on the length rate l' = (v_a - v_b).d only: a rigid translation or rotation is not damped
    ps = ParticleSystem([[0.0, 0.0], [1.0, 0.0]], [[0.3, 1.0], [0.3, -1.0]])
    springs = DampedSprings([[0, 1]], stiffness=0.0, damping=5.0)
    assert np.abs(Scene(ps, [springs]).forces(0.0, ps.state())).max() < 1e-15
    ps2 = ParticleSystem([[0.0, 0.0], [1.0, 0.0]], [[-1.0, 0.0], [1.0, 0.0]])  # separating at l' = 2
    Q = Scene(ps2, [DampedSprings([[0, 1]], stiffness=0.0, damping=5.0)]).forces(0.0, ps2.state())
    assert np.allclose(Q, [[10.0, 0.0], [-10.0, 0.0]])


# -- Jacobians --------------------------------------------------------------------------------------

@pytest.mark.parametrize("dim", [2, 3])
def test_spring_jacobians_match_finite_differences(dim):
    # the analytic blocks -k[(1 - r/l)(I - dd^T) + dd^T] (+ damping terms) equal centred differences
    ps, springs = random_network(7 + dim, N=6, dim=dim)
    scene = Scene(ps, [springs])
    y = ps.state()
    s = ps.split
    fj = springs.jacobian(0.0, y)

    def Q_of_x(xf):
        yy = y.copy()
        yy[:s] = xf
        return scene.forces(0.0, yy).ravel()

    def Q_of_v(vf):
        yy = y.copy()
        yy[s:] = vf
        return scene.forces(0.0, yy).ravel()

    # measured max abs difference 3.2e-9 (centred-difference truncation at eps = 1e-6); bounds rtol 1e-6,
    # atol 1e-7 (entries are O(10))
    check_grad(Q_of_x, y[:s], fj.dQdx, rtol=1e-6, atol=1e-7)
    check_grad(Q_of_v, y[s:], fj.dQdv, rtol=1e-6, atol=1e-7)
    # symmetric stiffness part when the spring is at rest (no damping terms): K = K^T
    undamped = DampedSprings(springs.pairs, stiffness=springs.ks, damping=0.0, rest_length=springs.rest)
    Scene(ps, [undamped])
    K = undamped.jacobian(0.0, y).dQdx
    assert abs(K - K.T).max() < 1e-12 and undamped.jacobian(0.0, y).dQdv is None


def test_scene_jacobian_matches_finite_differences():
    # full state Jacobian [[0, I], [W dQ/dx, W dQ/dv]] of gravity + drag + springs + anchors vs FD
    ps, springs = random_network(3, N=6, dim=3)
    scene = Scene(ps, [Gravity(), Drag(np.linspace(0.1, 0.6, 6)), springs,
                       AnchorSprings([0, 2], stiffness=50.0, damping=0.3)])
    y = ps.state()
    J = scene.jac(0.0, y)
    assert J.format == "csr" and J.shape == (2 * ps.split, 2 * ps.split)
    check_grad(lambda yy: scene.rhs(0.0, yy), y, J, rtol=1e-6, atol=1e-7)  # measured max abs diff 3.7e-9


def test_stiff_net_implicit_euler_bounded_explicit_diverges():
    # a stiff hanging net (k_s = 1e4, m = 0.01) at h = 0.01, h omega_max = 35: explicit Euler blows up
    # (SimulationDiverged; ORACLES A2: never stable undamped), implicit Euler with the sparse Jacobian
    # stays bounded and only dissipates (ORACLES A1: energy factor 1/(1 + (h omega)^2) per mode)
    net = hanging_net(6, 6, spacing=0.1, mass=0.01, stiffness=1e4)
    h = 1e-2
    assert h * net.params["omega_max_bound"] > 10  # far beyond every explicit stability limit
    with pytest.raises(SimulationDiverged, match="not finite"):
        net.scene().simulate(2.0, h, "euler")
    res = net.scene().simulate(2.0, h, "implicit_euler")
    assert res.njev == 200  # the analytic sparse Jacobian was used (one per step), not finite differences
    x = res.y[: net.system.split].reshape(net.system.N, 3, -1)
    # every particle stays within 1 mm of its rest position (measured 0.26 mm: sag 0.22 mm + overshoot)
    assert np.abs(x - net.system.x0[:, :, None]).max() < 1e-3
    E = res.diagnostics["energy"]
    assert E.max() <= E[0] + 1e-12 * abs(E[0])  # measured: never above E0


def test_shearless_net_implicit_euler_newton_refreshes_jacobian():
    # without shear springs the net is a nearly singular mechanism: simplified Newton with J frozen at the
    # step's start contracts by only ~1/3 per iteration and used to stop at 3e-12 > 1e-12 after 20 iterations
    # (t = 0.13). Re-evaluating J when contraction is slow must carry the run through the whole 2 s.
    net = hanging_net(shear=False)
    res = net.scene().simulate(2.0, 0.01, "implicit_euler")
    assert res.success and np.all(np.isfinite(res.y))
    assert 200 < res.njev < 600  # refreshed on some steps (measured 397 evaluations for 200 steps)
    E = res.diagnostics["energy"]
    assert E.max() <= E[0] + 1e-12 * abs(E[0])  # implicit Euler only dissipates


# -- diagnostics ------------------------------------------------------------------------------------

def test_diagnostics_values():
    # T = 1/2 sum m v^2, V_gravity = -sum m g.x, V_springs = 1/2 k (l - r)^2, P = sum m v, L = sum x x m v
    ps = ParticleSystem([[0.0, 1.0, 0.0], [2.0, 1.0, 0.0]], [[0.0, 0.0, 1.0], [0.0, 2.0, 0.0]], [1.0, 2.0])
    springs = DampedSprings([[0, 1]], stiffness=3.0, rest_length=1.0)
    scene = Scene(ps, [Gravity(), springs])
    d = scene.diagnostics(0.0, ps.state())
    assert d["kinetic"] == pytest.approx(0.5 * 1 * 1 + 0.5 * 2 * 4)
    assert d["V_gravity"] == pytest.approx(9.81 * (1 * 0.0 + 2 * 0.0))
    assert d["V_springs"] == pytest.approx(0.5 * 3.0 * 1.0)
    assert d["energy"] == pytest.approx(d["kinetic"] + d["V_gravity"] + d["V_springs"])
    assert np.allclose(d["momentum"], [0.0, 4.0, 1.0])
    assert np.allclose(d["angular_momentum"], np.cross([0, 1, 0], [0, 0, 1]) + np.cross([2, 1, 0], [0, 4, 0]))
    ps2 = ParticleSystem([[1.0, 0.0]], [[0.0, 3.0]], 2.0)
    assert np.allclose(ps2.angular_momentum(ps2.state()), [6.0])


def test_user_force_callable_and_effect_subclass():
    # a user force through the callable protocol and through an Effect subclass give the same motion:
    # an anchor spring F = -k x is a harmonic oscillator, x(t) = cos(omega t), omega = sqrt(k/m)
    k, m = 4.0, 1.0
    ps = ParticleSystem([[1.0, 0.0]], masses=m)
    uf = UserForce(lambda t, x, v: -k * x, name="anchor", potential=lambda x: 0.5 * k * float(np.sum(x * x)),
                   jacobian=lambda t, x, v: (-k * np.eye(2), None))

    class Anchor(Effect):
        name, phase = "anchor", "force"

        def bind(self, system):
            self.system = system

        def apply(self, t, y, Q):
            Q -= k * self.system.unpack(y)[0]

    a = Scene(ps, [uf]).simulate(1.0, 0.01, "rk4")
    b = Scene(ps, [Anchor()]).simulate(1.0, 0.01, "rk4")
    assert np.array_equal(a.y, b.y)
    assert abs(a.y[0, -1] - np.cos(np.sqrt(k / m))) < 1e-8  # RK4 at h omega = 0.02: measured 2.4e-9
    assert np.ptp(a.diagnostics["energy"]) < 1e-9  # the user potential is in the energy; measured 1.8e-10
    assert Scene(ps, [uf]).has_jacobian and not Scene(ps, [Anchor()]).has_jacobian


# -- bad inputs -----------------------------------------------------------------------------------

@pytest.mark.parametrize("kwargs, match", [
    (dict(positions=[[0.0, 0.0, 0.0, 0.0]]), r"positions must be a float array of shape \(N, 2\) .* or a float array "
                                             r"of shape \(N, 3\) .*got \[\[0.0, 0.0, 0.0, 0.0\]\]"),
    (dict(positions=np.zeros((0, 3))), r"positions must be .*not empty.*got array\(\[\], shape=\(0, 3\)"),
    (dict(positions=[[np.nan, 0.0]]), r"positions must be .*finite.*got \[\[nan, 0.0\]\]"),
    (dict(positions=[[0.0, 0.0]], velocities=[[np.inf, 0.0]]), r"velocities must be .*finite.*got \[\[inf, 0.0\]\]"),
    (dict(positions=[[0.0, 0.0]], velocities=[[0.0, 0.0, 0.0]]),
     r"velocities must have the shape of positions \(1, 2\), got \(1, 3\)"),
    (dict(positions=[[0.0, 0.0]], masses=0.0), r"masses must be .*entries > 0.*got 0.0"),
    (dict(positions=[[0.0, 0.0]], masses=np.nan), r"masses must be .*got nan"),
    (dict(positions=[[0.0, 0.0], [1.0, 1.0]], masses=[1.0, 2.0, 3.0]),
     r"masses must be a float array of shape \(N,\).*N = 2.*got \[1.0, 2.0, 3.0\]"),
])
def test_particle_system_rejects_bad_input(kwargs, match):
    with pytest.raises(ValueError, match=match):
        ParticleSystem(**kwargs)


@pytest.mark.parametrize("make, match", [
    (lambda: DampedSprings([0, 1]), r"pairs must be an integer array of shape \(S, 2\).*got \[0, 1\]; it has 1 axes"),
    (lambda: DampedSprings([[0.5, 1]]), r"pairs must be .*got \[\[0.5, 1\]\]; entries are not integers"),
    (lambda: DampedSprings([[0, 3]]), r"pairs must index particles in \[0, 3\), got \[0, 3\] at spring 0"),
    (lambda: DampedSprings([[0, 1], [2, 2]]), r"pairs must be .*no index twice in a row.*; row 1 is \[2, 2\]"),
    (lambda: DampedSprings([[0, 1]], stiffness=-1.0), r"stiffness must be .*entries >= 0.*got -1.0"),
    (lambda: DampedSprings([[0, 1]], damping=[1.0, 2.0]), r"damping must be a float array of shape \(S,\).*S = 1.*"
                                                          r"got \[1.0, 2.0\]"),
    (lambda: DampedSprings([[0, 1]], rest_length=np.nan), "rest_length must be .*got nan"),
    (lambda: Gravity([0.0, -9.81]), r"g must have shape \(3,\) for a 3-D system"),
    (lambda: Drag(-0.5), r"damping must be .*entries >= 0.*got -0.5"),
    (lambda: AnchorSprings([5]), r"indices must be distinct particle indices in \[0, 3\)"),
    (lambda: AnchorSprings([0], stiffness=0.0), "stiffness must be a finite number > 0, got 0.0"),
    (lambda: UserForce(lambda t, x, v: np.zeros(5)), r"must return an array broadcastable to \(3, 3\)"),
])
def test_effects_reject_bad_input(make, match):
    ps = ParticleSystem(np.eye(3))
    with pytest.raises(ValueError, match=match):
        Scene(ps, [make()])


def test_user_force_rejects_non_callable():
    with pytest.raises(ValueError, match="force must be a callable, got 3.0"):
        UserForce(3.0)


def test_models_reject_bad_input():
    with pytest.raises(ValueError, match="mass must be positive, got -1"):
        projectile_drag_model(mass=-1.0)
    with pytest.raises(ValueError, match="stiffness must be positive, got 0"):
        two_body_spring_model(stiffness=0.0)
    with pytest.raises(ValueError, match="nx and ny must be >= 2"):
        hanging_net(1, 5)


# -- figures (ch01) and bench smoke -----------------------------------------------------------------

def test_fig_projectile_drag(figure_data):
    # drag closed form and free fall: the simulated trajectories sit on the exact ones (RK4 at the quick
    # step h = 0.05: measured 7.2e-8 with drag, 7e-15 without (ORACLES A8)), and drag shortens the range
    d = figure_data("ch01_projectile_drag")
    assert d["max_err_drag"] < 5e-7 and d["max_err_nodrag"] < 1e-12
    # range without drag 2 vx vy / g (measured rel 1.1e-4: linear interpolation of the ground crossing)
    assert d["range_nodrag"] == pytest.approx(2 * 10.0 * 10.0 / 9.81, rel=1e-3)
    assert d["range_drag"] < 0.7 * d["range_nodrag"]
    assert d["v_terminal"] == pytest.approx(1.0 * 9.81 / 0.5)  # m g / k


def test_fig_spring_energy(figure_data):
    # spring-mass energy per method (ORACLES A1): Euler grows by (1 + (h w)^2) per step, symplectic
    # Euler stays bounded, RK4 loses a little
    d = figure_data("ch01_spring_energy")
    rel = {k: np.asarray(v) for k, v in d["rel_energy"].items()}
    y2 = d["h_omega"] ** 2
    n = len(rel["euler"]) - 1
    # exact one-step factors compounded over n steps (measured rel 3e-15, 1e-16, 2.5e-12; bound 1e-9)
    assert rel["euler"][-1] == pytest.approx((1 + y2) ** n - 1, rel=1e-9)
    assert rel["implicit_euler"][-1] == pytest.approx((1 + y2) ** -n - 1, rel=1e-9)
    assert rel["midpoint"][-1] == pytest.approx((1 + y2 * y2 / 4) ** n - 1, rel=1e-9)
    # symplectic Euler: bounded by the modified energy, |dE/E| <= h omega / 2 (measured 0.0526 at 0.1)
    assert np.abs(rel["symplectic_euler"]).max() < 0.6 * d["h_omega"]
    # Verlet conserves 1/2 v^2 + 1/2 w^2 (1 - y^2/4) x^2: |dE/E| <= (y^2/4)/(1 - y^2/4) (measured 0.0025)
    assert np.abs(rel["verlet"]).max() <= (y2 / 4) / (1 - y2 / 4) * (1 + 1e-9)
    # implicit midpoint conserves quadratic invariants exactly (measured 4.4e-15, bound 1e-13)
    assert np.abs(rel["implicit_midpoint"]).max() < 1e-13
    # RK4 loses energy by the factor 1 - y^6/72 + y^8/576 per step (measured rel 2.9e-9: the relative
    # change itself is 4e-6, so roundoff of E enters at 1e-16/4e-6; bound 1e-7)
    assert rel["rk4"][-1] == pytest.approx((1 - y2 ** 3 / 72 + y2 ** 4 / 576) ** n - 1, rel=1e-7)


def test_fig_hanging_net(figure_data):
    # stiff net at h omega_max = 35: explicit Euler diverged (ORACLES A2: never stable undamped), implicit
    # Euler stayed bounded, only dissipated (ORACLES A1) and settled on the static equilibrium K u = -Q
    d = figure_data("ch01_hanging_net")
    assert d["explicit_diverged"] and d["h_omega"] > 2
    assert d["omega_max"] <= d["omega_max_bound"]  # the Gershgorin bound of the model holds
    E = d["implicit_energy"]
    assert np.all(np.isfinite(E)) and np.max(E) <= E[0] + 1e-12 * abs(E[0])
    assert d["implicit_max_strain"] < 0.01  # measured 1.2e-3
    assert d["njev"] > 0  # the analytic sparse Jacobian was used
    # final sag vs the linear static solve: measured rel 5e-4 (6x6), bound 1e-2 (geometric nonlinearity)
    assert d["implicit_final_sag"] == pytest.approx(d["static_sag"], rel=1e-2)


def test_bench_smoke():
    # the benchmark runs in quick mode and every goal has a finite measurement (no timing asserts)
    from pbanim.bench.particles import run

    rep = run(quick=True)
    assert rep.goals and all(np.isfinite(g.measured) for g in rep.goals)
    assert all(r[-1] < 1e-12 for r in rep.tables[0].rows)  # scene step and numpy step agree


# -- issue 27: nothing silent (each input below was a silent wrong answer or a bare error) -----------------
def test_springs_far_apart_give_finite_forces_not_nan():
    # |d|² overflows for |d| > 1e154: c = k_s(l − r)/l was inf/inf = NaN; now from the scaled length, and the
    # readable loop (hypot) agrees: f = −k_s(1 − r/l) d along d (ORACLES A7: equal and opposite)
    ps = ParticleSystem([[1e200, 0.0], [-1e200, 0.0], [0.0, 3e199]])
    springs = DampedSprings([[0, 1], [1, 2]], stiffness=1.0, damping=0.5, rest_length=1.0)
    Scene(ps, [springs])
    y = ps.state()
    f = springs.spring_forces(y)
    assert np.isfinite(f).all()
    assert f[0, 0] == pytest.approx(-2e200, rel=1e-12) and f[0, 1] == 0.0
    Q = spring_forces_loop(ps.x0, ps.v0, springs.pairs, springs.ks, springs.kd, springs.rest)
    assert np.allclose(Q[0], f[0], rtol=1e-12, atol=0) and np.allclose(Q.sum(axis=0), 0.0, atol=1e188)
    assert springs.lengths(y)[0] == pytest.approx(2e200, rel=1e-15)         # was inf


def test_a_zero_length_spring_pushes_nothing_and_its_jacobian_is_the_linear_spring():
    # coincident ends, rest length 0: f = −k_s d is exactly 0 (no 0/0 direction), ∂f/∂x_a = −k_s I
    ps = ParticleSystem([[0.5, 0.5], [0.5, 0.5]], [[1.0, 0.0], [0.0, 0.0]])
    springs = DampedSprings([[0, 1]], stiffness=3.0, damping=1.0, rest_length=0.0)
    scene = Scene(ps, [springs])
    assert np.array_equal(scene.forces(0.0, ps.state()), np.zeros((2, 2)))
    K = springs.jacobian(0.0, ps.state()).dQdx.toarray()
    assert np.array_equal(K[:2, :2], -3.0 * np.eye(2)) and np.array_equal(K[:2, 2:], 3.0 * np.eye(2))
    assert np.array_equal(spring_forces_loop(ps.x0, ps.v0, np.array([[0, 1]]), np.array([3.0]),
                                             np.array([1.0]), np.array([0.0])), np.zeros((2, 2)))


def test_a_spring_from_a_particle_to_itself_is_refused():
    x = np.array([[0.0, 0.0], [1.0, 0.0]])
    with pytest.raises(InvalidInput, match=r"spring_forces_loop: pairs must be .*no index twice in a row.*row 0 is "
                                           r"\[1, 1\]"):
        spring_forces_loop(x, x, np.array([[1, 1]]), np.ones(1), np.ones(1), np.ones(1))   # was a silent zero
    with pytest.raises(InvalidInput, match=r"pairs must be .*an index is 2"):
        spring_forces_loop(x, x, np.array([[0, 2]]), np.ones(1), np.ones(1), np.ones(1))   # was an IndexError


@pytest.mark.parametrize("y, detail", [(lambda y: np.stack([y, y]), "a batch of states is not accepted here"),
                                       (lambda y: "abc", ""), (lambda y: y[:-1], r"shape \(7,\)")])
def test_one_state_functions_refuse_a_batch_or_a_string(y, detail):
    # kinetic_energy(batch) was a bare ValueError (reshape), unpack("abc") a bare AttributeError
    ps = ParticleSystem([[0.0, 0.0], [1.0, 0.0]], [[0.0, 1.0], [0.0, -1.0]])
    bad = y(ps.state())
    for f in (ps.kinetic_energy, ps.unpack, ps.linear_momentum, ps.angular_momentum, ps.center_of_mass):
        with pytest.raises(InvalidInput, match=rf"{f.__name__}: y must be a float array of shape \(8,\).*{detail}"):
            f(bad)


def test_forces_add_into_q_itself_so_a_list_is_refused():
    # Q += ... on a list converted by the check would change a copy: the force was silently lost
    ps = ParticleSystem([[0.0, 0.0], [1.0, 0.0]], masses=2.0)
    grav = Gravity([0.0, -10.0])
    Scene(ps, [grav])
    with pytest.raises(InvalidInput, match=r"Gravity.apply: Q must be a float64 numpy array of shape \(2, 2\).*"
                                           r"written in place"):
        grav.apply(0.0, ps.state(), [[0.0, 0.0], [0.0, 0.0]])
    Q = np.zeros((2, 2))
    grav.apply(0.0, ps.state(), Q)
    assert np.array_equal(Q, [[0.0, -20.0], [0.0, -20.0]])


def test_momenta_of_a_huge_state_overflow_to_inf_not_nan():
    # x × m v with |x|, |v| ~ 1e200: inf − inf was NaN; now ±inf (the true value is beyond double range) or
    # the exact value where it fits (the centre of mass of ±1e300 is 0)
    ps = ParticleSystem([[1e200, -1e200], [-1e200, 1e200]], [[1e200, 1e200], [-1e200, 1e200]])
    y = ps.state()
    L, P = ps.angular_momentum(y), ps.linear_momentum(y)
    assert not np.isnan(L).any() and not np.isnan(P).any()
    assert np.array_equal(P, [0.0, 2e200]) and np.array_equal(L, [np.inf])
    big = ParticleSystem([[1e300, 0.0], [-1e300, 0.0]], masses=[1e300, 1e300])
    assert np.array_equal(big.center_of_mass(big.state()), [0.0, 0.0])   # was NaN (inf/inf)
