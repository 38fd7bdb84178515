"""The lean twin of the 3-D biped's world-frame contact step (chapter 08): the same formulas, fewer calls.

:class:`~pbanim.control.biped3d_step.WorldStep` reads as the lecture writes the step (one joint at a time,
``np.cross``, ``np.linalg.solve`` twice, the library's hand-off). At h = 2 ms its Python calls, not its
arithmetic, set the cost (``pbanim bench control``), so ``WorldStep(lean=True)`` (the default) runs
this module instead, computing the same quantities:

1. **kinematics** on Python floats, link by link in tree order: R_i = R_λ(i) ᴶR_i R_a(q_i) (Rodrigues; about
   a coordinate axis ±eₖ, the biped's every joint, the two columns it turns: a = ±(R_λ ᴶR)eₖ),
   o_i = o_λ + R_λ p_i, the world joint column Sᵂ = (a, o × a) and c_i = o_i + R_i c̄_i on nine floats a
   frame, then four arrays (R, o, c, Sᵂ) built once: ~1500 float operations cost less than the ~55 numpy
   calls of a batched form on 3 × 3 blocks (measured 117 → 54 µs a state); the floats stay in the dict for
   the controller. numpy's 3 × 3 products go through BLAS (fused multiply-adds), these do not: equal to a
   few ulps, not bit for bit;
2. **point Jacobians** J = v − [P]× a as one batched product over the points; the centres of
   mass' Jacobians J_c are computed once per state and kept (the mass matrix and the controller's centre of
   mass velocity read the same ones);
3. **H** = Σ mᵢ J_c,iᵀ J_c,i + J_ω,iᵀ Īᵂᵢ J_ω,i as two (3n × nv) products; one Cholesky factorization of
   H + hK serves the free velocity and the contact rows (:func:`scipy.linalg.cho_factor`); **C(q, q̇)** by the
   world-frame Newton–Euler sums on Python floats (forward: velocities and bias accelerations; backward: the
   subtrees' wrenches about the world origin; :func:`bias`);
4. **the contact solve** on the near points only, by the readable step's contact law
   (``WorldStep._impulses``: the box-friction hand-off, the active set from the last step's contact states,
   PGS in chunks when it does not certify), through :func:`pbanim.lcp.handoff_lean.handoff_floats` (its
   rounds' tests on floats: the library's answer bit for bit);
5. **the update** q⁺ = q + h q̇(q, u⁺) on floats, with the pelvis's R of the kinematics (one array built).

``WorldStep.clock``, a dict (kinematics, H, dynamics, contact, steps) or None, adds up the CPU seconds (process
time: on a shared machine the wall clock measures the load) each part takes (``pbanim bench control``).
``tests/test_biped3d_lean.py`` holds the two paths equal to a few ulps per step (ORACLES F20).
"""

from __future__ import annotations

from math import atan2, cos, inf, sin, sqrt
from time import process_time

import numpy as np
from scipy.linalg.lapack import dpotrf, dpotrs
from ..errors import InvalidInput, SimulationDiverged
from .biped3d_bias import _rotational, bias


__all__: list = []      # internal: reached through WorldStep(lean=True)


def _coordinate_axis(u) -> tuple[int, float]:
    """(k, ±1) when the joint axis u is ±eₖ exactly, else (−1, 0)."""
    for k in range(3):
        if abs(u[k]) == 1.0 and u[k - 1] == 0.0 and u[k - 2] == 0.0:
            return k, u[k]
    return -1, 0.0


class LeanPlan:
    """What the lean step needs of a tree, built once: per link its parent, joint placement and axis (floats)."""

    def __init__(self, ws) -> None:
        tree = ws.tree
        n = tree.n
        if any(not 0 <= tree.parent[i] < i for i in range(1, n)):
            raise InvalidInput("LeanPlan: the tree's links must come after their parents")
        self.n, self.nv = n, tree.nv
        self.mass3 = np.repeat(ws.mass, 3)[:, None]
        self.mask = ws.mask.astype(float)
        self.gravity = np.asarray(tree.gravity, dtype=float)
        self.gravity_f = tuple(float(x) for x in self.gravity)
        self.mass_f = [float(m) for m in ws.mass]
        self.damping = np.asarray(tree.arrays()["damping"], dtype=float)
        self.cache = (None, None)           # (q's bytes, its kinematics): the last state's, read again
        self.contacts = (ws.links, ws.points[:, :, None], self.mask[ws.links])
        self.contacts_f = [(int(lk), tuple(float(x) for x in p)) for lk, p in zip(ws.links, ws.points)]
        self.basis = {}                     # the near points' normals' bytes → their frames (n, t₁, t₂) (≤ 64 kept)
        links = []                          # the float kinematics' plan, tree order (module docstring, 1)
        for i in range(1, n):
            j = tree.joints[i]
            rev = j.kind != "fixed"
            u = [float(x) for x in j.axis]
            links.append((i, tree.parent[i], ws.qi[i] if rev else -1, ws.vi[i] if rev else -1,
                          tuple(float(x) for x in j.p),
                          None if np.all(j.R == np.eye(3)) else tuple(float(x) for x in np.ravel(j.R)), tuple(u),
                          (u[0] * u[0], u[0] * u[1], u[0] * u[2], u[1] * u[1], u[1] * u[2], u[2] * u[2]),
                          tuple(float(x) for x in ws.com[i]), *_coordinate_axis(u)))
        self.links = links
        self.com_f = [tuple(float(x) for x in c) for c in ws.com]


