"""The resting-contact effect (chapter 07): scenes declare it; without it nothing here runs.

At every force evaluation the effect detects the contacts, assembles d̈ = A f + b
(:mod:`pbanim.contact.assembly`), solves the LCP (:func:`pbanim.lcp.solve.solve_lcp`) and adds
Q_C = Jᵀ f to the generalized force (phase "constraint"). qpsolvers is imported by the first QP solve,
so a scene without this effect never imports it and never assembles an A.

Stabilization (documented choice). An acceleration-level condition d̈ ≥ 0 lets the integrator's
O(h) position error accumulate into slow sinking. With ``stabilization="baumgarte"`` (default) the
condition becomes d̈ + k_d ḋ + k_s d ≥ 0 (Baumgarte 1972; the lecture's k_s C + k_d Ċ), with
d = −depth the signed separation and ḋ = J u the normal relative velocity: a penetrated contact is
pushed out like a critically damped spring (defaults k_s = 400 s⁻², k_d = 40 s⁻¹), and a resting
contact at d = ḋ = 0 is untouched, so an exactly resting stack stays exactly at rest.
``"none"`` solves the lecture's plain condition.

Where this scheme is valid: frictionless (or known-sliding) contacts that persist, with consistent
accelerations. It cannot resolve impacts (velocities must already be non-approaching: use the
collision chapter's impulses first) and it breaks down with friction in Painlevé's configuration,
where the acceleration-level problem can be inconsistent — there use the velocity-level
time-stepping scheme (:mod:`pbanim.contact.friction`).

References: D. Baraff, SIGGRAPH 1994 and 2001 course notes; J. Baumgarte, "Stabilization of constraints
and integrals of motion in dynamical systems", Comput. Methods Appl. Mech. Eng. 1 (1972).
"""

from __future__ import annotations

from typing import Any, Callable

import numpy as np

from .assembly import assemble_particles, assemble_rigid
from .specs import check_contacts, state_of
from ..bodies import require_bodies
from ..bodies import BodySystem
from ..contracts import Array, Choice, Flag, Func, Opt, Real, contract
from ..lcp.solve import LCP_SOLVERS, solve_lcp
from ..lcp.specs import SolverOptions
from ..errors import InconsistentContact, InfeasibleContact, InvalidInput
from ..scene import Effect

__all__ = ["RestingContact"]

_STAB = ("none", "baumgarte")
_GAIN = Real(ge=0)
_TIME = Real()
_STATE = Array((state_of("self.system"),))
_FORCES = Array(("self.system.N", "self.system.dof"))


