"""The lean twin of one body's augmented flight step (chapter 10; part of :mod:`pbanim.design`): one RK4 step
of the state y and its tangent rows T = Φᵀ together (:func:`pbanim.design.flight.augmented_step`, the step of
every analytic ∂S/∂u) without the (13N, 13N) matrix of the variational equations.

The readable step evaluates (f, Ṫ) four times, each time assembling ∂f/∂y as a 13 × 13 matrix (one body) and
forming Ṫ = T (∂f/∂y)ᵀ + ∂f/∂u. For one body only two blocks of that matrix are not zero,

    δẋ = W δP,   δq̇ = δq Aqqᵀ + δL AqLᵀ,   δṖ = δL̇ = 0,
    Aqq = ½ (Ξ (I_w⁻¹[L]× − [ω]×) Ξᵀ 2/|q|² + Ω(ω)),   AqL = ½ Ξ I_w⁻¹,

plus the parameter terms ∂f/∂u (δW P on δẋ, δm g on δṖ, ½ Ξ R (δI⁻¹ ∘ Rᵀ L) on δq̇). The state's stages do
not depend on T, so the lean step runs them first — the readable RK4 (:func:`pbanim.ode.rk4_step`) on the
one-body f on floats (:mod:`~pbanim.design.lean_flight`), the very step of
:func:`~pbanim.design.flight.plain_step` — then builds the blocks of the four stage states at once (the
readable formulas, :func:`pbanim.design.flight._blocks`, on four rows) and runs the same RK4 on T with one
(p, 13) × (13, 4) product per stage. The stage sums and the normalization are the readable ones, so y₁ is
the readable state bit for bit (f on floats is the readable f on this build, ORACLES H10) and T₁ differs
from the readable one only by the order in which the seven products of each δq̇ entry are summed: a few
ulps of the terms per stage (ORACLES H12).

==========  ==============  ============  =====================================================
symbol      code            shape         meaning
==========  ==============  ============  =====================================================
y           ``y``           (13,)         [x, q, P, L] of the one body
Φᵀ          ``T``           (p, 13)       tangent rows, one per parameter
Aqqᵀ, AqLᵀ  ``M``           (4, 13, 4)    the stages' δq̇ columns of (∂f/∂y)ᵀ (zero rows elsewhere)
∂f/∂u       ``E``           (4, p, 13)    the stages' parameter terms (None without mass or inertia parameters)
==========  ==============  ============  =====================================================

Limiting cases: ω = 0 gives Aqq = 0 (δq moves only by δL); with no mass or inertia parameter ∂f/∂u = 0 and
the rows of x and P move as W δP and not at all.

References: Popović et al. SIGGRAPH 2000 §4 (variational equations carried with the state); Hairer, Nørsett &
Wanner I, §II.4 (RK methods and linearization commute); Baraff, SIGGRAPH 1997 notes (q̇ = ½ ω q).
"""

from __future__ import annotations

import numpy as np

from ..ode import rk4_step
from ..rigid import quat_to_matrix
from .flight import _blocks, _omega, normalize
from .lean_flight import one_body_rhs

__all__: list = []


def one_body_augmented(model):
    """step(y, T, h) → (y₁, T₁) of :func:`~pbanim.design.flight.augmented_step` for a one-body model (module
    docstring), made once per model and kept on it; None when the model has more than one body."""
    if model.N != 1:
        return None
    step = model.__dict__.get("_lean_augmented")
    if step is None:
        step = model.__dict__["_lean_augmented"] = _make_step(model, one_body_rhs(model))
    return step


def _make_step(model, f):
    W = float(model.W[0])
    Iinv4 = np.repeat(model.Iinv, 4, axis=0)
    p = model.n_params
    mass, inertia = bool(np.any(model.dW)), bool(np.any(model.dIinv))
    dW = model.dW[:, 0]
    dmg = (model.dm[:, :, None] * model.g).reshape(p, 3)
    dI = model.dIinv[:, 0]

    def step(y, T, h):
        ys = []

        def rec(t, yy):
            ys.append(yy)
            return f(t, yy)

        y1 = rk4_step(rec, 0.0, y, h)                      # the state: plain_step's stages, bit for bit
        S = np.array(ys)                                   # the four stage states (4, 13)
        q, L = S[:, 3:7], S[:, 10:]
        R = quat_to_matrix(q)
        w, Lb = _omega(R, Iinv4, L)
        X, Aqq, AqL = _blocks(q, R, w, L, Iinv4)
        M = np.zeros((4, 13, 4))
        M[:, 3:7], M[:, 10:] = np.swapaxes(Aqq, 1, 2), np.swapaxes(AqL, 1, 2)
        E = None
        if mass or inertia:
            E = np.zeros((4, p, 13))
            if mass:
                E[:, :, :3] = dW[None, :, None] * S[:, None, 7:10]
                E[:, :, 7:10] = dmg
            if inertia:
                dw = np.einsum("sij,psj->spi", R, dI[:, None, :] * Lb[None])      # R (δI⁻¹ ∘ Rᵀ L)
                E[:, :, 3:7] = 0.5 * np.einsum("ski,spi->spk", X, dw)
        stage = iter(range(4))

        def tangent(t, Z):
            i = next(stage)
            K = np.empty_like(Z)
            K[:, :3] = W * Z[:, 7:10]
            K[:, 3:7] = Z @ M[i]
            K[:, 7:] = 0.0
            if E is not None:
                K += E[i]
            return K

        T1 = rk4_step(tangent, 0.0, T, h)
        return normalize(y1, T1, 1)

    return step
