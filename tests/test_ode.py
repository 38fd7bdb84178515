"""pbanim.ode: the methods themselves — tableaux, one-step energy maps, stability limits, orders.

ORACLES A1 (exact one-step energy factors and modified energies), A2 (stiff-spring stability limits),
A3 (convergence orders, parametrized over the registry), A9 (rooted-tree order conditions of every
tableau), plus the bad-input contract of ``solve``.
"""

import functools

import numpy as np
import pytest
import scipy.sparse as sp

import pbanim
from pbanim.errors import ConvergenceError, SimulationDiverged
from pbanim.models.ode import damped_oscillator, harmonic_oscillator, kepler
from pbanim.ode import METHODS, TABLEAUX, explicit_rk_step, get_method
from pbanim.testing import assert_order

RK_NAMES = ["euler", "midpoint", "rk4", "dopri5", "dop853", "vern7"]


# --------------------------------------------------------------------------------------------------
# tableaux: Butcher's rooted-tree order conditions (ORACLES A9)
# --------------------------------------------------------------------------------------------------
@functools.lru_cache(maxsize=None)
def rooted_trees(n):
    """All rooted trees with n nodes, each a sorted tuple of its subtrees (1, 1, 2, 4, 9, 20, 48, 115 …)."""
    if n == 1:
        return ((),)

    def forests(m, largest):
        # multisets of trees with m nodes in total, in non-increasing order of (size, tree)
        if m == 0:
            yield ()
            return
        for k in range(min(m, largest[0]), 0, -1):
            for t in rooted_trees(k):
                if (k, t) > largest:
                    continue
                for rest in forests(m - k, (k, t)):
                    yield ((k, t),) + rest

    return tuple(sorted({tuple(sorted(t for _, t in f)) for f in forests(n - 1, (n, ()))}))


def _size(t):
    return 1 + sum(_size(c) for c in t)


def _gamma(t):
    g = _size(t)
    for c in t:
        g *= _gamma(c)
    return g


def _phi(t, A, c):
    """Φᵢ(t): the stage weights of the elementary differential of tree t (product over the subtrees)."""
    v = np.ones(len(c))
    for child in t:
        v = v * (A @ _phi(child, A, c))
    return v


def _worst_condition(b, A, c, p):
    """max |Σ bᵢ Φᵢ(t) − 1/γ(t)| over the trees of order p."""
    return max(abs(b @ _phi(t, A, c) - 1.0 / _gamma(t)) for t in rooted_trees(p))


def test_rooted_tree_counts():
    # the number of rooted trees with n nodes (OEIS A000081): the order conditions of order n
    assert [len(rooted_trees(n)) for n in range(1, 9)] == [1, 1, 2, 4, 9, 20, 48, 115]


@pytest.mark.parametrize("name", sorted(TABLEAUX))
def test_tableau_order_conditions(name):
    # ORACLES A9: Butcher's conditions Σ bᵢΦᵢ(t) = 1/γ(t) hold for every tree up to the declared order and
    # fail at the next (the order is exact); the embedded weights b̂ = b − e likewise up to embedded_order
    tab = TABLEAUX[name]
    for p in range(1, tab.order + 1):
        # measured ≤ 1.0e-15 (DOP853, 30-digit decimals in double), ≤ 3.9e-15 (Verner)
        assert _worst_condition(tab.B, tab.A, tab.C, p) < 1e-14, (name, p)
    assert _worst_condition(tab.B, tab.A, tab.C, tab.order + 1) > 1e-6  # measured ≥ 1.7e-5
    if tab.E is not None:
        bhat, q = tab.B - tab.E, tab.embedded_order
        assert all(_worst_condition(bhat, tab.A, tab.C, p) < 1e-14 for p in range(1, q + 1))
        assert _worst_condition(bhat, tab.A, tab.C, q + 1) > 1e-6   # b̂ is only of order q


