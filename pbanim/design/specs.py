"""What the arguments of chapter 10's callables must be, beyond the shared vocabulary (:mod:`pbanim.contracts`).

Specs that :mod:`pbanim.contracts.specs` cannot say with its own words:

* :class:`ParameterNames` — names of the parameter vector u of a design scene (``x0``, ``theta1``,
  ``restitution``, ``normal0``, ...: the scene's own list, which depends on the scene), distinct, at least
  one (a single string stands for a list of one); refused with :class:`~pbanim.design.UnknownParameter`;
* :class:`Quaternion` — a non-zero quaternion (w, x, y, z) (normalized by the callee, so any length but 0);
* :class:`DesignState` — a design state y = [x, q, P, L] (13N,) of a flight model, finite, with non-zero
  quaternions (q/|q| is the orientation; q = 0 has none);
* :class:`UnitRows` — plane normals n, rows of length 1;
* :class:`SketchPoints` — a motion sketch [(t, x̄), ...];
* :class:`OutputTriples` — outputs [(body, t, "position" | "orientation"), ...] of a trajectory.

The contract machinery knows that a spec reads another argument when it has a ``size`` given as a reference
(:func:`pbanim.contracts.declare._refs`); :class:`ParameterNames` and :class:`OutputTriples` keep the
reference to their scene or trajectory there.
"""

from __future__ import annotations

import numpy as np

from ..contracts import Array, Spec
from ..contracts.specs import short

__all__ = ["ParameterNames", "Quaternion", "DesignState", "UnitRows", "SketchPoints", "OutputTriples", "u_size"]


class ParameterNames(Spec):
    """Parameter names of the scene ``scene`` (a reference: ``"self"`` in a scene's methods, ``"scene"`` in
    a function); ``one=True``: a single name (returned as a str); ``empty=True``: an empty list is allowed."""

    def __init__(self, scene: str = "self", *, one: bool = False, empty: bool = False) -> None:
        self.size = "$" + scene          # a reference: the contract resolves the scene before this check
        self.one, self.empty = one, empty

    def describe(self) -> str:
        if self.one:
            return "a parameter name of the scene"
        return "a list of distinct parameter names of the scene" + ("" if self.empty else " (at least one)")

    def _fail(self, env, name, value, detail):
        from .scene import UnknownParameter

        return UnknownParameter(f"{env.where}: {name} must be {self.describe()}, got {short(value)}; {detail}")

    def check(self, name, value, env):
        scene = env.resolve(self.size)
        known = scene.names()
        if self.one:
            if not isinstance(value, str) or value not in known:
                raise self._fail(env, name, value, f"the scene has {known}")
            return value
        items = [value] if isinstance(value, str) else value
        if not isinstance(items, (list, tuple)):
            raise env.fail(name, self.describe(), value)
        bad = [n for n in items if not isinstance(n, str) or n not in known]
        if bad:
            raise self._fail(env, name, value, f"parameter {bad[0]!r} does not exist; the scene has {known}")
        if len(set(items)) != len(items):
            raise env.fail(name, self.describe(), value, "a name repeats")
        if not items and not self.empty:
            raise env.fail(name, self.describe(), value, "it is empty")
        return list(items)

    def example(self, env):
        return ["x0", "v0"]

    def bad(self, env):
        out = [("None", None), ("a number", 1.0), ("an unknown name", ["no-such-name"])]
        if not self.one:
            out += [("a repeated name", ["x0", "x0"])] + ([] if self.empty else [("empty", [])])
        return out

    def edges(self, env):
        known = env.resolve(self.size).names()
        return [("the last", known[-1])] if self.one else [("every name", known), ("one string", "x0")]


def u_size(scene: str = "scene", names: str = "names"):
    """The length of u for the names ``names`` of ``scene`` (a shape entry for :class:`Array`; the default
    selection of :func:`pbanim.design.simulate` when ``names`` is None)."""

    def size(env):
        sc = env.resolve("$" + scene)
        sel = env.values.get(names)
        if sel is None:
            sel = [f"{k}{i}" for i in range(sc.N) for k in ("x", "theta", "v", "omega")]
        return sum(sc.size(k) for k in ([sel] if isinstance(sel, str) else sel))

    return size


class Quaternion(Array):
    """A quaternion (w, x, y, z), finite and non-zero (the callee normalizes it)."""

    def __init__(self, **kw) -> None:
        super().__init__((4,), **kw)

    def describe(self, env=None) -> str:
        return super().describe(env) + ", a non-zero quaternion (w, x, y, z)"

    def check(self, name, value, env):
        a = super().check(name, value, env)
        if not np.all(np.sum(a * a, axis=-1) > 0):
            raise env.fail(name, self.describe(env), value, "a zero quaternion has no orientation")
        return a

    def example(self, env):
        return np.array([1.0, 0.0, 0.0, 0.0]) if self.batch is None else super().example(env)

    def bad(self, env):
        return super().bad(env) + [("zero", np.zeros(4))]

    def edges(self, env):
        return [e for e in super().edges(env) if e[0] != "zeros"] + [("not unit", np.array([2.0, 0.0, 0.0, 0.0]))]


