"""The weighted control QP on its lean path equals the readable one (ORACLES F23).

:class:`pbanim.control.qp_lean.LeanQP` builds the QP of :meth:`QPController.solve` into arrays laid out once
per contact set and calls ProxQP once; the readable path builds, scales and solves the same QP. Both answers
are ProxQP's to its tolerance eps_abs = 1e-9 in the scaled unknowns x̃ = D⁻¹ x (accelerations in their units,
torques and forces over M g): the tolerance here is 1e3 eps_abs in those units (measured over these states: 2.3e-8 M g
on τ, 2.5e-8 M g on f, 2e-14 relative on q̈), and the status and the active contacts are the same. Where ProxQP reports a feasible QP primal infeasible (its
false certificate, ORACLES F21/F22) the lean path's answer from the previous active set is checked against the
readable QP's own matrices.
"""

import numpy as np
import pytest

from pbanim.articulated.planar import PlanarKernel
from pbanim.articulated.planar_lean import LeanPlanarStep
from pbanim.articulated.planar_step import PlanarContactStep, PlanarGround
from pbanim.control.biped import BIPED_JOINTS, biped_contact_points, planar_biped
from pbanim.control.qp import QPController
from pbanim.control.qp_balance import balance_tasks, crouched_state
from pbanim.control.qp_lean import LeanQP

pytest.importorskip("proxsuite")

TREE = planar_biped()
KERNEL = PlanarKernel(TREE)
POINTS = biped_contact_points(TREE)
EPS_ABS = 1e-9


def _pair(ground, **kw):
    q0, _ = crouched_state(KERNEL, 0.3)
    posture = {nm: float(q0[i]) for nm, i in BIPED_JOINTS.items() if i >= 2}
    ctrl = QPController(KERNEL, POINTS, ground, balance_tasks(KERNEL.centre_of_mass(q0), posture),
                        torque_limits=300.0, **kw)
    lean = LeanPlanarStep(PlanarContactStep(KERNEL, POINTS, ground))
    return q0, ctrl, LeanQP(ctrl, lean), lean


@pytest.mark.parametrize("limits", [None, {"torso": (-0.05, 0.05)}])
def test_lean_qp_equals_the_readable_qp(limits):
    # ORACLES F23: 40 states near the stance (random speeds, a foot lifted or tilted now and then): the same
    # status and contacts, answers within 1e3 eps_abs of each other in the solver's scaled units
    ground = PlanarGround(0.0, 0.9)
    q0, ctrl, lq, lean = _pair(ground, joint_limits=limits)
    assert lq.supported
    f_scale = ctrl.f_scale
    rng = np.random.default_rng(3)
    seen = set()
    for _ in range(40):
        q = q0 + 0.02 * rng.standard_normal(KERNEL.nv) * (rng.random() < 0.5)
        qd = 0.3 * rng.standard_normal(KERNEL.nv)
        kin = lean.kinematics(q)
        a = lq.solve(q, qd, kin + (lean.com_jacobians(kin[2], kin[3]),))
        b = ctrl.solve(q, qd)
        assert np.array_equal(a.active, b.active)
        seen.add((a.status, int(a.active.sum())))
        if not b.success and a.success:
            # ProxQP's false PRIMAL_INFEASIBLE (ORACLES F21, F22): the lean answer, from the active set, is checked
            # here against the readable QP's own matrices, the feasible answer ProxQP missed
            assert "PRIMAL_INFEASIBLE" in b.message and a.solver_status == ["ACTIVE_SET_CERTIFIED"]
            P = ctrl.build(q, qd)
            x = np.concatenate([a.qdd, a.tau[ctrl.actuated], a.forces[a.active].ravel()])
            assert np.abs(P["Aeq"] @ x - P["beq"]).max() <= 1e-9 * f_scale and (P["G"] @ x).max() <= 1e-9 * f_scale
            assert np.all(P["lb"] - 1e-9 <= x) and np.all(x <= P["ub"] + 1e-9) and a.kkt <= 1e-12
            continue
        assert a.status == b.status
        if not b.success:
            continue
        tol = 1e3 * EPS_ABS
        assert np.abs(a.tau - b.tau).max() <= tol * f_scale
        assert np.abs(a.forces - b.forces).max() <= tol * f_scale
        assert np.abs(a.qdd - b.qdd).max() <= tol * (1.0 + np.abs(b.qdd).max())
        for g in b.residuals:
            assert a.residuals[g] <= a.tolerances[g] and a.tolerances[g] == pytest.approx(b.tolerances[g], rel=1e-9)
        for name, e in b.task_errors.items():
            assert abs(a.task_errors[name] - e) <= tol * (1.0 + e) * 10
    assert len(seen) >= 2                                 # more than one contact set or status was met


def test_prioritized_and_other_backends_go_to_the_readable_path():
    # ORACLES F23: what the lean path does not handle is answered by QPController.solve itself
    ground = PlanarGround(0.0, 0.9)
    q0, ctrl, lq, lean = _pair(ground, mode="prioritized")
    assert not lq.supported
    qd = np.zeros(KERNEL.nv)
    kin = lean.kinematics(q0)
    a = lq.solve(q0, qd, kin + (lean.com_jacobians(kin[2], kin[3]),))
    b = ctrl.solve(q0, qd)
    assert a.status == b.status and np.array_equal(a.tau, b.tau)
