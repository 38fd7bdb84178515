"""The simultaneous impulse law, applied in rounds until no contact approaches (chapter 06).

One *round* is one impulse vector for all contacts at once (see :mod:`pbanim.collision.impulse`):
compression by the plastic LCP w = A f_c + v⁻ ≥ 0 ⊥ f_c ≥ 0 (A = J W Jᵀ, W = M⁻¹), restitution by
Poisson's hypothesis f = f_c + s ε f_c, then friction (``"staggered"``: contact by contact; ``"lcp"``:
in the same LCP with a pyramidal cone). A round never creates kinetic energy, but it may leave a contact
approaching: the restitution part ε f_c pulls on the neighbours of a compressed contact through the
off-diagonal entries of A (a contact with f_c = 0 and w ≈ 0 is dragged into approach), and a friction
impulse changes the normal velocities of the contacts sharing its bodies. Measured on random clusters
of touching spheres before rounds existed: 68 of 150 "resolved" impacts left a contact approaching, at
up to 106 % of the largest contact speed.

So the law is applied again, from the velocities the last round left, as a new impact (the threshold
decides its ε again), until every contact has v_rel ≥ −tol·S (S: the largest contact speed before or
after), at most ``max_rounds`` rounds — a cap known before the first (each round is an LCP solve; the
physical cascade of a light body between heavy ones has about π√(M/m) impacts). If contacts still
approach after the cap, or after a round of resting contact (ε = 0: what still approaches was made by its
friction), one *plastic finish* stops them: the frictionless LCP with ε = 0, whose solution has w ≥ 0 by its own
certificate and dissipates (ΔT = −½ f_cᵀ A f_c). The result says so (``extra["plastic_finish"]``).
Measured on random clusters of 2–15 touching spheres (ε, μ and the threshold random): with masses within
a factor 4, at most 31 rounds (120 clusters); with masses spread over 10⁶, 8 of 190 impacts reached the
cap of 100 rounds.

:func:`certified` then checks the answer (see :mod:`pbanim.collision.impulse`): finite, no contact
approaching faster than tol·S, no energy gained beyond tol·T⁻ — else a named error, never a silent answer.

Energy, by construction: Poisson restitution with one ε gives ΔT = −½(1 − ε²) f_cᵀ A f_c ≤ 0; each
staggered friction impulse is capped so that it dissipates (ΔT = −s|u_t| + ½ s² t̂ᵀK t̂ ≤ 0, see
:func:`_tangent_friction`); Newton's law inside the friction LCP (``"lcp"``) can create energy when
several contacts couple (Kane's paradox; up to +99 % on random clusters of three spheres on the ground),
so a round that does is redone as compression with friction (plastic: ΔT ≤ 0) plus a normal restitution
impulse scaled down to the largest s ≤ 1 with ΔT ≤ 0.

References: Glocker, *Set-valued force laws* (2001) — Poisson vs Newton restitution; Kane & Levinson,
J. Appl. Mech. 52 (1985) — energy gain of Newton's law with friction; Anitescu & Potra (1997).
"""

from __future__ import annotations

import dataclasses

import numpy as np

from .impulse import ImpulseResult, apply_impulses, collision_matrix, contact_velocity
from .lcp import _friction_lcp, _normal_lcp, solve_lcp_small
from ..errors import ConvergenceError, NonFiniteResult
from ..geometry import cross, tangent_basis
from ..results import natural_map_residual

__all__: list[str] = []      # the law's internals: resolve_collisions is the public entry


def _normal_speeds(bodies, c) -> np.ndarray:
    return np.einsum("ij,ij->i", contact_velocity(bodies, c), c.normal)


def _tangent_friction(K: np.ndarray, u: np.ndarray, n: np.ndarray, jn: float, mu: float):
    """Tangential impulse from the 2×2 system K_tt J_t = −u_t, clamped to the disc ‖J_t‖ ≤ μ jn.

    The unclamped impulse dissipates (ΔT = −½ J_tᵀK_tt J_t); a clamped one, J_t = −s t̂ along the slip,
    changes T by −s|u_t| + ½ s² t̂ᵀK_tt t̂, so s is also capped at 2|u_t|/t̂ᵀK_tt t̂ (it binds only for an
    anisotropic K_tt, where s = μ jn could otherwise reverse the slip faster than it stops it).
    """
    t1, t2 = tangent_basis(n)
    return _friction_in_plane(K, u, np.stack([t1[0], t2[0]], axis=1), jn, mu)


