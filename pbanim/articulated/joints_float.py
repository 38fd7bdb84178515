"""The joint rows of a small scene on plain floats: R, I⁻¹_world, ω, J's angular entries, J̇u and C (chapter 08).

:class:`~pbanim.articulated.joints_lean.LeanJoints` lays the multiplier solve of ball and hinge joints out
in preallocated arrays; its row evaluation still pays some seventy numpy calls per force evaluation on
arrays of a few rows (a microsecond or more each), whatever the number of joints. For a scene of a few
bodies this module evaluates the same quantities on Python floats, body by body and joint by joint, with
everything that does not change during a run (the joints' bodies, anchors, axes and rows; the inertias)
bound once, at ``bind``:

    s = 2/|q|²,  R = R(q) (the formula of :func:`pbanim.rigid.quat_to_matrix`),
    I⁻¹_world = R diag(I⁻¹_body) Rᵀ,  ω = I⁻¹_world L,  ω × L (the gyroscopic torque, negated in Q),
    r = R r⁰,  p = x + r;  ball rows:  C = p_a − p_b,  J̇u = ω_a × (ω_a × r_a) − ω_b × (ω_b × r_b),
    J angular blocks −[r_a]× on a, [r_b]× on b;
    hinge rows:  â = R a⁰,  t₁ = normalize(e − (e·â_a) â_a) (e = x̂, or ŷ where |â_a,x| ≥ 0.9),  t₂ = â_a × t₁,
    C = tₖ·â_b,  J = ±(tₖ × â_b),  J̇u = (ω_a·t)(ω_a·â_b) + (ω_b·t)(ω_b·â_b) − 2 (ω_a·â_b)(ω_b·t) − (t·â_b)|ω_a − ω_b|²,

the formulas of :mod:`pbanim.articulated.joints_lean` (its docstring derives the hinge rows' J̇u), so the
same ẏ and λ to roundoff (ω as I⁻¹_world L rather than R (I⁻¹_body (Rᵀ L)): equal to a few ulps). The
matrix work (J W Jᵀ, its Cholesky factor, λ) stays in numpy (``LeanJoints.constrain``).

=========================  ==============================  ===============================
symbol                     code                            per
=========================  ==============================  ===============================
y = [x, q, P, L]           ``yl``                          a list of 13N floats
R, I⁻¹_world (rows)        ``R[n]``, ``Iw`` (9N floats)    body
ω, −ω × L                  ``w[n]``, ``gyro``              body
J angular values, J̇u, C    ``vals``, ``bias``, ``C``       joint (in LeanJoints' put order)
=========================  ==============================  ===============================

When: bodies of diagonal I⁻¹_body (principal axes: every body the package's models build), none static,
at most :data:`FLOAT_MAX_JOINTS` joints (the float rows grow as the number of joints, some ten µs each;
the vectorized ones barely: they cross near twenty). Otherwise the array rows of ``joints_lean`` run.
Equal to them and to the readable rows to roundoff (``tests/test_joints_float.py``, ORACLES I13).

Limiting cases: a joint to the world (b = −1) has R_b = 1, ω_b = 0, x_b = 0: its b side is its constant
anchor and axis; one ball joint gives three rows and a 3×3 J W Jᵀ.
"""

from __future__ import annotations

from math import sqrt

import numpy as np

from ..contracts import Obj, contract
from .fastkernel import _quat_rows

__all__ = ["FLOAT_MAX_JOINTS", "float_rows"]

#: Up to this many joints the rows are evaluated on floats (see the module docstring).
FLOAT_MAX_JOINTS = 12


@contract(lean=Obj("pbanim.articulated.joints_lean:LeanJoints"))
def float_rows(lean) -> "FloatRows | None":
    """The float rows of a :class:`~pbanim.articulated.joints_lean.LeanJoints` plan, or None where its
    bodies do not qualify (see the module docstring); built once, at ``bind``.

    >>> from pbanim.models.articulated import rod_chain
    >>> scene, rb, _ = rod_chain(3)
    >>> j = [e for e in scene.effects if e.name == "joints"][0]
    >>> float_rows(j._lean) is not None, float_rows(j._lean).k
    (True, 15)
    """
    s = lean.effect.system
    inv_I = np.asarray(s.inv_I_body, dtype=float)
    off = inv_I * (1.0 - np.eye(3))
    if lean.m > FLOAT_MAX_JOINTS or lean.any_static or np.any(off != 0.0) or not np.all(np.isfinite(inv_I)):
        return None
    return FloatRows(lean)


