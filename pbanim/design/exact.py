"""Exact free flight of spheres: the closed-form flight map, its sensitivities and its impact times (chapter 10).

When every body is a sphere with an isotropic inertia I = I_s 𝟙 and the only force is gravity, the
deck's free-flight equations (ẋ = W P, Ṗ = m g, L̇ = 0, q̇ = ½ (0, ω) ⊗ q, ω = L/I_s) integrate in
closed form over a flight of length τ:

    x(τ) = x₀ + W P₀ τ + ½ g τ²,   P(τ) = P₀ + m g τ,   L(τ) = L₀,   q(τ) = exp(½ ω τ) ⊗ q₀,

and so do the sensitivities (one tangent column δ·, all columns at once; δφ the world rotation vector of δq):

    δx(τ) = δx₀ + τ (W δP₀ + δW P₀),     δP(τ) = δP₀ + τ δm g,     δL(τ) = δL₀,
    δφ(τ) = R(ωτ) δφ₀ + τ J_l(ωτ) δω,    δω = δL / I_s,            δq(τ) = ½ Ξ(q(τ)) δφ(τ),

with J_l the left Jacobian of SO(3) (:func:`pbanim.design.left_jacobian`). The impact times are roots of
quadratics: a sphere against a plane has the gap g(τ) = γ + β τ + ½ (n·g) τ² (γ = n·(x₀ − o) − r,
β = n·v₀), and two spheres under the same gravity move *linearly* relative to each other, so
|d₀ + w τ|² − (r_a + r_b)² = 0 (d = x_a − x_b, w = v_a − v_b) is a quadratic too. The first root where a
gap goes from positive to zero is the impact — no step, no bracket, no Brent iteration — and the
continuous-flow saltation Φ⁺ = G(Φ⁻ + f⁻δτ) + G_u − f⁺δτ applies as it stands (the flow is exact).

Frictionless impulses on spheres pass through the centres (c = r × n = 0), so no impact changes L, and
the orientation rows never feed back into the positions: the map is exact for the positions, momenta,
impact times and orientations alike. The RK4 path (:mod:`pbanim.design.flight`) remains the general one
(boxes, anisotropic inertia, inertia parameters); on spheres both agree to the RK4 error of the rotation
and to roundoff on the positions (RK4 is exact on quadratics), ORACLES H7.

==========  ===============  ===========  ================================================
symbol      code             shape        meaning
==========  ===============  ===========  ================================================
τ           ``tau``          scalar       flight time
γ, β, α     ``c, b, a``      (F,)         gap polynomial γ + βτ + ατ² of every feature
I_s⁻¹       ``model.Iinv``   (N, 3)       isotropic inverse inertia (three equal moments)
Tᵀ = Φ      ``T``            (p, 13N)     sensitivity rows, as in :mod:`pbanim.design.flight`
==========  ===============  ===========  ================================================

Limiting cases: τ = 0 is the identity; ω = 0 leaves q and δφ unchanged; with g = 0 the positions are
straight lines and a plane's gap is linear in τ (α = 0, one root).

References: Popović et al. SIGGRAPH 2000 §4 (S and ∂S/∂u; closed forms where the motion has them);
Hiskens & Pai 2000 (saltation of hybrid systems); J. Solà et al. 2018 (the left Jacobian); W. H. Press
et al., *Numerical Recipes*, §5.6 (roots of a quadratic without cancellation).
"""

from __future__ import annotations

import numpy as np

from ..collision import Sphere
from ..contracts import Array, Obj, Opt, Real, contract, finite_result
from ..errors import InvalidInput
from ..rigid import quat_exp, quat_multiply, quat_to_matrix, skew
from .flight import FlightModel, _qdot, rotation_tangent
from .impact import Features, saltation_post
from .scene import DesignScene, TooManyImpacts
from .specs import DesignState, ParameterNames, UnitRows

__all__ = ["exact_reason", "exact_applies", "flight_map", "first_impact", "next_events", "ExactFlight"]


def exact_reason(scene, model: FlightModel) -> str:
    """Why the closed-form flight does *not* apply ('' when it does): every body a sphere with isotropic
    inertia, no inertia parameter (a perturbed moment would make the rotation anisotropic)."""
    if not all(isinstance(b.shape, Sphere) for b in scene.bodies):
        return "a body is not a sphere"
    Ii = model.Iinv
    if np.any(np.abs(Ii - Ii[:, :1]) > 1e-12 * Ii[:, :1]):
        return "a sphere has anisotropic inertia"
    if np.any(model.dIinv):
        return "an inertia parameter is free"
    return ""


