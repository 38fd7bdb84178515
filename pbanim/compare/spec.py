"""What a scene is, once, for every engine: bodies, joints, world, step and duration (chapter 11).

The lecture ends with "how to start": write your own engine, or start from an existing one (Bullet,
ODE, PhysX, Havok …). To choose, run the same small scene in each and compare each answer with the exact
one. A scene here is plain data — every number an engine needs, in SI units and in one frame — and each
engine module (:mod:`.native`, :mod:`.bullet`, :mod:`.mujoco`) translates it to its own knobs. Every
engine hands back the same :class:`Trace` (the state of every body at every step), so the error against
the closed form is computed once per scene, never once per engine.

State of body i at time t (world frame, centre of mass):

    xᵢ(t), qᵢ(t) = (w, x, y, z),  vᵢ(t) = ẋᵢ,  ωᵢ(t),      Rᵢ = R(qᵢ)
    E = Σᵢ ½ mᵢ |vᵢ|² + ½ ωᵢ·(Rᵢ I_body,i Rᵢᵀ) ωᵢ − mᵢ g·xᵢ       (the mechanical energy)
    C_joint = (x_a + R_a r_a) − (x_b + R_b r_b)                    (an anchor pair; b = −1: the world)

========  =====================  ==========  ==============================================
symbol    code                   shape       meaning
========  =====================  ==========  ==============================================
h, T      ``Run.h, spec.duration``           step (s), simulated time (s)
g         ``spec.gravity``       (3,)        gravity (m/s²); the ground, when present, is z = 0
m, I      ``Body.mass, inertia`` (), (3,)    mass (kg), principal moments about the centre (kg m²)
ε, μ      ``restitution, friction``          coefficient of one body's material (see the engines
                                             for how two materials combine)
x, q      ``Trace.x, Trace.q``   (k, N, 3/4) positions and orientations at the k recorded steps
v, ω      ``Trace.v, Trace.w``   (k, N, 3)   linear and angular velocity (world)
========  =====================  ==========  ==============================================

Limiting cases: a trace of one sample is the initial state; a scene without ground and joints is
free flight, which every engine integrates with its own step map (PyBullet and MuJoCo: semi-implicit
Euler, so free fall is off by exactly g h t / 2).

References: A. Boeing, T. Bräunl, "Evaluation of real-time physics simulation systems", GRAPHITE 2007;
S. Giovanni, K. Yin, "LocoTest: deploying and evaluating physics-based locomotion on multiple simulation
platforms", Motion in Games 2011 (LNCS 7060); D. Baraff, "Rigid body simulation", SIGGRAPH 1997 notes.
"""

from __future__ import annotations

from dataclasses import dataclass, field
import numpy as np

from ..contracts import Array, Choice, Flag, Int, Obj, Opt, Real, Seq, Text, contract
from ..errors import InvalidInput, PbanimError, check_result
from ..rigid.quat import quat_to_matrix

__all__ = ["Body", "Joint", "SceneSpec", "Trace", "Unsupported", "energy", "energy_readable", "joint_drift"]

SHAPES = ("sphere", "box", "none")
JOINT_KINDS = ("hinge", "ball")


class Unsupported(PbanimError):
    """A scene asks for something an engine cannot express; the harness writes ``reason`` in the row."""

    def __init__(self, engine: str, reason: str) -> None:
        self.engine, self.reason = engine, reason
        super().__init__(f"{engine} cannot express this scene: {reason}")


def _vec(name: str, value, n: int) -> tuple:
    """``value`` as a tuple of n floats (the data stays hashable); the checks of the values are the
    contracts' (scenes built inside pbanim pass literal numbers)."""
    a = np.asarray(value, dtype=float).ravel()
    if a.shape != (n,) or not np.all(np.isfinite(a)):
        raise InvalidInput(f"{name} must be {n} finite numbers, got {value!r}")
    return tuple(float(x) for x in a)


_V3 = Array((3,))


@contract(name=Text(), shape=Choice(SHAPES), size=Array((None,), gt=0, scalar=True), mass=Real(gt=0),
          inertia=Array((3,), gt=0), x=_V3, quat=Array((4,)), v=_V3, w=_V3, restitution=Real(ge=0, le=1),
          friction=Real(ge=0))
