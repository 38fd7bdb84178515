"""The Baraff–Witkin bend condition: C = θ − θ₀, the dihedral angle across an edge shared by two triangles.

A hinge is the edge (x₀, x₁) and the two opposite vertices x₂, x₃. With the edge vectors

    e = x₁ − x₀,   a = x₂ − x₀,   b = x₃ − x₀,
    n₁ = a × e,   n₂ = e × b       (the two area-weighted normals, equal when the hinge is flat),

Baraff & Witkin define θ by sin θ = (n̂₁ × n̂₂)·ê and cos θ = n̂₁·n̂₂. Both are ratios with the positive factor
|n₁||n₂|, and the identities (a × e)·(e × b) = (e·a)(e·b) − (a·b)(e·e) and (a × e) × (e × b) = T e with
T = a·(e × b) = det[a, e, b] give θ from inner products alone:

    θ = atan2(S, Cc),     S = T |e|,     Cc = (e·a)(e·b) − (a·b)(e·e).

That makes the derivatives short. In the nine coordinates z = (e, a, b), with R = S² + Cc²,

    ∇θ = (Cc ∇S − S ∇Cc)/R,
    ∇²θ = (Cc ∇²S − S ∇²Cc + ∇S ∇Ccᵀ − ∇Cc ∇Sᵀ)/R − ∇θ (2S ∇S + 2Cc ∇Cc)ᵀ/R,

where ∇T = (b × a, e × b, a × e), ∇²T is made of the skew blocks ±[a]×, ±[b]×, ±[e]×, ∇|e| = (ê, 0, 0),
∇²|e| = (I − êêᵀ)/|e| in the (e, e) block, ∇S = |e|∇T + T∇|e|, ∇²S = |e|∇²T + T∇²|e| + ∇T∇|e|ᵀ + ∇|e|∇Tᵀ,
∇Cc = (a(e·b) + b(e·a) − 2(a·b)e, e(e·b) − b(e·e), e(e·a) − a(e·e)), and ∇²Cc has the blocks
(e, e): abᵀ + baᵀ − 2(a·b)I, (e, a): (e·b)I + beᵀ − 2ebᵀ, (e, b): (e·a)I + aeᵀ − 2eaᵀ, (a, b): eeᵀ − (e·e)I.
The map to the particles is linear, z = L x with L = [[−1, 1, 0, 0], [−1, 0, 1, 0], [−1, 0, 0, 1]] ⊗ I₃, so
∂C/∂x = Lᵀ∇θ and ∂²C/∂x² = Lᵀ ∇²θ L. The readable version (:func:`pbanim.cloth.readable.bend_gradient`) uses
Bridson, Marino & Fedkiw's closed form of ∂θ/∂x instead; the tests check that the two agree and that the
Hessian matches finite differences of the gradient (ORACLES J1).

Limiting cases: a flat hinge (T = 0, Cc > 0) has θ = 0; folding x₃ onto x₂ sends θ → ±π (where atan2 jumps:
cloth never gets there under a bend stiffness); a degenerate triangle (n₁ = 0) has no angle (R = 0: NaN,
named by the finiteness checks of the callers).

References: D. Baraff, A. Witkin, "Large steps in cloth simulation", SIGGRAPH 1998, §4.3 (bend condition);
R. Bridson, S. Marino, R. Fedkiw, "Simulation of clothing with folds and wrinkles", SCA 2003, §4 (∂θ/∂x);
R. Tamstorf, E. Grinspun, "Discrete bending forces and their Jacobians", Graphical Models 75, 2013.
"""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np

from .conditions import Conditions

__all__ = ["BendCondition", "hinge_angles"]

_LC = np.array([[-1.0, 1.0, 0.0, 0.0], [-1.0, 0.0, 1.0, 0.0], [-1.0, 0.0, 0.0, 1.0]])
_L = np.kron(_LC, np.eye(3))                                 # (9, 12): z = L x
_I3 = np.eye(3)


def _skew(w):
    """[w]× (E, 3, 3): [w]× u = w × u."""
    S = np.zeros(w.shape[:-1] + (3, 3))
    S[..., 0, 1], S[..., 0, 2], S[..., 1, 2] = -w[..., 2], w[..., 1], -w[..., 0]
    S[..., 1, 0], S[..., 2, 0], S[..., 2, 1] = w[..., 2], -w[..., 1], w[..., 0]
    return S


def _outer(p, q):
    return p[:, :, None] * q[:, None, :]


def _hinge_gradient(X):
    """θ = atan2(S, Cc) and ∇θ in z = (e, a, b) for hinge vertices X (E, 4, 3), with the pieces both the readable
    ∇²θ and the lean edge-coordinate terms (:mod:`.lean_terms`) build on: e, a, b; ee, ea, eb, ab (their dot
    products); T = a·(e × b), r = |e|, S = T r, Cc = (e·a)(e·b) − (a·b)(e·e); ê; ∇T, ∇|e| = (ê, 0, 0), ∇S, ∇Cc;
    R = S² + Cc²; ∇θ = (Cc ∇S − S ∇Cc)/R. A namespace of arrays (E,) or (E, 3) or (E, 9)."""
    e, a, b = X[:, 1] - X[:, 0], X[:, 2] - X[:, 0], X[:, 3] - X[:, 0]
    dot = lambda p, q: np.einsum("ij,ij->i", p, q)  # noqa: E731
    ee, ea, eb, ab = dot(e, e), dot(e, a), dot(e, b), dot(a, b)
    T = dot(a, np.cross(e, b))
    r = np.sqrt(ee)
    S, Cc = T * r, ea * eb - ab * ee
    theta = np.arctan2(S, Cc)
    with np.errstate(divide="ignore", invalid="ignore"):
        ehat = e / r[:, None]
        gT = np.concatenate([np.cross(b, a), np.cross(e, b), np.cross(a, e)], axis=1)
        gr = np.concatenate([ehat, np.zeros((len(X), 6))], axis=1)
        gS = r[:, None] * gT + T[:, None] * gr
        gC = np.concatenate([a * eb[:, None] + b * ea[:, None] - 2.0 * ab[:, None] * e,
                             e * eb[:, None] - b * ee[:, None], e * ea[:, None] - a * ee[:, None]], axis=1)
        R = S * S + Cc * Cc
        g = (Cc[:, None] * gS - S[:, None] * gC) / R[:, None]
    return SimpleNamespace(e=e, a=a, b=b, ee=ee, ea=ea, eb=eb, ab=ab, T=T, r=r, S=S, Cc=Cc, theta=theta, ehat=ehat,
                           gT=gT, gr=gr, gS=gS, gC=gC, R=R, g=g)


