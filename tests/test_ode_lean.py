"""The lean adaptive loops compute the readable formulas (A13), and the work-precision floor (A14).

The adaptive loops of the explicit pairs, RODAS4 and Radau IIA keep their stages in preallocated buffers,
form every stage sum as one product, and (Radau, n ≤ 12) solve the Newton system through one real
3n × 3n inverse; these tests hold each against the readable version it replaces. The floor of
``pbanim bench ode`` (fewest evaluations × one call of f) is checked on synthetic sweeps whose answer is
known in closed form.
"""

import numpy as np
import pytest
import scipy.sparse as sp
from hypothesis import given, settings, strategies as st

import pbanim
from pbanim.errors import InvalidInput
from pbanim.ode.adaptive import DOPRI5
from pbanim.ode.high_order import DOP853, VERN7
from pbanim.ode.methods import explicit_rk_step
from pbanim.ode.problems import van_der_pol
from pbanim.ode.radau import LAM, TINV, block_inverse, radau5_step
from pbanim.ode.rosenbrock import rodas4_step

PAIRS = {"dopri5": DOPRI5, "dop853": DOP853, "vern7": VERN7}


def _linear(seed, n=3, scale=1.0):
    A = scale * np.random.default_rng(seed).normal(size=(n, n))
    return A, (lambda t, y: y @ A.T + np.sin(t)), np.random.default_rng(seed + 1).normal(size=n)


def _first_step(f, y0, method, h, jac=None):
    """The state after the first step of the adaptive loop, started with step h (loose tolerance: accepted)."""
    r = pbanim.solve(f, (0.0, 1.0), y0, method=method, h=h, rtol=1.0, atol=1.0, max_steps=1, jac=jac)
    assert r.nsteps == 1 and r.t[1] == pytest.approx(h, rel=1e-15)
    return r.y[:, 1]


# --------------------------------------------------------------------------------------------------
# A13: the lean loops against the readable formulas
# --------------------------------------------------------------------------------------------------
@settings(max_examples=30, deadline=None)
@given(seed=st.integers(0, 10**6), name=st.sampled_from(sorted(PAIRS)), h=st.floats(1e-3, 0.3))
def test_pair_loop_step_equals_readable_tableau_loop(seed, name, h):
    # ORACLES A13: one step of the buffered loop = explicit_rk_step's stage loop, to roundoff
    A, f, y0 = _linear(seed)
    lean = _first_step(f, y0, name, h)
    ref = explicit_rk_step(PAIRS[name], f, 0.0, y0, h)
    # measured ≤ 0.92ε (dopri5), 3.8ε (dop853), 5.2ε (vern7) over 200 random cases
    assert np.max(np.abs(lean - ref)) <= 32 * np.finfo(float).eps * (1.0 + np.max(np.abs(ref)))


def test_pair_loop_batch_step_equals_single_steps():
    # ORACLES A13: the buffers shaped (K, n) give fun the batch, and each row steps as alone (measured 2.2e-16)
    A, f, _ = _linear(3, n=2)
    Y0 = np.array([[1.0, 0.0], [0.3, -2.0]])
    for name in PAIRS:
        r = pbanim.solve(f, (0.0, 1.0), Y0, method=name, h=0.05, rtol=1.0, atol=1.0, max_steps=1)
        for k in range(2):
            ref = explicit_rk_step(PAIRS[name], f, 0.0, Y0[k], 0.05)
            assert np.max(np.abs(r.y[k, :, 1] - ref)) < 2e-15


@pytest.mark.parametrize("name", ["dopri5", "dop853", "vern7", "rodas4", "radau5"])
def test_outputs_are_not_the_reused_buffers(name):
    # ORACLES A13: the loops reuse buffers internally, but every returned state is its own array: each
    # column of y lies on y = e^(−t)·y₀ (an aliased buffer would repeat the last state); and fun is given a
    # fresh array at every call, so a fun that keeps its y (a student's log) sees it unchanged afterwards
    kept, copies = [], []

    def f(t, y):
        kept.append(y)
        copies.append(np.array(y, copy=True))
        return -y

    r = pbanim.solve(f, (0.0, 4.0), [1.0, 2.0], method=name, rtol=1e-8, atol=1e-10, jac=lambda t, y: -np.eye(2))
    exact = np.exp(-r.t) * np.array([[1.0], [2.0]])
    assert r.y.shape[1] >= 10 and np.max(np.abs(r.y - exact)) < 1e-8   # measured ≤ 1.7e-9 (dopri5)
    assert len({float(v) for v in r.y[0]}) == r.y.shape[1]
    assert len(kept) > 20 and all(np.array_equal(a, b) for a, b in zip(kept, copies))


