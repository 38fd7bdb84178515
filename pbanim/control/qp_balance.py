"""Standing balance under a push with the QP controller on the planar biped (chapter 08, part 2).

The biped stands with bent knees on both feet; the QP controller (:mod:`.qp`) tracks three features:

    centre of mass    c̈* = k_p (c̄ − c) − k_d ċ          c̄ above the middle of the feet (priority 0)
    angular momentum  L̇* = −k_L L                        about the centre of mass (priority 1, or 0)
    posture           q̈ⱼ* = k_q (q̄ⱼ − qⱼ) − k_q' q̇ⱼ      the standing pose and an upright torso (priority 1)

Priorities matter only to ``mode="prioritized"``. By default the centre of mass is alone at level 0;
``momentum_priority=0`` puts balance first as a whole: the centre of mass and the angular momentum share
level 0 (traded by their weights inside it), the posture uses what they leave.
With the centre of mass alone on top, the top level buys c̈* with any motion the constraints allow —
it whips the torso, which no lower level can then undo — and the biped fell at 20 N s where the weighted
controller recovers 24 (measured; ORACLES F14). With the momentum beside it (weight 1e-2) and the torso
kept within ±0.3 rad by a joint limit (an inequality of every level, ``joint_limits``), it recovered ±20 but
lost backward pushes of 8, 12, 16 and 24 N s (measured): a backward push sends the centre of pressure to
the heels, the toes carry nothing and lift past ``contact_tol``, and then nothing holds the soles — the level
above fixes c̈ and L̇, turning a foot back down changes both, so the posture level cannot — and the biped
rocks on its heels (c̈ₓ pinned near g d/z ≈ 0.9 m/s², the pendulum about the heel, while c̈* asked −6) until it
falls. The weighted QP's posture term (weight 1e-3) turns the feet back down; strict levels need it said on a
level of its own: ``press`` holds each heel and toe at its standing place by a point task on a level above
balance (:data:`BALANCE_FIRST`; the 3-D step does the same). So the prioritized controller recovers what the
weighted one recovers, every push of −24 … 24 N s, and neither ±28 (beyond the capture point below).

and the simulation is the velocity-level contact step of chapter 08
(:class:`~pbanim.articulated.planar_step.PlanarContactStep`: Coulomb friction, heel and toe points), the
QP's torques applied for ``control_every`` steps. At ``push_time`` an impulse P (N s, +x forward) hits the
torso's centre of mass: Δq̇ = M⁻¹ J_cᵀ P (as in :mod:`.walk`). The centre of mass must come back to c̄
(ORACLES F14); how far it can be pushed depends on the feet: the centre of pressure cannot leave them, so
the controller first uses the ankles (the centre of pressure moves to the toe or the heel) and then the
whole body's angular momentum (the hip strategy: the torso swings to produce the horizontal force).

A linear inverted pendulum of height z gives the scale: after Δv = P/M the centre of mass stops before
the edge of the foot when Δv/ω < (distance from c to the edge), ω = √(g/z) (the capture point).

Runs use the one fixed-step driver (:func:`pbanim.ode.driver.drive`: its grid, its cap, its finiteness
check). A fall is reported as a fall (time and cause, the walk's detector) and the run stops there; a
control QP without a feasible answer stops the run too, with the QP's message (outcome "infeasible").

Solver options: ProxQP's defaults (eps_abs 1e-9, no row equilibration), not the 3-D controller's
(``equilibrate``, ``primal_inf`` 1e-8). Measured on the weighted envelope (−32 … 32 N s, 17 runs, lean path): the
same outcome for every push with either; equilibration alone leaves the equations of motion 3.7e-7 off (F10's
bound is 1e-8; with eps_abs 1e-11 6.2e-9) at the same CPU (20.6, 20.5, 19.1 s); its one gain is beyond the
capture point, where −28 and −32 end "fell" at 0.90 and 0.88 s instead of "infeasible" (a false certificate) at
0.86 and 0.82 s. The prioritized path, which calls ProxQP at every level, took 24.5 s instead of 5.5 at
eps_abs 1e-11 on one run (−16 N s without the soles' level), ending the same way.

Limiting cases: P = 0 — the crouched stance is an equilibrium (every task met, the state does not move);
μ = 0 — the feet cannot push sideways, so the centre of mass cannot be brought back (only the posture
moves); a push inside the capture-point bound but a controller solved every k steps — the torques are held
between solves and the recovery degrades as k grows.

Notation: c, ċ centre of mass and its velocity; c̄ its target; L angular momentum about c; P the push.

References: de Lasa, Mordatch & Hertzmann 2010; B. Stephens, "Humanoid push recovery", Humanoids 2007
(ankle and hip strategies); J. Pratt et al., "Capture point", Humanoids 2006.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, replace

import numpy as np

from ..articulated.planar import PlanarKernel
from ..articulated.planar_lean import LeanPlanarStep
from ..articulated.planar_step import PlanarContactStep, PlanarGround
from ..contracts import Array, Choice, Flag, Int, Opt, Real, Seq, Text, contract, unchecked
from ..errors import check_number
from ..ode.driver import MAX_STEPS, drive, step_grid
from .biped import BIPED_JOINTS as JI
from .biped import biped_contact_points, planar_biped
from .pd import InvalidGains
from .qp import MODES, InfeasibleControl, QPController
from .qp_lean import LeanQP
from .qp_lean_levels import LeanLevels
from .qp_solve import backends
from .qp_tasks import InvalidTask, Task
from .specs import Mapping, Pair, named
from .walk import fall_cause

__all__ = ["BALANCE_FIRST", "BalanceResult", "balance_tasks", "crouched_state", "simulate_balance", "simulate_balance_pushes"]


class _Stop(Exception):
    """Ends the loop at a fall or an infeasible control QP (caught by :func:`simulate_balance`)."""


def crouched_state(kernel: PlanarKernel, knee: float = 0.3) -> tuple[np.ndarray, np.ndarray]:
    """(q, q̇) at rest on both feet, flat on y = 0, knees bent by ``knee`` rad, torso upright, and the centre
    of mass above the middle of the feet (the thighs' lean a found by bisection: hip a, knee −``knee``,
    ankle ``knee`` − a)."""
    knee = check_number("knee", knee, low=0.0, high=1.2)
    pts = biped_contact_points(kernel.tree)
    links, local = [lk for lk, _ in pts], [p for _, p in pts]

    def pose(a: float) -> tuple[np.ndarray, float]:
        q = np.zeros(kernel.nv)
        for side in ("left", "right"):
            q[JI[f"{side}_hip"]], q[JI[f"{side}_knee"]], q[JI[f"{side}_ankle"]] = a, -knee, knee - a
        soles = kernel.points(q, links, local)
        q[1] -= soles[:, 1].min()
        return q, float(kernel.centre_of_mass(q)[0] - 0.5 * (soles[:, 0].min() + soles[:, 0].max()))

    lo, hi = -0.6, 0.6 + knee                      # the offset changes sign between these leans
    lo_sign = pose(lo)[1] > 0
    for _ in range(60):                             # bisection: a cap known before it starts
        mid = 0.5 * (lo + hi)
        if (pose(mid)[1] > 0) == lo_sign:
            lo = mid
        else:
            hi = mid
    return pose(0.5 * (lo + hi))[0], np.zeros(kernel.nv)


_GAIN = named(InvalidTask, Real(ge=0))
_LEVEL = named(InvalidTask, Int(ge=0, le=10))
_TASK_GAINS = dict(kp=_GAIN, kd=_GAIN, momentum=_GAIN, posture_kp=_GAIN, posture_kd=_GAIN, posture_weight=_GAIN,
                   momentum_weight=_GAIN, momentum_priority=_LEVEL, posture_priority=_LEVEL)


@contract(com_target=Array((2,)), posture=Mapping(Text(), Real(), min_len=1), **_TASK_GAINS)
def balance_tasks(com_target, posture: dict, *, kp: float = 60.0, kd: float = 25.0, momentum: float = 2.0,
                  posture_kp: float = 100.0, posture_kd: float = 20.0, posture_weight: float = 1e-3,
                  momentum_weight: float = 1e-3, momentum_priority: int = 1, posture_priority: int = 1) -> list:
    """The three tasks of the module docstring (the centre of mass at priority 0, the angular momentum at
    ``momentum_priority``, the posture at ``posture_priority``): gains k_p, k_d of the centre of mass, k_L
    (``momentum``), the posture's k_q, k_q' and the two weights (which also weigh a task inside its level)."""
    return [Task("com", target=com_target, kp=kp, kd=kd, weight=1.0, priority=0),
            Task("momentum", kd=momentum, weight=momentum_weight, priority=momentum_priority),
            Task("posture", target=dict(posture), kp=posture_kp, kd=posture_kd, weight=posture_weight,
                 priority=posture_priority)]


@dataclass
class BalanceResult:
    """States, centre of mass, contact forces (the QP's and the simulation's) and the outcome of a run.

    ``forces`` / ``sim_forces``: (k, m, 2) normal and tangential force per contact point (QP answer /
    simulated impulse ÷ h); ``status``: the QP's status per recorded step; ``outcome``: "balanced",
    "fell" or "infeasible", with ``end_time`` and ``cause``.
    """

    t: np.ndarray
    q: np.ndarray
    com: np.ndarray
    vcom: np.ndarray
    com_target: np.ndarray
    forces: np.ndarray
    sim_forces: np.ndarray
    status: list
    residuals: np.ndarray            # (k, 4): dynamics, contact, cone, limits of the recorded QP answers
    outcome: str
    end_time: float
    cause: str
    push_time: float
    push: float
    support: tuple
    mu: float
    h: float
    wall_time: float
    qp_time: float

    @contract(last=Real(gt=0))
    def com_error(self, last: float = 0.5) -> float:
        """Largest |c − c̄| over the last ``last`` seconds (m)."""
        k = self.t >= self.t[-1] - last
        return float(np.abs(self.com[k] - self.com_target).max())

    @property
    def recovered(self) -> bool:
        return self.outcome == "balanced"


_RUN = dict(t_end=Real(gt=0), h=Real(gt=0), push_time=Real(ge=0), mode=Choice(MODES), control_every=Int(ge=1),
            friction=Real(ge=0), knee=Real(ge=0, le=1.2),
            torque_limits=named(InvalidGains, Array((6,), ge=0, finite=False, scalar=True)), record_every=Int(ge=1),
            backend=Choice(backends), max_steps=Int(ge=1), joint_limits=Opt(Mapping(Text(), Pair(Real(), Real()))),
            lean=Flag(), press=Flag(), **_TASK_GAINS)
_PUSH = Real(ge=-1e4, le=1e4)
_SOLES = ("left heel", "left toe", "right heel", "right toe")      # biped_contact_points' order

#: The prioritized controller the chapter compares with the weighted default (ORACLES F14): the soles held
#: flat on the top level, then the centre of mass and the angular momentum (weight 1e-2), then the posture;
#: the torso within ±0.3 rad by an inequality of every level.
BALANCE_FIRST = {"mode": "prioritized", "press": True, "momentum_priority": 0, "momentum_weight": 1e-2,
                 "joint_limits": {"torso": (-0.3, 0.3)}}


@contract(push=_PUSH, **_RUN)
def simulate_balance(push: float = 0.0, t_end: float = 2.5, h: float = 2e-3, *, push_time: float = 0.5,
                     mode: str = "weighted", control_every: int = 1, friction: float = 0.9, knee: float = 0.3,
                     torque_limits=300.0, record_every: int = 5, backend: str = "proxqp",
                     max_steps: int = MAX_STEPS, kp: float = 60.0, kd: float = 25.0, momentum: float = 2.0,
                     posture_kp: float = 100.0, posture_kd: float = 20.0, posture_weight: float = 1e-3,
                     momentum_weight: float = 1e-3, momentum_priority: int = 1, posture_priority: int = 1,
                     joint_limits: dict | None = None, lean: bool = True, press: bool = False) -> BalanceResult:
    """Stand the planar biped with the QP controller and push it (``push`` N s at ``push_time`` s).

    ``kp`` … ``momentum_weight``: the gains and weights of :func:`balance_tasks`. ``lean`` (default): the
    simulation's contact step is :class:`~pbanim.articulated.planar_lean.LeanPlanarStep` (the readable step's
    operations in their order), the weighted QP is solved on its lean path (:class:`~pbanim.control.qp_lean.LeanQP`,
    ORACLES F23), the prioritized one on its lean levels (:class:`~pbanim.control.qp_lean_levels.LeanLevels`,
    ORACLES F25) and one lean kinematics of q serves the QP, the step and the fall detector; ``lean=False``
    runs :class:`PlanarContactStep` and :meth:`QPController.solve` themselves (ORACLES F22: the same run to the QP
    runs' own spread). ``press``: the soles held flat, a point task per heel and toe (k_p 100, k_d 20, its
    standing position the target) on a level of their own above the others (:data:`BALANCE_FIRST`; module
    docstring). :data:`BALANCE_FIRST` holds the prioritized options the chapter compares with the weighted default.
    """
    options = {k: v for k, v in locals().items() if k not in ("push", "t_end", "h")}
    return _balance(push, t_end, h, options)


@contract(pushes=Seq(_PUSH), **_RUN)
def simulate_balance_pushes(pushes=(), t_end: float = 2.5, h: float = 2e-3, *, push_time: float = 0.5,
                            mode: str = "weighted", control_every: int = 1, friction: float = 0.9, knee: float = 0.3,
                            torque_limits=300.0, record_every: int = 5, backend: str = "proxqp",
                            max_steps: int = MAX_STEPS, kp: float = 60.0, kd: float = 25.0, momentum: float = 2.0,
                            posture_kp: float = 100.0, posture_kd: float = 20.0, posture_weight: float = 1e-3,
                            momentum_weight: float = 1e-3, momentum_priority: int = 1, posture_priority: int = 1,
                            joint_limits: dict | None = None, lean: bool = True,
                            press: bool = False) -> list[BalanceResult]:
    """``[simulate_balance(P, t_end, h, …) for P in pushes]``, equal bit for bit, with the stance before
    ``push_time`` simulated once: every run is the unpushed one until the step its push lands in, so that
    run stops there (kept: the state, the held torques and QP answer, the contact modes, the records) and
    each push continues from it. A run that ends before the push (t_end ≤ push_time, a fall) is every run."""
    options = {k: v for k, v in locals().items() if k not in ("pushes", "t_end", "h")}
    pushes = [float(p) for p in pushes]
    shared = _balance(0.0, t_end, h, options, watch=True)
    if isinstance(shared, BalanceResult):                  # no push lands: every run is this one
        return [replace(shared, push=p) for p in pushes]
    return [_balance(p, t_end, h, options, branch=shared) for p in pushes]


class _Branch(Exception):
    """Stops the unpushed run of :func:`simulate_balance_pushes` before the step its pushes land in."""


def _balance(push: float, t_end: float, h: float, o: dict, *, watch: bool = False, branch: tuple | None = None):
    """The run of :func:`simulate_balance` (options ``o``). ``watch``: stop before the push's step and return
    the snapshot (step index, state, loop bookkeeping, contact modes, records, wall time) instead of a result,
    or the result when the run ends first; ``branch``: such a snapshot, continued with ``push`` (the steps
    before it neither taken nor recorded)."""
    task_options = {k: o[k] for k in _TASK_GAINS}
    every, push_time = int(o["control_every"]), o["push_time"]
    tree = planar_biped()
    kernel = PlanarKernel(tree)
    ground = PlanarGround(0.0, o["friction"])
    pts = biped_contact_points(tree)
    stepper = PlanarContactStep(kernel, pts, ground)
    q0, qd0 = crouched_state(kernel, o["knee"])
    soles = kernel.points(q0, [lk for lk, _ in pts], [p for _, p in pts])
    support = (float(soles[:, 0].min()), float(soles[:, 0].max()))
    target = kernel.centre_of_mass(q0)                       # above the middle of the feet
    names = [lk.name for lk in tree.links]
    torso = np.array([names.index("torso")])
    posture = {nm: float(q0[i]) for nm, i in JI.items() if i >= 2}
    tasks = balance_tasks(target, posture, **task_options)
    if o["press"]:                                           # the soles held flat, on a level above the others
        tasks = [Task("point", target=tuple(p[:2]), kp=100.0, kd=20.0, priority=0, name=nm, link=int(lk),
                      local=tuple(loc)) for nm, (lk, loc), p in zip(_SOLES, pts, soles)] \
            + [replace(t, priority=t.priority + 1) for t in tasks]
    ctrl = QPController(kernel, pts, ground, tasks, mode=o["mode"],
                        torque_limits=o["torque_limits"], backend=o["backend"], joint_limits=o["joint_limits"])
    record_every = o["record_every"]
    grid = step_grid(0.0, t_end, h, max_steps=o["max_steps"], record_every=record_every)
    m, nv = len(pts), kernel.nv
    rec = {k: [] for k in ("t", "q", "com", "vcom", "f", "fs", "status", "res")}
    state = {"tau": np.zeros(nv), "last": None, "k": 0, "pushed": False, "qp": 0.0, "stop": None, "near": None,
             "z": None, "wall": 0.0}
    k0, y0 = 0, np.concatenate([q0, qd0])
    if branch is not None:
        k0, y0, saved, modes, records = branch
        state.update(saved)
        stepper.modes[:] = modes
        rec = {k: list(v) for k, v in records.items()}
    solve = unchecked(ctrl.solve)
    kinematics, com = unchecked(kernel.kinematics), unchecked(kernel.centre_of_mass)
    lean = LeanPlanarStep(stepper) if o["lean"] else None
    lean_qp = (LeanLevels if o["mode"] == "prioritized" else LeanQP)(ctrl, lean) if lean is not None else None
    if lean_qp is not None and lean_qp.supported:       # the QP's lean twin (ORACLES F23) takes the lean kinematics
        solve = unchecked(lean_qp.solve)
    else:
        lean_qp = None
    readable = unchecked(stepper.step)

    def lean_kinematics(q):
        lk = lean.kinematics(q)
        return lk + (lean.com_jacobians(lk[2], lk[3]),)
    counter = [0]

    def advance(t, y, hh):
        k = counter[0]
        counter[0] = k + 1
        if k < k0:                                   # a step of the shared run before the branch point
            return y0
        q, qd = y[:nv], y[nv:]
        if watch and t >= push_time - 1e-12:            # the shared run reached the push's step: keep it, stop
            state["snapshot"] = (k, y, {g: state[g] for g in ("tau", "last", "k", "qp")}, stepper.modes.copy(),
                                 {g: list(v) for g, v in rec.items()})
            raise _Branch
        if lean_qp is not None:                        # the QP and the step share the lean kinematics of q
            kin = state.pop("lk", None) or lean_kinematics(q)
        else:
            kin = state.pop("kin", None) or kinematics(q)
        if not state["pushed"] and push != 0.0 and t >= push_time - 1e-12:
            H, _, kin_p = kernel.dynamics(q, qd, kinematics(q) if lean_qp is not None else kin)
            Jc = kernel.jacobians(kin_p, torso, kin_p["c"][torso])[0]
            qd = qd + np.linalg.solve(H, Jc.T @ np.array([push, 0.0]))
            state["pushed"] = True
        if state["k"] % every == 0:
            start = time.perf_counter()
            try:
                res = solve(q, qd, kin, raise_on_failure=True)
            except InfeasibleControl as exc:
                state["stop"] = ("infeasible", t, str(exc))
                raise _Stop from None
            state["qp"] += time.perf_counter() - start
            state["tau"], state["last"] = res.tau, res
        state["k"] += 1
        if lean_qp is not None:
            q1, u1, state["near"], state["z"] = lean.step(q, qd, hh, state["tau"], None, kin[:4], kin[4])
            state["lk"] = lk1 = lean_kinematics(q1)              # the next step's kinematics (the same q)
            cause = fall_cause(kernel, {"o": np.stack([lk1[2].real, lk1[2].imag], axis=1)}, q1, ground)
        else:
            if lean is not None:
                lk = lean_kinematics(q)
                q1, u1, state["near"], state["z"] = lean.step(q, qd, hh, state["tau"], None, lk[:4], lk[4])
            else:
                q1, u1 = readable(q, qd, hh, state["tau"], None, kin)
                state["near"], state["z"] = stepper.last["near"], stepper.last["impulses"]
            state["kin"] = kin1 = kinematics(q1)               # the next step's kinematics (the same q)
            cause = fall_cause(kernel, kin1, q1, ground)
        if cause:
            state["stop"] = ("fell", t + hh, cause)
            raise _Stop
        return np.concatenate([q1, u1])

    def record(t1, y1):
        if counter[0] <= k0:
            return
        q1 = y1[:nv]
        c, v = com(q1, y1[nv:])
        res = state["last"]
        fs = np.zeros((m, 2))
        near = state["near"]
        if near is not None and near.size:
            fs[near] = state["z"].reshape(-1, 2) / h
        rec["t"].append(t1), rec["q"].append(q1.copy()), rec["com"].append(c), rec["vcom"].append(v)
        rec["f"].append(res.forces), rec["fs"].append(fs), rec["status"].append(res.status)
        rec["res"].append([res.residuals[g] for g in ("dynamics", "contact", "cone", "limits")])

    start = time.perf_counter()
    outcome, end, cause = "balanced", float(t_end), ""
    try:
        drive(advance, grid, y0, record=record, record_every=record_every)
    except _Stop:
        outcome, end, cause = state["stop"]
    except _Branch:
        k, y, saved, modes, records = state["snapshot"]
        saved["wall"] = state["wall"] + time.perf_counter() - start
        return k, y, saved, modes, records
    wall = state["wall"] + time.perf_counter() - start
    arr = lambda key, shape: np.array(rec[key]).reshape((-1,) + shape)  # noqa: E731
    return BalanceResult(t=np.array(rec["t"]), q=arr("q", (nv,)), com=arr("com", (2,)), vcom=arr("vcom", (2,)),
                         com_target=target, forces=arr("f", (m, 2)), sim_forces=arr("fs", (m, 2)),
                         status=rec["status"], residuals=arr("res", (4,)), outcome=outcome, end_time=float(end),
                         cause=cause, push_time=push_time, push=push, support=support, mu=ground.mu, h=h,
                         wall_time=wall, qp_time=state["qp"])
