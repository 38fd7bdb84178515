"""Argument specs the controllers need beyond :mod:`pbanim.contracts` (chapter 08, part 2).

The controllers take a few kinds of argument the shared vocabulary has no word for: a dict from joint
names to indices, angles or gains; a collection of event names; a (link, point) pair; a boolean mask of
contact points; the kinematics dict of the state being passed; a time no earlier than one the object
holds. Each is a :class:`~pbanim.contracts.Spec` here, with its fuzzer side (``example``, ``bad``,
``edges``).

==============================  ========================================================================
spec                            accepts
==============================  ========================================================================
``Mapping(key, value)``         a dict whose keys meet ``key`` and values meet ``value`` (``keys=``: exactly
                                those keys; ``distinct=True``: no value twice); returned as a new dict
``Names()``                     a list, tuple, set or frozenset of strings (events, final states) → tuple
``Pair(first, second)``         a 2-item list or tuple, (link index, point in the link frame) → tuple
``Mask(size)``                  a boolean array of ``size`` entries (which contact points are held)
``KinematicsOf(kernel, q)``     the dict ``kernel.kinematics(q)`` made for this call's q (recomputed once
                                at the boundary and compared: a dict of another state is refused)
``NotBefore(ref)``              a finite time t ≥ the referenced time (a state machine's entry time)
``Count(arg)``                  not a spec: a shape entry, the number of items of another argument
``named(error, spec)``          what ``spec`` accepts, refused as ``error`` (InvalidGains, InvalidTask, ...:
                                subclasses of InvalidInput the controllers' users already catch)
==============================  ========================================================================

A spec that reads another argument keeps the reference in ``size`` (as :class:`~pbanim.contracts.Index`
does): the contract checks it after the arguments it reads.
"""

from __future__ import annotations

import copy

import numpy as np

from ..contracts import Real, Spec
from ..errors import InvalidInput

__all__ = ["Mapping", "Names", "Pair", "Mask", "KinematicsOf", "NotBefore", "Count", "named"]


class Mapping(Spec):
    """A dict whose keys meet ``key`` and values meet ``value``."""

    def __init__(self, key: Spec, value: Spec, *, min_len: int = 0, keys=None, distinct: bool = False) -> None:
        self.key, self.value, self.min_len, self.distinct = key, value, min_len, distinct
        self.keys = None if keys is None else tuple(keys)
        self.specs = (key, value)              # read by the contract: references inside come last

    def describe(self) -> str:
        what = f"a dict mapping {self.key.describe()} to {self.value.describe()}"
        if self.keys is not None:
            what += f" with exactly the keys {', '.join(map(repr, self.keys))}"
        elif self.min_len:
            what += f" with at least {self.min_len} item{'s' if self.min_len > 1 else ''}"
        return what + (", no value twice" if self.distinct else "")

    def check(self, name, value, env):
        if not isinstance(value, dict) or len(value) < self.min_len:
            raise env.fail(name, self.describe(), value)
        if self.keys is not None and set(value) != set(self.keys):
            raise env.fail(name, self.describe(), value, f"its keys are {sorted(map(str, value))}")
        out = {}
        for k, v in value.items():
            out[self.key.check(f"{name} (a key)", k, env)] = self.value.check(f"{name}[{k!r}]", v, env)
        if self.distinct and len({_hashable(v) for v in out.values()}) != len(out):
            raise env.fail(name, self.describe(), value, "a value repeats")
        return out

    def _keys(self, env) -> list:
        return list(self.keys) if self.keys is not None else [self.key.example(env)]

    def example(self, env):
        return {k: self.value.example(env) for k in self._keys(env)}

    def bad(self, env):
        try:
            good = self.example(env)
        except NotImplementedError:          # a value spec with no example (Anything): any payload
            good = {k: 0.0 for k in self._keys(env)}
        k0 = next(iter(good))
        out = [("None", None), ("a string", "x"), ("a list", list(good.values()))]
        out += [(f"a value {label}", {**good, k0: v}) for label, v in self.value.bad(env)[:3]]
        out += [(f"a key {label}", {v: good[k0]}) for label, v in
                [(lb, v) for lb, v in self.key.bad(env) if v is not None][:1]]
        if self.keys is not None:
            out.append(("a key missing", dict(list(good.items())[:-1])))
        elif self.min_len:
            out.append(("empty", {}))
        return out

    def edges(self, env):
        keys = self._keys(env)
        return [(f"values {label}", {k: v for k in keys}) for label, v in self.value.edges(env)[:3]
                if not self.distinct or len(keys) == 1]


