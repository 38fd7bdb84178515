"""The prioritized control QP of a planar character on its lean path: one level after another, laid out once.

:meth:`QPController._prioritized <pbanim.control.qp.QPController._prioritized>` solves one QP per priority
level ℓ = 0, 1, …, L and a last one for the regularization,

    level ℓ:  min  Σ_{k∈ℓ} wₖ ‖J_k q̈ − bₖ‖²   s.t.  the equations of motion, the held contact points, the cones,
                                                  the limits, and A_ℓ' x = A_ℓ' x*_ℓ' for every level ℓ' above
    last:     min  ‖q̈‖² + ‖τ/τ_s‖² + ‖f/f_s‖²    s.t.  the same, with every level kept

(:func:`~.qp_solve.keep_level` adds each solved level's rows without making the equalities dependent), each
through :func:`~.qp_solve.solve_qp` (its checks, its scaling, ProxQP) and judged by ``_feasible``. On the planar
biped pressing its soles (:data:`~.qp_balance.BALANCE_FIRST`: four point tasks, then the centre of mass and the
angular momentum, then the posture) that is four QPs a step of 23 unknowns, and the Python around them costs
four times ProxQP's own time.

:class:`LeanLevels` solves the same levels from the lean build of :class:`~.qp_lean.LeanQP` (one pass over the
lean kinematics for H, C, the features, the contact and the point tasks' rows, arrays laid out once per
contact set, in the scaled unknowns x̃ = D⁻¹x):

* **a task level** (Q̃ = Σ wₖ J_kᵀ J_k on the q̈ block only: singular) has many optima x̃ but one value of
  its tasks, A_ℓ x* (a strictly convex function of y = A_ℓ x over the convex image of the feasible set), and
  only that value reaches the levels below. The readable path takes ProxQP's answer from the warm start of the
  level above (x0); so does the lean path, the same call with the same data, built without solve_qp's checks
  (the data are checked finite and below :data:`~.qp_solve.MAX_DATUM` once);
* **the last level** (Q̃ = D R D = I: strictly convex, one optimum) is sought first from the active set of the
  last step's last level (:class:`~.qp_active.ActiveSet`, as in :class:`~.qp_lean.LeanQP`), ProxQP from the
  level above's answer when that does not certify;
* every level's answer is judged as ``_feasible`` judges it (each constraint group within its tolerance, the
  kept rows within feasibility_tol (f_scale + max |b|)) and by its KKT residual, with the readable path's
  consequences: an answer not feasible keeps the level above ("… (kept level above)", not certified), a KKT
  residual above :data:`~.qp.KKT_TOL` makes the status "unconverged" (:meth:`QPController._judge` itself says
  so); where the readable path would go on from an answer that is not feasible (no feasible level above), or the
  data are not finite, the readable :meth:`QPController.solve` answers from the same state.

So the answer is the readable one to the solver's tolerance: the same problems level by level, each
level's kept value A_ℓ x* the same to eps_abs (tests/test_qp_lean_levels.py, ORACLES F25).

Notation as in :mod:`.qp`: q̈, τ, f the unknowns, x̃ = D⁻¹x with D = R^{-1/2}; A_ℓ the stacked rows of level ℓ's
tasks; ε the regularization. Reference: M. de Lasa and A. Hertzmann, "Prioritized optimization for task-space
control", IROS 2009.
"""

from __future__ import annotations

import time
from math import isfinite

import numpy as np

from ..articulated.planar_lean import LeanPlanarStep
from .qp import KKT_TOL, QPController
from .qp_active import ActiveSet as _ActiveSet
from .qp_active import kkt_lean as _kkt
from .qp_lean import LeanQP, _task_terms
from .qp_solve import MAX_DATUM, _level_rows

__all__ = []

_LEVEL_KINDS = ("com", "momentum", "posture", "point")


