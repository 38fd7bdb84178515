"""Characters: what a control step costs, and how fast the walking biped runs (chapter 08, part 2).

Tables:

* one control step of the planar biped [µs]: SIMBICON's servos explicit and stable (the controller alone),
  the contact step that integrates them (closed-form planar dynamics + velocity-level contact), and the
  QP controller per installed qpsolvers backend (building and solving one QP);
* the walking biped (SIMBICON walk, 10 s; quick: 2 s) for each servo at the steps where it walks:
  wall time, real-time factor, mean speed;
* the walk's lean step (:mod:`pbanim.control.walk_lean`, the default) against its readable step
  (``simulate_walk(lean=False)``) in alternating rounds: the same walk bit for bit, the real-time factors
  and their ratio (median and quartiles).

Goals (issue 16): the SIMBICON biped simulates at least 5× faster than real time (Table 1's walk with
stable PD servos at h = 2 ms, the chapter's step, where the walk's speed is within 0.5 % of its h = 1 ms
value: measured 1.023 against 1.022 m/s; the paper's explicit PD with the paper's gains needs h ≤ 0.8 ms
and is not robust there, see :mod:`pbanim.control.simbicon`); one QP control step of the planar biped
solves in ≤ 1 ms with proxsuite.
"""

from __future__ import annotations

import numpy as np

from . import Goal, Report, Table, median_time
from ..articulated.planar import PlanarKernel
from ..articulated.planar_step import PlanarContactStep
from ..control import WALK, Simbicon, simulate_walk
from ..control.biped import biped_contact_points, planar_biped

__all__ = ["run"]


def _walking_state(h: float = 2e-3):
    """A state in the middle of a walk (the controller's machine in step with it)."""
    r = simulate_walk(WALK, 2.0, h, servo="stable", record_every=1)
    return r.q[-1], r.qd[-1]


_WALK3D_RT = [np.nan]


def _walk3d_table(quick: bool, repeats: int) -> Table:
    """The 3-D walk's real-time factor (2 s; quick: 1 s) and what one of its steps costs, part by part: the
    ABA on floats alone bounds the factor at h / t_ABA (the floor CPython's per-operation cost sets)."""
    from ..articulated.fast import aba_fast
    from ..control.biped3d import biped3d, biped3d_contact_points, standing_state3d
    from ..control.biped3d_step import WorldStep
    from ..control.simbicon3d_walk import simulate_walk3d

    h = 2e-3
    res = simulate_walk3d(t_end=1.0 if quick else 2.0, h=h, record_every=100)
    _WALK3D_RT[0] = res.realtime_factor
    tree = biped3d()
    ws = WorldStep(tree, biped3d_contact_points(tree))
    q, qd = standing_state3d()
    tau = np.zeros(18)
    t_aba = median_time(lambda: aba_fast(tree, q, qd, tau), repeats, min_time=0.05)
    t_kin = median_time(lambda: ws.mass_matrix(ws.kinematics(q)), repeats, min_time=0.05)
    t_step = median_time(lambda: ws.step(q, qd, h, tau), repeats, min_time=0.05)
    return Table(f"3-D SIMBICON walk, h = {h * 1e3:g} ms: real-time factor (goal ≥ 1) and one step's parts [ms]; the "
                 f"floor h / t_ABA is the factor if a step cost only its ABA on Python floats",
                 ["real-time factor", "outcome", "ABA (floats)", "kinematics + H", "whole contact step",
                  "floor h / t_ABA"],
                 [[res.realtime_factor, "fell" if res.fell else "walked", t_aba * 1e3, t_kin * 1e3, t_step * 1e3,
                   h / t_aba]])