def kinematics(ws, q) -> dict:
    """The dict of :meth:`WorldStep.kinematics` (R, o, c, S) on floats (module docstring, 1); the last
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
    """(R, o, c, Sᵂ) on Python floats, link by link in tree order (parents first): the readable step's
    formulas — R_i = R_λ ᴶR_i R_a(q_i) (Rodrigues: c 1 + s [a]× + (1 − c) a aᵀ), o_i = o_λ + R_λ p_i,
    a_i = R_λ ᴶR_i a, the column (a_i, o_i × a_i), c_i = o_i + R_i c̄_i — on nine floats a frame, then four
    arrays. The floats stay in the dict (``"Rf"``, ``"of"``, ``"cf"``: per link, R row-major; ``"Sf"``: per
    joint column) for the controller."""
    P = ws._plan
    ql = q.tolist()
    w, x, y, z = ql[0], ql[1], ql[2], ql[3]
    nrm = sqrt(w * w + x * x + y * y + z * z)
    if nrm == inf:                          # the squares overflow (|q| ≳ 1e154): scale by the largest entry first
        big = max(abs(w), abs(x), abs(y), abs(z))
        w, x, y, z = w / big, x / big, y / big, z / big
        nrm = sqrt(w * w + x * x + y * y + z * z)
    if not nrm > 1e-9:
        raise InvalidInput(f"q[:4] must be the pelvis's (non-zero) quaternion, got {q[:4]}")
    w, x, y, z = w / nrm, x / nrm, y / nrm, z / nrm                 # quat_to_matrix's formula, s = 2/|q|²
    s = 2.0 / (w * w + x * x + y * y + z * z)
    xx, yy, zz = s * x * x, s * y * y, s * z * z
    xy, xz, yz = s * x * y, s * x * z, s * y * z
    wx, wy, wz = s * w * x, s * w * y, s * w * z
    R0 = (1.0 - yy - zz, xy - wz, xz + wy, xy + wz, 1.0 - xx - zz, yz - wx, xz - wy, yz + wx, 1.0 - xx - yy)
    px, py, pz = ql[4], ql[5], ql[6]
    Rs, os, cs = [R0] * P.n, [(px, py, pz)] * P.n, [None] * P.n
    cols = [None] * P.nv
    r00, r01, r02, r10, r11, r12, r20, r21, r22 = R0
    for j in range(3):                      # the pelvis: [[R₀, 0], [p̂ R₀, R₀]] (body-frame q̇)
        e0, e1, e2 = R0[j], R0[3 + j], R0[6 + j]
        cols[j] = (e0, e1, e2, py * e2 - pz * e1, pz * e0 - px * e2, px * e1 - py * e0)
        cols[3 + j] = (0.0, 0.0, 0.0, e0, e1, e2)
    m0, m1, m2 = P.com_f[0]
    cs[0] = (px + (r00 * m0 + r01 * m1 + r02 * m2), py + (r10 * m0 + r11 * m1 + r12 * m2),
             pz + (r20 * m0 + r21 * m1 + r22 * m2))
    for i, lam, qk, vk, p, JR, axis, aa, com, kax, sgn in P.links:
        a00, a01, a02, a10, a11, a12, a20, a21, a22 = Rs[lam]
        ox, oy, oz = os[lam]
        p0, p1, p2 = p
        ox, oy, oz = (ox + (a00 * p0 + a01 * p1 + a02 * p2), oy + (a10 * p0 + a11 * p1 + a12 * p2),
                      oz + (a20 * p0 + a21 * p1 + a22 * p2))
        if JR is not None:                                          # R_λ ᴶR
            b00, b01, b02, b10, b11, b12, b20, b21, b22 = JR
            a00, a01, a02, a10, a11, a12, a20, a21, a22 = (
                a00 * b00 + a01 * b10 + a02 * b20, a00 * b01 + a01 * b11 + a02 * b21, a00 * b02 + a01 * b12 + a02 * b22,
                a10 * b00 + a11 * b10 + a12 * b20, a10 * b01 + a11 * b11 + a12 * b21, a10 * b02 + a11 * b12 + a12 * b22,
                a20 * b00 + a21 * b10 + a22 * b20, a20 * b01 + a21 * b11 + a22 * b21, a20 * b02 + a21 * b12 + a22 * b22)
        if qk >= 0 and kax >= 0:                                     # a = ±eₖ: R_a(θ) turns two columns
            th = ql[qk]
            c, sn = cos(th), sin(th)
            if sgn < 0.0:
                sn = -sn
            if kax == 0:                                                # R_λ R_x(θ): columns 1, 2
                e0, e1, e2 = a00, a10, a20
                a01, a02, a11, a12, a21, a22 = (c * a01 + sn * a02, c * a02 - sn * a01, c * a11 + sn * a12,
                                                c * a12 - sn * a11, c * a21 + sn * a22, c * a22 - sn * a21)
            elif kax == 1:                                              # R_λ R_y(θ): columns 2, 0
                e0, e1, e2 = a01, a11, a21
                a00, a02, a10, a12, a20, a22 = (c * a00 - sn * a02, c * a02 + sn * a00, c * a10 - sn * a12,
                                                c * a12 + sn * a10, c * a20 - sn * a22, c * a22 + sn * a20)
            else:                                                       # R_λ R_z(θ): columns 0, 1
                e0, e1, e2 = a02, a12, a22
                a00, a01, a10, a11, a20, a21 = (c * a00 + sn * a01, c * a01 - sn * a00, c * a10 + sn * a11,
                                                c * a11 - sn * a10, c * a20 + sn * a21, c * a21 - sn * a20)
            if sgn < 0.0:
                e0, e1, e2 = -e0, -e1, -e2
            cols[vk] = (e0, e1, e2, oy * e2 - oz * e1, oz * e0 - ox * e2, ox * e1 - oy * e0)
        elif qk >= 0:
            ux, uy, uz = axis
            th = ql[qk]
            c, sn = cos(th), sin(th)
            t = 1.0 - c
            xx_, xy_, xz_, yy_, yz_, zz_ = aa
            b00, b01, b02 = t * xx_ + c, t * xy_ - sn * uz, t * xz_ + sn * uy
            b10, b11, b12 = t * xy_ + sn * uz, t * yy_ + c, t * yz_ - sn * ux
            b20, b21, b22 = t * xz_ - sn * uy, t * yz_ + sn * ux, t * zz_ + c
            e0, e1, e2 = (a00 * ux + a01 * uy + a02 * uz, a10 * ux + a11 * uy + a12 * uz,
                          a20 * ux + a21 * uy + a22 * uz)                  # the world axis a
            cols[vk] = (e0, e1, e2, oy * e2 - oz * e1, oz * e0 - ox * e2, ox * e1 - oy * e0)
            a00, a01, a02, a10, a11, a12, a20, a21, a22 = (
                a00 * b00 + a01 * b10 + a02 * b20, a00 * b01 + a01 * b11 + a02 * b21, a00 * b02 + a01 * b12 + a02 * b22,
                a10 * b00 + a11 * b10 + a12 * b20, a10 * b01 + a11 * b11 + a12 * b21, a10 * b02 + a11 * b12 + a12 * b22,
                a20 * b00 + a21 * b10 + a22 * b20, a20 * b01 + a21 * b11 + a22 * b21, a20 * b02 + a21 * b12 + a22 * b22)
        Rs[i] = (a00, a01, a02, a10, a11, a12, a20, a21, a22)
        os[i] = (ox, oy, oz)
        m0, m1, m2 = com
        cs[i] = (ox + (a00 * m0 + a01 * m1 + a02 * m2), oy + (a10 * m0 + a11 * m1 + a12 * m2),
                 oz + (a20 * m0 + a21 * m1 + a22 * m2))
    return {"R": np.array(Rs).reshape(P.n, 3, 3), "o": np.array(os), "c": np.array(cs),
            "S": np.array(list(zip(*cols))), "Rf": Rs, "of": os, "cf": cs, "Sf": cols}


_I1, _I2 = np.array([1, 2, 0]), np.array([2, 0, 1])


def _cross(u, v):
    """u × v row by row: component k is u_{k+1} v_{k+2} − u_{k+2} v_{k+1}, np.cross's products."""
    return u[:, _I1] * v[:, _I2] - u[:, _I2] * v[:, _I1]