class RestingContact(Effect):
    """Resting contact forces by an LCP at the acceleration level (phase "constraint").

    Parameters
    ----------
    detect : callable ``detect(y) -> Contacts``
        Contact generation (e.g. a model's manifold function or the collision chapter's narrow phase);
        ``a, b`` body indices (−1 = static world), ``point``, ``normal`` (from b to a), ``depth``.
    solver : {"qp", "lemke", "dantzig", "pgs"}
    stabilization : {"baumgarte", "none"}
    stiffness, damping : float
        Baumgarte gains k_s [1/s²] and k_d [1/s].
    tol : float
        Natural-map residual tolerance passed to :func:`solve_lcp`.
    fallback : str, optional
        Explicit fallback solver (see :func:`solve_lcp`).
    solver_options : dict, optional
        Extra options for the solver (``max_iter``, ``backend``, ...).
    warm_start : bool
        Pass the previous forces as warm start when the contact count is unchanged.
    friction : float
        Coulomb μ for *sliding* rigid contacts (force direction n − μ t̂, Baraff 1994); A is then not
        symmetric, so ``solver`` must be "lemke" or "dantzig". An LCP without solution (Painlevé) raises
        :class:`~pbanim.errors.InconsistentContact`. Sticking contacts stay frictionless here: use the
        velocity-level :class:`~pbanim.contact.friction.TimeStepping` for stick/slip.

    Examples
    --------
    >>> from pbanim.particles import ParticleSystem, Gravity
    >>> from pbanim.scene import Scene
    >>> from pbanim.contact.assembly import make_contacts
    >>> ps = ParticleSystem([[0.0, 0.0]], masses=2.0)
    >>> ground = lambda y: make_contacts([0], [-1], [[y[0], y[1]]], [[0.0, 1.0]], [max(0.0, -y[1])])
    >>> scene = Scene(ps, [Gravity(), RestingContact(ground, solver="lemke")])
    >>> scene.pipeline
    ('gravity', 'resting_contact', 'integrate')
    >>> res = scene.simulate(1.0, 0.01)
    >>> bool(abs(res.y[1, -1]) < 1e-15), float(res.diagnostics["contact_force_total"][-1])   # f = m g
    (True, 19.62)
    """

    name = "resting_contact"
    phase = "constraint"
    # (drift_free, inherited: under symplectic Euler the scene solves once per step, at (q₀, v₀), and
    # ``last`` (warm start, diagnostics) is that solve's answer; see pbanim.scene)

    @contract(detect=Func(), solver=Choice(LCP_SOLVERS), stabilization=Choice(_STAB), stiffness=_GAIN, damping=_GAIN,
              tol=Real(gt=0, lt=1), fallback=Opt(Choice(LCP_SOLVERS)), solver_options=Opt(SolverOptions()),
              warm_start=Flag(), friction=_GAIN)
    def __init__(self, detect: Callable[[np.ndarray], Any], solver: str = "qp", *,
                 stabilization: str = "baumgarte", stiffness: float = 400.0, damping: float = 40.0,
                 tol: float = 1e-10, fallback: str | None = None, solver_options: dict | None = None,
                 warm_start: bool = True, friction: float = 0.0) -> None:
        self.detect, self.solver, self.stabilization = detect, solver, stabilization
        self.ks, self.kd, self.tol, self.fallback = float(stiffness), float(damping), float(tol), fallback
        self.solver_options = dict(solver_options or {})
        self.warm_start = bool(warm_start)
        if friction > 0 and solver not in ("lemke", "dantzig"):
            raise InvalidInput(f"RestingContact: solver must be 'lemke' or 'dantzig' with friction > 0 (A is not "
                               f"symmetric), got {solver!r}")
        self.friction = float(friction)
        self.last = None          # the last ContactSolution
        self.last_contacts = None
        self.solves = 0

    @contract(system=BodySystem())           # a refusal lists the protocol members the system lacks
    def bind(self, system) -> None:
        kind = require_bodies(system, "RestingContact").kind
        if kind == "rigid":
            self._assemble, self._N = assemble_rigid, system.N
        elif self.friction > 0:
            raise InvalidInput("friction in RestingContact needs a RigidBodies system; use TimeStepping for particles")
        elif kind == "particles":
            self._assemble, self._N = assemble_particles, system.N
        else:
            raise InvalidInput(f"RestingContact assembles rows for particles or rigid bodies, got a {kind!r} system "
                             f"({type(system).__name__})")
        self.system = system

    def _generalized_velocity(self, y: np.ndarray) -> np.ndarray:
        u = self.system.generalized_velocity(y)
        return np.vstack([u, np.zeros((1, u.shape[1]))])

    @contract(t=_TIME, y=_STATE, Q=_FORCES)
    def solve(self, t: float, y: np.ndarray, Q: np.ndarray):
        """Detect, assemble and solve at (t, y); returns (ContactSolution, ContactProblem, contacts) or None.

        What ``detect(y)`` returns must be None or a Contacts among the system's bodies, in its dimension
        (:func:`pbanim.contact.specs.check_contacts`; anything else is :class:`~pbanim.errors.InvalidInput`
        naming ``detect``)."""
        contacts = self.detect(y)
        if contacts is not None:        # a user's detect: what it returns reaches the assembly unchecked
            check_contacts("RestingContact", "detect(y)", contacts, self.system)
        if contacts is None or len(contacts.a) == 0:
            self.last, self.last_contacts = None, contacts
            return None
        if self.friction > 0:
            prob = assemble_rigid(self.system, y, contacts, Q, friction=self.friction)
        else:
            prob = self._assemble(self.system, y, contacts, Q)
        b = prob.b
        if self.stabilization == "baumgarte":
            u = prob.u if prob.u is not None else self._generalized_velocity(y)
            ddot = prob.rows.matvec(u)
            b = b + self.kd * ddot - self.ks * np.asarray(contacts.depth, dtype=float)
        ws = None
        if self.warm_start and self.last is not None and self.last.f.size == b.size:
            ws = self.last.f
        try:
            sol = solve_lcp(prob.A, b, self.solver, tol=self.tol, fallback=self.fallback, warm_start=ws,
                            validate=False, **self.solver_options)
        except InfeasibleContact as exc:
            if self.friction > 0:   # Painlevé: no forces satisfy the sliding-friction LCP
                raise InconsistentContact(f"t = {t:.6g}: {exc.solver} status {exc.status}, residual "
                                          f"{exc.residual:.3e}, min A_ii = {np.diag(prob.A).min():.3g}") from exc
            raise
        self.last, self.last_contacts = sol, contacts
        self.solves += 1
        return sol, prob, contacts

    @contract(t=_TIME, y=_STATE, Q=_FORCES)
    def constrain(self, t: float, y: np.ndarray, Q: np.ndarray) -> np.ndarray:
        out = self.solve(t, y, Q)
        if out is None:
            return Q
        sol, prob, _ = out
        return Q + prob.generalized_force(sol.f, self._N)

    history_diagnostics = True          # the last solve's forces: read at the recorded times of a run

    @contract(t=_TIME, y=_STATE)
    def diagnostics(self, t: float, y: np.ndarray) -> dict:
        sol, c = self.last, self.last_contacts
        if sol is None:
            return {"contact_count": 0, "contact_residual": 0.0, "contact_force_total": 0.0,
                    "max_penetration": 0.0}
        c = self.detect(y)  # penetration at the recorded state (forces: of the last solve)
        if c is not None:
            check_contacts("RestingContact", "detect(y)", c, self.system)
        return {"contact_count": int(sol.f.size), "contact_residual": sol.residual,
                "contact_force_total": float(sol.f.sum()),
                "max_penetration": float(np.max(c.depth, initial=0.0)) if c is not None else 0.0}
