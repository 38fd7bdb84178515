"""Analytical derivatives of RNEA and ABA with respect to q, q̇, τ, readable, one state (chapter 08).

Carpentier & Mansard (RSS 2018) differentiate the recursions themselves instead of the whole function by
finite differences. Every dependence of RNEA on q goes through the link transforms ⁱX_λ = X_J(q_i) X_T(i),
and for every joint kind of :mod:`pbanim.articulated.tree` a displacement δ of joint i in its tangent space
moves the child frame by S_i δ in its own coordinates, so

    ∂ⁱX_λ/∂q_i δ = −(S_i δ)× ⁱX_λ        (revolute, continuous, prismatic: δ a scalar; floating: δ = (δω, δv)
                                           in the link's axes, q ⊕ δ = (quat ⊗ exp(δω/2), p + R δv); fixed: none).

With x̄ the "bar" product, x ×* f = f̄ x (f̄ = [[−n×, −F×], [−F×, 0]] for f = (n, F)), the derivative of each
line of RNEA (module :mod:`pbanim.articulated.dynamics`) along any parameter is one line more:

    ∂v̂_i = ⁱX_λ ∂v̂_λ + [q: (ⁱX_λ v̂_λ)× S_i  in joint i's columns;  q̇: S_i]
    ∂â_i = ⁱX_λ ∂â_λ + [q: (ⁱX_λ â_λ)× S_i;  q̇: v̂_i× S_i] − (S_i q̇_i)× ∂v̂_i
    ∂f̂_i = I_i ∂â_i + (I_i v̂_i)‾ ∂v̂_i + v̂_i×* I_i ∂v̂_i
    ∂f̂_λ += ⁱX_λᵀ ∂f̂_i + [q: ⁱX_λᵀ f̂_i‾ S_i in joint i's columns],        ∂τ_i = S_iᵀ ∂f̂_i,

each ∂ a 6 × nv array (one column per tangent coordinate), so one state costs O(n·nv) spatial products
(the paper's world-frame form reaches O(n d); this local-frame form is the one to read). ∂τ/∂q̈ = H (CRBA).

ABA is the inverse of RNEA in q̈, so at q̈ = ABA(q, q̇, τ) (the implicit-function theorem on τ = RNEA):

    ∂q̈/∂q = −H⁻¹ ∂τ/∂q,      ∂q̈/∂q̇ = −H⁻¹ (∂τ/∂q̇ + B),      ∂q̈/∂τ = H⁻¹,

with B = diag(b) the joint damping ABA adds (−b q̇ in τ). External forces f̂ᵉˣᵗ are held fixed in link
coordinates (as RNEA and ABA take them). Derivatives with respect to q are in the tangent space (nv columns:
the velocity coordinates), as Pinocchio's ``computeRNEADerivatives`` / ``computeABADerivatives`` give them
(tests: ORACLES L1). The batched versions over K states are in :mod:`.derivatives_batch`.

Reference: J. Carpentier, N. Mansard, "Analytical derivatives of rigid body dynamics algorithms", RSS 2018.
"""

from __future__ import annotations

import numpy as np

from ..contracts import Array, Opt, contract
from ..errors import check_result
from ..geometry import skew
from ..rigid.quat import quat_exp, quat_multiply, quat_to_matrix
from .dynamics import _crba, external_forces, link_transforms
from .fast import aba_fast
from .spatial import crm
from .specs import JointPositions, Tree
from .tree import ArticulatedTree

__all__ = ["rnea_derivatives", "aba_derivatives", "tangent_step", "bar"]

_TREE, _Q = Tree(), JointPositions("tree")
_V = Array(("tree.nv",), empty=True)
_FEXT = Opt(Array(("tree.n", 6)))
_HUGE = "of a tree and state with huge entries"


