"""The result of S(t, u): the trajectory, its derivatives at the output times and its certificate (chapter 10).

:func:`pbanim.design.simulate` returns a :class:`Trajectory`: the states on the grid, S and ∂S/∂u at the
output times (positions, orientations in the tangent space δφ = 2 Ξ(q)ᵀ δq, velocities v, ω and their
derivatives), the impacts, the rests and the touches, and what can be trusted: ``differentiable`` and
``certified`` (see the class).

References: Popović et al. SIGGRAPH 2000 §4 (S(t, u) and ∂S/∂u).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..contracts import Index, Real, contract
from ..errors import InvalidInput
from ..rigid import quat_to_matrix
from .flight import FlightModel, omega_tangent, rotation_tangent

__all__ = ["Trajectory"]

_BODY = Index("self.N")
_TIME = Real()


@dataclass
class Trajectory:               # a record pbanim builds (simulate) and users read
    """S(t, u) on the grid, and ∂S/∂u at the output times, with its certificate.

    Attributes
    ----------
    t : (K,) grid times;  y : (K, 13N) states [x, q, P, L]
    outputs : dict time → (y, Φᵀ (p, 13N)) at the requested output times and the end
    impacts : list of Impact;  differentiable : bool (False: an impact grazed or came with another, a
        tangent touch, a rest on a turning plane — each said in ``notes``)
    names, N, model, nsteps
    flight : "exact" (closed-form sphere flight) or "rk4" — the path that computed it
    rests : list of Rest — spheres that came to rest on a plane (ORACLES D1: when, the speed dropped, the
        Zeno time); their rows of ∂S/∂u after that are the resting derivative (:mod:`pbanim.design.rest`)
    touches : list of Impact — tangent touches (no impulse, ``grazing``): S is not differentiable there
    clearance : the least gap over every recorded state and feature (the certificate, in scene units)
    certified : clearance ≥ −penetration_tol (False only for runs started with ``check_start=False``;
        otherwise a failed certificate is a :class:`~pbanim.design.PenetrationError`)
    """

    t: np.ndarray
    y: np.ndarray
    outputs: dict
    impacts: list
    names: list
    N: int
    model: FlightModel
    nsteps: int
    differentiable: bool = True
    notes: list = field(default_factory=list)
    flight: str = "rk4"
    rests: list = field(default_factory=list)
    touches: list = field(default_factory=list)
    clearance: float = np.inf
    certified: bool = True

    def _out(self, t):
        key = _key(t)
        if key not in self.outputs:
            raise InvalidInput(f"Trajectory: t must be an output time of this trajectory, one of "
                               f"{sorted(self.outputs)}, got {t!r}; pass it in simulate(times=...)")
        return self.outputs[key]

    def _body(self, i):            # the contract checked an outside call; inside callers pass checked goals
        return int(i)

    @contract(i=_BODY, t=_TIME)
    def position(self, i: int, t: float) -> np.ndarray:
        i = self._body(i)
        return self._out(t)[0][3 * i:3 * i + 3].copy()

    @contract(i=_BODY, t=_TIME)
    def orientation(self, i: int, t: float) -> np.ndarray:
        i, N = self._body(i), self.N
        return self._out(t)[0][3 * N + 4 * i:3 * N + 4 * i + 4].copy()

    @contract(i=_BODY, t=_TIME)
    def d_position(self, i: int, t: float) -> np.ndarray:
        """∂x_i(t)/∂u, shape (3, p)."""
        i = self._body(i)
        return self._sens(t)[:, 3 * i:3 * i + 3].T.copy()

    @contract(i=_BODY, t=_TIME)
    def d_orientation(self, i: int, t: float) -> np.ndarray:
        """∂φ_i(t)/∂u (3, p): the world rotation vector of δq, δφ = 2 Ξ(q)ᵀ δq / |q|²."""
        i, N = self._body(i), self.N
        y, T = self._out(t)[0], self._sens(t)
        q = y[3 * N + 4 * i:3 * N + 4 * i + 4]
        return rotation_tangent(q[None], T[:, None, 3 * N + 4 * i:3 * N + 4 * i + 4])[:, 0].T

    @contract(i=_BODY, t=_TIME)
    def velocities(self, i: int, t: float) -> tuple[np.ndarray, np.ndarray]:
        """(v_i, ω_i) at an output time."""
        i, N, m = self._body(i), self.N, self.model
        y = self._out(t)[0]
        R = quat_to_matrix(y[3 * N + 4 * i:3 * N + 4 * i + 4])
        L = y[10 * N + 3 * i:10 * N + 3 * i + 3]
        return m.W[i] * y[7 * N + 3 * i:7 * N + 3 * i + 3], R @ (m.Iinv[i] * (R.T @ L))

    @contract(i=_BODY, t=_TIME)
    def d_velocities(self, i: int, t: float) -> tuple[np.ndarray, np.ndarray]:
        """(∂v_i/∂u, ∂ω_i/∂u), each (3, p)."""
        i, N, m = self._body(i), self.N, self.model
        y, T = self._out(t)[0], self._sens(t)
        q, P, L = y[3 * N + 4 * i:3 * N + 4 * i + 4], y[7 * N + 3 * i:7 * N + 3 * i + 3], y[10 * N + 3 * i:10 * N + 3 * i + 3]
        R = quat_to_matrix(q)
        Lb = R.T @ L
        w = R @ (m.Iinv[i] * Lb)
        dphi = self.d_orientation(i, t).T
        sub = FlightModel(1, m.W[i:i + 1], m.m[i:i + 1], m.Iinv[i:i + 1], m.g, m.dW[:, i:i + 1], m.dm[:, i:i + 1],
                          m.dIinv[:, i:i + 1])
        dw = omega_tangent(sub, R[None], L[None], Lb[None], w[None], dphi[:, None], T[:, None, 10 * N + 3 * i:10 * N + 3 * i + 3])[:, 0]
        dv = m.W[i] * T[:, 7 * N + 3 * i:7 * N + 3 * i + 3] + m.dW[:, i:i + 1] * P[None]
        return dv.T, dw.T

    def _sens(self, t):
        T = self._out(t)[1]
        if T is None:
            raise InvalidInput("this trajectory was simulated with sensitivities=False; no ∂S/∂u to give")
        return T

    @contract(i=_BODY)
    def positions(self, i: int) -> np.ndarray:
        """x_i on the whole grid, (K, 3)."""
        i = self._body(i)
        return self.y[:, 3 * i:3 * i + 3]


def _key(t) -> float:
    return round(float(t), 12)
