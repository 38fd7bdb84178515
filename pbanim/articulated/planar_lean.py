"""The planar contact step in one pass: the lean form of :class:`PlanarKernel` + :class:`PlanarContactStep`.

A walking character takes thousands of steps of a tree with nine coordinates: each step's arithmetic is a
few dozen numpy operations on 9 × 9 arrays, and what the readable path pays on top — a kinematics dict, the
kernel's and the step's method calls, index arrays gathered again, the contact-mode certificate as twenty
array reductions — costs more than the arithmetic. :class:`LeanPlanarStep` takes the same step

    (H + h K_d) u⁺ = H q̇ + h (τ − C(q, q̇)) + Jᵀ z,        q⁺ = q + h u⁺

with everything that depends only on the tree and the contact points gathered once (the path matrix and the
axis columns as complex arrays, the contact points' rows of the path, their offsets, the ground's normal),
kinematics as plain local arrays, and the contact modes of the previous step tried first and certified on
Python floats. Every formula is the readable one's, operation for operation: the two paths give the same
states bit for bit (the tests compare whole walks, ORACLES I6, F4). Whatever the lean path does not handle
itself — a contact problem whose previous modes fail, a state or a step that overflows — it hands to the
readable step from the same state, which answers or raises exactly as it would have.

Notation as in :mod:`.planar` and :mod:`.planar_step`: q, q̇ joint coordinates; φ link angles; oᵢ, cᵢ joint
origins and centres of mass as complex numbers x + i y; H, C the mass matrix and the bias forces; J the
contact rows (normal, tangent per point); z their impulses; K_d the implicit damping gains.
"""

from __future__ import annotations

from math import isfinite

import numpy as np

try:                            # the gufuncs np.linalg.solve calls, without its per-call checks (same LAPACK)
    from numpy.linalg._umath_linalg import solve as _solve_many, solve1 as _solve_one
except ImportError:             # pragma: no cover - another numpy: the public function, same arithmetic
    _solve_many = _solve_one = np.linalg.solve

from ..contracts import unchecked
from ..lcp.planar import SEPARATE, SLIDE_NEG, SLIDE_POS, STICK, solve_planar_contact
from ..lcp.specs import LIMIT as _LIMIT
from .planar_step import PlanarContactStep

__all__ = ["LeanPlanarStep"]

_TOL = 1e-9                     # solve_planar_contact's default certificate tolerance