def test_inconsistent_tableau_is_rejected():
    # consistency checks: ΣB = 1, rows of A sum to C
    with pytest.raises(ValueError, match="weights B must sum to 1"):
        pbanim.Tableau("bad", np.zeros((2, 2)), np.array([0.5, 0.4]), np.zeros(2), 1)
    with pytest.raises(ValueError, match="rows of A must sum to C"):
        pbanim.Tableau("bad", np.array([[0, 0], [0.5, 0]]), np.array([0, 1.0]), np.array([0, 0.4]), 2)


@pytest.mark.parametrize("name", RK_NAMES)
def test_compiled_step_equals_readable_tableau_loop(name):
    # the registered (compiled) step and the readable loop over the tableau are the same formula
    f = kepler(0.5).rhs
    y = np.array([0.7, 0.2, -0.3, 1.1])
    fast = METHODS[name].step(f, 0.3, y, 0.05)
    slow = explicit_rk_step(name, f, 0.3, y, 0.05)
    assert np.max(np.abs(fast - slow)) <= 1e-15  # measured 0


@pytest.mark.parametrize("name", RK_NAMES)
def test_explicit_rk_exact_on_polynomials_of_its_degree(name):
    # an order-p explicit RK method integrates y' = p t^(p−1) exactly (ORACLES A3)
    p = TABLEAUX[name].order
    f = lambda t, y: np.full_like(y, p * t ** (p - 1))  # noqa: E731
    y1 = METHODS[name].step(f, 0.5, np.array([0.5 ** p]), 0.7)
    assert y1[0] == pytest.approx(1.2 ** p, rel=1e-14)


# --------------------------------------------------------------------------------------------------
# A1: one-step energy maps on ẍ = −ω²x
# --------------------------------------------------------------------------------------------------
W, H = 2.0, 0.15  # y = hω = 0.3
Y = H * W
ENERGY_FACTOR = {  # ORACLES A1: E₁/E₀ exactly
    "euler": 1 + Y**2,
    "implicit_euler": 1 / (1 + Y**2),
    "midpoint": 1 + Y**4 / 4,
    "rk4": 1 - Y**6 / 72 + Y**8 / 576,
    "implicit_midpoint": 1.0,
    "exponential_euler": 1.0,  # e^(hJ) is the exact flow: a rotation in (ωx, v)
}


def _one_step(name, y0, h=H, omega=W):
    osc = harmonic_oscillator(omega)
    return METHODS[name].step(osc.rhs, 0.0, np.array(y0, float), h, 1, osc.jac)


@pytest.mark.parametrize("name", sorted(ENERGY_FACTOR))
@pytest.mark.parametrize("y0", [(1.0, 0.0), (0.3, -1.7)])
def test_exact_one_step_energy_factor(name, y0):
    # ORACLES A1: on the oscillator one step multiplies E = ½(v² + ω²x²) by |R(ihω)|², whatever the state
    E = lambda y: 0.5 * (y[1] ** 2 + W**2 * y[0] ** 2)  # noqa: E731
    ratio = E(_one_step(name, y0)) / E(np.array(y0))
    assert ratio == pytest.approx(ENERGY_FACTOR[name], rel=1e-12)  # ORACLES A1 bound; measured ≤ 2.2e-16


def _modified_energy(name, y, h=H, omega=W):
    x, v = y
    if name == "symplectic_euler":
        return 0.5 * (v**2 + omega**2 * x**2) - 0.5 * h * omega**2 * x * v
    return 0.5 * v**2 + 0.5 * omega**2 * (1 - (h * omega) ** 2 / 4) * x**2  # verlet


@pytest.mark.parametrize("name", ["symplectic_euler", "verlet"])
def test_symplectic_modified_energy_is_exactly_conserved(name):
    # ORACLES A1: kick-then-drift symplectic Euler conserves H̃ = E − ½hω²xv; Verlet ½v² + ½ω²(1 − y²/4)x²
    y = np.array([0.3, -1.7])
    H0 = _modified_energy(name, y)
    for _ in range(50):
        y = _one_step(name, y)
    assert _modified_energy(name, y) == pytest.approx(H0, rel=1e-12)  # ORACLES A1 bound; measured ≤ 8.9e-16 after 50 steps


