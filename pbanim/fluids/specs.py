"""Argument specs of chapter 09 that the shared vocabulary (:mod:`pbanim.contracts.specs`) lacks (issue 27).

=======================  ======================================================================================
spec                     accepts
=======================  ======================================================================================
``GridShape()``          2 or 3 cell counts nᵢ ≥ 3 (``dims``, ``minimum`` to narrow), Π nᵢ ≤ ``MAX_CELLS``
``Mask(shape)``          a boolean (or 0/1) cell mask of that shape with at least one fluid (False) cell
``Cells(grid)``          a float array of the grid's cell shape (``faces=i``: of the faces of axis i; ``faces``
                         may name the argument that holds i; ``pad=g``: g ghost layers on every side)
``Velocity(grid)``       d float arrays: uᵢ on the faces of axis i (``at="cells"``: Stam's d cell arrays)
``Points(grid)``         d finite coordinate arrays of one shape (where a field is sampled)
``Named(item)``          a dict from non-empty names (or from ``keys``) to what ``item`` accepts
``StateOn(grid)``        a :class:`~pbanim.fluids.scene.FluidState` whose fields fit the grid, float64 arrays (an
                         effect's ``apply`` writes them in place), finite
``Slots(grid)``          a list of d entries that the callable overwrites (the ``out`` of ``Grid.gradient``)
=======================  ======================================================================================

``grid`` names the argument holding the :class:`~pbanim.fluids.grid.Grid` (``"self"`` for its methods), kept
as a reference (``size = "$grid"``): the contract checks the grid before the fields. ``MAX_CELLS`` = 2²² (2048²,
160³ cells) bounds what one call costs before it starts (a field is at most 32 MiB, a sweep or a step touches
each cell a fixed number of times); ``MAX_SWEEPS`` and ``MAX_ITER`` cap relaxation sweeps and Krylov iterations.

Results are lists of fields and (field, :class:`~pbanim.fluids.poisson.SolveInfo`) pairs, deeper than
:func:`pbanim.contracts.finite_result` reads: :func:`finite_fields` is their certificate
(:class:`~pbanim.errors.NonFiniteResult`), and :func:`quiet` silences numpy's overflow warnings on the way.
"""

from __future__ import annotations

import functools
import math
import numbers
import os
from sys import _getframe

import numpy as np

from ..contracts import Array, Int, Spec
from ..errors import NonFiniteResult

__all__ = ["MAX_CELLS", "MAX_SWEEPS", "MAX_ITER", "GridShape", "Mask", "Cells", "Velocity", "Points", "Named",
           "StateOn", "Slots", "finite_fields", "quiet"]

_PKG = os.path.dirname(os.path.dirname(os.path.abspath(__file__))) + os.sep
MAX_CELLS = 1 << 22
MAX_SWEEPS = 10_000
MAX_ITER = 100_000


class GridShape(Spec):
    """2 or 3 integers ≥ ``minimum`` (a list, a tuple or an integer array), at most ``MAX_CELLS`` cells in all;
    returned as a tuple of ints."""

    def __init__(self, *, dims=(2, 3), minimum: int = 3) -> None:
        self.dims, self.minimum, self._count = tuple(dims), minimum, Int(ge=minimum)

    def describe(self) -> str:
        n = " or ".join(map(str, self.dims))
        return f"{n} cell counts, each an integer >= {self.minimum}, at most {MAX_CELLS} cells in all"

    def check(self, name, value, env):
        if isinstance(value, np.ndarray) and value.ndim == 1:
            value = value.tolist()
        if not isinstance(value, (list, tuple)) or len(value) not in self.dims:
            raise env.fail(name, self.describe(), value)
        out = tuple(self._count.check(f"{name}[{i}]", n, env) for i, n in enumerate(value))
        if math.prod(out) > MAX_CELLS:
            raise env.fail(name, self.describe(), value, f"{math.prod(out)} cells")
        return out

    def example(self, env):
        return (self.minimum + 1,) * self.dims[0]

    def bad(self, env):
        m = self.minimum
        side = int(MAX_CELLS ** (1 / self.dims[-1])) + 2
        return [("None", None), ("a string", "8x8"), ("one number", m + 1), ("too few axes", (m + 1,)),
                ("too many axes", (m + 1,) * (self.dims[-1] + 1)), ("an axis too short", (m - 1,) * self.dims[0]),
                ("a fraction", (m + 0.5,) * self.dims[0]), ("NaN", (math.nan,) * self.dims[0]),
                ("too many cells", (side,) * self.dims[-1])]

    def edges(self, env):
        return [(f"{d} axes of {self.minimum}", (self.minimum,) * d) for d in self.dims] + \
               [("an integer array", np.full(self.dims[0], self.minimum + 1))]


