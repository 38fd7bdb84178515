"""The continuous problem of one event sequence of several spheres (chapter 10, issue 30 point 3; part of
:mod:`pbanim.design`).

The one-sphere problem (:mod:`pbanim.design.sequence_flights`) for B spheres: the sequence
σ = (e₁, …, e_K) of events e_k = (a, plane j) or (a, sphere b) is fixed, and the nodes of multiple shooting
are the events of *any* body. Between τ_{k−1} and τ_k every body flies its own parabola,

    x_i(t) = a_{k,i} + b_{k,i} s + ½ g s²,   s = t − τ_k,

and the unknowns z = [A₀, V₀, (τ_k, A_k, V_k) for k = 1..K] (A_k, V_k: the B positions and the B velocities
just after event k) obey at every event (Δ = τ_k − τ_{k−1}, v⁻ = V_{k−1} + gΔ)

    A_{k−1} + V_{k−1}Δ + ½ gΔ² − A_k = 0,     P_k(v⁻, A_k) − V_k = 0,     g_k(A_k) = 0,

where P_k leaves every body not in e_k as it is and

* a plane j: v_a⁺ = R_j v_a⁻, R_j = 𝟙 − (1 + ε) n_j n_jᵀ;  g_k = n_j·a_a − n_j·o_j − r_a;
* a sphere b (frictionless, chapter 6's impulse between two free bodies): n = (a_a − a_b)/|a_a − a_b|,
  w = n·(v_a⁻ − v_b⁻),  v_a⁺ = v_a⁻ − (1 + ε) m_b/(m_a + m_b) w n,  v_b⁺ = v_b⁻ + (1 + ε) m_a/(m_a + m_b) w n
  (m_a v_a + m_b v_b unchanged, w reversed and scaled by ε);  g_k = |a_a − a_b| − r_a − r_b.

The inequalities: an approach at each event (−n_j·v_a⁻ ≥ v_min, or −w ≥ v_min), Δ ≥ Δ_min, τ_K < t_end, and
at every node every body outside every plane and every other sphere it is not touching there. The sketch
distance E = ½ Σ_i Σ |x_i(t) − x̄_i|² over each body's sketch points, the goals x_i(t_g) = target. Every
Jacobian is analytic; the pair impulse's, with N = (𝟙 − nnᵀ)/|a_a − a_b|,

    ∂(w n)/∂v_a⁻ = nnᵀ = −∂(w n)/∂v_b⁻,    ∂(w n)/∂a_a = n (N(v_a⁻ − v_b⁻))ᵀ + w N = −∂(w n)/∂a_b.

The start: per body a gravity parabola per flight between its own events (:func:`_fit_flight`: its sketch
points, their neighbours, its plane touches), read at every node.

==========  ===============  ======================================================
symbol      code             meaning
==========  ===============  ======================================================
e_k         ``events[k−1]``  (a, "plane", j) or (a, "body", b), a < b
τ_k         ``z[base(k)[0]]``  time of event k
A_k, V_k    ``base(k)``      positions at τ_k, velocities just after event k (B × 3 each)
m, r        ``m, r``         masses, radii
==========  ===============  ======================================================

Limiting cases: B = 1 is the one-sphere problem's equations; equal masses and ε = 1 exchange the normal
velocities of a pair.

References: Popović, Seitz & Erdmann, ACM TOG 2003 §4; Posa, Cantu & Tedrake, IJRR 2014 (event times as
unknowns); Bock & Plitt 1984 (multiple shooting); Baraff 2001 notes §8 (the impulse).
"""

from __future__ import annotations

import numpy as np

from .sequence_flights import _end_row, _fit_flight

__all__ = ["BodyFlights", "pair_impulse"]


