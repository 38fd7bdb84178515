"""The 3-D biped under the QP controller: biases, equilibrium, a push, a scripted step (ORACLES F21, F10, F15)."""

import numpy as np
import pytest

from pbanim.articulated.dynamics import bias_forces, crba
from pbanim.control.biped3d import BIPED3D_JOINTS, standing_state3d
from pbanim.control.qp import QPController
from pbanim.control.qp_biped3d import TRUNK, QPBiped3D, _centroidal3d, _link_motion, _point_bias
from pbanim.control.qp_biped3d_run import crouched_state3d, simulate_stand3d, simulate_step, stand_tasks
from pbanim.control.qp_tasks import InvalidTask, Task
from pbanim.errors import InvalidInput

pytest.importorskip("proxsuite")

G = 9.81


def _random_state(seed=0):
    rng = np.random.default_rng(seed)
    q, _ = standing_state3d()
    q[7:] = 0.4 * rng.normal(size=12)
    q[:4] = rng.normal(size=4)
    q[:4] /= np.linalg.norm(q[:4])
    return q, rng.normal(size=18)


def test_biases_and_bias_forces_against_rnea_and_differences():
    # ORACLES F21: the accelerations at q̈ = 0 (points, centre of mass, L̇) equal central differences of the
    # velocities along the motion (error O(ε²): ε = 1e-5 gives ~1e-9), C equals RNEA's ID(q, q̇, 0) to roundoff
    ctrl = QPBiped3D([])
    w = ctrl.world
    q, qd = _random_state()
    kin = w.kinematics(q)
    V, A = _link_motion(w, kin, qd, ctrl.owner)
    cf = _centroidal3d(w, kin, qd, V, A)
    C = bias_forces(ctrl.kernel, q, qd)
    assert np.abs(cf.C - C).max() <= 1e-12 * np.abs(C).max()
    assert np.abs(w.mass_matrix(kin) - crba(ctrl.kernel, q)).max() <= 1e-12 * np.abs(crba(ctrl.kernel, q)).max()
    P, J = w.point_jacobians(kin, ctrl.links, ctrl.local)
    a = _point_bias(kin, V, A, ctrl.links, P)

    def along(qq):
        k = w.kinematics(qq)
        V2, A2 = _link_motion(w, k, qd, ctrl.owner)
        c2 = _centroidal3d(w, k, qd, V2, A2)
        return w.point_jacobians(k, ctrl.links, ctrl.local)[1] @ qd, c2.vcom, c2.L

    eps = 1e-5
    up, down = along(w.integrate(q, qd, eps)), along(w.integrate(q, -qd, eps))
    for fd, an in zip([(u - d) / (2 * eps) for u, d in zip(up, down)], (a, cf.bias, cf.L_bias)):
        assert np.abs(fd - an).max() <= 1e-6 * (1.0 + np.abs(an).max())
    # L = A_L q̇ by its definition Σ mᵢ (cᵢ − c) × ċᵢ + Īᵢ ωᵢ
    vc = (J_c := w.point_jacobians(kin, np.arange(w.tree.n), np.einsum("nji,nj->ni", kin["R"], kin["c"] - kin["o"]))[1]) @ qd
    Iw = kin["R"] @ w.inertia @ kin["R"].transpose(0, 2, 1)
    L = (w.mass[:, None] * np.cross(kin["c"] - cf.com, vc)).sum(0) + np.einsum("nij,nj->i", Iw, V[:, :3])
    assert J_c.shape[0] == w.tree.n and np.allclose(cf.L, L, rtol=1e-12, atol=1e-12 * np.abs(L).max())


@pytest.mark.parametrize("mode", ["weighted", "prioritized"])
def test_one_qp_obeys_newton_euler_cones_and_limits(mode):
    # ORACLES F10, F21: at a moving state on both feet, the answer keeps H q̈ + C = Sᵀτ + J_cᵀ f, the cones and
    # the limits, and M c̈ = Σ f + M g, L̇ = Σ (p − c) × f for the whole body
    ctrl = QPBiped3D([], mode=mode, torque_limits=300.0, joint_limits={"left_knee": (-2.0, -0.05)})
    q, qd = crouched_state3d(ctrl)
    kin = ctrl.world.kinematics(q)
    com = ctrl.world.mass @ kin["c"] / ctrl.world.mass.sum()
    posture = {nm: float(q[v + 1]) for nm, v in BIPED3D_JOINTS.items()}
    ctrl.tasks = ctrl._checked(stand_tasks(com + np.array([0.02, 0.01, -0.01]), posture))
    qd = 0.05 * np.random.default_rng(1).normal(size=18)
    res = ctrl.solve(q, qd, raise_on_failure=True)
    assert res.active.sum() == 8
    for g in ("dynamics", "contact", "cone", "limits"):
        assert res.residuals[g] <= res.tolerances[g]
    assert res.newton_euler[0] <= 1e-6 * ctrl.f_scale and res.newton_euler[1] <= 1e-6 * ctrl.f_scale
    assert np.all(res.forces[:, 0] >= -1e-6 * ctrl.f_scale)
    assert np.all(np.abs(res.forces[:, 1:]) <= ctrl.ground.mu * res.forces[:, :1] + 1e-6 * ctrl.f_scale)