@settings(max_examples=20, deadline=None)
@given(seed=st.integers(0, 10**6), h=st.floats(1e-3, 0.2))
def test_rodas4_loop_step_equals_readable_step(seed, h):
    # ORACLES A13: the buffered RODAS4 loop = rodas4_step (the readable stage loop), to roundoff
    A, f, y0 = _linear(seed)
    jac = lambda t, y: A  # noqa: E731
    lean = _first_step(f, y0, "rodas4", h, jac)
    ref = rodas4_step(f, 0.0, y0, h, jac=jac)
    # measured 0 (the same sums in the same order) over 200 random cases
    assert np.max(np.abs(lean - ref)) <= 16 * np.finfo(float).eps * (1.0 + np.max(np.abs(ref)))


@settings(max_examples=20, deadline=None)
@given(seed=st.integers(0, 10**6), h=st.floats(1e-3, 0.5), stiff=st.sampled_from([1.0, 1e4]))
def test_radau_small_path_step_equals_readable_step(seed, h, stiff):
    # ORACLES A13: on a linear f Newton is exact after one iteration, so the 3n × 3n inverse path and
    # radau5_step (real + complex solves, Newton to 1e-13) give the same collocation solution
    A = -stiff * np.eye(3) + np.random.default_rng(seed).normal(size=(3, 3))
    f = lambda t, y: A @ y  # noqa: E731
    y0 = np.array([1.0, -0.5, 0.25])
    lean = _first_step(f, y0, "radau5", h, lambda t, y: A)
    ref = radau5_step(f, 0.0, y0, h, jac=lambda t, y: A)
    assert np.max(np.abs(lean - ref)) <= 1e-14 * (1.0 + np.max(np.abs(ref)))   # measured ≤ 8.9e-16 (400 cases)


@settings(max_examples=30, deadline=None)
@given(seed=st.integers(0, 10**6), n=st.integers(1, 5), hd=st.floats(1e-4, 10.0), sign=st.sampled_from([1, -1]))
def test_block_inverse_is_the_real_and_the_complex_solve(seed, n, hd, sign):
    # ORACLES A13: block_inverse = diag((γ/h I − J)⁻¹, real form of ((α − iβ)/h I − J)⁻¹), and the adaptive
    # loop's Kronecker form (Λ ⊗ I)/h − I₃ ⊗ J is the same matrix
    rng = np.random.default_rng(seed)
    J = rng.normal(size=(n, n))
    hd = sign * hd
    Minv = block_inverse(hd, J)
    g, a, b = LAM[0, 0], LAM[1, 1], LAM[1, 2]
    I = np.eye(n)
    r0, r1, r2 = rng.normal(size=(3, n))
    x = Minv @ np.concatenate([r0, r1, r2])
    ref0 = np.linalg.solve(g / hd * I - J, r0)
    ref12 = np.linalg.solve(complex(a, -b) / hd * I - J, r1 + 1j * r2)
    M = np.kron(LAM, I) / hd - np.kron(np.eye(3), J)
    scale = np.linalg.cond(M) * np.finfo(float).eps * (1 + np.max(np.abs(x)))
    assert np.max(np.abs(x[:n] - ref0)) <= 100 * scale
    assert np.max(np.abs(x[n:2 * n] - ref12.real)) <= 100 * scale
    assert np.max(np.abs(x[2 * n:] - ref12.imag)) <= 100 * scale
    assert np.max(np.abs(M @ Minv - np.eye(3 * n))) <= 100 * np.linalg.cond(M) * np.finfo(float).eps


def test_radau_small_path_equals_generic_path():
    # ORACLES A13: a sparse J takes the generic path (one real and one complex LU); the same run with a dense J
    # takes the 3n × 3n inverse: the steps and the result agree to roundoff
    p = van_der_pol(100.0)
    dense = pbanim.solve(p.rhs, (0.0, 50.0), p.y0, method="radau5", rtol=1e-7, atol=1e-9, jac=p.jac)
    sparse = pbanim.solve(p.rhs, (0.0, 50.0), p.y0, method="radau5", rtol=1e-7, atol=1e-9,
                          jac=lambda t, y: sp.csr_matrix(p.jac(t, y)))
    assert dense.success and sparse.success
    assert dense.nsteps == sparse.nsteps                              # measured 73 and 73
    assert np.max(np.abs(dense.y[:, -1] - sparse.y[:, -1])) < 1e-14   # measured 1.8e-15 (|y| = 1.6)


def test_block_inverse_checks_its_arguments():
    # ORACLES A13: bad steps and matrices are refused by name
    with pytest.raises(InvalidInput, match="hd must be a finite nonzero step, got 0.0"):
        block_inverse(0.0, np.eye(2))
    with pytest.raises(InvalidInput, match=r"J must be a square \(n, n\) matrix, got shape \(2, 3\)"):
        block_inverse(0.1, np.ones((2, 3)))
    with pytest.raises(InvalidInput, match="J must be finite"):
        block_inverse(0.1, np.array([[np.nan]]))


