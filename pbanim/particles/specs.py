"""Argument specs that chapters 01 and 03 need beyond :mod:`pbanim.contracts` (issue 27).

=========================  ==================================================================================
spec                       accepts
=========================  ==================================================================================
``IndexArray(shape, ...)`` an integer array of indices of a given shape (symbols bound across the call, as in
                           ``Array``): entries ≥ 0, or ≥ −1 with ``world=True`` (−1: a fixed point of the world),
                           below ``size`` when the size is known (an int or a reference), no index repeated in a
                           row (``distinct="rows"``: a rod or a spring joins two *different* ends) or anywhere
                           (``distinct="all"``)
``Buffer(shape)``          a float64 ndarray of that shape that the callable writes into (Q of ``apply``, the
                           ``out`` of ``kick_drift``): a list or an int array would be converted to a copy and the
                           writes lost, so they are refused; ``finite=False`` for an output buffer
``Direction(dims)``        a non-zero finite vector of one of the lengths ``dims`` (a normal, an axis)
``Matrix(shape)``          a dense or scipy.sparse 2-D matrix of finite floats (``sparse=True``: returned as CSR)
=========================  ==================================================================================

These read :class:`pbanim.contracts.Env` like the vocabulary's own specs: a shape entry is an int, None (any),
a symbol (a plain string, bound by its first use in the call) or a reference (a dotted string or ``$name``).
"""

from __future__ import annotations

import math

import numpy as np
import scipy.sparse as sp

from ..contracts import Array, Either, Env, Spec
from ..contracts.arrays import float_array_or_none

__all__ = ["IndexArray", "Buffer", "Direction", "Matrix", "point", "points"]


def _ref(d) -> bool:
    return callable(d) or isinstance(d, str) and ("." in d or d.startswith("$"))


def _match_shape(shape: tuple, got: tuple, env: Env) -> str:
    """Check ``got`` against ``shape`` and bind its symbols in ``env``; return a detail when it does not fit."""
    if len(got) != len(shape):
        return f"it has {len(got)} axes, not {len(shape)} (shape {got})"
    bound = {}
    for d, s in zip(shape, got):
        if d is None:
            continue
        if _ref(d):
            d = env.resolve(d)
        elif isinstance(d, str):
            want = env.symbols.get(d, bound.get(d))
            if want is None:
                bound[d] = s
                continue
            d = want
        if int(d) != s:
            return f"shape {got}"
    env.symbols.update(bound)
    return ""


def _example_shape(shape: tuple, env: Env, default: int = 1) -> tuple:
    out = []
    for d in shape:
        if d is None:
            out.append(default)
        elif _ref(d):
            out.append(int(env.resolve(d)))
        elif isinstance(d, str):
            out.append(env.symbols.setdefault(d, default))
        else:
            out.append(int(d))
    return tuple(out)


def _dims(shape: tuple) -> str:
    text = ", ".join("any" if d is None else str(d) for d in shape)
    return f"({text}{',' if len(shape) == 1 else ''})"


