"""Tests of pbanim.reduced (q = q(u), (JᵀMJ)ü = Jᵀ(Q − M J̇u̇)) and of the ch04 comparison with maximal
coordinates and the Lagrangian (ORACLES A5, B6, B7, G1), plus the ch04 figures' data and the bench smoke run.
"""

import numpy as np
import pytest
import sympy as sp

import pbanim
from pbanim.constraints import Constraints, Distance, solve_multipliers
from pbanim.errors import InvalidInput, NonFiniteResult, SingularChartError, StepLimitExceeded
from pbanim.models.reduced import (bead_x_chart, cart_pendulum, chain_rod_tensions,
                                   maximal_chain, n_link_chart, n_link_pendulum, pendulum_period,
                                   simple_pendulum, spherical_pendulum)
from pbanim.particles import Drag, Gravity, ParticleSystem
from pbanim.reduced import ChartGuard, ReducedSystem, check_chart, simulate_fixed
from pbanim.scene import Scene
from pbanim.testing import assert_order, drift_ratio


def _down_crossing(t, y):
    return y[0]


_down_crossing.direction = -1


# measured |T_sim/T − 1| at rtol 1e-10: 1.0e-12, 4.6e-11, 9.5e-10, 5.7e-8 — it grows towards the separatrix,
# where dT/dE → ∞ turns the run's small energy error into a period error; bounds ≈ 10× measured
@pytest.mark.parametrize("deg, bound", [(10, 1e-11), (90, 5e-10), (170, 1e-8), (179, 5e-7)])
def test_pendulum_period_matches_elliptic_integral(deg, bound):
    # ORACLES A5: T = 4√(L/g) K(m), m = sin²(θ₀/2); simulated in reduced coordinates (dopri5, rtol 1e-10),
    # period = time between two successive downward zero crossings of θ (located by the event finder)
    th0 = np.radians(deg)
    mod = simple_pendulum(theta0=th0, length=1.0)
    T = pendulum_period(th0, 1.0, 9.81)
    res = pbanim.solve(mod.reduced().rhs, (0.0, 1.3 * T), mod.state(), method="dopri5", rtol=1e-10,
                       atol=1e-12, events=[_down_crossing])
    te = res.t_events[0]
    assert te.size == 2
    assert abs((te[1] - te[0]) / T - 1) < bound
    assert abs(te[0] / T - 0.25) < 5e-11  # quarter period: measured 1.9e-13 … 5.1e-12


def test_numeric_chart_sympy_chart_and_lagrangian_agree():
    # one physics, three codes: hand-written J, J̇u̇ (student path), sympy-derived chart, Euler–Lagrange;
    # with gravity and drag (drag enters the Lagrangian side through JᵀQ only, so compare reduced ones)
    L = np.array([1.0, 0.6, 0.8, 1.1, 0.5])
    mod = n_link_pendulum(5, lengths=L, masses=[1.0, 2.0, 0.5, 1.5, 1.0])
    q, J, Jd = n_link_chart(L)
    num = ReducedSystem(q, J, Jd, mod.masses, 2, [Gravity(mod.g)], u0=mod.u0)
    sym, lag = mod.reduced(), mod.lagrangian()
    rng = np.random.default_rng(3)
    for _ in range(5):
        y = rng.uniform(-2, 2, 10)
        a, b, c = num.rhs(0.0, y), sym.rhs(0.0, y), lag.rhs(0.0, y)
        # measured 2.6e-14 (accelerations of O(10)), energies 2.8e-14; bound 2e-13
        np.testing.assert_allclose(a, b, atol=2e-13)
        np.testing.assert_allclose(b, c, atol=2e-13)
        assert abs(num.energy(y) - lag.energy(y)) < 2e-13
    dragged = ReducedSystem(q, J, Jd, mod.masses, 2, [Gravity(mod.g), Drag(0.5)], u0=mod.u0)
    y = rng.uniform(-1, 1, 10)
    # drag does negative power: d/dt E = Q_drag·q̇ = −k|q̇|² (computed through Jᵀ)
    qd = dragged.particle_state(y)[10:]
    Edot = y[5:] @ (dragged.generalized_mass(y[:5]) @ dragged.rhs(0.0, y)[5:]) \
        - y[5:] @ (num.generalized_mass(y[:5]) @ num.rhs(0.0, y)[5:])
    assert abs(Edot + 0.5 * qd @ qd) < 5e-14  # measured 5.3e-15


