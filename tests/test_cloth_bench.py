"""The helpers of ``pbanim bench cloth`` and the goal lines of ``pbanim bench ode``'s stiff rows (issue 29).

No timing is asserted here (speed goals live in the benchmarks): these tests check what the benchmark
computes — the runs' errors against the reference shrink, the banded odeint path equals solve_ivp, the
stability search finds the explicit limit — and that a goal bounded by CPython's per-call floor says so.
"""

import numpy as np

from pbanim.bench.cloth import _run, largest_stable_step, sheet
from pbanim.bench.ode import _floor_verdict


def test_banded_odeint_and_sparse_solvers_agree_on_the_sheet():
    # the interleaved banded Jacobian handed to odeint is the sparse one: all three solvers agree to tolerance
    cloth = sheet(4)
    a = _run(cloth, "scipy odeint", 1e-8, 0.02, 60.0)
    b = _run(cloth, "scipy Radau", 1e-8, 0.02, 60.0)
    c = _run(cloth, "scipy BDF", 1e-8, 0.02, 60.0)
    assert np.abs(a - b).max() < 1e-6 and np.abs(c - b).max() < 1e-6       # measured ~1e-9 m


def test_large_steps_error_falls_with_h():
    # ORACLES J3: implicit Euler, first order: a 4× smaller step, about 4× smaller error
    cloth = sheet(4)
    ref = _run(cloth, "scipy Radau", 1e-9, 0.02, 60.0)
    e1, e2 = (np.abs(_run(cloth, "large steps", h, 0.02, 60.0) - ref).max() for h in (0.02 / 2, 0.02 / 8))
    assert 2.5 < e1 / e2 < 6.0, (e1, e2)


def test_explicit_step_shrinks_with_stiffness_large_steps_do_not():
    h1, h2 = (largest_stable_step("symplectic Euler", k, 4) for k in (1e2, 1e4))
    assert h2 < h1 / 4                                                      # ∝ k^(−1/2): 10× here
    assert largest_stable_step("large steps", 1e4, 4) == 0.1


def test_ode_goal_lines_say_when_the_floor_makes_a_goal_unmeetable():
    assert "NOT MEETABLE in pure Python" in _floor_verdict(2.3, 0.5, "solve_ivp")
    assert "2.30×" in _floor_verdict(2.3, 0.5, "solve_ivp")
    assert "meetable in principle" in _floor_verdict(0.2, 0.5, "solve_ivp")
    assert _floor_verdict(float("nan"), 1.0, "odeint") == ""


def test_cg_tolerance_of_the_cost_rows_is_below_the_step_truncation_error():
    # ORACLES J3, J6: at the benchmark's CG tolerance the solve's error is a small fraction of the large
    # step's own truncation error (step doubling), with either preconditioner; a loose tolerance is not
    from pbanim.bench.cloth import CG_TOL, cg_error_vs_truncation
    for pc in ("jacobi", "multigrid"):
        ex, ev = cg_error_vs_truncation(12, CG_TOL, pc)
        assert ex < 0.2 and ev < 0.2, (pc, ex, ev)                 # measured ≤ 0.04 at N = 32
    assert max(cg_error_vs_truncation(12, 0.5, "jacobi")) > max(cg_error_vs_truncation(12, CG_TOL, "jacobi"))


def test_multigrid_needs_fewer_cg_iterations_than_jacobi_on_the_sheet():
    # ORACLES J6: the V-cycle preconditioner cuts the iterations of the cost rows (counts, not times)
    from pbanim.bench.cloth import step_costs
    jac, mg = step_costs((32,), 1, "jacobi")[32], step_costs((32,), 1, "multigrid")[32]
    assert mg[1] < jac[1] / 2, (mg[1], jac[1])                     # measured 5 vs 141 (l1-Jacobi smoothing: 67)


def test_richardson_reference_of_large_steps_is_converged_and_its_correction_bounds_its_error():
    # ORACLES J3 (the large step is first order with a smooth expansion): two levels of Richardson
    # extrapolation of large steps of T/12, T/24, T/48 (the N = 128 reference of the benchmark) land
    # orders of magnitude closer to scipy Radau at rtol 1e-10 than the finest large step, and the last
    # correction |R₂ − R₁| it prints is not smaller than its actual error
    from pbanim.bench.cloth import RICHARDSON, T_END, richardson
    cloth = sheet(6)
    ref = _run(cloth, "scipy Radau", 1e-10, T_END, 600.0)
    r2, gap = richardson(cloth)
    e2 = np.abs(r2 - ref).max()
    e1 = np.abs(_run(cloth, "large steps", T_END / RICHARDSON[-1], T_END, 600.0) - ref).max()
    assert e2 <= 1e-2 * e1, (e2, e1)                                # measured 2.1e-7 against 2.6e-4 m
    assert e2 <= gap, (e2, gap)                                     # measured 2.1e-7 ≤ 3.4e-6 m
