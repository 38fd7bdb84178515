"""Integrators as data: Butcher tableaux, split (symplectic) steps, the registry (implicit steps: ode_implicit).

Every method advances ẏ = f(t, y) by one step h: ``step(fun, t, y, h, split=None, jac=None) -> y_new``,
on a state of shape (n,) or a batch (K, n) (``fun`` then receives (K, n) arrays). See :mod:`pbanim.ode`
for the lecture (equations, notation, stability limits, references).

Explicit Runge–Kutta methods (Euler, midpoint, RK4, the Dormand–Prince 5(4) pair) are :class:`Tableau`
objects run by one stepper, :func:`explicit_rk_step`; a tableau checks its own consistency
(ΣB = 1, rows of A sum to C, A strictly lower triangular) when it is built.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Callable

import numpy as np

from .implicit import (expm_small, exponential_euler_step, implicit_euler_step, implicit_midpoint_step,
                           newton_solve)
from ..errors import InvalidInput

__all__ = ["Method", "Tableau", "METHODS", "TABLEAUX", "get_method", "explicit_rk_step", "euler_step",
           "midpoint_step", "rk4_step", "symplectic_euler_step", "verlet_step", "implicit_euler_step",
           "implicit_midpoint_step", "exponential_euler_step", "dopri5_step", "newton_solve",
           "expm_small"]


# ---------------------------------------------------------------------------------------------------
# Butcher tableaux
# ---------------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class Tableau:
    """An explicit Runge–Kutta method  kᵢ = f(t + cᵢh, y + h Σⱼ aᵢⱼ kⱼ),  y₁ = y + h Σᵢ bᵢ kᵢ.

    ``E`` (optional) holds b − b̂ of an embedded lower-order formula, so the local error estimate is
    h Σᵢ eᵢ kᵢ. Building a tableau checks ΣB = 1, Σⱼ aᵢⱼ = cᵢ and that A is strictly lower triangular.

    >>> TABLEAUX["rk4"].stages, TABLEAUX["dopri5"].order
    (4, 5)
    """

    name: str
    A: np.ndarray
    B: np.ndarray
    C: np.ndarray
    order: int
    E: np.ndarray | None = None
    rows: tuple = field(init=False, repr=False)

    def __post_init__(self):
        A, B, C = (np.asarray(x, dtype=float) for x in (self.A, self.B, self.C))
        s = len(B)
        if A.shape != (s, s) or C.shape != (s,):
            raise InvalidInput(f"tableau {self.name}: A must be ({s}, {s}) and C ({s},), got {A.shape}, {C.shape}")
        if abs(B.sum() - 1.0) > 1e-14:
            raise InvalidInput(f"tableau {self.name}: weights B must sum to 1, got {B.sum()!r}")
        if np.max(np.abs(A.sum(axis=1) - C)) > 1e-14:
            raise InvalidInput(f"tableau {self.name}: rows of A must sum to C")
        if np.any(np.triu(A) != 0):
            raise InvalidInput(f"tableau {self.name}: A must be strictly lower triangular (explicit method)")
        object.__setattr__(self, "A", A)
        object.__setattr__(self, "B", B)
        object.__setattr__(self, "C", C)
        # nonzero coefficients per stage, precomputed so the stepper skips the zeros
        rows = tuple(tuple((j, A[i, j]) for j in range(i) if A[i, j] != 0) for i in range(s))
        object.__setattr__(self, "rows", rows)

    @property
    def stages(self) -> int:
        return len(self.B)


def _frac(*xs):
    return np.array([float(x) for x in xs])


_F = lambda a, b: a / b  # noqa: E731  (readable rational coefficients)

TABLEAUX: dict[str, Tableau] = {
    "euler": Tableau("euler", np.zeros((1, 1)), _frac(1), _frac(0), 1),
    "midpoint": Tableau("midpoint", np.array([[0, 0], [0.5, 0]]), _frac(0, 1), _frac(0, 0.5), 2),
    "rk4": Tableau("rk4", np.array([[0, 0, 0, 0], [0.5, 0, 0, 0], [0, 0.5, 0, 0], [0, 0, 1, 0]]),
                   _frac(1 / 6, 1 / 3, 1 / 3, 1 / 6), _frac(0, 0.5, 0.5, 1), 4),
    # Dormand & Prince (1980), the 5(4) pair with the FSAL property (last row of A = B)
    "dopri5": Tableau(
        "dopri5",
        np.array([
            [0, 0, 0, 0, 0, 0, 0],
            [_F(1, 5), 0, 0, 0, 0, 0, 0],
            [_F(3, 40), _F(9, 40), 0, 0, 0, 0, 0],
            [_F(44, 45), _F(-56, 15), _F(32, 9), 0, 0, 0, 0],
            [_F(19372, 6561), _F(-25360, 2187), _F(64448, 6561), _F(-212, 729), 0, 0, 0],
            [_F(9017, 3168), _F(-355, 33), _F(46732, 5247), _F(49, 176), _F(-5103, 18656), 0, 0],
            [_F(35, 384), 0, _F(500, 1113), _F(125, 192), _F(-2187, 6784), _F(11, 84), 0]]),
        _frac(_F(35, 384), 0, _F(500, 1113), _F(125, 192), _F(-2187, 6784), _F(11, 84), 0),
        _frac(0, _F(1, 5), _F(3, 10), _F(4, 5), _F(8, 9), 1, 1), 5,
        E=_frac(_F(35, 384) - _F(5179, 57600), 0, _F(500, 1113) - _F(7571, 16695),
                _F(125, 192) - _F(393, 640), _F(-2187, 6784) + _F(92097, 339200),
                _F(11, 84) - _F(187, 2100), _F(-1, 40))),
}


def _grouped(pairs) -> tuple:
    """Σ aⱼ kⱼ as ((a, j₀, (j₁, …)), …): the stages that share a coefficient a are summed, then multiplied."""
    groups: dict = {}
    for j, a in pairs:
        groups.setdefault(float(a), []).append(j)
    return tuple((a, js[0], tuple(js[1:])) for a, js in groups.items())


def _increment(k: list, h: float, groups: tuple):
    """h Σ aⱼ kⱼ over the grouped nonzero coefficients: (k₀ + k₃)·(h a) + (k₁ + k₂)·(h b) + …"""
    (a, j0, more), *rest = groups
    s = k[j0]
    for j in more:
        s = s + k[j]
    inc = s * (h * a)
    for a, j0, more in rest:
        s = k[j0]
        for j in more:
            s = s + k[j]
        inc = inc + s * (h * a)
    return inc


def _make_rk_step(tab: Tableau) -> Callable:
    """Turn a tableau into a step function that skips its zero coefficients.

    The coefficients are read once, here: per stage i the node cᵢ and the nonzero aᵢⱼ grouped by value,
    and the nonzero weights bᵢ. A tableau whose every stage uses only the one before it (Euler, midpoint,
    RK4: kᵢ = f(t + cᵢh, y + aᵢ,ᵢ₋₁ h kᵢ₋₁)) gets a closure that keeps only the last stage in the loop;
    any other tableau (Dormand–Prince) keeps the list of stages. Both do the numpy operations one would
    write by hand for that tableau, so the registered steps cost no more than a hand-written loop; the
    readable loop over the full tableau is :func:`explicit_rk_step`, and the tests check that they agree.
    """
    s = tab.stages
    weights = _grouped((i, b) for i, b in enumerate(tab.B) if b != 0)
    if all(len(tab.rows[i]) == 1 and tab.rows[i][0][0] == i - 1 for i in range(1, s)):
        chain = tuple((float(tab.C[i]), float(tab.rows[i][0][1])) for i in range(1, s))

        def step(fun, t, y, h, split=None, jac=None):
            last = fun(t, y)
            k = [last]
            for c, a in chain:
                last = fun(t + c * h, y + last * (h * a))
                k.append(last)
            return y + _increment(k, h, weights)
    else:
        stages = tuple((float(tab.C[i]), _grouped(tab.rows[i])) for i in range(1, s))

        def step(fun, t, y, h, split=None, jac=None):
            k = [fun(t, y)]
            for c, groups in stages:
                k.append(fun(t + c * h, y + _increment(k, h, groups)) if groups else fun(t + c * h, y))
            return y + _increment(k, h, weights)

    step.__name__ = step.__qualname__ = f"{tab.name}_step"
    step.tableau = tab
    step.nfev = s  # right-hand-side evaluations per step
    return step


_RK_STEPS = {name: _make_rk_step(tab) for name, tab in TABLEAUX.items()}


def explicit_rk_step(tableau: Tableau | str, fun: Callable, t: float, y: np.ndarray, h: float) -> np.ndarray:
    """One step of an explicit Runge–Kutta method given by its Butcher tableau (or its name).

    Readable reference: the stage loop written out with the full A matrix (the registered steps run the
    same formula with the zero coefficients skipped).

    >>> f = lambda t, y: -y
    >>> float(explicit_rk_step("rk4", f, 0.0, np.array([1.0]), 0.1)[0])  # 1 − h + h²/2 − h³/6 + h⁴/24
    0.9048375
    """
    # BEGIN SOLUTION explicit_rk_step
    tab = TABLEAUX[tableau] if isinstance(tableau, str) else tableau
    y = np.asarray(y)
    K = np.zeros((tab.stages,) + y.shape, dtype=np.result_type(y, float))
    for i in range(tab.stages):
        yi = y + h * np.tensordot(tab.A[i, :i], K[:i], axes=1) if i else y
        K[i] = fun(t + tab.C[i] * h, yi)
    return y + h * np.tensordot(tab.B, K, axes=1)
    # END SOLUTION


def euler_step(fun: Callable, t: float, y: np.ndarray, h: float, split: int | None = None, jac=None) -> np.ndarray:
    """Explicit Euler: y₁ = y₀ + h f(t₀, y₀) (order 1; energy factor 1 + h²ω² on the oscillator).

    >>> euler_step(lambda t, y: -y, 0.0, np.array([1.0]), 0.1)
    array([0.9])
    """
    # BEGIN SOLUTION euler_step
    return y + h * fun(t, y)
    # END SOLUTION


euler_step.nfev = 1
midpoint_step = _RK_STEPS["midpoint"]
midpoint_step.__doc__ = """Explicit midpoint: k₁ = f(t, y), y₁ = y + h f(t + h/2, y + h/2 k₁) (order 2)."""
rk4_step = _RK_STEPS["rk4"]
rk4_step.__doc__ = """Classical Runge–Kutta 4: four stages, order 4, stable on the oscillator iff hω ≤ 2√2.

