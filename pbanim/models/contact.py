"""Canonical resting-contact models (chapter 07) with their exact answers (ORACLES D4–D9).

* Degenerate LCPs (D8): PSD non-unique, Murty's matrix (a P-matrix: unique solution), infeasible,
  trivial — and random contact LCPs A = J W Jᵀ, full-rank (m < n) or redundant (m > n), for benchmarks.
* Boxes (D4, D5): a box resting on a plane (Σf = mg), stacks with mass ratios (interface force = weight
  above), a box on an incline (D6: static iff tan θ ≤ μ, else a = g(sin θ − μ cos θ)).
* Painlevé's rod (D7): B(θ) = 1 + 3 cos θ (cos θ − μ sin θ); B < 0 is possible iff μ > 4/3.
* Spheres poured into a box (a pile settling).

Every scene returns a :class:`ContactScene`: the system, a vectorized ``detect(y) -> Contacts`` (vertex–
face manifolds: the corners of a box against a plane or against the top face of the box below it), the
force effects, and the exact values to test against.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Callable

import numpy as np

from ..collision.shapes import Contacts
from ..contact.assembly import make_contacts
from ..errors import InvalidInput, check_count, check_number

__all__ = ["LCPCase", "psd_nonunique_lcp", "murty_lcp", "infeasible_lcp", "trivial_lcp", "random_contact_lcp",
           "ContactScene", "box_on_plane", "box_stack", "box_on_incline", "incline_expected", "painleve_B",
           "painleve_rod", "sphere_pour"]


@dataclass
class LCPCase:
    """An LCP w = A f + b ≥ 0 ⊥ f ≥ 0 with what is known about it."""

    name: str
    A: np.ndarray
    b: np.ndarray
    feasible: bool
    solution: np.ndarray | None = None   # the unique solution, when it is unique
    note: str = ""


def psd_nonunique_lcp() -> LCPCase:
    """A = [[1,1],[1,1]], b = (−1,−1): every f ≥ 0 with f₁ + f₂ = 1 solves it (ORACLES D8)."""
    return LCPCase("psd-nonunique", np.array([[1.0, 1.0], [1.0, 1.0]]), np.array([-1.0, -1.0]), True,
                   note="solutions: f ≥ 0, f1 + f2 = 1")


def murty_lcp(n: int = 8) -> LCPCase:
    """Murty's upper-triangular P-matrix (1 on the diagonal, 2 above), b = −1: unique solution e_n.

    >>> murty_lcp(3).A
    array([[1., 2., 2.],
           [0., 1., 2.],
           [0., 0., 1.]])
    """
    n = check_count("n", n, 1, 10_000)
    A = np.eye(n) + 2.0 * np.triu(np.ones((n, n)), 1)
    sol = np.zeros(n)
    sol[-1] = 1.0
    return LCPCase(f"murty-{n}", A, -np.ones(n), True, sol, "P-matrix; Lemke-type pivoting can need 2^n steps")


def infeasible_lcp() -> LCPCase:
    """A = [−1], b = [−1]: w = −f − 1 < 0 for every f ≥ 0 (no solution)."""
    return LCPCase("infeasible", np.array([[-1.0]]), np.array([-1.0]), False)


def trivial_lcp(m: int = 3) -> LCPCase:
    """b ≥ 0: f = 0 is the solution (unique here, A = I)."""
    m = check_count("m", m, 0, 10_000)   # dense m × m matrices
    return LCPCase("trivial", np.eye(m), np.linspace(0.0, 1.0, m), True, np.zeros(m))


def random_contact_lcp(m: int, redundant: bool = False, seed: int = 0) -> LCPCase:
    """A frictionless contact LCP A = J W Jᵀ, b = J a_free (always feasible: b lies in range(J)).

    ``redundant=False``: n = 2m generalized velocities (A full rank); ``redundant=True``: n = m // 2 + 1
    (rank-deficient A, like the four corners of every box face). Half the contacts are pressed.
    """
    m = check_count("m", m, 1, 10_000)
    rng = np.random.default_rng(seed)
    n = m // 2 + 1 if redundant else 2 * m
    J = rng.normal(size=(m, n)) / np.sqrt(n)
    W = rng.uniform(0.5, 2.0, size=n)
    a_free = rng.normal(size=n)
    return LCPCase(f"contact-{'redundant' if redundant else 'fullrank'}-{m}", (J * W) @ J.T, J @ a_free, True)


# ---------------------------------------------------------------------------------------------
# Box scenes
# ---------------------------------------------------------------------------------------------
@dataclass
class ContactScene:
    """A contact scene: system, contact detection, force effects and the exact answers."""

    system: Any
    detect: Callable
    forces: list
    exact: dict = field(default_factory=dict)
    half_extents: np.ndarray | None = None


def _corners(half: np.ndarray, bottom_only: bool) -> np.ndarray:
    s = np.array([[sx, sy, sz] for sx in (-1, 1) for sy in (-1, 1) for sz in ((-1,) if bottom_only else (-1, 1))])
    return s * half


def _box_contacts(a, b, point, normal, depth):
    """The Contacts of a box scene's narrow phase, valid by construction (normals: a fixed unit plane normal or
    a rotation's column; points and depths finite while the state is, which the stepping drivers check), stored
    as :class:`~pbanim.collision.shapes.Contacts` stores them without its per-call validation (a time step's
    ``check_contacts`` still checks what it receives)."""
    c = object.__new__(Contacts)
    c.a, c.b = np.asarray(a, dtype=np.intp), np.asarray(b, dtype=np.intp)
    c.point, c.normal, c.depth = point, normal, depth
    c.radius, c.radius_b = np.zeros(c.a.size), np.zeros(c.a.size)
    return c


def _plane_corners(bodies, y, half, normal, offset, margin, bodies_idx=None, bottom_only=False):
    """Corners of boxes ``bodies_idx`` within ``margin`` of the static plane n·x = offset."""
    idx = np.arange(bodies.N) if bodies_idx is None else np.asarray(bodies_idx)
    x = bodies.unpack(y)[0][idx]
    R = bodies.rotations(y)[idx]
    c = _corners(half, bottom_only)
    pts = x[:, None, :] + np.einsum("nij,kj->nki", R, c)
    sep = pts @ normal - offset
    keep = sep <= margin
    body = np.broadcast_to(idx[:, None], sep.shape)[keep]
    m = int(keep.sum())
    return _box_contacts(body, -np.ones(m, int), pts[keep], np.tile(normal, (m, 1)), -sep[keep])


def _check_mass(name, value):
    value = float(value)
    if not (np.isfinite(value) and value > 0):
        raise InvalidInput(f"{name} must be positive, got {value}")
    return value


def box_on_plane(mass: float = 1.0, half_extents=(0.5, 0.25, 0.125), g: float = 9.81,
                 margin: float = 1e-9) -> ContactScene:
    """A box resting on the ground plane z = 0 (ORACLES D4): Σf = m g, Σ r×f = 0.

    Corner forces are indeterminate (four contacts, three constrained directions): only totals are exact.

    >>> sc = box_on_plane(2.0)
    >>> c = sc.detect(sc.system.state()); len(c.a), float(abs(c.depth).max()), sc.exact["total_force"]
    (4, 0.0, 19.62)
    """
    from ..rigid.bodies import RigidBodies
    from ..rigid.effects import RigidGravity
    from ..rigid.inertia import box_inertia

    mass = _check_mass("mass", mass)
    h = np.asarray(half_extents, dtype=float)
    bodies = RigidBodies(mass, box_inertia(mass, 2 * h), positions=[[0.0, 0.0, h[2]]])
    n = np.array([0.0, 0.0, 1.0])

    def detect(y):
        return _plane_corners(bodies, y, h, n, 0.0, margin)

    return ContactScene(bodies, detect, [RigidGravity((0.0, 0.0, -g))], {"total_force": mass * g}, h)


def box_stack(n: int = 10, mass_ratio: float = 100.0, pattern: str = "alternating", half_extents=(0.5, 0.5, 0.25),
              g: float = 9.81, margin: float = 1e-9) -> ContactScene:
    """n boxes stacked on the ground (ORACLES D5); interface k (below box k) carries the weight above.

    ``pattern``: "alternating" masses 1, r, 1, r, … (every interface has ratio 1:r), "heavy_top" (all 1,
    the top box r), "light_top" (all r, the top box 1). ``exact["weights_above"][k]`` = g Σ_{j≥k} m_j.

    >>> sc = box_stack(3, 100.0)
    >>> sc.system.mass.tolist(), sc.exact["weights_above"].round(6).tolist()
    ([1.0, 100.0, 1.0], [1000.62, 990.81, 9.81])
    """
    from ..rigid.bodies import RigidBodies
    from ..rigid.effects import RigidGravity
    from ..rigid.inertia import box_inertia

    n = check_count("n", n)
    mass_ratio = _check_mass("mass_ratio", mass_ratio)
    patterns = ("alternating", "heavy_top", "light_top")
    if pattern not in patterns:
        raise InvalidInput(f"pattern must be one of {patterns}, got {pattern!r}")
    k = np.arange(n)
    masses = {"alternating": np.where(k % 2 == 1, mass_ratio, 1.0),
              "heavy_top": np.where(k == n - 1, mass_ratio, 1.0),
              "light_top": np.where(k == n - 1, 1.0, mass_ratio)}[pattern]
    h = np.asarray(half_extents, dtype=float)
    pos = np.zeros((n, 3))
    pos[:, 2] = h[2] * (2 * k + 1)
    inertia = np.stack([box_inertia(mm, 2 * h) for mm in masses])
    bodies = RigidBodies(masses, inertia, positions=pos)
    up = np.array([0.0, 0.0, 1.0])
    bottom = _corners(h, True)

    def detect(y):
        # one pass (rotations once, one Contacts): the bottom corners of box 0 against the ground, then
        # the bottom corners of box k ≥ 1 against the top face of box k − 1
        x = bodies.unpack(y)[0]
        R = bodies.rotations(y)
        pts = x[:, None, :] + np.einsum("nij,kj->nki", R, bottom)                 # (n, 4, 3) bottom corners
        sep0 = pts[0] @ up                                                         # ground z = 0
        keep0 = sep0 <= margin
        nrm = R[:-1, :, 2]                                                         # top-face normals
        top = x[:-1] + h[2] * nrm
        sep = np.einsum("nkj,nj->nk", pts[1:] - top[:, None, :], nrm)
        keep = sep <= margin
        a = np.broadcast_to(k[1:, None], sep.shape)[keep]
        m0 = int(keep0.sum())
        normals = np.broadcast_to(nrm[:, None, :], sep.shape + (3,))[keep]
        return _box_contacts(np.concatenate([np.zeros(m0, int), a]), np.concatenate([-np.ones(m0, int), a - 1]),
                             np.vstack([pts[0][keep0], pts[1:][keep]]), np.vstack([np.tile(up, (m0, 1)), normals]),
                             -np.concatenate([sep0[keep0], sep[keep]]))

    weights = g * np.cumsum(masses[::-1])[::-1]
    return ContactScene(bodies, detect, [RigidGravity((0.0, 0.0, -g))],
                        {"weights_above": weights, "masses": masses, "top_height": pos[-1, 2]}, h)


def incline_expected(angle: float, friction: float, g: float = 9.81) -> dict:
    """ORACLES D6: static iff tan θ ≤ μ (friction m g sin θ per unit mass); else a = g (sin θ − μ cos θ).

    >>> incline_expected(np.arctan(0.5), 0.6)["static"], incline_expected(0.5, 0.1)["acceleration"] > 0
    (True, True)
    """
    static = np.tan(angle) <= friction
    acc = 0.0 if static else g * (np.sin(angle) - friction * np.cos(angle))
    return {"static": bool(static), "acceleration": float(acc), "friction_per_mass": float(g * np.sin(angle))
            if static else float(friction * g * np.cos(angle)), "normal_per_mass": float(g * np.cos(angle))}


def box_on_incline(angle: float, friction: float, mass: float = 1.0, half_extents=(0.25, 0.25, 0.125),
                   g: float = 9.81, margin: float = 1e-6, yaw: float = 0.0) -> ContactScene:
    """A box at rest on a plane tilted by ``angle`` about the y axis (downhill along +x′), ORACLES D6.

    ``yaw`` turns the box and the friction reference direction about the incline normal (a 4-facet
    pyramid is weaker by cos(π/4) along its diagonals). ``exact`` is :func:`incline_expected`;
    ``exact["downhill"]`` is the unit downhill direction.
    """
    from ..rigid.bodies import RigidBodies
    from ..rigid.effects import RigidGravity
    from ..rigid.inertia import box_inertia
    from ..rigid.quat import quat_from_axis_angle, quat_multiply

    mass = _check_mass("mass", mass)
    if not (0 <= angle < np.pi / 2):
        raise InvalidInput(f"angle must be in [0, π/2) rad, got {angle}")
    h = np.asarray(half_extents, dtype=float)
    s, c = np.sin(angle), np.cos(angle)
    normal = np.array([s, 0.0, c])          # plane through the origin, tilted about y: downhill is +x′
    downhill = np.array([c, 0.0, -s])
    q = quat_multiply(quat_from_axis_angle(normal, yaw),
                      quat_from_axis_angle([0.0, 1.0, 0.0], angle))
    bodies = RigidBodies(mass, box_inertia(mass, 2 * h), positions=[h[2] * normal], orientations=[q])

    def detect(y):
        return _plane_corners(bodies, y, h, normal, 0.0, margin, bottom_only=True)

    ex = incline_expected(angle, friction, g)
    ex["downhill"], ex["normal"], ex["friction"] = downhill, normal, float(friction)
    return ContactScene(bodies, detect, [RigidGravity((0.0, 0.0, -g))], ex, h)


def painleve_B(theta, friction):
    """B(θ) = 1 + 3 cos θ (cos θ − μ sin θ): the rod end's normal acceleration per unit N/m (ORACLES D7).

    min over θ is negative iff μ > 4/3 (the minimum of (tan²θ + 4)/(3 tan θ) is 4/3 at tan θ = 2).

    >>> round(float(painleve_B(np.arctan(2.0), 4.0 / 3.0)), 12)
    0.0
    """
    theta = np.asarray(theta, dtype=float)
    return 1.0 + 3.0 * np.cos(theta) * (np.cos(theta) - friction * np.sin(theta))


def painleve_rod(theta: float = np.arctan(2.0), friction: float = 2.0, mass: float = 1.0, half_length: float = 0.5,
                 slide_speed: float = 1.0, g: float = 9.81, margin: float = 1e-6) -> ContactScene:
    """A thin rod (half length l) leaning at θ on the ground, its lower end sliding at ``slide_speed`` in −x
    (away from under the rod), with no spin. At t = 0: d̈ = B(θ) N/m − g (+ l θ̇² sin θ = 0).

    ``exact``: B, the acceleration-level coefficient A = B/m, b = −g.
    """
    from ..rigid.bodies import RigidBodies
    from ..rigid.effects import RigidGravity
    from ..rigid.quat import quat_from_axis_angle

    mass = _check_mass("mass", mass)
    l = float(half_length)
    axis = np.array([np.cos(theta), 0.0, np.sin(theta)])
    I = mass * l * l / 3.0
    q = quat_from_axis_angle([0.0, 1.0, 0.0], -theta)      # body x → axis
    x0 = l * axis
    bodies = RigidBodies(mass, [I * 1e-3, I, I], positions=[x0], orientations=[q],
                         velocities=[[-slide_speed, 0.0, 0.0]])
    up = np.array([0.0, 0.0, 1.0])

    def detect(y):
        x = bodies.unpack(y)[0]
        R = bodies.rotations(y)
        ends = x[:, None, :] + np.einsum("nij,kj->nki", R, np.array([[-l, 0, 0], [l, 0, 0]]))
        sep = ends[0] @ up
        keep = sep <= margin
        m = int(keep.sum())
        return make_contacts(np.zeros(m, int), -np.ones(m, int), ends[0][keep], np.tile(up, (m, 1)), -sep[keep])

    B = float(painleve_B(theta, friction))
    return ContactScene(bodies, detect, [RigidGravity((0.0, 0.0, -g))],
                        {"B": B, "A": B / mass, "b": -g, "theta": theta, "friction": friction})


def sphere_pour(n: int = 100, radius: float = 0.05, box_half: float = 0.3, seed: int = 0, g: float = 9.81,
                margin: float | None = None) -> ContactScene:
    """n spheres (point masses of radius r) dropped on a jittered lattice into an open box |x|, |y| ≤ L, z ≥ 0.

    ``detect`` returns sphere–wall and sphere–sphere contacts with separation ≤ ``margin`` (default r/2);
    ``exact["radius"]`` for penetration checks.
    """
    from ..particles.system import Gravity, ParticleSystem

    n = check_count("n", n)
    r = check_number("radius", radius, low=0.0, low_open=True)
    box_half = check_number("box_half", box_half, low=r, low_open=True)
    margin = 0.5 * r if margin is None else check_number("margin", margin, low=0.0)
    rng = np.random.default_rng(seed)
    with np.errstate(over="ignore"):   # a lattice row longer than n is never needed (and may overflow)
        per = max(1, int(min(n, np.floor(2 * box_half / (2.2 * r)))))
    i = np.arange(n)
    pos = np.stack([-box_half + 1.1 * r + 2.2 * r * (i % per), -box_half + 1.1 * r + 2.2 * r * ((i // per) % per),
                    r + 0.05 + 2.4 * r * (i // (per * per))], axis=1)
    pos[:, :2] += rng.uniform(-0.05 * r, 0.05 * r, size=(n, 2))
    ps = ParticleSystem(pos, np.zeros_like(pos), masses=1.0)
    walls_n = np.array([[0, 0, 1.0], [1.0, 0, 0], [-1.0, 0, 0], [0, 1.0, 0], [0, -1.0, 0]])
    walls_d = np.array([0.0, -box_half, -box_half, -box_half, -box_half])
    iu, ju = np.triu_indices(n, 1)

    def detect(y):
        x = y[: 3 * n].reshape(n, 3)
        sep_w = x @ walls_n.T - walls_d - r                      # (n, 5)
        kw = sep_w <= margin
        bi, wi = np.nonzero(kw)
        d = x[iu] - x[ju]
        dist = np.linalg.norm(d, axis=1)
        sep_p = dist - 2 * r
        kp = sep_p <= margin
        nrm_p = d[kp] / dist[kp, None]
        a = np.concatenate([bi, iu[kp]])
        b = np.concatenate([-np.ones(bi.size, int), ju[kp]])
        pts = np.vstack([x[bi] - r * walls_n[wi], x[ju[kp]] + r * nrm_p])
        nrm = np.vstack([walls_n[wi], nrm_p])
        return make_contacts(a, b, pts, nrm, -np.concatenate([sep_w[kw], sep_p[kp]]))

    return ContactScene(ps, detect, [Gravity(np.array([0.0, 0.0, -g]))], {"radius": r, "box_half": box_half})
