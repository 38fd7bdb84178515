"""Contact scenes that are not at rest by construction, and their vectorized narrow phase (chapter 07).

Two scenes for the work-precision benchmark of contact (``pbanim bench contact``):

* :func:`dropped_stack` — n boxes (half extents h = (0.5, 0.5, 0.25) m, 1 kg) dropped from gaps of
  1 mm (box k centred at z_k = h_z(2k + 1) + (k + 1)·gap) with lateral offsets of a few millimetres
  (uniform in [−δ, δ] per axis, seeded), friction μ = 0.5. The stack must land, stop and stay.
* :func:`sphere_pile` — n rigid spheres (r = 0.05 m, 1 kg, I = ⅖ m r²) poured on a jittered lattice
  into the open box |x|, |y| ≤ L = 0.3 m, z ≥ 0, friction μ = 0.5 (they roll, hit and pile).

Narrow phase, one vectorized pass per kind of pair (no Python loop over pairs or contacts):

* box–plane: the eight corners c of every box, p = x + R c, separation s = n·p − d;
* box–box (vertex–face): the corners of box a in the frame of box b, p_b = R_bᵀ(p − x_b); a corner
  inside the slab |p_b,k| ≤ h_k + tol (k = 1, 2, 3; the face's lateral extent widened by ``lateral_tol``
  so that the overhang of an offset stack keeps its support) touches the face of b along the axis of
  least penetration k* = argmax_k (|p_b,k| − h_k), normal n = sign(p_b,k*) R_b e_k*, separation
  s = |p_b,k*| − h_k*. Both directions are computed and, per pair, the one with more corners kept (a
  face resting on a face: the upper box's four corners). Edge–edge contacts are not generated.
* sphere–sphere and sphere–plane: s = |x_a − x_b| − 2r and s = n·x − d − r.

Every contact carries a *key* (a, b, feature) that is stable while the contact persists; the
time stepper uses it to start each step from the previous step's impulses and active set.

=========  ===============  ===========  =============================================
symbol     code             shape        meaning
=========  ===============  ===========  =============================================
h          ``half``         (3,)         box half extents
δ          ``offset``       scalar       lateral offsets drawn from [−δ, δ] (m)
s          ``-depth``       (m,)         separation (negative: penetration)
key        ``keys``         (m,) int     a·K² + b·K + feature, stable across steps
=========  ===============  ===========  =============================================

Limiting cases: gap = offset = 0 gives the stack of :func:`pbanim.models.contact.box_stack`
(exactly touching, four corner contacts per interface); one sphere gives a ball dropped in a box.

References: D. Baraff, SIGGRAPH 2001 course notes, rigid body simulation II (vertex–face contacts);
C. Ericson, *Real-Time Collision Detection* (2005), §4.4 (oriented boxes), §5.2.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Callable

import numpy as np

from ..collision.broad import grid_pairs
from ..collision.shapes import Contacts
from ..errors import InvalidInput, check_count, check_number

__all__ = ["ContactScene3D", "SceneDetect", "dropped_stack", "sphere_pile", "brick_wall", "box_plane_contacts",
           "box_box_contacts",
           "box_box_contacts_loop", "sphere_contacts"]

_CORNERS = np.array([[sx, sy, sz] for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)], dtype=float)


@dataclass
class ContactScene3D:
    """A rigid-body contact scene: ``detect(y) -> (Contacts, keys)``, gravity, and what it is made of."""

    system: Any
    detect: Callable
    forces: list
    friction: float
    info: dict = field(default_factory=dict)


class SceneDetect:
    """The narrow phase of a scene: ``detect(y) -> (Contacts, keys)`` (validated, the public call) and
    ``detect.arrays(y, R) -> (a, b, point, normal, separation, keys)`` (raw arrays, for a stepper that has the
    rotations R (N, 3, 3) of the step already; its geometry is valid by construction: unit normals from
    rotation columns or fixed planes, finite points while the state is finite, which the driver checks)."""

    def __init__(self, bodies, arrays: Callable, rotations: bool = True) -> None:
        self.bodies, self.arrays, self.rotations = bodies, arrays, rotations

    def __call__(self, y):
        y = np.asarray(y, dtype=float)
        if y.shape != (13 * self.bodies.N,):
            raise InvalidInput(f"detect needs a state of shape ({13 * self.bodies.N},), got {y.shape}")
        R = self.bodies.rotations(y) if self.rotations else None
        a, b, p, n, sep, keys = self.arrays(y, R)
        return _contacts(a, b, p, n, sep), keys


def _contacts(a, b, p, n, sep, radius=None) -> Contacts:
    m = len(a)
    return Contacts(a=np.asarray(a, dtype=np.intp), b=np.asarray(b, dtype=np.intp), point=np.reshape(p, (m, 3)),
                    normal=np.reshape(n, (m, 3)), depth=-np.asarray(sep, dtype=float),
                    radius=None if radius is None else np.asarray(radius, dtype=float))


def box_plane_contacts(x, R, half, normal, offset, margin, plane_id: int = 0):
    """Corners of every box within ``margin`` of the plane n·p = d: (a, point, separation, feature)."""
    pts = x[:, None, :] + (_CORNERS * half) @ np.swapaxes(R, 1, 2)                # (N, 8, 3): x + R c
    sep = pts @ normal - offset
    bi, ci = np.nonzero(sep <= margin)
    return bi, pts[bi, ci], sep[bi, ci], 8 * plane_id + ci


def _corner_in_box(x, R, half, ia, ib, margin, lateral_tol):
    """Corners of boxes ia touching a face of boxes ib (vectorized over pairs): mask (P, 8), the corners in
    b's frame (P, 8, 3), normals (P, 3), separations (P, 8). The face of b: its axis of least overlap k*
    (the separating-axis test on b's three face normals, overlap_k = h_k + Σⱼ |(R_bᵀR_a)_kj| h_j − |d_k|,
    d = R_bᵀ(x_a − x_b)); a corner c of a sits at d + C c in b's frame, C = R_bᵀR_a (no world points)."""
    Rb = R[ib]
    d = np.einsum("pji,pj->pi", Rb, x[ia] - x[ib])
    C = np.swapaxes(Rb, 1, 2) @ R[ia]
    overlap = half + np.abs(C) @ half - np.abs(d)
    P = d.shape[0]
    rng = np.arange(P)
    k = np.argmin(overlap, axis=1)                                                         # (P,)
    sign = np.where(d[rng, k] >= 0, 1.0, -1.0)
    loc = d[:, None, :] + (_CORNERS * half) @ np.swapaxes(C, 1, 2)                       # (P, 8, 3) in b's frame
    hk = half[k][:, None]
    sep = sign[:, None] * loc[rng, :, k] - hk                                              # (P, 8)
    lateral = np.abs(loc) - half
    lateral[rng, :, k] = -np.inf
    inside = (lateral.max(axis=2) <= lateral_tol) & (sep <= margin) & (sep > -hk)
    return inside, loc, sign[:, None] * Rb[rng, :, k], sep


