"""What one argument must be: the vocabulary of argument contracts.

Each :class:`Spec` says, once, what a public argument must be. Three readers use it:

* the boundary check (:mod:`pbanim.contracts.declare`): ``spec.check(name, value, env)`` returns the
  value converted (a float, an int, a float array) or raises :class:`~pbanim.errors.InvalidInput` whose
  message names the argument, says what was expected and shows what came in;
* the fuzzer (``tests/test_contracts_fuzz.py``): ``spec.example(env)`` is a valid value, ``spec.bad(env)``
  the values the check must refuse (NaN, ±inf, out of range, a string, None, an empty array, a wrong
  shape, a batch where one state is expected), ``spec.edges(env)`` the valid values at the edges of the
  domain (zero, a bound, 10³⁰⁰, an empty or a batched array where those are allowed);
* the reader: ``spec.describe()`` is the phrase in the messages ("a finite number > 0").

========================  =====================================================================
spec                      accepts
========================  =====================================================================
``Real(ge=, gt=, le=, lt=)``  one finite number in the range (``finite=False``: ±inf allowed) → float
``Int(ge=, le=)``         one integer (2.0 accepted, 2.5, True and "2" refused) → int
``Index(size)``           an integer in 0 … size − 1 (size: an int, a reference, or a callable of env)
``Array(shape, ...)``     a float array of that shape (ints, symbols bound across the call, None = any;
                          ``batch="first"`` or ``"last"``: one extra axis for a batch of states;
                          ``scalar=True``: a number broadcast to the shape; bounds apply elementwise)
``Indices(size, shape)``  an integer array of indices into something of that size
``Choice(options)``       a name from a registry (a collection, or a callable returning one)
``Flag()``                True or False
``Text()``, ``PathLike()``  a string; a string or a path
``Func()``                a callable
``Obj(*types)``           an instance of one of the types (classes, or "module:Class" resolved lazily)
``Has(*members)``         an object with these members (a protocol by duck typing)
``Seq(item)``             a list or tuple whose every item meets ``item``
``Opt(spec)``             None, or what ``spec`` accepts
``Either(*specs)``        what the first spec that accepts it makes of it
``Anything(reason)``      anything: an exemption, with its reason
========================  =====================================================================

A reference (``"system.N"``, ``"positions"``) names another argument of the same call, then
attributes of it; a string in a shape that names no argument is a symbol, bound by its first use in the
call (``Array(("n", 3))`` for positions and ``Array(("n",))`` for masses: the same n).
"""

from __future__ import annotations

import math
import numbers

import numpy as np

from ..errors import InvalidInput

__all__ = ["Spec", "Real", "Int", "Index", "Array", "Indices", "Choice", "Flag", "Text", "PathLike", "Func",
           "Obj", "Has", "Seq", "Opt", "Either", "Anything", "Env", "short"]


def short(value, limit: int = 60) -> str:
    """``repr(value)`` cut to ``limit`` characters; arrays as their shape and dtype when large."""
    if isinstance(value, np.ndarray) and value.size > 6:
        return f"an array of shape {value.shape} and dtype {value.dtype}"
    text = " ".join(repr(value).split())     # one line
    return text if len(text) <= limit else text[:limit] + "..."


class Env:
    """The call being checked: its function name, its argument values, its shape symbols."""

    __slots__ = ("where", "values", "symbols")

    def __init__(self, where: str, values: dict) -> None:
        self.where, self.values, self.symbols = where, values, {}

    def resolve(self, ref):
        """An int, a callable of the env, or a dotted reference to an argument and its attributes."""
        if callable(ref):
            return ref(self)
        if not isinstance(ref, str):
            return ref
        head, *attrs = ref.lstrip("$").split(".")
        try:
            obj = self.values[head]
            for a in attrs:
                obj = getattr(obj, a)
        except (KeyError, AttributeError) as exc:
            raise InvalidInput(f"{self.where}: cannot check the arguments against {ref}: {exc} (is the object "
                               "bound to a system, or built completely?)") from None
        return obj() if callable(obj) else obj

    def fail(self, name: str, expected: str, value, detail: str = "") -> InvalidInput:
        tail = f"; {detail}" if detail else ""
        return InvalidInput(f"{self.where}: {name} must be {expected}, got {short(value)}{tail}")


