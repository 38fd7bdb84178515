"""The design scene and its parameter vector u (chapter 10, part of :mod:`pbanim.design`).

Popović's simulation function q(t) = S(t, u) maps a parameter vector u to the motion. Here u is a
*selection* of named blocks of the scene's nominal values, in the order the caller lists them:

==================  =====  ========================================================================
name                size   meaning
==================  =====  ========================================================================
``x{i}``            3      initial centre of mass of body i (world)
``theta{i}``        3      initial orientation as a world rotation vector: q₀ = exp(½θ) ⊗ q_ref
``v{i}``            3      initial linear velocity (P₀ = m v₀)
``omega{i}``        3      initial world angular velocity (L₀ = R₀ I R₀ᵀ ω₀)
``mass{i}``         1      mass m (W = 1/m); the inertia moments are separate parameters
``inertia{i}``      3      principal moments (I₁, I₂, I₃) in the body frame
``restitution``     1      ε, shared by every impact
``normal{j}``       3      normal of plane j (normalized inside: n = ν/|ν|), turning about its anchor
==================  =====  ========================================================================

The orientation is a tangent-space parameter, never the four quaternion components: a perturbation
δθ moves q₀ along the unit sphere, q₀ + δq₀ = exp(½ J_l(θ)δθ) ⊗ q₀ with the left Jacobian of SO(3)

    J_l(θ) = 𝟙 + (1 − cos a)/a² [θ]× + (a − sin a)/a³ [θ]×²,   a = |θ|      (J_l(0) = 𝟙),

so ∂q₀/∂θ = ½ Ξ(q₀) J_l(θ), with Ξ(q) the 4 × 3 matrix of (0, ω) ⊗ q = Ξ(q) ω (ORACLES H2).

Limiting cases: θ = 0 gives q₀ = q_ref; a sphere's orientation never changes its contacts, so its
``theta``/``omega`` columns of ∂x/∂u vanish (frictionless impacts exert no torque on a sphere).

References: J. Popović, S. M. Seitz, M. Erdmann, Z. Popović, A. Witkin, "Interactive manipulation of
rigid body simulations", SIGGRAPH 2000, §3 (the parameters u); J. Solà et al., "A micro Lie theory for
state estimation in robotics", 2018 (the left Jacobian J_l).
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field

import numpy as np

from ..collision import Box, Plane, Sphere, check_restitution
from ..contracts import Array, Flag, Int, Obj, Opt, Real, Seq, contract, finite_result
from ..errors import InvalidInput, PbanimError
from ..rigid import quat_exp, quat_multiply, quat_normalize, quat_to_matrix, skew
from .specs import ParameterNames, Quaternion, u_size

__all__ = ["DesignBody", "DesignScene", "UnknownParameter", "UncertifiedTrajectory", "TooManyImpacts",
           "RestingContactError", "PenetrationError", "GrazingImpactWarning", "left_jacobian", "xi"]


class UnknownParameter(InvalidInput, KeyError):
    """A parameter name that the scene does not have; the message lists the names it has."""

    def __str__(self) -> str:          # KeyError would quote the message
        return str(self.args[0])


class UncertifiedTrajectory(PbanimError, RuntimeError):
    """S(t, u) has no certified value here: the run cannot go on without a result that could be wrong (too
    many impacts, a resting contact the model does not have, a state inside an obstacle)."""


class TooManyImpacts(UncertifiedTrajectory):
    """More impacts than the cap (bounces that accumulate faster than ``rest_speed`` ends them: Zeno)."""

    def __init__(self, count: int, t: float) -> None:
        self.count, self.t = int(count), float(t)
        super().__init__(f"more than {count} impacts by t = {t:.6g}: the bounces accumulate (Zeno, ORACLES D1) "
                         "before the rebound speed falls below rest_speed; raise rest_speed or max_impacts, or "
                         "shorten t_end")


class RestingContactError(UncertifiedTrajectory):
    """A contact that would have to rest (touching, slower than ``rest_speed``, pressed in) where the design
    model has no resting contact: a box's vertex, two bodies, or a sphere on two planes at once."""


class PenetrationError(UncertifiedTrajectory):
    """The certificate of a trajectory failed: a recorded state lies inside a plane or another body by more
    than ``penetration_tol``."""


class GrazingImpactWarning(UserWarning):
    """An impact with (nearly) zero approach speed, or two contacts at once: S(t, u) is not differentiable."""