class DesignState(Array):
    """A design state y = [x (3N), q (4N), P (3N), L (3N)] of the flight model ``model`` (a reference),
    finite, every quaternion non-zero."""

    def __init__(self, model: str = "model") -> None:
        super().__init__((f"{model}.n_state",))
        self.model = model

    def describe(self, env=None) -> str:
        return super().describe(env) + ", a design state [x, q, P, L] with non-zero quaternions"

    def check(self, name, value, env):
        a = super().check(name, value, env)
        N = a.size // 13
        q = a[3 * N:7 * N].reshape(N, 4)
        if not np.all(np.sum(q * q, axis=1) > 0):
            raise env.fail(name, self.describe(env), value, "a quaternion is zero")
        return a

    def example(self, env):
        a = super().example(env)
        N = a.size // 13
        a[3 * N:7 * N] = np.tile([1.0, 0.0, 0.0, 0.0], N)
        return a

    def bad(self, env):
        return super().bad(env) + [("a zero quaternion", np.zeros_like(self.example(env)))]

    def edges(self, env):
        return [e for e in super().edges(env) if e[0] != "zeros"]


class UnitRows(Array):
    """A float array of ``shape`` whose rows (last axis) are unit vectors (|n| = 1 to 1e-9): plane normals."""

    def describe(self, env=None) -> str:
        return super().describe(env) + " of unit rows"

    def check(self, name, value, env):
        a = super().check(name, value, env)
        if a.size and not np.all(np.abs(np.sqrt(np.sum(a * a, axis=-1)) - 1.0) <= 1e-9):
            raise env.fail(name, self.describe(env), value, "a row is not of length 1")
        return a

    def example(self, env):
        a = super().example(env)
        return a / np.linalg.norm(a, axis=-1, keepdims=True) if a.size else a

    def bad(self, env):
        a = self.example(env)
        return super().bad(env) + ([("not unit", 2.0 * a)] if a.size else [])

    def edges(self, env):
        return [e for e in super().edges(env) if e[0] not in ("zeros", "1e300 entries")]


class SketchPoints(Spec):
    """A motion sketch: a list of (time, 3-vector) pairs, finite (returned as [(float, array(3))]); the span
    the times must lie in is the callee's to check (it depends on other arguments)."""

    def __init__(self, *, min_len: int = 0) -> None:
        self.min_len = min_len

    def describe(self) -> str:
        return "a list of (time, 3 finite numbers) sketch points" + (f", at least {self.min_len}" if self.min_len
                                                                     else "")

    def check(self, name, value, env):
        if not isinstance(value, (list, tuple)) or len(value) < self.min_len:
            raise env.fail(name, self.describe(), value)
        out = []
        for k, item in enumerate(value):
            try:
                t, x = item
                t, x = float(t), np.array(x, dtype=float).reshape(-1)
            except (TypeError, ValueError):
                raise env.fail(name, self.describe(), value, f"point {k} is not a (time, 3-vector) pair") from None
            if x.shape != (3,) or not (np.isfinite(t) and np.all(np.isfinite(x))):
                raise env.fail(name, self.describe(), value, f"point {k} is ({t}, {x})")
            out.append((t, x))
        return out

    def example(self, env):
        return [(0.1 * k, np.array([0.1 * k, 0.0, 1.0])) for k in range(max(3, self.min_len))]

    def bad(self, env):
        return [("None", None), ("a string", "x"), ("a point of 2 numbers", [(0.1, [1.0, 2.0])]),
                ("a NaN time", [(np.nan, [0.0, 0.0, 1.0])])]


class OutputTriples(Spec):
    """Outputs of a trajectory: a non-empty list of (body, time, "position" | "orientation") triples, the body
    an index into ``owner``'s bodies (a reference: a Trajectory or a DesignScene, both have ``N``)."""

    def __init__(self, owner: str) -> None:
        self.size = "$" + owner + ".N"

    def describe(self) -> str:
        return "a non-empty list of (body index, time, 'position' | 'orientation') triples"

    def check(self, name, value, env):
        n = int(env.resolve(self.size))
        if not isinstance(value, (list, tuple)) or not value:
            raise env.fail(name, self.describe(), value)
        out = []
        for k, item in enumerate(value):
            ok = isinstance(item, (list, tuple)) and len(item) == 3
            if ok:
                i, t, kind = item
                ok = (isinstance(i, (int, np.integer)) and not isinstance(i, bool) and 0 <= i < n
                      and isinstance(t, (int, float, np.floating, np.integer)) and np.isfinite(t)
                      and kind in ("position", "orientation"))
            if not ok:
                raise env.fail(name, self.describe(), value, f"item {k} is {item!r} (bodies 0 … {n - 1})")
            out.append((int(i), float(t), kind))
        return out

    def example(self, env):
        return [(0, 0.5, "position")]

    def bad(self, env):
        return [("None", None), ("empty", []), ("an unknown kind", [(0, 0.5, "velocity")]),
                ("a body past the end", [(int(env.resolve(self.size)), 0.5, "position")])]
