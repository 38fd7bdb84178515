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
  (monomials of Jᵢ, by the coordinates they contain), never of the whole Lagrangian. The products
  are multiplied out monomial by monomial and equal monomials are collected by summing their numeric
  coefficients in a dict (no ``simplify``): a chain's M_jk keeps O(1) terms and c_j O(n) terms.
  Compilation (:mod:`pbanim.reduced.codegen`) evaluates the distinct monomial factors once (sympy
  ``lambdify`` with CSE) and every entry of M and f as a coefficient-weighted sum of their products
  (one ``np.bincount``).
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
``import pbanim.reduced.lagrangian``. Derived and compiled models are cached per process (:func:`lagrangian_system`).
The symbolic matrices ``M``, ``velocity_terms``, ``potential_gradient`` are assembled from the collected
terms on first access (the numeric path never needs them).

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
from dataclasses import dataclass
from fractions import Fraction
from functools import cached_property
from typing import Any, Sequence

import numpy as np
import sympy

from .codegen import LagrangianSystem, compile_equations
from .chart import _point_kinematics_cached, point_kinematics, validate_coords
from .inputs import COORDS, SYMBOL, Expr, Hashable, PointMass, nonreal, validate_points
from ..contracts import Array, Choice, Either, Obj, Opt, Seq, contract
from ..errors import InvalidInput

__all__ = ["EulerLagrangeEquations", "LagrangianSystem", "derive_equations", "compile_equations",
           "lagrangian_system", "clear_cache", "cache_info", "energy_rate", "speeds_for"]


def _num(c):
    """A sympy number as an exact Python number (int/Fraction) or a float, for fast accumulation."""
    if c.is_Integer:
        return int(c)
    if c.is_Rational:
        return Fraction(int(c.p), int(c.q))
    if c.is_number and c.is_real:
        return float(c)
    raise InvalidInput(f"coefficients must be real numbers, got {c!r}; substitute numbers for parameters")


def _sym(v):
    return sympy.Rational(v.numerator, v.denominator) if isinstance(v, Fraction) else sympy.sympify(v)


@dataclass
class EulerLagrangeEquations:
    """Euler–Lagrange equations M(u) ü = f(u, u̇, t), f = Q_nc − c − ∂V/∂u, in collected-term form.

    Attributes
    ----------
    coords, speeds : tuple of sympy.Symbol
    t : sympy.Symbol or None
        The time symbol of a rheonomic (time-dependent) model.
    M_terms : dict (j, k) → {(r₁, r₂): coefficient}, j ≤ k
        M_jk = Σ coefficient · r₁ · r₂ (kinematic route).
    c_terms : list of {(r₁, r₂): coefficient}
        Velocity-product terms c_j, same form.
    G_terms : list of {r: coefficient}
        Gravity's part of ∂V/∂u_j = Σ coefficient · r.
    M_extra, c_extra, G_extra : sympy.Matrix or None
        Parts given as whole expressions (energy route, extra T, user V).
    forces : sympy.Matrix (n, 1)
        Generalized non-conservative forces Q_nc.
    T, V, T0 : sympy.Expr
        Kinetic and potential energy; T0 is T at u̇ = 0 (non-zero only for moving charts).
    route : str
    derivation_time : float
        Seconds spent deriving (not compiling).

    The properties ``M``, ``velocity_terms``, ``potential_gradient`` and ``forcing`` return sympy
    matrices (assembled on first access).
    """

    coords: tuple
    speeds: tuple
    t: Any
    M_terms: dict
    c_terms: list
    G_terms: list
    M_extra: Any
    c_extra: Any
    G_extra: Any
    forces: Any
    T: Any
    V: Any
    T0: Any
    route: str
    derivation_time: float = 0.0

    @property
    def n(self) -> int:
        return len(self.coords)

    @cached_property
    def M(self):
        """Generalized mass M(u) (sympy, symmetric)."""
        n = self.n
        M = sympy.zeros(n, n)
        for (j, k), acc in self.M_terms.items():
            M[j, k] = M[k, j] = sympy.Add(*[_sym(v) * a * b for (a, b), v in acc.items() if v != 0])
        return M + self.M_extra if self.M_extra is not None else M

    @cached_property
    def velocity_terms(self):
        """c(u, u̇, t) (sympy column)."""
        c = sympy.Matrix([sympy.Add(*[_sym(v) * a * b for (a, b), v in acc.items() if v != 0])
                          for acc in self.c_terms]) if self.c_terms else sympy.zeros(self.n, 1)
        return c + self.c_extra if self.c_extra is not None else c

    @cached_property
    def potential_gradient(self):
        """∂V/∂u (sympy column)."""
        G = sympy.Matrix([sympy.Add(*[_sym(v) * a for a, v in acc.items() if v != 0]) for acc in self.G_terms]) \
            if self.G_terms else sympy.zeros(self.n, 1)
        return G + self.G_extra if self.G_extra is not None else G

    @property
    def forcing(self):
        """f = Q_nc − c − ∂V/∂u (sympy column)."""
        return self.forces - self.velocity_terms - self.potential_gradient