class LeanPlanarStep:
    """``LeanPlanarStep(step)``: the lean twin of a :class:`PlanarContactStep` (its kernel, points, ground).

    ``kinematics(q)`` → (rot, w, zo, zc); ``step(q, qd, h, tau, kd, kin)`` → (q⁺, u⁺, near, z), the
    readable :meth:`PlanarContactStep.step`'s result and its contact set and impulses. The readable step's
    ``modes`` are the lean one's (shared), so either path may take the next step.
    """

    def __init__(self, step: PlanarContactStep) -> None:
        k = step.kernel
        self.readable, self.kernel = step, k
        n = k.n
        self.n, self.nv = n, k.nv
        self.Phi, self.P, self.mass, self.Hrot, self.gz = k.Phi, k.P, k.mass, k._Hrot, k._gz
        self.rooted = k.parent >= 0
        self.parent, self.ez, self.rcz, self.Dz = k.parent, k._ez, k._rcz, k._Dz
        # the real matrices a product with a complex vector casts to complex at every call, cast once
        self.Pz, self.Pr, self.Rv = k.P.astype(complex), k.Pr, k.Rv.astype(complex)
        self.damping = k.damping
        self.diag = np.arange(k.nv) * (k.nv + 1)              # flat indices of a (nv, nv) matrix's diagonal
        self.links, self.r0z = step.links, step._r0z
        self.Pr_c, self.Dz_c = k.Pr[step.links], k._Dz[step.links]
        self.nbar, self.tbar = step._nbar, step._tbar
        self.mu, self.erp, self.margin, self.cfm = step.ground.mu, step.erp, step.margin, step.cfm
        self.modes = step.modes
        self._systems: dict = {}                              # contact modes → (rows, T) of the mode solve
        self._solve = unchecked(solve_planar_contact)
        self._readable_step = unchecked(step.step)
        self._kinematics = unchecked(k.kinematics)

    # -- the kernel's formulas (PlanarKernel.kinematics, _jacobians_z, _bias_z, dynamics) ----------------
    def kinematics(self, q):
        """(e^{iφ}, the parents' rotated placements w, joint origins o, centres c) as complex arrays."""
        rot = np.exp(1j * (self.Phi @ q))
        w = np.where(self.rooted, rot[self.parent], 1.0) * self.ez
        zo = self.Pz @ w + self.Dz @ q
        return rot, w, zo, zo + rot * self.rcz

    def com_jacobians(self, zo, zc):
        """The centres' complex Jacobians (n, nv)."""
        return (1j * (zc[:, None] - zo[None, :]) * self.Pr) @ self.Rv + self.Dz

    def dynamics(self, qd, w, zo, zc, Jz):
        """(H, C) with H q̈ + C = τ."""
        phid = self.Phi @ qd
        pd2 = np.where(self.rooted, phid[self.parent], 0.0) ** 2
        bias = -((self.P * pd2[None, :]) @ w) - phid ** 2 * (zc - zo)
        JmT = Jz.conj().T * self.mass
        return (JmT @ Jz).real + self.Hrot, (JmT @ (bias - self.gz)).real

    # -- the step --------------------------------------------------------------------------------------
    def step(self, q, qd, h, tau, kd, kin, Jz):
        """(q⁺, u⁺, near, z): :meth:`PlanarContactStep.step` from ``kin`` = :meth:`kinematics` (q) and the
        centres' Jacobians ``Jz``; ``kd`` None or the servos' implicit gains. Falls back to the readable
        step (which then answers or raises) when the arithmetic is not finite or the modes fail."""
        rot, w, zo, zc = kin
        try:
            with np.errstate(all="ignore"):
                out = self._lean(q, qd, h, tau, kd, rot, w, zo, zc, Jz)
        except np.linalg.LinAlgError:
            out = None
        if out is None:
            return self._fallback(q, qd, h, tau, kd)
        return out

    def _lean(self, q, qd, h, tau, kd, rot, w, zo, zc, Jz):
        H, C = self.dynamics(qd, w, zo, zc, Jz)
        Mt = H.copy()
        Mt.flat[self.diag] += h * (self.damping if kd is None else self.damping + kd)
        rhs = H @ qd + h * (tau - C)
        if not isfinite(Mt.sum() + rhs.sum()):
            return None
        links = self.links
        pz = zo[links] + rot[links] * self.r0z
        gap = (pz * self.nbar).real
        Jc = (1j * (pz[:, None] - zo[None, :]) * self.Pr_c) @ self.Rv + self.Dz_c
        vn = ((Jc @ qd) * self.nbar).real
        # the points near the ground, gap < margin + h max(−vₙ, 0) + 10 h², on Python floats (the same roundings)
        margin, hh10 = self.margin, h * h * 10.0
        gapl = gap.tolist()
        near = np.array([i for i, (gi, vi) in enumerate(zip(gapl, vn.tolist()))
                         if gi < margin + h * (-vi if -vi > 0.0 or -vi != -vi else 0.0) + hh10], dtype=np.intp)
        modes = self.modes
        if not near.size:
            u = _solve_one(Mt, rhs)
            modes[:] = SEPARATE
            z = None
        else:
            Jn = Jc[near]
            m2 = 2 * near.size
            R = np.empty((m2 + 1, self.nv))                     # [rhs, the contact rows]: one solve for both
            R[0], R[1::2], R[2::2] = rhs, (Jn * self.nbar).real, (Jn * self.tbar).real
            rows = R[1:]
            sol = _solve_many(Mt, R.T)
            u, MinvJt = sol[:, 0], sol[:, 1:]
            A = rows @ MinvJt
            dl = A.diagonal().tolist()
            if isfinite(sum(dl)):                               # A_ii += cfm max(max_j A_jj, 1e-300), on floats
                e = self.cfm * max(max(dl), 1e-300)
                A.flat[::m2 + 1] = [x + e for x in dl]
            else:                                               # NaN or inf: numpy's max, which carries them
                A.flat[::m2 + 1] += self.cfm * max(float(A.diagonal().max()), 1e-300)
            bl = (rows @ u).tolist()
            erp, nearl = self.erp, near.tolist()
            for j, gj in enumerate([gapl[i] for i in nearl]):         # b_n += max(g, 0)/h + erp min(g, 0)/h
                gp = gj if gj > 0.0 or gj != gj else 0.0
                gm = gj if gj < 0.0 or gj != gj else 0.0
                bl[2 * j] = bl[2 * j] + (gp / h + erp * gm / h)
            b = np.array(bl)
            ml = modes.tolist()
            guess0 = tuple(ml[i] for i in nearl)                # the previous step's modes
            z, guess = self._modes_solve(A, b, bl, guess0)
            if z is None:                                       # the lean rounds stop short: the readable solve
                if not (np.isfinite(A).all() and np.isfinite(b).all()):
                    return None
                z, guess, _ = self._solve(A, b, self.mu, np.array(guess0, dtype=modes.dtype))
            u = u + MinvJt @ z
            modes[:] = SEPARATE
            modes[near] = guess
        q1 = q + h * u
        if not isfinite(q1.sum() + u.sum()):
            return None
        return q1, u, near, z

    def _round(self, A, b, bl, guess):
        """One round of solve_planar_contact with the modes ``guess`` (a tuple): (z, whether every condition
        holds, z and w = A z + b as lists, the scale of the tolerance); None when b is not finite."""
        system = self._systems.get(guess)
        if system is None:
            system = self._systems[guess] = self._mode_system(np.array(guess))
        cols, T = system
        if cols is None:
            z = np.zeros(b.size)
        else:
            z = T @ _solve_one(A[cols] @ T, -b[cols])
        w = (A @ z + b).tolist()
        zl = z.tolist()
        scale = _TOL * (1.0 + max(map(abs, bl)))
        if not isfinite(scale + sum(bl)):
            return None
        mu = self.mu
        for i, md in enumerate(guess):
            zn, zt, wn, wt = zl[2 * i], zl[2 * i + 1], w[2 * i], w[2 * i + 1]
            if md == SEPARATE:
                ok = wn >= -scale
            else:
                ok = zn >= -scale and abs(wn) <= scale
                if md == STICK:
                    ok = ok and abs(zt) <= mu * zn + scale and abs(wt) <= scale
                elif md == SLIDE_POS:
                    ok = ok and wt >= -scale
                else:
                    ok = ok and wt <= scale
            if not ok:
                return z, False, zl, w, scale
        return z, True, zl, w, scale

    def _modes_solve(self, A, b, bl, guess):
        """(z, modes) of solve_planar_contact(A, b, μ, guess) when its mode switching finds them (its rounds,
        in its order: the modes imposed, the conditions checked, the failing modes switched, at most 3m + 3
        rounds); (None, guess) when it would go further (a round's z or w not finite, a singular system, A
        or b beyond the solver's limit, the modes cycling or the rounds used up: the readable solve then
        answers; a cycle means PGS, as every round is a function of the modes alone)."""
        out = self._round(A, b, bl, guess)
        if out is None:
            return None, guess
        if out[1]:
            return out[0], guess
        if not float(np.abs(A).max()) <= _LIMIT or not max(map(abs, bl)) <= _LIMIT:
            return None, guess
        mu, seen = self.mu, {guess}
        for _ in range(3 * len(guess) + 2):
            z, ok, zl, w, eps = out
            if not isfinite(sum(zl) + sum(w)):
                return None, guess
            new = []                                            # lcp.planar._switch_modes, contact by contact
            for i, md in enumerate(guess):
                zn, zt, wn, wt = zl[2 * i], zl[2 * i + 1], w[2 * i], w[2 * i + 1]
                nm = md
                if md == SEPARATE and wn < -eps:
                    nm = STICK
                if md != SEPARATE and zn < -eps:
                    nm = SEPARATE
                if md == STICK and abs(zt) > mu * zn + eps:
                    if zt > 0:
                        nm = SLIDE_NEG
                    if zt < 0:
                        nm = SLIDE_POS
                if (md == SLIDE_POS and wt < -eps) or (md == SLIDE_NEG and wt > eps):
                    nm = STICK
                new.append(nm)
            guess = tuple(new)
            if guess in seen:                                   # the modes cycle: no round will hold
                return None, guess
            seen.add(guess)
            out = self._round(A, b, bl, guess)
            if out[1]:
                return out[0], guess
        return None, guess

    def _mode_system(self, modes):
        """(rows, T) of solve_planar_contact's mode solve: the equations w_r = 0 and the map from their
        unknowns to z (a sliding contact's tangential impulse ∓μ zₙ folded in); (None, None) when no
        contact touches."""
        rows = []
        for i, md in enumerate(modes.tolist()):
            if md != SEPARATE:
                rows.append(2 * i)
            if md == STICK:
                rows.append(2 * i + 1)
        if not rows:
            return None, None
        cols = np.array(rows)
        T = np.zeros((2 * modes.size, cols.size))
        for c, r in enumerate(rows):
            T[r, c] = 1.0
            if r % 2 == 0 and modes[r // 2] in (SLIDE_POS, SLIDE_NEG):
                T[r + 1, c] = -self.mu if modes[r // 2] == SLIDE_POS else self.mu
        return cols, T

    def _fallback(self, q, qd, h, tau, kd):
        """The readable step from the same state and modes: its answer, or its named error."""
        q1, u = self._readable_step(q, qd, h, tau, kd, self._kinematics(q))
        last = self.readable.last
        return q1, u, last["near"], (last["impulses"] if last["near"].size else None)
