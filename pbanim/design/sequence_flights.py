"""The continuous problem of one impact sequence (chapter 10, issue 30 point 3; part of :mod:`pbanim.design`).

With the sequence σ = (j₁, …, j_K) of planes hit by a sphere fixed, multiple shooting takes the impacts as
its nodes: flight k starts at τ_k (τ₀ = 0) from the state just after impact k, (a_k, b_k), and

    x(t) = a_k + b_k s + ½ g s²,   s = t − τ_k,   τ_k ≤ t < τ_{k+1}.

The unknowns z = [a₀, b₀, (τ_k, a_k, b_k) for k = 1..K] obey, at every impact k (Δ = τ_k − τ_{k−1},
v⁻ = b_{k−1} + gΔ, R_j = 𝟙 − (1 + ε) n_j n_jᵀ: a frictionless sphere's impulse),

    a_{k−1} + b_{k−1}Δ + ½ gΔ² − a_k = 0,   R_j v⁻ − b_k = 0,   n_j·a_k − (n_j·o_j + r) = 0,

and the inequalities −n_j·v⁻ ≥ v_min (an approach), Δ ≥ Δ_min, τ_K < t_end, every a_k outside the other
planes. The sketch distance E = ½ Σ |x(t_i) − x̄_i|² and the goals x(t_g) = target are read on the flight
that holds the time. Every Jacobian is analytic: ∂x/∂a_k = 𝟙, ∂x/∂b_k = s𝟙, ∂x/∂τ_k = −(b_k + g s);
∂(continuity)/∂τ_k = (v⁻, R_j g), /∂τ_{k−1} = −(v⁻, R_j g).

The start: per flight a gravity parabola fitted to the sketch points inside it (weight 1), to the four
nearest outside (weight 0.1: the tangential motion is continuous through a frictionless impact) and to
its touches of the planes at both ends (weight 10), from the proposed impact times.

==========  ==============  ===========================================================
symbol      code            meaning
==========  ==============  ===========================================================
τ_k         ``z[6 + 7(k−1)]``  time of impact k
a_k, b_k    ``base(k)``     position at τ_k, velocity just after impact k
n_j, o_j    ``n, off``      plane normals; n_j·o_j + r, the offset of the centre's plane
==========  ==============  ===========================================================

Limiting cases: K = 0 is one parabola (single shooting of x₀, v₀); ε = 1 keeps |v| at each impact.

References: Popović, Seitz & Erdmann, ACM TOG 2003 §4; Posa, Cantu & Tedrake, IJRR 2014 (impact times
as unknowns); Bock & Plitt 1984 (multiple shooting).
"""

from __future__ import annotations

import numpy as np

__all__ = ["Flights", "planes_of"]


def _fit_flight(ts, X, g, a, b, touches):
    """(x(a), ẋ(a)) of the gravity parabola x(t) = x(a) + ẋ(a) s + ½ g s², s = t − a, fitted by least squares to
    the sketch points (ts, X) inside [a, b) (weight 1), the four nearest [a, b) outside (weight 0.1) and the
    touches (n, s, c): n·x(a + s) = c (weight 10)."""
    w = np.where((ts >= a) & (ts < b), 1.0, 0.0)
    near = np.argsort(np.minimum(np.abs(ts - a), np.abs(ts - b)))[:4]
    w[near] = np.maximum(w[near], 0.1)
    A, rhs = [], []
    for t, xb, wt in zip(ts, X, w):
        if wt > 0:
            s = t - a
            A.append(wt * np.hstack([np.eye(3), s * np.eye(3)]))
            rhs.append(wt * (xb - 0.5 * g * s * s))
    for nj, s, c in touches:
        A.append(10.0 * np.hstack([nj, s * nj])[None])
        rhs.append(10.0 * np.array([c - 0.5 * s * s * (nj @ g)]))
    return np.linalg.lstsq(np.vstack(A), np.concatenate(rhs), rcond=None)[0]


def planes_of(scene):
    """(normals (J, 3), n_j·o_j + r (J,)): the planes the centre of body 0 (a sphere of radius r) touches."""
    n = np.array([p.normal for p in scene.planes], dtype=float).reshape(-1, 3)
    return n, np.einsum("ji,ji->j", n, scene.anchors) + scene.bodies[0].shape.radius


def _end_row(fl, z, dt_min):
    """The last event at least dt_min before t_end (t_end − τ_K − Δ_min ≥ 0; with no event, 1 ≥ 0): (row,
    its Jacobian (1, size)), for a problem ``fl`` with ``K``, ``size``, ``t_end``, ``base`` and ``tau``."""
    last = np.zeros((1, fl.size))
    if fl.K:
        last[0, fl.base(fl.K)[0]] = -1.0
    return [fl.t_end - (fl.tau(z)[-1] if fl.K else 0.0) - (dt_min if fl.K else -1.0)], last


