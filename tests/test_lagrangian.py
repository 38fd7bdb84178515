"""Tests of pbanim.reduced.lagrangian: symbolic Euler–Lagrange equations and their compiled numeric form (ch04).

Oracles: ORACLES B7 (dE/dt = 0 along the EOM, M symmetric positive definite), textbook closed forms of
the double pendulum, the bead on a rotating hoop and the cart-pendulum (small oscillations, invariants).
"""

import dataclasses

import numpy as np
import pytest
import sympy as sp
from hypothesis import given
from hypothesis import strategies as st

import pbanim
import pbanim.reduced.lagrangian as lg
from pbanim.errors import InvalidInput, NonFiniteResult, SingularChartError, StepLimitExceeded
from pbanim.models.reduced import (bead_on_rotating_hoop, cart_pendulum, double_pendulum, n_link_pendulum,
                                   simple_pendulum, spherical_pendulum)


def _double(route="kinematic", forces=None):
    a, b = sp.symbols("a b")
    pts = [(2, [sp.sin(a), -sp.cos(a)]), (1, [sp.sin(a) + sp.Rational(1, 2) * sp.sin(b),
                                             -sp.cos(a) - sp.Rational(1, 2) * sp.cos(b)])]
    return lg.derive_equations([a, b], pts, gravity=[0, -sp.Rational(981, 100)], route=route, forces=forces)


@pytest.mark.parametrize("route", ["kinematic", "energy"])
def test_energy_rate_simplifies_to_zero(route):
    # ORACLES B7: for a conservative scleronomic model dE/dt = ½u̇ᵀṀu̇ − u̇ᵀc ≡ 0 along the derived EOM
    eq = _double(route)
    assert sp.simplify(lg.energy_rate(eq)) == 0
    cart = cart_pendulum()
    coords, pos, _ = cart.build()
    eqc = lg.derive_equations(list(coords), list(zip(cart.masses.tolist(), pos)), gravity=[0, -9.81], route=route)
    assert sp.simplify(lg.energy_rate(eqc)) == 0


def test_energy_rate_detects_wrong_velocity_terms_and_counts_damping():
    # the check can fail: dropping the Coriolis/centrifugal terms leaves dE/dt = ½u̇ᵀṀu̇ ≠ 0
    eq = _double()
    broken = dataclasses.replace(eq, c_terms=[{}, {}], c_extra=None)
    assert sp.simplify(lg.energy_rate(broken)) != 0
    # a generalized damping force Q = −c u̇ removes energy at the rate −c|u̇|² (power of Q_nc)
    a, b = eq.coords
    ad, bd = eq.speeds
    damped = _double(forces=[-3 * ad, -3 * bd])
    assert sp.simplify(lg.energy_rate(damped) + 3 * ad ** 2 + 3 * bd ** 2) == 0


def test_double_pendulum_matches_textbook_equations():
    # closed form (absolute angles): M = [[(m1+m2)L1², m2L1L2 cos Δ], [·, m2L2²]], Δ = θ1 − θ2,
    # c = m2L1L2 sin Δ (θ̇2², −θ̇1²), ∂V/∂θ = g((m1+m2)L1 sin θ1, m2L2 sin θ2)
    m1, m2, L1, L2, g = 2.0, 1.0, 1.0, 0.5, 9.81
    mod = double_pendulum(lengths=(L1, L2), masses=(m1, m2), g=g)
    sysl = mod.lagrangian()
    rng = np.random.default_rng(0)
    for _ in range(5):
        y = rng.uniform(-2, 2, 4)
        t1, t2, w1, w2 = y
        d = t1 - t2
        M = np.array([[(m1 + m2) * L1 ** 2, m2 * L1 * L2 * np.cos(d)], [m2 * L1 * L2 * np.cos(d), m2 * L2 ** 2]])
        f = -np.array([m2 * L1 * L2 * np.sin(d) * w2 ** 2 + g * (m1 + m2) * L1 * np.sin(t1),
                       -m2 * L1 * L2 * np.sin(d) * w1 ** 2 + g * m2 * L2 * np.sin(t2)])
        Mn, fn = sysl.mass_and_forcing(0.0, y)
        # measured 3.6e-15, bound 1e-12 (roundoff of O(10) entries)
        np.testing.assert_allclose(Mn, M, atol=1e-12)
        np.testing.assert_allclose(fn, f, atol=1e-12)


