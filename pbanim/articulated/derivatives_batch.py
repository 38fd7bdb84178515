"""Analytical derivatives of RNEA and ABA over a batch of K states (chapter 08).

The recursion of :mod:`pbanim.articulated.derivatives` (read that module first), with the derivatives with
respect to q and to q̇ carried together as C = 2 nv columns and the batch axis last: ∂v̂_i is (6, C, K), so
that every line of the recursion is a few numpy operations on contiguous (C, K) planes, whatever the state.
The transforms are applied from their parts, ⁱX_λ = [[E, 0], [−E r×, E]],

    ⁱX_λ (ω, v) = (E ω, E (v − r × ω)),        ⁱX_λᵀ (n, f) = (Eᵀ n + r × Eᵀ f, Eᵀ f),

the cross products component by component, v̂ × ŵ = (ω × w_ω, v × w_ω + ω × w_v) and
v̂ ×* f̂ = (ω × n + v × f, ω × f), and the constant link inertias I_i as one matrix product over all planes.
The loops run over the n links only. The results equal the readable ones state by state to roundoff
(ORACLES L1, I5). ``q`` of shape (nq,) is one state (K = 1, the result squeezed).
"""

from __future__ import annotations

import numpy as np

from ..contracts import Array, Opt, contract
from ..errors import check_result
from .batched import _crba_batch, link_transforms_batch
from .dynamics import external_forces
from .fast import aba_fast, batch_of
from .specs import JointPositions, Tree
from .tree import ArticulatedTree

__all__ = ["rnea_derivatives_batch", "aba_derivatives_batch"]

_TREE, _QB = Tree(), JointPositions("tree", batch="first")
_VB = Array(("tree.nv",), batch="first", empty=True)
_FB = Opt(Array(("tree.n", 6), batch="first"))
_HUGE = "of a tree and states with huge entries"


def _x3(a, b):
    """a × b along the first axis (3, ...), broadcasting over the rest."""
    out = np.empty(np.broadcast_shapes(a.shape, b.shape))
    out[0] = a[1] * b[2] - a[2] * b[1]
    out[1] = a[2] * b[0] - a[0] * b[2]
    out[2] = a[0] * b[1] - a[1] * b[0]
    return out


def _crm(x, y):
    """x̂ × ŷ for motion vectors along the first axis (6, ...)."""
    return np.concatenate([_x3(x[:3], y[:3]), _x3(x[3:], y[:3]) + _x3(x[:3], y[3:])])


def _crf(x, f):
    """x̂ ×* f̂ for a motion and a force vector along the first axis (6, ...)."""
    return np.concatenate([_x3(x[:3], f[:3]) + _x3(x[3:], f[3:]), _x3(x[:3], f[3:])])


def _rot(E, w, transpose=False):
    """E w (or Eᵀ w) for E (3, 3, K) and w (3, ..., K)."""
    if transpose:
        return np.stack([E[0, i] * w[0] + E[1, i] * w[1] + E[2, i] * w[2] for i in range(3)])
    return np.stack([E[i, 0] * w[0] + E[i, 1] * w[1] + E[i, 2] * w[2] for i in range(3)])


def _X(E, r, m):
    """ⁱX_λ m = (E ω, E (v − r × ω)) for motion vectors m (6, ..., K)."""
    r = r.reshape((3,) + (1,) * (m.ndim - 2) + r.shape[-1:])
    return np.concatenate([_rot(E, m[:3]), _rot(E, m[3:] - _x3(r, m[:3]))])


def _XT(E, r, f):
    """ⁱX_λᵀ f = (Eᵀ n + r × Eᵀ f, Eᵀ f) for force vectors f (6, ..., K)."""
    r = r.reshape((3,) + (1,) * (f.ndim - 2) + r.shape[-1:])
    Ef = _rot(E, f[3:], True)
    return np.concatenate([_rot(E, f[:3], True) + _x3(r, Ef), Ef])


def _parts(X):
    """(E, r) of ⁱX_λ = [[E, 0], [−E r×], E]] (K, 6, 6), batch axis last: r× = −Eᵀ (−E r×)."""
    E = np.ascontiguousarray(np.moveaxis(X[:, :3, :3], 0, -1))
    M = -np.einsum("kji,kjl->kil", X[:, :3, :3], X[:, 3:, :3])
    return E, np.ascontiguousarray(np.stack([M[:, 2, 1], M[:, 0, 2], M[:, 1, 0]]))