def _friction_in_plane(K: np.ndarray, u: np.ndarray, T: np.ndarray, jn: float, mu: float):
    """:func:`_tangent_friction` in the tangent basis T (3, 2) of the contact (its columns t₁, t₂)."""
    ut = T.T @ u
    if mu == 0.0 or jn <= 0 or not np.any(ut):
        return np.zeros(3), bool(mu > 0 and jn > 0)
    Ktt = T.T @ K @ T
    jt = np.linalg.lstsq(Ktt, -ut, rcond=None)[0]
    if np.linalg.norm(jt) <= mu * jn:
        return T @ jt, True
    d = ut / np.linalg.norm(ut)
    k = float(d @ Ktt @ d)
    s = mu * jn if k <= 0 else min(mu * jn, 2.0 * float(np.linalg.norm(ut)) / k)
    return T @ (-s * d), False


def _largest_scale(qa: float, qb: float, qc: float, slack: float) -> float:
    """The largest s in [0, 1] with qa s² + qb s + qc ≤ slack (qc ≤ slack: s = 0 qualifies)."""
    if qa + qb + qc <= slack:
        return 1.0
    if qa <= 0.0:                                                  # linear: root of qb s + qc = 0
        return float(np.clip((slack - qc) / qb, 0.0, 1.0)) if qb > 0 else 0.0
    disc = max(qb * qb - 4 * qa * (qc - slack), 0.0)
    return float(np.clip((-qb + np.sqrt(disc)) / (2 * qa), 0.0, 1.0))


def _restitution_scale(A, u, fc, r) -> float:
    """The largest s in [0, 1] with ΔT(s) = (fc + s r)·u + ½ (fc + s r)ᵀA(fc + s r) ≤ 0 (roundoff allowed)."""
    qa, qb = 0.5 * float(r @ A @ r), float(r @ u + fc @ A @ r)
    qc = float(fc @ u + 0.5 * fc @ A @ fc)                         # ≤ 0: the plastic impulse dissipates
    return _largest_scale(qa, qb, qc, 1e-12 * max(1.0, float(np.abs(fc) @ (np.abs(A) @ np.abs(fc)))))


def _energy_after(bodies, c, J) -> float:
    """T of a copy of ``bodies`` after the impulses J (m, 3)."""
    copy = dataclasses.replace(bodies, v=bodies.v.copy(), omega=bodies.omega.copy())
    apply_impulses(copy, c, J)
    return copy.kinetic_energy()


def _friction_round(bodies, c, u0, u0n, e_i, mu, lcp):
    """Normal and friction impulses from one LCP (Newton's law inside it); when that creates energy,
    compression with friction (plastic) plus a normal restitution impulse scaled to keep ΔT ≤ 0."""
    T0 = bodies.kinetic_energy()
    f, J, sticking, its, residual = _friction_lcp(bodies, c, u0, u0n + e_i * np.minimum(u0n, 0.0), mu, lcp)
    if e_i.any() and _energy_after(bodies, c, J) > T0 * (1 + 1e-12):
        f, J, sticking, its, residual = _friction_lcp(bodies, c, u0, u0n, mu, lcp)
        R = (e_i * f)[:, None] * c.normal
        t0, t1, tm = _energy_after(bodies, c, J), _energy_after(bodies, c, J + R), _energy_after(bodies, c, J - R)
        qa, qb = 0.5 * (t1 + tm) - t0, 0.5 * (t1 - tm)             # T(s) = t0 + qb s + qa s², exactly
        s = _largest_scale(qa, qb, t0 - T0, 1e-12 * T0)
        f, J = f + s * e_i * f, J + s * R
    apply_impulses(bodies, c, J)
    return f, J - f[:, None] * c.normal, sticking, its, residual


