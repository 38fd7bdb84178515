"""Analytical derivatives of RNEA and ABA over a batch of K states, in the world frame (chapter 08).

The same derivatives as :mod:`pbanim.articulated.derivatives` (read that module first), organized as
Carpentier & Mansard (RSS 2018) do for speed: every spatial quantity in world coordinates, where RNEA needs
no transform between links (F_λ += F_i), and a displacement δ of joint k moves its whole subtree rigidly by
the world twist ξ = S_k δ. Holding q̇ and q̈ fixed, that displacement turns each vector of the subtree
(S_j, I_j, f̂ᵉˣᵗ_j) with it, and changes the velocities and accelerations of the subtree by
ξ × (v̂_i − v̂_λ(k)) and ξ × (â_i − â_λ(k)) − (ξ × v̂_λ(k)) × (v̂_i − v̂_λ(k)). Power is frame-independent, so
the turning of S_j and F_j cancels in τ_j = S_jᵀ F_j, and what is left is linear in two vectors per column:

    w = ξ × v̂_λ(k),   g = ξ × â_λ(k) + v̂_λ(k) × w,        (a change of q_k)
    ∂τ_j/∂q_k = S_jᵀ (B^c_j w − Y_j g)          for j in the subtree of k (k itself included),
    ∂τ_j/∂q_k = S_jᵀ (ξ ×* F_k + B^c_k w − Y_k g)   for j a strict ancestor of k,

with Y_j = Σ_{i ⪰ j} I_i the composite inertia, F_j = Σ f̂_i the composite force and B^c_j = Σ B_i,
B_i = I_i (v̂_i×) − (I_i v̂_i)‾ − (v̂_i×*) I_i (the body's "Coriolis" matrix: ∂f̂_i = −B_i ξ when v̂_i grows by
ξ). A change δ of q̇_k (ξ = S_k δ) adds ξ to the subtree's velocities and ξ × v̂_i + z to its accelerations,
z = (v̂_λ(k) + v̂_k) × ξ, so ∂τ_j/∂q̇_k = S_jᵀ (−B^c_j ξ + Y_j z) in the subtree and S_jᵀ (−B^c_k ξ + Y_k z)
above it. H comes with them: H_jk = S_jᵀ Y_j S_k (k ⪯ j). Each line is one numpy operation on all K states
((K, 6, 6) stacks); the loops run over the links. The results equal the readable ones state by state to
roundoff (ORACLES L1, I5). ``q`` of shape (nq,) is one state (K = 1, the result squeezed).

Trees without a floating joint take a lean path for ∂ABA (:func:`_aba_derivatives_lean`): the batch axis
last, the large arrays in buffers kept per tree and K (fresh arrays of megabytes cost page faults), S_jᵀ B^c_j
read off B^c_j S_j (Bᵀ = B + 2h̄, h̄ antisymmetric), only the pairs (j, c) on a common path, and one Cholesky
factor of H for q̈, H⁻¹ and −H⁻¹ ∂τ (no ABA sweep). The general path (any tree, floating roots included) is
kept beside it; both equal the readable derivatives to roundoff.
"""

from __future__ import annotations

import weakref

import numpy as np

from ..contracts import Array, Opt, contract
from ..errors import check_result
from .batched import _crf, _crm, link_transforms_batch
from .derivatives import bar
from .dynamics import external_forces
from .fast import _joint_frame_forces, _pivot_array, aba_fast, batch_of
from .fastbatch import _cross_into, _inertia_bias, _kinematics, _motion
from .fastbatch import _work as _kernel_work
from .fastplan import FLOATING, plan_for
from .spatial import crm, plucker_inverse
from .specs import JointPositions, Tree
from .tree import ArticulatedTree

__all__ = ["rnea_derivatives_batch", "aba_derivatives_batch"]

_TREE, _QB = Tree(), JointPositions("tree", batch="first")
_VB = Array(("tree.nv",), batch="first", empty=True)
_FB = Opt(Array(("tree.n", 6), batch="first"))
_HUGE = "of a tree and states with huge entries"


def _mv(M, x):
    return np.einsum("kij,kj->ki", M, x)


