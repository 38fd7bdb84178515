"""Three classic test problems of the work-precision benchmark: Pleiades, Van der Pol, Robertson.

Each is an :class:`IVP` — ``rhs(t, y)``, its analytic Jacobian ``jac(t, y)``, ``y0``, ``t_end`` and a
reference solution ``y_ref`` at t_end — with the same right-hand side for every solver (pbanim, scipy).

Pleiades (non-stiff, 28 states; Hairer, Nørsett & Wanner I, §II.10): seven stars in the plane, masses
mᵢ = i, G = 1,

    ẍᵢ = Σⱼ≠ᵢ mⱼ (xⱼ − xᵢ)/rᵢⱼ³,   rᵢⱼ = |xⱼ − xᵢ|,    t ∈ [0, 3]   (close encounters near t = 1.2–2.9).

Invariants: the energy Σ ½mᵢ|ẋᵢ|² − Σᵢ<ⱼ mᵢmⱼ/rᵢⱼ and the momentum Σ mᵢẋᵢ.

Van der Pol (stiff, μ = 1000): ÿ − μ(1 − y²)ẏ + y = 0, y = [y, ẏ] from [2, 0] on [0, 3000] (the
relaxation oscillation of period ≈ (3 − 2 ln 2)μ ≈ 1614: long slow phases where the stiffness ratio is
~μ², and fast jumps).

Robertson (stiff chemical kinetics, rates over nine orders of magnitude), on [0, 40]:

    ẏ₁ = −0.04y₁ + 10⁴y₂y₃,   ẏ₂ = 0.04y₁ − 10⁴y₂y₃ − 3·10⁷y₂²,   ẏ₃ = 3·10⁷y₂²,   y(0) = (1, 0, 0);

y₁ + y₂ + y₃ = 1 is a linear invariant (every Runge–Kutta or Rosenbrock method keeps it to roundoff
when J is exact), and y₂ ~ 10⁻⁵ is the component the error measure must see (relative error).

Notation: n states; ``y_ref`` the reference at ``t_end``; ``error(y)`` the benchmark's error measure
(max absolute error, or max relative error per component for Robertson).

Limiting cases: μ → 0 turns Van der Pol into the harmonic oscillator; at t = 0 Robertson's y₂ grows
linearly, y₂ ≈ 0.04t, until the fast reaction 3·10⁷y₂² balances it (y₂ ≈ 3.6·10⁻⁵ at t ≈ 10⁻³).

Reference solutions: computed once by several codes (pbanim ``radau5``, ``rodas4``, ``dop853``, ``vern7``;
scipy's ``Radau``, ``DOP853``, ``LSODA``, ``BDF``), which agree to 1.3·10⁻¹¹ (Pleiades), 5·10⁻¹³ (Van der
Pol) and 2·10⁻¹³ relative (Robertson; the numbers are in the code); ``tests/test_ode_stiff.py`` checks
them against a fresh run (ORACLES A12).

References: Hairer, Nørsett & Wanner, *Solving ODEs I*, §II.10 (Pleiades); Hairer & Wanner, *Solving
ODEs II*, §IV.1 and §IV.10 (Van der Pol, Robertson); Robertson, "The solution of a set of reaction rate
equations", in *Numerical Analysis* (Walsh ed., 1966).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

import numpy as np

from ..errors import InvalidInput, check_positive

__all__ = ["IVP", "pleiades", "van_der_pol", "robertson"]


@dataclass(frozen=True)
class IVP:
    """An initial value problem with its analytic Jacobian and a reference state at ``t_end``."""

    name: str
    rhs: Callable
    jac: Callable
    y0: np.ndarray
    t_end: float
    y_ref: np.ndarray
    relative: bool = False     # error per component relative to |y_ref| (Robertson)

    def error(self, y) -> float:
        """The benchmark's error of a state y(t_end): max |y − y_ref| (relative per component if ``relative``)."""
        y = np.asarray(y, dtype=float)
        if y.shape != self.y_ref.shape:
            raise InvalidInput(f"y must be a state of shape {self.y_ref.shape} ({self.name}), got {y.shape}")
        d = np.abs(y - self.y_ref)
        return float(np.max(d / np.abs(self.y_ref) if self.relative else d))


_M = np.arange(1.0, 8.0)


def _pleiades_rhs(t, y):
    x, z = y[0:7], y[7:14]
    dx = x[None, :] - x[:, None]            # dx[i, j] = xⱼ − xᵢ
    dz = z[None, :] - z[:, None]
    r2 = dx * dx + dz * dz
    np.fill_diagonal(r2, np.inf)
    w = _M[None, :] / (r2 * np.sqrt(r2))
    return np.concatenate([y[14:], (w * dx).sum(axis=1), (w * dz).sum(axis=1)])