@contract(f=Array((6,), batch="first"))
def bar(f: np.ndarray) -> np.ndarray:
    """f̄ (…, 6, 6) with x ×* f = f̄ x for every motion vector x: f̄ = [[−n×, −F×], [−F×, 0]], f = (n, F)."""
    f = np.asarray(f, dtype=float)
    N, F = skew(f[..., :3]), skew(f[..., 3:])
    out = np.zeros(f.shape[:-1] + (6, 6))
    out[..., :3, :3] = -N
    out[..., :3, 3:] = -F
    out[..., 3:, :3] = -F
    return out


@contract(tree=_TREE, q=_Q, dv=_V)
def tangent_step(tree: ArticulatedTree, q, dv) -> np.ndarray:
    """q ⊕ δ: q moved by the tangent vector δ (nv): q + δ on one-coordinate joints; a floating joint's
    (quat, p) becomes (quat ⊗ exp(δω/2), p + R(quat) δv) (δω, δv in the link's axes, as its q̇)."""
    out = np.array(q, dtype=float)
    dv = np.asarray(dv, dtype=float)
    for j, qs, vs in zip(tree.joints, tree._q_index, tree._v_index):
        if j.kind == "floating":
            quat, w = out[qs.start:qs.start + 4], dv[vs.start:vs.start + 3]
            out[qs.start + 4:qs.stop] += quat_to_matrix(quat / np.linalg.norm(quat)) @ dv[vs.start + 3:vs.stop]
            out[qs.start:qs.start + 4] = quat_multiply(quat, quat_exp(w))
        elif j.kind != "fixed":
            out[qs] += dv[vs]
    return out


def _rnea_derivatives(tree, q, qd, qdd, f_ext):
    """(∂τ/∂q, ∂τ/∂q̇) by the differentiated recursion of the module docstring."""
    A, fx, n, nv = tree.arrays(), external_forces(tree, f_ext), tree.n, tree.nv
    Xup = link_transforms(tree, q)
    v, a, f = [None] * n, [None] * n, [None] * n
    dv_q, da_q, df_q = [None] * n, [None] * n, [None] * n           # ∂/∂q, 6 × nv each
    dv_d, da_d, df_d = [None] * n, [None] * n, [None] * n           # ∂/∂q̇
    for i in range(n):                                              # forward: root to leaves
        S, vi, lam, X, I = A["S"][i], A["vi"][i], tree.parent[i], Xup[i], A["I"][i]
        vJ = S @ qd[vi]
        vp = X @ v[lam] if lam >= 0 else np.zeros(6)
        ap = X @ (a[lam] if lam >= 0 else A["a0"])
        v[i] = vp + vJ
        cv, cJ = crm(v[i]), crm(vJ)                                 # v̂_i×, v̂_J× (v̂×* = −(v̂×)ᵀ)
        a[i] = ap + S @ qdd[vi] + cv @ vJ
        # BEGIN SOLUTION _rnea_derivatives.forward
        dv_q[i] = X @ dv_q[lam] if lam >= 0 else np.zeros((6, nv))
        dv_d[i] = X @ dv_d[lam] if lam >= 0 else np.zeros((6, nv))
        da_q[i] = X @ da_q[lam] if lam >= 0 else np.zeros((6, nv))
        da_d[i] = X @ da_d[lam] if lam >= 0 else np.zeros((6, nv))
        dv_q[i][:, vi] += crm(vp) @ S                               # ∂(ⁱX_λ v̂_λ)/∂q_i = (ⁱX_λ v̂_λ)× S_i
        dv_d[i][:, vi] += S
        da_q[i][:, vi] += crm(ap) @ S
        da_d[i][:, vi] += cv @ S
        da_q[i] -= cJ @ dv_q[i]                                     # ∂(v̂_i × v̂_J) = −v̂_J × ∂v̂_i (+ the q̇ term)
        da_d[i] -= cJ @ dv_d[i]
        h = I @ v[i]
        f[i] = I @ a[i] - cv.T @ h - fx[i]
        G = bar(h) - cv.T @ I                                       # ∂(v̂ ×* I v̂)/∂v̂
        df_q[i] = I @ da_q[i] + G @ dv_q[i]
        df_d[i] = I @ da_d[i] + G @ dv_d[i]
        # END SOLUTION
    dtau_q, dtau_d = np.zeros((nv, nv)), np.zeros((nv, nv))
    for i in reversed(range(n)):                                    # backward: leaves to root
        S, vi, lam, X = A["S"][i], A["vi"][i], tree.parent[i], Xup[i]
        # BEGIN SOLUTION _rnea_derivatives.backward
        dtau_q[vi] = S.T @ df_q[i]
        dtau_d[vi] = S.T @ df_d[i]
        if lam >= 0:
            f[lam] = f[lam] + X.T @ f[i]
            df_q[lam] = df_q[lam] + X.T @ df_q[i]
            df_q[lam][:, vi] += X.T @ bar(f[i]) @ S                 # (∂ⁱX_λ/∂q_i)ᵀ f̂_i = ⁱX_λᵀ f̂_i‾ S_i
            df_d[lam] = df_d[lam] + X.T @ df_d[i]
        # END SOLUTION
    return dtau_q, dtau_d


