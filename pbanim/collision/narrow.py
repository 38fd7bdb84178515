"""Narrow phase: contact points, normals and depths for pairs of shapes (chapter 06).

Every function returns :class:`~pbanim.collision.shapes.Contacts` with the normal pointing from b to a.
Sphere–plane and sphere–sphere are vectorized over many pairs (the hot path of particle and billiard
scenes); box–plane is vectorized over boxes; box–box works one pair at a time (boxes are few).

Box–box uses the separating axis test (Gottschalk, Lin & Manocha 1996; Ericson, *Real-Time Collision
Detection* §4.4): two convex boxes are disjoint iff their projections on one of 15 axes are — the 3 + 3
face normals and the 9 cross products of edge directions. The axis of least overlap gives the normal n and
depth. For a face axis the manifold is the incident face clipped against the side planes of the
reference face (Sutherland–Hodgman), keeping the points below the reference face — this yields 4 points
for face–face, 2 for edge–face and 1 for vertex–face; for an edge axis it is the midpoint of the closest
points of the two supporting edges. Face axes are preferred unless an edge axis is clearly shallower, so
a resting box gets its stable 4-point manifold.
"""

from __future__ import annotations

import numpy as np

from .shapes import Box, Capsule, Contacts, Plane, Sphere, _as3
from .specs import BodyIds, Rotations
from ..contracts import Array, Either, Obj, Opt, Real, contract
from ..errors import InvalidInput

__all__ = ["sphere_plane", "sphere_sphere", "box_plane", "box_box", "sphere_box", "capsule_plane",
           "capsule_sphere", "collide"]

_EDGE_BIAS = 0.95   # an edge axis wins only if its overlap is < 0.95 × the best face overlap
_EPS_AXIS = 1e-9    # |Aᵢ × Bⱼ| below this: parallel edges, the axis is skipped


# what the arguments must be (checked for calls from outside pbanim; see pbanim.contracts)
_CENTRES = Either(Array(("k", 3)), Array(("k", 2)), Array((3,)), Array((2,)))
_RADII = Array(("k",), ge=0, scalar=True)
_IDS = BodyIds(("k",), scalar=True)
_ID = BodyIds(())
_MARGIN = Real(ge=0)
_POINT = Array((3,))
_ROT = Rotations((3, 3))
_HALF = Array((3,), gt=0, scalar=True)
_SHAPE = Obj(Plane, Sphere, Box, Capsule)


def _per(name: str, value, k: int, dtype=float) -> np.ndarray:
    """``value`` (one entry or one per item) broadcast to k items, or InvalidInput naming it."""
    v = np.asarray(value, dtype=dtype).reshape(-1)
    if v.size not in (1, k):
        raise InvalidInput(f"{name} must be one value or one per item ({k}), got {v.size} values")
    return np.broadcast_to(v, (k,)).copy()


def _idx(ids, k: int) -> np.ndarray:
    return _per("a and b (body indices)", ids, k, np.intp)


@contract(centers=_CENTRES, radii=_RADII, plane=Obj(Plane), a=_IDS, b=_IDS, margin=_MARGIN)
def sphere_plane(centers, radii, plane: Plane, a=0, b=-1, margin: float = 0.0) -> Contacts:
    """Contacts of spheres (or point particles, radius 0) with a static plane.

    depth = r − (n·c − offset); a contact exists when depth ≥ −margin (stored clipped to ≥ 0): a sphere
    exactly touching the plane (depth 0) is a contact.

    >>> c = sphere_plane([[0, 0, 0.9], [0, 0, 3]], [1.0, 1.0], Plane([0, 0, 1]), a=[4, 5])
    >>> c.a, c.depth.round(12), c.point[0].round(12)
    (array([4]), array([0.1]), array([ 0.  ,  0.  , -0.05]))
    """
    c = _as3(centers)
    k = len(c)
    r = _per("radii", radii, k)
    depth = r - plane.distance(c)
    hit = depth >= -margin
    n = np.broadcast_to(plane.normal, (int(hit.sum()), 3))
    d = np.maximum(depth[hit], 0.0)
    point = c[hit] - (r[hit] - 0.5 * d)[:, None] * n
    return Contacts(_idx(a, k)[hit], _idx(b, k)[hit], point, n, d, radius=r[hit])


