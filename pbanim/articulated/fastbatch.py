"""The world-frame ABA over K states, laid out for numpy (chapter 08; equations in :mod:`.fastplan`).

Run on arrays of K states, the scalar kernel of :mod:`.fastkernel` makes one numpy call per arithmetic
operation — about 4000 calls for a 10-link chain — and allocates a fresh array for each result. This
module does the same arithmetic with shapes chosen so that each call does more of it, into buffers kept
from one call to the next (fresh large arrays cost page faults, which on some machines cost more than
the arithmetic):

===========================  =====================  ==============================================================
what                         shape                  how
===========================  =====================  ==============================================================
every per-state quantity     (components, n, K)     batch axis last; each component of all links one contiguous block
R_i, p_i (kinematics)        (3, 3, n, K), (3, n, K)  one link at a time (R_i needs R_λ), ~9 calls a link
S_i, v̂_i, ĉ_i, Ĉ_i           (6, n, K)              S and ĉ for all links at once; v̂ and Ĉ are sums along the path
I_i, p̂_i                     (6, 6, n, K), (6, n, K)  all links at once, ~80 calls in all
backward (I^A, p^A)          per link (6, 6, K)     U = I^A S one einsum, I^A −= U Uᵀ/D one outer product, ~10 calls
forward (â')                 per link (6, K)        ~4 calls
===========================  =====================  ==============================================================

The sequential parts (kinematics and the two sweeps) are inherent to ABA: a link needs its parent's pose
and its children's articulated inertias. A floating root uses the scalar kernel's formulas on rows of K.
The buffers make a call not re-entrant: one tree is not to be evaluated from two threads at once.
"""

from __future__ import annotations

import numpy as np

from .fastcomposite import bias_com, lean_fits, sweep_composite
from .fastkernel import _cross, _floating_accel, _quat_frame, _rotate
from .fastplan import FIXED, FLOATING, PRISMATIC, REVOLUTE, Plan

__all__ = ["sweep_batch"]

_UPPER = [(r, c) for r in range(6) for c in range(r, 6)]       # the order of the scalar kernel's 21 entries


def _work(P: Plan, K: int) -> dict:
    """The buffers for batches of K states (the last size used is kept)."""
    w = P.work
    if w.get("K") != K:
        n = P.n
        w.clear()
        w.update(K=K, R=np.empty((3, 3, n, K)), p=np.empty((3, n, K)), S=np.empty((6, n, K)),
                 vJ=np.empty((6, n, K)), v=np.zeros((6, n + 1, K)), C=np.zeros((6, n + 1, K)),
                 vp=np.empty((6, n, K)), c=np.empty((6, n, K)), qdl=np.zeros((n, K)), IA=np.empty((6, 6, n, K)),
                 pA=np.empty((6, n, K)), h=np.empty((3, n, K)), mh=np.empty((3, n, K)), P=np.empty((3, n, K)),
                 L=np.empty((3, n, K)), J=np.empty((3, 3, n, K)), T=np.empty((3, 3, n, K)),
                 t=np.empty((3, n, K)), s=np.empty((n, K)), U=np.empty((6, n, K)), d=np.empty((n, K)),
                 u=np.empty((n, K)), acc=np.empty((6, n, K)), M=np.empty((3, 3, K)),
                 T66=np.empty((6, 6, K)), T6=np.empty((6, K)), tK=np.empty(K), out=np.empty((P.nv, K)),
                 qT=np.empty((P.nq, K)), qdT=np.empty((P.nv, K)), tauT=np.empty((P.nv, K)), bqd=np.empty((P.nv, K)),
                 qr=np.empty((len(P.revolute_q), K)), cos=np.empty((len(P.revolute_q), K)),
                 sin=np.empty((len(P.revolute_q), K)), sc=np.empty((len(P.revolute_q), 2, K)),
                 t32=np.empty((3, 2, K)))
    return w


def _cross_into(a, b, out, t):
    """out = a × b for stacks of 3 components (no aliasing of out with a or b); t: scratch like a[0]."""
    for i, j, k in ((0, 1, 2), (1, 2, 0), (2, 0, 1)):
        np.multiply(a[j], b[k], out=out[i])
        np.multiply(a[k], b[j], out=t)
        out[i] -= t


