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

import difflib
import importlib
import math
import numbers
import os

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


# -- arrays ----------------------------------------------------------------------------------------------
_F64 = np.dtype(float)
_MIN, _MAX, _ISFINITE, _isfinite = np.minimum.reduce, np.maximum.reduce, np.isfinite, math.isfinite
_ALL = np.logical_and.reduce
_VDOT = np.vdot                 # one BLAS pass, no warning on overflow


def _seeded(label: str) -> np.random.Generator:
    return np.random.default_rng(sum(ord(c) * (i + 1) for i, c in enumerate(label)))


class Array(Spec):
    """A float array of a given shape (or any shape: ``shape=None``), finite and inside bounds elementwise.

    ``batch="first"`` / ``"last"`` admits one extra axis there (a batch of states); ``scalar=True`` admits
    one number for the whole array (returned as a float); ``empty=True`` admits zero entries.
    """

    def __init__(self, shape=None, *, ge=None, gt=None, le=None, lt=None, finite: bool = True,
                 batch: str | None = None, scalar: bool = False, empty: bool = False, nan: bool = False) -> None:
        if batch not in (None, "first", "last"):
            raise TypeError(f"batch must be None, 'first' or 'last', got {batch!r}")
        self.shape = None if shape is None else tuple(shape)
        self.bounds, self.finite, self.batch, self.scalar, self.empty = _Bounds(ge, gt, le, lt), finite, batch, \
            scalar, empty
        self.nan = nan              # NaN admitted too (an array under inspection, e.g. by a finiteness check)
        if nan:
            self.finite = False
        self._has_refs = self.shape is not None and any(_is_ref(d) for d in self.shape)
        self._bounded = self.bounds.lo is not None or self.bounds.hi is not None
        self._lo = -math.inf if self.bounds.lo is None else float(self.bounds.lo)
        self._hi = math.inf if self.bounds.hi is None else float(self.bounds.hi)

    def describe(self, env: Env | None = None) -> str:
        b = self.bounds.phrase()
        if self.shape is None:
            what = "a float array"
        else:
            shown = []
            for d in self.shape:
                if d is None:
                    shown.append("any")
                elif env is not None and _is_ref(d):
                    try:
                        shown.append(str(env.resolve(d)))
                    except InvalidInput:
                        shown.append(str(d))
                else:
                    shown.append(str(d if not callable(d) else "?"))
            what = f"a float array of shape ({', '.join(shown)}{',' if len(self.shape) == 1 else ''})"
            if env is not None:
                known = [f"{d} = {env.symbols[d]}" for d in self.shape
                         if isinstance(d, str) and not _is_ref(d) and d in env.symbols]
                known += [f"{d.lstrip('$')}" for d in self.shape if isinstance(d, str) and _is_ref(d)]
                if known:
                    what += f" ({', '.join(known)})"
        extra = [p for p in (
            "finite" if self.finite else "" if self.nan else "not NaN", f"entries {b}" if b else "",
            f"or a batch of them (extra {self.batch} axis)" if self.batch else "",
            "or one number for all" if self.scalar else "", "" if self.empty else "not empty") if p]
        return what + (f" ({', '.join(extra)})" if extra else "")

    def _dims(self, env: Env):
        return [env.resolve(d) if _is_ref(d) else d for d in self.shape] if self._has_refs else self.shape

    def check(self, name, value, env):
        if type(value) is np.ndarray and value.dtype is _F64:
            a = value
        else:
            if value is None or isinstance(value, (str, bytes, complex)) or \
                    isinstance(value, np.ndarray) and value.dtype.kind in "bcOSUV":
                raise env.fail(name, self.describe(env), value)
            try:
                a = np.asarray(value, dtype=float)
            except (TypeError, ValueError):
                raise env.fail(name, self.describe(env), value) from None
        if a.ndim == 0 and self.scalar:
            v = float(a)
            if not (math.isfinite(v) if self.finite else v == v) or not self.bounds.inside(v):
                raise env.fail(name, self.describe(env), value)
            return v
        if self.shape is not None:
            self._check_shape(name, a, value, env)
        if a.size == 0:
            if not self.empty:
                raise env.fail(name, self.describe(env), value, "it is empty")
            return a
        if self._bounded and self.bounds.hi is None and self.finite:   # a lower bound: the least entry, a·a
            lo = _MIN(a, None)
            if not _isfinite(_VDOT(a, a)) and not _ALL(_ISFINITE(a), None) or lo != lo:
                raise env.fail(name, self.describe(env), value, "it has NaN or inf entries")
            if lo < self._lo or self.bounds.lo_open and lo == self._lo:
                raise env.fail(name, self.describe(env), value, f"entries range over [{lo:g}, {_MAX(a, None):g}]")
        elif self._bounded:      # NaN propagates through min and max, ±inf lands in one of them
            lo, hi = _MIN(a, None), _MAX(a, None)
            if self.finite and not (_isfinite(lo) and _isfinite(hi)) or lo != lo or hi != hi:
                raise env.fail(name, self.describe(env), value, "it has NaN or inf entries" if self.finite else
                               "it has NaN entries")
            b = self.bounds
            if lo < self._lo or hi > self._hi or b.lo_open and lo == self._lo or b.hi_open and hi == self._hi:
                raise env.fail(name, self.describe(env), value, f"entries range over [{lo:g}, {hi:g}]")
        elif self.finite:       # a·a is NaN or inf when an entry is (or when it overflows: then entry by entry)
            if not _isfinite(_VDOT(a, a)) and not _ALL(_ISFINITE(a), None):
                raise env.fail(name, self.describe(env), value, "it has NaN or inf entries")
        elif not self.nan and np.isnan(a).any():
            raise env.fail(name, self.describe(env), value, "it has NaN entries")
        return a

    def _check_shape(self, name, a, value, env):
        dims = self._dims(env)
        shape = a.shape
        nd = len(dims)
        if len(shape) != nd:
            if self.batch and len(shape) == nd + 1:
                shape = shape[1:] if self.batch == "first" else shape[:-1]
            else:
                detail = ("a batch of states is not accepted here" if len(shape) == nd + 1 else
                          f"it has {len(shape)} axes, not {nd}")
                raise env.fail(name, self.describe(env), value, f"{detail} (shape {a.shape})")
        syms = env.symbols
        for d, s in zip(dims, shape):
            if d is None or d == s:
                continue
            if d.__class__ is str:          # a symbol: bound by its first use in the call
                want = syms.get(d)
                if want is None:
                    syms[d] = s
                    continue
                if want == s:
                    continue
            raise env.fail(name, self.describe(env), value, "" if isinstance(value, np.ndarray) and
                           value.size > 6 else f"shape {a.shape}")

    # -- the fuzzer's side --------------------------------------------------------------------------------
    def _example_shape(self, env):
        if self.shape is None:
            return (3,)
        out = []
        for d in self._dims(env):
            if d is None:
                out.append(2)
            elif isinstance(d, str):
                out.append(env.symbols.setdefault(d, 2))
            else:
                out.append(int(d))
        return tuple(out)

    def example(self, env):
        shape = self._example_shape(env)
        b = self.bounds
        mid = b.middle()
        a = mid + _seeded(repr(shape)).uniform(-0.25, 0.25, shape)
        lo = b.lo if b.lo is not None else -np.inf
        hi = b.hi if b.hi is not None else np.inf
        return np.clip(a, lo, hi) if (b.lo is not None or b.hi is not None) and not (
            b.lo_open or b.hi_open) else a

    def bad(self, env):
        a = self.example(env)
        out = [("None", None), ("a string", "1.0"), ("complex", a + 1j)]
        if a.size:
            for label, v in (("NaN", np.nan), ("inf", np.inf), ("-inf", -np.inf)):
                if v == v and not self.finite or self.nan:
                    continue
                w = a.copy()
                w.flat[0] = v
                out.append((f"a {label} entry", w))
            for label, v in self.bounds.outside():
                w = a.copy()
                w.flat[-1] = v
                out.append((f"an entry {label}", w))
        if self.shape is not None:
            out.append(("two extra axes", a[None, None]))
            if not self.batch:
                out.append(("a batch", np.stack([a, a])))
            if not self.empty and len(self.shape) >= 1:
                out.append(("empty", np.zeros((0,) + a.shape[1:])))
        elif not self.empty:
            out.append(("empty", np.zeros(0)))
        return out

    def edges(self, env):
        a = self.example(env)
        out = [("a nested list", a.tolist())]
        if self.bounds.inside(0.0):
            out.append(("zeros", np.zeros_like(a)))
        if self.bounds.hi is None and self.bounds.lo is None:
            out.append(("1e300 entries", np.full_like(a, 1e300)))
        if self.batch == "first":
            out.append(("a batch", np.stack([a, a])))
        elif self.batch == "last":
            out.append(("a batch", np.stack([a, a], axis=-1)))
        if self.scalar:
            out.append(("one number", float(self.bounds.middle())))
        return out


