"""RNEA, CRBA and ABA vectorized over a batch of K states (chapter 08).

The same recursions as :mod:`pbanim.articulated.dynamics` (read that module first), with every per-link
quantity carrying a leading batch axis: ⁱX_λ (K, 6, 6), v̂_i (K, 6), I^A_i (K, 6, 6). The loops run over
the n links only; each step is one array operation on all K states, so the Python overhead of a step is
paid once per batch instead of once per state. Cross products are applied directly,

    v̂ × ŵ = (ω × w_ω,  v × w_ω + ω × w_v),     v̂ ×* f̂ = (ω × n + v × f,  ω × f),

instead of forming the 6 × 6 matrices. ``q`` of shape (nq,) is treated as K = 1 and the result squeezed.

Forward dynamics over a batch is :func:`aba_batch`, which runs the world-frame ABA of
:mod:`pbanim.articulated.fast` (one numpy operation per step for all K states, no 6 × 6 transform in its
sweeps: see :mod:`pbanim.articulated.fastplan` for why that is the same q̈).
"""

from __future__ import annotations

import numpy as np

from ..contracts import Array, Opt, contract
from ..errors import check_result
from ..geometry import cross as _cross
from .dynamics import external_forces
from .fast import aba_fast, batch_of
from .specs import JointPositions, Tree
from .tree import ArticulatedTree

_TREE, _QB = Tree(), JointPositions("tree", batch="first")
_VB = Array(("tree.nv",), batch="first", empty=True)
_FB = Opt(Array(("tree.n", 6), batch="first"))
_HUGE = "of a tree and states with huge entries"

__all__ = ["rnea_batch", "crba_batch", "aba_batch", "link_transforms_batch", "energy_batch"]


def _crm(v, w):
    return np.concatenate([_cross(v[..., :3], w[..., :3]),
                           _cross(v[..., 3:], w[..., :3]) + _cross(v[..., :3], w[..., 3:])], axis=-1)


def _crf(v, f):
    return np.concatenate([_cross(v[..., :3], f[..., :3]) + _cross(v[..., 3:], f[..., 3:]),
                           _cross(v[..., :3], f[..., 3:])], axis=-1)


def _mv(M, x):
    return np.einsum("kij,kj->ki", M, x)


def _mtv(M, x):
    return np.einsum("kji,kj->ki", M, x)


def link_transforms_batch(tree: ArticulatedTree, q: np.ndarray) -> list[np.ndarray]:
    """ⁱX_λ(i) for each link, each (K, 6, 6)."""
    A = tree.arrays()
    return [tree.joint_transform(i, q[:, A["qi"][i]]) @ A["XT"][i] for i in range(tree.n)]


@contract(tree=_TREE, q=_QB, qd=_VB, qdd=_VB, f_ext=_FB)
def rnea_batch(tree: ArticulatedTree, q, qd, qdd, f_ext=None) -> np.ndarray:
    """τ for K states at once: q (K, nq), q̇ and q̈ (K, nv) → τ (K, nv)."""
    single, q, (qd, qdd) = batch_of(q, qd=qd, qdd=qdd)
    with np.errstate(over="ignore", invalid="ignore"):      # an overflow is named by check_result below
        tau = _rnea_batch(tree, q, qd, qdd, f_ext)
    check_result("rnea_batch", tau, _HUGE)
    return tau[0] if single else tau


def _rnea_batch(tree, q, qd, qdd, f_ext):
    A, K = tree.arrays(), q.shape[0]
    fx = external_forces(tree, f_ext, K)
    Xup = link_transforms_batch(tree, q)
    v, a, f = [None] * tree.n, [None] * tree.n, [None] * tree.n
    a0 = np.broadcast_to(A["a0"], (K, 6))
    for i in range(tree.n):
        S, vi, lam = A["S"][i], A["vi"][i], tree.parent[i]
        vJ = qd[:, vi] @ S.T
        v[i] = (_mv(Xup[i], v[lam]) if lam >= 0 else 0.0) + vJ
        a[i] = _mv(Xup[i], a[lam] if lam >= 0 else a0) + qdd[:, vi] @ S.T + _crm(v[i], vJ)
        I = A["I"][i]
        f[i] = a[i] @ I.T + _crf(v[i], v[i] @ I.T) - fx[:, i]
    tau = np.zeros((K, tree.nv))
    for i in reversed(range(tree.n)):
        tau[:, A["vi"][i]] = f[i] @ A["S"][i]
        lam = tree.parent[i]
        if lam >= 0:
            f[lam] = f[lam] + _mtv(Xup[i], f[i])
    return tau


