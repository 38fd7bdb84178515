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
  (or :class:`~pbanim.errors.ConvergenceError` at the pivot cap) — never a wrong answer. One round of
  this law can leave a contact approaching (restitution and friction pull on the neighbours), so it is
  applied in rounds until none approaches (:mod:`pbanim.collision.simultaneous`).

Both conserve linear momentum exactly; with ε = 1 both conserve energy on Newton's cradle.

Every answer certifies itself (ORACLES D2, D3): after the impulses no contact approaches,
v⁺_rel ≥ −tol·S (S: the largest contact speed ‖u‖ before or after, so the bound is in the problem's own
units; tol = 1e-12 by default, about 4500 ulps), and the kinetic energy has not grown, T⁺ ≤ T⁻(1 + tol).
An answer that fails either stops with :class:`~pbanim.errors.ConvergenceError` naming the contact or
the energies. The result also says what each contact was (``regime``: "colliding" faster than the
threshold, "resting" slower, "touching" — v⁻_rel = 0 within tol·S, a grazing contact that needs no
impulse but is reported — or "separating") and what is left (``approach``, ``energy_before/after``).

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

from .shapes import Contacts
from .specs import ContactsFor, SymmetricPSD, UnitVectors
from ..contracts import Array, Choice, Either, Flag, Int, Obj, Opt, Real, contract
from ..errors import ConvergenceError, InvalidInput, NonFiniteResult
from ..geometry import cross, skew

__all__ = ["ImpulseBodies", "ImpulseResult", "collision_matrix", "contact_velocity", "contact_impulse",
           "apply_impulses", "resolve_collisions"]

MODES = ("sequential", "simultaneous")
FRICTION_MODELS = ("staggered", "lcp")
LCP_METHODS = ("lemke", "enumerate")


@contract(x=Array(("B1", 3)), v=Array(("B1", 3)), omega=Array(("B1", 3)), inv_mass=Array(("B1",), ge=0),
          inv_I=SymmetricPSD(("B1", 3, 3)))
@dataclass
class ImpulseBodies:
    """Velocities and inverse masses of B bodies plus one world row (index −1 = B), for impulses.

    Build with :meth:`make`; particles have ``inv_I = 0`` and ``omega = 0``. Inverse masses are ≥ 0 (0: a
    static body) and inverse inertias symmetric positive semidefinite; the world row is zero.

    >>> bodies = ImpulseBodies.make(x=[[0, 0, 1.0]], v=[[0, 0, -1.0]], inv_mass=[0.5])
    >>> bodies.inv_mass, bodies.B
    (array([0.5, 0. ]), 1)
    """

    x: np.ndarray
    v: np.ndarray
    omega: np.ndarray
    inv_mass: np.ndarray
    inv_I: np.ndarray

    def __post_init__(self) -> None:      # the world row: a cross-field rule no single spec says
        if len(self.inv_mass) == 0 or self.inv_mass[-1] != 0 or np.any(np.asarray(self.inv_I)[-1] != 0):
            raise InvalidInput("ImpulseBodies: inv_mass and inv_I must end with the world row, which is zero "
                               f"(got inv_mass[-1] = {self.inv_mass[-1] if len(self.inv_mass) else None}); "
                               "build the record with ImpulseBodies.make")

    @property
    def B(self) -> int:
        return len(self.inv_mass) - 1

    @classmethod
    @contract(x=Array(("B", 3)), v=Array(("B", 3)), inv_mass=Array(("B",), ge=0, scalar=True),
              omega=Opt(Array(("B", 3))), inv_I=Opt(Either(SymmetricPSD(("B", 3, 3)), SymmetricPSD((3, 3)))))
    def make(cls, x, v, inv_mass, omega=None, inv_I=None) -> "ImpulseBodies":
        """The record of B bodies at centres x (B, 3) with velocities v, ω and inverse masses and inertias
        (one for all, or one per body), plus the world row."""
        x, v = np.asarray(x, float).reshape(-1, 3), np.asarray(v, float).reshape(-1, 3)
        B = len(x)
        w = np.broadcast_to(np.asarray(inv_mass, float), (B,))
        om = np.zeros((B, 3)) if omega is None else np.asarray(omega, float).reshape(B, 3)
        iI = np.zeros((B, 3, 3)) if inv_I is None else np.broadcast_to(np.asarray(inv_I, float), (B, 3, 3))
        pad = lambda a: np.concatenate([a, np.zeros((1,) + a.shape[1:])])  # noqa: E731 - the world row
        return cls(pad(x), pad(v), pad(om), pad(w), pad(iI))

    def kinetic_energy(self) -> float:
        """½ Σ m v² + ½ Σ ωᵀ I ω over dynamic bodies (I = (I⁻¹)⁺ when I⁻¹ is singular)."""
        dyn = self.inv_mass > 0
        with np.errstate(over="ignore", invalid="ignore"):
            T = 0.5 * np.sum((self.v[dyn] ** 2).sum(1) / self.inv_mass[dyn])
            rot = np.abs(self.inv_I).sum(axis=(1, 2)) > 0
            if rot.any():
                try:
                    L = np.linalg.solve(self.inv_I[rot], self.omega[rot][..., None])[..., 0]
                except np.linalg.LinAlgError:       # a singular I⁻¹: the pseudo-inverse
                    L = np.einsum("nij,nj->ni", np.linalg.pinv(self.inv_I[rot], hermitian=True), self.omega[rot])
                T += 0.5 * np.sum(L * self.omega[rot])
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
        Sweeps of the sequential loop, or pivots of the simultaneous LCPs.
    mode : str
    residual : float
        Natural-map residual of the last normal LCP (simultaneous) or the most negative v_rel left (sequential).
    extra : dict
        ``rounds`` of the simultaneous law, ``plastic_finish`` (True when contacts still approaching after
        ``max_rounds`` rounds, or after a resting round's friction, were stopped by one frictionless
        plastic LCP), ``energy_capped`` (sequential impulses scaled down because Newton's law with friction
        would have created energy).
    regime : ndarray of str (m,)
        Each contact before the impulses: "colliding" (faster than the threshold), "resting" (slower),
        "touching" (v⁻_rel = 0 within tol·S: grazing, reported, no impulse needed) or "separating".
    approach : float
        The largest approach speed left, max(0, −min v⁺_rel) (certified ≤ ``tolerance``).
    energy_before, energy_after : float
        Kinetic energies (certified: after ≤ before·(1 + tol)).
    tolerance : float
        tol·S, the approach the certificate allowed (m/s).
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
    regime: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype="<U10"))
    approach: float = 0.0
    energy_before: float = 0.0
    energy_after: float = 0.0
    tolerance: float = 0.0