def _round(bodies, c, e_i: np.ndarray, mu: float, lcp: str, friction_model: str = "staggered", lean: bool = False):
    """One application of the law (ε per contact): all normal impulses at once, then friction; in place
    (``lean``: the staggered friction pass by :func:`_staggered_lean`, the readable one bit for bit)."""
    u0 = contact_velocity(bodies, c)
    u0n = np.einsum("ij,ij->i", u0, c.normal)
    if mu > 0 and friction_model == "lcp":
        return _friction_round(bodies, c, u0, u0n, e_i, mu, lcp)
    A = _normal_lcp(bodies, c)
    # compression (ε = 0): the plastic impulses f_c ⊥ A f_c + u⁻ ≥ 0 dissipate T; restitution adds
    # s·ε_i f_c per contact (Poisson), with the largest s ≤ 1 that keeps ΔT ≤ 0 (s = 1 when every ε_i is
    # the same: ΔT = −½(1 − ε²) f_cᵀ A f_c)
    fc, its = solve_lcp_small(A, u0n, method=lcp)
    f = fc + _restitution_scale(A, u0n, fc, e_i * fc) * e_i * fc
    apply_impulses(bodies, c, f[:, None] * c.normal)
    residual = natural_map_residual(fc, A @ fc + u0n)
    Jt = np.zeros((c.m, 3))
    sticking = np.zeros(c.m, bool)
    if mu > 0 and lean:
        _staggered_lean(bodies, c, f, mu, Jt, sticking)
    elif mu > 0:
        K = collision_matrix(bodies, c)
        for i in np.flatnonzero(f > 0):
            ci = c.select([i])
            Jt[i], sticking[i] = _tangent_friction(K[i], contact_velocity(bodies, ci)[0], c.normal[i], f[i], mu)
            apply_impulses(bodies, ci, Jt[i:i + 1])
    return f, Jt, sticking, its, residual


def _staggered_lean(bodies, c, f: np.ndarray, mu: float, Jt: np.ndarray, sticking: np.ndarray) -> None:
    """The staggered friction pass of :func:`_round` (contact by contact, in index order, each impulse applied
    before the next contact's velocity is read), without a one-contact selection per contact: the tangent
    bases of all the pushed contacts at once (:func:`~pbanim.geometry.tangent_basis` row by row is the same
    arithmetic), u = (v_a + ω_a × r_a) − (v_b + ω_b × r_b) and the update of :func:`apply_impulses` written
    for one contact with the same operations in the same order — the readable pass bit for bit (ORACLES D22)."""
    idx = np.flatnonzero(f > 0)
    if not idx.size:
        return
    K = collision_matrix(bodies, c)
    t1, t2 = tangent_basis(c.normal[idx])
    x, v, w, inv_mass, inv_I = bodies.x, bodies.v, bodies.omega, bodies.inv_mass, bodies.inv_I
    ca, cb, point = c.a, c.b, c.point
    for k, i in enumerate(idx.tolist()):
        a, b = ca[i:i + 1], cb[i:i + 1]
        a0, b0 = int(a[0]), int(b[0])
        ra, rb = point[i] - x[a0], point[i] - x[b0]
        u = (v[a0] + cross(w[a0], ra)) - (v[b0] + cross(w[b0], rb))
        J, sticking[i] = _friction_in_plane(K[i], u, np.stack([t1[k], t2[k]], axis=1), f[i], mu)
        Jt[i] = J
        dv, dw = np.zeros_like(v), np.zeros_like(w)            # apply_impulses' accumulation, one contact
        J1 = J[None]
        dv[a0] += inv_mass[a0] * J                             # 0 + x, as np.add.at adds
        dv[b0] += -(inv_mass[b0] * J)
        dw[a0] += np.einsum("kij,kj->ki", inv_I[a], cross(ra[None], J1))[0]
        dw[b0] += -np.einsum("kij,kj->ki", inv_I[b], cross(rb[None], J1))[0]
        v += dv                                                # every row, as apply_impulses (−0 + 0 = +0)
        w += dw


