"""Cost of one QP control step of the planar biped, per QP backend (a helper of ``pbanim bench control``).

One control step is what :meth:`pbanim.control.qp.QPController.solve` does at every step of a run:
build the QP at the current state (kinematics, mass matrix, contact rows, the three balance tasks of
:func:`pbanim.control.qp_balance.balance_tasks`) and solve it. The state is the biped standing on both
feet with bent knees (:func:`pbanim.control.qp_balance.crouched_state`), moving a little (a small
velocity, so the bias terms are not zero), four contact points active. Timings are medians of repeats,
each repeat looped for a minimum time (:func:`pbanim.bench.median_time`); the weighted mode is one QP
per step, the prioritized mode one per priority level plus one for the regularization.

Rows (:data:`QP_STEP_HEADER`): proxsuite's dense ProxQP called directly first (the default), then every
backend that ``qpsolvers`` finds installed, through ``qpsolvers.solve_problem`` (a new backend appears as
a row when it is installed). The goal line of the family is "one QP control step of the planar biped
solves in ≤ 1 ms with proxsuite" (:func:`qp_step_goal`).

**What the goal times.** A run's control step is not the readable :meth:`QPController.solve`:
:func:`~pbanim.control.qp_balance.simulate_balance` takes the lean path by default (``lean=True``:
:class:`~pbanim.control.qp_lean.LeanQP`, ORACLES F23), which builds the same QP into arrays laid out once
per contact set from the lean kinematics, and solves it from the last step's active set, calling ProxQP
only when that guess is not certified. The goal line times that step *with ProxQP called every step*
(:func:`lean_proxqp_step`: the remembered active set dropped before each call): the lean kinematics of q,
the build, ProxQP's dense solve of the same QP (the same scaling, eps_abs, eps_rel = 0, max_iter) and the
judge; its answer is the readable one's to F23's tolerance (checked in the run: the table prints the
difference, and the goal is not measured when it is larger). The active-set shortcut alone is not a
ProxQP solve and is printed only beside it, as are the readable step and the bare ProxQP call on this
QP (the floor of any step that solves with ProxQP). The rows are measured in alternating rounds, each
round looped for a minimum process CPU time; the goal is the median process CPU time per step (the wall
time on an unloaded core; the wall medians are printed beside it: on a shared machine the wall clock
counts the other jobs).

Measured on a shared 2-core machine at load 4.5–7.3, six full runs of ``pbanim bench control`` (7 rounds each):
the goal's step 1.09, 1.15, 1.22, 1.12, 0.99, 0.93 ms CPU (median of the runs 1.10 ms: the line missed by 10 %),
the readable step in the same rounds 1.54, 1.80, 1.81, 1.61, 1.44, 1.37 ms (lean / readable 0.66–0.72), the bare
ProxQP call 0.12–0.16 ms; the goal as it was timed before (the readable step, wall-clock median) read 2.33, 2.14
and 3.47 ms in runs alternating with these at the same load (1.22 ms on an idle machine). The goal step's parts,
each timed alone on its own arguments (CPU medians of 5 rounds, load ~6): the lean kinematics 35 µs, LeanQP's
build 283, the tasks' Q and g 28, ProxQP 158, the KKT residual 103, the active-set bookkeeping 28, the judge 101:
0.74 ms of the whole step's 1.27 ms in the same rounds (a part looped alone runs warm; the solve after the build,
timed whole, 0.49–0.72 ms against its parts' 0.42: the rest is the data's size check before ProxQP, the
finiteness checks and the arrays' glue). The counted floor (the row above) is 0.2–0.34 ms: the step is 3–4× it,
so this count does not show the line to be call-bound; what is left is numpy work in :mod:`pbanim.control.qp_lean`.
"""

from __future__ import annotations

import numpy as np

from . import Table, _alternating, median_time
from ..lcp.qp import backend_failure

__all__ = ["QP_STEP_HEADER", "lean_proxqp_step", "qp_step_goal", "qp_step_rows", "standing_controller"]

QP_STEP_HEADER = ["backend", "mode", "step [ms]", "build [ms]", "QP solves", "status"]


def standing_controller(backend: str = "proxqp", native: bool = True, mode: str = "weighted"):
    """(controller, q, q̇) of the standing biped used by every row (the same problem for every backend)."""
    from ..articulated import PlanarKernel
    from ..articulated.planar_step import PlanarGround
    from ..control.biped import BIPED_JOINTS, biped_contact_points, planar_biped
    from ..control.qp import QPController
    from ..control.qp_balance import balance_tasks, crouched_state

    kernel = PlanarKernel(planar_biped())
    q, qd = crouched_state(kernel, 0.3)
    qd = qd + 0.01 * np.sin(np.arange(kernel.nv))                 # a little motion: non-zero bias terms
    qd[:2] = 0.0
    posture = {nm: float(q[i]) for nm, i in BIPED_JOINTS.items() if i >= 2}
    tasks = balance_tasks(kernel.centre_of_mass(q) + [0.01, 0.0], posture)
    ctrl = QPController(kernel, biped_contact_points(kernel.tree), PlanarGround(), tasks, mode=mode,
                        torque_limits=300.0, backend=backend, native=native, contact_speed=1.0)
    return ctrl, q, qd