def test_check_chart_accepts_a_right_chart_and_catches_slips():
    q, J, Jd = n_link_chart([1.0, 0.5, 2.0])
    u, ud = np.array([0.3, -1.0, 2.0]), np.array([1.0, -2.0, 0.5])
    ok = check_chart(q, J, Jd, u, ud)
    assert ok.ok and ok.J_error < 1e-9 and ok.Jdot_udot_error < 1e-9  # measured 1.1e-11, 5.7e-11 (FD, eps 1e-5)
    bad = check_chart(q, J, lambda u, ud: -Jd(u, ud), u, ud)           # sign slip in J̇u̇
    assert not bad.ok and bad.Jdot_udot_error > 0.1
    badJ = check_chart(q, lambda u: 2 * J(u), Jd, u, ud)                # wrong J
    assert not badJ.ok and badJ.J_error > 0.1
    with pytest.raises(ValueError, match=r"J\(u\) must have shape \(6, 3\)"):
        check_chart(q, lambda u: J(u)[:, :2], Jd, u, ud)


def test_chart_condition_number_oracle():
    # ORACLES B6: κ of JᵀMJ in the reference metric. Bead by x (reference x = 0): JᵀMJ = mR²/(R² − x²),
    # κ = R²/(R² − x²) exactly; spherical pendulum (reference θ₀): κ = sin²θ₀ / sin²θ
    red = bead_x_chart(radius=2.0).reduced()
    for x in (0.5, 1.9, 1.99):
        red.rhs(0.0, [x, 0.1])
        assert abs(red.guard.last_cond / (4.0 / (4.0 - x * x)) - 1) < 2e-15  # measured 2.2e-16
    sph = spherical_pendulum(theta0=1.0).reduced()
    for th in (0.5, 0.01, 1e-3):
        sph.rhs(0.0, [th, 0.3, 0.0, 1.0])
        assert abs(sph.guard.last_cond / (np.sin(1.0) ** 2 / np.sin(th) ** 2) - 1) < 2e-15  # measured 3.3e-16


def test_singular_chart_detected_and_maximal_coordinates_pass():
    # ORACLES B6: a bead on a circle with v₀² > 2gR reaches the equator x = R, where the x chart is
    # singular: the reduced run raises SingularChartError (never NaN); chapter 03's constrained particle
    # passes the same point with |ΔE/E| < 1e-6
    mod = bead_x_chart(x0=0.0, xdot0=5.0, radius=1.0)
    red = mod.reduced()
    with pytest.raises(SingularChartError, match="singular chart") as info:
        simulate_fixed(red.rhs, mod.state(), 1.0, 1e-3, "rk4")
    assert info.value.u[0] > 0.99 and not np.isfinite(info.value.cond) or info.value.cond > 1e8
    # just inside the domain, the condition number itself trips the guard: κ = 1/(1 − x²) = 5e8 > 1e8
    with pytest.raises(SingularChartError, match="above max_cond = 1.0e\\+08"):
        red.rhs(0.0, [1 - 1e-9, 0.0])
    ps = ParticleSystem([[0.0, -1.0]], [[5.0, 0.0]], masses=1.0)
    scene = Scene(ps, [Gravity([0.0, -9.81]), Constraints([Distance([[-1, 0]], lengths=1.0, anchors=[0, 0])])])
    res = scene.simulate(0.6, 1e-3, "rk4")
    E = res.diagnostics["energy"]
    assert res.y[1].max() > 0.2               # went over the equator (y > 0)
    assert np.abs(E - E[0]).max() / abs(E[0]) < 1e-6  # measured 6.9e-11


def _three_runs(mod, t_end, rtol=1e-10):
    t_eval = np.linspace(0.0, t_end, 9)
    mx = maximal_chain(mod)
    red, lag = mod.reduced(), mod.lagrangian()
    kw = dict(method="dopri5", rtol=rtol, atol=rtol * 1e-2, t_eval=t_eval)
    a = pbanim.solve(mx.scene.rhs, (0.0, t_end), mx.state(), **kw)
    b = pbanim.solve(red.rhs, (0.0, t_end), mod.state(), **kw)
    c = pbanim.solve(lag.rhs, (0.0, t_end), mod.state(), **kw)
    return mx, red, a, b, c


