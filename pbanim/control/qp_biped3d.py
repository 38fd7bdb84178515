"""The QP controller of the 3-D biped: features in space, friction pyramids, the same QP (chapter 08, part 2).

The planar controller (:mod:`.qp`) carries over with its unknowns x = (q̈, τ, f), its constraints and its
two modes unchanged; what is new is the model's kinematics (:class:`~pbanim.control.biped3d_step.WorldStep`:
world-frame joint columns Sᵂ, point Jacobians, H) and three force entries per contact point f = (fₙ, fₜ₁, fₜ₂),
kept inside the four-sided friction pyramid |fₜₖ| ≤ μ fₙ (:func:`~pbanim.control.qp_solve.friction_pyramid`).
The four sole corners of each foot are the contact candidates (twelve rows a foot for six degrees of
freedom: :func:`~pbanim.control.qp_solve.contact_rows` keeps a full-rank subset).

**Accelerations at q̈ = 0** (the biases J̇ q̇). With Vᵢ = (ωᵢ, vᵢ) the spatial velocity of link i in world
coordinates (v the velocity of the body point at the world origin; Vᵢ = Σ_{j ⪯ i} Sⱼ q̇ⱼ over its ancestors'
columns), a joint's column is fixed in its link, so Ṡⱼ = Vⱼ × Sⱼ (spatial cross product
(ω, v) × (ω', v') = (ω × ω', ω × v' + v × ω')) and

    Aᵢ = Σ_{j ⪯ i} Vⱼ × Sⱼ q̇ⱼ,          a_p = A_v + A_ω × p + ω × (v + ω × p)

the spatial acceleration of link i and the acceleration of its point p when q̈ = 0 (``_link_motion``,
``_point_bias``). The floating pelvis's six columns move with it (body-frame q̇): the same rule.

**Features** (de Lasa, Mordatch & Hertzmann 2010), each ÿ = J_y q̈ + J̇_y q̇:

    centre of mass     c = Σ mᵢ cᵢ / M,      J_c = Σ mᵢ J_cᵢ / M,        bias Σ mᵢ a_cᵢ / M
    angular momentum   L = Σ mᵢ (cᵢ − c) × ċᵢ + Īᵢ ωᵢ = A_L q̇,   A_L = Σ mᵢ [cᵢ − c]× J_cᵢ + Īᵢ J_ωᵢ,
                       L̇ = A_L q̈ + Σ mᵢ (cᵢ − c) × a_cᵢ + Īᵢ Aᵢ,ω + ωᵢ × Īᵢ ωᵢ       (Īᵢ = Rᵢ Iᵢ Rᵢᵀ)
    trunk orientation  ω̇₀ = R₀ q̈₀:₃ (the pelvis's body-frame q̇; the torso is welded to it), the error the
                       rotation vector log(R̄ R₀ᵀ) with R̄ = R_z(ψ̄) R_y(θ̄) R_x(φ̄)
    a point, a joint   as in the plane (3 rows a point; a joint θ = q[v + 1], the quaternion has 4 numbers)

The bias forces come from the same sums (the principle of virtual work over the links, at q̈ = 0):

    C = Σᵢ J_cᵢᵀ mᵢ (a_cᵢ − g) + J_ωᵢᵀ (Īᵢ Aᵢ,ω + ωᵢ × Īᵢ ωᵢ) + b q̇   (equal to RNEA's ID(q, q̇, 0), tested)

computed once, by the 3-D contact step's :func:`~pbanim.control.biped3d_lean.bias` (b the joint damping,
which the step's dynamics include; zero on this biped).

Newton and Euler for the whole body then say M c̈ = Σ fⱼ + M g and L̇ = Σ (pⱼ − c) × fⱼ for every QP
answer (ORACLES F21, tested): a check of every bias above, with no finite difference.

**The solver.** The equations of motion have entries of the body's weight M g (≈ 690 N in the force
columns, after the solver's unit scaling) and the contact rows entries of 1; ProxQP's test for primal
infeasibility (a relative threshold of 1e-4 by default) then fires on feasible QPs. Measured on the
scripted step (:func:`~pbanim.control.qp_biped3d_run.simulate_step`, h = 8 ms): ProxQP alone stops with
"PROXQP_PRIMAL_INFEASIBLE" at t = 0.064 s (both feet down, the centre of mass shifting); retried with
eps_abs × 10 and the regularization × 10 it gets to t = 1.08 s (the landing) and fails there alike.
An LP phase 1 (``scipy.optimize.linprog`` on the same equalities, cones and bounds) finds both QPs
feasible with zero violation (the first strictly: every cone row, normal force and torque bound slack
by 0.17 M g at once). Badly scaled, not infeasible: the QP goes to ProxQP with its rows equilibrated (each
over its largest entry) and the certificate's threshold at 1e-8 (``solver_options``); the landing's QP
is solved in 25 iterations, and the step runs on ProxQP alone (ORACLES F21).

Tasks are :class:`~pbanim.control.qp_tasks.Task` objects with ``dim=3``: ``com`` and ``point`` 3-vectors,
``momentum`` a 3-vector L̄, ``posture`` joint names of :data:`~pbanim.control.biped3d.BIPED3D_JOINTS` or the
trunk's three angles :data:`TRUNK` (a posture task names either kind, not both).

=========  ===============  ==============  ===========================================================
symbol     code             shape           meaning
=========  ===============  ==============  ===========================================================
x          ``x``            (18 + 12 + 3m)  q̈, τ (the twelve leg joints), f = (fₙ, fₜ₁, fₜ₂) per point
H, C       ``H``, ``C``     (18, 18), (18)  mass matrix (WorldStep), bias forces (RNEA at q̈ = 0)
Vᵢ, Aᵢ     ``V``, ``A0``    (n, 6)          link velocities, accelerations at q̈ = 0 (ω first)
=========  ===============  ==============  ===========================================================

Limiting cases: at rest every bias but gravity's is zero (V = 0 ⇒ A = 0, a_p = 0); a pure translation of
the pelvis leaves L and A_L unchanged; μ = 0 allows only normal forces.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..contracts import Anything, Array, Choice, Flag, Int, Opt, Real, Seq, Text, contract, unchecked
from ..errors import InvalidInput, NonFiniteResult
from ..geometry import cross as _checked_cross
from ..rigid.quat import quat_from_axis_angle, quat_multiply, quat_to_matrix
from .biped3d import BIPED3D_JOINTS, biped3d, biped3d_contact_points
from .biped3d_lean import bias as _bias
from .biped3d_step import WorldStep
from .pd import InvalidGains, _per_joint
from .qp import _CONTACTS, _TOL, MODES, InfeasibleControl, QPController, QPResult
from .qp_solve import backends, contact_rows, friction_pyramid, joint_limit_bounds, limit_settings, settings
from .qp_tasks import Task, check_tasks
from .simbicon3d import rotation_vector
from .specs import Mapping, Pair, named

_cross = unchecked(_checked_cross)     # a × b by components: np.cross's arithmetic without its axis moves

__all__ = ["Centroidal3D", "Ground3D", "QPBiped3D", "QPResult3D", "TRUNK", "trunk_matrix"]

TRUNK = ("trunk_roll", "trunk_pitch", "trunk_yaw")
_Q, _QD = Array((19,)), Array((18,))
_KIN = Opt(Anything("the dict of the controller's kinematics(q), or None"))


@contract(mu=Real(ge=0), height=Real(), normal=Array((3,)), tangents=Array((2, 3)))
@dataclass(frozen=True)
class Ground3D:
    """The plane z = ``height`` with friction ``mu``: normal ẑ, tangents x̂, ŷ (the pyramid's directions)."""

    mu: float = 0.9
    height: float = 0.0
    normal: tuple = (0.0, 0.0, 1.0)
    tangents: tuple = ((1.0, 0.0, 0.0), (0.0, 1.0, 0.0))

    @contract(P=Array(("m", 3)))
    def gap(self, P: np.ndarray) -> np.ndarray:
        """Height of the points P (m, 3) above the plane (m)."""
        return P[:, 2] - self.height


def _cross6(V: np.ndarray, W: np.ndarray) -> np.ndarray:
    """Spatial motion cross products V × W of (…, 6) arrays (ω first)."""
    w, v, w2, v2 = V[..., :3], V[..., 3:], W[..., :3], W[..., 3:]
    return np.concatenate([_cross(w, w2), _cross(w, v2) + _cross(v, w2)], axis=-1)


def _link_motion(world: WorldStep, kin: dict, qd: np.ndarray, owner=None) -> tuple[np.ndarray, np.ndarray]:
    """(V (n, 6), A (n, 6)): each link's spatial velocity and its acceleration at q̈ = 0 (module docstring);
    ``owner``: the link each velocity column moves (the step's own ``_joint_link`` when not given)."""
    owner = world._joint_link if owner is None else owner
    mask = world.mask.astype(float)
    cols = kin["S"].T * qd[:, None]                           # Sⱼ q̇ⱼ (nv, 6)
    V = mask @ cols                                           # Vᵢ = Σ_{j ⪯ i} Sⱼ q̇ⱼ
    return V, mask @ _cross6(V[owner], cols)                  # Aᵢ = Σ_{j ⪯ i} Vⱼ × Sⱼ q̇ⱼ


def _point_bias(kin: dict, V: np.ndarray, A: np.ndarray, links, P: np.ndarray) -> np.ndarray:
    """a_p = A_v + A_ω × p + ω × (v + ω × p) (m, 3) of world points P (m, 3) on ``links`` at q̈ = 0."""
    links = np.asarray(links, dtype=int)
    w, v, aw, av = V[links, :3], V[links, 3:], A[links, :3], A[links, 3:]
    return av + _cross(aw, P) + _cross(w, v + _cross(w, P))


@dataclass(frozen=True)
class Centroidal3D:
    """Centre of mass (position, velocity, Jacobian, bias) and angular momentum about it (L, A_L, bias)."""

    mass: float
    com: np.ndarray          # (3,)
    vcom: np.ndarray         # (3,)
    J: np.ndarray            # (3, nv)
    bias: np.ndarray         # (3,)
    L: np.ndarray            # (3,)
    A: np.ndarray            # (3, nv)
    L_bias: np.ndarray       # (3,)
    C: np.ndarray            # (nv,)  bias forces C(q, q̇) of H q̈ + C = τ (gravity in them)


def _centroidal3d(world: WorldStep, kin: dict, qd: np.ndarray, V: np.ndarray, A: np.ndarray) -> Centroidal3D:
    """The centroidal features of the module docstring at (q, q̇) (``kin``: world.kinematics(q); V, A:
    ``_link_motion``)."""
    n = world.tree.n
    m, M = world.mass, float(world.mass.sum())
    c = kin["c"]
    local = np.einsum("nji,nj->ni", kin["R"], c - kin["o"])
    _, Jc = world.point_jacobians(kin, np.arange(n), local)             # (n, 3, nv)
    Jw = kin["S"][None, :3, :] * world.mask[:, None, :]
    ac = _point_bias(kin, V, A, np.arange(n), c)
    com = m @ c / M
    r = c - com
    Iw = kin["R"] @ world.inertia @ kin["R"].transpose(0, 2, 1)
    rx = np.zeros((n, 3, 3))                                              # [rᵢ]×
    rx[:, 0, 1], rx[:, 0, 2], rx[:, 1, 2] = -r[:, 2], r[:, 1], -r[:, 0]
    rx -= rx.transpose(0, 2, 1)
    AL = np.einsum("n,nij,njv->iv", m, rx, Jc) + np.einsum("nij,njv->iv", Iw, Jw)
    w, Iww = V[:, :3], np.einsum("nij,nj->ni", Iw, V[:, :3])
    tq = np.einsum("nij,nj->ni", Iw, A[:, :3]) + _cross(w, Iww)       # Īᵢ αᵢ + ωᵢ × Īᵢ ωᵢ
    Lb = m @ _cross(r, ac) + tq.sum(axis=0)
    J = np.einsum("n,niv->iv", m, Jc) / M
    C = _bias(world, kin, qd)                  # the same link sums, written once (the 3-D step's lean C)
    return Centroidal3D(mass=M, com=com, vcom=J @ qd, J=J, bias=m @ ac / M, L=AL @ qd, A=AL, L_bias=Lb, C=C)


@contract(roll=Real(), pitch=Real(), yaw=Real())
def trunk_matrix(roll: float, pitch: float, yaw: float) -> np.ndarray:
    """R̄ = R_z(yaw) R_y(pitch) R_x(roll)."""
    qz, qy, qx = (quat_from_axis_angle(np.eye(3)[k], a) for k, a in ((2, yaw), (1, pitch), (0, roll)))
    return quat_to_matrix(quat_multiply(quat_multiply(qz, qy), qx))


@dataclass
class QPResult3D(QPResult):
    """:class:`~pbanim.control.qp.QPResult` of the 3-D biped (forces (8, 3): fₙ, fₜ₁ along x̂, fₜ₂ along ŷ),
    with the centre of mass c, ċ and the Newton–Euler residuals (|M c̈ − Σ f − M g| N, |L̇ − Σ(p − c) × f| N m)
    of the answer (ORACLES F21)."""

    com: np.ndarray = None
    vcom: np.ndarray = None
    newton_euler: np.ndarray = None


class QPBiped3D(QPController):
    """The QP controller of the 3-D biped (:func:`~pbanim.control.biped3d.biped3d`; module docstring).

    The arguments are :class:`~pbanim.control.qp.QPController`'s with the ground a :class:`Ground3D` of
    friction ``friction``; ``solve``, ``torques`` and ``active_contacts`` take (q (19,), q̇ (18,)) and
    ``contacts`` (a mask or indices of the eight sole corners, left foot first) as the planar one.
    Joint limits and posture tasks name joints of :data:`~pbanim.control.biped3d.BIPED3D_JOINTS`.
    The QP goes to the solver with ``solver_options`` (module docstring, "The solver").
    """

    solver_options = {"equilibrate": True, "primal_inf": 1e-8}

    @contract(tasks=Seq(Anything("Task objects with dim=3, checked in the body")), mode=Choice(MODES),
              torque_limits=named(InvalidGains, Array((12,), ge=0, finite=False, scalar=True)),
              friction=Real(ge=0), min_normal=Real(ge=0), contact_tol=Real(ge=0), contact_speed=Real(ge=0),
              regularization=Real(gt=0), task_tol=_TOL, feasibility_tol=_TOL, backend=Choice(backends),
              native=Flag(), eps_abs=_TOL, max_iter=Int(ge=1, le=100_000),
              joint_limits=Opt(Mapping(Text(), Pair(Real(), Real()))), limit_horizon=Real(gt=0, le=10))
    def __init__(self, tasks=(), *, mode: str = "weighted", torque_limits=np.inf, friction: float = 0.9,
                 min_normal: float = 0.0, contact_tol: float = 2e-3, contact_speed: float = 0.05,
                 regularization: float = 1e-6, task_tol: float = 1e-4, feasibility_tol: float = 1e-6,
                 backend: str = "proxqp", native: bool = True, eps_abs: float = 1e-9, max_iter: int = 2000,
                 joint_limits: dict | None = None, limit_horizon: float = 0.1) -> None:
        tree = biped3d()
        pts = biped3d_contact_points(tree)
        self.kernel = tree                                     # n and nv, as the planar kernel's
        self.world = WorldStep(tree, pts, friction=friction)
        self.owner = self.world._joint_link
        self.links = np.array([lk for lk, _ in pts])
        self.local = np.array([p for _, p in pts])
        self.ground, self.mode = Ground3D(float(friction)), mode
        nv = tree.nv
        self.actuated = np.arange(6, nv)
        self.na = int(self.actuated.size)
        self.S = np.zeros((self.na, nv))
        self.S[np.arange(self.na), self.actuated] = 1.0
        self.joints = dict(BIPED3D_JOINTS, **{nm: k for k, nm in enumerate(TRUNK)})
        settings(self, _per_joint(torque_limits, self.na), min_normal, contact_tol, contact_speed, regularization, task_tol,
                 feasibility_tol, backend, native, eps_abs, max_iter)
        self.tasks = self._checked(tasks)
        limit_settings(self, joint_limits, limit_horizon, BIPED3D_JOINTS)
        self.f_scale = float(self.world.mass.sum()) * 9.81

    def _checked(self, tasks) -> list:
        tasks = check_tasks(tasks, self.kernel, self.joints, dim=3)
        for t in tasks:
            trunk = set(t.target) & set(TRUNK) if t.kind == "posture" else set()
            if trunk and set(t.target) != set(TRUNK):
                raise InvalidInput(f"task {t.name!r}: a trunk posture names exactly {TRUNK}, and no joint beside")
        return tasks

    def _replace(self, name: str, new: Task) -> None:
        self.task(name)
        self.tasks = self._checked([new if t.name == name else t for t in self.tasks])

    @contract(q=_Q)
    def kinematics(self, q) -> dict:
        """World frames of the biped at q (:meth:`WorldStep.kinematics`)."""
        return self.world.kinematics(np.asarray(q, dtype=float))

    def _motion(self, kin: dict, qd: np.ndarray) -> tuple:
        if "V" not in kin:                                    # cached: one kinematics serves build and tasks
            kin["V"], kin["A0"] = _link_motion(self.world, kin, qd, self.owner)
        return kin["V"], kin["A0"]

    def _contacts(self, kin: dict, qd: np.ndarray) -> tuple:
        """(active mask, Jacobians (m, 3, nv), biases J̇q̇ (m, 3)) of the sole corners."""
        P, J = self.world.point_jacobians(kin, self.links, self.local)
        V, A = self._motion(kin, qd)
        vn = (J @ qd)[:, 2]
        active = (self.ground.gap(P) <= self.contact_tol) & (vn <= self.contact_speed)
        return active, J, _point_bias(kin, V, A, self.links, P)

    @contract(q=_Q, qd=_QD, kin=_KIN)
    def active_contacts(self, q, qd, kin: dict | None = None) -> np.ndarray:
        """Which sole corners are on the ground (gap ≤ ``contact_tol``, not leaving faster than ``contact_speed``)."""
        kin = self.kinematics(q) if kin is None else kin
        return self._contacts(kin, np.asarray(qd, dtype=float))[0]

    @contract(q=_Q, qd=_QD, kin=_KIN, contacts=_CONTACTS)
    def build(self, q, qd, kin: dict | None = None, contacts=None) -> dict:
        """The QP's matrices at (q, q̇), as :meth:`QPController.build`'s (three force entries a point)."""
        q, qd = np.asarray(q, dtype=float), np.asarray(qd, dtype=float)
        kin = self.kinematics(q) if kin is None else kin
        V, A = self._motion(kin, qd)
        cf = _centroidal3d(self.world, kin, qd, V, A)
        H, C = self.world.mass_matrix(kin), cf.C
        if contacts is not None and np.asarray(contacts).dtype != bool:
            contacts = np.asarray(contacts, dtype=int)
        active, J, Jb = self._mask(contacts, kin, qd)
        if not np.isfinite(H.sum() + C.sum() + Jb.sum() + cf.bias.sum() + cf.L_bias.sum()):
            raise NonFiniteResult("QPBiped3D.build: the equations of motion at (q, q̇)",
                                  "the state's speeds or positions are too large")
        Jnt, bnt, keep = contact_rows(J[active], Jb[active], self.ground)
        nv, na, m3 = self.kernel.nv, self.na, Jnt.shape[0]
        N = nv + na + m3
        Aeq = np.zeros((nv + keep.size, N))
        Aeq[:nv, :nv], Aeq[:nv, nv:nv + na], Aeq[:nv, nv + na:] = H, -self.S.T, -Jnt.T
        Aeq[nv:, :nv] = Jnt[keep]
        beq = np.concatenate([-C, -bnt[keep]])
        G = friction_pyramid(m3 // 3, 3, self.ground.mu, nv + na, N)
        lb = np.concatenate([np.full(nv, -np.inf), -self.torque_limits, np.tile([self.min_normal, -np.inf, -np.inf], m3 // 3)])
        ub = np.concatenate([np.full(nv, np.inf), self.torque_limits, np.full(m3, np.inf)])
        if self.limit_index.size:
            i = self.limit_index
            lb[i], ub[i] = joint_limit_bounds(q[1:], qd, i, self.limit_lo, self.limit_hi, self.limit_horizon)
        rows = []
        for t in self.tasks:
            Jy, bias, ydes = self._task_rows(t, kin, q, qd, cf)
            Ay = np.zeros((Jy.shape[0], N))
            Ay[:, :nv] = Jy
            rows.append((t, Ay, ydes - bias))
        R = np.concatenate([np.ones(nv), np.full(na + m3, self.f_scale ** -2)])
        self._last = {"centroidal": cf, "points": self.world.point_jacobians(kin, self.links, self.local)[0]}
        return {"Aeq": Aeq, "beq": beq, "G": G, "lb": lb, "ub": ub, "tasks": rows, "R": R, "active": active,
                "H": H, "C": C, "Jnt": Jnt, "bnt": bnt, "keep": keep, "N": N, "dirs": 3, "centroidal": cf}

    def _task_rows(self, t: Task, kin: dict, q, qd, cf: Centroidal3D) -> tuple:
        """(J_y, J̇_y q̇, ÿ*) of one task (module docstring)."""
        nv = self.kernel.nv
        if t.kind == "momentum":
            return cf.A, cf.L_bias, t.acceleration + t.kd * (t._target - cf.L)
        if t.kind == "com":
            y, yd, J, bias = cf.com, cf.vcom, cf.J, cf.bias
        elif t.kind == "point":
            links = np.array([t.link])
            P, J = self.world.point_jacobians(kin, links, np.array([t.local]))
            V, A = self._motion(kin, qd)
            y, J, bias = P[0], J[0], _point_bias(kin, V, A, links, P)[0]
            yd = J @ qd
        elif set(t.target) == set(TRUNK):                      # the trunk's orientation: ω̇₀ = R₀ q̈₀:₃
            J = np.zeros((3, nv))
            J[:, :3] = kin["R"][0]
            ang = [t.target[nm] for nm in TRUNK]
            err = rotation_vector(trunk_matrix(*ang) @ kin["R"][0].T)
            return J, np.zeros(3), t.acceleration + t.kp * err + t.kd * (t.velocity - kin["R"][0] @ qd[:3])
        else:
            idx = np.array([self.joints[nm] for nm in t.target])
            J = np.zeros((idx.size, nv))
            J[np.arange(idx.size), idx] = 1.0
            y, yd, bias = q[idx + 1], qd[idx], np.zeros(idx.size)
        return J, bias, t.acceleration + t.kp * (t._target - y) + t.kd * (t.velocity - yd)

    @contract(q=_Q, qd=_QD, kin=_KIN, contacts=_CONTACTS, raise_on_failure=Flag())
    def solve(self, q, qd, kin: dict | None = None, contacts=None, *, raise_on_failure: bool = False):
        """Solve the control QP at (q, q̇) (:meth:`QPController.solve`; forces (8, 3): fₙ, fₜ₁, fₜ₂)."""
        res = QPController.solve.__wrapped__(self, q, qd, kin, contacts)
        res = QPResult3D(**vars(res), **self._newton_euler(res))
        if raise_on_failure and not res.success:
            raise InfeasibleControl(res)
        return res

    def _newton_euler(self, res) -> dict:
        """The centre of mass and |M c̈ − Σ f − M g| (N), |L̇ − Σ (pⱼ − c) × fⱼ| (N m) at the answer."""
        cf, P = self._last["centroidal"], self._last["points"]
        F = res.forces[:, [1, 2, 0]]                          # (fₜ₁, fₜ₂, fₙ) along x̂, ŷ, ẑ: world forces
        lin = cf.mass * (cf.J @ res.qdd + cf.bias) - F.sum(axis=0) - cf.mass * np.asarray(self.kernel.gravity)
        ang = cf.A @ res.qdd + cf.L_bias - _cross(P - cf.com, F).sum(axis=0)
        return {"com": cf.com, "vcom": cf.vcom, "newton_euler": np.array([np.linalg.norm(lin), np.linalg.norm(ang)])}

    @contract(q=_Q, qd=_QD, kin=_KIN)
    def torques(self, q, qd, kin: dict | None = None) -> np.ndarray:
        """τ (18,) of one control step (:class:`~pbanim.control.qp.InfeasibleControl` when infeasible)."""
        return self.solve(q, qd, kin, raise_on_failure=True).tau
