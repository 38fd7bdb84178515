"""High-order and stiff integrators: dense output (A10), L-stability (A11), stiff test problems and their
references (A12), the PI controller, bad input, property tests, and the work-precision interpolation.
"""

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st
from scipy.linalg import expm

import pbanim
from pbanim.derivatives import central_jacobian
from pbanim.errors import InvalidInput
from pbanim.models.ode import damped_oscillator, free_fall, kepler
from pbanim.ode import METHODS
from pbanim.ode.control import Controller
from pbanim.ode.high_order import (DOP853, DOP853_A_EXTRA, DOP853_C_EXTRA, VERN7, VERN7_A_EXTRA, VERN7_C_EXTRA,
                                   dop853_dense, dop853_eval, vern7_dense, vern7_eval)
from pbanim.ode.problems import pleiades, robertson, van_der_pol
from pbanim.testing import order_fit

NEW = ["dop853", "vern7", "rodas4", "radau5"]


# --------------------------------------------------------------------------------------------------
# A10: continuous extensions
# --------------------------------------------------------------------------------------------------
def _all_stages(tab, A_x, C_x, f, y, h):
    """Every stage of one step (the method's, then f(t + h, y₁) and the dense-output ones), written out."""
    s = tab.stages
    K = np.zeros((s + len(C_x), y.size))
    A = np.zeros((len(K), len(K)))
    A[:s, :s] = tab.A
    A[s:, :] = A_x
    c = np.concatenate([tab.C, C_x])
    for i in range(len(K)):
        K[i] = f(c[i] * h, y + h * A[i, :i] @ K[:i])
    return K, y + h * tab.B @ K[:s]


@pytest.mark.parametrize("tab, A_x, C_x, dense, evaluate", [
    (DOP853, DOP853_A_EXTRA, DOP853_C_EXTRA, dop853_dense, dop853_eval),
    (VERN7, VERN7_A_EXTRA, VERN7_C_EXTRA, vern7_dense, vern7_eval)], ids=["dop853", "vern7"])
def test_continuous_extension_order(tab, A_x, C_x, dense, evaluate):
    # ORACLES A10: inside one step, y(t + θh) from the continuous extension has local error O(h^(q+1)):
    # q = 7 for both pairs; it meets y₁ at θ = 1 exactly and y₀ at θ = 0
    kp = kepler(0.3)
    hs = 0.2 / 2.0 ** np.arange(3)
    errs = []
    for h in hs:
        K, y1 = _all_stages(tab, A_x, C_x, kp.rhs, kp.y0, h)
        F = dense(kp.y0, y1, K, h)
        # measured 0 (dop853), 3.2e-14 (vern7: 16-digit coefficients of size 10³ summed)
        assert np.max(np.abs(evaluate(kp.y0, F, 1.0) - y1)) < 1e-12
        assert np.max(np.abs(evaluate(kp.y0, F, 0.0) - kp.y0)) == 0.0
        errs.append(max(np.max(np.abs(evaluate(kp.y0, F, th) - kp.exact(th * h)[:, 0])) for th in (0.3, 0.7)))
    slope = order_fit(hs, errs, window=(1e-15, 1e-3)).order
    assert abs(slope - 8) < 0.5  # measured 7.89 (dop853), 8.23 (vern7)


@pytest.mark.parametrize("name", NEW)
def test_t_eval_does_not_shorten_steps(name):
    # ORACLES A10: output at 201 times costs no step: same steps, and the points lie on the solution
    # within the run's own error
    kp = kepler(0.3)
    te = np.linspace(0, kp.period, 201)
    a = pbanim.solve(kp.rhs, (0, kp.period), kp.y0, method=name, rtol=1e-8, atol=1e-10, t_eval=te)
    b = pbanim.solve(kp.rhs, (0, kp.period), kp.y0, method=name, rtol=1e-8, atol=1e-10)
    assert a.nsteps == b.nsteps and np.array_equal(a.t, te)
    err_steps = np.max(np.abs(b.y - kp.exact(b.t)))
    assert np.max(np.abs(a.y - kp.exact(te))) < 20 * err_steps  # measured 1.0× – 4.4× the error at the steps


