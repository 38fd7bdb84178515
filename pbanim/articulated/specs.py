"""Argument specs that chapter 08 needs beyond :mod:`pbanim.contracts` (issue 27).

=============================  ==============================================================================
spec                           accepts
=============================  ==============================================================================
``Tree()``                     an :class:`~pbanim.articulated.ArticulatedTree` with at least one link
``JointPositions(tree, ...)``  q of a tree, (nq,) (a batch (K, nq) with ``batch="first"``; the state
                               y = [q, q̇] with ``state=True``; joint i's q_i with ``joint="i"``): finite, and
                               the quaternion of every floating joint non-zero (its norm does not matter)
``UnitAxis()``                 a non-zero finite 3-vector (a joint axis, a rotation axis), returned of unit length
``Parent(size)``               −1 (the world) or the index of an existing link
``LinkPoints(size)``           a list of (link, point) pairs: a link index and a 3-vector in its frame
``PlanarKinematics()``         the dict ``kernel.kinematics(q)`` of the call's q
=============================  ==============================================================================

Rotations and inertias are chapter 05's specs, reused: :class:`pbanim.rigid.domain.Rotation` and
:class:`pbanim.rigid.admissible.Inertia` (``definite=False``: a link may be a point mass or massless). A URDF
file's numbers go through the same specs (:func:`check_with`, with the element as the place), so a refusal
reads the same either way.
"""

from __future__ import annotations

import math
import numbers

import numpy as np

from ..contracts import Array, Env, Obj, Spec

__all__ = ["Tree", "JointPositions", "UnitAxis", "Parent", "LinkPoints", "PlanarKinematics", "Size", "check_with"]


def _floats(name, value, env, expected, shape=None):
    """``value`` as a finite float array (of ``shape``), or the named refusal."""
    if value is None or isinstance(value, (str, bytes, complex)) or \
            isinstance(value, np.ndarray) and value.dtype.kind in "bcOSUV":
        raise env.fail(name, expected, value)
    try:
        a = np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        raise env.fail(name, expected, value) from None
    if shape is not None and a.shape != shape:
        raise env.fail(name, expected, value, f"shape {a.shape}")
    if not np.isfinite(a).all():
        raise env.fail(name, expected, value, "it has NaN or inf entries")
    return a


class Tree(Obj):
    """An ArticulatedTree with at least one link."""

    def __init__(self) -> None:
        super().__init__("pbanim.articulated.tree:ArticulatedTree", what="an ArticulatedTree with at least one link")

    def check(self, name, value, env):
        super().check(name, value, env)
        if value.n == 0:
            raise env.fail(name, self.describe(), value, "the tree has no links: add one with ArticulatedTree.add")
        return value

    def bad(self, env):
        from .tree import ArticulatedTree

        return [("None", None), ("a string", "x"), ("a number", 1.0), ("an empty tree", ArticulatedTree())]


class Size:
    """A shape entry of :class:`~pbanim.contracts.Array` computed from the call, ``fn(env)`` (prints as
    ``text`` in messages)."""

    def __init__(self, fn, text: str) -> None:
        self.fn, self.text = fn, text

    def __call__(self, env) -> int:
        return self.fn(env)

    def __str__(self) -> str:
        return self.text


