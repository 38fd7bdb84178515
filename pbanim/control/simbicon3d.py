"""SIMBICON in 3-D: the four-state machine, sagittal and coronal balance feedback, heading (chapter 08).

The planar controller (:mod:`.simbicon`) carries over to the 3-D biped (:mod:`.biped3d`) as Yin, Loken &
van de Panne (SIGGRAPH 2007, section 5) describe it:

1. **The machine**: states R0 (right stance, δt seconds), R1 (right stance until the left foot strikes),
   L0, L1 the mirror images; each state holds targets for the swing hip, swing and stance knees and
   ankles, and the torso.
2. **Balance feedback in both planes**: with d and v the centre of mass's offset from the stance ankle
   and its velocity, both in the heading frame (x forward, y left), the swing hip's targets are

       θ̄_sag = θ̄_sag,0 + c_d,sag d_x + c_v,sag v_x,     θ̄_cor = ± θ̄_cor,0 + c_d,cor d_y + c_v,cor v_y,

   θ̄_cor positive moving the swing foot to the left (the sign of θ̄_cor,0 points it outwards).
3. **The torso and the swing thigh are servoed in the world frame**: with R̄ the target orientation and R
   the link's, the world torque is τ = k_p log(R̄ Rᵀ) − k_v ω (log: the rotation vector). The torso's
   target is R_z(ψ̄) R_−y(θ̄_tor) (ψ̄ the heading), the swing thigh's R_z(ψ̄) R_x(θ̄_cor) R_−y(θ̄_sag).
   Only the hips can act on the trunk, so the stance hip supplies what the swing hip does not:
   τ_stance = −τ_torso − τ_swing. The stance leg's yaw has almost no inertia and, while the foot lands on
   one heel corner, no friction torque to hold it: this rule's yaw part then spins the stance foot (measured
   without a damper: 0.75 rad in the first 0.1 s of a stance, unpushed; a whole turn after a 20 N s lateral
   push, the rotated sole then failing the ankle's roll support). A stable damper −k_v,yaw q̇⁺ on the stance
   hip's yaw joint (``Gait3D.stance_yaw_kv``) holds it. A hip is three revolutes with world axes aⱼ: the world torque τ on the
   thigh (−τ on the pelvis) is the joint torques τⱼ = aⱼ·τ (the same power τ·ω_rel = Σ τⱼ q̇ⱼ).
4. **Turning**: the heading ψ̄ is a target; changing it yaws the trunk and the swing thigh toward it.

Knees and ankles are joint-space stable PD servos (as the planar walk's: τ = k_p(θ̄ − θ − hθ̇) − k_v θ̇⁺,
:mod:`.pd`), and the swing hip's damping about each of its own axes is taken at θ̇⁺ too (the thigh's yaw
inertia, ≈ 0.03 kg m², would otherwise bound the step at h < 2 I/k_v ≈ 2 ms, ORACLES F1).

:data:`WALK3D` is **ours**: the sagittal numbers are Table 1's planar walk (δt 0.3 s; swh 0.4/−0.7, swk
−1.1/−0.05, swa 0.2/0.2, stk −0.05/−0.1, sta 0.2/0.2, c_d 0/2.2, c_v 0.2/0), the coronal ones ours
(θ̄_cor,0 = 0, c_d,cor 0.5, c_v,cor 0.4: with c_v,cor 0.2 it fell after 7.7 s), Table 1's k_p = 300, k_v = 30
on the knees, ankles and torso, and ours on the swing hip, 600/60, with the stance-hip yaw damper
k_v,yaw = 30 N m s/rad. Why (lateral pushes; the push: P to the side on the torso, over 0.1 s from 0.1 s
after the first right (R0) or left (L0) strike after t = 1 s, :mod:`.simbicon3d_walk`; "recovered": no fall
to t = 4 s): with Table 1's 300/30 and no damper 20 N s fell at h = 2 ms (and 10 N s at t = 1.2 s fell at 2
and 3.5 ms) — the stance foot spun (above) and a late push left the 300/30 swing hip too slow to move the
foot to its coronal target before the strike (commanded 0.24 rad, landed at ≈ 0.1). Measured at h = 2 ms,
± 20 N s in R0 (+: to the left): 300/30 with k_v,yaw 0 / 30: + falls / falls, − falls / holds; 600/60 with
k_v,yaw 30: both hold; 1000/100 with 30: + falls; 1000/100 with 100: falls unpushed (1.75 s). Shipped,
600/60 with 30, measured at h = 2, 3, 3.5 ms (ORACLES F18):

=========  ======  ======  ======  ======  ======  ======  ======  ======
P (N s)    +20 R0  −20 R0  +20 L0  −20 L0  +30 R0  −30 R0  +30 L0  −30 L0
=========  ======  ======  ======  ======  ======  ======  ======  ======
h = 2 ms   holds   holds   holds   holds   falls   holds   holds   holds
h = 3 ms   holds   holds   holds   holds   falls   holds   holds   holds
h = 3.5 ms holds   holds   holds   holds   falls   holds   holds   holds
=========  ======  ======  ======  ======  ======  ======  ======  ======

(+30 R0 falls at 2.98, 3.38, 3.35 s: pushed toward the swing side late in the step.) Measured with PGS at tol as
the contact solve; with the exact solve of the hand-off (:mod:`.biped3d_step`) the h = 2 ms row is the same
(+30 R0 falls at 2.99 s); the 3 and 3.5 ms rows were not measured again. The largest push
recovered in every case measured is 20 N s (0.29 m/s for 70 kg); 30 N s holds in 3 of the 4 cases.
The unpushed walk and the other claims: ORACLES F18, :mod:`.simbicon3d_walk`.

Notation: ψ heading (yaw about z); d, v centre-of-mass offset and velocity in the heading frame; θ̄ targets;
k_p, k_v gains; h the step; R_a(θ) the rotation by θ about axis a.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from math import atan2, cos, sin

import numpy as np

from ..contracts import Anything, Array, Choice, Obj, Real, Text, contract, unchecked
from .specs import Mapping, Names, NotBefore, Pair
from .biped3d import BIPED3D_JOINTS as JI
from .biped3d_lean import rotation_vector_floats
from .biped3d_step import WorldStep
from .fsm import StateMachine, Transition

__all__ = ["Phase3D", "Gait3D", "WALK3D", "Simbicon3D", "rotation_vector"]

_ANGLE = Real(ge=-np.pi, le=np.pi)
_FB = Real(ge=0)
STATES = ("R0", "R1", "L0", "L1")
SIDES = {"R": ("right", "left"), "L": ("left", "right")}
_Y, _X, _Z = (0.0, -1.0, 0.0), (1.0, 0.0, 0.0), (0.0, 0.0, 1.0)


@contract(swh=_ANGLE, swk=_ANGLE, swa=_ANGLE, stk=_ANGLE, sta=_ANGLE, tor=_ANGLE, cor=_ANGLE, cd=_FB, cv=_FB,
          cd_cor=_FB, cv_cor=_FB)
@dataclass(frozen=True)
class Phase3D:
    """Targets of one state (rad): swing hip sagittal (swh) and coronal (cor, outward positive), swing and
    stance knee and ankle, torso pitch (tor, back positive); sagittal (cd, cv) and coronal feedback gains."""

    swh: float
    swk: float
    swa: float
    stk: float
    sta: float
    tor: float = 0.0
    cor: float = 0.0
    cd: float = 0.0
    cv: float = 0.0
    cd_cor: float = 0.0
    cv_cor: float = 0.0


_GAINS = Mapping(Choice(("hip", "torso", "knee", "ankle")), Real(ge=0), keys=("hip", "torso", "knee", "ankle"))


@contract(name=Text(), dt=Real(gt=0, le=5), phases=Pair(Obj(Phase3D), Obj(Phase3D)), kp=_GAINS, kv=_GAINS,
          limit=Real(gt=0), stance_yaw_kv=Real(ge=0))
@dataclass(frozen=True)
class Gait3D:
    """δt, the two phases (timed, then until foot strike), gains (k_p, k_v) per joint kind, torque limit, and the
    stance hip's yaw damper k_v,yaw (N m s/rad; module docstring, item 3)."""

    name: str
    dt: float
    phases: tuple
    kp: dict = field(default_factory=lambda: {"hip": 300.0, "torso": 300.0, "knee": 300.0, "ankle": 300.0})
    kv: dict = field(default_factory=lambda: {"hip": 30.0, "torso": 30.0, "knee": 30.0, "ankle": 30.0})
    limit: float = 600.0
    stance_yaw_kv: float = 0.0


