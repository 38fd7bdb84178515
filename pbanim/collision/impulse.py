"""Collision impulses with restitution ε and Coulomb friction μ (chapter 06, Baraff's impulse response).

One contact. With r = p − x for each body, the velocity of the contact point changes under an impulse J
(applied +J to a, −J to b) by Δu = K J, with the 3 × 3 *collision matrix* (Mirtich 1996)

    K = (1/m_a + 1/m_b) 𝟙 − [r_a]× I_a⁻¹ [r_a]× − [r_b]× I_b⁻¹ [r_b]×,

whose normal entry is Baraff's denominator nᵀKn = 1/m_a + 1/m_b + n·(I_a⁻¹(r_a×n))×r_a + n·(I_b⁻¹(r_b×n))×r_b.
Newton's law v⁺_rel = −ε v⁻_rel along n, frictionless, gives Baraff's impulse

    j = −(1+ε) v⁻_rel / nᵀKn,     J = j n.

With friction the impact first tries to *stick*: J = K⁻¹(−ε v⁻_rel n − u⁻) (tangential velocity to zero);
it sticks iff ‖J_t‖ ≤ μ J·n. Otherwise it *slides* against the initial slip direction t̂ = u_t/‖u_t‖:
J = j (n − μ t̂) with j = −(1+ε) v⁻_rel / nᵀK(n − μ t̂). This is exact (equal to integrating Routh's
impact process) when the slip direction stays fixed, e.g. a sphere on a plane. A static body or the
world (index −1) is a row with zero inverse mass and inertia, so no formula special-cases it.

Several contacts.
- ``"sequential"`` (Baraff 1989/course notes): loop over the colliding contacts, one impulse at a time,
  until none approaches. Each impulse obeys Newton's law for its own pair, as if the collisions were a
  sequence of binary impacts separated by tiny gaps: the *propagating* law — Newton's cradle passes the
  whole velocity down the chain, (v₀, 0, 0) → (0, 0, v₀). Contacts approaching slower than the
  restitution threshold are *resting*: after the loop they are stopped together (ε = 0, by the LCP
  below), as Baraff hands resting contact to the contact-force solver — one corner at a time would spin
  a box that lands flat.
- ``"simultaneous"``: one impulse vector for all contacts at once. Compression: the plastic impulses
  f_c from the linear complementarity problem w = A f_c + v⁻ ≥ 0, f_c ≥ 0, f_cᵀw = 0 with A = J W Jᵀ
  (W = M⁻¹); restitution (Poisson's hypothesis): f = f_c + s ε f_c with s = 1 when all contacts share ε,
  so ΔT = −½(1 − ε²) f_cᵀ A f_c ≤ 0 — never an energy gain (Newton's law applied to every contact
  together, b = v⁻ + ε min(v⁻, 0), can create kinetic energy with several contacts; measured +772 % on
  random scenes). One ε serves the whole impact: all contacts restitute when any collides faster than
  the threshold, none when all rest (s guards roundoff). Newton's cradle: (v₀, 0, 0) → (−v₀/3, 2v₀/3, 2v₀/3). Solved by
  Lemke's complementary pivoting (or by enumerating active sets, the readable check). Friction, by
  ``friction_model``: ``"staggered"`` (default) applies it contact by contact after the normal impulses,
  from the 2 × 2 tangential system K_tt J_t = −u_t clamped to μ f; ``"lcp"`` solves normal and
  friction impulses in one LCP with a pyramidal cone of 8 edges (Stewart & Trinkle 1996; sliding
  speeds λ as the extra unknowns), exact when the slip direction is a cone edge. Both LCPs go to the
  one LCP core (:mod:`pbanim.lcp`: Lemke with a lexicographic ratio test, then the natural-map
  certificate); an answer that does not certify stops with :class:`~pbanim.errors.InfeasibleContact`
  (or :class:`~pbanim.errors.ConvergenceError` at the pivot cap) — never a wrong answer; "staggered"
  always returns.

Both conserve linear momentum exactly; with ε = 1 both conserve energy on Newton's cradle.

=================  ==============  ============  ====================================================
symbol             code            shape         meaning
=================  ==============  ============  ====================================================
1/m                ``inv_mass``    (B+1,)        inverse masses, last row the world (0)
I⁻¹                ``inv_I``       (B+1, 3, 3)   world-frame inverse inertia (0 for particles/static)
x, v, ω            ``x, v, omega`` (B+1, 3)      centres, linear and angular velocities
K                  ``K``           (m, 3, 3)     collision matrices
u                  ``u``           (m, 3)        relative contact velocities ṗ_a − ṗ_b
J                  ``impulse``     (m, 3)        impulse on a (−J on b)
ε, μ               ``restitution``, ``friction``
=================  ==============  ============  ====================================================

References: Baraff, *Physically Based Modeling: Rigid Body Simulation* (SIGGRAPH course notes 2001) §8;
Mirtich, *Impulse-based dynamic simulation of rigid body systems* (1996); Cottle, Pang & Stone, *The
Linear Complementarity Problem* (Lemke's method); Glocker, *Set-valued force laws* (the two laws).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from .lcp import _friction_lcp, _normal_lcp, solve_lcp_small
from .shapes import Contacts, check_friction, check_restitution
from ..errors import ConvergenceError, InvalidInput
from ..geometry import skew, tangent_basis
from ..results import natural_map_residual

__all__ = ["ImpulseBodies", "ImpulseResult", "collision_matrix", "contact_velocity", "contact_impulse",
           "apply_impulses", "resolve_collisions"]


@dataclass
class ImpulseBodies:
    """Velocities and inverse masses of B bodies plus one world row (index −1 = B), for impulses.

    Build with :meth:`make`; particles have ``inv_I = 0`` and ``omega = 0``.

    >>> bodies = ImpulseBodies.make(x=[[0, 0, 1.0]], v=[[0, 0, -1.0]], inv_mass=[0.5])
    >>> bodies.inv_mass, bodies.B
    (array([0.5, 0. ]), 1)
    """

    x: np.ndarray
    v: np.ndarray
    omega: np.ndarray
    inv_mass: np.ndarray
    inv_I: np.ndarray

    @property
    def B(self) -> int:
        return len(self.inv_mass) - 1

    @classmethod
    def make(cls, x, v, inv_mass, omega=None, inv_I=None) -> "ImpulseBodies":
        x, v = np.asarray(x, float).reshape(-1, 3), np.asarray(v, float).reshape(-1, 3)
        B = len(x)
        w = np.broadcast_to(np.asarray(inv_mass, float), (B,))
        om = np.zeros((B, 3)) if omega is None else np.asarray(omega, float).reshape(B, 3)
        iI = np.zeros((B, 3, 3)) if inv_I is None else np.broadcast_to(np.asarray(inv_I, float), (B, 3, 3))
        pad = lambda a: np.concatenate([a, np.zeros((1,) + a.shape[1:])])  # noqa: E731 - the world row
        return cls(pad(x), pad(v), pad(om), pad(w), pad(iI))

    def kinetic_energy(self) -> float:
        """½ Σ m v² + ½ Σ ωᵀ I ω over dynamic bodies."""
        dyn = self.inv_mass > 0
        T = 0.5 * np.sum((self.v[dyn] ** 2).sum(1) / self.inv_mass[dyn])
        rot = np.abs(self.inv_I).sum(axis=(1, 2)) > 0
        if rot.any():
            Lw = np.linalg.solve(self.inv_I[rot], self.omega[rot][..., None])[..., 0]
            T += 0.5 * np.sum(Lw * self.omega[rot])
        return float(T)


@dataclass
class ImpulseResult:
    """Outcome of :func:`resolve_collisions`.

    Attributes
    ----------
    v, omega : ndarray (B, 3)
        Velocities after the impulses (world row dropped).
    impulse : ndarray (m, 3)
        Total impulse on body a at each contact (−impulse on b).
    normal_impulse : ndarray (m,)
    sticking : ndarray of bool (m,)
        Contacts whose tangential velocity was brought to zero within the friction cone.
    iterations : int
        Sweeps of the sequential loop, or pivots of the simultaneous LCP.
    mode : str
    residual : float
        Natural-map residual of the normal LCP (simultaneous) or the most negative v_rel left (sequential).
    """

    v: np.ndarray
    omega: np.ndarray
    impulse: np.ndarray
    normal_impulse: np.ndarray
    sticking: np.ndarray
    iterations: int
    mode: str
    residual: float = 0.0
    extra: dict = field(default_factory=dict)


def _lever(bodies: ImpulseBodies, c: Contacts):
    return c.point - bodies.x[c.a], c.point - bodies.x[c.b]


def contact_velocity(bodies: ImpulseBodies, c: Contacts) -> np.ndarray:
    """u = ṗ_a − ṗ_b with ṗ = v + ω × r, shape (m, 3); v_rel = n·u.

    A ball spinning about y over the ground: its lowest point moves at v − ω × (R ẑ):

    >>> b = ImpulseBodies.make([[0, 0, 1.0]], [[1.0, 0, -2.0]], 1.0, omega=[[0, 3.0, 0]])
    >>> contact_velocity(b, Contacts([0], [-1], [[0, 0, 0]], [[0, 0, 1]], [0]))
    array([[-2.,  0., -2.]])
    """
    # BEGIN SOLUTION contact_velocity
    ra, rb = _lever(bodies, c)
    return (bodies.v[c.a] + np.cross(bodies.omega[c.a], ra)) - (bodies.v[c.b] + np.cross(bodies.omega[c.b], rb))
    # END SOLUTION


def collision_matrix(bodies: ImpulseBodies, c: Contacts) -> np.ndarray:
    """K = (1/m_a + 1/m_b) 𝟙 − [r_a]× I_a⁻¹ [r_a]× − [r_b]× I_b⁻¹ [r_b]×, shape (m, 3, 3).

    A solid ball (m = 1, R = 1, I = 2/5) on the ground: 1 along n, 1 + R²/I = 7/2 along the tangents.

    >>> b = ImpulseBodies.make([[0, 0, 1.0]], [[0, 0, 0]], 1.0, inv_I=np.eye(3) / 0.4)
    >>> np.diag(collision_matrix(b, Contacts([0], [-1], [[0, 0, 0]], [[0, 0, 1]], [0]))[0])
    array([3.5, 3.5, 1. ])
    """
    # BEGIN SOLUTION collision_matrix
    ra, rb = _lever(bodies, c)
    Sa, Sb = skew(ra), skew(rb)
    lin = (bodies.inv_mass[c.a] + bodies.inv_mass[c.b])[:, None, None] * np.eye(3)
    return lin - Sa @ bodies.inv_I[c.a] @ Sa - Sb @ bodies.inv_I[c.b] @ Sb
    # END SOLUTION


def apply_impulses(bodies: ImpulseBodies, c: Contacts, J: np.ndarray) -> None:
    """In place: v_a += J/m_a, ω_a += I_a⁻¹(r_a × J); the opposite on b (repeated bodies accumulate).

    The world row (index −1) has zero inverse mass: it absorbs −J and stays at rest.

    >>> b = ImpulseBodies.make([[0, 0, 0]], [[0, 0, -1.0]], 0.5)
    >>> apply_impulses(b, Contacts([0, 0], [-1, -1], [[0, 0, 0]] * 2, [[0, 0, 1]] * 2, [0, 0]), [[0, 0, 1.0]] * 2)
    >>> b.v
    array([[0., 0., 0.],
           [0., 0., 0.]])
    """
    # BEGIN SOLUTION apply_impulses
    J = np.asarray(J, float).reshape(-1, 3)
    ra, rb = _lever(bodies, c)
    dv = np.zeros_like(bodies.v)
    dw = np.zeros_like(bodies.omega)
    np.add.at(dv, c.a, bodies.inv_mass[c.a, None] * J)
    np.add.at(dv, c.b, -bodies.inv_mass[c.b, None] * J)
    np.add.at(dw, c.a, np.einsum("kij,kj->ki", bodies.inv_I[c.a], np.cross(ra, J)))
    np.add.at(dw, c.b, -np.einsum("kij,kj->ki", bodies.inv_I[c.b], np.cross(rb, J)))
    bodies.v += dv
    bodies.omega += dw
    # END SOLUTION


def contact_impulse(K: np.ndarray, u: np.ndarray, n: np.ndarray, restitution: float,
                    friction: float = 0.0) -> tuple[np.ndarray, bool]:
    """Impulse J on body a at one contact (readable version): Newton's law along n, Coulomb friction.

    Returns ``(J, sticking)``; J = 0 if the contact is not approaching (n·u ≥ 0).

    A particle (m = 1) hitting the ground at 2 m/s with ε = 0.5 receives j = (1 + ε)·2 = 3:

    >>> J, stick = contact_impulse(np.eye(3), np.array([0, 0, -2.0]), np.array([0, 0, 1.0]), 0.5)
    >>> J, stick
    (array([0., 0., 3.]), False)
    """
    # BEGIN SOLUTION contact_impulse
    vn = float(n @ u)
    if vn >= 0 or float(n @ K @ n) <= 0:      # separating, or two static bodies (nothing can move)
        return np.zeros(3), False
    if friction == 0.0:
        return (-(1 + restitution) * vn / float(n @ K @ n)) * n, False
    J = np.linalg.solve(K, -restitution * vn * n - u)          # stick: u⁺ = −ε v⁻_rel n
    jn = float(n @ J)
    Jt = J - jn * n
    if np.linalg.norm(Jt) <= friction * jn * (1 + 1e-12):
        return J, True
    ut = u - vn * n                                             # slide against the initial slip direction
    nt = np.linalg.norm(ut)
    t = ut / nt if nt > 0 else -Jt / np.linalg.norm(Jt)
    d = n - friction * t
    return (-(1 + restitution) * vn / float(n @ K @ d)) * d, False
    # END SOLUTION


def _tangent_friction(K: np.ndarray, u: np.ndarray, n: np.ndarray, jn: float, mu: float):
    """Tangential impulse from the 2×2 system K_tt J_t = −u_t, clamped to the disc ‖J_t‖ ≤ μ jn."""
    t1, t2 = tangent_basis(n)
    T = np.stack([t1[0], t2[0]], axis=1)                       # (3, 2) tangent basis
    ut = T.T @ u
    if mu == 0.0 or jn <= 0 or not np.any(ut):
        return np.zeros(3), bool(mu > 0 and jn > 0)
    jt = np.linalg.solve(T.T @ K @ T, -ut)
    norm = np.linalg.norm(jt)
    if norm <= mu * jn:
        return T @ jt, True
    return T @ (-mu * jn * ut / np.linalg.norm(ut)), False


def _restitution_scale(A, u, fc, r) -> float:
    """The largest s in [0, 1] with ΔT(s) = (fc + s r)·u + ½ (fc + s r)ᵀA(fc + s r) ≤ 0 (roundoff allowed)."""
    qa, qb = 0.5 * float(r @ A @ r), float(r @ u + fc @ A @ r)
    qc = float(fc @ u + 0.5 * fc @ A @ fc)                         # ≤ 0: the plastic impulse dissipates
    slack = 1e-12 * max(1.0, float(np.abs(fc) @ (np.abs(A) @ np.abs(fc))))
    if qa + qb + qc <= slack:
        return 1.0
    if qa <= 0.0:                                                  # linear: root of qb s + qc = 0
        return float(np.clip(-qc / qb, 0.0, 1.0)) if qb > 0 else 0.0
    return float(np.clip((-qb + np.sqrt(max(qb * qb - 4 * qa * qc, 0.0))) / (2 * qa), 0.0, 1.0))


def _simultaneous(bodies: ImpulseBodies, c: Contacts, e_i: np.ndarray, mu: float, lcp: str,
                  friction_model: str = "staggered"):
    """All normal impulses at once from the LCP (ε per contact), with friction; in place."""
    u0n = np.einsum("ij,ij->i", contact_velocity(bodies, c), c.normal)
    b = u0n + e_i * np.minimum(u0n, 0.0)
    if mu > 0 and friction_model == "lcp":
        f, J, sticking, its, residual = _friction_lcp(bodies, c, contact_velocity(bodies, c), b, mu, lcp)
        apply_impulses(bodies, c, J)
        return f, J - f[:, None] * c.normal, sticking, its, residual
    A = _normal_lcp(bodies, c)
    # compression (ε = 0): the plastic impulses f_c ⊥ A f_c + u⁻ ≥ 0 dissipate T; restitution adds
    # s·ε_i f_c per contact (Poisson), with the largest s ≤ 1 that keeps ΔT ≤ 0 (s = 1 when every ε_i is
    # the same: ΔT = −½(1 − ε²) f_cᵀ A f_c)
    fc, its = solve_lcp_small(A, u0n, method=lcp)
    f = fc + _restitution_scale(A, u0n, fc, e_i * fc) * e_i * fc
    apply_impulses(bodies, c, f[:, None] * c.normal)
    residual = natural_map_residual(fc, A @ fc + u0n)
    Jt = np.zeros((c.m, 3))
    sticking = np.zeros(c.m, bool)
    if mu > 0:
        K = collision_matrix(bodies, c)
        for i in np.flatnonzero(f > 0):
            ci = c.select([i])
            Jt[i], sticking[i] = _tangent_friction(K[i], contact_velocity(bodies, ci)[0], c.normal[i], f[i], mu)
            apply_impulses(bodies, ci, Jt[i])
    return f, Jt, sticking, its, residual


def resolve_collisions(bodies: ImpulseBodies, contacts: Contacts, restitution: float = 1.0,
                       friction: float = 0.0, mode: str = "sequential", rest_velocity: float = 0.0,
                       max_iter: int = 1000, tol: float = 1e-12, lcp: str = "lemke",
                       friction_model: str = "staggered") -> ImpulseResult:
    """Apply collision impulses to ``bodies`` (in place) so no contact approaches; see the module docstring.

    Contacts approaching slower than ``rest_velocity`` get ε = 0 (resting contact: stopped, not bounced).

    Three equal balls in a row, the first moving at 1 (Newton's cradle, ORACLES D2):

    >>> def cradle():
    ...     return ImpulseBodies.make(x=[[0, 0, 0], [2, 0, 0], [4, 0, 0]], v=[[1, 0, 0], [0, 0, 0], [0, 0, 0]],
    ...                               inv_mass=1.0)
    >>> c = Contacts(a=[1, 2], b=[0, 1], point=[[1, 0, 0], [3, 0, 0]], normal=[[1, 0, 0]] * 2, depth=[0, 0])
    >>> resolve_collisions(cradle(), c, 1.0, mode="sequential").v[:, 0]
    array([0., 0., 1.])
    >>> resolve_collisions(cradle(), c, 1.0, mode="simultaneous").v[:, 0].round(12)
    array([-0.33333333,  0.66666667,  0.66666667])
    """
    eps, mu = check_restitution(restitution), check_friction(friction)
    if mode not in ("sequential", "simultaneous"):
        raise InvalidInput(f"mode must be 'sequential' or 'simultaneous', got {mode!r}")
    if friction_model not in ("staggered", "lcp"):
        raise InvalidInput(f"friction_model must be 'staggered' or 'lcp', got {friction_model!r}")
    if rest_velocity < 0:
        raise InvalidInput(f"rest_velocity must be >= 0, got {rest_velocity}")
    c = contacts
    m = c.m
    impulse = np.zeros((m, 3))
    sticking = np.zeros(m, bool)
    u0n = np.einsum("ij,ij->i", contact_velocity(bodies, c), c.normal) if m else np.zeros(0)
    scale = max(1.0, float(np.abs(u0n).max())) if m else 1.0
    its, residual = 0, 0.0
    if m and mode == "sequential":
        # Baraff's loop over the colliding contacts (faster than rest_velocity), one impulse at a time
        fast = max(rest_velocity, tol * scale)
        for its in range(1, max_iter + 1):
            vn = np.einsum("ij,ij->i", contact_velocity(bodies, c), c.normal)
            colliding = np.flatnonzero(vn < -fast)
            if colliding.size == 0:
                break
            for i in colliding:
                ci = c.select([i])
                u = contact_velocity(bodies, ci)[0]
                J, stick = contact_impulse(collision_matrix(bodies, ci)[0], u, c.normal[i], eps, mu)
                apply_impulses(bodies, ci, J)
                impulse[i] += J
                sticking[i] = stick
        else:
            vn = np.einsum("ij,ij->i", contact_velocity(bodies, c), c.normal)
            raise ConvergenceError("sequential impulses", max_iter, float(-vn.min()), tol * scale,
                                   detail=f"{int((vn < -fast).sum())} contacts still colliding")
        # what still approaches is resting contact: stopped together (ε = 0), as Baraff hands it to ch07
        vn = np.einsum("ij,ij->i", contact_velocity(bodies, c), c.normal)
        if np.any(vn < -tol * scale):
            f, Jt, st, _, residual = _simultaneous(bodies, c, np.zeros(m), mu, lcp, friction_model)
            impulse += f[:, None] * c.normal + Jt
            sticking |= st
    elif m:
        # one ε for the whole impact (Poisson): every contact restitutes when any contact collides faster
        # than the threshold, none when all are resting; one ε keeps ΔT = −½(1 − ε²) f_cᵀAf_c ≤ 0
        e_i = np.full(m, eps if np.any(-u0n > rest_velocity) else 0.0)
        f, Jt, sticking, its, residual = _simultaneous(bodies, c, e_i, mu, lcp, friction_model)
        impulse += f[:, None] * c.normal + Jt
    bodies.v[-1] = 0.0
    bodies.omega[-1] = 0.0
    jn = np.einsum("ij,ij->i", impulse, c.normal) if m else np.zeros(0)
    return ImpulseResult(bodies.v[:-1].copy(), bodies.omega[:-1].copy(), impulse, jn, sticking, its, mode, residual)
