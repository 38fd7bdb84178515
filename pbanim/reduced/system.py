"""Reduced (generalized) coordinates: particles q = q(u) moved by parameters u (chapter 04).

Governing equations (the lecture's slide "Reduced coordinates")
---------------------------------------------------------------
Choose explicit parameters u instead of implicit constraints C(q) = 0:

    q = q(u, t)   ⇒   q̇ = J u̇ + ∂q/∂t,   q̈ = J ü + b,   b = J̇ u̇ + 2 ∂J/∂t u̇ + ∂²q/∂t²

(b = J̇u̇ for a time-independent chart). Newton for the particles, M q̈ = Q + Q_C, with a workless
constraint force (Q_Cᵀq̇ = 0 for every admissible q̇, i.e. Jᵀ Q_C = 0): applying Jᵀ makes Q_C disappear,

    (JᵀMJ) ü + (JᵀM J̇) u̇ − JᵀQ = 0      (here: (JᵀMJ) ü = Jᵀ(Q − M b)).

Q comes from any particle force effect of :mod:`pbanim.particles` (gravity, drag, springs, user
forces), evaluated at the particle state [q(u), q̇] and projected by Jᵀ. The constraint force the chart
exerts, Q_C = M q̈ − Q, is what the maximal-coordinate formulation (chapter 03) computes as Jᵀλ.

Notation
--------
==========  ====================  ============  ==================================================
symbol      code                  shape         meaning
==========  ====================  ============  ==================================================
u, u̇        ``u, ud``             (k,)          generalized coordinates and rates; y = [u, u̇]
q, q̇        ``q, qd``             (N·dim,)      particle positions/velocities (flattened)
J           ``J``                 (N·dim, k)    ∂q/∂u
J̇u̇ (b)      ``b``                 (N·dim,)      velocity-product acceleration, q̈ = J ü + b
M           ``m`` (diagonal)      (N·dim,)      particle masses, each repeated dim times
Q, Q_C      ``Q``, ``QC``         (N, dim)      applied and constraint forces on the particles
JᵀMJ        ``A``                 (k, k)        generalized mass (SPD while the chart is regular)
κ           ``ChartGuard.cond``   scalar        condition number of JᵀMJ (see :class:`ChartGuard`)
==========  ====================  ============  ==================================================

Limiting cases
--------------
* u = q (identity chart): J = I, b = 0 — plain particles.
* A chart losing rank (spherical pendulum at its pole, a bead on a circle parametrized by x at
  x = ±R where J → ∞) makes JᵀMJ singular relative to its reference value: the solve raises
  :class:`pbanim.errors.SingularChartError` instead of returning huge or NaN accelerations (ORACLES B6);
  maximal coordinates pass the same point untroubled.
* Non-constant M(u) makes symplectic Euler and Verlet (split methods on [u, u̇]) non-symplectic: use
  implicit midpoint for long energy runs (ORACLES B7).

References
----------
A. Witkin, D. Baraff, *Physically Based Modeling*, SIGGRAPH 2001 course notes ("Constrained dynamics").
R. Featherstone, *Rigid Body Dynamics Algorithms* (2008), ch. 2 and 4. E. Hairer, C. Lubich, G. Wanner,
*Geometric Numerical Integration* (2006), §VI.3 and §VII.1 (charts vs constrained formulations).

Examples
--------
>>> import numpy as np
>>> from pbanim.particles import Gravity
>>> L = 1.0                                     # simple pendulum, θ from the downward vertical
>>> q = lambda u: L * np.array([np.sin(u[0]), -np.cos(u[0])])
>>> J = lambda u: L * np.array([[np.cos(u[0])], [np.sin(u[0])]])
>>> Jdu = lambda u, ud: L * ud[0] ** 2 * np.array([-np.sin(u[0]), np.cos(u[0])])
>>> pend = ReducedSystem(q, J, Jdu, masses=1.0, dim=2, forces=[Gravity([0.0, -9.81])], u0=[0.3])
>>> pend.rhs(0.0, [np.pi / 2, 0.0])             # released from horizontal: θ̈ = −g/L
array([ 0.  , -9.81])
"""

from __future__ import annotations

from typing import Any, Callable, Sequence

import numpy as np