class Indices(Spec):
    """An integer array (or list) of indices into something of ``size`` items, of a given shape."""

    def __init__(self, size, shape=(None,), *, empty: bool = False, distinct: bool = False) -> None:
        self.size, self.shape, self.empty, self.distinct = size, tuple(shape), empty, distinct

    def describe(self) -> str:
        dims = ", ".join("any" if d is None else str(d) for d in self.shape)
        return (f"an integer array of shape ({dims}{',' if len(self.shape) == 1 else ''}) of indices in "
                f"0 … {self.size if isinstance(self.size, str) else 'size'} − 1"
                + (", distinct" if self.distinct else "") + ("" if self.empty else ", not empty"))

    def check(self, name, value, env):
        n = int(env.resolve(self.size))
        if value is None or isinstance(value, (str, bytes)):
            raise env.fail(name, self.describe(), value)
        try:
            a = np.asarray(value)
        except (TypeError, ValueError):
            raise env.fail(name, self.describe(), value) from None
        if a.size == 0:
            if not self.empty:
                raise env.fail(name, self.describe(), value, "it is empty")
            return np.zeros(a.shape if a.ndim == len(self.shape) else (0,) * len(self.shape), dtype=np.intp)
        if a.dtype.kind == "f" and np.isfinite(a).all() and (a == np.round(a)).all():
            a = a.astype(np.intp)
        if a.dtype.kind not in "iu":
            raise env.fail(name, self.describe(), value, "entries are not integers")
        if a.ndim != len(self.shape) or any(d is not None and not isinstance(d, str) and d != s
                                            for d, s in zip(self.shape, a.shape)):
            raise env.fail(name, self.describe(), value, f"shape {a.shape}")
        if a.min() < 0 or a.max() >= n:
            raise env.fail(name, f"indices in 0 … {n - 1}", value, f"entries range over [{a.min()}, {a.max()}]")
        if self.distinct and len(np.unique(a)) != a.size:
            raise env.fail(name, self.describe(), value, "an index repeats")
        return a.astype(np.intp, copy=False)

    def example(self, env):
        n = int(env.resolve(self.size))
        shape = tuple(1 if d is None or isinstance(d, str) else d for d in self.shape)
        return (np.arange(int(np.prod(shape))) % max(n, 1)).reshape(shape)

    def bad(self, env):
        n = int(env.resolve(self.size))
        a = self.example(env)
        out = [("None", None), ("a string", "0"), ("past the end", np.full_like(a, n)),
               ("negative", np.full_like(a, -1)), ("fractions", a + 0.5), ("NaN", np.full(a.shape, np.nan))]
        if not self.empty:
            out.append(("empty", np.zeros((0,) + a.shape[1:], dtype=int)))
        return out