_BODIES = Obj(ImpulseBodies)


def _lever(bodies: ImpulseBodies, c: Contacts):
    return c.point - bodies.x[c.a], c.point - bodies.x[c.b]


@contract(bodies=_BODIES, contacts=ContactsFor("bodies"))
def contact_velocity(bodies: ImpulseBodies, contacts: Contacts) -> np.ndarray:
    """u = ṗ_a − ṗ_b with ṗ = v + ω × r, shape (m, 3); v_rel = n·u.

    A ball spinning about y over the ground: its lowest point moves at v − ω × (R ẑ):

    >>> b = ImpulseBodies.make([[0, 0, 1.0]], [[1.0, 0, -2.0]], 1.0, omega=[[0, 3.0, 0]])
    >>> contact_velocity(b, Contacts([0], [-1], [[0, 0, 0]], [[0, 0, 1]], [0]))
    array([[-2.,  0., -2.]])
    """
    c = contacts
    # BEGIN SOLUTION contact_velocity
    ra, rb = _lever(bodies, c)
    return (bodies.v[c.a] + cross(bodies.omega[c.a], ra)) - (bodies.v[c.b] + cross(bodies.omega[c.b], rb))
    # END SOLUTION


@contract(bodies=_BODIES, contacts=ContactsFor("bodies"))
def collision_matrix(bodies: ImpulseBodies, contacts: Contacts) -> np.ndarray:
    """K = (1/m_a + 1/m_b) 𝟙 − [r_a]× I_a⁻¹ [r_a]× − [r_b]× I_b⁻¹ [r_b]×, shape (m, 3, 3).

    A solid ball (m = 1, R = 1, I = 2/5) on the ground: 1 along n, 1 + R²/I = 7/2 along the tangents.

    >>> b = ImpulseBodies.make([[0, 0, 1.0]], [[0, 0, 0]], 1.0, inv_I=np.eye(3) / 0.4)
    >>> np.diag(collision_matrix(b, Contacts([0], [-1], [[0, 0, 0]], [[0, 0, 1]], [0]))[0])
    array([3.5, 3.5, 1. ])
    """
    c = contacts
    # BEGIN SOLUTION collision_matrix
    ra, rb = _lever(bodies, c)
    Sa, Sb = skew(ra), skew(rb)
    lin = (bodies.inv_mass[c.a] + bodies.inv_mass[c.b])[:, None, None] * np.eye(3)
    return lin - Sa @ bodies.inv_I[c.a] @ Sa - Sb @ bodies.inv_I[c.b] @ Sb
    # END SOLUTION