class Mask(Spec):
    """A boolean mask (or 0/1 numbers) of the cell shape held by the argument ``shape`` (a reference), with at
    least one cell left False (fluid); returned as a bool array (a copy)."""

    def __init__(self, shape: str = "$shape") -> None:
        self.size = shape                      # a reference: the contract checks the shape first

    def describe(self, env=None) -> str:
        shape = tuple(env.resolve(self.size)) if env is not None else "the grid's"
        return f"a boolean mask of shape {shape} (True = solid) with at least one fluid cell"

    def check(self, name, value, env):
        shape = tuple(env.resolve(self.size))
        try:
            a = np.asarray(value)                 # None or a string: shape (), refused below
        except (TypeError, ValueError):
            raise env.fail(name, self.describe(env), value) from None
        if a.shape != shape:
            raise env.fail(name, self.describe(env), value, f"shape {a.shape}")
        if a.dtype != bool:
            if a.dtype.kind not in "iuf" or not np.isin(a, (0, 1)).all():
                raise env.fail(name, self.describe(env), value, "entries other than True/False (or 0/1)")
            a = a != 0
        if a.all():
            raise env.fail(name, self.describe(env), value, "it covers every cell: no fluid is left")
        return a.copy()

    def example(self, env):
        m = np.zeros(tuple(env.resolve(self.size)), dtype=bool)
        m[(1,) * m.ndim] = True
        return m

    def bad(self, env):
        shape = tuple(env.resolve(self.size))
        return [("None", None), ("a string", "x"), ("all solid", np.ones(shape, bool)),
                ("halves", np.full(shape, 0.5)), ("a wrong shape", np.zeros(shape[:-1] + (shape[-1] + 1,), bool)),
                ("NaN", np.full(shape, np.nan))]

    def edges(self, env):
        shape = tuple(env.resolve(self.size))
        one = (np.arange(math.prod(shape)) > 0).reshape(shape).astype(int)
        return [("no obstacle", np.zeros(shape, bool)), ("one fluid cell", one)]


def _grid_ref(grid: str) -> str:
    return grid if grid.startswith("$") else "$" + grid


class Cells(Array):
    """A float array of the grid's cell shape (or of the faces of axis ``faces``; ``faces`` may name the
    argument that holds the axis, None there meaning the cells), with ``pad`` ghost layers per side.

    The bounds and options of :class:`~pbanim.contracts.Array` apply (``ge=``, ``finite=``, ...)."""

    def __init__(self, grid: str = "grid", *, faces=None, pad: int = 0, **kw) -> None:
        super().__init__((_grid_ref(grid),), **kw)    # a reference in the shape: checked after the grid
        self.grid, self.faces, self.pad = _grid_ref(grid), faces, pad

    def _dims(self, env):
        g = env.resolve(self.grid)
        i = self.faces
        if isinstance(i, str):
            i = env.values.get(i)
            if i is not None and not (isinstance(i, numbers.Integral) and not isinstance(i, (bool, np.bool_))
                                      and 0 <= i < g.dim):
                raise env.fail(self.faces, f"None (the cells) or an axis in 0 … {g.dim - 1}", i)
        shape = g.shape if i is None else g.face_shape(int(i))
        return [n + 2 * self.pad for n in shape]

    def describe(self, env=None) -> str:
        where = f"({'the cells' if self.faces is None else f'the faces of axis {self.faces}'} of {self.grid[1:]})"
        try:
            shape = f"{tuple(self._dims(env))}" if env is not None else where
        except Exception:  # noqa: BLE001 - a phrase only: the check itself reports what is wrong
            shape = where
        b = self.bounds.phrase()
        extra = ", ".join(p for p in ("finite" if self.finite else "not NaN", f"entries {b}" if b else "",
                                      f"{self.pad} ghost layers included" if self.pad else "") if p)
        return f"a float array of shape {shape} ({extra})"


@functools.lru_cache(maxsize=None)
def _field(shape) -> Array:
    """The Array spec of one shape (one per shape met)."""
    return Array(shape)