def _is_ref(ref) -> bool:
    """A reference to another argument: a callable of the env, or a string with a dot or a leading $
    ("system.N", "$n"); any other string in a shape is a symbol."""
    return callable(ref) or isinstance(ref, str) and ("." in ref or ref.startswith("$"))


class Spec:
    """What one argument must be. Subclasses define ``check`` and ``describe``, and the fuzzer's
    ``example``, ``bad`` and ``edges``."""

    def check(self, name: str, value, env: Env):
        raise NotImplementedError

    def describe(self) -> str:
        raise NotImplementedError

    def example(self, env: Env):
        raise NotImplementedError(f"no example for {self.describe()}: give one in the fuzz's examples")

    def bad(self, env: Env) -> list:
        """(label, value) pairs that the check must refuse."""
        return [("None", None), ("a string", "x")]

    def edges(self, env: Env) -> list:
        """(label, value) pairs inside the contract, at the edges of its domain."""
        return []

    def __repr__(self) -> str:
        return f"<{type(self).__name__}: {self.describe()}>"


# -- numbers ---------------------------------------------------------------------------------------------
class _Bounds:
    """Closed or open bounds of a range, their phrase, and a value inside them."""

    def __init__(self, ge=None, gt=None, le=None, lt=None) -> None:
        if ge is not None and gt is not None or le is not None and lt is not None:
            raise TypeError("give ge or gt, le or lt, not both")
        self.lo, self.lo_open = (gt, True) if gt is not None else (ge, False)
        self.hi, self.hi_open = (lt, True) if lt is not None else (le, False)

    def inside(self, v) -> bool:
        lo, hi = self.lo, self.hi
        return ((lo is None or (v > lo if self.lo_open else v >= lo))
                and (hi is None or (v < hi if self.hi_open else v <= hi)))

    def phrase(self) -> str:
        parts = []
        if self.lo is not None:
            parts.append(f"{'>' if self.lo_open else '>='} {self.lo:g}")
        if self.hi is not None:
            parts.append(f"{'<' if self.hi_open else '<='} {self.hi:g}")
        return " and ".join(parts)

    def middle(self) -> float:
        lo, hi = self.lo, self.hi
        if lo is not None and hi is not None:
            return (lo + hi) / 2
        if lo is not None:
            return lo + 1.0
        if hi is not None:
            return hi - 1.0
        return 0.5

    def outside(self) -> list:
        out = []
        if self.lo is not None:
            out.append(("below the range", self.lo - max(1.0, abs(self.lo))))
            if self.lo_open:
                out.append(("at the open lower bound", self.lo))
        if self.hi is not None:
            out.append(("above the range", self.hi + max(1.0, abs(self.hi))))
            if self.hi_open:
                out.append(("at the open upper bound", self.hi))
        return out

    def at(self) -> list:
        out = []
        if self.lo is not None:
            out.append(("the lower bound", self.lo) if not self.lo_open else ("just above the lower bound",
                                                                              self.lo + max(1e-300, abs(self.lo) * 1e-12)))
        else:
            out.append(("-1e300", -1e300))
        if self.hi is not None:
            out.append(("the upper bound", self.hi) if not self.hi_open else ("just below the upper bound",
                                                                              self.hi - max(1e-300, abs(self.hi) * 1e-12)))
        else:
            out.append(("1e300", 1e300))
        if self.inside(0.0):
            out.append(("zero", 0.0))
        return out