def _relations(tree):
    """(owner, anc, desc): the link of each velocity column, anc[j, c] = link of c ⪯ link of j (an ancestor
    or the same), desc[j, c] = link of j ≺ link of c (a strict ancestor), each (nv,) / (nv, nv)."""
    A, n = tree.arrays(), tree.n
    owner = np.repeat(np.arange(n), [v.stop - v.start for v in A["vi"]])
    up = np.zeros((n, n), dtype=bool)                           # up[i, k]: k ⪯ i
    for i in range(n):
        lam = tree.parent[i]
        if lam >= 0:
            up[i] = up[lam]
        up[i, i] = True
    anc = up[np.ix_(owner, owner)]
    return owner, anc, anc.T & ~np.equal.outer(owner, owner)


def _rnea_derivatives_batch(tree, q, qd, qdd, f_ext):
    """(∂τ/∂q, ∂τ/∂q̇, H), each (K, nv, nv), by the world-frame recursion of the module docstring."""
    A, K, n, nv = tree.arrays(), q.shape[0], tree.n, tree.nv
    fx = external_forces(tree, f_ext, K)
    Xup = link_transforms_batch(tree, q)
    owner, anc, desc = _relations(tree)
    Sw, X0 = [None] * n, [None] * n
    v, a, vlam, alam, F = (np.zeros((K, n, 6)) for _ in range(5))    # per link, stacked on axis 1
    Y, Bc = np.zeros((K, n, 6, 6)), np.zeros((K, n, 6, 6))
    for i in range(n):                                          # forward: world-frame kinematics and bodies
        lam, vi = tree.parent[i], A["vi"][i]
        X0[i] = Xup[i] @ X0[lam] if lam >= 0 else Xup[i]       # ⁱX_0
        Sw[i] = plucker_inverse(X0[i]) @ A["S"][i]              # S_i in world coordinates (K, 6, d)
        if lam >= 0:
            vlam[:, i], alam[:, i] = v[:, lam], a[:, lam]
        else:
            alam[:, i] = A["a0"]
        vJ = np.einsum("kid,kd->ki", Sw[i], qd[:, vi])
        v[:, i] = vlam[:, i] + vJ
        a[:, i] = alam[:, i] + np.einsum("kid,kd->ki", Sw[i], qdd[:, vi]) + _crm(v[:, i], vJ)
        XI = (np.swapaxes(X0[i], 1, 2).reshape(-1, 6) @ A["I"][i]).reshape(K, 6, 6)   # ⁱX_0ᵀ I_i, one product
        Yi = Y[:, i] = XI @ X0[i]                               # ⁰I_i = ⁱX_0ᵀ I_i ⁱX_0
        h = _mv(Yi, v[:, i])
        F[:, i] = _mv(Yi, a[:, i]) + _crf(v[:, i], h) - np.einsum("kji,kj->ki", X0[i], fx[:, i])
        IV = Yi @ crm(v[:, i])
        Bc[:, i] = IV + np.swapaxes(IV, 1, 2) - bar(h)          # B_i = I v̂× − (I v̂)‾ − v̂×* I  (I symmetric)
    for i in reversed(range(n)):                                # backward: composites, no transforms
        lam = tree.parent[i]
        if lam >= 0:
            Y[:, lam] += Y[:, i]
            Bc[:, lam] += Bc[:, i]
            F[:, lam] += F[:, i]
    # every velocity column c at once (its joint k = owner[c]): rows (K, nv, 6)
    xi = np.swapaxes(np.concatenate(Sw, axis=2), 1, 2)          # ξ_c = S_k e_c
    same = owner.size == n and np.array_equal(owner, np.arange(n))   # one column per link: no gather
    VL, AL, V, FK, BK, YK = ((x if same else x[:, owner]) for x in (vlam, alam, v, F, Bc, Y))
    w = _crm(xi, VL)
    g = _crm(xi, AL) + _crm(VL, w)
    z = _crm(VL + V, xi)
    Pq = _crf(xi, FK) + np.einsum("kcij,kcj->kci", BK, w) - np.einsum("kcij,kcj->kci", YK, g)
    Pd = np.einsum("kcij,kcj->kci", YK, z) - np.einsum("kcij,kcj->kci", BK, xi)
    SB, SY = np.einsum("kci,kcij->kcj", xi, BK), np.einsum("kci,kcij->kcj", xi, YK)   # rows S_jᵀ B^c_j, S_jᵀ Y_j
    T = lambda x: np.swapaxes(x, 1, 2)                          # noqa: E731
    dq = np.where(anc, SB @ T(w) - SY @ T(g), 0.0) + np.where(desc, xi @ T(Pq), 0.0)
    dqd = np.where(anc, SY @ T(z) - SB @ T(xi), 0.0) + np.where(desc, xi @ T(Pd), 0.0)
    Hf = SY @ T(xi)                                             # H_jc = S_jᵀ Y_j S_c for c ⪯ j
    H = np.where(anc, Hf, 0.0) + np.where(desc, T(Hf), 0.0)
    return dq, dqd, H


