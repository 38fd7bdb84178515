"""Collisions in scenes: the post-step effect for particle and rigid scenes (chapter 06).

:class:`Collisions` is a post-step effect for particle scenes (``ParticleSystem``: point particles or
spheres of a given radius) and rigid scenes (``RigidBodies`` with one shape per body). After each step it
detects contacts (broad phase on bounding spheres, then the narrow phase), applies impulses
(:func:`pbanim.collision.impulse.resolve_collisions`) and projects the remaining penetration away (each
body moved along the normal of its deepest contact, shared by inverse mass). That is *fixed-step
detection*: the collision is noticed after the step, when the bodies already overlap, so the impact
happens up to h late; :func:`pbanim.collision.toi.simulate_collisions` locates it instead.

Limits: the projection moves each body by its deepest contact only, so long-lived resting stacks jiggle
(resting contact forces are chapter 07, :mod:`pbanim.contact`); capsule–capsule and capsule–box pairs
have no narrow-phase test (rejected when the effect is bound).

Restitution threshold (ORACLES D10): a contact approaching slower than ``rest_velocity`` gets ε = 0.
Gravity adds g·h of approach speed per step to a body lying on the ground, so a threshold below g·h
bounces a resting body every step (jitter); the default ``rest_velocity = 3·g·h`` (``gravity`` = 9.81
m/s² unless given) stops it: a resting body never rises.
"""

from __future__ import annotations

from typing import Any, Sequence

import numpy as np

from .broad import _grid_pairs_small, all_pairs, grid_pairs
from .lean_spheres import _Pending, lean_spheres, obstacles_apart, quick_obstacles
from .impulse import FRICTION_MODELS, MODES, ImpulseBodies, ImpulseResult, resolve_collisions
from .narrow import collide, sphere_plane, sphere_sphere
from .shapes import Box, Capsule, Contacts, Plane, Sphere
from .specs import Obstacle
from ..bodies import BodySystem, require_bodies
from ..contracts import Array, Choice, Either, Flag, Indices, Int, Obj, Opt, Real, Seq, contract
from ..scene import Effect
from ..errors import InvalidInput


class _StateSize:
    """The length of the bound system's flat state (``n_state`` where the system has it)."""

    def __call__(self, env) -> int:
        system = env.resolve("self.system")
        n = getattr(system, "n_state", None)
        return int(n) if n is not None else int(np.size(system.state()))

    def __repr__(self) -> str:
        return "len(system state)"


_STATE = Array((_StateSize(),))
_TIME = Real()
_STEP = Real(gt=0)
_MARGIN = Real(ge=0)
_SHAPES = Obj(Sphere, Box, Capsule)

__all__ = ["Collisions"]


