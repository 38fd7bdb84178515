"""SIMBICON: a planar biped walks with PD servos, a four-state machine and balance feedback (chapter 08).

Yin, Loken & van de Panne (SIGGRAPH 2007) make a biped walk with three ideas:

1. **A finite state machine** of four states per stride: right stance for δt seconds (state 0), right
   stance until the left foot strikes the ground (state 1), then the mirror images (states 2, 3). Each
   state holds targets θ̄ for the swing hip (swh), swing knee (swk), swing ankle (swa), stance knee (stk),
   stance ankle (sta) and the torso (tor); joint-space PD servos track them.
2. **The torso and the swing hip are servoed in the world frame**: τ_torso = k_p(θ̄_tor − φ) − k_v φ̇ is the
   torque the torso needs, and since only the hips can give it, the stance hip supplies the rest:
   τ_stance = −τ_torso − τ_swing.
3. **Balance feedback** on the swing hip's world-frame target:

       θ̄_swh = θ̄_swh,0 + c_d d + c_v v,

   d the horizontal distance from the stance ankle to the centre of mass, v the centre of mass's
   horizontal velocity. Falling forward (d, v > 0) places the swing foot further ahead, which catches
   the fall; with c_d = c_v = 0 the same servos and machine fall within a few steps (tested).

A gait is a handful of numbers (:class:`Gait`). :data:`WALK` is the paper's planar walk, Table 1 of Yin,
Loken & van de Panne 2007, exactly: δt = 0.3 s; states 0/2: c_d 0, c_v 0.2, tor 0, swh 0.4, swk −1.1,
swa 0.2, stk −0.05, sta 0.2; states 1/3: c_d 2.2, c_v 0, tor 0, swh −0.7, swk −0.05, swa 0.2, stk −0.1,
sta 0.2; gains k_p = 300 N m/rad, k_v = 30 N m s/rad on every joint, as in the paper's 2-D biped. In our
model it walks 20 s at 1.02 m/s with stable PD at every step we measured from 0.5 to 25 ms (ORACLES F4).
With explicit PD (the paper's servo) the same gains ask for a small step: the swing foot (1 kg, I = 0.0035
kg m²) under k_v = 30 has h k_v / I ≈ 17 at h = 2 ms, far past F1's bound 2 for a free foot, and the walk
falls at 1 and 2 ms while it walks at 0.5, 0.7 and 0.8 ms (measured; falls at 0.6 ms: the explicit walk is
not robust, the stable one is). The swing hip's −0.7 in states 1/3 with c_d = 2.2 retracts the swing leg
until it strikes, so states 1/3 last a few milliseconds to a few tens of milliseconds.

:data:`FAST_WALK` is ours: Table 1's walk with δt = 0.2 s and the torso leaned 0.1 rad forward (tor = −0.1),
to show that a gait is its numbers (measured 1.66 m/s at h = 2 ms against the walk's 1.02). An earlier
version of this module shipped a walk of its own (swh 0.5/−0.1, swa 0.6/0.15, sta 0/0 and ankle gains
30/3): it was tuned around the too-low ankle gains and is gone; Table 1 walks as it stands.
The servos are explicit PD (the paper's), or stable PD (:mod:`.pd`) for the joint-space joints.

Notation: φ torso angle (world, positive leaning back); θ joint angles (hips relative to the torso, knees
and ankles relative to the segment above); d, v as above; δt the timed states' duration.
"""

from __future__ import annotations

from dataclasses import dataclass, field, fields, replace

import numpy as np

from ..articulated.planar import PlanarKernel
from ..contracts import Array, Choice, Flag, Obj, Opt, Real, Text, contract, unchecked
from ..errors import InvalidInput
from .biped import BIPED_JOINTS as JI
from .fsm import StateMachine, Transition
from .specs import KinematicsOf, Mapping, Names, NotBefore, Pair

__all__ = ["Phase", "Gait", "WALK", "FAST_WALK", "Simbicon"]

