"""pbanim.solve: long runs and the driver — Kepler invariants (A4), pendulum period (A5), adaptive error
control (A6), linear momentum (A7), free fall (A8), event location, batch mode, scipy delegation.
"""

import numpy as np
import pytest
from scipy.integrate import solve_ivp
from scipy.special import ellipk

import pbanim
from pbanim.models.ode import damped_oscillator, free_fall, harmonic_oscillator, kepler, pendulum
from pbanim.ode import METHODS
from pbanim.testing import assert_conserved, drift_ratio


# --------------------------------------------------------------------------------------------------
# A4: Kepler orbit, e = 0.6
# --------------------------------------------------------------------------------------------------
@pytest.mark.parametrize("name, steps_per_orbit, orbits", [
    ("symplectic_euler", 2000, 10), ("verlet", 1000, 10), ("implicit_midpoint", 400, 4)])
def test_kepler_symplectic_methods_keep_L_and_bounded_energy(name, steps_per_orbit, orbits):
    # ORACLES A4: symplectic methods keep L = x v_y − y v_x to roundoff (central force) and E bounded:
    # the late-window energy deviation is no larger than 1.5× the early window's
    kp = kepler(0.6)
    T = kp.period
    r = pbanim.solve(kp.rhs, (0, orbits * T), kp.y0, method=name, h=T / steps_per_orbit, split=2)
    L = kp.invariants["angular_momentum"](r.y)
    assert_conserved(L, rtol=1e-13, name="angular momentum")  # measured 1.1e-14 – 2.3e-14
    E = kp.invariants["energy"](r.y)
    assert drift_ratio(E) <= 1.5  # ORACLES A4 bound; measured 1.0000000 (all three)
    assert np.max(np.abs(E - kp.params["E"])) < 0.05 * abs(kp.params["E"])  # measured ≤ 8.7e-3: bounded


def test_kepler_rk4_secular_energy_drift_scales_as_h5():
    # ORACLES A4: RK4's energy, sampled at whole periods, drifts secularly ∝ h⁵ (ratio 32 per halving);
    # its angular momentum is not conserved to roundoff (not symplectic), unlike Verlet's
    kp = kepler(0.6)
    T, orbits = kp.period, 4
    drifts = []
    for n in (400, 800):
        r = pbanim.solve(kp.rhs, (0, orbits * T), kp.y0, method="rk4", h=T / n)
        E = kp.invariants["energy"](r.y[:, ::n])  # whole periods
        slope = np.polyfit(np.arange(orbits + 1), E - E[0], 1)[0]
        drifts.append(slope)
        assert np.all(np.diff(E) < 0)  # monotone secular loss of energy at whole periods
    ratio = drifts[0] / drifts[1]
    assert 20 < ratio < 48  # measured 31.97 (2⁵ = 32)
    L = kp.invariants["angular_momentum"](r.y)
    assert np.max(np.abs(L / L[0] - 1)) > 1e-10  # measured 2.9e-9: RK4 does not keep L


def test_kepler_explicit_euler_spirals_outward_and_lrl_invariant():
    # ORACLES A4: explicit Euler's energy grows at every periapsis (spirals out); dopri5 keeps E, L and the
    # Laplace–Runge–Lenz vector A = v × L − GM r̂ = (GM e, 0) to its tolerance
    kp = kepler(0.6)
    T = kp.period
    n = 2000
    r = pbanim.solve(kp.rhs, (0, 5 * T), kp.y0, method="euler", h=T / n)
    E = kp.invariants["energy"](r.y[:, ::n])
    assert np.all(np.diff(E) > 0)
    r = pbanim.solve(kp.rhs, (0, 5 * T), kp.y0, method="dopri5", rtol=1e-10, atol=1e-12)
    A = kp.invariants["lrl"](r.y)
    assert np.max(np.abs(A - np.array([[0.6], [0.0]]))) < 5e-9  # measured 6.7e-10
    assert np.max(np.abs(kp.invariants["energy"](r.y) - kp.params["E"])) < 3e-9  # measured 4.2e-10
    assert np.max(np.abs(kp.invariants["angular_momentum"](r.y) - kp.params["L"])) < 2e-9  # measured 2.3e-10