@contract(tree=_TREE, q=_Q, qd=_V, qdd=_V, f_ext=_FEXT)
def rnea_derivatives(tree: ArticulatedTree, q, qd, qdd, f_ext=None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(∂τ/∂q, ∂τ/∂q̇, ∂τ/∂q̈ = H) of τ = RNEA(q, q̇, q̈), each (nv, nv); ∂/∂q in the tangent space
    (see :func:`tangent_step`).

    >>> from pbanim.models.articulated import pendulum_chain
    >>> tree = pendulum_chain(1, lengths=1.0, masses=1.0)           # one point mass on a unit rod
    >>> dq, dqd, H = rnea_derivatives(tree, np.array([0.3]), np.zeros(1), np.zeros(1))
    >>> bool(abs(dq[0, 0] - 9.81 * np.cos(0.3)) < 1e-12), H.round(12).tolist()   # ∂(m g l sin q)/∂q
    (True, [[1.0]])
    """
    with np.errstate(over="ignore", invalid="ignore"):
        dq, dqd = _rnea_derivatives(tree, q, qd, qdd, f_ext)
        H = _crba(tree, q)
    return (check_result("rnea_derivatives", dq, _HUGE), check_result("rnea_derivatives", dqd, _HUGE),
            check_result("rnea_derivatives", H, _HUGE))


@contract(tree=_TREE, q=_Q, qd=_V, tau=_V, f_ext=_FEXT)
def aba_derivatives(tree: ArticulatedTree, q, qd, tau, f_ext=None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(∂q̈/∂q, ∂q̈/∂q̇, ∂q̈/∂τ = H⁻¹) of q̈ = ABA(q, q̇, τ) (damping and f̂ᵉˣᵗ included), each (nv, nv):
    −H⁻¹ times the RNEA derivatives at q̈ (module docstring). A joint that moves no inertia raises ABA's
    named error; an overflow :class:`~pbanim.errors.NonFiniteResult`."""
    with np.errstate(over="ignore", invalid="ignore"):
        qdd = check_result("aba_derivatives", aba_fast(tree, q, qd, tau, f_ext), _HUGE)   # the same q̈ (I5)
        dq, dqd = _rnea_derivatives(tree, q, qd, qdd, f_ext)
        H = _crba(tree, q)
        # BEGIN SOLUTION aba_derivatives.implicit
        Minv = np.linalg.inv(H)
        Minv = 0.5 * (Minv + Minv.T)
        dqd = dqd + np.diag(tree.arrays()["damping"])
        out = (-Minv @ dq, -Minv @ dqd, Minv)
        # END SOLUTION
    for x in out:
        check_result("aba_derivatives", x, _HUGE)
    return out