@contract(scene=Obj(DesignScene), names=ParameterNames("scene", empty=True))
def exact_applies(scene, names=()) -> bool:
    """Whether :func:`pbanim.design.simulate` flies ``scene`` in closed form with free parameters ``names``
    (the nominal inertias decide; callers that record no states may then take one grid step per span)."""
    ok = all(isinstance(b.shape, Sphere) and np.ptp(b.inertia) <= 1e-12 * b.inertia[0] for b in scene.bodies)
    return ok and not any(str(n).startswith("inertia") for n in names)


def _left_jacobians(theta: np.ndarray) -> np.ndarray:
    """J_l(θ) for rows θ (N, 3) → (N, 3, 3) (series near |θ| = 0), as :func:`pbanim.design.left_jacobian`."""
    a = np.sqrt(np.sum(theta * theta, axis=1))
    small = a < 1e-4
    a_s = np.where(small, 1.0, a)
    c1 = np.where(small, 0.5 - a * a / 24.0, (1.0 - np.cos(a_s)) / a_s ** 2)
    c2 = np.where(small, 1.0 / 6.0 - a * a / 120.0, (a_s - np.sin(a_s)) / a_s ** 3)
    S = skew(theta)
    return np.eye(3) + c1[:, None, None] * S + c2[:, None, None] * (S @ S)


@contract(model=Obj(FlightModel), y=DesignState(), T=Opt(Array(("model.n_params", "model.n_state"), empty=True)),
          tau=Real(), returns=finite_result)
def flight_map(model: FlightModel, y: np.ndarray, T: np.ndarray | None, tau: float):
    """(y(τ), T(τ)): the closed-form flight of the module docstring (new arrays; ``T`` may be None)."""
    with np.errstate(all="ignore"):       # an overflow (τ ≈ 1e300) is named by the result's certificate
        return _flight_map(model, y, T, tau)


def _flight_map(model: FlightModel, y: np.ndarray, T: np.ndarray | None, tau: float, still: bool | None = None):
    """The flight map; ``still`` (default: L = 0 for every body) skips the rotation's products: exp(0) = 1 and
    R = J_l = 𝟙, so q(τ) = q₀ and δφ(τ) = δφ₀ + τ δω give what the products give, to the sign of a zero."""
    N = model.N
    x, q, P, L = (y[:3 * N].reshape(N, 3), y[3 * N:7 * N].reshape(N, 4), y[7 * N:10 * N].reshape(N, 3),
                  y[10 * N:].reshape(N, 3))
    W, m, g = model.W[:, None], model.m[:, None], model.g
    if still is None:
        still = not L.any()
    w = model.Iinv[:, :1] * L                                   # ω = L / I_s
    th = w * tau
    E = None if still else quat_exp(th)
    q1 = q.copy() if still else quat_multiply(E, q)
    q1 /= np.sqrt(np.sum(q1 * q1, axis=1))[:, None]
    y1 = np.concatenate([(x + tau * W * P + 0.5 * tau * tau * g).ravel(), q1.ravel(),
                         (P + tau * m * g).ravel(), L.ravel()])
    if T is None or T.size == 0:
        return y1, T
    p = T.shape[0]
    Tx, Tq = T[:, :3 * N].reshape(p, N, 3), T[:, 3 * N:7 * N].reshape(p, N, 4)
    TP, TL = T[:, 7 * N:10 * N].reshape(p, N, 3), T[:, 10 * N:].reshape(p, N, 3)
    T1 = np.empty_like(T)
    T1[:, :3 * N] = (Tx + tau * (W[None] * TP + model.dW[:, :, None] * P[None])).reshape(p, 3 * N)
    T1[:, 7 * N:10 * N] = (TP + tau * model.dm[:, :, None] * g).reshape(p, 3 * N)
    T1[:, 10 * N:] = T[:, 10 * N:]
    dphi0 = rotation_tangent(q, Tq)                             # (p, N, 3)
    dw = model.Iinv[None, :, :1] * TL
    if still:
        dphi1 = dphi0 + tau * dw
    else:
        R, Jl = quat_to_matrix(E), _left_jacobians(th)
        dphi1 = np.einsum("nij,pnj->pni", R, dphi0) + tau * np.einsum("nij,pnj->pni", Jl, dw)
    T1[:, 3 * N:7 * N] = _qdot(q1[None], dphi1).reshape(p, 4 * N)  # δq = ½ (0, δφ) ⊗ q
    return y1, T1