# --------------------------------------------------------------------------------------------------
# A5: large-amplitude pendulum period
# --------------------------------------------------------------------------------------------------
@pytest.mark.parametrize("deg", [170.0, 179.0])
def test_pendulum_period_elliptic_integral(deg):
    # ORACLES A5: T = 4√(L/g) K(m) with m = sin²(θ₀/2); θ crosses 0 downward at T/4 and upward at 3T/4
    th0 = np.radians(deg)
    p = pendulum(th0, length=1.0, g=9.81)
    T_exact = 4 * np.sqrt(1 / 9.81) * ellipk(np.sin(th0 / 2) ** 2)
    assert p.period == pytest.approx(T_exact, rel=1e-15)
    ev = lambda t, y: y[0]  # noqa: E731
    r = pbanim.solve(p.rhs, (0, 1.2 * T_exact), p.y0, method="dopri5", rtol=1e-11, atol=1e-12, events=ev)
    t1, t3 = r.t_events[0][:2]
    assert 4 * t1 == pytest.approx(T_exact, rel=2e-11)  # measured 1.5e-12 (170°), 3.2e-12 (179°)
    assert 2 * (t3 - t1) == pytest.approx(T_exact, rel=3e-8)  # measured 6.6e-11 (170°), 4.0e-9 (179°)
    wrong = 4 * np.sqrt(1 / 9.81) * ellipk(np.sin(th0 / 2))  # the classic bug: passing k instead of m
    assert abs(4 * t1 / wrong - 1) > 0.05


# --------------------------------------------------------------------------------------------------
# A6: adaptive stepping
# --------------------------------------------------------------------------------------------------
def _tol_units(kp, r, rtol, atol):
    ex = kp.exact(r.t)
    return np.sqrt(np.mean(((r.y - ex) / (atol + rtol * np.abs(ex))) ** 2))


def test_adaptive_error_in_tolerance_units():
    # ORACLES A6: RMS((y − y*)/(atol + rtol|y*|)) < 5 on a damped oscillator over 10 s (a problem whose
    # global error stays at the local tolerance), and a 10× tighter tolerance gives a smaller error.
    # (On Kepler the *global* error grows along the orbit, to 50–1600 tolerance units for scipy's RK45
    # and ours alike, which take the same steps.)
    m = damped_oscillator(1.0, 0.2)
    errs = []
    for rtol in (1e-5, 1e-6, 1e-7, 1e-8):
        r = pbanim.solve(m.rhs, (0, 10.0), m.y0, method="dopri5", rtol=rtol, atol=rtol)
        assert r.status == 0 and r.success
        units = _tol_units(m, r, rtol, rtol)
        assert units < 5  # ORACLES A6 bound; measured 0.81 – 0.87
        errs.append(np.max(np.abs(r.y - m.exact(r.t))))
    assert np.all(np.diff(errs) < 0)
    s = solve_ivp(m.rhs, (0, 10.0), m.y0, rtol=1e-6, atol=1e-6)
    assert r.nsteps > 0 and len(s.t) - 1 == pbanim.solve(m.rhs, (0, 10.0), m.y0, method="dopri5", rtol=1e-6,
                                                          atol=1e-6).nsteps  # same controller as scipy


def test_adaptive_step_size_underflow_fails_cleanly():
    # ORACLES A6: y' = y² from y(0) = 1 blows up at t = 1: the run ends with status −1 and a message (no hang)
    r = pbanim.solve(lambda t, y: y**2, (0.0, 2.0), [1.0], method="dopri5")
    assert r.status == -1 and not r.success
    assert "step size underflow" in r.message
    assert abs(r.t[-1] - 1.0) < 1e-5 and r.nsteps < 2000  # measured t = 1 + 2.9e-7, 213 steps
    r = pbanim.solve(lambda t, y: y**2, (0.0, 0.9), [1.0], method="dopri5", max_steps=5)
    assert r.status == -1 and "max_steps = 5" in r.message


def test_adaptive_nonfinite_fun_names_the_time():
    # fun undefined past t = 0.5 (sqrt of a negative number): every trial step across it is rejected, the step
    # underflows at the boundary and the message says fun went non-finite there (nothing returned as NaN)
    def fun(t, y):
        with np.errstate(invalid="ignore"):
            return np.sqrt(np.array([0.5 - t]))

    r = pbanim.solve(fun, (0.0, 1.0), [0.0], method="dopri5", rtol=1e-8, atol=1e-10)
    assert r.status == -1 and "non-finite" in r.message
    assert abs(r.t[-1] - 0.5) < 1e-6 and np.all(np.isfinite(r.y))
    # the exact solution y = (0.5^1.5 - (0.5 - t)^1.5) / 1.5 is reached up to the singular end point
    assert abs(r.y[0, -1] - 0.5**1.5 / 1.5) < 1e-6
    # a blow-up with finite stages keeps the stiff/blow-up hint instead
    r = pbanim.solve(lambda t, y: y**2, (0.0, 2.0), [1.0], method="dopri5")
    assert "non-finite" not in r.message and "blow up" in r.message