@given(st.lists(st.floats(-3.0, 3.0), min_size=5, max_size=5))
def test_mass_matrix_symmetric_positive_definite(u):
    # ORACLES B7: M(u) = ΣJᵀmJ is symmetric positive definite for a chain (J has full column rank)
    sysl = n_link_pendulum(5, lengths=[1.0, 0.5, 0.8, 1.2, 0.3], masses=[1.0, 2.0, 0.5, 1.0, 3.0]).lagrangian()
    M = sysl.mass_matrix(np.array(u))
    assert np.array_equal(M, M.T)  # built symmetric by construction (upper triangle mirrored)
    assert np.linalg.eigvalsh(M).min() > 0


def test_kinematic_and_energy_routes_agree_numerically():
    # two derivations of the same Euler–Lagrange equations (ΣJᵀmJ / ΣJᵀm b vs Hessian of T and
    # (∂p/∂u)u̇ − ∂T/∂u) give the same M and f; measured 4.4e-15, bound 1e-12
    for mod in (n_link_pendulum(3), spherical_pendulum(), bead_on_rotating_hoop()):
        a, b = mod.lagrangian("kinematic"), mod.lagrangian("energy")
        rng = np.random.default_rng(1)
        for _ in range(3):
            y = rng.uniform(0.2, 1.4, 2 * mod.n)
            Ma, fa = a.mass_and_forcing(0.7, y)
            Mb, fb = b.mass_and_forcing(0.7, y)
            np.testing.assert_allclose(Ma, Mb, atol=1e-12)
            np.testing.assert_allclose(fa, fb, atol=1e-12)


def test_cache_derives_once_and_keys_on_the_model():
    lg.clear_cache()
    a = n_link_pendulum(2, lengths=[1.0, 0.7]).lagrangian()
    b = n_link_pendulum(2, lengths=[1.0, 0.7]).lagrangian()
    c = n_link_pendulum(2, lengths=[1.0, 0.8]).lagrangian()
    assert a is b and c is not a
    assert lg.cache_info() == {"size": 2, "hits": 1, "misses": 2}
    th = sp.Symbol("th")
    s1 = lg.lagrangian_system([th], [(1.0, [sp.sin(th), -sp.cos(th)])], gravity=[0.0, -9.81])
    s2 = lg.lagrangian_system([th], [(1.0, [sp.sin(th), -sp.cos(th)])], gravity=[0.0, -9.81])
    assert s1 is s2 and s1.derivation_time > 0 and s1.compile_time > 0


def test_rotating_hoop_equilibrium_frequency_and_jacobi_integral():
    # bead on a hoop spinning at Ω (time-dependent chart): small oscillations about cos θ* = g/(RΩ²)
    # at ω² = Ω² − g²/(R²Ω²); the Jacobi integral h = T₂ − T₀ + V is conserved, E = T + V is not
    mod = bead_on_rotating_hoop(radius=1.0, omega=5.0)
    th_star, w = mod.info["theta_star"], mod.info["omega_small"]
    sysl = mod.lagrangian()
    y0 = np.array([th_star + 1e-4, 0.0])
    assert abs(sysl.rhs(0.0, [th_star, 0.0])[1]) < 1e-12  # equilibrium
    res = pbanim.solve(sysl.rhs, (0.0, 3.0), y0, method="dopri5", rtol=1e-11, atol=1e-13)
    x = res.y[0] - th_star
    ups = np.flatnonzero((x[:-1] < 0) & (x[1:] >= 0))
    tc = res.t[ups] - x[ups] * (res.t[ups + 1] - res.t[ups]) / (x[ups + 1] - x[ups])
    period = np.mean(np.diff(tc))
    # measured rel 1.7e-6 (amplitude 1e-4 nonlinearity + linear interpolation of crossings), bound 1e-5
    assert abs(period * w / (2 * np.pi) - 1) < 1e-5
    y1 = np.array([0.3, 2.0])
    r2 = pbanim.solve(sysl.rhs, (0.0, 2.0), y1, method="dopri5", rtol=1e-11, atol=1e-13)
    h = [sysl.jacobi_integral(r2.y[:, k], r2.t[k]) for k in range(r2.t.size)]
    E = [sysl.energy(r2.y[:, k], r2.t[k]) for k in range(r2.t.size)]
    assert np.ptp(h) < 1e-9 * abs(h[0])  # measured 1.8e-10 (|h| = 8.5; rtol 1e-11 run)
    assert np.ptp(E) > 1.0  # the motor does work on the bead


