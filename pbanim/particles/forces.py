"""Forces that act on particles one at a time: anchor springs, and user forces from callables (chapter 01).

=========================  ==========================================================================
force                      Qᵢ contribution and potential V
=========================  ==========================================================================
:class:`AnchorSprings`     Qᵢ += −k_s (xᵢ − pᵢ) − k_d vᵢ        V = ½ Σ k_s |xᵢ − pᵢ|²  (pins to fixed points)
:class:`UserForce`         Q += F(t, x, v)                     V given by the user, if any
=========================  ==========================================================================

Both are scene effects of phase "force" (see :mod:`pbanim.scene`); the protocol methods ``apply(t, y, Q)``
add into Q in place, so Q must be the float64 array itself (a list would be a copy whose sum is lost).
"""

from __future__ import annotations

from typing import Any, Callable

import numpy as np
import scipy.sparse as sp

from .specs import Buffer, IndexArray, point
from .springs import ForceJacobian
from ..contracts import Array, Func, Obj, Opt, Real, Text, contract, unchecked
from ..errors import InvalidInput
from ..scene import Effect

__all__ = ["AnchorSprings", "UserForce"]

_SYSTEM = Obj("pbanim.particles.system:ParticleSystem")
_Y = Array(("self.system.n_state",))
_Q = Buffer(("self.system.N", "self.system.dim"))
_T = Real()


class AnchorSprings(Effect):
    """Zero-rest-length damped springs pinning particles to fixed world points (Witkin's "mouse spring").

    Qᵢ += −k_s (xᵢ − pᵢ) − k_d vᵢ for each anchored particle i; V = ½ Σ k_s |xᵢ − pᵢ|². Local (the force
    on i depends on i only) and linear, so its Jacobians are constant diagonals.

    Parameters
    ----------
    indices : array_like of int, shape (A,)
        Anchored particles (distinct, in [0, N)).
    points : array_like, shape (A, dim), optional
        Anchor points; default the particles' initial positions.
    stiffness, damping : float
        k_s > 0, k_d ≥ 0.

    Examples
    --------
    >>> from pbanim.particles import ParticleSystem
    >>> from pbanim.scene import Scene
    >>> ps = ParticleSystem([[1.0, 0.0], [5.0, 5.0]])
    >>> Scene(ps, [AnchorSprings([0], [[0.0, 0.0]], stiffness=3.0)]).forces(0.0, ps.state())
    array([[-3., -0.],
           [ 0.,  0.]])
    """

    phase = "force"
    linear = True       # Q = c + K_x x + K_v v, constant: a small scene steps by its linear map
    nan_safe = True     # a NaN state gives NaN forces, never an exception (a run checks its states in blocks)

    @contract(indices=IndexArray(("A",), distinct="all", empty=True), points=Opt(point("A")),
              stiffness=Real(gt=0), damping=Real(ge=0), name=Text(nonempty=True))
    def __init__(self, indices: Any, points: Any = None, stiffness: float = 1e3, damping: float = 0.0,
                 name: str = "anchors") -> None:
        self.idx = np.atleast_1d(np.asarray(indices)).astype(np.intp)
        self.points_in, self.name = points, name
        self.ks, self.kd = float(stiffness), float(damping)

    @contract(system=_SYSTEM)
    def bind(self, system: Any) -> None:
        N, dim = system.N, system.dim
        if np.any((self.idx < 0) | (self.idx >= N)) or len(np.unique(self.idx)) != len(self.idx):
            raise InvalidInput(f"indices must be distinct particle indices in [0, {N}), got {self.idx.tolist()}")
        p = system.x0[self.idx] if self.points_in is None else np.asarray(self.points_in, float)
        if p.shape != (len(self.idx), dim):
            raise InvalidInput(f"points must have shape ({len(self.idx)}, {dim}), got {p.shape}")
        self.system, self.points = system, p.copy()
        self._unpack = unchecked(system.unpack)     # the step loop's own calls pay no argument check
        n = N * dim
        diag = np.zeros((N, dim))
        diag[self.idx] = 1.0
        self._Kx = sp.diags(-self.ks * diag.ravel(), shape=(n, n), format="csr")
        self._Kv = sp.diags(-self.kd * diag.ravel(), shape=(n, n), format="csr") if self.kd > 0 else None

    @contract(t=_T, y=_Y, Q=_Q)
    def apply(self, t: float, y: np.ndarray, Q: np.ndarray) -> None:
        x, v = self._unpack(y)
        Q[self.idx] -= self.ks * (x[self.idx] - self.points) + self.kd * v[self.idx]

    @contract(y=_Y)
    def potential_energy(self, y: np.ndarray) -> float:
        x, _ = self.system.unpack(y)
        e = x[self.idx] - self.points
        return float(0.5 * self.ks * np.sum(e * e))

    @contract(t=_T, y=_Y)
    def diagnostics(self, t: float, y: np.ndarray) -> dict[str, float]:
        return {f"V_{self.name}": self.potential_energy(y)}

    @contract(t=_T, y=_Y)
    def jacobian(self, t: float, y: np.ndarray) -> ForceJacobian:
        return ForceJacobian(self._Kx, self._Kv)


