"""The world-frame ABA as straight-line arithmetic on "scalars" (chapter 08; equations in :mod:`.fastplan`).

Every quantity is a tuple of its components — a rotation R is 9 numbers (row-major), a spatial vector
6, an articulated inertia I^A its 21 upper-triangle entries (00, 01, …, 05, 11, …, 55) — and every
component is either a Python float (one state: no numpy call at all, ~10 ns per operation) or a numpy
array of K states (one numpy call per operation, paid once for the whole batch). The code below is the
same for both; :mod:`.fast` feeds it floats or arrays. Per link it costs about 400 operations:

==================================  =========================================================  ==========
step                                formula                                                    operations
==================================  =========================================================  ==========
joint frame                         M = R_λ R_T',  p = p_λ + R_λ p_T',  R = M R_z(q)             ≈ 30–75
motion subspace, velocity           S = (z, p × z),  v̂ = v̂_λ + S q̇,  ĉ = v̂_λ × S q̇,  Ĉ += ĉ     ≈ 55
rigid inertia and bias              h, m(|h|²1 − hhᵀ) + R Ī Rᵀ, p̂ = v̂ ×* I v̂ + I Ĉ − f̂ᵉˣᵗ       ≈ 90–190
backward (rank-1 projection)        U = I^A S, D, u, I^A_λ += I^A − U Uᵀ/D, p^A_λ += …           ≈ 175
forward                             q̈ = (u − U·â'_λ)/D,  â' = â'_λ + S q̈                         ≈ 25
==================================  =========================================================  ==========

Constants of the plan are floats, so terms known at build time (the world's identity frame above a
root, zero inertias, unit placements) fold into float arithmetic and cost no numpy call in a batch.
"""

from __future__ import annotations

from .fastplan import FIXED, FLOATING, PRISMATIC, REVOLUTE, Plan

__all__ = ["IDENTITY", "sweep"]

IDENTITY = (1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0)
_ZERO3 = (0.0, 0.0, 0.0)


def _matmul(A, B):
    a00, a01, a02, a10, a11, a12, a20, a21, a22 = A
    b00, b01, b02, b10, b11, b12, b20, b21, b22 = B
    return (a00 * b00 + a01 * b10 + a02 * b20, a00 * b01 + a01 * b11 + a02 * b21, a00 * b02 + a01 * b12 + a02 * b22,
            a10 * b00 + a11 * b10 + a12 * b20, a10 * b01 + a11 * b11 + a12 * b21, a10 * b02 + a11 * b12 + a12 * b22,
            a20 * b00 + a21 * b10 + a22 * b20, a20 * b01 + a21 * b11 + a22 * b21, a20 * b02 + a21 * b12 + a22 * b22)


def _rotate(R, x):
    r00, r01, r02, r10, r11, r12, r20, r21, r22 = R
    x0, x1, x2 = x
    return (r00 * x0 + r01 * x1 + r02 * x2, r10 * x0 + r11 * x1 + r12 * x2, r20 * x0 + r21 * x1 + r22 * x2)


def _rotate_t(R, x):
    """Rᵀ x."""
    r00, r01, r02, r10, r11, r12, r20, r21, r22 = R
    x0, x1, x2 = x
    return (r00 * x0 + r10 * x1 + r20 * x2, r01 * x0 + r11 * x1 + r21 * x2, r02 * x0 + r12 * x1 + r22 * x2)


def _cross(a, b):
    return (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])


def _cross_motion(v, w):
    """v̂ × ŵ = (ω × ω_w, u × ω_w + ω × u_w) for v̂ = (ω, u)."""
    w0, w1, w2, u0, u1, u2 = v
    j0, j1, j2, k0, k1, k2 = w
    return (w1 * j2 - w2 * j1, w2 * j0 - w0 * j2, w0 * j1 - w1 * j0,
            u1 * j2 - u2 * j1 + w1 * k2 - w2 * k1, u2 * j0 - u0 * j2 + w2 * k0 - w0 * k2,
            u0 * j1 - u1 * j0 + w0 * k1 - w1 * k0)


def _add6(a, b):
    return (a[0] + b[0], a[1] + b[1], a[2] + b[2], a[3] + b[3], a[4] + b[4], a[5] + b[5])


