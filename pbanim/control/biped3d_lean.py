"""The lean twin of the 3-D biped's world-frame contact step (chapter 08): the same formulas, fewer calls.

:class:`~pbanim.control.biped3d_step.WorldStep` reads as the lecture writes the step (one joint at a time,
``np.cross``, ``np.linalg.solve`` twice, the library's hand-off). At h = 2 ms its Python calls, not its
arithmetic, set the cost (``pbanim bench control``), so ``WorldStep(lean=True)`` (the default) runs
this module instead, computing the same quantities:

1. **kinematics** level by level: the links at one depth of the tree (both legs at once) take one batched
   product R_i = R_λ(i) ᴶR_i R_a(q_i) and o_i = o_λ + R_λ p_i; every joint's Rodrigues matrix R_a(q) is
   built once per step for all joints; the world joint columns Sᵂ = (a, o × a) for all joints at once;
2. **point Jacobians** J = v + a × P with the cross product written out on (m, nv) arrays; the centres of
   mass' Jacobians J_c are computed once per state and kept (the mass matrix and the controller's centre of
   mass velocity read the same ones);
3. **H** = Σ mᵢ J_c,iᵀ J_c,i + J_ω,iᵀ Īᵂᵢ J_ω,i as two (3n × nv) products; one Cholesky factorization of
   H + hK serves the free velocity and the contact rows (:func:`scipy.linalg.cho_factor`);
4. **the contact solve** on the near points only, by the readable step's contact law
   (``WorldStep._impulses``: the box-friction hand-off, the active set from the last step's contact states,
   PGS in chunks when it does not certify), through :func:`pbanim.lcp.handoff_lean.handoff_floats` (its
   rounds' tests on floats: the library's answer bit for bit);
5. **the update** q⁺ = q + h q̇(q, u⁺) on floats, with the pelvis's R of the kinematics.

``WorldStep.clock``, a dict (kinematics, H, dynamics, contact, steps) or None, adds up the CPU seconds (process
time: on a shared machine the wall clock measures the load) each part takes (``pbanim bench control``). ``tests/test_biped3d_lean.py`` holds the two paths equal to a few ulps per step (ORACLES F19).
"""

from __future__ import annotations

from math import atan2, sqrt
from time import process_time

import numpy as np
from scipy.linalg.lapack import dpotrf, dpotrs

from ..errors import SimulationDiverged
from ..contracts import unchecked
from ..rigid.quat import quat_to_matrix

_quat_to_matrix = unchecked(quat_to_matrix)

__all__: list = []      # internal: reached through WorldStep(lean=True)