@contract(q=Array((4,), batch="first"))
def xi(q: np.ndarray) -> np.ndarray:
    """Ξ(q) (..., 4, 3) with (0, ω) ⊗ q = Ξ(q) ω; Ξᵀ Ξ = |q|² 𝟙 and δφ = 2 Ξ(q)ᵀ δq / |q|².

    >>> xi(np.array([1.0, 0, 0, 0]))[1:]
    array([[1., 0., 0.],
           [0., 1., 0.],
           [0., 0., 1.]])
    """
    q = np.asarray(q, dtype=float)
    X = np.empty(q.shape[:-1] + (4, 3))
    X[..., 0, :] = -q[..., 1:]
    X[..., 1:, :] = q[..., :1, None] * np.eye(3) - skew(q[..., 1:])
    return X


@contract(theta=Array((3,)), returns=finite_result)
def left_jacobian(theta) -> np.ndarray:
    """J_l(θ) of SO(3) (3, 3): exp(θ + δθ) = exp(J_l δθ) exp(θ) to first order (series near a = 0)."""
    th = np.asarray(theta, dtype=float)
    with np.errstate(all="ignore"):        # an overflow (|θ| ≈ 1e300) is named by the result's certificate
        a = float(np.linalg.norm(th))
        S = skew(th)
        if a < 1e-4:
            c1, c2 = 0.5 - a * a / 24.0, 1.0 / 6.0 - a * a / 120.0
        else:
            c1, c2 = (1.0 - np.cos(a)) / a ** 2, (a - np.sin(a)) / a ** 3
        return np.eye(3) + c1 * S + c2 * (S @ S)


_VEC3 = Array((3,))


@contract(shape=Obj(Sphere, Box, what="a pbanim.collision Sphere or Box"), mass=Real(gt=0), position=_VEC3,
          orientation=Quaternion(), velocity=_VEC3, angular_velocity=_VEC3, inertia=Opt(Array((3,), gt=0)))
@dataclass
class DesignBody:
    """One rigid body of a design scene: a :class:`~pbanim.collision.Sphere` or :class:`~pbanim.collision.Box`
    with its mass, principal moments (default: the shape's; I₁ + I₂ ≥ I₃ in any order) and initial state."""

    shape: object
    mass: float = 1.0
    position: np.ndarray = field(default_factory=lambda: np.zeros(3))
    orientation: np.ndarray = field(default_factory=lambda: np.array([1.0, 0, 0, 0]))
    velocity: np.ndarray = field(default_factory=lambda: np.zeros(3))
    angular_velocity: np.ndarray = field(default_factory=lambda: np.zeros(3))
    inertia: np.ndarray | None = None

    def __post_init__(self) -> None:     # the contract checked the arguments; here: conversions, I₁ + I₂ ≥ I₃
        self.mass = float(self.mass)
        for name in ("position", "velocity", "angular_velocity"):
            setattr(self, name, np.array(getattr(self, name), dtype=float).reshape(3))
        self.orientation = quat_normalize(np.array(self.orientation, dtype=float).reshape(4))
        mom = np.diag(self.shape.inertia(self.mass)) if self.inertia is None else self.inertia
        self.inertia = _moments("inertia", mom)


def _vec3(name: str, value) -> np.ndarray:
    a = np.array(value, dtype=float).reshape(-1)
    if a.shape != (3,) or not np.all(np.isfinite(a)):
        raise InvalidInput(f"{name} must be 3 finite numbers, got {value!r}")
    return a


def _moments(name: str, value) -> np.ndarray:
    """Principal moments: 3 positive finite numbers with I₁ + I₂ ≥ I₃ (values that come from inside: a
    shape's moments, a parameter vector u)."""
    a = np.array(value, dtype=float).reshape(-1)
    if a.shape != (3,) or not np.all(np.isfinite(a)) or np.any(a <= 0):
        raise InvalidInput(f"{name} must be 3 positive finite principal moments, got {value!r}")
    s = np.sort(a)
    if s[0] + s[1] < s[2] * (1 - 1e-12):
        raise InvalidInput(f"{name} violates the triangle inequality I1 + I2 >= I3: {a.tolist()}")
    return a


_NAME = re.compile(r"^(x|theta|v|omega|mass|inertia|normal)(\d+)$|^restitution$")


