"""The 3-D biped's bias forces C(q, q̇) on Python floats (chapter 08; the lean step of :mod:`.biped3d_lean`).

For a tree whose root floats (body-frame q̇, world columns [[R, 0], [p̂ R, R]]) and whose other joints are
revolute or fixed, with the world joint columns Sᵂ_j = (a_j, o_j × a_j) of :meth:`WorldStep.kinematics
<pbanim.control.biped3d_step.WorldStep.kinematics>`, the generalized forces at q̈ = 0 less gravity's,

    C = Σᵢ mᵢ J_c,iᵀ (a_c,i − g) + J_ω,iᵀ (Īᵂᵢ α_i + ω_i × Īᵂᵢ ω_i) + b ⊙ q̇     (b the joint damping),

are the recursive Newton–Euler sums in the world frame (Featherstone, *Rigid Body Dynamics Algorithms*,
2008, ch. 5, spatial vectors at the world origin): a forward pass for the link velocities and bias
accelerations, a backward pass for the subtrees' wrenches, C_j = Sᵂ_jᵀ (n, f). Written on floats, one link at
a time (~150 operations a link), where a batched form on (n × 3) arrays makes ~45 numpy calls: the step's
cost at h = 2 ms is its calls (``pbanim bench control``). Equal to RNEA to roundoff
(``tests/test_biped3d_lean.py``, ORACLES F20). The link inertias R Ī Rᵀ and angular Jacobians are computed
once per state here and shared with the mass matrix.
"""

from __future__ import annotations

import numpy as np

__all__: list = []      # internal: reached through WorldStep(lean=True) and biped3d_lean.bias


def _rotational(ws, kin):
    """(Īᵂ (n, 3, 3), J_ω (n, 3, nv)) of a state: the links' world inertias R Ī Rᵀ and their angular
    velocity Jacobians (Sᵂ's angular rows over each link's joints), computed once per kinematics dict (the
    mass matrix and the bias forces read the same ones)."""
    got = kin.get("IwJw")
    if got is None:
        R = kin["R"]
        got = kin["IwJw"] = (R @ ws.inertia @ R.transpose(0, 2, 1), kin["S"][None, :3, :] * ws._plan.mask[:, None, :])
    return got