class FloatRows:
    """R, ω, J's angular entries, J̇u and C of ball and hinge joints on floats (see the module docstring)."""

    def __init__(self, lean) -> None:
        s = lean.effect.system
        N = self.N = lean.N
        self.k = lean.k
        self.d = [tuple(float(v) for v in np.diagonal(s.inv_I_body[n])) for n in range(N)]
        self.inv_mass = [float(v) for v in s.inv_mass]
        joints, start = [], 0
        for j in lean.effect.joints:
            a, b = j.a, (j.b if j.b >= 0 else None)
            ra0 = tuple(float(v) for v in j.anchor_a)
            rb0 = tuple(float(v) for v in j.anchor_b)
            hinge = j.kind == "hinge"
            axa = tuple(float(v) for v in j.axis_a) if hinge else None
            axb = tuple(float(v) for v in j.axis_b) if hinge else None
            joints.append((start, a, b, ra0, rb0, axa, axb))
            start += 5 if hinge else 3
        self.joints = joints

    def bodies(self, yl: list):
        """(R rows, ω, [I⁻¹_world (9N floats), then Q_gyro = (0, −ω × L) (6N floats)]) of every body at ``yl``."""
        N = self.N
        Rs, ws, Iw, gyro = [], [], [], []
        for n in range(N):
            R = _quat_rows(*yl[3 * N + 4 * n:3 * N + 4 * n + 4])
            r00, r01, r02, r10, r11, r12, r20, r21, r22 = R
            d0, d1, d2 = self.d[n]
            # I⁻¹_world = R diag(d) Rᵀ (symmetric: six products of rows)
            a0, a1, a2 = r00 * d0, r01 * d1, r02 * d2
            b0, b1, b2 = r10 * d0, r11 * d1, r12 * d2
            c0, c1, c2 = r20 * d0, r21 * d1, r22 * d2
            i00 = a0 * r00 + a1 * r01 + a2 * r02
            i01 = a0 * r10 + a1 * r11 + a2 * r12
            i02 = a0 * r20 + a1 * r21 + a2 * r22
            i11 = b0 * r10 + b1 * r11 + b2 * r12
            i12 = b0 * r20 + b1 * r21 + b2 * r22
            i22 = c0 * r20 + c1 * r21 + c2 * r22
            Lx, Ly, Lz = yl[10 * N + 3 * n:10 * N + 3 * n + 3]
            ox = i00 * Lx + i01 * Ly + i02 * Lz
            oy = i01 * Lx + i11 * Ly + i12 * Lz
            oz = i02 * Lx + i12 * Ly + i22 * Lz
            Rs.append(R)
            ws.append((ox, oy, oz))
            Iw += (i00, i01, i02, i01, i11, i12, i02, i12, i22)
            gyro += (0.0, 0.0, 0.0, oz * Ly - oy * Lz, ox * Lz - oz * Lx, oy * Lx - ox * Ly)
        return Rs, ws, Iw + gyro

    def rows(self, yl: list, Rs, ws, want_C: bool = False, want_Cdot: bool = False):
        """(J's angular values in LeanJoints' put order, J̇u, C or None, Ċ or None) at ``yl`` (k rows each).
        Ċ = J u: v_a + ω_a × r_a − v_b − ω_b × r_b for the ball rows, (tₖ × â_b)·(ω_a − ω_b) for the hinge's."""
        N = self.N
        bias = [0.0] * self.k
        C = [0.0] * self.k if want_C else None
        Cd = [0.0] * self.k if want_Cdot else None
        ball_a, ball_b, hinge_a, hinge_b = [], [], [], []
        zero = (0.0, 0.0, 0.0)
        im = self.inv_mass
        for start, a, b, ra0, rb0, axa, axb in self.joints:
            ra = Rs[a]
            wa = ws[a]
            rx = ra[0] * ra0[0] + ra[1] * ra0[1] + ra[2] * ra0[2]
            ry = ra[3] * ra0[0] + ra[4] * ra0[1] + ra[5] * ra0[2]
            rz = ra[6] * ra0[0] + ra[7] * ra0[1] + ra[8] * ra0[2]
            if b is None:
                rb, wb = None, zero
                sx, sy, sz = rb0
            else:
                rb, wb = Rs[b], ws[b]
                sx = rb[0] * rb0[0] + rb[1] * rb0[1] + rb[2] * rb0[2]
                sy = rb[3] * rb0[0] + rb[4] * rb0[1] + rb[5] * rb0[2]
                sz = rb[6] * rb0[0] + rb[7] * rb0[1] + rb[8] * rb0[2]
            ax_, ay_, az_ = wa
            bx_, by_, bz_ = wb
            wr, ww = ax_ * rx + ay_ * ry + az_ * rz, ax_ * ax_ + ay_ * ay_ + az_ * az_
            vr, vv = bx_ * sx + by_ * sy + bz_ * sz, bx_ * bx_ + by_ * by_ + bz_ * bz_
            bias[start] = (ax_ * wr - rx * ww) - (bx_ * vr - sx * vv)
            bias[start + 1] = (ay_ * wr - ry * ww) - (by_ * vr - sy * vv)
            bias[start + 2] = (az_ * wr - rz * ww) - (bz_ * vr - sz * vv)
            ball_a += (rz, -ry, -rz, rx, ry, -rx)
            ball_b += (-sz, sy, sz, -sx, -sy, sx)
            if want_C:
                xa = yl[3 * a:3 * a + 3]
                xb = yl[3 * b:3 * b + 3] if b is not None else zero
                C[start] = (xa[0] + rx) - (xb[0] + sx)
                C[start + 1] = (xa[1] + ry) - (xb[1] + sy)
                C[start + 2] = (xa[2] + rz) - (xb[2] + sz)
            if want_Cdot:
                pa = yl[7 * N + 3 * a:7 * N + 3 * a + 3]
                pb = yl[7 * N + 3 * b:7 * N + 3 * b + 3] if b is not None else zero
                mb = im[b] if b is not None else 0.0
                Cd[start] = (im[a] * pa[0] + (ay_ * rz - az_ * ry)) - (mb * pb[0] + (by_ * sz - bz_ * sy))
                Cd[start + 1] = (im[a] * pa[1] + (az_ * rx - ax_ * rz)) - (mb * pb[1] + (bz_ * sx - bx_ * sz))
                Cd[start + 2] = (im[a] * pa[2] + (ax_ * ry - ay_ * rx)) - (mb * pb[2] + (bx_ * sy - by_ * sx))
            if axa is None:
                continue
            # hinge: â_a, â_b, the tangents t₁, t₂ ⟂ â_a, gₖ = tₖ × â_b
            ux = ra[0] * axa[0] + ra[1] * axa[1] + ra[2] * axa[2]
            uy = ra[3] * axa[0] + ra[4] * axa[1] + ra[5] * axa[2]
            uz = ra[6] * axa[0] + ra[7] * axa[1] + ra[8] * axa[2]
            if rb is None:
                nx, ny, nz = axb
            else:
                nx = rb[0] * axb[0] + rb[1] * axb[1] + rb[2] * axb[2]
                ny = rb[3] * axb[0] + rb[4] * axb[1] + rb[5] * axb[2]
                nz = rb[6] * axb[0] + rb[7] * axb[1] + rb[8] * axb[2]
            if abs(ux) < 0.9:                       # e = x̂: t₁ = x̂ − u_x û
                t1x, t1y, t1z = 1.0 - ux * ux, -ux * uy, -ux * uz
            else:                                   # e = ŷ: t₁ = ŷ − u_y û
                t1x, t1y, t1z = -uy * ux, 1.0 - uy * uy, -uy * uz
            nt = sqrt(t1x * t1x + t1y * t1y + t1z * t1z)
            t1x, t1y, t1z = t1x / nt, t1y / nt, t1z / nt
            t2x, t2y, t2z = uy * t1z - uz * t1y, uz * t1x - ux * t1z, ux * t1y - uy * t1x
            g1 = (t1y * nz - t1z * ny, t1z * nx - t1x * nz, t1x * ny - t1y * nx)
            g2 = (t2y * nz - t2z * ny, t2z * nx - t2x * nz, t2x * ny - t2y * nx)
            hinge_a += g1 + g2
            hinge_b += (-g1[0], -g1[1], -g1[2], -g2[0], -g2[1], -g2[2])
            wan, wbn = ax_ * nx + ay_ * ny + az_ * nz, bx_ * nx + by_ * ny + bz_ * nz
            dx, dy, dz = ax_ - bx_, ay_ - by_, az_ - bz_
            dd = dx * dx + dy * dy + dz * dz
            for row, (tx, ty, tz), g in ((start + 3, (t1x, t1y, t1z), g1), (start + 4, (t2x, t2y, t2z), g2)):
                tab = tx * nx + ty * ny + tz * nz
                bias[row] = ((ax_ * tx + ay_ * ty + az_ * tz) * wan + (bx_ * tx + by_ * ty + bz_ * tz) * (wbn - 2.0 * wan)
                             - tab * dd)
                if want_C:
                    C[row] = tab
                if want_Cdot:
                    Cd[row] = g[0] * dx + g[1] * dy + g[2] * dz
        return ball_a + ball_b + hinge_a + hinge_b, bias, C, Cd