def test_modified_energy_catches_a_fake_symplectic_euler():
    # ORACLES A1: explicit Euler (the usual "symplectic Euler" bug) violates H̃ = E − ½hω²xv by O(h²)
    y0 = np.array([0.3, -1.7])
    drift = abs(_modified_energy("symplectic_euler", _one_step("euler", y0)) / _modified_energy("symplectic_euler", y0) - 1)
    assert drift > 1e-3  # measured 1.05e-2


def test_damped_symplectic_euler_step_determinant():
    # ORACLES A1: on ẍ = −ω²x − cẋ the symplectic-Euler one-step map has determinant 1 − hc
    w, c, h = 3.0, 0.7, 0.1
    osc = damped_oscillator(w, c)
    step = METHODS["symplectic_euler"].step
    Phi = np.column_stack([step(osc.rhs, 0.0, e, h, 1) for e in np.eye(2)])
    assert np.linalg.det(Phi) == pytest.approx(1 - h * c, rel=1e-13)  # measured 2.2e-16
    Phi_euler = np.column_stack([METHODS["euler"].step(osc.rhs, 0.0, e, h) for e in np.eye(2)])
    assert abs(np.linalg.det(Phi_euler) - (1 - h * c)) > 1e-2  # explicit Euler's is 1 − hc + h²ω²


# --------------------------------------------------------------------------------------------------
# A2: stiff spring stability limits (k = 1e6, ω = 1e3)
# --------------------------------------------------------------------------------------------------
OMEGA = 1e3
H_CRIT = {"symplectic_euler": 2 / OMEGA, "verlet": 2 / OMEGA, "rk4": 2 * np.sqrt(2) / OMEGA}


@pytest.mark.parametrize("name", sorted(H_CRIT))
def test_stiff_spring_stability_limit(name):
    # ORACLES A2: stable iff hω < 2 (symplectic Euler, Verlet), hω ≤ 2√2 (RK4): bounded at 0.99·h_crit,
    # SimulationDiverged at 1.01·h_crit
    osc = harmonic_oscillator(OMEGA)
    h = 0.99 * H_CRIT[name]
    r = pbanim.solve(osc.rhs, (0, 20000 * h), osc.y0, method=name, h=h)
    scale = np.abs(r.y / np.array([[1.0], [OMEGA]])).max()
    assert scale < 20  # measured 7.09 (symplectic Euler's tilted ellipse), 1.0 (Verlet, RK4)
    h = 1.01 * H_CRIT[name]
    with pytest.raises(SimulationDiverged, match="diverged at t = .* \\(step [0-9]+\\): state y is not finite"):
        pbanim.solve(osc.rhs, (0, 20000 * h), osc.y0, method=name, h=h)


def test_stiff_spring_explicit_euler_never_stable_implicit_always():
    # ORACLES A2: explicit Euler grows by (1 + h²ω²) per step for every h; implicit Euler decays at hω = 10
    osc = harmonic_oscillator(OMEGA)
    with pytest.raises(SimulationDiverged) as err:
        pbanim.solve(osc.rhs, (0, 3.0), osc.y0, method="euler", h=1 / OMEGA)
    assert err.value.step > 0 and err.value.quantity == "state y"
    r = pbanim.solve(osc.rhs, (0, 1.0), osc.y0, method="implicit_euler", h=10 / OMEGA, jac=osc.jac)
    E = osc.invariants["energy"](r.y)
    assert np.all(np.isfinite(r.y)) and np.all(np.diff(E) < 0)
    assert E[1] / E[0] == pytest.approx(1 / 101, rel=1e-12)  # A1 factor 1/(1 + y²), y = 10


