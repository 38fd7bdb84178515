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

from ..errors import InvalidInput, check_number
from ..lcp.planar import SEPARATE, SLIDE_NEG, SLIDE_POS, STICK, solve_planar_contact  # noqa: F401 (re-exported)
from .planar import PlanarKernel

__all__ = ["PlanarGround", "PlanarContactStep", "solve_planar_contact", "SEPARATE", "STICK", "SLIDE_POS",
           "SLIDE_NEG"]


class PlanarGround:
    """The ground line through the origin at slope ``angle`` (radians; positive climbs toward +x)."""

    def __init__(self, angle: float = 0.0, friction: float = 0.9) -> None:
        self.angle = check_number("angle", angle, low=-np.pi / 3, high=np.pi / 3)
        self.mu = check_number("friction", friction, low=0.0)
        self.normal = np.array([-np.sin(self.angle), np.cos(self.angle)])
        self.tangent = np.array([np.cos(self.angle), np.sin(self.angle)])

    def gap(self, p: np.ndarray) -> np.ndarray:
        return p @ self.normal

    def height(self, x) -> np.ndarray:
        """The ground's height y at abscissa x."""
        return np.asarray(x) * np.tan(self.angle)


class PlanarContactStep:
    """Steps a planar tree with contact points on the ground; torques and implicit damping per call.

    ``points``: (link index, point in the link frame (3,)) pairs, e.g. a heel and a toe per foot.
    """

    def __init__(self, kernel: PlanarKernel, points, ground: PlanarGround | None = None, *,
                 erp: float = 0.2, margin: float = 0.01, cfm: float = 1e-6) -> None:
        if not isinstance(kernel, PlanarKernel):
            raise InvalidInput(f"kernel must be a PlanarKernel, got {type(kernel).__name__}")
        pts = list(points)
        if not pts:
            raise InvalidInput("points must list at least one (link, point) pair")
        self.kernel = kernel
        self.links = np.array([int(lk) for lk, _ in pts])
        if np.any(self.links < 0) or np.any(self.links >= kernel.n):
            raise InvalidInput(f"contact links must be in 0..{kernel.n - 1}, got {self.links.tolist()}")
        self.local = np.array([np.asarray(p, dtype=float) for _, p in pts])
        if self.local.shape != (len(pts), 3) or not np.all(np.isfinite(self.local)):
            raise InvalidInput(f"contact points must be finite 3-vectors, got shape {self.local.shape}")
        self.ground = PlanarGround() if ground is None else ground
        self.erp = check_number("erp", erp, low=0.0, high=1.0)
        self.margin = check_number("margin", margin, low=0.0)
        self.cfm = check_number("cfm", cfm, low=0.0, high=1e-2)
        self.modes = np.zeros(len(pts), dtype=int)      # per contact point, SEPARATE when not near
        self._r0z = kernel.point_offsets(self.links, self.local)
        self._nbar = complex(self.ground.normal[0], -self.ground.normal[1])
        self._tbar = complex(self.ground.tangent[0], -self.ground.tangent[1])
        self.last: dict = {}

    def step(self, q: np.ndarray, qd: np.ndarray, h: float, tau: np.ndarray, kd=None, kin=None):
        """(q⁺, u⁺) after one step of length h with joint forces τ and implicit damping gains ``kd``
        (per coordinate, ≥ 0); ``kin``: the kernel's kinematics of q when the caller has it."""
        k, gr = self.kernel, self.ground
        H, C, kin = k.dynamics(q, qd, kin)
        d = k.damping if kd is None else k.damping + kd
        Mt = H + h * np.diag(d)
        rhs = H @ qd + h * (tau - C)
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
            z, modes, info = solve_planar_contact(A, b, gr.mu, self.modes[near])
            u = u + MinvJt @ z
            self.modes[:] = SEPARATE
            self.modes[near] = modes
            self.last = {"near": near, "impulses": z, "path": info["path"], "gap": gap}
        else:
            u = np.linalg.solve(Mt, rhs)
            self.modes[:] = SEPARATE
            self.last = {"near": near, "impulses": np.zeros(0), "path": "free", "gap": gap}
        return q + h * u, u

    def contact_forces(self, h: float) -> np.ndarray:
        """Normal force per contact point over the last step (impulse / h), zero where not in contact."""
        f = np.zeros(self.local.shape[0])
        if self.last.get("near") is not None and self.last["near"].size:
            f[self.last["near"]] = self.last["impulses"][0::2] / h
        return f