class JointPositions(Array):
    """q of a tree (see the module docstring); ``tree`` names the argument (or attribute) holding the tree."""

    def __init__(self, tree: str = "tree", *, batch: str | None = None, state: bool = False,
                 joint: str | None = None) -> None:
        self.tree_ref, self.state, self.joint = tree, state, joint
        size = Size(self._joint_size, f"nq of joint {joint}") if joint else (
            Size(self._state_size, "nq + nv") if state else f"{tree}.nq")
        super().__init__((size,), batch=batch, empty=True)      # a tree of fixed joints only has nq = 0

    def _tree(self, env):
        return env.resolve(self.tree_ref)

    def _state_size(self, env):
        t = self._tree(env)
        return t.nq + t.nv

    def _joint_size(self, env):
        t, i = self._tree(env), env.values.get(self.joint)
        s = t._q_index[i] if isinstance(i, numbers.Integral) and 0 <= i < t.n else None
        return -1 if s is None else s.stop - s.start

    def _quaternions(self, env) -> list[int]:
        """Where each floating joint's quaternion starts in the checked array."""
        t = self._tree(env)
        if self.joint:
            i = env.values.get(self.joint)
            return [0] if t.joints[i].kind == "floating" else []
        return [s.start for j, s in zip(t.joints, t._q_index) if j.kind == "floating"]

    def describe(self, env: Env | None = None) -> str:
        what = "the state [q, q̇]" if self.state else ("the joint's coordinates q_i" if self.joint else "joint "
                                                                                                        "positions q")
        return f"{what}: {super().describe(env)}, every floating joint's quaternion non-zero"

    def check(self, name, value, env):
        a = super().check(name, value, env)
        for k in self._quaternions(env):
            if not (a[..., k:k + 4] != 0.0).any(axis=-1).all():
                raise env.fail(name, self.describe(env), value,
                               f"the quaternion {name}[{k}:{k + 4}] of a floating joint is zero")
        return a

    def example(self, env):
        a = super().example(env)
        for k in self._quaternions(env):
            a[..., k:k + 4] = (1.0, 0.0, 0.0, 0.0)
        return a

    def bad(self, env):
        out = super().bad(env)
        ks = self._quaternions(env)
        if ks:
            a = self.example(env)
            a[..., ks[0]:ks[0] + 4] = 0.0
            out.append(("a zero quaternion", a))
        return out

    def edges(self, env):
        return [e for e in super().edges(env) if e[0] != "zeros" or not self._quaternions(env)]


class UnitAxis(Spec):
    """A non-zero finite 3-vector, returned divided by its length (scaled first: 1e300 entries are fine)."""

    def describe(self) -> str:
        return "a non-zero finite 3-vector (an axis)"

    def check(self, name, value, env):
        a = _floats(name, value, env, self.describe(), (3,))
        top = float(np.abs(a).max())
        if top == 0.0:
            raise env.fail(name, self.describe(), value, "it is zero")
        a = a / top
        return a / math.sqrt(float(a @ a))

    def example(self, env):
        return np.array([0.0, 0.0, 1.0])

    def bad(self, env):
        return [("None", None), ("a string", "x"), ("zero", np.zeros(3)), ("NaN", np.array([np.nan, 0.0, 1.0])),
                ("inf", np.array([np.inf, 0.0, 1.0])), ("a wrong length", np.ones(2)), ("a batch", np.ones((2, 3)))]

    def edges(self, env):
        return [("tiny", np.full(3, 1e-300)), ("huge", np.full(3, 1e300)), ("not unit", [0.0, 3.0, 4.0])]


class Parent(Spec):
    """−1 (the world) or the index of an existing link, 0 … size − 1 (parents come before children)."""

    def __init__(self, size) -> None:
        self.size = size

    def describe(self) -> str:
        return "−1 (the world) or an existing link's index (parents come before children)"

    def check(self, name, value, env):
        n = int(env.resolve(self.size))
        if isinstance(value, (bool, np.bool_)) or not isinstance(value, (numbers.Integral, np.integer)) \
                or not -1 <= value < n:
            raise env.fail(name, f"−1 (the world) or an existing link 0..{n - 1} (parents come before children, "
                                 "so the tree has no cycle)", value)
        return int(value)

    def example(self, env):
        return -1

    def bad(self, env):
        n = int(env.resolve(self.size))
        return [("below the world", -2), ("a link not yet added", n), ("a fraction", 0.5), ("None", None),
                ("a string", "0")]

    def edges(self, env):
        n = int(env.resolve(self.size))
        return [("the last link", n - 1)] if n else []


