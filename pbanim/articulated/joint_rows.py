"""The joint rows of :class:`~pbanim.articulated.RigidJoints`, all joints at once (chapter 08).

The rows are those of the table in :mod:`pbanim.articulated.joints` (C, J, J̇u per row, rows of one joint
together, joints in order); this module evaluates them kind by kind over arrays of joints instead of
one joint and one row at a time. Everything that depends only on the joints — which body each row
touches, the row offsets of each kind, the anchors and axes stacked — is laid out once, when the
joints are bound to their bodies (:class:`JointRowPlan`); a force evaluation then costs a fixed
number of array operations whatever the number of joints.

With anchors r = R r⁰ and world points p = x + r of bodies a and b (b = −1: the world, x = 0, R = 1):

* ball rows (ball, hinge, weld): C = p_a − p_b, J_a = [1, −[r_a]×] (row k: [e_k, r_a × e_k]),
  J̇u = ω_a × (ω_a × r_a) − ω_b × (ω_b × r_b);
* hinge rows: C = t_k·â_b with t₁, t₂ ⟂ â_a (:func:`pbanim.geometry.tangent_basis`), J = [0, t_k × â_b];
* rotation rows (slider, weld): C = 2 sign(w) R_b vec(q_b⁻¹ q_a q₀⁻¹), J = [0, e_k];
* slide rows: C = t_k·d, d = p_a − p_b, t_k ⟂ â_b; J_a = [t_k, r_a × t_k], J_b = [t_k, r_b × t_k − t_k × d].
"""

from __future__ import annotations

import numpy as np

from ..contracts import unchecked
from ..geometry import cross as _cross, tangent_basis as _tangent_basis
from ..rigid.quat import quat_conjugate as _conj, quat_multiply as _qmul, quat_to_matrix as _q2m

__all__ = ["JointRowPlan", "ROWS_PER_JOINT"]

ROWS_PER_JOINT = {"ball": 3, "hinge": 5, "slider": 5, "weld": 6}

cross, tangent_basis = unchecked(_cross), unchecked(_tangent_basis)
quat_conjugate, quat_multiply, quat_to_matrix = unchecked(_conj), unchecked(_qmul), unchecked(_q2m)
_EYE = np.eye(3)


def _dot(a, b):
    return np.einsum("...i,...i->...", a, b)


def _cx(a, b):
    """a × b for float arrays (..., 3) of one shape, or broadcasting on the leading axes: the components of
    :func:`pbanim.geometry.cross` in the same order (the same bits), without its conversions (hot path)."""
    a0, a1, a2 = a[..., 0], a[..., 1], a[..., 2]
    b0, b1, b2 = b[..., 0], b[..., 1], b[..., 2]
    out = np.empty(a.shape if a.shape == b.shape else np.broadcast_shapes(a.shape, b.shape))
    out[..., 0] = a1 * b2 - a2 * b1
    out[..., 1] = a2 * b0 - a0 * b2
    out[..., 2] = a0 * b1 - a1 * b0
    return out


def _cx_axes(r):
    """The rows r × e_k, k = 1..3, of each r (m, 3), as (m, 3, 3): what ``cross(r[:, None, :], 1)`` gives,
    each entry written out (r × e_x = (0, r_z, −r_y), …; the products by 0 and 1 dropped, equal values)."""
    out = np.zeros(r.shape[:-1] + (3, 3))
    out[..., 0, 1], out[..., 0, 2] = r[..., 2], -r[..., 1]
    out[..., 1, 0], out[..., 1, 2] = -r[..., 2], r[..., 0]
    out[..., 2, 0], out[..., 2, 1] = r[..., 1], -r[..., 0]
    return out