@dataclass(frozen=True)
class Body:
    """One rigid body. ``size`` is the radius (sphere) or the half extents (box); ``shape="none"`` has no
    collision geometry (links of a chain, a top held at its tip). ``quat`` is (w, x, y, z); ``v`` and
    ``w`` are the world-frame velocity of the centre of mass and the angular velocity at t = 0."""

    name: str
    shape: str
    size: tuple
    mass: float
    inertia: tuple
    x: tuple
    quat: tuple = (1.0, 0.0, 0.0, 0.0)
    v: tuple = (0.0, 0.0, 0.0)
    w: tuple = (0.0, 0.0, 0.0)
    restitution: float = 0.0
    friction: float = 0.0

    def __post_init__(self) -> None:
        who = f"body {self.name!r}"
        if self.shape not in SHAPES:
            raise InvalidInput(f"{who}: shape must be one of {list(SHAPES)}, got {self.shape!r}")
        n = {"sphere": 1, "box": 3, "none": len(np.atleast_1d(self.size))}[self.shape]
        object.__setattr__(self, "size", _vec(f"{who}: size", self.size, n))     # one radius, three half extents
        for name, n in (("inertia", 3), ("x", 3), ("quat", 4), ("v", 3), ("w", 3)):
            object.__setattr__(self, name, _vec(f"{who}: {name}", getattr(self, name), n))
        q = np.asarray(self.quat)
        if abs(np.linalg.norm(q) - 1.0) > 1e-9:
            raise InvalidInput(f"{who}: quat must be a unit quaternion (w, x, y, z), got {self.quat} (norm "
                               f"{np.linalg.norm(q):.6g})")
        object.__setattr__(self, "mass", float(self.mass))


@contract(kind=Choice(JOINT_KINDS), a=Int(ge=-1), b=Int(ge=-1), anchor_a=_V3, anchor_b=_V3, axis=_V3)
@dataclass(frozen=True)
class Joint:
    """A joint between body ``a`` and body ``b`` (−1: the world): ``anchor_a`` / ``anchor_b`` in the bodies'
    frames (world for b = −1); a hinge turns about ``axis`` (frame of a)."""

    kind: str
    a: int
    b: int
    anchor_a: tuple
    anchor_b: tuple
    axis: tuple = (0.0, 0.0, 1.0)

    def __post_init__(self) -> None:
        if self.kind not in JOINT_KINDS:
            raise InvalidInput(f"joint kind must be one of {list(JOINT_KINDS)}, got {self.kind!r}")
        for name in ("anchor_a", "anchor_b", "axis"):
            object.__setattr__(self, name, _vec(f"joint {name}", getattr(self, name), 3))
        if self.a == self.b:
            raise InvalidInput(f"a joint joins two different bodies: a and b must differ, got a = b = {self.a}")
        if self.kind == "hinge" and not np.linalg.norm(self.axis) > 0:
            raise InvalidInput(f"a hinge's axis must be a non-zero vector, got {self.axis}")


_STEPS = Array((None,), gt=0)


@contract(name=Text(nonempty=True), title=Text(), bodies=Seq(Obj(Body), min_len=1), gravity=_V3,
          duration=Real(gt=0), steps=_STEPS, quick_steps=_STEPS, ground=Flag(), joints=Seq(Obj(Joint)),
          params=Obj(dict, what="a dict of the scene's own numbers"), quick_duration=Opt(Real(gt=0)), notes=Text())
@dataclass(frozen=True)
class SceneSpec:
    """A scene described once. ``params`` holds the scene's own numbers (h₀, θ, v₀, …) that its exact
    answer uses; ``steps`` / ``quick_steps`` are the step sweep; ``notes`` says what the exact answer is."""

    name: str
    title: str
    bodies: tuple
    gravity: tuple
    duration: float
    steps: tuple
    quick_steps: tuple
    ground: bool = False
    joints: tuple = ()
    params: dict = field(default_factory=dict)
    quick_duration: float | None = None
    notes: str = ""

    def __post_init__(self) -> None:
        if not self.bodies:
            raise InvalidInput(f"scene {self.name!r}: needs at least one body, got none")
        object.__setattr__(self, "bodies", tuple(self.bodies))
        object.__setattr__(self, "joints", tuple(self.joints))
        object.__setattr__(self, "gravity", _vec(f"scene {self.name!r}: gravity", self.gravity, 3))
        object.__setattr__(self, "duration", float(self.duration))
        for name in ("steps", "quick_steps"):
            hs = tuple(float(h) for h in getattr(self, name))
            if not hs or not all(np.isfinite(h) and 0 < h <= self.duration for h in hs):
                raise InvalidInput(f"scene {self.name!r}: {name} must be positive steps ≤ duration "
                                   f"{self.duration:g} s, got {getattr(self, name)!r}")
            object.__setattr__(self, name, hs)
        for j in self.joints:
            for end in (j.a, j.b):
                if not -1 <= end < len(self.bodies):
                    raise InvalidInput(f"scene {self.name!r}: joint body index {end} out of range "
                                       f"[-1, {len(self.bodies) - 1}]")

    @contract(quick=Flag())
    def time(self, quick: bool) -> float:
        return float(self.quick_duration if quick and self.quick_duration else self.duration)

    @property
    def masses(self) -> np.ndarray:
        return np.array([b.mass for b in self.bodies])

    @property
    def inertias(self) -> np.ndarray:
        return np.array([b.inertia for b in self.bodies])


