"""The weighted control QP of a planar character on its lean path: shapes decided once, one bound solver call.

:meth:`QPController.solve <pbanim.control.qp.QPController.solve>` is written to be read: it builds the QP of
:mod:`.qp` from the kernel's kinematics dict, the centroidal features (:func:`~.qp_features.centroidal`), one
row block per task (:func:`~.qp_tasks.task_rows`) zero-padded to all N = n_v + n_a + 2m unknowns, the contact
rows, the friction pyramid and the bounds, hands them to :func:`~.qp_solve.solve_qp` (which checks their size,
scales them and calls ProxQP), and judges the answer (:meth:`QPController._judge`). On the planar biped the
QP has 15–23 unknowns and ProxQP needs two iterations: the Python around it costs more than the solve.

:class:`LeanQP` solves the same QP

    min  ½ x̃ᵀ Q̃ x̃ + g̃ᵀ x̃   s.t.  Ã x̃ = b,   C̃ x̃ ≤ 0,   l̃ ≤ x̃ ≤ ũ         (x = D x̃, D = R^{-1/2})

with Q̃ = ε I + Σₖ wₖ J_kᵀ J_k on the q̈ block only (a task acts on q̈ alone; ε D R D = ε I elsewhere, set
once), g̃ = −Σₖ wₖ J_kᵀ (ÿₖ* − J̇_k q̇), Ã = [[H, −Sᵀ D_τ, −J_cᵀ D_f], [J_c,keep, 0, 0]], b = [−C, −J̇_c q̇]:

* what depends only on the controller — D, the cone rows C̃, the bounds of τ and f, the posture's indices,
  each task's gains and weight — is set at construction; per contact set (which points are active, which
  of their rows are kept) the arrays of the QP are allocated once and rewritten in place at every step;
* H, C and the bias accelerations J̇ q̇ of the centres come from one pass over the complex kinematics of
  :class:`~pbanim.articulated.planar_lean.LeanPlanarStep` (its ``kinematics`` and ``com_jacobians``), the
  centroidal features and the contact rows from the same arrays (the formulas of :mod:`.qp_features` and
  :func:`~.qp_solve.contact_rows`, QR with column pivoting for the kept rows);
* the optimum is first sought from the active set of the last answer (the cone rows and bounds held as
  equalities: one solve of the KKT matrix, corrected for up to four rounds by the primal active-set step),
  kept only when every inactive row holds to eps_abs and every held row's multiplier has its sign; a
  standing or recovering biped keeps its active set for hundreds of steps (measured: 3 of 1250 control steps
  of a 20 N s run ask ProxQP, 28 of 952 of a 30 N s fall). Otherwise ProxQP's dense ``solve``, bound once,
  is called once, and its multipliers give the next active set. The answer from the active set is the QP's
  optimum to roundoff (strictly convex: ε > 0), where ProxQP's is to eps_abs, and it is not subject to
  ProxQP's false infeasibility certificate (F21, F22: tests/test_qp_lean.py meets one);
* the answer is certified by the same cheap checks as the readable path: the KKT residual from ProxQP's
  multipliers (:data:`~.qp.KKT_TOL`), each constraint group's residual against its tolerance, each task's error.

The result is a :class:`~.qp.QPResult` with the readable path's status, residuals, tolerances and task errors;
equal to the readable path to the solver's tolerance (the operations are the same up to their order;
tests/test_qp_lean.py, ORACLES F23). Whatever it does not handle — a prioritized controller (:mod:`.qp_lean_levels` has its lean levels), another
backend, a task kind other than centre of mass, angular momentum and posture, data that are not finite or
beyond :data:`~.qp_solve.MAX_DATUM`, a status other than met or compromise — goes to the readable
:meth:`QPController.solve` from the same state, which answers (or raises) as it always does.

Notation as in :mod:`.qp`: q̈, τ, f the unknowns; H, C the equations of motion; J_c, J̇_c q̇ the contact rows;
μ friction; wₖ, ÿₖ* the tasks' weights and desired accelerations; ε the regularization.
"""

