"""The rigid bodies' right-hand side on Python floats, for a few bodies (chapter 05, part of :mod:`pbanim.rigid`).

:meth:`pbanim.rigid.RigidBodies.derivative` evaluates, for every body i at once,

    Rᵢ = R(qᵢ) (s = 2/|qᵢ|², the formula of :func:`pbanim.rigid.quat_to_matrix`),   ωᵢ = Rᵢ (I⁻¹_body,i (Rᵢᵀ Lᵢ)),
    ẋᵢ = Wᵢ Pᵢ,   q̇ᵢ = ½ (0, ωᵢ) ⊗ qᵢ,   Ṗᵢ = Fᵢ,   L̇ᵢ = τᵢ      (F, τ zeroed on a static body),

with some twenty numpy calls on arrays of a few rows: for the handful of bodies of a chain or a stack, about a
microsecond each of dispatch for nanoseconds of arithmetic. :func:`derivative_floats` computes the same
quantities body by body on Python floats, with the same products in the same order as the vectorized code
(its ``einsum`` contractions over a contiguous row sum the products in the order (0 + p₀ + p₂) + p₁ for three
terms and (p₀ + p₂) + (p₁ + p₃) for four, as numpy's two-lane inner loop does; over a column, Rᵀ L, in turn
from +0, so a zero keeps its sign), so on this package's numpy the results
are equal bit for bit; on any other build they agree to a few ulps of each product's size
(``tests/test_rigid_derivative_float.py``, ORACLES C5).

When: :meth:`RigidBodies.derivative` takes this path for at most :data:`FLOAT_MAX_BODIES` bodies when the
class's ``derivative`` and ``derivative_and_omega`` are the package's own code (a course assignment's copy or a
user's subclass runs what it wrote) and ``lean_path`` is true; ``rb.lean_path = False`` runs the vectorized
one. Limits: the quaternions of a run (|q|² neither overflows nor underflows, as for
:func:`pbanim.rigid.quat._matrices`); a zero quaternion divides by zero and is handed to the vectorized path.
The post-step stage q ← q/|q| of :class:`pbanim.rigid.QuaternionRenormalize` has its float twin here too,
:func:`renormalize_floats` (|q|² summed in turn, as ``np.sum`` over a row of four does); a |q|² within a factor
of 2 of the range where :func:`pbanim.rigid.domain.tame` rescales (or NaN) hands the step to the arrays.
Reference: Baraff, *Physically Based Modeling: Rigid Body Simulation* (SIGGRAPH 1997 notes) §§2–5.
"""

from __future__ import annotations

from math import sqrt

import numpy as np

from .domain import _SAFE

#: Up to this many bodies the right-hand side runs on floats: the float loop costs a few µs per body, the
#: vectorized one about 40 µs whatever N (measured: a 3-rod chain's RK4 stage).
FLOAT_MAX_BODIES = 8


def derivative_floats(rb, y: np.ndarray, Q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(ẏ, ω) of :meth:`pbanim.rigid.RigidBodies.derivative_and_omega` on floats (see the module docstring);
    ``y`` the flat state (13N,), ``Q`` the forces (N, 6). Raises ZeroDivisionError for a zero quaternion."""
    N = rb.N
    yl = y.tolist()
    Ql = np.asarray(Q, dtype=float).reshape(6 * N).tolist()
    W = rb.inv_mass.tolist()
    A = rb.inv_I_body.reshape(N, 9).tolist()
    dyn = rb._dyn[:, 0].tolist() if rb._any_static else None
    dx, dq, dF, dT, om = [], [], [], [], []
    for i in range(N):
        q0, q1, q2, q3 = yl[3 * N + 4 * i: 3 * N + 4 * i + 4]
        p0, p1, p2 = yl[7 * N + 3 * i: 7 * N + 3 * i + 3]
        l0, l1, l2 = yl[10 * N + 3 * i: 10 * N + 3 * i + 3]
        s = 2.0 / ((q0 * q0 + q2 * q2) + (q1 * q1 + q3 * q3))
        xx, yy, zz = s * q1 * q1, s * q2 * q2, s * q3 * q3
        xy, xz, yz = s * q1 * q2, s * q1 * q3, s * q2 * q3
        wx, wy, wz = s * q0 * q1, s * q0 * q2, s * q0 * q3
        r00, r01, r02 = 1.0 - yy - zz, xy - wz, xz + wy
        r10, r11, r12 = xy + wz, 1.0 - xx - zz, yz - wx
        r20, r21, r22 = xz - wy, yz + wx, 1.0 - xx - yy
        u0 = 0.0 + r00 * l0 + r10 * l1 + r20 * l2              # Rᵀ L
        u1 = 0.0 + r01 * l0 + r11 * l1 + r21 * l2
        u2 = 0.0 + r02 * l0 + r12 * l1 + r22 * l2
        a00, a01, a02, a10, a11, a12, a20, a21, a22 = A[i]
        v0 = (0.0 + a00 * u0 + a02 * u2) + a01 * u1            # I⁻¹_body Rᵀ L
        v1 = (0.0 + a10 * u0 + a12 * u2) + a11 * u1
        v2 = (0.0 + a20 * u0 + a22 * u2) + a21 * u1
        w0 = (0.0 + r00 * v0 + r02 * v2) + r01 * v1             # ω = R I⁻¹_body Rᵀ L
        w1 = (0.0 + r10 * v0 + r12 * v2) + r11 * v1
        w2 = (0.0 + r20 * v0 + r22 * v2) + r21 * v1
        m = W[i]
        dx += (p0 * m, p1 * m, p2 * m)
        dq += (-0.5 * (w0 * q1 + w1 * q2 + w2 * q3), 0.5 * (w0 * q0 + w1 * q3 - w2 * q2),
               0.5 * (w1 * q0 + w2 * q1 - w0 * q3), 0.5 * (w2 * q0 + w0 * q2 - w1 * q1))
        f = Ql[6 * i: 6 * i + 6]
        if dyn is not None:
            d = dyn[i]
            f = [c * d for c in f]
        dF += f[:3]
        dT += f[3:]
        om += (w0, w1, w2)
    return np.array(dx + dq + dF + dT), np.array(om).reshape(N, 3)


_LO, _HI = 2.0 * _SAFE[0], 0.5 * _SAFE[1]        # |q|² here: tame() leaves every q as it is


def renormalize_floats(y: np.ndarray, N: int) -> bool:
    """q ← q/|q| of every body, in place in the flat state ``y`` (13N,), on floats; False (``y`` untouched) when
    a |q|² is near the rescaling range of :func:`pbanim.rigid.domain.tame` or not a number."""
    q = y[3 * N:7 * N].tolist()
    out = []
    for i in range(N):
        a, b, c, d = q[4 * i: 4 * i + 4]
        n2 = a * a + b * b + c * c + d * d
        if not _LO < n2 < _HI:
            return False
        s = sqrt(n2)
        out += (a / s, b / s, c / s, d / s)
    y[3 * N:7 * N] = out
    return True