def _rnea_derivatives_batch(tree, q, qd, qdd, f_ext):
    """(∂τ/∂q, ∂τ/∂q̇), each (K, nv, nv)."""
    A, K, n, nv = tree.arrays(), q.shape[0], tree.n, tree.nv
    fx = np.moveaxis(external_forces(tree, f_ext, K), 0, -1)        # (n, 6, K)
    parts = [_parts(X) for X in link_transforms_batch(tree, q)]
    qdT, qddT = np.ascontiguousarray(qd.T), np.ascontiguousarray(qdd.T)
    a0 = np.broadcast_to(A["a0"][:, None], (6, K))
    v, a, f, Dv, Da, Df = ([None] * n for _ in range(6))            # D*: (6, 2 nv, K), q columns then q̇
    for i in range(n):                                              # forward: root to leaves
        S, vi, lam, I = A["S"][i], A["vi"][i], tree.parent[i], A["I"][i]
        E, r = parts[i]
        cq, cd = vi, slice(nv + vi.start, nv + vi.stop)
        vJ = S @ qdT[vi]
        if lam >= 0:
            vp, ap = _X(E, r, v[lam]), _X(E, r, a[lam])
            Dv[i], Da[i] = _X(E, r, Dv[lam]), _X(E, r, Da[lam])
        else:
            vp, ap = np.zeros((6, K)), _X(E, r, a0)
            Dv[i], Da[i] = np.zeros((6, 2 * nv, K)), np.zeros((6, 2 * nv, K))
        v[i] = vp + vJ
        a[i] = ap + S @ qddT[vi] + _crm(v[i], vJ)
        for c in range(S.shape[1]):
            s = S[:, c, None]
            Dv[i][:, cq.start + c] += _crm(vp, s)                   # (ⁱX_λ v̂_λ) × S_i
            Dv[i][:, cd.start + c] += s
            Da[i][:, cq.start + c] += _crm(ap, s)                   # (ⁱX_λ â_λ) × S_i
            Da[i][:, cd.start + c] += _crm(v[i], s)                 # v̂_i × S_i
        Da[i] -= _crm(vJ[:, None], Dv[i])
        h = I @ v[i]
        f[i] = I @ a[i] + _crf(v[i], h) - fx[i]
        Df[i] = (np.tensordot(I, Da[i], 1) + _crf(Dv[i], h[:, None])
                 + _crf(v[i][:, None], np.tensordot(I, Dv[i], 1)))
    dtau = np.zeros((nv, 2 * nv, K))
    for i in reversed(range(n)):                                    # backward: leaves to root
        S, vi, lam = A["S"][i], A["vi"][i], tree.parent[i]
        dtau[vi] = np.tensordot(S.T, Df[i], 1)
        if lam >= 0:
            E, r = parts[i]
            f[lam] = f[lam] + _XT(E, r, f[i])
            Df[lam] = Df[lam] + _XT(E, r, Df[i])
            for c in range(S.shape[1]):                             # ⁱX_λᵀ (S_i ×* f̂_i)
                Df[lam][:, vi.start + c] += _XT(E, r, _crf(np.broadcast_to(S[:, c, None], (6, K)), f[i]))
    out = np.moveaxis(dtau, -1, 0)
    return out[:, :, :nv], out[:, :, nv:]


@contract(tree=_TREE, q=_QB, qd=_VB, qdd=_VB, f_ext=_FB)
def rnea_derivatives_batch(tree: ArticulatedTree, q, qd, qdd, f_ext=None):
    """(∂τ/∂q, ∂τ/∂q̇, H) for K states: q (K, nq), q̇ and q̈ (K, nv) → three (K, nv, nv) arrays."""
    single, q, (qd, qdd) = batch_of(q, qd=qd, qdd=qdd)
    with np.errstate(over="ignore", invalid="ignore"):
        out = (*_rnea_derivatives_batch(tree, q, qd, qdd, f_ext), _crba_batch(tree, q))
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
        dq, dqd = _rnea_derivatives_batch(tree, q, qd, qdd, f_ext)
        Minv = np.linalg.inv(_crba_batch(tree, q))
        Minv = 0.5 * (Minv + np.swapaxes(Minv, 1, 2))
        dqd += np.diag(tree.arrays()["damping"])
        out = (-(Minv @ dq), -(Minv @ dqd), Minv)
    for x in out:
        check_result("aba_derivatives_batch", x, _HUGE)
    return tuple(x[0] for x in out) if single else out