_POINTS = Opt(Seq(PointMass()))
_GRAVITY = Opt(Either(Array((None,)), Seq(Expr(), min_len=1, max_len=3)))
_DERIVE = dict(coords=COORDS, points=_POINTS, T=Opt(Expr()), V=Expr(), gravity=_GRAVITY, forces=Opt(Seq(Expr())),
               t=Opt(SYMBOL), route=Choice(("kinematic", "energy")))


@contract(**_DERIVE)
def derive_equations(coords: Sequence, points: Sequence | None = None, *, T=None, V=0, gravity=None,
                     forces=None, t=None, route: str = "kinematic") -> EulerLagrangeEquations:
    """Derive M(u), c(u, u̇, t), ∂V/∂u and Q_nc from point-mass kinematics and/or T and V.

    Parameters
    ----------
    coords : list of sympy.Symbol
        Generalized coordinates u (plain symbols).
    points : list of (mass, position), optional
        Point masses (positive numbers) with positions rᵢ(u, t) (sequences of 1–3 sympy expressions).
    T : sympy expression, optional
        Extra kinetic energy in u, u̇ (rates named ``<coord>_dot``: :func:`speeds_for`), added to the
        points' ½Σmᵢ|ṙᵢ|².
    V : sympy expression
        Extra potential energy in u (and t).
    gravity : sequence of numbers, optional
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
    if points is None and T is None:
        raise InvalidInput("give points (point masses and their positions) or T (a kinetic energy), got neither")
    pts = validate_points(points or [])
    n = len(coords)
    dim = len(pts[0][1]) if pts else 0
    g = None
    if gravity is not None:
        g = [sympy.sympify(x) for x in gravity]
        if len(g) != dim:
            raise InvalidInput(f"gravity must have {dim} components (the points' dimension), got {len(g)}")
        if any(not x.is_number or nonreal(x) for x in g):
            raise InvalidInput(f"gravity must be finite real numbers, got {list(gravity)!r}")
        g = [_num(x) for x in g]
    # the same derivation as ReducedSystem.from_sympy of these positions (derived once, shared)
    kin = _point_kinematics_cached([r[d] for _, r in pts for d in range(dim)], coords, t)
    speeds = kin.speeds
    masses = [_num(m) for m, _ in pts for _ in range(dim)]
    gd = [g[d] for _ in pts for d in range(dim)] if g is not None else None
    Vx = sympy.sympify(V)
    if g is not None:
        Vx = Vx - sympy.Add(*[_sym(m * gg) * e for m, gg, e in
                              zip(masses, gd, [r[d] for _, r in pts for d in range(dim)]) if gg != 0])
    T_pts = sympy.Add(*[_sym(m) * v * v for m, v in zip(masses, kin.qdot)]) / 2
    split: dict = {}

    def cm(x):
        r = split.get(x)
        if r is None:
            c, rest = x.as_coeff_Mul()
            r = split[x] = (_num(c), rest)
        return r

    Macc: dict = {(j, k): {} for j in range(n) for k in range(j, n)}
    cacc: list[dict] = [{} for _ in range(n)]
    Gacc: list[dict] = [{} for _ in range(n)]
    for row_i, (m, Jt, bt) in enumerate(zip(masses, kin.J_terms, kin.b_terms)):
        nz = [j for j in range(n) if Jt[j]]
        gg = gd[row_i] if gd is not None else 0
        for a, j in enumerate(nz):
            for x in Jt[j]:
                cx, rx = cm(x)
                if gg != 0:  # ∂V/∂u_j = −Σ m g_d J_dj
                    Gacc[j][rx] = Gacc[j].get(rx, 0) - m * gg * cx
                if route != "kinematic":
                    continue
                mcx = m * cx
                for k in nz[a:]:
                    accM = Macc[(j, k)]
                    for z in Jt[k]:
                        cz, rz = cm(z)
                        key = (rx, rz) if (j != k or hash(rx) <= hash(rz)) else (rz, rx)
                        accM[key] = accM.get(key, 0) + mcx * cz
                accc = cacc[j]
                for z in bt:
                    cz, rz = cm(z)
                    accc[(rx, rz)] = accc.get((rx, rz), 0) + mcx * cz
    Tx = sympy.sympify(T) if T is not None else sympy.S.Zero
    if route == "energy":
        Tx = Tx + T_pts
    M_extra = c_extra = None
    if Tx != 0:  # energy route (or an extra T): M = ∂²T/∂u̇², c = (∂p/∂u)u̇ + ∂p/∂t − ∂T/∂u
        p = [Tx.diff(s) for s in speeds]
        M_extra, c_extra = sympy.zeros(n, n), sympy.zeros(n, 1)
        for j in range(n):
            for k in range(j, n):
                M_extra[j, k] = M_extra[k, j] = p[j].diff(speeds[k])
            extra = sympy.Add(*[p[j].diff(coords[k]) * speeds[k] for k in range(n)])
            if t is not None:
                extra += p[j].diff(t)
            c_extra[j] = extra - Tx.diff(coords[j])
    Vu = sympy.sympify(V)
    G_extra = sympy.Matrix([Vu.diff(q) for q in coords]) if Vu != 0 else None
    if forces is None:
        Qnc = sympy.zeros(n, 1)
    else:
        fl = list(forces)
        if len(fl) != n:
            raise InvalidInput(f"forces must have one entry per coordinate ({n}), got {len(fl)}")
        Qnc = sympy.Matrix([sympy.sympify(f) for f in fl])
    Ttot = Tx + T_pts if route == "kinematic" else Tx
    T0 = Ttot.subs({s: 0 for s in speeds}) if t is not None else sympy.S.Zero
    free = Qnc.free_symbols | Vu.free_symbols | Tx.free_symbols
    stray = free - set(coords) - set(speeds) - {t}
    if stray:
        raise InvalidInput(f"the model has symbols that are neither coordinates, speeds nor t: "
                         f"{sorted(map(str, stray))}; substitute numbers for parameters first")
    return EulerLagrangeEquations(coords, speeds, t, Macc if route == "kinematic" else {},
                                  cacc if route == "kinematic" else [], Gacc, M_extra, c_extra, G_extra, Qnc,
                                  Ttot, Vx, T0, route, time.perf_counter() - t0)


@contract(coords=COORDS)
def speeds_for(coords: Sequence) -> tuple:
    """The rate symbols u̇ used by :func:`derive_equations`: ``<name>_dot`` for each coordinate.

    >>> import sympy as sp
    >>> speeds_for(sp.symbols("x theta"))
    (x_dot, theta_dot)
    """
    return tuple(sympy.Symbol(f"{c.name}_dot") for c in validate_coords(list(coords)))


@contract(eqs=Obj(EulerLagrangeEquations))
def energy_rate(eqs: EulerLagrangeEquations):
    """Symbolic dE/dt along the equations, E = T + V (scleronomic, Q_nc = 0 ⇒ it simplifies to 0).

    dE/dt = u̇ᵀMü + ½u̇ᵀṀu̇ + ∂V/∂u·u̇ with Mü = f: u̇ᵀ(Q_nc − c) + ½u̇ᵀṀu̇ (no inverse of M needed).
    """
    ud = sympy.Matrix(eqs.speeds)
    Mdot = sympy.zeros(eqs.n, eqs.n)
    for k, q in enumerate(eqs.coords):
        Mdot += eqs.M.diff(q) * eqs.speeds[k]
    return (ud.T * Mdot * ud)[0] / 2 - (ud.T * eqs.velocity_terms)[0] + (ud.T * eqs.forces)[0]


_CACHE: dict[Any, LagrangianSystem] = {}
_STATS = {"hits": 0, "misses": 0}


def _freeze(x):
    if isinstance(x, (list, tuple)):
        return tuple(_freeze(v) for v in x)
    if isinstance(x, np.ndarray):
        return tuple(x.tolist())
    return sympy.sympify(x) if not isinstance(x, (str, type(None))) else x


@contract(coords=COORDS, points=_POINTS, key=Hashable())
def lagrangian_system(coords: Sequence, points: Sequence | None = None, *, key: Any = None,
                      **kwargs: Any) -> LagrangianSystem:
    """Derive (:func:`derive_equations`) and compile (:func:`compile_equations`) once per process.

    The cache key is ``key`` if given (e.g. ``("n_link", 10, masses, lengths, g)``), else the model's
    sympy inputs themselves (hashable), together with every keyword option (gravity, route, t, ...), so
    a call that changes any of them derives anew. A cache hit returns the same compiled object. The
    keyword options are checked by :func:`derive_equations`'s contract on every call, before the cache
    is read (they come from the models inside pbanim too).
    """
    unknown = sorted(set(kwargs) - set(_DERIVE))
    if unknown:
        raise InvalidInput(f"lagrangian_system: unknown options {unknown}; the options of derive_equations are "
                           f"{sorted(set(_DERIVE) - {'coords', 'points'})}")
    _, kwargs = derive_equations.__contract__.check((), dict(kwargs))
    options = tuple(sorted((k, _freeze(v)) for k, v in kwargs.items()))
    if key is None:
        key = (_freeze(list(coords)), _freeze([(m, list(r)) for m, r in (points or [])]), options)
    else:   # the caller's key names the model; the options that change the equations are always part of it
        key = (key, options)
    hit = _CACHE.get(key)
    if hit is not None:
        _STATS["hits"] += 1
        return hit
    _STATS["misses"] += 1
    sysl = compile_equations(derive_equations(coords, points, **kwargs))
    _CACHE[key] = sysl
    return sysl


def clear_cache() -> None:
    """Forget every derived model (benchmarks use it to time a cold derivation)."""
    _CACHE.clear()
    _STATS.update(hits=0, misses=0)


def cache_info() -> dict[str, int]:
    """{"size", "hits", "misses"} of the per-process model cache."""
    return {"size": len(_CACHE), **_STATS}