@pytest.mark.parametrize("n, t_end", [(2, 2.0), (5, 1.0)])
def test_maximal_reduced_lagrangian_agree_and_tensions_match(n, t_end):
    # ORACLES G1/B7: the chain as (a) constrained particles (ch03, Distance rods, no stabilization), (b) reduced
    # coordinates, (c) Euler–Lagrange agree to the integrator tolerance (dopri5 at rtol 1e-10, atol 1e-12)
    mod = n_link_pendulum(n, lengths=np.linspace(1.0, 0.6, n), masses=np.linspace(1.0, 2.0, n),
                          theta0=0.8 + 0.2 * np.arange(n))
    mx, red, a, b, c = _three_runs(mod, t_end)
    N2 = 2 * n
    xa = a.y[:N2]
    xb = np.array([red.particle_state(b.y[:, k])[:N2] for k in range(b.t.size)]).T
    xc = np.array([red.particle_state(c.y[:, k])[:N2] for k in range(c.t.size)]).T
    # (a) vs (b): measured 7.6e-11 (n=2), 3.8e-11 (n=5) m, positions of O(1) m: < rtol; bound 5e-10.
    # (b) vs (c) are one ODE in the same coordinates (same accepted steps): measured 2.6e-15; bound 1e-13
    assert np.abs(xa - xb).max() < 5e-10
    assert np.abs(xb - xc).max() < 1e-13
    # λ from (a) vs the rod tensions from (b)'s chart force Q_C = Mq̈ − Q: tension = −λL
    L = mod.info["lengths"]
    Q = np.outer(mod.masses, mod.g)
    for k in range(1, b.t.size):
        lam = solve_multipliers([mx.rods], mx.system, a.y[:, k], Q).lam
        tens = chain_rod_tensions(red, b.y[:, k])
        # measured rel 1.9e-10 (n=2), 8.7e-11 (n=5): the states' own difference; bound 1e-9
        np.testing.assert_allclose(-lam * L, tens, rtol=1e-9)


def test_tension_at_rest_and_release_from_horizontal():
    # hanging at rest: tension of link k = g Σ(masses below k) (ORACLES B3); a simple pendulum released
    # from horizontal has tension 3mg at the bottom (ORACLES B1), both from the reduced chart force
    mod = n_link_pendulum(3, masses=[1.0, 2.0, 3.0], g=10.0, theta0=[0, 0, 0])
    red = mod.reduced()
    np.testing.assert_allclose(chain_rod_tensions(red, np.zeros(6)), [60.0, 50.0, 30.0], rtol=1e-13)
    pend = simple_pendulum(theta0=np.pi / 2, mass=2.0).reduced()
    v = np.sqrt(2 * 9.81)
    np.testing.assert_allclose(chain_rod_tensions(pend, [0.0, v]), [3 * 2.0 * 9.81], rtol=1e-13)


def test_long_run_energy_implicit_midpoint_bounded_rk4_drifts():
    # ORACLES B7 / A4: cart-pendulum (M(u) not constant, integrable). Implicit midpoint (symplectic for
    # any H): energy error bounded and oscillating (late/early window ratio ≈ 1). RK4: secular drift whose
    # rate scales like h⁵ (fitted slope; measured 4.93 from h = 0.1, 0.05, 0.025)
    mod = cart_pendulum(theta0=1.0)
    sysl = mod.lagrangian()
    y0 = mod.state()
    E0 = sysl.energy(y0)
    im = simulate_fixed(sysl.rhs, y0, 40.0, 0.05, "implicit_midpoint", energy=sysl.energy, record_every=2)
    e_im = im.diagnostics["energy"]
    assert drift_ratio(e_im) < 1.5  # measured 1.00 (late/early window)
    assert np.abs(e_im - E0).max() < 5e-3 * abs(E0)  # O(h²) oscillation: measured 1.1e-3·|E0| at h = 0.05
    rates = []
    hs = np.array([0.1, 0.05, 0.025])
    for h in hs:
        rk = simulate_fixed(sysl.rhs, y0, 40.0, h, "rk4", energy=sysl.energy, record_every=int(round(0.2 / h)))
        rates.append(abs(np.polyfit(rk.t, rk.diagnostics["energy"] - E0, 1)[0]))
        if h == 0.1:
            assert drift_ratio(rk.diagnostics["energy"]) > 3.0  # secular: measured 5.1
    assert_order(hs, rates, 5.0, tol=0.3)