def box_box_contacts(x, R, half, pairs, margin: float, lateral_tol: float):
    """Vertex–face contacts of the box pairs (i, j) (array (P, 2)); see the module docstring. Both directions
    (corners of i on j's faces, of j on i's) in one pass over the 2P ordered pairs.

    Returns (a, b, point, normal, separation, feature) with the normal from b to a."""
    pairs = np.asarray(pairs, dtype=np.intp).reshape(-1, 2)
    P = pairs.shape[0]
    ia = np.concatenate([pairs[:, 0], pairs[:, 1]])
    ib = np.concatenate([pairs[:, 1], pairs[:, 0]])
    inside, _, normal, sep = _corner_in_box(x, R, half, ia, ib, margin, lateral_tol)
    count = inside.sum(axis=1)
    use_ij = count[:P] >= count[P:]
    inside &= np.concatenate([use_ij, ~use_ij])[:, None]
    q, c = np.nonzero(inside)                                          # i-on-j contacts first, then j-on-i
    a, b = ia[q], ib[q]
    point = x[a] + np.einsum("pij,pj->pi", R[a], _CORNERS[c] * half)
    return a, b, point, normal[q], sep[q, c], c


def box_box_contacts_loop(x, R, half, pairs, margin: float, lateral_tol: float):
    """Readable per-pair, per-corner version of :func:`box_box_contacts` (same output, same order)."""
    out = {"ij": [], "ji": []}
    for i, j in np.asarray(pairs, dtype=int).reshape(-1, 2):
        found = {}
        for tag, a, b in (("ij", i, j), ("ji", j, i)):
            d = R[b].T @ (x[a] - x[b])
            overlap = [half[k] + np.abs(R[b][:, k] @ R[a]) @ half - abs(d[k]) for k in range(3)]
            k = int(np.argmin(overlap))
            sign = 1.0 if d[k] >= 0 else -1.0
            found[tag] = []
            for c, corner in enumerate(_CORNERS):
                p = x[a] + R[a] @ (corner * half)
                loc = R[b].T @ (p - x[b])
                sep = sign * loc[k] - half[k]
                lateral_ok = all(abs(loc[o]) - half[o] <= lateral_tol for o in range(3) if o != k)
                if lateral_ok and margin >= sep > -half[k]:
                    found[tag].append((a, b, p, sign * R[b][:, k], sep, c))
        tag = "ij" if len(found["ij"]) >= len(found["ji"]) else "ji"
        out[tag] += found[tag]
    rows = out["ij"] + out["ji"]
    if not rows:
        return (np.zeros(0, np.intp),) * 2 + (np.zeros((0, 3)),) * 2 + (np.zeros(0), np.zeros(0, np.intp))
    a, b, p, n, s, c = zip(*rows)
    return np.array(a), np.array(b), np.array(p), np.array(n), np.array(s), np.array(c)