class Flights:
    """The continuous problem of one sequence: unknowns z = [a₀, b₀, (τ_k, a_k, b_k) for k = 1..K]."""

    def __init__(self, scene, planes, t_end, pts, goals):
        self.g, self.eps = scene.gravity, float(scene.restitution)
        self.n, self.off = planes_of(scene)
        self.planes, self.K, self.t_end = [int(j) for j in planes], len(planes), float(t_end)
        self.ts = np.array([t for t, _ in pts]).reshape(-1)
        self.X = np.array([x for _, x in pts]).reshape(-1, 3)
        self.goals = goals
        self.size = 6 + 7 * self.K

    def base(self, k):
        """Index of τ_k (k ≥ 1) and of a_k, b_k: (τ index or None, a slice, b slice)."""
        if k == 0:
            return None, slice(0, 3), slice(3, 6)
        i = 6 + 7 * (k - 1)
        return i, slice(i + 1, i + 4), slice(i + 4, i + 7)

    def tau(self, z):
        return np.concatenate([[0.0], z[6::7][:self.K]])

    def flight_of(self, z, t):
        return int(np.searchsorted(self.tau(z), t, side="right") - 1)

    def position(self, z, t):
        """(x(t), ∂x/∂z (3, size))."""
        k = self.flight_of(z, t)
        it, sa, sb = self.base(k)
        s = t - (0.0 if it is None else z[it])
        b = z[sb]
        J = np.zeros((3, self.size))
        J[:, sa] = np.eye(3)
        J[:, sb] = s * np.eye(3)
        if it is not None:
            J[:, it] = -(b + self.g * s)
        return z[sa] + b * s + 0.5 * self.g * s * s, J

    def objective(self, z):
        E, dE = 0.0, np.zeros(self.size)
        for t, xb in zip(self.ts, self.X):
            x, J = self.position(z, t)
            E += 0.5 * float((x - xb) @ (x - xb))
            dE += (x - xb) @ J
        return E, dE

    def equalities(self, z):
        """Continuity (position, velocity), contact at each impact, then the goals: (c, ∂c/∂z)."""
        rows, J = [], []
        for k in range(1, self.K + 1):
            i0, a0, b0 = self.base(k - 1)
            i1, a1, b1 = self.base(k)
            nj = self.n[self.planes[k - 1]]
            Rj = np.eye(3) - (1.0 + self.eps) * np.outer(nj, nj)
            dt = z[i1] - (0.0 if i0 is None else z[i0])
            vm = z[b0] + self.g * dt
            Jk = np.zeros((7, self.size))
            Jk[0:3, a0], Jk[0:3, b0], Jk[0:3, a1], Jk[0:3, i1] = np.eye(3), dt * np.eye(3), -np.eye(3), vm
            Jk[3:6, b0], Jk[3:6, b1], Jk[3:6, i1] = Rj, -np.eye(3), Rj @ self.g
            if i0 is not None:
                Jk[0:3, i0], Jk[3:6, i0] = -vm, -(Rj @ self.g)
            Jk[6, a1] = nj
            rows.append(np.concatenate([z[a0] + z[b0] * dt + 0.5 * self.g * dt * dt - z[a1], Rj @ vm - z[b1],
                                        [nj @ z[a1] - self.off[self.planes[k - 1]]]]))
            J.append(Jk)
        for gl in self.goals:
            x, Jx = self.position(z, gl.time)
            rows.append(x - gl.target)
            J.append(Jx)
        return np.concatenate(rows), np.vstack(J)

    def inequalities(self, z, v_min=1e-3, dt_min=1e-4):
        """Approach speed ≥ v_min at each impact, increasing impact times inside (0, t_end), every flight's
        start outside every plane: (h ≥ 0, ∂h/∂z)."""
        rows, J = [], []
        for k in range(1, self.K + 1):
            i0, _, b0 = self.base(k - 1)
            i1, a1, _ = self.base(k)
            nj = self.n[self.planes[k - 1]]
            dt = z[i1] - (0.0 if i0 is None else z[i0])
            r = np.zeros((2, self.size))
            r[0, b0], r[0, i1] = -nj, -(nj @ self.g)
            r[1, i1] = 1.0
            if i0 is not None:
                r[0, i0], r[1, i0] = nj @ self.g, -1.0
            rows.append([-(nj @ (z[b0] + self.g * dt)) - v_min, dt - dt_min])
            J.append(r)
        r, Jr = _end_row(self, z, dt_min)
        rows.append(r)
        J.append(Jr)
        for k in range(self.K + 1):
            _, a, _ = self.base(k)
            others = [j for j in range(len(self.off)) if k == 0 or j != self.planes[k - 1]]
            G = np.zeros((len(others), self.size))
            G[:, a] = self.n[others]
            rows.append(self.n[others] @ z[a] - self.off[others])
            J.append(G)
        return np.concatenate([np.atleast_1d(r) for r in rows]), np.vstack(J)

    def start(self, times):
        """z from the sketch and the impact-time guesses: per flight a gravity parabola fitted to its sketch
        points (weight 1), its neighbours' (weight 0.1) and its touches of the planes at both ends (weight 10)."""
        tau = np.concatenate([[0.0], np.asarray(times, float)])
        ends = np.append(tau[1:], self.t_end)
        z = np.zeros(self.size)
        for k in range(self.K + 1):
            a, b = tau[k], ends[k]
            touches = [(self.n[self.planes[kk - 1]], te - a, self.off[self.planes[kk - 1]])
                       for kk, te in ((k, a), (k + 1, b)) if 1 <= kk <= self.K]
            coef = _fit_flight(self.ts, self.X, self.g, a, b, touches)
            it, sa, sb = self.base(k)
            if it is not None:
                z[it] = a
            z[sa], z[sb] = coef[:3], coef[3:]
        return z