@contract(ca=_CENTRES, ra=_RADII, cb=_CENTRES, rb=_RADII, a=_IDS, b=_IDS, margin=_MARGIN)
def sphere_sphere(ca, ra, cb, rb, a, b, margin: float = 0.0) -> Contacts:
    """Contacts of sphere pairs (vectorized): n = (c_a − c_b)/|c_a − c_b|, depth = r_a + r_b − |c_a − c_b|.

    A contact exists when depth ≥ −margin: spheres exactly r_a + r_b apart touch (depth 0). Coincident
    centres get the normal +z (any unit normal is valid there).

    >>> c = sphere_sphere([[1.9, 0, 0]], 1.0, [[0, 0, 0]], 1.0, a=1, b=0)
    >>> c.normal, c.depth.round(12), c.point.round(12)
    (array([[1., 0., 0.]]), array([0.1]), array([[0.95, 0.  , 0.  ]]))
    """
    ca, cb = _as3(ca), _as3(cb)
    k = max(len(ca), len(cb))
    if len(ca) not in (1, k) or len(cb) not in (1, k):
        raise InvalidInput(f"sphere_sphere: ca and cb must hold one centre or one per pair, got {len(ca)} and "
                           f"{len(cb)}")
    ca, cb = np.broadcast_to(ca, (k, 3)), np.broadcast_to(cb, (k, 3))
    ra, rb = _per("ra", ra, k), _per("rb", rb, k)
    diff = ca - cb
    dist = np.sqrt(np.einsum("ij,ij->i", diff, diff))
    depth = ra + rb - dist
    hit = depth >= -margin
    dist_h = dist[hit]
    n = np.empty((int(hit.sum()), 3))
    ok = dist_h > 0
    n[ok] = diff[hit][ok] / dist_h[ok, None]
    n[~ok] = (0.0, 0.0, 1.0)  # coincident centres: any unit normal is a valid answer
    d = np.maximum(depth[hit], 0.0)
    point = cb[hit] + (rb[hit] - 0.5 * d)[:, None] * n
    return Contacts(_idx(a, k)[hit], _idx(b, k)[hit], point, n, d, radius=ra[hit], radius_b=rb[hit])


@contract(x=_CENTRES, R=Either(Rotations(("k", 3, 3)), _ROT), half_extents=Either(Array(("k", 3), gt=0), _HALF),
          plane=Obj(Plane), a=_IDS, b=_IDS, margin=_MARGIN)
def box_plane(x, R, half_extents, plane: Plane, a=0, b=-1, margin: float = 0.0) -> Contacts:
    """Vertex manifold of boxes on a plane: every corner with depth = offset − n·v ≥ −margin.

    ``x`` (k, 3) centres, ``R`` (k, 3, 3) rotations (columns = body axes), ``half_extents`` (k, 3) or (3,).

    >>> c = box_plane([0, 0, 0.45], np.eye(3), [1, 1, 0.5], Plane())
    >>> c.m, c.depth.round(12)
    (4, array([0.05, 0.05, 0.05, 0.05]))
    """
    x = _as3(x)
    k = len(x)
    R, he = np.asarray(R, dtype=float).reshape(-1, 3, 3), np.asarray(half_extents, dtype=float)
    he = (np.full(3, he) if he.size == 1 else he).reshape(-1, 3)
    if len(R) not in (1, k) or len(he) not in (1, k):
        raise InvalidInput(f"box_plane: R and half_extents must be one or one per box ({k}), got {len(R)} "
                           f"and {len(he)}")
    R, he = np.broadcast_to(R, (k, 3, 3)), np.broadcast_to(he, (k, 3))
    signs = Box(1.0).vertices()                                   # (8, 3) of ±1
    verts = x[:, None, :] + np.einsum("kij,kvj->kvi", R, signs[None] * he[:, None, :])   # (k, 8, 3)
    depth = plane.offset - verts @ plane.normal                   # (k, 8)
    hit = depth >= -margin
    d = np.maximum(depth[hit], 0.0)
    n = np.broadcast_to(plane.normal, (d.size, 3))
    point = verts[hit] + 0.5 * d[:, None] * n
    ia = np.repeat(_idx(a, k), 8).reshape(k, 8)[hit]
    ib = np.repeat(_idx(b, k), 8).reshape(k, 8)[hit]
    return Contacts(ia, ib, point, n, d)


@contract(x=_CENTRES, R=Either(Rotations(("k", 3, 3)), _ROT), radius=Real(gt=0), half_length=Real(gt=0),
          plane=Obj(Plane), a=_IDS, b=_IDS, margin=_MARGIN)