class LeanLevels(LeanQP):
    """``LeanLevels(ctrl, lean_step)``: the lean twin of ``ctrl.solve`` for a prioritized planar controller on
    native ProxQP without solver options (``supported``; otherwise every call goes to ``ctrl.solve``)."""

    @staticmethod
    def _supports(ctrl: QPController, lean_step: LeanPlanarStep) -> bool:
        """Whether the lean levels handle ``ctrl``: prioritized, native ProxQP, no solver options."""
        return (ctrl.mode == "prioritized" and ctrl.backend == "proxqp" and ctrl.native
                and all(t.kind in _LEVEL_KINDS for t in ctrl.tasks) and lean_step.kernel is ctrl.kernel
                and not ctrl.solver_options)

    def _level_layout(self, Lay: dict) -> dict:
        """The last level's Q̃ = D R D and the ProxQP's warm-start flag, once per contact set."""
        if "Qreg_s" not in Lay:
            nv, N, D = self.nv, Lay["N"], Lay["D"]
            R = np.concatenate([np.ones(nv), np.full(N - nv, self.f_scale ** -2)])
            Lay["Qreg_s"] = D[:, None] * np.diag(R) * D
            Lay["zeros"] = np.zeros(N)
            Lay["warm"] = self._proxqp.InitialGuess.WARM_START
        return Lay

    def _lean(self, t0, H, C, Jnt, bnt, keep, active, Lay, rows, As, beq, lbs, ubs):
        """The levels from the lean build (:meth:`_build`, begun at ``t0``); None: the readable path answers."""
        ctrl, nv, na = self.ctrl, self.nv, self.na
        Lay = self._level_layout(Lay)
        N, D = Lay["N"], Lay["D"]
        Gs, l, u = Lay["Gs"], Lay["l"], Lay["u"]
        nc = Gs.shape[0]
        # the unscaled equalities, for keep_level (the readable path keeps the levels in x, not x̃)
        n0 = As.shape[0]
        Aeq = np.zeros((n0, N))
        Aeq[:nv, :nv], Aeq[:nv, nv:nv + na], Aeq[:nv, nv + na:] = H, -ctrl.S.T, -Jnt.T
        Aeq[nv:, :nv] = Jnt[keep]
        live = [r for r in rows if r[3] > 0]
        levels = [[r for r in live if r[5] == lv] for lv in sorted({r[5] for r in live})]
        lbq, ubq = lbs[:nv], ubs[:nv]
        big = np.max([np.abs(H).max(), np.abs(beq).max(), np.abs(Jnt).max(initial=0.0),
                      np.abs(lbq[np.isfinite(lbq)]).max(initial=0.0), np.abs(ubq[np.isfinite(ubq)]).max(initial=0.0)])
        if not big <= MAX_DATUM:
            return None                                   # not finite or too large: the readable path says why
        t1 = time.perf_counter()
        x, statuses, iters, kkt, Z = None, [], 0, 0.0, None
        for here in levels + [None]:
            if here is None:                              # the last level: the regularization
                Q, g = Lay["Qreg_s"], Lay["zeros"]
                r = _ActiveSet.solve(Lay, Q, g, As, beq, Gs, u, lbs, ubs, ctrl.eps_abs)
            else:
                Ak = np.vstack([self._padded(J, idx, N) for _, J, _, _, idx, _ in here])
                T, Z = _level_rows(Aeq, Ak, Z=Z)          # Z: the equalities' null space, kept while they are
                if T is None:                             # A_k x fixed by the equalities: every feasible x is optimal
                    statuses.append("level fixed by the constraints")
                    continue
                Q, g = np.zeros((N, N)), np.zeros(N)
                Qq, gq = _task_terms(Q[:nv, :nv], g[:nv], here)   # in place: Σ wₖ Aₖᵀ Aₖ, −Σ wₖ Aₖᵀ bₖ
                if not np.max([np.abs(Qq).max(), np.abs(gq).max()]) <= MAX_DATUM:
                    return None
                r = None
            if r is None:
                kw = {} if x is None else {"x": x / D, "initial_guess": Lay["warm"]}
                r = self._dense_solve(Q, g, As, beq, Gs, l, u, l_box=lbs, u_box=ubs, eps_abs=ctrl.eps_abs,
                                      eps_rel=0.0, max_iter=ctrl.max_iter, **kw)
                if here is None:
                    _ActiveSet.remember(Lay, r.z, nc, lbs, ubs)
            xs = np.array(r.x, dtype=float)
            if not isfinite(float(xs.sum())):
                return None
            z = np.asarray(r.z)
            kk = _kkt(Q, g, As, beq, Gs, u, lbs, ubs, xs, r.y, z[:nc], z[nc:])
            xk = D * xs
            st = str(r.info.status).split(".")[-1]
            iters += int(r.info.iter)
            if not self._feasible(xk, H, C, Jnt, bnt, keep, lbq, ubq, Aeq, beq, n0):
                if x is None or not self._feasible(x, H, C, Jnt, bnt, keep, lbq, ubq, Aeq, beq, n0):
                    return None                           # the readable path goes on from xk: it says what happens
                statuses.append(f"{st} (kept level above)")   # as the readable path: x stays, not certified
                kkt = np.inf
                continue
            x, kkt = xk, max(kkt, kk)
            statuses.append(st)
            if here is not None:                          # keep this optimum (keep_level's rows T A_k x = T A_k x*)
                Aeq, beq = np.vstack([Aeq, T]), np.concatenate([beq, T @ x])
                As = np.vstack([As, T])                   # T acts on q̈ only, where D = 1
                Z = None
        t2 = time.perf_counter()
        if kkt <= KKT_TOL:
            return self._judge(x, H, C, Jnt, bnt, keep, active, rows, lbq, ubq, kkt, statuses, iters, t1 - t0, t2 - t1)
        # a level not certified (as the readable path, which goes on): QPController._judge says "unconverged"
        P = {"Aeq": Aeq[:n0], "beq": beq[:n0], "C": C, "bnt": bnt, "lb": lbs * D, "ub": ubs * D, "active": active,
             "tasks": [(t, self._padded(J, idx, N), b)
                       for t, (_, J, b, _, idx, _) in zip(ctrl.tasks, rows)]}
        return ctrl._judge(P, x, statuses, iters, kkt, t1 - t0, t2 - t1)

    def _padded(self, J, idx, N: int) -> np.ndarray:
        """A task's rows over all N unknowns (zero outside q̈), as QPController.build lays them out."""
        Jq = self._eye_nv[idx] if J is None else J
        A = np.zeros((Jq.shape[0], N))
        A[:, :self.nv] = Jq
        return A

    def _feasible(self, x, H, C, Jnt, bnt, keep, lbq, ubq, Aeq, beq, n0) -> bool:
        """:meth:`QPController._feasible` on the lean arrays: every group within its tolerance, the kept rows
        (past the first n0) within feasibility_tol (f_scale + max |b|)."""
        res, tol, _, _ = self._groups(x, H, C, Jnt, bnt, keep, lbq, ubq)
        if not all(res[k] <= tol[k] for k in res):
            return False
        kept = self.ctrl.feasibility_tol * (self.f_scale + np.abs(beq).max(initial=0.0))
        return bool(np.abs(Aeq[n0:] @ x - beq[n0:]).max(initial=0.0) <= kept)