class IndexArray(Spec):
    """An integer array of indices (see the module docstring); returned as an ``intp`` array."""

    def __init__(self, shape=(None,), *, size=None, world: bool = False, distinct: str | None = None,
                 empty: bool = False, what: str = "particle indices") -> None:
        if distinct not in (None, "rows", "all"):
            raise TypeError(f"distinct must be None, 'rows' or 'all', got {distinct!r}")
        self.shape, self.size, self.world, self.distinct, self.empty, self.what = \
            tuple(shape), size, world, distinct, empty, what

    def describe(self, env: Env | None = None) -> str:
        n = self.size if isinstance(self.size, (int, str)) else "size"
        if env is not None and self.size is not None:
            n = env.resolve(self.size)
        lo = "-1 (a fixed world point)" if self.world else "0"
        hi = "" if self.size is None else f" and < {n}"
        rows = {"rows": ", no index twice in a row", "all": ", all distinct", None: ""}[self.distinct]
        return (f"an integer array of shape {_dims(self.shape)} of {self.what} >= {lo}{hi}{rows}"
                + ("" if self.empty else ", not empty"))

    def check(self, name, value, env):
        if value is None or isinstance(value, (str, bytes, bool)):
            raise env.fail(name, self.describe(env), value)
        try:
            a = np.asarray(value)
        except (TypeError, ValueError):
            raise env.fail(name, self.describe(env), value) from None
        if a.size == 0 and a.ndim < len(self.shape):     # [] for (m, 2): no rows
            a = a.reshape((0,) + tuple(d if isinstance(d, int) else 0 for d in self.shape[1:]))
        if a.dtype.kind == "f" and a.size and np.isfinite(a).all() and (a == np.round(a)).all():
            a = a.astype(np.intp)
        elif a.dtype.kind == "f" and not a.size:
            a = a.astype(np.intp)
        if a.dtype.kind not in "iu":
            raise env.fail(name, self.describe(env), value, "entries are not integers")
        detail = _match_shape(self.shape, a.shape, env)
        if detail:
            raise env.fail(name, self.describe(env), value, detail)
        if a.size == 0:
            if not self.empty:
                raise env.fail(name, self.describe(env), value, "it is empty")
            return a.astype(np.intp)
        lo, hi = int(a.min()), int(a.max())
        if lo < (-1 if self.world else 0):
            raise env.fail(name, self.describe(env), value, f"an index is {lo}")
        if self.size is not None and hi >= int(env.resolve(self.size)):
            raise env.fail(name, self.describe(env), value, f"an index is {hi}")
        if self.distinct == "all" and len(np.unique(a)) != a.size:
            raise env.fail(name, self.describe(env), value, "an index repeats")
        if self.distinct == "rows" and a.ndim == 2 and a.shape[1] > 1:
            s = np.sort(a, axis=1)
            same = np.flatnonzero((s[:, 1:] == s[:, :-1]).any(axis=1))
            if same.size:
                r = int(same[0])
                raise env.fail(name, self.describe(env), value, f"row {r} is {a[r].tolist()}")
        return a.astype(np.intp, copy=False)

    def example(self, env):
        shape = _example_shape(self.shape, env)
        k = shape[-1] if len(shape) > 1 else 1
        n = int(env.resolve(self.size)) if self.size is not None else k
        row = np.arange(k) % max(n, 1)
        return np.broadcast_to(row, shape).copy() if len(shape) > 1 else np.arange(shape[0]) % max(n, 1)

    def bad(self, env):
        a = self.example(env)
        out = [("None", None), ("a string", "0"), ("fractions", a + 0.5), ("NaN", np.full(a.shape, np.nan)),
               ("below the lowest index", np.full_like(a, -2 if self.world else -1))]
        if self.size is not None:
            out.append(("past the end", np.full_like(a, int(env.resolve(self.size)))))
        if a.ndim >= 1:
            out.append(("two extra axes", a[None, None]))
        if not self.empty:
            out.append(("empty", np.zeros((0,) + a.shape[1:], dtype=int)))
        if self.distinct == "rows" and a.ndim == 2 and a.shape[1] > 1:
            out.append(("a row with an index twice", np.zeros_like(a)))
        if self.distinct == "all" and a.size > 1:
            out.append(("an index twice", np.zeros_like(a)))
        return out

    def edges(self, env):
        a = self.example(env)
        out = [("a nested list", a.tolist())]
        if self.empty:
            out.append(("empty", np.zeros((0,) + a.shape[1:], dtype=int)))
        return out


class Buffer(Spec):
    """A float64 ndarray of a shape, written in place (returned as the same object)."""

    def __init__(self, shape, *, finite: bool = True) -> None:
        self.shape, self.finite = tuple(shape), finite

    def describe(self, env: Env | None = None) -> str:
        what = f"a float64 numpy array of shape {_dims(self.shape)}"
        if env is not None:
            dims = [env.resolve(d) if _ref(d) else env.symbols.get(d, d) if isinstance(d, str) else d
                    for d in self.shape]
            what = f"a float64 numpy array of shape {_dims(tuple(dims))}"
        return what + (", finite" if self.finite else "") + " (written in place: a list would be a copy)"

    def check(self, name, value, env):
        if not isinstance(value, np.ndarray) or value.dtype != np.float64:
            raise env.fail(name, self.describe(env), value)
        detail = _match_shape(self.shape, value.shape, env)
        if detail:
            raise env.fail(name, self.describe(env), value, detail)
        if not value.flags.writeable:
            raise env.fail(name, self.describe(env), value, "it is read-only")
        if self.finite and value.size and not math.isfinite(np.add.reduce(value, axis=None)) \
                and not np.isfinite(value).all():
            raise env.fail(name, self.describe(env), value, "it has NaN or inf entries")
        return value

    def example(self, env):
        return np.zeros(_example_shape(self.shape, env, 2))

    def bad(self, env):
        a = self.example(env)
        out = [("None", None), ("a list", a.tolist()), ("an int array", a.astype(int)),
               ("two extra axes", a[None, None])]
        if a.size:
            ro = a.copy()
            ro.flags.writeable = False
            out.append(("read-only", ro))
            if self.finite:
                w = a.copy()
                w.flat[0] = np.nan
                out.append(("a NaN entry", w))
        return out

    def edges(self, env):
        a = self.example(env)
        # an output buffer's old entries stay where the callable writes nothing: no NaN edge for it
        return [("1e300 entries", np.full_like(a, 1e300))] if self.finite else [("ones", np.ones_like(a))]