@contract(bodies=_BODIES, contacts=ContactsFor("bodies"), J=Array(("contacts.m", 3), empty=True))
def apply_impulses(bodies: ImpulseBodies, contacts: Contacts, J: np.ndarray) -> None:
    """In place: v_a += J/m_a, ω_a += I_a⁻¹(r_a × J); the opposite on b (repeated bodies accumulate).

    The world row (index −1) has zero inverse mass: it absorbs −J and stays at rest.

    >>> b = ImpulseBodies.make([[0, 0, 0]], [[0, 0, -1.0]], 0.5)
    >>> apply_impulses(b, Contacts([0, 0], [-1, -1], [[0, 0, 0]] * 2, [[0, 0, 1]] * 2, [0, 0]), [[0, 0, 1.0]] * 2)
    >>> b.v
    array([[0., 0., 0.],
           [0., 0., 0.]])
    """
    c = contacts
    # BEGIN SOLUTION apply_impulses
    J = np.asarray(J, float).reshape(-1, 3)
    ra, rb = _lever(bodies, c)
    dv = np.zeros_like(bodies.v)
    dw = np.zeros_like(bodies.omega)
    np.add.at(dv, c.a, bodies.inv_mass[c.a, None] * J)
    np.add.at(dv, c.b, -bodies.inv_mass[c.b, None] * J)
    np.add.at(dw, c.a, np.einsum("kij,kj->ki", bodies.inv_I[c.a], cross(ra, J)))
    np.add.at(dw, c.b, -np.einsum("kij,kj->ki", bodies.inv_I[c.b], cross(rb, J)))
    bodies.v += dv
    bodies.omega += dw
    # END SOLUTION


@contract(K=SymmetricPSD((3, 3)), u=Array((3,)), n=UnitVectors((3,)), restitution=Real(ge=0, le=1),
          friction=Real(ge=0))