# --------------------------------------------------------------------------------------------------
# A3: convergence order of every registered method (Kepler, e = 0.3, exact from Kepler's equation)
# --------------------------------------------------------------------------------------------------
# first steps chosen so every error lies in the asymptotic range inside the fit window 1e-10..1e-2;
# Dormand–Prince's fifth-order error constant is small, so it needs the longer span T = 6 to be asymptotic
# (Verner's too, T = 6). An eighth-order method gains 2⁸ per halving, so its three errors span 2¹⁶: from
# the asymptotic range (h ≤ 1/4 on T = 2) they reach 2e-13, and its window is extended down to 1e-13,
# still 100× above the roundoff floor of the 4-state orbit
H0 = {1: 2.0**-10, 2: 2.0**-5, 4: 2.0**-4, 5: 2.0**-4, 6: 2.0**-3, 7: 2.0**-1, 8: 2.0**-2, 12: 8.0 / 6}
SPAN = {5: 6.0, 7: 6.0, 12: 8.0}
WINDOW = {8: (1e-13, 1e-2), 12: (1e-13, 1e-2)}
H0_BY_NAME = {"rodas4": 2.0**-5}   # RODAS4's error constant is larger than RK4's: asymptotic from h = 1/32


@pytest.mark.parametrize("name", sorted(METHODS))
def test_convergence_order(name):
    # ORACLES A3: fitted slope of log(error) vs log(h) within ±0.15 of the declared order
    m = METHODS[name]
    kp = kepler(0.3)
    T = SPAN.get(m.order, 2.0)
    exact = kp.exact(T)[:, 0]
    hs = H0_BY_NAME.get(name, H0[m.order]) / 2.0 ** np.arange(3)
    errs = []
    for h in hs:
        y = kp.y0.copy()
        for k in range(int(round(T / h))):
            y = m.step(kp.rhs, k * h, y, h, 2)
        errs.append(np.max(np.abs(y - exact)))
    p = assert_order(hs, errs, m.order, window=WINDOW.get(m.order, (1e-10, 1e-2)))
    # ORACLES bound; measured 0.998, 2.030, 4.079, 0.999, 2.000, 1.002, 2.001, 5.097; dop853 7.90, vern7 6.99,
    # rodas4 3.92, radau5 5.00; dprkn6 6.05, dprkn8 7.99, dprkn12 12.12 (order 12 shows only between errors
    # 5e-5 and 2e-12: from h = 4/3 over t = 8, three halvings)
    assert abs(p - m.order) < 0.15


# --------------------------------------------------------------------------------------------------
# implicit steps: Newton, Jacobians
# --------------------------------------------------------------------------------------------------
def test_linear_force_one_newton_iteration_is_baraffs_step():
    # implicit Euler on a linear spring: y₁ = (I − hJ)⁻¹ y₀ (Baraff & Witkin's linearized step) exactly
    osc = damped_oscillator(1e3, 20.0)
    J = osc.jac(0, None)
    h = 0.01
    y1 = METHODS["implicit_euler"].step(osc.rhs, 0.0, osc.y0, h, 1, osc.jac)
    ref = np.linalg.solve(np.eye(2) - h * J, osc.y0)
    assert np.max(np.abs(y1 - ref)) <= 1e-15 * np.abs(ref).max()  # measured 0
    # the same with a sparse Jacobian and with finite differences
    ys = METHODS["implicit_euler"].step(osc.rhs, 0.0, osc.y0, h, 1, lambda t, y: sp.csr_matrix(J))
    yfd = METHODS["implicit_euler"].step(osc.rhs, 0.0, osc.y0, h, 1, None)
    assert np.max(np.abs(ys - ref)) <= 1e-15 * np.abs(ref).max()
    assert np.max(np.abs(yfd - ref)) <= 1e-13 * np.abs(ref).max()  # measured 0 (FD exact on linear f)


def test_implicit_midpoint_conserves_quadratic_energy_of_linear_system():
    # implicit midpoint is symplectic and conserves quadratic invariants: E of the oscillator to roundoff
    osc = harmonic_oscillator(5.0)
    r = pbanim.solve(osc.rhs, (0, 10.0), osc.y0, method="implicit_midpoint", h=0.3, jac=osc.jac)
    E = osc.invariants["energy"](r.y)
    assert np.max(np.abs(E / E[0] - 1)) < 5e-15  # measured 6.7e-16
    assert r.njev == len(r.t) - 1