def _quat_rows(w, x, y, z):
    """R(q) row-major for q = (w, x, y, z) of any norm: s = 2/|q|², the formula of
    :func:`pbanim.rigid.quat_to_matrix` (the same products in the same order)."""
    s = 2.0 / (w * w + x * x + y * y + z * z)
    xx, yy, zz, xy, xz, yz = s * x * x, s * y * y, s * z * z, s * x * y, s * x * z, s * y * z
    wx, wy, wz = s * w * x, s * w * y, s * w * z
    return (1.0 - yy - zz, xy - wz, xz + wy, xy + wz, 1.0 - xx - zz, yz - wx, xz - wy, yz + wx, 1.0 - xx - yy)


def _quat_frame(M, p, q4, pq):
    """Floating joint: R = M R(quaternion), origin p + M p_q (the quaternion's norm does not matter)."""
    Rq = _quat_rows(*q4)
    t = _rotate(M, pq)
    return _matmul(M, Rq), (p[0] + t[0], p[1] + t[1], p[2] + t[2])


def _inertia_bias(lp, R, p, v, C, fx):
    """The link's world spatial inertia (21 entries) and bias p̂ = v̂ ×* I v̂ + I Ĉ − f̂ᵉˣᵗ (world)."""
    m = lp.mass
    t = _rotate(R, lp.com)
    h0, h1, h2 = p[0] + t[0], p[1] + t[1], p[2] + t[2]
    mh0, mh1, mh2 = m * h0, m * h1, m * h2
    xx, yy, zz, xy, xz, yz = mh0 * h0, mh1 * h1, mh2 * h2, mh0 * h1, mh0 * h2, mh1 * h2
    A00, A11, A22, A01, A02, A12 = yy + zz, xx + zz, xx + yy, -xy, -xz, -yz
    J = None
    if lp.Ibar is not None:                                   # Ī_w = R Ī Rᵀ
        i00, i01, i02, i11, i12, i22 = lp.Ibar
        r00, r01, r02, r10, r11, r12, r20, r21, r22 = R
        t00, t01, t02 = r00 * i00 + r01 * i01 + r02 * i02, r00 * i01 + r01 * i11 + r02 * i12, r00 * i02 + r01 * i12 + r02 * i22
        t10, t11, t12 = r10 * i00 + r11 * i01 + r12 * i02, r10 * i01 + r11 * i11 + r12 * i12, r10 * i02 + r11 * i12 + r12 * i22
        t20, t21, t22 = r20 * i00 + r21 * i01 + r22 * i02, r20 * i01 + r21 * i11 + r22 * i12, r20 * i02 + r21 * i12 + r22 * i22
        J = (t00 * r00 + t01 * r01 + t02 * r02, t00 * r10 + t01 * r11 + t02 * r12, t00 * r20 + t01 * r21 + t02 * r22,
             t10 * r10 + t11 * r11 + t12 * r12, t10 * r20 + t11 * r21 + t12 * r22, t20 * r20 + t21 * r21 + t22 * r22)
        A00, A01, A02, A11, A12, A22 = A00 + J[0], A01 + J[1], A02 + J[2], A11 + J[3], A12 + J[4], A22 + J[5]
    IA = (A00, A01, A02, 0.0, -mh2, mh1, A11, A12, mh2, 0.0, -mh0, A22, -mh1, mh0, 0.0, m, 0.0, 0.0, m, 0.0, m)
    b = None
    if v is not None:                                         # momentum (L, P), then v̂ ×* (L, P)
        w0, w1, w2, u0, u1, u2 = v
        P0, P1, P2 = m * (u0 + w1 * h2 - w2 * h1), m * (u1 + w2 * h0 - w0 * h2), m * (u2 + w0 * h1 - w1 * h0)
        L0, L1, L2 = h1 * P2 - h2 * P1, h2 * P0 - h0 * P2, h0 * P1 - h1 * P0
        if J is not None:
            L0, L1, L2 = L0 + J[0] * w0 + J[1] * w1 + J[2] * w2, L1 + J[1] * w0 + J[3] * w1 + J[4] * w2, \
                L2 + J[2] * w0 + J[4] * w1 + J[5] * w2
        b = (w1 * L2 - w2 * L1 + u1 * P2 - u2 * P1, w2 * L0 - w0 * L2 + u2 * P0 - u0 * P2,
             w0 * L1 - w1 * L0 + u0 * P1 - u1 * P0, w1 * P2 - w2 * P1, w2 * P0 - w0 * P2, w0 * P1 - w1 * P0)
    if C is not None:                                         # + I Ĉ
        c0, c1, c2, c3, c4, c5 = C
        Q0, Q1, Q2 = m * (c3 + c1 * h2 - c2 * h1), m * (c4 + c2 * h0 - c0 * h2), m * (c5 + c0 * h1 - c1 * h0)
        N0, N1, N2 = h1 * Q2 - h2 * Q1, h2 * Q0 - h0 * Q2, h0 * Q1 - h1 * Q0
        if J is not None:
            N0, N1, N2 = N0 + J[0] * c0 + J[1] * c1 + J[2] * c2, N1 + J[1] * c0 + J[3] * c1 + J[4] * c2, \
                N2 + J[2] * c0 + J[4] * c1 + J[5] * c2
        b = (N0, N1, N2, Q0, Q1, Q2) if b is None else _add6(b, (N0, N1, N2, Q0, Q1, Q2))
    if fx is not None:                                        # f̂ᵉˣᵗ from joint-frame to world coordinates
        f = _rotate(R, fx[3:])
        nn = _rotate(R, fx[:3])
        pf = _cross(p, f)
        fw = (-(nn[0] + pf[0]), -(nn[1] + pf[1]), -(nn[2] + pf[2]), -f[0], -f[1], -f[2])
        b = fw if b is None else _add6(b, fw)
    return IA, (b if b is not None else (0.0,) * 6)