class LeanPlan:
    """What the lean step needs of a tree, built once: the links by depth, joint placements and axes."""

    def __init__(self, ws) -> None:
        tree = ws.tree
        n = tree.n
        depth = [0] * n
        for i in range(1, n):
            depth[i] = depth[tree.parent[i]] + 1
        order = sorted(range(n), key=lambda i: depth[i])          # breadth first: each level one slice
        pos = [0] * n
        for k, i in enumerate(order):
            pos[i] = k
        self.inv = np.array(pos)                                  # tree order from breadth-first order
        self.levels = []
        for d in range(1, max(depth) + 1):
            lev = [i for i in order if depth[i] == d]
            pp = [pos[tree.parent[i]] for i in lev]
            if pp == list(range(pp[0], pp[0] + len(pp))) or pp == [pp[0]] * len(pp):
                psl = slice(pp[0], pp[0] + (len(pp) if len(set(pp)) > 1 else 1))   # a view (or one parent)
            else:
                psl = np.array(pp)
            JR = np.array([tree.joints[i].R for i in lev])
            self.levels.append((slice(pos[lev[0]], pos[lev[0]] + len(lev)), psl,
                                None if np.all(JR == np.eye(3)) else JR,
                                np.array([tree.joints[i].p for i in lev], dtype=float)[:, :, None]))
        rev = [i for i in range(1, n) if tree.joints[i].kind != "fixed"]
        self.rev = np.array(rev)
        self.rev_q = np.array([ws.qi[i] for i in rev])
        self.rev_v = np.array([ws.vi[i] for i in rev])
        self.axis = np.array([tree.joints[i].axis for i in rev], dtype=float)
        self.n, self.nv = n, tree.nv
        self.rot0 = np.tile(np.eye(3), (n, 1, 1))
        self.rev_b = np.array([pos[i] for i in rev])               # the revolute joints in breadth-first order
        self.rev_par = np.array([tree.parent[i] for i in rev])
        JRr = np.array([tree.joints[i].R for i in rev])
        self.rev_JR = None if np.all(JRr == np.eye(3)) else JRr
        self.eye = np.tile(np.eye(3), (len(rev), 1, 1))
        self.ax = np.array([[[0, -a[2], a[1]], [a[2], 0, -a[0]], [-a[1], a[0], 0]] for a in self.axis])
        self.aa = np.einsum("ki,kj->kij", self.axis, self.axis)
        self.mass3 = np.repeat(ws.mass, 3)[:, None]
        self.mask = ws.mask.astype(float)
        self.gravity = np.asarray(tree.gravity, dtype=float)
        self.damping = np.asarray(tree.arrays()["damping"], dtype=float)
        self.cache = (None, None)           # (q's bytes, its kinematics): the last state's, read again
        self.contacts = (ws.links, ws.points[:, :, None], self.mask[ws.links])
        self.basis = {}                     # the near points' normals' bytes → their frames (n, t₁, t₂) (≤ 64 kept)


def kinematics(ws, q) -> dict:
    """The dict of :meth:`WorldStep.kinematics` (R, o, c, S) by levels (module docstring, 1); the last
    state's dict is kept and returned again for the same q (the runner reads q⁺ twice: its fall test, then
    the next step)."""
    key = q.tobytes()
    if ws._plan.cache[0] == key:
        return ws._plan.cache[1]
    clock = ws.clock
    t0 = process_time() if clock is not None else 0.0
    kin = _kinematics(ws, q)
    ws._plan.cache = (key, kin)
    if clock is not None:
        clock["kinematics"] += process_time() - t0
    return kin


def _kinematics(ws, q) -> dict:
    P = ws._plan
    n, nv = P.n, P.nv
    nrm = sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3])
    if not nrm > 1e-9:
        from ..errors import InvalidInput
        raise InvalidInput(f"q[:4] must be the pelvis's (non-zero) quaternion, got {q[:4]}")
    R0 = _quat_to_matrix(q[:4] / nrm)
    Rb, ob = np.empty((n, 3, 3)), np.empty((n, 3))               # breadth-first order
    Rb[0], ob[0] = R0, q[4:7]
    rot = P.rot0.copy()
    ang = q[P.rev_q][:, None, None]
    c = np.cos(ang)
    rot[P.rev_b] = c * P.eye + np.sin(ang) * P.ax + (1.0 - c) * P.aa     # R_a(q) = c 1 + s [a]× + (1 − c) a aᵀ
    for sl, psl, JR, p in P.levels:                                # R_i = R_λ ᴶR_i R_a(q_i), o_i = o_λ + R_λ p_i
        Rp = Rb[psl]
        np.matmul(Rp if JR is None else Rp @ JR, rot[sl], out=Rb[sl])
        np.add(ob[psl], np.matmul(Rp, p)[:, :, 0], out=ob[sl])
    R, o = Rb[P.inv], ob[P.inv]
    S = np.zeros((6, nv))
    px, py, pz = q[4:7].tolist()
    S[:3, :3], S[3:, 3:6] = R0, R0
    S[3:, :3] = np.array([[0.0, -pz, py], [pz, 0.0, -px], [-py, px, 0.0]]) @ R0      # p̂ R0
    Rl = R[P.rev_par] if P.rev_JR is None else R[P.rev_par] @ P.rev_JR          # the joint frames' R_λ ᴶR
    a = (Rl @ P.axis[:, :, None])[:, :, 0]
    S[:3, P.rev_v] = a.T
    S[3:, P.rev_v] = _cross(o[P.rev], a).T
    cm = o + (R @ ws.com[:, :, None])[:, :, 0]
    return {"R": R, "o": o, "c": cm, "S": S}