# --------------------------------------------------------------------------------------------------
# A14: the work-precision floor
# --------------------------------------------------------------------------------------------------
def _synthetic(n_pb, n_ivp, n_ode, t_f, over_pb, over_ivp, over_ode, p=8.0):
    """Sweeps on exact power laws: error = (N₀/N)^p over four tolerances; time = N·(t_f + overhead)."""
    def pts(N0, over):
        return [(10.0 ** -k, (N0 / N) ** p, N * (t_f + over), N) for k, N in enumerate(N0 * 10 ** (np.arange(4) / 2))]
    return {"pbanim:dop853": pts(n_pb, over_pb), "pbanim:vern7": pts(2 * n_pb, over_pb),
            "pbanim:dopri5": pts(3 * n_pb, over_pb), "pbanim:dprkn6": pts(4 * n_pb, over_pb),
            "pbanim:dprkn8": pts(5 * n_pb, over_pb), "pbanim:dprkn12": pts(6 * n_pb, over_pb),
            "scipy:RK45": pts(3 * n_ivp, over_ivp),
            "scipy:DOP853": pts(n_ivp, over_ivp), "scipy:LSODA": pts(2 * n_ivp, over_ivp), "odeint": pts(n_ode, over_ode)}


def test_floor_columns_are_fewest_evaluations_times_one_call():
    # ORACLES A14: on power-law sweeps the interpolated N(level) is exact, so floor = N·t_f and
    # floor/ivp = N_pb·t_f / (N_ivp·(t_f + overhead_ivp)) in closed form
    from pbanim.bench.ode import LEVELS, _compare

    t_f, n_pb, n_ivp, n_ode = 2e-6, 100.0, 80.0, 70.0
    sw = _synthetic(n_pb, n_ivp, n_ode, t_f, 1e-6, 3e-6, 0.3e-6)
    (_, lv), worst, _ = _compare("kepler", sw, t_f)
    col = {name: i for i, name in enumerate(lv.header)}
    for row in lv.rows:
        L = row[col["level"]]
        N_pb = n_pb * L ** (-1 / 8)                       # error = (N₀/N)⁸ → N = N₀·error^(−1/8)
        assert row[col["nfev_pb"]] == pytest.approx(N_pb, rel=1e-9)
        assert row[col["floor_pb_s"]] == pytest.approx(t_f * N_pb, rel=1e-9)
        assert row[col["floor/ivp"]] == pytest.approx(n_pb * t_f / (n_ivp * 5e-6), rel=1e-9)
        assert row[col["floor/odeint"]] == pytest.approx(n_pb * t_f / (n_ode * 2.3e-6), rel=1e-9)
        assert row[col["over_pb_us"]] == pytest.approx(1.0, rel=1e-9)
    assert len(lv.rows) == len(LEVELS)
    # the overhead that would still meet the goals: 0.5·N_ivp·5 us = N_pb·(2 + x) → x = 0
    assert worst["allow_ivp"] == pytest.approx(0.5 * n_ivp * 5.0 / n_pb - 2.0, abs=1e-9)
    assert worst["allow_odeint"] == pytest.approx(n_ode * 2.3 / n_pb - 2.0, abs=1e-9)


@pytest.mark.parametrize("n_pb, expect_ivp, expect_ode", [(80.0, "reachable in principle", "reachable in principle"),
                                                          (200.0, "UNREACHABLE", "reachable in principle"),
                                                          (300.0, "UNREACHABLE", "UNREACHABLE")])
def test_floor_note_says_which_goal_is_out_of_reach(n_pb, expect_ivp, expect_ode):
    # ORACLES A14: floor/ivp > 0.5 (floor/odeint > 1) means no integrator overhead, however small, meets it
    from pbanim.bench.ode import _compare, floor_ratios

    sw = _synthetic(n_pb, 80.0, 100.0, 2e-6, 1e-6, 3e-6, 3e-6)
    _, worst, _ = _compare("kepler", sw, 2e-6)
    note = floor_ratios("kepler", worst)
    ivp, ode = note.split("; vs odeint")
    assert expect_ivp in ivp and expect_ode in ode
    # the budget in numpy calls: allow_ivp us / t_np
    if expect_ivp != "UNREACHABLE":
        budget = worst["allow_ivp"]
        assert f"{budget / 0.5:.1f} numpy calls of 0.50 us" in floor_ratios("kepler", worst, 0.5e-6)
    # closed forms: floor/ivp = n_pb·2 / (80·5), floor/odeint = n_pb·2 / (100·5)
    assert worst["floor_ivp"] == pytest.approx(n_pb * 2.0 / 400.0, rel=1e-9)
    assert worst["floor_odeint"] == pytest.approx(n_pb * 2.0 / 500.0, rel=1e-9)