def _first_down_root(a, b, c, tol, horizon):
    """For each quadratic a τ² + b τ + c: the first τ ∈ (0, horizon] where it falls through zero after
    having been above ``tol`` (at τ = 0 or at its vertex); +inf where there is none. Vectorized."""
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        D = b * b - 4.0 * a * c
        sq = np.sqrt(np.maximum(D, 0.0))
        qq = -0.5 * (b + np.where(b >= 0, sq, -sq))             # no cancellation (Numerical Recipes §5.6)
        r1 = np.where(a != 0, qq / a, np.inf)
        r2 = np.where(qq != 0, c / qq, np.inf)
        roots = np.stack([r1, r2])
        falling = 2.0 * a * roots + b < 0                       # the gap decreases through the root
        tv = np.where(a < 0, -b / (2.0 * a), -np.inf)            # vertex of a concave gap
        peak = np.where((tv > 0), c - b * b / (4.0 * a), -np.inf)
        was_up = (c > tol) | ((peak > tol) & (tv < roots))
        ok = (D >= 0) & np.isfinite(roots) & falling & (roots > 0) & (roots <= horizon) & was_up
    return np.where(ok, roots, np.inf).min(axis=0)


@contract(feat=Obj(Features), model=Obj(FlightModel), y=DesignState(),
          normals=UnitRows(("feat.n_planes", 3), empty=True), horizon=Real(gt=0, finite=False), tol=Real(ge=0))
def first_impact(feat, model: FlightModel, y: np.ndarray, normals: np.ndarray, horizon: float, tol: float):
    """(τ, feature) of the first impact within ``horizon`` of exact flight from y, or None."""
    if feat.n_bodies != model.N:
        raise InvalidInput(f"first_impact: feat was built for {feat.n_bodies} bodies, model has N = {model.N}")
    return next_events(feat, model, y, normals, horizon, tol)[0]


def _touch_at_vertex(a, b, c, tol, horizon, roots):
    """Tangent touches of convex quadratics a τ² + b τ + c that never fall through zero: the vertex, within
    ``tol`` above zero, inside (0, horizon], from a gap above ``tol``; +inf where there is none."""
    with np.errstate(divide="ignore", invalid="ignore"):
        tv = np.where(a > 0, -b / (2.0 * a), np.inf)
        low = c - b * b / (4.0 * a)
        ok = (a > 0) & (tv > 0) & (tv <= horizon) & (c > tol) & (low <= tol) & ~np.isfinite(roots)
    return np.where(ok, tv, np.inf)


def _quartic_events(coef, tol, horizon):
    """(first falling root, first touch) of p(τ) = Σ coef[i] τ^(4−i) after it was above ``tol`` (a pair of
    spheres of which one rests: they accelerate differently, the squared gap is a quartic)."""
    def real_in(r):
        r = r[np.abs(r.imag) <= 1e-7 * np.maximum(1.0, np.abs(r.real))].real
        return np.sort(r[(r > 0) & (r <= horizon)])

    dp, ddp = np.polyder(coef), np.polyder(coef, 2)
    crit = real_in(np.roots(dp)) if np.any(dp) else np.zeros(0)
    roots = []
    for r in real_in(np.roots(coef)) if np.any(coef[:-1]) else []:
        for _ in range(2):                               # polish (np.roots is an eigenvalue solve)
            d = np.polyval(dp, r)
            r = r - np.polyval(coef, r) / d if d != 0 else r
        roots.append(r)
    up = coef[-1] > tol
    for t_, kind in sorted([(r, "root") for r in roots] + [(c, "crit") for c in crit]):
        if kind == "crit":
            v = np.polyval(coef, t_)
            if v > tol:
                up = True
            elif up and v >= -tol and np.polyval(ddp, t_) > 0:
                return np.inf, t_                         # down to zero and back: a touch
        elif up and np.polyval(dp, t_) < 0:
            return t_, np.inf
    return np.inf, np.inf