def _schur(IA, pA, S, tau):
    """U = I^A S, D = Sᵀ U, u = τ − Sᵀ p^A for a one-degree-of-freedom joint."""
    a00, a01, a02, a03, a04, a05, a11, a12, a13, a14, a15, a22, a23, a24, a25, a33, a34, a35, a44, a45, a55 = IA
    s0, s1, s2, s3, s4, s5 = S
    U = (a00 * s0 + a01 * s1 + a02 * s2 + a03 * s3 + a04 * s4 + a05 * s5,
         a01 * s0 + a11 * s1 + a12 * s2 + a13 * s3 + a14 * s4 + a15 * s5,
         a02 * s0 + a12 * s1 + a22 * s2 + a23 * s3 + a24 * s4 + a25 * s5,
         a03 * s0 + a13 * s1 + a23 * s2 + a33 * s3 + a34 * s4 + a35 * s5,
         a04 * s0 + a14 * s1 + a24 * s2 + a34 * s3 + a44 * s4 + a45 * s5,
         a05 * s0 + a15 * s1 + a25 * s2 + a35 * s3 + a45 * s4 + a55 * s5)
    D = U[0] * s0 + U[1] * s1 + U[2] * s2 + U[3] * s3 + U[4] * s4 + U[5] * s5
    p0, p1, p2, p3, p4, p5 = pA
    return U, D, tau - (p0 * s0 + p1 * s1 + p2 * s2 + p3 * s3 + p4 * s4 + p5 * s5)


def _project_into(IA, pA, U, d, u, IAp, pAp):
    """(I^A_λ + I^A − U d Uᵀ, p^A_λ + p^A + U d u): the child's articulated body seen through its joint."""
    a00, a01, a02, a03, a04, a05, a11, a12, a13, a14, a15, a22, a23, a24, a25, a33, a34, a35, a44, a45, a55 = IA
    b00, b01, b02, b03, b04, b05, b11, b12, b13, b14, b15, b22, b23, b24, b25, b33, b34, b35, b44, b45, b55 = IAp
    u0, u1, u2, u3, u4, u5 = U
    w0, w1, w2, w3, w4, w5 = u0 * d, u1 * d, u2 * d, u3 * d, u4 * d, u5 * d
    IA = (b00 + a00 - w0 * u0, b01 + a01 - w0 * u1, b02 + a02 - w0 * u2, b03 + a03 - w0 * u3,
          b04 + a04 - w0 * u4, b05 + a05 - w0 * u5, b11 + a11 - w1 * u1, b12 + a12 - w1 * u2,
          b13 + a13 - w1 * u3, b14 + a14 - w1 * u4, b15 + a15 - w1 * u5, b22 + a22 - w2 * u2,
          b23 + a23 - w2 * u3, b24 + a24 - w2 * u4, b25 + a25 - w2 * u5, b33 + a33 - w3 * u3,
          b34 + a34 - w3 * u4, b35 + a35 - w3 * u5, b44 + a44 - w4 * u4, b45 + a45 - w4 * u5, b55 + a55 - w5 * u5)
    return IA, (pAp[0] + pA[0] + w0 * u, pAp[1] + pA[1] + w1 * u, pAp[2] + pA[2] + w2 * u,
                pAp[3] + pA[3] + w3 * u, pAp[4] + pA[4] + w4 * u, pAp[5] + pA[5] + w5 * u)