def pair_impulse(va, vb, d, ma, mb, eps):
    """The velocities after a frictionless impact of spheres a, b (d = a_a − a_b, the normal along d) and
    the Jacobian of (v_a⁺, v_b⁺) (6,) with respect to (v_a⁻, v_b⁻, d) (6 × 9)."""
    rho = float(np.linalg.norm(d))
    n = d / rho
    vr = va - vb
    w = float(n @ vr)
    N = (np.eye(3) - np.outer(n, n)) / rho
    c = 1.0 + eps
    mua, mub = mb / (ma + mb), ma / (ma + mb)
    nn = np.outer(n, n)
    dwn_d = np.outer(n, N @ vr) + w * N
    J = np.zeros((6, 9))
    J[0:3, 0:3], J[0:3, 3:6], J[0:3, 6:9] = np.eye(3) - c * mua * nn, c * mua * nn, -c * mua * dwn_d
    J[3:6, 0:3], J[3:6, 3:6], J[3:6, 6:9] = c * mub * nn, np.eye(3) - c * mub * nn, c * mub * dwn_d
    return np.concatenate([va - c * mua * w * n, vb + c * mub * w * n]), J


class BodyFlights:
    """The continuous problem of one event sequence of B spheres: z = [A₀, V₀, (τ_k, A_k, V_k) for k = 1..K]."""

    def __init__(self, scene, events, t_end, sketches, goals):
        self.B, self.g, self.eps = scene.N, scene.gravity, float(scene.restitution)
        self.r = np.asarray(scene.radius, float)
        self.m = np.array([b.mass for b in scene.bodies], float)
        self.n = np.array([p.normal for p in scene.planes], dtype=float).reshape(-1, 3)
        self.off = np.einsum("ji,ji->j", self.n, scene.anchors)          # n_j·o_j (no radius)
        self.events, self.K, self.t_end = [tuple(e) for e in events], len(events), float(t_end)
        self.sketches = [(np.array([t for t, _ in p]).reshape(-1), np.array([x for _, x in p]).reshape(-1, 3))
                         for p in sketches]
        self.goals = goals
        self.M = 6 * self.B
        self.size = self.M + (self.M + 1) * self.K
        self.gt = np.tile(self.g, self.B)

    def base(self, k):
        """(τ index or None, A slice, V slice) of node k."""
        i = 0 if k == 0 else self.M + (self.M + 1) * (k - 1) + 1
        return (None if k == 0 else i - 1), slice(i, i + 3 * self.B), slice(i + 3 * self.B, i + self.M)

    def tau(self, z):
        return np.concatenate([[0.0], [z[self.base(k)[0]] for k in range(1, self.K + 1)]])

    def position(self, z, body, t):
        """(x_body(t), ∂x/∂z (3, size))."""
        k = int(np.searchsorted(self.tau(z), t, side="right") - 1)
        it, sa, sb = self.base(k)
        s = t - (0.0 if it is None else z[it])
        ia, ib = sa.start + 3 * body, sb.start + 3 * body
        b = z[ib:ib + 3]
        J = np.zeros((3, self.size))
        J[:, ia:ia + 3], J[:, ib:ib + 3] = np.eye(3), s * np.eye(3)
        if it is not None:
            J[:, it] = -(b + self.g * s)
        return z[ia:ia + 3] + b * s + 0.5 * self.g * s * s, J

    def objective(self, z):
        """(E, ∂E/∂z): every body's sketch points read on the flight that holds their time, all at once."""
        tau = self.tau(z)
        E, dE = 0.0, np.zeros(self.size)
        starts = np.array([self.base(k)[1].start for k in range(self.K + 1)])
        for body, (ts, X) in enumerate(self.sketches):
            k = np.searchsorted(tau, ts, side="right") - 1
            s = (ts - tau[k])[:, None]
            ia = starts[k][:, None] + 3 * body + np.arange(3)
            ib = ia + 3 * self.B
            b = z[ib]
            res = z[ia] + b * s + 0.5 * self.g * s * s - X
            E += 0.5 * float(np.sum(res * res))
            np.add.at(dE, ia, res)
            np.add.at(dE, ib, res * s)
            has = k > 0
            np.add.at(dE, starts[k[has]] - 1, -np.sum(res[has] * (b[has] + self.g * s[has]), axis=1))
        return E, dE

    def _event(self, z, k):
        """Event k's pieces: (τ indices, A/V slices before and after, Δ, v⁻)."""
        i0, a0, b0 = self.base(k - 1)
        i1, a1, b1 = self.base(k)
        dt = z[i1] - (0.0 if i0 is None else z[i0])
        return i0, a0, b0, i1, a1, b1, dt, z[b0] + self.gt * dt

    def equalities(self, z):
        """Continuity of every body's position, the event's velocity law, its contact, then the goals."""
        rows, J = [], []
        M3 = 3 * self.B
        for k in range(1, self.K + 1):
            i0, a0, b0, i1, a1, b1, dt, vm = self._event(z, k)
            a, kind, o = self.events[k - 1]
            Pv, Px, post = np.eye(M3), np.zeros((M3, M3)), vm.copy()
            Jc = np.zeros(self.size)
            sa = slice(a1.start + 3 * a, a1.start + 3 * a + 3)
            if kind == "plane":
                nj = self.n[o]
                Pv[3 * a:3 * a + 3, 3 * a:3 * a + 3] -= (1.0 + self.eps) * np.outer(nj, nj)
                post[3 * a:3 * a + 3] = Pv[3 * a:3 * a + 3, 3 * a:3 * a + 3] @ vm[3 * a:3 * a + 3]
                gap = nj @ z[sa] - self.off[o] - self.r[a]
                Jc[sa] = nj
            else:
                sb = slice(a1.start + 3 * o, a1.start + 3 * o + 3)
                d = z[sa] - z[sb]
                pv, Jp = pair_impulse(vm[3 * a:3 * a + 3], vm[3 * o:3 * o + 3], d, self.m[a], self.m[o], self.eps)
                ia, ib = slice(3 * a, 3 * a + 3), slice(3 * o, 3 * o + 3)
                post[ia], post[ib] = pv[:3], pv[3:]
                for rs, J6 in ((ia, Jp[:3]), (ib, Jp[3:])):
                    Pv[rs, ia], Pv[rs, ib] = J6[:, 0:3], J6[:, 3:6]
                    Px[rs, ia], Px[rs, ib] = J6[:, 6:9], -J6[:, 6:9]
                rho = float(np.linalg.norm(d))
                gap = rho - self.r[a] - self.r[o]
                Jc[sa], Jc[sb] = d / rho, -d / rho
            Jk = np.zeros((2 * M3 + 1, self.size))
            Jk[:M3, a0], Jk[:M3, b0], Jk[:M3, a1], Jk[:M3, i1] = np.eye(M3), dt * np.eye(M3), -np.eye(M3), vm
            Jk[M3:2 * M3, b0], Jk[M3:2 * M3, b1], Jk[M3:2 * M3, i1] = Pv, -np.eye(M3), Pv @ self.gt
            Jk[M3:2 * M3, a1] += Px
            if i0 is not None:
                Jk[:M3, i0], Jk[M3:2 * M3, i0] = -vm, -(Pv @ self.gt)
            Jk[2 * M3] = Jc
            rows.append(np.concatenate([z[a0] + z[b0] * dt + 0.5 * self.gt * dt * dt - z[a1], post - z[b1], [gap]]))
            J.append(Jk)
        for gl in self.goals:
            x, Jx = self.position(z, gl.body, gl.time)
            rows.append(x - gl.target)
            J.append(Jx)
        return np.concatenate(rows), np.vstack(J)

    def inequalities(self, z, v_min=1e-3, dt_min=1e-4):
        """An approach at each event, increasing times inside (0, t_end), every node clear of the planes and
        spheres not touched there (squared distances for pairs): (h ≥ 0, ∂h/∂z)."""
        rows, J = [], []
        for k in range(1, self.K + 1):
            i0, a0, b0, i1, a1, b1, dt, vm = self._event(z, k)
            a, kind, o = self.events[k - 1]
            r = np.zeros((2, self.size))
            ja = slice(b0.start + 3 * a, b0.start + 3 * a + 3)
            if kind == "plane":
                nj = self.n[o]
                r[0, ja], r[0, i1] = -nj, -(nj @ self.g)
                if i0 is not None:
                    r[0, i0] = nj @ self.g
                app = -(nj @ vm[3 * a:3 * a + 3])
            else:
                jb = slice(b0.start + 3 * o, b0.start + 3 * o + 3)
                d = z[a1.start + 3 * a:a1.start + 3 * a + 3] - z[a1.start + 3 * o:a1.start + 3 * o + 3]
                rho = float(np.linalg.norm(d))
                n, vr = d / rho, vm[3 * a:3 * a + 3] - vm[3 * o:3 * o + 3]
                Nv = (vr - n * (n @ vr)) / rho
                r[0, ja], r[0, jb] = -n, n                    # gravity moves both alike: no τ terms
                r[0, a1.start + 3 * a:a1.start + 3 * a + 3], r[0, a1.start + 3 * o:a1.start + 3 * o + 3] = -Nv, Nv
                app = -(n @ vr)
            r[1, i1] = 1.0
            if i0 is not None:
                r[1, i0] = -1.0
            rows.append([app - v_min, dt - dt_min])
            J.append(r)
        r, Jr = _end_row(self, z, dt_min)
        rows.append(r)
        J.append(Jr)
        for k in range(self.K + 1):
            _, sa, _ = self.base(k)
            e = self.events[k - 1] if k else None
            for i in range(self.B):
                ia = sa.start + 3 * i
                x = z[ia:ia + 3]
                planes = [j for j in range(len(self.off)) if not (e and e[1] == "plane" and e[0] == i and e[2] == j)]
                G = np.zeros((len(planes), self.size))
                G[:, ia:ia + 3] = self.n[planes]
                rows.append(self.n[planes] @ x - self.off[planes] - self.r[i])
                J.append(G)
                for l in range(i + 1, self.B):
                    if e and e[1] == "body" and (e[0], e[2]) == (i, l):
                        continue
                    il = sa.start + 3 * l
                    d = x - z[il:il + 3]
                    G = np.zeros((1, self.size))
                    G[0, ia:ia + 3], G[0, il:il + 3] = 2 * d, -2 * d
                    rows.append([d @ d - (self.r[i] + self.r[l]) ** 2])
                    J.append(G)
        return np.concatenate([np.atleast_1d(np.asarray(r, float)) for r in rows]), np.vstack(J)

    def start(self, times):
        """z from the sketches and the event-time guesses: per body a parabola per flight between its own
        events (:func:`_fit_flight`), read at every node."""
        tau = np.concatenate([[0.0], np.asarray(times, float)])
        z = np.zeros(self.size)
        for i, (ts, X) in enumerate(self.sketches):
            own = [k for k in range(1, self.K + 1) if i in (self.events[k - 1][0], self.events[k - 1][2])
                   and (self.events[k - 1][1] == "body" or self.events[k - 1][0] == i)]
            edges = [0] + own
            for q, k0 in enumerate(edges):
                a = tau[k0]
                b = tau[edges[q + 1]] if q + 1 < len(edges) else self.t_end
                touches = [(self.n[self.events[kk - 1][2]], tau[kk] - a, self.off[self.events[kk - 1][2]] + self.r[i])
                           for kk in (k0, edges[q + 1] if q + 1 < len(edges) else 0)
                           if kk and self.events[kk - 1][1] == "plane"]
                c = _fit_flight(ts, X, self.g, a, b, touches)
                last = edges[q + 1] if q + 1 < len(edges) else self.K + 1
                for k in range(k0, last):
                    it, sa, sb = self.base(k)
                    s = tau[k] - a
                    z[sa.start + 3 * i:sa.start + 3 * i + 3] = c[:3] + c[3:] * s + 0.5 * self.g * s * s
                    z[sb.start + 3 * i:sb.start + 3 * i + 3] = c[3:] + self.g * s
                    if it is not None:
                        z[it] = tau[k]
        return z