def test_standing_carries_the_weight_and_keeps_still():
    # ORACLES F21: at equilibrium Σ f_z = M g, the centre of mass still above the middle of the soles
    r = simulate_stand3d(t_end=0.5, h=8e-3)
    assert r.outcome == "stood"
    Mg = r.mass * G
    assert np.abs(r.forces[:, :, 0].sum(axis=1) - Mg).max() <= 1e-4 * Mg
    assert r.com_error(0.5) <= 1e-5
    assert np.abs(r.residuals).max() <= 1e-6 * Mg and np.abs(r.newton_euler).max() <= 1e-6 * Mg
    soles = r.extra["start_com"]
    assert np.abs(r.com[-1] - soles).max() <= 1e-5


@pytest.mark.parametrize("mode, push", [("weighted", (10.0, 0.0, 0.0)), ("prioritized", (0.0, 10.0, 0.0))])
def test_push_is_survived_and_the_com_returns(mode, push):
    # ORACLES F21: a forward push (weighted) and a lateral one (prioritized) of 10 N s at the torso are survived
    # (the largest pushes brought back within 1 cm by 1.5 s are measured in the oracle); here, 1 s: the push
    # moves the centre of mass ≥ 5 mm, and it is on its way back: down to half its excursion, still decreasing
    r = simulate_stand3d(push=push, t_end=1.0, h=8e-3, push_time=0.05, mode=mode)
    assert r.outcome == "stood", r.cause
    away = np.linalg.norm((r.com - r.com_target)[:, :2], axis=1)
    assert away.max() >= 5e-3 and away[-1] <= 0.5 * away.max()
    assert np.all(np.diff(away[r.t >= 0.7]) < 0)
    assert np.abs(r.newton_euler).max() <= 1e-6 * r.mass * G


def _check_step(outcome, cause, extra, com_error, com_target, residuals, newton_euler, mass):
    """The scripted step's checks (ORACLES F21): both soles flat at the end, length to 5 mm, sideways drift 1 cm,
    the centre of mass within 2 cm of its last target, every QP's residuals (dynamics, cone, limits in N;
    contact in m/s²) within 1e-6 of M g and of 1, Newton–Euler within 1e-6 M g."""
    assert outcome == "stepped", cause
    assert extra["corners"] == 8
    assert abs(extra["length"] - 0.2) <= 5e-3 and abs(extra["drift"]) <= 1e-2
    assert com_error <= 0.02 and np.allclose(com_target[-1], extra["start_com"] + [0.1, 0.0, 0.0], rtol=0, atol=1e-12)
    Mg = mass * G
    assert np.abs(residuals[:, [0, 2, 3]]).max() <= 1e-6 * Mg and np.abs(residuals[:, 1]).max() <= 1e-6
    assert np.abs(newton_euler).max() <= 1e-6 * Mg


def test_prioritized_scripted_step_lands_on_two_feet():
    # ORACLES F21: shift, lift, swing 0.2 m, land, shift back, prioritized (centre of mass; swing foot and trunk;
    # momentum and posture) on ProxQP alone (the QPs equilibrated, ProxQP's infeasibility threshold 1e-8: before,
    # it called feasible QPs of this step infeasible). Measured at h = 8 ms: 3.4 mm short, drift 4.6 mm
    r = simulate_step(length=0.2, h=8e-3, mode="prioritized")
    _check_step(r.outcome, r.cause, r.extra, r.com_error(0.1), r.com_target, r.residuals, r.newton_euler, r.mass)


def test_figure_qp_biped3d_step(figure_data):
    # ORACLES F21: the figure's step (weighted, quick mode h = 10 ms, on ProxQP alone) passes the step's checks
    # (measured 3.4 mm short, drift 0.7 mm); its key frames are in time order within the run
    d = figure_data("ch08_qp_biped3d_step")
    w = d["weighted"]
    _check_step(w["outcome"], w["cause"], w, w["com_error"], w["com_target"], w["residuals"], w["newton_euler"],
                w["mass"])
    assert np.all(np.diff(d["frames_t"]) > 0) and d["frames_t"][-1] <= w["t"][-1] + 1e-12


