"""Runge–Kutta–Nyström pairs (ORACLES A15): order conditions, the lean loop against the readable step,
dense output, and the problems they refuse."""

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

import pbanim
from pbanim.errors import InvalidInput
from pbanim.models.ode import damped_oscillator, free_fall, harmonic_oscillator, kepler
from pbanim.ode import METHODS
from pbanim.ode.nystrom import hermite5, nystrom_step
from pbanim.ode.nystrom_tables import NYSTROM

NAMES = sorted(NYSTROM)
EPS = np.finfo(float).eps


@pytest.mark.parametrize("name", NAMES)
def test_quadrature_and_row_conditions(name):
    # ORACLES A15: velocity weights integrate c^(q-1) exactly for q <= p, position weights 1/(q(q+1)) for q < p,
    # rows of A sum to c²/2, b̄ = b(1 - c); the next moment fails (the order is not higher than declared)
    p = NYSTROM[name]
    c, o = p.C, p.order
    for q in range(1, o + 1):
        assert abs(p.BP @ c ** (q - 1) - 1 / q) < 1e-15       # measured ≤ 1.7e-16
    for q in range(1, o):
        assert abs(p.B @ c ** (q - 1) - 1 / (q * (q + 1))) < 1e-15
    assert abs(p.BP @ c ** o - 1 / (o + 1)) > 1e-9              # measured 4.4e-4, 1.2e-6, 1.8e-8
    np.testing.assert_allclose(p.A.sum(axis=1), c ** 2 / 2, atol=1e-14)
    np.testing.assert_allclose(p.B, p.BP * (1 - c), atol=1e-15)
    assert abs(p.EB.sum()) < 1e-14 and abs(p.EBP.sum()) < 1e-14  # both members of a pair integrate constants


@pytest.mark.parametrize("name", NAMES)
def test_local_error_order(name):
    # ORACLES A15: one step from periapsis of a Kepler orbit has local error O(h^(p+1)) (asymptotic slope)
    kp = kepler(0.3)
    H = {"dprkn6": 0.5, "dprkn8": 0.8, "dprkn12": 0.8}[name]
    hs = H / 2.0 ** np.arange(3)
    errs = [np.max(np.abs(nystrom_step(name, kp.rhs, 0.0, kp.y0, h) - kp.exact(h)[:, 0])) for h in hs]
    slope = np.log2(errs[1] / errs[2])
    assert slope > NYSTROM[name].order + 0.5       # measured 7.10, 9.54, 13.17 (p + 1 = 7, 9, 13)


@pytest.mark.parametrize("name", NAMES)
def test_free_fall_exact(name):
    # ORACLES A8: constant acceleration is integrated exactly by every Nyström pair, fixed and adaptive
    ff = free_fall(9.81, 10.0, 2.0)
    r = pbanim.solve(ff.rhs, (0, 1.3), ff.y0, method=name, rtol=1e-3, atol=1e-3)
    assert r.success
    assert np.max(np.abs(r.y - ff.exact(r.t))) < 64 * EPS * 10     # measured ≤ 3.6e-15


@pytest.mark.parametrize("name", NAMES)
def test_adaptive_loop_replays_the_readable_step(name):
    # ORACLES A13 for the Nyström loop: every accepted step equals nystrom_step with the same h
    kp = kepler(0.6)
    r = pbanim.solve(kp.rhs, (0, 7.0), kp.y0, method=name, rtol=1e-8, atol=1e-10)
    assert r.success and len(r.t) > 10
    for k in range(len(r.t) - 1):
        y1 = nystrom_step(name, kp.rhs, r.t[k], r.y[:, k], r.t[k + 1] - r.t[k])
        assert np.max(np.abs(y1 - r.y[:, k + 1])) <= 32 * EPS * (1 + np.max(np.abs(y1)))   # measured ≤ 4ε


@pytest.mark.parametrize("name", NAMES)
def test_kepler_error_follows_the_tolerance(name):
    # ORACLES A4: 3 periods of e = 0.5; the global error shrinks with rtol and stays within 1e3·rtol
    kp = kepler(0.5)
    T = 3 * kp.period
    errs = []
    for rtol in (1e-6, 1e-9):
        r = pbanim.solve(kp.rhs, (0, T), kp.y0, method=name, rtol=rtol, atol=rtol * 1e-2)
        errs.append(np.max(np.abs(r.y[:, -1] - kp.exact(T)[:, 0])))
        assert errs[-1] < 1e3 * rtol                # measured ≤ 1.1e2·rtol (dprkn6 at 1e-9)
    assert errs[1] < errs[0] / 30


