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
d                  ``depth``    (m,)        penetration depth (≥ 0; 0 = touching)
=================  ===========  ==========  ==================================================
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Iterable

import numpy as np
from ..errors import InvalidInput, as_float, as_floats, check_positive

__all__ = ["Contacts", "Plane", "Sphere", "Box", "Capsule", "check_restitution", "check_friction"]


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
        Penetration depths ≥ 0.

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
        d = point.shape[-1] if point.ndim >= 1 and point.shape[-1] in (2, 3) else 3   # 2-D scenes: (m, 2)
        if point.size % d or normal.size % d:
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
    def concatenate(cls, parts: Iterable["Contacts"]) -> "Contacts":
        parts = [p for p in parts if p.m]
        if not parts:
            return cls.empty()
        return cls(np.concatenate([p.a for p in parts]), np.concatenate([p.b for p in parts]),
                   np.concatenate([p.point for p in parts]), np.concatenate([p.normal for p in parts]),
                   np.concatenate([p.depth for p in parts]), np.concatenate([p.radius for p in parts]),
                   np.concatenate([p.radius_b for p in parts]))

    def select(self, mask) -> "Contacts":
        """The contacts where ``mask`` (bool array or index array) holds."""
        mask = np.asarray(mask)
        if mask.dtype == bool and mask.shape != (self.m,):
            raise InvalidInput(f"mask must be a bool array of shape ({self.m},) (one per contact), got {mask.shape}")
        if mask.dtype != bool and (mask.dtype.kind not in "iu" or mask.ndim != 1
                                   or np.any((mask < -self.m) | (mask >= self.m))):
            raise InvalidInput(f"mask must be bool (m,) or contact indices in [0, {self.m}), got {mask!r}")
        return Contacts(self.a[mask], self.b[mask], self.point[mask], self.normal[mask], self.depth[mask],
                        self.radius[mask], self.radius_b[mask])

    def swapped(self) -> "Contacts":
        """The same contacts seen from the other body: a ↔ b, n → −n, radius ↔ radius_b."""
        return Contacts(self.b, self.a, self.point, -self.normal, self.depth, self.radius_b, self.radius)


def _shape_inertia(shape, mass, moments) -> np.ndarray:
    """diag(moments) after checking the mass and that the moments are representable (finite, > 0)."""
    m = _positive("mass", mass, "a body has a positive finite mass")
    with np.errstate(over="ignore", under="ignore", invalid="ignore"):
        d = np.array([f(m) for f in moments], dtype=float)
    if not (np.all(np.isfinite(d)) and np.all(d > 0)):
        raise InvalidInput(f"{shape!r}.inertia({mass}) has moments {d.tolist()}, not finite and > 0 (the "
                           "dimensions or mass overflow double precision); use moderate units")
    return np.diag(d)


_positive = check_positive


def check_restitution(restitution) -> float:
    """Validate ε ∈ [0, 1] (ORACLES G3).

    >>> check_restitution(1.5)
    Traceback (most recent call last):
    ...
    pbanim.errors.InvalidInput: restitution must lie in [0, 1], got 1.5; use 0 for a plastic and 1 for an elastic impact
    """
    e = as_float("restitution", restitution)
    if not (0.0 <= e <= 1.0):
        raise InvalidInput(f"restitution must lie in [0, 1], got {restitution}; use 0 for a plastic and 1 "
                         "for an elastic impact")
    return e


def check_friction(friction) -> float:
    """Validate the Coulomb coefficient μ ≥ 0 (ORACLES G3)."""
    mu = float(friction)
    if not (np.isfinite(mu) and mu >= 0.0):
        raise InvalidInput(f"friction must be a finite coefficient >= 0, got {friction}; use 0 for smooth contact")
    return mu


class Plane:
    """Static half-space boundary {p : n·p = offset}; the free side is n·p > offset.

    >>> Plane([0, 0, 2.0]).normal, Plane([0, 0, 1], offset=1.0).distance([[0, 0, 3.0]])
    (array([0., 0., 1.]), array([2.]))
    """

    static = True

    def __init__(self, normal=(0.0, 0.0, 1.0), offset: float = 0.0) -> None:
        n = as_floats("normal", normal).reshape(-1)
        if n.size == 2:
            n = np.array([n[0], n[1], 0.0])
        if n.shape != (3,) or not np.all(np.isfinite(n)) or np.linalg.norm(n) == 0:
            raise InvalidInput(f"plane normal must be a finite nonzero 2- or 3-vector, got {normal}")
        self.normal = n / np.linalg.norm(n)
        self.offset = float(offset)
        if not np.isfinite(self.offset):
            raise InvalidInput(f"plane offset must be finite, got {offset}")

    def distance(self, points) -> np.ndarray:
        """Signed distance n·p − offset of points (k, 3) (or (k, 2), padded with z = 0)."""
        p = _as3(points)
        return p @ self.normal - self.offset

    def __repr__(self) -> str:
        return f"Plane(normal={self.normal.tolist()}, offset={self.offset})"


class Sphere:
    """Sphere of radius r about the body centre.

    >>> Sphere(0)
    Traceback (most recent call last):
    ...
    pbanim.errors.InvalidInput: Sphere radius must be positive and finite, got 0; a sphere needs a radius > 0 (use a particle for a point)
    """

    def __init__(self, radius: float) -> None:
        self.radius = _positive("Sphere radius", radius, "a sphere needs a radius > 0 (use a particle for a point)")

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

    def __init__(self, half_extents) -> None:
        he = np.asarray(half_extents, dtype=float)
        he = np.broadcast_to(he, (3,)).copy() if he.shape in ((), (1,), (3,)) else np.full(3, np.nan)
        if not np.all(np.isfinite(he)) or np.any(he <= 0):
            raise InvalidInput(f"Box half_extents must be three positive finite numbers, got {half_extents}; "
                             "a box with a zero extent is degenerate (use a Plane)")
        self.half_extents = he

    def vertices(self) -> np.ndarray:
        """The 8 corners in the body frame, (8, 3)."""
        s = np.array([[i, j, k] for i in (-1, 1) for j in (-1, 1) for k in (-1, 1)], dtype=float)
        return s * self.half_extents

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
    pbanim.errors.InvalidInput: Capsule half_length must be positive and finite, got 0.0; a capsule of zero length is a Sphere
    """

    def __init__(self, radius: float, half_length: float) -> None:
        self.radius = _positive("Capsule radius", radius, "a capsule needs a radius > 0")
        self.half_length = _positive("Capsule half_length", half_length, "a capsule of zero length is a Sphere")

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