# --------------------------------------------------------------------------------------------------
# A7: linear momentum of an internal-force system
# --------------------------------------------------------------------------------------------------
M1, M2, KS, REST = 1.0, 3.0, 40.0, 1.0


def two_body_spring(t, y):
    """Two particles in 2-D joined by a spring: y = [x₁, x₂, v₁, v₂]; forces equal and opposite."""
    d = y[2:4] - y[0:2]
    ln = np.sqrt(d @ d)
    F = KS * (ln - REST) * d / ln  # force on particle 1 (towards 2 when stretched)
    return np.concatenate([y[4:], F / M1, -F / M2])


def two_body_spring_jac(t, y):
    """∂f/∂y of :func:`two_body_spring`: ∂F/∂d = k_s[(1 − L₀/l) I + (L₀/l) d̂d̂ᵀ] (equal and opposite blocks)."""
    d = y[2:4] - y[0:2]
    ln = np.sqrt(d @ d)
    u = d / ln
    K = KS * ((1 - REST / ln) * np.eye(2) + (REST / ln) * np.outer(u, u))
    J = np.zeros((8, 8))
    J[0:4, 4:8] = np.eye(4)
    J[4:6, 0:2], J[4:6, 2:4] = -K / M1, K / M1
    J[6:8, 0:2], J[6:8, 2:4] = K / M2, -K / M2
    return J


def test_two_body_spring_jacobian():
    # the analytic Jacobian used below matches centred finite differences
    from pbanim.testing import check_grad

    y = np.array([0.1, -0.2, 1.3, 0.2, 0.5, -0.2, -0.1, 0.4])
    check_grad(lambda z: two_body_spring(0.0, z), y, two_body_spring_jac(0.0, y))


@pytest.mark.parametrize("name", sorted(METHODS))
def test_internal_forces_conserve_linear_momentum(name):
    # ORACLES A7: every method preserves P = m₁v₁ + m₂v₂ of an internal-force system to roundoff (the
    # Jacobian-based methods with the analytic Jacobian, whose momentum rows cancel exactly)
    y0 = np.array([0.0, 0.0, 1.3, 0.2, 0.5, -0.2, -0.1, 0.4])
    r = pbanim.solve(two_body_spring, (0, 2.0), y0, method=name, h=0.01, split=4, jac=two_body_spring_jac)
    P = M1 * r.y[4:6] + M2 * r.y[6:8]
    assert np.max(np.abs(P - P[:, :1])) < 2e-14  # measured ≤ 3.3e-15
    assert len(r.t) > 10


# --------------------------------------------------------------------------------------------------
# A8: constant force
# --------------------------------------------------------------------------------------------------
@pytest.mark.parametrize("name", ["midpoint", "rk4", "verlet", "implicit_midpoint", "dopri5"])
def test_free_fall_exact(name):
    # ORACLES A8: RK2 and higher, Verlet (and the implicit midpoint rule) are exact for free fall
    ff = free_fall(9.81, 10.0, 2.0)
    r = pbanim.solve(ff.rhs, (0, 1.0), ff.y0, method=name, h=0.1)
    assert np.max(np.abs(r.y - ff.exact(r.t))) < 2e-14  # measured ≤ 3.6e-15


@pytest.mark.parametrize("name, sign", [("euler", 1), ("symplectic_euler", -1), ("implicit_euler", -1)])
def test_first_order_free_fall_error_is_half_g_h_t(name, sign):
    # ORACLES A8: explicit Euler's position error is exactly +½ g h t (symplectic/implicit Euler: −½ g h t)
    g, h = 9.81, 0.05
    ff = free_fall(g, 10.0, 2.0)
    r = pbanim.solve(ff.rhs, (0, 1.0), ff.y0, method=name, h=h)
    err = r.y[0] - ff.exact(r.t)[0]
    np.testing.assert_allclose(err, sign * 0.5 * g * h * r.t, rtol=1e-12, atol=1e-14)


