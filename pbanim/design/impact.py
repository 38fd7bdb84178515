"""Impacts as jumps of the state and of its sensitivities (chapter 10, part of :mod:`pbanim.design`).

An impact maps the state just before it to the state just after, q⁺ = q⁻ + J(q⁻, m, I, ε, n). For one
frictionless contact between bodies a and b (b may be the static world) at point p with normal n (b → a),
chapter 6's impulse (:func:`pbanim.collision.contact_impulse`, Baraff) is J = j n with

    c = r × n,  r = p − x,   v_rel = n·(v_a − v_b) + c_a·ω_a − c_b·ω_b,
    k = W_a + W_b + c_aᵀ I_a⁻¹ c_a + c_bᵀ I_b⁻¹ c_b,      j = −(1 + ε) v_rel / k,
    P_a⁺ = P_a + j n,  L_a⁺ = L_a + j c_a   (and −j n, −j c_b on b).

**Its derivative** (pushed forward one tangent column at a time, all columns at once):

    δj = −(δε v_rel + (1 + ε) δv_rel + j δk) / k,
    δk = δW_a + δW_b + Σ [2 (I⁻¹c)·δc + 2 δφ·((I⁻¹c) × c) + Σₖ δI⁻¹ₖ (Rᵀc)ₖ²],
    δP⁺ = δP + δj n + j δn,    δL⁺ = δL + δj c + j δc,     δc = (δp − δx) × n + r × δn.

**The impact time moves** with u. The event is the gap g(y, u) = 0 (sphere–plane n·(x − o) − r,
box vertex–plane n·(x + R s − o), sphere–sphere |x_a − x_b| − r_a − r_b; ġ = v_rel for all three), so

    δτ = −δg / ġ,      Φ⁺ = G (Φ⁻ + f⁻ δτ) + G_u − f⁺ δτ

(G, G_u: the jump's derivatives; f∓: the flight derivative before and after): the *saltation* of hybrid
systems. For a ball dropped on the floor (h, v): S = [[−ε, 0], [−(1 + ε) g/v⁻, −ε]] (ORACLES H1);
dropping the δτ terms gives [[1, 0], [0, −ε]], which is wrong.

Grazing: when ġ → 0, δτ = −δg/ġ blows up and S(t, u) is not differentiable (it jumps between
"touches" and "misses"); two contacts at once (a box landing flat) make the order of the impulses, hence
S, non-smooth. Both are reported (:class:`~pbanim.design.GrazingImpactWarning`, ``Impact.grazing``,
``Impact.simultaneous``), never returned as a silent number.

==========  ============  ===========  =================================================
symbol      code          shape        meaning
==========  ============  ===========  =================================================
n, p        ``n, p``      (3,)         contact normal (b → a), contact point
δn, δp      ``dn, dp``    (p, 3)       their tangents
j, k        ``j, k``      scalars      impulse magnitude, effective inverse mass nᵀKn
δτ          ``dtau``      (p,)         derivative of the impact time
==========  ============  ===========  =================================================

References: Popović et al. SIGGRAPH 2000 §4.2 (derivatives through collisions, the moving impact
time); Aizerman & Gantmacher 1958, Hiskens & Pai 2000 (trajectory sensitivity of hybrid systems, the
saltation matrix); Baraff 2001 course notes §8 (the impulse).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..collision import Contacts, ImpulseBodies, Sphere, collision_matrix, contact_impulse, contact_velocity
from ..contracts import Array, Flag, Index, Obj, Opt, Real, contract, finite_result
from ..errors import InvalidInput
from ..geometry import cross
from ..rigid import quat_to_matrix
from .flight import FlightModel, flight_rhs, omega_tangent, rotation_tangent
from .specs import DesignState, UnitRows

__all__ = ["Features", "Impact", "gaps", "apply_impact", "saltation_post"]


@dataclass
class Impact:                   # a record pbanim builds (simulate) and users read
    """One impact of a trajectory: when, which feature, how fast, and whether S is smooth there."""

    t: float
    kind: str            # "plane" or "pair"
    body: int
    other: int           # plane index (kind "plane") or the second body (kind "pair")
    speed: float         # approach speed −v_rel > 0
    impulse: float       # j
    grazing: bool = False
    simultaneous: bool = False


class Features:
    """Every feature that can collide: (body, plane, body-frame offset s, radius) and sphere pairs."""

    def __init__(self, scene) -> None:
        body, plane, off, rad = [], [], [], []
        for i, b in enumerate(scene.bodies):
            pts = np.zeros((1, 3)) if isinstance(b.shape, Sphere) else b.shape.vertices()
            r = b.shape.radius if isinstance(b.shape, Sphere) else 0.0
            for j in range(len(scene.planes)):
                for s in pts:
                    body.append(i), plane.append(j), off.append(s), rad.append(r)
        self.body, self.plane = np.array(body, int), np.array(plane, int)
        self.off, self.rad = np.array(off, float).reshape(-1, 3), np.array(rad, float)
        spheres = [i for i, b in enumerate(scene.bodies) if isinstance(b.shape, Sphere)]
        pairs = [(a, b) for k, a in enumerate(spheres) for b in spheres[k + 1:]] if scene.body_collisions else []
        self.pairs = np.array(pairs, int).reshape(-1, 2)
        self.radius = scene.radius
        self.anchors = scene.anchors
        self.n_plane = len(self.body)
        self.n_bodies, self.n_planes = scene.N, len(scene.planes)

    def __len__(self) -> int:
        return self.n_plane + len(self.pairs)

    @property
    def n_features(self) -> int:
        """Plane features (one per sphere and plane, one per box vertex and plane), then sphere pairs."""
        return len(self)


def gaps(feat: Features, y: np.ndarray, N: int, normals: np.ndarray) -> np.ndarray:
    """Signed gaps of every feature (plane features first, then sphere pairs); < 0 is penetration."""
    x = y[:3 * N].reshape(N, 3)
    out = np.empty(len(feat))
    if feat.n_plane:
        R = quat_to_matrix(y[3 * N:7 * N].reshape(N, 4))
        pc = x[feat.body] + np.einsum("fij,fj->fi", R[feat.body], feat.off)
        n = normals[feat.plane]
        out[:feat.n_plane] = np.einsum("fi,fi->f", n, pc - feat.anchors[feat.plane]) - feat.rad
    if len(feat.pairs):
        a, b = feat.pairs[:, 0], feat.pairs[:, 1]
        out[feat.n_plane:] = np.linalg.norm(x[a] - x[b], axis=1) - feat.radius[a] - feat.radius[b]
    return out


def _body(y, T, N, i):
    """(x, q, P, L) of body i and their tangent rows (p, 3|4)."""
    sl = lambda k, w: slice(k * N + w * i, k * N + w * (i + 1))  # noqa: E731
    parts = (sl(0, 3), slice(3 * N + 4 * i, 3 * N + 4 * i + 4), sl(7, 3), sl(10, 3))
    return [y[s] for s in parts], [T[:, s] for s in parts], parts


@contract(model=Obj(FlightModel), feat=Obj(Features), k=Index("feat.n_features"), t=Real(), y=DesignState(),
          T=Opt(Array(("model.n_params", "model.n_state"), empty=True)),
          normals=UnitRows(("feat.n_planes", 3), empty=True),
          dnormals=Opt(Array(("model.n_params", "feat.n_planes", 3), empty=True)), eps=Real(ge=0, le=1),
          deps=Opt(Array(("model.n_params",), empty=True)), locate=Flag(), rate=Opt(Array(("model.n_state",))),
          returns=finite_result)
def apply_impact(model: FlightModel, feat: Features, k: int, t: float, y: np.ndarray, T: np.ndarray | None,
                 normals: np.ndarray, dnormals: np.ndarray | None, eps: float, deps: np.ndarray | None,
                 locate: bool = True, rate: np.ndarray | None = None):
    """The impulse of feature ``k`` at the event state (y, T) → (y⁺, T⁺, Impact, δτ).

    ``T`` (p, 13N) are the sensitivities just before; ``dnormals`` (p, planes, 3) and ``deps`` (p,) the
    parameter tangents of the plane normals and of ε. ``locate=False`` skips the impact-time correction
    (a contact resolved at the same instant as another). ``rate`` is the rate dy⁻/dτ of the computed
    state at the event (default f(y⁻), the continuous flow). T⁺ = G(T + rate δτ) + G_u *without* the
    −f⁺δτ of the saltation: the caller subtracts it (:func:`saltation_post`), or the exact rate of the
    step that follows the impact (:func:`pbanim.design.simulate.simulate`).

    A feature that does not approach (v_rel ≥ 0) receives no impulse: y⁺ = y, T⁺ = T, δτ = 0 and
    ``Impact.speed`` = −v_rel ≤ 0 (callers apply impacts to approaching features only). An impact with
    ġ = 0 exactly has no finite δτ: it is marked grazing and δτ = 0 (S has no derivative there).
    """
    N = model.N
    if feat.n_bodies != N:
        raise InvalidInput(f"apply_impact: feat was built for {feat.n_bodies} bodies, model has N = {N}")
    p = 0 if T is None else T.shape[0]
    if k < feat.n_plane:
        a, b, kind, other = int(feat.body[k]), -1, "plane", int(feat.plane[k])
    else:
        a, b = (int(v) for v in feat.pairs[k - feat.n_plane])
        kind, other = "pair", b
    (xa, qa, Pa, La), _, _ = _body(y, np.zeros((0, y.size)), N, a)
    Ra = quat_to_matrix(qa)
    # ---- the contact frame (n, p) and the gap's rate ġ
    if kind == "plane":
        n = normals[other]
        s_w = Ra @ feat.off[k]
        point = xa + s_w - feat.rad[k] * n
    else:
        xb = y[3 * b:3 * b + 3]
        d = xa - xb
        if not np.linalg.norm(d) > 0:
            raise InvalidInput(f"apply_impact: y puts bodies {a} and {b} at the same centre: no contact normal")
        n = d / np.linalg.norm(d)
        point = xb + feat.radius[b] * n
    bodies_ab = [a] + ([b] if b >= 0 else [])
    W = model.W
    v = {i: W[i] * y[7 * N + 3 * i:7 * N + 3 * i + 3] for i in bodies_ab}
    R = {i: quat_to_matrix(y[3 * N + 4 * i:3 * N + 4 * i + 4]) for i in bodies_ab}
    Iw_inv = {i: R[i] @ (model.Iinv[i][:, None] * R[i].T) for i in bodies_ab}
    L = {i: y[10 * N + 3 * i:10 * N + 3 * i + 3] for i in bodies_ab}
    w = {i: Iw_inv[i] @ L[i] for i in bodies_ab}
    xs = {i: y[3 * i:3 * i + 3] for i in bodies_ab}
    c = {i: cross(point - xs[i], n) for i in bodies_ab}
    sgn = {a: 1.0, b: -1.0}
    vrel = sum(sgn[i] * (n @ v[i] + c[i] @ w[i]) for i in bodies_ab)
    kk = sum(W[i] + c[i] @ Iw_inv[i] @ c[i] for i in bodies_ab)
    if not vrel < 0:                  # separating or sliding along: no impulse, nothing moves
        return y.copy(), (None if T is None else T.copy()), Impact(float(t), kind, a, other, float(-vrel), 0.0), \
            (None if T is None else np.zeros(p))
    j = -(1.0 + eps) * vrel / kk
    # ---- the value: chapter 6's impulse (Baraff), applied to the momenta
    ib = ImpulseBodies.make(x=[xs[i] for i in bodies_ab], v=[v[i] for i in bodies_ab],
                            inv_mass=[W[i] for i in bodies_ab], omega=[w[i] for i in bodies_ab],
                            inv_I=np.array([Iw_inv[i] for i in bodies_ab]))
    con = Contacts([0], [1 if b >= 0 else -1], [point], [n], [0.0])
    J, _ = contact_impulse(collision_matrix(ib, con)[0], contact_velocity(ib, con)[0], n, eps)
    y1 = y.copy()
    for i in bodies_ab:
        y1[7 * N + 3 * i:7 * N + 3 * i + 3] += sgn[i] * J
        y1[10 * N + 3 * i:10 * N + 3 * i + 3] += sgn[i] * cross(point - xs[i], J)
    impact = Impact(float(t), kind, a, other, float(-vrel), float(j))
    if T is None:
        return y1, None, impact, None
    # ---- the impact time: δτ = −δg/ġ, and the state tangent on the event surface
    f_minus = flight_rhs(model, y) if rate is None else rate
    Ta = _body(y, T, N, a)[1]
    dphi_a = rotation_tangent(qa[None], Ta[1][:, None, :])[:, 0]
    if kind == "plane":
        dn = dnormals[:, other] if dnormals is not None else np.zeros((p, 3))
        pc = xa + s_w
        dg = dn @ (pc - feat.anchors[other]) + (Ta[0] + cross(dphi_a, s_w[None])) @ n
    else:
        dg = (Ta[0] - T[:, 3 * b:3 * b + 3]) @ n
    # BEGIN SOLUTION apply_impact.event_time
    gdot = vrel if rate is None else _gap_rate(kind, qa, a, b, n, s_w if kind == "plane" else None, rate, N)
    if gdot == 0.0:
        impact.grazing, locate = True, False     # δτ = −δg/ġ is infinite: S has no derivative here
    dtau = -dg / gdot if locate else np.zeros(p)
    Ts = T + dtau[:, None] * f_minus[None]
    # END SOLUTION
    # ---- tangents of every quantity at the event
    tb = {}
    for i in bodies_ab:
        (_, qi, Pi, _), (Tx, Tq, TP, TL), _ = _body(y, Ts, N, i)
        dphi = rotation_tangent(qi[None], Tq[:, None, :])[:, 0]
        Lb = R[i].T @ L[i]
        sub = FlightModel(1, W[i:i + 1], model.m[i:i + 1], model.Iinv[i:i + 1], model.g, model.dW[:, i:i + 1],
                          model.dm[:, i:i + 1], model.dIinv[:, i:i + 1])
        dw = omega_tangent(sub, R[i][None], L[i][None], Lb[None], w[i][None], dphi[:, None], TL[:, None])[:, 0]
        dv = W[i] * TP + model.dW[:, i:i + 1] * Pi[None]
        tb[i] = (Tx, dphi, dv, dw)
    if kind == "plane":
        dn = dnormals[:, other] if dnormals is not None else np.zeros((p, 3))
        dp = tb[a][0] + cross(tb[a][1], s_w[None]) - feat.rad[k] * dn
    else:
        dd = tb[a][0] - tb[b][0]
        dist = np.linalg.norm(xa - xb)
        dn = (dd - np.outer(dd @ n, n)) / dist
        dp = tb[b][0] + feat.radius[b] * dn
    dvrel = np.zeros(p)
    dk = np.zeros(p)
    dc = {}
    for i in bodies_ab:
        Tx, dphi, dv, dw = tb[i]
        r = point - xs[i]
        dc[i] = cross(dp - Tx, n[None]) + cross(r[None], dn)
        dvrel += sgn[i] * (dn @ v[i] + dv @ n + dc[i] @ w[i] + dw @ c[i])
        ac = Iw_inv[i] @ c[i]
        dk += model.dW[:, i] + 2.0 * dc[i] @ ac + 2.0 * dphi @ cross(ac, c[i])
        dk += model.dIinv[:, i] @ (R[i].T @ c[i]) ** 2
    # BEGIN SOLUTION apply_impact.impulse_derivative
    de = np.zeros(p) if deps is None else deps
    dj = -(de * vrel + (1.0 + eps) * dvrel + j * dk) / kk
    T1 = Ts.copy()
    for i in bodies_ab:
        T1[:, 7 * N + 3 * i:7 * N + 3 * i + 3] += sgn[i] * (np.outer(dj, n) + j * dn)
        T1[:, 10 * N + 3 * i:10 * N + 3 * i + 3] += sgn[i] * (np.outer(dj, c[i]) + j * dc[i])
    return y1, T1, impact, dtau
    # END SOLUTION


def saltation_post(model: FlightModel, y1: np.ndarray, T1: np.ndarray, dtau: np.ndarray) -> np.ndarray:
    """The last term of the saltation, T⁺ −= f(y⁺) δτ (the continuous-flow version)."""
    # BEGIN SOLUTION saltation_post
    return T1 - dtau[:, None] * flight_rhs(model, y1)[None]
    # END SOLUTION


def _gap_rate(kind, qa, a, b, n, s_w, rate, N):
    """dg/dτ along the computed rate (the discrete counterpart of ġ = v_rel)."""
    dx = rate[3 * a:3 * a + 3]
    if kind == "pair":
        return float((dx - rate[3 * b:3 * b + 3]) @ n)
    dphi = rotation_tangent(qa[None], rate[None, 3 * N + 4 * a:3 * N + 4 * a + 4][:, None])[0, 0]
    return float((dx + cross(dphi, s_w)) @ n)
