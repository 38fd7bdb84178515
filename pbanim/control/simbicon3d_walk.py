"""Running the 3-D biped: the controller, the lean contact step and the fall detector in one loop (chapter 08).

Each step of length h: the controller (:class:`.simbicon3d.Simbicon3D`) reads the state and the foot
strikes of the last step and returns τ₀ and the stable-PD damping k; the lean step
(:class:`.biped3d_step.WorldStep`) advances the biped with contact and box friction; a foot "strikes" when
one of its four sole corners carries a normal impulse. A fall (the pelvis below 0.7 m, or the trunk tipped
past 1 rad) stops the run and is reported with its time and cause. Runs go through the one fixed-step
driver (:mod:`pbanim.ode.driver`: its grid, its cap; its finiteness check → ``SimulationDiverged`` made in the
step itself, before the fall test reads q⁺, without the check's own argument checks).

A push is an impulse P (N s, horizontal, world frame) on the torso's centre of mass at time t_P:
Δq̇ = H⁻¹ J_cᵀ P; or, with ``push_phase`` = (state, delay, duration), the force P / duration (generalized
force J_cᵀ P / duration added to τ₀) over ``duration`` seconds from ``delay`` after the first entry into
``state`` at or after t_P (e.g. ("R0", 0.1, 0.1): 0.1 s after a right-foot strike, for 0.1 s; each step
receives its share of the window, so Σ h F = P; a delay of at least h). A turn moves the controller's heading ψ̄ toward a new value from a given time, at 0.5 rad/s (a step change
of 0.7 rad at once fell within 0.4 s: the stance hip's yaw torque spun the stance foot).

The start: standing straight, both soles on the ground, moving forward at ``speed`` (default
:data:`START_SPEED` = 0.5 m/s). The walk's basin of starts is narrow, its lower edge between 0.38 and 0.45 m/s
at the steps measured: at h = 1 ms starts of 0.45, 0.5 and 0.55 m/s walk, 0.3 and 0.4 m/s fall (3.39 s, 2.84
s: the slow first steps collapse the stance leg), 0.7 m/s falls at 0.80 s (legs together, too fast to step);
at h = 2 ms 0.38 m/s falls (2.67 s) and 0.40, 0.42 walk. A 0.4 m/s start (this runner's earlier default) sat
on that edge, so whether it fell looked like a matter of h (fell at 1 and 1.5 ms, walked at 2–4 ms); from 0.5
m/s the walk is converged in h: 20 s at h = 1, 1.5, 2, 3, 3.5 ms all walk, 62, 62, 62, 61, 61 strikes, 16.07,
16.04, 16.02, 15.98, 15.99 m, 0.827–0.823 m/s over the last 5 s; h = 4 ms falls (3.43 s; it walked from 0.4
m/s), 5 ms (2.31 s) — those with the earlier gains (300/30 swing hip, no stance-hip yaw damper); with
:data:`.simbicon3d.WALK3D`'s: 20 s at 2 and 3.5 ms (65 strikes, 0.89 and 0.90 m/s; with the contact's exact
solve, :mod:`.biped3d_step`: 65 strikes, 0.887 and 0.904 m/s over the last 5 s), 6 s at 1 and 4 ms.
Pushes, turns: ORACLES F18.
"""

from __future__ import annotations

import time
from math import cos
from dataclasses import dataclass

import numpy as np

from ..contracts import Array, Choice, Int, Obj, Opt, Real, contract, unchecked
from ..ode.driver import MAX_STEPS, check_finite_quick, drive, step_grid
from .biped3d import biped3d, biped3d_contact_points, standing_state3d
from .biped3d_step import WorldStep
from .simbicon3d import WALK3D, Gait3D, Simbicon3D
from .specs import Items

__all__ = ["Walk3DResult", "simulate_walk3d"]


START_SPEED = 0.5        # m/s: the start's forward speed, inside the walk's basin (see the module docstring)
TURN_RATE = 0.5          # rad/s: how fast the heading target turns toward a new heading
_COS1 = cos(1.0)                                     # the trunk's tip at which the walk has fallen: 1 rad


class _Fell(Exception):
    pass


@dataclass
class Walk3DResult:
    """States, centre of mass, machine trace, fall (time, cause), wall time and step of a 3-D walk."""

    t: np.ndarray
    q: np.ndarray
    com: np.ndarray
    heading: np.ndarray
    trace: list
    fell: bool
    fall_time: float | None
    fall_cause: str
    wall_time: float
    h: float

    @contract(last=Real(gt=0))
    def speed(self, last: float = 5.0) -> float:
        """Mean horizontal speed of the centre of mass over the last ``last`` seconds (m/s)."""
        k = self.t >= self.t[-1] - last
        d = self.com[k][-1, :2] - self.com[k][0, :2]
        return float(np.linalg.norm(d) / max(self.t[k][-1] - self.t[k][0], 1e-12))

    @property
    def steps(self) -> int:
        """Foot strikes: the number of entries into R0 or L0 after the start."""
        return sum(1 for _, s in self.trace[1:] if s in ("R0", "L0"))

    @property
    def realtime_factor(self) -> float:
        """Simulated seconds per wall-clock second."""
        t_sim = self.fall_time if self.fell else float(self.t[-1])
        return float(t_sim / self.wall_time) if self.wall_time > 0 else float("inf")