# --------------------------------------------------------------------------------------------------
# events
# --------------------------------------------------------------------------------------------------
def ground(t, y):
    return y[0]


ground.terminal = True
ground.direction = -1


@pytest.mark.parametrize("name", ["rk4", "verlet", "dopri5", "implicit_midpoint"])
def test_event_ground_crossing_time(name):
    # a particle falling from 10 m hits the ground at t = √(2·10/g); methods exact on free fall locate it
    # to 1e-12; the run ends at the event (status 1) with the event state as its last point
    ff = free_fall(9.81, 10.0, 0.0)
    r = pbanim.solve(ff.rhs, (0, 5.0), ff.y0, method=name, h=0.01, events=ground)
    t_hit = np.sqrt(2 * 10.0 / 9.81)
    assert r.status == 1 and r.message == "A termination event occurred."
    assert abs(r.t_events[0][0] - t_hit) < 1e-12  # required 1e-12; measured ≤ 1.1e-15
    assert r.t[-1] == r.t_events[0][0] and abs(r.y[0, -1]) < 1e-12
    assert r.y_events[0][0][1] == pytest.approx(-9.81 * t_hit, rel=1e-13)


def test_non_terminal_events_direction_and_count():
    # x = cos t crosses 0 downward at π/2, 5π/2 and upward at 3π/2: direction filters, non-terminal events
    # record every crossing, terminal = 2 stops at the second one
    osc = harmonic_oscillator(1.0)
    both = lambda t, y: y[0]  # noqa: E731
    down = lambda t, y: y[0]  # noqa: E731
    down.direction = -1
    up2 = lambda t, y: y[0]  # noqa: E731
    up2.direction, up2.terminal = 1, 2
    r = pbanim.solve(osc.rhs, (0, 8.0), osc.y0, method="rk4", h=0.01, events=[both, down])
    np.testing.assert_allclose(r.t_events[0], [np.pi / 2, 3 * np.pi / 2, 5 * np.pi / 2], atol=5e-9)  # 6.5e-10
    np.testing.assert_allclose(r.t_events[1], [np.pi / 2, 5 * np.pi / 2], atol=5e-9)  # RK4 error ~ h⁴
    assert r.status == 0 and r.t[-1] == 8.0
    r = pbanim.solve(osc.rhs, (0, 20.0), osc.y0, method="dopri5", rtol=1e-10, atol=1e-12, events=up2)
    assert r.status == 1 and r.t[-1] == pytest.approx(7 * np.pi / 2, abs=1e-8)


def test_t_eval_points_on_the_method_trajectory():
    # t_eval: partial steps of the method land on the requested times; exact for RK4 on free fall
    ff = free_fall(9.81, 10.0, 1.0)
    te = np.linspace(0, 1.0, 7)
    for name in ("rk4", "dopri5"):
        r = pbanim.solve(ff.rhs, (0, 1.0), ff.y0, method=name, h=0.1, t_eval=te)
        np.testing.assert_array_equal(r.t, te)
        assert np.max(np.abs(r.y - ff.exact(te))) < 1e-13
    # with a terminal event, t_eval output stops before the event (as in scipy); the event state is kept
    ff = free_fall(9.81, 10.0, 0.0)
    r = pbanim.solve(ff.rhs, (0, 5.0), ff.y0, method="rk4", h=0.01, t_eval=np.linspace(0, 5, 11), events=ground)
    np.testing.assert_array_equal(r.t, [0.0, 0.5, 1.0])
    assert r.status == 1 and abs(r.y_events[0][0, 0]) < 1e-12


def test_backward_integration():
    # t_span may run backwards (as in solve_ivp): the oscillator returns from t = π to its start state
    osc = harmonic_oscillator(1.0)
    yT = osc.exact([np.pi])[:, 0]
    for name, tol in (("rk4", 1e-9), ("dopri5", 3e-10), ("verlet", 1e-4)):
        r = pbanim.solve(osc.rhs, (np.pi, 0.0), yT, method=name, h=0.01, rtol=1e-10, atol=1e-12)
        assert r.t[-1] == 0.0 and np.all(np.diff(r.t) < 0)
        assert np.max(np.abs(r.y[:, -1] - osc.y0)) < tol  # measured 2.6e-10 (rk4), 3.8e-11 (dopri5), 1.3e-5 (verlet)


