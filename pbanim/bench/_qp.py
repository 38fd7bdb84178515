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
solves in ≤ 1 ms with proxsuite" (:func:`qp_step_time_proxsuite`).
"""

from __future__ import annotations

import numpy as np

from . import median_time
from ..lcp.qp import backend_failure

__all__ = ["QP_STEP_HEADER", "qp_step_rows", "qp_step_time_proxsuite", "standing_controller"]

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


def qp_step_time_proxsuite(quick: bool) -> float:
    """Median time (s) of one weighted QP control step of the standing planar biped with proxsuite."""
    ctrl, q, qd = standing_controller("proxqp", True, "weighted")
    ctrl.solve(q, qd)
    repeats, min_time = (3, 0.05) if quick else (7, 0.3)
    return median_time(lambda: ctrl.solve(q, qd), repeats=repeats, min_time=min_time)