def _row(label: str, backend: str, native: bool, mode: str, quick: bool) -> list:
    ctrl, q, qd = standing_controller(backend, native, mode)
    res = ctrl.solve(q, qd)                                       # warm-up (lazy imports), and the status
    repeats, min_time = (3, 0.05) if quick else (7, 0.3)
    step = median_time(lambda: ctrl.solve(q, qd), repeats=repeats, min_time=min_time)
    build = median_time(lambda: ctrl.build(q, qd), repeats=repeats, min_time=min_time)
    return [label, mode, 1e3 * step, 1e3 * build, len(res.solver_status), res.status]


def qp_step_rows(quick: bool) -> list[list]:
    """One row per backend (proxsuite native first, then each installed qpsolvers backend) and mode:
    backend, mode, median time of one control step (ms), of building the QP alone (ms), number of QP
    solves per step, and the step's status ("met" / "compromise": solved; "infeasible": it failed; "backend
    error <type>: <message>": the backend raised, e.g. quadprog on a singular matrix)."""
    import qpsolvers

    rows = [_row("proxsuite (native ProxQP)", "proxqp", True, "weighted", quick),
            _row("proxsuite (native ProxQP)", "proxqp", True, "prioritized", quick)]
    for name in qpsolvers.available_solvers:
        try:
            rows.append(_row(f"{name} (qpsolvers)", name, False, "weighted", quick))
        except Exception as exc:  # noqa: BLE001  (a backend that cannot take the problem is a row that says so)
            rows.append([f"{name} (qpsolvers)", "weighted", float("nan"), float("nan"), 0, backend_failure(exc)])
    return rows


def lean_proxqp_step(ctrl):
    """``step(q, q̇) -> QPResult``: the control step a run takes on the lean path (as
    :func:`~pbanim.control.qp_balance.simulate_balance` binds it: the lean kinematics of q, then
    :meth:`LeanQP.solve <pbanim.control.qp_lean.LeanQP.solve>`, unchecked) with ProxQP called at every step:
    the active set remembered from the last answer is dropped before each call, so LeanQP's active-set start
    has no guess and its one ProxQP call solves the QP (``solver_status`` says PROXQP_SOLVED)."""
    from ..articulated.planar_lean import LeanPlanarStep
    from ..articulated.planar_step import PlanarContactStep
    from ..contracts import unchecked
    from ..control.biped import biped_contact_points
    from ..control.qp_lean import LeanQP

    lean = LeanPlanarStep(PlanarContactStep(ctrl.kernel, biped_contact_points(ctrl.kernel.tree), ctrl.ground))
    lean_qp = LeanQP(ctrl, lean)
    solve, layouts = unchecked(lean_qp.solve), lean_qp._layouts   # the layouts hold the remembered active set

    def step(q, qd, proxqp: bool = True):
        if proxqp:
            for lay in layouts.values():
                lay.pop("guess", None)
        lk = lean.kinematics(q)
        return solve(q, qd, lk + (lean.com_jacobians(lk[2], lk[3]),))

    return step


def _bare_proxqp(ctrl, q, qd):
    """ProxQP's dense solve alone on this step's QP, as :func:`~pbanim.control.qp_solve.solve_qp` hands it over
    (scaled by D = R^{-1/2}; the same settings): the one call every step that solves with ProxQP makes."""
    import proxsuite

    P = ctrl.build(q, qd)
    D = P["R"] ** -0.5
    Q = ctrl.eps * np.diag(P["R"])
    g = np.zeros(P["N"])
    for t, A, b in P["tasks"]:
        if t.weight > 0:
            Q += t.weight * A.T @ A
            g -= t.weight * A.T @ b
    Qs, gs, As, Cs = D[:, None] * Q * D, D * g, P["Aeq"] * D, P["G"] * D
    l, u, lbs, ubs = np.full(Cs.shape[0], -np.inf), np.zeros(Cs.shape[0]), P["lb"] / D, P["ub"] / D
    solve = proxsuite.proxqp.dense.solve
    return lambda: solve(Qs, gs, As, P["beq"], Cs, l, u, l_box=lbs, u_box=ubs, eps_abs=ctrl.eps_abs, eps_rel=0.0,
                         max_iter=ctrl.max_iter)