_I1, _I2 = np.array([1, 2, 0]), np.array([2, 0, 1])


def _cross(u, v):
    """u × v row by row: component k is u_{k+1} v_{k+2} − u_{k+2} v_{k+1}, np.cross's products."""
    return u[:, _I1] * v[:, _I2] - u[:, _I2] * v[:, _I1]


def jacobians_at(S, P, mask):
    """J (m, 3, nv) of world points P (m, 3): column v is (v_v + a_v × P) where the point moves with it."""
    ax, ay, az = S[0], S[1], S[2]
    Px, Py, Pz = P[:, 0:1], P[:, 1:2], P[:, 2:3]
    J = np.empty((P.shape[0], 3, S.shape[1]))
    np.add(S[3], ay * Pz - az * Py, out=J[:, 0])
    np.add(S[4], az * Px - ax * Pz, out=J[:, 1])
    np.add(S[5], ax * Py - ay * Px, out=J[:, 2])
    J *= mask[:, None, :]
    return J


def point_jacobians(ws, kin, links, points):
    """(P, J) of :meth:`WorldStep.point_jacobians`; the centres of mass' J_c once per state."""
    if points is ws.com and len(links) == ws.tree.n:
        return kin["c"], com_jacobians(ws, kin)
    if links is ws.links and points is ws.points:                 # the contact points: their arrays kept
        links, pts, mask = ws._plan.contacts
    else:
        links = np.asarray(links).astype(int)
        pts, mask = np.asarray(points, dtype=float)[:, :, None], ws._plan.mask[links]
    P = kin["o"][links] + (kin["R"][links] @ pts)[:, :, 0]
    return P, jacobians_at(kin["S"], P, mask)


def com_jacobians(ws, kin):
    """J_c (n, 3, nv), computed once per kinematics dict."""
    Jc = kin.get("Jc")
    if Jc is None:
        Jc = kin["Jc"] = jacobians_at(kin["S"], kin["c"], ws._plan.mask)
    return Jc


def mass_matrix(ws, kin):
    """H = Σ mᵢ J_c,iᵀ J_c,i + J_ω,iᵀ Īᵂᵢ J_ω,i as two products of (3n × nv) blocks."""
    P = ws._plan
    n, nv = P.n, P.nv
    Jc = com_jacobians(ws, kin).reshape(3 * n, nv)
    Jw = kin["S"][None, :3, :] * P.mask[:, None, :]
    R = kin["R"]
    IJ = R @ (ws.inertia @ (R.transpose(0, 2, 1) @ Jw))
    return (P.mass3 * Jc).T @ Jc + Jw.reshape(3 * n, nv).T @ IJ.reshape(3 * n, nv)


