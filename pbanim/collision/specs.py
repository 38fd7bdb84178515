"""Argument specs of chapter 06 that the shared vocabulary (:mod:`pbanim.contracts.specs`) lacks.

=====================  ==========================================================================
spec                   accepts
=====================  ==========================================================================
``BodyIds(shape)``     integer body indices ≥ −1 (−1 is the static world), of a shape (or one int)
``UnitVectors(shape)`` a float array whose last axis holds unit vectors (|n| = 1 to 1e-6): normals
``Rotations(shape)``   a float array whose last two axes are rotation matrices (RᵀR = 𝟙, det R = 1,
                       to 1e-6): body orientations, columns = body axes in world coordinates
``SymmetricPSD(shape)`` a float array whose last two axes are symmetric positive semidefinite
                       matrices (inverse inertias I⁻¹, collision matrices K)
``ContactsFor(bodies)`` a 3-D :class:`~pbanim.collision.shapes.Contacts` whose body indices exist in
                       the :class:`~pbanim.collision.impulse.ImpulseBodies` argument ``bodies``
``Obstacle()``         a static obstacle: a ``Plane``, or a ``(Sphere, centre)`` pair
=====================  ==========================================================================

Each is checked at the call boundary only (see :mod:`pbanim.contracts.declare`) and gives the fuzz its
valid example, the values it must refuse and its edge values.
"""

from __future__ import annotations

import numbers

import numpy as np

from ..contracts import Array, Spec

__all__ = ["BodyIds", "UnitVectors", "Rotations", "SymmetricPSD", "ContactsFor", "Obstacle"]


class BodyIds(Spec):
    """Integer body indices ≥ −1 (−1 = the static world) of ``shape`` (symbols bound across the call);
    ``scalar=True`` also admits one integer for all. Floats equal to integers are accepted."""

    def __init__(self, shape=("m",), *, scalar: bool = False, empty: bool = True) -> None:
        self.shape, self.scalar, self.empty = tuple(shape), scalar or not shape, empty

    def describe(self) -> str:
        if not self.shape:
            return "a body index ≥ −1 (−1 = the world)"
        dims = ", ".join(str(d) for d in self.shape)
        return (f"body indices ≥ −1 (−1 = the world) of shape ({dims}{',' if len(self.shape) == 1 else ''})"
                + (" or one index" if self.scalar else ""))

    def check(self, name, value, env):
        if value is None or isinstance(value, (str, bytes, bool, np.bool_)):
            raise env.fail(name, self.describe(), value)
        try:
            a = np.asarray(value)
        except (TypeError, ValueError):
            raise env.fail(name, self.describe(), value) from None
        if a.dtype.kind == "f" and a.size and np.isfinite(a).all() and (a == np.round(a)).all():
            a = a.astype(np.intp)
        if a.dtype.kind not in "iu" and not (a.dtype.kind == "f" and a.size == 0):
            raise env.fail(name, self.describe(), value, "entries are not integers")
        if a.ndim == 0:
            if not self.scalar:
                raise env.fail(name, self.describe(), value)
        elif a.ndim != len(self.shape):
            raise env.fail(name, self.describe(), value, f"shape {a.shape}")
        else:
            for d, s in zip(self.shape, a.shape):
                want = env.symbols.get(d, d) if isinstance(d, str) else d
                if isinstance(want, str):
                    env.symbols[d] = s
                elif want is not None and int(want) != s:
                    raise env.fail(name, self.describe(), value, f"shape {a.shape}")
        if a.size == 0:
            if not self.empty:
                raise env.fail(name, self.describe(), value, "it is empty")
            return a.astype(np.intp)
        if a.min() < -1:
            raise env.fail(name, self.describe(), value, f"smallest entry {a.min()}")
        return a.astype(np.intp) if a.ndim else int(a)

    def example(self, env):
        shape = tuple(env.symbols.setdefault(d, 1) if isinstance(d, str) else (1 if d is None else d)
                      for d in self.shape)
        return np.zeros(shape, dtype=np.intp)

    def bad(self, env):
        a = self.example(env)
        return [("None", None), ("a string", "0"), ("below the world", np.full_like(a, -2)),
                ("fractions", a + 0.5), ("NaN", np.full(a.shape, np.nan)), ("two extra axes", a[None, None])]

    def edges(self, env):
        return [("the world", np.full_like(self.example(env), -1))]


class UnitVectors(Array):
    """A float array of ``shape`` whose last axis holds unit vectors (|n| = 1 to 1e-6), e.g. normals."""

    def describe(self, env=None) -> str:
        return super().describe(env) + " of unit vectors"

    def check(self, name, value, env):
        a = super().check(name, value, env)
        if a.size and not np.all(np.abs(np.einsum("...i,...i->...", a, a) - 1.0) <= 1e-6):
            raise env.fail(name, self.describe(env), value, "a vector is not of length 1")
        return a

    def example(self, env):
        a = super().example(env)
        return a / np.linalg.norm(a, axis=-1, keepdims=True)

    def bad(self, env):
        a = self.example(env)
        return super().bad(env) + [("not unit", 2.0 * a), ("zero", np.zeros_like(a))]

    def edges(self, env):
        return [e for e in super().edges(env) if e[0] not in ("zeros", "1e300 entries")]


