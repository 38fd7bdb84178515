"""Friction: polyhedral cones and velocity-level contact time stepping (chapter 07).

Coulomb's cone ‖f_t‖ ≤ μ f_n is replaced by a pyramid with k facets: the friction force is
Σⱼ βⱼ dⱼ with βⱼ ≥ 0 along k unit tangents dⱼ = cos(2πj/k) t₁ + sin(2πj/k) t₂ and Σⱼ βⱼ ≤ μ f_n.
It is exact along the generators and weaker by cos(π/k) halfway between them (ORACLES D6: a
4-facet pyramid is anisotropic along the diagonals).

Velocity-level time stepping (Stewart & Trinkle 1996; Anitescu & Potra 1997). Over a step h, with
impulses p_n (normal), β (friction), and λ (≈ the sliding speed), the new velocity is

    u⁺ = ũ + W (J_nᵀ p_n + Dᵀ β),         ũ = u + h W Q      (rigid bodies: ũ = W(M u + h Q), L kept)

and (p_n, β, λ) solve one LCP per step:

    0 ≤ p_n ⊥ J_n u⁺ + s/h ≥ 0                     (s: signed separation, −depth; s > 0 = look-ahead)
    0 ≤ β   ⊥ D u⁺ + E λ ≥ 0                       (friction opposes the slip, maximal dissipation)
    0 ≤ λ   ⊥ μ p_n − Eᵀ β ≥ 0                     (inside the cone, or sliding on its boundary)

then q⁺ = q + h u⁺ (quaternions by q ← exp(½ h ω⁺) ⊗ q). The LCP matrix
[[J_n W J_nᵀ, J_n W Dᵀ, 0], [D W J_nᵀ, D W Dᵀ, E], [μ, −Eᵀ, 0]] is not symmetric: Lemke's method
solves it (Stewart–Trinkle prove a solution always exists — Painlevé's configuration included).

Where each scheme is valid
--------------------------
* Acceleration level (:class:`pbanim.contact.effect.RestingContact`, Baraff 1994): smooth resting
  or frictionless sliding contact with consistent accelerations; second-order integrators apply; it
  cannot take impacts, and with friction it can be *inconsistent* (Painlevé: B(θ) < 0, μ > 4/3), which
  :func:`acceleration_lcp_check` detects and reports with :class:`~pbanim.errors.InconsistentContact`.
* Velocity level (this module): impacts (inelastic), stick/slip friction, Painlevé — always solvable,
  first order in h, and it dissipates: the price of robustness.

=========  ===============  ===========  ==========================================================
symbol     code             shape        meaning
=========  ===============  ===========  ==========================================================
k          ``facets``       int          number of friction directions (cone facets)
μ          ``friction``     (m,)         Coulomb coefficient
D          ``D``            (mk, n)      tangential Jacobian rows (k per contact)
E          ``E``            (mk, m)      block column of ones
p_n, β, λ  ``pn, beta, lam``             normal impulses, friction impulses, slip-speed multipliers
=========  ===============  ===========  ==========================================================

References: D. E. Stewart, J. C. Trinkle, "An implicit time-stepping scheme for rigid body dynamics with
inelastic collisions and Coulomb friction", IJNME 39 (1996); M. Anitescu, F. A. Potra, "Formulating
dynamic multi-rigid-body contact problems with friction as solvable LCPs", Nonlinear Dynamics 14 (1997);
P. Painlevé, "Sur les lois du frottement de glissement", C. R. Acad. Sci. 121 (1895).
"""

from __future__ import annotations

import time
from typing import Any, Callable, Sequence

import numpy as np

from .assembly import ContactRows, assemble_rigid, particle_blocks, particle_rows, rigid_rows, rigid_state
from .specs import RIGID, ContactsOn, check_contacts, finite_parts, state_of
from ..bodies import require_bodies
from ..collision.shapes import Contacts
from ..bodies import BodySystem
from ..contracts import Array, Choice, Flag, Func, Int, Obj, Opt, Real, Seq, contract
from ..lcp.solve import LCP_SOLVERS, solve_lcp
from ..lcp.specs import SolverOptions
from ..errors import InconsistentContact, InfeasibleContact, InvalidInput
from ..results import ContactSolution, SimResult
from ..ode.driver import MAX_STEPS, check_finite, drive, step_grid

