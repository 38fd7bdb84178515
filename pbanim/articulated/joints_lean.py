"""The lean joint step: ball and hinge rows, J W Jᵀ, its factor and λ in preallocated arrays (chapter 08).

:meth:`pbanim.articulated.RigidJoints.constrain` (the readable path) evaluates the rows of the table in
:mod:`pbanim.articulated.joints` through :class:`~pbanim.articulated.joint_rows.JointRowPlan`, asks the
bodies for ω and for W, and builds J from zeros at every force evaluation: some three hundred numpy calls
on arrays of a few rows. For a scene whose joints are all ``ball`` or ``hinge`` (no limits, no motors, the
dense solver) this module computes the same multipliers with everything that does not change during a run
laid out once, at ``bind``:

* J's sparsity is fixed: a ball row is [1, −[r_a]×] on body a and [−1, [r_b]×] on body b, a hinge row
  [0, t_k × â_b] and its negative. The linear blocks (±1, 0) are written once into a buffer J (k, N + 1, 6)
  (the last body block is the world's, never read); a step writes only the angular entries, by one
  ``np.put`` per kind at precomputed flat indices;
* R = R(q) is the formula of :func:`pbanim.rigid.quat_to_matrix` with the products (s q_i) q_j of one outer
  product (the same products, the same sums: the same bits), written into the rows of a padded buffer whose
  last entry is the world's identity; I⁻¹_world = R I⁻¹_body Rᵀ and ω = R (I⁻¹_body (Rᵀ L)) as the bodies
  compute them;
* r = R r⁰ for both sides of every joint by one ``einsum`` on the stacked sides; the ball rows' J̇u =
  ω_a × (ω_a × r_a) − ω_b × (ω_b × r_b) by the cross product's components;
* the hinge rows' J̇u written with dot products only (Lagrange's a × (b × c) = b (a·c) − c (a·b) and
  Binet–Cauchy (a × b)·(c × d) = (a·c)(b·d) − (a·d)(b·c)):

      J̇u = (ω_a·t)(ω_a·â_b) + (ω_b·t)(ω_b·â_b) − 2 (ω_a·â_b)(ω_b·t) − (t·â_b) |ω_a − ω_b|²,

  the three cross-product terms of the readable form regrouped (equal to roundoff, not bit for bit);
* J W Jᵀ by the blocks W_n = diag(1/m_n, I⁻¹_world,n) (one ``einsum``), its Cholesky factor by LAPACK and the
  same refusal rule as the readable path (κ estimated above 10¹⁰: handed back), λ, and Q + Jᵀλ.

A step the factor refuses (dependent rows: a closed loop), or whose system is not finite, returns None and
the readable path decides (least squares, or the named error). Equal to the readable path to roundoff
(``tests/test_joints_lean_path.py``, ORACLES I11); ``joints.lean_path = False`` runs the readable one.

=========================  ==============================  =================================
symbol                     code                            shape
=========================  ==============================  =================================
R, I⁻¹_world, ω            ``Rw[:N]``, ``Iw``, ``w``       (N, 3, 3), (N, 3, 3), (N, 3)
r_a, r_b (stacked)         ``r``                           (2m, 3): sides a then b
J, J̇u, W                   ``self._J``, ``bias``, ``Wb``   (k, N + 1, 6), (k,), (N, 6, 6)
=========================  ==============================  =================================
"""

from __future__ import annotations

import numpy as np
from scipy.linalg.lapack import dpotrf as _potrf, dpotrs as _potrs

from ..contracts import Obj, contract, package_code

__all__ = ["lean_joints"]

