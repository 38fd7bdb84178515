"""Featherstone's algorithms, readable: RNEA, CRBA, ABA for one state (chapter 08).

With the tree of :mod:`pbanim.articulated.tree` (ⁱX_λ = X_J(q_i) X_T(i), S_i, I_i) and the base
acceleration â₀ = (0, −g) (gravity as a fictitious upward acceleration of the world):

RNEA, inverse dynamics τ = ID(q, q̇, q̈) (Featherstone 2008, Table 5.1):
    v̂_i = ⁱX_λ v̂_λ + S_i q̇_i,   â_i = ⁱX_λ â_λ + S_i q̈_i + v̂_i × S_i q̇_i,
    f̂_i = I_i â_i + v̂_i ×* I_i v̂_i − f̂ᵉˣᵗ_i,   then from the leaves:  τ_i = S_iᵀ f̂_i,  f̂_λ += ⁱX_λᵀ f̂_i.
CRBA, the joint-space mass matrix H (Table 6.2): composite inertias I^c_λ += ⁱX_λᵀ I^c_i ⁱX_λ, then
    H_ii = S_iᵀ I^c_i S_i and, walking F = I^c_i S_i up to each ancestor j, H_ji = H_ijᵀ = S_jᵀ F.
ABA, forward dynamics q̈ = FD(q, q̇, τ) in O(n) (Table 7.1): articulated inertias I^A and bias forces p^A
from the leaves, U_i = I^A_i S_i, D_i = S_iᵀ U_i, u_i = τ_i − S_iᵀ p^A_i, and accelerations from the root.

So H q̈ + C(q, q̇) = τ with C = ID(q, q̇, 0): ABA equals the CRBA solve H⁻¹(τ − C) (tested), and
RNEA(q, q̇, ABA(q, q̇, τ)) = τ. Joint damping b adds −b q̇ to τ in ABA and the simulation (not in RNEA,
which is the rigid-body inverse dynamics). External forces f̂ᵉˣᵗ (n, 6) are in link coordinates.
The vectorized versions over a batch of K states are in :mod:`pbanim.articulated.batched`.

ABA's pivots D_i are the pivots of H's LDLᵀ factorization taken leaves first (eliminating a joint is
projecting its subtree's articulated inertia through it), so a joint that moves no inertia (D_i = 0) is
a zero pivot of H: :func:`check_articulated_inertia` finds it from CRBA and names the joint.
"""

from __future__ import annotations

import numpy as np

from ..contracts import Array, Int, Opt, Real, contract
from ..errors import InvalidInput, NonFiniteResult, SingularChartError, check_result
from .spatial import crf, crm
from .specs import JointPositions, Tree
from .tree import ArticulatedTree

__all__ = ["link_transforms", "rnea", "crba", "aba", "kinetic_energy", "potential_energy", "bias_forces",
           "world_poses", "external_forces", "check_articulated_inertia", "SingularJointInertia", "joint_label"]

_TREE, _Q = Tree(), JointPositions("tree")
_V = Array(("tree.nv",), empty=True)
_FEXT = Opt(Array(("tree.n", 6)))
_HUGE = "of a tree and state with huge entries"


class SingularJointInertia(InvalidInput):
    """A movable joint of a model moves no inertia: its articulated inertia D = Sᵀ I^A S vanishes (a massless
    leaf link, or a massless link between two joints about one axis), so q̈ = D⁻¹(…) has no value."""


def joint_label(tree: ArticulatedTree, i: int) -> str:
    """"joint i ('name')" for messages."""
    names = getattr(tree, "joint_names", None)
    return f"joint {i} ({names[i]!r})" if names and i < len(names) else f"joint {i}"


@contract(tree=_TREE, q=_Q)
def link_transforms(tree: ArticulatedTree, q: np.ndarray) -> list[np.ndarray]:
    """ⁱX_λ(i) = X_J(q_i) X_T(i) for every link (the child-from-parent transforms)."""
    A = tree.arrays()
    return [tree.joint_transform(i, q[A["qi"][i]]) @ A["XT"][i] for i in range(tree.n)]


