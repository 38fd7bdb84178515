"""The lean twin of S(t, u) for the sketching interface's tumbling box (chapter 10, issue 30 point 5; part
of :mod:`pbanim.design`).

Between impacts a rigid body under gravity flies the deck's free-flight equations, and only the rotation
needs a step: the translation is a parabola (RK4 is exact on it), L is constant, and the variational
equations split the same way (δẋ = W δP, δṖ = 0, δL̇ = 0). So the lean step integrates the quaternion
alone, on a handful of floats, and its tangent rows by the linearized stages:

    q̇ = ½ Ξ(q) ω,   ω = I_w⁻¹ L,   I_w⁻¹ = R diag(I⁻¹) Rᵀ,
    [δq̇ δL̇] = [δq δL] Aᵀ,   A = [[½ (Ξ D + Ω(ω)), ½ Ξ I_w⁻¹], [0, 0]],   D = (I_w⁻¹[L]× − [ω]×) Ξᵀ 2/|q|²,

the same stages as :func:`pbanim.design.flight.augmented_step` (RK4, then q ← q/|q|, δq ← (𝟙 − q̂q̂ᵀ)δq/|q|)
and the same rate d y₁/dh as :func:`pbanim.design.flight.step_rate` (k₂' = A(Y₂) k₁/2, …). The tangent is
needed only where an impact or t* reads it (none after t*): the steps between are kept, and their linearized
maps built for all of them at once (:meth:`_Flight.transport`), one product per step. Everything else
is the readable run's own law, called once per impact: the grid is :func:`pbanim.ode.driver.step_grid`
between 0, t* and t_end; the impact is located by :func:`pbanim.ode.events.crossings` (Brent on the RK4
partial step) and applied by :func:`pbanim.design.impact.apply_impact` with the step's rate, then
T⁺ −= δτ ⊗ rate of the rest of the step — so the result equals :func:`pbanim.design.simulate` to roundoff
(ORACLES L5). The drawn positions between grid points are the parabolas x_a + W P_a s + ½ g s² from the
last impact: the flight grid step ``h_flight`` needs only the accuracy of the impacts, not the spacing of
the drawing.

Where the readable run does more — a gap that dips inside a step (a touch, a hidden impact), a contact
touching at the start or after an impact, an impact slower than ``SLOW`` (a graze, a rest), more than
``MAX_IMPACTS`` — :func:`_box_run` returns None and the caller runs the readable S.

==========  ==============  ========  ===========================================
symbol      code            shape     meaning
==========  ==============  ========  ===========================================
x, q, P, L  ``x, q, P, L``  3,4,3,3   the state (Baraff's layout)
Φᵀ          ``Tx … TL``     (p, ·)    tangent rows, one per parameter
A           ``A7``          (7, 7)    the (q, L) block of ∂f/∂y at a stage
==========  ==============  ========  ===========================================

Limiting cases: ω = 0 leaves q and its rows fixed (A = 0 on δq, ½ Ξ I_w⁻¹ on δL); a cube (isotropic I) has
ω constant and the step reproduces exp(½ωh) ⊗ q to the RK4 error.

References: Popović et al. SIGGRAPH 2000 §4–5; Hairer, Nørsett & Wanner I §II.4 (RK and linearization
commute); Baraff, SIGGRAPH 1997 notes (q̇ = ½ ω q).
"""

from __future__ import annotations

import math

import numpy as np

from ..collision import Sphere
from ..ode.driver import step_grid
from ..ode.events import crossings, make_events
from ..rigid import quat_to_matrix
from .impact import Features, apply_impact
from .rest import hermite_dips

__all__: list = []

SLOW = 1e-2
MAX_IMPACTS = 100
NAMES = {"x0", "theta0", "v0", "omega0"}


def box_applies(scene, names) -> bool:
    """One body that is not a sphere, free parameters among x₀, θ₀, v₀, ω₀ (no mass, inertia, plane or ε)."""
    return scene.N == 1 and not isinstance(scene.bodies[0].shape, Sphere) and set(names) <= NAMES