def _kinematics(P: Plan, w: dict, qT, qdT, cos, sin) -> None:
    """World R_i into w["R"] (3, 3, n, K), p_i into w["p"]; floating joints' world twists into w["vJ"]."""
    R, p, M, sc, t32 = w["R"], w["p"], w["M"], w["sc"], w["t32"]
    np.copyto(sc[:, 0], sin)                                      # (sin, −sin) of each revolute joint
    np.negative(sin, out=sc[:, 1])
    rev = 0
    for i, lp in enumerate(P.links):
        lam, RT, pT = lp.parent, P.RTm[i], P.pTm[i]
        if lam >= 0:
            Mi = R[:, :, lam] if RT is None else np.einsum("ijk,jl->ilk", R[:, :, lam], RT, out=M)
            np.einsum("ijk,j->ik", R[:, :, lam], pT, out=p[:, i])
            p[:, i] += p[:, lam]
        else:
            Mi = (np.eye(3) if RT is None else RT)[:, :, None]
            p[:, i] = pT[:, None]
        Ri = R[:, :, i]
        if lp.kind == REVOLUTE:                                   # R = M R_z(q)
            np.multiply(Mi[:, :2], cos[rev], out=Ri[:, :2])        # (M₀ c, M₁ c) + (M₁ s, M₀ (−s))
            Ri[:, :2] += np.multiply(Mi[:, 1::-1], sc[rev], out=t32)
            rev += 1
            Ri[:, 2] = Mi[:, 2]
        elif lp.kind in (PRISMATIC, FIXED):
            Ri[...] = Mi
            if lp.kind == PRISMATIC:
                p[:, i] += Mi[:, 2] * qT[lp.qi]
        else:                                                     # floating (a root): the scalar formulas
            k, j = lp.qi, lp.vi
            Rt, pt = _quat_frame(tuple(Mi.reshape(9, -1)), tuple(p[:, i]), qT[k:k + 4], qT[k + 4:k + 7])
            Ri[...] = np.reshape(np.broadcast_arrays(*Rt, qT[0])[:9], Ri.shape)
            p[:, i] = pt
            wv, u = _rotate(Rt, qdT[j:j + 3]), _rotate(Rt, qdT[j + 3:j + 6])
            pxw = _cross(pt, wv)
            w["vJ"][:, i] = [wv[0], wv[1], wv[2], pxw[0] + u[0], pxw[1] + u[1], pxw[2] + u[2]]


def _motion(P: Plan, w: dict, qdT) -> None:
    """S, v̂_J = S q̇, v̂ (sum along the path), ĉ = v̂_λ × v̂_J and Ĉ (its sum along the path)."""
    R, p, S, vJ, v, C, vp, c, t = w["R"], w["p"], w["S"], w["vJ"], w["v"], w["C"], w["vp"], w["c"], w["s"]
    Z = R[:, 2]
    _cross_into(p, Z, S[3:], t)                                   # S = (z, p × z) for revolute joints
    S[:3] = Z
    rev, pri = P.kinds == REVOLUTE, P.kinds == PRISMATIC
    if not rev.all():
        S[:, ~rev] = 0.0
        S[3:, pri] = Z[:, pri]                                    # (0, z) for prismatic ones
    one = P.dof >= 0
    w["qdl"][one] = qdT[P.dof[one]]
    flo = P.kinds == FLOATING
    if flo.any():
        keep = vJ[:, flo].copy()
        np.multiply(S, w["qdl"], out=vJ)
        vJ[:, flo] = keep
    else:
        np.multiply(S, w["qdl"], out=vJ)
    for i, lam in enumerate(P.parents.tolist()):                  # −1 is the zero row n (the world)
        np.add(v[:, lam], vJ[:, i], out=v[:, i])
    np.take(v, np.where(P.parents < 0, P.n, P.parents), axis=1, out=vp)
    _cross_into(vp[:3], vJ[:3], c[:3], t)                         # ω_λ × ω_J
    _cross_into(vp[3:], vJ[:3], c[3:], t)                         # u_λ × ω_J + ω_λ × u_J
    _cross_into(vp[:3], vJ[3:], w["t"], t)
    c[3:] += w["t"]
    for i, lam in enumerate(P.parents.tolist()):
        np.add(C[:, lam], c[:, i], out=C[:, i])


def _inertia_bias(P: Plan, w: dict, F) -> None:
    """World spatial inertias into w["IA"] (6, 6, n, K) and biases p̂ = v̂ ×* I v̂ + I Ĉ − f̂ᵉˣᵗ into w["pA"]."""
    J = _centres(P, w)
    _rigid_inertia(P, w, J)
    _bias(P, w, F, J)