@contract(gait=Obj(Gait3D), t_end=Real(gt=0, le=600), h=Real(gt=0, le=0.01), speed=Real(ge=0, le=2),
          push=Opt(Array((3,))), turn=Opt(Array((2,))), friction=Real(ge=0), record_every=Int(ge=1),
          max_steps=Int(ge=1), push_phase=Opt(Items(Choice(("R0", "R1", "L0", "L1")), Real(ge=0, le=5), Real(gt=0, le=5))))
def simulate_walk3d(gait: Gait3D = WALK3D, t_end: float = 20.0, h: float = 2e-3, *, speed: float = START_SPEED,
                    push=None, turn=None, friction: float = 0.9, record_every: int = 25,
                    max_steps: int = MAX_STEPS, push_phase=None) -> Walk3DResult:
    """Walk the 3-D biped from a standing start moving at ``speed`` m/s. ``push``: (t_P, P_x, P_y), an
    impulse (N s, world) on the torso at time t_P (spread over a phase with ``push_phase``: module docstring);
    ``turn``: (t, ψ̄), the heading target from time t."""
    if push_phase is not None:
        phase, delay, duration = push_phase
    tree = biped3d()
    ws = WorldStep(tree, biped3d_contact_points(tree), friction=friction, tol=1e-5)
    ctrl = Simbicon3D(ws, gait)
    torques, stepf, kinematics = unchecked(ctrl.torques), unchecked(ws.step), unchecked(ws.kinematics)
    q0, qd0 = standing_state3d(speed=speed)
    nq = tree.nq
    torso = [lk.name for lk in tree.links].index("torso")
    M = float(ws.mass.sum())
    state = {"events": (), "pushed": False, "window": None}
    ts, qs, coms, heads = [], [], [], []

    def record(t1, y1):
        kin = kinematics(y1[:nq])
        ts.append(t1), qs.append(y1[:nq].copy()), coms.append(ws.mass @ kin["c"] / M)
        heads.append(ctrl.history[-1][4] if ctrl.history else 0.0)

    def advance(t, y, hh):
        q, qd = y[:nq], y[nq:]
        if turn is not None and t >= turn[0]:                   # ψ̄ moves toward the new heading at TURN_RATE
            ctrl.heading += float(np.clip(turn[1] - ctrl.heading, -TURN_RATE * hh, TURN_RATE * hh))
        kin = kinematics(q)
        force = None
        if push is not None and push_phase is None and not state["pushed"] and t >= push[0]:
            _, Jc = ws.point_jacobians(kin, np.array([torso]), ws.com[[torso]])
            qd = qd + np.linalg.solve(ws.mass_matrix(kin), Jc[0].T @ np.array([push[1], push[2], 0.0]))
            state["pushed"] = True
        elif push is not None and push_phase is not None:
            w = state["window"]
            if w is None and ctrl.fsm.state == phase and ctrl.fsm.entered >= push[0]:
                w = state["window"] = (ctrl.fsm.entered + delay, ctrl.fsm.entered + delay + duration)
            overlap = 0.0 if w is None else min(t + hh, w[1]) - max(t, w[0])
            if overlap > 0:                                  # the step's share of the window: Σ h F = P exactly
                _, Jc = ws.point_jacobians(kin, np.array([torso]), ws.com[[torso]])
                force = Jc[0].T @ np.array([push[1], push[2], 0.0]) * (overlap / (duration * hh))
        tau, k = torques(t, q, qd, state["events"], kin, hh)
        if force is not None:
            tau = tau + force
        q1, u1 = stepf(q, qd, hh, tau, k, kin)
        y1 = np.concatenate([q1, u1])
        check_finite_quick(y1, t, round(t / h), max_size=64)      # the driver's check, |y|² on floats
        left = right = False
        if ws.last is not None:                                  # corners 0–3 the left sole's, 4–7 the right's
            for c, f in zip(ws.last["contacts"].tolist(), ws.last["impulses"][0::3].tolist()):
                if f > 0:
                    if c < 4:
                        left = True
                    elif c < 8:
                        right = True
        state["events"] = ("left_strike",) * left + ("right_strike",) * right
        kin1 = kinematics(q1)
        r22 = kin1["Rf"][0][8] if "Rf" in kin1 else float(kin1["R"][0, 2, 2])     # the pelvis's R₂₂
        cause = ("pelvis dropped below 0.7 m" if q1[6] < 0.7 else
                 f"trunk tipped {np.degrees(np.arccos(min(r22, 1.0))):.0f}°" if r22 < _COS1 else "")
        if cause:
            state["fall"] = (t + hh, cause)
            raise _Fell(cause)
        return y1

    grid = step_grid(0.0, t_end, h, max_steps=max_steps, record_every=record_every)
    y0 = np.concatenate([q0, qd0])
    record(0.0, y0)
    start = time.perf_counter()
    fell, fall_time, cause = False, None, ""
    try:
        drive(advance, grid, y0, record=record, record_every=record_every, check_every=grid.n_steps)
    except _Fell:
        fell, (fall_time, cause) = True, state["fall"]
    wall = time.perf_counter() - start
    return Walk3DResult(t=np.array(ts), q=np.array(qs), com=np.array(coms), heading=np.array(heads),
                        trace=list(ctrl.fsm.trace), fell=fell, fall_time=fall_time, fall_cause=cause,
                        wall_time=wall, h=h)