# -- names, flags, objects -------------------------------------------------------------------------------
class Choice(Spec):
    """A name from a registry (a collection, or a callable returning one, read at each check)."""

    def __init__(self, options) -> None:
        self.options = options

    def _opts(self):
        opts = self.options() if callable(self.options) else self.options
        return list(opts)

    def describe(self) -> str:
        opts = self._opts()
        shown = ", ".join(repr(o) for o in opts[:12]) + (", ..." if len(opts) > 12 else "")
        return f"one of {shown}"

    def check(self, name, value, env):
        opts = self._opts()
        try:
            ok = value in opts and not isinstance(value, bool)
        except TypeError:
            ok = False
        if not ok:
            near = difflib.get_close_matches(value, [o for o in opts if isinstance(o, str)], n=3) \
                if isinstance(value, str) else []
            raise env.fail(name, self.describe(), value, f"did you mean {', '.join(map(repr, near))}?"
                           if near else "")
        return value

    def example(self, env):
        return self._opts()[0]

    def bad(self, env):
        return [("an unknown name", "no-such-name"), ("None", None), ("a number", 3.0)]


class Flag(Spec):
    """True or False (numpy bools too; 0, 1 and strings refused)."""

    def describe(self) -> str:
        return "True or False"

    def check(self, name, value, env):
        if not isinstance(value, (bool, np.bool_)):
            raise env.fail(name, self.describe(), value)
        return bool(value)

    def example(self, env):
        return False

    def bad(self, env):
        return [("None", None), ("a string", "yes"), ("a number", 2.0)]

    def edges(self, env):
        return [("True", True)]