from __future__ import annotations

import time
from math import isfinite, sqrt

import numpy as np
from scipy.linalg.lapack import dgeqp3

from ..articulated.planar_lean import LeanPlanarStep
from ..contracts import Anything, Array, Flag, Obj, contract, unchecked
from .qp import KKT_TOL, InfeasibleControl, QPController, QPResult
from .qp_active import ActiveSet as _ActiveSet
from .qp_active import kkt_lean as _kkt
from .qp_solve import MAX_DATUM, friction_pyramid

__all__ = ["LeanQP"]

_KINDS = ("com", "momentum", "posture")


class LeanQP:
    """``LeanQP(ctrl, lean_step)``: the lean twin of ``ctrl.solve`` for a weighted planar controller on native
    ProxQP (``supported`` says whether ``ctrl`` is one; otherwise every call goes to ``ctrl.solve``).

    ``lean_step``: the :class:`LeanPlanarStep` of the simulation (its kernel's constants and kinematics).
    The tasks, weights and settings are read at construction: change them on ``ctrl`` and build a new one.
    """

    @contract(ctrl=Obj(QPController), lean_step=Obj(LeanPlanarStep))
    def __init__(self, ctrl: QPController, lean_step: LeanPlanarStep) -> None:
        k = ctrl.kernel
        self.ctrl, self.lean, self.kernel = ctrl, lean_step, k
        self._readable = unchecked(ctrl.solve)
        self.supported = self._supports(ctrl, lean_step)
        nv, na = k.nv, ctrl.na
        self.nv, self.na = nv, na
        self.mass, self.M = k.mass, float(k.mass.sum())
        self.IzzPhi = k.Izz @ k.Phi
        self.links, self.r0z = ctrl.links, k.point_offsets(ctrl.links, ctrl.local)
        self.Pr_c, self.Dz_c, self.P_c = k.Pr[ctrl.links], k._Dz[ctrl.links], k.P[ctrl.links]
        n_, t_ = ctrl.ground.normal, ctrl.ground.tangent
        self.normal, self.nx, self.ny, self.tx, self.ty = n_, float(n_[0]), float(n_[1]), float(t_[0]), float(t_[1])
        self.Pr, self.Dz, self.P = k.Pr, k._Dz, k.P
        self.tasks = []             # (kind, weight, gains, target, acceleration, velocity, idx, name, priority, point's link, offset)
        for t in ctrl.tasks:
            idx = np.array([ctrl.joints[nm] for nm in t.target]) if t.kind == "posture" else None
            pt = (int(t.link), complex(k.point_offsets([t.link], [t.local])[0])) if t.kind == "point" else (-1, 0j)
            self.tasks.append((t.kind, float(t.weight), float(t.kp), float(t.kd), t._target, t.acceleration,
                               t.velocity, idx, t.name, int(t.priority)) + pt)
        self.eps, self.f_scale = ctrl.eps, ctrl.f_scale
        self.equilibrate = bool(ctrl.solver_options.get("equilibrate", False))
        self.primal_inf = ctrl.solver_options.get("primal_inf")
        self._layouts: dict = {}
        self._eye_nv = np.eye(nv)
        if self.supported:
            import proxsuite  # lazy: only a controller that solves loads it

            self._dense_solve = proxsuite.proxqp.dense.solve
            self._proxqp = proxsuite.proxqp

    @staticmethod
    def _supports(ctrl: QPController, lean_step: LeanPlanarStep) -> bool:
        """Whether the lean path handles ``ctrl``: weighted, native ProxQP, tasks of :data:`_KINDS`."""
        return (ctrl.mode == "weighted" and ctrl.backend == "proxqp" and ctrl.native
                and all(t.kind in _KINDS for t in ctrl.tasks) and lean_step.kernel is ctrl.kernel
                and not set(ctrl.solver_options) - {"equilibrate", "primal_inf"})

    # -- once per contact set -------------------------------------------------------------------
    def _layout(self, m2: int) -> dict:
        """The arrays of the QP with 2m = ``m2`` force entries: D, Q̃ (its constant diagonal set), Ã with −Sᵀ D_τ
        set, C̃, l, u and the bounds' constant entries (the layout of :meth:`QPController.build`)."""
        L = self._layouts.get(m2)
        if L is not None:
            return L
        c, nv, na = self.ctrl, self.nv, self.na
        N = nv + na + m2
        R = np.concatenate([np.ones(nv), np.full(na, self.f_scale ** -2), np.full(m2, self.f_scale ** -2)])
        D = R ** -0.5
        Q = np.zeros((N, N))
        Q.flat[::N + 1] = D * (self.eps * R) * D
        G = friction_pyramid(m2 // 2, 2, c.ground.mu, nv + na, N)
        lb = np.concatenate([np.full(nv, -np.inf), -c.torque_limits, np.tile([c.min_normal, -np.inf], m2 // 2)])
        ub = np.concatenate([np.full(nv, np.inf), c.torque_limits, np.full(m2, np.inf)])
        L = {"N": N, "D": D, "Dq": D[nv:], "Q": Q, "g": np.zeros(N), "G": G, "Gs": G * D, "l": np.full(G.shape[0], -np.inf),
             "u": np.zeros(G.shape[0]), "lb": lb, "ub": ub, "lbs": lb / D, "ubs": ub / D, "StD": -c.S.T * D[nv:nv + na]}
        self._layouts[m2] = L
        return L

    # -- per step -------------------------------------------------------------------------------
    @contract(q=Array(("self.nv",)), qd=Array(("self.nv",)), kin=Anything("LeanPlanarStep.kinematics(q) and its "
              "com_jacobians: complex arrays of the same q"), raise_on_failure=Flag())
    def solve(self, q, qd, kin, *, raise_on_failure: bool = False) -> QPResult:
        """The control QP at (q, q̇): :meth:`QPController.solve`'s result (see the module docstring);
        ``kin`` = (rot, w, zo, zc, Jz) of :class:`LeanPlanarStep` at q."""
        if self.supported:
            with np.errstate(all="ignore"):
                t0 = time.perf_counter()
                B = self._build(q, qd, kin)         # None when the contact rows' QR fails
                out = None if B is None else self._lean(t0, *B)
            if out is not None:
                if raise_on_failure and not out.success:
                    raise InfeasibleControl(out)
                return out
        return self._readable(q, qd, raise_on_failure=raise_on_failure)

    def _lean(self, t0, H, C, Jnt, bnt, keep, active, Lay, rows, Aeq, beq, lbs, ubs):
        """The weighted QP from the lean build (:meth:`_build`, begun at ``t0``); None: the readable path answers."""
        ctrl, nv, N, D = self.ctrl, self.nv, Lay["N"], Lay["D"]
        Q, g = Lay["Q"], Lay["g"]
        Qq, gq = _task_terms(self.eps * self._eye_nv, np.zeros(nv), [r for r in rows if r[3] > 0])
        Q[:nv, :nv] = Qq
        g[:nv] = gq
        neq = Aeq.shape[0]
        Gs, l, u = Lay["Gs"], Lay["l"], Lay["u"]
        if not isfinite(float(Qq.sum() + gq.sum() + Aeq.sum() + beq.sum())):
            return None                                   # not finite: the readable path says why
        As, Cs, bs, ls, us = Aeq, Gs, beq, l, u
        if self.equilibrate:                              # solve_qp's equilibrate: rows over their largest entry
            sa = np.abs(Aeq).max(axis=1, initial=0.0)
            sa = 1.0 / np.where(sa > 0, sa, 1.0)
            sc = np.abs(Gs).max(axis=1, initial=0.0)
            sc = 1.0 / np.where(sc > 0, sc, 1.0)
            As, bs, Cs, ls, us = sa[:, None] * Aeq, sa * beq, sc[:, None] * Gs, sc * l, sc * u
        t1 = time.perf_counter()
        r = _ActiveSet.solve(Lay, Q, g, As, bs, Cs, us, lbs, ubs, ctrl.eps_abs)
        if r is None and not max(np.abs(Qq).max(), np.abs(gq).max(), np.abs(Aeq).max(), np.abs(beq).max(),
                                 np.abs(lbs[:nv][np.isfinite(lbs[:nv])]).max(initial=0.0),
                                 np.abs(ubs[:nv][np.isfinite(ubs[:nv])]).max(initial=0.0)) <= MAX_DATUM:
            return None                                   # beyond MAX_DATUM ProxQP stalls: the readable path says why
        if r is None and self.primal_inf is None:
            r = self._dense_solve(Q, g, As, bs, Cs, ls, us, l_box=lbs, u_box=ubs, eps_abs=ctrl.eps_abs, eps_rel=0.0,
                                  max_iter=ctrl.max_iter)
        elif r is None:
            qp = self._proxqp.dense.QP(N, neq, Cs.shape[0], True)
            st = qp.settings
            st.eps_abs, st.eps_rel, st.max_iter, st.eps_primal_inf = ctrl.eps_abs, 0.0, ctrl.max_iter, self.primal_inf
            qp.init(Q, g, As, bs, Cs, ls, us, lbs, ubs)
            qp.solve()
            r = qp.results
        if not isinstance(r, _ActiveSet):
            _ActiveSet.remember(Lay, r.z, Cs.shape[0], lbs, ubs)
        xs, y, z = r.x, r.y, r.z
        t2 = time.perf_counter()
        if not isfinite(float(xs.sum())):
            return None
        nc = Cs.shape[0]
        kkt = _kkt(Q, g, As, bs, Cs, us, lbs, ubs, xs, y, z[:nc], z[nc:])
        x = D * xs
        return self._judge(x, H, C, Jnt, bnt, keep, active, rows, lbs[:nv], ubs[:nv], kkt,
                           [str(r.info.status).split(".")[-1]], int(r.info.iter), t1 - t0, t2 - t1)

    def _build(self, q, qd, kin):
        """(H, C, J_c, J̇_c q̇, kept rows, active mask, layout, task rows, Ã, b, l̃, ũ) at (q, q̇); None when the
        contact rows' QR fails (the readable path answers)."""
        rot, w, zo, zc, Jz = kin
        lean, nv, na, m = self.lean, self.nv, self.na, self.mass
        # equations of motion and the centres' bias accelerations J̇ᵢ q̇ (PlanarKernel.dynamics, _bias_z)
        phid = lean.Phi @ qd
        pd2 = np.where(lean.rooted, phid[lean.parent], 0.0) ** 2
        bias_i = -((lean.P * pd2[None, :]) @ w) - phid ** 2 * (zc - zo)
        JmT = Jz.conj().T * m
        H = (JmT @ Jz).real + lean.Hrot
        C = (JmT @ (bias_i - lean.gz)).real
        # centroidal features (qp_features.centroidal on complex numbers)
        M = self.M
        comz = (m @ zc) / M
        Jcz = (m @ Jz) / M
        rz = (zc - comz).conj()
        A_L = m @ (rz[:, None] * Jz).imag + self.IzzPhi
        bz = (m @ bias_i) / M
        vz = Jcz @ qd
        L, L_bias = float(A_L @ qd), float(m @ (rz * bias_i).imag)
        # contact points: positions, Jacobians, biases, which are active (QPController._contacts)
        links = self.links
        pz = zo[links] + rot[links] * self.r0z
        Jp = (1j * (pz[:, None] - zo[None, :]) * self.Pr_c) @ lean.Rv + self.Dz_c
        Jx, Jy = Jp.real, Jp.imag
        nx, ny, tx, ty = self.nx, self.ny, self.tx, self.ty
        gap = pz.real * nx + pz.imag * ny
        Jn = nx * Jx + ny * Jy
        ctrl = self.ctrl
        active = (gap <= ctrl.contact_tol) & (Jn @ qd <= ctrl.contact_speed)
        act = np.flatnonzero(active)
        ma = act.size
        m2 = 2 * ma
        Lay = self._layout(m2)
        N, D = Lay["N"], Lay["D"]
        Jnt = np.empty((m2, nv))
        bnt = np.empty(m2)
        if ma:
            bp = -((self.P_c[act] * pd2[None, :]) @ w) - phid[links[act]] ** 2 * (pz[act] - zo[links[act]])
            Jnt[0::2], Jnt[1::2] = Jn[act], tx * Jx[act] + ty * Jy[act]
            bnt[0::2], bnt[1::2] = bp.real * nx + bp.imag * ny, bp.real * tx + bp.imag * ty
            qr, jpvt, _, _, info = dgeqp3(np.asfortranarray(Jnt.T))
            if info != 0:
                return None
            dd = np.abs(np.diag(qr))
            keep = np.sort(jpvt[:int(np.sum(dd > 1e-9 * max(dd[0], 1e-300)))] - 1)
        else:
            keep = np.zeros(0, dtype=int)
        nk = keep.size
        # the tasks' rows: e = J q̈ − b (J None for a posture: q̈[idx] − b)
        rows = []                                         # (name, J, b, weight, idx, priority) of every task
        com, vcom = np.array([comz.real, comz.imag]), np.array([vz.real, vz.imag])
        for kind, wt, kp, kd, target, acc, vel, idx, name, prio, link, r0 in self.tasks:
            if kind == "com":
                J = np.vstack([Jcz.real, Jcz.imag])
                b = acc + kp * (target - com) + kd * (vel - vcom) - np.array([bz.real, bz.imag])
            elif kind == "momentum":
                J = A_L[None, :]
                b = acc + kd * (target - L) - L_bias
            elif kind == "point":                         # qp_features.point_feature on complex numbers
                pt = zo[link] + rot[link] * r0
                Jt = (1j * (pt - zo) * self.Pr[link]) @ lean.Rv + self.Dz[link]
                bt = -((self.P[link] * pd2) @ w) - phid[link] ** 2 * (pt - zo[link])
                J = np.vstack([Jt.real, Jt.imag])
                b = acc + kp * (target - np.array([pt.real, pt.imag])) + kd * (vel - J @ qd) - np.array([bt.real, bt.imag])
            else:
                J = None
                b = acc + kp * (target - q[idx]) + kd * (vel - qd[idx])
            rows.append((name, J, b, wt, idx, prio))
        # the QP's equalities and bounds, in the scaled unknowns x̃ = D⁻¹ x
        neq = nv + nk
        Aeq = np.zeros((neq, N))
        Aeq[:nv, :nv], Aeq[:nv, nv:nv + na], Aeq[:nv, nv + na:] = H, Lay["StD"], -Jnt.T * Lay["Dq"][na:]
        Aeq[nv:, :nv] = Jnt[keep]
        beq = np.concatenate([-C, -bnt[keep]])
        lbs, ubs = Lay["lbs"], Lay["ubs"]
        if ctrl.limit_index.size:
            i, T = ctrl.limit_index, ctrl.limit_horizon
            kk = 2.0 / (T * T)
            lbs, ubs = lbs.copy(), ubs.copy()
            lbs[i] = kk * (ctrl.limit_lo - q[i] - T * qd[i])
            ubs[i] = kk * (ctrl.limit_hi - q[i] - T * qd[i])
        return H, C, Jnt, bnt, keep, active, Lay, rows, Aeq, beq, lbs, ubs

    def _groups(self, x, H, C, Jnt, bnt, keep, lbq, ubq) -> tuple:
        """(violation, tolerance) per constraint group of x: :meth:`QPController._residuals` on the lean arrays."""
        ctrl, nv, na = self.ctrl, self.nv, self.na
        qdd, tau_a, f = x[:nv], x[nv:nv + na], x[nv + na:]
        tau = np.zeros(nv)
        tau[ctrl.actuated] = tau_a
        F = f.reshape(-1, 2)
        fn, ft = F[:, 0], np.abs(F[:, 1])
        dyn = float(np.abs(H @ qdd + C - tau - Jnt.T @ f).max())
        con = float(np.abs(Jnt[keep] @ qdd + bnt[keep]).max(initial=0.0))
        cone = float(np.maximum(ft - ctrl.ground.mu * fn, ctrl.min_normal - fn).max(initial=0.0))
        lim = float(max((np.abs(tau_a) - ctrl.torque_limits).max(initial=0.0),
                        np.maximum(lbq - qdd, qdd - ubq).max(initial=0.0)))
        ftol, fs = ctrl.feasibility_tol, self.f_scale
        tol = {"dynamics": ftol * (fs + np.abs(C).max()), "contact": ftol * (1.0 + np.abs(bnt).max(initial=0.0)),
               "cone": ftol * fs, "limits": ftol * fs}
        res = {"dynamics": dyn, "contact": con, "cone": cone, "limits": lim}
        return res, tol, tau, F

    def _judge(self, x, H, C, Jnt, bnt, keep, active, rows, lbq, ubq, kkt, statuses, iters, t_build, t_solve):
        """:meth:`QPController._judge` on the lean arrays; None (the readable path answers) unless met or compromise."""
        ctrl, nv = self.ctrl, self.nv
        qdd = x[:nv]
        res, tol, tau, F = self._groups(x, H, C, Jnt, bnt, keep, lbq, ubq)
        dyn, con, cone, lim = res["dynamics"], res["contact"], res["cone"], res["limits"]
        if not (dyn <= tol["dynamics"] and con <= tol["contact"] and cone <= tol["cone"] and lim <= tol["limits"]
                and kkt <= KKT_TOL):
            return None
        errors, missed = {}, {}
        for name, J, b, wt, idx, _ in rows:
            d = (qdd[idx] if J is None else J @ qdd) - b
            e = sqrt(float(d @ d))                        # np.linalg.norm's arithmetic for a vector
            errors[name] = e
            if wt > 0 and e > ctrl.task_tol * (1.0 + sqrt(float(b @ b))):
                missed[name] = e
        forces = np.zeros((self.links.size, 2))
        forces[active] = F
        msg = ("every task met" if not missed else "least-squares compromise: " + ", ".join(
            f"task {n!r} misses its desired acceleration by {e:.3g}" for n, e in missed.items()))
        return QPResult(status="compromise" if missed else "met", message=msg, tau=tau, qdd=qdd.copy(), forces=forces,
                        active=active, task_errors=errors, residuals=res, tolerances=tol,
                        solver_status=statuses, iterations=iters,
                        build_time=t_build, solve_time=t_solve, kkt=float(kkt))


def _task_terms(Qq: np.ndarray, gq: np.ndarray, rows) -> tuple:
    """Qq + Σ wₖ J_kᵀ J_k and gq − Σ wₖ J_kᵀ bₖ over the task ``rows`` (name, J, b, w, idx, …) in their order, in
    place (a posture's J = None: its joints' diagonal entries): the readable path's t.weight * A.T @ A."""
    for _, J, b, wt, idx, *_ in rows:
        if J is None:
            np.add.at(Qq, (idx, idx), wt)
            np.subtract.at(gq, idx, wt * b)
        else:
            Qq += (wt * J.T) @ J
            gq -= (wt * J.T) @ b
    return Qq, gq
