"""Collision shapes and the ``Contacts`` record (chapter 06, part of :mod:`pbanim.collision`).

A shape is geometry in its body frame; the pose (centre x, rotation R) comes from the body. A contact
between bodies a and b is (point p, unit normal n pointing from b towards a, penetration depth ≥ 0):
body a moves along +n to separate, and the relative normal velocity

    v_rel = n·(ṗ_a − ṗ_b),     ṗ = v + ω × (p − x)

is negative when the bodies approach. Index −1 is the static world (planes and fixed obstacles).

=================  ===========  ==========  ==================================================
symbol             code         shape       meaning
=================  ===========  ==========  ==================================================
a, b               ``a, b``     (m,) int    body indices (−1 = the static world)
p                  ``point``    (m, 3)      contact point, midway between the two surfaces
n                  ``normal``   (m, 3)      unit normal, from b towards a
d                  ``depth``    (m,)        penetration depth (0 = touching; < 0: a gap, for look-ahead)
=================  ===========  ==========  ==================================================

Touching counts: the narrow phase reports a contact when depth ≥ −margin, so two spheres exactly r_a + r_b
apart (depth 0) are a contact, never skipped.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Iterable

import numpy as np

from .specs import BodyIds, UnitVectors
from ..contracts import Array, Either, Indices, Obj, Opt, Real, Seq, Spec, contract
from ..errors import InvalidInput, as_float, check_number

__all__ = ["Contacts", "Plane", "Sphere", "Box", "Capsule", "check_restitution", "check_friction"]


_POINTS = Either(Array(("m", 3), empty=True), Array(("m", 2), empty=True))
_MASS = Real(gt=0)


class _Mask(Spec):
    """A bool array with one entry per contact (``size`` is a reference to the count)."""

    def __init__(self, size) -> None:
        self.size = size

    def describe(self) -> str:
        return "a bool array with one entry per contact"

    def check(self, name, value, env):
        a = np.asarray(value) if isinstance(value, (list, tuple, np.ndarray)) else None
        m = int(env.resolve(self.size))
        if a is None or a.dtype != bool or a.shape != (m,):
            raise env.fail(name, f"a bool array of shape ({m},)", value)
        return a

    def example(self, env):
        return np.ones(int(env.resolve(self.size)), dtype=bool)

    def bad(self, env):
        return [("None", None), ("too long", np.ones(int(env.resolve(self.size)) + 1, dtype=bool))]


@contract(a=BodyIds(("m",)), b=BodyIds(("m",)), point=_POINTS, normal=Either(
    UnitVectors(("m", 3), empty=True), UnitVectors(("m", 2), empty=True)), depth=Array(("m",), empty=True),
    radius=Opt(Array(("m",), ge=0, empty=True)), radius_b=Opt(Array(("m",), ge=0, empty=True)))
@dataclass
class Contacts:
    """Struct of arrays of m contacts (the interface every contact solver codes against).

    Attributes
    ----------
    a, b : ndarray of int, shape (m,)
        The two bodies; −1 is the static world. ``a`` moves along +``normal`` to separate.
    point : ndarray, shape (m, 3) (or (m, 2) for contacts of 2-D particles)
    normal : ndarray, shape (m, 3) (or (m, 2))
        Unit normals pointing from b towards a.
    depth : ndarray, shape (m,)
        Penetration depths (0: touching; negative: a gap, the look-ahead contacts of chapter 07).
    radius, radius_b : ndarray, shape (m,), optional
        Curvature radii of a's and b's features (0: a vertex or a face).

    Examples
    --------
    >>> c = Contacts(a=[0], b=[-1], point=[[0, 0, 0]], normal=[[0, 0, 1]], depth=[0.01])
    >>> c.m, c.normal.shape
    (1, (1, 3))
    >>> Contacts.concatenate([c, Contacts.empty()]).m
    1
    """

    a: np.ndarray
    b: np.ndarray
    point: np.ndarray
    normal: np.ndarray
    depth: np.ndarray
    radius: np.ndarray | None = None      # curvature radius of a's feature (sphere, capsule end); 0: vertex
    radius_b: np.ndarray | None = None    # the same for b; 0: a vertex or a face of b

    def __post_init__(self) -> None:
        self.a = np.asarray(self.a, dtype=np.intp).reshape(-1)
        self.b = np.asarray(self.b, dtype=np.intp).reshape(-1)
        point = np.asarray(self.point, dtype=float)
        normal = np.asarray(self.normal, dtype=float)
        # the contract checks each argument of a call from outside pbanim; contacts built inside (the narrow
        # phase, the contact chapter's make_contacts) are checked here, once, with the cross-field rules
        d = point.shape[-1] if point.ndim >= 1 and point.shape[-1] in (2, 3) else 3   # 2-D scenes: (m, 2)
        if point.size % d or normal.size % d or (point.ndim == normal.ndim == 2 and point.shape[1] != normal.shape[1]):
            raise InvalidInput(f"Contacts point and normal must have shape (m, 2) or (m, 3) alike, got "
                               f"{point.shape} and {normal.shape}")
        self.point = point.reshape(-1, d)
        self.normal = normal.reshape(-1, d)
        self.depth = np.asarray(self.depth, dtype=float).reshape(-1)
        m = self.a.size
        self.radius = np.zeros(m) if self.radius is None else np.asarray(self.radius, dtype=float).reshape(-1)
        self.radius_b = np.zeros(m) if self.radius_b is None else np.asarray(self.radius_b, dtype=float).reshape(-1)
        if self.radius.size != m or self.radius_b.size != m or np.any(~(self.radius >= 0)) or np.any(~(self.radius_b >= 0)):
            raise InvalidInput(f"Contacts radius and radius_b must hold m = {m} finite values >= 0, got "
                               f"{self.radius} and {self.radius_b}")
        if not (self.b.size == m and len(self.point) == m and len(self.normal) == m and self.depth.size == m):
            raise InvalidInput(f"Contacts fields must all have m = {m} rows, got b {self.b.shape}, point "
                             f"{self.point.shape}, normal {self.normal.shape}, depth {self.depth.shape}")
        if m:   # one fused pass: unit normals (a zero or NaN normal is no contact direction), finite geometry
            nn = np.einsum("ij,ij->i", self.normal, self.normal)
            if not (np.all(np.abs(nn - 1.0) <= 1e-6) and np.isfinite(self.point).all()
                    and np.isfinite(self.depth).all()):
                bad = int(np.flatnonzero(~(np.abs(nn - 1.0) <= 1e-6) | ~np.isfinite(self.point).all(axis=1)
                                         | ~np.isfinite(self.depth))[0])
                raise InvalidInput(f"Contacts need finite points and depths and unit normals, got contact {bad}: "
                                   f"point {self.point[bad].tolist()}, normal {self.normal[bad].tolist()} "
                                   f"(|n| = {np.sqrt(nn[bad]):.6g}), depth {self.depth[bad]}")

    @property
    def m(self) -> int:
        """Number of contacts."""
        return int(self.a.size)

    def __len__(self) -> int:
        return self.m

    @classmethod
    def empty(cls) -> "Contacts":
        return cls(np.zeros(0, np.intp), np.zeros(0, np.intp), np.zeros((0, 3)), np.zeros((0, 3)), np.zeros(0))

    @classmethod
    @contract(parts=Seq(Obj("pbanim.collision.shapes:Contacts")))
    def concatenate(cls, parts: Iterable["Contacts"]) -> "Contacts":
        """One set holding every contact of ``parts`` in order (all 2-D or all 3-D)."""
        parts = [p for p in parts if p.m]
        if not parts:
            return cls.empty()
        if len({p.point.shape[1] for p in parts}) > 1:
            raise InvalidInput(f"Contacts.concatenate: parts mix 2-D and 3-D contacts (point widths "
                               f"{sorted({p.point.shape[1] for p in parts})}); give contacts of one dimension")
        return cls(np.concatenate([p.a for p in parts]), np.concatenate([p.b for p in parts]),
                   np.concatenate([p.point for p in parts]), np.concatenate([p.normal for p in parts]),
                   np.concatenate([p.depth for p in parts]), np.concatenate([p.radius for p in parts]),
                   np.concatenate([p.radius_b for p in parts]))

    @contract(mask=Either(_Mask("self.m"), Indices("self.m", (None,), empty=True)))
    def select(self, mask) -> "Contacts":
        """The contacts where ``mask`` (bool array of shape (m,), or contact indices) holds."""
        mask = np.asarray(mask)
        out = object.__new__(Contacts)       # rows of checked contacts: no second check (hot in impulse loops)
        for name in ("a", "b", "point", "normal", "depth", "radius", "radius_b"):
            setattr(out, name, getattr(self, name)[mask])
        return out

    def swapped(self) -> "Contacts":
        """The same contacts seen from the other body: a ↔ b, n → −n, radius ↔ radius_b."""
        return Contacts(self.b, self.a, self.point, -self.normal, self.depth, self.radius_b, self.radius)


def _shape_inertia(shape, mass, moments) -> np.ndarray:
    """diag(moments) after checking the mass and that the moments are representable (finite, > 0)."""
    m = float(mass)
    with np.errstate(over="ignore", under="ignore", invalid="ignore"):
        d = np.array([f(m) for f in moments], dtype=float)
    if not (np.all(np.isfinite(d)) and np.all(d > 0)):
        raise InvalidInput(f"{shape!r}.inertia: mass {mass} gives moments {d.tolist()}, not finite and > 0 "
                           "(a mass <= 0, or dimensions and mass that overflow double precision); use a "
                           "positive mass in moderate units")
    return np.diag(d)


@contract(restitution=Real(ge=0, le=1))
def check_restitution(restitution) -> float:
    """Validate ε ∈ [0, 1] (ORACLES G3): 0 is a plastic, 1 an elastic impact.

    The contract refuses a bad value from outside pbanim; the body checks a value passed on from inside
    (a model's or a design scene's own argument).

    >>> check_restitution(1.5)
    Traceback (most recent call last):
    ...
    pbanim.errors.InvalidInput: check_restitution: restitution must be a finite number >= 0 and <= 1, got 1.5
    """
    e = as_float("restitution", restitution)
    if not (0.0 <= e <= 1.0):
        raise InvalidInput(f"restitution must lie in [0, 1], got {restitution}; use 0 for a plastic and 1 "
                           "for an elastic impact")
    return e


@contract(friction=Real(ge=0))
def check_friction(friction) -> float:
    """Validate the Coulomb coefficient μ ≥ 0 (ORACLES G3); the body checks a value passed on from inside
    pbanim, as :func:`check_restitution` does."""
    return check_number("friction", friction, low=0.0)


class Plane:
    """Static half-space boundary {p : n·p = offset}; the free side is n·p > offset.

    >>> Plane([0, 0, 2.0]).normal, Plane([0, 0, 1], offset=1.0).distance([[0, 0, 3.0]])
    (array([0., 0., 1.]), array([2.]))
    """

    static = True

    @contract(normal=Either(Array((3,)), Array((2,))), offset=Real())
    def __init__(self, normal=(0.0, 0.0, 1.0), offset: float = 0.0) -> None:
        n = np.array(normal, dtype=float).reshape(-1)
        if n.size == 2:
            n = np.array([n[0], n[1], 0.0])
        big = float(np.abs(n).max()) if n.shape == (3,) else 0.0
        if not (np.isfinite(big) and big > 0):     # a zero normal has no direction (a spec cannot say so)
            raise InvalidInput(f"Plane.__init__: normal must be a finite nonzero 2- or 3-vector, got "
                               f"{np.asarray(normal).tolist()}; a plane needs a direction")
        n = n / big                                # scaled first: |n| of a 1e300 vector overflows
        self.normal = n / np.linalg.norm(n)
        self.offset = float(offset)

    @contract(points=Either(Array(("k", 3)), Array(("k", 2)), Array((3,)), Array((2,))))
    def distance(self, points) -> np.ndarray:
        """Signed distance n·p − offset of points (k, 3) (or (k, 2), padded with z = 0; or one point)."""
        p = _as3(points)
        return p @ self.normal - self.offset

    def __repr__(self) -> str:
        return f"Plane(normal={self.normal.tolist()}, offset={self.offset})"


class Sphere:
    """Sphere of radius r about the body centre.

    >>> Sphere(0)
    Traceback (most recent call last):
    ...
    pbanim.errors.InvalidInput: Sphere.__init__: radius must be a finite number > 0, got 0
    """

    @contract(radius=Real(gt=0))
    def __init__(self, radius: float) -> None:
        self.radius = float(radius)       # a point is a particle of radius 0, not a Sphere

    @contract(mass=_MASS)
    def inertia(self, mass: float) -> np.ndarray:
        """Body-frame inertia tensor of a solid sphere, (2/5) m r² 𝟙."""
        r = np.float64(self.radius)
        return _shape_inertia(self, mass, [lambda m: 0.4 * m * r * r] * 3)

    def __repr__(self) -> str:
        return f"Sphere(radius={self.radius})"


class Box:
    """Box with half extents (hx, hy, hz) along the body axes.

    >>> Box([1, 0.5, 0.25]).vertices().shape
    (8, 3)
    """

    @contract(half_extents=Array((3,), gt=0, scalar=True))
    def __init__(self, half_extents) -> None:
        self.half_extents = np.broadcast_to(np.asarray(half_extents, dtype=float), (3,)).copy()

    def vertices(self) -> np.ndarray:
        """The 8 corners in the body frame, (8, 3)."""
        s = np.array([[i, j, k] for i in (-1, 1) for j in (-1, 1) for k in (-1, 1)], dtype=float)
        return s * self.half_extents

    @contract(mass=_MASS)
    def inertia(self, mass: float) -> np.ndarray:
        """Body-frame inertia (m/3) diag(hy²+hz², hx²+hz², hx²+hy²)."""
        hx, hy, hz = self.half_extents
        return _shape_inertia(self, mass, [lambda m: m / 3.0 * (hy * hy + hz * hz), lambda m: m / 3.0 * (hx * hx + hz * hz),
                                           lambda m: m / 3.0 * (hx * hx + hy * hy)])

    def __repr__(self) -> str:
        return f"Box(half_extents={self.half_extents.tolist()})"


class Capsule:
    """Capsule: the points within ``radius`` of the segment from −half_length to +half_length on body z.

    >>> Capsule(radius=0.1, half_length=0.0)
    Traceback (most recent call last):
    ...
    pbanim.errors.InvalidInput: Capsule.__init__: half_length must be a finite number > 0, got 0.0
    """

    @contract(radius=Real(gt=0), half_length=Real(gt=0))
    def __init__(self, radius: float, half_length: float) -> None:
        self.radius, self.half_length = float(radius), float(half_length)    # zero length: a Sphere

    @contract(mass=_MASS)
    def inertia(self, mass: float) -> np.ndarray:
        """Body-frame inertia, approximated by a solid cylinder of length 2(half_length + radius)."""
        r, hl = np.float64(self.radius), np.float64(self.half_length)
        ixx = lambda m: m * (3 * r * r + (2 * (hl + r)) ** 2) / 12.0  # noqa: E731
        return _shape_inertia(self, mass, [ixx, ixx, lambda m: 0.5 * m * r * r])

    def __repr__(self) -> str:
        return f"Capsule(radius={self.radius}, half_length={self.half_length})"


def _as3(points) -> np.ndarray:
    """Points as (k, 3) float, padding 2-D points with z = 0."""
    p = np.asarray(points, dtype=float)
    p = p.reshape(-1, p.shape[-1]) if p.ndim else p.reshape(1, 1)
    if p.shape[1] == 2:
        p = np.concatenate([p, np.zeros((len(p), 1))], axis=1)
    if p.shape[1] != 3:
        raise InvalidInput(f"points must have 2 or 3 coordinates, got shape {np.shape(points)}")
    return p