def _parameter_slices(scene, names) -> dict:
    """{name: slice of u} for the parameter blocks ``names`` of a design scene (``scene.check_names``, ``scene.size``),
    laid end to end in the order given: what :meth:`DesignScene.slices` and the stepped scene's answer."""
    out, k0 = {}, 0
    for k in scene.check_names(names):
        out[k] = slice(k0, k0 + scene.size(k))
        k0 += scene.size(k)
    return out


class DesignScene:
    """Bodies, static planes, gravity and one restitution ε: the model behind S(t, u).

    Parameters
    ----------
    bodies : list of DesignBody
    planes : list of pbanim.collision.Plane
        Static half-spaces {p : n·(p − o) ≥ 0}, o = offset·n the anchor about which a normal turns.
    gravity : 3 numbers
    restitution : float in [0, 1]
    body_collisions : bool
        Sphere–sphere impacts between bodies (boxes collide with the planes only).

    >>> s = DesignScene([DesignBody(Sphere(0.1), position=[0, 0, 1.0])], [Plane([0, 0, 1])])
    >>> s.size("x0"), s.size("restitution"), s.names()[:4]
    (3, 1, ['x0', 'theta0', 'v0', 'omega0'])
    """

    @contract(bodies=Seq(Obj(DesignBody), min_len=1), planes=Seq(Obj(Plane)), gravity=_VEC3,
              restitution=Real(ge=0, le=1), body_collisions=Flag())
    def __init__(self, bodies, planes=(), gravity=(0.0, 0.0, -9.81), restitution: float = 0.8,
                 body_collisions: bool = True) -> None:
        self.bodies, self.planes = list(bodies), list(planes)
        self.N = len(self.bodies)
        self.gravity = _vec3("gravity", gravity)
        self.restitution = check_restitution(restitution)
        self.body_collisions = bool(body_collisions)
        self.anchors = np.array([p.offset * p.normal for p in self.planes]).reshape(-1, 3)
        self.radius = np.array([b.shape.radius if isinstance(b.shape, Sphere) else 0.0 for b in self.bodies])
        self.nominal = self._nominal()

    # ----------------------------------------------------------------- names and nominal values
    def names(self) -> list[str]:
        """Every parameter name of the scene, in a fixed order."""
        out = [f"{k}{i}" for i in range(self.N) for k in ("x", "theta", "v", "omega", "mass", "inertia")]
        return out + ["restitution"] + [f"normal{j}" for j in range(len(self.planes))]

    def _nominal(self) -> dict:
        d = {}
        for i, b in enumerate(self.bodies):
            d.update({f"x{i}": b.position.copy(), f"theta{i}": np.zeros(3), f"v{i}": b.velocity.copy(),
                      f"omega{i}": b.angular_velocity.copy(), f"mass{i}": np.array([b.mass]),
                      f"inertia{i}": b.inertia.copy()})
        d["restitution"] = np.array([self.restitution])
        for j, p in enumerate(self.planes):
            d[f"normal{j}"] = p.normal.copy()
        return d

    @contract(names=ParameterNames())
    def check_names(self, names) -> list[str]:
        """``names`` as a list of known, distinct parameter names, or :class:`UnknownParameter` (the contract
        checks a call from outside; this body checks names that come from inside: a shooting's choice)."""
        names = [names] if isinstance(names, str) else list(names)
        known = set(self.names())
        for n in names:
            if not isinstance(n, str) or n not in known:
                raise UnknownParameter(f"parameter {n!r} does not exist; the scene has {self.names()}")
        if len(set(names)) != len(names) or not names:
            raise InvalidInput(f"parameter names must be distinct and at least one, got {names}")
        return names

    @contract(name=ParameterNames(one=True))
    def size(self, name: str) -> int:
        """The length of the block ``name`` of u (1 for ``mass{i}`` and ``restitution``, else 3)."""
        return 1 if name == "restitution" or name.startswith("mass") else 3

    @contract(names=ParameterNames())
    def vector(self, names) -> np.ndarray:
        """u: the nominal values of ``names`` concatenated."""
        return np.concatenate([self.nominal[n] for n in self.check_names(names)])

    @contract(names=ParameterNames(), u=Array((u_size("self"),)))
    def values(self, names, u) -> dict:
        """The full parameter dict with the blocks ``names`` taken from the vector ``u`` (checked: masses
        and moments positive, I₁ + I₂ ≥ I₃, ε in [0, 1], normals non-zero)."""
        names = self.check_names(names)
        u = np.asarray(u, dtype=float).reshape(-1)
        n = sum(self.size(k) for k in names)
        if u.size != n or not np.all(np.isfinite(u)):        # u from inside: a shooting's iterate
            raise InvalidInput(f"u must hold {n} finite numbers for {names}, got shape {u.shape}"
                               f"{'' if np.all(np.isfinite(u)) else ' with NaN/inf'}")
        d = {k: v.copy() for k, v in self.nominal.items()}
        k0 = 0
        for k in names:
            s = self.size(k)
            d[k] = u[k0:k0 + s].copy()
            k0 += s
        _check_values(d, self.N, len(self.planes))
        return d

    @contract(names=ParameterNames())
    def slices(self, names) -> dict:
        """{name: slice of u}."""
        return _parameter_slices(self, names)

    @contract(names=ParameterNames(), u=Array((u_size("self"),)))
    def with_values(self, names, u) -> "DesignScene":
        """A copy of the scene whose nominal values are those of ``u`` (an edit made permanent)."""
        d = self.values(names, u)
        new = object.__new__(DesignScene)
        new.__dict__.update(self.__dict__)
        new.nominal = d
        return new

    # ----------------------------------------------------------------- u → y₀ and ∂y₀/∂u
    def _initial_state(self, d: dict, slices: dict, p: int):
        """(y₀ (13N,), Φ₀ = ∂y₀/∂u (13N, p), model tangents) in Baraff's layout [x, q, P, L] (ORACLES H2)."""
        N = self.N
        y = np.zeros(13 * N)
        Phi = np.zeros((13 * N, p))
        x, q, P, L = (y[:3 * N].reshape(N, 3), y[3 * N:7 * N].reshape(N, 4), y[7 * N:10 * N].reshape(N, 3),
                      y[10 * N:].reshape(N, 3))
        Fx, Fq = Phi[:3 * N].reshape(N, 3, p), Phi[3 * N:7 * N].reshape(N, 4, p)
        FP, FL = Phi[7 * N:10 * N].reshape(N, 3, p), Phi[10 * N:].reshape(N, 3, p)
        dm, dIinv = np.zeros((N, p)), np.zeros((N, 3, p))
        for i, b in enumerate(self.bodies):
            th = d[f"theta{i}"]
            q[i] = quat_multiply(quat_exp(th), b.orientation)
            R = quat_to_matrix(q[i])
            m, I, v0, w0 = d[f"mass{i}"][0], d[f"inertia{i}"], d[f"v{i}"], d[f"omega{i}"]
            x[i], P[i] = d[f"x{i}"], m * v0
            Iw = R @ (I[:, None] * R.T)
            L[i] = Iw @ w0
            if f"x{i}" in slices:
                Fx[i][:, slices[f"x{i}"]] = np.eye(3)
            if f"theta{i}" in slices:
                Jl = left_jacobian(th)
                Fq[i][:, slices[f"theta{i}"]] = 0.5 * xi(q[i]) @ Jl
                FL[i][:, slices[f"theta{i}"]] = skew(L[i]) @ Jl * -1.0 + Iw @ skew(w0) @ Jl   # δφ×L − Iw(δφ×ω)
            if f"v{i}" in slices:
                FP[i][:, slices[f"v{i}"]] = m * np.eye(3)
            if f"omega{i}" in slices:
                FL[i][:, slices[f"omega{i}"]] = Iw
            if f"mass{i}" in slices:
                FP[i][:, slices[f"mass{i}"]] = v0[:, None]
                dm[i, slices[f"mass{i}"]] = 1.0
            if f"inertia{i}" in slices:
                FL[i][:, slices[f"inertia{i}"]] = R * (R.T @ w0)[None, :]          # R diag(Rᵀω₀)
                dIinv[i][:, slices[f"inertia{i}"]] = -np.diag(1.0 / I ** 2)
        return y, Phi, dm, dIinv


def _check_values(d: dict, N: int, n_planes: int) -> None:
    for i in range(N):
        if not d[f"mass{i}"][0] > 0:
            raise InvalidInput(f"mass{i} must be positive, got {d[f'mass{i}'][0]}")
        _moments(f"inertia{i}", d[f"inertia{i}"])
    check_restitution(d["restitution"][0])
    for j in range(n_planes):
        if not np.linalg.norm(d[f"normal{j}"]) > 0:
            raise InvalidInput(f"normal{j} must be a non-zero vector, got {d[f'normal{j}']}")