class JointRowPlan:
    """The layout of the rows of ``joints`` (a list of :class:`RigidJoint`) on ``N`` bodies, and their
    evaluation at a state (:meth:`evaluate`)."""

    def __init__(self, joints, N: int, qrel0) -> None:
        self.N = N
        kinds = [j.kind for j in joints]
        start = np.cumsum([0] + [ROWS_PER_JOINT[k] for k in kinds])
        self.k = int(start[-1])
        self.A = np.array([j.a for j in joints], dtype=int)      # −1 picks the world (the last padded entry)
        self.B = np.array([j.b for j in joints], dtype=int)
        self.anchor_a = np.array([j.anchor_a for j in joints], dtype=float).reshape(-1, 3)
        self.anchor_b = np.array([j.anchor_b for j in joints], dtype=float).reshape(-1, 3)
        self.axis_a = np.array([j.axis_a for j in joints], dtype=float).reshape(-1, 3)
        self.axis_b = np.array([j.axis_b for j in joints], dtype=float).reshape(-1, 3)
        self.qrel0_conj = quat_conjugate(np.array(qrel0, dtype=float).reshape(-1, 4))
        pick = lambda names: np.array([i for i, k in enumerate(kinds) if k in names], dtype=int)  # noqa: E731
        first = start[:-1]
        self.ball = pick(("ball", "hinge", "weld"))
        self.hinge = pick(("hinge",))
        self.rot = pick(("slider", "weld"))
        self.slide = pick(("slider",))
        # the rows of each group, (joints, rows of each joint)
        self.ball_rows = first[self.ball][:, None] + np.arange(3)
        self.hinge_rows = first[self.hinge][:, None] + np.arange(3, 5)
        rot_first = first[self.rot] + np.where(np.array(kinds, dtype=object)[self.rot] == "weld", 3, 0)
        self.rot_rows = rot_first.astype(int)[:, None] + np.arange(3)
        self.slide_rows = first[self.slide][:, None] + np.arange(3, 5)
        # the body of each row on side a and side b, and J's nonzero entries (a row touches ≤ 2 bodies)
        joint_of_row = np.repeat(np.arange(len(kinds)), np.diff(start))
        self.row_a, self.row_b = self.A[joint_of_row], self.B[joint_of_row]
        rows = np.arange(self.k)
        cols = lambda body: 6 * np.where(body < 0, N, body)[:, None] + np.arange(6)  # noqa: E731
        self._dense_a = (rows[:, None], cols(self.row_a))
        self._dense_b = (rows[:, None], cols(self.row_b))
        keep_a, keep_b = self.row_a >= 0, self.row_b >= 0
        self._sparse_rows = np.concatenate([np.repeat(rows[keep_a], 6), np.repeat(rows[keep_b], 6)])
        self._sparse_cols = np.concatenate([cols(self.row_a)[keep_a].ravel(), cols(self.row_b)[keep_b].ravel()])
        self._keep_a, self._keep_b = keep_a, keep_b

    def evaluate(self, system, y: np.ndarray, sparse: bool = False, velocities=None):
        """(C (k,), J (k, 6N) dense or CSR, J̇u (k,), Ċ = J u (k,)) at state y of ``system`` (``velocities``:
        its (v, ω) at y when the caller has them)."""
        N, k = self.N, self.k
        x, q, _, _ = system.unpack(y)
        v, w = system.velocities(y) if velocities is None else velocities
        R = quat_to_matrix(q)
        xw, vw, ww = (np.vstack([arr, np.zeros(3)]) for arr in (x, v, w))
        Rw = np.concatenate([R, _EYE[None]])
        A, B = self.A, self.B
        RA, RB = Rw[A], Rw[B]
        ra, rb = np.einsum("mij,mj->mi", RA, self.anchor_a), np.einsum("mij,mj->mi", RB, self.anchor_b)
        pa, pb = xw[A] + ra, xw[B] + rb
        wa, wb = ww[A], ww[B]
        C, bias = np.zeros(k), np.zeros(k)
        Ga, Gb = np.zeros((k, 6)), np.zeros((k, 6))          # each row's 6-vectors on body a and on body b
        if self.ball.size:
            g, rows = self.ball, self.ball_rows
            acc = _cx(wa[g], _cx(wa[g], ra[g])) - _cx(wb[g], _cx(wb[g], rb[g]))
            Ga[rows, :3] = _EYE
            Gb[rows, :3] = _EYE
            Ga[rows, 3:] = _cx_axes(ra[g])
            Gb[rows, 3:] = _cx_axes(rb[g])
            C[rows], bias[rows] = (pa - pb)[g], acc
        if self.hinge.size:
            g, rows = self.hinge, self.hinge_rows
            aa = np.einsum("mij,mj->mi", RA[g], self.axis_a[g])
            ab = np.einsum("mij,mj->mi", RB[g], self.axis_b[g])[:, None, :]
            T = np.stack(tangent_basis(aa), axis=1)                        # (m, 2, 3)
            wag, wbg = wa[g][:, None, :], wb[g][:, None, :]
            gab = _cx(T, ab)
            Ga[rows, 3:] = gab
            Gb[rows, 3:] = gab
            wat = _cx(wag, T)
            C[rows] = _dot(T, ab)
            bias[rows] = _dot(_cx(wag, wat), ab) + 2 * _dot(wat, _cx(wbg, ab)) \
                + _dot(T, _cx(wbg, _cx(wbg, ab)))
        if self.rot.size:
            g, rows = self.rot, self.rot_rows
            qw = np.vstack([q, [1.0, 0, 0, 0]])
            qrel = quat_multiply(quat_conjugate(qw[B[g]]), quat_multiply(qw[A[g]], self.qrel0_conj[g]))
            sign = np.where(qrel[:, 0] != 0, np.sign(qrel[:, 0]), 1.0)
            C[rows] = 2.0 * sign[:, None] * np.einsum("mij,mj->mi", RB[g], qrel[:, 1:])
            Ga[rows, 3:] = _EYE
            Gb[rows, 3:] = _EYE
        if self.slide.size:
            g, rows = self.slide, self.slide_rows
            ab = np.einsum("mij,mj->mi", RB[g], self.axis_b[g])
            T = np.stack(tangent_basis(ab), axis=1)                        # (m, 2, 3)
            rag, rbg, wag, wbg = ra[g][:, None, :], rb[g][:, None, :], wa[g], wb[g]
            d = (pa - pb)[g][:, None, :]
            dd = ((vw[A] + _cx(wa, ra)) - (vw[B] + _cx(wb, rb)))[g][:, None, :]
            acc = (_cx(wag, _cx(wag, ra[g])) - _cx(wbg, _cx(wbg, rb[g])))[:, None, :]
            wbt = _cx(wbg[:, None, :], T)
            Ga[rows, :3], Ga[rows, 3:] = T, _cx(rag, T)
            Gb[rows, :3], Gb[rows, 3:] = T, _cx(rbg, T) - _cx(T, d)
            C[rows] = _dot(T, d)
            bias[rows] = _dot(T, acc) + 2 * _dot(wbt, dd) + _dot(_cx(wbg[:, None, :], wbt), d)
        u = np.hstack([v, w]).ravel()
        if sparse:
            import scipy.sparse as sp

            vals = np.concatenate([Ga[self._keep_a].ravel(), -Gb[self._keep_b].ravel()])
            J = sp.csr_matrix((vals, (self._sparse_rows, self._sparse_cols)), shape=(k, 6 * N))  # a = b: summed
            return C, J, bias, J @ u
        J = np.zeros((k, 6 * (N + 1)))
        J[self._dense_a] += Ga
        J[self._dense_b] -= Gb
        J = np.ascontiguousarray(J[:, :6 * N])
        return C, J, bias, J @ u