@pytest.mark.parametrize("name", NEW)
def test_event_located_by_dense_output(name):
    # ORACLES A10 + A8: every continuous extension is exact on the quadratic free fall, so the ground
    # crossing is found at √(2·10/g) to roundoff, and the run ends there
    ff = free_fall(9.81, 10.0, 0.0)

    def ground(t, y):
        return y[0]

    ground.terminal, ground.direction = True, -1
    J = np.array([[0.0, 1.0], [0.0, 0.0]])   # exact J: forward differences would cost RODAS4 its exactness
    r = pbanim.solve(ff.rhs, (0, 5.0), ff.y0, method=name, rtol=1e-6, atol=1e-9, events=ground, jac=J)
    assert r.status == 1 and abs(r.t_events[0][0] - np.sqrt(2 * 10.0 / 9.81)) < 1e-12  # measured ≤ 2.0e-15
    assert abs(r.y[0, -1]) < 1e-11


# --------------------------------------------------------------------------------------------------
# A11: stability of the stiff methods
# --------------------------------------------------------------------------------------------------
@pytest.mark.parametrize("name", ["rodas4", "radau5"])
def test_l_stability(name):
    # ORACLES A11: A-stable (|R(z)| ≤ 1 on the left half-plane, sampled, including the imaginary axis) and
    # L-stable (R(z) → 0 as z → −∞): a k = 10¹² spring is damped in one step of any size
    from chapters.ch02_ode import stability_radius

    x, yv = np.meshgrid(np.linspace(-60.0, 0.0, 25), np.linspace(-60.0, 60.0, 25))
    rho = stability_radius(name, (x + 1j * yv).ravel())
    assert np.max(rho) <= 1 + 1e-9  # measured max 1.0 exactly (at z = 0)
    step = METHODS[name].step
    y = step(lambda t, y: -1e12 * y, 0.0, np.array([1.0]), 1.0, jac=lambda t, y: np.array([[-1e12]]))
    assert abs(y[0]) < 1e-9  # measured 8.8e-12 (rodas4), 3.0e-12 (radau5): R(z) ~ 1/z


# --------------------------------------------------------------------------------------------------
# A12: stiff problems against their references
# --------------------------------------------------------------------------------------------------
@pytest.mark.parametrize("make", [pleiades, van_der_pol, robertson])
def test_problem_jacobians(make):
    # ORACLES A12: the analytic Jacobians match centred finite differences (the one reference for every Jacobian)
    p = make()
    y = p.y0 + 0.01 * np.arange(p.y0.size) + 0.1
    J = central_jacobian(lambda z: p.rhs(0.0, z), y)
    assert np.max(np.abs(J - p.jac(0.0, y))) < 1e-8 * np.max(np.abs(J))  # measured ≤ 3.3e-10 relative (Pleiades)


@pytest.mark.parametrize("name", ["rodas4", "radau5"])
def test_robertson_mass_and_reference(name):
    # ORACLES A12: y₁ + y₂ + y₃ = 1 is a linear invariant: kept to roundoff with the exact J; the state
    # at t = 40 agrees with the reference within the tolerance (relative per component)
    p = robertson()
    r = pbanim.solve(p.rhs, (0, p.t_end), p.y0, method=name, rtol=1e-7, atol=1e-17, jac=p.jac)
    assert r.success
    assert np.max(np.abs(r.y.sum(axis=0) - 1.0)) < 1e-13  # measured ≤ 1.2e-15
    assert p.error(r.y[:, -1]) < 1e-6  # measured 9.5e-11 (radau5), 5.3e-9 (rodas4)


def test_van_der_pol_stiff_reference_and_reuse():
    # ORACLES A12: μ = 1000 over [0, 3000]: radau5 reaches the reference within its tolerance in a few hundred
    # steps (an explicit method needs ~10⁶ here), evaluating J on fewer steps than it takes and reusing
    # each factorization
    p = van_der_pol()
    r = pbanim.solve(p.rhs, (0, p.t_end), p.y0, method="radau5", rtol=1e-6, atol=1e-9, jac=p.jac)
    assert r.success and p.error(r.y[:, -1]) < 1e-4  # measured 9.6e-9
    assert r.nsteps < 4000  # measured 1275
    assert r.njev < 0.7 * r.nsteps and r.nlu < 2 * (r.nsteps + r.nrejected)  # measured 0.51, 1.63 per step
    q = pbanim.solve(p.rhs, (0, p.t_end), p.y0, method="rodas4", rtol=1e-6, atol=1e-9, jac=p.jac)
    assert q.success and p.error(q.y[:, -1]) < 1e-4  # measured 1.9e-7