class Collisions(Effect):
    """Post-step collision response (detection → impulses → projection) for particle and rigid scenes.

    Parameters
    ----------
    shapes : Shape or sequence of Shape, optional
        Rigid scenes: one ``Sphere``/``Box``/``Capsule`` per body (or one for all).
    obstacles : sequence
        Static world geometry: ``Plane`` objects, or ``(Sphere, centre)`` pairs.
    radius : float or (N,) array
        Particle scenes: particle radii (0 = points, which only meet obstacles).
    restitution, friction : float
        ε ∈ [0, 1] and μ ≥ 0.
    mode : {"sequential", "simultaneous"}
        See :mod:`pbanim.collision.impulse`.
    rest_velocity : float, optional
        Restitution threshold (m/s); default 3·gravity·h at each step.
    project : bool
        Remove the remaining penetration after the impulses (default True).
    friction_model : {"staggered", "lcp"}
        Friction in the simultaneous solve (see :mod:`pbanim.collision.impulse`).

    Examples
    --------
    >>> from pbanim.particles import ParticleSystem, Gravity
    >>> from pbanim.scene import Scene
    >>> ps = ParticleSystem([[0.0, 1.0]], [[0.0, 0.0]])
    >>> scene = Scene(ps, [Gravity(), Collisions(obstacles=[Plane([0, 1])], restitution=0.5)])
    >>> scene.pipeline
    ('gravity', 'integrate', 'collisions')
    >>> y = scene.simulate(1.5, 4e-3).y[:, -1]
    >>> bool(abs(y[1]) < 1e-12 and y[3] == 0.0)       # at rest on the ground
    True
    """

    name = "collisions"
    phase = "post_step"

    @contract(shapes=Opt(Either(_SHAPES, Seq(_SHAPES, min_len=1))), obstacles=Seq(Obstacle()),
              radius=Array(("N",), ge=0, scalar=True), restitution=Real(ge=0, le=1), friction=Real(ge=0),
              mode=Choice(MODES), rest_velocity=Opt(Real(ge=0)), gravity=Real(ge=0), project=Flag(),
              max_iter=Int(ge=1), friction_model=Choice(FRICTION_MODELS))
    def __init__(self, shapes=None, obstacles: Sequence = (), radius=0.0, restitution: float = 1.0,
                 friction: float = 0.0, mode: str = "sequential", rest_velocity: float | None = None,
                 gravity: float = 9.81, project: bool = True, max_iter: int = 1000,
                 friction_model: str = "staggered") -> None:
        self.restitution, self.friction = float(restitution), float(friction)
        self.mode, self.rest_velocity, self.gravity = mode, rest_velocity, float(gravity)
        self.friction_model = friction_model
        self.project, self.max_iter = bool(project), int(max_iter)
        self.planes, self.spheres = [], []
        for ob in obstacles:            # checked by the contract: a Plane, or (Sphere, 3-vector centre)
            if isinstance(ob, Plane):
                self.planes.append(ob)
            else:
                c = np.asarray(ob[1], float)
                self.spheres.append((ob[0], np.append(c, [0.0] * (3 - len(c)))))
        self.shapes_in, self.radius_in = shapes, radius
        self.log: list[dict] = []
        self.last: ImpulseResult | None = None
        self._bound = self._lean = None

    # -- binding ------------------------------------------------------------------------------------
    @contract(system=BodySystem())
    def bind(self, system) -> None:
        self.system = require_bodies(system, "Collisions")
        self.rigid = system.kind == "rigid"
        N = system.N
        if self.rigid:
            sh = self.shapes_in
            sh = [sh] * N if not isinstance(sh, (list, tuple)) else list(sh)
            if len(sh) != N or not all(isinstance(s, (Sphere, Box, Capsule)) for s in sh):
                raise InvalidInput(f"shapes must be one Sphere/Box/Capsule per body ({N} bodies), got {self.shapes_in!r}")
            self.shapes = sh
            kinds = sorted({type(x).__name__ for x in sh})
            ok = {("Box", "Box"), ("Box", "Sphere"), ("Sphere", "Sphere"), ("Capsule", "Sphere")}
            names = [type(x).__name__ for x in sh]
            bad = [(k1, k2) for i, k1 in enumerate(kinds) for k2 in kinds[i:]
                   if (k1, k2) not in ok and (k1 != k2 or names.count(k1) > 1)]
            if bad:
                raise InvalidInput(f"shapes: no narrow-phase test between bodies of kinds {bad}; supported body "
                                 f"pairs are {sorted(ok)} (every shape meets planes)")
            self.radius = np.array([s.radius if isinstance(s, (Sphere, Capsule)) else 0.0 for s in sh])
            self.is_sphere = np.array([isinstance(s, Sphere) for s in sh])
            self.inv_mass = system.inv_mass
        else:
            r = np.asarray(self.radius_in, float)      # each radius ≥ 0 by the contract; the count is known now
            if r.shape not in ((), (1,), (N,)):
                raise InvalidInput(f"Collisions: radius must be one number or one per particle ({N}), got shape "
                                   f"{r.shape}")
            r = np.broadcast_to(r, (N,)).copy()
            self.radius, self.is_sphere, self.dim = r, r > 0, system.dim
            if system.dim == 2:   # 2-D particles live in z = 0: a tilted plane or an off-plane sphere misses them
                for p in self.planes:
                    if abs(p.normal[2]) > 1e-12:
                        raise InvalidInput(f"obstacle {p!r} is a 3-D plane (normal has a z part) in a 2-D particle "
                                           "scene, whose particles stay in z = 0; give the plane a 2-D normal "
                                           "such as Plane([0, 1])")
                for s, c in self.spheres:
                    if c[2] != 0.0:
                        raise InvalidInput(f"obstacle sphere centre {c.tolist()} is off the plane z = 0 of a 2-D "
                                           "particle scene; give a 2-D centre")
            self.inv_mass = system.W
        self._quick = quick_obstacles(self, N)
        self._bound = None
        self._lean = lean_spheres(self, system)

    lean_path = True        # False: the readable response and broad phase (not pbanim.collision.lean_spheres' floats)

    @property
    def last(self) -> ImpulseResult | None:
        """The last response's :class:`~pbanim.collision.impulse.ImpulseResult` (None: no contact); a float
        response's record is built when first read."""
        got = self._last
        if isinstance(got, _Pending):
            got = self._last = got.result()
        return got

    @last.setter
    def last(self, value) -> None:
        self._last = value

    # -- state access ---------------------------------------------------------------------------
    def _poses(self, y):
        if self.rigid:
            x = self.system.unpack(y)[0]
            return x, self.system.rotations(y)
        x = self.system.unpack(y)[0]
        x3 = np.zeros((self.system.N, 3))
        x3[:, : self.dim] = x
        return x3, None

    @contract(y=_STATE)
    def bodies(self, y) -> ImpulseBodies:
        """The bodies' velocities and inverse masses at y, with the world row (for the impulse solver)."""
        x, _ = self._poses(y)
        if self.rigid:
            v, w = self.system.velocities(y)
            return ImpulseBodies.make(x, v, self.system.inv_mass, w, self.system.inv_inertia_world(y))
        v3 = np.zeros((self.system.N, 3))
        v3[:, : self.dim] = self.system.unpack(y)[1]
        return ImpulseBodies.make(x, v3, self.system.W)

    # -- detection ------------------------------------------------------------------------------
    @contract(y=_STATE, margin=_MARGIN)
    def contacts(self, y, margin: float = 0.0) -> Contacts:
        """All contacts at state y (bodies against obstacles and against each other)."""
        x, R = self._poses(y)
        N = len(x)
        parts = []
        sph = np.flatnonzero(self.is_sphere) if self.rigid else np.arange(N)
        for pl in self.planes:
            parts.append(sphere_plane(x[sph], self.radius[sph], pl, a=sph, margin=margin))
            if self.rigid:
                for i in np.flatnonzero(~self.is_sphere):
                    parts.append(collide(self.shapes[i], x[i], R[i], pl, None, None, i, -1, margin))
        for shape, centre in self.spheres:
            if not self.rigid:
                parts.append(sphere_sphere(x, self.radius, centre, shape.radius, np.arange(N), -1, margin))
                continue
            for i in range(N):
                parts.append(collide(self.shapes[i], x[i], R[i], shape, centre, np.eye(3), i, -1, margin))
        parts.append(self._pair_contacts(x, R, margin))
        return Contacts.concatenate(parts)

    def _bounds(self) -> np.ndarray:
        """The bounding-sphere radius of every body (read once, at the first broad phase)."""
        if self._bound is None:
            if self.rigid:
                self._bound = np.array([s.radius if isinstance(s, Sphere) else
                                        (s.radius + s.half_length if isinstance(s, Capsule) else
                                         np.linalg.norm(s.half_extents)) for s in self.shapes])
            else:
                self._bound = self.radius
        return self._bound

    def _pairs(self, x, margin):
        """Broad phase on bounding spheres: the grid's pairs (≤ SMALL_PAIRS bodies, lean: by one product, bit for bit)."""
        bound = self._bounds()
        if len(x) < 2 or not np.any(bound > 0):
            return np.zeros((0, 2), np.intp)
        small = len(x) <= self.SMALL_PAIRS and self.lean_path
        return _grid_pairs_small(x, bound, margin) if small else grid_pairs(x, bound, margin=margin).pairs

    def _candidates(self, x, margin):
        """The pairs the narrow phase tests: a few bodies (≤ SMALL_PAIRS) test every pair within a slightly
        wider margin (all_pairs: one product, several times cheaper than the grid there; the narrow phase
        keeps exactly the contacts the grid's pairs give, in the same sorted order), more take the grid."""
        bound = self._bounds()
        if len(x) > self.SMALL_PAIRS or len(x) < 2 or not np.any(bound > 0):
            return self._pairs(x, margin)
        slack = 1e-9 * (1.0 + float(bound.max()) + margin)
        return all_pairs(x, bound, margin=margin + slack).pairs

    SMALL_PAIRS = 64

    def _pair_contacts(self, x, R, margin) -> Contacts:
        pairs = self._candidates(x, margin)
        if not len(pairs):
            return Contacts.empty()
        i, j = pairs[:, 1], pairs[:, 0]
        if not self.rigid:
            keep = (self.radius[i] > 0) & (self.radius[j] > 0)
            return sphere_sphere(x[i[keep]], self.radius[i[keep]], x[j[keep]], self.radius[j[keep]], i[keep], j[keep], margin)
        both = self.is_sphere[i] & self.is_sphere[j]
        parts = [sphere_sphere(x[i[both]], self.radius[i[both]], x[j[both]], self.radius[j[both]], i[both], j[both], margin)]
        for a, b in zip(i[~both], j[~both]):
            if (self.inv_mass[a] == 0 and self.inv_mass[b] == 0):
                continue
            parts.append(collide(self.shapes[a], x[a], R[a], self.shapes[b], x[b], R[b], a, b, margin))
        return Contacts.concatenate(parts)

    @contract(y=_STATE, pairs=Opt(Indices("self.system.N", (None, 2), empty=True)))
    def gaps(self, y, pairs=None) -> np.ndarray:
        """Signed distances (> 0 apart) of every body–plane feature and of ``pairs`` of spheres."""
        x, R = self._poses(y)
        out = []
        for pl in self.planes:
            if self.rigid:
                for i, s in enumerate(self.shapes):
                    if isinstance(s, Box):
                        out.append(pl.distance(x[i] + (R[i] @ s.vertices().T).T))
                    elif isinstance(s, Capsule):
                        ends = x[i] + np.outer([-s.half_length, s.half_length], R[i][:, 2])
                        out.append(pl.distance(ends) - s.radius)
                    else:
                        out.append(pl.distance(x[i:i + 1]) - s.radius)
            else:
                out.append(pl.distance(x) - self.radius)
        for shape, centre in self.spheres:        # point particles, spheres (rigid: sphere bodies only)
            sel = self.is_sphere if self.rigid else np.ones(len(x), bool)
            out.append(np.linalg.norm(x[sel] - centre, axis=1) - self.radius[sel] - shape.radius)
        if pairs is not None and len(pairs):
            d = x[pairs[:, 0]] - x[pairs[:, 1]]
            out.append(np.linalg.norm(d, axis=1) - self.radius[pairs[:, 0]] - self.radius[pairs[:, 1]])
        return np.concatenate(out) if out else np.zeros(0)

    @contract(y=_STATE, margin=_MARGIN)
    def sphere_pairs(self, y, margin: float) -> np.ndarray:
        """Candidate sphere pairs (both spheres) within ``margin`` — the pairs whose gap is an event."""
        x, _ = self._poses(y)
        p = self._pairs(x, margin)
        if len(p):
            p = p[self.is_sphere[p[:, 0]] & self.is_sphere[p[:, 1]]]
        return p

    # -- response -------------------------------------------------------------------------------
    @contract(t=_TIME, y=_STATE, h=_STEP, margin=_MARGIN, plastic=Flag())
    def respond(self, t: float, y: np.ndarray, h: float, margin: float = 0.0, plastic: bool = False) -> np.ndarray:
        """Impulses for the contacts at y (and projection of the penetration); returns the new state.

        ``plastic=True`` uses ε = 0 for every contact (the resting contacts left after event location).
        A scene whose bodies cannot meet each other first tests its gaps to the obstacles (arrays bound
        once): nothing near, nothing built.
        """
        lean = self._lean
        if lean is not None and self.lean_path:
            out = lean.respond(t, y, h, margin, plastic)
            if out is not None:
                return out
        return self._readable(t, y, h, margin, plastic)

    def _readable(self, t: float, y: np.ndarray, h: float, margin: float, plastic: bool) -> np.ndarray:
        """:meth:`respond`'s readable response: detection, the impulse solver, the projection."""
        if self._quick is not None and obstacles_apart(self, y, margin):
            self.last = None
            return y
        c = self.contacts(y, margin)
        if c.m == 0:
            self.last = None
            return y
        bodies = self.bodies(y)
        rest = self.threshold(h)
        vn_before = np.einsum("ij,ij->i", bodies.v[c.a] - bodies.v[c.b], c.normal)
        eps = 0.0 if plastic else self.restitution
        res = resolve_collisions(bodies, c, eps, self.friction, self.mode, rest, self.max_iter,
                                 friction_model=self.friction_model, lean=self.lean_path)
        self.last = res
        if np.any(res.normal_impulse > 0):
            self.log.append({"t": t, "contacts": c.m, "impulse": float(res.normal_impulse.sum()),
                             "vn_min": float(vn_before.min()), "regime": res.regime.tolist()})
        y = self._apply(y, c, res.impulse)
        if self.project:
            y = self._project(y, c)
        return y

    def _apply(self, y, c: Contacts, J) -> np.ndarray:
        """Impulse J on body a and −J on body b at each contact point (the body protocol's apply_impulses)."""
        return self.system.apply_impulses(y, np.concatenate([c.a, c.b]), np.concatenate([c.point, c.point]),
                                          np.concatenate([J, -J]))

    def _project(self, y, c: Contacts) -> np.ndarray:
        """Move each body along the normal of its deepest contact by its inverse-mass share of the depth."""
        deep = c.depth > 0
        if not deep.any():
            return y
        c = c.select(deep)
        W = np.append(self.inv_mass, 0.0)
        wsum = W[c.a] + W[c.b]
        share = np.where(wsum > 0, c.depth / np.where(wsum > 0, wsum, 1.0), 0.0)
        N = len(self.inv_mass)
        best = np.zeros(N + 1)
        moves = [(c.a, share * W[c.a], 1.0), (c.b, share * W[c.b], -1.0)]
        for idx, move, _ in moves:
            np.maximum.at(best, idx, move)
        dx = np.zeros((N + 1, 3))
        for idx, move, sign in moves:      # the largest correction per body (ties: any of them)
            pick = (move > 0) & (move >= best[idx])
            dx[idx[pick]] = sign * move[pick, None] * c.normal[pick]
        y = np.array(y, dtype=float, copy=True)
        if self.rigid:
            self.system.unpack(y)[0][...] += dx[:N]
        else:
            self.system.unpack(y)[0][...] += dx[:N, : self.dim]
        return y

    @contract(h=_STEP)
    def threshold(self, h: float) -> float:
        """The restitution threshold (m/s) at step h: ``rest_velocity``, or 3·gravity·h by default."""
        return self.rest_velocity if self.rest_velocity is not None else 3.0 * self.gravity * h

    @contract(t=_TIME, y=_STATE, h=_STEP)
    def post_step(self, t: float, y: np.ndarray, h: float) -> np.ndarray:
        lean = self._lean
        if lean is not None and self.lean_path:
            out = lean.respond(t, y, h, 0.0, False)
            if out is not None:
                return out
        return self._readable(t, y, h, 0.0, False)

    history_diagnostics = True          # the last response: read at the recorded times of a run

    @contract(t=_TIME, y=_STATE)
    def diagnostics(self, t: float, y: np.ndarray) -> dict[str, Any]:
        """The last response: contacts, total normal impulse, and how many contacts were colliding (faster
        than the threshold), resting (slower: stopped with ε = 0) or touching (grazing, no impulse needed)."""
        res = self.last
        count = (lambda kind: 0 if res is None else int(np.count_nonzero(res.regime == kind)))  # noqa: E731
        return {"contacts": 0 if res is None else len(res.normal_impulse),
                "collision_impulse": 0.0 if res is None else float(res.normal_impulse.sum()),
                "colliding": count("colliding"), "resting": count("resting"), "touching": count("touching")}