WALK3D = Gait3D("3-D walk (ours: Table 1's sagittal numbers, our coronal ones)", 0.3,
                (Phase3D(swh=0.4, swk=-1.1, swa=0.2, stk=-0.05, sta=0.2, cd=0.0, cv=0.2, cor=0.0, cd_cor=0.5,
                         cv_cor=0.4),
                 Phase3D(swh=-0.7, swk=-0.05, swa=0.2, stk=-0.1, sta=0.2, cd=2.2, cv=0.0, cor=0.0, cd_cor=0.5,
                         cv_cor=0.4)),
                kp={"hip": 600.0, "torso": 300.0, "knee": 300.0, "ankle": 300.0},
                kv={"hip": 60.0, "torso": 30.0, "knee": 30.0, "ankle": 30.0}, stance_yaw_kv=30.0)


@contract(R=Array((3, 3)))
def rotation_vector(R: np.ndarray) -> np.ndarray:
    """log(R): the axis times the angle (|angle| ≤ π) of the rotation matrix R — through its quaternion
    (:func:`pbanim.rigid.matrix_to_quat`, :func:`pbanim.design.simulate.quat_log`), well conditioned at 0 and π;
    their arithmetic on floats, bit for bit (:func:`pbanim.control.biped3d_lean.rotation_vector_floats`)."""
    return rotation_vector_floats(R)