def test_floor_helpers_check_their_arguments():
    # ORACLES A14: the floor helpers refuse bad input with a named error
    from pbanim.bench.ode import counting, f_time, floor_ratios, nfev_at_error, numpy_call_time

    with pytest.raises(InvalidInput, match="problem must be one of"):
        f_time("lorenz")
    with pytest.raises(InvalidInput, match="samples"):
        f_time("kepler", samples=0)
    with pytest.raises(InvalidInput, match="missing"):
        floor_ratios("kepler", {"floor_ivp": 1.0})
    with pytest.raises(InvalidInput, match="level"):
        nfev_at_error([(1e-2, 1e-3, 1.0, 10)], -1.0)
    with pytest.raises(InvalidInput, match="rhs must be a callable"):
        counting(3.0)
    with pytest.raises(InvalidInput, match="calls"):
        numpy_call_time(calls=0)


def test_counting_wrapper_counts_and_keeps_autonomy():
    # ORACLES A14: the wrapper every library calls: it counts, and it keeps rhs.autonomous (RODAS4 then skips ∂f/∂t)
    from pbanim.bench.ode import _problem, counting, f_time

    rhs = _problem("robertson")[0]
    f, count = counting(rhs)
    y = np.array([1.0, 0.0, 0.0])
    assert np.array_equal(f(0.0, y), rhs(0.0, y)) and count[0] == 1 and f.autonomous
    count[0] = 0
    r = pbanim.solve(f, (0.0, 1.0), y, method="rodas4", rtol=1e-6, atol=1e-12, jac=_problem("robertson")[1])
    assert r.nfev == count[0] and r.nfev == 6 * r.nsteps + 5 * r.nrejected + 2   # 5 stages + f(y₁) per step
    t = f_time("robertson", samples=5, blocks=3)
    assert np.isfinite(t) and t > 0


@settings(max_examples=30, deadline=None)
@given(n0=st.floats(10.0, 1e4), p=st.floats(2.0, 9.0), k=st.floats(0.05, 0.95))
def test_nfev_at_error_is_exact_on_power_laws(n0, p, k):
    # ORACLES A14: between two sweep points on error = (N₀/N)^p the log–log interpolation is exact
    from pbanim.bench.ode import nfev_at_error

    pts = [(1e-3, (n0 / N) ** p, 1e-6 * N, N) for N in (n0 * 2.0, n0 * 20.0)]
    level = pts[0][1] ** (1 - k) * pts[1][1] ** k
    assert nfev_at_error(pts, level) == pytest.approx(n0 * level ** (-1 / p), rel=1e-9)
    assert nfev_at_error(pts, pts[1][1] / 10) == np.inf                       # not reached


@pytest.mark.parametrize("name", ["dopri5", "dop853", "vern7", "rodas4", "radau5"])
def test_adaptive_methods_refuse_complex_states(name):
    # a complex y0 used to lose its imaginary part silently in the real stage arrays: now a named error
    with pytest.raises(InvalidInput, match=r"solve: y0 must be a float array .* got array\(\[1\.\+0\.j\]\)"):
        pbanim.solve(lambda t, y: 1j * y, (0.0, 1.0), np.array([1.0 + 0j]), method=name, rtol=1e-8, atol=1e-10)
    with pytest.raises(InvalidInput, match="complex128"):
        pbanim.solve(lambda t, y: 1j * y, (0.0, 1.0), np.array([1.0]), method=name, rtol=1e-8, atol=1e-10)


@settings(max_examples=30, deadline=None)
@given(seed=st.integers(0, 10**6), complex_shift=st.booleans(), n=st.sampled_from([2, 3, 5]))
def test_shifted_solve_equals_numpy(seed, complex_shift, n):
    # ORACLES A13: (σI − J)⁻¹ r by the 2 × 2 closed form (and the general path) equals numpy's solve
    from pbanim.ode.implicit import factor
    rng = np.random.default_rng(seed)
    J, r = rng.normal(size=(n, n)), rng.normal(size=n)
    sigma = complex(rng.uniform(1.0, 3.0), rng.uniform(-1.0, 1.0)) if complex_shift else rng.uniform(1.0, 3.0)
    M = sigma * np.eye(n) - J
    ref = np.linalg.solve(M, r)
    # measured ≤ 4e-16 relative; bound 1e3 κ(M) ε
    assert np.max(np.abs(factor(sigma, J)(r) - ref)) <= 1e3 * np.linalg.cond(M) * np.finfo(float).eps * (
        1.0 + np.max(np.abs(ref)))
    with pytest.raises(np.linalg.LinAlgError):
        factor(1.0, np.eye(2))                              # σI − J = 0: singular, said so
