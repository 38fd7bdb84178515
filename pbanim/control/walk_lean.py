"""The walk's step on its lean path: SIMBICON's servos on Python floats, the planar contact step in one pass.

:func:`~pbanim.control.walk.simulate_walk` steps the biped thousands of times per run (the push envelope of
the chapter: 70 pushed runs of 7 s at h = 2 ms, each branched from the walk before its push by
:mod:`.walk_branch`). The readable step asks the controller (:meth:`Simbicon.torques`:
the machine, the balance feedback, a servo per joint in a loop over names) and then the contact step
(:class:`~pbanim.articulated.planar_step.PlanarContactStep`); each goes through a dozen calls that exist to
be read. Here the same step is taken with what depends only on the gait — per state of the machine the
joints of stance and swing, their targets and gains, the feedback gains — gathered once, the servos

    τ = k_p (θ̄ − θ) − k_v θ̇          (explicit),       τ = k_p (θ̄ − θ − h θ̇),  K_d = k_v     (stable),
    τ_torso = k_p (θ̄_tor − φ) − k_v φ̇,   τ_swing = k_p (θ̄_swh + c_d d + c_v v − (φ + θ_swh)) − k_v (φ̇ + θ̇_swh),
    τ_stance = −τ_torso − τ_swing,       τ ← clip(τ, −τ_max, τ_max)

evaluated on Python floats, and :class:`~pbanim.articulated.planar_lean.LeanPlanarStep` for the contact
step. Every operation is the readable path's, in its order: the two paths give the same walk bit for bit
(tests/test_simbicon.py runs both). The machine itself (:class:`~pbanim.control.fsm.StateMachine`), the push,
the strikes and the fall detector are the readable ones, called directly; the controller's ``history`` gets
the same entries as on the readable path.

Notation as in :mod:`.simbicon`: φ torso angle, θ joint angles, d and v the centre of mass's horizontal offset
from the stance ankle and its horizontal velocity, c_d and c_v the feedback gains, δt the timed states.
"""

from __future__ import annotations

import numpy as np

from ..articulated.planar_lean import LeanPlanarStep
from .biped import BIPED_JOINTS as JI
from .simbicon import SIDES, _update
from .walk import Fell, fall_cause, note_strikes, note_transition, push_due, pushed_velocity

__all__ = ["lean_advance", "servo_table"]

_TORSO = JI["torso"]


def servo_table(ctrl) -> dict:
    """Per state of the controller's machine: (stance hip, swing hip, the four joint-space servos as
    (name, index, target, k_p, k_v), φ̄_torso, θ̄_swh, c_d, c_v, the stance ankle's link)."""
    g = ctrl.gait
    kp, kv = g.kp, g.kv
    table = {}
    for name, ph in ctrl.fsm.states.items():
        stance, swing = SIDES[name[0]]
        servos = tuple((joint, JI[joint], target, kp[kind], kv[kind])
                       for joint, target, kind in ((f"{swing}_knee", ph.swk, "knee"), (f"{swing}_ankle", ph.swa, "ankle"),
                                                   (f"{stance}_knee", ph.stk, "knee"), (f"{stance}_ankle", ph.sta, "ankle")))
        cd, cv = (ph.cd, ph.cv) if ctrl.feedback else (None, None)
        table[name] = (JI[f"{stance}_hip"], JI[f"{swing}_hip"], f"{stance}_hip", f"{swing}_hip", servos, ph.tor,
                       ph.swh, cd, cv, ctrl.ankle_link[stance])
    return table


def lean_advance(kernel, ground, stepper, ctrl, push, state):
    """``advance(t, y, h)`` for the driver: the step of ``_readable_advance`` on the lean path."""
    lean = LeanPlanarStep(stepper)
    fsm = ctrl.fsm
    table = servo_table(ctrl)
    g = ctrl.gait
    kp_t, kv_t, kp_h, kv_h, lim = g.kp["torso"], g.kv["torso"], g.kp["hip"], g.kv["hip"], g.limit
    stable = ctrl.servo == "stable"
    mass = kernel.mass
    M = mass.sum()
    nv = kernel.nv
    history = ctrl.history
    nan = float("nan")
    normal = ground.normal.tolist()
    names = [lk.name for lk in kernel.tree.links]
    torso, shins = names.index("torso"), [names.index("left_shin"), names.index("right_shin")]
    hip_floor = 0.5 * kernel.tree.joints[0].p[1]

    def advance(t, y, hh):
        q, qd = y[:9], y[9:]
        before = fsm.state
        kin = state.pop("lean_kin", None) or lean.kinematics(q)
        rot, w, zo, zc = kin
        Jz = lean.com_jacobians(zo, zc)
        _update(fsm, t, state["events"])
        now = fsm.state
        st, sw, st_name, sw_name, servos, tor, swh, cd, cv, ankle = table[now]
        # the balance feedback: Simbicon.balance by PlanarKernel.centre_of_mass's formulas
        com = mass @ zc.view(np.float64).reshape(-1, 2) / M
        d = float(com[0] - zo[ankle].real)
        v = float((mass @ (Jz @ qd) / M).real)
        fb = (cd * d + cv * v) if cd is not None else 0.0
        ql, qdl = q.tolist(), qd.tolist()
        tau = [0.0] * nv
        kd = [0.0] * nv if stable else None
        rec = {}
        for joint, i, target, kp, kv in servos:
            rec[joint] = (target, ql[i])
            if stable:
                tau[i], kd[i] = kp * (target - ql[i] - hh * qdl[i]), kv
            else:
                tau[i] = kp * (target - ql[i]) - kv * qdl[i]
        phi, phid = ql[_TORSO], qdl[_TORSO]
        tau_torso = kp_t * (tor - phi) - kv_t * phid
        tau_swing = kp_h * (swh + fb - (phi + ql[sw])) - kv_h * (phid + qdl[sw])
        tau[sw] = tau_swing
        tau[st] = -tau_torso - tau_swing
        rec["torso"] = (tor, phi)
        rec[sw_name] = (swh + fb, phi + ql[sw])
        rec[st_name] = (nan, phi + ql[st])
        tau = np.array([-lim if x < -lim else lim if x > lim else x for x in tau])
        history.append((t, now, d, v, rec))
        if now != before:
            note_transition(state, now, t)
        if push_due(push, state, now, t):
            qd = pushed_velocity(kernel, kernel.kinematics(q), q, qd, push.impulse)
            state["pushed"] = t
        if kd is not None:
            kd = np.array(kd) if any(kd) else None
        q1, u1, near, z = lean.step(q, qd, hh, tau, kd, kin, Jz)
        events = ()
        if z is not None:
            zl = z.tolist()
            feet = [False, False]
            for j, c in enumerate(near.tolist()):
                if zl[2 * j] / hh > 0:
                    feet[c // 2] = True
            events = tuple(f"{side}_strike" for side, hit in zip(("left", "right"), feet) if hit)
            note_strikes(state, events, now, t + hh)
        state["events"] = events
        state["lean_kin"] = kin1 = lean.kinematics(q1)
        zo1 = kin1[2]
        gaps = [o.real * normal[0] + o.imag * normal[1] for o in (zo1[torso], zo1[shins[0]], zo1[shins[1]])]
        if abs(q1[_TORSO]) > 1.0 - 1e-9 or gaps[0] < hip_floor + 1e-9 or min(gaps[1:]) < 0.02 + 1e-9:
            cause = fall_cause(kernel, kernel.kinematics(q1), q1, ground)    # near a threshold: the readable test
            if cause:
                state["fall"] = (t + hh, cause)
                raise Fell(cause)
        return np.concatenate([q1, u1])

    return advance