def test_references_reproduced():
    # ORACLES A12: a fresh tight run reproduces the stored references (computed by several codes)
    for p, method, rtol, atol, bound in ((robertson(), "radau5", 1e-10, 1e-20, 1e-9),
                                         (pleiades(), "dop853", 1e-11, 1e-13, 1e-8)):
        r = pbanim.solve(p.rhs, (0, p.t_end), p.y0, method=method, rtol=rtol, atol=atol, jac=p.jac)
        assert p.error(r.y[:, -1]) < bound  # measured 3.9e-15 (Robertson), 2.8e-10 (Pleiades)


# --------------------------------------------------------------------------------------------------
# the PI controller and error control in tolerance units
# --------------------------------------------------------------------------------------------------
def test_pi_controller_formula():
    # ORACLES A6: the PI controller h·0.9·err^(−0.7/k)·err_prev^(0.4/k), clamped; I control when β = 0
    c = Controller.pi(8.0)
    assert c.factor(1.0, 1.0, False) == pytest.approx(0.9)
    assert c.factor(0.0, 1.0, False) == c.fac_max
    assert c.factor(1e-3, 1.0, False) == pytest.approx(0.9 * 1e-3 ** (-0.7 / 8))
    # the P part: a large previous error lets the step grow more, a small one less
    assert c.factor(0.5, 0.9, False) > c.factor(0.5, 0.1, False)
    # rejection: the I part only, never growth; NaN shrinks by fac_min
    assert c.factor(4.0, 0.1, True) == pytest.approx(0.9 * 4.0 ** (-1 / 8))
    assert c.factor(1e-6, 1.0, True) == 1.0 and c.factor(np.nan, 1.0, False) == c.fac_min
    assert Controller(5.0, 0.2).factor(0.3, 0.01, False) == pytest.approx(0.9 * 0.3 ** -0.2)  # β = 0: I control


@pytest.mark.parametrize("name", NEW)
def test_error_in_tolerance_units(name):
    # ORACLES A6 for the new methods: RMS((y − y*)/(atol + rtol|y*|)) stays of order one on a damped spring
    m = damped_oscillator(1.0, 0.2)
    for rtol in (1e-5, 1e-8):
        r = pbanim.solve(m.rhs, (0, 10.0), m.y0, method=name, rtol=rtol, atol=rtol, jac=m.jac)
        ex = m.exact(r.t)
        units = np.sqrt(np.mean(((r.y - ex) / (rtol + rtol * np.abs(ex))) ** 2))
        assert r.success and units < 5  # measured ≤ 0.17 (rodas4), ≤ 0.02 (the others)


# --------------------------------------------------------------------------------------------------
# bad input and properties
# --------------------------------------------------------------------------------------------------
@pytest.mark.parametrize("name", ["rodas4", "radau5"])
def test_stiff_methods_refuse_batch_and_bad_jacobians(name):
    # ORACLES G3: a named error that says which argument, what was expected and what came in
    f = damped_oscillator(3.0, 1.0).rhs
    with pytest.raises(InvalidInput, match=f"method '{name}' needs y0 of shape \\(n,\\); batch mode"):
        pbanim.solve(f, (0, 1.0), np.ones((3, 2)), method=name)
    with pytest.raises(InvalidInput, match="jac must return an \\(2, 2\\) matrix .* got shape \\(3, 3\\)"):
        pbanim.solve(f, (0, 1.0), [1.0, 0.0], method=name, jac=lambda t, y: np.eye(3))


def test_high_order_batch_equals_single():
    # ORACLES A6: the explicit pairs run batches (one step size for all, set by the worst trajectory), each
    # trajectory within its tolerance of its own single run
    m = damped_oscillator(2.0, 0.3)
    y0 = np.array([[1.0, 0.0], [0.5, -1.0]])
    for name in ("dop853", "vern7"):
        rb = pbanim.solve(m.rhs, (0, 3.0), y0, method=name, rtol=1e-9, atol=1e-12)
        rs = pbanim.solve(m.rhs, (0, 3.0), y0[1], method=name, rtol=1e-9, atol=1e-12)
        assert np.max(np.abs(rb.y[1, :, -1] - rs.y[:, -1])) < 1e-8  # measured 2.4e-12


@settings(max_examples=25, deadline=None)
@given(seed=st.integers(0, 10**6), name=st.sampled_from(NEW), log_rtol=st.floats(-9, -4),
       stiffness=st.sampled_from([1.0, 1e3, 1e6]))