def test_symplectic_euler_is_not_symplectic_when_mass_matrix_varies():
    # ORACLES B7 note: kick-drift on y = [u, u̇] is symplectic only for constant M (it treats u̇ as the
    # momentum). Simple pendulum (M = mL²): energy error bounded (window ratio 1.00). Cart-pendulum (M(u)):
    # secular loss, window ratio 3.8, E falls by 16% of |E₀| in 20 s at h = 0.01
    ratios = {}
    for mod in (simple_pendulum(theta0=1.0), cart_pendulum(theta0=1.0)):
        sysl = mod.lagrangian()
        res = simulate_fixed(sysl.rhs, mod.state(), 20.0, 0.01, "symplectic_euler", energy=sysl.energy,
                             record_every=5)
        E = res.diagnostics["energy"]
        ratios[mod.name] = (drift_ratio(E), (E[-1] - E[0]) / abs(E[0]))
    assert ratios["simple pendulum"][0] < 1.5
    assert ratios["cart pendulum"][0] > 2.0 and ratios["cart pendulum"][1] < -0.05


def test_bad_inputs_get_named_errors():
    q, J, Jd = n_link_chart([1.0, 1.0])
    with pytest.raises(ValueError, match=r"J must be a callable, got an array of shape \(4, 2\)"):
        ReducedSystem(q, np.eye(4, 2), Jd, 1.0, 2, u0=[0.0, 0.0])
    with pytest.raises(ValueError, match=r"J\(u\) must have shape \(len\(q\), len\(u\)\) = \(4, 2\), got \(4, 3\)"):
        ReducedSystem(q, lambda u: np.ones((4, 3)), Jd, 1.0, 2, u0=[0.0, 0.0])
    with pytest.raises(ValueError, match=r"Jdot_udot\(u, ud\) must have shape \(4,\)"):
        ReducedSystem(q, J, lambda u, ud: np.ones(3), 1.0, 2, u0=[0.0, 0.0])
    with pytest.raises(ValueError, match=r"ReducedSystem.__init__: udot0 must be a float array of shape .*2.*got \[1.0\]"):
        ReducedSystem(q, J, Jd, 1.0, 2, u0=[0.0, 0.0], udot0=[1.0])
    with pytest.raises(ValueError, match=r"masses must be .*entries > 0.*got \[1.0, -1.0\]"):
        ReducedSystem(q, J, Jd, [1.0, -1.0], 2, u0=[0.0, 0.0])
    with pytest.raises(ValueError, match="forces must be force effects"):
        ReducedSystem(q, J, Jd, 1.0, 2, [Constraints([Distance([[0, 1]])])], u0=[0.0, 0.0])
    red = ReducedSystem(q, J, Jd, 1.0, 2, u0=[0.0, 0.0])
    with pytest.raises(ValueError, match=r"ReducedSystem.rhs: y must be a float array of shape \(4,\).*got array\(\[0., 0., 0.\]\)"):
        red.rhs(0.0, np.zeros(3))
    th, ph = sp.symbols("th ph")
    with pytest.raises(ValueError, match=r"coords\[0\] must be a sympy Symbol .*got 'th'; a str"):
        ReducedSystem.from_sympy([[sp.sin(th), -sp.cos(th)]], ["th"], u0=[0.0])
    with pytest.raises(ValueError, match=r"positions must all have the same dimension"):
        ReducedSystem.from_sympy([[sp.sin(th), -sp.cos(th)], [th, ph, 0]], [th, ph], u0=[0.0, 0.0])
    with pytest.raises(ValueError, match=r"got symbols \['R'\]"):
        ReducedSystem.from_sympy([[sp.Symbol("R") * sp.sin(th), 0]], [th], u0=[0.0])
    with pytest.raises(ValueError, match="max_cond must be a finite number > 1, got 0.5"):
        ChartGuard(0.5)
    with pytest.raises(ValueError, match="dim must be given"):
        ReducedSystem.from_sympy([sp.sin(th), -sp.cos(th)], [th], u0=[0.0])
    with pytest.raises(ValueError, match="h must be a finite number > 0, got -0.1"):
        simulate_fixed(red.rhs, red.state(), 1.0, -0.1)
    with pytest.raises(ValueError, match=r"theta0 must satisfy 0 < \|theta0\| < pi"):
        pendulum_period(np.pi)


