"""Running a character: the controller, the contact step and the fall detector in one loop (chapter 08).

Each step of length h: the controller reads the state and the events of the last step (which foot
struck the ground) and returns joint forces; :class:`~pbanim.articulated.planar_step.PlanarContactStep`
advances the biped with contact and friction; then the fall detector looks at the new state. A fall is
reported as a fall — its time and its cause (the torso tipped past 1 rad, the hips dropped below half
their standing height, a knee or the torso touched the ground) — and the run stops there; a state that
is no longer finite raises :class:`~pbanim.errors.SimulationDiverged`. Runs use the one fixed-step
driver (:mod:`pbanim.ode.driver`): its step grid, its cap on the number of steps, its finiteness check.

A push is an impulse on the torso's centre of mass, P (N s, horizontal), applied at a chosen phase of a
chosen step: Δq̇ = H⁻¹ J_cᵀ P. The phase runs from 0 at a right-foot strike (the machine enters R0) to 1
at the next left-foot strike, measured with the duration of the step before.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field

import numpy as np

from ..articulated.planar import PlanarKernel
from ..articulated.planar_step import PlanarContactStep, PlanarGround
from ..contracts import Choice, Flag, Int, Obj, Opt, Real, contract, unchecked
from ..errors import InvalidInput
from .biped import BIPED_JOINTS as JI, biped_contact_points, planar_biped
from ..ode.driver import MAX_STEPS, drive, step_grid
from .simbicon import WALK, Gait, Simbicon

__all__ = ["Push", "WalkResult", "simulate_walk", "Fell", "stick_figure", "fall_cause", "start_state"]


class Fell(Exception):
    """Raised inside the loop to stop it at a fall (caught by :func:`simulate_walk`)."""


class Settled(Exception):
    """Raised inside the loop to stop a pushed run once it has recovered (``settle`` of
    :func:`.walk_branch.simulate_pushes`); the run ends there, not fallen."""


@contract(impulse=Real(ge=-1e4, le=1e4), phase=Real(ge=0, lt=1), count=Int(ge=2))
@dataclass(frozen=True)
class Push:
    """An impulse ``impulse`` (N s, +x forward, |P| ≤ 10⁴) on the torso at ``phase`` ∈ [0, 1) of the
    ``count``-th right step (0: the right foot strikes, 1: the left foot strikes; count ≥ 2: a step before
    it gives the duration)."""

    impulse: float
    phase: float = 0.5
    count: int = 10


@dataclass
class WalkResult:
    """What a run gives: states, FSM trace, fall (time and cause) and summary numbers."""

    t: np.ndarray
    q: np.ndarray
    qd: np.ndarray
    trace: list
    fell: bool
    fall_time: float | None
    fall_cause: str
    wall_time: float
    h: float
    com: np.ndarray
    strikes: list = field(default_factory=list)
    push_time: float | None = None
    targets: list = field(default_factory=list)
    settled: float | None = None        # stopped here as recovered (simulate_pushes' settle), else None

    @contract(last=Real(gt=0))
    def speed(self, last: float = 5.0) -> float:
        """Mean forward speed of the centre of mass over the last ``last`` seconds (m/s)."""
        k = self.t >= self.t[-1] - last
        return float((self.com[k][-1, 0] - self.com[k][0, 0]) / max(self.t[k][-1] - self.t[k][0], 1e-12))

    @property
    def realtime_factor(self) -> float:
        """Simulated seconds (up to the fall, if it fell) per wall-clock second."""
        t_sim = self.fall_time if self.fell else self.t[-1]
        return float(t_sim / self.wall_time) if self.wall_time > 0 else float("inf")


def fall_cause(kernel, kin, q, ground) -> str:
    """Why the biped at q has fallen ("" while it stands): the torso tipped past 1 rad, the hips dropped
    below half their standing height, or a knee touched the ground."""
    if abs(q[JI["torso"]]) > 1.0:
        return f"torso tipped to {q[JI['torso']]:.2f} rad"
    o = kin["o"]
    names = [lk.name for lk in kernel.tree.links]
    hip = ground.gap(o[names.index("torso")][None])[0]
    if hip < 0.5 * (kernel.tree.joints[0].p[1]):
        return f"hips dropped to {hip:.2f} m"
    for nm in ("left_shin", "right_shin"):
        if ground.gap(o[names.index(nm)][None])[0] < 0.02:
            return f"{nm.split('_')[0]} knee touched the ground"
    return ""


@contract(kernel=Obj(PlanarKernel), ground=Obj(PlanarGround), split=Real(ge=0, le=0.6), speed=Real(ge=-3, le=3),
          clearance=Real(ge=0, le=0.1))
def start_state(kernel: PlanarKernel, ground: PlanarGround, split: float = 0.2, speed: float = 0.4,
                clearance: float = 1e-4) -> tuple[np.ndarray, np.ndarray]:
    """(q₀, q̇₀): a walk in progress placed on the terrain. Torso upright, the right leg ``split`` rad ahead
    and the left one behind, both feet flat on the ground line (ankle = α − shin angle, α the slope), the
    body lifted so that the lowest of the four heel and toe points is ``clearance`` above the line (on a
    slope the front foot touches and the back one hangs above it, never inside); moving at ``speed`` m/s
    along the slope."""
    alpha = ground.angle
    q0 = np.zeros(kernel.nv)
    q0[JI["right_hip"]], q0[JI["left_hip"]] = split, -split
    q0[JI["right_ankle"]], q0[JI["left_ankle"]] = alpha - split, alpha + split
    pts = biped_contact_points(kernel.tree)
    kin = kernel.kinematics(q0)
    p = kernel.point_positions(kin, np.array([lk for lk, _ in pts]), np.array([r for _, r in pts]))
    q0[1] = (clearance - float(np.min(ground.gap(p)))) / ground.normal[1]     # lift along y: gap grows by n_y Δy
    qd0 = np.zeros(kernel.nv)
    qd0[0], qd0[1] = speed * ground.tangent
    return q0, qd0


@contract(gait=Obj(Gait), t_end=Real(gt=0), h=Real(gt=0), slope=Real(ge=-np.pi / 3, le=np.pi / 3), feedback=Flag(),
          push=Opt(Obj(Push)), servo=Choice(("explicit", "stable")), friction=Real(ge=0), record_every=Int(ge=1),
          max_steps=Int(ge=1), controller=Opt(Obj(Simbicon)), lean=Flag())
def simulate_walk(gait: Gait = WALK, t_end: float = 20.0, h: float = 5e-4, *, slope: float = 0.0,
                  feedback: bool = True, push: Push | None = None, servo: str = "explicit",
                  friction: float = 0.9, record_every: int = 20, max_steps: int = MAX_STEPS,
                  controller: Simbicon | None = None, lean: bool = True) -> WalkResult:
    """Walk the planar biped with SIMBICON on a ground of slope ``slope`` (rad, |slope| ≤ π/3) from a
    standing start. ``controller``: a :class:`Simbicon` of one's own (it carries its gait, feedback and
    servos, so those three are then not given).

    ``lean`` (default): each step runs the lean path of :mod:`.walk_lean` (the same arithmetic without the
    readable path's per-call overhead: the same states bit for bit, tested); ``lean=False`` runs the readable
    step below — the controller's :meth:`Simbicon.torques` and :class:`PlanarContactStep` — and is what a
    controller of one's own (a subclass with other torques) always runs."""
    if controller is not None and (gait is not WALK or feedback is not True or servo != "explicit"):
        raise InvalidInput("simulate_walk: give either controller (which carries its own gait, feedback and "
                           "servo) or gait, feedback and servo, not both")
    parts = _walker(gait, t_end, h, slope, feedback, servo, friction, record_every, max_steps, controller)
    return _run_walk(parts, push, _new_state(), lean, record_every)


def _walker(gait, t_end, h, slope, feedback, servo, friction, record_every, max_steps, controller=None) -> tuple:
    """(kernel, ground, stepper, controller (reset), step grid, q₀, q̇₀): what a walk is set up with."""
    tree = planar_biped()
    kernel = PlanarKernel(tree)
    ground = PlanarGround(slope, friction)
    stepper = PlanarContactStep(kernel, biped_contact_points(tree), ground)
    ctrl = controller or Simbicon(kernel, gait, feedback=feedback, servo=servo)
    ctrl.reset()
    grid = step_grid(0.0, t_end, h, max_steps=max_steps, record_every=record_every)
    q0, qd0 = start_state(kernel, ground)
    return kernel, ground, stepper, ctrl, grid, q0, qd0


def _new_state() -> dict:
    """The loop's bookkeeping at the start of a walk (events, machine entries, push, strikes)."""
    return {"events": (), "entries": {}, "pushed": None, "strikes": [], "enter": {}, "step": None}


def _run_walk(parts: tuple, push, state: dict, lean: bool, record_every: int, *, records=None, wrap=None,
             y0=None) -> WalkResult:
    """Drive the walk of ``parts`` (:func:`_walker`) over its grid. ``records`` (t, q, q̇, c lists, default: the
    start state's), ``wrap`` (a function of the step function, returning the one to drive) and ``y0`` (the
    state handed to the driver) let :mod:`.walk_branch` continue a walk from a saved state."""
    kernel, ground, stepper, ctrl, grid, q0, qd0 = parts
    ts, qs, qds, coms = records or ([0.0], [q0.copy()], [qd0.copy()], [kernel.centre_of_mass(q0)])
    run = (kernel, ground, stepper, ctrl, push, state)
    check_every = 1
    if lean and _leanable(ctrl, kernel):
        from .walk_lean import lean_advance

        advance = lean_advance(*run)
        check_every = grid.n_steps             # the lean step returns finite states only (else the readable raises)
    else:
        advance = _readable_advance(*run)
    record = None
    if wrap is not None:
        advance, record = wrap(advance)

    def record_state(t1, y1):
        if record is None or record():
            ts.append(t1), qs.append(y1[:9].copy()), qds.append(y1[9:].copy())
            coms.append(kernel.centre_of_mass(y1[:9]))

    start = time.perf_counter()
    fell, fall_time, cause = False, None, ""
    try:
        drive(advance, grid, np.concatenate([q0, qd0]) if y0 is None else y0, record=record_state,
              record_every=record_every, check_every=check_every)
    except Fell:
        fell, (fall_time, cause) = True, state["fall"]
    except Settled:
        pass                                   # state["settled"]: the time the run was stopped as recovered
    wall = time.perf_counter() - start
    return WalkResult(t=np.array(ts), q=np.array(qs), qd=np.array(qds), trace=list(ctrl.fsm.trace), fell=fell,
                      fall_time=fall_time, fall_cause=cause, wall_time=wall, h=grid.h, com=np.array(coms),
                      strikes=state["strikes"], push_time=state["pushed"], targets=list(ctrl.history[::record_every]),
                      settled=state.get("settled"))


def _leanable(ctrl: Simbicon, kernel: PlanarKernel) -> bool:
    """Whether the lean step computes what ``ctrl`` would: SIMBICON's own servos and balance (a subclass
    that overrides them runs the readable step) on a biped of the same masses."""
    cls = type(ctrl)
    return (cls.torques is Simbicon.torques and cls.balance is Simbicon.balance and cls.sides is Simbicon.sides
            and ctrl.kernel.n == kernel.n and np.array_equal(ctrl.kernel.mass, kernel.mass))


# -- between the steps: what both paths do (the machine's bookkeeping, the push, the strikes, the fall) ------
def note_transition(state: dict, now: str, t: float) -> None:
    """The machine entered ``now`` at time t: count it, and time the right step when the left one starts."""
    state["entries"][now] = state["entries"].get(now, 0) + 1
    state["enter"][now] = t
    if now == "L0" and "R0" in state["enter"]:
        state["step"] = t - state["enter"]["R0"]            # duration of the last right step


def push_due(push, state: dict, now: str, t: float) -> bool:
    """Whether the push lands in this step (its phase of its step reached, not yet applied)."""
    return (push is not None and state["pushed"] is None and now in ("R0", "R1")
            and state["entries"].get("R0", 0) == push.count and state["step"] is not None
            and t - state["enter"]["R0"] >= push.phase * state["step"])


def pushed_velocity(kernel: PlanarKernel, kin: dict, q, qd, impulse: float):
    """q̇ + H⁻¹ J_cᵀ P: the push P (horizontal) on the torso's centre of mass."""
    links = np.array([[lk.name for lk in kernel.tree.links].index("torso")])
    Jc = kernel.jacobians(kin, links, kin["c"][links])[0]
    H, _, _ = kernel.dynamics(q, qd)
    return qd + np.linalg.solve(H, Jc.T @ np.array([impulse, 0.0]))


def note_strikes(state: dict, events: tuple, now: str, t1: float) -> None:
    """A foot struck the ground at the end of a step in which it swung (the machine in state 1 of the
    other side's stance)."""
    for side in ("left", "right"):
        if f"{side}_strike" in events and now[0] != side[0].upper() and now.endswith("1"):
            state["strikes"].append((t1, side))


def _readable_advance(kernel, ground, stepper, ctrl, push, state):
    """One step: the controller, the push, the contact step, the events, the fall detector."""
    torques = unchecked(ctrl.torques)
    foot_points = {"left": [0, 1], "right": [2, 3]}

    def advance(t, y, hh):
        q, qd = y[:9], y[9:]
        before = ctrl.fsm.state
        kin = state.pop("kin", None) or kernel.kinematics(q)
        kernel.com_jacobians(kin)                                  # cached in kin: shared by controller and step
        tau, kd = torques(t, q, qd, state["events"], kin, hh)
        if ctrl.fsm.state != before:
            note_transition(state, ctrl.fsm.state, t)
        if push_due(push, state, ctrl.fsm.state, t):
            qd = pushed_velocity(kernel, kin, q, qd, push.impulse)
            state["pushed"] = t
        q1, u1 = stepper.step(q, qd, hh, tau, kd if np.any(kd) else None, kin)
        f = stepper.contact_forces(hh)
        events = tuple(f"{side}_strike" for side, idx in foot_points.items() if np.any(f[idx] > 0))
        note_strikes(state, events, ctrl.fsm.state, t + hh)
        state["events"] = events
        state["kin"] = kin1 = kernel.kinematics(q1)
        cause = fall_cause(kernel, kin1, q1, ground)
        if cause:
            state["fall"] = (t + hh, cause)
            raise Fell(cause)
        return np.concatenate([q1, u1])

    return advance


def stick_figure(kernel: PlanarKernel, q) -> list:
    """Line segments (each a (k, 2) array) drawing the biped at q: torso, thighs, shins, feet (heel–ankle–toe)."""
    kin = kernel.kinematics(np.asarray(q, dtype=float))
    names = [lk.name for lk in kernel.tree.links]
    o = kin["o"]
    i = names.index("torso")
    top = o[i] + 2.0 * (kin["c"][i] - o[i])                    # the torso's centre is halfway up
    segs = [np.array([o[i], top])]
    pts = biped_contact_points(kernel.tree)
    heel_toe = kernel.point_positions(kin, np.array([lk for lk, _ in pts]), np.array([p for _, p in pts]))
    for k, side in enumerate(("left", "right")):
        th, sh, ft = (names.index(f"{side}_{s}") for s in ("thigh", "shin", "foot"))
        segs.append(np.array([o[th], o[sh], o[ft]]))
        segs.append(np.array([heel_toe[2 * k], o[ft], heel_toe[2 * k + 1], heel_toe[2 * k]]))
    return segs
