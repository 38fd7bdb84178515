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

Joint limits (hinge angle or slide, measured from the configuration at ``bind``) are unilateral rows
C = θ − θ_lo ≥ 0, C = θ_hi − θ ≥ 0 with λ ≥ 0 ⊥ J u̇ + k_s C + k_d Ċ ≥ 0: the equality multipliers are
eliminated exactly and the rest goes to the LCP core (Lemke). At the acceleration level a stop cannot
cancel an approach speed at once: it acts as a stiff spring-damper of gains (k_s, k_d) and dissipates.
With ``projection=True`` a post-step stage (:mod:`.projection`) moves positions back onto C = 0 and
velocities onto J u = 0 after every step, as chapter 03's projection does for particles.
A ``motor`` is a constant torque about the hinge axis (force along the slider axis) between a and b; a
velocity motor (``motor_speed``, ``motor_max``) is a row θ̈ = (θ̇* − θ̇)/τ_m whose multiplier is bounded by
±motor_max, solved with the limits by the core's box-constrained Gauss–Seidel (:func:`pbanim.lcp.pgs_bounded`).

References: Witkin, "Constrained dynamics", SIGGRAPH course notes; Baraff, "Linear-time dynamics using
Lagrange multipliers", SIGGRAPH 1996; Catto, "Modeling and solving constraints", GDC 2009 (joint rows).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..contracts import Array, Choice, Either, Flag, Int, Obj, Opt, Real, Seq, contract, finite_result
from ..errors import InvalidInput, NonFiniteResult, SingularConstraintError
from ..geometry import cross
from ..rigid.quat import quat_conjugate, quat_multiply, quat_to_matrix
from ..lcp import pgs_bounded, solve_lcp
from scipy.linalg.lapack import dpotrf as _potrf, dpotrs as _potrs
from ..scene import Effect
from ..rigid.domain import RigidState
from .joint_rows import ROWS_PER_JOINT, JointRowPlan
from .joints_lean import lean_joints
from .specs import UnitAxis

__all__ = ["RigidJoint", "RigidJoints", "JOINTS"]

JOINTS = ("ball", "hinge", "slider", "weld")
_ANCHOR = Array((3,), ge=-1e50, le=1e50)         # m: bounded so that products of anchors stay finite
_BIG = Real(ge=-1e100, le=1e100)
_BODY = Int(ge=-1)


_Y = RigidState("self.system")
_T = Real()


@contract(kind=Choice(JOINTS), a=_BODY, b=_BODY, anchor_a=_ANCHOR, anchor_b=_ANCHOR, axis_a=UnitAxis(),
          axis_b=UnitAxis(), limits=Opt(Seq(_BIG, min_len=2, max_len=2)), motor=_BIG, motor_speed=Opt(_BIG),
          motor_max=Real(ge=0, le=1e100))
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
    limits: tuple | None = None        # (lower, upper) angle (hinge, rad) or slide (slider, m), 0 at bind
    motor: float = 0.0                 # constant torque about the hinge axis / force along the slider axis
    motor_speed: float | None = None   # velocity motor: target joint rate, reached with ...
    motor_max: float = 0.0             # ... at most this torque / force

    def __post_init__(self) -> None:    # cross-argument conditions (for every caller) and unit axes
        kind = self.kind
        if self.a == self.b:
            raise InvalidInput(f"RigidJoint: a and b must be two different bodies, got a = b = {self.a}")
        if self.limits is not None:
            if kind not in ("hinge", "slider"):
                raise InvalidInput(f"RigidJoint: limits apply to hinge and slider joints, got a {kind} joint with "
                                   "limits")
            lo, hi = (float(v) for v in self.limits)
            if not lo < hi:
                raise InvalidInput(f"RigidJoint: limits must be (lower, upper) with lower < upper, got {self.limits}")
            object.__setattr__(self, "limits", (lo, hi))
        if (self.motor or self.motor_speed is not None) and kind not in ("hinge", "slider"):
            raise InvalidInput(f"RigidJoint: a motor drives a hinge or a slider, got a {kind} joint with a motor")
        for name in ("axis_a", "axis_b"):
            ax = np.asarray(getattr(self, name), dtype=float)
            object.__setattr__(self, name, ax / max(float(np.linalg.norm(ax)), 1e-300))