def rounds(bodies, c, eps: float, mu: float, rest: float, lcp: str, friction_model: str, max_rounds: int,
           tol: float, speed: float, lean: bool = False):
    """The law applied round after round until no contact approaches faster than tol·S (at most
    ``max_rounds`` rounds, then the plastic finish); in place. ``speed``: the largest contact speed before.

    Each round's ε: ``eps`` when some contact approaches faster than ``rest``, else 0 (resting contact). A
    resting round is the last: the approach it leaves comes from its staggered friction (the impact itself
    is over), so the plastic finish stops it at once instead of more rounds of friction (twice the cost on a
    box resting on four corners, about 4 rounds a step).
    Returns (normal impulses f, tangential impulses J_t, sticking, pivots, residual, extra).
    """
    m = c.m
    f, Jt = np.zeros(m), np.zeros((m, 3))
    sticking = np.zeros(m, bool)
    pivots, residual, k = 0, 0.0, 0
    for k in range(1, max_rounds + 1):
        un = _normal_speeds(bodies, c)
        if k > 1 and un.min() >= -tol * max(speed, float(np.abs(un).max())):
            k -= 1
            break
        colliding = bool(np.any(-un > rest))
        e_i = np.full(m, eps if colliding else 0.0)
        fk, Jk, stk, its, residual = _round(bodies, c, e_i, mu, lcp, friction_model, lean)
        f, Jt, sticking, pivots = f + fk, Jt + Jk, np.where(fk > 0, stk, sticking), pivots + its
        if not colliding:   # a resting round: what it left approaching, its friction did: the finish stops it
            break
    un = _normal_speeds(bodies, c)
    finish = bool(un.min() < -tol * max(speed, float(np.abs(un).max())))
    if finish:          # stop what still approaches plastically, without friction (certified by the LCP)
        A = _normal_lcp(bodies, c)
        fc, its = solve_lcp_small(A, un, method=lcp)
        apply_impulses(bodies, c, fc[:, None] * c.normal)
        f, pivots, residual = f + fc, pivots + its, natural_map_residual(fc, A @ fc + un)
    return f, Jt, sticking, pivots, residual, {"rounds": k, "plastic_finish": finish}


def regimes(u0n: np.ndarray, rest: float, tol_v: float) -> np.ndarray:
    """What each contact is before the impulses: colliding, resting, touching (grazing) or separating."""
    out = np.where(u0n > tol_v, "separating", "touching").astype("<U11")
    out[-u0n > tol_v] = "resting"
    out[(-u0n > tol_v) & (-u0n > rest)] = "colliding"
    return out


def certified(bodies, c, impulse, sticking, its, mode, residual, extra, u0n, T0, speed, rest, tol):
    """The result, once it has passed the certificate: finite, no contact approaching, no energy gained."""
    if not (np.isfinite(bodies.v).all() and np.isfinite(bodies.omega).all() and np.isfinite(impulse).all()):
        raise NonFiniteResult("resolve_collisions: the velocities after the impulses")
    u1 = contact_velocity(bodies, c) if c.m else np.zeros((0, 3))
    vn = np.einsum("ij,ij->i", u1, c.normal)
    tol_v = tol * max(speed, float(np.sqrt(np.einsum("ij,ij->i", u1, u1)).max()) if c.m else 0.0)
    approach = max(0.0, float(-vn.min())) if c.m else 0.0
    T1 = bodies.kinetic_energy()
    if approach > tol_v:
        i = int(np.argmin(vn))
        raise ConvergenceError(f"{mode} impulses", extra["rounds"] or its, approach, tol_v,
                               detail=f"contact {i} (bodies {c.a[i]}, {c.b[i]}) still approaches at "
                                      f"v_rel = {vn[i]:.3e} m/s after the impulses")
    if T1 > T0 * (1 + tol):
        raise ConvergenceError(f"{mode} impulses", extra["rounds"] or its, T1 - T0, tol * T0,
                               detail=f"the kinetic energy grew from {T0:.6g} to {T1:.6g} J")
    jn = np.einsum("ij,ij->i", impulse, c.normal) if c.m else np.zeros(0)
    return ImpulseResult(bodies.v[:-1].copy(), bodies.omega[:-1].copy(), impulse, jn, sticking, its, mode, residual,
                         extra, regimes(u0n, rest, tol * speed), approach, T0, T1, tol_v)