__all__ = ["friction_directions", "velocity_lcp", "TimeStepping", "acceleration_lcp_check"]


#: most friction directions per contact (a cap known before any array is built: k = 10⁹ asked for 24 GB)
MAX_FACETS = 64
_FACETS = Int(ge=2, le=MAX_FACETS)


@contract(normal=Array(("m", 3)), facets=_FACETS, tangent=Opt(Array((3,))))
def friction_directions(normal, facets: int = 4, tangent=None) -> np.ndarray:
    """k unit tangents per contact, shape (m, k, 3): dⱼ = cos(2πj/k) t₁ + sin(2πj/k) t₂.

    ``normal`` (m, 3): unit vectors (to 10⁻⁶, as ``Contacts`` holds them). t₁ is ``tangent`` (default the x
    axis, or y when the normal is near x) projected on the contact plane
    (:func:`pbanim.geometry.cone_edges`, the frame the collision impulses use too); only its direction
    counts (it is scaled to unit length first, so 10³⁰⁰ does not overflow). 2 ≤ k ≤ 64.

    >>> friction_directions([[0.0, 0.0, 1.0]], 4).round(12)[0]
    array([[ 1.,  0.,  0.],
           [ 0.,  1.,  0.],
           [-1.,  0.,  0.],
           [-0., -1.,  0.]])
    """
    from ..geometry import cone_edges  # the one tangent frame, shared with the collision impulses

    n = np.array(normal, dtype=float, ndmin=2)
    length = np.linalg.norm(n, axis=1, keepdims=True)
    if not np.all(np.abs(length - 1.0) <= 1e-6):      # the tolerance of Contacts; the frame wants 1e-9
        raise InvalidInput(f"friction_directions: normal must hold unit vectors (|n| = 1 to 1e-6), got lengths "
                           f"{length.ravel()[:5].tolist()}")
    if not np.all(np.abs(length - 1.0) <= 1e-9):
        n /= length                                    # only then: unit normals keep collision's frame exactly
    if tangent is not None:
        tangent = np.asarray(tangent, dtype=float)
        scale = np.abs(tangent).max()
        if not scale > 0:
            raise InvalidInput(f"friction_directions: tangent must be a nonzero direction, got {tangent.tolist()}")
        tangent = tangent / scale
    return cone_edges(n, int(facets), tangent)


@contract(rows_n=Obj(ContactRows), rows_d=Opt(Obj(ContactRows)), Wb=Array(("rows_n.n_pad", "rows_n.d", "rows_n.d")),
          mu=Array(("rows_n.a.size",), ge=0, scalar=True, empty=True),
          u_free=Array(("rows_n.n_pad", "rows_n.d")), bias=Array(("rows_n.a.size",), empty=True), facets=_FACETS,
          returns=finite_parts)
