"""One contact step of a floating tree in the world frame: the 3-D biped's lean step (chapter 08).

The readable step is :class:`pbanim.articulated.contact.ArticulatedContact` (Stewart & Trinkle):

    u* = q̇ + h H⁻¹ (τ − C(q, q̇)),    u⁺ = u* + H⁻¹ Jᵀ z,    z the box-friction LCP's solution,
    q⁺ = q + h q̇(q, u⁺)  (the pelvis's quaternion renormalized).

This module computes the same step with three changes of *how*, none of *what*:

1. the free acceleration H⁻¹(τ − C) comes from the world-frame ABA on floats
   (:func:`pbanim.articulated.fast.aba_fast`) instead of CRBA + RNEA;
2. H and the point Jacobians come from one set of world-frame joint columns Sᵂ (6 × nv): a revolute
   joint with world axis a through the point o has the column (a, o × a), the floating pelvis with
   orientation R at p the six columns [[R, 0], [p̂ R, R]] (body-frame q̇); the centre of mass c of link i
   moves with J_c,i = (v + ω × c) over the columns of its ancestors, its angular velocity with J_ω,i = ω
   over the same columns, and H = Σᵢ mᵢ J_c,iᵀ J_c,i + J_ω,iᵀ Īᵂᵢ J_ω,i (the kinetic energy's Hessian);
3. the LCP is solved by the hand-off (:func:`pbanim.lcp.box.box_friction_handoff`, ORACLES I12): the
   active set from each point's state at the last step (contact persistence), PGS in chunks only when that
   guess does not certify. Its answer is the LCP's (A + cfm·max diag A·𝟙 is positive definite: one
   solution), where PGS at tol (this step's law before) stops on a sole with four loaded corners well away
   from it (A nearly singular there: the impulses' spread over the corners off by ~20 %, their sum on the
   foot at the residual's level): the walk's numbers moved by little (20 s at h = 2 ms: 65 strikes and
   0.8869 m/s over the last 5 s both ways).

Stable PD (Tan, Liu & Turk 2011; :mod:`.pd`): the controller gives τ = τ₀ − K q̇⁺ with K = diag(k) ≥ 0; the
damper at the next velocity is the mass matrix H + hK in both solves (with k = 0 the readable step):

    u* = q̇ + h (H + hK)⁻¹ (τ₀ − K q̇ − C),     u⁺ = u* + (H + hK)⁻¹ Jᵀ z,   A = J (H + hK)⁻¹ Jᵀ.

The contact rules are the readable step's: a point is near when its gap g < margin + h |n·J u*|; the
normal row's bias max(g, 0)/h + erp·min(g, 0)/h; constraint-force mixing cfm · max diag A.
``tests/test_biped3d.py`` checks H and J against :func:`~pbanim.articulated.dynamics.crba` and
:func:`~pbanim.articulated.contact.point_jacobians` to roundoff and one step against the readable one.
"""

from __future__ import annotations

import numpy as np

from ..articulated.contact import Plane
from ..articulated.fast import aba_fast
from ..articulated.system import ArticulatedSystem
from ..articulated.tree import ROTATING
from ..articulated.specs import Tree
from ..contracts import Anything, Array, Flag, Int, Opt, Real, contract, unchecked
from ..errors import InvalidInput
from ..geometry import skew, tangent_basis
from ..lcp.box import box_friction_handoff
from ..lcp.handoff_lean import handoff_floats as _handoff_floats
from ..rigid.quat import quat_to_matrix
from . import biped3d_lean as _lean

__all__ = ["WorldStep"]

_aba = unchecked(aba_fast)


