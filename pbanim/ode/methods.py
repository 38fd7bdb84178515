"""Integrators as data: Butcher tableaux, split (symplectic) steps, the registry (implicit steps: ode_implicit).

Every method advances ẏ = f(t, y) by one step h: ``step(fun, t, y, h, split=None, jac=None) -> y_new``,
on a state of shape (n,) or a batch (K, n) (``fun`` then receives (K, n) arrays). See :mod:`pbanim.ode`
for the lecture (equations, notation, stability limits, references).

Explicit Runge–Kutta methods (Euler, midpoint, RK4, the Dormand–Prince 5(4) and 8(5,3) pairs, Verner's
7(6) pair) are :class:`Tableau` objects run by one stepper (:func:`pbanim.ode.tableau.make_rk_step`; the
readable loop is :func:`explicit_rk_step`); a tableau checks its own consistency (ΣB = 1, rows of A sum
to C, A strictly lower triangular) when it is built. The stiff methods RODAS4 and Radau IIA live in
:mod:`pbanim.ode.rosenbrock` and :mod:`pbanim.ode.radau`, the Runge–Kutta–Nyström pairs for q̈ = g(t, q)
(``nystrom=True``: they refuse any other right-hand side) in :mod:`pbanim.ode.nystrom`; every adaptive
method carries its loop.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

import numpy as np

from .adaptive import DOPRI5, dopri5_step, solve_adaptive, solve_pair
from .high_order import DOP853, VERN7
from .nystrom import dprkn6_step, dprkn8_step, dprkn12_step, solve_nystrom
from .implicit import (expm_small, exponential_euler_step, implicit_euler_step, implicit_midpoint_step,
                           newton_solve)
from .radau import radau5_step, solve_radau
from .rosenbrock import rodas4_step, solve_rosenbrock
from .signature import STEP, finite_step
from .tableau import Tableau, make_rk_step
from ..contracts import Choice, Either, Flag, Func, Int, Obj, Opt, Real, Text, contract, unchecked
from ..errors import InvalidInput

__all__ = ["Method", "Tableau", "METHODS", "TABLEAUX", "get_method", "explicit_rk_step", "euler_step",
           "midpoint_step", "rk4_step", "symplectic_euler_step", "verlet_step", "implicit_euler_step",
           "implicit_midpoint_step", "exponential_euler_step", "dopri5_step", "dop853_step", "vern7_step",
           "rodas4_step", "radau5_step", "newton_solve", "expm_small"]


# ---------------------------------------------------------------------------------------------------
# Butcher tableaux (the class and its stepper: pbanim.ode.tableau; the high-order pairs: ode.high_order)
# ---------------------------------------------------------------------------------------------------
def _frac(*xs):
    return np.array([float(x) for x in xs])


TABLEAUX: dict[str, Tableau] = {
    "euler": Tableau("euler", np.zeros((1, 1)), _frac(1), _frac(0), 1),
    "midpoint": Tableau("midpoint", np.array([[0, 0], [0.5, 0]]), _frac(0, 1), _frac(0, 0.5), 2),
    "rk4": Tableau("rk4", np.array([[0, 0, 0, 0], [0.5, 0, 0, 0], [0, 0.5, 0, 0], [0, 0, 1, 0]]),
                   _frac(1 / 6, 1 / 3, 1 / 3, 1 / 6), _frac(0, 0.5, 0.5, 1), 4),
    "dopri5": DOPRI5,
    "dop853": DOP853,
    "vern7": VERN7,
}

_RK_STEPS = {name: make_rk_step(tab) for name, tab in TABLEAUX.items()}


@contract(tableau=Either(Choice(lambda: TABLEAUX), Obj(Tableau)), fun=Func(), t=Real(), y=STEP["y"], h=Real())
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


@contract(**STEP, returns=finite_step)
def euler_step(fun: Callable, t: float, y: np.ndarray, h: float, split: int | None = None, jac=None) -> np.ndarray:
    """Explicit Euler: y₁ = y₀ + h f(t₀, y₀) (order 1; energy factor 1 + h²ω² on the oscillator).

    >>> euler_step(lambda t, y: -y, 0.0, np.array([1.0]), 0.1)
    array([0.9])
    """
    # BEGIN SOLUTION euler_step
    return y + h * fun(t, y)
    # END SOLUTION


euler_step.nfev = 1


def _registered(name: str, doc: str):
    """The stepper of tableau ``name`` as a public step function: its name, its docstring, its contract."""
    f = _RK_STEPS[name]
    f.__name__ = f.__qualname__ = f"{name}_step"
    f.__module__ = __name__
    f.__doc__ = doc
    return contract(**STEP, returns=finite_step)(f)


midpoint_step = _registered("midpoint", """Explicit midpoint: k₁ = f(t, y), y₁ = y + h f(t + h/2, y + h/2 k₁) (order 2).""")
rk4_step = _registered("rk4", """Classical Runge–Kutta 4: four stages, order 4, stable on the oscillator iff hω ≤ 2√2.

