"""Forces, torques and the quaternion post-step for rigid bodies (chapter 05, part of :mod:`pbanim.rigid`).

Every force effect adds rows [F, τ] into Q (N, 6). A force f applied at the world point p of body i adds
F_i += f and τ_i += (p − x_i) × f. Endpoints on body −1 (the static world) land in a padding row that is
dropped, so springs to the world need no special case.

==========================  ===============================================================  ===========
effect                      force / torque                                                   potential V
==========================  ===============================================================  ===========
RigidGravity(g)             F = m g                                                          −Σ m g·x
PointForce(body, r, f)      f at the body point p = x + R r                                  —
RigidSprings(...)           f_a = −[k_s(ℓ − ℓ₀) + k_d ℓ̇] u,  f_b = −f_a,  u = (p_a − p_b)/ℓ    ½ k_s (ℓ − ℓ₀)²
LinearDrag(c)               F = −c v                                                         —
AngularDrag(c)              τ = −c ω                                                         —
QuaternionRenormalize       post-step q ← q/|q|                                              —
==========================  ===============================================================  ===========

Particles join a rigid scene as point bodies (:meth:`pbanim.rigid.RigidBodies` with any inertia and
forces applied at r = 0): a force through the centre of mass exerts no torque, so their rotation is inert
and their translation is exactly a particle's.
"""

from __future__ import annotations

from typing import Callable

import numpy as np

from .bodies import RigidBodies, _matvec
from ..contracts import Array, Either, Func, Obj, Opt, Real, contract, package_code_cached
from .derivative_float import FLOAT_MAX_BODIES, renormalize_floats
from .domain import BodyIndices, RigidState, certifier, certify, row_norms, tame
from ..geometry import cross as _cross
from ..scene import Effect
from ..errors import InvalidInput

__all__ = ["RigidGravity", "PointForce", "RigidSprings", "LinearDrag", "AngularDrag", "QuaternionRenormalize"]


_SYSTEM = Obj(RigidBodies)
_T = Real()
_Y = RigidState("self.system")
_Q = Array(("self.system.N", 6))
_K_ROWS = Array(("k", 3))
_K_GAIN = Array(("k",), ge=0, scalar=True)


def _per_item(value, k: int) -> np.ndarray:
    """A scalar or (k,) parameter (checked by the contract) as (k,)."""
    return np.broadcast_to(np.asarray(value, dtype=float), (k,)).copy()


def _in_range(who: str, name: str, idx: np.ndarray, system: RigidBodies, world: bool) -> None:
    """Indices given before the system was known, checked when the effect is bound to it."""
    lo = -1 if world else 0
    if idx.size and (idx.min() < lo or idx.max() >= system.N):
        raise InvalidInput(f"{who}: {name} must lie in [{lo}, {system.N - 1}]"
                           f"{' (-1: the static world)' if world else ' (forces on the world do nothing)'}, got {idx}")


def _require_rigid(effect: Effect, system) -> RigidBodies:
    if not isinstance(system, RigidBodies):
        raise InvalidInput(f"{type(effect).__name__} acts on RigidBodies, got {type(system).__name__}")
    return system


def _accumulate(Q: np.ndarray, N: int, idx: np.ndarray, F: np.ndarray, tau: np.ndarray, what: str, y) -> None:
    """Q[idx] += [F, τ] with repeated indices summed; index N (the world) is dropped. (An overflow from a
    finite state is named by the effect's certificate on outside calls, by the stepping loop inside.)"""
    buf = np.zeros((N + 1, 6))
    np.add.at(buf, idx, np.concatenate([F, tau], axis=1))
    Q += buf[:-1]


