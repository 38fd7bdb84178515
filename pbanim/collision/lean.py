"""The lean time-of-impact step of one particle among planes (chapter 06, part of :mod:`pbanim.collision`).

:func:`pbanim.collision.simulate_collisions` locates each impact as an event of :func:`pbanim.solve` and
answers it with the general machinery: the signed distances of every feature and their rates, the
resting-contact test, a call of the event solver per step, contact detection, Baraff's impulse loop and
the projection, then the post-step detection. For one particle under constant forces among static planes
(the bouncing ball of ORACLES D1, a ball in a box) every one of those has a closed form on floats, bound
once per run (:class:`LeanBall`):

    flight        one RK4 step on y = [x, v] with the constant acceleration a = W Q of the scene's forces
                  (the readable arithmetic, stage by stage);
    gaps          gᵢ = nᵢ·x − dᵢ − r,  ġᵢ = nᵢ·v  (plane i: normal nᵢ, offset dᵢ; particle radius r);
    impact        RK4 is exact on the parabola x(s) = x + s v + ½ s² a, so the root the event location finds
                  is the first root in (0, h] of gᵢ + s nᵢ·v + ½ s² nᵢ·a = 0 over the planes that start
                  apart (the state there: the RK4 step of size s);
    response      one contact, approaching faster than the restitution threshold v_rest:
                  J = −(1 + ε)(n·v)/(nᵀK n) n with K = W I,  v ← v + W J;  penetration d > 0 projected, x += d n.

A step that is anything else — a feature resting or touching (g ≤ v_rest h and slow), an impact at the
step's start, two contacts at once, an approach within a hair of the threshold, a contact left at the
end of the step — is handed, whole, to the readable step (nothing has been written before the hand-over).
The two agree to the root finder's tolerance (``tests/test_collision.py``, ORACLES D1).

==========================  ==================  ===============================
symbol                      code                shape
==========================  ==================  ===============================
y = [x, v]                  ``y``               list of 2 dim floats
nᵢ, dᵢ                      ``planes``          tuples of 3 floats, a float
a = W Q, W                  ``acc``, ``W``      dim floats, a float
ε, v_rest, r                ``eps``, ``vrest``, ``r``
==========================  ==================  ===============================
"""

from __future__ import annotations

from math import sqrt

import numpy as np

from ..contracts import Int, Obj, Real, contract, package_code_cached
from ..ode.driver import check_finite

__all__ = ["lean_ball"]

_HAIR = 1e-9          # relative distance to a threshold below which a step is handed to the readable one


@contract(scene=Obj("pbanim.scene:Scene"), col=Obj("pbanim.collision.scene:Collisions"),
          method=Obj("pbanim.ode.methods:Method"), gap_tol=Real(ge=0), max_events=Int(ge=1))
def lean_ball(scene, col, method, gap_tol: float, max_events: int) -> "LeanBall | None":
    """The lean plan of a run of :func:`~pbanim.collision.simulate_collisions` with ``toi="event"``, or None
    when the run does not qualify: one particle (``scene.system.kind == "particles"``), force effects all
    constant (``affine() -> (c, None)``), no constraint and no other post-step effect, ``col`` with planes
    only, no friction, the sequential mode, 0 < ε < 1, and RK4."""
    from ..scene import Scene

    system = scene.system
    if type(scene) is not Scene or getattr(system, "kind", None) != "particles" or system.N != 1 \
            or method.name != "rk4":
        return None
    if scene._constraint or any(e is not col for e in scene._post) or col.spheres or not col.planes:
        return None
    if col.friction != 0.0 or col.mode != "sequential" or not (0.0 < col.restitution < 1.0):
        return None
    # the trust rule (pbanim.contracts.package_code): the float step replaces the effect's response and the
    # forces' apply by their closed forms; a user's subclass or a copy of the module runs what it wrote
    if not package_code_cached(col, "respond", "post_step", "threshold", "gaps", "contacts", "diagnostics"):
        return None
    for e in scene._force:
        aff = getattr(e, "affine", None)
        if not callable(aff) or not package_code_cached(e, "apply", "affine") or aff()[1] is not None:
            return None
    W = float(system.W[0])
    if not W > 0:
        return None
    dim = system.dim
    Q = [0.0] * dim                       # the readable W Q: the constant forces summed in declaration order
    for e in scene._force:
        c = e.affine()[0]
        if c is not None:
            c = np.asarray(c, float).ravel().tolist()
            Q = [q + (c[i] if len(c) == dim else c[0]) for i, q in enumerate(Q)]
    acc = tuple(W * q for q in Q)
    return LeanBall(system.dim, W, acc, col, float(col.radius[0]), gap_tol, max_events)