_ANGLE = Real(ge=-np.pi, le=np.pi)              # a target angle [rad]
_FEEDBACK = Real(ge=0)                           # c_d [rad/m], c_v [rad s/m]: a negative gain moves the foot the wrong way
JOINT_KINDS = ("hip", "knee", "ankle", "torso")
_GAINS = Mapping(Choice(JOINT_KINDS), Real(ge=0), keys=JOINT_KINDS)
STATES = ("R0", "R1", "L0", "L1")
_STATE = Array(("self.kernel.nv",))


@contract(swh=_ANGLE, swk=_ANGLE, swa=_ANGLE, stk=_ANGLE, sta=_ANGLE, tor=_ANGLE, cd=_FEEDBACK, cv=_FEEDBACK)
@dataclass(frozen=True)
class Phase:
    """Targets of one state (radians) and its balance-feedback gains."""

    swh: float
    swk: float
    swa: float
    stk: float
    sta: float
    tor: float = 0.0
    cd: float = 0.0
    cv: float = 0.0


@contract(name=Text(), dt=Real(gt=0, le=5), phases=Pair(Obj(Phase), Obj(Phase)), kp=_GAINS, kv=_GAINS,
          limit=Real(gt=0))
@dataclass(frozen=True)
class Gait:
    """δt ∈ (0, 5] s, the two phases (timed, then until foot strike), PD gains per joint kind (hip, knee,
    ankle, torso; ≥ 0) and the torque limit (> 0)."""

    name: str
    dt: float
    phases: tuple
    kp: dict = field(default_factory=lambda: {"hip": 300.0, "knee": 300.0, "ankle": 300.0, "torso": 300.0})
    kv: dict = field(default_factory=lambda: {"hip": 30.0, "knee": 30.0, "ankle": 30.0, "torso": 30.0})
    limit: float = 400.0


# Yin, Loken & van de Panne 2007, Table 1, the walk (every number the paper's)
WALK = Gait("walk", 0.3, (Phase(swh=0.4, swk=-1.1, swa=0.2, stk=-0.05, sta=0.2, cd=0.0, cv=0.2),
                          Phase(swh=-0.7, swk=-0.05, swa=0.2, stk=-0.1, sta=0.2, cd=2.2, cv=0.0)))
# ours: Table 1's walk with shorter timed states and the torso leaned forward (a gait is its numbers)
FAST_WALK = Gait("fast walk (ours)", 0.2, tuple(replace(ph, tor=-0.1) for ph in WALK.phases))

SIDES = {"R": ("right", "left"), "L": ("left", "right")}       # state prefix → (stance, swing)


