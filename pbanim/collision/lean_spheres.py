"""The lean response of a few particles among planes and each other (chapter 06, part of :mod:`pbanim.collision`).

:meth:`pbanim.collision.Collisions.respond` answers the contacts of a step with the general machinery: the
broad phase, contact records from the narrow phase, the body record of the impulse solver, Baraff's sequential
loop with its certificate, and the projection — a few dozen numpy calls on arrays of a few numbers. For the
package's own particle scenes with at most :data:`SMALL` particles, no sphere obstacle, no friction and the
sequential mode, :class:`LeanSpheres` takes the same response on floats, with what does not change during a
run bound once, when the effect is bound: the candidate pairs (every pair i < j of spheres, in the order the
broad phase sorts them), the planes, the inverse masses. Per step, on the state's floats:

    contacts     plane k, particle i: depth = rᵢ − (n·xᵢ − d), kept when depth ≥ −margin (normal n);
                 pair (j, i), i < j: n = (x_j − x_i)/|x_j − x_i|, depth = r_i + r_j − |x_j − x_i|
    no approach  u = v_a − v_b, v⁻ = n·u for every contact: when none is below −tol·S (S = max ‖u‖) nothing
                 collides and nothing rests, the impulses are zero and the certificate holds as it stands
                 (T⁺ = T⁻, no approach beyond tol·S): no impulse loop, no certificate to compute
    impact       Baraff's sequential loop of :func:`pbanim.collision.impulse.resolve_collisions`, operation for
                 operation (K = (W_a + W_b)𝟙, j = −(1 + ε) v⁻/nᵀKn, J = j n, the energy cap), then its
                 certificate (no approach beyond tol·S, T⁺ ≤ T⁻(1 + tol)), once per impact
    update       v += W J on a, −W J on b (accumulated in the readable order), then the projection: each
                 particle moved along its deepest contact's normal by its inverse-mass share of the depth

A step it cannot answer as the readable one would — contacts still approaching after the loop (resting
contact, handed to the plastic LCP), a certificate that fails, a non-finite value — returns None before
anything is written, and :meth:`~pbanim.collision.Collisions.respond` runs the readable response, which
answers or names the failure. The result record (``Collisions.last``, an
:class:`~pbanim.collision.impulse.ImpulseResult`) is built when it is read. The two responses agree to
roundoff (``tests/test_collision.py``, ORACLES D2, D17).

:meth:`LeanSpheres.floats` is the response on the flat state as a Python list: the float plan of a small
particle scene (:mod:`pbanim.particles.lean`) calls it on the list its drift leaves, so the cradle's whole step
runs on floats. The per-step path that meets no impact (a touching pair, the cradle between impacts) reads
the contacts, approach speeds and projection straight from the flat list, building the 3-vectors of the
velocities only for the impulse loop or when ``Collisions.last`` is read.
"""

from __future__ import annotations

from math import inf, sqrt

import numpy as np

__all__: list = []

#: at most this many particles take the float response (the pairs grow as N²; the vectorized one barely)
SMALL = 12
_TOL = 1e-12                # the certificate's relative tolerance (resolve_collisions' default)


def lean_spheres(col, system) -> "LeanSpheres | None":
    """The float response of ``col`` bound to ``system``, or None when the scene does not qualify (the module
    docstring; the package's own effect and particle system, :func:`pbanim.contracts.package_code`)."""
    from ..contracts import package_code
    from ..particles import ParticleSystem

    if col.rigid or col.spheres or col.friction != 0.0 or col.mode != "sequential" or system.N > SMALL:
        return None
    if not isinstance(system, ParticleSystem) or not package_code(system, "apply_impulses", "unpack", "state"):
        return None
    if not package_code(col, "respond", "post_step", "contacts", "bodies", "threshold", "_apply", "_project",
                        "_pair_contacts", "_candidates"):
        return None
    return LeanSpheres(col, system)


def quick_obstacles(col, N: int):
    """What tells an empty contact set of ``col`` (bound to N bodies), read once: the obstacles as arrays, when
    bodies cannot meet each other (one body, or point particles) and every body is a sphere or a point; else
    None (:meth:`~pbanim.collision.Collisions.respond` then builds the contact set)."""
    from .shapes import Sphere

    if col.rigid and not all(isinstance(s, Sphere) for s in col.shapes):
        return None
    if N > 1 and np.any(col.radius > 0):
        return None
    dim = 3 if col.rigid else col.dim
    normals = np.array([np.append(p.normal, [0.0] * 3)[:dim] for p in col.planes]).reshape(-1, dim)
    centres = np.array([c[:dim] for _, c in col.spheres]).reshape(-1, dim)
    return (np.ascontiguousarray(normals.T), np.array([p.offset for p in col.planes]), centres,
            np.array([sh.radius for sh, _ in col.spheres]))