def _spd_solve(A: np.ndarray, rhs: np.ndarray):
    """λ = A⁻¹ rhs by a Cholesky factor of the symmetric A = J W Jᵀ when it is well conditioned (LAPACK potrf,
    potrs: a tenth of the SVD least squares' cost at 5–30 rows, equal to it to roundoff for independent rows);
    None when the factorization fails or A is near singular (κ estimated from the factor's diagonal above
    10¹⁰), where the caller's least squares decides."""
    c, info = _potrf(A, lower=False, clean=False)
    if info != 0:
        return None
    d = np.abs(np.diag(c))
    if not d.min() > 1e-5 * d.max():              # κ(A) ≳ (max/min)²: leave it to the least squares
        return None
    return _potrs(c, rhs)[0]


class RigidJoints(Effect):
    """The joint constraints of a :class:`~pbanim.rigid.RigidScene` (phase "constraint").

    ``joints`` is a list of dicts or :class:`RigidJoint`: ``kind``, ``a``, ``b``, ``anchor_a``, ``anchor_b``
    (body frames; the world's frame for b = −1) and, for hinge and slider, ``axis_a``, ``axis_b``.
    """

    name = "joints"
    phase = "constraint"

    @contract(joints=Seq(Either(Obj(RigidJoint), Obj(dict, what="a dict of RigidJoint's fields")), min_len=1),
              ks=Real(ge=0), kd=Real(ge=0), limit_margin=Real(ge=0), motor_time=Real(gt=0),
              solver=Choice(("dense", "linear")), projection=Flag(), projection_tol=Real(gt=0),
              projection_max_iter=Int(ge=1, le=1000))
    def __init__(self, joints, ks: float = 0.0, kd: float = 0.0, limit_margin: float = 1e-3,
                 motor_time: float = 0.01, solver: str = "dense", projection: bool = False,
                 projection_tol: float = 1e-12, projection_max_iter: int = 20) -> None:
        self.joints = [j if isinstance(j, RigidJoint) else self._joint(j, k) for k, j in enumerate(joints)]
        self.ks, self.kd = float(ks), float(kd)
        self.limit_margin, self.motor_time = float(limit_margin), float(motor_time)
        if solver == "linear" and any(j.limits is not None or j.motor_speed is not None for j in self.joints):
            raise InvalidInput("RigidJoints: solver='linear' handles equality joints only; limits and velocity "
                               "motors need solver='dense'")
        self.solver = solver
        self.projection = bool(projection)
        self._projection_args = (float(projection_tol), int(projection_max_iter))
        self._order = None
        self._lean = None
        self.lean_path = True           # False: every force evaluation takes the readable path
        self.last_lambda = None
        self.last_limit_lambda = None

    @staticmethod
    def _joint(d: dict, k: int) -> RigidJoint:
        """A joint from a dict of RigidJoint's fields, checked by RigidJoint's contract (``axis_b`` defaults to
        ``axis_a``, ``a`` to body 0, ``b`` to the world); a refusal names ``joints[k]``."""
        unknown = set(d) - set(RigidJoint.__dataclass_fields__)
        if unknown:
            raise InvalidInput(f"RigidJoints: joints[{k}] has unknown fields {sorted(unknown)}; the fields are "
                               f"{list(RigidJoint.__dataclass_fields__)}")
        fields = {"a": 0, "b": -1, "anchor_a": (0.0, 0.0, 0.0), "anchor_b": (0.0, 0.0, 0.0),
                  "axis_a": (0.0, 0.0, 1.0), **d}
        fields.setdefault("axis_b", fields["axis_a"])
        try:
            _, kw = RigidJoint.__contract__.check((), fields)
            return RigidJoint(**kw)
        except InvalidInput as exc:
            raise InvalidInput(f"RigidJoints: joints[{k}]: {exc}") from None

    def stages(self) -> list:
        """Itself, plus the post-step projection onto C = 0, J u = 0 when ``projection`` is on."""
        from .projection import JointProjection

        return [self, JointProjection(self, *self._projection_args)] if self.projection else [self]

    @contract(system=Obj("pbanim.rigid.bodies:RigidBodies"))
    def bind(self, system) -> None:
        for k, j in enumerate(self.joints):
            for role, body in (("a", j.a), ("b", j.b)):
                if not -1 <= body < system.N:
                    raise InvalidInput(f"RigidJoints.bind: joints[{k}] body {role} must be -1 (world) or "
                                       f"0..{system.N - 1} (system has {system.N} bodies), got {body}")
        self.system = system
        q0 = system.unpack(system.state())[1]
        qw = np.vstack([q0, [1.0, 0, 0, 0]])
        # the relative orientation at rest: the weld/slider rotation rows hold q_b⁻¹ q_a = q_rel0
        self._qrel0 = [quat_multiply(quat_conjugate(qw[j.b]), qw[j.a]) for j in self.joints]
        self._plan = JointRowPlan(self.joints, system.N, self._qrel0)
        # which joints have motors, limits or velocity motors: fixed with the plan, so a step of joints
        # without them skips the loops over the joints that would find none
        self._motored = any(j.motor for j in self.joints)
        self._unilateral = any(j.limits is not None or j.motor_speed is not None for j in self.joints)
        self._lean = lean_joints(self)              # None: the readable path (joints_lean says when)

    # -- rows -----------------------------------------------------------------------------------
    @contract(y=_Y, sparse=Flag(), returns=finite_result)
    def rows(self, y: np.ndarray, sparse: bool = False):
        """(C, J (k, 6N), J̇u (k,), Ċ (k,)) at state y; J as a scipy.sparse CSR matrix with ``sparse``
        (all joints at once: :class:`~pbanim.articulated.joint_rows.JointRowPlan`, laid out at ``bind``)."""
        return self._plan.evaluate(self.system, y, sparse)

    # -- the constraint phase ------------------------------------------------------------------
    @contract(y=_Y, j=Obj(RigidJoint), qrel0=Array((4,)), returns=finite_result)
    def coordinate(self, y: np.ndarray, j: RigidJoint, qrel0) -> tuple[float, np.ndarray, float]:
        """The joint coordinate (hinge angle about â_b, or slide along â_b), its row on u, and its rate;
        ``qrel0``: the relative orientation q_b⁻¹ q_a at rest (``self._qrel0`` after ``bind``)."""
        s = self.system
        if not (-1 <= j.a < s.N and -1 <= j.b < s.N):
            raise InvalidInput(f"RigidJoints.coordinate: j joins bodies {j.a} and {j.b}, the system has {s.N}")
        x, q, _, _ = s.unpack(y)
        v, w = s.velocities(y)
        N = s.N
        pick = lambda arr, k, z: arr[k] if k >= 0 else z  # noqa: E731
        qa, qb = pick(q, j.a, np.array([1.0, 0, 0, 0])), pick(q, j.b, np.array([1.0, 0, 0, 0]))
        Rb = quat_to_matrix(qb)
        axis = Rb @ j.axis_b
        row = np.zeros(6 * N)
        if j.kind == "hinge":
            qe = quat_multiply(quat_conjugate(qb), quat_multiply(qa, quat_conjugate(qrel0)))
            value = 2.0 * np.arctan2(qe[1:] @ j.axis_b, qe[0])
            lin = np.zeros(3)
            ang = axis
        else:
            pa = pick(x, j.a, np.zeros(3)) + quat_to_matrix(qa) @ j.anchor_a
            pb = pick(x, j.b, np.zeros(3)) + Rb @ j.anchor_b
            value = float((pa - pb) @ axis)
            lin, ang = axis, np.zeros(3)
        for k, sign, anchor in ((j.a, 1.0, j.anchor_a), (j.b, -1.0, j.anchor_b)):
            if k >= 0:     # the slide moves the anchor: ω·(r × â); the hinge angle: ω·â (lin = 0 there)
                r = quat_to_matrix(q[k]) @ anchor
                row[6 * k:6 * k + 3] += sign * lin
                row[6 * k + 3:6 * k + 6] += sign * (ang + cross(r, lin))
        u = np.hstack([v, w]).ravel()
        return float(value), row, float(row @ u)

    def _motors(self, y, Q):
        for j, qrel0 in zip(self.joints, self._qrel0):
            if j.motor:
                _, row, _ = self.coordinate(y, j, qrel0)
                Q = Q + j.motor * row.reshape(Q.shape)        # generalized force of torque/force along the axis
        return Q

    def _limit_rows(self, y):
        """Inequality rows: active limits (λ ≥ 0, bias k_s C + k_d Ċ) and velocity motors (|λ| ≤ max,
        bias −(target − rate)/τ_m). Returns (bias, J, lo, hi)."""
        bias, J, lo, hi = [], [], [], []
        for j, qrel0 in zip(self.joints, self._qrel0):
            if j.limits is None and j.motor_speed is None:
                continue
            value, row, rate = self.coordinate(y, j, qrel0)
            if j.limits is not None:
                for c, sign in ((value - j.limits[0], 1.0), (j.limits[1] - value, -1.0)):
                    if c < self.limit_margin:                   # near or past the stop: an active unilateral row
                        bias.append(self.ks * c + self.kd * sign * rate), J.append(sign * row)
                        lo.append(0.0), hi.append(np.inf)
            if j.motor_speed is not None:                       # drive the rate to the target in time τ_m
                bias.append(-(j.motor_speed - rate) / self.motor_time), J.append(row)
                lo.append(-j.motor_max), hi.append(j.motor_max)
        return np.array(bias), np.array(J).reshape(len(bias), 6 * self.system.N), np.array(lo), np.array(hi)

    @contract(t=_T, y=_Y, Q=Array(("self.system.N", 6)), returns=finite_result)
    def constrain(self, t: float, y: np.ndarray, Q: np.ndarray) -> np.ndarray:
        if self._lean is not None and self.lean_path and self.solver == "dense":
            out = self._lean.constrain(y, Q)         # ball and hinge rows on preallocated arrays (joints_lean)
            if out is not None:
                return out
        if self._motored:
            Q = self._motors(y, Q)
        if self.solver == "linear":
            return self._constrain_linear(y, Q)
        return self._constrain_dense(y, Q)

    def _constrain_dense(self, y, Q):
        """The readable dense solve: the rows, J W Jᵀ, λ by Cholesky (least squares for dependent rows),
        limits and velocity motors by the LCP core."""
        s = self.system
        vel = s.velocities(y)
        C, J, jdot, Cdot = self._plan.evaluate(s, y, velocities=vel)
        Wb, WQ = self._free_acceleration(y, Q, vel[1])
        WJt = np.einsum("nij,knj->kni", Wb, J.reshape(len(C), s.N, 6)).reshape(len(C), -1)
        A = J @ WJt.T
        rhs = -jdot - J @ WQ - self.ks * C - self.kd * Cdot
        if not (np.all(np.isfinite(A)) and np.all(np.isfinite(rhs))):
            raise NonFiniteResult("the joint system J W Jᵀ λ = b", "the state or the bodies are too large")
        lam = _spd_solve(A, rhs)                  # independent rows (a tree): A = J W Jᵀ is SPD, Cholesky
        if lam is None:                           # dependent rows (a loop): the least-squares multipliers
            lam, res, rank, _ = np.linalg.lstsq(A, rhs, rcond=1e-12)
            if rank < len(C) and np.linalg.norm(A @ lam - rhs) > 1e-8 * max(1.0, np.linalg.norm(rhs)):
                raise SingularConstraintError(range(len(C)), float(np.linalg.norm(A @ lam - rhs)),
                                              "joint rows are dependent and inconsistent")
        bu0 = ()
        if self._unilateral:
            bu0, Ju, lo, hi = self._limit_rows(y)
        if len(bu0):
            # joint limits: unilateral rows with λ_u ≥ 0 ⊥ w_u ≥ 0 (w_u = J_u u̇ + k_s C + k_d Ċ); the equality
            # multipliers are eliminated exactly (Schur complement), the rest is an LCP for the one core
            k = bu0.size
            WJu = np.einsum("nij,knj->kni", Wb, Ju.reshape(k, s.N, 6)).reshape(k, -1)
            Aeu, Auu = J @ WJu.T, Ju @ WJu.T
            Ainv = np.linalg.pinv(A, rcond=1e-12)
            M = Auu - Aeu.T @ Ainv @ Aeu
            M = 0.5 * (M + M.T) + 1e-12 * max(1.0, float(np.abs(M).max())) * np.eye(k)
            bu = Ju @ WQ + bu0 + Aeu.T @ lam
            if np.all(lo == 0.0) and np.all(np.isinf(hi)):      # limits only: an LCP for Lemke
                lam_u = solve_lcp(M, bu, "lemke", tol=1e-9).f
            else:                                               # motor force bounds: box-constrained PGS
                lam_u = pgs_bounded(M, bu, lo, hi, max_iter=500, tol=1e-12)[0]
            lam = lam - Ainv @ (Aeu @ lam_u)
            self.last_limit_lambda = lam_u
            Q = Q + (Ju.T @ lam_u).reshape(Q.shape)
        self.last_lambda = lam
        return Q + (J.T @ lam).reshape(Q.shape)

    def _free_acceleration(self, y, Q, w=None):
        """(W blocks (N, 6, 6), u̇_free = W (Q + Q_gyro) flat) with Q_gyro = (0, −ω × I_world ω) = (0, −ω × L):
        the state holds L = I_world ω (``w``: ω when the caller has it)."""
        s = self.system
        Wb = s.inverse_mass_blocks(y)
        if w is None:
            w = s.velocities(y)[1]
        gyro = np.zeros_like(Q)
        gyro[:, 3:] = np.where(s.static[:, None], 0.0, -cross(w, s.unpack(y)[3]))
        return Wb, np.einsum("nij,nj->ni", Wb, Q + gyro).ravel()

    def _constrain_linear(self, y, Q):
        """Baraff's linear-time solve for joint trees: A = J W Jᵀ is block sparse (joints sharing a body),
        and eliminating the joints leaves first — deepest body first — creates no fill, so a sparse LDLᵀ in
        that order (natural ordering, no pivoting) costs O(n). Limits and motors use the dense path."""
        import scipy.sparse as sp
        from scipy.sparse.linalg import splu

        vel = self.system.velocities(y)
        C, J, jdot, Cdot = self._plan.evaluate(self.system, y, sparse=True, velocities=vel)
        Wb, WQ = self._free_acceleration(y, Q, vel[1])
        W = sp.block_diag(list(Wb), format="csr")
        A = (J @ W @ J.T).tocsc()
        rhs = -jdot - J @ WQ - self.ks * C - self.kd * Cdot
        order = self._leaves_first(len(C))
        try:
            lu = splu(A[order][:, order].tocsc(), permc_spec="NATURAL", diag_pivot_thresh=0.0,
                      options={"SymmetricMode": True})
            lam = np.empty_like(rhs)
            lam[order] = lu.solve(rhs[order])
        except RuntimeError:                    # dependent rows (a loop): not a tree, use the dense solve
            raise SingularConstraintError(range(len(C)), float("nan"), "solver='linear' needs a tree of joints "
                                          "(a closed loop makes the rows dependent); use solver='dense'") from None
        self.last_lambda = lam
        return Q + (J.T @ lam).reshape(Q.shape)

    def _leaves_first(self, k: int) -> np.ndarray:
        """Row order: joints by decreasing depth of their deeper body (the world has depth 0)."""
        if getattr(self, "_order", None) is None or self._order.size != k:
            depth = {-1: 0}
            pending = list(self.joints)
            for _ in range(len(self.joints) + 1):             # breadth-first from the world, ≤ n rounds
                rest = []
                for j in pending:
                    if j.a in depth or j.b in depth:
                        d = max(depth.get(j.a, -1), depth.get(j.b, -1)) + 1
                        depth.setdefault(j.a, d), depth.setdefault(j.b, d)
                    else:
                        rest.append(j)
                pending = rest
            n_rows = ROWS_PER_JOINT
            blocks, start = [], 0
            for j in self.joints:
                blocks.append((-max(depth.get(j.a, 0), depth.get(j.b, 0)), np.arange(start, start + n_rows[j.kind])))
                start += n_rows[j.kind]
            self._order = np.concatenate([rows for _, rows in sorted(blocks, key=lambda t: t[0])])
        return self._order

    @contract(t=_T, y=_Y, returns=finite_result)
    def diagnostics(self, t: float, y: np.ndarray) -> dict:
        if self._lean is not None and self.lean_path:
            C, Cdot = self._lean.errors(y)           # the same rows on the lean plan's arrays
        else:
            C, _, _, Cdot = self.rows(y)
        return {"joint_error": float(np.max(np.abs(C), initial=0.0)),
                "joint_velocity_error": float(np.max(np.abs(Cdot), initial=0.0))}