def _pleiades_jac(t, y):
    x, z = y[0:7], y[7:14]
    dx = x[None, :] - x[:, None]
    dz = z[None, :] - z[:, None]
    r2 = dx * dx + dz * dz
    np.fill_diagonal(r2, np.inf)
    r3 = r2 * np.sqrt(r2)
    r5 = r3 * r2
    m = _M[None, :]
    # ∂aᵢ/∂xⱼ for j ≠ i: mⱼ (I/r³ − 3 d dᵀ/r⁵); the diagonal block is minus the row sum
    axx, azz, axz = m * (1 / r3 - 3 * dx * dx / r5), m * (1 / r3 - 3 * dz * dz / r5), m * (-3 * dx * dz / r5)
    J = np.zeros((28, 28))
    J[:14, 14:] = np.eye(14)
    for B, (r, c) in ((axx, (14, 0)), (axz, (14, 7)), (axz, (21, 0)), (azz, (21, 7))):
        blk = B.copy()
        np.fill_diagonal(blk, -B.sum(axis=1))
        J[r:r + 7, c:c + 7] = blk
    return J


_pleiades_rhs.autonomous = True


def pleiades() -> IVP:
    """The Pleiades problem on [0, 3] (28 states: x, y positions then velocities of seven stars)."""
    y0 = np.concatenate([[3.0, 3.0, -1.0, -3.0, 2.0, -2.0, 2.0], [3.0, -3.0, 2.0, 0.0, 0.0, -4.0, 4.0],
                         [0.0, 0.0, 0.0, 0.0, 0.0, 1.75, -1.5], [0.0, 0.0, 0.0, -1.25, 1.0, 0.0, 0.0]])
    return IVP("Pleiades", _pleiades_rhs, _pleiades_jac, y0, 3.0, _PLEIADES_REF.copy())


def van_der_pol(mu: float = 1000.0) -> IVP:
    """Van der Pol ÿ − μ(1 − y²)ẏ + y = 0 from [2, 0] over [0, 3000] (reference for μ = 1000 only)."""
    mu = check_positive("mu", mu)

    def rhs(t, y):
        return np.array([y[1], mu * (1.0 - y[0] * y[0]) * y[1] - y[0]])

    def jac(t, y):
        return np.array([[0.0, 1.0], [-2.0 * mu * y[0] * y[1] - 1.0, mu * (1.0 - y[0] * y[0])]])

    rhs.autonomous = True
    ref = _VDP_REF.copy() if mu == 1000.0 else np.full(2, np.nan)
    return IVP(f"Van der Pol mu = {mu:g}", rhs, jac, np.array([2.0, 0.0]), 3000.0, ref)


def _robertson_rhs(t, y):
    a, b, c = y[0], y[1], y[2]
    r1, r2, r3 = 0.04 * a, 1e4 * b * c, 3e7 * b * b
    return np.array([r2 - r1, r1 - r2 - r3, r3])


def _robertson_jac(t, y):
    b, c = y[1], y[2]
    return np.array([[-0.04, 1e4 * c, 1e4 * b],
                     [0.04, -1e4 * c - 6e7 * b, -1e4 * b],
                     [0.0, 6e7 * b, 0.0]])


_robertson_rhs.autonomous = True


def robertson() -> IVP:
    """Robertson's kinetics from (1, 0, 0) over [0, 40]; error = max relative error per component."""
    return IVP("Robertson", _robertson_rhs, _robertson_jac, np.array([1.0, 0.0, 0.0]), 40.0,
               _ROBERTSON_REF.copy(), relative=True)


# reference states at t_end (see the module docstring). Pleiades: pbanim vern7 at rtol 1e-15; it agrees
# with pbanim dop853 (rtol 1e-15) to 7.0e-12 and scipy DOP853 (rtol 2.3e-14) to 6.1e-12. Van der Pol and
# Robertson: pbanim radau5 at rtol 1e-12 (atol 1e-15, 1e-22). Van der Pol: pbanim radau5 at 1e-11, scipy
# Radau at 1e-12 agree to 5e-14, pbanim rodas4 at 1e-11 to 5e-13, scipy LSODA at 1e-13 to 1.2e-11.
# Robertson (relative per component): pbanim radau5 at 1e-11 to 5e-15, rodas4 at 1e-11 to 2e-13, scipy
# LSODA and BDF at 1e-13 to 3e-12. (Radau runs at rtol 1e-13, pbanim's and scipy's alike, land ~1e-11
# off: the Newton stopping rule max(10ε/rtol, …) is loose there.)
_PLEIADES_REF = np.array([
    0.3706139143960403, 3.2372840920571693, -3.222559032418078, 0.6597091455774813, 0.3425581707153115,
    1.5621721014006753, -0.7003092922209689, -3.943437585518839, -3.271380973972578, 5.225081843457182,
    -2.5906124349775124, 1.198213693392481, -0.2429682344936064, 1.0914492404288094, 3.417003806311472,
    1.3545845016254956, -2.5900655978108316, 2.025053734714672, -1.1558151001623724, -0.8072988170221999,
    0.5952396354223347, -3.7412449612358567, 0.37734596857501584, 0.9386858869556609, 0.36679222272007367,
    -0.34740463538109007, 2.3449154481808914, -1.9470204342630595])
_VDP_REF = np.array([-1.5106069367441128, 0.001178380000730915])
_ROBERTSON_REF = np.array([0.7158270687194034, 9.185534764557802e-06, 0.2841637457458295])