class UserForce(Effect):
    """A user force from a callable: the small protocol for forces pbanim does not provide.

    ``force(t, x, v) -> F`` receives positions and velocities of shape (N, dim) (read-only views: do not
    modify them) and returns the force on every particle, an array broadcastable to (N, dim). Optional
    ``potential(x) -> V`` makes the force conservative in the scene energy; optional
    ``jacobian(t, x, v) -> (dQdx, dQdv)`` (sparse or dense (N·dim)², or None) lets implicit methods use it.
    For more control subclass :class:`pbanim.scene.Effect` and write ``apply(t, y, Q)`` (add into Q in place).

    Examples
    --------
    >>> from pbanim.particles import ParticleSystem
    >>> from pbanim.scene import Scene
    >>> ps = ParticleSystem([[1.0, 0.0]])
    >>> spring_to_origin = UserForce(lambda t, x, v: -4.0 * x, name="anchor",
    ...                              potential=lambda x: 2.0 * float(np.sum(x * x)))
    >>> scene = Scene(ps, [spring_to_origin]); scene.pipeline
    ('anchor', 'integrate')
    >>> scene.forces(0.0, ps.state()), scene.potential_energy(ps.state())
    (array([[-4., -0.]]), 2.0)
    """

    phase = "force"

    @contract(force=Func(), name=Text(nonempty=True), potential=Opt(Func()), jacobian=Opt(Func()))
    def __init__(self, force: Callable, name: str = "user_force", potential: Callable | None = None,
                 jacobian: Callable | None = None) -> None:
        self.force, self.name, self._potential, self._jacobian = force, str(name), potential, jacobian
        if jacobian is None:
            self.jacobian = None  # type: ignore[assignment]  # no Jacobian: implicit methods fall back to FD
        if potential is None:
            self.potential_energy = None  # type: ignore[assignment]

    @contract(system=_SYSTEM)
    def bind(self, system: Any) -> None:
        self.system, self._unpack = system, unchecked(system.unpack)
        x, v = system.unpack(system.state())
        F = self._force(0.0, x, v)
        if not np.isfinite(F).all():
            raise InvalidInput(f"force of {self.name!r} must return finite forces, got {F.ravel()[:4]} at the "
                               "initial state")

    def _force(self, t, x, v) -> np.ndarray:
        """The user's F(t, x, v), checked broadcastable to (N, dim) (a bare numpy error otherwise)."""
        F = np.asarray(self.force(t, x, v), dtype=float)
        try:
            np.broadcast_to(F, x.shape)
        except ValueError:
            raise InvalidInput(f"force of {self.name!r} must return an array broadcastable to "
                               f"({x.shape[0]}, {x.shape[1]}), got shape {F.shape}") from None
        return F

    @contract(t=_T, y=_Y, Q=_Q)
    def apply(self, t: float, y: np.ndarray, Q: np.ndarray) -> None:
        x, v = self._unpack(y)
        try:
            Q += self.force(t, x, v)
        except ValueError:      # the shape changed since bind: name it (a NaN force is the scene's to catch)
            self._force(t, x, v)
            raise

    @contract(y=_Y)
    def potential_energy(self, y: np.ndarray) -> float:  # replaced by None when no potential is given
        x, _ = self.system.unpack(y)
        V = np.asarray(self._potential(x), dtype=float)  # type: ignore[misc]
        if V.size != 1:
            raise InvalidInput(f"potential of {self.name!r} must return one number, got shape {V.shape}")
        return float(V.reshape(()))

    @contract(t=_T, y=_Y)
    def jacobian(self, t: float, y: np.ndarray) -> ForceJacobian:  # replaced by None when not given
        x, v = self.system.unpack(y)
        Kx, Kv = self._jacobian(t, x, v)  # type: ignore[misc]
        n = x.size
        out = [None if K is None else sp.csr_matrix(K, dtype=float) for K in (Kx, Kv)]
        for name, K in zip(("dQdx", "dQdv"), out):
            if K is not None and K.shape != (n, n):
                raise InvalidInput(f"jacobian of {self.name!r} must return {name} of shape ({n}, {n}), got {K.shape}")
        return ForceJacobian(*out)