def _bead():
    """A bead on the unit circle parametrized by x (q = (x, √(1 − x²))): singular at |x| = 1, undefined beyond."""
    q = lambda u: np.array([u[0], np.sqrt(1 - u[0] ** 2)])                     # noqa: E731
    J = lambda u: np.array([[1.0], [-u[0] / np.sqrt(1 - u[0] ** 2)]])          # noqa: E731
    Jd = lambda u, ud: np.array([0.0, -ud[0] ** 2 / (1 - u[0] ** 2) ** 1.5])    # noqa: E731
    return q, J, Jd


@pytest.mark.filterwarnings("ignore::RuntimeWarning")
def test_outside_the_chart_is_a_singular_chart_error_never_nan():
    # ORACLES B6: a numeric chart evaluated outside its domain (|x| > 1: np.sqrt gives NaN) used to return
    # NaN states, NaN energies, a NaN generalized mass and a ChartCheck of NaN errors without a word
    q, J, Jd = _bead()
    red = ReducedSystem(q, J, Jd, 1.0, 2, [Gravity()], u0=[0.2])
    for call in (lambda: red.particle_state([1.5, 0.0]), lambda: red.energy([1.5, 0.0]),
                 lambda: red.kinetic_energy([1.5, 0.0]), lambda: red.generalized_mass([1.5]),
                 lambda: red.rhs(0.0, [1.5, 0.0]), lambda: check_chart(q, J, Jd, [1.5], [1.0])):
        with pytest.raises(SingularChartError, match=r"at u = \[1.5\]"):
            call()
    assert np.isfinite(red.particle_state([0.5, 1.0])).all()      # inside the domain: numbers


def test_one_state_methods_refuse_batches_and_strings_by_name():
    # a batch of states or a string used to end in numpy's "inhomogeneous shape" / "could not convert" errors
    red = simple_pendulum().reduced()
    for name in ("energy", "kinetic_energy", "potential_energy", "particle_state"):
        with pytest.raises(InvalidInput, match=rf"(?s)ReducedSystem.{name}: y must be .*a batch of states is not"):
            getattr(red, name)(np.zeros((3, 2)))
        with pytest.raises(InvalidInput, match=rf"ReducedSystem.{name}: y must be .*got 'ab'"):
            getattr(red, name)("ab")
    with pytest.raises(InvalidInput, match=r"(?s)generalized_mass: u must be .*a batch of states is not"):
        red.generalized_mass(np.zeros((3, 1)))
    with pytest.raises(InvalidInput, match="max_cond must be a finite number > 1, got nan"):
        ChartGuard(float("nan"))
    with pytest.raises(InvalidInput, match=r"ChartGuard: A must have the shape \(2, 2\) of the reference"):
        g = ChartGuard()
        g.set_reference(np.eye(2))
        g.solve(np.eye(3), np.ones(3), np.zeros(3))


def test_simulate_caps_its_steps_before_the_first():
    red = simple_pendulum().reduced()
    with pytest.raises(StepLimitExceeded, match="max_steps = 100"):
        red.simulate(10.0, 0.01, "rk4", max_steps=100)
    assert red.simulate(1.0, 0.01, "rk4", max_steps=100).t[-1] == pytest.approx(1.0)