class LinkPoints(Spec):
    """A non-empty list of (link, point) pairs: ``link`` an index 0 … size − 1, ``point`` a finite 3-vector in
    the link's frame. Returned as a list of (int, float array) pairs."""

    def __init__(self, size) -> None:
        self.size = size

    def describe(self) -> str:
        return "a non-empty list of (link index, 3-vector in the link frame) pairs"

    def check(self, name, value, env):
        n = int(env.resolve(self.size))
        if not isinstance(value, (list, tuple)) or not value:
            raise env.fail(name, self.describe(), value)
        out = []
        for k, item in enumerate(value):
            if not isinstance(item, (list, tuple)) or len(item) != 2:
                raise env.fail(f"{name}[{k}]", "a (link, point) pair", item)
            lk = item[0]
            if isinstance(lk, (bool, np.bool_)) or not isinstance(lk, (numbers.Integral, np.integer)) \
                    or not 0 <= lk < n:
                raise env.fail(f"{name}[{k}] link", f"a link index in 0..{n - 1}", lk)
            out.append((int(lk), _floats(f"{name}[{k}] point", item[1], env, "a finite 3-vector", (3,))))
        return out

    def example(self, env):
        return [(int(env.resolve(self.size)) - 1, [0.0, -0.5, 0.0])]

    def bad(self, env):
        n = int(env.resolve(self.size))
        return [("None", None), ("empty", []), ("a link past the end", [(n, [0.0, 0.0, 0.0])]),
                ("a negative link", [(-1, [0.0, 0.0, 0.0])]), ("a NaN point", [(0, [np.nan, 0.0, 0.0])]),
                ("a 2-D point", [(0, [0.0, 0.0])]), ("not a pair", [0])]

    def edges(self, env):
        return [("a huge point", [(0, [1e300, 0.0, 0.0])])]


class PlanarKinematics(Spec):
    """The dict ``kernel.kinematics(q)`` of this call's ``q``: its angles φ = Φ q are compared (one product)
    so that the kinematics of another state cannot pass for this one."""

    def __init__(self, kernel: str = "self", q: str = "q") -> None:
        self.size, self.q = kernel, q        # size: a reference, so the contract checks this argument last

    def describe(self) -> str:
        return f"the dict kernel.kinematics({self.q}) of this {self.q}"

    def check(self, name, value, env):
        kernel = env.resolve(self.size)
        if not isinstance(value, dict) or not {"phi", "rot", "w", "zo", "zc"} <= value.keys() or \
                np.shape(value["phi"]) != (kernel.n,) or np.shape(value["zo"]) != (kernel.n,):
            raise env.fail(name, self.describe(), value)
        q = env.values.get(self.q)
        if q is not None:
            q = np.asarray(q, dtype=float)
            if q.shape == (kernel.nv,) and not np.allclose(value["phi"], kernel.Phi @ q, rtol=1e-12, atol=1e-12):
                raise env.fail(name, self.describe(), "a dict whose phi differs",
                               f"it is the kinematics of another state: pass kernel.kinematics({self.q}) or None")
        return value

    def example(self, env):
        kernel, q = env.resolve(self.size), env.values.get(self.q)
        return kernel.kinematics(np.zeros(kernel.nv) if q is None else np.asarray(q, dtype=float))

    def bad(self, env):
        kernel = env.resolve(self.size)
        out = [("a string", "x"), ("a list", [1.0])]
        q = env.values.get(self.q)
        if q is not None and kernel.revolute.any():
            out.append(("another state's", kernel.kinematics(np.asarray(q, dtype=float) + 0.1)))
        return out


def check_with(spec: Spec, where: str, name: str, value):
    """``spec.check`` outside a call (a value read from a file): the refusal names ``where`` and ``name``."""
    return spec.check(name, value, Env(where, {}))

