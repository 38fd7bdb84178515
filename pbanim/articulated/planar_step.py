"""One time step of a planar tree touching the ground, with joint servos folded into the step (chapter 08).

Velocity-level time stepping (Stewart & Trinkle 1996; chapter 07's :class:`~pbanim.contact.TimeStepping`)
with the planar closed forms of :class:`~pbanim.articulated.planar.PlanarKernel`:

    (H + h K_d) u⁺ = H q̇ + h (τ − C(q, q̇)) + Jᵀ z                (K_d: damping taken at the new velocity)
    q⁺ = q + h u⁺

K_d holds the passive joint damping and, for servos in *stable PD* form (Tan, Liu & Turk 2011), their
derivative gains: τ = k_p(θ̄ − θ − h θ̇) − k_d θ̇⁺ is the servo evaluated at the next state, so the k_d part
moves to the left-hand side and the step stays stable for any gains (ORACLES F1). Explicit servos put
their whole torque in τ and nothing in K_d.

Contacts are points on links against the ground line n·x = 0 (a slope of angle α has n = (−sin α, cos α)).
Per contact the normal impulse zₙ ≥ 0 and the friction impulse |zₜ| ≤ μ zₙ (in the plane the friction
cone is exactly this interval), with

    0 ≤ zₙ ⊥ vₙ⁺ + max(gap, 0)/h + β min(gap, 0)/h ≥ 0,      vₜ⁺ = 0 while |zₜ| < μ zₙ,
    zₜ = −μ zₙ sign(vₜ⁺) when sliding.

:func:`pbanim.lcp.planar.solve_planar_contact` (the LCP core) first tries the previous step's contact modes:
one linear solve, accepted when every condition above holds to roundoff; failing modes are switched, and
when that cycles projected Gauss–Seidel finds them. While a foot stays planted the guess is right and the
step costs one factorization of a small matrix.
"""

from __future__ import annotations

import numpy as np

from ..contracts import Array, Obj, Opt, Real, contract, finite_result
from ..errors import NonFiniteResult, check_result
from ..lcp.planar import SEPARATE, SLIDE_NEG, SLIDE_POS, STICK, solve_planar_contact  # noqa: F401 (re-exported)
from .planar import PlanarKernel
from .specs import LinkPoints, PlanarKinematics

__all__ = ["PlanarGround", "PlanarContactStep", "solve_planar_contact", "SEPARATE", "STICK", "SLIDE_POS",
           "SLIDE_NEG"]


_Q = Array(("self.kernel.nv",))


class PlanarGround:
    """The ground line through the origin at slope ``angle`` (radians; positive climbs toward +x)."""

    @contract(angle=Real(ge=-np.pi / 3, le=np.pi / 3), friction=Real(ge=0))
    def __init__(self, angle: float = 0.0, friction: float = 0.9) -> None:
        self.angle, self.mu = float(angle), float(friction)
        self.normal = np.array([-np.sin(self.angle), np.cos(self.angle)])
        self.tangent = np.array([np.cos(self.angle), np.sin(self.angle)])

    @contract(p=Array((2,), batch="first"))
    def gap(self, p: np.ndarray) -> np.ndarray:
        """n·p: the signed distance of points p (2,) or (m, 2) above the line."""
        return p @ self.normal

    @contract(x=Array(None, scalar=True))
    def height(self, x) -> np.ndarray:
        """The ground's height y at abscissa x."""
        return np.asarray(x) * np.tan(self.angle)


