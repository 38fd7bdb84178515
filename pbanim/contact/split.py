"""Box-friction time stepping with a position correction that adds no kinetic energy (chapter 07, large scenes;
issue 28 point 4).

:class:`pbanim.contact.stepping.FrictionStepping` removes a penetration s < 0 by Baumgarte feedback in the
velocity solve, w = J u⁺ + erp·s/h: the velocity that pushes the bodies apart is real velocity, so it adds
kinetic energy, and the feedback has its own step limit (erp ≈ 0.2, ORACLES B2). A pile then rests a few
tenths of a millimetre deep, wherever the sweeps have not converged. :class:`SplitStepping` splits the two jobs
(post-stabilization, Cline & Pai 2003; the "split impulse" of Bullet and Box2D):

1. velocity:  0 ≤ fᵢ ⊥ w_fᵢ = J_n,i u⁺ + max(sᵢ, 0)/h ≥ 0, box friction on the tangents (the same warm-started
   colored sweep, :func:`pbanim.lcp.rows.pgs_box_friction_rows`), the sweeps stopped by the residual test
   ``tol`` (relative to max(1, ‖b‖∞)) or by ``iterations``: no feedback on penetration;
2. position: the separation the step would end with, ŝᵢ = sᵢ + h J_n,i u⁺, corrected by a pseudo-velocity v,

       0 ≤ pᵢ ⊥ J_n,i v + ŝᵢ/h ≥ 0,   v = W J_nᵀ p,

   a frictionless LCP on the normal rows (:func:`pbanim.lcp.rows.pgs_normal_rows`, the same colors), swept
   until its residual is ≤ ``position_tol``/h (so the linearized ŝ + h J_n v ≥ −position_tol) or
   ``position_iterations``; it is needed only when some ŝᵢ < 0 (otherwise no sweep runs);
3. advance: x₁ = x + h (u⁺ + v), q₁ = exp(h(ω⁺ + v_ω)) ∘ q (as exp(h v_ω) ∘ exp(h ω⁺) ∘ q), momenta from u⁺ alone, the
   angular momentum turned with the body by exp(h v_ω) (its body-frame value, hence T = ½ Lᵀ I_w⁻¹ L, unchanged).

v is a pseudo-velocity: it moves the bodies and is then forgotten, so the velocities, momenta and kinetic energy
after the step are exactly those of the velocity solve (the correction adds no kinetic energy: ORACLES D19);
the potential energy it adds is at most m g times the penetration it removes.

=========  ===============  ===========  ==================================================
symbol     code             shape        meaning
=========  ===============  ===========  ==================================================
u⁺         ``u``            (N+1, 6)     velocities after the contact impulses (last row: world)
ŝ          ``pred``         (m,)         separation the step would end with (linearized)
p          ``p``            (m,)         pseudo-impulses on the normal rows
v          ``v``            (N+1, 6)     pseudo-velocity (moves positions only)
=========  ===============  ===========  ==================================================

Limiting cases: no penetration predicted → no pseudo sweep, the step is FrictionStepping's with erp = 0 for
penetrations; ``correction=False`` → FrictionStepping's step (Baumgarte, ``erp``); a sphere (its normals
through its centre) gets no angular pseudo-velocity.

References: M. B. Cline, D. K. Pai, "Post-stabilization for rigid body simulation with contact and
constraints", ICRA 2003; E. Catto, "Iterative dynamics with temporal coherence", GDC 2005, and Box2D's
position solver (non-linear Gauss–Seidel on positions); E. Coumans, Bullet's split impulse.
"""

from __future__ import annotations

import numpy as np

from .stepping import FrictionStepping
from .specs import RIGID
from ..contracts import Flag, Func, Int, Obj, Real, Seq, contract
from ..lcp.rows import pgs_normal_rows

__all__ = ["SplitStepping"]


