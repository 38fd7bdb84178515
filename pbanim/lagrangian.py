"""Lagrangian mechanics with sympy: L = T − V → Euler–Lagrange equations → a fast numeric rhs (ch04).

Governing equations (the lecture's slide "Lagrangian Mechanics")
----------------------------------------------------------------
For generalized coordinates u (one equation per coordinate) and L(u, u̇, t) = T − V,

    d/dt(∂L/∂u̇ⱼ) − ∂L/∂uⱼ = Q_nc,ⱼ      ⇔      M(u) ü + c(u, u̇, t) + ∂V/∂u = Q_nc

with the generalized mass M = ∂²T/∂u̇∂u̇ and the velocity-product (Coriolis / centrifugal) terms
c = (∂p/∂u) u̇ + ∂p/∂t − ∂T/∂u, p = ∂T/∂u̇. For T = ½u̇ᵀM(u)u̇ this is c = Ṁu̇ − ½∂(u̇ᵀMu̇)/∂u
(Christoffel symbols of the first kind contracted with u̇ twice).

Two derivation routes, giving the same equations (``tests/test_lagrangian.py`` checks it):

* **kinematic** (default for point masses rᵢ(u, t)): Jᵢ = ∂rᵢ/∂u, M = Σ Jᵢᵀ mᵢ Jᵢ and c = Σ Jᵢᵀ mᵢ bᵢ with
  bᵢ = J̇ᵢu̇ + 2∂Jᵢ/∂t u̇ + ∂²rᵢ/∂t² — the reduced-coordinate equation (JᵀMJ)ü + (JᵀMJ̇)u̇ = JᵀQ of
  :mod:`pbanim.reduced`, derived symbolically. Only derivatives of small expressions are taken
  (Jᵢ entries, whose free symbols are known), never of the whole Lagrangian: an n-link chain costs
  O(n³) small terms, and common-subexpression elimination (CSE) shares them at compile time.
* **energy** (any T(u, u̇, t), e.g. a rigid link's ½Iθ̇²): M = Hessian of T in u̇, c from the formula above.

Notation
--------
=========  =======================  ============  =================================================
symbol     code                     shape         meaning
=========  =======================  ============  =================================================
u, u̇       ``coords``, ``speeds``   (n,)          generalized coordinates and their rates (sympy)
mᵢ, rᵢ     ``points``               (dim,) each   point masses and their positions rᵢ(u, t)
M(u)       ``M``                    (n, n)        generalized mass, symmetric positive definite
c          ``velocity_terms``       (n,)          Coriolis / centrifugal (and frame) terms
∂V/∂u      ``potential_gradient``   (n,)          gravity and other conservative forces
Q_nc       ``forces``               (n,)          generalized non-conservative forces
f          ``forcing``              (n,)          Q_nc − c − ∂V/∂u, so M ü = f
y          ``y``                    (2n,)         numeric state [u, u̇]
=========  =======================  ============  =================================================

Limiting cases
--------------
* One point mass on a rod (simple pendulum): M = mL², c = 0, ∂V/∂u = mgL sin θ; period 4√(L/g)K(m),
  m = sin²(θ₀/2) (ORACLES A5).
* Scleronomic, conservative: E = T + V is conserved and dE/dt along the equations is 0 identically
  (symbolic check, ORACLES B7). Rheonomic (bead on a rotating hoop): E is not conserved, the Jacobi
  integral h = ½u̇ᵀMu̇ − T₀ + V is.
* A chart where M(u) loses rank (spherical pendulum at the pole) raises
  :class:`pbanim.errors.SingularChartError` (ORACLES B6) rather than returning NaN.

This module imports sympy at its top and is therefore **not** imported by ``import pbanim``; use
``import pbanim.lagrangian``. Derived and compiled models are cached per process (:func:`lagrangian_system`).

References
----------
H. Goldstein, *Classical Mechanics*, ch. 1–2 (Euler–Lagrange equations, Jacobi integral). R. Featherstone,
*Rigid Body Dynamics Algorithms* (2008), ch. 2 (joint-space inertia as ΣJᵀmJ). A. Witkin, D. Baraff,
*Physically Based Modeling* (SIGGRAPH 2001 notes). E. Hairer, C. Lubich, G. Wanner, *Geometric Numerical
Integration*, §VI (why implicit midpoint for M(u) ≠ const). T. Kane, D. Levinson, *Dynamics* (1985) and
sympy.physics.mechanics (the baselines of ``pbanim bench reduced``).

Examples
--------
>>> import sympy as sp
>>> th = sp.Symbol("theta")
>>> sysl = lagrangian_system([th], points=[(1.0, [sp.sin(th), -sp.cos(th)])], gravity=[0.0, -9.81])
>>> sysl.rhs(0.0, [np.pi / 2, 0.0])            # released from horizontal: θ̈ = −g/L
array([ 0.  , -9.81])
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from typing import Any, Callable, Sequence

import numpy as np
import sympy

from .errors import SingularChartError
from .reduced_chart import ChartGuard, point_kinematics, validate_coords

__all__ = ["EulerLagrangeEquations", "LagrangianSystem", "derive_equations", "compile_equations",
           "lagrangian_system", "clear_cache", "cache_info", "energy_rate"]


@dataclass
class EulerLagrangeEquations:
    """Symbolic Euler–Lagrange equations M(u) ü = f(u, u̇, t), f = Q_nc − c − ∂V/∂u.

    Attributes
    ----------
    coords, speeds : tuple of sympy.Symbol
    t : sympy.Symbol or None
        The time symbol of a rheonomic (time-dependent) model.
    M : sympy.Matrix (n, n)
    velocity_terms, potential_gradient, forces : sympy.Matrix (n, 1)
    T, V : sympy.Expr
        Kinetic and potential energy; ``T0`` is T at u̇ = 0 (non-zero only for moving frames).
    route : str
        "kinematic" or "energy".
    derivation_time : float
        Seconds spent deriving (not compiling).
    """

    coords: tuple
    speeds: tuple
    t: Any
    M: Any
    velocity_terms: Any
    potential_gradient: Any
    forces: Any
    T: Any
    V: Any
    T0: Any
    route: str
    derivation_time: float = 0.0

    @property
    def n(self) -> int:
        return len(self.coords)

    @property
    def forcing(self):
        """f = Q_nc − c − ∂V/∂u as a sympy column."""
        return self.forces - self.velocity_terms - self.potential_gradient


def _validate_points(points, dim_hint=None) -> list:
    out, dim = [], dim_hint
    for k, item in enumerate(points):
        if not (isinstance(item, (list, tuple)) and len(item) == 2):
            raise ValueError(f"points[{k}] must be a pair (mass, position), got {item!r}")
        m, r = item
        r = sympy.Matrix(list(r) if not isinstance(r, sympy.MatrixBase) else list(r))
        if dim is None:
            dim = r.shape[0]
        if r.shape[0] != dim or dim not in (1, 2, 3):
            raise ValueError(f"points[{k}] position must have {dim} components (all points share one "
                             f"dimension, 1–3), got shape {r.shape}")
        m = sympy.sympify(m)
        if m.is_number and not m > 0:
            raise ValueError(f"mass must be positive, got {m} for points[{k}]")
        out.append((m, r))
    return out


def derive_equations(coords: Sequence, points: Sequence | None = None, *, T=None, V=0, gravity=None,
                     forces=None, t=None, route: str = "kinematic") -> EulerLagrangeEquations:
    """Derive M(u), c(u, u̇, t), ∂V/∂u and Q_nc from point-mass kinematics and/or T and V.

    Parameters
    ----------
    coords : list of sympy.Symbol
        Generalized coordinates u (plain symbols).
    points : list of (mass, position), optional
        Point masses with positions rᵢ(u, t) (sequences of 1–3 sympy expressions).
    T : sympy expression, optional
        Extra kinetic energy in u, u̇ (the symbols ``speeds`` are named ``<coord>_dot``; obtain them
        with :func:`speeds_for`), added to the points' ½Σmᵢ|ṙᵢ|².
    V : sympy expression
        Potential energy in u (and t).
    gravity : sequence of float, optional
        Uniform g (shape (dim,)) acting on the points: V += −Σ mᵢ g·rᵢ.
    forces : sequence of n sympy expressions, optional
        Generalized non-conservative forces Q_nc(u, u̇, t).
    t : sympy.Symbol, optional
        Time symbol, for positions or energies that depend on time explicitly.
    route : {"kinematic", "energy"}
        "kinematic" builds M = ΣJᵀmJ and c = ΣJᵀm b from the points; "energy" differentiates T.

    Examples
    --------
    >>> import sympy as sp
    >>> a, b = sp.symbols("a b")
    >>> eq = derive_equations([a, b], [(1, [sp.sin(a), -sp.cos(a)]),
    ...                                (1, [sp.sin(a) + sp.sin(b), -sp.cos(a) - sp.cos(b)])])
    >>> sp.simplify(eq.M[0, 1] - sp.cos(a - b))
    0
    """
    t0 = time.perf_counter()
    coords = validate_coords(coords)
    if route not in ("kinematic", "energy"):
        raise ValueError(f"route must be 'kinematic' or 'energy', got {route!r}")
    if t is not None and not isinstance(t, sympy.Symbol):
        raise ValueError(f"t must be a sympy Symbol or None, got {t!r}")
    if points is None and T is None:
        raise ValueError("give points (point masses and their positions) or T (a kinetic energy), got neither")
    pts = _validate_points(points or [])
    n = len(coords)
    dim = pts[0][1].shape[0] if pts else 0
    Vx = sympy.sympify(V)
    if gravity is not None:
        g = [sympy.sympify(x) for x in gravity]
        if len(g) != dim:
            raise ValueError(f"gravity must have {dim} components (the points' dimension), got {len(g)}")
        Vx = Vx - sympy.Add(*[m * g[d] * r[d] for m, r in pts for d in range(dim)])
    kin = point_kinematics([r[d] for _, r in pts for d in range(dim)], coords, t)
    speeds = kin.speeds
    masses = [m for m, _ in pts for _ in range(dim)]
    T_pts = sympy.Add(*[m * v * v for m, v in zip(masses, kin.qdot)]) / 2
    M = sympy.zeros(n, n)
    c = sympy.zeros(n, 1)
    Tx = sympy.sympify(T) if T is not None else sympy.S.Zero
    if route == "kinematic":
        # M = Σ Jᵢᵀ mᵢ Jᵢ and c = Σ Jᵢᵀ mᵢ bᵢ, term lists summed once (sympy Add of many args)
        Mt = {(j, k): [] for j in range(n) for k in range(j, n)}
        ct: list[list] = [[] for _ in range(n)]
        for m, row, b in zip(masses, kin.J, kin.b):
            nz = [j for j in range(n) if row[j] != 0]
            for a, j in enumerate(nz):
                for k in nz[a:]:
                    Mt[(j, k)].append(m * row[j] * row[k])
                if b != 0:
                    ct[j].append(m * row[j] * b)
        for (j, k), terms in Mt.items():
            M[j, k] = M[k, j] = sympy.Add(*terms)
        c = sympy.Matrix([sympy.Add(*terms) for terms in ct])
    else:
        Tx = Tx + T_pts
    if Tx != 0:  # energy route (or an extra T): M = ∂²T/∂u̇², c = (∂p/∂u)u̇ + ∂p/∂t − ∂T/∂u
        p = [Tx.diff(s) for s in speeds]
        for j in range(n):
            for k in range(j, n):
                M[j, k] = M[k, j] = M[j, k] + p[j].diff(speeds[k])
            extra = sympy.Add(*[p[j].diff(coords[k]) * speeds[k] for k in range(n)])
            if t is not None:
                extra += p[j].diff(t)
            c[j] = c[j] + extra - Tx.diff(coords[j])
    G = sympy.Matrix([Vx.diff(q) for q in coords])
    if forces is None:
        Qnc = sympy.zeros(n, 1)
    else:
        fl = list(forces)
        if len(fl) != n:
            raise ValueError(f"forces must have one entry per coordinate ({n}), got {len(fl)}")
        Qnc = sympy.Matrix([sympy.sympify(f) for f in fl])
    Ttot = Tx + T_pts if route == "kinematic" else Tx
    T0 = Ttot.subs({s: 0 for s in speeds}) if t is not None else sympy.S.Zero
    stray = (M.free_symbols | c.free_symbols | G.free_symbols | Qnc.free_symbols | Ttot.free_symbols) \
        - set(coords) - set(speeds) - {t}
    if stray:
        raise ValueError(f"the model has symbols that are neither coordinates, speeds nor t: "
                         f"{sorted(map(str, stray))}; substitute numbers for parameters first")
    return EulerLagrangeEquations(coords, speeds, t, M, c, G, Qnc, Ttot, Vx, T0, route,
                                  time.perf_counter() - t0)


def speeds_for(coords: Sequence) -> tuple:
    """The rate symbols u̇ used by :func:`derive_equations`: ``<name>_dot`` for each coordinate.

    >>> import sympy as sp
    >>> speeds_for(sp.symbols("x theta"))
    (x_dot, theta_dot)
    """
    return tuple(sympy.Symbol(f"{c.name}_dot") for c in coords)


def energy_rate(eqs: EulerLagrangeEquations):
    """Symbolic dE/dt along the equations, E = T + V (scleronomic, Q_nc = 0 ⇒ it simplifies to 0).

    dE/dt = u̇ᵀMü + ½u̇ᵀṀu̇ + ∂V/∂u·u̇ with ü replaced by M⁻¹f: u̇ᵀ(f + ∂V/∂u) + ½u̇ᵀṀu̇ = ½u̇ᵀṀu̇ − u̇ᵀc
    (for Q_nc = 0), computed without inverting M.
    """
    ud = sympy.Matrix(eqs.speeds)
    Mdot = sympy.zeros(eqs.n, eqs.n)
    for k, q in enumerate(eqs.coords):
        Mdot += eqs.M.diff(q) * eqs.speeds[k]
    return ((ud.T * Mdot * ud)[0] / 2 - (ud.T * eqs.velocity_terms)[0] + (ud.T * eqs.forces)[0])


@dataclass
class LagrangianSystem:
    """Compiled equations M(u) ü = f(u, u̇, t): a numeric rhs, mass matrix and energies.

    Attributes
    ----------
    equations : EulerLagrangeEquations
    n : int
        Number of generalized coordinates.
    compile_time : float
        Seconds to generate and compile the numeric functions (CSE + lambdify).
    guard : ChartGuard
        Condition-number check of M(u) (raises SingularChartError near a singular chart).
    """

    equations: EulerLagrangeEquations
    n: int
    compile_time: float
    _eom: Callable = field(repr=False)
    _energy: Callable = field(repr=False)
    guard: ChartGuard = field(repr=False, default_factory=ChartGuard)
    nfev: int = 0

    def __post_init__(self) -> None:
        n = self.n
        iu = np.triu_indices(n)
        pos = np.empty((n, n), dtype=np.intp)
        pos[iu] = np.arange(len(iu[0]))
        pos.T[iu] = pos[iu]
        self._sym_index, self._ntri = pos, len(iu[0])

    @property
    def derivation_time(self) -> float:
        return self.equations.derivation_time

    def _args(self, t, y):
        y = np.asarray(y, dtype=float)
        if y.shape != (2 * self.n,):
            raise ValueError(f"y must have shape ({2 * self.n},) = [u, u̇], got {y.shape}")
        a = y.tolist()
        a.insert(0, float(t))
        return a

    def mass_and_forcing(self, t: float, y) -> tuple[np.ndarray, np.ndarray]:
        """M(u) (n, n) and f(u, u̇, t) (n,) at a state y = [u, u̇]."""
        args = self._args(t, y)
        try:
            out = np.array(self._eom(*args))
        except (ValueError, ZeroDivisionError, OverflowError) as exc:   # math.sqrt(-1), 1/0 ...
            raise SingularChartError(np.inf, args[1: self.n + 1], f"the equations cannot be evaluated "
                                     f"({exc}); outside the chart's domain") from None
        return out[self._sym_index], out[self._ntri:]

    def mass_matrix(self, u, t: float = 0.0) -> np.ndarray:
        """M(u) at coordinates u (any u̇)."""
        return self.mass_and_forcing(t, np.concatenate([np.asarray(u, float), np.zeros(self.n)]))[0]

    def accelerations(self, t: float, y) -> np.ndarray:
        """ü = M⁻¹f, with the chart check of :class:`pbanim.reduced.ChartGuard`."""
        M, f = self.mass_and_forcing(t, y)
        return self.guard.solve(M, f, np.asarray(y)[: self.n])

    def rhs(self, t: float, y) -> np.ndarray:
        """dy/dt = [u̇, ü] for the integrators of :mod:`pbanim.ode`."""
        self.nfev += 1
        y = np.asarray(y, dtype=float)
        out = np.empty(2 * self.n)
        out[: self.n] = y[self.n:]
        out[self.n:] = self.accelerations(t, y)
        return out

    def energies(self, y, t: float = 0.0) -> dict[str, float]:
        """T, V, E = T + V and the Jacobi integral h = T − 2T₀ + ... (see :meth:`jacobi_integral`)."""
        T, V, T0, T1 = self._energy(*self._args(t, y))
        return {"kinetic": T, "potential": V, "energy": T + V, "jacobi": T - T1 - 2 * T0 + V}

    def energy(self, y, t: float = 0.0) -> float:
        """E = T + V at state y (conserved for scleronomic conservative models)."""
        T, V, _, _ = self._energy(*self._args(t, y))
        return float(T + V)

    def jacobi_integral(self, y, t: float = 0.0) -> float:
        """h = Σ pⱼu̇ⱼ − L = T₂ − T₀ + V, conserved when L has no explicit t (bead on a rotating hoop)."""
        return float(self.energies(y, t)["jacobi"])


def compile_equations(eqs: EulerLagrangeEquations, *, cse: bool = True) -> LagrangianSystem:
    """Compile M (upper triangle), f and the energies into scalar Python code (sympy.lambdify, CSE).

    Scalar ``math`` code with common subexpressions shared beats numpy ufunc calls on scalars by ~10×
    for these small dense models.
    """
    t0 = time.perf_counter()
    tsym = eqs.t if eqs.t is not None else sympy.Symbol("_t")
    args = [tsym, *eqs.coords, *eqs.speeds]
    n = eqs.n
    f = eqs.forcing
    outs = [eqs.M[j, k] for j in range(n) for k in range(j, n)] + [f[j] for j in range(n)]
    eom = sympy.lambdify(args, outs, modules="math", cse=cse)
    T2 = (sympy.Matrix(eqs.speeds).T * eqs.M * sympy.Matrix(eqs.speeds))[0] / 2
    T1 = (eqs.T - T2 - eqs.T0) if eqs.t is not None else sympy.S.Zero
    en = sympy.lambdify(args, [eqs.T, eqs.V, eqs.T0, T1], modules="math", cse=cse)
    return LagrangianSystem(eqs, n, time.perf_counter() - t0, eom, en)


_CACHE: dict[Any, LagrangianSystem] = {}
_STATS = {"hits": 0, "misses": 0}


def _freeze(x):
    if isinstance(x, (list, tuple)):
        return tuple(_freeze(v) for v in x)
    if isinstance(x, np.ndarray):
        return tuple(x.tolist())
    return sympy.sympify(x) if not isinstance(x, (str, type(None))) else x


def lagrangian_system(coords: Sequence, points: Sequence | None = None, *, key: Any = None,
                      **kwargs: Any) -> LagrangianSystem:
    """Derive (:func:`derive_equations`) and compile (:func:`compile_equations`) once per process.

    The cache key is ``key`` if given (e.g. ``("n_link", 10, masses, lengths, g)``), else the model's
    sympy inputs themselves (hashable). A cache hit returns the same compiled object.
    """
    if key is None:
        key = (_freeze(list(coords)), _freeze([(m, list(r)) for m, r in (points or [])]),
               tuple(sorted((k, _freeze(v)) for k, v in kwargs.items())))
    hit = _CACHE.get(key)
    if hit is not None:
        _STATS["hits"] += 1
        return hit
    _STATS["misses"] += 1
    cse = kwargs.pop("cse", True)
    sysl = compile_equations(derive_equations(coords, points, **kwargs), cse=cse)
    _CACHE[key] = sysl
    return sysl


def clear_cache() -> None:
    """Forget every derived model (benchmarks use it to time a cold derivation)."""
    _CACHE.clear()
    _STATS.update(hits=0, misses=0)


def cache_info() -> dict[str, int]:
    """{"size", "hits", "misses"} of the per-process model cache."""
    return {"size": len(_CACHE), **_STATS}
