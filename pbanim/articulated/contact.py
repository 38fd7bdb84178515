"""Contact and friction for articulated trees: velocity-level time stepping (chapter 08).

Points fixed on links touch the ground (a plane n·x = offset, or any terrain that gives a gap and a
normal per point, such as :class:`Staircase`), and spheres fixed on links touch the spheres of other links
(self-collision; a link and its parent never collide, they meet at their joint). A box on a link is its
eight corners as points. Each step (Stewart & Trinkle 1996, as the
rigid-body :class:`~pbanim.contact.TimeStepping` of chapter 07, but with the tree's coupled mass matrix):

    u* = q̇ + h H(q)⁻¹ (τ − b q̇ − C(q, q̇))                    (free velocity; C from RNEA: gravity, Coriolis)
    u⁺ = u* + H⁻¹ (J_nᵀ f + J_Dᵀ β)                           (normal impulses f, friction impulses β ≥ 0)
    0 ≤ f ⊥ J_n u⁺ + max(g, 0)/h + erp·min(g, 0)/h ≥ 0        (no crossing within the step; g the gap)
    |tₖ| ≤ μ f, J_tₖ u⁺ = 0 while |tₖ| < μ f                  (box friction along two tangents t₁, t₂)
    q⁺ = q + h q̇(q, u⁺)                                       (floating quaternions renormalized)

Joint position limits (lower ≤ q_i ≤ upper, :mod:`.tree`) are stops: a joint near a limit is one more
contact, without friction, whose row is ±e_i on q̇ and whose gap is q_i − lower or upper − q_i (the same
complementarity, so a stop neither pulls nor lets the joint pass). A sphere pair (i, j) with centres cᵢ, cⱼ, radii rᵢ, rⱼ has gap |cᵢ − cⱼ| − rᵢ − rⱼ, normal n = (cᵢ − cⱼ)/|cᵢ − cⱼ|
and the relative Jacobian J(pᵢ) − J(pⱼ) at the surface points pᵢ = cᵢ − rᵢn, pⱼ = cⱼ + rⱼn: the same rows as a
ground contact, so the same solve. The point Jacobian J_p (3 × nv) of a point p on link i has, for every
joint j on the path from the root to i, the columns ω_j × p + v_j of the joint's motion subspace expressed in world Plücker coordinates
(⁰X_j S_j = (ω_j, v_j), v_j the velocity of the point at the world origin). The impulses come from the
core's projected Gauss–Seidel with box friction (:func:`pbanim.lcp.pgs_box_friction`, capped sweeps, its
residual kept in ``last``): Lemke on the Stewart–Trinkle form stops on secondary rays when a ragdoll's
many contact points are redundant, where PGS degrades gracefully. ``solver="active_set"`` solves the same
problem by the active set (one linear solve per guess of which contacts push, stick or slide), its first
guess each contact's state at the previous step (contact persistence, keyed by the contact point, sphere pair
or joint stop), PGS sweeps finding the guess when the exchanges cycle (:func:`pbanim.lcp.box.box_friction_handoff`); an
answer not certified to ``tol`` within ``max_iter`` sweeps is counted in ``fallbacks``. With the constraint-force mixing, A is positive definite
and the problem has one solution, so the two solvers answer the same impulses to their tolerance — where
PGS stops at its sweep cap on a ragdoll lying on many redundant points, the active set still certifies
(ORACLES I12).
"""

from __future__ import annotations

import time

import numpy as np

from ..errors import InvalidInput, check_count, check_number
from ..geometry import cross, tangent_basis
from ..lcp import pgs_box_friction
from ..lcp.box import box_friction_handoff
from ..ode.driver import MAX_STEPS, check_finite, drive, step_grid
from ..results import SimResult
from .dynamics import _mass_bias_poses, bias_forces, crba, world_poses
from .spatial import plucker_inverse
from .system import ArticulatedSystem

__all__ = ["ArticulatedContact", "point_jacobians", "Plane", "Staircase"]

SOLVERS = ("pgs", "active_set")


