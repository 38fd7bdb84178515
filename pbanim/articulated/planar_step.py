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

:func:`solve_planar_contact` first tries the previous step's contact modes (separate, stick, slide ±):
one linear solve, accepted when every condition above holds to roundoff; a change of modes falls back
to the core's projected Gauss–Seidel (:func:`pbanim.lcp.pgs_box_friction`) and the modes it finds are
polished by the same direct solve. While a foot stays planted the guess is right and the step costs one
factorization of a small matrix.
"""

from __future__ import annotations

import numpy as np

from ..errors import InvalidInput, check_number
from ..lcp import pgs_box_friction
from .planar import PlanarKernel

__all__ = ["PlanarGround", "PlanarContactStep", "solve_planar_contact", "SEPARATE", "STICK", "SLIDE_POS",
           "SLIDE_NEG"]

SEPARATE, STICK, SLIDE_POS, SLIDE_NEG = 0, 1, 2, 3        # SLIDE_POS: sliding along +t (friction −μ zₙ)


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


def _check_modes(A, b, z, modes, mu, tol) -> bool:
    w = A @ z + b
    scale = tol * (1.0 + np.abs(b).max(initial=0.0))
    zn, zt, wn, wt = z[0::2], z[1::2], w[0::2], w[1::2]
    sep = modes == SEPARATE
    stick = modes == STICK
    pos, neg = modes == SLIDE_POS, modes == SLIDE_NEG
    ok = np.all(wn[sep] >= -scale) and np.all(zn[~sep] >= -scale) and np.all(np.abs(wn[~sep]) <= scale)
    ok = ok and np.all(np.abs(zt[stick]) <= mu * zn[stick] + scale) and np.all(np.abs(wt[stick]) <= scale)
    return bool(ok and np.all(wt[pos] >= -scale) and np.all(wt[neg] <= scale))


def _switch_modes(w, z, modes, mu, eps):
    """One round of mode changes from the violated conditions (a touching contact pulls: separate; a
    separated one penetrates: stick; sticking beyond the cone: slide; a slide that reverses: stick)."""
    zn, zt, wn, wt = z[0::2], z[1::2], w[0::2], w[1::2]
    new = modes.copy()
    new[(modes == SEPARATE) & (wn < -eps)] = STICK
    new[(modes != SEPARATE) & (zn < -eps)] = SEPARATE
    over = (modes == STICK) & (np.abs(zt) > mu * zn + eps)
    new[over & (zt > 0)] = SLIDE_NEG
    new[over & (zt < 0)] = SLIDE_POS
    new[((modes == SLIDE_POS) & (wt < -eps)) | ((modes == SLIDE_NEG) & (wt > eps))] = STICK
    return new


def _solve_modes(A, b, modes, mu):
    """z with the contact modes imposed (one linear solve), or None when that system is singular."""
    m = modes.size
    z = np.zeros(2 * m)
    rows = []                                            # equations w_r = 0
    for i, md in enumerate(modes):
        if md != SEPARATE:
            rows.append(2 * i)
        if md == STICK:
            rows.append(2 * i + 1)
    if not rows:
        return z
    # unknowns: the normal impulses of touching contacts and the tangential ones of sticking contacts;
    # a sliding contact's tangential impulse is ∓μ zₙ, folded into its normal column
    cols = np.array(rows)
    T = np.zeros((2 * m, cols.size))
    for c, r in enumerate(cols):
        T[r, c] = 1.0
        if r % 2 == 0 and modes[r // 2] in (SLIDE_POS, SLIDE_NEG):
            T[r + 1, c] = -mu if modes[r // 2] == SLIDE_POS else mu
    K = A[cols] @ T
    try:
        x = np.linalg.solve(K, -b[cols])
    except np.linalg.LinAlgError:
        return None
    return T @ x


def solve_planar_contact(A: np.ndarray, b: np.ndarray, mu: float, guess=None, *, tol: float = 1e-9,
                         max_iter: int = 200) -> tuple[np.ndarray, np.ndarray, dict]:
    """Impulses z = (zₙ₁, zₜ₁, zₙ₂, …) of planar contacts with w = A z + b (see the module docstring).

    ``guess``: contact modes to try first (previous step's). Modes are switched where a condition fails
    (at most 3m + 3 rounds); if that cycles, projected Gauss–Seidel finds the modes. Returns (z, modes,
    info) with info["path"] "guess" (the modes held), "modes" (switched), "pgs+polish" or "pgs" (the
    polish failed; z is PGS's, with its residual).
    """
    m = b.size // 2
    modes = np.array(guess if guess is not None and len(guess) == m else np.zeros(m, int))
    for it in range(3 * m + 3):                           # mode switching, a cap known before it starts
        z = _solve_modes(A, b, modes, mu)
        if z is None:
            break
        if _check_modes(A, b, z, modes, mu, tol):
            return z, modes, {"path": "guess" if it == 0 else "modes", "sweeps": it}
        modes = _switch_modes(A @ z + b, z, modes, mu, tol * (1.0 + np.abs(b).max(initial=0.0)))
    # PGS on the 3-row form (a zero second tangent with unit diagonal), then polish its modes
    A3 = np.zeros((3 * m, 3 * m))
    b3 = np.zeros(3 * m)
    idx = np.arange(3 * m).reshape(m, 3)[:, :2].ravel()
    A3[np.ix_(idx, idx)] = A
    A3[2::3, 2::3] = np.eye(m)
    b3[idx] = b
    z3, res, sweeps = pgs_box_friction(A3, b3, mu, max_iter=max_iter, tol=tol)
    z = z3[idx]
    w = A @ z + b
    zn, zt, wt = z[0::2], z[1::2], w[1::2]
    modes = np.where(zn <= 1e-12 * (1 + zn.max(initial=0.0)), SEPARATE,
                     np.where(np.abs(zt) < mu * zn * (1 - 1e-6), STICK, np.where(wt > 0, SLIDE_POS, SLIDE_NEG)))
    zp = _solve_modes(A, b, modes, mu)
    if zp is not None and _check_modes(A, b, zp, modes, mu, tol):
        return zp, modes, {"path": "pgs+polish", "sweeps": sweeps}
    return z, modes, {"path": "pgs", "sweeps": sweeps, "residual": res}


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
