"""Readable versions of the contact assembly (chapter 07): one contact, one body at a time.

Each is the reference its vectorized twin in :mod:`pbanim.contact.assembly` is tested equal to
(``tests/test_contact.py``): :func:`assemble_rigid_loop` is Baraff 1994's ``compute_aij`` for
:func:`~pbanim.contact.assembly.assemble_rigid`, :func:`assemble_particles_loop` the same for point masses,
:func:`delassus_by_bodies` the body-by-body sum for :func:`pbanim.lcp.delassus`. Notation as in
:mod:`pbanim.contact.assembly` (A = J W Jᵀ, b the free relative acceleration d̈ at f = 0, −1 the world).
"""

from __future__ import annotations

import numpy as np

from .assembly import _PARTICLE_Q, _PARTICLE_Y, _RIGID_Q, _RIGID_Y, _ROWS, _free_accel, rigid_state
from .specs import PARTICLES, RIGID, ContactsOn, finite_parts
from ..contracts import Array, Opt, contract
from ..lcp.specs import JacobianRows, RowIndices, length_of

__all__ = ["assemble_rigid_loop", "assemble_particles_loop", "delassus_by_bodies"]


_BLOCKS = length_of("Wb")


@contract(a=RowIndices(_BLOCKS), b=RowIndices(_BLOCKS), Ga=_ROWS, Gb=_ROWS, Wb=Array(("n", "d", "d")),
          other=Opt(JacobianRows(_BLOCKS)), returns=finite_parts)
def delassus_by_bodies(a, b, Ga, Gb, Wb, other=None) -> np.ndarray:
    """Readable A = J W Kᵀ, body by body: row i acts on body a[i] with +Ga[i] and on b[i] with −Gb[i], so

        Aᵢⱼ = Σ_β Σ (σ gᵢ)ᵀ W_β (σ′ hⱼ)   over the ends of rows i and j that lie on the same body β.

    The reference for :func:`pbanim.lcp.delassus` (same arguments; a Python loop over bodies and rows).
    """
    oa, ob, Ha, Hb = (a, b, Ga, Gb) if other is None else other
    A = np.zeros((len(a), len(oa)))
    for beta in range(Wb.shape[0]):
        ends_j = [(i, 1.0, Ga[i]) for i in np.flatnonzero(a == beta)] + \
            [(i, -1.0, Gb[i]) for i in np.flatnonzero(b == beta)]
        ends_k = [(j, 1.0, Ha[j]) for j in np.flatnonzero(oa == beta)] + \
            [(j, -1.0, Hb[j]) for j in np.flatnonzero(ob == beta)]
        for i, si, g in ends_j:
            for j, sj, hj in ends_k:
                A[i, j] += si * sj * (g @ Wb[beta] @ hj)
    return A


@contract(bodies=RIGID, y=_RIGID_Y, contacts=ContactsOn("bodies"), Q=_RIGID_Q, returns=finite_parts)
def assemble_rigid_loop(bodies, y: np.ndarray, contacts, Q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Readable per-contact version of :func:`assemble_rigid` (Baraff 1994's ``compute_aij``): returns (A, b).

    Aᵢⱼ is the change of d̈ᵢ caused by a unit force fⱼ along nⱼ, applied to a_j (+) and b_j (−).
    """
    N = bodies.N
    S = rigid_state(bodies, y)
    vdot, wdot = _free_accel(S, Q)
    m = len(contacts.a)
    idx = lambda k: N if k < 0 else int(k)  # noqa: E731
    A = np.zeros((m, m))
    b = np.zeros(m)
    for i in range(m):
        ai, bi, pi, ni = idx(contacts.a[i]), idx(contacts.b[i]), contacts.point[i], contacts.normal[i]
        ra, rb = pi - S["x"][ai], pi - S["x"][bi]
        va, wa, vb, wb = S["v"][ai], S["omega"][ai], S["v"][bi], S["omega"][bi]
        Ra, Rb = float(contacts.radius[i]), float(contacts.radius_b[i])
        qa = np.zeros(3) if Ra > 0 else ra            # a rounded end: its centre stands in for the point
        qb = np.zeros(3) if Rb > 0 else rb
        qa_dd = vdot[ai] + np.cross(wdot[ai], qa) + np.cross(wa, np.cross(wa, qa))
        qb_dd = vdot[bi] + np.cross(wdot[bi], qb) + np.cross(wb, np.cross(wb, qb))
        dd = (va + np.cross(wa, qa)) - (vb + np.cross(wb, qb))
        if Rb > 0:                                     # d = |q_a − x_b| − R_a − R_b
            D = (S["x"][ai] if Ra > 0 else pi) - S["x"][bi]
            perp = dd - (dd @ ni) * ni
            b[i] = ni @ (qa_dd - qb_dd) + perp @ perp / np.linalg.norm(D)
        else:                                          # b's face turns with b: ṅ = ω_b × n
            ndot = np.cross(wb, ni)
            b[i] = ni @ (qa_dd - qb_dd) + 2.0 * ndot @ dd - Ra * ndot @ ndot
        for j in range(m):
            aj, bj, pj, nj = idx(contacts.a[j]), idx(contacts.b[j]), contacts.point[j], contacts.normal[j]
            total = 0.0
            for body, sign_i, r_i in ((ai, 1.0, ra), (bi, -1.0, rb)):
                for other, sign_j in ((aj, 1.0), (bj, -1.0)):
                    if other != body:
                        continue
                    rj = pj - S["x"][body]
                    dv = S["inv_mass"][body] * nj * sign_j
                    dw = S["Iinv"][body] @ np.cross(rj, nj) * sign_j
                    total += sign_i * ni @ (dv + np.cross(dw, r_i))
            A[i, j] = total
    return A, b


@contract(system=PARTICLES, y=_PARTICLE_Y, contacts=ContactsOn("system"), Q=_PARTICLE_Q, returns=finite_parts)
def assemble_particles_loop(system, y: np.ndarray, contacts, Q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Readable per-contact version of :func:`assemble_particles`: returns (A, b)."""
    x, v = system.unpack(y)
    m = len(contacts.a)
    A = np.zeros((m, m))
    b = np.zeros(m)
    for i in range(m):
        ai, bi, ni = int(contacts.a[i]), int(contacts.b[i]), contacts.normal[i]
        acc_a = Q[ai] * system.W[ai] if ai >= 0 else 0.0
        acc_b = Q[bi] * system.W[bi] if bi >= 0 else 0.0
        b[i] = ni @ (acc_a - acc_b)
        if ai >= 0 and bi >= 0:
            dv = v[ai] - v[bi]
            dv_perp = dv - (dv @ ni) * ni
            b[i] += dv_perp @ dv_perp / np.linalg.norm(x[ai] - x[bi])
        for j in range(m):
            aj, bj, nj = int(contacts.a[j]), int(contacts.b[j]), contacts.normal[j]
            for body, si in ((ai, 1.0), (bi, -1.0)):
                if body < 0:
                    continue
                for other, sj in ((aj, 1.0), (bj, -1.0)):
                    if other == body:
                        A[i, j] += si * sj * system.W[body] * (ni @ nj)
    return A, b