_CYCLIC = ((0, 1, 2), (1, 2, 0), (2, 0, 1))


def _crm_t(v, w, out):
    """out = v̂ × ŵ on stacks with the components first ((6, ...) arrays), into ``out`` (not aliasing v or w):
    the products and sums of :func:`.fastkernel._cross_motion` in its order, without temporaries."""
    t = np.empty_like(out[0])
    for i, j, k in _CYCLIC:
        np.multiply(v[j], w[k], out=out[i])                     # ω × ω_w
        out[i] -= np.multiply(v[k], w[j], out=t)
        o = out[3 + i]                                          # ((u × ω_w) + ω_j u_w,k) − ω_k u_w,j
        np.multiply(v[3 + j], w[k], out=o)
        o -= np.multiply(v[3 + k], w[j], out=t)
        o += np.multiply(v[j], w[3 + k], out=t)
        o -= np.multiply(v[k], w[3 + j], out=t)
    return out


def _crf_t(v, f, out):
    """out = v̂ ×* f̂ = (ω × n + u × F, ω × F) on stacks with the components first, into ``out`` (not aliasing
    v or f): the kernel's cross products into buffers (:func:`.fastbatch._cross_into`), then the sum."""
    t, b = np.empty_like(out[0]), np.empty_like(out[:3])
    _cross_into(v[:3], f[:3], out[:3], t)                      # ω × n
    _cross_into(v[3:], f[3:], b, t)                            # + u × F
    out[:3] += b
    _cross_into(v[:3], f[3:], out[3:], t)                      # ω × F
    return out


def _coriolis_matrices(I, v, h, X, B, t):
    """B_i = X + Xᵀ − h̄ with X = I_i (v̂_i ×), for stacks I (6, 6, n, K), v̂ and h = I v̂ (6, n, K), into B
    (X, t: scratch of the shapes of I and I[:, 0]).

    Column l of X from the columns of I: a row r times ω× is r × ω, so X[:, :3] = I_ω × ω + I_u × u and
    X[:, 3:] = I_u × ω, each component one line on all rows at once."""
    for l, (j, k) in enumerate(((1, 2), (2, 0), (0, 1))):
        for x, off, out in ((v[:3], 0, X[:, l]), (v[:3], 3, X[:, 3 + l])):
            np.multiply(I[:, off + j], x[k], out=out)
            np.multiply(I[:, off + k], x[j], out=t)
            out -= t
        np.multiply(I[:, 3 + j], v[3 + k], out=t)
        X[:, l] += t
        np.multiply(I[:, 3 + k], v[3 + j], out=t)
        X[:, l] -= t
    np.add(X, X.transpose(1, 0, 2, 3), out=B)
    for rows, cols, x in ((0, 0, h[:3]), (0, 3, h[3:]), (3, 0, h[3:])):   # − h̄: + n× on one block, + F× on two
        for r, c, sign, k in ((0, 1, -1, 2), (0, 2, 1, 1), (1, 0, 1, 2), (1, 2, -1, 0), (2, 0, -1, 1), (2, 1, 1, 0)):
            if sign > 0:
                B[rows + r, cols + c] += x[k]
            else:
                B[rows + r, cols + c] -= x[k]
    return B


_WORK: "weakref.WeakKeyDictionary" = weakref.WeakKeyDictionary()