_P1 = np.array([1, 2, 0])            # (a × b)_i = a_P1 b_P2 − a_P2 b_P1, the order of pbanim.geometry.cross
_P2 = np.array([2, 0, 1])
# R(q) from P_ij = (s q_i) q_j (flattened 4×4): entry e = (c_e + s1_e P[i1_e]) + s2_e P[i2_e], the sums of
# pbanim.rigid.quat._matrices ((1 − yy) − zz, xy − wz, …) with the same operands in the same order
_R_I = np.array([10, 6, 7, 6, 5, 11, 7, 11, 5, 15, 3, 2, 3, 15, 1, 2, 1, 10])
_R_S = np.array([-1.0, 1, 1, 1, -1, 1, 1, 1, -1, -1, -1, 1, 1, -1, -1, -1, 1, -1])
_R_C = np.array([1.0, 0, 0, 0, 1, 0, 0, 0, 1])
_EX_EY = np.array([[0.0, 1.0, 0.0], [1.0, 0.0, 0.0]])    # tangent_basis's reference: y where |n_x| ≥ 0.9, else x
# the rows r × e_k of a ball row's angular block: entries (0,1) r_z, (0,2) −r_y, (1,0) −r_z, (1,2) r_x, (2,0) r_y,
# (2,1) −r_x (the zeros of the diagonal stay the buffer's zeros)
_AX_SRC = np.array([2, 1, 2, 0, 1, 0])
_AX_SGN = np.array([1.0, -1.0, -1.0, 1.0, 1.0, -1.0])
_AX_ROW = np.array([0, 0, 1, 1, 2, 2])
_AX_COL = np.array([1, 2, 0, 2, 0, 1])


def _cross(a, b):
    """a × b on the last axis (broadcasting), the components of :func:`pbanim.geometry.cross` (same bits)."""
    return a.take(_P1, -1) * b.take(_P2, -1) - a.take(_P2, -1) * b.take(_P1, -1)


def _dot(a, b):
    return np.einsum("...i,...i->...", a, b)


@contract(joints=Obj("pbanim.articulated.joints:RigidJoints"))
def lean_joints(joints) -> "LeanJoints | None":
    """The lean plan of bound :class:`~pbanim.articulated.RigidJoints`, or None when they do not qualify (a
    slider or weld, limits, motors, or a system or joints class whose methods are not the package's own);
    built once, at ``bind``.

    >>> from pbanim.models.articulated import rod_chain
    >>> scene, rb, _ = rod_chain(3)
    >>> j = [e for e in scene.effects if e.name == "joints"][0]
    >>> lean_joints(j) is not None
    True
    """
    s = getattr(joints, "system", None)
    if s is None or any(j.kind not in ("ball", "hinge") for j in joints.joints):
        return None
    if joints._motored or joints._unilateral:
        return None
    from ..rigid.bodies import RigidBodies

    if not isinstance(s, RigidBodies) or not package_code(s, "velocities", "inverse_mass_blocks",
                                                           "inv_inertia_world", "unpack"):
        return None
    if not package_code(joints, "constrain", "_free_acceleration", "rows", "_constrain_dense"):
        return None
    return LeanJoints(joints)