def point(rows=None) -> Either:
    """A point (or vector) in 2-D or 3-D, shape (2,) or (3,); with ``rows``: one per row, (rows, 2|3)."""
    if rows is None:
        return Either(Array((2,)), Array((3,)))
    return Either(Array((rows, 2)), Array((rows, 3)))


def points(rows) -> Either:
    """One point for all rows, or one per row: (2,), (3,), (rows, 2) or (rows, 3)."""
    return Either(Array((2,)), Array((3,)), Array((rows, 2)), Array((rows, 3)))


class Direction(Spec):
    """A non-zero finite vector of length 2 or 3 (a normal, a direction); returned as a float array."""

    def __init__(self, dims=(2, 3)) -> None:
        self.dims = tuple(dims)
        self._inner = Either(*[Array((d,)) for d in self.dims])

    def describe(self) -> str:
        return f"a non-zero finite vector of length {' or '.join(map(str, self.dims))}"

    def check(self, name, value, env):
        try:
            a = self._inner.check(name, value, env)
        except Exception:
            raise env.fail(name, self.describe(), value) from None
        if not np.any(a) or not math.isfinite(float(np.linalg.norm(a))):
            raise env.fail(name, self.describe(), value, "its length is 0" if not np.any(a) else "its length overflows")
        return a

    def example(self, env):
        return np.eye(self.dims[0])[-1]

    def bad(self, env):
        d = self.dims[0]
        return [("None", None), ("a string", "x"), ("zero", np.zeros(d)), ("NaN", np.full(d, np.nan)),
                ("a wrong length", np.ones(max(self.dims) + 1)), ("a batch", np.ones((2, d)))]

    def edges(self, env):
        d = self.dims[0]
        return [("tiny", np.full(d, 1e-300)), ("huge", np.full(d, 1e300)), ("a nested list", [1.0] * d)]


class Matrix(Spec):
    """A 2-D matrix, dense (array_like) or scipy.sparse, of finite floats, of a shape (symbols bound across the
    call); returned as a float ndarray, or as the sparse matrix (CSR with ``sparse=True``, which also turns a
    dense one into CSR)."""

    def __init__(self, shape=(None, None), *, sparse: bool = False) -> None:
        self.shape, self.sparse = tuple(shape), sparse

    def describe(self, env: Env | None = None) -> str:
        return f"a matrix (dense or scipy.sparse) of shape {_dims(self.shape)} with finite entries"

    def check(self, name, value, env):
        if sp.issparse(value):
            m = value.tocsr()
            data = m.data
            if data.dtype.kind not in "fiu":
                raise env.fail(name, self.describe(env), value, f"dtype {data.dtype}")
        else:
            m = float_array_or_none(value)
            if m is None:
                raise env.fail(name, self.describe(env), value)
            data = m
        detail = _match_shape(self.shape, tuple(m.shape), env)
        if detail:
            raise env.fail(name, self.describe(env), value, detail)
        if data.size and not np.isfinite(data).all():
            raise env.fail(name, self.describe(env), value, "it has NaN or inf entries")
        if sp.issparse(m):
            return m if m.dtype == np.float64 else m.astype(float)
        return sp.csr_matrix(m) if self.sparse else m

    def example(self, env):
        shape = _example_shape(self.shape, env, 2)
        a = np.zeros(shape)
        k = min(shape)
        a[range(k), range(k)] = 2.0
        return a

    def bad(self, env):
        a = self.example(env)
        w = a.copy()
        w.flat[0] = np.nan
        s = sp.csr_matrix(a)
        s.data[:] = np.inf
        return [("None", None), ("a string", "A"), ("a NaN entry", w), ("a sparse inf entry", s),
                ("a vector", a[0]), ("complex", a + 1j)]

    def edges(self, env):
        a = self.example(env)
        return [("sparse", sp.csr_matrix(a)), ("zeros", np.zeros_like(a)), ("1e300 entries", a * 5e299)]
