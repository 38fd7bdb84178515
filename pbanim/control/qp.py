"""Optimization-based control: one QP per control step over q̈, τ and f (chapter 08, part 2).

The lecture's second kind of controller computes the torques by optimization at every step (de Lasa,
Mordatch & Hertzmann, "Feature-Based Locomotion Controllers", SIGGRAPH 2010). The unknowns are the joint
accelerations q̈, the actuated torques τ and, for each contact point j on the ground, its normal and
tangential force fⱼ = (fₙ, fₜ); the QP is

    min   Σₖ wₖ ‖J_k q̈ + J̇_k q̇ − ÿₖ*‖² + ε (‖q̈‖² + ‖τ/τ_s‖² + ‖f/f_s‖²)       (tasks, :mod:`.qp_tasks`)
    s.t.  M q̈ + C = Sᵀ τ + J_cᵀ f                    (equations of motion; C: Coriolis and gravity)
          J_c q̈ + J̇_c q̇ = 0                          (a contact point on the ground does not accelerate)
          |fₜ| ≤ μ fₙ,   fₙ ≥ fₙ,min ≥ 0             (friction cone, exact in the plane; no pulling)
          |τ| ≤ τ_max                                (torque limits)
          θ + T θ̇ + ½T² θ̈ ∈ [θ_min, θ_max]             (joint limits, optional: box bounds on q̈)

with J_c the rows n·Jⱼ, t·Jⱼ of the contact points (n, t the ground's normal and tangent; a foot flat on
the ground has four such rows for three degrees of freedom, so only a full-rank subset of them is kept,
chosen by QR with column pivoting), S the selection of the actuated coordinates (the planar base — two
sliders and a hinge — is not actuated) and τ_s = M|g|·1 m, f_s = M|g| scales for the small
regularization ε that makes the solution unique.

Two ways to combine tasks (``mode``):

* **weighted**: one QP with the sum above;
* **prioritized**: one QP per priority level ℓ = 0, 1, …, each minimizing only its own tasks subject to the
  constraints *and* to A_ℓ' x = A_ℓ' x*_ℓ' for every level ℓ' above: for a convex
  least-squares objective over a polyhedron the optimal set is exactly {x feasible : A x = A x*}, so a lower
  level can use only what the higher ones leave free (ORACLES F13). A last QP minimizes the regularization.

The result (:class:`QPResult`) says what happened, never only a number: ``"met"`` (every task's desired
acceleration reached), ``"compromise"`` (the constraints hold but some target cannot be met: the
least-squares compromise, with each task's error named in the message; ORACLES F12), ``"unconverged"``
(the constraints hold, but the solver's multipliers do not certify the answer optimal) or ``"infeasible"``
(the constraints are inconsistent or the solver failed: which constraint group is violated and by how
much). Every answer is judged by residuals computed here, not by the solver's claim (ORACLES F10).

=========  ==================  ==============  ===========================================================
symbol     code                shape           meaning
=========  ==================  ==============  ===========================================================
q̈, τ, f    ``x``               (nv + na + 2m)  the unknowns, in this order; f = (fₙ₁, fₜ₁, fₙ₂, …)
M, C       ``H``, ``C``        (nv, nv), (nv)  mass matrix and bias forces (PlanarKernel.dynamics)
S          ``S``               (na, nv)        actuated coordinates
J_c        ``Jnt``             (2m, nv)        normal and tangential rows of the active contact points
μ          ``ground.mu``       scalar          Coulomb friction
wₖ, ÿₖ*    ``Task``            —               weights and desired feature accelerations
=========  ==================  ==============  ===========================================================

Limiting cases: no contact — the base accelerates under gravity alone (the unactuated rows); one task
at weight 1 with all others zero — that task is met whenever the constraints allow it; μ = 0 — only normal
forces, so the centre of mass cannot accelerate sideways.

Backends (``backend``): ``"proxqp"`` with ``native=True`` calls proxsuite's dense ProxQP directly with its
own box constraints (the conventions of :func:`pbanim.lcp.solve_lcp`'s QP route); any other name in
``qpsolvers.available_solvers`` (or ``native=False``) goes through ``qpsolvers.solve_problem``.

References: de Lasa, Mordatch & Hertzmann 2010 (features, prioritized optimization); M. de Lasa and
A. Hertzmann, "Prioritized optimization for task-space control", IROS 2009; Y. Abe, M. da Silva,
J. Popović, "Multiobjective control with frictional contacts", SCA 2007; A. Bambade et al., "PROX-QP",
RSS 2022.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field

import numpy as np

from ..articulated.planar import PlanarKernel
from ..articulated.planar_step import PlanarGround
from ..contracts import Array, Choice, Either, Flag, Index, Indices, Int, Obj, Opt, Real, Seq, Text, contract
from ..errors import NonFiniteResult, PbanimError
from .biped import BIPED_JOINTS
from .pd import InvalidGains, _per_joint
from .qp_features import centroidal
from .qp_solve import (backends, contact_rows, friction_pyramid, joint_limit_bounds, keep_level, limit_settings, settings,
                       solve_qp)
from .qp_tasks import TARGET, InvalidTask, Task, UnknownTask, check_tasks, task_rows
from .specs import Count, KinematicsOf, Mapping, Mask, Pair, named

__all__ = ["MODES", "InfeasibleControl", "InvalidTask", "QPController", "QPResult", "Task", "UnknownTask"]

MODES = ("weighted", "prioritized")
STATUSES = ("met", "compromise", "unconverged", "infeasible")
KKT_TOL = 1e-7      # the relative KKT residual up to which an answer is certified optimal (native ProxQP: ≤ 3e-9)
_TOL = Real(gt=0, lt=1)                 # a relative tolerance: 1 or more would call anything a match
_STATE = Array(("self.kernel.nv",))
_KIN = Opt(KinematicsOf())
_CONTACTS = Opt(Either(Mask("self.links.size"), Indices("self.links.size", empty=True, distinct=True)))
_ACTUATED = Count("actuated", default=lambda env: env.values["kernel"].nv - 3,
                  text="the number of actuated coordinates")


class InfeasibleControl(PbanimError, RuntimeError):
    """A control QP had no solution that satisfies its constraints (``result`` says which failed)."""

    def __init__(self, result: QPResult) -> None:
        self.result = result
        super().__init__(result.message)


@dataclass
class QPResult:
    """One control step: torques, accelerations, contact forces, and what happened.

    ``tau`` and ``qdd`` have one entry per coordinate (zero torque on unactuated ones); ``forces`` (m, 2)
    the (normal, tangential) force of every contact point (zero where ``active`` is False). ``residuals``
    holds the largest violation of each constraint group ("dynamics" N or N m, "contact" m/s², "cone" and
    "limits"), ``task_errors`` each task's ‖J q̈ + J̇ q̇ − ÿ*‖ at the answer, ``kkt`` the largest relative
    KKT residual of the QPs solved (:func:`~pbanim.control.qp_solve.kkt_residual`; inf when a backend gives
    no multipliers). ``status``: "met" or "compromise" (constraints hold, the answer certified optimal:
    kkt ≤ :data:`KKT_TOL`), "unconverged" (constraints hold, optimality not certified: usable torques, maybe
    not the optimum), "infeasible" (a constraint fails, or no answer: the arrays hold the solver's last
    iterate for diagnosis only, and :meth:`QPController.torques` raises :class:`InfeasibleControl`).
    """

    status: str
    message: str
    tau: np.ndarray
    qdd: np.ndarray
    forces: np.ndarray
    active: np.ndarray
    task_errors: dict
    residuals: dict
    tolerances: dict
    solver_status: list = field(default_factory=list)
    iterations: int = 0
    build_time: float = 0.0
    solve_time: float = 0.0
    kkt: float = 0.0

    @property
    def success(self) -> bool:
        """True when the constraints hold (status "met", "compromise" or "unconverged")."""
        return self.status != "infeasible"


class QPController:
    """The QP controller of a planar character (see the module docstring).

    ``points``: the contact candidates, (link index, point in the link frame (3,)) pairs (e.g.
    :func:`pbanim.models.biped.biped_contact_points`); a point is active when its gap to the ground is at
    most ``contact_tol`` and it does not leave the ground faster than ``contact_speed`` (or as given to
    :meth:`solve`). ``joints``: names → coordinates for posture tasks
    (default: the biped's :data:`BIPED_JOINTS` when the tree is the biped, else each link's own name).
    ``joint_limits``: name → (θ_min, θ_max) rad for joints of ``joints``, kept with the horizon
    ``limit_horizon`` T (s) as inequalities of every QP (:func:`~pbanim.control.qp_solve.joint_limit_bounds`).
    """

    solver_options = {}      # more of solve_qp's options (the 3-D biped's: equilibrate, primal_inf)

    @contract(kernel=Obj(PlanarKernel), points=Seq(Pair(Index("kernel.n"), Array((3,)))),
              ground=Opt(Obj(PlanarGround)), tasks=Seq(Obj(Task)), mode=Choice(MODES),
              actuated=Opt(Indices("kernel.nv", empty=True, distinct=True)),
              joints=Opt(Mapping(Text(), Index("kernel.nv"))),
              torque_limits=named(InvalidGains, Array((_ACTUATED,), ge=0, finite=False, scalar=True, empty=True)),
              min_normal=Real(ge=0), contact_tol=Real(ge=0), contact_speed=Real(ge=0), regularization=Real(gt=0),
              task_tol=_TOL, feasibility_tol=_TOL, backend=Choice(backends), native=Flag(),
              eps_abs=_TOL, max_iter=Int(ge=1, le=100_000),
              joint_limits=Opt(Mapping(Text(), Pair(Real(), Real()))), limit_horizon=Real(gt=0, le=10))
    def __init__(self, kernel: PlanarKernel, points, ground: PlanarGround | None = None, tasks=(), *,
                 mode: str = "weighted", actuated=None, joints: dict | None = None, torque_limits=np.inf,
                 min_normal: float = 0.0, contact_tol: float = 2e-3, contact_speed: float = 0.05, regularization: float = 1e-6,
                 task_tol: float = 1e-4, feasibility_tol: float = 1e-6,
                 backend: str = "proxqp", native: bool = True, eps_abs: float = 1e-9, max_iter: int = 2000,
                 joint_limits: dict | None = None, limit_horizon: float = 0.1):
        self.kernel, nv = kernel, kernel.nv
        pts = list(points)
        self.links = np.array([int(lk) for lk, _ in pts], dtype=int)
        self.local = np.array([np.asarray(p, dtype=float) for _, p in pts], dtype=float).reshape(len(pts), 3)
        self.ground = ground or PlanarGround()
        self.mode = mode
        act = np.arange(3, nv) if actuated is None else np.asarray(actuated, dtype=int)
        self.actuated, self.na = act, int(act.size)
        self.S = np.zeros((self.na, nv))
        self.S[np.arange(self.na), self.actuated] = 1.0
        names = [lk.name for lk in kernel.tree.links]
        if joints is None:
            joints = dict(BIPED_JOINTS) if names[-1] == "right_foot" and nv == len(BIPED_JOINTS) else \
                {nm: int(kernel.vidx[i]) for i, nm in enumerate(names) if kernel.vidx[i] >= 0}
        self.joints = dict(joints)
        settings(self, _per_joint(torque_limits, self.na), min_normal, contact_tol, contact_speed, regularization, task_tol,
                 feasibility_tol, backend, native, eps_abs, max_iter)
        self.tasks = check_tasks(tasks, kernel, self.joints)
        limit_settings(self, joint_limits, limit_horizon, self.joints)
        M = float(kernel.mass.sum())
        self.f_scale = M * max(float(np.linalg.norm(kernel.g)), 1.0)

    # -- tasks -------------------------------------------------------------------------------
    @contract(name=Text())
    def task(self, name: str) -> Task:
        """The task called ``name`` (:class:`UnknownTask` when there is none)."""
        for t in self.tasks:
            if t.name == name:
                return t
        raise UnknownTask(f"no task named {name!r}; the controller has {[t.name for t in self.tasks]}")

    def _replace(self, name: str, new: Task) -> None:
        self.task(name)
        self.tasks = check_tasks([new if t.name == name else t for t in self.tasks], self.kernel, self.joints)

    @contract(name=Text(), target=named(InvalidTask, Opt(TARGET)))
    def set_target(self, name: str, target) -> None:
        """Give the task ``name`` a new target (validated)."""
        self._replace(name, self.task(name).with_target(target))

    @contract(name=Text(), weight=named(InvalidTask, Real(ge=0)))
    def set_weight(self, name: str, weight) -> None:
        """Give the task ``name`` a new weight (≥ 0, finite)."""
        self._replace(name, self.task(name).with_weight(weight))

    # -- the problem ------------------------------------------------------------------------
    @contract(q=_STATE, qd=_STATE, kin=_KIN)
    def active_contacts(self, q: np.ndarray, qd: np.ndarray, kin: dict | None = None) -> np.ndarray:
        """Which contact points are on the ground, a boolean mask (m,): gap ≤ ``contact_tol`` and not
        leaving it (normal speed ≤ ``contact_speed``; a heel that lifts while the foot rolls is not held)."""
        kin = self.kernel.kinematics(q) if kin is None else kin
        return self._contacts(kin, qd)[0]

    def _contacts(self, kin: dict, qd: np.ndarray) -> tuple:
        """(active mask, Jacobians (m, 2, nv), biases J̇q̇ (m, 2)) of every contact point."""
        k = self.kernel
        p = k.point_positions(kin, self.links, self.local)
        J = k.jacobians(kin, self.links, p)
        vn = (J @ qd) @ self.ground.normal
        active = (self.ground.gap(p) <= self.contact_tol) & (vn <= self.contact_speed)
        return active, J, k.bias_acceleration(kin, self.links, p, qd)

    def _mask(self, contacts, kin, qd) -> tuple:
        """(mask, J, J̇q̇): the contacts given (a mask or indices, checked by the contract) or the active ones."""
        active, J, Jb = self._contacts(kin, qd)
        if contacts is None:
            return active, J, Jb
        c = np.asarray(contacts)
        if c.dtype == bool:
            return c.copy(), J, Jb
        mask = np.zeros(self.links.size, bool)
        mask[c] = True
        return mask, J, Jb

    @contract(q=_STATE, qd=_STATE, kin=_KIN, contacts=_CONTACTS)
    def build(self, q, qd, kin: dict | None = None, contacts=None) -> dict:
        """The QP's matrices at (q, q̇): equalities (``Aeq``, ``beq``), cone rows (``G`` x ≤ 0), bounds
        (``lb``, ``ub``), task rows (``tasks``: (task, A, b) with error A x − b) and the pieces they came from."""
        k = self.kernel
        q, qd = np.asarray(q, dtype=float), np.asarray(qd, dtype=float)
        kin = k.kinematics(q) if kin is None else kin
        H, C, kin = k.dynamics(q, qd, kin)
        cf = centroidal(k, q, qd, kin)
        active, J, Jb = self._mask(contacts, kin, qd)
        if not np.isfinite(H.sum() + C.sum() + Jb.sum() + cf.bias.sum() + cf.L_bias):
            raise NonFiniteResult("QPController.build: the equations of motion at (q, q̇)",
                                  "the state's speeds or positions are too large")
        Jnt, bnt, keep = contact_rows(J[active], Jb[active], self.ground)
        nv, na, m2 = k.nv, self.na, Jnt.shape[0]
        N = nv + na + m2
        Aeq = np.zeros((nv + keep.size, N))
        Aeq[:nv, :nv], Aeq[:nv, nv:nv + na], Aeq[:nv, nv + na:] = H, -self.S.T, -Jnt.T
        Aeq[nv:, :nv] = Jnt[keep]
        beq = np.concatenate([-C, -bnt[keep]])
        mu = self.ground.mu
        G = friction_pyramid(m2 // 2, 2, mu, nv + na, N)        # fₜ − μ fₙ ≤ 0 and −fₜ − μ fₙ ≤ 0
        lb = np.concatenate([np.full(nv, -np.inf), -self.torque_limits, np.tile([self.min_normal, -np.inf], m2 // 2)])
        ub = np.concatenate([np.full(nv, np.inf), self.torque_limits, np.full(m2, np.inf)])
        if self.limit_index.size:
            i = self.limit_index
            lb[i], ub[i] = joint_limit_bounds(q, qd, i, self.limit_lo, self.limit_hi, self.limit_horizon)
        rows = []
        for t in self.tasks:
            J, bias, ydes = task_rows(t, k, kin, q, qd, cf, self.joints)
            A = np.zeros((J.shape[0], N))
            A[:, :nv] = J
            rows.append((t, A, ydes - bias))
        R = np.concatenate([np.ones(nv), np.full(na, self.f_scale ** -2), np.full(m2, self.f_scale ** -2)])
        return {"Aeq": Aeq, "beq": beq, "G": G, "lb": lb, "ub": ub, "tasks": rows, "R": R, "active": active,
                "H": H, "C": C, "Jnt": Jnt, "bnt": bnt, "keep": keep, "N": N}

    # -- solving ----------------------------------------------------------------------------
    @contract(q=_STATE, qd=_STATE, kin=_KIN, contacts=_CONTACTS, raise_on_failure=Flag())
    def solve(self, q, qd, kin: dict | None = None, contacts=None, *, raise_on_failure: bool = False) -> QPResult:
        """Solve the control QP at (q, q̇) (weighted or prioritized by ``mode``); see :class:`QPResult`."""
        t0 = time.perf_counter()
        P = self.build(q, qd, kin, contacts)
        t1 = time.perf_counter()
        N, R, statuses, iters = P["N"], P["R"], [], 0
        common = {"Aeq": P["Aeq"], "beq": P["beq"], "lb": P["lb"], "ub": P["ub"], "scale": R ** -0.5,
                  "backend": self.backend, "native": self.native, "eps_abs": self.eps_abs, "max_iter": self.max_iter,
                  **self.solver_options}
        live = [(t, A, b) for t, A, b in P["tasks"] if t.weight > 0]
        if self.mode == "weighted":
            Q = self.eps * np.diag(R)
            g = np.zeros(N)
            for t, A, b in live:
                Q += t.weight * A.T @ A
                g -= t.weight * A.T @ b
            x, st, it, kkt = solve_qp(Q, g, C=P["G"], l=np.full(P["G"].shape[0], -np.inf),
                                      u=np.zeros(P["G"].shape[0]), **common)
            statuses.append(st)
            iters += it
        else:
            x, statuses, iters, kkt = self._prioritized(P, live, common)
        result = self._judge(P, x, statuses, iters, kkt, t1 - t0, time.perf_counter() - t1)
        if raise_on_failure and not result.success:
            raise InfeasibleControl(result)
        return result

    def _prioritized(self, P: dict, live: list, common: dict) -> tuple[np.ndarray, list, int]:
        """One QP per priority level, then the regularization, each keeping the optima above (module docstring).

        A level whose solve does not come back feasible (ProxQP can misreport a feasible but badly
        conditioned level as infeasible) keeps the answer of the level above, which satisfies everything
        required so far; its status says so ("… kept level above").
        """
        G, zero, N = P["G"], np.zeros(P["G"].shape[0]), P["N"]
        Aeq, beq, x, statuses, iters, kkt = P["Aeq"], P["beq"], None, [], 0, 0.0
        levels = [[(t, A, b) for t, A, b in live if t.priority == lv] for lv in sorted({t.priority for t, _, _ in live})]
        for here in levels + [None]:
            if here is None:                                   # the last level: the regularization
                Q, g = np.diag(P["R"]), np.zeros(N)
            else:
                Q = sum(t.weight * A.T @ A for t, A, _ in here)
                g = -sum(t.weight * A.T @ b for t, A, b in here)
            xk, st, it, kk = solve_qp(Q, g, C=G, l=zero - np.inf, u=zero, **dict(common, Aeq=Aeq, beq=beq, x0=x))
            iters += it
            if x is not None and not self._feasible(P, xk, Aeq, beq) and self._feasible(P, x, Aeq, beq):
                statuses.append(f"{st} (kept level above)")
                kkt = np.inf                                   # this level's tasks were not optimized
                continue
            x, kkt = xk, max(kkt, kk)
            statuses.append(st)
            if not np.all(np.isfinite(x)):
                break
            if here is not None:                               # keep this optimum (rows Aeq does not fix yet)
                Aeq, beq = keep_level(Aeq, beq, np.vstack([A for _, A, _ in here]), x)
        return x, statuses, iters, kkt

    def _feasible(self, P: dict, x, Aeq, beq) -> bool:
        """x satisfies every constraint group to the tolerances :meth:`_judge` holds it to, and the optima
        kept from the levels above (rows of ``Aeq`` past the problem's own) to ``feasibility_tol`` (force scale)."""
        if not np.all(np.isfinite(x)):
            return False
        res, tol = self._residuals(P, x)
        n0 = P["Aeq"].shape[0]
        kept = self.feasibility_tol * (self.f_scale + np.abs(beq).max(initial=0.0))
        return all(res[g] <= tol[g] for g in res) and np.abs(Aeq[n0:] @ x - beq[n0:]).max(initial=0.0) <= kept

    def _residuals(self, P: dict, x) -> tuple[dict, dict]:
        """(violation, tolerance) per constraint group of a finite x: the equations of motion, the held contact
        points, the cones and the limits (torques and the joint limits' bounds on q̈)."""
        nv, na = self.kernel.nv, self.na
        qdd, tau_a = x[:nv], x[nv:nv + na]
        F = x[nv + na:].reshape(-1, P.get("dirs", 2))        # per point (fₙ, fₜ…): 2 entries planar, 3 in 3-D
        fn, ft = F[:, 0], np.abs(F[:, 1:]).max(axis=1, initial=0.0)
        res = {"dynamics": float(np.abs(P["Aeq"][:nv] @ x - P["beq"][:nv]).max()),
               "contact": float(np.abs(P["Aeq"][nv:] @ x - P["beq"][nv:]).max(initial=0.0)),
               "cone": float(np.maximum(np.abs(ft) - self.ground.mu * fn, self.min_normal - fn).max(initial=0.0)),
               "limits": float(max((np.abs(tau_a) - self.torque_limits).max(initial=0.0),
                                   np.maximum(P["lb"][:nv] - qdd, qdd - P["ub"][:nv]).max(initial=0.0)))}
        tol = {"dynamics": self.feasibility_tol * (self.f_scale + np.abs(P["C"]).max()),
               "contact": self.feasibility_tol * (1.0 + np.abs(P["bnt"]).max(initial=0.0)),
               "cone": self.feasibility_tol * self.f_scale, "limits": self.feasibility_tol * self.f_scale}
        return res, tol

    @contract(q=_STATE, qd=_STATE, kin=_KIN)
    def torques(self, q, qd, kin: dict | None = None) -> np.ndarray:
        """τ (nv,) of one control step; :class:`InfeasibleControl` when the QP has no feasible answer."""
        return self.solve(q, qd, kin, raise_on_failure=True).tau

    def _judge(self, P, x, statuses, iters, kkt, t_build, t_solve) -> QPResult:
        """The answer checked against every constraint and task, with a status and a message."""
        nv, na = self.kernel.nv, self.na
        finite = np.all(np.isfinite(x))
        x = np.where(np.isfinite(x), x, 0.0)
        qdd, tau_a, F = x[:nv], x[nv:nv + na], x[nv + na:].reshape(-1, P.get("dirs", 2))
        res, tol = self._residuals(P, x)
        with np.errstate(over="ignore"):                  # targets near MAX_DATUM: an error of inf, said so
            errors = {t.name: float(np.linalg.norm(A @ x - b)) for t, A, b in P["tasks"]}
        bad = [g for g in res if not res[g] <= tol[g]]
        tau = np.zeros(nv)
        tau[self.actuated] = tau_a
        forces = np.zeros((self.links.size, F.shape[1]))
        forces[P["active"]] = F
        if bad or not finite:
            status = "infeasible"
            what = "; ".join(f"{g} violated by {res[g]:.3g} (tolerance {tol[g]:.1e})" for g in bad) or "no finite answer"
            msg = (f"the control QP's constraints are inconsistent or the solver failed ({', '.join(statuses)}): "
                   f"{what}; relax the limits or targets, or check the contacts")
        elif not kkt <= KKT_TOL:
            status = "unconverged"
            msg = (f"the constraints hold but the solver's answer is not certified optimal ({', '.join(statuses)}): "
                   f"KKT residual {kkt:.1e} > {KKT_TOL:.0e}; the torques are usable and the task errors are as "
                   f"reported, but the least-squares optimum may be better (a more accurate backend, or more max_iter)")
        else:
            missed = {t.name: errors[t.name] for t, A, b in P["tasks"]
                      if t.weight > 0 and errors[t.name] > self.task_tol * (1.0 + np.linalg.norm(b))}
            status = "compromise" if missed else "met"
            msg = ("every task met" if not missed else "least-squares compromise: " + ", ".join(
                f"task {n!r} misses its desired acceleration by {e:.3g}" for n, e in missed.items()))
        return QPResult(status=status, message=msg, tau=tau, qdd=qdd.copy(), forces=forces, active=P["active"],
                        task_errors=errors, residuals=res, tolerances=tol, solver_status=statuses,
                        iterations=int(iters), build_time=t_build, solve_time=t_solve, kkt=float(kkt))