class SplitStepping(FrictionStepping):
    """Box-friction time stepping (PGS on the rows) with a position correction by pseudo-velocities (module
    docstring). ``tol``: the velocity sweeps' residual test (relative to max(1, ‖b‖∞)); ``iterations`` their
    cap; ``position_tol`` (m): the penetration the position sweeps leave at most (linearized);
    ``position_iterations`` their cap; ``correction=False``: FrictionStepping's Baumgarte step (``erp``).
    ``stats`` adds "position_steps" (steps that needed a correction) and "position_sweeps"."""

    @contract(system=RIGID, detect=Func(), forces=Seq(Obj("pbanim.scene:Effect")), friction=Real(ge=0),
              iterations=Int(ge=1, le=100_000), tol=Real(gt=0, lt=1), position_tol=Real(gt=0),
              position_iterations=Int(ge=1, le=100_000), erp=Real(gt=0, le=1), correction=Flag(), warm_start=Flag())
    def __init__(self, system, detect, forces=(), *, friction: float = 0.5, iterations: int = 50, tol: float = 1e-3,
                 position_tol: float = 2e-5, position_iterations: int = 100, erp: float = 0.2,
                 correction: bool = True, warm_start: bool = True) -> None:
        super().__init__(system, detect, forces, friction=friction, solver="pgs", iterations=iterations, erp=erp,
                         tol=tol, warm_start=warm_start, assembly="rows")
        self.position_tol, self.position_iterations = float(position_tol), int(position_iterations)
        self.correction = bool(correction)
        self.stats.update(position_steps=0, position_sweeps=0)

    def step(self, t: float, y: np.ndarray, h: float) -> np.ndarray:
        """One step t → t + h (``last_info``: contacts, residuals of both solves, the penetration at y): the step of
        FrictionStepping, whose velocity solve (:meth:`_solve_rows`) is replaced, then the bodies moved by h v."""
        self._h, self._shift = h, None
        self.last_info = {}
        y1 = super().step(t, y, h)
        self.last_info.setdefault("position_residual", 0.0)
        if self._shift is not None:
            _correct(self.system, y1, self._shift)
        return y1

    def _solve_rows(self, rows, Wb, u, bias, keys):
        """The velocity solve without feedback on penetration, then the position sweeps (module docstring, steps
        1–2): returns FrictionStepping's (z, residual, u⁺) and keeps h v for :meth:`step`."""
        if not self.correction:
            return super()._solve_rows(rows, Wb, u, bias, keys)
        h, N = self._h, self.system.N
        sep = -np.asarray(self.last_info["contacts"].depth, dtype=float)
        bias = bias.copy()
        bias[0::3] = np.maximum(sep, 0.0) / h                          # no feedback on penetration
        z, res, u = super()._solve_rows(rows, Wb, u, bias, keys)
        a, b = self._bodies
        Gan, Gbn = rows.Ga[0::3], rows.Gb[0::3]
        pred = sep + h * (np.einsum("rd,rd->r", Gan, u[a]) - np.einsum("rd,rd->r", Gbn, u[b]))
        if np.any(pred < -self.position_tol):
            p, pres, sweeps, v = pgs_normal_rows(a, b, Gan, Gbn, Wb, pred / h, self._colors_of(keys),
                                                 max_iter=self.position_iterations, tol=self.position_tol / h)
            self.stats["position_steps"] += 1
            self.stats["position_sweeps"] += sweeps
            self.last_info["position_residual"] = h * pres
            self._shift = h * v[:N]
        return z, res, u


def _correct(system, y, dq) -> None:
    """Move the bodies of state y (in place) by the displacement dq = h v (N, 6): x += h v_x; the rotation
    exp(h v_ω) applied to q and to the world angular momentum L (its body-frame value unchanged)."""
    from ..rigid.quat import quat_exp, quat_multiply, quat_rotate

    x, q, _, L = system.unpack(y)
    x += dq[:, :3]
    turn = np.flatnonzero(np.any(dq[:, 3:] != 0.0, axis=1))
    if turn.size:
        dr = quat_exp(dq[turn, 3:])
        q[turn] = quat_multiply(dr, q[turn])
        L[turn] = quat_rotate(dr, L[turn])