def bias(ws, kin, qd):
    """C(q, q̇) − (the gravity's generalized force): the world-frame Newton–Euler sums over the links,

        C = Σᵢ mᵢ J_c,iᵀ (a_c,i − g) + J_ω,iᵀ (Īᵂᵢ α_i + ω_i × Īᵂᵢ ω_i)    at q̈ = 0,

    with (ω_i, v_O,i) = Σ_j Sᵂ_j q̇_j over link i's joints (v_O: the velocity of the point at the world
    origin), the bias accelerations (α_i, a_O,i) = Σ_j V_j ×ₘ Sᵂ_j q̇_j (V_j the velocity of the joint's
    link; ×ₘ the motion cross product) and a_c = a_O + α × c + ω × v_c, v_c = v_O + ω × c.

    On Python floats, link by link: forward, V_i = V_λ + S_i q̇_i and (α_i, a_O,i) = (α_λ, a_O,λ) +
    V_λ ×ₘ S_i q̇_i (V_i ×ₘ S_i q̇_i differs by S_i q̇_i ×ₘ S_i q̇_i = 0; the pelvis's six columns give V₀ ×ₘ V₀ = 0);
    backward, each link's force f = m a_c and moment about the world origin n = Īα + ω × Īω + c × f summed
    over its subtree, C_j = Sᵂ_jᵀ (n, f) (J_c,j = v_j + a_j × c: (a × c)·f = a·(c × f)). Equal to the
    batched sums to roundoff (``tests/test_biped3d_lean.py``: against the readable ABA)."""
    P = ws._plan
    n = P.n
    cols = kin.get("Sf")
    if cols is None:
        cols = kin["Sf"] = kin["S"].T.tolist()
    cf = kin.get("cf")
    if cf is None:
        cf = kin["cf"] = kin["c"].tolist()
    Iw = _rotational(ws, kin)[0].reshape(n, 9).tolist()
    qdl = qd.tolist()
    gx, gy, gz = P.gravity_f
    W = [None] * n                          # each link's (ω, v_O, α, a_O): 12 floats
    F = [None] * n                          # each link's (n, f) about the world origin, then its subtree's
    w0 = [0.0] * 6
    for j in range(6):                      # the pelvis: V₀ = Σ S_j q̇_j over its six columns
        col, x = cols[j], qdl[j]
        for r in range(6):
            w0[r] += col[r] * x
    W[0] = (*w0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0)
    masses = P.mass_f
    for i, lam, qk, vk, *_ in P.links:
        wx, wy, wz, vx, vy, vz, ax_, ay_, az_, bx, by, bz = W[lam]
        if qk >= 0:
            e0, e1, e2, f0, f1, f2 = cols[vk]
            x = qdl[vk]
            e0, e1, e2, f0, f1, f2 = e0 * x, e1 * x, e2 * x, f0 * x, f1 * x, f2 * x       # S_i q̇_i
            ax_, ay_, az_ = ax_ + (wy * e2 - wz * e1), ay_ + (wz * e0 - wx * e2), az_ + (wx * e1 - wy * e0)
            bx, by, bz = (bx + (wy * f2 - wz * f1) + (vy * e2 - vz * e1),
                          by + (wz * f0 - wx * f2) + (vz * e0 - vx * e2),
                          bz + (wx * f1 - wy * f0) + (vx * e1 - vy * e0))
            wx, wy, wz, vx, vy, vz = wx + e0, wy + e1, wz + e2, vx + f0, vy + f1, vz + f2
        W[i] = (wx, wy, wz, vx, vy, vz, ax_, ay_, az_, bx, by, bz)
    for i in range(n):                      # each link's wrench about the world origin
        wx, wy, wz, vx, vy, vz, ax_, ay_, az_, bx, by, bz = W[i]
        cx, cy, cz = cf[i]
        ux, uy, uz = vx + (wy * cz - wz * cy), vy + (wz * cx - wx * cz), vz + (wx * cy - wy * cx)      # v_c
        m = masses[i]
        fx = m * (bx + (ay_ * cz - az_ * cy) + (wy * uz - wz * uy) - gx)
        fy = m * (by + (az_ * cx - ax_ * cz) + (wz * ux - wx * uz) - gy)
        fz = m * (bz + (ax_ * cy - ay_ * cx) + (wx * uy - wy * ux) - gz)
        i0, i1, i2, i3, i4, i5, i6, i7, i8 = Iw[i]
        lx, ly, lz = i0 * wx + i1 * wy + i2 * wz, i3 * wx + i4 * wy + i5 * wz, i6 * wx + i7 * wy + i8 * wz
        F[i] = [i0 * ax_ + i1 * ay_ + i2 * az_ + (wy * lz - wz * ly) + (cy * fz - cz * fy),
                i3 * ax_ + i4 * ay_ + i5 * az_ + (wz * lx - wx * lz) + (cz * fx - cx * fz),
                i6 * ax_ + i7 * ay_ + i8 * az_ + (wx * ly - wy * lx) + (cx * fy - cy * fx), fx, fy, fz]
    C = [0.0] * P.nv
    for i, lam, qk, vk, *_ in reversed(P.links):     # subtree sums, children before parents
        Fi, Fl = F[i], F[lam]
        for r in range(6):
            Fl[r] += Fi[r]
        if qk >= 0:
            e0, e1, e2, f0, f1, f2 = cols[vk]
            C[vk] = e0 * Fi[0] + e1 * Fi[1] + e2 * Fi[2] + f0 * Fi[3] + f1 * Fi[4] + f2 * Fi[5]
    F0 = F[0]
    for j in range(6):
        e0, e1, e2, f0, f1, f2 = cols[j]
        C[j] = e0 * F0[0] + e1 * F0[1] + e2 * F0[2] + f0 * F0[3] + f1 * F0[4] + f2 * F0[5]
    return np.array(C) + P.damping * qd
