"""Named errors of pbanim.

Every failure a student can meet has a name and a message that says what went wrong, with which
value, and what to do about it. Solvers never return garbage: they raise one of these, or return a
result whose ``success`` is False.

======================  ==========================================================================
error                   raised when
======================  ==========================================================================
InvalidInput            an argument has the wrong shape, size, sign, range or value (also a ValueError)
SimulationDiverged      a state or force stops being finite, or grows past a bound, during stepping
StepLimitExceeded       a fixed-step run would need more steps than its ``max_steps`` cap
BodyProtocolError       a system given to impulses, constraints or contacts lacks the body protocol
SingularConstraintError the constraint system JWJᵀλ = r has no solution (inconsistent rows)
ConvergenceError        an iterative solver (CG, Newton, PGS) did not reach its tolerance
SingularChartError      a reduced-coordinate chart loses rank (generalized mass near singular)
InfeasibleContact       a contact QP / LCP has no solution or the solver failed
InconsistentContact     the acceleration-level contact problem is inconsistent (Painlevé)
======================  ==========================================================================
"""

from __future__ import annotations

import math

import numpy as np

__all__ = [
    "PbanimError",
    "InvalidInput",
    "SimulationDiverged",
    "StepLimitExceeded",
    "BodyProtocolError",
    "SingularConstraintError",
    "ConvergenceError",
    "SingularChartError",
    "InfeasibleContact",
    "InconsistentContact",
    "NonFiniteResult",
    "check_result",
    "check_count",
    "check_number",
    "check_positive",
    "as_floats",
    "as_float",
]


def check_count(name: str, value, minimum: int = 1, maximum: int | None = None) -> int:
    """``value`` as an int >= ``minimum``, or :class:`InvalidInput` naming ``name`` (NaN, inf, 2.5, "3" refused).

    >>> check_count("max_steps", 10.0)
    10
    """
    if isinstance(value, bool) or not isinstance(value, (int, float, np.integer, np.floating)) \
            or not math.isfinite(value) or int(value) != value or value < minimum:
        what = "a positive integer" if minimum == 1 else f"an integer ≥ {minimum}"
        raise InvalidInput(f"{name} must be {what}, got {value}")
    if maximum is not None and value > maximum:
        raise InvalidInput(f"{name} must be at most {maximum}, got {value}")
    return int(value)


def check_number(name: str, value, *, low: float = -math.inf, high: float = math.inf, low_open: bool = False,
                 high_open: bool = False) -> float:
    """``value`` as a finite float in [low, high] (open ends on request), or :class:`InvalidInput`.

    >>> check_number("stiffness", float("nan"), low=0.0)
    Traceback (most recent call last):
    ...
    pbanim.errors.InvalidInput: stiffness must be a finite number >= 0, got nan
    """
    try:
        v = float(value)
    except (TypeError, ValueError):
        v = math.nan
    ok = math.isfinite(v) and (v > low if low_open else v >= low) and (v < high if high_open else v <= high)
    if not ok:
        parts = []
        if low > -math.inf:
            parts.append(f"{'>' if low_open else '>='} {low:g}")
        if high < math.inf:
            parts.append(f"{'<' if high_open else '<='} {high:g}")
        raise InvalidInput(f"{name} must be a finite number{' ' if parts else ''}{' and '.join(parts)}, got {value!r}")
    return v


def as_float(name: str, value) -> float:
    """``value`` as one float (NaN and inf pass through for the caller's range check), or
    :class:`InvalidInput` when it is not a number."""
    try:
        return float(value)
    except (TypeError, ValueError):
        text = repr(value)
        raise InvalidInput(f"{name} must be a number, got {text[:60]}{'...' if len(text) > 60 else ''}") from None


def as_floats(name: str, value, ndmin: int = 0):
    """``value`` as a float array (a copy), or :class:`InvalidInput` when it is not numbers (e.g. a string)."""
    try:
        return np.array(value, dtype=float, ndmin=ndmin)
    except (TypeError, ValueError):
        text = repr(value)
        raise InvalidInput(f"{name} must be numbers (an array of floats), got {text[:60]}"
                           f"{'...' if len(text) > 60 else ''}") from None