def obstacles_apart(col, y, margin: float) -> bool:
    """Whether ``col.contacts(y, margin)`` would find none (a gap n·x − d − r or |x − c| − r − R above
    ``margin`` everywhere), from the arrays of :func:`quick_obstacles`: one product per kind of obstacle."""
    NT, off, C, R = col._quick
    x = col.system.unpack(y)[0]
    r = col.radius[:, None]
    if len(off) and not (x @ NT - off - r).min() > margin:
        return False
    if len(C):
        d = x[:, None, :] - C[None]
        if not (np.sqrt((d * d).sum(axis=2)) - r - R).min() > margin:
            return False
    return True


class LeanSpheres:
    """The float response of the module docstring, bound to one effect and its particle system."""

    tol = _TOL                  # the certificate's relative tolerance (a fused run's own test of no approach)

    def __init__(self, col, system) -> None:
        from ..contracts import unchecked

        self.col, self.N, self.dim, self.split = col, system.N, system.dim, system.split
        self.threshold = unchecked(col.threshold)
        self.pad = [0.0] * (3 - system.dim)
        self.W = [float(w) for w in system.W]
        r = [float(x) for x in col.radius]
        self.r = r
        self.planes = [(tuple(p.normal.tolist()), float(p.offset)) for p in col.planes]
        N, d = self.N, self.dim
        # (a, b, r_a + r_b, offsets of a and b, the sum again for the axis test: inf (no test) below 1e-150,
        # where dₖ² could underflow)
        self.pairs = [(j, i, r[i] + r[j], j * d, i * d, r[i] + r[j] if r[i] + r[j] > 1e-150 else inf)
                      for i in range(N) for j in range(i + 1, N) if r[i] > 0 and r[j] > 0]
        self.rows = [(i, i * d) for i in range(N)]          # (particle, offset of its position in the state)
        self.voff = [self.split + i * d for i in range(N)] + [None]     # of its velocity (the world: none)
        self.Wp = self.W + [0.0]
        self.zeros = [0.0] * (N + 1)                        # a move per body, the world's last

    # -- contacts ---------------------------------------------------------------------------------
    def contacts(self, flat: list, margin: float) -> list:
        """(a, b, normal, depth ≥ 0) of every contact at the flat state ``flat``, in the readable order. In
        2-D the particles' z is 0: the terms 0·n_z (plane) and 0 − 0 (pair) the readable 3-vectors carry are
        left out where they change no bit (a sum of squares plus +0; n·x plus ±0 when n·x ≠ 0, and when
        n·x = ±0 the depth r − (±0 − d) is the same number). A pair farther apart than r_a + r_b + margin along
        one axis is skipped before the square root: the rounded |d| = √(fl(Σ dₖ²)) is at least |dₖ| (√(fl(dₖ²))
        = |dₖ| where dₖ² does not underflow, and rounding is monotone), so its depth would fall below −margin too."""
        out = []
        r = self.r
        if self.dim == 2:
            for n, off in self.planes:
                n0, n1 = n[0], n[1]
                for i, k in self.rows:
                    depth = r[i] - ((flat[k] * n0 + flat[k + 1] * n1) - off)
                    if depth >= -margin:
                        out.append((i, -1, n, depth if depth > 0.0 else 0.0))
            lo = -margin
            for a, b, rr, ka, kb, rf in self.pairs:
                d0 = flat[ka] - flat[kb]
                # rf − |d₀| < −margin: the smaller of rf − d₀ and rf + d₀ (= rf − (−d₀) exactly) is below it
                if rf - d0 < lo or rf + d0 < lo:
                    continue            # |d| ≥ |dₖ| in floats too: the depth below is below −margin as well
                d1 = flat[ka + 1] - flat[kb + 1]
                if rf - d1 < lo or rf + d1 < lo:
                    continue
                dist = sqrt(d0 * d0 + d1 * d1)
                depth = rr - dist
                if depth >= lo:
                    out.append((a, b, (d0 / dist, d1 / dist, 0.0) if dist > 0 else (0.0, 0.0, 1.0),
                                depth if depth > 0.0 else 0.0))
            return out
        for n, off in self.planes:
            n0, n1, n2 = n
            for i, k in self.rows:
                depth = r[i] - ((flat[k] * n0 + flat[k + 1] * n1 + flat[k + 2] * n2) - off)
                if depth >= -margin:
                    out.append((i, -1, n, depth if depth > 0.0 else 0.0))
        for a, b, rr, ka, kb, rf in self.pairs:
            d0, d1, d2 = flat[ka] - flat[kb], flat[ka + 1] - flat[kb + 1], flat[ka + 2] - flat[kb + 2]
            if (rf - (d0 if d0 >= 0.0 else -d0) < -margin or rf - (d1 if d1 >= 0.0 else -d1) < -margin
                    or rf - (d2 if d2 >= 0.0 else -d2) < -margin):
                continue
            dist = sqrt(d0 * d0 + d1 * d1 + d2 * d2)
            depth = rr - dist
            if depth >= -margin:
                out.append((a, b, (d0 / dist, d1 / dist, d2 / dist) if dist > 0 else (0.0, 0.0, 1.0),
                            depth if depth > 0.0 else 0.0))
        return out

    def readable(self, t: float, y: np.ndarray, h: float, margin: float, plastic: bool) -> np.ndarray:
        """The effect's readable response (what answers a state :meth:`floats` hands off)."""
        return self.col._readable(t, y, h, margin, plastic)

    def velocities(self, flat: list) -> list:
        """The particles' velocities as 3-lists, and the world's row (zero) last."""
        s, d, pad = self.split, self.dim, self.pad
        v = [flat[k:k + d] + pad for k in range(s, s + self.N * d, d)]
        v.append([0.0, 0.0, 0.0])
        return v

    def approach(self, flat: list, c: list) -> tuple:
        """(v⁻ = n·(v_a − v_b) per contact, S = max ‖v_a − v_b‖) on the flat state: the readable 3-vector
        arithmetic (in 2-D the z terms are 0 − 0 = 0: n·u gets its + 0·n_z, ‖u‖² its + 0 dropped)."""
        vo, u0n, speed = self.voff, [], 0.0
        if self.dim == 2:
            for a, b, n, _ in c:
                ka, kb = vo[a], vo[b]
                if kb is None:
                    u0, u1 = flat[ka], flat[ka + 1]
                else:
                    u0, u1 = flat[ka] - flat[kb], flat[ka + 1] - flat[kb + 1]
                u0n.append(u0 * n[0] + u1 * n[1] + 0.0 * n[2])
                sp = sqrt(u0 * u0 + u1 * u1)
                if sp > speed:                  # max(speed, sp): the first of equals, NaN never taken
                    speed = sp
            return u0n, speed
        for a, b, n, _ in c:
            ka, kb = vo[a], vo[b]
            if kb is None:
                u0, u1, u2 = flat[ka], flat[ka + 1], flat[ka + 2]
            else:
                u0, u1, u2 = flat[ka] - flat[kb], flat[ka + 1] - flat[kb + 1], flat[ka + 2] - flat[kb + 2]
            u0n.append(u0 * n[0] + u1 * n[1] + u2 * n[2])
            sp = sqrt(u0 * u0 + u1 * u1 + u2 * u2)
            if sp > speed:
                speed = sp
        return u0n, speed

    # -- the response -----------------------------------------------------------------------------
    def respond(self, t: float, y: np.ndarray, h: float, margin: float, plastic: bool):
        """The new state, or None when the readable response must answer (see the module docstring); sets
        ``col.last`` (built when read) and appends to ``col.log`` as the readable response does."""
        flat = y.tolist()
        out = self.floats(t, flat, h, margin, plastic)
        return out if out is None else y if out is flat else np.array(out)

    def floats(self, t: float, flat: list, h: float, margin: float, plastic: bool, record: bool = True):
        """:meth:`respond` on the flat state as a list of floats: a new list, ``flat`` itself when nothing
        changes, or None (the readable response answers); the float plan of :mod:`pbanim.particles.lean` calls
        it after its own kick and drift, so a step makes no numpy call between its two conversions.
        ``record=False`` (a fused run's steps before its last, :mod:`pbanim.particles.lean_run`): a step with
        no impulse leaves ``col.last`` as it is (the run's last step sets it; a step with an impulse always
        sets it and logs it)."""
        col = self.col
        c = self.contacts(flat, margin)
        if not c:
            if record:
                col._last = None            # (Collisions.last's own slot: the property reads it)
            return flat
        u0n, speed = self.approach(flat, c)
        if not speed < inf:
            return None
        tol_s = _TOL * speed
        if min(u0n) >= -tol_s:          # nothing approaches: no impulse, the certificate holds as it stands
            if record:
                col._last = _Pending(self, flat, c, None, u0n, 1, 0, speed, self.threshold(h), None)
            return self._finish(flat, c, None)
        rest = self.threshold(h)
        v = self.velocities(flat)
        eps = 0.0 if plastic else col.restitution
        out = self._sequential(v, c, eps, max(rest, tol_s), speed, col.max_iter)
        if out is None:
            return None
        impulse, its, capped, T0, T1, vn1, speed1 = out
        jn = [J[0] * n[0] + J[1] * n[1] + J[2] * n[2] for J, (_, _, n, _) in zip(impulse, c)]
        pending = _Pending(self, v, c, impulse, u0n, its, capped, speed, rest, (T0, T1, vn1, speed1, jn))
        col.last = pending
        if any(j > 0 for j in jn):
            col.log.append({"t": t, "contacts": len(c), "impulse": float(np.sum(jn)), "vn_min": min(u0n),
                            "regime": pending.regimes().tolist()})
        return self._finish(flat, c, impulse)

    def _sequential(self, v, c, eps, fast, speed, max_iter):
        """Baraff's loop of :func:`pbanim.collision.impulse._sequential` on floats (``v`` updated in place), its
        end test and certificate: (impulses, sweeps, capped, T⁻, T⁺, v⁺ₙ, S⁺), or None for the readable one."""
        W, tol_s = self.W + [0.0], _TOL * speed
        T0 = self.energy(v)
        if not T0 < float("inf"):
            return None                          # the readable one names the non-finite energy
        impulse = [[0.0, 0.0, 0.0] for _ in c]
        capped = 0
        for its in range(1, max_iter + 1):
            vn = [_vn(v, a, b, n) for a, b, n, _ in c]
            hit = [i for i, x in enumerate(vn) if x < -fast]
            if not hit:
                break
            for i in hit:
                a, b, n, _ = c[i]
                va, vb = v[a], v[b]
                u = (va[0] - vb[0], va[1] - vb[1], va[2] - vb[2])
                w = W[a] + W[b]
                Kn = (n[0] * w, n[1] * w, n[2] * w)
                vni, nKn = n[0] * u[0] + n[1] * u[1] + n[2] * u[2], Kn[0] * n[0] + Kn[1] * n[1] + Kn[2] * n[2]
                if vni >= 0 or nKn <= 0:
                    continue
                j = -(1 + eps) * vni / nKn
                J = (j * n[0], j * n[1], j * n[2])
                work = J[0] * u[0] + J[1] * u[1] + J[2] * u[2]
                quad = 0.5 * ((J[0] * w) * J[0] + (J[1] * w) * J[1] + (J[2] * w) * J[2])
                if work + quad > 1e-12 * (abs(work) + quad):
                    f = min(1.0, -work / quad) if work < 0 else 0.0
                    J, capped = (J[0] * f, J[1] * f, J[2] * f), capped + 1
                wa, wb = W[a], W[b]
                va[0], va[1], va[2] = va[0] + wa * J[0], va[1] + wa * J[1], va[2] + wa * J[2]
                if b >= 0:
                    vb[0], vb[1], vb[2] = vb[0] + -wb * J[0], vb[1] + -wb * J[1], vb[2] + -wb * J[2]
                acc = impulse[i]
                acc[0], acc[1], acc[2] = acc[0] + J[0], acc[1] + J[1], acc[2] + J[2]
        else:
            return None                          # the sweep cap: the readable loop names it
        vn1 = [_vn(v, a, b, n) for a, b, n, _ in c]
        if min(vn1) < -tol_s:
            return None                          # resting contact left: the plastic LCP of the readable one
        speed1 = 0.0
        for a, b, _, _ in c:
            va, vb = v[a], v[b]
            u = (va[0] - vb[0], va[1] - vb[1], va[2] - vb[2])
            speed1 = max(speed1, sqrt(u[0] * u[0] + u[1] * u[1] + u[2] * u[2]))
        T1 = self.energy(v)
        tol_v = _TOL * max(speed, speed1)
        if not (max(0.0, -min(vn1)) <= tol_v and T1 <= T0 * (1 + _TOL) and speed1 < float("inf")):
            return None                          # the certificate fails: the readable one raises
        return impulse, its, capped, T0, T1, vn1, speed1

    def energy(self, v: list) -> float:
        """½ Σ |vᵢ|²/Wᵢ over the particles with Wᵢ > 0 (vₖ² as numpy squares: vₖ·vₖ, inf past overflow)."""
        terms = [(vi[0] * vi[0] + vi[1] * vi[1] + vi[2] * vi[2]) / w for vi, w in zip(v, self.W) if w > 0]
        return float(0.5 * np.sum(terms))

    def _finish(self, flat, c, impulse):
        """The state after the impulses (v += W J, the readable accumulation order) and the projection: a new
        list, ``flat`` when nothing moves, None when it overflows."""
        col, N, d, s, W = self.col, self.N, self.dim, self.split, self.W
        out, check = None, 0.0          # check: the sum of the entries written (non-finite if one of them is)
        if impulse is not None:
            dv = [[0.0, 0.0, 0.0] for _ in range(N)]
            for (a, _, _, _), J in zip(c, impulse):
                row, wa = dv[a], W[a]
                row[0], row[1], row[2] = row[0] + wa * J[0], row[1] + wa * J[1], row[2] + wa * J[2]
            for (_, b, _, _), J in zip(c, impulse):
                if b >= 0:
                    row, wb = dv[b], W[b]
                    row[0], row[1], row[2] = row[0] + wb * -J[0], row[1] + wb * -J[1], row[2] + wb * -J[2]
            out = list(flat)
            for i in range(N):
                for k in range(d):
                    out[s + i * d + k] += dv[i][k]
                    check += out[s + i * d + k]
        if col.project:
            # each body moved along its deepest contact's normal by its share of the depth: the last of the
            # largest moves in the readable order (a's, then b's), found in one pass
            Wp, dx = self.Wp, None
            for side, sign in ((0, 1.0), (1, -1.0)):
                for cc in c:
                    dep = cc[3]
                    if dep > 0:
                        if dx is None:
                            dx, best = {}, self.zeros[:]
                        a, b = cc[0], cc[1]
                        wsum = Wp[a] + Wp[b]
                        body = cc[side]
                        m = (dep / wsum if wsum > 0 else 0.0) * Wp[body]
                        if m > 0 and m >= best[body]:
                            best[body] = m
                            n = cc[2]
                            dx[body] = (sign * m * n[0], sign * m * n[1], sign * m * n[2])
            if dx:
                if out is None:
                    out = list(flat)
                for body, move in dx.items():
                    if 0 <= body < N:
                        k = body * d
                        out[k] += move[0]
                        out[k + 1] += move[1]
                        check += out[k] + out[k + 1]
                        if d == 3:
                            out[k + 2] += move[2]
                            check += out[k + 2]
        if out is None:
            return flat
        if check - check != 0.0:
            return None                           # an overflowing update: the readable one names it
        return out