class Text(Spec):
    """A string (``nonempty=True``: with at least one character)."""

    def __init__(self, *, nonempty: bool = False) -> None:
        self.nonempty = nonempty

    def describe(self) -> str:
        return "a non-empty string" if self.nonempty else "a string"

    def check(self, name, value, env):
        if not isinstance(value, str) or self.nonempty and not value:
            raise env.fail(name, self.describe(), value)
        return value

    def example(self, env):
        return "x"

    def bad(self, env):
        return [("None", None), ("a number", 1.0)] + ([("empty", "")] if self.nonempty else [])


class PathLike(Spec):
    """A file or folder path: a string or an ``os.PathLike``."""

    def describe(self) -> str:
        return "a path (a string or os.PathLike)"

    def check(self, name, value, env):
        if not isinstance(value, (str, os.PathLike)) or value == "":
            raise env.fail(name, self.describe(), value)
        return value

    def bad(self, env):
        return [("None", None), ("a number", 1.0), ("empty", "")]


class Func(Spec):
    """A callable (a function, a lambda, an object with ``__call__``)."""

    def describe(self) -> str:
        return "a callable"

    def check(self, name, value, env):
        if not callable(value) or isinstance(value, type) and False:
            raise env.fail(name, self.describe(), value)
        return value

    def bad(self, env):
        return [("None", None), ("a string", "f"), ("a number", 1.0)]


class Obj(Spec):
    """An instance of one of ``types`` (classes, or ``"module:Class"`` strings resolved on first use, so
    that a low layer can name a high layer's class without importing it)."""

    def __init__(self, *types, what: str | None = None) -> None:
        self.types, self.what, self._resolved = types, what, None

    def classes(self) -> tuple:
        if self._resolved is None:
            out = []
            for t in self.types:
                if isinstance(t, str):
                    mod, _, cls = t.partition(":")
                    t = getattr(importlib.import_module(mod), cls)
                out.append(t)
            self._resolved = tuple(out)
        return self._resolved

    def describe(self) -> str:
        if self.what:
            return self.what
        names = [t.rpartition(":")[2] if isinstance(t, str) else t.__name__ for t in self.types]
        return "an instance of " + " or ".join(names)

    def check(self, name, value, env):
        if not isinstance(value, self.classes()):
            raise env.fail(name, self.describe(), value, f"a {type(value).__name__}")
        return value

    def bad(self, env):
        return [("None", None), ("a string", "x"), ("a number", 1.0)]


