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
from ..geometry import cross as _cross
from ..scene import Effect
from ..errors import InvalidInput

__all__ = ["RigidGravity", "PointForce", "RigidSprings", "LinearDrag", "AngularDrag", "QuaternionRenormalize"]


def _rows3(value, name: str) -> np.ndarray:
    """Points or vectors as a finite (k, 3) array (a flat array of 3k numbers is read row by row)."""
    a = np.asarray(value, dtype=float)
    if a.size % 3 or (a.ndim >= 1 and a.shape[-1] != 3 and a.size):
        raise InvalidInput(f"{name} must have shape (k, 3), got shape {a.shape}")
    a = a.reshape(-1, 3)
    if not np.all(np.isfinite(a)):
        raise InvalidInput(f"{name} must be finite, got {a[~np.isfinite(a)][0]}")
    return a


def _per_item(value, k: int, name: str) -> np.ndarray:
    """A scalar or (k,) parameter broadcast to (k,), checked finite and >= 0."""
    a = np.asarray(value, dtype=float)
    try:
        out = np.broadcast_to(a, (k,)).copy()
    except ValueError:
        raise InvalidInput(f"{name} must be a scalar or have shape ({k},), got shape {a.shape}") from None
    if np.any(~np.isfinite(out)) or np.any(out < 0):
        raise InvalidInput(f"{name} must be finite and >= 0, got {out[~np.isfinite(out) | (out < 0)][0]}")
    return out


def _indices(value, name: str) -> np.ndarray:
    a = np.atleast_1d(np.asarray(value))
    if a.size and (a.dtype.kind not in "iu" and not (a.dtype.kind == "f" and np.all(np.isfinite(a))
                                                      and np.all(a == np.round(a)))):
        raise InvalidInput(f"{name} must be integer body indices, got {a.ravel()[:5].tolist()}")
    if a.ndim != 1:
        raise InvalidInput(f"{name} must be a 1-D array of body indices, got shape {a.shape}")
    return a.astype(np.intp)


def _require_rigid(effect: Effect, system) -> RigidBodies:
    if not isinstance(system, RigidBodies):
        raise InvalidInput(f"{type(effect).__name__} acts on RigidBodies, got {type(system).__name__}")
    return system


def _accumulate(Q: np.ndarray, N: int, idx: np.ndarray, F: np.ndarray, tau: np.ndarray) -> None:
    """Q[idx] += [F, τ] with repeated indices summed; index N (the world) is dropped."""
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

    def __init__(self, g=(0.0, 0.0, -9.81)) -> None:
        self.g = np.asarray(g, dtype=float)
        if self.g.shape != (3,) or not np.all(np.isfinite(self.g)):
            raise InvalidInput(f"g must be a finite 3-vector, got {g}")

    def bind(self, system: RigidBodies) -> None:
        self.system = _require_rigid(self, system)
        self._mg = np.concatenate([system._mass_finite[:, None] * self.g, np.zeros((system.N, 3))], axis=1)

    def apply(self, t: float, y: np.ndarray, Q: np.ndarray) -> None:
        Q += self._mg

    def potential_energy(self, y: np.ndarray) -> float:
        return float(-np.sum(self._mg[:, :3] * self.system.unpack(y)[0]))


