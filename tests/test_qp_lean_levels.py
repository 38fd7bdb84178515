"""The prioritized control QP on its lean path equals the readable one (ORACLES F25).

:class:`pbanim.control.qp_lean_levels.LeanLevels` solves the levels of ``QPController._prioritized`` from the
lean build of :class:`~pbanim.control.qp_lean.LeanQP`: a task level whose tasks' value the equalities already fix
is not solved (every feasible point is its optimum, keep_level adds no row), the others by the same ProxQP call
from the same warm start, the last (strictly convex) level from the last step's active set. Each level's kept
value A_ℓ x* is unique, so the answers agree to the solver's tolerance eps_abs = 1e-9 in the scaled unknowns
x̃ = D⁻¹x (forces and torques over M g). Where ProxQP does not certify a level at eps_abs = 1e-9 (the readable
status "unconverged") the two paths can differ by more than that; there they are compared with the readable path
at eps_abs = 1e-11, which certifies.
"""

from dataclasses import replace

import numpy as np
import pytest

from pbanim.articulated.planar import PlanarKernel
from pbanim.articulated.planar_lean import LeanPlanarStep
from pbanim.articulated.planar_step import PlanarContactStep, PlanarGround
from pbanim.control.biped import BIPED_JOINTS, biped_contact_points, planar_biped
from pbanim.control.qp import KKT_TOL, QPController
from pbanim.control.qp_balance import BALANCE_FIRST, balance_tasks, crouched_state, simulate_balance
from pbanim.control.qp_lean_levels import LeanLevels
from pbanim.control.qp_solve import keep_level
from pbanim.control.qp_tasks import Task

pytest.importorskip("proxsuite")

TREE = planar_biped()
KERNEL = PlanarKernel(TREE)
POINTS = biped_contact_points(TREE)
SOLES = ("left heel", "left toe", "right heel", "right toe")


def _balance_first(**kw):
    """The controller of simulate_balance(**BALANCE_FIRST): the soles' point tasks on top, then the centre of mass
    and the angular momentum, then the posture; the torso within ±0.3 rad."""
    q0, _ = crouched_state(KERNEL, 0.3)
    posture = {nm: float(q0[i]) for nm, i in BIPED_JOINTS.items() if i >= 2}
    soles = KERNEL.points(q0, [lk for lk, _ in POINTS], [p for _, p in POINTS])
    tasks = balance_tasks(KERNEL.centre_of_mass(q0), posture, momentum_priority=0, momentum_weight=1e-2)
    tasks = [Task("point", target=tuple(p[:2]), kp=100.0, kd=20.0, priority=0, name=nm, link=int(lk),
                  local=tuple(loc)) for nm, (lk, loc), p in zip(SOLES, POINTS, soles)] \
        + [replace(t, priority=t.priority + 1) for t in tasks]
    ground = PlanarGround(0.0, 0.9)
    make = lambda **extra: QPController(KERNEL, POINTS, ground, tasks, mode="prioritized",  # noqa: E731
                                        torque_limits=300.0, joint_limits={"torso": (-0.3, 0.3)}, **kw, **extra)
    ctrl = make()
    lean = LeanPlanarStep(PlanarContactStep(KERNEL, POINTS, ground))
    return q0, ctrl, make(eps_abs=1e-11, max_iter=20000), LeanLevels(ctrl, lean), lean