def test_linear_systems_property(seed, name, log_rtol, stiffness):
    # ORACLES A6: on random stable linear systems y' = Ay (eigenvalues down to −stiffness) every new method ends at
    # status 0 with a finite state whose error is a bounded number of tolerance units; stiff ones are
    # left to the implicit methods (an explicit pair would need ~stiffness·T steps)
    if stiffness > 1.0 and name in ("dop853", "vern7"):
        stiffness = 1.0
    rng = np.random.default_rng(seed)
    Q, _ = np.linalg.qr(rng.normal(size=(3, 3)))
    A = Q @ np.diag(-np.array([0.5, 2.0, stiffness])) @ Q.T + 0.5 * (lambda S: S - S.T)(rng.normal(size=(3, 3)))
    y0 = rng.normal(size=3)
    rtol = 10.0 ** log_rtol
    r = pbanim.solve(lambda t, y: A @ y, (0, 2.0), y0, method=name, rtol=rtol, atol=rtol, jac=lambda t, y: A)
    assert r.status == 0 and np.all(np.isfinite(r.y))
    exact = expm(2.0 * A) @ y0
    assert np.max(np.abs(r.y[:, -1] - exact)) < 0.5 * rtol * (1 + np.max(np.abs(y0)))  # measured ≤ 0.073 (720 draws)


# --------------------------------------------------------------------------------------------------
# the benchmark's interpolation at equal error
# --------------------------------------------------------------------------------------------------
def test_time_at_error_interpolates_log_log():
    # ORACLES A6 (what the benchmark compares): at equal error the time is read off the log–log line through
    # the sweep points, exactly for points on a power law
    from pbanim.bench.ode import library_curve, time_at_error

    # a work-precision line error = 1e-2 · (t / 1e-3)^(−4) through three sweep points
    ts = np.array([1e-3, 1e-2, 1e-1])
    pts = [(None, 1e-2 * (t / 1e-3) ** -4, t, 100 * t / 1e-3) for t in ts]
    t, nf = time_at_error(pts, 1e-4)
    assert t == pytest.approx(1e-3 * 100 ** 0.25, rel=1e-12) and nf == pytest.approx(100 * 100 ** 0.25)
    assert time_at_error(pts, 1e-2)[0] == pytest.approx(1e-3)
    assert time_at_error(pts, 1e-20)[0] == np.inf                     # not reached
    other = [(None, 1e-12, 1e-3, 10)]                                 # reaches everything faster
    assert library_curve({"a": pts, "b": other}, ["a", "b"], 1e-4)[2] == "b"


@settings(max_examples=25, deadline=None)
@given(seed=st.integers(0, 10**6), h=st.floats(1e-3, 10.0))
def test_radau5_step_is_its_stability_function(seed, h):
    # ORACLES A11: on y' = Ay one Radau IIA(5) step is y₁ = Q(hA)⁻¹P(hA)y₀, the (2, 3) Padé approximant of
    # e^(hA): P(z) = 1 + 2z/5 + z²/20, Q(z) = 1 − 3z/5 + 3z²/20 − z³/60 (Hairer & Wanner II, §IV.5)
    rng = np.random.default_rng(seed)
    A = rng.normal(size=(3, 3)) - 2.0 * np.eye(3)
    y0 = rng.normal(size=3)
    Z, eye = h * A, np.eye(3)
    P = eye + 0.4 * Z + Z @ Z / 20
    Q = eye - 0.6 * Z + 3 * Z @ Z / 20 - Z @ Z @ Z / 60
    y1 = METHODS["radau5"].step(lambda t, y: A @ y, 0.0, y0, h, jac=lambda t, y: A)
    exact = np.linalg.solve(Q, P @ y0)
    # measured ≤ 1.7e-13 relative, ≤ 8.7e-16·κ(Q) (1200 draws); the bound scales with κ(Q), the Newton solves' floor
    assert np.max(np.abs(y1 - exact)) < 5e-15 * (1 + np.max(np.abs(exact))) * np.linalg.cond(Q)


def test_problem_arguments_are_checked():
    # ORACLES G3: the problems refuse a bad μ and a state of the wrong shape by name
    with pytest.raises(InvalidInput, match="mu must be positive"):
        van_der_pol(-1.0)
    with pytest.raises(InvalidInput, match="y must be a state of shape \\(3,\\) \\(Robertson\\), got \\(2,\\)"):
        robertson().error(np.zeros(2))