class Velocity(Spec):
    """A list (or tuple) of d float arrays, finite: uᵢ on the faces of axis i (``at="cells"``: d arrays of the
    cell shape, Stam's collocated layout); returned as a list of float arrays (not copies when already float)."""

    def __init__(self, grid: str = "grid", *, at: str = "faces") -> None:
        if at not in ("faces", "cells"):
            raise TypeError(f"at must be 'faces' or 'cells', got {at!r}")
        self.size, self.at = _grid_ref(grid), at     # size: a reference, checked after the grid

    def shapes(self, env) -> list:
        g = env.resolve(self.size)
        return [g.face_shape(i) if self.at == "faces" else g.shape for i in range(g.dim)]

    def describe(self, env=None) -> str:
        where = "uᵢ on the faces of axis i" if self.at == "faces" else "one per component, at the cells"
        if env is None:
            return f"a list of d finite float arrays ({where})"
        shapes = self.shapes(env)
        return f"a list of {len(shapes)} finite float arrays of shapes {', '.join(map(str, shapes))} ({where})"

    def check(self, name, value, env):
        shapes = self.shapes(env)
        if not isinstance(value, (list, tuple)) or len(value) != len(shapes):
            detail = f"{len(value)} arrays, not {len(shapes)}" if isinstance(value, (list, tuple)) else \
                f"one {type(value).__name__}, not a list of arrays"
            raise env.fail(name, self.describe(env), value, detail)
        return [_field(s).check(f"{name}[{i}]", c, env) for i, (s, c) in enumerate(zip(shapes, value))]

    def example(self, env):
        return [0.1 * (i + 1) + _field(s).example(env) for i, s in enumerate(self.shapes(env))]

    def bad(self, env):
        u = self.example(env)
        nan, inf = u[:-1] + [np.full_like(u[-1], np.nan)], [np.full_like(u[0], np.inf)] + u[1:]
        wrong = [np.zeros(tuple(n + 1 for n in u[0].shape))] + u[1:]
        return [("None", None), ("a string", "u"), ("one array", u[0]), ("one component short", u[:-1]),
                ("a NaN entry", nan), ("an inf entry", inf), ("a component of the wrong shape", wrong),
                ("a stacked array", np.zeros((len(u), 2, 2)))]

    def edges(self, env):
        u = self.example(env)
        return [("nested lists", [c.tolist() for c in u]), ("a tuple", tuple(u)),
                ("zeros", [np.zeros_like(c) for c in u]), ("1e300 entries", [np.full_like(c, 1e300) for c in u])]


class Points(Spec):
    """d finite coordinate arrays of one shape (any shape, empty allowed); returned as a list of float arrays."""

    def __init__(self, grid: str = "grid") -> None:
        self.size = _grid_ref(grid)

    def describe(self, env=None) -> str:
        d = env.resolve(self.size).dim if env is not None else "d"
        return f"a list of {d} finite coordinate arrays of one shape (x, y(, z))"

    def check(self, name, value, env):
        d = env.resolve(self.size).dim
        if not isinstance(value, (list, tuple)) or len(value) != d:
            raise env.fail(name, self.describe(env), value)
        pts = [_ANY.check(f"{name}[{a}]", p, env) for a, p in enumerate(value)]
        shapes = {np.shape(p) for p in pts}
        if len(shapes) > 1:
            raise env.fail(name, self.describe(env), value, f"shapes {[np.shape(p) for p in pts]}")
        return [np.asarray(p, dtype=float) for p in pts]

    def example(self, env):
        g = env.resolve(self.size)
        return [np.linspace(0.0, e, 5) for e in g.extent]

    def bad(self, env):
        p = self.example(env)
        nan = [np.where(np.arange(c.size) == 1, np.nan, c) for c in p]
        return [("None", None), ("a string", "x"), ("one array", p[0]), ("one axis short", p[:-1]),
                ("a NaN coordinate", nan), ("shapes that differ", [p[0]] + [c[:-1] for c in p[1:]])]

    def edges(self, env):
        p = self.example(env)
        return [("empty", [np.zeros(0) for _ in p]), ("far outside the box", [np.full(3, 1e300) for _ in p]),
                ("far on the other side", [np.full(3, -1e300) for _ in p]), ("scalars", [0.5 for _ in p])]


_ANY = Array(None, empty=True, scalar=True)


class Named(Spec):
    """A dict whose keys are non-empty strings (or one of ``keys``) and whose values ``item`` accepts; returned
    as a new dict of the converted values."""

    def __init__(self, item: Spec, *, keys=None) -> None:
        self.item, self.keys = item, None if keys is None else tuple(keys)   # the contract reads item's refs

    def describe(self, env=None) -> str:
        keys = "non-empty names" if self.keys is None else f"names in {list(self.keys)}"
        inner = self.item.describe(env) if isinstance(self.item, (Cells, Velocity)) else self.item.describe()
        return f"a dict from {keys} to {inner}"

    def check(self, name, value, env):
        if not isinstance(value, dict):
            raise env.fail(name, self.describe(env), value)
        out = {}
        for k, v in value.items():
            if not isinstance(k, str) or not k or self.keys is not None and k not in self.keys:
                raise env.fail(name, self.describe(env), value, f"the key {k!r}")
            out[k] = self.item.check(f"{name}[{k!r}]", v, env)
        return out

    def example(self, env):
        return {(self.keys or ("s",))[0]: self.item.example(env)}

    def bad(self, env):
        k = (self.keys or ("s",))[0]
        v = self.item.example(env)
        out = [("None", None), ("a list", [v]), ("an empty key", {"": v}), ("a number as key", {1: v})]
        if self.keys is not None:
            out.append(("an unknown key", {"no-such-key": v}))
        out += [(f"a value {label}", {k: b}) for label, b in self.item.bad(env)[:3]]
        return out

    def edges(self, env):
        return [("empty", {})]