_SYM = [[0, 1, 2, 3, 4, 5], [1, 6, 7, 8, 9, 10], [2, 7, 11, 12, 13, 14], [3, 8, 12, 15, 16, 17],
        [4, 9, 13, 16, 18, 19], [5, 10, 14, 17, 19, 20]]


def _solve_sym6(IA, rhs, pivot, i):
    """x with I^A x = rhs by LDLᵀ (I^A symmetric positive definite); pivots checked against the diagonal."""
    M = [[IA[_SYM[r][c]] for c in range(6)] for r in range(6)]
    floor = 1e-14 * (abs(M[0][0]) + abs(M[1][1]) + abs(M[2][2]) + abs(M[3][3]) + abs(M[4][4]) + abs(M[5][5])) / 6
    L = [[0.0] * 6 for _ in range(6)]
    Dv, Di = [0.0] * 6, [0.0] * 6
    for j in range(6):                                        # 6 columns: a fixed count
        dj = M[j][j]
        for k in range(j):
            dj = dj - L[j][k] * L[j][k] * Dv[k]
        Dv[j], Di[j] = dj, pivot(dj, i, floor)
        for r in range(j + 1, 6):
            x = M[r][j]
            for k in range(j):
                x = x - L[r][k] * L[j][k] * Dv[k]
            L[r][j] = x * Di[j]
    y = list(rhs)
    for r in range(6):
        for k in range(r):
            y[r] = y[r] - L[r][k] * y[k]
    for r in range(6):
        y[r] = y[r] * Di[r]
    for r in reversed(range(6)):
        for k in range(r + 1, 6):
            y[r] = y[r] - L[k][r] * y[k]
    return tuple(y)


