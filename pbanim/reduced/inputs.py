"""What the inputs of chapter 04 must be: specs the vocabulary of :mod:`pbanim.contracts` lacks.

==================  =======================================================================================
spec                accepts
==================  =======================================================================================
``Expr()``          a finite real number (an int stays exact) or a real sympy expression (no nan, ±oo, zoo, I)
``SYMBOL``          a sympy Symbol (a coordinate u or the time t); ``COORDS``: a non-empty list of them
``EXPRESSIONS``     a list of ``Expr`` (flat positions q(u, t)) or a sympy Matrix
``PointMass()``     a pair (m, r): m > 0 finite (a number or a positive sympy number), r 1–3 expressions
``Hashable()``      any value usable as a dict key (a model's cache key)
==================  =======================================================================================

The checks of sympy values live here once (:func:`nonreal`, :func:`mass_problem`): the specs use them at
the boundary and the derivation uses them for values that arrive from inside pbanim. sympy is imported
only when a value is not a plain number, so ``import pbanim.reduced`` does not import it.
"""

from __future__ import annotations

import math
import numbers

import numpy as np

from ..contracts import Either, Obj, Seq, Spec
from ..errors import InvalidInput

__all__ = ["Expr", "SYMBOL", "COORDS", "EXPRESSIONS", "PointMass", "Hashable", "nonreal", "mass_problem", "validate_points"]


class Expr(Spec):
    """A real number or a sympy expression (the vocabulary of :mod:`pbanim.contracts` has no sympy spec).

    A finite Python or numpy real is accepted (an int stays an int, so sympy keeps it exact); NaN, ±inf,
    a complex number, a string (sympy would ``eval`` it) and None are refused. A sympy expression is
    accepted unless it holds nan, ±oo, zoo or the imaginary unit I (a position or a mass must be real and
    finite). sympy is imported only when a value is not a plain number.
    """

    def describe(self) -> str:
        return "a finite real number or a real sympy expression"

    def check(self, name, value, env):
        if isinstance(value, (bool, np.bool_)) or value is None or isinstance(value, (str, bytes)):
            raise env.fail(name, self.describe(), value)
        if isinstance(value, numbers.Number):
            if not isinstance(value, numbers.Real) or not math.isfinite(value):
                raise env.fail(name, self.describe(), value)
            return value if isinstance(value, (int, np.integer)) else float(value)
        bad = nonreal(value)
        if bad is None:
            raise env.fail(name, self.describe(), value, f"a {type(value).__name__}")
        if bad:
            raise env.fail(name, self.describe(), value, f"it holds {bad}")
        return value

    def example(self, env):
        return 0.5

    def bad(self, env):
        return [("NaN", math.nan), ("complex", 1j), ("inf", math.inf), ("None", None), ("a string", "x")]

    def edges(self, env):
        return [("zero", 0), ("1e300", 1e300)]


def nonreal(e) -> str | None:
    """For a sympy object: "" when it holds no nan, ±oo, zoo or I, else the first it holds; None when ``e``
    is not a sympy object. (The one check of sympy inputs: specs and internal callers use it.)"""
    import sympy

    if not isinstance(e, (sympy.Basic, sympy.MatrixBase)):
        return None
    S = sympy.S
    for atom, text in ((S.NaN, "nan"), (S.Infinity, "oo"), (S.NegativeInfinity, "-oo"), (S.ComplexInfinity, "zoo"),
                       (S.ImaginaryUnit, "the imaginary unit I")):
        if e.has(atom):
            return text
    return ""


SYMBOL = Obj("sympy:Symbol", what="a sympy Symbol (sympy.symbols('q1 q2'); time enters through the t argument, "
                                  "not dynamicsymbols)")
COORDS = Seq(SYMBOL, min_len=1)
EXPRESSIONS = Either(Seq(Expr()), Obj("sympy:MatrixBase", what="a sympy Matrix of expressions"))


def mass_problem(m) -> str:
    """Why ``m`` cannot be a point mass ("" when it can): the one check of masses, for the contract
    (:class:`PointMass`) and for internal callers. sympy comparisons are never made on NaN or complex
    values (they raise sympy's own TypeError): the answer comes from the number's assumptions."""
    import sympy

    if isinstance(m, (bool, np.bool_)) or m is None or isinstance(m, (str, bytes)):
        return "it is not a number"
    try:
        x = sympy.sympify(m)
    except (sympy.SympifyError, TypeError, ValueError):
        return "it is not a number"
    if not isinstance(x, sympy.Expr) or not x.is_number:
        return "it is not a number (substitute numbers for parameters)"
    if nonreal(x):
        return f"it is not a finite real number (it holds {nonreal(x)})"
    if x.is_positive is not True or x.is_finite is not True:
        return "it is not > 0"
    return ""


class PointMass(Spec):
    """A point mass of :func:`derive_equations`: a pair (mass, position), the mass a finite number > 0 (or
    a positive sympy number), the position 1–3 real expressions in the coordinates (or a sympy Matrix)."""

    _POSITION = Either(Seq(Expr(), min_len=1, max_len=3), Obj("sympy:MatrixBase"))

    def describe(self) -> str:
        return "a pair (mass > 0, position of 1–3 real expressions)"

    def check(self, name, value, env):
        if not (isinstance(value, (list, tuple)) and len(value) == 2):
            raise env.fail(name, self.describe(), value)
        m, r = value
        why = mass_problem(m)
        if why:
            raise env.fail(f"{name} mass", "a finite number > 0 (or a positive sympy number)", m, why)
        return (m, self._POSITION.check(f"{name} position", r, env))

    def example(self, env):
        return (1.0, [0.5])

    def bad(self, env):
        return [("a NaN mass", (math.nan, [0.5])), ("a complex mass", (1 + 2j, [0.5])),
                ("a negative mass", (-1.0, [0.5])), ("None", None), ("a string", "x"), ("a triple", (1.0, [0.5], 0))]


class Hashable(Spec):
    """Any value usable as a dict key (the vocabulary of :mod:`pbanim.contracts` has no such spec)."""

    def describe(self) -> str:
        return "a hashable value (a tuple of numbers and names, say)"

    def check(self, name, value, env):
        try:
            hash(value)
        except TypeError:
            raise env.fail(name, self.describe(), value, "it is unhashable") from None
        return value

    def example(self, env):
        return ("example",)

    def bad(self, env):
        return [("a list", ["n_link", 3]), ("a dict", {"n": 3})]

    def edges(self, env):
        return [("None", None)]


def validate_points(points) -> list:
    """The point masses of a derivation as [(m, [r₁, …])] of sympy numbers and expressions (one dimension
    for all, 1–3), or InvalidInput naming the point (for internal callers; the boundary has PointMass)."""
    import sympy

    out, dim = [], None
    for k, item in enumerate(points):
        if not (isinstance(item, (list, tuple)) and len(item) == 2):
            raise InvalidInput(f"points[{k}] must be a pair (mass, position), got {item!r}")
        m, r = item
        r = list(r)
        if dim is None:
            dim = len(r)
        if len(r) != dim or dim not in (1, 2, 3):
            raise InvalidInput(f"points[{k}] position must have {dim} components (all points share one "
                             f"dimension, 1–3), got {len(r)}")
        why = mass_problem(m)
        if why:
            raise InvalidInput(f"points[{k}] mass must be a finite number > 0, got {m!r}; {why}")
        out.append((sympy.sympify(m), [sympy.sympify(e) for e in r]))
    return out