def check_positive(name: str, value, fix: str = "") -> float:
    """``value`` as a positive finite float, or :class:`InvalidInput` "NAME must be positive and finite"."""
    try:
        v = float(value)
    except (TypeError, ValueError):
        v = math.nan
    if not (math.isfinite(v) and v > 0):
        raise InvalidInput(f"{name} must be positive and finite, got {value}{_tail(fix)}")
    return v


def _tail(detail: str) -> str:
    """"; detail" when there is a detail, else nothing (the middle part of every message below)."""
    return f"; {detail}" if detail else ""


class PbanimError(Exception):
    """Base class of every error pbanim raises on purpose (besides ``ValueError`` for bad input)."""


class InvalidInput(PbanimError, ValueError):
    """A bad argument at a public boundary; the message names the argument, what was expected and what
    came in. A ``ValueError``, so code that caught those keeps working."""


class SimulationDiverged(PbanimError, FloatingPointError):
    """A simulation produced a non-finite (or exploding) quantity.

    Attributes
    ----------
    t : float
        Time at the start of the step that diverged.
    step : int
        Index of that step (0-based), or -1 when unknown.
    quantity : str
        What stopped being finite ("state", "velocity", "lambda", ...), or passed its bound (``what``
        says which: "is not finite" by default, "exceeds its bound" for a cap such as a largest energy).
    """

    def __init__(self, t: float, step: int, quantity: str, detail: str = "", what: str = "is not finite") -> None:
        self.t = float(t)
        self.step = int(step)
        self.quantity = quantity
        msg = (f"simulation diverged at t = {self.t:.6g} (step {self.step}): {quantity} {what}"
               f"{_tail(detail)}; reduce the step h or use a stabler method")
        super().__init__(msg)


class StepLimitExceeded(InvalidInput):
    """A fixed-step run would need more steps than its cap (checked before the first step).

    Attributes
    ----------
    h, span : float
        The step and |t_end − t₀|.
    n_steps : int or float
        The number of steps the run needs (inf when span/h overflows).
    max_steps : int
        The cap.
    """

    def __init__(self, h: float, span: float, n_steps: float, max_steps: int) -> None:
        self.h, self.span, self.n_steps, self.max_steps = float(h), float(span), n_steps, int(max_steps)
        super().__init__(f"h = {self.h:g} needs {n_steps} steps over t_span, more than max_steps = "
                         f"{self.max_steps} (|t_end − t0| = {self.span:g}); raise max_steps or enlarge h")


class BodyProtocolError(InvalidInput, TypeError):
    """A system does not implement the body protocol (:class:`pbanim.bodies.Bodies`).

    A ``TypeError`` (wrong kind of object) and, for code written before the protocol, a ``ValueError``.

    Attributes
    ----------
    who : str
        The effect or solver that needed it.
    system : str
        The system's type name.
    missing : list[str]
        The protocol members the system lacks (empty: it has them all but is not a ``Bodies``).
    """

    def __init__(self, who: str, system: str, missing) -> None:
        self.who, self.system, self.missing = who, system, list(missing)
        tail = (f"{system} lacks {', '.join(self.missing)}" if self.missing else
                f"{system} has every member but is not a Bodies: subclass it or call Bodies.register({system})")
        super().__init__(f"{who} needs a system implementing the body protocol (pbanim.bodies.Bodies); {tail}")


class SingularConstraintError(PbanimError, ValueError):
    """The constraint system is singular and inconsistent: no λ satisfies it.

    Attributes
    ----------
    rows : list[int]
        Indices of the dependent (conflicting) constraint rows.
    residual : float
        Norm of the residual of the best (least-squares) answer.
    """

    def __init__(self, rows, residual: float, detail: str = "") -> None:
        self.rows, self.residual = [int(r) for r in rows], float(residual)
        msg = (f"constraints are inconsistent: rows {self.rows} are dependent and conflict "
               f"(least-squares residual {self.residual:.3e}){_tail(detail)}; "
               "remove or fix the conflicting constraints")
        super().__init__(msg)


