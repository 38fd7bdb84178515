"""Compiling Euler–Lagrange equations into a fast numeric rhs (ch04; used by :mod:`pbanim.reduced.lagrangian`).

Every entry e of the outputs (the upper triangle of M, then f = Q_nc − c − ∂V/∂u) is a sum

    out_e = Σ_k C_k · a[i_k] · a[j_k]

over the distinct *factors* a (a[0] = 1; sin θⱼ, cos θⱼ, θ̇ⱼ² sin θⱼ, ... and any whole expression that
came from an energy-route or user term). The factors are compiled once with sympy's ``lambdify``
(``math`` module, common-subexpression elimination); the sums run as one ``np.bincount`` over the
term list. A chain of n links has O(n) factors and O(n²) terms, so the work per call is O(n²) numpy
flops instead of O(n³) interpreted scalar operations.

Imports sympy at its top (it is only imported through :mod:`pbanim.reduced.lagrangian`).
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from typing import Any, Callable

import numpy as np
import sympy

from ..contracts import Array, Flag, Obj, Real, contract
from ..errors import InvalidInput, NonFiniteResult, SingularChartError, check_result
from .chart import ChartGuard

__all__ = ["LagrangianSystem", "compile_equations"]

_STATE = Array(("self.n_state",))
_TIME = Real()


@dataclass
class LagrangianSystem:
    """Compiled equations M(u) ü = f(u, u̇, t): a numeric rhs, mass matrix and energies.

    Attributes
    ----------
    equations : EulerLagrangeEquations
    n : int
        Number of generalized coordinates.
    compile_time : float
        Seconds to generate and compile the numeric functions.
    guard : ChartGuard
        Condition-number check of M(u) (raises SingularChartError near a singular chart). Without a
        reference metric it Jacobi-scales M(u) at each u; the models of :mod:`pbanim.models.reduced`
        hand out their own view of a cached system with the reference set at their u0.
    nfev : int
        Right-hand-side evaluations so far.
    """

    equations: Any
    n: int
    compile_time: float
    _factors: Callable = field(repr=False)
    _terms: tuple = field(repr=False)
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

    @property
    def n_state(self) -> int:
        """Length of the state y = [u, u̇]: 2n."""
        return 2 * self.n

    def _args(self, t, y):
        y = np.asarray(y, dtype=float)
        if y.shape != (2 * self.n,):
            raise InvalidInput(f"y must have shape ({2 * self.n},) = [u, u̇], got {y.shape}")
        a = y.tolist()
        a.insert(0, float(t))
        return a

    @contract(t=_TIME, y=_STATE)
    def mass_and_forcing(self, t: float, y) -> tuple[np.ndarray, np.ndarray]:
        """M(u) (n, n) and f(u, u̇, t) (n,) at a state y = [u, u̇] (SingularChartError when not finite)."""
        M, f = self._mass_and_forcing(t, y)
        return self._finite(M, y, "M(u)"), self._finite(f, y, "f(u, u̇, t)")

    def _finite(self, value, y, what):
        if not np.isfinite(value).all():
            raise SingularChartError(np.inf, np.asarray(y, float)[: self.n].tolist(), f"{what} is not finite "
                                     "(outside the chart's domain, or an overflow)")
        return value

    def _mass_and_forcing(self, t, y):
        """M and f unchecked (the rhs's guard checks them)."""
        args = self._args(t, y)
        eidx, coef, ia, ib, nout, nfac = self._terms
        a = np.empty(nfac)
        a[0] = 1.0
        try:
            a[1:] = self._factors(*args)
        except OverflowError as exc:        # a float power past 1e308
            raise NonFiniteResult("the equations' terms", f"at y = {args[1:]} ({exc})") from None
        except (ValueError, ZeroDivisionError) as exc:   # math.sqrt(-1), 1/0 ...
            raise SingularChartError(np.inf, args[1: self.n + 1], f"the equations cannot be evaluated "
                                     f"({exc}); outside the chart's domain") from None
        with np.errstate(invalid="ignore", over="ignore"):   # inf · 0 → NaN: caught by the caller's check
            out = np.bincount(eidx, coef * a[ia] * a[ib], nout)
        return out[self._sym_index], out[self._ntri:]

    @contract(u=Array(("self.n",)), t=_TIME)
    def mass_matrix(self, u, t: float = 0.0) -> np.ndarray:
        """M(u) at coordinates u (any u̇)."""
        y = np.concatenate([np.asarray(u, float), np.zeros(self.n)])
        return self._finite(self._mass_and_forcing(t, y)[0], y, "M(u)")

    @contract(t=_TIME, y=_STATE)
    def accelerations(self, t: float, y) -> np.ndarray:
        """ü = M⁻¹f, with the chart check of :class:`pbanim.reduced.ChartGuard`."""
        M, f = self._mass_and_forcing(t, y)
        return self.guard.solve(M, f, np.asarray(y)[: self.n])

    @contract(t=_TIME, y=_STATE)
    def rhs(self, t: float, y) -> np.ndarray:
        """dy/dt = [u̇, ü] for the integrators of :mod:`pbanim.ode`."""
        self.nfev += 1
        y = np.asarray(y, dtype=float)
        out = np.empty(2 * self.n)
        M, f = self._mass_and_forcing(t, y)      # validates the shape of y first
        out[self.n:] = self.guard.solve(M, f, y[: self.n])
        out[: self.n] = y[self.n:]
        return out

    @contract(y=_STATE, t=_TIME)
    def energies(self, y, t: float = 0.0) -> dict[str, float]:
        """T, V, E = T + V and the Jacobi integral h = T₂ − T₀ + V (T = T₂ + T₁ + T₀ by degree in u̇)."""
        y = np.asarray(y, dtype=float)
        M, _ = self._mass_and_forcing(t, y)
        ud = y[self.n:]
        with np.errstate(invalid="ignore", over="ignore"):
            T2 = 0.5 * float(ud @ M @ ud)
        try:
            V, T0, T1 = self._energy(*self._args(t, y))
        except OverflowError as exc:
            raise NonFiniteResult("the energies", f"at y = {y.tolist()} ({exc})") from None
        except (ValueError, ZeroDivisionError) as exc:
            raise SingularChartError(np.inf, y[: self.n].tolist(), f"the energies cannot be evaluated ({exc}); "
                                     "outside the chart's domain") from None
        T = T2 + T1 + T0
        out = {"kinetic": T, "potential": V, "energy": T + V, "jacobi": T2 - T0 + V}
        check_result("energies", list(out.values()), f"at y = {y.tolist()}")
        return out

    @contract(y=_STATE, t=_TIME)
    def energy(self, y, t: float = 0.0) -> float:
        """E = T + V at state y (conserved for scleronomic conservative models)."""
        return float(self.energies(y, t)["energy"])

    @contract(y=_STATE, t=_TIME)
    def jacobi_integral(self, y, t: float = 0.0) -> float:
        """h = Σ pⱼu̇ⱼ − L = T₂ − T₀ + V, conserved when L has no explicit t (bead on a rotating hoop)."""
        return float(self.energies(y, t)["jacobi"])


@contract(eqs=Obj("pbanim.reduced.lagrangian:EulerLagrangeEquations"), cse=Flag())
def compile_equations(eqs, *, cse: bool = True) -> LagrangianSystem:
    """Compile the collected terms of ``eqs`` (see the module docstring) into a :class:`LagrangianSystem`."""
    t0 = time.perf_counter()
    tsym = eqs.t if eqs.t is not None else sympy.Symbol("_t")
    args = [tsym, *eqs.coords, *eqs.speeds]
    n = eqs.n
    factors: list = [sympy.S.One]
    index: dict = {sympy.S.One: 0}

    def fid(x):
        i = index.get(x)
        if i is None:
            i = index[x] = len(factors)
            factors.append(x)
        return i

    E, C, IA, IB = [], [], [], []

    def add(e, coef, x, z=sympy.S.One):
        if coef != 0 and x != 0 and z != 0:
            E.append(e)
            C.append(float(coef))
            IA.append(fid(x))
            IB.append(fid(z))

    tri = [(j, k) for j in range(n) for k in range(j, n)]
    ntri = len(tri)
    for e, jk in enumerate(tri):
        for (r1, r2), v in eqs.M_terms.get(jk, {}).items():
            add(e, v, r1, r2)
        if eqs.M_extra is not None:
            add(e, 1, eqs.M_extra[jk])
    for j in range(n):
        e = ntri + j
        if eqs.c_terms:
            for (r1, r2), v in eqs.c_terms[j].items():
                add(e, -v, r1, r2)
        for r, v in eqs.G_terms[j].items():
            add(e, -v, r)
        if eqs.c_extra is not None:
            add(e, -1, eqs.c_extra[j])
        if eqs.G_extra is not None:
            add(e, -1, eqs.G_extra[j])
        add(e, 1, eqs.forces[j])
    fac = sympy.lambdify(args, factors[1:], modules="math", cse=cse) if len(factors) > 1 else (lambda *a: [])
    terms = (np.array(E, dtype=np.intp), np.array(C), np.array(IA, dtype=np.intp), np.array(IB, dtype=np.intp),
             ntri + n, len(factors))
    zero = {s: 0 for s in eqs.speeds}
    T1 = (sympy.Add(*[eqs.T.diff(s).subs(zero) * s for s in eqs.speeds]) if eqs.t is not None
          else sympy.S.Zero)
    en = sympy.lambdify(args, [eqs.V, eqs.T0, T1], modules="math", cse=cse)
    return LagrangianSystem(eqs, n, time.perf_counter() - t0, fac, terms, en)