def sphere_contacts(x, r: float, pairs, margin: float):
    """Sphere–sphere contacts for the pairs (P, 2): (a, b, point on b's surface, normal b→a, separation)."""
    i, j = pairs[:, 0], pairs[:, 1]
    d = x[i] - x[j]
    dist = np.linalg.norm(d, axis=1)
    keep = dist - 2 * r <= margin
    n = d[keep] / dist[keep, None]
    return i[keep], j[keep], x[j[keep]] + r * n, n, dist[keep] - 2 * r


def _ground_and_pairs(ground, boxes, up, K):
    """The ground's contacts (body −1, normal ``up``) followed by the box–box ones, as the scenes' arrays
    (A, B, points, normals, separations, keys): a contact's key is (A·K + B + 1)·8 + its feature."""
    g_a, g_p, g_s, g_f = ground
    a, b, p, nn, s, f = boxes
    A = np.concatenate([g_a, a])
    B = np.concatenate([np.full(g_a.size, -1, np.intp), b])
    keys = (A * K + (B + 1)) * 8 + np.concatenate([g_f, f])
    normal = np.concatenate([np.broadcast_to(up, (g_a.size, 3)), nn])
    return A, B, np.concatenate([g_p, p]), normal, np.concatenate([g_s, s]), keys


def dropped_stack(n: int = 10, gap: float = 1e-3, offset: float = 3e-3, friction: float = 0.5, seed: int = 0,
                  half_extents=(0.5, 0.5, 0.25), g: float = 9.81, margin: float = 2e-3,
                  lateral_tol: float = 1e-2) -> ContactScene3D:
    """n boxes dropped from ``gap`` above each other with lateral offsets in [−offset, offset] (see module).

    >>> sc = dropped_stack(3)
    >>> c, keys = sc.detect(sc.system.state()); c.a.size, bool(np.all(c.depth < 0))   # 4 corners per box, 1 mm up
    (12, True)
    """
    from ..rigid.bodies import RigidBodies
    from ..rigid.effects import RigidGravity
    from ..rigid.inertia import box_inertia

    n = check_count("n", n, 1, 1000)
    gap = check_number("gap", gap, low=0.0)
    offset = check_number("offset", offset, low=0.0)
    friction = check_number("friction", friction, low=0.0)
    half = np.asarray(half_extents, dtype=float)
    if half.shape != (3,) or not np.all(np.isfinite(half) & (half > 0)):
        raise InvalidInput(f"half_extents must be 3 positive numbers, got {half_extents!r}")
    if 2 * offset > lateral_tol:
        raise InvalidInput(f"offset must be ≤ lateral_tol / 2 = {lateral_tol / 2} m (the face extension that keeps an "
                           f"overhanging corner in contact), got {offset}")
    rng = np.random.default_rng(seed)
    k = np.arange(n)
    pos = np.zeros((n, 3))
    pos[:, :2] = rng.uniform(-offset, offset, size=(n, 2))
    pos[:, 2] = half[2] * (2 * k + 1) + (k + 1) * gap
    bodies = RigidBodies(np.ones(n), np.stack([box_inertia(1.0, 2 * half)] * n), positions=pos)
    up = np.array([0.0, 0.0, 1.0])
    pairs = np.stack([k[1:], k[:-1]], axis=1)          # neighbours in the stack (a broad phase by construction)
    K = n + 1
    ups, world = np.tile(up, (8, 1)), np.full(8, -1, np.intp)  # one box: at most its 8 corners on the ground

    def arrays(y, R):
        x = y[:3 * n].reshape(n, 3)
        g_a, g_p, g_s, g_f = box_plane_contacts(x[:1], R[:1], half, up, 0.0, margin)
        if n == 1:                                     # one box: the ground alone
            return g_a, world[:g_a.size], g_p, ups[:g_a.size], g_s, (g_a * K) * 8 + g_f
        return _ground_and_pairs((g_a, g_p, g_s, g_f), box_box_contacts(x, R, half, pairs, margin, lateral_tol),
                                 up, K)

    detect = SceneDetect(bodies, arrays)
    return ContactScene3D(bodies, detect, [RigidGravity((0.0, 0.0, -g))], friction,
                          {"half_extents": half, "top": n - 1, "gap": gap, "offset": offset})


