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

from .specs import PARTICLES, RIGID, ContactsOn, RigidState, finite_parts, state_of
from ..collision.shapes import Contacts
from ..contracts import Array, Either, Int, Obj, Opt, Real, contract
from ..errors import InvalidInput, as_floats
from ..geometry import cross
from ..lcp.solve import delassus
from ..lcp.specs import JacobianRows, RowIndices

__all__ = ["ContactProblem", "rigid_state", "delassus_by_bodies", "assemble_rigid", "assemble_rigid_loop",
           "assemble_particles",
           "assemble_particles_loop", "make_contacts", "ContactRows", "rigid_rows", "particle_rows", "particle_blocks"]


@contract(a=Array(("m",), ge=-1, empty=True), b=Array(("m",), ge=-1, empty=True), point=Array(("m", "d"), empty=True),
          normal=Array(("m", "d"), empty=True), depth=Opt(Array(("m",), empty=True)))
def make_contacts(a, b, point, normal, depth=None):
    """A contact set: the collision chapter's :class:`~pbanim.collision.shapes.Contacts` (2-D or 3-D points).

    ``a``, ``b`` (m,): body indices (integers ≥ −1, −1 the static world); ``point``, ``normal`` (m, d)
    with d = 2 or 3, unit normals from b towards a (|n| = 1 to 10⁻⁶, checked by ``Contacts``);
    ``depth`` (m,): penetration (negative: a gap), default 0.

    >>> c = make_contacts([0], [-1], [[0.0, 0.0, 0.0]], [[0.0, 0.0, 1.0]])
    >>> c.a.tolist(), c.depth.tolist()
    ([0], [0.0])
    """
    # models and scenes call this from inside pbanim with values no contract checked: convert and check here
    a, b = (np.atleast_1d(as_floats(nm, v)) for nm, v in (("a", a), ("b", b)))
    if not (np.all(np.isfinite(a)) and np.all(a == np.round(a)) and np.all(np.isfinite(b)) and np.all(b == np.round(b))):
        raise InvalidInput(f"a and b must be body indices (integers, −1 for the world), got {a} and {b}")
    a, b = a.astype(np.intp), b.astype(np.intp)
    point = as_floats("point", point, ndmin=2)
    normal = as_floats("normal", normal, ndmin=2)
    if point.shape[-1] not in (2, 3):
        raise InvalidInput(f"make_contacts: point must hold 2-D or 3-D points (shape (m, 2) or (m, 3)), got shape "
                           f"{point.shape}")
    depth = np.zeros(a.size) if depth is None else np.atleast_1d(as_floats("depth", depth))
    return Contacts(a=a, b=b, point=point, normal=normal, depth=depth)


_ROWS = Array(("m", "d"), empty=True)


@contract(a=RowIndices("$n_pad"), b=RowIndices("$n_pad"), Ga=_ROWS, Gb=_ROWS, n_pad=Int(ge=1))
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

    @contract(u=Either(Array(("self.n_pad", "self.d")), Array((lambda env: env.values["self"].n_pad *
                                                                env.values["self"].d,))))
    def matvec(self, u: np.ndarray) -> np.ndarray:
        """J u for generalized velocities u of shape (n_pad, d) (or flat)."""
        u = np.reshape(u, (self.n_pad, self.d))
        return np.einsum("ij,ij->i", self.Ga, u[self.a]) - np.einsum("ij,ij->i", self.Gb, u[self.b])

    @contract(z=Array(("self.a.size",), empty=True))
    def rmatvec(self, z: np.ndarray) -> np.ndarray:
        """Jᵀ z as an array of shape (n_pad, d) (forces/impulses per body)."""
        out = np.zeros((self.n_pad, self.d))
        np.add.at(out, self.a, self.Ga * z[:, None])
        np.add.at(out, self.b, -self.Gb * z[:, None])
        return out

    @contract(other=Obj("pbanim.contact.assembly:ContactRows"), Wb=Array(("self.n_pad", "self.d", "self.d")),
              block=Int(ge=1), returns=finite_parts)
    def gram(self, other: "ContactRows", Wb: np.ndarray, block: int = 1) -> np.ndarray:
        """J W Kᵀ (dense (m, m_other)) for block-diagonal W given as blocks ``Wb`` (n_pad, d, d); ``block``:
        rows in groups on the same two bodies (see :func:`pbanim.lcp.delassus`)."""
        if other.n_pad != self.n_pad or other.d != self.d:
            raise InvalidInput(f"ContactRows.gram: other must be rows on the same bodies (n_pad = {self.n_pad}, "
                               f"d = {self.d}), got n_pad = {other.n_pad}, d = {other.d}")
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

    @contract(f=Array(("self.b.size",), empty=True), n_bodies=Int(ge=0), returns=finite_parts)
    def generalized_force(self, f: np.ndarray, n_bodies: int) -> np.ndarray:
        """Q_C = Jᵀ f as an array of shape (N, d) (the world row dropped; N = ``n_bodies`` = n_pad − 1)."""
        r = self.rows if self.force_rows is None else self.force_rows
        if n_bodies != r.n_pad - 1:
            raise InvalidInput(f"ContactProblem.generalized_force: n_bodies must be the number of bodies the rows "
                               f"were built for, {r.n_pad - 1}, got {n_bodies}")
        return r.rmatvec(f)[:n_bodies]