def _frames_of(kin) -> tuple[list, list]:
    """The frames of a kinematics dict as floats: each link's R (nine floats, row-major) and each joint column
    Sᵂ (six floats) — the lean kinematics keeps them (``"Rf"``, ``"Sf"``), the readable one's arrays are read."""
    Rf = kin.get("Rf")
    if Rf is None:
        Rf = kin["Rf"] = [tuple(r) for r in kin["R"].reshape(-1, 9).tolist()]
    cols = kin.get("Sf")
    if cols is None:
        cols = kin["Sf"] = kin["S"].T.tolist()
    return Rf, cols


def _rot9(axis, angle: float) -> tuple:
    """R_a(θ) as nine floats (row-major): :func:`pbanim.control.biped3d_step._rot`'s Rodrigues, on floats."""
    x, y, z = axis
    c, s = cos(angle), sin(angle)
    t = 1.0 - c
    return (t * x * x + c, t * x * y - s * z, t * x * z + s * y,
            t * x * y + s * z, t * y * y + c, t * y * z - s * x,
            t * x * z - s * y, t * y * z + s * x, t * z * z + c)


def _mul9(A, B) -> tuple:
    """A B of two 3 × 3 matrices given as nine floats (row-major)."""
    a0, a1, a2, a3, a4, a5, a6, a7, a8 = A
    b0, b1, b2, b3, b4, b5, b6, b7, b8 = B
    return (a0 * b0 + a1 * b3 + a2 * b6, a0 * b1 + a1 * b4 + a2 * b7, a0 * b2 + a1 * b5 + a2 * b8,
            a3 * b0 + a4 * b3 + a5 * b6, a3 * b1 + a4 * b4 + a5 * b7, a3 * b2 + a4 * b5 + a5 * b8,
            a6 * b0 + a7 * b3 + a8 * b6, a6 * b1 + a7 * b4 + a8 * b7, a6 * b2 + a7 * b5 + a8 * b8)


def _mul9t(A, B) -> tuple:
    """A Bᵀ of two 3 × 3 matrices given as nine floats (row-major)."""
    a0, a1, a2, a3, a4, a5, a6, a7, a8 = A
    b0, b1, b2, b3, b4, b5, b6, b7, b8 = B
    return (a0 * b0 + a1 * b1 + a2 * b2, a0 * b3 + a1 * b4 + a2 * b5, a0 * b6 + a1 * b7 + a2 * b8,
            a3 * b0 + a4 * b1 + a5 * b2, a3 * b3 + a4 * b4 + a5 * b5, a3 * b6 + a4 * b7 + a5 * b8,
            a6 * b0 + a7 * b1 + a8 * b2, a6 * b3 + a7 * b4 + a8 * b5, a6 * b6 + a7 * b7 + a8 * b8)