def run(quick: bool = False) -> Report:
    rep = Report("control")
    repeats = 3 if quick else 7
    tree = planar_biped()
    kernel = PlanarKernel(tree)
    step = PlanarContactStep(kernel, biped_contact_points(tree))
    q, qd = _walking_state()
    rows = []
    for servo in ("explicit", "stable"):
        ctrl = Simbicon(kernel, WALK, servo=servo)
        kin = kernel.kinematics(q)
        kernel.com_jacobians(kin)
        t_ctrl = median_time(lambda: ctrl.torques(0.0, q, qd, (), kin, 1e-3), repeats, min_time=0.05)
        tau, k = ctrl.torques(0.0, q, qd, (), kin, 1e-3)
        t_step = median_time(lambda: step.step(q, qd, 1e-3, tau, k if np.any(k) else None), repeats, min_time=0.05)
        rows.append([f"SIMBICON, {servo} PD", t_ctrl * 1e6, t_step * 1e6, (t_ctrl + t_step) * 1e6])
    rep.tables.append(Table("one control step of the planar biped [µs] (SIMBICON's servos)",
                            ["controller", "controller", "contact step (h = 1 ms)", "total"], rows))
    qp_time, qp_note = np.nan, ""
    try:
        import proxsuite  # noqa: F401
    except ImportError:
        qp_note = "proxsuite is not installed"
    from ._qp import QP_STEP_HEADER, qp_step_rows, qp_step_time_proxsuite

    rep.tables.append(Table("one QP control step of the planar biped (build + solve), per backend", QP_STEP_HEADER,
                            qp_step_rows(quick)))
    if not qp_note:
        qp_time = qp_step_time_proxsuite(quick)
    t_end = 2.0 if quick else 10.0
    walk_rows, rt = [], {}
    for servo, h in (("explicit", 5e-4), ("explicit", 2e-3), ("stable", 1e-3), ("stable", 2e-3), ("stable", 8e-3)):
        res = simulate_walk(WALK, t_end, h, servo=servo, record_every=100)
        rt[(servo, h)] = res.realtime_factor
        walk_rows.append([f"{servo} PD", h * 1e3, res.wall_time, res.realtime_factor,
                          res.speed(min(5.0, t_end / 2)), "fell" if res.fell else "walked"])
    rep.tables.append(Table(f"SIMBICON walk, {t_end:g} s simulated", ["servos", "h [ms]", "wall [s]",
                                                                      "real-time factor", "speed [m/s]", "outcome"],
                            walk_rows))
    lean_rows, ratios = [], []
    for servo, h in (("explicit", 1e-3), ("stable", 2e-3)):
        rts = {True: [], False: []}
        for _ in range(2 if quick else 5):
            for lean in (False, True):
                rts[lean].append(simulate_walk(WALK, 1.0 if quick else 2.0, h, servo=servo, record_every=100,
                                               lean=lean).realtime_factor)
        r = np.array(rts[True]) / np.array(rts[False])
        ratios.append(float(np.median(r)))
        lean_rows.append([f"{servo} PD", h * 1e3, float(np.median(rts[False])), float(np.median(rts[True])),
                          float(np.median(r)), f"{np.percentile(r, 25):.2f}–{np.percentile(r, 75):.2f}"])
    rep.tables.append(Table("the walk's lean step against its readable step (alternating rounds; the same walk bit "
                            "for bit)", ["servos", "h [ms]", "real-time factor, readable", "real-time factor, lean",
                                         "lean / readable", "quartiles"], lean_rows))
    rep.notes.append("Table 1's gains (300/30 on every joint, the 1 kg feet included) ask explicit PD for h ≤ 0.8 ms "
                     "(falls at 2 ms after 2.3 s); stable PD walks at every step measured from 0.5 to 25 ms")
    rep.goals.append(Goal("control-simbicon-realtime", rt[("stable", 2e-3)], 5.0, ">=", "x",
                          "simulated seconds per wall-clock second, Table 1's walk, stable PD servos at h = 2 ms"))
    rep.tables.append(_walk3d_table(quick, repeats))
    rep.goals.append(Goal("control-simbicon3d-realtime", _WALK3D_RT[0], 1.0, ">=", "x",
                          "simulated seconds per wall-clock second, the 3-D SIMBICON walk at h = 2 ms"))
    rep.goals.append(Goal("control-qp-step-proxsuite", qp_time * 1e3 if np.isfinite(qp_time) else np.nan, 1.0, "<=",
                          " ms", "one QP control step of the planar biped (build + solve)", skipped=qp_note))
    return rep
