"""The control family's goal step is a ProxQP solve of the readable QP on the lean path (ORACLES F27, F23).

``pbanim bench control``'s goal ``control-qp-step-proxsuite`` times one QP control step of the standing biped as a
run takes it (:func:`pbanim.control.qp_balance.simulate_balance` solves on :class:`~pbanim.control.qp_lean.LeanQP`
by default) with ProxQP called at every step (:func:`pbanim.bench._qp.lean_proxqp_step`). These tests hold the
step to that: every call is answered by ProxQP (never by the last step's active set), the answer is the readable
:meth:`QPController.solve`'s to F23's tolerance (1e3 eps_abs in the scaled unknowns: τ and f within 1e-6 M g,
q̈ within 1e-6 (1 + |q̈|)), and the table the goal is read from prints it so. Speed is measured by the benchmark,
never asserted here.
"""

import numpy as np
import pytest

from pbanim.bench._qp import lean_proxqp_step, qp_step_goal, standing_controller

pytest.importorskip("proxsuite")

TOL = 1e-6          # ORACLES F23: 1e3 eps_abs (eps_abs = 1e-9) in the scaled unknowns, forces over M g


def _close(a, b, Mg):
    assert a.status == b.status and np.array_equal(a.active, b.active), (a.status, b.status, a.active, b.active)
    assert np.abs(a.tau - b.tau).max() <= TOL * Mg, np.abs(a.tau - b.tau).max() / Mg
    assert np.abs(a.forces - b.forces).max() <= TOL * Mg, np.abs(a.forces - b.forces).max() / Mg
    assert np.abs(a.qdd - b.qdd).max() <= TOL * (1.0 + np.abs(b.qdd).max())


def test_every_goal_step_is_a_proxqp_solve_equal_to_the_readable_step():
    # ORACLES F27: called again at the same state (where the last answer's active set certifies at once) the
    # goal's step still asks ProxQP; the same call without the drop is answered by the active set, so the drop
    # is what makes the step a ProxQP solve
    ctrl, q, qd = standing_controller()
    step, Mg = lean_proxqp_step(ctrl), ctrl.f_scale
    readable = ctrl.solve(q, qd)
    for _ in range(3):
        r = step(q, qd)
        assert r.solver_status == ["PROXQP_SOLVED"] and r.iterations > 0, (r.solver_status, r.iterations)
        _close(r, readable, Mg)
    shortcut = step(q, qd, proxqp=False)
    assert shortcut.solver_status == ["ACTIVE_SET_CERTIFIED"] and shortcut.iterations == 0
    _close(shortcut, readable, Mg)


def test_the_goal_step_equals_the_readable_step_near_the_stance():
    # ORACLES F23 (with ProxQP on both sides): states near the bench's stance, random speeds, one foot's heel
    # lifting (fewer contacts: another layout of the QP); each answer ProxQP's and the readable one's (measured
    # ≤ 5.4e-9 M g on τ, ≤ 1.5e-13 on q̈)
    ctrl, q0, qd0 = standing_controller()
    step, Mg = lean_proxqp_step(ctrl), ctrl.f_scale
    rng = np.random.default_rng(7)
    contacts = set()
    for k in range(12):
        q = q0 + 0.02 * rng.standard_normal(q0.size) * (np.arange(q0.size) >= 2)
        qd = qd0 + 0.3 * rng.standard_normal(q0.size)
        qd[:2] = 0.0
        if k % 3 == 2:
            q[1] += 0.004                         # the base lifted 4 mm: fewer points (none) within contact_tol
        readable = ctrl.solve(q, qd)
        r = step(q, qd)
        contacts.add(int(readable.active.sum()))
        if readable.status not in ("met", "compromise"):
            continue                              # LeanQP hands these to the readable path (F23)
        assert r.solver_status == ["PROXQP_SOLVED"], r.solver_status
        _close(r, readable, Mg)
    assert len(contacts) >= 2, contacts           # at least two contact sets (two layouts) were met


def test_the_goal_table_states_what_it_timed():
    # ORACLES F27: the goal's value is the lean ProxQP step's; its row says PROXQP_SOLVED and its difference from
    # the readable answer (≤ 1e-6 M g); the readable step, the bare ProxQP call and the step's counted floor (ProxQP
    # and more) are rows beside it
    table, value, note = qp_step_goal(quick=True)
    assert len(table.rows) == 5 and np.isfinite(value) and value > 0
    floor = table.rows[4]
    assert floor[0].startswith("floor of the goal's step") and floor[1] > table.rows[3][1] and "lower bound" in note
    lean = table.rows[1]
    assert "ProxQP every step" in lean[0] and lean[6].endswith("PROXQP_SOLVED") and 0 <= lean[7] <= TOL
    assert "ACTIVE_SET_CERTIFIED" in table.rows[2][6] and table.rows[0][7] == 0
    assert abs(lean[1] - 1e3 * value) <= 1e-9 * lean[1] and "ProxQP called every step" in note
    assert "readable" in table.rows[0][0] and "ProxQP's dense solve alone" in table.rows[3][0]
