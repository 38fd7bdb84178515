"""Joints between rigid bodies in maximal coordinates: ball, hinge, slider, weld (chapter 08).

Each link is a :class:`~pbanim.rigid.RigidBodies` body with generalized velocity u = (v, ω); a joint
between bodies a and b (b = −1: the world) is a set of constraint rows C(y) = 0 whose multipliers λ
solve, at every force evaluation, the same system as the particle constraints of chapter 03,

    J W Jᵀ λ = −J̇u − J W (Q + Q_gyro) − k_s C − k_d Ċ,        Q_C = Jᵀ λ,

with W = diag(1/m, I⁻¹_world) per body and Q_gyro = (0, −ω × I ω) the gyroscopic torque. With anchors
r_a, r_b and axes fixed in the bodies' frames (world vectors p = x + R r, â = R a):

=========  ==================================================  =====================================
joint      C                                                   J rows on body a (b: the negative)
=========  ==================================================  =====================================
ball       p_a − p_b (3)                                       [1, −[r_a]×]   (p_a − x_a = r_a world)
hinge      ball, and t₁·â_b, t₂·â_b with t₁, t₂ ⟂ â_a (2)      [0, (tₖ × â_b)ᵀ]
slider     tₖ·(p_a − p_b) with tₖ ⟂ â_b turning with b (2),     [tₖᵀ, (r_a × tₖ)ᵀ]; b: [tₖᵀ, (r_b × tₖ − tₖ × d)ᵀ]
           and the relative rotation 2 vec(q_b⁻¹ q_a q₀⁻¹) (3)         [0, 1] for the rotation rows
weld       ball, and the relative rotation (3)                 [1, −[r_a]×] and [0, 1]
=========  ==================================================  =====================================

J̇u collects the velocity-product terms: ω × (ω × r) for anchors, (ω_a × (ω_a × t))·â_b +
2(ω_a × t)·(ω_b × â_b) + t·(ω_b × (ω_b × â_b)) for the hinge rows, and the slider's rows likewise.
Baumgarte gains (k_s, k_d) make the error obey C̈ + k_d Ċ + k_s C = 0 (tested against its closed form).

References: Witkin, "Constrained dynamics", SIGGRAPH course notes; Baraff, "Linear-time dynamics using
Lagrange multipliers", SIGGRAPH 1996; Catto, "Modeling and solving constraints", GDC 2009 (joint rows).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import InvalidInput, SingularConstraintError, check_count
from ..geometry import cross, skew, tangent_basis
from ..rigid.quat import quat_conjugate, quat_multiply, quat_to_matrix
from ..scene import Effect

__all__ = ["RigidJoint", "RigidJoints", "JOINTS"]

JOINTS = ("ball", "hinge", "slider", "weld")


@dataclass(frozen=True)
class RigidJoint:
    """One joint: ``kind``, bodies ``a`` and ``b`` (−1: world), anchors and axis in each body's frame."""

    kind: str
    a: int
    b: int
    anchor_a: np.ndarray
    anchor_b: np.ndarray
    axis_a: np.ndarray
    axis_b: np.ndarray


def _vec(v, name):
    a = np.asarray(v, dtype=float)
    if a.shape != (3,) or not np.all(np.isfinite(a)):
        raise InvalidInput(f"{name} must be a finite 3-vector, got {v!r}")
    return a


