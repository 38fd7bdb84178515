"""The 3-D biped standing, pushed and stepping under the QP controller (chapter 08, part 2).

**Standing.** The biped stands on both feet, knees bent by κ (hip pitch a, knee −κ, ankle pitch κ − a: the
feet flat, the trunk upright; the lean a puts the centre of mass above the middle of the support polygon,
found by bisection as :func:`~pbanim.control.qp_balance.crouched_state` does in the plane). The tasks
(:func:`stand_tasks`):

    centre of mass     c̈* = k_p (c̄ − c) − k_d ċ            (3 rows; priority 0)
    angular momentum   L̇* = −k_L L                           (3 rows; priority 1)
    trunk              ω̇₀* = k_R log(R̄ R₀ᵀ) − k_R' ω₀        (upright, heading ψ̄; priority 1)
    posture            θ̈* = k_q (θ̄ − θ) − k_q' θ̇            (the standing pose; priority 2)

At equilibrium (q̇ = 0, c = c̄) Newton's law leaves Σ f = −M g: the vertical contact force carries the
weight M g, and the centre of the pressure lies under c, inside the support polygon (ORACLES F21).
A push P (N s, a horizontal 3-vector) at ``push_time`` hits the torso's centre: Δq̇ = H⁻¹ J_cᵀ P.

**Stepping** (:func:`~pbanim.control.qp_biped3d_walk.simulate_step`, written in :mod:`.qp_biped3d_walk` with the
walk of a few steps): the same tasks and a script of four phases of length T each,

1. shift: c̄(t) moves from the middle of the feet to above the stance (right) foot's sole centre;
2. lift and swing: the left foot's four contact rows are released (``contacts=``: the right foot's only),
   two point tasks (the left sole's heel and toe centres) follow p̄(t) = p₀ + s(t) (ℓ, 0, 0) +
   b(t) (0, 0, z_c), s the minimum-jerk ramp 10s³ − 15s⁴ + 6s⁵, b = 16 s²(1 − s)² the lift;
   they end 2 mm into the ground (a contact is taken, not hovered over);
3. land and shift back: every corner whose gap is within ``contact_tol`` is a contact again; c̄ moves to
   the middle of the new support polygon; each sole on the ground is held flat where it came down by its
   heel and toe tasks (``press``, :mod:`.qp_biped3d_walk`);
4. hold: double support, the step's length is the left sole's displacement (ℓ to a stated tolerance).

Trajectories feed their velocity and acceleration forward (the tasks' ``velocity``, ``acceleration``).

**Levels of the prioritized step** (de Lasa, Mordatch & Hertzmann 2010: constraints, then balance, then the
end effectors, then the rest): the contacts and the equations of motion are the QP's equalities; level 0 the
centre of mass; level 1 the swing foot's heel and toe and the trunk's orientation; level 2 the damping of L
and the posture (:data:`STEP_LEVELS`). Measured at h = 8 ms (swing foot at level 1; the levels of c, L,
trunk, posture; the landed sole held at its planned place): (0, 2, 1, 2) lands 0.1966 m, 8 corners; (0, 0, 2, 2), the momentum with the centre of mass,
lands on 6 corners only (L̇ = −k L leaves the leg too little freedom to swing); (0, 2, 2, 2) lands 0.2165 m
with QP residuals of 2e-4 M g. The weighted step uses the same tasks with weights (``weights`` of
:func:`stand_tasks`, ``swing_weight``).

The simulation is the 3-D contact step of chapter 08 (:class:`~pbanim.control.biped3d_step.WorldStep`:
Coulomb friction, four sole corners a foot), the QP's torques held for ``control_every`` steps. A fall (the
pelvis below half its standing height, or the trunk tilted more than 1 rad) or an infeasible QP ends the
run, said so in the outcome.

Notation: c, ċ centre of mass; c̄ its target; L angular momentum about c; R₀ the trunk's orientation; M g
the weight; ℓ the step length; z_c the swing clearance; T a phase's duration.
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np

from ..contracts import Array, Choice, Int, Obj, Real, Text, contract, unchecked
from ..errors import SimulationDiverged, check_number
from .biped3d import BIPED3D_JOINTS, biped3d_contact_points, standing_state3d
from .biped3d_step import WorldStep
from .qp import MODES, InfeasibleControl
from .qp_biped3d import TRUNK, QPBiped3D
from .qp_tasks import InvalidTask, Task
from .specs import Mapping, named

_GAIN = named(InvalidTask, Real(ge=0))

# joint ranges (rad, ours: a human's ranges rounded; the knee short of straight), inequalities of every QP: near a
# limit they brake the joint (θ̇ ≤ (θ_max − θ)/T), which also keeps a prioritized level from whipping a free leg
JOINT_LIMITS = {f"{s}_{j}": r for s in ("left", "right") for j, r in
                (("hip_z", (-0.6, 0.6)), ("hip_x", (-0.6, 0.6)), ("hip_y", (-1.2, 1.8)), ("knee", (-2.2, -0.05)),
                 ("ankle_y", (-0.8, 0.8)), ("ankle_x", (-0.5, 0.5)))}
# the prioritized step's levels of (centre of mass, momentum, trunk, posture), the swing foot at level 1: balance
# first, then the swing foot and the trunk, then momentum damping and posture (module docstring, measured there)
STEP_LEVELS = (0, 2, 1, 2)
SIM_TOL = 1e-5           # the contact step's PGS tolerance (as the 3-D walk's; 1e-6 costs ~10x the sweeps standing)

__all__ = ["Biped3DRun", "crouched_state3d", "simulate_stand3d", "stand_tasks"]


@contract(ctrl=Obj(QPBiped3D), knee=Real(ge=0, le=1.2))
def crouched_state3d(ctrl: QPBiped3D, knee: float = 0.4) -> tuple[np.ndarray, np.ndarray]:
    """(q, q̇) at rest on both feet flat on z = 0, knees bent by ``knee`` rad, trunk upright, the centre of
    mass above the middle of the soles (the lean found by bisection, 60 halvings)."""
    knee = check_number("knee", knee, low=0.0, high=1.2)
    q0, _ = standing_state3d(clearance=0.0)

    def pose(a: float) -> tuple[np.ndarray, float]:
        q = q0.copy()
        for side in ("left", "right"):
            q[BIPED3D_JOINTS[f"{side}_hip_y"] + 1] = a
            q[BIPED3D_JOINTS[f"{side}_knee"] + 1] = -knee
            q[BIPED3D_JOINTS[f"{side}_ankle_y"] + 1] = knee - a
        kin = ctrl.world.kinematics(q)
        P, _ = ctrl.world.point_jacobians(kin, ctrl.links, ctrl.local)
        q[6] -= P[:, 2].min()
        com = ctrl.world.mass @ kin["c"] / ctrl.world.mass.sum()
        return q, float(com[0] - 0.5 * (P[:, 0].min() + P[:, 0].max()))

    lo, hi = -0.6, 0.6 + knee
    lo_sign = pose(lo)[1] > 0
    for _ in range(60):
        mid = 0.5 * (lo + hi)
        if (pose(mid)[1] > 0) == lo_sign:
            lo = mid
        else:
            hi = mid
    return pose(0.5 * (lo + hi))[0], np.zeros(18)


@contract(com_target=Array((3,)), posture=Mapping(Text(), Real(), min_len=1), kp=_GAIN, kd=_GAIN, momentum=_GAIN,
          trunk_kp=_GAIN, trunk_kd=_GAIN, posture_kp=_GAIN, posture_kd=_GAIN, heading=Real(ge=-10, le=10),
          weights=Array((4,), ge=0), priorities=Array((4,), ge=0, le=10))
def stand_tasks(com_target, posture: dict, *, kp: float = 40.0, kd: float = 15.0, momentum: float = 2.0,
                trunk_kp: float = 200.0, trunk_kd: float = 30.0, posture_kp: float = 100.0, posture_kd: float = 20.0,
                heading: float = 0.0, weights=(1.0, 1e-2, 1e-1, 1e-3), priorities=(0, 1, 1, 2)) -> list:
    """The four tasks of the module docstring (centre of mass, momentum, trunk, posture), ``weights`` and
    ``priorities`` in that order (a weight also weighs a task inside its level of the prioritized solve)."""
    w, p = weights, [int(k) for k in priorities]
    return [Task("com", target=com_target, kp=kp, kd=kd, weight=w[0], priority=p[0], dim=3),
            Task("momentum", kd=momentum, weight=w[1], priority=p[1], dim=3),
            Task("posture", name="trunk", target=dict(zip(TRUNK, (0.0, 0.0, heading))), kp=trunk_kp, kd=trunk_kd,
                 weight=w[2], priority=p[2], dim=3),
            Task("posture", target=dict(posture), kp=posture_kp, kd=posture_kd, weight=w[3], priority=p[3], dim=3)]


@dataclass
class Biped3DRun:
    """A run's record: times, states, centre of mass, the QP's forces (k, 8, 3) and residuals (k, 4:
    dynamics, contact, cone, limits), the Newton–Euler residuals (k, 2: |M c̈ − Σf − M g| N, |L̇ − Σ(p − c)
    × f| N m) and the outcome ("stood", "stepped", "fell" or "infeasible") with its time and cause."""

    t: np.ndarray
    q: np.ndarray
    com: np.ndarray
    com_target: np.ndarray
    forces: np.ndarray
    residuals: np.ndarray
    newton_euler: np.ndarray
    status: list
    outcome: str
    end_time: float
    cause: str
    mass: float
    h: float
    wall_time: float
    extra: dict

    @property
    def ok(self) -> bool:
        return self.outcome in ("stood", "stepped", "walked")

    @contract(last=Real(gt=0))
    def com_error(self, last: float = 0.3) -> float:
        """Largest horizontal |c − c̄| over the last ``last`` seconds (m)."""
        k = self.t >= self.t[-1] - last
        return float(np.linalg.norm((self.com[k] - self.com_target[k])[:, :2], axis=1).max())


def _run(ctrl: QPBiped3D, q, qd, t_end: float, h: float, control_every: int, script, push=None,
         push_time: float = 0.0, record_every: int = 5) -> tuple:
    """The loop shared by standing and stepping: ``script(t, q, q̇, kin) -> contacts`` sets the tasks' targets
    and the contact mask of the coming QP (None: the active corners)."""
    tree = ctrl.kernel
    stepper = WorldStep(tree, biped3d_contact_points(tree), friction=ctrl.ground.mu, tol=SIM_TOL)
    step, solve = unchecked(stepper.step), unchecked(ctrl.solve)
    torso = [lk.name for lk in tree.links].index("torso")
    n = int(round(t_end / h))
    if not 1 <= n <= 10_000_000:
        raise SimulationDiverged(f"{n} steps of {h} s to {t_end} s: outside 1 … 1e7")
    z0 = q[6]
    rec = {k: [] for k in ("t", "q", "com", "target", "f", "res", "ne", "status")}
    tau, res, stop, pushed = np.zeros(18), None, None, push is None
    start = time.perf_counter()
    for k in range(n):                                    # a cap known before the loop starts: n steps
        t = k * h
        kin = stepper.kinematics(q)
        if not pushed and t >= push_time - 1e-12:
            P, J = stepper.point_jacobians(kin, np.array([torso]), np.array([tree.links[torso].com]))
            qd = qd + np.linalg.solve(stepper.mass_matrix(kin), J[0].T @ np.asarray(push, dtype=float))
            pushed = True
        if k % control_every == 0:
            contacts = script(t, q, qd, kin)
            try:
                res = solve(q, qd, dict(kin), contacts, raise_on_failure=True)
            except InfeasibleControl as exc:
                stop = ("infeasible", t, str(exc))
                break
            tau = res.tau
        q, qd = step(q, qd, h, tau, None, kin)
        if not np.all(np.isfinite(q)) or not np.all(np.isfinite(qd)):
            raise SimulationDiverged(f"the 3-D biped's state became non-finite at t = {t + h:.4g} s")
        if q[6] < 0.5 * z0 or stepper.kinematics(q)["R"][0][2, 2] < np.cos(1.0):
            stop = ("fell", t + h, "the pelvis dropped below half its height or the trunk tilted past 1 rad")
            break
        if (k + 1) % record_every == 0 or k == n - 1:
            _record(rec, ctrl, t + h, q, res)
    wall = time.perf_counter() - start
    return rec, stop, wall


def _record(rec: dict, ctrl: QPBiped3D, t: float, q, res) -> None:
    rec["t"].append(t), rec["q"].append(q.copy()), rec["status"].append(res.status)
    rec["com"].append(res.com), rec["target"].append(ctrl.task("com")._target.copy())
    rec["f"].append(res.forces), rec["ne"].append(res.newton_euler)
    rec["res"].append([res.residuals[g] for g in ("dynamics", "contact", "cone", "limits")])


def _result(rec, stop, wall, ctrl, h, ok, t_end, extra) -> Biped3DRun:
    outcome, end, cause = (ok, float(t_end), "") if stop is None else stop
    arr = lambda key, shape: np.array(rec[key], dtype=float).reshape((-1,) + shape)
    return Biped3DRun(t=np.array(rec["t"]), q=arr("q", (19,)), com=arr("com", (3,)), com_target=arr("target", (3,)),
                      forces=arr("f", (8, 3)), residuals=arr("res", (4,)), newton_euler=arr("ne", (2,)),
                      status=rec["status"], outcome=outcome, end_time=float(end), cause=cause,
                      mass=float(ctrl.world.mass.sum()), h=h, wall_time=wall, extra=extra)


def _controller(mode, knee, friction, heading=0.0, **kw) -> tuple:
    ctrl = QPBiped3D([], mode=mode, friction=friction, torque_limits=300.0, joint_limits=JOINT_LIMITS)
    q, qd = crouched_state3d(ctrl, knee)
    kin = ctrl.world.kinematics(q)
    com = ctrl.world.mass @ kin["c"] / ctrl.world.mass.sum()
    posture = {nm: float(q[v + 1]) for nm, v in BIPED3D_JOINTS.items()}
    ctrl.tasks = ctrl._checked(stand_tasks(com, posture, heading=heading, **kw))
    return ctrl, q, qd, com


@contract(push=Array((3,)), t_end=Real(gt=0, le=5), h=Real(ge=1e-3, le=0.01), push_time=Real(ge=0),
          mode=Choice(MODES), control_every=Int(ge=1, le=100), knee=Real(ge=0, le=1.2), friction=Real(ge=0),
          record_every=Int(ge=1))
def simulate_stand3d(push=(0.0, 0.0, 0.0), t_end: float = 1.0, h: float = 2e-3, *, push_time: float = 0.2,
                     mode: str = "weighted", control_every: int = 1, knee: float = 0.4, friction: float = 0.9,
                     record_every: int = 5) -> Biped3DRun:
    """Stand the 3-D biped under the QP controller for ``t_end`` s, pushed by ``push`` N s at ``push_time``."""
    ctrl, q, qd, com = _controller(mode, knee, friction)
    push = None if not np.any(push) else push
    rec, stop, wall = _run(ctrl, q, qd, t_end, h, control_every, lambda *a: None, push, push_time, record_every)
    return _result(rec, stop, wall, ctrl, h, "stood", t_end, {"push": push, "mode": mode, "start_com": com})


from .qp_biped3d_walk import simulate_step  # noqa: E402  (its public path here kept; the footsteps live there)
