"""Valid calls for pbanim.control (chapter 08, part 2): servos, state machines, SIMBICON, the QP controller.

Runs are kept to a handful of steps (a walk or a balance of 5–10 steps): the fuzz calls each entry a few
dozen times.
"""

import functools

import numpy as np

from pbanim.articulated.planar import PlanarKernel
from pbanim.articulated.planar_step import PlanarGround
from pbanim.control import (WALK, Gait, Phase, PDServo, Push, QPController, Simbicon, StateMachine, Task,
                            Transition, simulate_balance, simulate_walk)
from pbanim.control.biped import BIPED_JOINTS, biped_contact_points, planar_biped
from pbanim.control.qp_balance import BalanceResult, balance_tasks, crouched_state
from pbanim.control.walk import WalkResult
from pbanim.control.biped3d import biped3d, biped3d_contact_points, standing_state3d
from pbanim.control.biped3d_step import WorldStep
from pbanim.control.simbicon3d import WALK3D, Gait3D, Phase3D, Simbicon3D
from pbanim.control.simbicon3d_walk import Walk3DResult, simulate_walk3d
from pbanim.control.qp_biped3d import Ground3D, QPBiped3D
from pbanim.control.qp_biped3d_run import Biped3DRun, crouched_state3d, simulate_stand3d, stand_tasks


@functools.lru_cache(maxsize=1)
def _biped3d():
    """The 3-D biped's tree (read only)."""
    return biped3d()


def _world_step():
    return WorldStep(_biped3d(), biped3d_contact_points(_biped3d()))


@functools.lru_cache(maxsize=1)
def _biped():
    """The biped's kernel (read only: every object below may share it)."""
    return PlanarKernel(planar_biped())


def _servo():
    return PDServo({"hip": 1, "knee": 3}, nv=5, kp=[100.0, 50.0], kv=[10.0, 5.0], limits=[1e9, 20.0])


def _machine():
    return StateMachine({"A": 0, "B": 1}, [Transition("A", "B", after=0.3), Transition("B", "A", on="e")], "A")


@functools.lru_cache(maxsize=1)
def _crouched():
    return crouched_state(_biped(), 0.3)


def _stance():
    q, qd = _crouched()
    return q.copy(), qd + 0.01


def _tasks():
    k = _biped()
    q, _ = _stance()
    posture = {nm: float(q[i]) for nm, i in (("left_knee", 4), ("right_knee", 7))}
    return balance_tasks(k.centre_of_mass(q) + [0.01, 0.0], posture)


def _qp():
    k = _biped()
    return QPController(k, biped_contact_points(k.tree), PlanarGround(0.0, 0.9), _tasks(), torque_limits=300.0)


def _qp_state(ctrl=None):
    q, qd = _stance()
    return {"q": q, "qd": qd}


def _qp3d():
    return QPBiped3D([], torque_limits=300.0, joint_limits={"left_knee": (-2.0, -0.05)})


@functools.lru_cache(maxsize=1)
def _crouched3d():
    return crouched_state3d(_qp3d(), 0.4)


def _state3d(ctrl=None):
    q, qd = _crouched3d()
    return {"q": q.copy(), "qd": qd + 0.01}


@functools.lru_cache(maxsize=1)
def _short_stand3d():
    """A result record (read only: com_error does not change it)."""
    return simulate_stand3d(t_end=0.016, h=8e-3, record_every=1)


@functools.lru_cache(maxsize=1)
def _short_walk():
    """A result record (read only: speed does not change it)."""
    return simulate_walk(WALK, 0.02, 2e-3, servo="stable", record_every=1)


@functools.lru_cache(maxsize=1)
def _short_balance():
    """A result record (read only: com_error does not change it)."""
    return simulate_balance(5.0, 0.02, 2e-3, push_time=0.004)


INSTANCES = {
    PDServo: _servo,
    StateMachine: _machine,
    Transition: lambda: Transition("A", "B", after=0.3),
    Phase: lambda: WALK.phases[0],
    Gait: lambda: WALK,
    Simbicon: lambda: Simbicon(_biped(), WALK),
    Push: lambda: Push(50.0, 0.4, 2),
    WalkResult: _short_walk,
    Task: lambda: Task("com", target=(0.0, 1.0), kp=10.0, kd=5.0),
    QPController: _qp,
    BalanceResult: _short_balance,
    Phase3D: lambda: WALK3D.phases[0],
    Gait3D: lambda: WALK3D,
    Simbicon3D: lambda: Simbicon3D(_world_step()),
    Walk3DResult: lambda: simulate_walk3d(t_end=0.006, h=2e-3, record_every=1),
    QPBiped3D: _qp3d,
    Ground3D: Ground3D,
    Biped3DRun: _short_stand3d,
}