def _vn(v, a, b, n) -> float:
    va, vb = v[a], v[b]
    return (va[0] - vb[0]) * n[0] + (va[1] - vb[1]) * n[1] + (va[2] - vb[2]) * n[2]


class _Pending:
    """What a lean response leaves for ``Collisions.last``: the :class:`ImpulseResult` built when read."""

    def __init__(self, lean, v, c, impulse, u0n, its, capped, speed, rest, done) -> None:
        # v: the step's velocities (3-lists, the world's row last), or with no impulse (done None) the flat state
        # they are read from when the record is built
        self.lean, self.v, self.c, self.impulse, self.u0n = lean, v, c, impulse, u0n
        self.its, self.capped, self.speed, self.rest, self.done = its, capped, speed, rest, done

    def regimes(self) -> np.ndarray:
        from .simultaneous import regimes

        return regimes(np.array(self.u0n), self.rest, _TOL * self.speed)

    def result(self):
        from .impulse import ImpulseResult

        c, m, v, impulse = self.c, len(self.c), self.v, self.impulse
        if self.done is None:                  # no impulse: the velocities, energy and approach as they stood
            v, impulse = self.lean.velocities(v), np.zeros((m, 3))
            T = self.lean.energy(v)
            vn1, speed1, jn, T0, T1 = self.u0n, self.speed, [0.0] * m, T, T
        else:
            T0, T1, vn1, speed1, jn = self.done
        return ImpulseResult(np.array(v[:-1]), np.zeros((self.lean.N, 3)), np.array(impulse, float),
                             np.array(jn, float), np.zeros(m, bool), self.its, "sequential", 0.0,
                             {"rounds": 0, "plastic_finish": False, "energy_capped": self.capped}, self.regimes(),
                             max(0.0, -min(vn1)), T0, T1, _TOL * max(self.speed, speed1))
