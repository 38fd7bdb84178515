"""S(t, u) through resting and sliding contact: the scene and its contact geometry (chapter 10, after chapter 07).

The deck ends with its limitations: "sliding and static contacts — complex linear complementarity
formulation". Here the simulation function q(t) = S(t, u) of a rigid body is the velocity-level contact
step of chapter 07 (Stewart–Trinkle / Anitescu–Potra with box friction,
:class:`pbanim.contact.FrictionStepping`), taken at every step of a fixed grid:

    ũ = (v + h g, ω),   w = G u⁺ + β = A z + b,   u⁺ = ũ + W Gᵀ z,   A = G W Gᵀ,   b = G ũ + β,
    0 ≤ λ ⊥ w_n ≥ 0,   |τⱼ| ≤ μ λ  with w_τⱼ = 0 inside and opposing on the bound,   z = (λ, τ₁, τ₂) per contact,
    x⁺ = x + h v⁺,   q⁺ = exp(½ h ω⁺) ⊗ q,   P⁺ = m v⁺,   L⁺ = I_w(q) ω⁺,

β_n = s/h for a separation s > 0 (look-ahead), erp·s/h for a penetration, and the contact frame (n, t₁, t₂)
is chapter 07's (:func:`pbanim.geometry.tangent_basis`). Two additions to chapter 07's step: A carries a
compliance κ = 10⁻⁶ max Aᵢᵢ (the four corners of a face landing flat get one answer, and one derivative),
and with restitution ε > 0 a contact that would be crossed within the step (s + h ũ_n < 0) approaching
faster than v_rest (default 3|g|h) gets β_n = ε ũ_n, i.e. v_n⁺ = −ε ũ_n (Newton's law), a sphere's
position reflected in the step (x⁺ = x + h v⁺ − (1 + ε) s n, exact for a linear approach); slower
approaches are plastic, which is how a bouncing ball comes to rest (ORACLES L3). Every feature of the scene is a candidate at
every step (no margin: a feature entering a margin would make S jump), so S is continuous in u and smooth
on every interval of u where no contact changes its mode; ∂S/∂u is :mod:`pbanim.design.stepped_sim`.

This module holds what the step needs from the scene: the body (a sphere or a box), the static planes
and boxes, μ, and every feature's separation s, contact frame D = (n, t₁, t₂), lever r = p − x and their
derivatives with respect to the body's position and orientation (δx, δφ), δR = [δφ]× R:

==========================  ===========================================================================
feature                     s,  n,  r = p − x,  derivatives
==========================  ===========================================================================
sphere (radius ρ) — plane    s = n·x − o − ρ,   r = −ρ n;      ∂s = (nᵀ, 0)
box corner c — plane         s = n·(x + Rc) − o,  r = Rc;     ∂s = (nᵀ, (Rc × n)ᵀ),  ∂r = (0, −[Rc]×)
sphere — static box          d = x − clamp(x) (box frame),  n = d/|d|,  s = |d| − ρ,  r = −ρ n;
                             ∂n = (𝟙 − nnᵀ) P_c / |d| on δx (P_c: the clamped axes),  ∂s = (nᵀ, 0)
==========================  ===========================================================================

and t₁ = (a − (a·n) n)/|·| (a = x̂, or ŷ where |n_x| ≥ 0.9), t₂ = n × t₁, differentiated through n.

==========  ===============  ==================================================================
symbol      code             meaning
==========  ===============  ==================================================================
u           ``names, u``     ``x0``, ``theta0``, ``v0``, ``omega0`` (as chapter 10) and ``friction`` μ
s, D, r     ``Frames``       separations (m,), frames (m, 3, 3) rows n, t₁, t₂, levers (m, 3)
ξ           tangent          (δx, δφ, δP, δL): 12 numbers per parameter (δφ: world rotation vector)
==========  ===============  ==================================================================

Limiting cases: μ = 0 makes the tangential impulses zero (the frictionless LCP); a body far from every
obstacle flies by symplectic Euler (v⁺ = v + hg, x⁺ = x + hv⁺: error ½ g h t against the parabola, the
chapter 07 law — chapter 10's event-driven :func:`pbanim.design.simulate` is exact in flight).

References: D. E. Stewart, J. C. Trinkle, IJNME 39 (1996); M. Anitescu, F. A. Potra, Nonlinear Dynamics 14
(1997); F. de Avila Belbute-Peres et al., "End-to-end differentiable physics for learning and control",
NeurIPS 2018; T. Howell et al., "Dojo: a differentiable physics engine for robotics", 2022; C. Ericson,
*Real-Time Collision Detection* (2005), §5.1 (closest point on a box).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..collision import Box, Plane, Sphere
from ..contracts import Array, Choice, Obj, Opt, Real, Seq, contract
from ..errors import InvalidInput
from ..geometry import cross, skew, tangent_basis
from ..rigid import quat_exp, quat_multiply, quat_normalize, quat_to_matrix
from .scene import DesignBody, UnknownParameter, left_jacobian, _parameter_slices
from .specs import Quaternion

__all__ = ["StaticBox", "ContactScene", "Frames", "frames", "CONTACT_NAMES"]

CONTACT_NAMES = ("x0", "theta0", "v0", "omega0", "friction")
_NAMES = Obj(list, tuple, str)


@contract(half_extents=Array((3,), gt=0), center=Array((3,)), orientation=Quaternion())
@dataclass
class StaticBox:
    """A fixed box obstacle (a table, a cup's wall): half extents, centre and orientation."""

    half_extents: np.ndarray
    center: np.ndarray = field(default_factory=lambda: np.zeros(3))
    orientation: np.ndarray = field(default_factory=lambda: np.array([1.0, 0, 0, 0]))

    def __post_init__(self) -> None:
        self.half_extents = np.array(self.half_extents, dtype=float).reshape(3)
        self.center = np.array(self.center, dtype=float).reshape(3)
        self.orientation = quat_normalize(np.array(self.orientation, dtype=float).reshape(4))
        self.R = quat_to_matrix(self.orientation)


class ContactScene:
    """One rigid body (a sphere or a box) among static planes and boxes, with Coulomb friction μ: the model
    behind the stepped S(t, u) (a box collides with the planes only; a sphere with both).

    >>> s = ContactScene(DesignBody(Sphere(0.1), position=[0, 0, 0.1]), [Plane([0, 0, 1])], friction=0.4)
    >>> s.names(), s.size("friction"), s.n_features
    (['x0', 'theta0', 'v0', 'omega0', 'friction'], 1, 1)
    """

    @contract(body=Obj(DesignBody), planes=Seq(Obj(Plane)), boxes=Seq(Obj(StaticBox)), friction=Real(ge=0),
              gravity=Array((3,)), erp=Real(gt=0, le=1), restitution=Real(ge=0, le=1), rest_speed=Opt(Real(ge=0)))
    def __init__(self, body, planes=(), boxes=(), friction: float = 0.5, gravity=(0.0, 0.0, -9.81),
                 erp: float = 0.2, restitution: float = 0.0, rest_speed=None) -> None:
        self.body, self.planes, self.boxes = body, list(planes), list(boxes)
        self.sphere = isinstance(body.shape, Sphere)
        if not self.sphere and self.boxes:
            raise InvalidInput("ContactScene: a box body collides with planes only (box–box contact is not in the "
                               "stepped design model); use a sphere, or planes")
        if not isinstance(body.shape, (Sphere, Box)):
            raise InvalidInput(f"ContactScene: the body must be a Sphere or a Box, got {body.shape!r}")
        self.friction, self.erp = float(friction), float(erp)
        self.restitution, self.rest_speed = float(restitution), None if rest_speed is None else float(rest_speed)
        self.gravity = np.array(gravity, dtype=float).reshape(3)
        self.mass, self.inertia = float(body.mass), np.array(body.inertia, dtype=float)
        self.radius = float(body.shape.radius) if self.sphere else 0.0
        self.corners = np.zeros((1, 3)) if self.sphere else body.shape.vertices()
        self.plane_n = np.array([p.normal for p in self.planes]).reshape(-1, 3)
        self.plane_o = np.array([p.offset for p in self.planes]).reshape(-1)
        t1, t2 = tangent_basis(self.plane_n) if self.planes else (np.zeros((0, 3)), np.zeros((0, 3)))
        self.plane_D = np.stack([self.plane_n, t1, t2], axis=1)          # chapter 07's frame, fixed per plane
        self.n_features = len(self.corners) * len(self.planes) + len(self.boxes)
        if self.n_features == 0:
            raise InvalidInput("ContactScene: give at least one plane or static box (nothing to touch)")
        self.nominal = {"x0": body.position.copy(), "theta0": np.zeros(3), "v0": body.velocity.copy(),
                        "omega0": body.angular_velocity.copy(), "friction": np.array([self.friction])}

    # ---------------------------------------------------------------- the parameter vector u
    def names(self) -> list[str]:
        """Every parameter name: the body's initial state blocks and μ."""
        return list(CONTACT_NAMES)

    @contract(names=_NAMES)
    def check_names(self, names) -> list[str]:
        """``names`` as a list of known, distinct names (or :class:`UnknownParameter`)."""
        names = [names] if isinstance(names, str) else list(names)
        bad = [n for n in names if n not in CONTACT_NAMES]
        if bad:
            raise UnknownParameter(f"names: parameter {bad[0]!r} does not exist; the contact scene has {list(CONTACT_NAMES)}")
        if len(set(names)) != len(names) or not names:
            raise InvalidInput(f"parameter names must be distinct and at least one, got {names}")
        return names

    @contract(name=Choice(CONTACT_NAMES))
    def size(self, name: str) -> int:
        """The length of the block ``name``: 1 for ``friction``, else 3."""
        return 1 if name == "friction" else 3

    @contract(names=_NAMES)
    def slices(self, names) -> dict:
        """{name: slice of u}."""
        return _parameter_slices(self, names)

    @contract(names=_NAMES)
    def vector(self, names) -> np.ndarray:
        """u: the nominal values of ``names`` concatenated."""
        return np.concatenate([self.nominal[n] for n in self.check_names(names)])

    @contract(names=_NAMES, u=Array((None,)))
    def values(self, names, u) -> dict:
        """The parameter dict with the blocks ``names`` taken from ``u`` (μ ≥ 0, finite)."""
        names = self.check_names(names)
        u = np.asarray(u, dtype=float).reshape(-1)
        n = sum(self.size(k) for k in names)
        if u.size != n or not np.all(np.isfinite(u)):
            raise InvalidInput(f"u must hold {n} finite numbers for {names}, got {u.size} values")
        d = {k: v.copy() for k, v in self.nominal.items()}
        for k, sl in self.slices(names).items():
            d[k] = u[sl].copy()
        if d["friction"][0] < 0:
            raise InvalidInput(f"friction must be ≥ 0, got {d['friction'][0]}")
        return d

    @contract(names=_NAMES, u=Array((None,)))
    def initial(self, names, u):
        """(y₀ = [x, q, P, L] (13,), T₀ (p, 12) tangent rows (δx, δφ, δP, δL) per parameter, μ, δμ (p,))."""
        d = self.values(names, u)
        sl = self.slices(names)
        p = sum(s.stop - s.start for s in sl.values())
        th, w0 = d["theta0"], d["omega0"]
        q = quat_multiply(quat_exp(th), self.body.orientation)
        R = quat_to_matrix(q)
        Iw = R @ (self.inertia[:, None] * R.T)
        L = Iw @ w0
        y = np.concatenate([d["x0"], q, self.mass * d["v0"], L])
        T, dmu = np.zeros((p, 12)), np.zeros(p)
        if "x0" in sl:
            T[sl["x0"], 0:3] = np.eye(3)
        if "theta0" in sl:
            Jl = left_jacobian(th)
            T[sl["theta0"], 3:6] = Jl.T
            T[sl["theta0"], 9:12] = ((-skew(L) + Iw @ skew(w0)) @ Jl).T
        if "v0" in sl:
            T[sl["v0"], 6:9] = self.mass * np.eye(3)
        if "omega0" in sl:
            T[sl["omega0"], 9:12] = Iw.T
        if "friction" in sl:
            dmu[sl["friction"]] = 1.0
        return y, T, float(d["friction"][0]), dmu


@dataclass
class Frames:
    """Every feature's contact geometry at one state (m features) and its derivatives in (δx, δφ).

    ``kind`` (m,): 0 sphere–plane, 1 corner–plane, 2 sphere–box; ``other`` (m,): the plane or box index;
    ``region`` (m, 4) and ``dregion`` (m, 4, 6): for sphere–box features, e − |c_l| per box axis (its sign
    says face / edge / vertex region: a change of region is a kink of the geometry) and 0.9 − |n_x| (where
    chapter 07's tangent frame changes its reference axis), with their derivatives; +inf elsewhere."""

    s: np.ndarray
    D: np.ndarray
    r: np.ndarray
    ds: np.ndarray
    dD: np.ndarray
    dr: np.ndarray
    kind: np.ndarray
    other: np.ndarray
    region: np.ndarray
    dregion: np.ndarray


def _frame_jac(n: np.ndarray, dn: np.ndarray):
    """(t₁, t₂) of chapter 07's tangent frame and their derivatives (3, 6) from dn (3, 6)."""
    a = np.array([1.0, 0, 0]) if abs(n[0]) < 0.9 else np.array([0.0, 1, 0])
    w = a - (a @ n) * n
    nw = np.linalg.norm(w)
    t1 = w / nw
    dw = -np.outer(n, a @ dn) - (a @ n) * dn
    dt1 = (np.eye(3) - np.outer(t1, t1)) @ dw / nw
    t2 = np.cross(n, t1)
    dt2 = -skew(t1) @ dn + skew(n) @ dt1
    return t1, t2, dt1, dt2


@contract(scene=Obj(ContactScene), x=Array((3,)), R=Array((3, 3)))
def frames(scene: ContactScene, x: np.ndarray, R: np.ndarray) -> Frames:
    """The contact geometry of every feature at position x, rotation R (see the module docstring)."""
    nP, nc = len(scene.planes), len(scene.corners)
    m = scene.n_features
    s, D, r = np.empty(m), np.empty((m, 3, 3)), np.empty((m, 3))
    ds, dD, dr = np.zeros((m, 6)), np.zeros((m, 3, 3, 6)), np.zeros((m, 3, 6))
    kind, other = np.empty(m, int), np.empty(m, int)
    region, dregion = np.full((m, 4), np.inf), np.zeros((m, 4, 6))
    if nP:
        cw = scene.corners @ R.T                                           # (nc, 3)
        k = np.arange(nP * nc)
        j, c = k // nc, k % nc
        n = scene.plane_n[j]
        s[k] = np.einsum("ki,ki->k", n, x + cw[c]) - scene.plane_o[j] - scene.radius
        D[k] = scene.plane_D[j]
        ds[k, :3] = n
        if scene.sphere:
            r[k], kind[k] = -scene.radius * n, 0
        else:
            r[k], kind[k] = cw[c], 1
            ds[k, 3:] = cross(cw[c], n)
            dr[k, :, 3:] = -skew(cw[c])
        other[k] = j
    for b, box in enumerate(scene.boxes):
        i = nP * nc + b
        cl = box.R.T @ (x - box.center)
        clamped = np.abs(cl) > box.half_extents
        d_l = cl - np.clip(cl, -box.half_extents, box.half_extents)
        dist = np.linalg.norm(d_l)
        if not dist > 0:
            raise InvalidInput(f"the sphere's centre is inside static box {b} at x = {x.tolist()}: no contact normal "
                               "(start the body outside, or use smaller steps)")
        n = box.R @ d_l / dist
        Pc = box.R @ (clamped[:, None] * box.R.T)
        dn = np.zeros((3, 6))
        dn[:, :3] = (np.eye(3) - np.outer(n, n)) @ Pc / dist
        t1, t2, dt1, dt2 = _frame_jac(n, dn)
        s[i], D[i], r[i] = dist - scene.radius, np.stack([n, t1, t2]), -scene.radius * n
        ds[i, :3] = n
        dD[i] = np.stack([dn, dt1, dt2])
        dr[i] = -scene.radius * dn
        kind[i], other[i] = 2, b
        region[i, :3] = box.half_extents - np.abs(cl)
        dregion[i, :3, :3] = -np.sign(cl)[:, None] * box.R.T
        region[i, 3], dregion[i, 3] = 0.9 - abs(n[0]), -np.sign(n[0]) * dn[0]
    return Frames(s, D, r, ds, dD, dr, kind, other, region, dregion)