class _Flight:
    """The lean (q, δq, δL) RK4 step of one body (module docstring), with its constants: the stage states on
    floats, then the four stages' matrices A built at once, then the tangent stages (one product each)."""

    def __init__(self, W, m, Iinv, g):
        self.W, self.m, self.g, self.gl = W, m, g, tuple(float(v) for v in g)
        self.Iinv = np.asarray(Iinv, dtype=float)
        self.i1, self.i2, self.i3 = (float(v) for v in Iinv)

    def stage(self, q, L):
        """(q̇, q, ω) at the stage quaternion q (not unit), on floats: ω = R I⁻¹ Rᵀ L, q̇ = ½ Ξ(q) ω."""
        w0, x1, x2, x3 = q
        r00, r01, r02, r10, r11, r12, r20, r21, r22, s = _rot_floats(q)
        l0, l1, l2 = L
        b0 = self.i1 * (r00 * l0 + r10 * l1 + r20 * l2)          # I⁻¹ Rᵀ L
        b1 = self.i2 * (r01 * l0 + r11 * l1 + r21 * l2)
        b2 = self.i3 * (r02 * l0 + r12 * l1 + r22 * l2)
        a, b, c = r00 * b0 + r01 * b1 + r02 * b2, r10 * b0 + r11 * b1 + r12 * b2, r20 * b0 + r21 * b1 + r22 * b2
        qd = (0.5 * (-x1 * a - x2 * b - x3 * c), 0.5 * (w0 * a + x3 * b - x2 * c),
              0.5 * (-x3 * a + w0 * b + x1 * c), 0.5 * (x2 * a - x1 * b + w0 * c))
        return qd, q, (a, b, c)

    def _matrices(self, st, L):
        """The (q, L) blocks of ∂f/∂y at the stages st [(q̇, q, ω)], all at once: Aqq (n, 4, 4) and AqL (n, 4, 3)
        (module docstring), from the stage quaternions and rates."""
        Q = np.array([e[1] for e in st])
        w0, x1, x2, x3 = Q.T
        X = np.stack([-Q[:, 1:], np.stack([w0, x3, -x2], -1), np.stack([-x3, w0, x1], -1),
                      np.stack([x2, -x1, w0], -1)], axis=1)
        R = quat_to_matrix(Q)
        Iw = (R * self.Iinv) @ R.transpose(0, 2, 1)
        l0, l1, l2 = L
        SL = np.array(((0.0, -l2, l1), (l2, 0.0, -l0), (-l1, l0, 0.0)))
        Om = np.array([((0.0, -a, -b, -c), (a, 0.0, -c, b), (b, c, 0.0, -a), (c, -b, a, 0.0)) for a, b, c in
                       (e[2] for e in st)])
        sc = (2.0 / np.einsum("ni,ni->n", Q, Q))[:, None, None]
        Aqq = 0.5 * (X @ (((Iw @ SL - Om[:, 1:, 1:]) @ X.transpose(0, 2, 1)) * sc) + Om)
        return Aqq, 0.5 * (X @ Iw)

    def state(self, y, h):
        """One RK4 step of the state alone, normalized (:func:`pbanim.design.flight.plain_step`)."""
        return self._advance(y, h)[0]

    def _advance(self, y, h):
        """(y₁, |q₁| before the normalization, the four stages) of one RK4 step of the state, on floats."""
        x0, x1, x2, w0, v1, v2, v3, p0, p1, p2 = y[:10].tolist()
        L = y[10:]
        st1 = self.stage((w0, v1, v2, v3), L)
        a1, b1, c1, d1 = st1[0]
        hh = 0.5 * h
        st2 = self.stage((w0 + hh * a1, v1 + hh * b1, v2 + hh * c1, v3 + hh * d1), L)
        a2, b2, c2, d2 = st2[0]
        st3 = self.stage((w0 + hh * a2, v1 + hh * b2, v2 + hh * c2, v3 + hh * d2), L)
        a3, b3, c3, d3 = st3[0]
        st4 = self.stage((w0 + h * a3, v1 + h * b3, v2 + h * c3, v3 + h * d3), L)
        a4, b4, c4, d4 = st4[0]
        h6 = h / 6.0
        q = (w0 + h6 * (a1 + 2.0 * a2 + 2.0 * a3 + a4), v1 + h6 * (b1 + 2.0 * b2 + 2.0 * b3 + b4),
             v2 + h6 * (c1 + 2.0 * c2 + 2.0 * c3 + c4), v3 + h6 * (d1 + 2.0 * d2 + 2.0 * d3 + d4))
        n = math.sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3])
        W, m, (g0, g1, g2), hg = self.W, self.m, self.gl, 0.5 * h * h
        y1 = np.array((x0 + h * W * p0 + hg * g0, x1 + h * W * p1 + hg * g1, x2 + h * W * p2 + hg * g2,
                       q[0] / n, q[1] / n, q[2] / n, q[3] / n, p0 + h * m * g0, p1 + h * m * g1, p2 + h * m * g2,
                       *L.tolist()))
        return y1, n, (st1, st2, st3, st4)

    def step(self, y, T, h, rate=False):
        """One RK4 step of (y, T) (T may be None), normalized; with ``rate`` also its d y₁/dh (13,)."""
        y1, n, st = self._advance(y, h)
        q1 = y1[3:7]
        if T is None and not rate:
            return y1, None
        Aqq, AqL = self._matrices(st, y[10:])
        T1 = None
        if T is not None:
            Zq = T[:, 3:7]
            B = T[:, 10:] @ AqL.transpose(0, 2, 1)              # δL's part of each stage (δL̇ = 0)
            K1 = Zq @ Aqq[0].T + B[0]
            K2 = (Zq + 0.5 * h * K1) @ Aqq[1].T + B[1]
            K3 = (Zq + 0.5 * h * K2) @ Aqq[2].T + B[2]
            K4 = (Zq + h * K3) @ Aqq[3].T + B[3]
            T1 = T.copy()
            T1[:, :3] += h * self.W * T[:, 7:10]
            Tq = Zq + h / 6.0 * (K1 + 2.0 * K2 + 2.0 * K3 + K4)
            Tq -= np.outer(Tq @ q1, q1)
            T1[:, 3:7] = Tq / n
        if not rate:
            return y1, T1
        k1, k2, k3, k4 = (np.array(e[0]) for e in st)
        d2 = Aqq[1] @ (0.5 * k1)
        d3 = Aqq[2] @ (0.5 * (k2 + h * d2))
        d4 = Aqq[3] @ (k3 + h * d3)
        r = np.zeros(13)
        r[:3] = self.W * y[7:10] + h * self.g
        rq = (k1 + 2.0 * k2 + 2.0 * k3 + k4) / 6.0 + h / 6.0 * (2.0 * d2 + 2.0 * d3 + d4)
        r[3:7] = (rq - (rq @ q1) * q1) / n
        r[7:10] = self.m * self.g
        return y1, T1, r

    def transport(self, pending, T, L):
        """T carried through the pending steps [(stages, |q₁|, q̂₁, h)] (no impact among them, so L is one):
        each step's tangent map built at once for all of them — the RK4 stages linearized,
        M = 𝟙 + h/6 (K₁ + 2K₂ + 2K₃ + K₄) with K₁ = A₁, K₂ = A₂(𝟙 + h/2 K₁), …, then the projection
        (𝟙 − q̂q̂ᵀ)/|q₁| — and applied in order (one product per step)."""
        k = len(pending)
        Aqq, AqL = self._matrices([e for p in pending for e in p[0]], L)
        Aqq, AqL = Aqq.reshape(k, 4, 4, 4), AqL.reshape(k, 4, 4, 3)
        h = np.array([p[3] for p in pending])[:, None, None]
        I4 = np.eye(4)
        Kz, Kl = Aqq[:, 0], AqL[:, 0]
        Mz, Ml = Kz.copy(), Kl.copy()
        for i, c in ((1, 0.5), (2, 0.5), (3, 1.0)):
            Kz, Kl = Aqq[:, i] @ (I4 + c * h * Kz), Aqq[:, i] @ (c * h * Kl) + AqL[:, i]
            w = 1.0 if i == 3 else 2.0
            Mz, Ml = Mz + w * Kz, Ml + w * Kl
        qh = np.array([p[2] for p in pending])
        P = (I4 - qh[:, :, None] * qh[:, None, :]) / np.array([p[1] for p in pending])[:, None, None]
        Pz, Pl = P @ (I4 + h / 6.0 * Mz), P @ (h / 6.0 * Ml)
        T = T.copy()
        C = np.einsum("pl,kql->kpq", T[:, 10:], Pl)
        PzT = Pz.transpose(0, 2, 1)
        Tq = T[:, 3:7]
        for j in range(k):
            Tq = Tq @ PzT[j] + C[j]
        T[:, 3:7] = Tq
        T[:, :3] += float(h.sum()) * self.W * T[:, 7:10]
        return T

    def rhs(self, y):
        """f(y) (13,), the flow's rate after an impact (the −f⁺δτ of the saltation)."""
        f = np.zeros(13)
        f[:3], f[3:7], f[7:10] = self.W * y[7:10], self.stage(tuple(y[3:7]), y[10:])[0], self.m * self.g
        return f

    def omega(self, y):
        """ω (world) at a unit-or-not state y, on floats."""
        return self.stage(tuple(y[3:7]), y[10:])[2]


