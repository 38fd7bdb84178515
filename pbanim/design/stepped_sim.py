"""∂S/∂u through resting and sliding contact: one differentiated contact step (chapter 10, after chapter 07).

The step of :mod:`pbanim.design.stepped` solves the box-friction complementarity problem w = A z + b by
chapter 07's active-set solver (:func:`pbanim.lcp.active_set.box_friction_active_set`), which returns with
z the *active set*: per contact, off (z = 0), or on with each tangent sticking or sliding at ±μλ. On a fixed
active set z solves a linear system, one block per contact, and that system is differentiated (implicit
differentiation, de Avila Belbute-Peres et al. 2018; Howell et al. 2022):

==============  =========================================  =================================================
contact mode    its rows of K z = r                         their derivative (δw|_z: w's change at fixed z)
==============  =========================================  =================================================
separating      λ = τ₁ = τ₂ = 0                              δz = 0
sticking        w_n = w_τ₁ = w_τ₂ = 0                        A δz = −δw|_z  (three rows)
sliding τⱼ      w_n = 0,  τⱼ = σⱼ μ λ  (σⱼ = ±1)              A_n δz = −δw_n|_z,   δτⱼ − σⱼμ δλ = σⱼ λ δμ
==============  =========================================  =================================================

with δw|_z = δG u⁺ + G (δũ + δW Gᵀz + W δGᵀz) + δβ. Redundant contacts (a box flat on four corners:
A singular, the system consistent) are solved in least squares; the velocity change W Gᵀδz is unique. The
rest of the step is smooth: δv = δP/m, δω = (−[ω]× + I_w⁻¹[L]×) δφ + I_w⁻¹ δL,

    δx⁺ = δx + h δv⁺,   δφ⁺ = R(hω⁺) δφ + h J_l(hω⁺) δω⁺,   δP⁺ = m δv⁺,   δL⁺ = (−[L⁺]× + I_w[ω⁺]×) δφ + I_w δω⁺.

**Switches.** The derivative holds while no contact changes its mode. Every quantity whose sign keeps the
mode — λ (contact ↔ separation), w_n of a separating contact, μλ − |τⱼ| (stick → slip), −σⱼ w_τⱼ (slip →
stick), the separation s of a contact (the bias law's kink at s = 0), the region of a sphere on a box (face,
edge, vertex) — is a *slack* g with its derivative ∂g/∂u. Along parameter k the first switch is predicted at
δu*_k = −g/(∂g/∂u_k) (exact where g is linear in u_k). The step reports the nearest; a run whose nearest
|δu*_k| is within ``switch_tol`` is *at a switch*: its ∂S/∂u is one-sided and is flagged, never silent.

References: F. de Avila Belbute-Peres, K. Smith, K. Allen, J. Tenenbaum, J. Z. Kolter, NeurIPS 2018
(differentiating an LCP step on its active set); T. Howell, S. Le Cleac'h, J. Brüdigam, J. Z. Kolter,
M. Schwager, Z. Manchester, "Dojo", 2022; Stewart & Trinkle 1996; chapter 07 (:mod:`pbanim.contact`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..contact.assembly import rigid_rows
from ..contracts import unchecked
from ..geometry import skew
from ..lcp.active_set import box_friction_active_set, box_friction_residual
from ..lcp import pgs_box_friction
from ..lcp.box import box_state
from ..rigid import quat_exp, quat_multiply, quat_to_matrix
from .scene import UncertifiedTrajectory, left_jacobian
from .stepped import frames

__all__ = ["StepInfo", "contact_step", "nearest_switch", "SWITCH_KINDS", "MODES"]

#: the slack kinds: what changes when that slack reaches zero
SWITCH_KINDS = ("contact → separation", "separation → contact", "stick → slip", "slip → stick",
                "look-ahead ↔ penetration (s = 0)", "face/edge/vertex region or tangent frame",
                "impact law ↔ look-ahead (restitution)")
#: per-contact modes in the result: 0 separating, 1 sticking, 2 sliding
MODES = ("separating", "sticking", "sliding")
#: the contacts' compliance κ relative to max Aᵢᵢ (the redundant contacts of a face get a unique answer)
CFM = 1e-6


@dataclass
class StepInfo:
    """What one step solved: z, the active set (``state`` (m, 3): on, σ₁, σ₂), the LCP residual, the modes
    (m,) and, with sensitivities, the slacks g (n_s,), ∂g/∂u (n_s, p) and their (contact, kind) labels."""

    z: np.ndarray
    state: np.ndarray
    residual: float
    modes: np.ndarray
    slack: np.ndarray | None = None
    dslack: np.ndarray | None = None
    labels: np.ndarray | None = None
    consistent: bool = True
    solved: bool = True


def _state_of(z, mu):
    """The active set a projected Gauss–Seidel answer z suggests (on where λ > 0; ±1 where |τⱼ| ≈ μλ to 10⁻⁶)."""
    return box_state(z, mu, rel=1e-6)


def _neighbours(st):
    """Active sets one change away from ``st``: a contact switched on or off, a tangent to another state."""
    for c in range(st.shape[0]):
        for j, vals in ((0, (0, 1)), (1, (-1, 0, 1)), (2, (-1, 0, 1))):
            for v in vals:
                if v != st[c, j] and (j == 0 or st[c, 0] == 1):
                    nb = st.copy()
                    nb[c, j] = v
                    if j == 0 and v == 0:
                        nb[c, 1:] = 0
                    yield nb


def _fixed(A, b, mu, st):
    """z of the linear system of the active set ``st`` (no exchange), its residual and st."""
    z, res, _, _ = box_friction_active_set(A, b, mu, state=st, max_iter=1, tol=0.0)
    return z, box_friction_residual(z, A @ z + b, mu), st


def _solve(A, b, mu, state0, tol, loose=1e-4):
    """Chapter 07's active-set box-friction solve (as :class:`pbanim.contact.FrictionStepping`) from the
    previous step's set, then from the default guess (b_n < 0 on, sticking), then from the set a projected
    Gauss–Seidel answer suggests, then a descent over neighbouring active sets (one contact or tangent
    changed, one linear solve each; a flat face landing while sliding can make the pivoting cycle). The best
    set found is returned when its residual is below ``loose`` (relative): the step is then flagged by its
    caller (its ∂S/∂u is not the derivative of an exact solve); otherwise the step raises."""
    lim = tol * max(1.0, float(np.max(np.abs(b))))
    best = (np.inf, None)
    for guess in (state0, None, "pgs"):
        if isinstance(guess, str):
            guess = _state_of(pgs_box_friction(A, b, mu, max_iter=300, tol=1e-10)[0], mu)
        z, res, _, st = box_friction_active_set(A, b, mu, state=guess, max_iter=40, tol=tol)
        if res <= lim:
            return z, res, st
        best = min(best, (res, st), key=lambda r: r[0])
    for _ in range(8 * b.size):
        res0 = best[0]
        singles = list(_neighbours(best[1]))
        for nb in singles + [n2 for n1 in singles for n2 in _neighbours(n1)]:   # one change, then two
            z, res, _, st = box_friction_active_set(A, b, mu, state=nb, max_iter=1, tol=tol)
            if res <= lim:
                z, res, _, st = box_friction_active_set(A, b, mu, state=st, max_iter=40, tol=tol)
                if res <= lim:
                    return z, res, st
            best = min(best, (res, nb), key=lambda r: r[0])
            if nb is singles[-1] and best[0] < res0:
                break                                  # a single change improved: no pairs needed this round
        if not best[0] < res0:
            break
    zp, rp, _ = pgs_box_friction(A, b, mu, max_iter=1000, tol=1e-12)
    if min(best[0], rp) <= loose * max(1.0, float(np.max(np.abs(b)))):   # a looser answer: the caller flags it
        return (zp, rp, _state_of(zp, mu)) if rp < best[0] else _fixed(A, b, mu, best[1])
    raise UncertifiedTrajectory(f"the contact problem of a step is not solved: box-friction residual {best[0]:.3e} "
                                f"> {lim:.1e} from the previous active set, the default guess, projected "
                                "Gauss–Seidel's and a descent over neighbouring active sets (and 1000 sweeps of projected Gauss–Seidel))")


def _solve_reduced(A, b, mu, state0, tol):
    """:func:`_solve` on the contacts that can push (b_n < 0, or on in the previous step) and any whose
    w_n = (A z + b)_n turns out negative, added until none is: the same z as the whole problem (a contact
    left out has z = 0 and w_n ≥ 0, which is all its complementarity asks) on a smaller system."""
    m = b.size // 3
    cand = b[0::3] < 0
    if state0 is not None:
        cand |= state0[:, 0] == 1
    thr = 0.1 * tol * max(1.0, float(np.max(np.abs(b))))
    while True:
        rows = (3 * np.flatnonzero(cand)[:, None] + np.arange(3)).ravel()
        z, st = np.zeros(b.size), np.zeros((m, 3), int)
        if rows.size:
            zs, _, sts = _solve(A[rows[:, None], rows], b[rows], mu, None if state0 is None else state0[cand], tol)
            z[rows], st[cand] = zs, sts
        wn = A[0::3] @ z + b[0::3]
        late = ~cand & (wn < -thr)
        if not late.any():
            return z, box_friction_residual(z, A @ z + b, mu), st
        cand |= late


def contact_step(scene, y, T, mu: float, dmu, h: float, state0=None, tol: float = 1e-9):
    """One velocity-level contact step y → y⁺ (and T → T⁺, tangent rows (p, 12), when T is not None).

    Returns (y⁺, T⁺, :class:`StepInfo`). ``dmu`` (p,) is δμ per parameter; ``state0`` the previous step's
    active set (contact persistence, as chapter 07 warm-starts it)."""
    x, q, P, L = y[:3], y[3:7], y[7:10], y[10:13]
    m, I = scene.mass, scene.inertia
    R = quat_to_matrix(q)
    Iw_inv, Iw = R @ (R.T / I[:, None]), R @ (I[:, None] * R.T)
    v, w = P / m, Iw_inv @ L
    ut = np.concatenate([v + h * scene.gravity, w])
    fr = frames(scene, x, R)
    M = fr.s.size
    D = fr.D.reshape(3 * M, 3)
    rr = np.repeat(fr.r, 3, axis=0)
    S = {"x": np.vstack([x, np.zeros(3)])}       # rigid_rows reads the positions only: its full-state contract skipped
    rows = unchecked(rigid_rows)(S, np.zeros(3 * M, int), np.ones(3 * M, int), x + rr, D)       # chapter 07's rows
    Wb = np.zeros((2, 6, 6))
    Wb[0, :3, :3], Wb[0, 3:, 3:] = np.eye(3) / m, Iw_inv
    A = rows.gram(rows, Wb, block=3)
    A = 0.5 * (A + A.T)
    A[np.diag_indices_from(A)] += CFM * float(np.max(np.diag(A)))
    G = rows.Ga
    beta = np.zeros(3 * M)
    slope = np.where(fr.s > 0, 1.0, scene.erp) / h
    un = G[0::3] @ ut                                                       # approach velocities ũ_n
    eps = scene.restitution
    v_rest = (3.0 * h * float(np.linalg.norm(scene.gravity))) if scene.rest_speed is None else scene.rest_speed
    imp = (eps > 0) & (fr.s + h * un < 0) & (un < -v_rest)                  # impacts of this step: v_n⁺ ≥ −ε ũ_n
    beta[0::3] = np.where(imp, eps * un, slope * fr.s)
    b = G @ ut + beta
    z, res, st = _solve_reduced(A, b, mu, state0, tol)
    F = G.T @ z
    up = ut + Wb[0] @ F
    v1, w1 = up[:3], up[3:]
    L1 = Iw @ w1
    refl = imp & (z[0::3] > 0) & scene.sphere          # a sphere's impact in the step: the reflected position
    x1 = x + h * v1 - (1 + eps) * (fr.s[refl] @ fr.D[refl, 0])
    y1 = np.concatenate([x1, quat_multiply(quat_exp(h * w1), q), m * v1, L1])
    on = st[:, 0] == 1
    modes = np.where(on, np.where(np.any(st[:, 1:] != 0, axis=1), 2, 1), 0)
    info = StepInfo(z, st, float(res), modes.astype(np.int8))
    info.solved = bool(res <= tol * max(1.0, float(np.max(np.abs(b)))))
    if T is None:
        return y1, None, info
    # ---- the derivative on the active set
    p = T.shape[0]
    T6, Tphi, TP, TL = T[:, :6], T[:, 3:6], T[:, 6:9], T[:, 9:12]
    dut = np.hstack([TP / m, Tphi @ (-skew(w) + Iw_inv @ skew(L)).T + TL @ Iw_inv.T])
    Fa = F[3:]
    dWF = np.hstack([np.zeros((p, 3)), Tphi @ (-skew(Iw_inv @ Fa) + Iw_inv @ skew(Fa)).T])
    dDr = fr.dD.reshape(3 * M, 3, 6)
    drr = np.repeat(fr.dr, 3, axis=0)
    ang = -np.einsum("rij,rjk->rik", skew(D), drr) + np.einsum("rij,rjk->rik", skew(rr), dDr)
    dG = np.concatenate([dDr, ang], axis=1)                                 # (3M, 6, 6): ∂G_row/∂(δx, δφ)
    dFz = T6 @ np.einsum("r,rjk->jk", z, dG).T
    dbeta = np.zeros((p, 3 * M))
    dun = T6 @ np.einsum("rjk,j->rk", dG[0::3], ut).T + dut @ G[0::3].T
    dbeta[:, 0::3] = np.where(imp, eps * dun, T6 @ (fr.ds * slope[:, None]).T)
    dwz = T6 @ np.einsum("rjk,j->rk", dG, up).T + (dut + dWF + dFz @ Wb[0]) @ G.T + dbeta
    # BEGIN SOLUTION contact_step.active_set
    K = np.eye(3 * M)
    rhs = np.zeros((p, 3 * M))
    eq = np.zeros(3 * M, bool)
    eq[0::3] = on
    for j in (1, 2):
        eq[j::3] = on & (st[:, j] == 0)
    K[eq] = A[eq]
    rhs[:, eq] = -dwz[:, eq]
    ci, cj = np.nonzero(on[:, None] & (st[:, 1:] != 0))
    sig = st[ci, cj + 1]
    K[3 * ci + 1 + cj, 3 * ci] = -sig * mu
    rhs[:, 3 * ci + 1 + cj] = np.outer(dmu, sig * z[3 * ci])
    dz = np.linalg.lstsq(K, rhs.T, rcond=1e-12)[0].T
    # END SOLUTION
    gap = np.abs(dz @ K.T - rhs).max(initial=0.0)
    info.consistent = info.solved and bool(gap <= 1e-7 * max(1.0, float(np.abs(rhs).max(initial=0.0))))
    dF = dFz + dz @ G
    dup = dut + dWF + dF @ Wb[0]
    dv1, dw1 = dup[:, :3], dup[:, 3:]
    th = h * w1
    dx_refl = -(1 + eps) * (np.einsum("pk,ck,ci->pi", T6, fr.ds[refl], fr.D[refl, 0])
                            + np.einsum("c,cik,pk->pi", fr.s[refl], fr.dD[refl, 0], T6))
    T1 = np.hstack([T[:, :3] + h * dv1 + dx_refl, Tphi @ quat_to_matrix(quat_exp(th)).T + h * dw1 @ left_jacobian(th).T,
                    m * dv1, Tphi @ (-skew(L1) + Iw @ skew(w1)).T + dw1 @ Iw.T])
    _slacks(info, fr, z, st, A @ z + b, dwz + dz @ A.T, dz, T6, mu, dmu)
    if eps > 0:                                   # where a contact enters or leaves its impact law
        g_s, dg_s = fr.s + h * un, T6 @ fr.ds.T + h * dun
        g_v, dg_v = un + v_rest, dun
        k1, k2 = np.flatnonzero(un < -v_rest), np.flatnonzero(fr.s + h * un < 0)
        info.slack = np.concatenate([info.slack, g_s[k1], g_v[k2]])
        info.dslack = np.vstack([info.dslack, dg_s[:, k1].T, dg_v[:, k2].T])
        info.labels = np.vstack([info.labels, np.stack([np.r_[k1, k2], np.full(k1.size + k2.size, 6)], axis=1)])
    return y1, T1, info


def _slacks(info, fr, z, st, w, dw, dz, T6, mu, dmu):
    """The slacks that keep each contact in its mode, their derivatives and labels (contact, kind)."""
    g, dg, lab = [], [], []
    for c in range(fr.s.size):
        if st[c, 0] == 0:
            g.append(w[3 * c]), dg.append(dw[:, 3 * c]), lab.append((c, 1))
            continue
        lam = z[3 * c]
        g.append(lam), dg.append(dz[:, 3 * c]), lab.append((c, 0))
        g.append(fr.s[c]), dg.append(T6 @ fr.ds[c]), lab.append((c, 4))
        for j in (1, 2):
            tau = z[3 * c + j]
            if st[c, j] == 0:
                g.append(mu * lam - abs(tau))
                dg.append(dmu * lam + mu * dz[:, 3 * c] - np.sign(tau) * dz[:, 3 * c + j]), lab.append((c, 2))
            else:
                g.append(-st[c, j] * w[3 * c + j]), dg.append(-st[c, j] * dw[:, 3 * c + j]), lab.append((c, 3))
        for k in np.flatnonzero(np.isfinite(fr.region[c])):
            g.append(fr.region[c, k]), dg.append(T6 @ fr.dregion[c, k]), lab.append((c, 5))
    info.slack, info.dslack = np.array(g, float), np.array(dg, float).reshape(len(g), -1)
    info.labels = np.array(lab, int).reshape(-1, 2)


def nearest_switch(info: StepInfo):
    """Per parameter k: (|δu*_k|, signed δu*_k, slack index) of the nearest predicted switch of this step."""
    g, dg = info.slack, info.dslack
    p = dg.shape[1]
    if g.size == 0:
        return np.full(p, np.inf), np.full(p, np.inf), np.full(p, -1)
    tiny = 1e-12 * np.max(np.abs(dg), axis=0, initial=0.0)      # a roundoff derivative moves no slack
    with np.errstate(divide="ignore", invalid="ignore"):
        ds = np.where(np.abs(dg) > np.maximum(tiny, 1e-300), -g[:, None] / dg, np.inf)
    ds = np.where(np.isnan(ds), np.inf, ds)
    k = np.argmin(np.abs(ds), axis=0)
    val = ds[k, np.arange(p)]
    return np.abs(val), val, k