def velocity_lcp(rows_n: ContactRows, rows_d: ContactRows | None, Wb: np.ndarray, mu, u_free: np.ndarray,
                 bias: np.ndarray, facets: int) -> tuple[np.ndarray, np.ndarray]:
    """The Stewart–Trinkle LCP (A, b) in the unknowns z = [p_n (m), β (mk), λ (m)].

    ``rows_d`` None (frictionless): z = p_n, A = J_n W J_nᵀ (symmetric PSD), b = J_n ũ + bias; else
    ``rows_d`` holds the k = ``facets`` friction rows of each contact in turn (m k rows, same bodies).
    """
    m = rows_n.a.size
    if rows_d is not None and (rows_d.a.size != m * int(facets) or rows_d.n_pad != rows_n.n_pad
                               or rows_d.d != rows_n.d):
        raise InvalidInput(f"velocity_lcp: rows_d must hold facets = {facets} rows per contact of rows_n "
                           f"(m k = {m * int(facets)} rows on n_pad = {rows_n.n_pad} bodies), got "
                           f"{rows_d.a.size} rows on {rows_d.n_pad}")
    Ann = rows_n.gram(rows_n, Wb)
    bn = rows_n.matvec(u_free) + bias
    if rows_d is None:
        return 0.5 * (Ann + Ann.T), bn
    k = int(facets)
    And = rows_n.gram(rows_d, Wb)
    Add = rows_d.gram(rows_d, Wb)
    E = np.kron(np.eye(m), np.ones((k, 1)))
    mk = m * k
    A = np.zeros((m * (k + 2), m * (k + 2)))
    A[:m, :m], A[:m, m:m + mk] = Ann, And
    A[m:m + mk, :m], A[m:m + mk, m:m + mk], A[m:m + mk, m + mk:] = And.T, 0.5 * (Add + Add.T), E
    A[m + mk:, :m], A[m + mk:, m:m + mk] = np.diag(np.broadcast_to(mu, (m,))), -E.T
    b = np.concatenate([bn, rows_d.matvec(u_free), np.zeros(m)])
    return A, b