def _hashable(v):
    return v.tobytes() if isinstance(v, np.ndarray) else v


class Names(Spec):
    """A collection of names: a list, tuple, set or frozenset of strings (not one string); → tuple."""

    def describe(self) -> str:
        return "a list, tuple or set of strings"

    def check(self, name, value, env):
        if not isinstance(value, (list, tuple, set, frozenset)) or not all(isinstance(v, str) for v in value):
            raise env.fail(name, self.describe(), value)
        return tuple(value)

    def example(self, env):
        return ()

    def bad(self, env):
        return [("None", None), ("a string", "x"), ("a number", 1.0), ("a list of numbers", [1.0])]

    def edges(self, env):
        return [("a set", {"x"})]


class Pair(Spec):
    """A list or tuple of two items meeting ``first`` and ``second``; → tuple."""

    def __init__(self, first: Spec, second: Spec) -> None:
        self.specs = (first, second)

    def describe(self) -> str:
        items = ", ".join(s.describe() for s in self.specs)
        return f"a pair ({items})" if len(self.specs) == 2 else f"a tuple of {len(self.specs)} ({items})"

    def check(self, name, value, env):
        if not isinstance(value, (list, tuple)) or len(value) != len(self.specs):
            raise env.fail(name, self.describe(), value)
        return tuple(s.check(f"{name}[{i}]", v, env) for i, (s, v) in enumerate(zip(self.specs, value)))

    def example(self, env):
        return tuple(s.example(env) for s in self.specs)

    def bad(self, env):
        try:
            good = self.example(env)
        except NotImplementedError:          # an item with no example (an object): None stands in
            good = (None, None)
        out = [("None", None), ("a string", "x"), ("one item", good[:1])]
        for i, s in enumerate(self.specs):
            out += [(f"item {i} {label}", tuple(v if j == i else g for j, g in enumerate(good)))
                    for label, v in s.bad(env)[:2]]
        return out


class Items(Pair):
    """A list or tuple of as many items as ``specs``, each meeting its spec; → tuple."""

    def __init__(self, *specs: Spec) -> None:
        self.specs = tuple(specs)


class Mask(Spec):
    """A boolean array of ``size`` entries (size: an int, a reference or a callable of the env)."""

    def __init__(self, size) -> None:
        self.size = size

    def describe(self) -> str:
        return f"a boolean mask of {self.size} entries"

    def check(self, name, value, env):
        n = int(env.resolve(self.size))
        a = None if value is None or isinstance(value, (str, bytes)) else np.asarray(value)
        if a is None or a.dtype != bool or a.shape != (n,):
            raise env.fail(name, f"a boolean mask of {n} entries", value)
        return a.copy()

    def example(self, env):
        return np.ones(int(env.resolve(self.size)), dtype=bool)

    def bad(self, env):
        n = int(env.resolve(self.size))
        return [("None", None), ("a string", "x"), ("too long", np.ones(n + 1, bool)), ("numbers", np.ones(n))]

    def edges(self, env):
        return [("none held", np.zeros(int(env.resolve(self.size)), dtype=bool))]