>>> float(rk4_step(lambda t, y: np.ones_like(y) * t**3, 0.0, np.zeros(1), 1.0)[0])  # exact on cubics
0.25
""")
dop853_step = _registered("dop853", """One fixed step of Dormand–Prince's eighth-order formula (12 stages; adaptive: ``solve``).""")
vern7_step = _registered("vern7", """One fixed step of Verner's seventh-order formula (9 stages used; adaptive: ``solve``).""")


def _split(y: np.ndarray, split: int | None) -> int:
    n = y.shape[-1]
    return n // 2 if split is None else int(split)


@contract(**STEP, returns=finite_step)
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


@contract(**STEP, returns=finite_step)
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
@contract(name=Text(nonempty=True), order=Int(ge=1), symplectic=Flag(), implicit=Flag(), adaptive=Flag(), step=Func(),
          description=Text(), run=Opt(Func()), nystrom=Flag())
@dataclass(frozen=True)
class Method:
    """A registered integrator: its properties (data) and its step function.

    ``implicit`` means the step uses the Jacobian ∂f/∂y (Newton iterations, or matrix functions for the
    exponential integrator, the Rosenbrock and Radau stages): a scene passes its analytic Jacobian to
    these methods. An ``adaptive`` method also has ``run``, its error-controlled loop, called by
    :func:`pbanim.solve` as ``run(fun, t0, tf, y0, f0, method, h, rtol, atol, t_eval, events, max_steps,
    split, jac)``; ``step`` is its fixed-step form (scenes, convergence tests).
    """

    name: str
    order: int
    symplectic: bool
    implicit: bool
    adaptive: bool
    step: Callable
    description: str = ""
    run: Callable | None = None
    nystrom: bool = False     # only for f(t, [q, v]) = [v, g(t, q)] (Runge–Kutta–Nyström: pbanim.ode.nystrom)

    def __post_init__(self) -> None:
        # the registry runs the step without its boundary check: a run checks its arguments once; the
        # evaluations per step (``nfev``, set on the checked function) stay readable on the unchecked one
        raw = unchecked(self.step)
        if getattr(raw, "nfev", None) is None and getattr(self.step, "nfev", None) is not None:
            raw.nfev = self.step.nfev
        object.__setattr__(self, "step", raw)


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
    Method("dopri5", 5, False, False, True, dopri5_step, "adaptive Dormand–Prince 5(4)", solve_adaptive),
    Method("dop853", 8, False, False, True, dop853_step, "adaptive Dormand–Prince 8(5,3), PI control, "
           "dense output of order 7", solve_pair),
    Method("vern7", 7, False, False, True, vern7_step, "adaptive Verner 7(6), PI control, dense output",
           solve_pair),
    Method("rodas4", 4, False, True, True, rodas4_step, "adaptive Rosenbrock RODAS4 (L-stable, one LU per "
           "step)", solve_rosenbrock),
    Method("radau5", 5, False, True, True, radau5_step, "adaptive Radau IIA order 5 (L-stable; Jacobian and "
           "LU reused across steps)", solve_radau),
    Method("dprkn6", 6, False, False, True, dprkn6_step, "adaptive Nyström 6(4) for q̈ = g(t, q) (5 evaluations "
           "per step)", solve_nystrom, nystrom=True),
    Method("dprkn8", 8, False, False, True, dprkn8_step, "adaptive Nyström 8(6) for q̈ = g(t, q) (8 evaluations "
           "per step)", solve_nystrom, nystrom=True),
    Method("dprkn12", 12, False, False, True, dprkn12_step, "adaptive Nyström 12(10) for q̈ = g(t, q) (17 "
           "evaluations per step)", solve_nystrom, nystrom=True),
]}


@contract(name=Choice(lambda: METHODS))
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