class Simbicon3D:
    """The 3-D controller: ``torques(t, q, q̇, events, kin, h)`` → (τ₀, k), τ = τ₀ − k ⊙ q̇⁺.

    ``step``: the biped's :class:`~pbanim.control.biped3d_step.WorldStep` (its kinematics and Jacobians);
    ``heading``: the target yaw ψ̄ (rad), changeable between steps (:attr:`heading`).
    """

    @contract(step=Obj(WorldStep), gait=Obj(Gait3D), heading=Real(ge=-10, le=10), start=Choice(STATES))
    def __init__(self, step: WorldStep, gait: Gait3D = WALK3D, heading: float = 0.0, start: str = "R0") -> None:
        self.step, self.gait, self.heading = step, gait, float(heading)
        tree = step.tree
        names = [lk.name for lk in tree.links]
        self.link = {nm: names.index(nm) for nm in ("pelvis", "left_thigh", "right_thigh", "left_foot", "right_foot")}
        p0, p1 = gait.phases
        self.fsm = StateMachine({"R0": p0, "R1": p1, "L0": p0, "L1": p1},
                                [Transition("R0", "R1", after=gait.dt), Transition("R1", "L0", on="left_strike"),
                                 Transition("L0", "L1", after=gait.dt), Transition("L1", "R0", on="right_strike")],
                                initial=start)
        self.mass = step.mass
        self.M = float(step.mass.sum())
        self.history: list = []
        # the hot loop's calls, bound once without their argument checks (the arguments are this class's own)
        self._update, self._balance = unchecked(self.fsm.update), unchecked(self.balance)
        self._jacobians, self._all = unchecked(step.point_jacobians), np.arange(tree.n)
        self._frames = (None, None, None)             # (ψ̄, θ̄_tor) → R_z(ψ̄), R_z(ψ̄) R_−y(θ̄_tor): recomputed on change
        self._servos = {}                             # (stance, phase) → the joint servos' (q̇ index, target, k_p, k_v)
        self._hips = {}                               # swing side → (the swing hip's, the stance hip's q̇ indices)
        self._maskf = step.mask.astype(float)         # the columns of each link's ancestors, as 0/1 floats
        self._anc = {}                                # link → the q̇ indices of its ancestors' joints (and its own)

    def sides(self) -> tuple[str, str]:
        """(stance, swing)."""
        return SIDES[self.fsm.state[0]]

    @contract(kin=Anything("the dict of step.kinematics(q)"), qd=Array(("self.step.tree.nv",)))
    def balance(self, kin, qd) -> tuple[np.ndarray, np.ndarray, float]:
        """(d, v, ψ): the centre of mass's offset from the stance ankle and its velocity in the heading frame
        (x forward, y left; 2-vectors), and the pelvis's heading ψ."""
        _, Jc = self._jacobians(kin, self._all, self.step.com)
        M = self.M
        cx, cy, _ = (self.mass @ kin["c"]).tolist()
        mJ = (self.mass @ Jc.reshape(Jc.shape[0], -1)).reshape(3, -1)          # Σᵢ mᵢ J_c,i
        vx, vy, _ = (mJ @ qd / M).tolist()
        Rp = _frames_of(kin)[0][self.link["pelvis"]]
        psi = atan2(Rp[3], Rp[0])
        c, s = cos(psi), sin(psi)
        ox, oy, _ = kin["o"][self.link[f"{self.sides()[0]}_foot"]].tolist()
        rx, ry = cx / M - ox, cy / M - oy                                       # from the stance ankle
        return np.array([c * rx + s * ry, -s * rx + c * ry]), np.array([c * vx + s * vy, -s * vx + c * vy]), psi

    @contract(t=NotBefore("self.fsm.entered"), q=Array(("self.step.tree.nq",)), qd=Array(("self.step.tree.nv",)),
              events=Names(), kin=Anything("the dict of step.kinematics(q), or None"), h=Real(ge=0))
    def torques(self, t: float, q, qd, events=(), kin=None, h: float = 0.0):
        """Joint forces (τ₀, k) for the state (q, q̇) at time t after ``events`` (module docstring); records
        (t, state, d, v, ψ) in :attr:`history`."""
        st = self.step
        kin = st.kinematics(q) if kin is None else kin              # (checks the quaternion)
        self._update(t, events)
        ph: Phase3D = self.fsm.payload
        stance, swing = self.sides()
        g = self.gait
        kp, kv = g.kp, g.kv
        nv = qd.size
        tau, k = [0.0] * nv, [0.0] * nv
        d, v, psi = self._balance(kin, qd)
        ql, qdl = q.tolist(), qd.tolist()
        # knees and ankles: joint space, stable PD (q index = q̇ index + 1: the quaternion's extra number)
        servos = self._servos.get((stance, ph))
        if servos is None:
            servos = self._servos[(stance, ph)] = [
                (JI[joint], target, kp[kind], kv[kind]) for joint, target, kind in (
                    (f"{swing}_knee", ph.swk, "knee"), (f"{swing}_ankle_y", ph.swa, "ankle"),
                    (f"{swing}_ankle_x", 0.0, "ankle"), (f"{stance}_knee", ph.stk, "knee"),
                    (f"{stance}_ankle_y", ph.sta, "ankle"), (f"{stance}_ankle_x", 0.0, "ankle"))]
        for i, target, kpi, kvi in servos:
            tau[i], k[i] = kpi * (target - ql[i + 1] - h * qdl[i]), kvi
        # world-frame torso and swing thigh on floats (3 × 3 matrices as nine floats, row-major)
        Rf, cols = _frames_of(kin)
        if self._frames[0] != (self.heading, ph.tor):
            Rz = _rot9(_Z, self.heading)
            self._frames = ((self.heading, ph.tor), Rz, _mul9(Rz, _rot9(_Y, ph.tor)))
        _, Rz, R_tor = self._frames
        p = Rf[self.link["pelvis"]]
        q0, q1, q2 = qdl[0], qdl[1], qdl[2]
        w0 = (p[0] * q0 + p[1] * q1 + p[2] * q2, p[3] * q0 + p[4] * q1 + p[5] * q2,
              p[6] * q0 + p[7] * q1 + p[8] * q2)                  # the pelvis's world angular velocity R₀ ω
        kpt, kvt = kp["torso"], kv["torso"]
        tau_torso = [kpt * r - kvt * w for r, w in
                     zip(rotation_vector_floats(_mul9t(R_tor, p), as_list=True), w0)]
        sag = ph.swh + ph.cd * d[0] + ph.cv * v[0]
        out = 1.0 if swing == "left" else -1.0
        cor = out * ph.cor + ph.cd_cor * d[1] + ph.cv_cor * v[1]
        R_sw = _mul9(_mul9(Rz, _rot9(_X, cor)), _rot9(_Y, sag))
        thigh = self.link[f"{swing}_thigh"]
        anc = self._anc.get(thigh)
        if anc is None:
            anc = self._anc[thigh] = np.flatnonzero(self._maskf[thigh]).tolist()
        wx = wy = wz = 0.0
        for j in anc:                                             # ω_thigh = Σ over its joints aⱼ q̇ⱼ
            col, x = cols[j], qdl[j]
            wx, wy, wz = wx + col[0] * x, wy + col[1] * x, wz + col[2] * x
        kph, kvh = kp["hip"], kv["hip"]
        tx, ty, tz = tau_swing = [kph * r - kvh * w for r, w in
                                  zip(rotation_vector_floats(_mul9t(R_sw, Rf[thigh]), as_list=True), (wx, wy, wz))]
        hips = self._hips.get(swing)
        if hips is None:
            hips = self._hips[swing] = ([JI[f"{swing}_hip_{a}"] for a in "zxy"], [JI[f"{stance}_hip_{a}"] for a in "zxy"])
        sw, stn = hips
        for j in sw:                                              # τⱼ = aⱼ·τ, its damping about its own axis at q̇⁺
            ax, ay, az = cols[j][:3]                              # the joint's world axis aⱼ
            tau[j], k[j] = ax * tx + ay * ty + az * tz + kvh * qdl[j], kvh
        sx, sy, sz = [-a - b for a, b in zip(tau_torso, tau_swing)]         # τ_stance = −τ_torso − τ_swing
        for j in stn:
            ax, ay, az = cols[j][:3]
            tau[j] = ax * sx + ay * sy + az * sz
        k[stn[0]] = g.stance_yaw_kv                                # the stance leg's spin damped, at q̇⁺
        lim = g.limit
        for i, x in enumerate(tau):                                # clipped to ±limit (np.clip's comparisons)
            if x < -lim:
                tau[i] = -lim
            elif x > lim:
                tau[i] = lim
        self.history.append((t, self.fsm.state, d, v, psi))
        return np.array(tau), np.array(k)

    @contract(t=Real())
    def reset(self, t: float = 0.0) -> None:
        """Back to the initial state at time t, history cleared."""
        self.fsm.reset(t)
        self.history = []