def capsule_plane(x, R, radius: float, half_length: float, plane: Plane, a=0, b=-1, margin: float = 0.0) -> Contacts:
    """Capsule on a plane: its two end spheres against the plane (2 points when lying flat).

    >>> lying = np.array([[1.0, 0, 0], [0, 0, -1], [0, 1, 0]])     # body z along world −y
    >>> c = capsule_plane([0, 0, 0.09], lying, 0.1, 1.0, Plane())
    >>> c.m, c.depth.round(12)
    (2, array([0.01, 0.01]))
    """
    x = _as3(x)
    k = len(x)
    R = np.asarray(R, dtype=float).reshape(-1, 3, 3)
    if len(R) not in (1, k):
        raise InvalidInput(f"capsule_plane: R must be one rotation or one per capsule ({k}), got {len(R)}")
    R = np.broadcast_to(R, (k, 3, 3))
    axis = R[:, :, 2] * half_length
    ends = np.stack([x - axis, x + axis], axis=1).reshape(-1, 3)
    return sphere_plane(ends, radius, plane, a=np.repeat(_idx(a, k), 2), b=np.repeat(_idx(b, k), 2), margin=margin)


@contract(x=_POINT, R=_ROT, radius=Real(gt=0), half_length=Real(gt=0), center=_POINT, sphere_radius=Real(gt=0),
          a=_ID, b=_ID, margin=_MARGIN)
def capsule_sphere(x, R, radius: float, half_length: float, center, sphere_radius: float, a=0, b=1,
                   margin: float = 0.0) -> Contacts:
    """Capsule a against sphere b: the sphere centre's closest point on the segment, then sphere–sphere.

    >>> c = capsule_sphere([0, 0, 0], np.eye(3), 0.5, 1.0, [0, 0, 2.0], 0.6)
    >>> c.normal.round(12), c.depth.round(12)
    (array([[ 0.,  0., -1.]]), array([0.1]))
    """
    x = _as3(x)[0]
    R = np.asarray(R, dtype=float).reshape(3, 3)
    c = _as3(center)[0]
    u = R[:, 2]
    s = np.clip((c - x) @ u, -half_length, half_length)
    q = x + s * u
    return sphere_sphere(q[None], radius, c[None], sphere_radius, a, b, margin)


@contract(center=_POINT, radius=Real(gt=0), x=_POINT, R=_ROT, half_extents=_HALF, a=_ID, b=_ID, margin=_MARGIN)
def sphere_box(center, radius: float, x, R, half_extents, a: int = 0, b: int = 1, margin: float = 0.0) -> Contacts:
    """Sphere a against box b: the closest point of the box to the centre (clamped in the box frame).

    A centre inside the box is pushed out through the nearest face.

    >>> c = sphere_box([0, 0, 1.4], 0.5, [0, 0, 0], np.eye(3), [1, 1, 1])
    >>> c.normal, c.depth.round(12), c.point.round(12)
    (array([[0., 0., 1.]]), array([0.1]), array([[0.  , 0.  , 0.95]]))
    """
    c = _as3(center)[0]
    x = _as3(x)[0]
    R = np.asarray(R, dtype=float).reshape(3, 3)
    he = np.broadcast_to(np.asarray(half_extents, float), (3,))
    p = R.T @ (c - x)
    q = np.clip(p, -he, he)
    d = p - q
    dist = float(np.linalg.norm(d))
    if dist > 0:
        n = R @ (d / dist)
        depth = radius - dist
    else:                                    # centre inside: leave through the nearest face
        k = int(np.argmin(he - np.abs(p)))
        s = 1.0 if p[k] >= 0 else -1.0
        n = s * R[:, k]
        q = p.copy()
        q[k] = s * he[k]
        depth = radius + he[k] - abs(p[k])
    if depth < -margin:
        return Contacts.empty()
    point = 0.5 * ((c - radius * n) + (x + R @ q))
    return Contacts([a], [b], [point], [n], [max(depth, 0.0)], radius=[float(radius)])


def _clip(poly: list, normal: np.ndarray, limit: float) -> list:
    """Sutherland–Hodgman: keep the part of a convex polygon with normal·p ≤ limit."""
    out = []
    for i in range(len(poly)):
        p, q = poly[i], poly[(i + 1) % len(poly)]
        dp, dq = normal @ p - limit, normal @ q - limit
        if dp <= 0:
            out.append(p)
        if dp * dq < 0:
            out.append(p + (q - p) * (dp / (dp - dq)))
    return out