@contract(tree=_TREE, q=_QB)
def crba_batch(tree: ArticulatedTree, q) -> np.ndarray:
    """H(q) for K states: (K, nv, nv)."""
    single, q, _ = batch_of(q)
    with np.errstate(over="ignore", invalid="ignore"):
        H = _crba_batch(tree, q)
    check_result("crba_batch", H, _HUGE)
    return H[0] if single else H


def _crba_batch(tree, q):
    A, K = tree.arrays(), q.shape[0]
    Xup = link_transforms_batch(tree, q)
    Ic = [np.broadcast_to(I, (K, 6, 6)).copy() for I in A["I"]]
    for i in reversed(range(tree.n)):
        lam = tree.parent[i]
        if lam >= 0:
            Ic[lam] += np.swapaxes(Xup[i], 1, 2) @ Ic[i] @ Xup[i]
    H = np.zeros((K, tree.nv, tree.nv))
    for i in range(tree.n):
        S, vi = A["S"][i], A["vi"][i]
        F = Ic[i] @ S                                           # (K, 6, d_i)
        B = np.swapaxes(F, 1, 2) @ S
        H[:, vi, vi] = 0.5 * (B + np.swapaxes(B, 1, 2))
        j = i
        while tree.parent[j] >= 0:                              # at most depth(i) < n steps
            F = np.swapaxes(Xup[j], 1, 2) @ F
            j = tree.parent[j]
            Hij = np.swapaxes(F, 1, 2) @ A["S"][j]
            H[:, vi, A["vi"][j]] = Hij
            H[:, A["vi"][j], vi] = np.swapaxes(Hij, 1, 2)
    return H


@contract(tree=_TREE, q=_QB, qd=_VB, tau=_VB, f_ext=_FB)
def aba_batch(tree: ArticulatedTree, q, qd, tau, f_ext=None) -> np.ndarray:
    """q̈ for K states at once: q (K, nq), q̇ and τ (K, nv) → q̈ (K, nv), joint damping and external forces
    included. This is the world-frame ABA of :func:`~pbanim.articulated.fast.aba_fast` (equations in
    :mod:`~pbanim.articulated.fastplan`), whose sweeps need no 6 × 6 transforms; the link-coordinate
    recursion to read is :func:`~pbanim.articulated.dynamics.aba`. ``q`` of shape (nq,) is one state."""
    return aba_fast(tree, q, qd, tau, f_ext)


@contract(tree=_TREE, q=_QB, qd=_VB)
def energy_batch(tree: ArticulatedTree, q, qd) -> np.ndarray:
    """E = ½ q̇ᵀ H(q) q̇ − Σᵢ mᵢ g·x_cᵢ for K states at once: q (K, nq), q̇ (K, nv) → (K,) (one state: a
    scalar array). Kinetic energy by :func:`crba_batch`; the centres of mass from the link-from-world
    transforms ⁱX_0 = ⁱX_λ ᵏX_0 = [[E, 0], [−E r×, E]] of every link, as
    :func:`~pbanim.articulated.dynamics.potential_energy` takes them one state at a time."""
    single, q, (qd,) = batch_of(q, qd=qd)
    with np.errstate(over="ignore", invalid="ignore"):
        E = 0.5 * np.einsum("ki,kij,kj->k", qd, _crba_batch(tree, q), qd)
        Xup = link_transforms_batch(tree, q)
        X0 = [None] * tree.n
        for i, lk in enumerate(tree.links):
            lam = tree.parent[i]
            X0[i] = Xup[i] @ X0[lam] if lam >= 0 else Xup[i]
            Et = np.swapaxes(X0[i][:, :3, :3], 1, 2)                 # link → world
            M = -Et @ X0[i][:, 3:, :3]                               # r× of the link's origin r
            x = np.stack([M[:, 2, 1], M[:, 0, 2], M[:, 1, 0]], axis=1) + Et @ lk.com
            E = E - lk.mass * (x @ tree.gravity)
    check_result("energy_batch", E, _HUGE)
    return E[0] if single else E