class TimeStepping:
    """Velocity-level contact time stepping with Coulomb friction (Stewart–Trinkle / Anitescu–Potra).

    Parameters
    ----------
    system : RigidBodies or ParticleSystem (3-D)
    detect : callable ``detect(y) -> Contacts``
    forces : sequence of force-phase effects (gravity, ...); they are bound here.
    friction : float or array (m,)
        μ ≥ 0; 0 solves the frictionless LCP (any solver), μ > 0 needs ``solver="lemke"``.
    facets : int
        Number of friction directions k (≥ 2; 4 is a pyramid).
    solver : str
        LCP solver name (see :func:`pbanim.lcp.solve.solve_lcp`).
    erp : float
        Fraction of a penetration removed per step (0 < erp ≤ 1); a positive separation is always
        fully used as look-ahead (the contact may close, not overshoot).
    tangent : array (3,), optional
        Reference direction for the first friction direction t₁.
    accept_unconverged : bool
        For iterative solvers (PGS with a sweep budget, as game engines run it): keep stepping with the
        best iterate when the LCP is not solved to ``tol`` instead of raising
        :class:`~pbanim.errors.InfeasibleContact`. Never silent: the step's residual and an
        ``lcp_unconverged`` flag are recorded in the diagnostics.
    lean : bool
        Let :meth:`simulate` take the lean step (:mod:`pbanim.contact.lean`: bound once, equal to the
        readable :meth:`step` to roundoff) when it applies — rigid bodies, no friction, a narrow phase with
        raw arrays (:class:`pbanim.contact.scenes.SceneDetect`) — or, with friction and Lemke's method on a few
        rigid bodies, :mod:`pbanim.contact.lean_friction` (also equal to roundoff); False: the readable step always.

    Examples
    --------
    >>> from pbanim.particles import ParticleSystem, Gravity
    >>> from pbanim.contact.assembly import make_contacts
    >>> ps = ParticleSystem([[0.0, 0.0, 0.0]], [[1.0, 0.0, 0.0]], masses=1.0)
    >>> floor = lambda y: make_contacts([0], [-1], [y[:3]], [[0.0, 0.0, 1.0]], [-y[2]])
    >>> ts = TimeStepping(ps, floor, [Gravity()], friction=0.5)
    >>> res = ts.simulate(0.1, 0.01)       # sliding: v drops by μ g t = 0.4905
    >>> round(float(res.y[3, -1]), 10)
    0.5095
    """

    @contract(system=BodySystem(), detect=Func(), forces=Seq(Obj("pbanim.scene:Effect")),
              friction=Array((None,), ge=0, scalar=True), facets=_FACETS, solver=Choice(LCP_SOLVERS),
              erp=Real(gt=0, le=1), tol=Real(gt=0, lt=1), tangent=Opt(Array((3,))),
              solver_options=Opt(SolverOptions()), accept_unconverged=Flag(), lean=Flag())
    def __init__(self, system, detect: Callable, forces: Sequence[Any] = (), *, friction=0.0, facets: int = 4,
                 solver: str = "lemke", erp: float = 0.2, tol: float = 1e-10, tangent=None,
                 solver_options: dict | None = None, accept_unconverged: bool = False, lean: bool = True) -> None:
        mu = np.asarray(friction, dtype=float)
        if np.any(mu > 0) and solver != "lemke":
            raise InvalidInput(f"TimeStepping: solver must be 'lemke' with friction > 0 (the LCP is not symmetric), "
                               f"got {solver!r}")
        if tangent is not None and not np.abs(np.asarray(tangent, dtype=float)).max() > 0:
            raise InvalidInput(f"TimeStepping: tangent must be a nonzero direction, got {tangent}")
        kind = require_bodies(system, "TimeStepping").kind
        if kind not in ("rigid", "particles"):
            raise InvalidInput(f"TimeStepping steps particles or rigid bodies, got a {kind!r} system")
        self.rigid = kind == "rigid"
        if not self.rigid and system.dof != 3:
            raise InvalidInput(f"TimeStepping needs 3-D particles, got dim = {system.dof}")
        self.system, self.detect, self.forces = system, detect, list(forces)
        for e in self.forces:
            e.bind(system)
        self.mu, self.facets, self.solver, self.erp, self.tol = mu, int(facets), solver, float(erp), float(tol)
        self.tangent, self.solver_options = tangent, dict(solver_options or {})
        self.accept_unconverged = bool(accept_unconverged)
        self.lean = bool(lean)
        self.last: ContactSolution | None = None
        self.last_info: dict = {}

    def _detect(self, y):
        """``detect(y)``'s contacts (a narrow phase of :mod:`pbanim.contact.scenes` returns (Contacts, keys):
        the keys serve :class:`~pbanim.contact.stepping.FrictionStepping`'s warm starts, not this step)."""
        out = self.detect(y)
        return out[0] if isinstance(out, tuple) and len(out) == 2 and isinstance(out[0], Contacts) else out

    def _applied(self, t: float, y: np.ndarray) -> np.ndarray:
        Q = self.system.zero_forces()
        for e in self.forces:
            e.apply(t, y, Q)
        return Q

    def _kinematics(self, y, Q, h, R=None):
        """Free velocity ũ (n_pad, d), W blocks, and a row builder rows(a, b, p, d) (``R``: the rotations of y,
        when the step has them)."""
        s = self.system
        N = s.N
        if self.rigid:
            S = rigid_state(s, y, R)
            _, _, P, L = s.unpack(y)
            Pp, Lp = np.zeros((N + 1, 3)), np.zeros((N + 1, 3))
            Pp[:N], Lp[:N] = P + h * Q[:, :3], L + h * Q[:, 3:]
            u = np.hstack([S["inv_mass"][:, None] * Pp, np.einsum("nij,nj->ni", S["Iinv"], Lp)])
            return u, S["Wb"], (lambda a, b, p, d: rigid_rows(S, a, b, p, d)), 6
        x, v = s.unpack(y)
        u = np.vstack([v + h * Q * s.W[:, None], np.zeros((1, 3))])
        return u, particle_blocks(s), (lambda a, b, p, d: particle_rows(N, 3, a, b, d)), 3

    @contract(t=Real(), y=Array((state_of("self.system"),)), h=Real(gt=0))
    def step(self, t: float, y: np.ndarray, h: float) -> np.ndarray:
        """One step t → t + h; returns the new state (``self.last`` holds the LCP solution)."""
        s = self.system
        Q = self._applied(t, y)
        u, Wb, rows, nd = self._kinematics(y, Q, h)
        contacts = self._detect(y)
        if contacts is not None:        # what a user's detect returns reaches the assembly unchecked
            check_contacts("TimeStepping", "detect(y)", contacts, s)
        N = s.N
        self.last_info = {"contacts": contacts, "m": 0 if contacts is None else len(contacts.a)}
        if contacts is not None and len(contacts.a):
            a = np.where(np.asarray(contacts.a) < 0, N, contacts.a)
            b = np.where(np.asarray(contacts.b) < 0, N, contacts.b)
            m = a.size
            rn = rows(a, b, contacts.point, contacts.normal)
            sep = -np.asarray(contacts.depth, dtype=float)
            bias = np.where(sep > 0, sep, self.erp * sep) / h
            try:
                mu = np.broadcast_to(self.mu, (m,))
            except ValueError:
                raise InvalidInput(f"friction has {self.mu.size} values but detect returned {m} contacts at "
                                   f"t = {t:.6g}; give one μ, or one per contact") from None
            rd = None
            k = self.facets
            if np.any(mu > 0):
                d = friction_directions(contacts.normal, k, self.tangent)  # (m, k, 3)
                rd = rows(np.repeat(a, k), np.repeat(b, k), np.repeat(contacts.point, k, axis=0), d.reshape(-1, 3))
            A, bb = velocity_lcp(rn, rd, Wb, mu, u, bias, k)
            ws = self.last.f if (self.last is not None and self.last.f.size == bb.size) else None
            sol = solve_lcp(A, bb, self.solver, tol=self.tol, warm_start=ws,
                            raise_on_failure=not self.accept_unconverged, **self.solver_options)
            self.last = sol
            pn = sol.f[:m]
            imp = rn.rmatvec(pn)
            fric = None
            if rd is not None:
                fric = rd.rmatvec(sol.f[m:m + m * k])
                imp = imp + fric
            u = u + np.einsum("nij,nj->ni", Wb, imp)
            self.last_info.update(normal_impulse=pn, impulse=imp[:N], friction_impulse=None if fric is None else fric[:N])
        else:
            self.last = None
        return self._advance(y, u[:N], h)

    def _advance(self, y, u, h, R=None):
        s = self.system
        if not self.rigid:
            x, _ = s.unpack(y)
            return np.concatenate([(x + h * u).ravel(), u.ravel()])
        from ..rigid.quat import quat_exp, quat_multiply

        x, q, P, L = s.unpack(y)
        v, w = u[:, :3], u[:, 3:]
        P_new = np.where(s.static, 0.0, s.mass)[:, None] * v
        R = s.rotations(y) if R is None else R
        Iw = R @ s.I_body @ np.swapaxes(R, 1, 2)
        L_new = np.where(s.static[:, None], 0.0, np.einsum("nij,nj->ni", Iw, w))
        q_new = quat_multiply(quat_exp(h * w), q)
        return np.concatenate([(x + h * v).ravel(), q_new.ravel(), P_new.ravel(), L_new.ravel()])

    @contract(t_end=Real(gt=0), h=Real(gt=0), y0=Opt(Array((state_of("self.system"),))), record_every=Int(ge=1),
              max_steps=Int(ge=1), diagnostics=Flag())
    def simulate(self, t_end: float, h: float, *, y0: np.ndarray | None = None, record_every: int = 1,
                 max_steps: int = MAX_STEPS, diagnostics: bool = True) -> SimResult:
        """Fixed steps from 0 to ``t_end`` through the one driver (:mod:`pbanim.ode.driver`, same step rule).

        Diagnostics (``diagnostics=True``): what describes a step — contact count, residual, total normal
        impulse, solver time, unconverged flag — read at the recorded times; the deepest penetration of each
        recorded state computed from the recorded states when ``result.diagnostics`` is first read
        (:class:`pbanim.results.LazyDiagnostics`). ``diagnostics=False``: the states alone. The step is the
        lean one (:mod:`pbanim.contact.lean`) when it applies and ``lean`` was not turned off."""
        from ..contracts import unchecked
        from ..results import LazyDiagnostics
        from .lean import LeanFrictionless, lean_applies
        from .lean_friction import LeanFriction, lean_friction_applies

        grid = step_grid(0.0, t_end, h, max_steps=max_steps, record_every=record_every)
        y = np.array(self.system.state() if y0 is None else y0, dtype=float, copy=True)
        check_finite(y, 0.0, 0, "initial state")
        ts, ys = [0.0], [y.copy()]
        c0 = self._detect(y)           # a user's detect is checked once, on the initial state, before any step
        if c0 is not None:
            check_contacts("TimeStepping", "detect(y)", c0, self.system)
        keys = ("contact_count", "contact_residual", "normal_impulse_total", "lcp_time", "lcp_unconverged")
        diag: dict[str, list] | None = {k: [0.0] for k in keys} if diagnostics else None

        def record(t1, y1):
            ts.append(t1)
            ys.append(y1.copy())
            if diag is None:
                return
            sol, info = self.last, self.last_info
            diag["contact_count"].append(0 if sol is None else info["m"])
            diag["contact_residual"].append(0.0 if sol is None else sol.residual)
            diag["normal_impulse_total"].append(0.0 if sol is None else float(np.sum(info["normal_impulse"])))
            diag["lcp_time"].append(0.0 if sol is None else sol.time)
            diag["lcp_unconverged"].append(0.0 if sol is None else float(not sol.success))

        if self.lean and lean_applies(self):
            step = LeanFrictionless(self).step
        elif self.lean and lean_friction_applies(self):
            step = LeanFriction(self).step
        else:
            step = self.step
        step = unchecked(step)
        start = time.perf_counter()
        drive(step, grid, y, record=record, record_every=record_every)
        wall = time.perf_counter() - start
        Y = np.array(ys).T

        def series():
            out = {k: np.array(v, dtype=float) for k, v in diag.items()}
            pen = []
            for k in range(Y.shape[1]):
                c = self._detect(Y[:, k])
                if c is not None:
                    check_contacts("TimeStepping", "detect(y)", c, self.system)
                pen.append(max(0.0, float(np.max(c.depth, initial=0.0))) if c is not None else 0.0)
            out["max_penetration"] = np.array(pen)
            return out

        return SimResult(t=np.array(ts), y=Y, status=0, wall_time=wall, method="velocity-level",
                         nsteps=grid.n_steps, diagnostics=LazyDiagnostics(series) if diagnostics else {})