def _box_run(scene, names, u, t_end: float, t_draw: np.ndarray, t_star, h: float):
    """(X at t_draw (K, 3), x(t*), ∂x(t*)/∂u (3, p), impacts [(t, feature, speed)]) or None (see the module).
    The flight grid has step ``h`` between 0, t* and t_end, as :func:`pbanim.design.simulate` with
    times=[t*]."""
    from .simulate import _model

    d = scene.values(names, u)
    sl = scene.slices(names)
    p = sum(s.stop - s.start for s in sl.values())
    y, Phi, dm, dIinv = scene._initial_state(d, sl, p)
    model = _model(scene, d, dm, dIinv)
    fl = _Flight(float(model.W[0]), float(model.m[0]), model.Iinv[0], model.g)
    T = Phi.T.copy() if t_star is not None else None
    nrm = np.array([d[f"normal{j}"] / np.linalg.norm(d[f"normal{j}"]) for j in range(len(scene.planes))]).reshape(-1, 3)
    feat = Features(scene)
    off, nrm_t = feat.off, [tuple(n) for n in nrm]
    c0j = np.einsum("ji,ji->j", nrm, feat.anchors[:len(nrm)])      # a box vertex has radius 0
    eps, dn0, de0 = float(d["restitution"][0]), np.zeros((p, len(scene.planes), 3)), np.zeros(p)

    nv = len(off) // max(1, len(nrm))                  # the features are plane-major: k = j·nv + vertex
    verts = off[:nv]

    def gaps_rates(yy):
        """Every feature's gap and its rate ġ = n·v + (R s)·(n × ω), as one product with the body frame."""
        R = _rot(yy[3:7])
        a, b, c = fl.omega(yy)
        M = np.concatenate([nrm @ R, np.array([(n1 * c - n2 * b, n2 * a - n0 * c, n0 * b - n1 * a)
                                               for n0, n1, n2 in nrm_t]) @ R], axis=0).T       # (3, 2J)
        V = verts @ M
        J = len(nrm_t)
        return (V[:, :J] + (nrm @ yy[:3] - c0j)).T.ravel(), (V[:, J:] + nrm @ (fl.W * yy[7:10])).T.ravel()

    def gap(k):
        """The gap of feature k alone (for Brent), on floats."""
        (n0, n1, n2), (s0, s1, s2), cj = nrm_t[k // nv], tuple(verts[k % nv]), float(c0j[k // nv])

        def fn(tt, yv):
            r00, r01, r02, r10, r11, r12, r20, r21, r22, _ = _rot_floats(yv[3:7])
            p0 = yv[0] + r00 * s0 + r01 * s1 + r02 * s2
            p1 = yv[1] + r10 * s0 + r11 * s1 + r12 * s2
            p2 = yv[2] + r20 * s0 + r21 * s1 + r22 * s2
            return n0 * p0 + n1 * p1 + n2 * p2 - cj
        return fn

    tol = lambda yy: 1e-9 * max(1.0, *(abs(v) for v in yy[:3].tolist()))  # noqa: E731  (simulate's contact_tol)
    g0, d0 = gaps_rates(y)
    if np.any(g0 <= max(tol(y), 1e-6)):
        return None                                     # touching at the start: the readable settle decides
    breaks = sorted({0.0, float(t_end)} | ({float(t_star)} if t_star is not None else set()))
    anchors, impacts = [(0.0, y[:3].copy(), y[7:10].copy())], []
    x_star = A = None
    pending = []                                        # steps whose tangent map is not applied yet
    for a, b in zip(breaks[:-1], breaks[1:]):
        grid = step_grid(a, b, h)
        for i in range(grid.n_steps):
            t = a + i * grid.h
            t1 = b if i == grid.n_steps - 1 else a + (i + 1) * grid.h
            dtau = None
            for _ in range(4 * MAX_IMPACTS + 4):
                if dtau is None:                        # the state now, its tangent when needed (transport)
                    y1, n1, st = fl._advance(y, t1 - t)
                    T1 = None
                else:
                    y1, T1, r = fl.step(y, T, t1 - t, rate=True)
                    T1 -= np.outer(dtau, r)
                g1, d1 = gaps_rates(y1)
                tl = tol(y)
                low = float(g1.min()) <= tl                  # else no gap can end the step inside or touching
                if low and np.any((np.abs(g0) <= tl) & (g1 < -tl)):
                    return None                         # touching, then inside: the readable settle decides
                y0 = y
                part = lambda s_, y0=y0: fl.state(y0, s_)  # noqa: E731  (the RK4 partial step)
                found = _dips(part, t, y0, g0, d0, g1, d1, t1 - t, tl, gap)
                if found is None:
                    return None                         # a tangent touch: the readable run decides
                hit = np.flatnonzero((g0 > tl) & (g1 <= 0)) if low else ()
                if len(hit):
                    evs = make_events([gap(k) for k in hit])
                    te, _, ev = crossings(evs, g0[hit], t, y0, t1, y1, t1 - t, part)[0]
                    found.append((te, int(hit[evs.index(ev)])))
                if not found:
                    if dtau is None and T is not None:
                        pending.append((st, n1, y1[3:7], t1 - t))
                    else:
                        T = T1
                    y, g0, d0 = y1, g1, d1
                    break
                te, k = min(found)
                if pending:
                    T, pending = fl.transport(pending, T, y[10:]), []
                if T is None:
                    ye, Te, rate = fl.state(y0, te - t), None, None
                else:
                    ye, Te, rate = fl.step(y0, T, te - t, rate=True)
                    if dtau is not None:
                        Te -= np.outer(dtau, rate)
                y, T, imp, dtau = apply_impact(model, feat, k, te, ye, Te, nrm, dn0, eps, de0, rate=rate)
                g0, d0 = gaps_rates(y)
                others = np.abs(g0) <= max(tol(y), 1e-6)
                others[k] = False
                if imp.speed < SLOW or d0[k] < SLOW or others.any() or len(impacts) >= MAX_IMPACTS:
                    return None                         # a graze, a rest, a second contact: the readable run
                impacts.append((te, k, imp.speed))
                anchors.append((te, y[:3].copy(), y[7:10].copy()))
                t = te
                if t1 - t <= 1e-14 * max(1.0, abs(t1)):
                    if T is not None:
                        T = T - np.outer(dtau, fl.rhs(y))
                    break
            else:
                return None
        if t_star is not None and b == float(t_star):
            if pending:
                T, pending = fl.transport(pending, T, y[10:]), []
            x_star, A = y[:3].copy(), T[:, :3].T.copy()
            T = None                                    # after t*: the drawing needs positions only
    X = np.empty((len(t_draw), 3))
    ta = np.array([a_[0] for a_ in anchors])
    idx = np.searchsorted(ta, t_draw, side="right") - 1
    for j, (t_a, x_a, P_a) in enumerate(anchors):
        sel = idx == j
        s = t_draw[sel] - t_a
        X[sel] = x_a + s[:, None] * (fl.W * P_a) + 0.5 * (s * s)[:, None] * fl.g
    return X, x_star, A, impacts


def _dips(part, t, y, g0, d0, g1, d1, h, tol, gap):
    """The readable run's test for a gap that dips inside the step: the Hermite candidates, then the true
    minimum along the partial step (bounded Brent); [(t_e, feature)] of the hidden impacts (in and out, located
    by Brent), or None when a gap touches (within ``tol``, no impulse: the readable run records it)."""
    from scipy.optimize import minimize_scalar

    out = []
    for k in hermite_dips(g0, d0, g1, d1, h, tol):
        fn = gap(k)
        low = minimize_scalar(lambda s: fn(0.0, part(s)), bounds=(0.0, h), method="bounded",
                              options={"xatol": 1e-9 * h})
        s, gk = float(low.x), float(low.fun)
        if gk < 0:
            ev = make_events([fn])
            out.append((crossings(ev, [g0[k]], t, y, t + s, part(s), s, part)[0][0], int(k)))
        elif gk <= tol:
            return None
    return out


def _rot_floats(q):
    """The nine entries of R(q/|q|) (row by row) and s = 2/|q|², on floats: the formula of
    :func:`pbanim.rigid.quat_to_matrix` for the few quaternions of one step."""
    w0, x1, x2, x3 = q
    s = 2.0 / (w0 * w0 + x1 * x1 + x2 * x2 + x3 * x3)
    xx, yy, zz, xy, xz, yz = s * x1 * x1, s * x2 * x2, s * x3 * x3, s * x1 * x2, s * x1 * x3, s * x2 * x3
    wx, wy, wz = s * w0 * x1, s * w0 * x2, s * w0 * x3
    return (1.0 - yy - zz, xy - wz, xz + wy, xy + wz, 1.0 - xx - zz, yz - wx, xz - wy, yz + wx, 1.0 - xx - yy, s)


def _rot(q):
    return np.array(_rot_floats(q)[:9]).reshape(3, 3)