class Plane:
    """The ground n·x = offset (n normalized): gap n·p − offset, normal n everywhere."""

    def __init__(self, normal=(0.0, 0.0, 1.0), offset: float = 0.0) -> None:
        n = np.asarray(normal, dtype=float)
        if n.shape != (3,) or not np.all(np.isfinite(n)) or not np.linalg.norm(n) > 0:
            raise InvalidInput(f"normal must be a non-zero finite 3-vector, got {normal!r}")
        self.normal = n / np.linalg.norm(n)
        self.offset = check_number("offset", offset)

    def gap_normal(self, P: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        return P @ self.normal - self.offset, np.broadcast_to(self.normal, P.shape)


class Staircase:
    """Stairs going down along +x (z up): height 0 for x < ``start``, then treads ``run`` long, each
    ``rise`` lower, ``steps`` of them, then flat. A point touches the tread below it (normal +z, gap
    z − height(x)). Without ``risers`` the risers are not modelled: a point moving back into one is under
    its tread by up to a rise and is pushed up out of it. With ``risers``, a point under its tread (gap < 0)
    that is nearer to the riser ending that tread (the face x = edge going down to the next tread) is pushed
    out of that face, the nearest one: normal +x, gap x − edge."""

    def __init__(self, rise: float = 0.2, run: float = 0.4, steps: int = 5, start: float = 0.0,
                 risers: bool = False) -> None:
        self.rise = check_number("rise", rise, low=0.0)
        self.run = check_number("run", run, low=0.0, low_open=True)
        self.steps = check_count("steps", steps, minimum=0, maximum=10_000)
        self.start = check_number("start", start)
        if not isinstance(risers, bool):
            raise InvalidInput(f"risers must be True or False, got {risers!r}")
        self.risers = risers

    def _tread(self, x) -> np.ndarray:
        """The number k of the tread below x (0 before the stairs, ``steps`` after them): height −rise·k."""
        return np.clip(np.floor((np.asarray(x, dtype=float) - self.start) / self.run) + 1, 0, self.steps)

    def height(self, x) -> np.ndarray:
        return -self.rise * self._tread(x)

    def gap_normal(self, P: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        x = P[:, 0]
        k = self._tread(x)
        gap = P[:, 2] + self.rise * k
        normal = np.zeros(P.shape)
        normal[:, 2] = 1.0
        riser = self.start + self.run * k - x                   # distance to the riser at the tread's end
        side = (gap < 0) & (k < self.steps) & (riser < -gap) & (P[:, 2] > -self.rise * (k + 1)) & self.risers
        if side.any():
            gap[side], normal[side] = -riser[side], (1.0, 0.0, 0.0)
        return gap, normal


def point_jacobians(tree, q: np.ndarray, links, points) -> tuple[np.ndarray, np.ndarray]:
    """World positions (m, 3) and point Jacobians (m, 3, nv) of link-frame ``points`` on ``links``.

    The motion subspaces in world Plücker coordinates (ω_j, v_j) = ⁰X_j S_j are formed once per link, and the
    columns ω_j × p + v_j of every point at once, kept on the path from the root to the point's link (the
    same products as a walk up the path, point by point, so the same numbers)."""
    return _point_jacobians(tree, world_poses(tree, q), links, points)


def _point_jacobians(tree, poses, links, points) -> tuple[np.ndarray, np.ndarray]:
    """:func:`point_jacobians` from the tree's ``poses`` = :func:`.dynamics.world_poses` (tree, q)."""
    A = tree.arrays()
    _, X0, origins = poses
    links = np.asarray(links, dtype=int).reshape(-1)
    m, nv = links.size, tree.nv
    P = np.zeros((m, 3))
    for k, (i, r) in enumerate(zip(links.tolist(), points)):
        P[k] = origins[i] + X0[i][:3, :3].T @ r
    Sw = np.zeros((6, nv))                                          # ⁰X_j S_j, the columns of joint j
    for j, (X, S, vi) in enumerate(zip(X0, A["S"], A["vi"])):
        if S.shape[1]:
            Sw[:, vi] = plucker_inverse(X) @ S
    cols = cross(Sw[:3].T[None, :, :], P[:, None, :]) + Sw[3:].T[None, :, :]      # (m, nv, 3)
    J = np.where(A["path"][links][:, :, None], cols, 0.0).transpose(0, 2, 1).copy()
    return P, J


class ArticulatedContact:
    """Velocity-level contact stepping of an :class:`ArticulatedSystem` on a ground plane.

    ``contact_points``: list of (link index, point in the link frame). ``normal``, ``offset``: the plane
    n·x = offset (default: up against gravity through the origin), or ``terrain``: any object with
    ``gap_normal(P) -> (gaps (m,), unit normals (m, 3))`` such as :class:`Staircase`. ``friction`` μ ≥ 0.
    """

    def __init__(self, system: ArticulatedSystem, contact_points, *, friction: float = 0.5,
                 normal=None, offset: float = 0.0, terrain=None, erp: float = 0.2, margin: float = 0.02,
                 cfm: float = 1e-6, max_iter: int = 300, tol: float = 1e-8, spheres=(),
                 solver: str = "pgs") -> None:
        if not isinstance(system, ArticulatedSystem):
            raise InvalidInput(f"system must be an ArticulatedSystem, got {type(system).__name__}")
        self.system, self.tree = system, system.tree
        pts = list(contact_points)
        if not pts:
            raise InvalidInput("contact_points must list at least one (link, point) pair")
        self.links = [check_count("contact link", lk, minimum=0, maximum=self.tree.n - 1) for lk, _ in pts]
        self.points = np.array([np.asarray(p, dtype=float) for _, p in pts])
        if self.points.shape != (len(pts), 3) or not np.all(np.isfinite(self.points)):
            raise InvalidInput(f"contact points must be finite 3-vectors, got shape {self.points.shape}")
        g = self.tree.gravity
        n = -g / np.linalg.norm(g) if normal is None and np.any(g) else np.asarray(
            normal if normal is not None else (0.0, 0.0, 1.0), dtype=float)
        if n.shape != (3,) or not np.linalg.norm(n) > 0:
            raise InvalidInput(f"normal must be a non-zero 3-vector, got {normal!r}")
        self.normal = n / np.linalg.norm(n)
        self.offset = check_number("offset", offset)
        if terrain is not None and not callable(getattr(terrain, "gap_normal", None)):
            raise InvalidInput(f"terrain must have a gap_normal(P) method, got {type(terrain).__name__}")
        self.terrain = Plane(self.normal, self.offset) if terrain is None else terrain
        self.mu = check_number("friction", friction, low=0.0)
        self._set_spheres(list(spheres))
        self.erp = check_number("erp", erp, low=0.0, high=1.0)
        self.margin = check_number("margin", margin, low=0.0)
        self.cfm = check_number("cfm", cfm, low=0.0, high=1e-2)
        self.max_iter = check_count("max_iter", max_iter, maximum=100_000)
        self.tol = check_number("tol", tol, low=0.0, low_open=True, high=1.0)
        self.limited = self.tree.limited()          # joint stops: (q index, q̇ index, lower, upper)
        if solver not in SOLVERS:
            raise InvalidInput(f"solver must be one of {SOLVERS}, got {solver!r}")
        self.solver = solver
        self._persist: dict = {}                     # contact key -> its [on, stick/slide, stick/slide] state
        self.fallbacks = 0                           # active-set steps handed to PGS
        self.last = None
        # H, C and the points' Jacobians from one evaluation of the transforms ⁱX_λ(q) per step (each of CRBA,
        # RNEA and the world poses computes the same ones): the same steps bit for bit; False: the readable
        # crba, bias_forces and point_jacobians, each with its own
        self.lean_path = True

    def _set_spheres(self, spheres: list) -> None:
        """Spheres (link, centre in the link frame, radius) that collide with the spheres of other links,
        except across a joint (a link and its parent always touch there)."""
        links, centres, radii = [], [], []
        for k, sp in enumerate(spheres):
            if not (isinstance(sp, (tuple, list)) and len(sp) == 3):
                raise InvalidInput(f"spheres[{k}] must be (link, centre, radius), got {sp!r}")
            links.append(check_count(f"spheres[{k}] link", sp[0], minimum=0, maximum=self.tree.n - 1))
            c = np.asarray(sp[1], dtype=float)
            if c.shape != (3,) or not np.all(np.isfinite(c)):
                raise InvalidInput(f"spheres[{k}] centre must be a finite 3-vector, got {sp[1]!r}")
            centres.append(c)
            radii.append(check_number(f"spheres[{k}] radius", sp[2], low=0.0, low_open=True))
        self.sphere_links, self.sphere_centres, self.radii = links, np.array(centres).reshape(-1, 3), np.array(radii)
        par = self.tree.parent
        self.pairs = np.array([(a, b) for a in range(len(links)) for b in range(a + 1, len(links))
                               if links[a] != links[b] and par[links[a]] != links[b] and par[links[b]] != links[a]],
                              dtype=int).reshape(-1, 2)

    def step(self, t: float, y: np.ndarray, h: float) -> np.ndarray:
        s, tree = self.system, self.tree
        q, qd = y[:s.nq], y[s.nq:]
        if self.lean_path:
            H, C, poses = _mass_bias_poses(tree, q, qd)
        else:
            H, C, poses = crba(tree, q), None, None
        tau = s._tau(t, q, qd) - tree.arrays()["damping"] * qd
        u = qd + h * np.linalg.solve(H, tau - (bias_forces(tree, q, qd) if C is None else C))
        P, Jp = (point_jacobians(tree, q, self.links, self.points) if poses is None
                 else _point_jacobians(tree, poses, self.links, self.points))
        gap, nrm = self.terrain.gap_normal(P)
        speed = np.einsum("kij,j,ki->k", Jp, u, nrm)                  # normal speed of each point at u*
        near = np.flatnonzero(gap < self.margin + h * np.abs(speed))
        blocks = [(nrm[near], Jp[near], gap[near], near)] if near.size else []
        if self.pairs.size:
            blocks += self._sphere_blocks(q, u, h)
        rows, g, mu, keys = [], [], [], []
        if blocks:
            nn = np.concatenate([b[0] for b in blocks])
            JJ = np.concatenate([b[1] for b in blocks])
            g.append(np.concatenate([b[2] for b in blocks]))
            keys.append(np.concatenate([b[3] for b in blocks]))
            t1, t2 = tangent_basis(nn)
            rows.append(np.stack([np.einsum("ki,kij->kj", nn, JJ), np.einsum("ki,kij->kj", t1, JJ),
                                  np.einsum("ki,kij->kj", t2, JJ)], axis=1).reshape(3 * len(nn), -1))   # [n, t₁, t₂]·J
            mu.append(np.full(len(nn), self.mu))
        stops = self._stop_rows(q, u, h)
        if stops is not None:
            rows.append(stops[0]), g.append(stops[1]), mu.append(np.zeros(len(stops[1]))), keys.append(stops[2])
        if rows:
            rows, g, mu = np.concatenate(rows), np.concatenate(g), np.concatenate(mu)
            m = g.size
            HinvJt = np.linalg.solve(H, rows.T)
            A = rows @ HinvJt
            # a touch of constraint-force mixing keeps A positive definite with redundant contacts
            A += self.cfm * max(float(np.max(np.diag(A))), 1e-300) * np.eye(3 * m)
            bias = rows @ u
            bias[0::3] += np.maximum(g, 0) / h + self.erp * np.minimum(g, 0) / h
            if self.solver == "active_set":
                z, residual, sweeps = self._active_set(A, bias, mu, np.concatenate(keys))
            else:
                z, residual, sweeps = pgs_box_friction(A, bias, mu, max_iter=self.max_iter, tol=self.tol)
            u = u + HinvJt @ z
            n_stop = 0 if stops is None else len(stops[1])
            self.last = {"impulses": z, "residual": residual, "sweeps": sweeps, "contacts": near,
                         "sphere_contacts": m - near.size - n_stop, "joint_stops": n_stop}
        else:
            self.last = None
        q1 = q + h * s.qdot(q, u)
        y1 = np.concatenate([q1, u])
        return s._renormalize(y1)

    def _stop_rows(self, q, u, h):
        """Joint stops as contacts without friction: for a joint at q near its limit lower (upper) the row
        +e_i (−e_i) on q̇ with gap q − lower (upper − q), rows [e, 0, 0], and the stops' keys; None when no
        stop is near."""
        found, keys = [], []
        base = len(self.links) + len(self.pairs)                          # after the points and sphere pairs
        for k, (qi, vi, lo, hi) in enumerate(self.limited):
            for side, (gap, sign) in enumerate(((q[qi] - lo, 1.0), (hi - q[qi], -1.0))):
                if gap < self.margin + h * max(-sign * u[vi], 0.0):       # ±inf limits never pass
                    found.append((vi, sign, gap)), keys.append(base + 2 * k + side)
        if not found:
            return None
        rows = np.zeros((3 * len(found), self.tree.nv))
        for k, (vi, sign, _) in enumerate(found):
            rows[3 * k, vi] = sign
        return rows, np.array([f[2] for f in found]), np.array(keys, dtype=int)

    def simulate(self, t_end: float, h: float, *, record_every: int = 1, max_steps: int = MAX_STEPS) -> SimResult:
        """Fixed steps through the one driver; diagnostics: energy, lowest contact-point gap."""
        grid = step_grid(0.0, t_end, h, max_steps=max_steps, record_every=record_every)
        y = self.system.state()
        check_finite(y, 0.0, 0, "initial state")
        ts, ys, es, gaps = [0.0], [y.copy()], [self.system.energy(y)], [self._min_gap(y)]

        def record(t1, y1):
            ts.append(t1), ys.append(y1.copy()), es.append(self.system.energy(y1)), gaps.append(self._min_gap(y1))

        start = time.perf_counter()
        drive(self.step, grid, y, record=record, record_every=record_every)
        return SimResult(t=np.array(ts), y=np.array(ys).T, wall_time=time.perf_counter() - start,
                         method="velocity-level (articulated)", nsteps=grid.n_steps,
                         diagnostics={"energy": np.array(es), "min_gap": np.array(gaps)})

    def _sphere_blocks(self, q, u, h) -> list:
        """Contacts between spheres on different links: normal n from sphere j to sphere i, the relative
        Jacobian J_i(pᵢ) − J_j(pⱼ) at the two surface points pᵢ = cᵢ − rᵢ n, pⱼ = cⱼ + rⱼ n."""
        C, Jc = point_jacobians(self.tree, q, self.sphere_links, self.sphere_centres)
        i, j = self.pairs[:, 0], self.pairs[:, 1]
        d = C[i] - C[j]
        dist = np.linalg.norm(d, axis=1)
        gap = dist - self.radii[i] - self.radii[j]
        n = d / np.maximum(dist, 1e-12)[:, None]
        closing = np.einsum("ki,kij,j->k", n, Jc[i] - Jc[j], u)
        near = np.flatnonzero(gap < self.margin + h * np.maximum(-closing, 0.0))
        if not near.size:
            return []
        i, j, n = i[near], j[near], n[near]
        pi, pj = C[i] - self.radii[i][:, None] * n, C[j] + self.radii[j][:, None] * n
        _, X0, origins = world_poses(self.tree, q)
        li, lj = [self.sphere_links[k] for k in i], [self.sphere_links[k] for k in j]
        loc = [X0[lk][:3, :3] @ (p - origins[lk]) for lk, p in zip(li + lj, list(pi) + list(pj))]
        _, J = point_jacobians(self.tree, q, li + lj, loc)
        return [(n, J[:near.size] - J[near.size:], gap[near], len(self.links) + near)]

    def _active_set(self, A, b, mu, keys) -> tuple:
        """Impulses by the active set from each persisting contact's last state (a new contact: on if
        b_f < 0, sticking), PGS sweeps finding its guess when it cycles (:func:`pbanim.lcp.box.box_friction_handoff`); an
        answer not certified after ``max_iter`` sweeps is counted in ``fallbacks``. Returns (z, residual,
        PGS sweeps)."""
        state0 = np.zeros((keys.size, 3), dtype=int)
        state0[:, 0] = b[0::3] < 0
        for r, k in enumerate(keys.tolist()):
            if k in self._persist:
                state0[r] = self._persist[k]
        z, res, sweeps, state, certified = box_friction_handoff(A, b, mu, state=state0, max_iter=self.max_iter,
                                                                tol=self.tol)
        self.fallbacks += not certified
        self._persist = dict(zip(keys.tolist(), state))
        return z, res, sweeps

    def _min_gap(self, y) -> float:
        P, _ = point_jacobians(self.tree, y[:self.system.nq], self.links, self.points)
        return float(np.min(self.terrain.gap_normal(P)[0]))