# --------------------------------------------------------------------------------------------------
# batch mode and scipy delegation
# --------------------------------------------------------------------------------------------------
def test_batch_equals_loop():
    # K pendulums at once: fun sees (K, n) arrays, y has shape (K, n, n_points); fixed-step batch equals
    # the per-trajectory runs to roundoff, adaptive batch (one shared step) agrees within the tolerance
    th = np.radians([10.0, 60.0, 120.0, 170.0])
    p = pendulum(th)
    shapes = []

    def f(t, y):
        shapes.append(y.shape)
        return p.rhs(t, y)

    rb = pbanim.solve(f, (0, 2.0), p.y0, method="rk4", h=0.01)
    assert rb.y.shape == (4, 2, len(rb.t)) and set(shapes) == {(4, 2)}
    for name, tol in (("rk4", 1e-14), ("verlet", 1e-14), ("dopri5", 1e-8)):
        rb = pbanim.solve(p.rhs, (0, 2.0), p.y0, method=name, h=0.01, rtol=1e-9, atol=1e-11)
        for k in range(4):
            rk = pbanim.solve(p.rhs, (0, 2.0), p.y0[k], method=name, h=0.01, rtol=1e-9, atol=1e-11)
            assert np.max(np.abs(rb.y[k, :, -1] - rk.y[:, -1])) <= tol  # measured 0 (fixed), 2.6e-9 (dopri5)
    rb = pbanim.solve(p.rhs, (0, 1.0), p.y0, method="implicit_euler", h=0.01)  # batched Newton, FD Jacobian
    r3 = pbanim.solve(p.rhs, (0, 1.0), p.y0[3], method="implicit_euler", h=0.01)
    assert np.max(np.abs(rb.y[3] - r3.y)) < 1e-13  # measured 4.4e-16


def test_scipy_delegation_and_agreement():
    # method="scipy:RK45" is solve_ivp itself; pbanim's dopri5 (same Dormand–Prince pair) agrees within tol
    kp = kepler(0.5)
    te = np.linspace(0, kp.period, 5)
    r = pbanim.solve(kp.rhs, (0, kp.period), kp.y0, method="scipy:RK45", rtol=1e-9, atol=1e-12, t_eval=te)
    s = solve_ivp(kp.rhs, (0, kp.period), kp.y0, method="RK45", rtol=1e-9, atol=1e-12, t_eval=te)
    np.testing.assert_array_equal(r.y, s.y)
    assert r.method == "scipy:RK45" and r.nfev == s.nfev and r.success
    ours = pbanim.solve(kp.rhs, (0, kp.period), kp.y0, method="dopri5", rtol=1e-9, atol=1e-12, t_eval=te)
    assert np.max(np.abs(ours.y - r.y)) < 3e-9  # measured 4.5e-10 (same pair, same controller)
    rr = pbanim.solve(kp.rhs, (0, 1.0), kp.y0, method="scipy:Radau", jac=lambda t, y: np.eye(4))
    assert rr.success and rr.njev >= 1


def test_bench_ode_smoke():
    # `pbanim bench ode --quick` on one problem runs and every goal has a finite measurement (no timing
    # asserts); the full family also sweeps Pleiades, the stiff spring, Van der Pol and Robertson
    from pbanim.bench import format_report
    from pbanim.bench.ode import PROBLEMS, run

    assert list(PROBLEMS) == ["kepler", "pleiades", "stiff_spring", "van_der_pol", "robertson"]
    rep = run(quick=True, problems=["kepler"])
    assert [g.id for g in rep.goals] == ["ode-kepler-vs-solve_ivp", "ode-kepler-vs-odeint", "ode-rk4-overhead",
                                         "ode-batch-vs-loop"]
    assert all(np.isfinite(g.measured) for g in rep.goals)
    text = format_report(rep)
    assert "goal ode-rk4-overhead:" in text and "goal ode-kepler-vs-odeint:" in text


def test_event_that_never_fires_gives_empty_arrays():
    # an event that never crosses zero: scipy's shapes, t_events[0] of shape (0,), y_events[0] of shape (0, n)
    from pbanim import solve

    res = solve(lambda t, y: -y, (0.0, 1.0), [1.0, 2.0], method="rk4", h=0.1, events=[lambda t, y: y[0] + 5.0])
    assert res.status == 0
    assert res.t_events[0].shape == (0,) and res.y_events[0].shape == (0, 2)