class ConvergenceError(PbanimError, RuntimeError):
    """An iterative solver stopped before reaching its tolerance.

    Attributes
    ----------
    iterations : int
    residual : float
    tol : float
    """

    def __init__(self, solver: str, iterations: int, residual: float, tol: float, detail: str = "") -> None:
        self.solver, self.iterations, self.residual, self.tol = solver, int(iterations), float(residual), float(tol)
        msg = (f"{solver} did not converge: residual {self.residual:.3e} > tol {self.tol:.1e} after "
               f"{self.iterations} iterations{_tail(detail)}; raise max_iter, loosen tol "
               "or use a direct solver")
        super().__init__(msg)


class SingularChartError(PbanimError, ValueError):
    """A reduced-coordinate chart is (nearly) singular: the generalized mass JᵀMJ lost rank."""

    def __init__(self, cond: float, u, detail: str = "") -> None:
        self.cond = float(cond)
        self.u = u
        msg = (f"reduced coordinates are near a singular chart: cond(JᵀMJ) = {self.cond:.3e} at u = {u}"
               f"{_tail(detail)}; switch to another chart or to maximal coordinates")
        super().__init__(msg)


class InfeasibleContact(PbanimError, RuntimeError):
    """A contact problem (QP or LCP) has no solution, or its solver failed.

    Attributes
    ----------
    status : str
        The solver's own status.
    residual : float
        Natural-map residual ‖f − max(0, f − (Af + b))‖ of the best iterate (nan when none).
    """

    def __init__(self, solver: str, status: str, residual: float = float("nan"), detail: str = "") -> None:
        self.solver = solver
        self.status = str(status)
        self.residual = float(residual)
        msg = (f"contact solver {solver!r} failed: status {self.status}, residual {self.residual:.3e}"
               f"{_tail(detail)}")
        super().__init__(msg)


class InconsistentContact(PbanimError, RuntimeError):
    """The acceleration-level contact LCP is inconsistent (e.g. Painlevé's paradox).

    Use the velocity-level (impulse) time-stepping scheme instead.
    """

    def __init__(self, detail: str = "") -> None:
        msg = ("acceleration-level contact problem is inconsistent (no contact forces satisfy the "
               f"complementarity conditions){_tail(detail)}; use the velocity-level scheme")
        super().__init__(msg)


class NonFiniteResult(PbanimError, FloatingPointError):
    """A computation on finite inputs produced NaN or Inf: the inputs are too large for double precision
    (a length of 1e300 m squared in an inertia, a speed of 1e200 m/s squared in a Coriolis term)."""

    def __init__(self, what: str, detail: str = "") -> None:
        self.what = what
        super().__init__(f"{what} is not finite although every input was{_tail(detail)}; the inputs are too "
                         "large for double precision (rescale the model)")


def check_result(what: str, value, detail: str = ""):
    """``value`` when every entry is finite, else :class:`NonFiniteResult` naming ``what``."""
    if not np.all(np.isfinite(value)):
        raise NonFiniteResult(what, detail)
    return value


# -- the helpers' own contracts (declared last: pbanim.contracts imports this module's errors) ------------
from .contracts import Anything, Array, Flag, Int, Opt, Real, Text, contract  # noqa: E402

_NAME = Text(nonempty=True)
_VALUE = Anything("the value under check: any value is answered, with itself converted or InvalidInput")
check_count = contract(name=_NAME, value=_VALUE, minimum=Int(), maximum=Opt(Int()))(check_count)
check_number = contract(name=_NAME, value=_VALUE, low=Real(finite=False), high=Real(finite=False), low_open=Flag(),
                        high_open=Flag())(check_number)
check_positive = contract(name=_NAME, value=_VALUE, fix=Text())(check_positive)
as_float = contract(name=_NAME, value=_VALUE)(as_float)
as_floats = contract(name=_NAME, value=_VALUE, ndmin=Int(ge=0, le=32))(as_floats)
check_result = contract(what=Text(nonempty=True), value=Array(None, nan=True, empty=True), detail=Text())(check_result)