class RigidJoints(Effect):
    """The joint constraints of a :class:`~pbanim.rigid.RigidScene` (phase "constraint").

    ``joints`` is a list of dicts or :class:`RigidJoint`: ``kind``, ``a``, ``b``, ``anchor_a``, ``anchor_b``
    (body frames; the world's frame for b = −1) and, for hinge and slider, ``axis_a``, ``axis_b``.
    """

    name = "joints"
    phase = "constraint"

    def __init__(self, joints, ks: float = 0.0, kd: float = 0.0) -> None:
        self.joints = [j if isinstance(j, RigidJoint) else self._joint(j) for j in joints]
        if not self.joints:
            raise InvalidInput("joints must hold at least one joint")
        for name, g in (("ks", ks), ("kd", kd)):
            if not (np.isfinite(g) and g >= 0):
                raise InvalidInput(f"{name} must be a finite number >= 0, got {g}")
        self.ks, self.kd = float(ks), float(kd)
        self.last_lambda = None

    @staticmethod
    def _joint(d) -> RigidJoint:
        kind = d.get("kind")
        if kind not in JOINTS:
            raise InvalidInput(f"joint kind must be one of {JOINTS}, got {kind!r}")
        axis_a = _vec(d.get("axis_a", (0.0, 0.0, 1.0)), "axis_a")
        axis_b = _vec(d.get("axis_b", d.get("axis_a", (0.0, 0.0, 1.0))), "axis_b")
        for nm, ax in (("axis_a", axis_a), ("axis_b", axis_b)):
            if kind in ("hinge", "slider") and not np.linalg.norm(ax) > 1e-12:
                raise InvalidInput(f"a {kind} joint's {nm} must be non-zero, got {ax}")
        a = check_count("joint body a", d.get("a", 0), minimum=-1)
        b = check_count("joint body b", d.get("b", -1), minimum=-1)
        return RigidJoint(kind, a, b, _vec(d.get("anchor_a", (0, 0, 0)), "anchor_a"),
                          _vec(d.get("anchor_b", (0, 0, 0)), "anchor_b"),
                          axis_a / max(np.linalg.norm(axis_a), 1e-300), axis_b / max(np.linalg.norm(axis_b), 1e-300))

    def bind(self, system) -> None:
        if getattr(system, "kind", None) != "rigid":
            raise InvalidInput(f"RigidJoints act on a RigidBodies system, got {type(system).__name__}")
        for j in self.joints:
            for role, k in (("a", j.a), ("b", j.b)):
                if not -1 <= k < system.N:
                    raise InvalidInput(f"joint body {role} must be -1 (world) or 0..{system.N - 1}, got {k}")
            if j.a == j.b:
                raise InvalidInput(f"a joint connects two different bodies, got a = b = {j.a}")
        self.system = system
        q0 = system.unpack(system.state())[1]
        qw = np.vstack([q0, [1.0, 0, 0, 0]])
        # the relative orientation at rest: the weld/slider rotation rows hold q_b⁻¹ q_a = q_rel0
        self._qrel0 = [quat_multiply(quat_conjugate(qw[j.b]), qw[j.a]) for j in self.joints]

    # -- rows -----------------------------------------------------------------------------------
    def rows(self, y: np.ndarray):
        """(C, J (k, 6N), J̇u (k,), Ċ (k,)) at state y."""
        s = self.system
        N = s.N
        x, q, _, _ = s.unpack(y)
        v, w = s.velocities(y)
        R = quat_to_matrix(q)
        xw, Rw = np.vstack([x, np.zeros(3)]), np.concatenate([R, np.eye(3)[None]])
        vw, ww, qw = np.vstack([v, np.zeros(3)]), np.vstack([w, np.zeros(3)]), np.vstack([q, [1.0, 0, 0, 0]])
        C, J, bias = [], [], []

        def row(ja, jb, a, b, c, jdot):          # ja, jb: 6-vectors on bodies a, b
            r = np.zeros(6 * N)
            if a >= 0:
                r[6 * a:6 * a + 6] += ja
            if b >= 0:
                r[6 * b:6 * b + 6] -= jb
            C.append(c), J.append(r), bias.append(jdot)

        for j, qrel0 in zip(self.joints, self._qrel0):
            a, b = j.a, j.b
            ra, rb = Rw[a] @ j.anchor_a, Rw[b] @ j.anchor_b
            pa, pb = xw[a] + ra, xw[b] + rb
            if j.kind in ("ball", "hinge", "weld"):
                acc = cross(ww[a], cross(ww[a], ra)) - cross(ww[b], cross(ww[b], rb))
                for k in range(3):
                    e = np.eye(3)[k]
                    row(np.concatenate([e, cross(ra, e)]), np.concatenate([e, cross(rb, e)]), a, b,
                        (pa - pb)[k], acc[k])
            if j.kind == "hinge":
                aa, ab = Rw[a] @ j.axis_a, Rw[b] @ j.axis_b
                for t in tangent_basis(aa[None])[:2]:
                    t = t[0]
                    g = cross(t, ab)
                    jd = cross(ww[a], cross(ww[a], t)) @ ab + 2 * cross(ww[a], t) @ cross(ww[b], ab) \
                        + t @ cross(ww[b], cross(ww[b], ab))
                    row(np.concatenate([np.zeros(3), g]), np.concatenate([np.zeros(3), g]), a, b, t @ ab, jd)
            if j.kind in ("slider", "weld"):
                qrel = quat_multiply(quat_conjugate(qw[b]), quat_multiply(qw[a], quat_conjugate(qrel0)))
                err = 2.0 * np.sign(qrel[0] if qrel[0] != 0 else 1.0) * (Rw[b] @ qrel[1:])   # small-angle, world
                for k in range(3):
                    e = np.eye(3)[k]
                    row(np.concatenate([np.zeros(3), e]), np.concatenate([np.zeros(3), e]), a, b, err[k], 0.0)
            if j.kind == "slider":
                ab = Rw[b] @ j.axis_b
                d = pa - pb
                dd = (vw[a] + cross(ww[a], ra)) - (vw[b] + cross(ww[b], rb))
                for t in tangent_basis(ab[None])[:2]:
                    t = t[0]
                    # C = t·d with t turning with b: Ċ = t·ḋ + (ω_b × t)·d
                    ga = np.concatenate([t, cross(ra, t)])
                    gb = np.concatenate([t, cross(rb, t) - cross(t, d)])
                    acc = cross(ww[a], cross(ww[a], ra)) - cross(ww[b], cross(ww[b], rb))
                    jd = t @ acc + 2 * cross(ww[b], t) @ dd + cross(ww[b], cross(ww[b], t)) @ d
                    row(ga, gb, a, b, t @ d, jd)
        C, J, bias = np.array(C), np.array(J), np.array(bias)
        u = np.hstack([v, w]).ravel()
        return C, J, bias, J @ u

    # -- the constraint phase ------------------------------------------------------------------
    def constrain(self, t: float, y: np.ndarray, Q: np.ndarray) -> np.ndarray:
        s = self.system
        C, J, jdot, Cdot = self.rows(y)
        Wb = s.inverse_mass_blocks(y)                                    # (N, 6, 6)
        v, w = s.velocities(y)
        Iw = np.linalg.pinv(Wb[:, 3:, 3:])                               # world inertia (0 for static)
        gyro = np.zeros_like(Q)
        gyro[:, 3:] = -cross(w, np.einsum("nij,nj->ni", Iw, w))
        WQ = np.einsum("nij,nj->ni", Wb, Q + gyro).ravel()
        WJt = np.einsum("nij,knj->kni", Wb, J.reshape(len(C), s.N, 6)).reshape(len(C), -1)
        A = J @ WJt.T
        rhs = -jdot - J @ WQ - self.ks * C - self.kd * Cdot
        lam, res, rank, _ = np.linalg.lstsq(A, rhs, rcond=1e-12)
        if rank < len(C) and np.linalg.norm(A @ lam - rhs) > 1e-8 * max(1.0, np.linalg.norm(rhs)):
            raise SingularConstraintError(range(len(C)), float(np.linalg.norm(A @ lam - rhs)),
                                          "joint rows are dependent and inconsistent")
        self.last_lambda = lam
        return Q + (J.T @ lam).reshape(Q.shape)

    def diagnostics(self, t: float, y: np.ndarray) -> dict:
        C, _, _, Cdot = self.rows(y)
        return {"joint_error": float(np.max(np.abs(C), initial=0.0)),
                "joint_velocity_error": float(np.max(np.abs(Cdot), initial=0.0))}
