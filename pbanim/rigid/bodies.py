"""The :class:`RigidBodies` system: Baraff's state for many bodies in one set of arrays (chapter 05).

Per body i, y holds (xᵢ, qᵢ, Pᵢ, Lᵢ); derived: Rᵢ = R(qᵢ/|qᵢ|), vᵢ = Wᵢ Pᵢ, ωᵢ = Rᵢ I⁻¹_body,i Rᵢᵀ Lᵢ, and

    ẋ = v,   q̇ = ½ (0, ω) ⊗ q,   Ṗ = F,   L̇ = τ,       T = ½ P·v + ½ L·ω.

Flat layout y = [x.ravel() (3N), q.ravel() (4N), P.ravel() (3N), L.ravel() (3N)], split = 7N; Q (N, 6) =
[F, τ about xᵢ] in world axes. A point p moving with body i has ṗ = vᵢ + ωᵢ × (p − xᵢ); an impulse j at p
changes Pᵢ += j, Lᵢ += (p − xᵢ) × j. Body index −1 is the static world: per-body arrays are padded with one
row of W = 0, I⁻¹ = 0, x = 0, R = E, so every formula treats it like any body.

Every array operation runs over all N bodies at once (``einsum`` on (N, 3, 3) stacks, column arithmetic
on quaternions, ``np.add.at`` for impulses); :meth:`RigidBodies.derivative_readable` is the per-body loop
of Baraff's notes, kept for teaching and tested against the vectorized :meth:`RigidBodies.derivative`.
See :mod:`pbanim.rigid` for the full lecture, notation table and references (Baraff 1997 §§2–5).
"""

from __future__ import annotations

import numpy as np

from ..contracts import Array, Opt, contract, package_code_cached
from ..geometry import cross
from .admissible import Inertia
from .derivative_float import FLOAT_MAX_BODIES, derivative_floats
from .domain import Flags, Vectors, certifier, certify, row_norms
from .inertia import validate_inertia
from .protocol import _Y, RigidBodyProtocol, _matTvec, _matvec
from .quat import _matrices, normalized, quat_to_matrix
from ..errors import InvalidInput, as_floats

__all__ = ["RigidBodies"]

_ROWS = Array(("self.N", 3))               # one row per body
_ONE_OR_EACH = Opt(Array((3,), batch="first"))


def _per_body(name: str, value, N: int, tail: tuple) -> np.ndarray:
    a = np.asarray(value, dtype=float)
    try:
        return np.broadcast_to(a, (N,) + tail).copy()
    except ValueError:
        raise InvalidInput(f"{name} must have shape {tail} or ({N}, {', '.join(map(str, tail))}), "
                         f"got {a.shape}") from None