@contract(bodies=RIGID, y=Array((state_of("bodies"),)), contacts=ContactsOn("bodies"), Q=Array(("bodies.N", 6)),
          friction=Array(("contacts.m",), ge=0, scalar=True, empty=True), solver=Choice(LCP_SOLVERS),
          tol=Real(gt=0, lt=1))
def acceleration_lcp_check(bodies, y: np.ndarray, contacts, Q: np.ndarray, friction=0.0, *,
                           solver: str = "lemke", tol: float = 1e-10) -> ContactSolution:
    """Solve the acceleration-level LCP (with sliding friction) and raise if it is inconsistent.

    Raises :class:`~pbanim.errors.InconsistentContact` when no contact forces satisfy
    d̈ = A f + b ≥ 0, f ≥ 0, fᵀd̈ = 0 (Lemke's secondary ray; Painlevé with B(θ) < 0 and b < 0).
    """
    prob = assemble_rigid(bodies, y, contacts, Q, friction=friction)
    try:
        sol = solve_lcp(prob.A, prob.b, solver, tol=tol)
    except InfeasibleContact as exc:
        eig = np.linalg.eigvals(prob.A).real.min() if prob.A.size else 0.0
        raise InconsistentContact(f"{exc.solver} status {exc.status}, residual {exc.residual:.3e}; "
                                  f"min Re eig(A) = {eig:.3g}, min b = {prob.b.min():.3g}") from exc
    sol.extra["problem"] = prob
    return sol