class PointForce(Effect):
    """Forces f (k, 3) (world frame; constant or ``force(t, y) -> (k, 3)``) at body-frame points r (k, 3).

    >>> from pbanim.rigid import RigidBodies
    >>> rb = RigidBodies(1.0, [1.0, 1.0, 1.0]); pf = PointForce([0], [[1.0, 0, 0]], [[0, 2.0, 0]])
    >>> pf.bind(rb); Q = rb.zero_forces(); pf.apply(0.0, rb.state(), Q); Q   # τ = r × f = (0, 0, 2)
    array([[0., 2., 0., 0., 0., 2.]])
    """

    name = "point_force"
    phase = "force"

    def __init__(self, bodies, points_body, force: np.ndarray | Callable) -> None:
        self.bodies = _indices(bodies, "bodies")
        self.points = _rows3(points_body, "points_body")
        if len(self.points) != len(self.bodies):
            raise InvalidInput(f"points_body must have one row per body index ({len(self.bodies)}), "
                             f"got {len(self.points)}")
        if callable(force):
            self.force = force
        else:
            f = np.asarray(force, float)
            try:
                self.force = np.broadcast_to(f, self.points.shape)
            except ValueError:
                raise InvalidInput(f"force must be a callable or broadcast to shape {self.points.shape}, got "
                                   f"shape {f.shape}") from None
            if not np.all(np.isfinite(self.force)):
                raise InvalidInput(f"force must be finite, got {self.force[~np.isfinite(self.force)][0]}")

    def bind(self, system: RigidBodies) -> None:
        self.system = _require_rigid(self, system)
        if self.bodies.size and (self.bodies.min() < 0 or self.bodies.max() >= system.N):
            raise InvalidInput(f"bodies must lie in [0, {system.N - 1}] (forces on the world do nothing), "
                             f"got {self.bodies}")
        self._idx = self.bodies

    def apply(self, t: float, y: np.ndarray, Q: np.ndarray) -> None:
        # BEGIN SOLUTION PointForce.apply
        rb = self.system
        f = np.asarray(self.force(t, y) if callable(self.force) else self.force, dtype=float).reshape(-1, 3)
        x, q, _, _ = rb.unpack(y)
        r = _matvec(rb.quat_to_matrix(q)[self.bodies], self.points)  # p − x in world axes
        _accumulate(Q, rb.N, self._idx, f, _cross(r, f))
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

    def __init__(self, body_a, point_a, body_b, point_b, stiffness, damping=0.0, rest_length=None) -> None:
        self.a = _indices(body_a, "body_a")
        self.b = _indices(body_b, "body_b")
        k = len(self.a)
        self.ra = _rows3(point_a, "point_a")
        self.rb = _rows3(point_b, "point_b")
        if not (len(self.b) == len(self.ra) == len(self.rb) == k):
            raise InvalidInput(f"body_a, point_a, body_b, point_b must all have {k} rows, got "
                             f"{len(self.b)}, {len(self.ra)}, {len(self.rb)}")
        self.ks = _per_item(stiffness, k, "stiffness")
        self.kd = _per_item(damping, k, "damping")
        self.rest_in = rest_length

    def bind(self, system: RigidBodies) -> None:
        self.system = rb = _require_rigid(self, system)
        self._ia, self._ib = rb._index(self.a), rb._index(self.b)
        if self.rest_in is None:
            pa, pb = self._points(rb.state())
            self.rest = np.linalg.norm(pa - pb, axis=1)
        else:
            self.rest = _per_item(self.rest_in, len(self.a), "rest_length")

    def _points(self, y):
        rb = self.system
        x, q, _, _ = rb.unpack(y)
        xp = np.concatenate([x, np.zeros((1, 3))])
        Rp = np.concatenate([rb.quat_to_matrix(q), np.eye(3)[None]])
        return xp[self._ia] + _matvec(Rp[self._ia], self.ra), xp[self._ib] + _matvec(Rp[self._ib], self.rb)

    def apply(self, t: float, y: np.ndarray, Q: np.ndarray) -> None:
        rb = self.system
        pa, pb = self._points(y)
        d = pa - pb
        ell = np.sqrt(np.sum(d * d, axis=1))
        u = d / np.where(ell > 0, ell, 1.0)[:, None]
        ddot = rb.point_velocity(y, self.a, pa) - rb.point_velocity(y, self.b, pb)
        mag = self.ks * (ell - self.rest) + self.kd * np.sum(ddot * u, axis=1)
        fa = -mag[:, None] * u
        x = np.concatenate([rb.unpack(y)[0], np.zeros((1, 3))])
        idx = np.concatenate([self._ia, self._ib])
        F = np.concatenate([fa, -fa])
        r = np.concatenate([pa - x[self._ia], pb - x[self._ib]])
        _accumulate(Q, rb.N, idx, F, _cross(r, F))

    def potential_energy(self, y: np.ndarray) -> float:
        pa, pb = self._points(y)
        return float(0.5 * np.sum(self.ks * (np.linalg.norm(pa - pb, axis=1) - self.rest) ** 2))

    def diagnostics(self, t: float, y: np.ndarray) -> dict:
        pa, pb = self._points(y)
        return {"spring_length": np.linalg.norm(pa - pb, axis=1)}


class _Drag(Effect):
    phase = "force"

    def __init__(self, coefficient) -> None:
        self.c_in = coefficient

    def bind(self, system: RigidBodies) -> None:
        self.system = _require_rigid(self, system)
        c = np.asarray(self.c_in, dtype=float)
        try:
            self.c = np.broadcast_to(c, (system.N,)).copy()
        except ValueError:
            raise InvalidInput(f"coefficient must be a scalar or have shape ({system.N},), got {c.shape}") from None
        if np.any(~np.isfinite(self.c)) or np.any(self.c < 0):
            raise InvalidInput(f"coefficient must be finite and >= 0, got {self.c_in}")


class LinearDrag(_Drag):
    """Linear drag F = −c v (c in kg/s)."""

    name = "linear_drag"

    def apply(self, t: float, y: np.ndarray, Q: np.ndarray) -> None:
        v, _ = self.system.velocities(y)
        Q[:, :3] -= self.c[:, None] * v


class AngularDrag(_Drag):
    """Angular drag τ = −c ω (c in kg·m²/s)."""

    name = "angular_drag"

    def apply(self, t: float, y: np.ndarray, Q: np.ndarray) -> None:
        _, w = self.system.velocities(y)
        Q[:, 3:] -= self.c[:, None] * w


class QuaternionRenormalize(Effect):
    """Post-step stage q ← q/|q| (||q| − 1| stays within a few ε)."""

    name = "renormalize"
    phase = "post_step"

    def bind(self, system: RigidBodies) -> None:
        self.system = _require_rigid(self, system)

    def post_step(self, t: float, y: np.ndarray, h: float) -> np.ndarray:
        # BEGIN SOLUTION QuaternionRenormalize.post_step
        q = self.system.unpack(y)[1]
        q /= np.sqrt(np.sum(q * q, axis=1, keepdims=True))
        return y
        # END SOLUTION