def bias(ws, kin, qd):
    """C(q, q̇) − (the gravity's generalized force): the world-frame Newton–Euler sums over the links,

        C = Σᵢ mᵢ J_c,iᵀ (a_c,i − g) + J_ω,iᵀ (Īᵂᵢ α_i + ω_i × Īᵂᵢ ω_i)    at q̈ = 0,

    with (ω_i, v_O,i) = Σ_j Sᵂ_j q̇_j over link i's joints (v_O: the velocity of the point at the world
    origin), the bias accelerations (α_i, a_O,i) = Σ_j V_j ×ₘ Sᵂ_j q̇_j (V_j the velocity of the joint's
    link; ×ₘ the motion cross product) and a_c = a_O + α × c + ω × v_c, v_c = v_O + ω × c."""
    P = ws._plan
    n, nv = P.n, P.nv
    S, Mk = kin["S"], P.mask
    Sq = S * qd                                    # (6, nv): each joint's S_j q̇_j
    V = Mk @ Sq.T                                  # (n, 6): each link's (ω, v_O)
    Vj = V[ws._joint_link]                         # (nv, 6): the velocity of the link each joint moves
    a, v = Sq[:3].T, Sq[3:].T
    w, vo = Vj[:, :3], Vj[:, 3:]
    c, om = kin["c"], V[:, :3]
    R = kin["R"]
    Iw = R @ ws.inertia @ R.transpose(0, 2, 1)
    Iom = (Iw @ om[:, :, None])[:, :, 0]
    # the five cross products that need only velocities, as one: w × a, w × v, v_O × a, ω × c, ω × Īω
    X5 = _cross(np.concatenate([w, w, vo, om, om]), np.concatenate([a, v, a, c, Iom]))
    wa, wv, va = X5[:nv], X5[nv:2 * nv], X5[2 * nv:3 * nv]
    omc, omIom = X5[3 * nv:3 * nv + n], X5[3 * nv + n:]
    A = Mk @ np.concatenate([wa, wv + va], axis=1)  # (n, 6): (α, a_O) at q̈ = 0
    vc = V[:, 3:] + omc
    X2 = _cross(np.concatenate([A[:, :3], om]), np.concatenate([c, vc]))      # α × c, ω × v_c
    ac = A[:, 3:] + X2[:n] + X2[n:] - P.gravity
    tq = (Iw @ A[:, :3, None])[:, :, 0] + omIom
    Jc = com_jacobians(ws, kin).reshape(3 * n, nv)
    Jw = (S[None, :3, :] * Mk[:, None, :]).reshape(3 * n, nv)
    return Jc.T @ (P.mass3[:, 0] * ac.reshape(-1)) + Jw.T @ tq.reshape(-1) + P.damping * qd


def rotation_vector_floats(R, as_list: bool = False):
    """log(R) (3,) of a rotation matrix (3, 3): :func:`pbanim.rigid.matrix_to_quat` (Shepperd: the largest of
    4w², 4x², 4y², 4z² under the square root, w ≥ 0), then :func:`pbanim.design.simulate.quat_log`
    (2 atan2(|v|, w) v / |v|; 2v / w below |v| = 1e-12) — their arithmetic in their order on nine floats, so
    their bits (``tests/test_biped3d_lean.py``), without the two calls' array work (the controller's two
    servos call it every step). An array (3,), or with ``as_list`` the list of its three floats."""
    (r00, r01, r02), (r10, r11, r12), (r20, r21, r22) = R.tolist()
    tr = r00 + r11 + r22
    cand = [1 + tr, 1 + 2 * r00 - tr, 1 + 2 * r11 - tr, 1 + 2 * r22 - tr]      # 4w², 4x², 4y², 4z²
    k = cand.index(max(cand))
    d21, d02, d10 = r21 - r12, r02 - r20, r10 - r01                            # 4w·(x, y, z)
    s01, s02, s12 = r01 + r10, r02 + r20, r12 + r21                            # 4xy, 4xz, 4yz
    row = ((cand[0], d21, d02, d10), (d21, cand[1], s01, s02), (d02, s01, cand[2], s12),
           (d10, s02, s12, cand[3]))[k]
    den = 2.0 * sqrt(max(cand[k], _TINY))
    w, x, y, z = row[0] / den, row[1] / den, row[2] / den, row[3] / den
    if w < 0:
        w, x, y, z = -w, -x, -y, -z
    s = sqrt(x * x + y * y + z * z)
    scale = 2.0 * atan2(s, w) / s if s > 1e-12 else 2.0 / max(w, 1e-300)
    out = [scale * x, scale * y, scale * z]
    return out if as_list else np.array(out)


_TINY = float(np.finfo(float).tiny)
def _cholesky(M):
    """The upper Cholesky factor of M (LAPACK's potrf, as :func:`scipy.linalg.cho_factor` calls it, without
    its wrapper's ~30 µs); a matrix that is not positive definite raises, as the readable solve would not."""
    c, info = dpotrf(M, lower=False, clean=False)
    if info != 0:
        raise SimulationDiverged(float("nan"), -1, "the mass matrix H + hK", f"LAPACK potrf info {info}",
                                 what="is not positive definite")
    return c