def sphere_pile(n: int = 50, radius: float = 0.05, box_half: float | None = 0.3, friction: float = 0.5, seed: int = 0,
                g: float = 9.81, margin: float | None = None, broad: str = "grid") -> ContactScene3D:
    """n rigid spheres poured into the open box |x|, |y| ≤ L, z ≥ 0 (see the module docstring).

    ``box_half`` None: L grows with n so that the lattice holds about four layers (the large scenes of
    ``pbanim bench contact_large``: the pile's depth, hence its contact forces, the same at every n).
    ``broad``: the sphere pairs the narrow phase tests — "grid" (:func:`pbanim.collision.broad.grid_pairs`,
    O(n) at bounded density) or "all_pairs" (the n(n − 1)/2 pairs); the same contacts in the same order.

    >>> sc = sphere_pile(4)
    >>> c, keys = sc.detect(sc.system.state()); bool(np.all(c.depth < 0))   # none touching (some near a wall)
    True
    """
    from ..rigid.bodies import RigidBodies
    from ..rigid.effects import RigidGravity
    from ..rigid.inertia import sphere_inertia

    n = check_count("n", n, 1, 5000)
    r = check_number("radius", radius, low=0.0, low_open=True)
    if broad not in ("grid", "all_pairs"):
        raise InvalidInput(f"broad must be 'grid' or 'all_pairs', got {broad!r}")
    if box_half is None:                              # about four layers of the 2.2 r lattice
        box_half = 1.1 * r * max(2, int(np.ceil(np.sqrt(n / 4.0))))
    L = check_number("box_half", box_half, low=2 * r, low_open=True)
    friction = check_number("friction", friction, low=0.0)
    margin = 0.1 * r if margin is None else check_number("margin", margin, low=0.0)
    rng = np.random.default_rng(seed)
    per = max(1, int(np.floor(2 * L / (2.2 * r))))
    i = np.arange(n)
    pos = np.stack([-L + 1.1 * r + 2.2 * r * (i % per), -L + 1.1 * r + 2.2 * r * ((i // per) % per),
                    r + 0.05 + 2.4 * r * (i // (per * per))], axis=1)
    pos[:, :2] += rng.uniform(-0.05 * r, 0.05 * r, size=(n, 2))
    bodies = RigidBodies(np.ones(n), np.stack([sphere_inertia(1.0, r)] * n), positions=pos)
    walls_n = np.array([[0, 0, 1.0], [1.0, 0, 0], [-1.0, 0, 0], [0, 1.0, 0], [0, -1.0, 0]])
    walls_d = np.array([0.0, -L, -L, -L, -L])
    every = np.stack(np.triu_indices(n, 1), axis=1) if broad == "all_pairs" else None
    K = n + 1

    def arrays(y, R=None):                              # spheres: no rotation needed
        x = y[:3 * n].reshape(n, 3)
        sep_w = x @ walls_n.T - walls_d - r
        bi, wi = np.nonzero(sep_w <= margin)
        pairs = every if every is not None else grid_pairs(x, np.full(n, r), margin).pairs
        a, b, p, nn, s = sphere_contacts(x, r, pairs, margin)
        A = np.concatenate([bi, a])
        B = np.concatenate([np.full(bi.size, -1, np.intp), b])
        keys = (A * K + (B + 1)) * 8 + np.concatenate([wi, np.zeros(a.size, np.intp)])
        return (A, B, np.concatenate([x[bi] - r * walls_n[wi], p]), np.concatenate([walls_n[wi], nn]),
                np.concatenate([sep_w[bi, wi], s]), keys)

    detect = SceneDetect(bodies, arrays, rotations=False)
    return ContactScene3D(bodies, detect, [RigidGravity((0.0, 0.0, -g))], friction,
                          {"radius": r, "box_half": L})


def brick_wall(n: int = 50, per_row: int = 10, half_extents=(0.2, 0.1, 0.1), gap: float = 1e-3, spacing: float = 5e-3,
               friction: float = 0.5, g: float = 9.81, margin: float = 2e-3, lateral_tol: float = 1e-2) -> ContactScene3D:
    """n boxes (1 kg) laid in running bond: course k holds ``per_row`` − k bricks shifted by k half pitches (each
    brick spans two below it; each course one brick shorter, a wall stepped in at both ends), bricks ``spacing``
    apart along the course, courses dropped from ``gap`` above each other; the last course may be partial.

    Pairs come from the broad phase on the bricks' bounding spheres (:func:`pbanim.collision.broad.grid_pairs`)
    at every step, the upper brick first, then the vertex–face test of :func:`box_box_contacts`: where a brick
    overlaps half of the one below, each has two corners over the other's face and the tie keeps the upper
    brick's, at its ends (the lower bricks' corners would hold it on a 5 mm base at its middle, where it tips);
    the ground by :func:`box_plane_contacts`.

    >>> sc = brick_wall(12, per_row=5)
    >>> c, keys = sc.detect(sc.system.state()); c.a.size               # 5 × 4 on the ground, 4 per brick above
    48
    """
    from ..rigid.bodies import RigidBodies
    from ..rigid.effects import RigidGravity
    from ..rigid.inertia import box_inertia

    n = check_count("n", n, 1, 5000)
    per_row = check_count("per_row", per_row, 2, 1000)
    if n > per_row * (per_row + 1) // 2:
        raise InvalidInput(f"n must be at most per_row (per_row + 1) / 2 = {per_row * (per_row + 1) // 2} bricks "
                           f"(courses of per_row, per_row − 1, … 1), got {n}")
    half = np.asarray(half_extents, dtype=float)
    if half.shape != (3,) or not np.all(np.isfinite(half) & (half > 0)):
        raise InvalidInput(f"half_extents must be 3 positive numbers, got {half_extents!r}")
    gap, spacing = check_number("gap", gap, low=0.0), check_number("spacing", spacing, low=0.0)
    friction = check_number("friction", friction, low=0.0)
    if spacing <= margin:
        raise InvalidInput(f"spacing must exceed the contact margin {margin} m (bricks of a course never touch)")
    pitch = 2 * half[0] + spacing
    pos = []
    for k in range(per_row):
        for i in range(per_row - k):
            if len(pos) < n:
                pos.append([(i + 0.5 * k - 0.5 * (per_row - 1)) * pitch, 0.0, half[2] * (2 * k + 1) + (k + 1) * gap])
    pos = np.array(pos)
    bodies = RigidBodies(np.ones(n), np.stack([box_inertia(1.0, 2 * half)] * n), positions=pos)
    up = np.array([0.0, 0.0, 1.0])
    bound = np.full(n, float(np.linalg.norm(half)))
    K = n + 1

    def arrays(y, R):
        x = y[:3 * n].reshape(n, 3)
        g_a, g_p, g_s, g_f = box_plane_contacts(x, R, half, up, 0.0, margin)
        pairs = grid_pairs(x, bound, margin).pairs
        pairs = np.where((x[pairs[:, 0], 2] < x[pairs[:, 1], 2])[:, None], pairs[:, ::-1], pairs)   # upper first
        return _ground_and_pairs((g_a, g_p, g_s, g_f), box_box_contacts(x, R, half, pairs, margin, lateral_tol),
                                 up, K)

    detect = SceneDetect(bodies, arrays)
    return ContactScene3D(bodies, detect, [RigidGravity((0.0, 0.0, -g))], friction,
                          {"half_extents": half, "top": n - 1, "gap": gap, "per_row": per_row})