>>> float(rk4_step(lambda t, y: np.ones_like(y) * t**3, 0.0, np.zeros(1), 1.0)[0])  # exact on cubics
0.25
"""


def dopri5_step(fun: Callable, t: float, y: np.ndarray, h: float, split: int | None = None, jac=None) -> np.ndarray:
    """One fixed step of the fifth-order Dormand–Prince formula (no error control; see :func:`pbanim.solve`)."""
    return _RK_STEPS["dopri5"](fun, t, y, h)


dopri5_step.nfev = 7


def _split(y: np.ndarray, split: int | None) -> int:
    n = y.shape[-1]
    return n // 2 if split is None else int(split)


def symplectic_euler_step(fun: Callable, t: float, y: np.ndarray, h: float, split: int | None = None,
                          jac=None) -> np.ndarray:
    """Symplectic Euler, kick then drift: v₁ = v₀ + h a(q₀, v₀); q₁ = q₀ + h q̇(q₀, v₁).

    ``split`` = number of position components q at the front of y (default n // 2). On ẍ = −ω²x it
    conserves H̃ = E − ½hω²xv exactly and is stable iff hω < 2 (ORACLES A1, A2).

    >>> symplectic_euler_step(lambda t, y: np.array([y[1], -y[0]]), 0.0, np.array([1.0, 0.0]), 0.1)
    array([ 0.99, -0.1 ])
    """
    # BEGIN SOLUTION symplectic_euler_step
    s = _split(y, split)
    k = fun(t, y)
    y1 = np.array(y, dtype=np.result_type(y, float), copy=True)
    y1[..., s:] += h * k[..., s:]
    k2 = fun(t, y1)
    y1[..., :s] = y[..., :s] + h * k2[..., :s]
    return y1
    # END SOLUTION


symplectic_euler_step.nfev = 2


def verlet_step(fun: Callable, t: float, y: np.ndarray, h: float, split: int | None = None, jac=None) -> np.ndarray:
    """Velocity Verlet: v½ = v₀ + h/2 a(q₀); q₁ = q₀ + h q̇(v½); v₁ = v½ + h/2 a(q₁, v½).

    Order 2, symplectic and time-reversible for separable H = T(v) + V(q); on ẍ = −ω²x it conserves
    ½v² + ½ω²(1 − h²ω²/4)x² exactly (ORACLES A1).

    >>> verlet_step(lambda t, y: np.array([y[1], -y[0]]), 0.0, np.array([1.0, 0.0]), 0.1)
    array([ 0.995    , -0.0997500])
    """
    # BEGIN SOLUTION verlet_step
    s = _split(y, split)
    half = 0.5 * h
    y1 = np.array(y, dtype=np.result_type(y, float), copy=True)
    y1[..., s:] += half * fun(t, y)[..., s:]
    y1[..., :s] += h * fun(t + half, y1)[..., :s]
    y1[..., s:] += half * fun(t + h, y1)[..., s:]
    return y1
    # END SOLUTION


verlet_step.nfev = 3


# ---------------------------------------------------------------------------------------------------
# the registry
# ---------------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class Method:
    """A registered integrator: its properties (data) and its step function.

    ``implicit`` means the step uses the Jacobian ∂f/∂y (Newton iterations, or matrix functions for the
    exponential integrator): a scene passes its analytic Jacobian to these methods.
    """

    name: str
    order: int
    symplectic: bool
    implicit: bool
    adaptive: bool
    step: Callable
    description: str = ""


METHODS: dict[str, Method] = {m.name: m for m in [
    Method("euler", 1, False, False, False, euler_step, "explicit Euler"),
    Method("midpoint", 2, False, False, False, midpoint_step, "explicit midpoint (RK2)"),
    Method("rk4", 4, False, False, False, rk4_step, "classical Runge–Kutta 4"),
    Method("symplectic_euler", 1, True, False, False, symplectic_euler_step, "symplectic Euler (kick then drift)"),
    Method("verlet", 2, True, False, False, verlet_step, "velocity Verlet"),
    Method("implicit_euler", 1, False, True, False, implicit_euler_step, "implicit Euler (Newton)"),
    Method("implicit_midpoint", 2, True, True, False, implicit_midpoint_step, "implicit midpoint (Newton)"),
    Method("exponential_euler", 2, False, True, False, exponential_euler_step,
           "exponential Rosenbrock–Euler (uses ∂f/∂y; exact for linear springs)"),
    Method("dopri5", 5, False, False, True, dopri5_step, "adaptive Dormand–Prince 5(4)"),
]}


def get_method(name: str) -> Method:
    """Look up a method by name, with a clear error listing the known names.

    >>> get_method("verlet").order
    2
    """
    try:
        return METHODS[name]
    except (KeyError, TypeError):
        raise InvalidInput(f"method must be one of {sorted(METHODS)} or 'scipy:<solve_ivp method>', "
                         f"got {name!r}") from None
