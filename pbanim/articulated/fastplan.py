"""ABA in one frame: what the fast kernels compute, and the per-tree plan they run from (chapter 08).

The readable ABA (:mod:`pbanim.articulated.dynamics`) works in link coordinates: every step of the
backward sweep carries an articulated inertia across a joint, I^A_λ += ⁱX_λᵀ I^a_i ⁱX_λ, a product of
6 × 6 matrices per link and per state. The fast kernels work in one frame, the world's, where those
transforms disappear from the sweeps; they move to one place, the rigid inertia of each link (10 numbers).

With the world-frame motion subspace S_i = ⁰X_i s_i (it now depends on q) and â₀ = (0, −g):

    v̂_i = v̂_λ + S_i q̇_i,                 ĉ_i = v̂_λ × S_i q̇_i   (= Ṡ_i q̇_i, since Ṡ_i = v̂_i × S_i)
    â_i = â_λ + ĉ_i + S_i q̈_i.

Shifted accelerations remove ĉ from the sweeps. Let Ĉ_i = Σ ĉ_j over the joints j from the root to i,
and â'_i = â_i − Ĉ_i, so that â'_i = â'_λ + S_i q̈_i and â'_root's parent = â₀. A link's force is then

    f̂_i = I_i â_i + v̂_i ×* I_i v̂_i − f̂ᵉˣᵗ_i = I_i â'_i + p̂_i,    p̂_i = v̂_i ×* I_i v̂_i + I_i Ĉ_i − f̂ᵉˣᵗ_i,

and ABA (Featherstone 2008, Table 7.1) runs on (I_i, p̂_i) with no velocity-product term and no transform:

    backward:  U_i = I^A_i S_i,  D_i = S_iᵀU_i,  u_i = τ_i − b_i q̇_i − S_iᵀp^A_i,
               I^A_λ += I^A_i − U_i D_i⁻¹ U_iᵀ,   p^A_λ += p^A_i + U_i D_i⁻¹ u_i
    forward:   q̈_i = D_i⁻¹(u_i − U_iᵀ â'_λ),   â'_i = â'_λ + S_i q̈_i.

(The joint force S_iᵀ Σ_{k ∈ subtree(i)} f̂_k is the same whichever acceleration variable is used, and in
one frame the subtree sum needs no transforms: the derivation of Table 7.1 goes through unchanged.)

The link's world inertia comes from its mass m, centre of mass h = p_i + R_i c and rotational inertia
Ī_w = R_i Ī R_iᵀ about it: I_i = [[Ī_w + m(|h|²1 − hhᵀ), m h×], [m h×ᵀ, m 1]]. Its momentum is
(Ī_w ω + h × m v_h, m v_h) with v_h = v + ω × h the velocity of the centre of mass.

=================  =============================================================================
symbol             meaning (world frame unless said)
=================  =============================================================================
R_i, p_i           orientation and origin of link i's joint frame (the link frame turned so that a
                   revolute or prismatic axis is its z axis: S_i = (z_i, p_i × z_i) or (0, z_i))
v̂ = (ω, v)         spatial velocity: angular, and the velocity of the point at the world origin
ĉ_i, Ĉ_i           velocity-product acceleration of joint i, and its sum from the root to i
â'_i               shifted acceleration â_i − Ĉ_i
I^A_i, p^A_i       articulated inertia (symmetric 6 × 6, stored as its 21 upper entries) and bias
=================  =============================================================================

Limiting cases the tests use: a fixed joint merges its link into the parent (I^A and p^A add, no
projection); one revolute link at rest has q̈ = (τ − b q̇ + m g·(z × h))/(Ī_zz + m|h⊥|²) about its axis;
a floating body alone obeys Newton–Euler, I â = −v̂ ×* I v̂ + f̂ᵉˣᵗ.

The plan below holds everything that does not depend on the state, computed once per tree: the joint
frames (a rotation Q_i with Q_i z = axis_i), placements R_T' = Q_λᵀ R_T Q_i and p_T' = Q_λᵀ p_T in them,
and the inertias in them, all as plain Python floats (the single-state kernel does its arithmetic on
floats; the batched one on arrays of K states, with the same code).

References: Featherstone, *Rigid Body Dynamics Algorithms*, Springer 2008, ch. 7 (ABA) and ch. 2
(spatial algebra); Carpentier et al., "The Pinocchio C++ library", IEEE/SICE SII 2019 (the reference
implementation the benchmark compares with, which also runs its sweeps in one frame).
"""

from __future__ import annotations

import weakref
from dataclasses import dataclass, field

import numpy as np

from .tree import ONE_DOF, ArticulatedTree

__all__ = ["FIXED", "FLOATING", "PRISMATIC", "REVOLUTE", "LinkPlan", "Plan", "plan_for"]

REVOLUTE, PRISMATIC, FIXED, FLOATING = 0, 1, 2, 3
_KIND = {"revolute": REVOLUTE, "continuous": REVOLUTE, "prismatic": PRISMATIC, "fixed": FIXED, "floating": FLOATING}