def external_forces(tree: ArticulatedTree, f_ext, K: int | None = None) -> np.ndarray:
    """f̂ᵉˣᵗ as (n, 6), or (K, n, 6) for a batch, validated finite (zeros when None)."""
    shape = (tree.n, 6) if K is None else (K, tree.n, 6)
    if f_ext is None:
        return np.zeros(shape)
    f = np.asarray(f_ext, dtype=float)
    try:
        f = np.broadcast_to(f, shape)
    except ValueError:
        raise InvalidInput(f"f_ext must have shape {shape} (link coordinates) to go with q, got {f.shape}") from None
    if not np.all(np.isfinite(f)):
        raise InvalidInput("f_ext must be finite")
    return f


def world_poses(tree: ArticulatedTree, q) -> tuple[list, list, np.ndarray]:
    """(Xup, X0, origins): the child-from-parent transforms, the link-from-world transforms ⁱX_0 and the
    link origins in world coordinates (n, 3), from ⁱX_0 = [[E, 0], [−E r×, E]]: r× = −Eᵀ(−E r×)."""
    return _poses(tree, link_transforms(tree, q))


def _poses(tree, Xup) -> tuple[list, list, np.ndarray]:
    """:func:`world_poses` from the transforms ``Xup`` = :func:`link_transforms` (tree, q)."""
    X0 = [None] * tree.n
    origins = np.zeros((tree.n, 3))
    for i in range(tree.n):
        lam = tree.parent[i]
        X0[i] = Xup[i] @ X0[lam] if lam >= 0 else Xup[i]
        M = -X0[i][:3, :3].T @ X0[i][3:, :3]
        origins[i] = (M[2, 1], M[0, 2], M[1, 0])
    return Xup, X0, origins


@contract(tree=_TREE, q=_Q, qd=_V, qdd=_V, f_ext=_FEXT)
def rnea(tree: ArticulatedTree, q, qd, qdd, f_ext=None) -> np.ndarray:
    """τ = ID(q, q̇, q̈): the joint forces that produce the accelerations q̈ (gravity included)."""
    with np.errstate(over="ignore", invalid="ignore"):      # an overflow is named by check_result below
        return check_result("rnea", _rnea(tree, q, qd, qdd, f_ext), _HUGE)


def _rnea(tree, q, qd, qdd, f_ext, Xup=None):
    A, fx = tree.arrays(), external_forces(tree, f_ext)
    Xup = link_transforms(tree, q) if Xup is None else Xup
    v, a, f = [None] * tree.n, [None] * tree.n, [None] * tree.n
    for i in range(tree.n):
        S, vi = A["S"][i], A["vi"][i]
        vJ = S @ qd[vi]
        lam = tree.parent[i]
        v[i] = (Xup[i] @ v[lam] if lam >= 0 else np.zeros(6)) + vJ
        a[i] = Xup[i] @ (a[lam] if lam >= 0 else A["a0"]) + S @ qdd[vi] + crm(v[i]) @ vJ
        I = A["I"][i]
        f[i] = I @ a[i] + crf(v[i]) @ (I @ v[i]) - fx[i]
    tau = np.zeros(tree.nv)
    for i in reversed(range(tree.n)):
        tau[A["vi"][i]] = A["S"][i].T @ f[i]
        lam = tree.parent[i]
        if lam >= 0:
            f[lam] = f[lam] + Xup[i].T @ f[i]
    return tau


@contract(tree=_TREE, q=_Q, qd=_V, f_ext=_FEXT)
def bias_forces(tree: ArticulatedTree, q, qd, f_ext=None) -> np.ndarray:
    """C(q, q̇) = ID(q, q̇, 0): gravity, Coriolis and centrifugal joint forces (minus external ones)."""
    return rnea(tree, q, qd, np.zeros(tree.nv), f_ext)


@contract(tree=_TREE, q=_Q)
def crba(tree: ArticulatedTree, q) -> np.ndarray:
    """H(q), the joint-space mass matrix (nv, nv), symmetric positive definite."""
    with np.errstate(over="ignore", invalid="ignore"):
        return check_result("crba", _crba(tree, q), _HUGE)