def _face_manifold(xr, Rr, hr, axis: int, nf, xi, Ri, hi, margin: float = 0.0):
    """Points of the incident box's face below the reference face (outward normal nf = ±Rr[:, axis]), or
    within ``margin`` above it (depth 0)."""
    k = int(np.argmax(np.abs(Ri.T @ nf)))
    s = -np.sign(Ri[:, k] @ nf) or -1.0
    fc = xi + s * hi[k] * Ri[:, k]
    o1, o2 = [j for j in range(3) if j != k]
    e1, e2 = hi[o1] * Ri[:, o1], hi[o2] * Ri[:, o2]
    poly = [fc + e1 + e2, fc - e1 + e2, fc - e1 - e2, fc + e1 - e2]
    for t in (j for j in range(3) if j != axis):
        u = Rr[:, t]
        poly = _clip(poly, u, u @ xr + hr[t])
        if poly:
            poly = _clip(poly, -u, -(u @ xr) + hr[t])
        if not poly:
            return np.zeros((0, 3)), np.zeros(0)
    P = np.array(poly)
    sep = (P - (xr + hr[axis] * nf)) @ nf          # < 0 below the reference face, 0 touching it
    keep = sep <= margin
    depth = np.maximum(-sep[keep], 0.0)
    return P[keep] + 0.5 * depth[:, None] * nf, depth


def _closest_on_lines(p1, d1, p2, d2):
    """Closest points p1 + s d1 and p2 + t d2 of two non-parallel lines."""
    r = p1 - p2
    a, e, bb = d1 @ d1, d2 @ d2, d1 @ d2
    c, f = d1 @ r, d2 @ r
    den = a * e - bb * bb
    s = (bb * f - c * e) / den
    t = (a * f - bb * c) / den
    return p1 + s * d1, p2 + t * d2


@contract(xa=_POINT, Ra=_ROT, ha=_HALF, xb=_POINT, Rb=_ROT, hb=_HALF, a=_ID, b=_ID, margin=_MARGIN)
def box_box(xa, Ra, ha, xb, Rb, hb, a: int = 0, b: int = 1, margin: float = 0.0) -> Contacts:
    """Contact manifold of two boxes by the separating axis test (see the module docstring).

    Boxes whose least overlap is ≥ −margin are in contact (touching faces, overlap 0, included); a gap
    inside the margin is reported with depth 0.

    Face–face: a unit cube resting on a larger box gives its 4 bottom corners.

    >>> c = box_box([0, 0, 1.4], np.eye(3), [0.5] * 3, [0, 0, 0], np.eye(3), [2, 2, 1])
    >>> c.m, c.normal[0], c.depth.round(12)
    (4, array([0., 0., 1.]), array([0.1, 0.1, 0.1, 0.1]))
    """
    xa, xb = _as3(xa)[0], _as3(xb)[0]
    Ra, Rb = np.asarray(Ra, float).reshape(3, 3), np.asarray(Rb, float).reshape(3, 3)
    ha, hb = np.broadcast_to(np.asarray(ha, float), (3,)), np.broadcast_to(np.asarray(hb, float), (3,))
    d = xa - xb
    best = [None, None]          # [face (overlap, kind, i, L), edge (...)]
    axes = [("a", i, Ra[:, i]) for i in range(3)] + [("b", j, Rb[:, j]) for j in range(3)]
    axes += [("e", (i, j), np.cross(Ra[:, i], Rb[:, j])) for i in range(3) for j in range(3)]
    for kind, idx, L in axes:
        nrm = np.linalg.norm(L)
        if nrm < _EPS_AXIS:
            continue
        L = L / nrm
        ra = ha @ np.abs(Ra.T @ L)
        rb = hb @ np.abs(Rb.T @ L)
        overlap = ra + rb - abs(L @ d)
        if overlap < -margin:
            return Contacts.empty()                     # a separating axis: no contact
        slot = 1 if kind == "e" else 0
        if best[slot] is None or overlap < best[slot][0]:
            best[slot] = (overlap, kind, idx, L if L @ d >= 0 else -L)
    face, edge = best
    if edge is not None and edge[0] < face[0] - (1 - _EDGE_BIAS) * abs(face[0]) - 1e-12:   # also for gaps < 0
        overlap, _, (i, j), n = edge
        sa = np.where(Ra.T @ n >= 0, -1.0, 1.0)         # a's supporting edge: the corner nearest b
        sb = np.where(Rb.T @ n >= 0, 1.0, -1.0)
        sa[i], sb[j] = 0.0, 0.0
        pa, pb = xa + Ra @ (sa * ha), xb + Rb @ (sb * hb)
        qa, qb = _closest_on_lines(pa, Ra[:, i], pb, Rb[:, j])
        return Contacts([a], [b], [(qa + qb) / 2], [n], [max(overlap, 0.0)])
    overlap, kind, axis, n = face
    if kind == "a":     # reference face on a, facing b: outward normal −n
        P, depth = _face_manifold(xa, Ra, ha, axis, -n, xb, Rb, hb, margin)
    else:               # reference face on b, facing a: outward normal +n
        P, depth = _face_manifold(xb, Rb, hb, axis, n, xa, Ra, ha, margin)
    k = len(depth)
    return Contacts(np.full(k, a), np.full(k, b), P, np.broadcast_to(n, (k, 3)), depth)