def _rows_one_by_one(joints, y: np.ndarray, sparse: bool = False):
    """The readable form of :meth:`JointRowPlan.evaluate`: one joint and one row at a time, straight from
    the table (the reference the array form is tested equal to, to roundoff; ``joints``: a bound
    :class:`~pbanim.articulated.RigidJoints`)."""
    s = joints.system
    N = s.N
    x, q, _, _ = s.unpack(y)
    v, w = s.velocities(y)
    R = quat_to_matrix(q)
    xw, Rw = np.vstack([x, np.zeros(3)]), np.concatenate([R, np.eye(3)[None]])
    vw, ww, qw = np.vstack([v, np.zeros(3)]), np.vstack([w, np.zeros(3)]), np.vstack([q, [1.0, 0, 0, 0]])
    C, bias = [], []
    ri, ci, vals = [], [], []                # J in coordinate form: each row touches ≤ 2 bodies

    def row(ja, jb, a, b, c, jdot):          # ja, jb: 6-vectors on bodies a, b
        k = len(C)
        for body, blk in ((a, ja), (b, -np.asarray(jb))):
            if body >= 0:
                ri.extend([k] * 6), ci.extend(range(6 * body, 6 * body + 6)), vals.extend(blk)
        C.append(c), bias.append(jdot)

    for j, qrel0 in zip(joints.joints, joints._qrel0):
        a, b = j.a, j.b
        ra, rb = Rw[a] @ j.anchor_a, Rw[b] @ j.anchor_b
        pa, pb = xw[a] + ra, xw[b] + rb
        if j.kind in ("ball", "hinge", "weld"):
            acc = cross(ww[a], cross(ww[a], ra)) - cross(ww[b], cross(ww[b], rb))
            for k in range(3):
                e = np.eye(3)[k]
                row(np.concatenate([e, cross(ra, e)]), np.concatenate([e, cross(rb, e)]), a, b,
                    (pa - pb)[k], acc[k])
        if j.kind == "hinge":
            aa, ab = Rw[a] @ j.axis_a, Rw[b] @ j.axis_b
            for t in tangent_basis(aa[None])[:2]:
                t = t[0]
                g = cross(t, ab)
                jd = cross(ww[a], cross(ww[a], t)) @ ab + 2 * cross(ww[a], t) @ cross(ww[b], ab) \
                    + t @ cross(ww[b], cross(ww[b], ab))
                row(np.concatenate([np.zeros(3), g]), np.concatenate([np.zeros(3), g]), a, b, t @ ab, jd)
        if j.kind in ("slider", "weld"):
            qrel = quat_multiply(quat_conjugate(qw[b]), quat_multiply(qw[a], quat_conjugate(qrel0)))
            err = 2.0 * np.sign(qrel[0] if qrel[0] != 0 else 1.0) * (Rw[b] @ qrel[1:])   # small-angle, world
            for k in range(3):
                e = np.eye(3)[k]
                row(np.concatenate([np.zeros(3), e]), np.concatenate([np.zeros(3), e]), a, b, err[k], 0.0)
        if j.kind == "slider":
            ab = Rw[b] @ j.axis_b
            d = pa - pb
            dd = (vw[a] + cross(ww[a], ra)) - (vw[b] + cross(ww[b], rb))
            for t in tangent_basis(ab[None])[:2]:
                t = t[0]
                # C = t·d with t turning with b: Ċ = t·ḋ + (ω_b × t)·d
                ga = np.concatenate([t, cross(ra, t)])
                gb = np.concatenate([t, cross(rb, t) - cross(t, d)])
                acc = cross(ww[a], cross(ww[a], ra)) - cross(ww[b], cross(ww[b], rb))
                jd = t @ acc + 2 * cross(ww[b], t) @ dd + cross(ww[b], cross(ww[b], t)) @ d
                row(ga, gb, a, b, t @ d, jd)
    import scipy.sparse as sp

    C, bias = np.array(C), np.array(bias)
    J = sp.csr_matrix((vals, (ri, ci)), shape=(len(C), 6 * N))   # duplicates (a = b rows) are summed
    u = np.hstack([v, w]).ravel()
    return C, (J if sparse else J.toarray()), bias, J @ u