def test_cart_pendulum_momentum_and_small_oscillation():
    # free cart: horizontal momentum p_x = (M+m)ẋ + mL cos θ θ̇ conserved; ω² = g(M+m)/(ML)
    mod = cart_pendulum(theta0=1e-4)
    sysl = mod.lagrangian()
    res = pbanim.solve(sysl.rhs, (0.0, 6.0), mod.state(), method="dopri5", rtol=1e-11, atol=1e-14)
    p = np.array([mod.info["momentum"](res.y[:, k]) for k in range(res.t.size)])
    assert np.max(np.abs(p)) < 1e-15  # starts at 0; measured 9e-19 (p_x is linear in y)
    th = res.y[1]
    dn = np.flatnonzero((th[:-1] > 0) & (th[1:] <= 0))
    tc = res.t[dn] - th[dn] * (res.t[dn + 1] - res.t[dn]) / (th[dn + 1] - th[dn])
    period = np.mean(np.diff(tc))
    assert abs(period * mod.info["omega_small"] / (2 * np.pi) - 1) < 1e-7  # measured 1.4e-8


def test_spherical_pendulum_conical_orbit_and_pole_singularity():
    # conical pendulum: φ̇² = g/(L cos θ) keeps θ constant; L_z conserved; the pole θ = 0 is a singular chart
    th0 = 0.8
    mod = spherical_pendulum(theta0=th0, phidot0=float(spherical_pendulum().info["conical_phidot"](th0)))
    sysl = mod.lagrangian()
    res = pbanim.solve(sysl.rhs, (0.0, 3.0), mod.state(), method="dopri5", rtol=1e-11, atol=1e-13)
    assert np.max(np.abs(res.y[0] - th0)) < 1e-11  # measured 1.0e-13 (rtol 1e-11 run)
    with pytest.raises(SingularChartError, match="singular chart"):
        sysl.rhs(0.0, [1e-6, 0.0, 0.0, 1.0])


def test_simple_pendulum_compiled_energy_and_rhs():
    # E = ½mL²θ̇² − mgL cos θ; θ̈ = −(g/L) sin θ
    mod = simple_pendulum(length=2.0, mass=3.0)
    sysl = mod.lagrangian()
    y = np.array([0.4, 1.5])
    assert abs(sysl.energy(y) - (0.5 * 3 * 4 * 1.5 ** 2 - 3 * 9.81 * 2 * np.cos(0.4))) < 1e-12
    assert abs(sysl.rhs(0.0, y)[1] + 9.81 / 2 * np.sin(0.4)) < 1e-13


def test_generalized_forces_and_extra_kinetic_energy_compile():
    # physical pendulum: a point mass m at L plus a rotor ½Iθ̇² (extra T) and viscous joint damping
    # Q_nc = −cθ̇: θ̈ = −(mgL sin θ + cθ̇)/(mL² + I) (closed form, both routes)
    th = sp.Symbol("th")
    (thd,) = lg.speeds_for([th])
    m, L, I, c, g = 2.0, 0.5, 0.3, 0.7, 9.81
    for route in ("kinematic", "energy"):
        sysl = lg.lagrangian_system([th], [(m, [L * sp.sin(th), -L * sp.cos(th)])], gravity=[0.0, -g],
                                    T=sp.Rational(3, 20) * thd ** 2, forces=[-c * thd], route=route)
        for y in ([0.4, 1.5], [-2.0, -0.3]):
            expect = -(m * g * L * np.sin(y[0]) + c * y[1]) / (m * L * L + I)
            assert abs(sysl.rhs(0.0, y)[1] - expect) < 1e-14  # measured 1.8e-15 (θ̈ of O(10))
        assert abs(sysl.energy([0.4, 1.5]) - (0.5 * (m * L * L + I) * 1.5 ** 2 - m * g * L * np.cos(0.4))) < 1e-13


@pytest.mark.parametrize("mass", [float("nan"), 1 + 2j, sp.nan, sp.I, sp.oo, sp.Symbol("m")])
def test_nan_or_complex_masses_are_refused_by_name(mass):
    # the builder used to hand NaN and complex masses to sympy, whose comparison raised its own TypeError
    th = sp.Symbol("th")
    with pytest.raises(InvalidInput, match=r"points\[0\] mass must be a finite number > 0"):
        lg.derive_equations([th], [(mass, [sp.sin(th), -sp.cos(th)])])
    with pytest.raises(InvalidInput, match=r"points\[0\] mass must be a finite number > 0"):
        lg.lagrangian_system([th], [(mass, [sp.sin(th), -sp.cos(th)])], gravity=[0.0, -9.81])


