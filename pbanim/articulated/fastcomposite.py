"""ABA's sweeps over K states without the 6 × 6 articulated inertias: composites and rank-one terms (chapter 08).

The backward sweep of :mod:`.fastbatch` (equations in :mod:`.fastplan`) carries a full articulated inertia
I^A_i per link and state, a (6, 6, K) array: three passes of 36 K values per link (U Uᵀ/D, I^A_i − U Uᵀ/D,
the sum into the parent). Unrolled along the tree, the recursion I^A_λ += I^A_i − U_i D_i⁻¹ U_iᵀ says

    I^A_i = Y_i − Σ_{j ≻ i} W_j U_jᵀ,      p^A_i = P_i + Σ_{j ≻ i} W_j u_j,      W_j = U_j D_j⁻¹,

with Y_i = Σ_{j ⪰ i} I_j the composite rigid inertia of the subtree of i (j ≻ i: j a strict descendant),
P_i = Σ_{j ⪰ i} p̂_j the composite bias, and a fixed joint contributing no term (its link simply sums into
Y and P). A composite rigid inertia is again a rigid inertia, 10 numbers instead of 36:

    Y = [[J, c×], [c×ᵀ, M 1]],   J = Σ (Ī_w + m(|h|²1 − hhᵀ)),   c = Σ m h,   M = Σ m,
    Y (ω, v) = (J ω + c × v,  M v − c × ω),

so the quantities the sweeps need follow without forming I^A: with g_ij = U_jᵀ S_i,

    U_i = Y_i S_i − Σ_{j ≻ i} W_j g_ij,    u_i = τ_i − S_iᵀ P_i − Σ_{j ≻ i} g_ij D_j⁻¹ u_j,    D_i = S_iᵀ U_i,

and the forward sweep is the kernel's (q̈_i = D_i⁻¹(u_i − U_iᵀ â'_λ), â'_i = â'_λ + S_i q̈_i). Y_i S_i, S_iᵀ P_i
and the composites are computed for all links at once; only the sums over descendants run link by link, each
one numpy call over the descendants (contiguous for a tree numbered depth first, as trees are built).

=================  ====================================================================================
symbol             meaning (world frame, batch axis last)
=================  ====================================================================================
Y_i, J, c, M       composite rigid inertia of the subtree of i: rotational part about the origin,
                   first moment Σ m h, total mass
P_i                composite bias Σ p̂_j over the subtree (p̂ of :mod:`.fastplan`)
U_i, D_i, u_i      ABA's I^A_i S_i, S_iᵀ I^A_i S_i, τ_i − b_i q̇_i − S_iᵀ p^A_i
W_j, g_ij          U_j / D_j and U_jᵀ S_i
=================  ====================================================================================

Cost: the sums over descendants are O(Σ_i |desc(i)|) = O(n · depth) products of 6 K values, against O(n)
products of 36 K values for the kernel's sweep. Measured on chains at K = 1024 (process time, loaded machine):
0.78× the kernel's sweep at 10 links, 0.87× at 20, 1.01× at 30 (Σ |desc(i)| = 14.5 n); so trees with
Σ |desc(i)| > 12 n (deep chains) and trees with a floating joint keep the kernel's sweep (:func:`lean_fits`).
Same q̈ as :func:`.fastbatch.sweep_batch` to roundoff (ORACLES I16); the sums run in another order and the biases
go through the centre of mass (:func:`bias_com`), so not bit for bit.

References: Featherstone, *Rigid Body Dynamics Algorithms*, Springer 2008, ch. 7 (ABA, the articulated
inertia as the composite one less the joints' rank-one terms) and ch. 6 (composite rigid inertias).
"""

from __future__ import annotations

import numpy as np

from .fastplan import FIXED, FLOATING, Plan

__all__: list[str] = []