class RigidGravity(Effect):
    """Uniform gravity F = m g on every dynamic body (default g = (0, 0, −9.81) m/s²).

    >>> from pbanim.rigid import RigidBodies
    >>> rb = RigidBodies(2.0, [1.0, 1.0, 1.0]); g = RigidGravity(); g.bind(rb)
    >>> Q = rb.zero_forces(); g.apply(0.0, rb.state(), Q); Q
    array([[  0.  ,   0.  , -19.62,   0.  ,   0.  ,   0.  ]])
    """

    name = "gravity"
    phase = "force"

    @contract(g=Array((3,)))
    def __init__(self, g=(0.0, 0.0, -9.81)) -> None:
        self.g = np.asarray(g, dtype=float)

    @contract(system=_SYSTEM)
    def bind(self, system: RigidBodies) -> None:
        self.system = _require_rigid(self, system)
        with np.errstate(over="ignore", invalid="ignore"):
            mg = system._mass_finite[:, None] * self.g
        self._mg = np.concatenate([certify("RigidGravity: m g", mg, system._mass_finite, self.g),
                                   np.zeros((system.N, 3))], axis=1)

    @contract(t=_T, y=_Y, Q=_Q, returns=certifier("the forces Q", "Q"))
    def apply(self, t: float, y: np.ndarray, Q: np.ndarray) -> None:
        Q += self._mg

    @contract(y=_Y)
    def potential_energy(self, y: np.ndarray) -> float:
        with np.errstate(over="ignore", invalid="ignore"):
            V = -np.sum(self._mg[:, :3] * self.system.unpack(y)[0])
        return float(certify("RigidGravity.potential_energy: −Σ m g·x", V, y))


class PointForce(Effect):
    """Forces f (k, 3) (world frame; constant, or ``force(t, y) -> (k, 3)``, or one (3,) for every point) at
    body-frame points r (k, 3) of bodies ``bodies`` (k,).

    >>> from pbanim.rigid import RigidBodies
    >>> rb = RigidBodies(1.0, [1.0, 1.0, 1.0]); pf = PointForce([0], [[1.0, 0, 0]], [[0, 2.0, 0]])
    >>> pf.bind(rb); Q = rb.zero_forces(); pf.apply(0.0, rb.state(), Q); Q   # τ = r × f = (0, 0, 2)
    array([[0., 2., 0., 0., 0., 2.]])
    """

    name = "point_force"
    phase = "force"

    @contract(bodies=BodyIndices(symbol="k"), points_body=_K_ROWS, force=Either(Func(), _K_ROWS, Array((3,))))
    def __init__(self, bodies, points_body, force: np.ndarray | Callable) -> None:
        self.bodies = np.asarray(bodies, dtype=np.intp).reshape(-1)
        self.points = np.asarray(points_body, dtype=float).reshape(-1, 3)
        if len(self.points) != len(self.bodies):      # calls from inside pbanim skip the contract
            raise InvalidInput(f"PointForce: points_body must have one row per body index ({len(self.bodies)}), "
                               f"got {len(self.points)}")
        self.force = force if callable(force) else np.broadcast_to(np.asarray(force, float), self.points.shape)

    @contract(system=_SYSTEM)
    def bind(self, system: RigidBodies) -> None:
        self.system = _require_rigid(self, system)
        _in_range("PointForce", "bodies", self.bodies, system, world=False)
        self._idx = self.bodies

    def _forces(self, t, y) -> np.ndarray:
        """f at (t, y); a callable's answer is checked (it arrives from the user, inside a step)."""
        if not callable(self.force):
            return self.force
        f = np.asarray(self.force(t, y), dtype=float)
        try:
            f = np.broadcast_to(f, self.points.shape)
        except ValueError:
            raise InvalidInput(f"PointForce: force(t, y) must return an array of shape {self.points.shape} or (3,), "
                               f"got shape {f.shape}") from None
        if not np.isfinite(f).all() and np.isfinite(y).all():
            raise InvalidInput(f"PointForce: force(t, y) must return finite forces, got {f.tolist()} at t = {t}")
        return f

    @contract(t=_T, y=_Y, Q=_Q, returns=certifier("the forces Q", "Q"))
    def apply(self, t: float, y: np.ndarray, Q: np.ndarray) -> None:
        # BEGIN SOLUTION PointForce.apply
        rb = self.system
        f = self._forces(t, y)
        x, q, _, _ = rb.unpack(y)
        r = _matvec(rb.quat_to_matrix(q)[self.bodies], self.points)  # p − x in world axes
        with np.errstate(over="ignore", invalid="ignore"):          # an overflow is named in _accumulate
            tau = _cross(r, f)
        _accumulate(Q, rb.N, self._idx, f, tau, "PointForce: F and τ = r × f", y)
        # END SOLUTION


