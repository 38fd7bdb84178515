"""Chart tools for reduced coordinates (ch04): the singular-chart guard, a finite-difference check of
J and J̇u̇ for hand-written charts, symbolic point kinematics, and a fixed-step runner.

The guard (ORACLES B6)
----------------------
A chart q(u) is singular where JᵀMJ loses rank (spherical pendulum at the pole) or where J blows up
(bead on a circle parametrized by x at x = ±R: JᵀMJ = mR²/(R² − x²) → ∞). Both show as a large
condition number of the generalized mass *measured in the metric of a reference configuration*:
with D = diag(A_ref)^(−1/2) and Ã = D A D,

    κ = max(‖Ã‖₁, 1) · max(‖Ã⁻¹‖₁, 1)        (= the 1-norm condition number of diag(Ã, I)),

scale-free (units of u do not matter) and meaningful for one coordinate (κ = max(a, 1/a) for a scalar
a = A/A_ref). ‖Ã⁻¹‖₁ is LAPACK's estimate (``dpocon``) from the Cholesky factor, O(k²) after the O(k³/3)
factorization that the solve needs anyway. Rounding errors in ü grow like κ·ε, so the default bound
κ ≤ 1e8 keeps about half the digits. A non-finite J, b or Q (outside the chart's domain) also raises.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass
from typing import Any, Callable, Sequence

import numpy as np
from scipy.linalg import lapack

from ..contracts import Array, Choice, Func, Int, Opt, Real, contract, unchecked
from ..errors import InvalidInput, SingularChartError
from .inputs import COORDS, EXPRESSIONS, SYMBOL, nonreal
from ..derivatives import central_jacobian, directional_derivative

_potrf, _pocon, _potrs = lapack.dpotrf, lapack.dpocon, lapack.dpotrs
_addred, _maxred = np.add.reduce, np.maximum.reduce

__all__ = ["ChartGuard", "ChartCheck", "check_chart", "PointKinematics", "point_kinematics", "simulate_fixed",
           "validate_coords"]


_GUARD_SQUARE = Array(("k", "k"))


class ChartGuard:
    """Solve A ü = r for the generalized mass A = JᵀMJ, raising SingularChartError when κ > max_cond.

    Examples
    --------
    >>> g = ChartGuard(max_cond=1e6); g.set_reference(np.diag([2.0, 8.0]))
    >>> g.solve(np.diag([2.0, 8.0]), np.array([2.0, 8.0]), u=[0.0, 0.0])
    array([1., 1.])
    >>> g.solve(np.diag([2.0, 8e-7]), np.array([2.0, 8.0]), u=[0.0, 1e-4])
    Traceback (most recent call last):
    ...
    pbanim.errors.SingularChartError: reduced coordinates are near a singular chart: cond(JᵀMJ) = 1.000e+07 ...
    """

    @contract(max_cond=Real(gt=1))
    def __init__(self, max_cond: float = 1e8) -> None:
        self.max_cond = float(max_cond)
        self.d: np.ndarray | None = None
        self.last_cond: float | None = None      # κ of the last solve (None before the first)

    @contract(A_ref=_GUARD_SQUARE)
    def set_reference(self, A_ref) -> None:
        """Use diag(A_ref) as the metric's scale (set at the initial state by the systems).

        Without a reference, κ is that of A Jacobi-scaled by its own diagonal at each u: it detects rank
        loss but not a metric that blows up as a whole (a 1×1 A); the result never depends on which
        configuration was evaluated first."""
        dg = np.diag(np.asarray(A_ref, float)).copy()
        if not np.all(np.isfinite(dg)) or np.any(dg <= 0):
            raise SingularChartError(np.inf, None, f"the reference generalized mass has diagonal {dg}")
        self.d = 1.0 / np.sqrt(dg)
        self._dd = self.d[:, None] * self.d[None, :]

    @contract(A=_GUARD_SQUARE)
    def condition(self, A) -> float:
        """κ of A (see the module docstring); inf if A is not finite or not positive definite."""
        return self._factor(np.asarray(A, float))[1]

    def _factor(self, A):
        """(Cholesky factor of the scaled A or None, κ, the scale d)."""
        if self.d is None:   # no reference: Jacobi-scale A at u itself (never latch the first u evaluated)
            dg = np.diag(A)
            if not np.all(dg > 0):
                return None, np.inf, None
            d = 1.0 / np.sqrt(dg)
            At = A * (d[:, None] * d[None, :])
        else:
            d = self.d
            if A.shape != self._dd.shape:
                raise InvalidInput(f"ChartGuard: A must have the shape {self._dd.shape} of the reference A_ref, "
                                   f"got {A.shape}")
            At = A * self._dd
        anorm = float(_maxred(_addred(np.abs(At), 0)))     # ‖Ã‖₁ (ufunc reductions: no wrapper cost)
        if not math.isfinite(anorm):
            return None, np.inf, d
        c, info = _potrf(At, lower=0, clean=0, overwrite_a=1)
        if info != 0:
            return None, np.inf, d
        rc, info = _pocon(c, 1.0)                        # with anorm = 1: rc = 1/‖Ã⁻¹‖₁ (estimate)
        if info != 0 or rc <= 0:
            return None, np.inf, d
        return c, max(anorm, 1.0) * max(1.0 / rc, 1.0), d

    @contract(A=_GUARD_SQUARE, r=Array(("k",)), u=Array(("k",)))
    def solve(self, A, r, u) -> np.ndarray:
        """ü = A⁻¹r, or SingularChartError(cond, u)."""
        c, kappa, d = self._factor(A)
        self.last_cond = kappa
        r = np.asarray(r, float)
        if c is None or kappa > self.max_cond or not math.isfinite(_addred(r)):
            u_list = [float(x) for x in np.asarray(u, float).ravel()]
            if not np.isfinite(r.sum()) or not np.all(np.isfinite(A)):
                detail = "the generalized mass or force is not finite (outside the chart's domain, or an overflow)"
            elif c is None:
                detail = "JᵀMJ is not positive definite (the chart lost rank)"
            else:
                detail = f"above max_cond = {self.max_cond:.1e}"
            raise SingularChartError(kappa, u_list, detail)
        x, info = _potrs(c, d * r, lower=0)
        return d * x


@dataclass
class ChartCheck:
    """Finite-difference check of a hand-written chart: relative errors of J and J̇u̇."""

    J_error: float
    Jdot_udot_error: float
    tol: float

    @property
    def ok(self) -> bool:
        return self.J_error <= self.tol and self.Jdot_udot_error <= self.tol


@contract(q=Func(), J=Func(), Jdot_udot=Func(), u=Array(("k",)), udot=Array(("k",)), eps=Real(gt=0, le=1),
          tol=Real(gt=0))
def check_chart(q: Callable, J: Callable, Jdot_udot: Callable, u, udot, eps: float = 1e-5,
                tol: float = 1e-6) -> ChartCheck:
    """Compare J(u) with centred differences of q, and J̇u̇ with d/ds[J(u + s u̇) u̇] at s = 0.

    Errors are relative to max(1, |reference|) (central differences: O(eps²) truncation). A chart that
    gives NaN or inf at u or u ± eps (outside its domain) raises :class:`SingularChartError`.

    Examples
    --------
    >>> q = lambda u: np.array([np.sin(u[0]), -np.cos(u[0])])
    >>> J = lambda u: np.array([[np.cos(u[0])], [np.sin(u[0])]])
    >>> bad = lambda u, ud: ud[0] ** 2 * np.array([np.sin(u[0]), np.cos(u[0])])   # sign slip
    >>> check_chart(q, J, bad, [0.3], [1.0]).ok
    False
    """
    u = np.atleast_1d(np.asarray(u, float))
    ud = np.atleast_1d(np.asarray(udot, float))
    with np.errstate(all="ignore"):
        J0 = np.asarray(J(u), float)
        Jfd = central_jacobian(q, u, eps)
        if J0.shape != Jfd.shape:
            raise InvalidInput(f"J(u) must have shape {Jfd.shape} (len(q), len(u)), got {J0.shape}")
        b_fd = directional_derivative(lambda z: np.asarray(J(z), float) @ ud, u, ud, eps).ravel()
        b = np.asarray(Jdot_udot(u, ud), float).ravel()
        if b.shape != b_fd.shape:
            raise InvalidInput(f"Jdot_udot(u, udot) must have shape {b_fd.shape} (len(q),), got {b.shape}")
        parts = {"J(u)": J0, "q near u": Jfd, "J near u": b_fd, "Jdot_udot(u, udot)": b}
        bad = [k for k, v in parts.items() if not np.isfinite(v).all()]
        if bad:
            raise SingularChartError(np.inf, u.tolist(), f"{', '.join(bad)} not finite (eps = {eps:g}; outside the "
                                     "chart's domain, or an overflow)")
        eJ = float(np.max(np.abs(J0 - Jfd), initial=0.0) / max(1.0, float(np.max(np.abs(Jfd), initial=0.0))))
        eb = float(np.max(np.abs(b - b_fd), initial=0.0) / max(1.0, float(np.max(np.abs(b_fd), initial=0.0))))
    if not (math.isfinite(eJ) and math.isfinite(eb)):
        raise SingularChartError(np.inf, u.tolist(), "the differences overflow (values near 1e308)")
    return ChartCheck(eJ, eb, tol)


@contract(coords=COORDS)
def validate_coords(coords) -> tuple:
    """Coordinates must be a non-empty list of distinct plain sympy Symbols (ValueError otherwise).

    The one check of coordinates: the contract checks them at the boundary, this body for the internal
    callers (derive_equations, point_kinematics, models) and for their distinctness."""
    import sympy

    if isinstance(coords, sympy.Basic) or not isinstance(coords, (list, tuple)) or len(coords) == 0:
        raise InvalidInput(f"coords must be a non-empty list of sympy Symbols, got {coords!r}")
    for c in coords:
        if not isinstance(c, sympy.Symbol):
            raise InvalidInput(f"coords must be sympy Symbols, got {c!r} of type {type(c).__name__}; use "
                             "sympy.symbols('q1 q2') (time enters through the t argument, not dynamicsymbols)")
    if len(set(coords)) != len(coords):
        raise InvalidInput(f"coords must be distinct, got {coords!r}")
    return tuple(coords)


@dataclass
class PointKinematics:
    """Symbolic J = ∂q/∂u (list of rows), q̇ = J u̇ + ∂q/∂t and b with q̈ = J ü + b.

    ``J_terms[i][j]`` and ``b_terms[i]`` keep the same quantities as lists of monomial terms (what
    :func:`pbanim.reduced.lagrangian.derive_equations` multiplies out and collects).
    """

    coords: tuple
    speeds: tuple
    J: list
    qdot: list
    b: list
    J_terms: list
    b_terms: list
    derivation_time: float


@contract(positions=EXPRESSIONS, coords=COORDS, t=Opt(SYMBOL))
def point_kinematics(positions: Sequence, coords: Sequence, t: Any = None) -> PointKinematics:
    """Differentiate flat position expressions q(u, t) once and twice (sympy, imported here).

    Term by term: each monomial of a position is differentiated only by the coordinates it contains
    (its free symbols), so a chain of n links costs O(n²) tiny derivatives, not O(n³) or O(n⁴).

    >>> import sympy as sp
    >>> th = sp.Symbol("th")
    >>> k = point_kinematics([sp.sin(th), -sp.cos(th)], [th])
    >>> k.J, k.b
    ([[cos(th)], [sin(th)]], [-th_dot**2*sin(th), th_dot**2*cos(th)])
    """
    import sympy

    t0 = time.perf_counter()
    coords = validate_coords(coords)
    if t is not None and not isinstance(t, sympy.Symbol):
        raise InvalidInput(f"t must be a sympy Symbol or None, got {t!r}")
    speeds = tuple(sympy.Symbol(f"{c.name}_dot") for c in coords)
    cset = set(coords)
    allowed = cset | ({t} if t is not None else set())
    index = {c: i for i, c in enumerate(coords)}
    n = len(coords)
    J, qdot, b, Jt_all, bt_all = [], [], [], [], []
    memo: dict = {}     # (monomial, symbol) → derivative: a chain repeats sin(u_j), cos(u_j) in every later point

    def diff(x, c):
        d = memo.get((x, c))
        if d is None:
            d = memo[(x, c)] = x.diff(c)
        return d

    for i, e in enumerate(positions):
        if isinstance(e, str) or not isinstance(sympy.sympify(e), sympy.Expr):
            raise InvalidInput(f"positions[{i}] must be a real number or a sympy expression, got {e!r}")
        bad = nonreal(sympy.sympify(e))
        if bad:
            raise InvalidInput(f"positions[{i}] must be real and finite, got {e} (it holds {bad})")
        e = sympy.expand(sympy.sympify(e), mul=True, multinomial=False, power_base=False, power_exp=False,
                         log=False, deep=False)
        stray = e.free_symbols - allowed
        if stray:
            raise InvalidInput(f"positions may depend only on coords{' and t' if t is not None else ''}; "
                             f"got symbols {sorted(map(str, stray))}; substitute numbers for parameters")
        Jt: list[list] = [[] for _ in range(n)]
        for term in sympy.Add.make_args(e):
            for c in term.free_symbols & cset:
                d = diff(term, c)
                Jt[index[c]].extend(sympy.Add.make_args(d) if d.is_Add else [d])
        row = [sympy.Add(*ts) if ts else sympy.S.Zero for ts in Jt]
        rt = e.diff(t) if t is not None else sympy.S.Zero
        qdot.append(sympy.Add(*[row[j] * speeds[j] for j in range(n) if Jt[j]], rt))
        bt = []
        for j in range(n):
            for jt in Jt[j]:
                for c in jt.free_symbols & cset:
                    bt.append(diff(jt, c) * speeds[j] * speeds[index[c]])
                if t is not None and t in jt.free_symbols:
                    bt.append(2 * diff(jt, t) * speeds[j])
        if t is not None:
            rtt = rt.diff(t)
            if rtt != 0:
                bt.extend(sympy.Add.make_args(sympy.expand(rtt)))
        bt = [x for x in bt if x != 0]
        b.append(sympy.Add(*bt))
        J.append(row)
        Jt_all.append(Jt)
        bt_all.append(bt)
    return PointKinematics(coords, speeds, J, qdot, b, Jt_all, bt_all, time.perf_counter() - t0)


_KINEMATICS: dict = {}      # (positions, coords, t) → PointKinematics: the few structures of a session
_KINEMATICS_MAX = 16


def _point_kinematics_cached(positions: Sequence, coords: Sequence, t: Any = None, lean: bool = True):
    """:func:`point_kinematics`, derived once per (positions, coords, t) (the lean twin; ``lean=False``
    derives again). ReducedSystem.from_sympy and derive_equations both differentiate the same positions
    of a model (its reduced system and its Lagrangian): the second gets the first's expressions, as
    fresh lists (a caller that edits them does not change the cache). Keys compare the expressions
    structurally (sympy ==), so equal keys give the same J, q̇, b term for term; ``derivation_time``
    is the first derivation's. Strings and unhashable entries are never cached (the readable path's
    checks see them)."""
    import sympy

    if not lean or any(isinstance(e, str) for e in positions):
        return point_kinematics(positions, coords, t)
    try:
        key = (tuple(sympy.sympify(e) for e in positions), tuple(coords), t)
        kin = _KINEMATICS.get(key)
    except (TypeError, sympy.SympifyError):
        return point_kinematics(positions, coords, t)
    if kin is None:
        kin = point_kinematics(positions, coords, t)
        while len(_KINEMATICS) >= _KINEMATICS_MAX:
            _KINEMATICS.pop(next(iter(_KINEMATICS)))
        _KINEMATICS[key] = kin
    return PointKinematics(kin.coords, kin.speeds, [list(r) for r in kin.J], list(kin.qdot), list(kin.b),
                           [[list(x) for x in Jt] for Jt in kin.J_terms], [list(x) for x in kin.b_terms],
                           kin.derivation_time)


def _methods():
    from ..ode import METHODS
    return METHODS


METHOD = Choice(_methods)


@contract(rhs=Func(), y0=Array(("n",)), t_end=Real(gt=0), h=Real(gt=0), method=METHOD, energy=Opt(Func()),
          record_every=Int(ge=1), split=Opt(Int(ge=0)), max_steps=Opt(Int(ge=1)))
def simulate_fixed(rhs: Callable, y0, t_end: float, h: float, method: str = "implicit_midpoint", *,
                   energy: Callable | None = None, record_every: int = 1, split: int | None = None,
                   max_steps: int | None = None):
    """Fixed-step run of ``rhs`` with a method of :mod:`pbanim.ode`, recording ``energy(y, t)`` every few steps.

    Runs through the one driver (:mod:`pbanim.ode.driver`: same step rule, cap and finiteness check).
    Implicit Euler and midpoint keep their Newton matrix across steps (:class:`pbanim.ode.implicit_run.NewtonSteps`:
    the states of the per-step solve to its Newton tolerance, without a Jacobian and an LU per step).
    Returns a :class:`pbanim.results.SimResult` (``diagnostics["energy"]`` when ``energy`` is given).
    A :class:`SingularChartError` raised by the rhs propagates (never NaN states); ``max_steps`` (default
    :data:`pbanim.ode.driver.MAX_STEPS`) caps the run before its first step.
    """
    from ..ode import get_method
    from ..ode.driver import MAX_STEPS, check_finite, drive, step_grid
    from ..ode.implicit_run import THETA, NewtonSteps
    from ..results import SimResult

    grid = step_grid(0.0, t_end, h, max_steps=MAX_STEPS if max_steps is None else max_steps,
                     record_every=record_every)
    m = get_method(method)
    y = np.array(y0, dtype=float)
    check_finite(y, 0.0, 0, "initial state")
    split = y.size // 2 if split is None else split
    if not 0 <= split <= y.size:
        raise InvalidInput(f"simulate_fixed: split must be in 0 … len(y0) = {y.size}, got {split}")
    ts, ys, es = [0.0], [y.copy()], ([energy(y, 0.0)] if energy else [])
    nfev = [0]
    f, step = unchecked(rhs), unchecked(m.step)     # the step loop holds them: no contract wrapper per call

    def fun(t, yy):
        nfev[0] += 1
        return f(t, yy)

    def record(t1, y1):
        ts.append(t1)
        ys.append(y1.copy())
        if energy:
            es.append(energy(y1, t1))

    if m.name in THETA:     # implicit Euler / midpoint: the Newton matrix kept across steps (to the Newton tol)
        advance = NewtonSteps(fun, m.name).step
    else:
        def advance(t, yy, hk):
            return step(fun, t, yy, hk, split=split)
    start = time.perf_counter()
    drive(advance, grid, y, record=record, record_every=record_every)
    wall = time.perf_counter() - start
    diag = {"energy": np.array(es)} if energy else {}
    return SimResult(t=np.array(ts), y=np.array(ys).T, nfev=nfev[0], wall_time=wall, method=method,
                     nsteps=grid.n_steps, diagnostics=diag)