class RigidBodies(RigidBodyProtocol):
    """N rigid bodies with Baraff's state y = [x (N,3), q (N,4), P (N,3), L (N,3)] (flat, 13N).

    Parameters
    ----------
    mass : float or array (N,)
        Masses m > 0; ``np.inf`` makes a body static (as does ``static``).
    inertia : array (3,), (3, 3), (N, 3) or (N, 3, 3)
        Body-frame inertia about the centre of mass; (3,) and (N, 3) give principal moments (a (3, 3)
        array is always one tensor). Checked: symmetric positive definite with I₁ + I₂ ≥ I₃.
    positions : array (N, 3), optional
        Centres of mass x (default 0).
    orientations : array (N, 4), optional
        Quaternions (w, x, y, z), normalized here (default identity).
    velocities, angular_velocities : array (N, 3), optional
        v and world-frame ω at t = 0; stored as P = m v and L = I_world ω.
    static : bool array (N,), optional
        Static bodies have W = 0 and I⁻¹ = 0: they never move, and impulses/forces on them vanish.

    Attributes
    ----------
    N, split : int
        Number of bodies; ``split = 7N`` position components (x and q) at the front of y.
    mass, inv_mass : (N,)
        ``inv_mass`` is 0 (and ``mass`` inf) for a static body.
    I_body, inv_I_body : (N, 3, 3)
        ``inv_I_body`` is 0 for a static body.
    inv_mass_padded, inv_I_body_padded : (N+1,), (N+1, 3, 3)
        The same with one zero row appended: body index −1 is the static world.

    Examples
    --------
    >>> rb = RigidBodies(mass=2.0, inertia=[1.0, 2.0, 3.0], positions=[[0.0, 0.0, 1.0]],
    ...                  velocities=[[1.0, 0.0, 0.0]], angular_velocities=[[0.0, 0.0, 2.0]])
    >>> y = rb.state(); y.shape, rb.split
    ((13,), 7)
    >>> v, w = rb.velocities(y); v, w
    (array([[1., 0., 0.]]), array([[0., 0., 2.]]))
    >>> rb.kinetic_energy(y)          # ½ m v² + ½ ω·Iω = 1 + 6
    7.0
    """

    #: False: :meth:`derivative` runs the vectorized arrays whatever N (the float twin's reference)
    lean_path = True

    @contract(mass=Array((None,), gt=0, finite=False, scalar=True), inertia=Inertia(batch=True, moments=True),
              positions=_ONE_OR_EACH, orientations=Opt(Vectors(4, batch="first", nonzero=True)),
              velocities=_ONE_OR_EACH, angular_velocities=_ONE_OR_EACH, static=Opt(Flags()))
    def __init__(self, mass, inertia, positions=None, orientations=None, velocities=None,
                 angular_velocities=None, *, static=None) -> None:
        m_in = np.atleast_1d(as_floats("mass", mass))
        if m_in.size == 0 or m_in.ndim != 1:
            raise InvalidInput(f"mass must be a positive number or one per body (N ≥ 1), got {mass!r}")
        I_in = as_floats("inertia", inertia)
        cands = [m_in.shape[0] if m_in.ndim == 1 and m_in.size > 1 else 1]
        for arr in (positions, orientations, velocities, angular_velocities):
            if arr is not None:
                a = np.asarray(arr, dtype=float)
                cands.append(a.shape[0] if a.ndim == 2 else 1)
        if I_in.ndim == 3 or (I_in.ndim == 2 and I_in.shape != (3, 3)):
            cands.append(I_in.shape[0])
        if static is not None:
            cands.append(np.atleast_1d(static).shape[0])
        N = max(cands)
        if N < 1:
            raise InvalidInput("need at least one body, got N = 0")
        m = _per_body("mass", m_in if m_in.size > 1 else m_in[0], N, ())
        st = np.zeros(N, bool) if static is None else _per_body("static", static, N, ()).astype(bool)
        st |= np.isposinf(m)
        bad = ~st & ~(np.isfinite(m) & (m > 0))
        if np.any(bad):
            raise InvalidInput(f"mass must be positive and finite (np.inf for a static body), got "
                             f"{m[bad][0]} for body {int(np.flatnonzero(bad)[0])}")
        if I_in.ndim not in (1, 2, 3) or I_in.shape[-1] != 3 or (I_in.ndim == 3 and I_in.shape[1] != 3):
            raise InvalidInput(f"inertia must have shape (3,) or (N, 3) (principal moments), or (3, 3) or "
                             f"(N, 3, 3) (tensors), got {I_in.shape}")
        if I_in.ndim == 1 or (I_in.ndim == 2 and I_in.shape != (3, 3)):  # principal moments
            I_in = I_in[..., :, None] * np.eye(3)
        Ib = _per_body("inertia", I_in, N, (3, 3))
        validate_inertia(Ib, "inertia")
        self.N, self.split = N, 7 * N
        self.static = st
        self.mass = np.where(st, np.inf, m)
        self._mass_finite = np.where(st, 0.0, m)  # for gravity-like forces (static bodies feel nothing)
        with np.errstate(over="ignore", divide="ignore"):
            self.inv_mass = np.where(st, 0.0, 1.0 / np.where(st, 1.0, m))
            self.inv_I_body = np.where(st[:, None, None], 0.0, np.linalg.inv(Ib))
        certify("RigidBodies: the inverse masses 1/m and inertias I⁻¹", np.concatenate(
            [self.inv_mass, self.inv_I_body.ravel()]), self._mass_finite, Ib)
        self.I_body = Ib
        self.inv_mass_padded = np.append(self.inv_mass, 0.0)
        self.inv_I_body_padded = np.concatenate([self.inv_I_body, np.zeros((1, 3, 3))])
        self._dyn = (~st).astype(float)[:, None]
        self._any_static = bool(st.any())

        x = np.zeros((N, 3)) if positions is None else _per_body("positions", positions, N, (3,))
        q = np.tile([1.0, 0, 0, 0], (N, 1)) if orientations is None else \
            normalized(_per_body("orientations", orientations, N, (4,)), "orientations", "RigidBodies")
        v = np.zeros((N, 3)) if velocities is None else _per_body("velocities", velocities, N, (3,))
        w = np.zeros((N, 3)) if angular_velocities is None else \
            _per_body("angular_velocities", angular_velocities, N, (3,))
        for name, a in (("positions", x), ("velocities", v), ("angular_velocities", w)):
            if not np.all(np.isfinite(a)):
                raise InvalidInput(f"{name} must be finite, got {a[~np.all(np.isfinite(a), axis=1)][0]}")
        if np.any(st & (np.any(v != 0, axis=1) | np.any(w != 0, axis=1))):
            raise InvalidInput("static bodies cannot move: give them zero velocities and angular_velocities")
        R = quat_to_matrix(q)
        with np.errstate(over="ignore", invalid="ignore"):
            Iw = R @ Ib @ np.swapaxes(R, 1, 2)
            self.x0, self.q0 = x, q
            self.P0 = self._mass_finite[:, None] * v
            self.L0 = np.where(st[:, None], 0.0, _matvec(Iw, w))
        certify("RigidBodies: the momenta P = m v and L = I ω", np.concatenate([self.P0, self.L0]),
                self._mass_finite, v, Ib, w)

    @property
    def n_state(self) -> int:
        """Length of the flat state y = [x, q, P, L]: 13N."""
        return 13 * self.N

    @contract(positions=Array(("n", 3)), velocities=Opt(Array(("n", 3))), masses=Array(("n",), gt=0, scalar=True))
    @classmethod
    def point_masses(cls, positions, velocities=None, masses=1.0) -> "RigidBodies":
        """Particles as rigid bodies (inertia m·E, never exercised): forces applied at r = 0 exert no
        torque, so their rotation stays inert and their translation is exactly a particle's. Use this to
        hang particles on rigid bodies with :class:`pbanim.rigid.RigidSprings`.

        >>> pm = RigidBodies.point_masses([[0.0, 0, 0], [1.0, 0, 0]], masses=2.0); pm.N, pm.mass
        (2, array([2., 2.]))
        """
        x = np.asarray(positions, dtype=float).reshape(-1, 3)
        m = np.broadcast_to(np.asarray(masses, dtype=float), (len(x),))
        return cls(m, m[:, None, None] * np.eye(3), positions=x, velocities=velocities)

    # -- state layout ---------------------------------------------------------------------------
    def state(self) -> np.ndarray:
        """A fresh flat copy of the initial state [x, q, P, L]."""
        return self.pack(self.x0, self.q0, self.P0, self.L0)

    @contract(x=_ROWS, quat=Array(("self.N", 4)), P=_ROWS, L=_ROWS)
    def pack(self, x, quat, P, L) -> np.ndarray:
        """Flat state from x (N,3), q (N,4), P (N,3), L (N,3)."""
        N = self.N
        return np.concatenate([np.reshape(x, 3 * N), np.reshape(quat, 4 * N), np.reshape(P, 3 * N),
                               np.reshape(L, 3 * N)]).astype(float)

    @contract(y=Array(("self.n_state",)))
    def unpack(self, y: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """Views (x (N,3), q (N,4), P (N,3), L (N,3)) into a flat state y (writes go through to y)."""
        N = self.N
        return (y[:3 * N].reshape(N, 3), y[3 * N:7 * N].reshape(N, 4), y[7 * N:10 * N].reshape(N, 3),
                y[10 * N:13 * N].reshape(N, 3))

    @contract(quat=Vectors(4, batch="first", nonzero=True))
    @staticmethod
    def quat_to_matrix(quat: np.ndarray) -> np.ndarray:
        """R (N,3,3) from quaternions (N,4), always via the unit quaternion q/|q|."""
        return quat_to_matrix(quat)

    # -- derived quantities ---------------------------------------------------------------------
    @contract(y=_Y)
    def rotations(self, y: np.ndarray) -> np.ndarray:
        """R (N, 3, 3) of every body."""
        return quat_to_matrix(self.unpack(y)[1])

    @contract(y=_Y, returns=certifier("RigidBodies.inv_inertia_world: R I⁻¹ Rᵀ"))
    def inv_inertia_world(self, y: np.ndarray) -> np.ndarray:
        """I⁻¹_world = R I⁻¹_body Rᵀ, shape (N, 3, 3) (zero for static bodies)."""
        # BEGIN SOLUTION RigidBodies.inv_inertia_world
        R = self.rotations(y)
        return R @ self.inv_I_body @ np.swapaxes(R, 1, 2)
        # END SOLUTION

    @contract(y=_Y, returns=certifier("RigidBodies.velocities: (v, ω)"))
    def velocities(self, y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(v = P/m, ω = I⁻¹_world L), each (N, 3); ω = R (I⁻¹_body (Rᵀ L)) without forming I⁻¹_world."""
        # BEGIN SOLUTION RigidBodies.velocities
        _, q, P, L = self.unpack(y)
        R = quat_to_matrix(q)
        return self.inv_mass[:, None] * P, _matvec(R, _matvec(self.inv_I_body, _matTvec(R, L)))
        # END SOLUTION

    @contract(y=_Y, returns=certifier("RigidBodies.body_angular_velocity: Rᵀω"))
    def body_angular_velocity(self, y: np.ndarray) -> np.ndarray:
        """ω in body coordinates, Rᵀω = I⁻¹_body Rᵀ L (the ω of Euler's equations), (N, 3)."""
        _, q, _, L = self.unpack(y)
        return _matvec(self.inv_I_body, _matTvec(quat_to_matrix(q), L))

    # -- dynamics -------------------------------------------------------------------------------
    def zero_forces(self) -> np.ndarray:
        """Q of shape (N, 6): [force, torque about the centre of mass], world frame."""
        return np.zeros((self.N, 6))

    @contract(y=_Y, Q=Array(("self.N", 6)), returns=certifier("RigidBodies.derivative: ẏ"))
    def derivative(self, y: np.ndarray, Q: np.ndarray) -> np.ndarray:
        """ẏ = [v, ½(0, ω)⊗q, F, τ] for all bodies at once (static bodies: 0); for a few bodies on floats
        (:mod:`pbanim.rigid.derivative_float`, the same bits; ``lean_path = False``: the arrays)."""
        if (self.N <= FLOAT_MAX_BODIES and self.lean_path        # a course copy or a subclass runs its own code
                and package_code_cached(self, "derivative", "derivative_and_omega")):
            try:
                return derivative_floats(self, y, Q)[0]
            except ZeroDivisionError:        # a zero quaternion: the vectorized path names it
                pass
        return RigidBodies.derivative_and_omega.__wrapped__(self, y, Q)[0]      # (no boundary in between)

    @contract(y=_Y, Q=Array(("self.N", 6)), returns=certifier("RigidBodies.derivative: ẏ"))
    def derivative_and_omega(self, y: np.ndarray, Q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(ẏ, ω): the derivative and the world angular velocities it used (one pass)."""
        # BEGIN SOLUTION RigidBodies.derivative_and_omega
        N = self.N
        q = y[3 * N:7 * N].reshape(N, 4)
        P = y[7 * N:10 * N].reshape(N, 3)
        L = y[10 * N:13 * N].reshape(N, 3)
        R = _matrices(q)                   # (a run's quaternions: unit up to drift)
        w = np.einsum("nij,nj->ni", R, np.einsum("nij,nj->ni", self.inv_I_body, np.einsum("nji,nj->ni", R, L)))
        dy = np.empty_like(y)
        np.multiply(P, self.inv_mass[:, None], out=dy[:3 * N].reshape(N, 3))
        qd = dy[3 * N:7 * N].reshape(N, 4)
        q0, q1, q2, q3 = q.T
        w0, w1, w2 = w.T
        qd[:, 0] = -0.5 * (w0 * q1 + w1 * q2 + w2 * q3)
        qd[:, 1] = 0.5 * (w0 * q0 + w1 * q3 - w2 * q2)
        qd[:, 2] = 0.5 * (w1 * q0 + w2 * q1 - w0 * q3)
        qd[:, 3] = 0.5 * (w2 * q0 + w0 * q2 - w1 * q1)
        Q = np.asarray(Q, dtype=float).reshape(N, 6)
        if self._any_static:
            Q = Q * self._dyn
        dy[7 * N:].reshape(2, N, 3)[:] = Q.reshape(N, 2, 3).transpose(1, 0, 2)   # [F rows; τ rows]
        return dy, w
        # END SOLUTION

    @contract(y=_Y, Q=Array(("self.N", 6)), returns=certifier("RigidBodies.derivative_readable: ẏ"))
    def derivative_readable(self, y: np.ndarray, Q: np.ndarray) -> np.ndarray:
        """The same ẏ, one body at a time, written as in Baraff's notes (for teaching; tests compare)."""
        from .quat import quat_multiply

        x, q, P, L = self.unpack(y)
        dx, dq, dP, dL = self.unpack(np.zeros_like(y))
        for i in range(self.N):
            R = quat_to_matrix(q[i])
            v = P[i] * self.inv_mass[i]
            I_inv = R @ self.inv_I_body[i] @ R.T
            omega = I_inv @ L[i]
            dx[i] = v
            dq[i] = 0.5 * quat_multiply(np.concatenate([[0.0], omega]), q[i])
            if not self.static[i]:
                dP[i], dL[i] = Q[i, :3], Q[i, 3:]
        return np.concatenate([dx.ravel(), dq.ravel(), dP.ravel(), dL.ravel()])

    # -- diagnostics ----------------------------------------------------------------------------
    @contract(y=_Y, returns=certifier("RigidBodies: the kinetic energy"))
    def translational_kinetic_energy(self, y: np.ndarray) -> float:
        """Σ ½ P·v = Σ |P|²/2m."""
        P = self.unpack(y)[2]
        return float(0.5 * np.sum(self.inv_mass[:, None] * P * P))

    @contract(y=_Y, returns=certifier("RigidBodies: the kinetic energy"))
    def rotational_kinetic_energy(self, y: np.ndarray) -> float:
        """Σ ½ L·ω = Σ ½ ωᵀ I_world ω."""
        L = self.unpack(y)[3]
        return float(0.5 * np.sum(L * self.velocities(y)[1]))

    @contract(y=_Y)
    def kinetic_energy(self, y: np.ndarray) -> float:
        """T = translational + rotational."""
        return self.translational_kinetic_energy(y) + self.rotational_kinetic_energy(y)

    @contract(y=_Y, returns=certifier("RigidBodies.linear_momentum: Σ P"))
    def linear_momentum(self, y: np.ndarray) -> np.ndarray:
        """Σ P over the bodies, (3,)."""
        return self.unpack(y)[2].sum(axis=0)

    @contract(y=_Y, returns=certifier("RigidBodies.center_of_mass"))
    def center_of_mass(self, y: np.ndarray) -> np.ndarray:
        """Mass-weighted mean of the dynamic bodies' positions, (3,); with no dynamic body, the mean of the
        static ones (the limit of equal masses m → ∞)."""
        x = self.unpack(y)[0]
        m = self._mass_finite if not self.static.all() else np.ones(self.N)
        w = m / m.max()                    # weights ≤ 1: no overflow for masses near 10³⁰⁸
        return (w / w.sum()) @ x

    @contract(y=_Y, about=Opt(Array((3,))), returns=certifier("RigidBodies.angular_momentum: Σ (x − o) × P + L"))
    def angular_momentum(self, y: np.ndarray, about=None) -> np.ndarray:
        """Σ (x − o) × P + L about the point o (default the origin), (3,)."""
        x, _, P, L = self.unpack(y)
        o = np.zeros(3) if about is None else np.asarray(about, dtype=float)
        return cross(x - o, P).sum(axis=0) + L.sum(axis=0)

    @contract(y=_Y)
    def angular_momentum_com(self, y: np.ndarray) -> np.ndarray:
        """Angular momentum about the (moving) centre of mass of the system, (3,)."""
        return self.angular_momentum(y, about=self.center_of_mass(y))

    @contract(y=_Y)
    def quaternion_norm_error(self, y: np.ndarray) -> float:
        """max ||q| − 1| over the bodies (drift of the stored quaternions)."""
        q = self.unpack(y)[1]
        return float(np.max(np.abs(row_norms(q) - 1.0)))