def _centres(P: Plan, w: dict):
    """Centres of mass h = p + R c into w["h"], m h into w["mh"]; returns Ī_w = R Ī Rᵀ (w["J"]) or None."""
    R, p, h, mh = w["R"], w["p"], w["h"], w["mh"]
    np.einsum("ajnk,jn->ank", R, P.com_n[..., 0], out=h)
    h += p                                                        # centre of mass h = p + R c
    np.multiply(h, P.mass_n, out=mh)
    if P.ibar_n is None:
        return None
    np.einsum("ajnk,jbnx->abnk", R, P.ibar_n, out=w["T"])
    return np.einsum("ajnk,bjnk->abnk", w["T"], R, out=w["J"])


def _rigid_inertia(P: Plan, w: dict, J) -> None:
    """The links' world spatial inertias I_i into w["IA"] (6, 6, n, K)."""
    IA, h, mh, s = w["IA"], w["h"], w["mh"], w["s"]
    A = IA[:3, :3]
    np.multiply(mh[:, None], h[None], out=A)                      # m(|h|² 1 − h hᵀ)
    np.negative(A, out=A)
    np.einsum("ank,ank->nk", mh, h, out=s)
    for k in range(3):
        A[k, k] += s
    if J is not None:                                             # + R Ī Rᵀ
        A += J
    for (r, cc), (sign, k) in {(0, 4): (-1, 2), (0, 5): (1, 1), (1, 3): (1, 2), (1, 5): (-1, 0), (2, 3): (-1, 1),
                               (2, 4): (1, 0)}.items():          # m h× and its transpose
        np.multiply(mh[k], sign, out=IA[r, cc])
        IA[cc, r] = IA[r, cc]
    for r in range(3):
        IA[r, r + 3] = 0.0
        IA[r + 3, r] = 0.0
    np.multiply(np.eye(3)[:, :, None, None], P.mass_n, out=IA[3:, 3:])


def _bias(P: Plan, w: dict, F, J) -> None:
    """The links' biases p̂ = v̂ ×* I v̂ + I Ĉ − f̂ᵉˣᵗ into w["pA"] (6, n, K); J: Ī_w or None."""
    R, p, pA, h, Pm, L, t, s = (w[k] for k in ("R", "p", "pA", "h", "P", "L", "t", "s"))
    n, m = P.n, P.mass_n
    v, C = w["v"][:, :n], w["C"][:, :n]
    # momentum P = m (u + ω × h), L = h × P + Ī_w ω; bias (ω × L + u × P, ω × P)
    _cross_into(v[:3], h, Pm, s)
    Pm += v[3:]
    Pm *= m
    _cross_into(h, Pm, L, s)
    if J is not None:
        L += np.einsum("abnk,bnk->ank", J, v[:3], out=t)
    _cross_into(v[:3], L, pA[:3], s)
    _cross_into(v[3:], Pm, t, s)
    pA[:3] += t
    _cross_into(v[:3], Pm, pA[3:], s)
    # + I Ĉ: Q = m (C_u + C_ω × h), (h × Q + Ī_w C_ω, Q)
    _cross_into(C[:3], h, Pm, s)
    Pm += C[3:]
    Pm *= m
    pA[3:] += Pm
    _cross_into(h, Pm, L, s)
    pA[:3] += L
    if J is not None:
        pA[:3] += np.einsum("abnk,bnk->ank", J, C[:3])
    if F is not None:
        _external(w, F)


def _external(w: dict, F) -> None:
    """w["pA"] −= f̂ᵉˣᵗ in world coordinates (F: (6, n, K) in joint frames)."""
    R, p, pA, t, s = w["R"], w["p"], w["pA"], w["t"], w["s"]
    f = np.einsum("ajnk,jnk->ank", R, F[3:])
    pA[3:] -= f
    pA[:3] -= np.einsum("ajnk,jnk->ank", R, F[:3])
    _cross_into(p, f, t, s)
    pA[:3] -= t