def test_exponential_euler_is_exact_for_a_linear_spring():
    # the exponential integrator's step is e^(hJ) y₀ for a linear system: the exact flow of a stiff damped
    # spring at any step (here hω = 100, c = 20), with a dense, a sparse or a finite-difference Jacobian
    m = damped_oscillator(1e3, 20.0)
    step = METHODS["exponential_euler"].step
    for jac in (m.jac, lambda t, y: sp.csr_matrix(m.jac(t, y)), None):
        y = step(m.rhs, 0.0, m.y0, 0.1, 1, jac)
        ex = m.exact([0.1])[:, 0]
        assert np.max(np.abs(y - ex) / np.array([1.0, 1e3])) < 1e-12  # measured 1e-16 (dense), 4e-14 (FD)
    yb = step(m.rhs, 0.0, np.tile(m.y0, (3, 1)), 0.1, 1, None)  # batch: one expm per trajectory
    assert np.max(np.abs(yb - m.exact([0.1])[:, 0]) / np.array([1.0, 1e3])) < 1e-12


@pytest.mark.parametrize("A", [
    np.array([[0.0, 1.0], [-1e6, -20.0]]) * 0.1,            # stiff underdamped spring, hω = 100
    np.array([[0.0, 1.0, 0.0], [-1e6, -2e5, 5.0], [0, 0, 0]]),  # overdamped, augmented with h f
    np.array([[0.0, np.pi], [-np.pi, 0.0]]),                # half a turn
])
def test_expm_small_matches_high_precision(A):
    # the scaling-and-squaring Padé exponential agrees with 50-digit mpmath like scipy.linalg.expm does
    import mpmath as mp
    import scipy.linalg as sla

    from pbanim.ode.implicit import expm_small

    with mp.workdps(50):
        ex = np.array(mp.expm(mp.matrix(A.tolist())).tolist(), dtype=float)
    scale = np.abs(ex).max()
    err, err_scipy = np.abs(expm_small(A) - ex).max() / scale, np.abs(sla.expm(A) - ex).max() / scale
    # measured 2.4e-14, 7.3e-12, 1.1e-16 (scipy: 1.0e-14, 7.0e-14, 2.2e-16: it squares fewer times)
    assert err < 5e-11 and err_scipy < 1e-12
    np.testing.assert_allclose(expm_small(np.stack([A, 2 * A])), np.stack([sla.expm(A), sla.expm(2 * A)]),
                               rtol=5e-11, atol=1e-13 * scale)  # batched = one by one; measured 1.5e-11


def test_newton_failure_raises_convergence_error():
    # implicit Euler on y' = y² from y = 10 at h = 1 asks for z = 10 + z², which has no real root
    with pytest.raises(ConvergenceError, match="Newton \\(implicit step\\) did not converge.*reduce the step h"):
        METHODS["implicit_euler"].step(lambda t, y: y**2, 0.0, np.array([10.0]), 1.0)


def test_newton_refreshes_jacobian_when_frozen_one_stalls():
    # y' = −y³ at h = 100 from y = 10: J frozen at y = 10 contracts far too slowly (it used to raise);
    # refreshing J makes it converge to the root of z + 100 z³ = 10
    z = METHODS["implicit_euler"].step(lambda t, y: -y**3, 0.0, np.array([10.0]), 100.0)
    assert abs(z[0] + 100 * z[0] ** 3 - 10.0) < 1e-12 * 10


# --------------------------------------------------------------------------------------------------
# bad input: every rejection names the argument
# --------------------------------------------------------------------------------------------------
f2 = harmonic_oscillator().rhs