@pytest.mark.parametrize("length, got", [(float("nan"), r"\[nan, nan\]"), (1j, r"\[1.0\*I\*sin\(th\)"),
                                         (sp.zoo, r"\[zoo\*sin\(th\)")])
def test_nan_or_complex_lengths_and_gravity_are_refused_by_name(length, got):
    th = sp.Symbol("th")
    pos = [length * sp.sin(th), -length * sp.cos(th)]
    with pytest.raises(InvalidInput, match=rf"points\[0\] position must be .*real sympy expression.*got {got}"):
        lg.derive_equations([th], [(1.0, pos)])
    with pytest.raises(InvalidInput, match=r"gravity must be .*got \[nan, -9.81\]"):
        lg.lagrangian_system([th], [(1.0, [sp.sin(th), -sp.cos(th)])], gravity=[float("nan"), -9.81])
    with pytest.raises(InvalidInput, match="lagrangian_system: unknown options"):
        lg.lagrangian_system([th], [(1.0, [sp.sin(th), -sp.cos(th)])], gravty=[0.0, -9.81])


def test_sympy_numbers_as_parameters_keep_working():
    # exact and symbolic numbers (not NaN, not complex) are still accepted: M = m L² exactly (ORACLES A5)
    th = sp.Symbol("th")
    m, L = sp.Rational(1, 2), sp.sqrt(2)
    eq = lg.derive_equations([th], [(m, [L * sp.sin(th), -L * sp.cos(th)])], gravity=[0, sp.Rational(-981, 100)])
    assert sp.simplify(eq.M[0, 0] - m * L ** 2) == 0
    sysl = lg.compile_equations(eq)
    assert abs(sysl.rhs(0.0, [np.pi / 2, 0.0])[1] + 9.81 / np.sqrt(2)) < 1e-14


def test_overflow_is_a_named_error():
    # θ̇ = 1e300: the compiled factors raise OverflowError (θ̇²), the energies overflow
    sysl = simple_pendulum().lagrangian()
    with pytest.raises(NonFiniteResult):
        sysl.energy([1.0, 1e300])
    with pytest.raises(NonFiniteResult):
        sysl.rhs(0.0, [1.0, 1e300])


def test_bad_inputs_get_named_errors():
    th, ph = sp.symbols("th ph")
    pts = [(1.0, [sp.sin(th), -sp.cos(th)])]
    with pytest.raises(ValueError, match=r"coords\[0\] must be a sympy Symbol .*got sin\(th\)"):
        lg.derive_equations([sp.sin(th)], pts)
    with pytest.raises(ValueError, match="coords must be a list of at least 1 of .*got 'th'"):
        lg.derive_equations("th", pts)
    with pytest.raises(ValueError, match="position must have 2 components"):
        lg.derive_equations([th, ph], [(1.0, [sp.sin(th), 0]), (1.0, [th, ph, 0])])
    with pytest.raises(ValueError, match="forces must have one entry per coordinate"):
        lg.derive_equations([th], pts, forces=[0, 0])
    with pytest.raises(ValueError, match="gravity must have 2 components"):
        lg.derive_equations([th], pts, gravity=[0, 0, -9.81])
    with pytest.raises(ValueError, match=r"symbols \['L'\]"):
        lg.derive_equations([th], [(1.0, [sp.Symbol("L") * sp.sin(th), 0])])
    with pytest.raises(ValueError, match=r"points\[0\] mass must be a finite number > 0 .*got -1.0"):
        lg.derive_equations([th], [(-1.0, [sp.sin(th), 0])])
    with pytest.raises(ValueError, match="route must be one of 'kinematic', 'energy', got 'newton'"):
        lg.derive_equations([th], pts, route="newton")
    with pytest.raises(ValueError, match="give points"):
        lg.derive_equations([th])
    sysl = simple_pendulum().lagrangian()
    with pytest.raises(ValueError, match=r"LagrangianSystem.rhs: y must be a float array of shape \(2,\).*"
                                         r"got \[0.1, 0.2, 0.3\]"):
        sysl.rhs(0.0, [0.1, 0.2, 0.3])