def sweep_batch(P: Plan, q, qd, tau, F, pivot, check_q, lean: bool = True) -> np.ndarray:
    """q̈ (nv, K) for q (K, nq), q̇ and τ (K, nv); F (6, n, K) external forces in joint frames or None;
    ``pivot(D, i, floor)`` returns 1/D or raises; ``check_q(P, qT)`` validates the quaternions. The result
    is a buffer of the plan: copy it before the next call. ``lean`` (where :func:`.fastcomposite.lean_fits`):
    the sweeps by composites and rank-one terms, no 6 × 6 articulated inertia (:mod:`.fastcomposite`);
    ``lean=False`` runs the sweeps below."""
    K = q.shape[0]
    w = _work(P, K)
    qT, qdT, tauT = w["qT"], w["qdT"], w["tauT"]
    np.copyto(qT, q.T)                                            # batch axis last, contiguous rows
    np.copyto(qdT, qd.T)
    np.copyto(tauT, tau.T)
    check_q(P, qT)
    if P.damping.any():                                           # τ − b q̇
        tauT -= np.multiply(P.damping[:, None], qdT, out=w["bqd"])
    np.take(qT, P.revolute_q, axis=0, out=w["qr"])
    _kinematics(P, w, qT, qdT, np.cos(w["qr"], out=w["cos"]), np.sin(w["qr"], out=w["sin"]))
    _motion(P, w, qdT)
    if "c_fits" not in w:                                         # kept with the buffers (per plan and K)
        w["c_fits"] = lean_fits(P)
    if lean and w["c_fits"]:
        bias_com(P, w, _centres(P, w), _cross_into)
        if F is not None:
            _external(w, F)
        return sweep_composite(P, w, w["tauT"], pivot, _cross_into)
    _inertia_bias(P, w, F)
    _backward(P, w, w["tauT"], pivot)
    return _forward(P, w, w["tauT"], pivot)


def _backward(P: Plan, w: dict, tauT, pivot) -> None:
    """Articulated inertias and biases, leaves first; U, 1/D and u of every joint kept for the forward pass."""
    IA, pA, S, U, d, u, T66, T6, tK = (w[k] for k in ("IA", "pA", "S", "U", "d", "u", "T66", "T6", "tK"))
    for i in reversed(range(P.n)):
        lp = P.links[i]
        lam = lp.parent
        if lp.kind == FIXED:
            if lam >= 0:
                IA[:, :, lam] += IA[:, :, i]
                pA[:, lam] += pA[:, i]
            continue
        if lp.kind == FLOATING:
            continue
        Ui, Si = U[:, i], S[:, i]
        np.einsum("rck,ck->rk", IA[:, :, i], Si, out=Ui)
        np.einsum("rk,rk->k", pA[:, i], Si, out=tK)
        np.subtract(tauT[lp.vi], tK, out=u[i])
        d[i] = pivot(np.einsum("rk,rk->k", Ui, Si, out=tK), i, 1e-280)
        if lam >= 0:
            W = np.multiply(Ui, d[i], out=T6)
            np.multiply(W[:, None], Ui[None], out=T66)
            A = IA[:, :, i]
            A -= T66
            IA[:, :, lam] += A
            pA[:, lam] += pA[:, i]
            W *= u[i]
            pA[:, lam] += W


def _forward(P: Plan, w: dict, tauT, pivot) -> np.ndarray:
    """Accelerations, root first: q̈_i = (u_i − U_iᵀ â'_λ)/D_i, â'_i = â'_λ + S_i q̈_i."""
    IA, pA, S, U, d, u, tK = (w[k] for k in ("IA", "pA", "S", "U", "d", "u", "tK"))
    K = tauT.shape[1]
    out, acc, a0 = w["out"], w["acc"], np.array(P.a0)
    for i, lp in enumerate(P.links):
        lam = lp.parent
        ap = a0[:, None] if lam < 0 else acc[:, lam]
        if lp.kind == FIXED:
            acc[:, i] = ap
        elif lp.kind == FLOATING:
            j = lp.vi
            x, a = _floating_accel(tuple(IA[r, c, i] for r, c in _UPPER), tuple(pA[:, i]),
                                   tuple(w["R"][:, :, i].reshape(9, K)), tuple(w["p"][:, i]), tauT[j:j + 6],
                                   P.a0, pivot, i)
            out[j:j + 6] = x
            acc[:, i] = a
        else:
            Ua = a0 @ U[:, i] if lam < 0 else np.einsum("rk,rk->k", U[:, i], ap, out=tK)
            x = out[lp.vi]
            np.subtract(u[i], Ua, out=x)
            x *= d[i]
            np.multiply(S[:, i], x, out=acc[:, i])
            acc[:, i] += ap
    return out
