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
"""

from __future__ import annotations

import numpy as np

from ..contracts import Array, Opt, contract
from ..errors import check_result
from .batched import _crf, _crm, link_transforms_batch
from .derivatives import bar
from .dynamics import external_forces
from .fast import aba_fast, batch_of
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


@contract(tree=_TREE, q=_QB, qd=_VB, qdd=_VB, f_ext=_FB)
def rnea_derivatives_batch(tree: ArticulatedTree, q, qd, qdd, f_ext=None):
    """(∂τ/∂q, ∂τ/∂q̇, H) for K states: q (K, nq), q̇ and q̈ (K, nv) → three (K, nv, nv) arrays."""
    single, q, (qd, qdd) = batch_of(q, qd=qd, qdd=qdd)
    with np.errstate(over="ignore", invalid="ignore"):
        out = _rnea_derivatives_batch(tree, q, qd, qdd, f_ext)
    for x in out:
        check_result("rnea_derivatives_batch", x, _HUGE)
    return tuple(x[0] for x in out) if single else out


@contract(tree=_TREE, q=_QB, qd=_VB, tau=_VB, f_ext=_FB)
def aba_derivatives_batch(tree: ArticulatedTree, q, qd, tau, f_ext=None):
    """(∂q̈/∂q, ∂q̈/∂q̇, H⁻¹) for K states: q (K, nq), q̇ and τ (K, nv) → three (K, nv, nv) arrays, at
    q̈ = ABA(q, q̇, τ) (damping and f̂ᵉˣᵗ included; a joint that moves no inertia raises ABA's named error)."""
    single, q, (qd, tau) = batch_of(q, qd=qd, tau=tau)
    with np.errstate(over="ignore", invalid="ignore"):
        qdd = aba_fast(tree, q, qd, tau, f_ext)
        dq, dqd, H = _rnea_derivatives_batch(tree, q, qd, qdd, f_ext)
        Minv = np.linalg.inv(H)
        Minv = 0.5 * (Minv + np.swapaxes(Minv, 1, 2))
        dqd += np.diag(tree.arrays()["damping"])
        out = (-(Minv @ dq), -(Minv @ dqd), Minv)
    for x in out:
        check_result("aba_derivatives_batch", x, _HUGE)
    return tuple(x[0] for x in out) if single else out