class RigidSprings(Effect):
    """Damped springs between body points (body index −1: a fixed world point).

    Parameters
    ----------
    body_a, body_b : int array (k,)
    point_a, point_b : array (k, 3)
        Body-frame attachment points (world coordinates for body −1).
    stiffness, damping : float or (k,)
        k_s ≥ 0, k_d ≥ 0.
    rest_length : float or (k,), optional
        Default: the initial distance.
    """

    name = "springs"
    phase = "force"

    @contract(body_a=BodyIndices(world=True, symbol="k"), point_a=_K_ROWS, body_b=BodyIndices(world=True, symbol="k"),
              point_b=_K_ROWS, stiffness=_K_GAIN, damping=_K_GAIN, rest_length=Opt(_K_GAIN))
    def __init__(self, body_a, point_a, body_b, point_b, stiffness, damping=0.0, rest_length=None) -> None:
        self.a = np.asarray(body_a, dtype=np.intp).reshape(-1)
        self.b = np.asarray(body_b, dtype=np.intp).reshape(-1)
        k = len(self.a)
        self.ra = np.asarray(point_a, dtype=float).reshape(-1, 3)
        self.rb = np.asarray(point_b, dtype=float).reshape(-1, 3)
        if not (len(self.b) == len(self.ra) == len(self.rb) == k):    # calls from inside pbanim skip the contract
            raise InvalidInput(f"RigidSprings: body_a, point_a, body_b, point_b must all have {k} rows, got "
                               f"{len(self.b)}, {len(self.ra)}, {len(self.rb)}")
        self.ks = _per_item(stiffness, k)
        self.kd = _per_item(damping, k)
        self.rest_in = rest_length

    @contract(system=_SYSTEM)
    def bind(self, system: RigidBodies) -> None:
        self.system = rb = _require_rigid(self, system)
        _in_range("RigidSprings", "body_a", self.a, rb, world=True)
        _in_range("RigidSprings", "body_b", self.b, rb, world=True)
        self._ia, self._ib = rb._index(self.a), rb._index(self.b)
        if self.rest_in is None:
            pa, pb = self._points(rb.state())
            self.rest = certify("RigidSprings: the initial lengths", row_norms(pa - pb), pa, pb)
        else:
            self.rest = _per_item(self.rest_in, len(self.a))

    def _points(self, y):
        rb = self.system
        x, q, _, _ = rb.unpack(y)
        xp = np.concatenate([x, np.zeros((1, 3))])
        Rp = np.concatenate([rb.quat_to_matrix(q), np.eye(3)[None]])
        return xp[self._ia] + _matvec(Rp[self._ia], self.ra), xp[self._ib] + _matvec(Rp[self._ib], self.rb)

    @contract(t=_T, y=_Y, Q=_Q, returns=certifier("the forces Q", "Q"))
    def apply(self, t: float, y: np.ndarray, Q: np.ndarray) -> None:
        rb = self.system
        with np.errstate(over="ignore", invalid="ignore"):
            pa, pb = self._points(y)
            d = pa - pb
            ell = row_norms(d)
            u = d / np.where(ell > 0, ell, 1.0)[:, None]
            ddot = rb.point_velocity(y, self.a, pa) - rb.point_velocity(y, self.b, pb)
            mag = self.ks * (ell - self.rest) + self.kd * np.sum(ddot * u, axis=1)
            fa = -mag[:, None] * u
            x = np.concatenate([rb.unpack(y)[0], np.zeros((1, 3))])
            idx = np.concatenate([self._ia, self._ib])
            F = np.concatenate([fa, -fa])
            r = np.concatenate([pa - x[self._ia], pb - x[self._ib]])
            tau = _cross(r, F)
        _accumulate(Q, rb.N, idx, F, tau, "RigidSprings: the spring forces", y)

    @contract(y=_Y)
    def potential_energy(self, y: np.ndarray) -> float:
        pa, pb = self._points(y)
        with np.errstate(over="ignore", invalid="ignore"):
            V = 0.5 * np.sum(self.ks * (row_norms(pa - pb) - self.rest) ** 2)
        return float(certify("RigidSprings.potential_energy: ½ k_s (ℓ − ℓ₀)²", V, y))

    @contract(t=_T, y=_Y)
    def diagnostics(self, t: float, y: np.ndarray) -> dict:
        pa, pb = self._points(y)
        return {"spring_length": certify("RigidSprings: the spring lengths", row_norms(pa - pb), y)}