class Rotations(Array):
    """A float array of ``shape`` whose last two axes are rotation matrices (RᵀR = 𝟙 and det R = 1, to 1e-6)."""

    def describe(self, env=None) -> str:
        return super().describe(env) + " of rotation matrices"

    def check(self, name, value, env):
        a = super().check(name, value, env)
        if a.ndim < 2 or a.shape[-2:] != (3, 3):
            raise env.fail(name, self.describe(env), value, "not 3 × 3 matrices")
        if a.size:
            gram = np.swapaxes(a, -1, -2) @ a
            if not (np.abs(gram - np.eye(3)).max() <= 1e-6 and np.linalg.det(a).min() > 0):
                raise env.fail(name, self.describe(env), value, "RᵀR ≠ 𝟙 or det R < 0")
        return a

    def example(self, env):
        a = super().example(env)
        return np.broadcast_to(np.eye(3), a.shape).copy()

    def bad(self, env):
        a = self.example(env)
        return super().bad(env) + [("scaled", 2.0 * a), ("a reflection", -a), ("zero", np.zeros_like(a))]

    def edges(self, env):
        return [e for e in super().edges(env) if e[0] not in ("zeros", "1e300 entries")]


class SymmetricPSD(Array):
    """A float array of ``shape`` whose last two axes are symmetric positive semidefinite matrices
    (to 1e-10 of the largest entry): inverse inertias, collision matrices."""

    def describe(self, env=None) -> str:
        return super().describe(env) + " of symmetric positive semidefinite matrices"

    def check(self, name, value, env):
        a = super().check(name, value, env)
        if a.ndim < 2 or a.shape[-1] != a.shape[-2]:
            raise env.fail(name, self.describe(env), value, "not square matrices")
        if a.size:
            s = float(np.abs(a).max())
            if not np.all(np.abs(a - np.swapaxes(a, -1, -2)) <= 1e-10 * s):
                raise env.fail(name, self.describe(env), value, "a matrix is not symmetric")
            if s > 0 and np.linalg.eigvalsh(a / s).min() < -1e-10:
                raise env.fail(name, self.describe(env), value, "a matrix has a negative eigenvalue")
        return a

    def example(self, env):
        a = super().example(env)
        return np.broadcast_to(np.eye(a.shape[-1]), a.shape).copy() * float(self.bounds.middle())

    def bad(self, env):
        a = self.example(env)
        skew = a.copy()
        skew[..., 0, -1] += 1.0
        return super().bad(env) + [("not symmetric", skew), ("negative definite", -a)]


class ContactsFor(Spec):
    """A 3-D :class:`~pbanim.collision.shapes.Contacts` whose body indices exist among ``bodies``
    (an :class:`~pbanim.collision.impulse.ImpulseBodies` argument: indices −1 … B − 1)."""

    def __init__(self, bodies: str = "bodies") -> None:
        self.bodies = bodies
        self.size = f"{bodies}.B"       # read by the contract: this spec refers to another argument

    def describe(self) -> str:
        return f"a Contacts of 3-D points whose body indices lie in −1 … {self.bodies}.B − 1"

    def check(self, name, value, env):
        from .shapes import Contacts

        if not isinstance(value, Contacts):
            raise env.fail(name, self.describe(), value, f"a {type(value).__name__}")
        B = int(env.resolve(self.size))
        if value.point.shape[1] != 3:
            raise env.fail(name, self.describe(), value, "its points are 2-D (impulses act on 3-D bodies)")
        if value.m and max(int(value.a.max()), int(value.b.max())) >= B:
            raise env.fail(name, self.describe(), value, f"it names body {max(value.a.max(), value.b.max())} of "
                                                         f"B = {B}")
        return value

    def example(self, env):
        from .shapes import Contacts

        x = env.resolve(self.bodies).x[0]
        return Contacts([0], [-1], [x - [0.0, 0.0, 0.5]], [[0.0, 0.0, 1.0]], [0.0])

    def bad(self, env):
        from .shapes import Contacts

        B = int(env.resolve(self.size))
        return [("None", None), ("a string", "x"), ("a number", 1.0),
                ("a body past the end", Contacts([B], [-1], [[0.0, 0.0, 0.0]], [[0.0, 0.0, 1.0]], [0.0])),
                ("2-D contacts", Contacts([0], [-1], [[0.0, 0.0]], [[0.0, 1.0]], [0.0]))]


class Obstacle(Spec):
    """A static obstacle of a collision scene: a ``Plane``, or a ``(Sphere, centre)`` pair with a finite
    2- or 3-vector centre (returned as a 3-vector)."""

    def describe(self) -> str:
        return "a Plane or a (Sphere, centre) pair with a finite 2- or 3-vector centre"

    def check(self, name, value, env):
        from .shapes import Plane, Sphere

        if isinstance(value, Plane):
            return value
        if not (isinstance(value, tuple) and len(value) == 2 and isinstance(value[0], Sphere)):
            raise env.fail(name, self.describe(), value)
        c = value[1]
        if c is None or isinstance(c, (str, bytes)) or isinstance(c, numbers.Number):
            raise env.fail(name, self.describe(), value)
        try:
            c = np.asarray(c, dtype=float)
        except (TypeError, ValueError):
            raise env.fail(name, self.describe(), value) from None
        if c.shape not in ((2,), (3,)) or not np.isfinite(c).all():
            raise env.fail(name, self.describe(), value, "the centre is not a finite 2- or 3-vector")
        return value[0], np.append(c, [0.0] * (3 - c.size))

    def example(self, env):
        from .shapes import Plane

        return Plane([0.0, 0.0, 1.0])

    def bad(self, env):
        from .shapes import Sphere

        return [("None", None), ("a string", "floor"), ("a sphere with a NaN centre", (Sphere(0.5), [0.0, np.nan])),
                ("a sphere without a centre", (Sphere(0.5),))]