def _angle_terms(X, hessian=True):
    """θ (E,), ∇θ (E, 9) and ∇²θ (E, 9, 9) in z = (e, a, b) for hinge vertices X (E, 4, 3)."""
    h = _hinge_gradient(X)
    theta, g = h.theta, h.g
    if not hessian:
        return theta, g, None
    e, a, b, ee, ea, eb, ab, T, r, S, Cc = h.e, h.a, h.b, h.ee, h.ea, h.eb, h.ab, h.T, h.r, h.S, h.Cc
    ehat, gT, gr, gS, gC, R, E = h.ehat, h.gT, h.gr, h.gS, h.gC, h.R, len(X)
    HT = np.zeros((E, 3, 3, 3, 3))                           # (E, row block, 3, col block, 3) over (e, a, b)
    Ka, Kb, Ke = _skew(a), _skew(b), _skew(e)
    HT[:, 0, :, 1, :], HT[:, 0, :, 2, :] = Kb, -Ka           # ∂(b × a)/∂a = [b]×, ∂(b × a)/∂b = −[a]×
    HT[:, 1, :, 0, :], HT[:, 1, :, 2, :] = -Kb, Ke           # ∂(e × b)/∂e = −[b]×, ∂(e × b)/∂b = [e]×
    HT[:, 2, :, 0, :], HT[:, 2, :, 1, :] = Ka, -Ke           # ∂(a × e)/∂e = [a]×, ∂(a × e)/∂a = −[e]×
    HC = np.zeros((E, 3, 3, 3, 3))
    HC[:, 0, :, 0, :] = _outer(a, b) + _outer(b, a) - 2.0 * ab[:, None, None] * _I3
    HC[:, 0, :, 1, :] = eb[:, None, None] * _I3 + _outer(b, e) - 2.0 * _outer(e, b)
    HC[:, 0, :, 2, :] = ea[:, None, None] * _I3 + _outer(a, e) - 2.0 * _outer(e, a)
    HC[:, 1, :, 2, :] = _outer(e, e) - ee[:, None, None] * _I3
    HC[:, 1, :, 0, :] = HC[:, 0, :, 1, :].transpose(0, 2, 1)
    HC[:, 2, :, 0, :] = HC[:, 0, :, 2, :].transpose(0, 2, 1)
    HC[:, 2, :, 1, :] = HC[:, 1, :, 2, :].transpose(0, 2, 1)
    HT, HC = HT.reshape(E, 9, 9), HC.reshape(E, 9, 9)
    with np.errstate(divide="ignore", invalid="ignore"):
        Hr = np.zeros((E, 9, 9))
        Hr[:, :3, :3] = (_I3 - _outer(ehat, ehat)) / r[:, None, None]
        HS = r[:, None, None] * HT + T[:, None, None] * Hr + _outer(gT, gr) + _outer(gr, gT)
        H = (Cc[:, None, None] * HS - S[:, None, None] * HC + _outer(gS, gC) - _outer(gC, gS)) / R[:, None, None]
        H -= _outer(g, 2.0 * (S[:, None] * gS + Cc[:, None] * gC)) / R[:, None, None]
    return theta, g, H


def hinge_angles(x, hinges) -> np.ndarray:
    """Dihedral angles θ (H,) of the hinges (H, 4) at positions x (N, 3) (0 for a flat hinge)."""
    return _angle_terms(np.asarray(x, dtype=float)[np.asarray(hinges, dtype=np.intp)], hessian=False)[0]


class BendCondition(Conditions):
    """C = θ − θ₀ per hinge (edge x₀x₁, opposite x₂, x₃), θ₀ the angle at the rest positions (module docstring).

    ``k`` (N·m per rad²) and ``kd`` (N·m·s) per hinge; the energy is ½ k (θ − θ₀)².
    """

    kind, nv, m = "bend", 4, 1

    def __init__(self, hinges, x_rest, k, kd) -> None:
        super().__init__(hinges, np.reshape(k, (-1, 1)) if np.ndim(k) else k,
                         np.reshape(kd, (-1, 1)) if np.ndim(kd) else kd)
        self.theta0 = hinge_angles(x_rest, self.elements) if len(self) else np.zeros(0)

    def evaluate(self, x, sel=None, hessian=True):
        el, theta0 = (self.elements, self.theta0) if sel is None else (self.elements[sel], self.theta0[sel])
        theta, g, H = _angle_terms(x[el], hessian)
        G = g @ _L
        return (theta - theta0)[:, None], G[:, None, :], None if H is None else (_L.T @ H @ _L)[:, None]