def _state():
    from .scene import FluidState     # the scene's module imports this one

    return FluidState


class StateOn(Spec):
    """A FluidState on the grid: ``u`` the face arrays and each scalar a cell array, float64 ndarrays (written
    in place: a list would be a copy, and the writes lost), finite; returned as the same object."""

    def __init__(self, grid: str = "grid") -> None:
        self.size, self._u = _grid_ref(grid), Velocity(grid)

    def describe(self, env=None) -> str:
        return ("a FluidState on the grid (u: float64 face arrays, scalars: float64 cell arrays, finite; "
                "written in place)")

    def check(self, name, value, env):
        if not isinstance(value, _state()):
            raise env.fail(name, self.describe(env), value, f"a {type(value).__name__}")
        g = env.resolve(self.size)
        if not isinstance(value.u, list) or len(value.u) != g.dim:
            raise env.fail(f"{name}.u", f"a list of {g.dim} face arrays", value.u)
        if not isinstance(value.scalars, dict):
            raise env.fail(f"{name}.scalars", "a dict of cell arrays", value.scalars)
        fields = [(f"{name}.u[{i}]", c, s) for i, (c, s) in enumerate(zip(value.u, self._u.shapes(env)))]
        fields += [(f"{name}.scalars[{k!r}]", v, g.shape) for k, v in value.scalars.items()]
        for label, c, shape in fields:
            if not isinstance(c, np.ndarray) or c.dtype != np.float64:
                raise env.fail(label, f"a float64 numpy array of shape {shape} (written in place)", c)
            _field(shape).check(label, c, env)
        return value

    def example(self, env):
        return _state()(self._u.example(env))

    def bad(self, env):
        FluidState, u, g = _state(), self._u.example(env), env.resolve(self.size)
        return [("None", None), ("a string", "state"), ("lists for the velocity", FluidState([c.tolist() for c in u])),
                ("a NaN velocity", FluidState([np.full_like(u[0], np.nan)] + u[1:])),
                ("a scalar of another shape", FluidState(u, {"s": np.zeros(tuple(n + 1 for n in g.shape))}))]


class Slots(Spec):
    """A list of d entries (one per axis) that the callable overwrites; returned as the same list."""

    def __init__(self, grid: str = "grid") -> None:
        self.size = _grid_ref(grid)

    def describe(self, env=None) -> str:
        d = env.resolve(self.size).dim if env is not None else "d"
        return f"a list of {d} entries (overwritten)"

    def check(self, name, value, env):
        if not isinstance(value, list) or len(value) != env.resolve(self.size).dim:
            raise env.fail(name, self.describe(env), value)
        return value

    def example(self, env):
        return [None] * env.resolve(self.size).dim

    def bad(self, env):
        d = env.resolve(self.size).dim
        return [("a tuple", (None,) * d), ("one short", [None] * (d - 1)), ("a string", "out")]


def _finite(value, depth: int = 0) -> bool:
    if isinstance(value, np.ndarray):
        return value.dtype.kind not in "fc" or bool(np.isfinite(value).all())
    if isinstance(value, float):
        return math.isfinite(value)
    if depth > 3:
        return True
    if isinstance(value, (list, tuple)):
        return all(_finite(v, depth + 1) for v in value)
    if isinstance(value, dict):
        return all(_finite(v, depth + 1) for v in value.values())
    residual = getattr(value, "residual", None)           # a SolveInfo
    return residual is None or _finite(residual, depth + 1)


def finite_fields(value, where: str, arguments=None):
    """A ``returns`` certificate: every float in the result (arrays, numbers, nested in lists, tuples, dicts,
    and a SolveInfo's residual) is finite, else :class:`~pbanim.errors.NonFiniteResult` naming the callable."""
    if not _finite(value):
        raise NonFiniteResult(f"the result of {where}")
    return value


def quiet(f):
    """``f`` (under ``@contract``) run in ``np.errstate(over="ignore", invalid="ignore")`` when the contract's
    caller is outside the package, so that its certificate names an overflow without a RuntimeWarning on the
    way; a call from inside (a solve's operator, a step, which set their own errstate) pays nothing."""

    @functools.wraps(f)
    def inner(*args, **kwargs):
        if _getframe(2).f_code.co_filename.startswith(_PKG):      # frame 1 is the contract's wrapper
            return f(*args, **kwargs)
        with np.errstate(over="ignore", invalid="ignore"):         # a fresh one per call: reentrant
            return f(*args, **kwargs)

    return inner