def sweep(P: Plan, q, qd, tau, trig, fx, pivot):
    """q̈ of the tree: ``q``, ``qd``, ``tau`` (damping already subtracted) are sequences of scalars indexed
    like q, q̇; ``trig[i]`` is (cos q_i, sin q_i) for a revolute link; ``fx[i]`` the external force on link
    i in its joint frame or None; ``pivot(D, i, floor)`` returns 1/D or raises. Returns a list of nv
    scalars."""
    n, links = P.n, P.links
    Rw, pw, vw, Cw, Sw, IA, pA = ([None] * n for _ in range(7))
    for i in range(n):                                        # kinematics, velocities, link inertias
        lp = links[i]
        lam = lp.parent
        Rp, pp, vp, Cp = (IDENTITY, _ZERO3, None, None) if lam < 0 else (Rw[lam], pw[lam], vw[lam], Cw[lam])
        M = Rp if lp.RT is None else _matmul(Rp, lp.RT)
        t = _rotate(Rp, lp.pT)
        p = (pp[0] + t[0], pp[1] + t[1], pp[2] + t[2])
        kind, vJ = lp.kind, None
        if kind == REVOLUTE:
            c, s = trig[i]
            m00, m01, m02, m10, m11, m12, m20, m21, m22 = M
            R = (c * m00 + s * m01, c * m01 - s * m00, m02, c * m10 + s * m11, c * m11 - s * m10, m12,
                 c * m20 + s * m21, c * m21 - s * m20, m22)
            S = (m02, m12, m22, p[1] * m22 - p[2] * m12, p[2] * m02 - p[0] * m22, p[0] * m12 - p[1] * m02)
        elif kind == PRISMATIC:
            R, x = M, q[lp.qi]
            p = (p[0] + x * M[2], p[1] + x * M[5], p[2] + x * M[8])
            S = (0.0, 0.0, 0.0, M[2], M[5], M[8])
        elif kind == FIXED:
            R, S = M, None
        else:                                                 # floating: q = (quaternion, origin), q̇ = body (ω, v)
            k, j = lp.qi, lp.vi
            R, p = _quat_frame(M, p, q[k:k + 4], q[k + 4:k + 7])
            w = _rotate(R, qd[j:j + 3])
            vJ = w + _add3(_cross(p, w), _rotate(R, qd[j + 3:j + 6]))
            S = None
        if S is not None:
            x = qd[lp.vi]
            vJ = (S[0] * x, S[1] * x, S[2] * x, S[3] * x, S[4] * x, S[5] * x)
        if vJ is None:
            v, C = vp, Cp
        elif vp is None:
            v, C = vJ, Cp
        else:
            c6 = _cross_motion(vp, vJ)
            v, C = _add6(vp, vJ), (c6 if Cp is None else _add6(Cp, c6))
        Rw[i], pw[i], vw[i], Cw[i], Sw[i] = R, p, v, C, S
        IA[i], pA[i] = _inertia_bias(lp, R, p, v, C, fx[i])
    Us, ds, us = [None] * n, [None] * n, [None] * n
    for i in reversed(range(n)):                              # articulated inertias, leaves first
        lp = links[i]
        lam = lp.parent
        if lp.kind == FIXED:
            if lam >= 0:
                IA[lam] = tuple(a + b for a, b in zip(IA[lam], IA[i]))
                pA[lam] = _add6(pA[lam], pA[i])
        elif lp.kind != FLOATING:                            # a floating link is a root: solved below
            U, D, u = _schur(IA[i], pA[i], Sw[i], tau[lp.vi])
            d = pivot(D, i, 1e-280)
            Us[i], ds[i], us[i] = U, d, u
            if lam >= 0:
                IA[lam], pA[lam] = _project_into(IA[i], pA[i], U, d, u, IA[lam], pA[lam])
    qdd, acc = [None] * P.nv, [None] * n
    for i in range(n):                                        # accelerations, root first
        lp = links[i]
        ap = P.a0 if lp.parent < 0 else acc[lp.parent]
        if lp.kind == FIXED:
            acc[i] = ap
        elif lp.kind == FLOATING:
            qdd[lp.vi:lp.vi + 6], acc[i] = _floating_accel(IA[i], pA[i], Rw[i], pw[i], tau[lp.vi:lp.vi + 6],
                                                           ap, pivot, i)
        else:
            U, S = Us[i], Sw[i]
            x = ds[i] * (us[i] - (U[0] * ap[0] + U[1] * ap[1] + U[2] * ap[2] + U[3] * ap[3] + U[4] * ap[4]
                                  + U[5] * ap[5]))
            qdd[lp.vi] = x
            acc[i] = (ap[0] + S[0] * x, ap[1] + S[1] * x, ap[2] + S[2] * x, ap[3] + S[3] * x, ap[4] + S[4] * x,
                      ap[5] + S[5] * x)
    return qdd


def _add3(a, b):
    return (a[0] + b[0], a[1] + b[1], a[2] + b[2])


def _floating_accel(IA, pA, R, p, tau, a0, pivot, i):
    """A floating root: Sᵀ(I^A â' + p^A) = τ with S = ⁰X_body invertible, so I^A â' = S⁻ᵀτ − p^A; then
    q̈ = S⁻¹(â' − â₀), the body-frame (ω̇, v̇)."""
    f = _rotate(R, tau[3:6])
    nn = _add3(_rotate(R, tau[0:3]), _cross(p, f))
    a = _solve_sym6(IA, (nn[0] - pA[0], nn[1] - pA[1], nn[2] - pA[2], f[0] - pA[3], f[1] - pA[4], f[2] - pA[5]),
                    pivot, i)
    dw = (a[0] - a0[0], a[1] - a0[1], a[2] - a0[2])
    du = (a[3] - a0[3], a[4] - a0[4], a[5] - a0[5])
    pw = _cross(p, dw)
    return list(_rotate_t(R, dw) + _rotate_t(R, (du[0] - pw[0], du[1] - pw[1], du[2] - pw[2]))), a