def next_events(feat, model: FlightModel, y: np.ndarray, normals: np.ndarray, horizon: float, tol: float,
                G: np.ndarray | None = None, skip: np.ndarray | None = None):
    """((τ, feature) of the first impact or None, [(τ, feature)] of the tangent touches before it) in exact
    flight from y, each body accelerating with G (N, 3) (default g: resting spheres slide with g − (n·g)n);
    features where ``skip`` is True (the resting ones) never fire."""
    N = model.N
    G = np.tile(model.g, (N, 1)) if G is None else G
    x, v = y[:3 * N].reshape(N, 3), model.W[:, None] * y[7 * N:10 * N].reshape(N, 3)
    hits, touch = [], []
    if feat.n_plane:
        n = normals[feat.plane]
        i = feat.body
        c = np.einsum("fi,fi->f", n, x[i] - feat.anchors[feat.plane]) - feat.rad
        a, b = 0.5 * np.einsum("fi,fi->f", n, G[i]), np.einsum("fi,fi->f", n, v[i])
        r = _first_down_root(a, b, c, tol, horizon)
        hits.append(r)
        touch.append(_touch_at_vertex(a, b, c, tol, horizon, r))
    if len(feat.pairs):
        A, B = feat.pairs[:, 0], feat.pairs[:, 1]
        d, w, dg = x[A] - x[B], v[A] - v[B], 0.5 * (G[A] - G[B])
        Rs = feat.radius[A] + feat.radius[B]
        tq = 2.0 * Rs * tol + tol * tol
        a, b, c = np.sum(w * w, axis=1), 2.0 * np.sum(d * w, axis=1), np.sum(d * d, axis=1) - Rs * Rs
        r = _first_down_root(a, b, c, tq, horizon)
        tt = _touch_at_vertex(a, b, c, tq, horizon, r)
        for f in np.flatnonzero(np.any(dg != 0, axis=1)):  # |d + wτ + ½Δg τ²|² − R²: a quartic
            coef = np.array([dg[f] @ dg[f], 2.0 * w[f] @ dg[f], a[f] + 2.0 * d[f] @ dg[f], b[f], c[f]])
            r[f], tt[f] = _quartic_events(coef, tq[f], horizon)
        hits.append(r)
        touch.append(tt)
    roots = np.concatenate(hits) if hits else np.zeros(0)
    touches = np.concatenate(touch) if touch else np.zeros(0)
    if skip is not None and roots.size:
        roots, touches = np.where(skip, np.inf, roots), np.where(skip, np.inf, touches)
    first = None
    if roots.size and np.isfinite(roots.min()):
        k = int(np.argmin(roots))
        first = (float(roots[k]), k)
    limit = first[0] if first else np.inf
    out = sorted((float(touches[k]), int(k)) for k in np.flatnonzero(touches < limit))
    return first, out


class ExactFlight:
    """The exact path of :func:`pbanim.design.simulate`: ``advance(t, y, h)`` for the driver, carrying the
    sensitivities at an *anchor* (the start or the last impact) and flying from there in closed form.

    The flow is exact, hence a group: the state at any time is the anchor's flight map, and the next
    impact time, computed once per anchor (the polynomial roots), holds until it happens. A grid step
    therefore costs one state map; the sensitivities move only at impacts (:meth:`advance`, with
    ``resolve(k, t, y⁻, T⁻, rate)`` applying the jump, rate None: the exact flow's f, then −f⁺δτ) and
    at output times (:meth:`current`). The driver carries the state alone; ``advance`` reads its own
    anchor, not the ``y`` it is handed (which is always the state it returned last). Resting spheres
    (``contacts``, :mod:`pbanim.design.rest`) fly the same map, projected onto their planes; tangent
    touches found at an anchor are recorded as the run passes them.
    """

    def __init__(self, model, feat, normals, resolve, t0: float, y: np.ndarray, T, contacts,
                 max_impacts: int) -> None:
        self.model, self.feat, self.normals, self.resolve = model, feat, normals, resolve
        self.contacts, self.cap = contacts, 4 * int(max_impacts) + 4
        self._anchor(float(t0), y, T)

    def _anchor(self, t, y, T) -> None:
        self.t_a, self.y_a, self.T_a = t, y, T
        c = self.contacts
        self.next, touches = next_events(self.feat, self.model, y, self.normals, np.inf, c.tol(y), c.gravity(),
                                         c.mask())
        self.pending = [(t + tau, k) for tau, k in touches]

    def current(self, t: float):
        """(y(t), T(t)) between the anchor and the next impact."""
        return self.contacts.project(*_flight_map(self.model, self.y_a, self.T_a, t - self.t_a))

    def _touches_until(self, t1) -> None:
        while self.pending and self.pending[0][0] <= t1:
            tt, k = self.pending.pop(0)
            self.contacts.touch(k, tt)

    def advance(self, t, y, hk):
        t1 = t + hk
        for _ in range(self.cap):
            if self.next is None or self.t_a + self.next[0] > t1:
                self._touches_until(t1)
                return self.contacts.project(_flight_map(self.model, self.y_a, None, t1 - self.t_a)[0])[0]
            te = self.t_a + self.next[0]
            self._touches_until(te)
            ye, Te = self.current(te)
            yy, TT, dtau = self.resolve(self.next[1], te, ye, Te, None)
            if TT is not None:
                TT = saltation_post(self.model, yy, TT, dtau)
            self.contacts.project(yy, TT)
            self._anchor(te, yy, TT)
        raise TooManyImpacts(self.cap, self.t_a)