class _Drag(Effect):
    phase = "force"

    @contract(system=_SYSTEM)
    def bind(self, system: RigidBodies) -> None:
        self.system = _require_rigid(self, system)
        c = np.asarray(self.c_in, dtype=float)
        try:
            self.c = np.broadcast_to(c, (system.N,)).copy()
        except ValueError:
            raise InvalidInput(f"{type(self).__name__}: coefficient must be a number or have shape ({system.N},) "
                               f"(one per body), got shape {c.shape}") from None

    def _drag(self, rows: slice, rate: np.ndarray, y, Q) -> None:
        Q[:, rows] -= self.c[:, None] * rate


_COEFFICIENT = Array((None,), ge=0, scalar=True)


class LinearDrag(_Drag):
    """Linear drag F = −c v (c in kg/s; one number, or one per body)."""

    name = "linear_drag"

    @contract(coefficient=_COEFFICIENT)
    def __init__(self, coefficient) -> None:
        self.c_in = coefficient

    @contract(t=_T, y=_Y, Q=_Q, returns=certifier("the forces Q", "Q"))
    def apply(self, t: float, y: np.ndarray, Q: np.ndarray) -> None:
        v, _ = self.system.velocities(y)
        self._drag(slice(0, 3), v, y, Q)


class AngularDrag(_Drag):
    """Angular drag τ = −c ω (c in kg·m²/s; one number, or one per body)."""

    name = "angular_drag"

    @contract(coefficient=_COEFFICIENT)
    def __init__(self, coefficient) -> None:
        self.c_in = coefficient

    @contract(t=_T, y=_Y, Q=_Q, returns=certifier("the forces Q", "Q"))
    def apply(self, t: float, y: np.ndarray, Q: np.ndarray) -> None:
        _, w = self.system.velocities(y)
        self._drag(slice(3, 6), w, y, Q)


class QuaternionRenormalize(Effect):
    """Post-step stage q ← q/|q| (||q| − 1| stays within a few ε; a q near 10³⁰⁰ or 10⁻³⁰⁰ is scaled to
    max |qᵢ| = 1 first, so |q|² neither overflows nor underflows)."""

    name = "renormalize"
    phase = "post_step"

    @contract(system=_SYSTEM)
    def bind(self, system: RigidBodies) -> None:
        self.system = _require_rigid(self, system)

    @contract(t=_T, y=_Y, h=Real(gt=0))
    def post_step(self, t: float, y: np.ndarray, h: float) -> np.ndarray:
        rb = self.system
        if (rb.N <= FLOAT_MAX_BODIES and rb.lean_path and package_code_cached(self, "post_step")
                and renormalize_floats(y, rb.N)):      # a few bodies on floats, the same bits
            return y
        tame(self.system.unpack(y)[1])
        # BEGIN SOLUTION QuaternionRenormalize.post_step
        q = self.system.unpack(y)[1]
        q /= np.sqrt(np.sum(q * q, axis=1, keepdims=True))
        return y
        # END SOLUTION
