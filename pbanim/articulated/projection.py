"""Post-step projection of rigid-body joints back onto C = 0 and J u = 0 (chapter 08).

Baumgarte feedback only pulls a drifting joint back over time; projection puts it back after every
step, as :class:`pbanim.constraints.Constraints` does for particles (Hairer, Lubich & Wanner, §VII.2):

    positions    δu = −W Jᵀ (J W Jᵀ)⁺ C,   x ← x + δv,   q ← normalize(q + ½ (0, δω) ⊗ q)      (repeat)
    velocities   λ = (J W Jᵀ)⁺ J u,        (P, L) ← (P, L) − Jᵀ λ                             (once)

Each position step is one Gauss–Newton step on C(y) = 0 with the mass metric W⁻¹: the smallest move,
in kinetic-energy terms, that cancels C to first order (a rotation δω of body i turns it by |δω|
about δω; small, since C is small after a step). Position steps repeat until max |C| ≤ ``tol`` or
``max_iter`` (a cap known before it starts; past it, :class:`~pbanim.errors.SingularConstraintError`
names the rows that did not converge). The velocity step is an impulse along the constraint normals:
afterwards J u = 0 exactly, and the kinetic energy never grows (an orthogonal projection in W⁻¹).

Notation: C, J the joint rows of :meth:`RigidJoints.rows`; W = diag(1/m, I⁻¹_world) per body; u = (v, ω);
(P, L) linear and angular momenta (the state of :class:`~pbanim.rigid.RigidBodies`).
"""

from __future__ import annotations

import numpy as np

from ..errors import SingularConstraintError
from ..rigid.quat import quat_multiply
from ..scene import Effect

__all__ = ["JointProjection"]


class JointProjection(Effect):
    """The post-step stage of :class:`~pbanim.articulated.RigidJoints` with ``projection=True``."""

    name = "joint-projection"
    phase = "post_step"

    def __init__(self, joints, tol: float = 1e-12, max_iter: int = 20) -> None:
        self.joints, self.tol, self.max_iter = joints, float(tol), int(max_iter)
        self.last_iterations = 0

    def bind(self, system) -> None:
        self.system = system

    def _lambda(self, y, J, rhs):
        Wb = self.system.inverse_mass_blocks(y)
        N = self.system.N
        WJt = np.einsum("nij,knj->kni", Wb, J.reshape(-1, N, 6)).reshape(J.shape[0], -1).T    # W Jᵀ (6N, k)
        lam = np.linalg.lstsq(J @ WJt, rhs, rcond=1e-12)[0]
        return WJt, lam

    def post_step(self, t: float, y: np.ndarray, h: float) -> np.ndarray:
        s = self.system
        y = y.copy()
        x, q, P, L = s.unpack(y)
        it = 0
        for it in range(1, self.max_iter + 1):
            C, J, _, _ = self.joints.rows(y)
            cmax = float(np.max(np.abs(C), initial=0.0))
            if cmax <= self.tol:
                break
            WJt, lam = self._lambda(y, J, C)
            du = -(WJt @ lam).reshape(-1, 6)
            x += du[:, :3]
            dq = np.concatenate([np.zeros((len(q), 1)), du[:, 3:]], axis=1)
            q += 0.5 * quat_multiply(dq, q)
            q /= np.linalg.norm(q, axis=1, keepdims=True)
        else:
            C = self.joints.rows(y)[0]
            bad = np.flatnonzero(np.abs(C) > self.tol)
            if bad.size:
                raise SingularConstraintError(bad[:20], float(np.max(np.abs(C))), "joint projection did not reach "
                                              f"|C| <= {self.tol:g} in {self.max_iter} steps")
        self.last_iterations = it
        _, J, _, _ = self.joints.rows(y)
        u = np.ravel(s.generalized_velocity(y))
        _, lam = self._lambda(y, J, J @ u)
        imp = (J.T @ lam).reshape(-1, 6)
        P -= imp[:, :3]
        L -= imp[:, 3:]
        return y