def test_hermite_interpolant_exact_on_quintics():
    # ORACLES A15: the quintic through (q, v, g) at both ends reproduces any quintic motion exactly
    rng = np.random.default_rng(3)
    a = rng.normal(size=(6, 2))                     # q(t) = Σ aₖ tᵏ, two components
    q = lambda t: sum(a[k] * t ** k for k in range(6))                          # noqa: E731
    v = lambda t: sum(k * a[k] * t ** (k - 1) for k in range(1, 6))             # noqa: E731
    g = lambda t: sum(k * (k - 1) * a[k] * t ** (k - 2) for k in range(2, 6))   # noqa: E731
    t0, h = 0.3, 0.7
    for th in (0.0, 0.25, 0.6, 1.0):
        qq, vv = hermite5(q(t0), v(t0), g(t0), q(t0 + h), v(t0 + h), g(t0 + h), h, th)
        np.testing.assert_allclose(qq, q(t0 + th * h), atol=1e-13)
        np.testing.assert_allclose(vv, v(t0 + th * h), atol=1e-12)


@pytest.mark.parametrize("name", NAMES)
def test_t_eval_and_events_use_the_interpolant(name):
    # ORACLES A10 for the Nyström pairs: t_eval does not change the steps; outputs lie on the orbit within
    # the interpolant's error; the event y = 0 (apoapsis, half a period) is found on it
    kp = kepler(0.5)
    T = 2 * kp.period
    plain = pbanim.solve(kp.rhs, (0, T), kp.y0, method=name, rtol=1e-9, atol=1e-11)
    te = np.linspace(0, T, 37)

    def crossing(t, y):
        return y[1]

    crossing.direction = -1.0
    r = pbanim.solve(kp.rhs, (0, T), kp.y0, method=name, rtol=1e-9, atol=1e-11, t_eval=te, events=crossing)
    assert r.nfev == plain.nfev and r.success
    np.testing.assert_allclose(r.y[:, -1], plain.y[:, -1], rtol=0, atol=1e-14)
    # the quintic's O(h⁶) error grows with the pair's step: measured 1.8e-9, 1.2e-7, 8.6e-5 (dprkn12 takes
    # 16 steps per period at this tolerance); event times 4.4e-11, 9.1e-11, 1.9e-6
    bound, t_bound = {"dprkn6": (1e-8, 1e-9), "dprkn8": (3e-6, 1e-9), "dprkn12": (1e-3, 2e-5)}[name]
    assert np.max(np.abs(r.y - kp.exact(te))) < bound
    np.testing.assert_allclose(r.t_events[0], [0.5 * kp.period, 1.5 * kp.period], atol=t_bound)


@pytest.mark.parametrize("name", NAMES)
def test_refuses_what_is_not_q_ddot_equals_g_of_q(name):
    with pytest.raises(InvalidInput, match="does not depend on the velocity"):
        pbanim.solve(damped_oscillator(1.0, 0.3).rhs, (0, 1), [1.0, 0.0], method=name)
    with pytest.raises(InvalidInput, match=r"\[:split\] = v"):
        pbanim.solve(lambda t, y: -y, (0, 1), [1.0, 2.0], method=name)
    with pytest.raises(InvalidInput, match="as many velocities as positions"):
        pbanim.solve(lambda t, y: -y, (0, 1), [1.0, 2.0, 3.0], method=name)
    with pytest.raises(InvalidInput, match="one trajectory"):
        pbanim.solve(harmonic_oscillator(1.0).rhs, (0, 1), np.ones((3, 2)), method=name)
    # fixed steps (a scene's simulate, Method.step) check the form at every step
    with pytest.raises(InvalidInput, match="does not depend on the velocity"):
        METHODS[name].step(damped_oscillator(1.0, 0.3).rhs, 0.0, np.array([1.0, 0.5]), 0.1)