@pytest.mark.parametrize("options", [{}, {"equilibrate": True}, {"primal_inf": 1e-8},
                                     {"equilibrate": True, "primal_inf": 1e-8}])
def test_solver_options_keep_the_closed_form_answer(options):
    # ORACLES F21: equilibrated rows and ProxQP's tighter infeasibility threshold solve the same problem:
    # min ½|x|² s.t. 1000 x₁ + 2000 x₂ = 1000, x₃ = 0.5, x₁ + x₂ + x₃ ≤ 10, x₁ ≥ −1 gives x = (0.2, 0.4, 0.5)
    from pbanim.control.qp_solve import solve_qp
    x, status, _, kkt = solve_qp(np.eye(3), np.zeros(3), Aeq=np.array([[1e3, 2e3, 0.0], [0.0, 0.0, 1.0]]),
                                 beq=np.array([1e3, 0.5]), C=np.ones((1, 3)), l=np.array([-np.inf]), u=np.array([10.0]),
                                 lb=np.array([-1.0, -np.inf, -np.inf]), ub=np.full(3, np.inf),
                                 scale=np.array([1.0, 2.0, 1.0]), **options)
    assert "SOLVED" in status and kkt <= 1e-8
    assert np.abs(x - [0.2, 0.4, 0.5]).max() <= 1e-9


def test_walk_plan_alternates_and_ends_above_the_middle():
    # ORACLES F21: the walk's segments (no simulation): feet alternate left first, the first and last steps half a
    # stride, c̄ moves above each stance sole (inset toward the other foot) and ends above the final middle
    from pbanim.control.qp_biped3d_walk import _segments
    soles = {"left": np.array([0.0, 0.09, 0.0]), "right": np.array([0.0, -0.09, 0.0])}
    com0 = np.array([0.0, 0.0, 0.9])
    plan = [("left", 0.1), ("right", 0.2), ("left", 0.2), ("right", 0.1)]
    segs = _segments(plan, soles, com0, 0.02, (0.6, 0.4, 0.6, 0.6, 0.2))
    assert [sg[0] for sg in segs] == [0.6, 0.4, 0.6, 0.4, 0.6, 0.4, 0.6, 0.4, 0.6, 0.2]
    assert [sg[3] for sg in segs[1:8:2]] == plan
    # above the right sole (y −0.09 + 0.02), then the left one moved 0.1 (y 0.09 − 0.02), then the right moved 0.2 …
    assert np.allclose(segs[0][2], [0.0, -0.07, 0.9]) and np.allclose(segs[2][2], [0.1, 0.07, 0.9])
    assert np.allclose(segs[4][2], [0.2, -0.07, 0.9]) and np.allclose(segs[6][2], [0.3, 0.07, 0.9])
    assert np.allclose(segs[-1][1], [0.3, 0.0, 0.9]) and np.allclose(segs[-1][2], segs[-1][1])
    # every segment starts where the one before ended; a swing holds c̄
    assert all(np.array_equal(a[2], b[1]) for a, b in zip(segs, segs[1:]))
    assert all(np.array_equal(sg[1], sg[2]) for sg in segs[1:8:2])


def test_tasks_of_the_other_dimension_are_refused():
    # ORACLES F15: a 3-D task in the planar controller, a planar one in the 3-D controller, a bad trunk task
    with pytest.raises(InvalidTask, match="3-vector"):
        Task("com", target=(0.0, 1.0), dim=3)
    with pytest.raises(InvalidTask, match="2-D"):
        QPBiped3D([Task("com", target=(0.0, 1.0))])
    with pytest.raises(InvalidInput, match="trunk"):
        QPBiped3D([Task("posture", target={TRUNK[0]: 0.0, "left_knee": -0.3}, dim=3)])
    with pytest.raises(InvalidInput, match="joint_limits"):
        QPBiped3D([], joint_limits={"trunk_roll": (-0.1, 0.1)})
    from pbanim.control.biped import planar_biped, biped_contact_points
    from pbanim.articulated.planar import PlanarKernel
    k = PlanarKernel(planar_biped())
    with pytest.raises(InvalidTask, match="3-D"):
        QPController(k, biped_contact_points(k.tree), tasks=[Task("com", target=(0.0, 1.0, 0.9), dim=3)])
