"""Free flight and its variational equations (chapter 10, part of :mod:`pbanim.design`).

Between impacts each body obeys the deck's free-flight equations in Baraff's state q = (x, r, mv, Iω)
(here y = [x, q, P, L], P = mv, L = Iω, quaternion q = r):

    ẋ = W P,   q̇ = ½ (0, ω) ⊗ q = ½ Ξ(q) ω,   Ṗ = m g,   L̇ = 0,   ω = R I⁻¹ Rᵀ L,

and the sensitivities Φ = ∂y/∂u obey the variational equations Φ̇ = (∂f/∂y) Φ + ∂f/∂u. Written for one
tangent column δy (the code carries all p columns at once, as rows of T = Φᵀ):

    δẋ = W δP + δW P,      δṖ = δm g,      δL̇ = 0,
    δq̇ = ½ Ξ(q) δω + ½ (0, ω) ⊗ δq,
    δω = δφ × ω − I_w⁻¹ (δφ × L) + I_w⁻¹ δL + R (δI⁻¹ ∘ Rᵀ L),    δφ = 2 Ξ(q)ᵀ δq / |q|²,

where δφ is the world rotation vector of δq (δR = [δφ]× R; the radial part of δq does not rotate).
Integrating the pair (y, Φ) with the same Runge–Kutta step differentiates the discrete flow exactly
(RK methods commute with linearization), so Φ agrees with finite differences of the computed S to the
finite-difference error, not to the integration error (ORACLES H2, H3).

The unit norm: after every step q ← q/|q| and, to stay the derivative of that map, δq ← (𝟙 − q̂q̂ᵀ)δq/|q|,
so every tangent column is tangent to the unit sphere (q̂·δq = 0).

==========  ==============  ============  =====================================================
symbol      code            shape         meaning
==========  ==============  ============  =====================================================
y           ``y``           (13N,)        [x (3N), q (4N), P (3N), L (3N)] (Baraff's layout)
Φᵀ          ``T``           (p, 13N)      one row per parameter: ∂y/∂u_k
W, m        ``W, m``        (N,)          inverse mass, mass
I⁻¹         ``Iinv``        (N, 3)        inverse principal moments (body frame)
δW, δm      ``dW, dm``      (p, N)        ∂W/∂u, ∂m/∂u (mass parameters)
δI⁻¹        ``dIinv``       (p, N, 3)     ∂I⁻¹/∂u (inertia parameters)
==========  ==============  ============  =====================================================

Limiting cases: a sphere (I ∝ 𝟙) has δω = I⁻¹δL (rotations commute with it); with ω = 0 the
orientation rows never change; with g = 0 and no mass parameter, Φ_x(t) = Φ_x(0) + t W Φ_P(0).

References: Popović et al. SIGGRAPH 2000 §4 (derivatives by integrating the variational equations with
the state); Hairer, Nørsett & Wanner, *Solving ODEs I*, §I.14 (variational equations) and §II.4 (RK
methods and linearization); Baraff, SIGGRAPH 1997 notes (the state and q̇ = ½ ω q).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..contracts import Array, Int, Obj, Real, contract, finite_result
from ..ode import rk4_step
from ..geometry import skew
from ..rigid import quat_to_matrix
from .scene import xi
from .specs import DesignState

__all__ = ["FlightModel", "flight_rhs", "flight_tangent", "augmented_step", "plain_step", "normalize",
           "step_rate", "flight_jacobian", "flight_tangent_readable"]


def _p(env) -> int:
    """p, the rows of dW (a shape entry: a reference, since a shape cannot mix symbols and references)."""
    return int(np.shape(env.values["dW"])[0])


@contract(N=Int(ge=1), W=Array(("$N",), gt=0), m=Array(("$N",), gt=0), Iinv=Array(("$N", 3), gt=0), g=Array((3,)),
          dW=Array((None, "$N"), empty=True), dm=Array((_p, "$N"), empty=True), dIinv=Array((_p, "$N", 3), empty=True))
@dataclass
class FlightModel:
    """The constants of free flight for one evaluation of S(t, u) and their parameter derivatives (W = 1/m
    is the caller's to keep; the flight reads both)."""

    N: int
    W: np.ndarray
    m: np.ndarray
    Iinv: np.ndarray
    g: np.ndarray
    dW: np.ndarray       # (p, N)
    dm: np.ndarray       # (p, N)
    dIinv: np.ndarray    # (p, N, 3)

    lean_path = True    # False: augmented_step runs the readable step (not pbanim.design.lean_tangent's)

    @property
    def n_state(self) -> int:
        """Length of a state y = [x, q, P, L]: 13N."""
        return 13 * self.N

    @property
    def n_params(self) -> int:
        """p, the number of parameters whose tangents the model carries (rows of T)."""
        return int(self.dW.shape[0])


_EYE3 = np.eye(3)


def _split(y: np.ndarray, N: int):
    return (y[:3 * N].reshape(N, 3), y[3 * N:7 * N].reshape(N, 4), y[7 * N:10 * N].reshape(N, 3),
            y[10 * N:13 * N].reshape(N, 3))


def _omega(R, Iinv, L):
    Lb = np.einsum("nji,nj->ni", R, L)          # Rᵀ L
    return np.einsum("nij,nj->ni", R, Iinv * Lb), Lb


def _cross(a, b):
    """a × b on the last axis for arrays of equal trailing shape 3 (broadcasting, no shape checks)."""
    a0, a1, a2 = a[..., 0], a[..., 1], a[..., 2]
    b0, b1, b2 = b[..., 0], b[..., 1], b[..., 2]
    return np.stack([a1 * b2 - a2 * b1, a2 * b0 - a0 * b2, a0 * b1 - a1 * b0], axis=-1)


def _qdot(q, w):
    """½ (0, ω) ⊗ q = ½ Ξ(q) ω for rows q (..., 4), w (..., 3): (−ω·v, s ω + ω × v)/2 with q = (s, v)."""
    v = q[..., 1:]
    return 0.5 * np.concatenate([-np.sum(w * v, axis=-1, keepdims=True), q[..., :1] * w + _cross(w, v)], axis=-1)


_MODEL = Obj(FlightModel)
_TANGENTS = Array(("model.n_params", "model.n_state"), empty=True)


@contract(model=_MODEL, y=DesignState(), returns=finite_result)
def flight_rhs(model: FlightModel, y: np.ndarray) -> np.ndarray:
    """f(y): the free-flight derivative of the state (same numbers as ``RigidBodies.derivative`` with gravity)."""
    N = model.N
    x, q, P, L = _split(y, N)
    R = quat_to_matrix(q)
    w, _ = _omega(R, model.Iinv, L)
    return np.concatenate([(model.W[:, None] * P).ravel(), _qdot(q, w).ravel(),
                           (model.m[:, None] * model.g).ravel(), np.zeros(3 * N)])


def rotation_tangent(q: np.ndarray, Tq: np.ndarray) -> np.ndarray:
    """δφ = 2 Ξ(q)ᵀ δq / |q|² = 2 (s δv − δs v + v × δv)/|q|² for tangent rows Tq (p, N, 4) → (p, N, 3)."""
    v, sc = q[None, :, 1:], q[None, :, :1]
    dv, ds = Tq[..., 1:], Tq[..., :1]
    return 2.0 * (sc * dv - ds * v + _cross(v, dv)) / np.sum(q * q, axis=-1)[None, :, None]


def omega_tangent(model: FlightModel, R, L, Lb, w, dphi, TL) -> np.ndarray:
    """δω (p, N, 3) from δφ, δL and the inertia parameters (see the module docstring)."""
    Iw_inv = np.einsum("nij,nj,nkj->nik", R, model.Iinv, R)
    dw = _cross(dphi, w[None]) + np.einsum("nij,pnj->pni", Iw_inv, TL - _cross(dphi, L[None]))
    if np.any(model.dIinv):
        dw += np.einsum("nij,pnj->pni", R, model.dIinv * Lb[None])
    return dw


def _blocks(q, R, w, L, Iinv):
    """(Ξ(q), ∂q̇/∂q (n, 4, 4), ∂q̇/∂L (n, 4, 3)) of n bodies, or of n stages of one body (rows of q, R, ω, L,
    I⁻¹): the per-body blocks of :func:`flight_jacobian`."""
    n = q.shape[0]
    X = xi(q)
    Iw_inv = np.matmul(R * Iinv[:, None, :], np.swapaxes(R, 1, 2))
    Sw, SL = skew(np.concatenate([w, L])).reshape(2, n, 3, 3)
    Dw_q = np.matmul(np.matmul(Iw_inv, SL) - Sw, np.swapaxes(X, 1, 2)) * (2.0 / np.sum(q * q, axis=1))[:, None, None]
    Om = np.empty((n, 4, 4))
    Om[:, 0, 0] = 0.0
    Om[:, 0, 1:], Om[:, 1:, 0], Om[:, 1:, 1:] = -w, w, Sw
    return X, 0.5 * (np.matmul(X, Dw_q) + Om), 0.5 * np.matmul(X, Iw_inv)


def flight_jacobian(model: FlightModel, y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(f(y), ∂f/∂y (13N, 13N)): the matrix of the variational equations, assembled per body.

    With δφ = (2/|q|²) Ξᵀ δq:  ∂ω/∂q = (−[ω]× + I_w⁻¹[L]×)(2/|q|²)Ξᵀ,  ∂ω/∂L = I_w⁻¹,
    ∂q̇/∂q = ½ Ξ ∂ω/∂q + ½ Ω(ω) (Ω(ω)q = (0, ω) ⊗ q),  ∂q̇/∂L = ½ Ξ I_w⁻¹,  ∂ẋ/∂P = W 𝟙.
    """
    N = model.N
    x, q, P, L = _split(y, N)
    R = quat_to_matrix(q)
    w, Lb = _omega(R, model.Iinv, L)
    f = np.concatenate([(model.W[:, None] * P).ravel(), _qdot(q, w).ravel(),
                        (model.m[:, None] * model.g).ravel(), np.zeros(3 * N)])
    X, Aqq, AqL = _blocks(q, R, w, L, model.Iinv)
    A = np.zeros((13 * N, 13 * N))
    for i in range(N):
        A[3 * i:3 * i + 3, 7 * N + 3 * i:7 * N + 3 * i + 3] = model.W[i] * _EYE3
        A[3 * N + 4 * i:3 * N + 4 * i + 4, 3 * N + 4 * i:3 * N + 4 * i + 4] = Aqq[i]
        A[3 * N + 4 * i:3 * N + 4 * i + 4, 10 * N + 3 * i:10 * N + 3 * i + 3] = AqL[i]
    return f, A, (R, X, Lb, P)


@contract(model=_MODEL, y=DesignState(), T=_TANGENTS, returns=finite_result)
def flight_tangent(model: FlightModel, y: np.ndarray, T: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(f(y), Ṫ): the state derivative and the variational equations Ṫ = T (∂f/∂y)ᵀ + ∂f/∂u for the
    tangent rows T (p, 13N) (the formulas of the module docstring, as one matrix)."""
    N, p = model.N, T.shape[0]
    f, A, (R, X, Lb, P) = flight_jacobian(model, y)
    dT = T @ A.T
    if np.any(model.dW):
        dT[:, :3 * N] += (model.dW[:, :, None] * P[None]).reshape(p, 3 * N)
        dT[:, 7 * N:10 * N] += (model.dm[:, :, None] * model.g).reshape(p, 3 * N)
    if np.any(model.dIinv):
        dw = np.einsum("nij,pnj->pni", R, model.dIinv * Lb[None])            # R (δI⁻¹ ∘ Rᵀ L)
        dT[:, 3 * N:7 * N] += 0.5 * np.einsum("nki,pni->pnk", X, dw).reshape(p, 4 * N)
    return f, dT


def flight_tangent_readable(model: FlightModel, y: np.ndarray, T: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The same as :func:`flight_tangent`, column by column in the module docstring's δ-formulas (the
    readable version, tested against the matrix one)."""
    N, p = model.N, T.shape[0]
    x, q, P, L = _split(y, N)
    R = quat_to_matrix(q)
    w, Lb = _omega(R, model.Iinv, L)
    f = flight_rhs(model, y)
    Tq = T[:, 3 * N:7 * N].reshape(p, N, 4)
    TP = T[:, 7 * N:10 * N].reshape(p, N, 3)
    TL = T[:, 10 * N:].reshape(p, N, 3)
    dphi = rotation_tangent(q, Tq)
    dw = omega_tangent(model, R, L, Lb, w, dphi, TL)
    dT = np.zeros_like(T)
    dT[:, :3 * N] = (model.W[None, :, None] * TP + model.dW[:, :, None] * P[None]).reshape(p, 3 * N)
    dT[:, 3 * N:7 * N] = (_qdot(q[None], dw) + _qdot(Tq, w[None])).reshape(p, 4 * N)
    dT[:, 7 * N:10 * N] = (model.dm[:, :, None] * model.g).reshape(p, 3 * N)
    return f, dT


def normalize(y: np.ndarray, T: np.ndarray | None, N: int):
    """q ← q/|q| and δq ← (𝟙 − q̂q̂ᵀ) δq/|q| (in place); returns (y, T)."""
    q = y[3 * N:7 * N].reshape(N, 4)
    n = np.sqrt(np.sum(q * q, axis=1))
    q /= n[:, None]
    if T is not None and T.size:
        Tq = T[:, 3 * N:7 * N].reshape(T.shape[0], N, 4)
        Tq -= q[None] * np.einsum("nk,pnk->pn", q, Tq)[:, :, None]
        Tq /= n[None, :, None]
    return y, T


def plain_step(model: FlightModel, y: np.ndarray, h: float) -> np.ndarray:
    """One RK4 step of the state alone (event location, finite differences); one body's f on floats
    (:mod:`~pbanim.design.lean_flight`, the same products in the same order)."""
    from .lean_flight import one_body_rhs

    f = one_body_rhs(model) or (lambda t, yy: flight_rhs(model, yy))
    y1 = rk4_step(f, 0.0, y, h)
    return normalize(y1, None, model.N)[0]


@contract(model=_MODEL, y=DesignState(), T=_TANGENTS, h=Real(ge=0), returns=finite_result)
def augmented_step(model: FlightModel, y: np.ndarray, T: np.ndarray, h: float):
    """One RK4 step of (y, Φᵀ) together, then the unit-norm projection: the exact derivative of
    :func:`plain_step` (the same stages, linearized). One body takes the lean twin
    (:mod:`~pbanim.design.lean_tangent`: the same state bit for bit, Φᵀ to roundoff); ``model.lean_path = False``
    runs this readable step."""
    if model.lean_path:
        from .lean_tangent import one_body_augmented

        lean = one_body_augmented(model)
        if lean is not None:
            return lean(y, T, h)
    n, p = y.size, T.shape[0]

    def fun(t, Y):
        f, dT = flight_tangent(model, Y[:n], Y[n:].reshape(p, n))
        return np.concatenate([f, dT.ravel()])

    Y1 = rk4_step(fun, 0.0, np.concatenate([y, T.ravel()]), h)
    return normalize(Y1[:n].copy(), Y1[n:].reshape(p, n).copy(), model.N)


def _jvp(model: FlightModel, y: np.ndarray, w: np.ndarray) -> np.ndarray:
    """(∂f/∂y) w: the variational right-hand side for one state direction, without parameter terms."""
    z = FlightModel(model.N, model.W, model.m, model.Iinv, model.g, np.zeros((1, model.N)), np.zeros((1, model.N)),
                    np.zeros((1, model.N, 3)))
    return flight_tangent(z, y, w[None])[1][0]


def step_rate(model: FlightModel, y: np.ndarray, h: float) -> np.ndarray:
    """d/dh of :func:`plain_step` (the RK4 step and its normalization) at step length h.

    The event time τ moves the end of a partial step, so the exact derivative of the computed S uses
    this rate where the continuous theory has f(y(τ)) (they differ by O(h⁴)). With the stages
    Y₂ = y + h/2 k₁, Y₃ = y + h/2 k₂, Y₄ = y + h k₃ and kᵢ = f(Yᵢ):

        dy₁/dh = (k₁ + 2k₂ + 2k₃ + k₄)/6 + h (2k₂' + 2k₃' + k₄')/6,
        k₂' = f'(Y₂) k₁/2,  k₃' = f'(Y₃)(k₂ + h k₂')/2,  k₄' = f'(Y₄)(k₃ + h k₃').
    """
    f = lambda yy: flight_rhs(model, yy)  # noqa: E731
    k1 = f(y)
    Y2 = y + 0.5 * h * k1
    k2 = f(Y2)
    Y3 = y + 0.5 * h * k2
    k3 = f(Y3)
    Y4 = y + h * k3
    k4 = f(Y4)
    d2 = _jvp(model, Y2, 0.5 * k1)
    d3 = _jvp(model, Y3, 0.5 * (k2 + h * d2))
    d4 = _jvp(model, Y4, k3 + h * d3)
    y1 = y + h / 6.0 * (k1 + 2 * k2 + 2 * k3 + k4)
    rate = (k1 + 2 * k2 + 2 * k3 + k4) / 6.0 + h / 6.0 * (2 * d2 + 2 * d3 + d4)
    N = model.N
    return normalize(y1, rate[None].copy(), N)[1][0]