from .chart import (METHOD, ChartCheck, ChartGuard, _point_kinematics_cached, check_chart, point_kinematics,
                    simulate_fixed)
from .inputs import COORDS, SYMBOL, Expr
from ..contracts import Array, Either, Func, Int, Obj, Opt, Real, Seq, Text, contract
from ..errors import InvalidInput, NonFiniteResult, SingularChartError, check_result

__all__ = ["ReducedSystem", "ChartGuard", "ChartCheck", "check_chart", "point_kinematics", "simulate_fixed"]


_MASSES = Array(("N",), gt=0, scalar=True)
_FORCES = Seq(Obj("pbanim.scene:Effect", what="a particle force effect (phase 'force')"))
_U = Array(("k",))
_STATE = Array(("self.n_state",))
_TIME = Real()
_COMMON = dict(masses=_MASSES, forces=_FORCES, u0=_U, udot0=Opt(_U), max_cond=Real(gt=1), name=Text())


class ReducedSystem:
    """Particles driven by generalized coordinates u through a chart q = q(u) (or q(u, t)).

    Parameters
    ----------
    q : callable ``q(u) -> (N·dim,)`` (or shape (N, dim))
        Particle positions.
    J : callable ``J(u) -> (N·dim, k)``
        ∂q/∂u. Check yours with :func:`check_chart`.
    Jdot_udot : callable ``Jdot_udot(u, ud) -> (N·dim,)``
        J̇u̇ = (∂(J u̇)/∂u) u̇.
    masses : float or array_like (N,)
    dim : int
        Particle dimension (2 or 3).
    forces : sequence of force effects
        Particle force effects (phase "force"), bound to an internal particle system.
    u0, udot0 : array_like (k,), optional
        Initial state; u0 is also the reference configuration of the chart check.
    max_cond : float
        Largest accepted condition number of JᵀMJ (relative to the reference), see :class:`ChartGuard`.

    The callables describe a time-independent chart. Use :meth:`from_sympy` to derive J and J̇u̇ from
    sympy expressions (compiled once, with CSE), which also allows a time-dependent chart q(u, t).
    Errors: ``ValueError`` for bad shapes or inputs (checked at construction, at u0);
    :class:`pbanim.errors.SingularChartError` from :meth:`rhs` near a singular chart.
    """

    @contract(q=Func(), J=Func(), Jdot_udot=Func(), dim=Int(ge=2, le=3), **_COMMON)
    def __init__(self, q: Callable, J: Callable, Jdot_udot: Callable, masses: Any = 1.0, dim: int = 2,
                 forces: Sequence = (), u0: Any = None, udot0: Any = None, *, max_cond: float = 1e8,
                 name: str = "reduced") -> None:
        u_chk = np.atleast_1d(np.asarray(u0, dtype=float)) if u0 is not None else None
        if u_chk is not None:  # shapes first, with messages, before any product
            try:
                nq, k = np.asarray(q(u_chk), float).size, u_chk.size
                sJ = np.shape(J(u_chk))
            except (TypeError, ValueError, IndexError) as exc:
                raise InvalidInput(f"q(u0) or J(u0) failed with u0 of shape {u_chk.shape} ({type(exc).__name__}: "
                                   f"{exc}); give u0 one entry per coordinate of the chart") from exc
            if sJ != (nq, k):
                raise InvalidInput(f"J(u) must have shape (len(q), len(u)) = ({nq}, {k}), got {sJ}")

        def kin(t, u, ud):
            qq = np.asarray(q(u), float).reshape(-1)
            JJ = np.asarray(J(u), float)
            return qq, JJ @ ud, JJ, np.asarray(Jdot_udot(u, ud), float).reshape(-1)

        self._setup(kin, masses, dim, forces, u0, udot0, max_cond, name)

    @contract(positions=Either(Seq(Either(Seq(Expr(), min_len=1), Obj("sympy:MatrixBase"), Expr()), min_len=1),
                               Obj("sympy:MatrixBase", what="a sympy Matrix of expressions")),
              coords=COORDS, dim=Opt(Int(ge=2, le=3)), t=Opt(SYMBOL), **_COMMON)
    @classmethod
    def from_sympy(cls, positions, coords: Sequence, masses: Any = 1.0, dim: int | None = None,
                   forces: Sequence = (), u0: Any = None, udot0: Any = None, *, t: Any = None,
                   max_cond: float = 1e8, name: str = "reduced") -> "ReducedSystem":
        """Build from sympy expressions q(u[, t]): J and b derived symbolically, compiled once (CSE).

        Parameters
        ----------
        positions : sequence of N position sequences (each of dim expressions), or a flat sequence
            of N·dim expressions (then give ``dim``).
        coords : list of sympy.Symbol
        t : sympy.Symbol, optional
            Time symbol of a moving chart.

        Examples
        --------
        >>> import sympy as sp
        >>> from pbanim.particles import Gravity
        >>> th = sp.Symbol("theta")
        >>> pend = ReducedSystem.from_sympy([[sp.sin(th), -sp.cos(th)]], [th], forces=[Gravity()], u0=[0.1])
        >>> pend.rhs(0.0, [np.pi / 2, 0.0])
        array([ 0.  , -9.81])
        """
        import sympy

        rows = list(positions) if not isinstance(positions, sympy.MatrixBase) else positions.tolist()
        if rows and all(isinstance(r, (list, tuple, sympy.MatrixBase)) for r in rows):
            dims = {len(r) for r in rows}
            if len(dims) != 1 or (dim is not None and dims != {dim}):
                raise InvalidInput(f"positions must all have the same dimension {dim or ''}, got lengths {sorted(dims)}")
            dim = dims.pop()
            flat = [sympy.sympify(e) for r in rows for e in r]
        else:
            if dim is None:
                raise InvalidInput("dim must be given when positions is a flat list of expressions")
            flat = [sympy.sympify(e) for e in rows]
            if len(flat) % dim:
                raise InvalidInput(f"positions must have N·dim entries, got {len(flat)} for dim = {dim}")
        kinm = _point_kinematics_cached(flat, coords, t)   # shared with derive_equations
        k = len(kinm.coords)
        args = [t if t is not None else sympy.Symbol("_t"), *kinm.coords, *kinm.speeds]
        Jnz = [(i, j, e) for i, row in enumerate(kinm.J) for j, e in enumerate(row) if e != 0]
        outs = flat + kinm.qdot + [e for _, _, e in Jnz] + kinm.b
        fn = sympy.lambdify(args, outs, modules="math", cse=True)
        nq = len(flat)
        jidx = np.array([i * k + j for i, j, _ in Jnz], dtype=np.intp)

        def kin(tt, u, ud):
            out = np.array(fn(float(tt), *u.tolist(), *ud.tolist()), dtype=float)
            JJ = np.zeros(nq * k)
            JJ[jidx] = out[2 * nq: 2 * nq + len(jidx)]
            return out[:nq], out[nq: 2 * nq], JJ.reshape(nq, k), out[2 * nq + len(jidx):]

        self = cls.__new__(cls)
        self._setup(kin, masses, dim, forces, u0 if u0 is not None else np.zeros(k), udot0, max_cond, name)
        self.kinematics = kinm
        return self

    # -- set-up ---------------------------------------------------------------------------------
    def _setup(self, kin, masses, dim, forces, u0, udot0, max_cond, name) -> None:
        from ..particles.system import ParticleSystem

        if dim not in (2, 3):
            raise InvalidInput(f"dim must be 2 or 3, got {dim!r}")
        if u0 is None:
            raise InvalidInput("u0 must be given (the initial coordinates, also the chart's reference)")
        u0 = np.atleast_1d(np.asarray(u0, dtype=float))
        if u0.ndim != 1 or u0.size == 0:
            raise InvalidInput(f"u0 must be a non-empty 1-D array, got shape {u0.shape}")
        k = u0.size
        ud0 = np.zeros(k) if udot0 is None else np.atleast_1d(np.asarray(udot0, dtype=float))
        if ud0.shape != (k,):
            raise InvalidInput(f"udot0 must have shape ({k},) like u0, got {ud0.shape}")
        try:
            q0, qd0, J0, b0 = kin(0.0, u0, ud0)
        except (TypeError, ValueError, IndexError) as exc:
            raise InvalidInput(f"the chart failed at u0 = {u0.tolist()} ({type(exc).__name__}: {exc}); check "
                               "that u0 and udot0 have one entry per coordinate") from exc
        if q0.size % dim:
            raise InvalidInput(f"q(u) must return N·dim = multiple of {dim} values, got {q0.size}")
        if J0.shape != (q0.size, k):
            raise InvalidInput(f"J(u) must have shape (len(q), len(u)) = ({q0.size}, {k}), got {J0.shape}")
        if b0.shape != (q0.size,):
            raise InvalidInput(f"Jdot_udot(u, ud) must have shape ({q0.size},), got {b0.shape}")
        N = q0.size // dim
        m = np.asarray(masses, dtype=float)
        if m.ndim > 1 or m.ndim == 1 and m.size != N:
            raise InvalidInput(f"masses must be one number or N = {N} numbers (one per particle of q(u)), got "
                               f"shape {m.shape}")
        if not (np.isfinite(m).all() and (m > 0).all()):
            raise InvalidInput(f"masses must be finite and > 0, got {m.tolist()}")
        if not (np.isfinite(q0).all() and np.isfinite(qd0).all()):
            raise SingularChartError(np.inf, u0.tolist(), "q(u0) or its velocity is not finite (u0 outside the "
                                     "chart's domain)")
        self.particles = ParticleSystem(q0.reshape(N, dim), qd0.reshape(N, dim), m)
        self.forces = list(forces)
        for e in self.forces:      # the one check of forces (the contract says only "an Effect")
            if getattr(e, "phase", None) != "force":
                raise InvalidInput(f"forces must be force effects (phase 'force'), got {e!r} with phase "
                                 f"{getattr(e, 'phase', None)!r}; constraints are what the chart replaces")
            e.bind(self.particles)
        self._kin, self.k, self.N, self.dim, self.name = kin, k, N, dim, name
        self.split = k
        self.u0, self.udot0 = u0, ud0
        self.m = np.repeat(self.particles.m, dim)
        self.guard = ChartGuard(max_cond)
        self.guard.set_reference(J0.T @ (self.m[:, None] * J0))
        self.nfev = 0

    @property
    def n_state(self) -> int:
        """Length of the state y = [u, u̇]: 2k."""
        return 2 * self.k

    # -- dynamics -------------------------------------------------------------------------------
    @contract(u0=Array(("self.k",)), udot0=Opt(Array(("self.k",))))
    def with_initial(self, u0: Any, udot0: Any = None) -> "ReducedSystem":
        """A new system on the same compiled chart with initial state (u0, u̇0) (its own chart reference,
        force effects and counters; nothing is shared but the compiled kinematics)."""
        import copy

        new = type(self).__new__(type(self))
        new._setup(self._kin, self.particles.m, self.dim, [copy.copy(e) for e in self.forces], u0, udot0,
                   self.guard.max_cond, self.name)
        new.kinematics = getattr(self, "kinematics", None)
        return new

    def state(self) -> np.ndarray:
        """Initial state y = [u0, u̇0]."""
        return np.concatenate([self.u0, self.udot0])

    @contract(y=_STATE, t=_TIME)
    def particle_state(self, y, t: float = 0.0) -> np.ndarray:
        """[q(u), q̇] (flat, the layout of :class:`pbanim.particles.ParticleSystem`) at state y."""
        return self._particle_state(y, t)

    def _particle_state(self, y, t):
        u, ud = self._split(y)
        q, qd, _, _ = self._eval(t, u, ud)
        out = np.concatenate([q, qd])
        if not np.isfinite(out).all():
            raise SingularChartError(np.inf, u.tolist(), "q(u) or q̇ = J u̇ is not finite (outside the chart's domain, "
                                     "or an overflow)")
        return out

    def _split(self, y):
        """(u, u̇) of a state; the shape check for internal callers (an ODE solver given a wrong y0)."""
        y = np.asarray(y, dtype=float)
        if y.shape != (2 * self.k,):
            raise InvalidInput(f"y must have shape ({2 * self.k},) = [u, u̇], got {y.shape}")
        return y[: self.k], y[self.k:]

    def _eval(self, t, u, ud):
        """q, q̇, J, b at (u, u̇, t): SingularChartError outside the chart's domain (math.sqrt(-1), 1/0),
        NonFiniteResult when a compiled chart overflows (a float power past 1e308)."""
        try:
            return self._kin(t, u, ud)
        except OverflowError as exc:
            raise NonFiniteResult("the chart q(u), J(u), J̇u̇", f"at u = {u.tolist()} ({exc})") from None
        except (ValueError, ZeroDivisionError) as exc:
            raise SingularChartError(np.inf, u.tolist(), f"the chart cannot be evaluated ({exc}); "
                                     "outside its domain") from None

    def _forces(self, t, q, qd) -> np.ndarray:
        Q = np.zeros((self.N, self.dim))
        if self.forces:
            yp = np.concatenate([q, qd])
            for e in self.forces:
                e.apply(t, yp, Q)
        return Q.reshape(-1)

    def _solve(self, t, y):
        u, ud = self._split(y)
        q, qd, J, b = self._eval(t, u, ud)
        # BEGIN SOLUTION ReducedSystem._solve
        Q = self._forces(t, q, qd)
        mJ = self.m[:, None] * J
        A = J.T @ mJ
        r = J.T @ (Q - self.m * b)
        udd = self.guard.solve(A, r, u)
        return udd, q, qd, J, b, Q
        # END SOLUTION

    @contract(t=_TIME, y=_STATE)
    def rhs(self, t: float, y) -> np.ndarray:
        """dy/dt = [u̇, ü] with (JᵀMJ) ü = Jᵀ(Q − M b)."""
        self.nfev += 1
        udd = self._solve(t, y)[0]
        return np.concatenate([np.asarray(y, float)[self.k:], udd])

    @contract(u=Array(("self.k",)), t=_TIME)
    def generalized_mass(self, u, t: float = 0.0) -> np.ndarray:
        """JᵀMJ at u (SingularChartError when it is not finite: outside the chart's domain, or an overflow)."""
        u = np.asarray(u, float)
        _, _, J, _ = self._eval(t, u, np.zeros(self.k))
        with np.errstate(all="ignore"):
            A = J.T @ (self.m[:, None] * J)
        if not np.isfinite(A).all():
            raise SingularChartError(np.inf, u.tolist(), "JᵀMJ is not finite (outside the chart's domain, or an "
                                     "overflow)")
        return A

    @contract(t=_TIME, y=_STATE)
    def constraint_force(self, t: float, y) -> np.ndarray:
        """Q_C = M q̈ − Q (N, dim): the workless force that keeps the particles on the chart."""
        # BEGIN SOLUTION ReducedSystem.constraint_force
        udd, q, qd, J, b, Q = self._solve(t, y)
        return (self.m * (J @ udd + b) - Q).reshape(self.N, self.dim)
        # END SOLUTION

    # -- energy ---------------------------------------------------------------------------------
    @contract(y=_STATE, t=_TIME)
    def kinetic_energy(self, y, t: float = 0.0) -> float:
        """T = ½ q̇ᵀMq̇ of the particles (NonFiniteResult when it overflows)."""
        yp = self._particle_state(y, t)
        return float(check_result("kinetic_energy", self.particles.kinetic_energy(yp)))

    @contract(y=_STATE, t=_TIME)
    def potential_energy(self, y, t: float = 0.0) -> float:
        """ΣV of the force effects that have a potential (NonFiniteResult when it overflows)."""
        yp = self._particle_state(y, t)
        return float(check_result("potential_energy", sum(e.potential_energy(yp) for e in self.forces
                                                          if callable(getattr(e, "potential_energy", None)))))

    @contract(y=_STATE, t=_TIME)
    def energy(self, y, t: float = 0.0) -> float:
        """E = T + ΣV of the particles at the state's q(u), q̇."""
        return float(check_result("energy", self.kinetic_energy(y, t) + self.potential_energy(y, t)))

    @contract(t_end=Real(gt=0), h=Real(gt=0), method=METHOD, y0=Opt(_STATE), record_every=Int(ge=1),
              max_steps=Opt(Int(ge=1)))
    def simulate(self, t_end: float, h: float, method: str = "implicit_midpoint", y0: Any = None,
                 record_every: int = 1, max_steps: int | None = None):
        """Fixed-step run (:func:`simulate_fixed`) recording E; returns a :class:`pbanim.results.SimResult`
        (``max_steps``: the cap on the number of steps, checked before the first)."""
        return simulate_fixed(self.rhs, self.state() if y0 is None else y0, t_end, h, method,
                              energy=self.energy, record_every=record_every, max_steps=max_steps)