class Simbicon:
    """The controller: ``torques(t, q, qd, events, kin)`` → (τ₀, k) with τ = τ₀ − k ⊙ q̇⁺ (k = 0: explicit).

    ``feedback``: the balance feedback on (the paper's) or off (c_d = c_v = 0); ``servo``: "explicit" or
    "stable" (stable PD on knees and ankles); ``kernel``: the biped's :class:`PlanarKernel`.
    """

    @contract(kernel=Obj(PlanarKernel), gait=Obj(Gait), feedback=Flag(), servo=Choice(("explicit", "stable")),
              start=Choice(STATES))
    def __init__(self, kernel, gait: Gait = WALK, *, feedback: bool = True, servo: str = "explicit",
                 start: str = "R0") -> None:
        names = [lk.name for lk in kernel.tree.links]
        if kernel.nv != len(JI) or not {"left_foot", "right_foot", "torso"} <= set(names):
            raise InvalidInput(f"Simbicon: kernel must be the planar biped's (pbanim.control.biped.planar_biped: "
                               f"{len(JI)} coordinates, a torso and two feet), got {kernel.nv} coordinates and links "
                               f"{names}")
        self.kernel, self.gait, self.feedback, self.servo = kernel, gait, bool(feedback), servo
        p0, p1 = gait.phases
        states = {"R0": p0, "R1": p1, "L0": p0, "L1": p1}
        self.fsm = StateMachine(states, [Transition("R0", "R1", after=gait.dt), Transition("R1", "L0", on="left_strike"),
                                         Transition("L0", "L1", after=gait.dt), Transition("L1", "R0", on="right_strike")],
                                initial=start)
        self.ankle_link = {s: names.index(f"{s}_foot") for s in ("left", "right")}
        self.history: list = []
        self._balance = unchecked(self.balance)           # this class's or a subclass's, without the wrapper

    def sides(self) -> tuple[str, str]:
        """(stance, swing): "right", "left" in states R0, R1 and the mirror in L0, L1."""
        return SIDES[self.fsm.state[0]]

    @contract(q=_STATE, qd=_STATE, kin=Opt(KinematicsOf()))
    def balance(self, q, qd, kin=None) -> tuple[float, float]:
        """(d, v): the centre of mass's horizontal offset from the stance ankle, and its horizontal velocity."""
        k = self.kernel
        kin = k.kinematics(q) if kin is None else kin
        com, vcom = k.centre_of_mass(q, qd, kin)
        stance = self.sides()[0]
        return float(com[0] - kin["o"][self.ankle_link[stance]][0]), float(vcom[0])

    @contract(t=NotBefore("self.fsm.entered"), q=_STATE, qd=_STATE, events=Names(), kin=Opt(KinematicsOf()),
              h=Real(ge=0))
    def torques(self, t, q, qd, events=(), kin=None, h: float = 0.0):
        """Joint forces for the state (q, q̇) at time t after the events of the last step; ``h`` the step
        (stable PD). Records (t, state, d, v, {joint: (target, angle)}) in :attr:`history` (hips and torso
        in the world frame). Runs inside a step loop with no check of its own: the contract checks calls
        from outside."""
        _update(self.fsm, t, events)
        ph: Phase = self.fsm.payload
        stance, swing = self.sides()
        g = self.gait
        kp, kv = g.kp, g.kv
        tau, k = np.zeros(q.size), np.zeros(q.size)
        d, v = self._balance(q, qd, kin)
        fb = (ph.cd * d + ph.cv * v) if self.feedback else 0.0
        rec = {}
        # joint-space servos: swing knee and ankle, stance knee and ankle
        for joint, target, kind in ((f"{swing}_knee", ph.swk, "knee"), (f"{swing}_ankle", ph.swa, "ankle"),
                                    (f"{stance}_knee", ph.stk, "knee"), (f"{stance}_ankle", ph.sta, "ankle")):
            i = JI[joint]
            rec[joint] = (target, q[i])
            if self.servo == "stable":
                tau[i], k[i] = kp[kind] * (target - q[i] - h * qd[i]), kv[kind]
            else:
                tau[i] = kp[kind] * (target - q[i]) - kv[kind] * qd[i]
        # world-frame torso and swing hip; the stance hip balances the torso
        phi, phid = q[JI["torso"]], qd[JI["torso"]]
        tau_torso = kp["torso"] * (ph.tor - phi) - kv["torso"] * phid
        sw, st = JI[f"{swing}_hip"], JI[f"{stance}_hip"]
        tau_swing = kp["hip"] * (ph.swh + fb - (phi + q[sw])) - kv["hip"] * (phid + qd[sw])
        tau[sw] = tau_swing
        tau[st] = -tau_torso - tau_swing
        rec["torso"] = (ph.tor, phi)
        rec[f"{swing}_hip"] = (ph.swh + fb, phi + q[sw])                # world frame
        rec[f"{stance}_hip"] = (np.nan, phi + q[st])
        lim = g.limit
        np.clip(tau, -lim, lim, out=tau)
        self.history.append((t, self.fsm.state, d, v, rec))
        return tau, k

    @contract(t=Real())
    def reset(self, t: float = 0.0) -> None:
        """Back to the initial state at time t, history cleared."""
        _reset(self.fsm, t)
        self.history = []

    def with_gait(self, **changes) -> "Simbicon":
        """A fresh controller with gait fields replaced (e.g. ``dt=0.25``; checked as a new :class:`Gait`)."""
        unknown = sorted(set(changes) - {f.name for f in fields(Gait)})
        if unknown:
            raise InvalidInput(f"Simbicon.with_gait: {unknown} are not gait fields; the fields are "
                               f"{[f.name for f in fields(Gait)]}")
        return Simbicon(self.kernel, replace(self.gait, **changes), feedback=self.feedback, servo=self.servo)


# the machine's raw methods for the step loop (a call from inside the package skips the check anyway; these
# skip the wrapper too, so a controller step costs what it cost before contracts)
_update, _reset = unchecked(StateMachine.update), unchecked(StateMachine.reset)