def test_time_dependent_chart_matches_lagrangian():
    # a moving chart q(u, t) (bead on a hoop spinning at Ω): b = J̇u̇ + 2∂J/∂t u̇ + ∂²q/∂t² in reduced
    # coordinates equals the Euler–Lagrange equations of the rheonomic Lagrangian
    from pbanim.models.reduced import bead_on_rotating_hoop

    mod = bead_on_rotating_hoop(omega=4.0)
    red, lag = mod.reduced(), mod.lagrangian()
    for t, y in [(0.0, [0.3, 1.0]), (0.7, [1.2, -2.0]), (2.1, [2.5, 0.4])]:
        np.testing.assert_allclose(red.rhs(t, y), lag.rhs(t, y), atol=1e-14)  # measured 8.9e-16


# ---- chapter 04 figures (quick mode data, via the shared figure_data fixture) --------------------------
def test_figure_period_amplitude(figure_data):
    # ORACLES A5 over amplitudes 10°…179°: measured max rel error 5.7e-8 (at 179°), bound 5e-7;
    # T grows monotonically from the small-angle 2π√(L/g) and T(179°)/T₀ = 2K(m)/π ≈ 3.9
    d = figure_data("ch04_period_amplitude")
    assert np.max(d["rel_err"]) < 5e-7
    assert np.all(np.diff(d["T_sim"]) > 0) and d["T_sim"][0] > d["T_small"]
    assert 3.5 < d["T_sim"][-1] / d["T_small"] < 4.2


def test_figure_double_pendulum_formulations(figure_data):
    # ORACLES G1: the three formulations overlay (measured 7.6e-11 m and 2.6e-15 m, bounds 5e-10, 1e-13)
    d = figure_data("ch04_double_pendulum_formulations")
    assert d["max_diff_maximal_reduced"] < 5e-10
    assert d["max_diff_reduced_lagrangian"] < 1e-13
    L = np.hypot(*d["tip_reduced"])
    assert L.max() <= 2.0 + 1e-9  # tip within reach of two 1 m rods


def test_figure_energy_error(figure_data):
    # h = 0.02 s, 5 s: RK4 (order 4) ≪ implicit midpoint (order 2, bounded) ≪ symplectic Euler (order 1, not
    # symplectic for M(u) ≠ const) in reduced coordinates; reduced and Lagrangian are one ODE (same numbers)
    d = figure_data("ch04_energy_error")
    assert d["reduced_rk4"] < 1e-6                 # measured 6.4e-8
    assert d["reduced_implicit_midpoint"] < 5e-5   # measured 8.0e-6
    assert d["reduced_symplectic_euler"] > 1e-3    # measured 1.3e-2
    for m in ("rk4", "implicit_midpoint", "symplectic_euler"):
        assert abs(d[f"reduced_{m}"] - d[f"lagrangian_{m}"]) <= 2e-8 * d[f"reduced_{m}"]  # measured 2.5e-9 rel
    assert d["maximal_rk4"] < 1e-4                 # measured 1.1e-5 (no stabilization: constraint drift)


def test_figure_cost_vs_n(figure_data):
    # equal accuracy: every formulation reached tip error ≤ tol with a finite cost
    d = figure_data("ch04_cost_vs_n")
    for f in ("maximal", "reduced", "lagrangian"):
        assert np.all(d[f"err_{f}"] <= d["tol"]) and np.all(np.isfinite(d[f"cost_{f}"]))
        assert np.all(d[f"cost_{f}"] > 0)


def test_figure_derivation_time(figure_data):
    # the three derivations are the same physics: ü from pbanim equals sympy's Kane and Lagrange to roundoff
    d = figure_data("ch04_derivation_time")
    assert all(np.all(np.isfinite(d[f"time_{k}"])) for k in ("pbanim", "kane", "lagrange"))
    np.testing.assert_allclose(d["rhs_pbanim"], d["rhs_kane"], atol=1e-12)   # measured 1e-15
    np.testing.assert_allclose(d["rhs_pbanim"], d["rhs_lagrange"], atol=1e-12)


def test_bench_smoke():
    # `pbanim bench reduced --quick` runs and every goal has a finite measurement (no timing asserts)
    from pbanim.bench.reduced import run

    rep = run(quick=True)
    assert {g.id for g in rep.goals} == {"reduced-derive-vs-kane", "reduced-rhs-vs-kane"}
    assert all(np.isfinite(g.measured) and g.measured > 0 for g in rep.goals)
    assert all(len(t.rows) > 0 for t in rep.tables)
