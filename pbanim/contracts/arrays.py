"""The array specs of the contract vocabulary: :class:`Array` (a float array of a shape, its bounds, a batch)
and :class:`Indices` (an integer array of indices). See :mod:`pbanim.contracts.specs` for the vocabulary and
its table; every name here is also importable from there."""

from __future__ import annotations

import math

import numpy as np

from ..errors import InvalidInput
from .specs import Env, Spec, _Bounds, _is_ref

__all__ = ["Array", "Indices"]


# -- arrays ----------------------------------------------------------------------------------------------
_F64 = np.dtype(float)
_MIN, _MAX, _ISFINITE, _isfinite = np.minimum.reduce, np.maximum.reduce, np.isfinite, math.isfinite
_ALL = np.logical_and.reduce
_VDOT = np.vdot                 # one BLAS pass, no warning on overflow



def float_array_or_none(value) -> np.ndarray | None:
    """``value`` as an array of floats, or None when it is not numbers: None, text, bytes, complex numbers,
    booleans, objects, or anything ``np.asarray(value, dtype=float)`` refuses (the one coercion of every
    array contract, dense or sparse)."""
    if value is None or isinstance(value, (str, bytes, complex)) or \
            isinstance(value, np.ndarray) and value.dtype.kind in "bcOSUV":
        return None
    try:
        return np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        return None

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
            a = float_array_or_none(value)
            if a is None:
                raise env.fail(name, self.describe(env), value)
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