class Has(Spec):
    """An object with the named members (a protocol checked by duck typing, e.g. a mechanical system)."""

    def __init__(self, *members: str, what: str | None = None) -> None:
        self.members, self.what = members, what

    def describe(self) -> str:
        return self.what or f"an object with {', '.join(self.members)}"

    def check(self, name, value, env):
        missing = [m for m in self.members if not hasattr(value, m)]
        if missing:
            raise env.fail(name, self.describe(), value, f"a {type(value).__name__} lacks {', '.join(missing)}")
        return value

    def bad(self, env):
        return [("None", None), ("a string", "x"), ("a number", 1.0)]


# -- combinators -----------------------------------------------------------------------------------------
class Seq(Spec):
    """A list or tuple (not a string) whose every item meets ``item``; returned as a list."""

    def __init__(self, item: Spec, *, min_len: int = 0, max_len: int | None = None) -> None:
        self.item, self.min_len, self.max_len = item, min_len, max_len

    def describe(self) -> str:
        n = f" of at least {self.min_len}" if self.min_len else ""
        return f"a list{n} of ({self.item.describe()})"

    def check(self, name, value, env):
        if not isinstance(value, (list, tuple)) or len(value) < self.min_len or \
                self.max_len is not None and len(value) > self.max_len:
            raise env.fail(name, self.describe(), value)
        return [self.item.check(f"{name}[{i}]", v, env) for i, v in enumerate(value)]

    def example(self, env):
        return [self.item.example(env) for _ in range(max(1, self.min_len))]

    def bad(self, env):
        out = [("None", None), ("a string", "x")]
        if self.min_len:
            out.append(("empty", []))
        out += [(f"an item {label}", [v]) for label, v in self.item.bad(env)[:3]]
        return out


class Opt(Spec):
    """None, or what ``spec`` accepts."""

    def __init__(self, spec: Spec) -> None:
        self.spec = spec

    def describe(self) -> str:
        return f"None or {self.spec.describe()}"

    def check(self, name, value, env):
        return None if value is None else self.spec.check(name, value, env)

    def example(self, env):
        return self.spec.example(env)

    def bad(self, env):
        return [(k, v) for k, v in self.spec.bad(env) if v is not None]

    def edges(self, env):
        return [("None", None)] + self.spec.edges(env)


class Either(Spec):
    """What the first of ``specs`` that accepts the value makes of it."""

    def __init__(self, *specs: Spec) -> None:
        self.specs = specs

    def describe(self) -> str:
        return ", or ".join(s.describe() for s in self.specs)

    def check(self, name, value, env):
        for s in self.specs:
            saved = dict(env.symbols)
            try:
                return s.check(name, value, env)
            except InvalidInput:
                env.symbols.clear()
                env.symbols.update(saved)
        raise env.fail(name, self.describe(), value)

    def example(self, env):
        return self.specs[0].example(env)

    def bad(self, env):
        out = []
        for label, v in self.specs[0].bad(env):
            try:
                self.check("x", v, Env("fuzz", env.values))
            except InvalidInput:
                out.append((label, v))
        return out

    def edges(self, env):
        return [e for s in self.specs for e in s.edges(env)]


class Anything(Spec):
    """No check: an explicit exemption, with its reason (printed by the surface test)."""

    def __init__(self, reason: str) -> None:
        if not reason:
            raise TypeError("Anything needs a reason")
        self.reason = reason

    def describe(self) -> str:
        return f"anything ({self.reason})"

    def check(self, name, value, env):
        return value

    def bad(self, env):
        return []