def step(ws, q, qd, h: float, tau0, k, kin):
    """(q⁺, u⁺) of :meth:`WorldStep.step` (module docstring)."""
    kin = kinematics(ws, q) if kin is None else kin
    clock = ws.clock
    c0 = process_time() if clock is not None else 0.0
    H = mass_matrix(ws, kin)
    c1 = process_time() if clock is not None else 0.0
    nv1 = H.shape[0] + 1
    K = None if k is None or not np.any(k) else np.asarray(k, dtype=float)
    if K is not None:
        H.reshape(-1)[::nv1] += h * K                          # H + hK (H is this step's own array: a view)
    cho = _cholesky(H)
    f = tau0 - bias(ws, kin, qd) if K is None else tau0 - K * qd - bias(ws, kin, qd)
    u = qd + h * dpotrs(cho, f)[0]                             # q̇ + h (H + hK)⁻¹ (τ₀ − K q̇ − C)
    c2 = process_time() if clock is not None else 0.0
    P, Jp = point_jacobians(ws, kin, ws.links, ws.points)
    gap, nrm = ws.terrain.gap_normal(P)
    Ju = Jp @ u
    speed = (Ju * nrm).sum(axis=1)
    near = np.flatnonzero(gap < ws.margin + h * np.abs(speed))
    ws.last = None
    if near.size:
        nn, JJ, g = nrm[near], Jp[near], gap[near]
        key = nn.tobytes()
        frames = ws._plan.basis.get(key)
        if frames is None:                                     # new normals (on a plane: once per count of points)
            ref = np.where(np.abs(nn[:, :1]) < 0.9, np.array([[1.0, 0.0, 0.0]]), np.array([[0.0, 1.0, 0.0]]))
            t1 = ref - (ref * nn).sum(axis=1)[:, None] * nn
            t1 /= np.sqrt((t1 * t1).sum(axis=1))[:, None]
            frames = np.stack([nn, t1, _cross(nn, t1)], axis=1)
            if len(ws._plan.basis) >= 64:
                ws._plan.basis.clear()
            ws._plan.basis[key] = frames
        rows = (frames @ JJ).reshape(3 * near.size, -1)
        MinvJt = dpotrs(cho, rows.T)[0]
        A = rows @ MinvJt
        u = ws._impulses(A, rows, MinvJt, u, g, near, h)             # the contact law: the readable step's
    else:
        ws._states = {}
    q1 = integrate(q, u, h, kin["R"][0])
    if clock is not None:                                      # pbanim bench control: the step's split
        clock["H"] += c1 - c0
        clock["dynamics"] += c2 - c1
        clock["contact"] += process_time() - c2
        clock["steps"] += 1
    return q1, u


def integrate(q, u, h: float, R0):
    """q⁺ = q + h q̇(q, u) on floats: ½ q ⊗ (0, ω) for the pelvis's quaternion (renormalized), R₀ v for its
    position (R₀ the kinematics' R of q/|q|), q̇ for the joints."""
    a0, a1, a2, a3 = q[:4].tolist()
    w1, w2, w3, v1, v2, v3 = u[:6].tolist()
    dq = [0.5 * (a0 * 0.0 - a1 * w1 - a2 * w2 - a3 * w3), 0.5 * (a0 * w1 + a1 * 0.0 + a2 * w3 - a3 * w2),
          0.5 * (a0 * w2 - a1 * w3 + a2 * 0.0 + a3 * w1), 0.5 * (a0 * w3 + a1 * w2 - a2 * w1 + a3 * 0.0)]
    q1 = np.empty(q.size)
    q1[:4] = q[:4] + h * np.array(dq)
    q1[:4] /= sqrt(float(q1[:4] @ q1[:4]))
    q1[4:7] = q[4:7] + h * (R0 @ np.array([v1, v2, v3]))
    q1[7:] = q[7:] + h * u[6:]
    return q1