@pytest.mark.parametrize("kwargs, match", [
    (dict(h=0.0), "solve: h must be a finite number > 0, got 0.0"),
    (dict(h=-0.1), "solve: h must be a finite number > 0, got -0.1"),
    (dict(h=np.nan), "solve: h must be a finite number > 0, got nan"),
    (dict(method="rk5"), "method must be one of .* got 'rk5'; did you mean 'rk4'"),
    (dict(method="scipy:Euler"), "method must be one of .* got 'scipy:Euler'; did you mean 'scipy:"),
    (dict(method="rk4", h=None), "h must be given for the fixed-step method 'rk4'"),
    (dict(rtol=0.0, method="dopri5"), "rtol must be a finite number > 0, got 0.0"),
    (dict(atol=-1.0, method="dopri5"), "atol must be a finite number >= 0, .* got -1.0"),
    (dict(max_steps=0), "max_steps must be a positive integer, got 0"),
    (dict(h=1e-6, max_steps=10), "needs 1000000 steps over t_span, more than max_steps = 10"),
    (dict(split=5), "split must be between 0 and n = 2"),
    (dict(t_eval=[0.5, 2.0]), "t_eval must be sorted .* within t_span"),
    (dict(t_eval=[0.5, 0.2]), "t_eval must be sorted"),
])
def test_bad_arguments_raise_value_error(kwargs, match):
    # bad arguments are rejected at the boundary with a message naming the argument and its value
    args = dict(method="rk4", h=0.1)
    args.update(kwargs)
    with pytest.raises(ValueError, match=match):
        pbanim.solve(f2, (0.0, 1.0), [1.0, 0.0], **args)


@pytest.mark.parametrize("y0, match", [
    ([1.0, np.nan], r"y0 must be a float array of shape \(n,\) .* got \[1.0, nan\]; it has NaN or inf entries"),
    ([1.0, np.inf], r"y0 must be a float array .* got \[1.0, inf\]; it has NaN or inf entries"),
    (np.zeros((2, 2, 2)), r"y0 must be a float array of shape \(n,\) .* it has 3 axes, not 1 \(shape \(2, 2, 2\)\)"),
    ([], "y0 must be a float array .* got \\[\\]; it is empty"),
])
def test_bad_initial_state(y0, match):
    with pytest.raises(ValueError, match=match):
        pbanim.solve(f2, (0.0, 1.0), y0, method="rk4", h=0.1)


def test_bad_fun_and_span():
    with pytest.raises(ValueError, match="fun\\(t, y\\) must return an array of the shape of y0 \\(3,\\), got \\(2,\\)"):
        pbanim.solve(lambda t, y: y[:2], (0.0, 1.0), [1.0, 0.0, 0.0], h=0.1)
    with pytest.raises(ValueError, match="fun must be a callable, got 3.0"):
        pbanim.solve(3.0, (0.0, 1.0), [1.0], h=0.1)
    with pytest.raises(ValueError, match="t_span must be two different times, got \\(1.0, 1.0\\)"):
        pbanim.solve(f2, (1.0, 1.0), [1.0, 0.0], h=0.1)
    with pytest.raises(ValueError, match=r"t_span must be a float array of shape \(2,\) .* got 1.0"):
        pbanim.solve(f2, 1.0, [1.0, 0.0], h=0.1)
    with pytest.raises(ValueError, match="events must be a callable, or a list"):
        pbanim.solve(f2, (0.0, 1.0), [1.0, 0.0], h=0.1, events=[1.0])
    with pytest.raises(ValueError, match="events are not supported in batch mode"):
        pbanim.solve(f2, (0.0, 1.0), np.ones((3, 2)), h=0.1, events=lambda t, y: y[0])
    with pytest.raises(ValueError, match="batch mode .* needs a pbanim method"):
        pbanim.solve(f2, (0.0, 1.0), np.ones((3, 2)), method="scipy:RK45")
    with pytest.raises(ValueError, match="get_method: name must be one of 'euler', .* got None"):
        get_method(None)


def test_non_finite_derivative_at_start_is_divergence():
    with pytest.raises(SimulationDiverged, match="derivative f\\(t0, y0\\) is not finite"):
        with np.errstate(divide="ignore"):
            pbanim.solve(lambda t, y: y / 0.0, (0.0, 1.0), [1.0], h=0.1)