SKIP_EDGES = {
    "pbanim.control.qp_biped3d_run.simulate_stand3d": "t_end at its bound (5 s of standing at 1 ms steps) runs for "
                                                      "minutes: the edges of t_end are what the step count's cap checks",
    "pbanim.control.qp_biped3d_walk.simulate_step": "phases at their bound (8 s of stepping) runs for minutes",
    "pbanim.control.simbicon3d_walk.simulate_walk3d": "t_end at its bound (600 s of walking) runs for an hour: the "
                                                      "edges of t_end are what the step grid's cap checks",
}

_M = np.array([[2.0, 0.3], [0.3, 1.0]])

CALLS = {
    "pbanim.control.pd.PDServo.__init__": lambda: {"joints": {"hip": 0}, "nv": 2, "world": ["hip"],
                                                   "angles": {"hip": np.array([1.0, 1.0])}},
    "pbanim.control.pd.PDServo.target_vector": lambda: {"targets": {"hip": 0.5}},
    "pbanim.control.pd.PDServo.explicit": lambda: {"targets": {"hip": 0.5}},
    "pbanim.control.pd.PDServo.stable": lambda: {"targets": {"hip": 0.5}},
    "pbanim.control.pd.stable_pd_acceleration": lambda: {
        "M": _M, "C": np.array([0.1, -0.2]), "q": np.array([0.3, -0.1]), "qd": np.array([1.0, 0.5]),
        "target": np.array([0.0, 0.2])},
    "pbanim.control.pd.servo_track": lambda: {"target": np.sin, "h": 0.01, "t_end": 0.1},
    "pbanim.control.pd.largest_stable_step": lambda: {"kp": 100.0, "kv": 20.0},
    "pbanim.control.fsm.StateMachine.__init__": lambda: {
        "states": {"A": 0, "B": 1}, "transitions": [Transition("A", "B", after=0.3), Transition("B", "A", on="e")],
        "initial": "A"},
    "pbanim.control.fsm.Transition.__init__": lambda: {"source": "A", "target": "B", "after": 0.3, "on": None},
    "pbanim.control.simbicon.Gait.__init__": lambda: {"name": "g", "dt": 0.3, "phases": WALK.phases,
                                                       "kp": dict(WALK.kp), "kv": dict(WALK.kv)},
    "pbanim.control.simbicon.Simbicon.__init__": lambda: {"kernel": _biped()},
    "pbanim.control.simbicon.Simbicon.balance": _qp_state,
    "pbanim.control.simbicon.Simbicon.torques": lambda ctrl: {**_qp_state(), "t": 0.1, "h": 1e-3},
    "pbanim.control.walk.simulate_walk": lambda: {"t_end": 0.01, "h": 2e-3, "record_every": 1},
    "pbanim.control.walk.start_state": lambda: {"kernel": _biped(), "ground": PlanarGround(0.05)},
    "pbanim.control.qp.QPController.__init__": lambda: {
        "kernel": _biped(), "points": biped_contact_points(_biped().tree), "tasks": _tasks(),
        "joints": dict(BIPED_JOINTS), "joint_limits": {"left_knee": (-2.0, 0.0)}},
    "pbanim.control.qp.QPController.task": lambda: {"name": "com"},
    "pbanim.control.qp.QPController.set_target": lambda: {"name": "com", "target": np.array([0.0, 1.0])},
    "pbanim.control.qp.QPController.set_weight": lambda: {"name": "com"},
    "pbanim.control.qp.QPController.active_contacts": _qp_state,
    "pbanim.control.qp.QPController.build": _qp_state,
    "pbanim.control.qp.QPController.solve": _qp_state,
    "pbanim.control.qp.QPController.torques": _qp_state,
    "pbanim.control.qp_balance.simulate_balance": lambda: {"t_end": 0.004, "h": 2e-3, "push_time": 0.002},
    "pbanim.control.qp_balance.simulate_balance_pushes": lambda: {"pushes": [5.0, 0.0], "t_end": 0.004, "h": 2e-3,
                                                                  "push_time": 0.002},
    "pbanim.control.biped3d.biped3d_contact_points": lambda: {"tree": _biped3d()},
    "pbanim.control.biped3d_step.WorldStep.__init__": lambda: {"tree": _biped3d(),
                                                               "contact_points": biped3d_contact_points(_biped3d())},
    "pbanim.control.biped3d_step.WorldStep.kinematics": lambda ws: {"q": standing_state3d()[0]},
    "pbanim.control.biped3d_step.WorldStep.point_jacobians": lambda ws: {
        "kin": ws.kinematics(standing_state3d()[0]), "links": np.array([7, 13]), "points": np.zeros((2, 3))},
    "pbanim.control.biped3d_step.WorldStep.mass_matrix": lambda ws: {"kin": ws.kinematics(standing_state3d()[0])},
    "pbanim.control.biped3d_step.WorldStep.step": lambda ws: {"q": standing_state3d()[0], "qd": np.zeros(18),
                                                              "h": 2e-3, "tau0": np.zeros(18)},
    "pbanim.control.biped3d_step.WorldStep.integrate": lambda ws: {"q": standing_state3d()[0], "u": np.ones(18),
                                                                   "h": 2e-3},
    "pbanim.control.simbicon3d.Gait3D.__init__": lambda: {"name": "g", "dt": 0.3, "phases": WALK3D.phases,
                                                           "kp": dict(WALK3D.kp), "kv": dict(WALK3D.kv)},
    "pbanim.control.simbicon3d.Simbicon3D.__init__": lambda: {"step": _world_step()},
    "pbanim.control.simbicon3d.Simbicon3D.balance": lambda c: {"kin": c.step.kinematics(standing_state3d()[0]),
                                                               "qd": np.zeros(18)},
    "pbanim.control.simbicon3d.Simbicon3D.torques": lambda c: {"t": 0.1, "q": standing_state3d()[0],
                                                               "qd": np.zeros(18), "h": 2e-3},
    "pbanim.control.simbicon3d_walk.simulate_walk3d": lambda: {"t_end": 0.006, "h": 2e-3, "record_every": 1},
    "pbanim.control.qp_biped3d.QPBiped3D.__init__": lambda: {"tasks": [], "joint_limits": {"left_knee": (-2.0, -0.05)}},
    "pbanim.control.qp_biped3d.QPBiped3D.kinematics": lambda c: {"q": _crouched3d()[0].copy()},
    "pbanim.control.qp_biped3d.QPBiped3D.active_contacts": _state3d,
    "pbanim.control.qp_biped3d.QPBiped3D.build": _state3d,
    "pbanim.control.qp_biped3d.QPBiped3D.solve": _state3d,
    "pbanim.control.qp_biped3d.QPBiped3D.torques": _state3d,
    "pbanim.control.qp_biped3d_run.crouched_state3d": lambda: {"ctrl": _qp3d()},
    "pbanim.control.qp_biped3d_run.stand_tasks": lambda: {"com_target": np.array([0.05, 0.0, 0.85]),
                                                         "posture": {"left_knee": -0.4}},
    "pbanim.control.qp_biped3d_run.simulate_stand3d": lambda: {"t_end": 0.016, "h": 8e-3, "push_time": 0.008,
                                                              "push": np.array([1.0, 0.0, 0.0]), "record_every": 1},
    "pbanim.control.qp_biped3d_walk.simulate_step": lambda: {"phases": np.array([0.06, 0.06, 0.06, 0.06]), "h": 0.01,
                                                            "record_every": 1},
}

EXEMPT = {
    "pbanim.control.walk.WalkResult.__init__": "a result record simulate_walk builds; users read it",
    "pbanim.control.qp.QPResult.__init__": "a result record QPController.solve builds; users read it",
    "pbanim.control.qp_balance.BalanceResult.__init__": "a result record simulate_balance builds; users read it",
    "pbanim.control.simbicon3d_walk.Walk3DResult.__init__": "a result record simulate_walk3d builds; users read it",
    "pbanim.control.qp_biped3d.QPResult3D.__init__": "a result record QPBiped3D.solve builds; users read it",
    "pbanim.control.qp_biped3d.Centroidal3D.__init__": "a record the controller builds from the model's sums",
    "pbanim.control.qp_biped3d_run.Biped3DRun.__init__": "a result record simulate_stand3d / simulate_step build",
}