class KinematicsOf(Spec):
    """The dict ``kernel.kinematics(q)`` of a :class:`~pbanim.articulated.planar.PlanarKernel` for this
    call's ``q``: recomputed at the boundary and compared (angles φ and joint origins), so that the
    kinematics of another state cannot pass for this one. Inside the package it is passed on unchecked."""

    def __init__(self, kernel: str = "self.kernel", q: str = "q") -> None:
        self.size, self.q = kernel, q          # size: the reference (the contract checks this last)

    def describe(self) -> str:
        return f"the dict kernel.kinematics({self.q}) of this {self.q}"

    def _want(self, env):
        kernel = env.resolve(self.size)
        try:
            q = np.asarray(env.values.get(self.q), dtype=float)
        except (TypeError, ValueError):
            return None
        if q.shape != (kernel.nv,) or not np.isfinite(q).all():
            return None                        # q's own spec refuses it
        return kernel.kinematics(q)

    def check(self, name, value, env):
        if not isinstance(value, dict) or not {"phi", "zo"} <= value.keys():
            raise env.fail(name, self.describe(), value)
        want = self._want(env)
        if want is None:
            return value
        for key in ("phi", "zo"):
            got = np.asarray(value[key])
            if got.shape != want[key].shape or not np.allclose(got, want[key], rtol=1e-12, atol=1e-12):
                raise env.fail(name, self.describe(), f"a dict whose {key} differs",
                               f"it is the kinematics of another state: pass kernel.kinematics({self.q}) or None")
        return value

    def example(self, env):
        return self._want(env)

    def bad(self, env):
        kernel = env.resolve(self.size)
        q = np.asarray(env.values.get(self.q), dtype=float)
        return [("a string", "x"), ("a list", [1.0]), ("another state's", kernel.kinematics(q + 0.1))]


class NotBefore(Spec):
    """A finite time t ≥ the time at ``ref`` (e.g. ``"self.entered"``: when the current state began)."""

    def __init__(self, ref: str) -> None:
        self.size = ref                        # the reference (the contract checks this last)
        self._number = Real()

    def describe(self) -> str:
        return f"a finite time >= {self.size}"

    def check(self, name, value, env):
        t = self._number.check(name, value, env)
        t0 = float(env.resolve(self.size))
        if t < t0:
            raise env.fail(name, f"a finite time >= {self.size} = {t0:g}", value, "time does not run backwards")
        return t

    def example(self, env):
        return float(env.resolve(self.size)) + 0.5

    def bad(self, env):
        return self._number.bad(env) + [("before the reference", float(env.resolve(self.size)) - 1.0)]

    def edges(self, env):
        return [("the reference", float(env.resolve(self.size))), ("1e300", 1e300)]


class Count:
    """A shape entry for :class:`~pbanim.contracts.Array`: the number of items of argument ``arg`` (or
    ``default(env)`` when it is None). Prints as ``len(arg)`` in messages."""

    def __init__(self, arg: str, default=None, text: str | None = None) -> None:
        self.arg, self.default, self.text = arg, default, text or f"len({arg})"

    def __call__(self, env) -> int:
        v = env.values.get(self.arg)
        if v is None and self.default is not None:
            return int(self.default(env))
        try:
            return len(v)
        except TypeError:
            return -1                          # not a collection: its own spec refuses it

    def __str__(self) -> str:
        return self.text

    __repr__ = __str__


_NAMED: dict = {}


def named(error: type, spec: Spec) -> Spec:
    """A copy of ``spec`` whose refusals are raised as ``error`` (a subclass of InvalidInput), message
    unchanged; it stays an instance of the spec's class (the fuzzer treats it alike)."""
    if not (isinstance(error, type) and issubclass(error, InvalidInput)):
        raise TypeError(f"named: error must be a subclass of InvalidInput, got {error!r}")
    base = type(spec)
    sub = _NAMED.get((base, error))
    if sub is None:
        def check(self, name, value, env):
            try:
                return base.check(self, name, value, env)
            except InvalidInput as exc:
                if isinstance(exc, error):
                    raise
                raise error(str(exc)) from None

        sub = type(base.__name__, (base,), {"check": check, "__doc__": base.__doc__,
                                              "__module__": base.__module__})
        _NAMED[(base, error)] = sub
    out = copy.copy(spec)
    out.__class__ = sub
    return out