@dataclass
class Trace:
    """What every engine returns: recorded times and body states, the wall time of the stepping alone,
    and engine-specific extras (``penetration`` per sample when the engine reports contact depths)."""

    t: np.ndarray
    x: np.ndarray
    q: np.ndarray
    v: np.ndarray
    w: np.ndarray
    wall: float
    steps: int
    extra: dict = field(default_factory=dict)
    settings: str = ""

    def __post_init__(self) -> None:
        self.t = np.asarray(self.t, float)
        k = self.t.size
        for name, d in (("x", 3), ("q", 4), ("v", 3), ("w", 3)):
            a = np.asarray(getattr(self, name), float)
            if a.ndim != 3 or a.shape[0] != k or a.shape[2] != d:
                raise InvalidInput(f"trace {name} must have shape ({k}, N, {d}), got {a.shape}")
            setattr(self, name, a)

    def first_nonfinite(self) -> float | None:
        """The first recorded time at which some state is NaN or infinite (None: all finite)."""
        bad = ~(np.isfinite(self.x).all(axis=(1, 2)) & np.isfinite(self.q).all(axis=(1, 2))
                & np.isfinite(self.v).all(axis=(1, 2)) & np.isfinite(self.w).all(axis=(1, 2)))
        return float(self.t[np.argmax(bad)]) if bad.any() else None


def _checked(spec: SceneSpec, tr: Trace, who: str) -> None:
    """A trace that fits the scene (one body per body) and is finite, with non-zero quaternions."""
    if tr.x.shape[1] != len(spec.bodies):
        raise InvalidInput(f"{who}: tr must hold the scene's {len(spec.bodies)} bodies, got {tr.x.shape[1]}")
    bad = tr.first_nonfinite()
    if bad is not None:
        raise InvalidInput(f"{who}: tr must be finite, got a non-finite state at t = {bad:.4g} s (a diverged run "
                           "has no energy)")
    if tr.q.size and not (np.linalg.norm(tr.q, axis=-1) > 0).all():
        raise InvalidInput(f"{who}: tr must hold non-zero quaternions, got a zero one")


_SPEC, _TRACE = Obj(SceneSpec), Obj(Trace)


@contract(spec=_SPEC, tr=_TRACE)
def energy(spec: SceneSpec, tr: Trace) -> np.ndarray:
    """E(t) of every sample (vectorized over samples and bodies), see the module docstring."""
    _checked(spec, tr, "energy")
    m, I = spec.masses, spec.inertias
    R = quat_to_matrix(tr.q / np.linalg.norm(tr.q, axis=-1, keepdims=True))   # (k, N, 3, 3)
    wb = np.einsum("knji,knj->kni", R, tr.w)                                     # ω in body axes
    with np.errstate(over="ignore", invalid="ignore"):
        kin = 0.5 * (m * (tr.v ** 2).sum(-1)).sum(-1) + 0.5 * (I * wb ** 2).sum(axis=(1, 2))
        E = kin - (m * (tr.x @ np.asarray(spec.gravity))).sum(-1)
    return check_result("energy E(t)", E)


@contract(spec=_SPEC, tr=_TRACE)
def energy_readable(spec: SceneSpec, tr: Trace) -> np.ndarray:
    """The same E(t), one sample and one body at a time (for reading; tested equal to :func:`energy`)."""
    _checked(spec, tr, "energy_readable")
    g = np.asarray(spec.gravity)
    out = np.zeros(tr.t.size)
    for k in range(tr.t.size):
        for i, body in enumerate(spec.bodies):
            R = quat_to_matrix(tr.q[k, i] / np.linalg.norm(tr.q[k, i]))
            I_world = R @ np.diag(body.inertia) @ R.T
            out[k] += 0.5 * body.mass * tr.v[k, i] @ tr.v[k, i] + 0.5 * tr.w[k, i] @ I_world @ tr.w[k, i]
            out[k] -= body.mass * g @ tr.x[k, i]
    return check_result("energy E(t)", out)


@contract(spec=_SPEC, tr=_TRACE)
def joint_drift(spec: SceneSpec, tr: Trace) -> np.ndarray:
    """max over the joints of |C_joint| at every sample (m); zeros when the scene has no joint."""
    _checked(spec, tr, "joint_drift")
    if not spec.joints:
        return np.zeros(tr.t.size)
    R = quat_to_matrix(tr.q / np.linalg.norm(tr.q, axis=-1, keepdims=True))

    def anchor(i: int, r) -> np.ndarray:
        return np.broadcast_to(np.asarray(r), (tr.t.size, 3)) if i < 0 else tr.x[:, i] + R[:, i] @ np.asarray(r)

    with np.errstate(over="ignore", invalid="ignore"):
        gaps = [np.linalg.norm(anchor(j.a, j.anchor_a) - anchor(j.b, j.anchor_b), axis=-1) for j in spec.joints]
    return check_result("joint drift |C|", np.max(gaps, axis=0))