class LeanJoints:
    """The multiplier solve of ball and hinge joints on preallocated arrays (see the module docstring)."""

    #: False: the array rows even where the float rows of :mod:`.joints_float` qualify
    floats = True

    def __init__(self, joints) -> None:
        s = joints.system
        js = joints.joints
        N, m = s.N, len(js)
        self.effect, self.N, self.m = joints, N, m
        width = [3 if j.kind == "ball" else 5 for j in js]
        start = np.cumsum([0] + width)[:-1]
        k = self.k = int(sum(width))
        A = np.array([j.a if j.a >= 0 else N for j in js], dtype=np.intp)
        B = np.array([j.b if j.b >= 0 else N for j in js], dtype=np.intp)
        self.AB = np.concatenate([A, B])
        self.anchors = np.array([j.anchor_a for j in js] + [j.anchor_b for j in js], dtype=float)
        H = np.array([i for i, j in enumerate(js) if j.kind == "hinge"], dtype=np.intp)
        self.mh = H.size
        self.ABh = np.concatenate([A[H], B[H]])
        self.axes = np.array([js[i].axis_a for i in H] + [js[i].axis_b for i in H], dtype=float).reshape(-1, 3)
        # buffers: padded bodies (index N: the world), J with its fixed linear blocks
        self.Rw = np.zeros((N + 1, 3, 3))
        self.Rw[N] = np.eye(3)
        self.ww = np.zeros((N + 1, 3))
        self.xw = np.zeros((N + 1, 3))
        J = self._J = np.zeros((k, N + 1, 6))
        ball_rows = (start[:, None] + np.arange(3)).ravel()              # (3m,)
        J[ball_rows, np.repeat(A, 3), np.tile(np.arange(3), m)] = 1.0
        J[ball_rows, np.repeat(B, 3), np.tile(np.arange(3), m)] = -1.0
        self.Jv = J[:, :N].reshape(k, 6 * N)                              # a view: the world block dropped
        flat = lambda rows, body, col: (rows * (N + 1) + body) * 6 + col  # noqa: E731
        # ball rows' angular entries: joint i, side s, entry e → J[start_i + row_e, body, 3 + col_e]
        rows_b = start[:, None] + _AX_ROW                                 # (m, 6)
        self._ball_idx = np.concatenate([flat(rows_b, A[:, None], 3 + _AX_COL),
                                         flat(rows_b, B[:, None], 3 + _AX_COL)]).ravel()
        self._ball_sgn = np.concatenate([np.tile(_AX_SGN, (m, 1)), -np.tile(_AX_SGN, (m, 1))])   # b: −G_b
        self.ball_rows = (start[:, None] + np.arange(3)).ravel()
        hrows = (start[H][:, None] + 3 + np.arange(2))                    # (mh, 2)
        cols = 3 + np.arange(3)
        self._hinge_idx = np.concatenate([flat(hrows[:, :, None], A[H][:, None, None], cols),
                                          flat(hrows[:, :, None], B[H][:, None, None], cols)]).ravel()
        self.hinge_rows = hrows.ravel()
        self.bias = np.zeros(k)
        self.Cbuf = np.zeros(k)
        self.Wb = np.zeros((N, 6, 6))
        self.Wb[:, :3, :3] = s.inv_mass[:, None, None] * np.eye(3)
        self.inv_I = s.inv_I_body * s._dyn[:, :, None]        # a static body: 0 (R 0 Rᵀ = 0 = I⁻¹_world·0)
        self.inv_I_b = s.inv_I_body
        self.dyn = s._dyn
        self.any_static = bool(s.static.any())
        self.inv_mass = s.inv_mass[:, None]
        # the float rows of a small scene (joints_float): W as one (6N, 6N) block diagonal whose angular blocks
        # are a strided view, J's angular entries by one put
        from .joints_float import float_rows

        self._all_idx = np.concatenate([self._ball_idx, self._hinge_idx])
        W = self._W = np.zeros((6 * N, 6 * N))
        W[np.arange(6 * N), np.arange(6 * N)] = np.repeat(s.inv_mass, 6)
        self._W_ang = np.lib.stride_tricks.as_strided(W[3:, 3:], shape=(N, 3, 3), strides=(
            (6 * N + 1) * 6 * W.itemsize, 6 * N * W.itemsize, W.itemsize))
        self._float = float_rows(self)

    def rotations(self, q: np.ndarray) -> np.ndarray:
        """R(q) of every body into the padded buffer's first N entries (see the module docstring)."""
        N = self.N
        sq = (2.0 / np.einsum("ni,ni->n", q, q))[:, None] * q
        P = (sq[:, :, None] * q[:, None, :]).reshape(N, 16)[:, _R_I] * _R_S
        R9 = self.Rw[:N].reshape(N, 9)
        np.add(_R_C + P[:, :9], P[:, 9:], out=R9)
        return self.Rw[:N]

    def state(self, y: np.ndarray):
        """(R, I⁻¹_world, ω, L) at y; fills the padded R and ω buffers."""
        N = self.N
        L = y[10 * N:].reshape(N, 3, 1)
        R = self.rotations(y[3 * N:7 * N].reshape(N, 4))
        RT = R.transpose(0, 2, 1)
        Iw = R @ self.inv_I_b @ RT
        w = (R @ (self.inv_I_b @ (RT @ L)))[..., 0]          # ω = R (I⁻¹_body (Rᵀ L)), as the bodies compute it
        self.ww[:N] = w
        return R, Iw, w, L[..., 0]

    def rows(self, y: np.ndarray):
        """(I⁻¹_world, ω, L, r, t·â_b) at y; fills J's angular entries and J̇u (``self.bias``)."""
        m, mh = self.m, self.mh
        R, Iw, w, L = self.state(y)
        Rw, ww = self.Rw, self.ww
        r = (Rw.take(self.AB, 0) @ self.anchors[:, :, None])[..., 0]       # r_a (first m), then r_b
        wab = ww.take(self.AB, 0)
        acc = wab * _dot(wab, r)[:, None] - r * _dot(wab, wab)[:, None]     # ω × (ω × r) = ω (ω·r) − r |ω|²
        bias = self.bias
        np.put(bias, self.ball_rows, acc[:m] - acc[m:])
        np.put(self._J, self._ball_idx, r.take(_AX_SRC, 1) * self._ball_sgn)
        tab = None
        if mh:
            ax = (Rw.take(self.ABh, 0) @ self.axes[:, :, None])[..., 0]
            aa, ab = ax[:mh], ax[mh:]
            ref = _EX_EY.take((np.abs(aa[:, 0]) < 0.9).view(np.int8), 0)
            t1 = ref - _dot(ref, aa)[:, None] * aa
            t1 /= np.sqrt(_dot(t1, t1))[:, None]
            T = np.concatenate([t1, _cross(aa, t1)], axis=1).reshape(mh, 2, 3)   # t₁, t₂ = â_a × t₁
            ab1 = ab[:, None, :]
            gab = _cross(T, ab1)                                            # (mh, 2, 3): t_k × â_b
            np.put(self._J, self._hinge_idx, np.concatenate([gab, -gab]))
            wh = ww.take(self.ABh, 0).reshape(2, mh, 1, 3)                 # ω_a, ω_b of the hinges
            tw = _dot(T, wh)                                                # ω_a·t, ω_b·t   (2, mh, 2)
            wb_ = _dot(wh, ab1)                                             # ω_a·â_b, ω_b·â_b (2, mh, 1)
            tab = _dot(T, ab1)                                              # t·â_b (= C of the hinge rows)
            dw = wh[0] - wh[1]
            np.put(bias, self.hinge_rows, tw[0] * wb_[0] + tw[1] * (wb_[1] - 2.0 * wb_[0]) - tab * _dot(dw, dw))
        return Iw, w, L, r, tab

    def constraint_values(self, y: np.ndarray, r, tab) -> np.ndarray:
        """C of every row at y (after :meth:`rows` at the same y): p_a − p_b, then t_k·â_b."""
        C, N = self.Cbuf, self.N
        self.xw[:N] = y[:3 * N].reshape(N, 3)
        p = self.xw.take(self.AB, 0) + r
        np.put(C, self.ball_rows, p[:self.m] - p[self.m:])
        if self.mh:
            np.put(C, self.hinge_rows, tab)
        return C

    def errors(self, y: np.ndarray):
        """(C, Ċ = J u) at y: the joints' drift and its rate (what their diagnostics report)."""
        if self._float is not None and self.floats:
            return self._errors_floats(y)
        N = self.N
        _, w, _, r, tab = self.rows(y)
        u = np.concatenate([self.inv_mass * y[7 * N:10 * N].reshape(N, 3), w], axis=1)
        return self.constraint_values(y, r, tab), self.Jv @ u.ravel()

    def _errors_floats(self, y: np.ndarray):
        fr = self._float
        yl = y.tolist()
        Rs, ws, _ = fr.bodies(yl)
        _, _, C, Cd = fr.rows(yl, Rs, ws, True, True)
        return np.array(C, dtype=float), np.array(Cd, dtype=float)

    def _constrain_floats(self, y: np.ndarray, Q: np.ndarray):
        """:meth:`constrain` with the rows on floats (:mod:`.joints_float`) and W Jᵀ by one product."""
        fr, N, Jv, k = self._float, self.N, self.Jv, self.k
        yl = y.tolist()
        Rs, ws, per_body = fr.bodies(yl)
        ks, kd = self.effect.ks, self.effect.kd           # read at each call: a caller may retune them
        vals, bias, C, Cd = fr.rows(yl, Rs, ws, bool(ks), bool(kd))
        nv = len(vals)
        arr = np.array(vals + per_body + bias + (C or []) + (Cd or []), dtype=float)   # one conversion, then views
        np.put(self._J, self._all_idx, arr[:nv])
        self._W_ang[...] = arr[nv:nv + 9 * N].reshape(N, 3, 3)
        JW = Jv @ self._W
        A = JW @ Jv.T
        Qg = arr[nv + 9 * N:nv + 15 * N]
        Qg += Q.ravel()                                    # Q + Q_gyro, Q_gyro = (0, −ω × L)
        rhs = JW @ Qg
        rhs += arr[nv + 15 * N:nv + 15 * N + k]
        np.negative(rhs, out=rhs)                          # −J̇u − J W (Q + Q_gyro)
        at = nv + 15 * N + k
        if ks:
            rhs -= ks * arr[at:at + k]
            at += k
        if kd:
            rhs -= kd * arr[at:at + k]                     # Ċ = J u
        c, info = _potrf(A, lower=False, clean=False)
        if info != 0:
            return None
        d = c.diagonal().tolist()                          # positive where the factor succeeded
        if not min(d) > 1e-5 * max(d):                     # the readable path's rule (joints._spd_solve)
            return None
        lam = _potrs(c, rhs)[0]
        check = float(lam @ lam)
        if check - check != 0.0:                           # not finite: the readable path names it
            return None
        self.effect.last_lambda = lam
        return Q + (lam @ Jv).reshape(N, 6)

    def constrain(self, y: np.ndarray, Q: np.ndarray):
        """Q + Jᵀλ (and ``last_lambda`` set on the joints), or None where the readable path must decide."""
        if self._float is not None and self.floats:
            return self._constrain_floats(y, Q)
        N, k = self.N, self.k
        Iw, w, L, r, tab = self.rows(y)
        Jv, Wb = self.Jv, self.Wb
        Wb[:, 3:, 3:] = Iw * self.dyn[:, :, None] if self.any_static else Iw
        WJt = (Jv.reshape(k, N, 6).transpose(1, 0, 2) @ Wb).transpose(1, 0, 2).reshape(k, 6 * N)   # (W Jᵀ)ᵀ
        A = Jv @ WJt.T
        gyro = _cross(w, L)
        if self.any_static:
            gyro = gyro * self.dyn
        Qg = Q.copy()
        Qg[:, 3:] -= gyro                                    # Q + Q_gyro, Q_gyro = (0, −ω × L)
        rhs = -self.bias - Jv @ (Wb @ Qg[:, :, None]).ravel()
        ks, kd = self.effect.ks, self.effect.kd           # read at each call: a caller may retune them
        if ks:
            rhs -= ks * self.constraint_values(y, r, tab)
        if kd:
            u = np.concatenate([self.inv_mass * y[7 * N:10 * N].reshape(N, 3), w], axis=1)
            rhs -= kd * (Jv @ u.ravel())                 # Ċ = J u
        check = float(A.sum()) + float(rhs.sum())
        if check - check != 0.0:                        # not finite: the readable path names it
            return None
        c, info = _potrf(A, lower=False, clean=False)
        if info != 0:
            return None
        d = np.abs(np.diagonal(c))
        if not d.min() > 1e-5 * d.max():                 # the readable path's rule (joints._spd_solve)
            return None
        lam = _potrs(c, rhs)[0]
        self.effect.last_lambda = lam
        return Q + (Jv.T @ lam).reshape(N, 6)