class Real(Spec):
    """One number (a Python or numpy real, or a 0-d array) in a range; ``finite=False`` admits ±inf
    (never NaN)."""

    def __init__(self, *, ge=None, gt=None, le=None, lt=None, finite: bool = True) -> None:
        self.bounds, self.finite = _Bounds(ge, gt, le, lt), finite
        b = self.bounds     # the range as plain floats, for a check with no method call
        self._lo = -math.inf if b.lo is None else float(b.lo)
        self._hi = math.inf if b.hi is None else float(b.hi)

    def describe(self) -> str:
        b = self.bounds.phrase()
        return f"{'a finite' if self.finite else 'a'} number{' ' + b if b else ''}" + ("" if self.finite else
                                                                                         " (not NaN)")

    def check(self, name, value, env):
        if type(value) is float or type(value) is int:
            v = float(value)
        elif isinstance(value, (bool, np.bool_)) or not isinstance(value, (numbers.Real, np.ndarray)) or \
                isinstance(value, np.ndarray) and (value.ndim or value.dtype.kind not in "fiu"):
            raise env.fail(name, self.describe(), value)
        else:
            v = float(value)
        lo, hi, b = self._lo, self._hi, self.bounds
        if not (lo <= v <= hi) or (b.lo_open and v == lo) or (b.hi_open and v == hi) or \
                (self.finite and (v == math.inf or v == -math.inf)):
            raise env.fail(name, self.describe(), value)
        return v

    def example(self, env):
        return self.bounds.middle()

    def bad(self, env):
        out = [("NaN", math.nan), ("None", None), ("a string", "1.0"), ("a batch", [1.0, 1.0]), ("empty", [])]
        if self.finite:
            out += [("inf", math.inf), ("-inf", -math.inf)]
        return out + self.bounds.outside()

    def edges(self, env):
        return self.bounds.at()


class Int(Spec):
    """One integer in a range (a float equal to an integer is accepted; bools and strings are not)."""

    def __init__(self, *, ge=None, le=None) -> None:
        self.bounds = _Bounds(ge=ge, le=le)

    def describe(self) -> str:
        b = self.bounds
        if b.lo in (0, 1) and b.hi is None:
            return "a positive integer" if b.lo == 1 else "a non-negative integer"
        phrase = b.phrase()
        return f"an integer{' ' + phrase if phrase else ''}"

    def check(self, name, value, env):
        if isinstance(value, (bool, np.bool_)) or not isinstance(value, (numbers.Real, np.integer, np.floating)) \
                or not math.isfinite(value) or int(value) != value or not self.bounds.inside(value):
            raise env.fail(name, self.describe(), value)
        return int(value)

    def example(self, env):
        lo, hi = self.bounds.lo, self.bounds.hi
        v = int(lo + 1) if lo is not None else 1
        return v if hi is None or v <= hi else int(lo if lo is not None else hi)

    def bad(self, env):
        return [("NaN", math.nan), ("inf", math.inf), ("a fraction", 1.5), ("None", None), ("a string", "1"),
                ("a batch", [1, 1])] + [(k, int(v)) for k, v in self.bounds.outside()]

    def edges(self, env):
        return [("the lower bound", int(self.bounds.lo))] if self.bounds.lo is not None else [("zero", 0)]


class Index(Spec):
    """An integer index into something of ``size`` items (0 … size − 1; negative indices refused)."""

    def __init__(self, size) -> None:
        self.size = size

    def describe(self) -> str:
        return f"an index in 0 … {self.size if isinstance(self.size, str) else 'size'} − 1"

    def check(self, name, value, env):
        n = int(env.resolve(self.size))
        if isinstance(value, (bool, np.bool_)) or not isinstance(value, (numbers.Integral, np.integer)) \
                or not 0 <= value < n:
            raise env.fail(name, f"an index in 0 … {n - 1}" if n else "an index, but there is nothing to index",
                           value)
        return int(value)

    def example(self, env):
        return 0

    def bad(self, env):
        n = int(env.resolve(self.size))
        return [("negative", -1), ("past the end", n), ("a fraction", 0.5), ("None", None), ("a string", "0")]

    def edges(self, env):
        n = int(env.resolve(self.size))
        return [("the last", n - 1)] if n > 0 else []


# the arrays and the other kinds live in their own modules; every name of the vocabulary is importable from here
from .arrays import Array, Indices  # noqa: E402
from .kinds import Anything, Choice, Either, Flag, Func, Has, Obj, Opt, PathLike, Seq, Text  # noqa: E402
