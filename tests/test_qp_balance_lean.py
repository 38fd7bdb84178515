"""The QP balance's fast paths: pushes branched from one stance, the lean contact step (ORACLES F22).

``simulate_balance_pushes`` equals the runs of ``simulate_balance`` one by one, and ``lean=True`` (the lean
planar contact step) equals ``lean=False`` (the readable one). The arithmetic is the same;
the tolerance is the run-to-run spread of the QP runs themselves (the same run in two processes differs by
~1e-7 m in c: ProxQP's and BLAS's results depend on memory alignment), far below a push's effect (a 1 N s
difference moves the centre of mass by millimetres).
"""

import numpy as np
import pytest

from pbanim.control.qp_balance import simulate_balance, simulate_balance_pushes

pytest.importorskip("proxsuite")

T_END, PUSH_TIME = 0.3, 0.1        # short runs: 150 steps, the push at step 50


def _close(a, b, tol=1e-9):
    assert a.outcome == b.outcome and a.end_time == b.end_time and a.push == b.push
    assert a.t.shape == b.t.shape and np.array_equal(a.t, b.t)
    assert np.abs(a.q - b.q).max() <= tol                       # m and rad
    assert np.abs(a.forces - b.forces).max() <= 1e3 * tol * a.forces.max()   # N, relative to the weight
    assert np.abs(a.sim_forces - b.sim_forces).max() <= 1e3 * tol * a.forces.max()


def test_lean_step_equals_the_readable_step():
    # ORACLES F22: the lean contact step takes the readable step's operations (the same run to the QP's spread)
    lean = simulate_balance(15.0, T_END, push_time=PUSH_TIME)
    readable = simulate_balance(15.0, T_END, push_time=PUSH_TIME, lean=False)
    _close(lean, readable)
    assert np.abs(lean.q[-1] - lean.q[0]).max() > 1e-3         # the push moved the biped (not a trivial run)


def test_branched_pushes_equal_the_runs_one_by_one():
    # ORACLES F22: each push continued from the shared stance is the run simulate_balance(P) gives; P = 0 too
    pushes = [-10.0, 0.0, 15.0]
    runs = simulate_balance_pushes(pushes, T_END, push_time=PUSH_TIME)
    assert [r.push for r in runs] == pushes
    for p, r in zip(pushes, runs):
        _close(r, simulate_balance(p, T_END, push_time=PUSH_TIME))
    assert not np.allclose(runs[0].q[-1], runs[2].q[-1])       # different pushes, different runs


def test_a_push_after_the_end_is_every_run():
    # no push lands before t_end: every run is the unpushed stance, labelled with its push
    runs = simulate_balance_pushes([5.0, -5.0], 0.1, push_time=0.5)
    assert [r.push for r in runs] == [5.0, -5.0]
    _close(runs[0], simulate_balance(5.0, 0.1, push_time=0.5))
    assert np.array_equal(runs[0].q, runs[1].q)