def qp_step_goal(quick: bool) -> tuple[Table, float, str]:
    """(table, the goal's value in s, the goal's note): one weighted QP control step of the standing biped with
    proxsuite, on the lean path with ProxQP every step, against the readable step (module docstring)."""
    from .control import _bare_calls, _count_calls

    ctrl, q, qd = standing_controller("proxqp", True, "weighted")
    lean = lean_proxqp_step(ctrl)
    readable = ctrl.solve(q, qd)
    res = {"readable": readable, "lean": lean(q, qd), "shortcut": lean(q, qd, proxqp=False)}
    Mg = ctrl.f_scale
    fns = {"readable": lambda: ctrl.solve(q, qd), "lean": lambda: lean(q, qd),
           "shortcut": lambda: lean(q, qd, proxqp=False), "proxqp": _bare_proxqp(ctrl, q, qd), **_bare_calls()}
    rounds, min_cpu = (3, 0.05) if quick else (7, 0.3)
    times = _alternating(fns, rounds, min_cpu)
    wall = {k: np.array([w for w, _ in v]) for k, v in times.items()}
    cpu = {k: np.array([c for _, c in v]) for k, v in times.items()}
    calls = _count_calls(lambda: lean(q, qd))           # (Python, builtins, numpy) calls of the goal's step
    for clock in (wall, cpu):                            # the floor per round: ProxQP's solve and the counted calls
        clock["floor"] = clock["proxqp"] + sum(n * clock[k] / 1000 for n, k in zip(calls, _bare_calls()))
    per = [float(np.median(cpu[k])) / 1000 for k in _bare_calls()]      # each kind's bare cost (CPU s)
    spread = lambda x: f"{1e3 * np.min(x):.3g}–{1e3 * np.max(x):.3g}"  # noqa: E731
    labels = {"readable": "readable QPController.solve (build, ProxQP, judge)",
              "lean": "lean LeanQP, ProxQP every step (the goal's step)",
              "shortcut": "lean LeanQP from the last active set (no ProxQP call; not the goal)",
              "proxqp": "ProxQP's dense solve alone on this QP (the floor of a ProxQP step)",
              "floor": f"floor of the goal's step: ProxQP + {calls[0]} Python, {calls[1]} builtin, {calls[2]} numpy calls "
                       f"at bare cost (a lower bound)"}
    rows, diff = [], {}
    for k, label in labels.items():
        r = res.get(k)
        if r is not None:
            diff[k] = max(np.abs(r.tau - readable.tau).max(), np.abs(r.forces - readable.forces).max()) / Mg
        ratio = cpu[k] / cpu["readable"]
        rows.append([label, 1e3 * float(np.median(cpu[k])), spread(cpu[k]), 1e3 * float(np.median(wall[k])),
                     spread(wall[k]), float(np.median(ratio)),
                     "" if r is None else f"{r.status}, {', '.join(r.solver_status)}",
                     "" if r is None else float(diff[k])])
    table = Table(f"one weighted QP control step of the standing biped [ms], {rounds} alternating rounds (median, "
                  f"min–max): the readable step, the lean step the runs take (simulate_balance's default) with ProxQP "
                  f"every step, and beside them the active-set shortcut, the bare ProxQP call and the goal step's "
                  f"floor (its counted calls at their bare cost, timed in the same rounds, and ProxQP's solve)",
                  ["step", "CPU", "spread", "wall", "spread", "CPU / readable", "status, solver",
                   "max |Δτ|, |Δf| / M g vs readable"], rows)
    equal = (res["lean"].status == readable.status and res["lean"].solver_status == ["PROXQP_SOLVED"]
             and np.array_equal(res["lean"].active, readable.active) and diff["lean"] <= 1e-6)   # ORACLES F23
    value = float(np.median(cpu["lean"])) if equal else np.nan
    note = (f"one QP control step of the planar biped (build + solve) with proxsuite: the lean step the runs take "
            f"(LeanQP, simulate_balance's default), ProxQP called every step, its answer the readable one's to "
            f"{diff['lean']:.1e} M g (F23: 1e-6); process CPU time, median of {rounds} alternating rounds "
            f"({spread(cpu['lean'])} ms; wall {1e3 * np.median(wall['lean']):.3g} ms); the readable "
            f"QPController.solve {1e3 * np.median(cpu['readable']):.3g} ms ({spread(cpu['readable'])}), the bare "
            f"ProxQP call {1e3 * np.median(cpu['proxqp']):.3g} ms; the step's counted floor {1e3 * np.median(cpu['floor']):.3g} "
            f"ms (ProxQP + {calls[0]} Python calls x {1e9 * per[0]:.0f} ns + {calls[1]} builtins x "
            f"{1e9 * per[1]:.0f} ns + {calls[2]} numpy calls x {1e9 * per[2]:.0f} ns; operators, "
            f"ufuncs and LAPACK's wrappers uncounted: a lower bound)")
    if not equal:
        note += f" — NOT MEASURED: the lean answer is not the readable one ({res['lean'].status}, {diff['lean']:.1e} M g)"
    return table, value, note