_SKEW = np.zeros((3, 9))                  # P ↦ [P]× flattened row-major: [[0, −z, y], [z, 0, −x], [−y, x, 0]]
_SKEW[2, 1] = _SKEW[0, 5] = _SKEW[1, 6] = -1.0
_SKEW[1, 2] = _SKEW[2, 3] = _SKEW[0, 7] = 1.0


def jacobians_at(S, P, mask):
    """J (m, 3, nv) of world points P (m, 3): column v is (v_v + a_v × P) where the point moves with it, as
    v − [P]× a: one batched product [P]× Sᵂ_ω (m, 3, 3)(3, nv), a subtraction and the mask (the cross
    product's six products in a 3 × 3 product with its three zeros: equal to the written-out form to an ulp)."""
    J = np.matmul((P @ _SKEW).reshape(-1, 3, 3), S[:3])
    np.subtract(S[3:], J, out=J)
    J *= mask[:, None, :]
    return J


def point_jacobians(ws, kin, links, points):
    """(P, J) of :meth:`WorldStep.point_jacobians`; the centres of mass' J_c once per state."""
    if points is ws.com and len(links) == ws.tree.n:
        return kin["c"], com_jacobians(ws, kin)
    if links is ws.links and points is ws.points and "Rf" in kin:   # the contact points: o + R p on floats
        Rf, of = kin["Rf"], kin["of"]
        rows = []
        for lk, (p0, p1, p2) in ws._plan.contacts_f:
            r0, r1, r2, r3, r4, r5, r6, r7, r8 = Rf[lk]
            ox, oy, oz = of[lk]
            rows.append((ox + (r0 * p0 + r1 * p1 + r2 * p2), oy + (r3 * p0 + r4 * p1 + r5 * p2),
                         oz + (r6 * p0 + r7 * p1 + r8 * p2)))
        P = np.array(rows)
        return P, jacobians_at(kin["S"], P, ws._plan.contacts[2])
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
    Iw, Jw = _rotational(ws, kin)
    return (P.mass3 * Jc).T @ Jc + Jw.reshape(3 * n, nv).T @ (Iw @ Jw).reshape(3 * n, nv)