def _work(tree, P, K):
    """Per tree (and plan, and K): the velocity columns' links, whether they are the links themselves, per row j
    the (ancestor columns c ⪯ j, strict-descendant columns) as slices where contiguous, and the large buffers
    (fresh arrays of megabytes cost page faults, which here cost more than the arithmetic). Not re-entrant,
    like the ABA kernel's own buffers."""
    hit = _WORK.get(tree)
    if hit is None or hit["plan"] is not P or hit["K"] != K:
        cols, anc, desc = _relations(tree)
        n, nv = P.n, P.nv

        def part(mask):
            idx = np.flatnonzero(mask)
            if idx.size and np.array_equal(idx, np.arange(idx[0], idx[-1] + 1)):
                return slice(int(idx[0]), int(idx[-1]) + 1)
            return idx
        YBh = np.empty((n, 78, K))                              # per link: Y (36 rows), B (36), h (6), contiguous
        hit = _WORK[tree] = dict(
            plan=P, K=K, cols=cols, same=np.array_equal(cols, np.arange(n)),
            rows=[(part(anc[j]), part(desc[j])) for j in range(nv)], X=np.empty((6, 6, n, K)),
            B=YBh[:, 36:72].reshape(n, 6, 6, K).transpose(1, 2, 0, 3), t=np.empty((6, n, K)),
            h=YBh[:, 72:].transpose(1, 0, 2), F=np.empty((6, n, K)), YBh=YBh,
            a=np.empty((6, n + 1, K)), RA=np.empty((2, nv, 12, K)), RD=np.empty((2, nv, 6, K)),
            Y=YBh[:, :36].reshape(n, 6, 6, K).transpose(1, 2, 0, 3), SBY=np.empty((12, nv, K)),
            out=np.zeros((nv, 3, nv, K)), L=np.zeros((nv, nv, K)),
            Li=np.zeros((nv, nv, K)), m=np.empty((8, 6, nv, K)))
    return hit


def _cholesky_inverse(H, L, Li, Minv, links):
    """H⁻¹ of symmetric positive definite stacks H (m, m, K) by Cholesky, H = L Lᵀ, H⁻¹ = L⁻ᵀ L⁻¹, into
    Minv (K, m, m), the batch axis first (L, Li: buffers whose strict upper triangles are zero). A pivot
    ≤ 1e-280 (a joint that moves no inertia) raises the ABA's named error for the joint's link ``links[j]``."""
    m = H.shape[0]
    for j in range(m):
        Lj = L[j, :j]
        d = H[j, j] - np.einsum("pk,pk->k", Lj, Lj)
        _pivot_array(d, int(links[j]), 1e-280)
        np.sqrt(d, out=L[j, j])
        if j + 1 < m:
            np.divide(H[j + 1:, j] - np.einsum("ipk,pk->ik", L[j + 1:, :j], Lj), L[j, j], out=L[j + 1:, j])
    for i in range(m):                                          # L⁻¹ row by row (forward substitution)
        r = Li[i]
        np.negative(np.einsum("jk,jck->ck", L[i, :i], Li[:i, :i]), out=r[:i])
        r[i] = 1.0
        r[:i + 1] /= L[i, i]
    Lk = Li.transpose(2, 0, 1)
    return np.matmul(Lk.transpose(0, 2, 1), Lk, out=Minv)