def contact_impulse(K: np.ndarray, u: np.ndarray, n: np.ndarray, restitution: float,
                    friction: float = 0.0) -> tuple[np.ndarray, bool]:
    """Impulse J on body a at one contact (readable version): Newton's law along n, Coulomb friction.

    Returns ``(J, sticking)``; J = 0 if the contact is not approaching (n·u ≥ 0). A singular K (a body
    that cannot turn about some axis) gets the least-squares stick impulse; a slide direction along which
    the contact cannot be decelerated (nᵀK(n − μ t̂) ≤ 0, a jam) gets the frictionless impulse.

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
    J = np.linalg.lstsq(K, -restitution * vn * n - u, rcond=None)[0]   # stick: u⁺ = −ε v⁻_rel n
    jn = float(n @ J)
    Jt = J - jn * n
    if np.linalg.norm(Jt) <= friction * jn * (1 + 1e-12):
        return J, True
    ut = u - vn * n                                             # slide against the initial slip direction
    nt, njt = np.linalg.norm(ut), np.linalg.norm(Jt)
    t = ut / nt if nt > 0 else (-Jt / njt if njt > 0 else np.zeros(3))
    d = n - friction * t
    if float(n @ K @ d) <= 0:                                   # a jam: no slide impulse decelerates
        d = n
    return (-(1 + restitution) * vn / float(n @ K @ d)) * d, False
    # END SOLUTION


def _sequential(bodies, c, eps, mu, fast, max_iter, impulse, sticking) -> tuple[int, int]:
    """Baraff's loop over the contacts approaching faster than ``fast``, one impulse at a time; in place.

    An impulse that would create energy (Newton's law with friction, Kane's paradox: ΔT = J·u + ½JᵀKJ > 0)
    is scaled down to the largest s J with ΔT ≤ 0 (the Coulomb cone is kept). Returns (sweeps, capped).
    """
    capped = 0
    for its in range(1, max_iter + 1):
        vn = np.einsum("ij,ij->i", contact_velocity(bodies, c), c.normal)
        colliding = np.flatnonzero(vn < -fast)
        if colliding.size == 0:
            return its, capped
        for i in colliding:
            ci = c.select([i])
            u, K = contact_velocity(bodies, ci)[0], collision_matrix(bodies, ci)[0]
            J, stick = contact_impulse(K, u, c.normal[i], eps, mu)
            work, quad = float(J @ u), 0.5 * float(J @ K @ J)
            if work + quad > 1e-12 * (abs(work) + quad):
                J, capped = J * (min(1.0, -work / quad) if work < 0 else 0.0), capped + 1
            apply_impulses(bodies, ci, J[None])
            impulse[i] += J
            sticking[i] = stick
    vn = np.einsum("ij,ij->i", contact_velocity(bodies, c), c.normal)
    raise ConvergenceError("sequential impulses", max_iter, float(-vn.min()), fast,
                           detail=f"{int((vn < -fast).sum())} contacts still colliding")


@contract(bodies=_BODIES, contacts=ContactsFor("bodies"), restitution=Real(ge=0, le=1), friction=Real(ge=0),
          mode=Choice(MODES), rest_velocity=Real(ge=0), max_iter=Int(ge=1), tol=Real(gt=0, lt=1),
          lcp=Choice(LCP_METHODS), friction_model=Choice(FRICTION_MODELS), max_rounds=Int(ge=1), lean=Flag())
def resolve_collisions(bodies: ImpulseBodies, contacts: Contacts, restitution: float = 1.0,
                       friction: float = 0.0, mode: str = "sequential", rest_velocity: float = 0.0,
                       max_iter: int = 1000, tol: float = 1e-12, lcp: str = "lemke",
                       friction_model: str = "staggered", max_rounds: int = 100, lean: bool = True) -> ImpulseResult:
    """Apply collision impulses to ``bodies`` (in place) so no contact approaches; see the module docstring.

    Contacts approaching slower than ``rest_velocity`` get ε = 0 (resting contact: stopped, not bounced).
    ``max_iter`` caps the sweeps of the sequential loop, ``max_rounds`` the rounds of the simultaneous law
    (each an LCP; a light body trapped between heavy ones needs about π√(M/m) of them, so after the cap
    what still approaches is stopped plastically, see :mod:`pbanim.collision.simultaneous`); ``tol`` is
    the relative tolerance of the certificate (no approach beyond tol·S, no energy growth beyond tol·T).
    ``lean=False`` runs the readable staggered friction pass of the simultaneous rounds (the lean one is
    the same arithmetic without a one-contact selection per contact: bit for bit, ORACLES D22).

    Three equal balls in a row, the first moving at 1 (Newton's cradle, ORACLES D2):

    >>> def cradle():
    ...     return ImpulseBodies.make(x=[[0, 0, 0], [2, 0, 0], [4, 0, 0]], v=[[1, 0, 0], [0, 0, 0], [0, 0, 0]],
    ...                               inv_mass=1.0)
    >>> c = Contacts(a=[1, 2], b=[0, 1], point=[[1, 0, 0], [3, 0, 0]], normal=[[1, 0, 0]] * 2, depth=[0, 0])
    >>> resolve_collisions(cradle(), c, 1.0, mode="sequential").v[:, 0]
    array([0., 0., 1.])
    >>> r = resolve_collisions(cradle(), c, 1.0, mode="simultaneous"); r.v[:, 0].round(12), r.regime.tolist()
    (array([-0.33333333,  0.66666667,  0.66666667]), ['colliding', 'touching'])
    """
    from .simultaneous import certified, rounds

    eps, mu, rest, c, m = float(restitution), float(friction), float(rest_velocity), contacts, contacts.m
    impulse, sticking = np.zeros((m, 3)), np.zeros(m, bool)
    T0 = bodies.kinetic_energy()
    u0 = contact_velocity(bodies, c) if m else np.zeros((0, 3))
    u0n = np.einsum("ij,ij->i", u0, c.normal)
    speed = float(np.sqrt(np.einsum("ij,ij->i", u0, u0)).max()) if m else 0.0
    if not (np.isfinite(T0) and np.isfinite(speed)):
        raise NonFiniteResult("resolve_collisions: the kinetic energy or a contact speed",
                              f"T = {T0}, max |u| = {speed}")
    its, residual, extra = 0, 0.0, {"rounds": 0, "plastic_finish": False, "energy_capped": 0}
    if m and mode == "sequential":
        # Baraff's loop over the colliding contacts (faster than rest_velocity), one impulse at a time
        its, extra["energy_capped"] = _sequential(bodies, c, eps, mu, max(rest, tol * speed), max_iter, impulse,
                                                  sticking)
        # what still approaches is resting contact: stopped together (ε = 0), as Baraff hands it to ch07
        vn = np.einsum("ij,ij->i", contact_velocity(bodies, c), c.normal)
        if np.any(vn < -tol * speed):
            f, Jt, st, _, residual, more = rounds(bodies, c, 0.0, mu, rest, lcp, friction_model, max_rounds, tol,
                                                 speed, lean)
            impulse += f[:, None] * c.normal + Jt
            sticking |= st
            extra.update(more)
    elif m:
        # one ε for the whole impact (Poisson): every contact restitutes when any contact collides faster
        # than the threshold, none when all are resting; one ε keeps ΔT = −½(1 − ε²) f_cᵀAf_c ≤ 0
        f, Jt, sticking, its, residual, more = rounds(bodies, c, eps, mu, rest, lcp, friction_model, max_rounds,
                                                      tol, speed, lean)
        impulse += f[:, None] * c.normal + Jt
        extra.update(more)
    bodies.v[-1] = 0.0
    bodies.omega[-1] = 0.0
    return certified(bodies, c, impulse, sticking, its, mode, residual, extra, u0n, T0, speed, rest, tol)