def test_a_damped_particle_scene_is_refused_with_fixed_steps():
    # a scene's fixed-step simulate goes through Method.step: a drag force would be answered wrong, so it is refused
    from pbanim.particles import Drag, Gravity, ParticleSystem
    from pbanim.scene import Scene

    ps = ParticleSystem([[0.0, 0.0, 1.0]], [[1.0, 0.0, 0.0]], masses=1.0)
    with pytest.raises(InvalidInput, match="dprkn8"):
        Scene(ps, [Gravity(), Drag(0.5)]).simulate(0.1, 0.01, method="dprkn8")
    res = Scene(ps, [Gravity()]).simulate(0.1, 0.01, method="dprkn8")       # ORACLES A8: free fall exact
    assert abs(res.y[2, -1] - (1.0 - 0.5 * 9.81 * 0.1 ** 2)) < 1e-14 and abs(res.y[0, -1] - 0.1) < 1e-14


@settings(max_examples=25, deadline=None)
@given(omega=st.floats(0.2, 20.0), x0=st.floats(-3.0, 3.0), v0=st.floats(-3.0, 3.0),
       k=st.integers(4, 10), name=st.sampled_from(NAMES))
def test_oscillator_energy_and_error_bounded(omega, x0, v0, k, name):
    # ORACLES A1/A15: on ẍ = −ω²x over one period every pair stays within 1e3·rtol of the exact state
    osc = harmonic_oscillator(omega)
    y0 = np.array([x0, v0])
    T = 2 * np.pi / omega
    rtol = 10.0 ** -k
    r = pbanim.solve(osc.rhs, (0, T), y0, method=name, rtol=rtol, atol=rtol)
    assert r.success and np.all(np.isfinite(r.y))
    scale = 1 + abs(x0) + abs(v0) / omega + abs(v0) + omega * abs(x0)
    assert np.max(np.abs(r.y[:, -1] - y0)) < 1e3 * rtol * scale   # measured ≤ 40·rtol·scale


def test_registry_marks_the_nystrom_methods():
    assert {n for n, m in METHODS.items() if m.nystrom} == set(NAMES)
    assert all(METHODS[n].order == NYSTROM[n].order and METHODS[n].adaptive for n in NAMES)


@pytest.mark.parametrize("name", NAMES)
def test_fun_gets_fresh_arrays(name):
    # ORACLES A13: a fun that keeps every y it is handed sees each unchanged after the run (no buffer reuse)
    kp = kepler(0.5)
    kept, copies = [], []

    def f(t, y):
        kept.append(y)
        copies.append(np.array(y, copy=True))
        return kp.rhs(t, y)

    r = pbanim.solve(f, (0, 3.0), kp.y0, method=name, rtol=1e-8, atol=1e-10)
    assert r.success and len(kept) == r.nfev
    assert all(np.array_equal(a, b) for a, b in zip(kept, copies))
    assert len({id(a) for a in kept}) == len(kept)          # a new array object at every call


def test_predictive_controller_closed_forms():
    # Gustafsson's factor: the I factor when there is no history or the error holds steady at equal steps; a
    # growing error shortens the step by (err_{n-1}/err_n)^(1/k), clamped to [fac_min, fac_max]; no growth
    # right after a rejection
    from pbanim.ode.control import Controller

    c = Controller(11.0, 1 / 11, 0.0, fac_min=0.333, fac_max=6.0)
    for err in (1e-6, 0.01, 0.3, 1.0):
        assert c.predictive(err, None, 1.0, False) == pytest.approx(c.factor(err, 1.0, False), rel=1e-15)
        assert c.predictive(err, err, 1.0, False) == pytest.approx(c.factor(err, 1.0, False), rel=1e-15)
    grow = c.predictive(0.5, 0.5 / 2 ** 11, 1.0, False)          # error up 2^11 in one step: half the I factor
    assert grow == pytest.approx(0.5 * 0.9 * 0.5 ** (-1 / 11), rel=1e-14)
    assert c.predictive(1e-30, 1.0, 4.0, False) == 6.0 and c.predictive(1.0, 1e-30, 1.0, False) == 0.333
    assert c.predictive(1e-3, 1e-3, 2.0, True) == 1.0 and c.predictive(0.0, None, 1.0, False) == 6.0