def _aba_derivatives_lean(tree, q, qd, tau, f_ext):
    """(∂q̈/∂q, ∂q̈/∂q̇, H⁻¹), each (K, nv, nv), for trees without a floating joint, the batch axis last inside.

    The world-frame ABA kernel's own steps (:mod:`.fastbatch`) give R_i, p_i, S_i, v̂_i, v̂_λ(i), Ĉ_i, the
    rigid world inertias I_i and p̂_i = v̂_i ×* I_i v̂_i + I_i Ĉ_i − f̂ᵉˣᵗ_i; its sweeps are not run. H (from the
    composites Y_j) is factored once, H = L Lᵀ, and the same factor gives q̈ = H⁻¹ (τ − b q̇ − S_jᵀ F⁰_j), F⁰
    the composite forces at q̈ = 0 (every â'_i = â₀), then â'_i = â'_λ + S_i q̈_i and f̂_i = I_i â'_i + p̂_i.
    Then the formulas of the module docstring, every cross product by its components, every column at once,
    only the pairs (j, c) on a common path, and −H⁻¹ ∂τ from the same factor."""
    P, K = plan_for(tree), q.shape[0]
    n, nv, par = P.n, P.nv, P.parents
    F = None
    if f_ext is not None:
        F = np.ascontiguousarray(_joint_frame_forces(P, external_forces(tree, f_ext, K)).transpose(2, 1, 0))
    w, b = _kernel_work(P, K), _work(tree, P, K)
    qT, qdT = w["qT"], w["qdT"]
    np.copyto(qT, q.T)
    np.copyto(qdT, qd.T)
    np.take(qT, P.revolute_q, axis=0, out=w["qr"])
    _kinematics(P, w, qT, qdT, np.cos(w["qr"], out=w["cos"]), np.sin(w["qr"], out=w["sin"]))
    _motion(P, w, qdT)                                          # S_i, v̂_i, v̂_λ(i), Ĉ_i
    _inertia_bias(P, w, F)                                      # w["IA"] = I_i (rigid), w["pA"] = p̂_i
    I, v, vp, ae, Fo, h, Y = w["IA"], w["v"][:, :n], w["vp"], b["a"], b["F"], b["h"], b["Y"]
    np.einsum("abnk,bnk->ank", I, v, out=h)                     # momenta I_i v̂_i
    Bc = _coriolis_matrices(I, v, h, b["X"], b["B"], b["t"])
    Y[...] = I
    YBh = b["YBh"]                                              # Y, B^c and h of each link: one contiguous block
    for i in reversed(range(n)):                                # composites, leaves first, no transforms
        lam = par[i]
        if lam >= 0:
            YBh[lam] += YBh[i]
    cols, rows, S = b["cols"], b["rows"], w["S"]
    pick = (lambda x: x) if b["same"] else (lambda x: x[..., cols, :])   # noqa: E731
    xi, YK = pick(S), pick(Y)
    SY = b["SBY"][6:]
    np.einsum("abck,bck->ack", YK, xi, out=SY)                  # S_jᵀ Y_j = (Y_j S_j)ᵀ
    out = b["out"]                                              # (row j, dq | dqd | H, column c, K)
    for j, (ca, cd) in enumerate(rows):                         # H_jc = S_jᵀ Y_j S_c for c ⪯ j
        out[j, 2, ca] = np.einsum("ak,ack->ck", SY[:, j], xi[:, ca])
    for j, (ca, cd) in enumerate(rows):
        out[j, 2, cd] = out[cd, 2, j]
    res = np.empty((3, K, nv, nv))                              # the results, the batch axis first
    Minv = _cholesky_inverse(out[:, 2], b["L"], b["Li"], res[2], cols)
    # q̈ = H⁻¹ (τ − b q̇ − S_jᵀ F⁰_j), F⁰ the composite forces at q̈ = 0 (â'_i = â₀ for every link)
    a0 = np.asarray(P.a0)
    np.einsum("abnk,b->ank", I, a0, out=Fo)
    Fo += w["pA"]
    for i in reversed(range(n)):
        if par[i] >= 0:
            Fo[:, par[i]] += Fo[:, i]
    rhs = tau.T - np.einsum("ack,ack->ck", xi, pick(Fo))
    if P.damping.any():
        rhs -= P.damping[:, None] * qd.T
    qdd = np.matmul(Minv, rhs.T[:, :, None])[:, :, 0].T
    Sq = S * np.where(P.dof[:, None] >= 0, qdd[np.maximum(P.dof, 0)], 0.0)   # S_i q̈_i per link
    acc = w["acc"]                                              # â'_i = â'_λ + S_i q̈_i, â'_root's parent = â₀
    for i in range(n):
        np.add(acc[:, par[i]] if par[i] >= 0 else a0[:, None], Sq[:, i], out=acc[:, i])
    np.add(acc, w["C"][:, :n], out=ae[:, :n])                   # â_i = â'_i + Ĉ_i; row n: the world's â₀
    ae[:, n] = a0[:, None]
    np.einsum("abnk,bnk->ank", I, acc, out=Fo)                  # f̂_i = I_i â'_i + p̂_i
    Fo += w["pA"]
    for i in reversed(range(n)):
        if par[i] >= 0:
            Fo[:, par[i]] += Fo[:, i]
    VL, V, BK, FK, hK = (pick(x) for x in (vp, v, Bc, Fo, h))
    AL = ae[:, np.where(par < 0, n, par)[cols]]
    RA, RD, SBY = b["RA"], b["RD"], b["SBY"]                    # (dq | dqd | H, column, component, K)
    T = lambda x: x.transpose(1, 0, 2)                          # noqa: E731  (component, column) ↔
    wq, g, z, Pq, Pd, Bxi, t6, t7 = b["m"]                      # (6, nv, K) buffers
    _crm_t(xi, VL, wq)
    _crm_t(xi, AL, g)
    g += _crm_t(VL, wq, t6)                                     # g = ξ × â_λ + v̂_λ × w
    _crm_t(np.add(VL, V, out=t7), xi, z)
    RA[0, :, :6], RA[1, :, 6:] = T(wq), T(z)
    np.negative(T(g), out=RA[0, :, 6:])
    np.negative(T(xi), out=RA[1, :, :6])
    np.einsum("abck,bck->ack", BK, xi, out=Bxi)
    _crf_t(xi, FK, Pq)                                          # Pq = ξ ×* F + B w − Y g, Pd = Y z − B ξ
    Pq += np.einsum("abck,bck->ack", BK, wq, out=t6)
    Pq -= np.einsum("abck,bck->ack", YK, g, out=t6)
    np.einsum("abck,bck->ack", YK, z, out=Pd)
    Pd -= Bxi
    RD[0], RD[1] = T(Pq), T(Pd)
    # rows S_jᵀ B^c_j = (B^c_jᵀ S_j)ᵀ with Bᵀ = B + 2h̄ (h̄ is antisymmetric), and S_jᵀ Y_j = (Y_j S_j)ᵀ
    _crf_t(xi, hK, t6)
    t6 *= 2.0
    np.add(Bxi, t6, out=SBY[:6])
    for j, (ca, cd) in enumerate(rows):                         # only the pairs on a common path
        if isinstance(ca, slice):
            np.einsum("ak,tcak->tck", SBY[:, j], RA[:, ca], out=out[j, :2, ca])
        else:
            out[j][:2, ca] = np.einsum("ak,tcak->tck", SBY[:, j], RA[:, ca])
        if isinstance(cd, slice):
            np.einsum("ak,tcak->tck", xi[:, j], RD[:, cd], out=out[j, :2, cd])
        else:
            out[j][:2, cd] = np.einsum("ak,tcak->tck", xi[:, j], RD[:, cd])
    if P.damping.any():
        out[:, 1] += P.damping[:, None, None] * np.eye(nv)[:, :, None]
    np.matmul(Minv, out[:, 0].transpose(2, 0, 1), out=res[0])
    np.matmul(Minv, out[:, 1].transpose(2, 0, 1), out=res[1])
    np.negative(res[:2], out=res[:2])
    return res[0], res[1], res[2]


