"""Assembly of the resting-contact LCP  d̈ = A f + b  (chapter 07, Baraff's acceleration level).

For contact i between bodies a and b at the point pᵢ with unit normal nᵢ (from b towards a), the
separation dᵢ = nᵢ·(p_a − p_b) has, at the contact instant,

    d̈ᵢ = nᵢ·(p̈_a − p̈_b) + 2 ṅᵢ·(ṗ_a − ṗ_b) = Aᵢ f + bᵢ,

with p̈ = v̇ + ω̇ × r + ω × (ω × r), r = p − x, ṅᵢ = ω_b × nᵢ (the normal turns with the face it
belongs to, on body b: vertex–face contact, Baraff 1994 §3). A rounded feature (a sphere, a capsule's
end; ``Contacts.radius``) touches through a point that slides over it: its centre takes the place of p
(so a spinning sphere on a plane feels no ω × (ω × r) term) and the curvature adds −R|ṅ|²; two rounded
features use d = |x_a − x_b| − R_a − R_b (see :func:`_velocity_terms`). The contact forces fⱼ nⱼ act on a (+)
and on b (−), so with the contact Jacobian rows Jᵢ = [nᵢᵀ, (r_a × nᵢ)ᵀ] on a and −[nᵢᵀ, (r_b × nᵢ)ᵀ]
on b and W = diag(1/m, I⁻¹) per body,

    A = J W Jᵀ   (symmetric PSD),     b = J W (Q + gyro) + velocity-product terms,

and the generalized contact force is Q_C = Jᵀ f. Index −1 is the static world: per-body arrays are
padded with one row of zero inverse mass and zero velocity, so no formula special-cases it. A is built by
the LCP core's :func:`pbanim.lcp.delassus` (the collision impulses of chapter 06 use the same one) and
the cross products by :func:`pbanim.geometry.cross`.

=========  ======================  ============  ===============================================
symbol     code                    shape         meaning
=========  ======================  ============  ===============================================
J          ``rows`` (ContactRows)  (m, 6(N+1))   contact Jacobian, per-contact blocks (last body = world)
W          ``Wb``                  (N+1, 6, 6)   block-diagonal inverse mass (1/m I₃, I⁻¹ world frame)
A, b       ``A, b``                (m, m), (m,)  LCP data
Q          ``Q``                   (N, 6)        applied force and torque about the centre of mass
Q_C        ``Jᵀf``                 (N, 6)        contact force and torque
=========  ======================  ============  ===============================================

Particles (point masses, radius ≥ 0): J has nᵢ on a and −nᵢ on b, W = diag(1/mᵢ); the velocity term
of a sphere–sphere contact (normal along the centres, not a body-fixed point) is the exact
ṅ·Δv = |Δv⊥|²/|x_a − x_b|, and zero against the static world (a fixed plane).

Limiting cases: a single body on the static world with one contact gives A = W(1 + ...) scalar;
all bodies at rest gives b = J W Q.

References: D. Baraff, "Fast contact force computation for nonpenetrating rigid bodies", SIGGRAPH 1994;
D. Baraff, "Physically based modeling: rigid body simulation II — nonpenetration constraints",
SIGGRAPH 2001 course notes (§8, "Computing contact forces").
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

from ..collision.shapes import Contacts
from ..errors import InvalidInput, as_floats
from ..geometry import cross
from ..lcp.solve import delassus

__all__ = ["ContactProblem", "rigid_state", "delassus_by_bodies", "assemble_rigid", "assemble_rigid_loop",
           "assemble_particles",
           "assemble_particles_loop", "make_contacts", "ContactRows", "rigid_rows", "particle_rows", "particle_blocks"]


def make_contacts(a, b, point, normal, depth=None):
    """A contact set: the collision chapter's :class:`~pbanim.collision.shapes.Contacts` (2-D or 3-D points).

    >>> c = make_contacts([0], [-1], [[0.0, 0.0, 0.0]], [[0.0, 0.0, 1.0]])
    >>> c.a.tolist(), c.depth.tolist()
    ([0], [0.0])
    """
    a, b = (np.atleast_1d(as_floats(nm, v)) for nm, v in (("a", a), ("b", b)))
    if not (np.all(np.isfinite(a)) and np.all(a == np.round(a)) and np.all(np.isfinite(b)) and np.all(b == np.round(b))):
        raise InvalidInput(f"a and b must be body indices (integers, −1 for the world), got {a} and {b}")
    a, b = a.astype(np.intp), b.astype(np.intp)
    point = as_floats("point", point, ndmin=2)
    normal = as_floats("normal", normal, ndmin=2)
    depth = np.zeros(a.size) if depth is None else np.atleast_1d(as_floats("depth", depth))
    return Contacts(a=a, b=b, point=point, normal=normal, depth=depth)


@dataclass
class ContactRows:
    """Rows of a contact Jacobian, stored per contact: row i is ``Ga[i]`` on body ``a[i]`` and
    ``−Gb[i]`` on body ``b[i]`` (indices padded: ``n_pad − 1`` is the static world).

    ``J u``, ``Jᵀ z`` and ``J W Kᵀ`` are computed from these (m, d) blocks without building J;
    :meth:`sparse` builds the scipy.sparse matrix when one is wanted.
    """

    a: np.ndarray
    b: np.ndarray
    Ga: np.ndarray
    Gb: np.ndarray
    n_pad: int

    @property
    def d(self) -> int:
        return self.Ga.shape[1]

    def matvec(self, u: np.ndarray) -> np.ndarray:
        """J u for generalized velocities u of shape (n_pad, d) (or flat)."""
        u = np.reshape(u, (self.n_pad, self.d))
        return np.einsum("ij,ij->i", self.Ga, u[self.a]) - np.einsum("ij,ij->i", self.Gb, u[self.b])

    def rmatvec(self, z: np.ndarray) -> np.ndarray:
        """Jᵀ z as an array of shape (n_pad, d) (forces/impulses per body)."""
        out = np.zeros((self.n_pad, self.d))
        np.add.at(out, self.a, self.Ga * z[:, None])
        np.add.at(out, self.b, -self.Gb * z[:, None])
        return out

    def gram(self, other: "ContactRows", Wb: np.ndarray, block: int = 1) -> np.ndarray:
        """J W Kᵀ (dense (m, m_other)) for block-diagonal W given as blocks ``Wb`` (n_pad, d, d); ``block``:
        rows in groups on the same two bodies (see :func:`pbanim.lcp.delassus`)."""
        return delassus(self.a, self.b, self.Ga, self.Gb, Wb, (other.a, other.b, other.Ga, other.Gb), block)

    def sparse(self) -> sp.csr_matrix:
        m, d = self.Ga.shape
        rows = np.repeat(np.arange(m), 2 * d)
        cols = np.concatenate([d * self.a[:, None] + np.arange(d), d * self.b[:, None] + np.arange(d)], axis=1).ravel()
        vals = np.concatenate([self.Ga, -self.Gb], axis=1).ravel()
        return sp.csr_matrix((vals, (rows, cols)), shape=(m, d * self.n_pad))


@dataclass
class ContactProblem:
    """The LCP data of one contact configuration.

    Attributes
    ----------
    A : ndarray (m, m)
    b : ndarray (m,)
    rows : ContactRows — the contact Jacobian J (normal directions).
    Wb : ndarray (n_pad, d, d) — inverse-mass blocks (the last one, the world, is zero).
    force_rows : ContactRows, optional — the force directions when they differ from the normals
        (sliding friction: nᵢ − μ t̂ᵢ); Q_C = (force rows)ᵀ f.
    """

    A: np.ndarray
    b: np.ndarray
    rows: ContactRows
    Wb: np.ndarray
    force_rows: ContactRows | None = None
    u: np.ndarray | None = None   # padded generalized velocities (n_pad, d) at assembly, when known

    @property
    def J(self) -> sp.csr_matrix:
        """The contact Jacobian as a scipy.sparse matrix (m, d·n_pad)."""
        return self.rows.sparse()

    def generalized_force(self, f: np.ndarray, n_bodies: int) -> np.ndarray:
        """Q_C = Jᵀ f as an array of shape (N, d) (the world row dropped)."""
        r = self.rows if self.force_rows is None else self.force_rows
        return r.rmatvec(f)[:n_bodies]


def rigid_state(bodies, y: np.ndarray, R: np.ndarray | None = None) -> dict[str, np.ndarray]:
    """Padded per-body arrays (row N = static world): x, v, ω, L, 1/m, I⁻¹ (world frame), W blocks.
    ``R`` (N, 3, 3): the rotations of y when the caller has them already (a time step computes them once)."""
    N = bodies.N
    x, _, P, L = bodies.unpack(y)
    R = bodies.rotations(y) if R is None else R
    S = {"x": np.zeros((N + 1, 3)), "v": np.zeros((N + 1, 3)), "omega": np.zeros((N + 1, 3)),
         "L": np.zeros((N + 1, 3)), "inv_mass": np.zeros(N + 1), "Iinv": np.zeros((N + 1, 3, 3))}
    S["x"][:N], S["L"][:N], S["inv_mass"][:N] = x, L, bodies.inv_mass
    S["Iinv"][:N] = R @ bodies.inv_I_body @ np.swapaxes(R, 1, 2)
    S["v"][:N] = bodies.inv_mass[:, None] * P
    S["omega"][:N] = np.einsum("nij,nj->ni", S["Iinv"][:N], L)
    Wb = np.zeros((N + 1, 6, 6))
    Wb[:, :3, :3] = S["inv_mass"][:, None, None] * np.eye(3)
    Wb[:, 3:, 3:] = S["Iinv"]
    S["Wb"] = Wb
    return S


def rigid_rows(S: dict, a: np.ndarray, b: np.ndarray, p: np.ndarray, d: np.ndarray) -> ContactRows:
    """Rows [dᵢᵀ, (r_a × dᵢ)ᵀ] on body a and −[dᵢᵀ, (r_b × dᵢ)ᵀ] on b (a, b padded: N = world).

    Row i maps the generalized velocities u = (v, ω) of all bodies to dᵢ·(ṗ_a − ṗ_b) at the point pᵢ.
    """
    ra, rb = p - S["x"][a], p - S["x"][b]
    return ContactRows(a, b, np.hstack([d, cross(ra, d)]), np.hstack([d, cross(rb, d)]), S["x"].shape[0])


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


def _free_accel(S: dict, Q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    N = Q.shape[0]
    Qp = np.zeros((N + 1, 6))
    Qp[:N] = Q
    vdot = S["inv_mass"][:, None] * Qp[:, :3]
    wdot = np.einsum("nij,nj->ni", S["Iinv"], Qp[:, 3:] + cross(S["L"], S["omega"]))
    return vdot, wdot


def _padded(contacts, N: int) -> tuple[np.ndarray, np.ndarray]:
    a = np.asarray(contacts.a)
    b = np.asarray(contacts.b)
    return np.where(a < 0, N, a), np.where(b < 0, N, b)


def assemble_rigid(bodies, y: np.ndarray, contacts, Q: np.ndarray, friction=0.0,
                   slip_tol: float = 1e-9) -> ContactProblem:
    """Vectorized A = J W Jᵀ and b for rigid bodies (no Python loop over contacts).

    With ``friction`` μ > 0, a *sliding* contact (tangential speed > ``slip_tol``) carries the Coulomb
    force −μ fᵢ t̂ᵢ opposite to its slip direction t̂ᵢ, so the force direction is nᵢ − μ t̂ᵢ and
    A = J W (J − μ J_t)ᵀ is no longer symmetric (Painlevé's B(θ) can make it negative, ORACLES D7).
    Sticking contacts are treated as frictionless here: static friction needs the velocity level.

    Parameters
    ----------
    bodies : RigidBodies
    y : ndarray — the flat state.
    contacts : Contacts — ``a, b`` (−1 = world), ``point`` (m, 3), ``normal`` (m, 3) from b to a.
    Q : ndarray (N, 6) — applied forces and torques (world frame, about the centres of mass).
    """
    N = bodies.N
    S = rigid_state(bodies, y)
    a, bb = _padded(contacts, N)
    p, n = np.asarray(contacts.point, dtype=float), np.asarray(contacts.normal, dtype=float)
    m = a.size
    # both ends at once: rows 0..m-1 are body a, m..2m-1 body b
    ends = np.concatenate([a, bb])
    r = np.vstack([p, p]) - S["x"][ends]
    v, w = S["v"][ends], S["omega"][ends]
    nn = np.vstack([n, n])
    rxn = cross(r, nn)
    rows = ContactRows(a, bb, np.hstack([n, rxn[:m]]), np.hstack([n, rxn[m:]]), N + 1)
    pdot = v + cross(w, r)
    pdot_rel = pdot[:m] - pdot[m:]
    mu = np.broadcast_to(np.asarray(friction, dtype=float), (m,))
    force_rows = None
    if np.any(mu > 0):
        vt = pdot_rel - np.einsum("ij,ij->i", pdot_rel, n)[:, None] * n
        speed = np.linalg.norm(vt, axis=1)
        slide = (speed > slip_tol) & (mu > 0)
        t_hat = np.where(slide[:, None], vt / np.where(speed > 0, speed, 1.0)[:, None], 0.0)
        force_rows = rigid_rows(S, a, bb, p, n - mu[:, None] * t_hat)
        A = rows.gram(force_rows, S["Wb"])
    else:
        A = rows.gram(rows, S["Wb"])
        A = 0.5 * (A + A.T)
    vdot, wdot = _free_accel(S, Q)
    b = _velocity_terms(contacts, n, m, S["x"][ends], p, r, v, w, vdot[ends], wdot[ends])
    return ContactProblem(A=A, b=b, rows=rows, Wb=S["Wb"], force_rows=force_rows, u=np.hstack([S["v"], S["omega"]]))


def _velocity_terms(contacts, n, m, x, p, r, v, w, vdot, wdot) -> np.ndarray:
    """b = d̈ at f = 0 for the rows of both ends (0..m−1: a, m..2m−1: b); see the module docstring.

    A rounded end (``radius`` > 0: a sphere or a capsule's end) touches through a point that slides over
    its surface, so its centre stands in for the contact point (r → 0 in ṗ and p̈). With b's feature a
    face (``radius_b`` = 0) the normal turns with b, ṅ = ω_b × n, and d = n·(q_a − p_b) − R_a gives
    d̈ = n·(q̈_a − p̈_b) + 2ṅ·(q̇_a − ṗ_b) − R_a|ṅ|²; with b rounded, d = |q_a − x_b| − R_a − R_b gives
    d̈ = n·(q̈_a − ẍ_b) + |Δ̇⊥|²/|Δ|, Δ = q_a − x_b (the sphere–sphere formula).
    """
    Ra = np.asarray(getattr(contacts, "radius", np.zeros(m)), dtype=float)
    Rb = np.asarray(getattr(contacts, "radius_b", np.zeros(m)), dtype=float)
    rounded = np.concatenate([Ra > 0, Rb > 0])
    rc = np.where(rounded[:, None], 0.0, r)                         # contact point or centre, per end
    qdot = v + cross(w, rc)
    qdd = vdot + cross(wdot, rc) + cross(w, qdot - v)
    dd = qdot[:m] - qdot[m:]
    ndot = cross(w[m:], n)
    face = np.einsum("ij,ij->i", n, qdd[:m] - qdd[m:]) + 2.0 * np.einsum("ij,ij->i", ndot, dd) \
        - Ra * np.einsum("ij,ij->i", ndot, ndot)
    if not np.any(Rb > 0):
        return face
    D = np.where(Ra[:, None] > 0, x[:m], p) - x[m:]
    dist = np.maximum(np.linalg.norm(D, axis=1), 1e-300)
    perp = dd - np.einsum("ij,ij->i", dd, n)[:, None] * n
    centres = np.einsum("ij,ij->i", n, qdd[:m] - qdd[m:]) + np.einsum("ij,ij->i", perp, perp) / dist
    return np.where(Rb > 0, centres, face)


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


def particle_rows(N: int, dim: int, a: np.ndarray, b: np.ndarray, d: np.ndarray) -> ContactRows:
    """Rows dᵢ on particle a and −dᵢ on b (padded indices: N = world)."""
    return ContactRows(a, b, d, d, N + 1)


def particle_blocks(system) -> np.ndarray:
    """Inverse-mass blocks (N+1, dim, dim): 1/mᵢ I, and zero for the world."""
    return np.append(system.W, 0.0)[:, None, None] * np.eye(system.dim)


def assemble_particles(system, y: np.ndarray, contacts, Q: np.ndarray) -> ContactProblem:
    """Vectorized A = J W Jᵀ and b for point masses (2-D or 3-D; −1 = static world).

    The velocity term: 0 against the world, |Δv⊥|²/|x_a − x_b| between two particles (sphere contact).
    """
    N, dim = system.N, system.dim
    x, v = system.unpack(y)
    a, bb = _padded(contacts, N)
    n = np.asarray(contacts.normal, dtype=float)
    rows = particle_rows(N, dim, a, bb, n)
    Wb = particle_blocks(system)
    A = rows.gram(rows, Wb)
    xp, vp = np.vstack([x, np.zeros(dim)]), np.vstack([v, np.zeros(dim)])
    accp = np.vstack([Q * system.W[:, None], np.zeros(dim)])
    dv = vp[a] - vp[bb]
    pair = bb < N
    dist = np.where(pair, np.linalg.norm(xp[a] - xp[bb], axis=1), 1.0)
    dv_perp = dv - np.einsum("ij,ij->i", dv, n)[:, None] * n
    b = np.einsum("ij,ij->i", n, accp[a] - accp[bb]) + np.where(pair, np.einsum("ij,ij->i", dv_perp, dv_perp) / dist, 0.0)
    return ContactProblem(A=0.5 * (A + A.T), b=b, rows=rows, Wb=Wb, u=vp)


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
