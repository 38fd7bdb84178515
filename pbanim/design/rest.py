"""Resting contact, touches and the certificate of a design trajectory (chapter 10, part of :mod:`pbanim.design`).

**Coming to rest.** A ball dropped on a floor with restitution ε < 1 bounces infinitely often in a finite
time (ORACLES D1): each bounce scales the normal speed by ε, so after an impact that leaves it with normal
speed v⁺ the remaining bounces end at the Zeno time

    t∞ = t + 2 v⁺ / (|a_n| (1 − ε)),        a_n = n·g < 0 (gravity presses the ball onto the plane),

and rise at most v⁺²/(2|a_n|). An event-driven S(t, u) cannot take infinitely many events, and a ball whose
bounces it stops taking sinks through the floor. Here a sphere *rests* on a plane from the moment it
touches it with normal speed |ġ| ≤ ``rest_speed`` while pressed in (g̈ < 0): after an impact whose rebound is
that slow, or when it arrives that slowly (ε = 0 treatment of slow contacts, as chapter 7's resting
threshold, ORACLES D10). The bounces it drops are recorded (:class:`Rest`: the speed and the Zeno time).

A resting sphere stays on the plane: n·(x − o) = r, n·v = 0. The design scene's impulses are frictionless,
so nothing stops it sliding: it keeps its tangential velocity and its spin, and on a tilted plane it
accelerates down the slope with g_t = g − (n·g) n — the motion the model says (friction would stop it; the
chapter has none). For a sphere the normal and tangential motions decouple, so the resting flow is the free
flow followed by the projection

    x ← x − n (n·(x − o) − r),   P ← P − n (n·P),   δx ← δx − n (n·δx),   δP ← δP − n (n·δP),

exact in the closed-form and the RK4 paths alike. Its derivative, the *resting* one, has ∂(n·x)/∂u = 0 and
∂(n·v)/∂u = 0 and the tangential rows of free flight: a perturbed ball comes to rest too, on the same plane
(stated in ``Trajectory.notes``; a free normal of that plane makes S not differentiable, said so).

**Touching features.** At the start and after every impact each feature that touches (|gap| ≤ tol) is
classified by its gap rate ġ and acceleration g̈ (ġ = n·(v + ω × s), g̈ = n·(g + ω̇ × s + ω × (ω × s)) for a
vertex s, ω̇ = −I_w⁻¹(ω × L); a sphere pair has ġ = n·w, g̈ = n·Δg + |w_⊥|²/d):

==========================================  =================================================================
ġ < 0 and not as below                       an impulse now (several: simultaneous, S not smooth)
|ġ| ≤ rest_speed, g̈ < 0                      rest (a sphere on one plane); else :class:`RestingContactError`
                                             (a box's vertex, two bodies, two planes: not in the model)
0 ≤ ġ ≤ rest_speed, g̈ ≥ 0, not the impact    a touch: grazing, reported (S is not differentiable there)
ġ > rest_speed                               separating
==========================================  =================================================================

**The certificate.** Every recorded state (the grid, the output times, the end) has every gap ≥
−``penetration_tol`` (a length in the scene's units): :func:`clearance_of`.

References: ORACLES D1 (the Zeno time), D10 (a resting threshold); Guendelman, Bridson & Fedkiw, SIGGRAPH
2003 (separating collision from resting contact); Popović et al. SIGGRAPH 2000 §4.2 (grazing impacts).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..collision import Sphere
from ..geometry import cross
from ..rigid import quat_to_matrix
from .impact import Impact, gaps
from .scene import RestingContactError

__all__ = ["Rest", "ContactState", "gap_rates", "gaps_many", "hermite_dips", "hermite_peak", "clearance_of"]


@dataclass
class Rest:                     # a record pbanim builds (simulate) and users read
    """Body ``body`` rests on plane ``plane`` from time ``t``; ``speed`` is the normal speed it left with (the
    bounces dropped rise at most speed²/2|a_n|) and ``zeno_time`` when they would have ended (ORACLES D1)."""

    t: float
    body: int
    plane: int
    speed: float
    zeno_time: float


def gap_rates(feat, model, y: np.ndarray, normals: np.ndarray, G: np.ndarray):
    """(ġ, g̈) of every feature (plane features, then sphere pairs) at y, bodies accelerating with G (N, 3)."""
    N = model.N
    x, q = y[:3 * N].reshape(N, 3), y[3 * N:7 * N].reshape(N, 4)
    P, L = y[7 * N:10 * N].reshape(N, 3), y[10 * N:13 * N].reshape(N, 3)
    R = quat_to_matrix(q)
    Iw_inv = np.matmul(R * model.Iinv[:, None, :], np.swapaxes(R, 1, 2))
    w = np.einsum("nij,nj->ni", Iw_inv, L)
    wdot = -np.einsum("nij,nj->ni", Iw_inv, cross(w, L))
    v = model.W[:, None] * P
    gd, gdd = np.empty(len(feat)), np.empty(len(feat))
    if feat.n_plane:
        i = feat.body
        s = np.einsum("fij,fj->fi", R[i], feat.off)
        n = normals[feat.plane]
        gd[:feat.n_plane] = np.einsum("fi,fi->f", n, v[i] + cross(w[i], s))
        acc = G[i] + cross(wdot[i], s) + cross(w[i], cross(w[i], s))
        gdd[:feat.n_plane] = np.einsum("fi,fi->f", n, acc)
    if len(feat.pairs):
        a, b = feat.pairs[:, 0], feat.pairs[:, 1]
        d, wv = x[a] - x[b], v[a] - v[b]
        dist = np.maximum(np.linalg.norm(d, axis=1), 1e-300)
        n = d / dist[:, None]
        vn = np.einsum("fi,fi->f", n, wv)
        gd[feat.n_plane:] = vn
        gdd[feat.n_plane:] = np.einsum("fi,fi->f", n, G[a] - G[b]) + (np.einsum("fi,fi->f", wv, wv) - vn * vn) / dist
    return gd, gdd


def gaps_many(feat, Y: np.ndarray, N: int, normals: np.ndarray) -> np.ndarray:
    """Gaps of every feature at every state of Y (K, 13N) → (K, F) (the certificate, vectorized)."""
    K = Y.shape[0]
    x = Y[:, :3 * N].reshape(K, N, 3)
    out = np.empty((K, len(feat)))
    if feat.n_plane:
        R = quat_to_matrix(Y[:, 3 * N:7 * N].reshape(K, N, 4))
        pc = x[:, feat.body] + np.einsum("kfij,fj->kfi", R[:, feat.body], feat.off)
        n = normals[feat.plane]
        out[:, :feat.n_plane] = np.einsum("fi,kfi->kf", n, pc - feat.anchors[feat.plane]) - feat.rad
    if len(feat.pairs):
        a, b = feat.pairs[:, 0], feat.pairs[:, 1]
        out[:, feat.n_plane:] = np.linalg.norm(x[:, a] - x[:, b], axis=2) - feat.radius[a] - feat.radius[b]
    return out


_U = np.linspace(0.0, 1.0, 65)[:, None]
_H = np.stack([2 * _U ** 3 - 3 * _U ** 2 + 1, _U ** 3 - 2 * _U ** 2 + _U,          # cubic Hermite basis
               -2 * _U ** 3 + 3 * _U ** 2, _U ** 3 - _U ** 2])


def hermite_dips(g0, d0, g1, d1, h: float, tol: float):
    """Features whose gap reaches a minimum inside a step (g > tol at both ends, ġ₀ < 0 < ġ₁) that the cubic
    Hermite interpolant of (g, ġ) puts near zero (within tol, or below half the smaller end gap): indices —
    candidates for a touch or for two crossings hidden in one step (the caller finds the true minimum)."""
    cand = np.flatnonzero((g0 > tol) & (g1 > tol) & (d0 < 0) & (d1 > 0))
    if cand.size == 0:
        return cand
    p = _H[0] * g0[cand] + _H[1] * h * d0[cand] + _H[2] * g1[cand] + _H[3] * h * d1[cand]
    low = p.min(axis=0) <= np.maximum(tol, 0.5 * np.minimum(g0[cand], g1[cand]))
    return cand[low]


class ContactState:
    """The contacts of one run of S(t, u): which spheres rest on which planes, the touches, the rests.

    ``impulse(k, t, y, T) → (y⁺, T⁺, Impact)`` applies feature k's impulse at the instant t (no
    impact-time correction); :meth:`settle` uses it for the touching features that approach.
    """

    def __init__(self, scene, model, feat, normals, dnormals, eps: float, rest_speed: float,
                 contact_tol: float) -> None:
        self.model, self.feat, self.normals, self.eps = model, feat, normals, float(eps)
        self.rest_speed, self.contact_tol = float(rest_speed), float(contact_tol)
        self.sphere = np.array([isinstance(b.shape, Sphere) for b in scene.bodies])
        self.moving = {j for j in range(normals.shape[0]) if np.any(dnormals[:, j])}
        self.acc_tol = 1e-9 * max(1.0, float(np.linalg.norm(model.g)))
        self.on: dict[int, int] = {}            # body → its resting plane feature
        self.rests: list[Rest] = []
        self.touches: list[Impact] = []
        self.notes: list[str] = []
        self.smooth = True
        self._G = None

    # ---- the resting set
    def tol(self, y) -> float:
        """The touching tolerance (a length): contact_tol · max(1, |x|∞)."""
        return self.contact_tol * max(1.0, float(np.abs(y[:3 * self.model.N]).max()))

    def gravity(self) -> np.ndarray:
        """Each body's acceleration (N, 3): g in flight, g − (n·g) n resting on a plane with normal n."""
        if self._G is None:
            g = self.model.g
            G = np.tile(g, (self.model.N, 1))
            for i, k in self.on.items():
                n = self.normals[self.feat.plane[k]]
                G[i] -= n * (n @ g)
            self._G = G
        return self._G

    def mask(self) -> np.ndarray:
        """True for the resting features (no events on them)."""
        m = np.zeros(len(self.feat), bool)
        m[list(self.on.values())] = True
        return m

    def project(self, y: np.ndarray, T: np.ndarray | None = None):
        """Keep every resting sphere on its plane: the normal position, momentum and their tangents (in place)."""
        N, feat = self.model.N, self.feat
        for i, k in self.on.items():
            j = feat.plane[k]
            n = self.normals[j]
            x, P = y[3 * i:3 * i + 3], y[7 * N + 3 * i:7 * N + 3 * i + 3]
            x -= n * (n @ (x - feat.anchors[j]) - feat.rad[k])
            P -= n * (n @ P)
            if T is not None and T.size:
                Tx, TP = T[:, 3 * i:3 * i + 3], T[:, 7 * N + 3 * i:7 * N + 3 * i + 3]
                Tx -= np.outer(Tx @ n, n)
                TP -= np.outer(TP @ n, n)
        return y, T

    def project_rows(self, rate: np.ndarray) -> np.ndarray:
        """A rate dy/dt (13N,) of the resting flow: the normal rows of x and P of resting spheres removed."""
        if self.on:
            self.project(np.zeros_like(rate), rate[None])
        return rate

    # ---- classification of touching features
    def _describe(self, k: int) -> str:
        feat = self.feat
        if k < feat.n_plane:
            i = int(feat.body[k])
            what = "sphere" if self.sphere[i] else "box vertex"
            return f"body {i} ({what}) on plane {int(feat.plane[k])}"
        a, b = (int(v) for v in feat.pairs[k - feat.n_plane])
        return f"bodies {a} and {b}"

    def touch(self, k: int, t: float, speed: float = 0.0) -> None:
        """Record a touch of feature k at t: a grazing contact without impulse (S not differentiable)."""
        feat = self.feat
        kind, body, other = ("plane", int(feat.body[k]), int(feat.plane[k])) if k < feat.n_plane else \
            ("pair", *(int(v) for v in feat.pairs[k - feat.n_plane]))
        self.touches.append(Impact(float(t), kind, body, other, float(speed), 0.0, grazing=True))

    def _start_rest(self, k: int, t: float, gd: float, gdd: float) -> None:
        feat = self.feat
        where = f"{self._describe(k)} at t = {t:.6g}"
        if k >= feat.n_plane or not self.sphere[feat.body[k]]:
            raise RestingContactError(
                f"{where} touch with normal speed {abs(gd):.3g} <= rest_speed = {self.rest_speed:g} while pressed "
                f"together (acceleration {gdd:.3g}): they come to rest, and the design model has resting contact "
                "for a sphere on one plane only; end the design before (t_end) or simulate it with pbanim.contact")
        i, j = int(feat.body[k]), int(feat.plane[k])
        if i in self.on:
            raise RestingContactError(
                f"{where}: body {i} rests on plane {int(feat.plane[self.on[i]])} and now also presses on plane {j}; "
                "resting on two planes at once is not in the design model (end the design before, t_end)")
        self.on[i] = k
        self._G = None
        speed = self.eps * -gd if gd < 0 else gd           # the rebound it would have had
        if speed == 0.0:
            zeno = t
        else:
            zeno = t + 2.0 * speed / (-gdd * (1.0 - self.eps)) if self.eps < 1.0 else np.inf
        self.rests.append(Rest(float(t), i, j, float(speed), float(zeno)))
        if j in self.moving:
            self.smooth = False
            self.notes.append(f"body {i} rests on plane {j} from t = {t:.6g}, whose normal is a free parameter: "
                              "the resting derivative with a turning plane is not computed (S not differentiable)")

    def settle(self, t: float, y: np.ndarray, T, impulse, hit: int = -1, max_passes: int = 100):
        """Classify every touching feature at (t, y) (see the module docstring) after the impact of feature
        ``hit`` (−1: the start); returns (y, T, the impulses applied). Projects the resting spheres."""
        feat, N, normals = self.feat, self.model.N, self.normals
        applied = []
        for _ in range(max_passes):
            g = gaps(feat, y, N, normals)
            gd, gdd = gap_rates(feat, self.model, y, normals, self.gravity())
            touching = np.abs(g) <= self.tol(y)
            slow = np.abs(gd) <= self.rest_speed
            pressed = gdd < -self.acc_tol
            approach = touching & (gd < 0) & ~(slow & pressed)
            if not approach.any():
                break
            for k in np.flatnonzero(approach):
                y2, T2, imp = impulse(int(k), t, y, T)
                if imp.speed > 0:
                    y, T = y2, T2
                    applied.append(imp)
        else:
            raise RestingContactError(f"at t = {t:.6g} the touching contacts still approach after {max_passes} "
                                      "rounds of impulses: they come to rest together, which the design model "
                                      "does not have (end the design before, t_end)")
        for k in np.flatnonzero(touching & slow):
            k = int(k)
            if k < feat.n_plane and self.on.get(int(feat.body[k])) == k:
                continue
            if pressed[k]:
                self._start_rest(k, t, float(gd[k]), float(gdd[k]))
            elif k != hit:
                self.touch(k, t, float(abs(gd[k])))
        for i, k in list(self.on.items()):
            if gd[k] > self.rest_speed or not touching[k]:
                del self.on[i]                         # an impulse lifted it: it flies again
                self._G = None
                self.notes.append(f"body {i} leaves plane {int(feat.plane[k])} at t = {t:.6g} (lifted by an impact)")
        self.project(y, T)
        return y, T, applied


def clearance_of(feat, Y: np.ndarray, N: int, normals: np.ndarray):
    """(min gap over every state of Y and every feature, index of that state, feature): the certificate."""
    if len(feat) == 0 or Y.shape[0] == 0:
        return np.inf, -1, -1
    G = gaps_many(feat, Y, N, normals)
    k = int(np.argmin(G))
    return float(G.flat[k]), k // G.shape[1], k % G.shape[1]


def hermite_peak(g0: float, d0: float, g1: float, d1: float, h: float) -> float:
    """Where the cubic Hermite interpolant of (g, ġ) over [0, h] is largest (a contact that left and came back)."""
    p = _H[0, :, 0] * g0 + _H[1, :, 0] * h * d0 + _H[2, :, 0] * g1 + _H[3, :, 0] * h * d1
    return float(_U[int(np.argmax(p)), 0] * h)