@contract(tree=_TREE, q=_QB, qd=_VB, qdd=_VB, f_ext=_FB)
def rnea_derivatives_batch(tree: ArticulatedTree, q, qd, qdd, f_ext=None):
    """(∂τ/∂q, ∂τ/∂q̇, H) for K states: q (K, nq), q̇ and q̈ (K, nv) → three (K, nv, nv) arrays."""
    single, q, (qd, qdd) = batch_of(q, qd=qd, qdd=qdd)
    with np.errstate(over="ignore", invalid="ignore"):
        out = _rnea_derivatives_batch(tree, q, qd, qdd, f_ext)
    for x in out:
        check_result("rnea_derivatives_batch", x, _HUGE)
    return tuple(x[0] for x in out) if single else out


def _aba_derivatives_general(tree, q, qd, tau, f_ext):
    """(∂q̈/∂q, ∂q̈/∂q̇, H⁻¹), each (K, nv, nv), from the RNEA derivatives above at q̈ = ABA (any tree)."""
    qdd = aba_fast(tree, q, qd, tau, f_ext)
    dq, dqd, H = _rnea_derivatives_batch(tree, q, qd, qdd, f_ext)
    Minv = np.linalg.inv(H)
    Minv = 0.5 * (Minv + np.swapaxes(Minv, 1, 2))
    dqd += np.diag(tree.arrays()["damping"])
    return -(Minv @ dq), -(Minv @ dqd), Minv


@contract(tree=_TREE, q=_QB, qd=_VB, tau=_VB, f_ext=_FB)
def aba_derivatives_batch(tree: ArticulatedTree, q, qd, tau, f_ext=None):
    """(∂q̈/∂q, ∂q̈/∂q̇, H⁻¹) for K states: q (K, nq), q̇ and τ (K, nv) → three (K, nv, nv) arrays, at
    q̈ = ABA(q, q̇, τ) (damping and f̂ᵉˣᵗ included; a joint that moves no inertia raises ABA's named error)."""
    single, q, (qd, tau) = batch_of(q, qd=qd, tau=tau)
    with np.errstate(over="ignore", invalid="ignore"):
        if np.any(plan_for(tree).kinds == FLOATING):
            out = _aba_derivatives_general(tree, q, qd, tau, f_ext)
        else:
            out = _aba_derivatives_lean(tree, q, qd, tau, f_ext)
    for x in out:
        check_result("aba_derivatives_batch", x, _HUGE)
    return tuple(x[0] for x in out) if single else out
