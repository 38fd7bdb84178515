"""Canonical rigid bodies (chapter 05): the torque-free asymmetric top in closed form, and the T-handle.

Euler's equations for a torque-free body in its principal frame, I₁ < I₂ < I₃,

    I₁ ω̇₁ = (I₂ − I₃) ω₂ ω₃,   I₂ ω̇₂ = (I₃ − I₁) ω₃ ω₁,   I₃ ω̇₃ = (I₁ − I₂) ω₁ ω₂,

conserve 2T = Σ Iᵢ ωᵢ² and M² = |L|² = Σ Iᵢ² ωᵢ². For M² > 2T I₂ (Landau & Lifshitz, *Mechanics* §37):

    ω₁ = A₁ cn u,   ω₂ = s A₂ sn u,   ω₃ = s A₃ dn u,     u = λ t + u₀,   s = sign ω₃(0),
    A₁² = (2T I₃ − M²)/(I₁(I₃ − I₁)),  A₂² = (2T I₃ − M²)/(I₂(I₃ − I₂)),  A₃² = (M² − 2T I₁)/(I₃(I₃ − I₁)),
    λ² = (I₃ − I₂)(M² − 2T I₁)/(I₁ I₂ I₃),   parameter m = k² = (I₂ − I₁)(2T I₃ − M²) / ((I₃ − I₂)(M² − 2T I₁)),

with cn, sn, dn = ``scipy.special.ellipj(u, m)`` — scipy takes the *parameter* m = k², not the modulus k.
The phase u₀ = F(φ₀ | m) (``ellipkinc``) with am u₀ = φ₀ = atan2(s ω₂(0)/A₂, ω₁(0)/A₁). For M² < 2T I₂ the
roles of axes 1 and 3 swap: the relabelling (I₃, I₂, I₁), (ω₃, −ω₂, ω₁) maps Euler's equations onto
themselves (the sign keeps the cyclic orientation), so the same formulas apply with I₃ − I₂ < 0, which
flips the sign of the sn term: ω₂' = −s A₂ sn u. ω has period 4K(m)/λ;
at M² = 2T I₂ (m = 1, the separatrix) the period is infinite. An exact spin about one principal axis
(two components of ω(0) zero) is a relative equilibrium: ω(t) = ω(0) (case "steady").

==============  ====================  =======
symbol          code                  shape
==============  ====================  =======
I₁, I₂, I₃      ``moments``           (3,)
ω(t) (body)     ``omega(t)``          (n, 3)
T, M²           ``energy, L2``        scalar
m = k²          ``m``                 scalar
λ               ``rate``              scalar
==============  ====================  =======
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from scipy.special import ellipj, ellipk, ellipkinc

from ..rigid.bodies import RigidBodies
from ..rigid.inertia import cylinder_inertia, parallel_axis, validate_inertia
from ..rigid.quat import quat_normalize, quat_to_matrix
from ..errors import InvalidInput

__all__ = ["TorqueFreeBody", "torque_free_body", "THandle", "t_handle"]


def _case_a(I, w0):
    """Amplitudes, rate, parameter and phase for the labelling where ω₃ keeps its sign (dn)."""
    I1, I2, I3 = I
    E2 = float(np.sum(I * w0 * w0))
    M2 = float(np.sum(I * I * w0 * w0))
    A1 = np.sqrt(max((E2 * I3 - M2) / (I1 * (I3 - I1)), 0.0))
    A2 = np.sqrt(max((E2 * I3 - M2) / (I2 * (I3 - I2)), 0.0))
    A3 = np.sqrt(max((M2 - E2 * I1) / (I3 * (I3 - I1)), 0.0))
    lam = np.sqrt(max((I3 - I2) * (M2 - E2 * I1) / (I1 * I2 * I3), 0.0))
    m = (I2 - I1) * (E2 * I3 - M2) / ((I3 - I2) * (M2 - E2 * I1))
    m = min(max(m, 0.0), 1.0)
    s = 1.0 if w0[2] >= 0 else -1.0
    s2 = s * (1.0 if I3 > I2 else -1.0)   # sign of the sn term: flips with the relabelled (descending) order
    phi0 = np.arctan2(s2 * w0[1] * A1, w0[0] * A2)  # atan2(sn, cn), both scaled by A₁A₂ > 0
    u0 = float(ellipkinc(phi0, m)) if m < 1 or abs(np.cos(phi0)) > 0 else 0.0
    return A1, A2, A3, lam, m, (s, s2), u0


@dataclass(frozen=True)
class TorqueFreeBody:
    """A torque-free asymmetric body (principal moments ascending) and its exact ω(t) (ORACLES C1).

    Examples
    --------
    >>> b = torque_free_body([1.0, 2.0, 3.0], [1.0, 0.1, 2.0])
    >>> w = b.omega([0.0, 1.0])
    >>> np.allclose(w[0], [1.0, 0.1, 2.0])
    True
    >>> E = 0.5 * np.sum(b.moments * w**2, axis=1); bool(np.allclose(E, b.energy))
    True
    """

    moments: np.ndarray
    omega0: np.ndarray
    energy: float
    L2: float
    m: float
    rate: float
    case: str
    _p: tuple = field(repr=False, default=())

    @property
    def period(self) -> float:
        """Period of ω(t): 4K(m)/λ (inf on the separatrix)."""
        if self.case == "steady":
            return np.inf
        return float(4 * ellipk(self.m) / self.rate) if self.m < 1 and self.rate > 0 else np.inf

    def omega(self, t) -> np.ndarray:
        """Body-frame angular velocity ω(t), shape (len(t), 3)."""
        t = np.atleast_1d(np.asarray(t, dtype=float))
        if self.case == "steady":           # spin about one principal axis: a relative equilibrium
            return np.tile(self.omega0, (len(t), 1))
        A1, A2, A3, lam, m, (s, s2), u0 = self._p
        sn, cn, dn, _ = ellipj(lam * t + u0, m)
        w = np.stack([A1 * cn, s2 * A2 * sn, s * A3 * dn], axis=1)
        if self.case == "M2<2TI2":          # undo the relabelling (I₃, I₂, I₁), (ω₃, −ω₂, ω₁)
            w = np.stack([w[:, 2], -w[:, 1], w[:, 0]], axis=1)
        return w

    def angular_momentum_body(self, t) -> np.ndarray:
        """L in body coordinates, I ω(t): on the sphere |L|² = M² and the ellipsoid Σ Lᵢ²/Iᵢ = 2T."""
        return self.omega(t) * self.moments

    def bodies(self, orientation=(1.0, 0.0, 0.0, 0.0), mass: float = 1.0, position=(0.0, 0.0, 0.0),
               velocity=(0.0, 0.0, 0.0)) -> RigidBodies:
        """One :class:`RigidBodies` with I_body = diag(moments) and world ω = R ω(0)."""
        q = quat_normalize(np.asarray(orientation, dtype=float))
        w_world = quat_to_matrix(q) @ self.omega0
        return RigidBodies(mass, self.moments, positions=[position], orientations=[q],
                           velocities=[velocity], angular_velocities=[w_world])


def torque_free_body(moments, omega0) -> TorqueFreeBody:
    """Closed-form torque-free motion for principal ``moments`` I₁ < I₂ < I₃ and body ``omega0``.

    Raises
    ------
    ValueError
        If the moments are not strictly ascending or break the triangle inequality, or ω(0) is not finite.
    """
    I = np.asarray(moments, dtype=float)
    w0 = np.asarray(omega0, dtype=float)
    if I.shape != (3,) or not (I[0] < I[1] < I[2]):
        raise InvalidInput(f"moments must be 3 strictly ascending principal moments I1 < I2 < I3, got {moments}")
    validate_inertia(np.diag(I), "moments")
    if w0.shape != (3,) or not np.all(np.isfinite(w0)) or not np.any(w0):
        raise InvalidInput(f"omega0 must be a finite non-zero 3-vector, got {omega0}")
    E2, M2 = float(np.sum(I * w0 * w0)), float(np.sum(I * I * w0 * w0))
    if np.count_nonzero(w0) == 1:      # exact principal-axis spin (also the unstable middle one): ω constant
        return TorqueFreeBody(moments=I, omega0=w0, energy=0.5 * E2, L2=M2, m=0.0 if w0[1] == 0 else 1.0,
                              rate=0.0, case="steady", _p=())
    if M2 >= E2 * I[1]:
        case, p = "M2>2TI2", _case_a(I, w0)
    else:
        case, p = "M2<2TI2", _case_a(I[::-1].copy(), np.array([w0[2], -w0[1], w0[0]]))
    return TorqueFreeBody(moments=I, omega0=w0, energy=0.5 * E2, L2=M2, m=p[4], rate=p[3], case=case, _p=p)


@dataclass(frozen=True)
class THandle:
    """A T-handle (Dzhanibekov's wing nut): two solid cylinders, in its principal frame.

    ``segments`` are the two cylinder axes (endpoints, (2, 2, 3)) in principal coordinates about the centre
    of mass (for drawing); ``body`` is the torque-free solution started near the intermediate axis.
    """

    mass: float
    moments: np.ndarray
    axes: np.ndarray
    segments: np.ndarray
    body: TorqueFreeBody


def t_handle(spin: float = 6.0, perturbation: float = 1e-3, axis: int = 1, shaft=(0.1, 0.8, 1.0),
             bar=(0.1, 1.0, 1.0)) -> THandle:
    """The T-handle spun about principal ``axis`` (0 min, 1 intermediate, 2 max) at ``spin`` rad/s, with
    ``perturbation``·spin added on the other two axes.

    ``shaft`` and ``bar`` are (radius, length, mass) of the two cylinders; the shaft runs along x from 0 to
    its length, the bar along y is centred on the shaft's end. The composite inertia about the common
    centre of mass is assembled with the parallel-axis theorem.

    >>> th = t_handle()
    >>> bool(th.moments[0] < th.moments[1] < th.moments[2])
    True
    """
    (rs, ls, ms), (rb, lb, mb) = shaft, bar
    Is = cylinder_inertia(ms, rs, ls, axis=0)
    Ib = cylinder_inertia(mb, rb, lb, axis=1)
    cs, cb = np.array([ls / 2, 0, 0]), np.array([ls, 0, 0])
    M = ms + mb
    com = (ms * cs + mb * cb) / M
    I = parallel_axis(Is, ms, cs - com) + parallel_axis(Ib, mb, cb - com)
    moments, A = np.linalg.eigh(I)
    A = A * np.sign(np.linalg.det(A))
    seg = np.array([[[0, 0, 0], [ls, 0, 0]], [[ls, -lb / 2, 0], [ls, lb / 2, 0]]]) - com
    seg = seg @ A                                             # world (handle) coordinates → principal
    w0 = np.full(3, perturbation * spin)
    w0[axis] = spin
    return THandle(mass=M, moments=moments, axes=A, segments=seg, body=torque_free_body(moments, w0))