def _rot(axis, angle: float) -> np.ndarray:
    """The lean twin of :func:`pbanim.articulated.spatial.rotation` for one angle (Rodrigues written out:
    one array built, where the readable form builds [a]× and its square; tests/test_biped3d.py compares them)."""
    x, y, z = axis
    c, s = np.cos(angle), np.sin(angle)
    t = 1.0 - c
    return np.array([[t * x * x + c, t * x * y - s * z, t * x * z + s * y],
                     [t * x * y + s * z, t * y * y + c, t * y * z - s * x],
                     [t * x * z - s * y, t * y * z + s * x, t * z * z + c]])


class WorldStep:
    """The lean contact step of a tree whose root is floating and whose other joints are revolute or fixed
    (the 3-D biped): ``step(q, q̇, h, τ₀, k) -> (q⁺, u⁺)``; ``kinematics(q)`` gives the world frames.

    ``contact_points``: (link, point in the link frame) pairs; the ground is the plane z = ``offset`` (or
    ``terrain`` with ``gap_normal``); friction μ; erp, margin, cfm, max_iter, tol as the readable step's.
    ``last`` holds the impulses (3 per near point: normal, two tangents), the near points and the residual.
    ``lean`` (default): the same step through :mod:`.biped3d_lean` (fewer, batched calls; equal to roundoff);
    ``lean=False``: the methods below as written.
    """

    @contract(tree=Tree(), contact_points=Anything("(link, point) pairs, checked in the body"),
              friction=Real(ge=0), terrain=Anything("any object with gap_normal(P)"), erp=Real(ge=0, le=1),
              margin=Real(ge=0), cfm=Real(ge=0, le=1e-2), max_iter=Int(ge=1, le=100_000), tol=Real(gt=0, lt=1),
              lean=Flag())
    def __init__(self, tree, contact_points, *, friction: float = 0.9, terrain=None, erp: float = 0.2,
                 margin: float = 0.02, cfm: float = 1e-6, max_iter: int = 300, tol: float = 1e-6,
                 lean: bool = True) -> None:
        self.tree = tree
        kinds = [j.kind for j in tree.joints]
        if kinds[0] != "floating" or any(k not in ROTATING + ("fixed",) for k in kinds[1:]):
            raise InvalidInput("WorldStep: the root must be floating and every other joint revolute or fixed")
        pts = list(contact_points)
        if not pts or not all(isinstance(c, (tuple, list)) and len(c) == 2 and 0 <= int(c[0]) < tree.n for c in pts):
            raise InvalidInput(f"WorldStep: contact_points must be (link index, point) pairs, got {pts!r:.200}")
        self.links = np.array([int(lk) for lk, _ in pts])
        self.points = np.array([np.asarray(p, dtype=float) for _, p in pts])
        if self.points.shape != (len(pts), 3) or not np.all(np.isfinite(self.points)):
            raise InvalidInput(f"WorldStep: contact points must be finite 3-vectors, got shape {self.points.shape}")
        self.terrain = Plane((0.0, 0.0, 1.0), 0.0) if terrain is None else terrain
        self.mu, self.erp, self.margin, self.cfm = float(friction), float(erp), float(margin), float(cfm)
        self.max_iter, self.tol = int(max_iter), float(tol)
        A = tree.arrays()
        self.qi = [s.start for s in A["qi"]]
        self.vi = [v.start for v in A["vi"]]
        n, nv = tree.n, tree.nv
        self.mask = np.zeros((n, nv), dtype=bool)              # columns of link i's ancestors (and its own)
        for i in range(n):
            j = i
            while j >= 0:
                self.mask[i, A["vi"][j]] = True
                j = tree.parent[j]
        self.mass = np.array([lk.mass for lk in tree.links])
        self.com = np.array([lk.com for lk in tree.links])
        self.inertia = np.array([lk.inertia for lk in tree.links])
        self.last, self._states = None, {}
        self._qdot = unchecked(ArticulatedSystem(tree).qdot)
        self._aba = _aba
        self.lean = bool(lean)
        self.clock = None                                       # the lean step's split, when a dict (bench)
        self._joint_link = np.zeros(nv, dtype=int)              # the link each velocity coordinate moves
        for i in range(n):
            self._joint_link[A["vi"][i]] = i
        self._plan = _lean.LeanPlan(self)

    @contract(q=Array(("self.tree.nq",)))
    def kinematics(self, q) -> dict:
        """World orientation R (n, 3, 3), joint origins o (n, 3), centres of mass c (n, 3) and joint columns
        Sᵂ (6, nv): angular rows first, then the velocity of the point at the world origin."""
        if self.lean:
            return _lean.kinematics(self, q)
        tree = self.tree
        n, nv = tree.n, tree.nv
        R, o = np.zeros((n, 3, 3)), np.zeros((n, 3))
        S = np.zeros((6, nv))
        nrm = np.linalg.norm(q[:4])
        if not nrm > 1e-9:
            raise InvalidInput(f"q[:4] must be the pelvis's (non-zero) quaternion, got {q[:4]}")
        R0 = quat_to_matrix(q[:4] / nrm)
        R[0], o[0] = R0, q[4:7]
        S[:3, :3], S[3:, :3], S[3:, 3:6] = R0, skew(q[4:7]) @ R0, R0
        for i in range(1, n):
            j, lam = tree.joints[i], tree.parent[i]
            Rl = R[lam] @ j.R
            o[i] = o[lam] + R[lam] @ j.p
            if j.kind == "fixed":
                R[i] = Rl
                continue
            a = Rl @ j.axis
            R[i] = Rl @ _rot(j.axis, q[self.qi[i]])
            v = self.vi[i]
            S[:3, v], S[3:, v] = a, np.cross(o[i], a)
        c = o + np.einsum("nij,nj->ni", R, self.com)
        return {"R": R, "o": o, "c": c, "S": S}

    @contract(kin=Anything("the dict of kinematics(q)"), links=Array(("m",), ge=0),
              points=Array(("m", 3)))
    def point_jacobians(self, kin, links, points) -> tuple[np.ndarray, np.ndarray]:
        """World positions (m, 3) and Jacobians (m, 3, nv) of link-frame ``points`` on ``links``."""
        if self.lean:
            return _lean.point_jacobians(self, kin, links, points)
        links = np.asarray(links).astype(int)
        P = kin["o"][links] + np.einsum("mij,mj->mi", kin["R"][links], points)
        S = kin["S"]
        J = S[None, 3:, :] + np.cross(S[:3].T[None, :, :], P[:, None, :]).transpose(0, 2, 1)
        return P, J * self.mask[links][:, None, :]

    @contract(kin=Anything("the dict of kinematics(q)"))
    def mass_matrix(self, kin) -> np.ndarray:
        """H = Σᵢ mᵢ J_c,iᵀ J_c,i + J_ω,iᵀ Īᵂᵢ J_ω,i."""
        if self.lean:
            return _lean.mass_matrix(self, kin)
        n = self.tree.n
        _, Jc = self.point_jacobians(kin, np.arange(n), np.einsum("nji,nj->ni", kin["R"], kin["c"] - kin["o"]))
        Jw = kin["S"][None, :3, :] * self.mask[:, None, :]
        Iw = kin["R"] @ self.inertia @ kin["R"].transpose(0, 2, 1)
        return np.einsum("n,nki,nkj->ij", self.mass, Jc, Jc) + np.einsum("nki,nkl,nlj->ij", Jw, Iw, Jw)

    @contract(q=Array(("self.tree.nq",)), qd=Array(("self.tree.nv",)), h=Real(gt=0, le=0.1),
              tau0=Array(("self.tree.nv",)), k=Opt(Array(("self.tree.nv",), ge=0)),
              kin=Anything("the dict of kinematics(q), or None"))
    def step(self, q, qd, h: float, tau0, k=None, kin=None):
        """(q⁺, u⁺) after one step of length h under τ = τ₀ − k ⊙ q̇⁺ (k None or 0: explicit τ₀)."""
        if self.lean:
            return _lean.step(self, q, qd, h, tau0, k, kin)
        kin = self.kinematics(q) if kin is None else kin
        H = self.mass_matrix(kin)
        K = np.zeros(qd.size) if k is None else np.asarray(k, dtype=float)
        acc = _aba(self.tree, q, qd, tau0 - K * qd)                        # H⁻¹ (τ₀ − K q̇ − C)
        Meff = H + h * np.diag(K)
        P, Jp = self.point_jacobians(kin, self.links, self.points)
        u = qd + h * (np.linalg.solve(Meff, H @ acc) if K.any() else acc)
        gap, nrm = self.terrain.gap_normal(P)
        speed = np.einsum("kij,j,ki->k", Jp, u, nrm)
        near = np.flatnonzero(gap < self.margin + h * np.abs(speed))
        self.last = None
        if near.size:
            nn, JJ, g = nrm[near], Jp[near], gap[near]
            t1, t2 = tangent_basis(nn)
            rows = np.stack([np.einsum("ki,kij->kj", nn, JJ), np.einsum("ki,kij->kj", t1, JJ),
                             np.einsum("ki,kij->kj", t2, JJ)], axis=1).reshape(3 * near.size, -1)
            MinvJt = np.linalg.solve(Meff, rows.T)
            A = rows @ MinvJt
            u = self._impulses(A, rows, MinvJt, u, g, near, h)
        else:
            self._states = {}
        return self.integrate(q, u, h), u

    def _impulses(self, A, rows, MinvJt, u, g, near, h: float):
        """The contact law, for both paths: u⁺ = u* + H⁻¹Jᵀz with z the box-friction LCP's solution on
        A + cfm·max diag A·𝟙 and the normal rows' bias max(g, 0)/h + erp·min(g, 0)/h, by the hand-off
        (:func:`pbanim.lcp.box.box_friction_handoff`: the active set from each near point's state at the last
        step — on where b_f < 0 and sticking for a point that was not near — then PGS in chunks, the active set
        retried from PGS's states): the LCP solved exactly, where PGS at tol stops far from the answer on a
        sole whose four corners carry load (A nearly singular there). The lean path calls its float first
        round (:mod:`pbanim.lcp.handoff_lean`, the same bits)."""
        A.flat[::A.shape[0] + 1] += self.cfm * max(float(A.diagonal().max()), 1e-300)      # A + cfm·max diag A·𝟙
        b = rows @ u
        erp = self.erp
        b[0::3] += [max(x, 0.0) / h + erp * min(x, 0.0) / h for x in g.tolist()]      # the normal rows' bias
        nl, last = near.tolist(), self._states
        bf = b[0::3].tolist()
        guess = [last.get(c) or (int(bf[m] < 0.0), 0, 0) for m, c in enumerate(nl)]
        if self.lean:
            z, res, sweeps, s, ok = _handoff_floats(A, b, self.mu, guess, max_iter=self.max_iter, tol=self.tol)
        else:
            z, res, sweeps, s, ok = box_friction_handoff(A, b, np.full(len(nl), self.mu), state=np.array(guess),
                                                         max_iter=self.max_iter, tol=self.tol)
            s = [tuple(x) for x in s.tolist()]
        self._states = dict(zip(nl, s))
        self.last = {"impulses": z, "contacts": near, "residual": res, "sweeps": sweeps, "certified": ok}
        return u + MinvJt @ z

    @contract(q=Array(("self.tree.nq",)), u=Array(("self.tree.nv",)), h=Real(gt=0))
    def integrate(self, q, u, h: float) -> np.ndarray:
        """q⁺ = q + h q̇(q, u) (:meth:`ArticulatedSystem.qdot`), the pelvis's quaternion renormalized."""
        q1 = q + h * self._qdot(q, u)
        q1[:4] /= np.linalg.norm(q1[:4])
        return q1