def _tree_work(P: Plan, w: dict) -> dict:
    """Per plan and K (kept in the kernel's buffer dict, cleared with it): each link's strict descendants as a
    slice (or an index array), the composite masses, and the buffers of the sweeps."""
    if "c_desc" not in w:
        n, K = P.n, w["K"]
        par = P.parents.tolist()
        below = [[] for _ in range(n)]
        for i in reversed(range(n)):                            # children carry their own descendants
            if par[i] >= 0:
                below[par[i]] += [i] + below[i]
        desc = []
        for i in range(n):
            idx = np.array(sorted(below[i]), dtype=int)
            contiguous = idx.size and np.array_equal(idx, np.arange(idx[0], idx[-1] + 1))
            desc.append(slice(int(idx[0]), int(idx[-1]) + 1) if contiguous else (idx if idx.size else None))
        M = P.mass_n[:, 0].copy()
        for i in reversed(range(n)):
            if par[i] >= 0:
                M[par[i]] += M[i]
        moving = [i for i in range(n) if P.kinds[i] != FIXED]
        w.update(c_desc=desc, c_M=M[:, None], c_moving=moving, c_dof=np.maximum(P.dof, 0), c_D=np.ones((n, K)),
                 c_Z=np.empty((12, n, K)), c_Zl=np.empty((n, 18, K)), c_YS=np.empty((7, n, K)),
                 c_SP=np.empty((n, K)), c_U=np.zeros((n, 7, K)), c_W=np.zeros((n, 7, K)),
                 c_g=np.empty((n, K)), c_acc=np.empty((n, 6, K)), c_t=np.empty((3, n, K)))
    return w


def lean_fits(P: Plan) -> bool:
    """Whether the composite sweeps pay here: no floating joint, and Σ |desc(i)| ≤ 12 n (module docstring)."""
    if np.any(P.kinds == FLOATING):
        return False
    depth = np.zeros(P.n, dtype=int)
    for i, lam in enumerate(P.parents.tolist()):
        depth[i] = depth[lam] + 1 if lam >= 0 else 0
    return int(depth.sum()) <= 12 * P.n                         # Σ_i |desc(i)| = Σ_i depth(i)


def bias_com(P: Plan, w: dict, J, cross) -> None:
    """The links' biases p̂ = v̂ ×* I v̂ + I Ĉ (without f̂ᵉˣᵗ) into w["pA"], through the centre of mass: with
    v_h = u + ω × h its velocity, ω × (h × P) + u × P = h × (ω × P) (Jacobi; v_h × m v_h = 0), so

        p̂ = (h × G + ω × Ī_w ω + Ī_w C_ω,  G),    G = m (ω × v_h + C_u + C_ω × h),

    five cross products where the kernel's momentum form takes seven (J: Ī_w or None)."""
    n, h, pA, t, s, G, L = P.n, w["h"], w["pA"], w["t"], w["s"], w["P"], w["L"]
    v, C = w["v"][:, :n], w["C"][:, :n]
    cross(v[:3], h, t, s)
    t += v[3:]                                                  # v_h
    cross(v[:3], t, G, s)
    cross(C[:3], h, L, s)
    G += L
    G += C[3:]
    G *= P.mass_n
    pA[3:] = G
    cross(h, G, pA[:3], s)
    if J is not None:
        np.einsum("abnk,bnk->ank", J, v[:3], out=L)
        cross(v[:3], L, t, s)
        pA[:3] += t
        pA[:3] += np.einsum("abnk,bnk->ank", J, C[:3], out=t)