def rotation_vector_floats(R, as_list: bool = False):
    """log(R) (3,) of a rotation matrix (3, 3), or of its nine floats row-major:
    :func:`pbanim.rigid.matrix_to_quat` (Shepperd: the largest of 4w², 4x², 4y², 4z² under the square root,
    w ≥ 0), then :func:`pbanim.design.simulate.quat_log` (2 atan2(|v|, w) v / |v|; 2v / w below |v| = 1e-12) —
    their arithmetic in their order on nine floats, so their bits but for |v| (norm's BLAS dot: an ulp apart
    in 2 % of rotations, ``tests/test_biped3d_lean.py``), without the two calls' array work (the controller's
    two servos call it every step). An array (3,), or with ``as_list`` the list of its three floats."""
    r00, r01, r02, r10, r11, r12, r20, r21, r22 = R.ravel().tolist() if isinstance(R, np.ndarray) else R
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
    K = None if k is None or not (k.any() if isinstance(k, np.ndarray) else np.any(k)) else np.asarray(k, dtype=float)
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
    q1 = integrate(q, u, h, kin["Rf"][0] if "Rf" in kin else kin["R"][0])
    if clock is not None:                                      # pbanim bench control: the step's split
        clock["H"] += c1 - c0
        clock["dynamics"] += c2 - c1
        clock["contact"] += process_time() - c2
        clock["steps"] += 1
    return q1, u


def integrate(q, u, h: float, R0):
    """q⁺ = q + h q̇(q, u) on floats: ½ q ⊗ (0, ω) for the pelvis's quaternion (renormalized), R₀ v for its
    position (R₀ the kinematics' R of q/|q|, nine floats row-major or an array), q̇ for the joints; one array
    built at the end."""
    ql, ul = q.tolist(), u.tolist()
    a0, a1, a2, a3, px, py, pz = ql[:7]
    w1, w2, w3, v1, v2, v3 = ul[:6]
    b0 = a0 + h * (0.5 * (a0 * 0.0 - a1 * w1 - a2 * w2 - a3 * w3))
    b1 = a1 + h * (0.5 * (a0 * w1 + a1 * 0.0 + a2 * w3 - a3 * w2))
    b2 = a2 + h * (0.5 * (a0 * w2 - a1 * w3 + a2 * 0.0 + a3 * w1))
    b3 = a3 + h * (0.5 * (a0 * w3 + a1 * w2 - a2 * w1 + a3 * 0.0))
    nb = sqrt(b0 * b0 + b1 * b1 + b2 * b2 + b3 * b3)
    r0, r1, r2, r3, r4, r5, r6, r7, r8 = R0 if isinstance(R0, tuple) else R0.ravel().tolist()
    out = [b0 / nb, b1 / nb, b2 / nb, b3 / nb, px + h * (r0 * v1 + r1 * v2 + r2 * v3),
           py + h * (r3 * v1 + r4 * v2 + r5 * v3), pz + h * (r6 * v1 + r7 * v2 + r8 * v3)]
    out += [x + h * v for x, v in zip(ql[7:], ul[6:])]
    return np.array(out)