def _crba(tree, q, Xup=None):
    A = tree.arrays()
    Xup = link_transforms(tree, q) if Xup is None else Xup
    Ic = [I.copy() for I in A["I"]]
    for i in reversed(range(tree.n)):
        lam = tree.parent[i]
        if lam >= 0:
            Ic[lam] = Ic[lam] + Xup[i].T @ Ic[i] @ Xup[i]
    H = np.zeros((tree.nv, tree.nv))
    for i in range(tree.n):
        S, vi = A["S"][i], A["vi"][i]
        F = Ic[i] @ S
        B = S.T @ F
        H[vi, vi] = 0.5 * (B + B.T)                # symmetric to the last bit (a 6×6 block for floating)
        j = i
        while tree.parent[j] >= 0:          # at most depth(i) < n steps: λ(j) < j
            F = Xup[j].T @ F
            j = tree.parent[j]
            H[vi, A["vi"][j]] = F.T @ A["S"][j]
            H[A["vi"][j], vi] = H[vi, A["vi"][j]].T
    return H


def _mass_bias_poses(tree, q, qd) -> tuple:
    """(H, C, world poses) = (:func:`crba`, :func:`bias_forces`, :func:`world_poses`) at (q, q̇) from one
    evaluation of the transforms ⁱX_λ(q) (each of the three computes the same ones): the same numbers, the
    same named errors (a contact step's lean path, :mod:`.contact`)."""
    Xup = link_transforms(tree, q)
    with np.errstate(over="ignore", invalid="ignore"):
        H = check_result("crba", _crba(tree, q, Xup), _HUGE)
        C = check_result("rnea", _rnea(tree, q, qd, np.zeros(tree.nv), None, Xup), _HUGE)
    return H, C, _poses(tree, Xup)


@contract(tree=_TREE, q=_Q, qd=_V, tau=_V, f_ext=_FEXT)
def aba(tree: ArticulatedTree, q, qd, tau, f_ext=None) -> np.ndarray:
    """q̈ = FD(q, q̇, τ) by the articulated-body algorithm, O(n); joint damping included."""
    with np.errstate(over="ignore", invalid="ignore"):
        return check_result("aba", _aba(tree, q, qd, tau, f_ext), _HUGE)


def _aba(tree, q, qd, tau, f_ext):
    A, fx = tree.arrays(), external_forces(tree, f_ext)
    tau = tau - A["damping"] * qd
    Xup = link_transforms(tree, q)
    n = tree.n
    v, c, IA, pA = [None] * n, [None] * n, [None] * n, [None] * n
    for i in range(n):
        S, vi = A["S"][i], A["vi"][i]
        vJ = S @ qd[vi]
        lam = tree.parent[i]
        v[i] = (Xup[i] @ v[lam] if lam >= 0 else np.zeros(6)) + vJ
        c[i] = crm(v[i]) @ vJ
        IA[i] = A["I"][i].copy()
        pA[i] = crf(v[i]) @ (A["I"][i] @ v[i]) - fx[i]
    U, Dinv, u = [None] * n, [None] * n, [None] * n
    for i in reversed(range(n)):
        S, vi = A["S"][i], A["vi"][i]
        U[i] = IA[i] @ S
        Dinv[i] = _inverse(S.T @ U[i], tree, i, q)
        u[i] = tau[vi] - S.T @ pA[i]
        lam = tree.parent[i]
        if lam >= 0:
            Ia = IA[i] - U[i] @ Dinv[i] @ U[i].T
            pa = pA[i] + Ia @ c[i] + U[i] @ (Dinv[i] @ u[i])
            IA[lam] = IA[lam] + Xup[i].T @ Ia @ Xup[i]
            pA[lam] = pA[lam] + Xup[i].T @ pa
    qdd = np.zeros(tree.nv)
    a = [None] * n
    for i in range(n):
        S, vi = A["S"][i], A["vi"][i]
        lam = tree.parent[i]
        ap = Xup[i] @ (a[lam] if lam >= 0 else A["a0"]) + c[i]
        qdd[vi] = Dinv[i] @ (u[i] - U[i].T @ ap)
        a[i] = ap + S @ qdd[vi]
    return qdd


def pivot_error(D, label: str, q, where: str = "") -> Exception:
    """The named error for an ABA pivot D that failed its test: NonFiniteResult when it overflowed, else
    SingularChartError (the joint moves (nearly) no inertia)."""
    if not np.all(np.isfinite(D)):
        return NonFiniteResult("ABA's articulated inertia", f"{label}{where}: {_HUGE}")
    return SingularChartError(np.inf, None if q is None else np.asarray(q).tolist(),
                              f"{label} has (nearly) zero articulated inertia about its axis{where}")