_RIGID_Y = Array((state_of("bodies"),))


@contract(bodies=RIGID, y=_RIGID_Y, R=Opt(Array(("bodies.N", 3, 3))), returns=finite_parts)
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


def _rows_of_state(env) -> int:
    return len(env.values["S"]["x"])


@contract(S=RigidState(), a=RowIndices(_rows_of_state), b=RowIndices(_rows_of_state), p=Array(("m", 3), empty=True),
          d=Array(("m", 3), empty=True), returns=finite_parts)
def rigid_rows(S: dict, a: np.ndarray, b: np.ndarray, p: np.ndarray, d: np.ndarray) -> ContactRows:
    """Rows [dᵢᵀ, (r_a × dᵢ)ᵀ] on body a and −[dᵢᵀ, (r_b × dᵢ)ᵀ] on b (a, b padded: N = world).

    Row i maps the generalized velocities u = (v, ω) of all bodies to dᵢ·(ṗ_a − ṗ_b) at the point pᵢ.
    """
    ra, rb = p - S["x"][a], p - S["x"][b]
    return ContactRows(a, b, np.hstack([d, cross(ra, d)]), np.hstack([d, cross(rb, d)]), S["x"].shape[0])


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


_RIGID_Q = Array(("bodies.N", 6))


@contract(bodies=RIGID, y=_RIGID_Y, contacts=ContactsOn("bodies"), Q=_RIGID_Q,
          friction=Array(("contacts.m",), ge=0, scalar=True, empty=True), slip_tol=Real(gt=0), returns=finite_parts)
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


def _padded_count(env) -> int:
    return env.values["N"] + 1


@contract(N=Int(ge=1), dim=Int(ge=2, le=3), a=RowIndices(_padded_count), b=RowIndices(_padded_count),
          d=Array((None, "$dim"), empty=True))
def particle_rows(N: int, dim: int, a: np.ndarray, b: np.ndarray, d: np.ndarray) -> ContactRows:
    """Rows dᵢ on particle a and −dᵢ on b (padded indices: N = world); ``d`` (m, dim), one per row of a."""
    if len(d) != len(a):      # (a shape may not mix a symbol with a reference: the count is checked here)
        raise InvalidInput(f"particle_rows: d must hold one direction per row of a ({len(a)}), got {len(d)}")
    return ContactRows(a, b, d, d, N + 1)


@contract(system=PARTICLES)
def particle_blocks(system) -> np.ndarray:
    """Inverse-mass blocks (N+1, dim, dim): 1/mᵢ I, and zero for the world."""
    return np.append(system.W, 0.0)[:, None, None] * np.eye(system.dim)


_PARTICLE_Y = Array((state_of("system"),))
_PARTICLE_Q = Array(("system.N", "system.dim"))


@contract(system=PARTICLES, y=_PARTICLE_Y, contacts=ContactsOn("system"), Q=_PARTICLE_Q, returns=finite_parts)
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


# the readable per-contact and per-body versions (tested equal to the vectorized ones above)
from .readable import assemble_particles_loop, assemble_rigid_loop, delassus_by_bodies  # noqa: E402