@contract(shape_a=_SHAPE, xa=Opt(_POINT), Ra=Opt(_ROT), shape_b=_SHAPE, xb=Opt(_POINT), Rb=Opt(_ROT), a=_ID, b=_ID,
          margin=_MARGIN)
def collide(shape_a, xa, Ra, shape_b, xb, Rb, a: int, b: int, margin: float = 0.0) -> Contacts:
    """Dispatch one pair of shapes (in either order) to its narrow-phase test.

    Planes are static (pose ignored: None is fine); a sphere needs its centre, a box or a capsule its
    rotation too. Pairs without a test (plane–plane, box–capsule, capsule–capsule) raise
    :class:`~pbanim.errors.InvalidInput` naming the pair.

    >>> collide(Plane(), None, None, Sphere(1.0), [0, 0, 0.5], np.eye(3), -1, 3).a
    array([3])
    """
    for shape, x, R, nx, nR in ((shape_a, xa, Ra, "xa", "Ra"), (shape_b, xb, Rb, "xb", "Rb")):
        if not isinstance(shape, Plane) and (x is None or R is None and not isinstance(shape, Sphere)):
            raise InvalidInput(f"collide: a {type(shape).__name__} needs its pose: {nx}"
                               f"{'' if isinstance(shape, Sphere) else f' and {nR}'} must be given, got "
                               f"{nx} = {x!r}, {nR} = {R!r}")
    if isinstance(shape_a, Plane) and not isinstance(shape_b, Plane):
        return collide(shape_b, xb, Rb, shape_a, xa, Ra, b, a, margin)
    if isinstance(shape_b, Plane):
        if isinstance(shape_a, Sphere):
            return sphere_plane(xa, shape_a.radius, shape_b, a, b, margin)
        if isinstance(shape_a, Box):
            return box_plane(xa, Ra, shape_a.half_extents, shape_b, a, b, margin)
        if isinstance(shape_a, Capsule):
            return capsule_plane(xa, Ra, shape_a.radius, shape_a.half_length, shape_b, a, b, margin)
    elif isinstance(shape_a, Sphere) and isinstance(shape_b, Sphere):
        return sphere_sphere(xa, shape_a.radius, xb, shape_b.radius, a, b, margin)
    elif isinstance(shape_a, Box) and isinstance(shape_b, Box):
        return box_box(xa, Ra, shape_a.half_extents, xb, Rb, shape_b.half_extents, a, b, margin)
    elif isinstance(shape_a, Sphere) and isinstance(shape_b, Box):
        return sphere_box(xa, shape_a.radius, xb, Rb, shape_b.half_extents, a, b, margin)
    elif isinstance(shape_a, Box) and isinstance(shape_b, Sphere):
        return sphere_box(xb, shape_b.radius, xa, Ra, shape_a.half_extents, b, a, margin).swapped()
    elif isinstance(shape_a, Capsule) and isinstance(shape_b, Sphere):
        return capsule_sphere(xa, Ra, shape_a.radius, shape_a.half_length, xb, shape_b.radius, a, b, margin)
    elif isinstance(shape_a, Sphere) and isinstance(shape_b, Capsule):
        return capsule_sphere(xb, Rb, shape_b.radius, shape_b.half_length, xa, shape_a.radius, b, a, margin).swapped()
    raise InvalidInput(f"collide: shape_a and shape_b: no narrow-phase test for {type(shape_a).__name__}–"
                       f"{type(shape_b).__name__}; supported: sphere/box/capsule–plane, sphere–sphere, "
                       "sphere–box, box–box, capsule–sphere")