@dataclass(frozen=True)
class LinkPlan:
    """One link's constants: joint kind, parent, indices, placement in the parent's joint frame
    (RT as 9 row-major floats, None for the identity; pT), mass, centre of mass c, rotational inertia
    Ī about it (6 floats xx, xy, xz, yy, yz, zz, None when zero) in its own joint frame, damping."""

    kind: int
    parent: int
    qi: int
    vi: int
    RT: tuple | None
    pT: tuple
    mass: float
    com: tuple
    Ibar: tuple | None
    damping: float


@dataclass(frozen=True)
class Plan:
    """The per-tree plan of the fast kernels (see the module docstring)."""

    links: tuple
    n: int
    nq: int
    nv: int
    a0: tuple                   # â₀ = (0, −g)
    damping: np.ndarray         # (nv,) joint damping b
    Qt: np.ndarray              # (n, 3, 3): Q_iᵀ, link coordinates → joint-frame coordinates
    revolute_q: np.ndarray      # q indices of the revolute joints (cos, sin computed at once)
    source: object              # the tree.arrays() dict this plan was built from (staleness check)
    mass_n: np.ndarray          # (n, 1) masses, (3, n, 1) centres of mass, (3, 3, n, 1) Ī or None:
    com_n: np.ndarray           # the links stacked for the batched kernel
    ibar_n: np.ndarray | None
    parents: np.ndarray         # (n,) λ(i), −1 for a root
    dof: np.ndarray             # (n,) the v index of a one-degree-of-freedom joint, else −1
    kinds: np.ndarray           # (n,) joint kinds
    RTm: tuple                  # per link R_T' as a (3, 3) array, or None for the identity
    pTm: np.ndarray             # (n, 3) p_T'
    floating_q: tuple           # (link, q index) of each floating joint (their quaternions are checked)
    work: dict = field(default_factory=dict, compare=False)   # the batched kernel's reusable buffers


def axis_frame(axis: np.ndarray) -> np.ndarray:
    """A rotation Q whose third column is the unit ``axis`` (the identity when axis = z exactly)."""
    a = np.asarray(axis, dtype=float)
    e = np.array([1.0, 0.0, 0.0]) if abs(a[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    x = e - (e @ a) * a
    x /= np.linalg.norm(x)
    return np.column_stack([x, np.cross(a, x), a])


def _floats(a) -> tuple:
    return tuple(float(x) for x in np.ravel(a))


def _build(tree: ArticulatedTree, A: dict) -> Plan:
    Q = [axis_frame(j.axis) if j.kind in ONE_DOF else np.eye(3) for j in tree.joints]
    links = []
    for i, (j, lk) in enumerate(zip(tree.joints, tree.links)):
        lam = tree.parent[i]
        Ql = Q[lam] if lam >= 0 else np.eye(3)
        RT = Ql.T @ j.R @ Q[i]
        Ib = Q[i].T @ lk.inertia @ Q[i]
        links.append(LinkPlan(
            kind=_KIND[j.kind], parent=lam, qi=A["qi"][i].start, vi=A["vi"][i].start,
            RT=None if np.array_equal(RT, np.eye(3)) else _floats(RT), pT=_floats(Ql.T @ j.p),
            mass=float(lk.mass), com=_floats(Q[i].T @ lk.com),
            Ibar=None if not np.any(Ib) else _floats(Ib[np.triu_indices(3)]),
            damping=float(tree.damping[i])))
    rev = [lp.qi for lp in links if lp.kind == REVOLUTE]
    ibar = np.stack([Q[i].T @ lk.inertia @ Q[i] for i, lk in enumerate(tree.links)], axis=-1)[..., None]
    kinds = np.array([lp.kind for lp in links], dtype=int)
    return Plan(links=tuple(links), n=tree.n, nq=tree.nq, nv=tree.nv, a0=_floats(A["a0"]),
                damping=np.asarray(A["damping"], dtype=float), Qt=np.stack([q.T for q in Q]),
                revolute_q=np.array(rev, dtype=int), source=A,
                mass_n=np.array([lp.mass for lp in links])[:, None], com_n=np.array([lp.com for lp in links]).T[..., None],
                ibar_n=ibar if any(lp.Ibar is not None for lp in links) else None,
                parents=np.array([lp.parent for lp in links], dtype=int),
                dof=np.array([lp.vi if lp.kind in (REVOLUTE, PRISMATIC) else -1 for lp in links], dtype=int),
                kinds=kinds, RTm=tuple(None if lp.RT is None else np.array(lp.RT).reshape(3, 3) for lp in links),
                pTm=np.array([lp.pT for lp in links], dtype=float).reshape(-1, 3),
                floating_q=tuple((i, lp.qi) for i, lp in enumerate(links) if lp.kind == FLOATING))


_PLANS: weakref.WeakKeyDictionary[ArticulatedTree, Plan] = weakref.WeakKeyDictionary()


def plan_for(tree: ArticulatedTree) -> Plan:
    """The tree's plan, built on first use and rebuilt whenever the tree's own cache is (after ``add``)."""
    A = tree.arrays()                       # raises InvalidInput for an empty tree
    plan = _PLANS.get(tree)
    if plan is None or plan.source is not A:
        plan = _PLANS[tree] = _build(tree, A)
    return plan