def _inverse(D: np.ndarray, tree, i: int, q) -> np.ndarray:
    """D⁻¹ of joint i's articulated inertia Sᵀ I^A S, or the named error when it is singular or overflowed."""
    if D.size == 0:
        return np.zeros((0, 0))
    if D.shape == (1, 1):                       # revolute and prismatic joints: a scalar
        d = float(D[0, 0])
        if not (np.isfinite(d) and abs(d) > 1e-280):
            raise pivot_error(d, joint_label(tree, i), q)
        return np.array([[1.0 / d]])
    scale = float(np.max(np.abs(D))) if np.all(np.isfinite(D)) else np.inf
    if not np.isfinite(scale) or scale < 1e-280 or np.linalg.cond(D) > 1e14:
        raise pivot_error(D, joint_label(tree, i), q)
    return np.linalg.inv(D)


@contract(tree=_TREE, q=_Q, qd=_V)
def kinetic_energy(tree: ArticulatedTree, q, qd) -> float:
    """T = ½ q̇ᵀ H(q) q̇."""
    with np.errstate(over="ignore", invalid="ignore"):
        T = float(0.5 * qd @ crba(tree, q) @ qd)
    return check_result("kinetic_energy", T, _HUGE)


@contract(tree=_TREE, q=_Q)
def potential_energy(tree: ArticulatedTree, q) -> float:
    """V = −Σ m_i g·x_ci, with x_ci the world position of link i's centre of mass."""
    _, X0, origins = world_poses(tree, q)
    V = 0.0
    with np.errstate(over="ignore", invalid="ignore"):
        for i, lk in enumerate(tree.links):
            V -= lk.mass * tree.gravity @ (origins[i] + X0[i][:3, :3].T @ lk.com)   # E ᵀ: link → world
    return check_result("potential_energy", float(V), _HUGE)


def _ldl_pivots(H: np.ndarray) -> np.ndarray:
    """The pivots d of H = LDLᵀ eliminated from the last coordinate to the first (leaves first), without
    pivoting; a non-positive pivot stops the elimination (the rest are left at 0)."""
    A = H[::-1, ::-1].copy()
    n = len(A)
    d = np.zeros(n)
    for j in range(n):                          # n eliminations
        d[j] = A[j, j]
        if not d[j] > 0:
            break
        col = A[j + 1:, j] / d[j]
        A[j + 1:, j + 1:] -= np.outer(col, A[j + 1:, j])
    return d[::-1]


@contract(tree=_TREE, rel=Real(gt=0, lt=1), seed=Int(ge=0))
def check_articulated_inertia(tree: ArticulatedTree, rel: float = 1e-10, seed: int = 0) -> None:
    """Refuse, with :class:`SingularJointInertia` naming the joint, a tree in which a movable joint moves no
    inertia: a pivot D_i of H(q) (ABA's articulated inertia about joint i, see the module docstring) at or
    below ``rel`` H_ii, or below 1e-14 of the largest H_jj, at a pseudo-random configuration (structural
    singularities hold at every q; one seen only at special configurations is left to ABA's own check)."""
    if tree.nv == 0:
        return
    rng = np.random.default_rng(seed)
    q = tree.neutral() + rng.uniform(-1.0, 1.0, tree.nq)
    for j, s in zip(tree.joints, tree._q_index):
        if j.kind == "floating":
            q[s.start:s.start + 4] /= np.linalg.norm(q[s.start:s.start + 4])
    H = crba(tree, q)
    d, h = _ldl_pivots(H), np.diag(H)
    floor = 1e-14 * float(h.max())
    owner = np.repeat(np.arange(tree.n), [v.stop - v.start for v in tree._v_index])
    bad = np.flatnonzero(~((d > rel * h) & (d > floor)))
    if bad.size:
        k = int(bad[-1])                        # the first failure in elimination order (leaves first)
        i = int(owner[k])
        name = tree.joint_names[i] if tree.joint_names else f"joint {i}"
        raise SingularJointInertia(f"<joint name={name!r}> ({tree.joints[i].kind}, above link "
                                   f"{tree.links[i].name!r}) moves no inertia: its articulated inertia D = Sᵀ I^A S "
                                   f"is {d[k]:.3g} (H_ii = {h[k]:.3g}); give the link below it (or its subtree) mass "
                                   "or inertia about the joint's axis, or make the joint fixed")