class LeanBall:
    """One particle among planes: the float step of the module docstring, bound to one run."""

    def __init__(self, dim: int, W: float, acc: tuple, col, r: float, gap_tol: float, max_events: int) -> None:
        self.dim, self.W, self.acc, self.col, self.r = dim, W, acc, col, r
        self.gap_tol, self.max_events = gap_tol, max_events
        self.planes = tuple((tuple((p.normal.tolist() + [0.0, 0.0])[:3]), float(p.offset)) for p in col.planes)
        self.eps = col.restitution
        self.impacts: tuple = ([], [])     # where :meth:`run` appends the times and states of its impacts

    def rk4(self, y: list, h: float) -> list:
        """One RK4 step of ẏ = (v, a) as :func:`pbanim.ode.tableau.make_rk_step` computes it, on floats: the
        stages' velocities v + a(h/2), v + a(h/2), v + a h (their positions feed no rate), then
        y + ((k₀ + k₃)(h/6) + (k₁ + k₂)(h/3)) component by component — the same operations, bit for bit."""
        d = self.dim
        h2, hb, hc = h * 0.5, h * (1 / 6), h * (1 / 3)
        out = list(y)
        for i, a in enumerate(self.acc):
            v = y[d + i]
            s1, s3 = v + a * h2, v + a * h
            out[i] = y[i] + ((v + s3) * hb + (s1 + s1) * hc)
            out[d + i] = v + ((a + a) * hb + (a + a) * hc)
        return out

    def run(self, grid, y0: list, record_every: int, threshold, readable) -> tuple[list, int, int]:
        """The whole run on floats: (the recorded states as lists, the number of lean steps, of impacts located
        by them), the impacts' times and states appended to the lists ``self.impacts`` holds.

        A step whose start gaps are all above the event margin (``far``, as :meth:`step` tests them) and whose
        RK4 end gaps are all positive is a flight: taken here, with the smallest end gap kept for the next
        step's start (RK4 written out as :meth:`rk4`, bit for bit). Any other step goes to :meth:`step` (an
        impact located), and what that hands back to ``readable(k, t, y, h) -> y₁`` (the readable step, its
        response and its checks). Every state is checked as the driver checks it (|y|² finite, else
        :class:`~pbanim.errors.SimulationDiverged` naming the step). ``threshold(h)``: the restitution
        threshold of a step of size h."""
        n, t0, H, hl = grid.n_steps, grid.t0, grid.h, grid.h_last
        d, acc, planes, r = self.dim, self.acc, self.planes, self.r
        inf, last, every = float("inf"), n - 1, record_every - 1
        (n0, n1, n2), off0 = planes[0]
        single = len(planes) == 1
        rows, y = [list(y0)], list(y0)
        handed = located = 0                 # steps handed to the readable one, impacts located here
        all_rows = record_every == 1
        times, states = self.impacts
        cache: dict = {}                     # per flight length hs: a(hs/2), a hs, Δv per component, hs/6, hs/3
        lo = None                            # the smallest gap of y when a flight left it, else None
        hk, hs0 = H, None
        vrest = threshold(H)
        far = max(vrest * H, self.gap_tol) * (1 + _HAIR)
        for k in range(n):
            if k == last:                    # the last step, shortened to end at t_end: its own margins
                hk, vrest = hl, threshold(hl)
                far = max(vrest * hl, self.gap_tol) * (1 + _HAIR)
            t = t0 + k * H
            hs = (t + hk) - t                # the flight's length as :meth:`step` takes it (t₁ − t)
            if hs != hs0:
                hs0, inc = hs, cache.get(hs)
                if inc is None:
                    hb, hc, h2 = hs * (1 / 6), hs * (1 / 3), hs * 0.5
                    inc = []
                    for a in acc:
                        inc += (a * h2, a * hs, (a + a) * hb + (a + a) * hc)
                    inc = cache[hs] = (*inc, hb, hc)
                if d == 2:
                    p0, q0, w0, p1, q1, w1, hb, hc = inc
            if lo is None:
                lo = min([g for g, _, _ in self.gaps(y)])
            if lo > far:
                if d == 2:
                    x0, x1, v0, v1 = y
                    s = v0 + p0
                    x0 = x0 + ((v0 + (v0 + q0)) * hb + (s + s) * hc)
                    s = v1 + p1
                    x1 = x1 + ((v1 + (v1 + q1)) * hb + (s + s) * hc)
                    v0, v1 = v0 + w0, v1 + w1
                    y1 = [x0, x1, v0, v1]
                    norm = x0 * x0 + x1 * x1 + v0 * v0 + v1 * v1
                    if single:
                        lo = x0 * n0 + x1 * n1 - off0 - r
                    else:
                        lo = min([x0 * n_[0] + x1 * n_[1] - off - r for n_, off in planes])
                else:
                    y1 = list(y)
                    hb, hc = inc[-2:]
                    for i in range(3):
                        ah2, ah, dv = inc[3 * i:3 * i + 3]
                        v = y[3 + i]
                        s = v + ah2
                        y1[i] = y[i] + ((v + (v + ah)) * hb + (s + s) * hc)
                        y1[3 + i] = v + dv
                    x0, x1, x2 = y1[0], y1[1], y1[2]
                    lo = min([x0 * n_[0] + x1 * n_[1] + x2 * n_[2] - off - r for n_, off in planes])
                    norm = sum([u * u for u in y1])
                if 0.0 < lo:
                    if not norm < inf:       # |y|² overflows: what the driver names (SimulationDiverged)
                        check_finite(np.array(y1), t, k, "state")
                    y = y1
                    if all_rows or k % record_every == every or k == last:
                        rows.append(y)
                    continue
            lo = None
            out = self.step(t, y, hk, vrest)
            if out is None:
                y = readable(k, t, y, hk)
                handed += 1
            else:
                y, impacts, logs = out
                if not sum([u * u for u in y]) < inf:
                    check_finite(np.array(y), t, k, "state")
                for tc, yc in impacts:
                    times.append(tc)
                    states.append(np.array(yc))
                self.col.log += logs
                located += len(impacts)
            if all_rows or k % record_every == every or k == last:
                rows.append(y)
        return rows, n - handed, located

    def gaps(self, y: list) -> list:
        """(gᵢ, nᵢ·v, nᵢ) for every plane (x and v padded with z = 0)."""
        r = self.r
        if self.dim == 2:
            x0, x1, v0, v1 = y
            return [(x0 * n[0] + x1 * n[1] - off - r, v0 * n[0] + v1 * n[1], n) for n, off in self.planes]
        x0, x1, x2, v0, v1, v2 = y
        return [(x0 * n[0] + x1 * n[1] + x2 * n[2] - off - r, v0 * n[0] + v1 * n[1] + v2 * n[2], n)
                for n, off in self.planes]

    def step(self, t: float, y: list, hk: float, vrest: float):
        """(y₁, impacts, logs) of the step from t to t + hk, or None: the step is the readable one's."""
        t1, tol, d, acc = t + hk, self.gap_tol, self.dim, self.acc
        impacts, logs = [], []
        far = max(vrest * hk, tol) * (1 + _HAIR)
        for _ in range(self.max_events):
            now = self.gaps(y)
            active = []
            for i, (g, gd, _) in enumerate(now):
                if g > far:
                    active.append(i)                     # apart, whatever its rate: an event
                elif not (abs(g) <= 0.5 * tol and gd > _HAIR * (1 + vrest)):
                    return None                          # resting, touching, or at a threshold
            hseg = t1 - t                                # (else: just left the plane, no event, no impact)
            y1 = self.rk4(y, hseg)
            ends = self.gaps(y1)
            if not active or min(ends[i][0] for i in active) > 0.0:
                return self._end(y1, ends, impacts, logs)
            tau = hseg
            if min(ends[i][0] for i in active) != 0.0:
                for i in active:
                    if ends[i][0] <= 0.0:
                        g, gd, n = now[i]
                        ga = acc[0] * n[0] + acc[1] * n[1] + (acc[2] * n[2] if d == 3 else 0.0)
                        tau = min(tau, _first_root(g, gd, 0.5 * ga, hseg))
            yc = y1 if tau == hseg else self.rk4(y, tau)
            tc = t + tau
            at = self.gaps(yc)
            y, log = self._respond(tc, yc, at, vrest, max(10 * tol, 2 * min(abs(at[i][0]) for i in active)))
            if y is None:
                return None
            impacts.append((tc, y))
            logs.append(log)
            t = tc
            if t1 - t <= 1e-14 * max(1.0, abs(t1)):
                return self._end(y, self.gaps(y), impacts, logs)
        return None

    def _respond(self, t: float, y: list, gaps: list, vrest: float, margin: float):
        """Newton's impulse at the one contact within ``margin`` and the projection; (None, None) otherwise."""
        near = [(g, gd, n) for g, gd, n in gaps if -g >= -margin]
        if len(near) != 1:
            return None, None
        g, vn, n = near[0]
        d, W = self.dim, self.W
        v = y[d:] + [0.0] * (3 - d)
        speed = sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2])
        fast = max(vrest, 1e-12 * speed)
        if not -vn > fast * (1 + _HAIR) + _HAIR:
            return None, None                            # resting or grazing: the readable response
        nKn = (W * n[0]) * n[0] + (W * n[1]) * n[1] + (W * n[2]) * n[2]
        j = -(1 + self.eps) * vn / nKn
        J = (j * n[0], j * n[1], j * n[2])
        y = y[:d] + [u + W * Jk for u, Jk in zip(y[d:], J)]
        depth = -g
        if depth > 0:                                    # the projection: the deepest contact's share
            move = depth / W * W
            y[:d] = [u + move * nk for u, nk in zip(y[:d], n)]
        log = {"t": t, "contacts": 1, "impulse": float(j * (n[0] * n[0] + n[1] * n[1] + n[2] * n[2])),
               "vn_min": vn, "regime": ["colliding"]}
        return y, log

    def _end(self, y1: list, gaps: list, impacts: list, logs: list):
        """The step's result if nothing touches at its end (the post-step detection finds no contact)."""
        if any(g <= 0.0 for g, _, _ in gaps):
            return None
        return y1, impacts, logs


def _first_root(g: float, gd: float, c: float, h: float) -> float:
    """The first s in (0, h] with g + gd s + c s² = 0 (g > 0 ≥ the value at h), by the stable formula."""
    if c == 0.0:
        return min(h, -g / gd)
    disc = sqrt(max(gd * gd - 4.0 * c * g, 0.0))
    q = -0.5 * (gd + (disc if gd >= 0 else -disc))
    roots = [s for s in (q / c, g / q if q != 0 else h) if 0.0 < s <= h]
    return min(roots) if roots else h