class PlanarContactStep:
    """Steps a planar tree with contact points on the ground; torques and implicit damping per call.

    ``points``: (link index, point in the link frame (3,)) pairs, e.g. a heel and a toe per foot.
    """

    @contract(kernel=Obj(PlanarKernel), points=LinkPoints("kernel.n"), ground=Opt(Obj(PlanarGround)),
              erp=Real(ge=0, le=1), margin=Real(ge=0), cfm=Real(ge=0, le=1e-2))
    def __init__(self, kernel: PlanarKernel, points, ground: PlanarGround | None = None, *,
                 erp: float = 0.2, margin: float = 0.01, cfm: float = 1e-6) -> None:
        pts = list(points)
        self.kernel = kernel
        self.links = np.array([int(lk) for lk, _ in pts])
        self.local = np.array([np.asarray(p, dtype=float) for _, p in pts]).reshape(-1, 3)
        self.ground = PlanarGround() if ground is None else ground
        self.erp, self.margin, self.cfm = float(erp), float(margin), float(cfm)
        self.modes = np.zeros(len(pts), dtype=int)      # per contact point, SEPARATE when not near
        self._r0z = kernel.point_offsets(self.links, self.local)
        self._nbar = complex(self.ground.normal[0], -self.ground.normal[1])
        self._tbar = complex(self.ground.tangent[0], -self.ground.tangent[1])
        self.last: dict = {}

    @contract(q=_Q, qd=_Q, h=Real(gt=0), tau=_Q, kd=Opt(Array(("self.kernel.nv",), ge=0)),
              kin=Opt(PlanarKinematics("self.kernel")))
    def step(self, q: np.ndarray, qd: np.ndarray, h: float, tau: np.ndarray, kd=None, kin=None):
        """(q⁺, u⁺) after one step of length h with joint forces τ and implicit damping gains ``kd``
        (per coordinate, ≥ 0); ``kin``: the kernel's kinematics of q when the caller has it. ``last``
        records the contact solve, with ``success``: whether its impulses meet every contact condition."""
        k, gr = self.kernel, self.ground
        H, C, kin = k.dynamics(q, qd, kin)
        d = k.damping if kd is None else k.damping + kd
        Mt = H + h * np.diag(d)
        rhs = H @ qd + h * (tau - C)
        if not np.isfinite(Mt.sum() + rhs.sum()):      # NaN or inf anywhere (or a sum that overflows)
            raise NonFiniteResult("the planar step's (H + h K_d) u⁺ = H q̇ + h (τ − C)", f"at h = {h:g}")
        # contact points as complex numbers x + i y; n·p = Re(p n̄)
        pz = kin["zo"][self.links] + kin["rot"][self.links] * self._r0z
        gap = (pz * self._nbar).real
        Jz = k._jacobians_z(kin, self.links, pz)
        vn = ((Jz @ qd) * self._nbar).real                   # normal speeds now: which points may touch
        near = np.flatnonzero(gap < self.margin + h * np.maximum(-vn, 0.0) + h * h * 10.0)
        if near.size:
            Jn = Jz[near]
            rows = np.empty((2 * near.size, k.nv))
            rows[0::2], rows[1::2] = (Jn * self._nbar).real, (Jn * self._tbar).real
            sol = np.linalg.solve(Mt, np.column_stack([rhs, rows.T]))
            u, MinvJt = sol[:, 0], sol[:, 1:]
            A = rows @ MinvJt
            A += self.cfm * max(float(A.diagonal().max()), 1e-300) * np.eye(A.shape[0])
            b = rows @ u
            g = gap[near]
            b[0::2] += np.maximum(g, 0.0) / h + self.erp * np.minimum(g, 0.0) / h
            if not (np.isfinite(A).all() and np.isfinite(b).all()):
                raise NonFiniteResult("the planar contact problem", f"at h = {h:g} (a step that large or that "
                                      "small overflows the impulse equations)")
            z, modes, info = solve_planar_contact(A, b, gr.mu, self.modes[near])
            u = u + MinvJt @ z
            self.modes[:] = SEPARATE
            self.modes[near] = modes
            self.last = {"near": near, "impulses": z, "path": info["path"], "gap": gap,
                         "success": bool(info["success"])}
        else:
            u = np.linalg.solve(Mt, rhs)
            self.modes[:] = SEPARATE
            self.last = {"near": near, "impulses": np.zeros(0), "path": "free", "gap": gap, "success": True}
        return check_result("PlanarContactStep.step", (q + h * u, u), f"at h = {h:g}")

    @contract(h=Real(gt=0), returns=finite_result)
    def contact_forces(self, h: float) -> np.ndarray:
        """Normal force per contact point over the last step (impulse / h), zero where not in contact."""
        f = np.zeros(self.local.shape[0])
        if self.last.get("near") is not None and self.last["near"].size:
            f[self.last["near"]] = self.last["impulses"][0::2] / h
        return f