def _composites(P: Plan, w: dict, cross) -> None:
    """J (9 rows), c (3) and P (6) per link summed over subtrees, then Y_i S_i and S_iᵀ P_i for all links.
    Needs w["h"], w["mh"] (centres of mass), w["pA"] = p̂ and, with rotational inertia, w["J"] = R Ī Rᵀ. The sums
    run on a copy with each link's 18 rows contiguous (an add of strided rows costs several times more)."""
    n, Z, Zl, t, s = P.n, w["c_Z"], w["c_Zl"], w["c_t"], w["s"]
    h, mh, S = w["h"], w["mh"], w["S"]
    A = Z[:9].reshape(3, 3, n, -1)                              # Ī_w + m(|h|²1 − hhᵀ)
    np.negative(mh, out=t)
    np.multiply(t[:, None], h[None], out=A)
    np.einsum("ank,ank->nk", mh, h, out=s)
    for k in range(3):
        A[k, k] += s
    if P.ibar_n is not None:
        A += w["J"]
    Z[9:12] = mh
    np.copyto(Zl[:, :12], Z.transpose(1, 0, 2))
    np.copyto(Zl[:, 12:], w["pA"].transpose(1, 0, 2))
    par = P.parents.tolist()
    for i in reversed(range(n)):                                # composites, leaves first
        if par[i] >= 0:
            Zl[par[i]] += Zl[i]
    c, YS = Zl[:, 9:12].transpose(1, 0, 2), w["c_YS"]
    np.einsum("nabk,bnk->ank", Zl[:, :9].reshape(n, 3, 3, -1), S[:3], out=YS[:3])   # Y S = (J ω + c × v, M v − c × ω)
    cross(c, S[3:], t, s)
    YS[:3] += t
    np.multiply(S[3:], w["c_M"], out=YS[3:6])
    cross(c, S[:3], t, s)
    YS[3:6] -= t
    np.einsum("ank,nak->nk", S, Zl[:, 12:], out=w["c_SP"])


def _backward(S, YS, U, W, g, d, desc, Dall, moving) -> None:
    """Rows (U_i, u_i) into U (n, 7, K), D_i into Dall, 1/D_i into d and (W_i, u_i/D_i) into W, leaves first;
    YS holds (Y_i S_i, τ_i − S_iᵀ P_i), so that one product over the descendants updates U_i and u_i together."""
    for i in moving[::-1]:
        Ui, Si, D = U[i], S[:, i], desc[i]
        if D is None:
            np.copyto(Ui, YS[:, i])
        else:
            gi = np.einsum("jrk,rk->jk", U[D, :6], Si, out=g[:D.stop - D.start] if isinstance(D, slice) else None)
            np.subtract(YS[:, i], np.einsum("jrk,jk->rk", W[D], gi), out=Ui)
        np.einsum("rk,rk->k", Ui[:6], Si, out=Dall[i])
        np.divide(1.0, Dall[i], out=d[i])
        np.multiply(Ui, d[i], out=W[i])


def sweep_composite(P: Plan, w: dict, tauT, pivot, cross) -> np.ndarray:
    """q̈ (nv, K) from the kernel's buffers after its kinematics, motion and bias steps (``w["pA"]`` = p̂,
    e.g. by :func:`bias_com`); ``cross``: the kernel's component cross product. The pivots are
    checked once after the backward sweep (``pivot`` raises for the first bad joint, leaves first, as the
    kernel's sweep would). The result is a buffer of the plan (copy it before the next call)."""
    _tree_work(P, w)
    _composites(P, w, cross)
    S, YS, U, W, g, tK = w["S"], w["c_YS"], w["c_U"], w["c_W"], w["c_g"], w["tK"]
    d, desc, Dall, moving = w["d"], w["c_desc"], w["c_D"], w["c_moving"]
    if moving:                                                  # τ_i − S_iᵀ P_i (rows of fixed joints unused)
        np.subtract(tauT[w["c_dof"]], w["c_SP"], out=YS[6])
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):   # a bad pivot is named below
        _backward(S, YS, U, W, g, d, desc, Dall, moving)
    if not np.all(np.abs(Dall[moving]) > 1e-280):              # NaN lands here too
        for i in moving[::-1]:
            pivot(Dall[i], i, 1e-280)
    out, acc, a0 = w["out"], w["c_acc"], np.array(P.a0)
    for i, lp in enumerate(P.links):                            # forward, root first
        lam = lp.parent
        ap = a0[:, None] if lam < 0 else acc[lam]
        if lp.kind == FIXED:
            acc[i] = ap
            continue
        x = out[lp.vi]                                          # q̈_i = u_i/D_i − W_iᵀ â'_λ
        np.subtract(W[i, 6], a0 @ W[i, :6] if lam < 0 else np.einsum("rk,rk->k", W[i, :6], ap, out=tK), out=x)
        np.multiply(S[:, i], x, out=acc[i])
        acc[i] += ap
    return out