def test_lean_levels_equal_the_readable_levels():
    # ORACLES F25: 40 states near the stance (random speeds, a foot lifted or tilted now and then): the same active
    # contacts; where the readable path (at eps_abs 1e-9, and at 1e-11) certifies its answer, the same status and
    # the answers within 1e3 eps_abs (in the scaled unknowns: τ, f over M g; q̈ relative; measured ≤ 5.1e-9 M g);
    # an answer neither certifies is "unconverged" on both, and the same
    q0, ctrl, tight, lq, lean = _balance_first()
    assert lq.supported
    f_scale, tol = ctrl.f_scale, 1e3 * 1e-9
    rng = np.random.default_rng(5)
    lean_answers, fixed = 0, 0
    for _ in range(40):
        q = q0 + 0.02 * rng.standard_normal(KERNEL.nv) * (rng.random() < 0.5)
        qd = 0.3 * rng.standard_normal(KERNEL.nv)
        kin = lean.kinematics(q)
        a = lq.solve(q, qd, kin + (lean.com_jacobians(kin[2], kin[3]),))
        b, c = ctrl.solve(q, qd), tight.solve(q, qd)
        assert np.array_equal(a.active, b.active)
        lean_answers += a.solver_status != b.solver_status
        fixed += "level fixed by the constraints" in a.solver_status
        refs = [r for r in (b, c) if r.status in ("met", "compromise")]      # the certified readable answers
        if a.status not in ("met", "compromise"):
            # a level ProxQP does not certify, or whose answer is not feasible (then the level above is kept), as on
            # the readable path: "unconverged", the constraints holding, the same answer as the readable one
            assert a.status == b.status == "unconverged" and all(a.residuals[g] <= a.tolerances[g] for g in a.residuals)
            assert np.abs(a.tau - b.tau).max() <= tol * f_scale and np.abs(a.forces - b.forces).max() <= tol * f_scale
            continue
        assert a.kkt <= KKT_TOL and all(a.residuals[g] <= a.tolerances[g] for g in a.residuals)
        for ref in refs:
            assert a.status == ref.status
            assert np.abs(a.tau - ref.tau).max() <= tol * f_scale
            assert np.abs(a.forces - ref.forces).max() <= tol * f_scale
            assert np.abs(a.qdd - ref.qdd).max() <= tol * (1.0 + np.abs(ref.qdd).max())
            for name, e in ref.task_errors.items():
                assert abs(a.task_errors[name] - e) <= tol * (1.0 + e) * 10
    assert lean_answers >= 30 and fixed >= 20           # the lean path answered, and skipped fixed levels


def test_a_level_the_constraints_fix_adds_no_row():
    # ORACLES F25: both feet flat and held, the soles' point tasks are combinations of the kept contact rows:
    # keep_level adds nothing (the level's objective is the same at every feasible point), and the lean path says so
    q0, ctrl, _, lq, lean = _balance_first()
    qd = np.zeros(KERNEL.nv)
    P = ctrl.build(q0, qd)
    top = np.vstack([A for t, A, _ in P["tasks"] if t.priority == 0])
    Aeq, _ = keep_level(P["Aeq"], P["beq"], top, np.zeros(P["N"]))
    assert Aeq.shape == P["Aeq"].shape
    kin = lean.kinematics(q0)
    a = lq.solve(q0, qd, kin + (lean.com_jacobians(kin[2], kin[3]),))
    assert a.solver_status[0] == "level fixed by the constraints"
    assert a.task_errors["left toe"] <= 1e-9 and a.task_errors["right heel"] <= 1e-9   # and met


@pytest.mark.parametrize("push", [20.0, -24.0])
def test_balance_runs_on_the_lean_levels_equal_the_readable_runs(push):
    # ORACLES F25: the figure's prioritized runs (BALANCE_FIRST) on the lean levels and on the readable ones: the
    # same outcome, the centre of mass within 1e-5 m and the joint angles within 2e-2 rad (measured over 2.5 s:
    # 2e-10 m, 8e-9 rad at 20 N s; 4.9e-6 m, 6.6e-3 rad at −24 N s, where ProxQP leaves some steps uncertified:
    # the readable run at eps_abs 1e-9 differs from itself at 1e-11 by 7.6e-3 rad, the lean run at 1e-11 from
    # the readable at 1e-11 by 1.9e-8 rad)
    a = simulate_balance(push, 1.5, **BALANCE_FIRST)
    b = simulate_balance(push, 1.5, lean=False, **BALANCE_FIRST)
    assert a.outcome == b.outcome == "balanced" and np.array_equal(a.t, b.t)
    assert np.abs(a.com - b.com).max() <= 1e-5
    assert np.abs(a.q - b.q).max() <= 2e-2
    assert np.abs(a.q[-1] - a.q[0]).max() > 1e-2        # the push moved the biped
