"""``pbanim bench design``: analytic ∂S/∂u vs finite differences, and the cost of one interactive update.

Rows (medians of repeats, measured in the same run):

* a tumbling box with 13 parameters (x₀, θ₀, v₀, ω₀, ε) through several impacts: wall time of the
  analytic sensitivities (one augmented run) against centred differences (26 runs) and Richardson
  differences (52 runs), and the error of each against the Richardson reference at a smaller step
  (equal or better accuracy is part of the goal);
* one min-norm update of a three-bounce ball trajectory (simulation with sensitivities + the update),
  with the exact sphere flight (:mod:`pbanim.design.exact`, the default for spheres) and with the RK4
  flight, the residual each update leaves and how far the two updates differ (the same problem, the
  same accuracy: RK4 is exact on the parabolas a sphere flies).

* the drag update of the sketching interface (issue 30, point 5): a ball with five bounces and a tumbling
  box, exact (S and ∂S/∂u per event) and predicted (the linearization made at press), and the Agg redraw.

Goals: analytic ≥ 5× faster than the plain centred difference *and* more accurate than it
(``design-analytic-vs-fd``); one update of a three-bounce trajectory ≤ 30 ms (``design-update-ms``); ≥ 30 drag updates a second for
the five-bounce ball and the tumbling box (``design-drag-rate-ball``, ``design-drag-rate-box``).
"""

from __future__ import annotations

import numpy as np

from . import Goal, Report, Table, median_time

__all__ = ["run", "box_scene", "ball_scene"]

NAMES = ["x0", "theta0", "v0", "omega0", "restitution"]


def box_scene():
    from ..collision import Box, Plane
    from ..design import DesignBody, DesignScene
    from ..rigid import quat_from_axis_angle

    b = DesignBody(Box([0.2, 0.15, 0.1]), mass=1.3, position=[0, 0, 1.0],
                   orientation=quat_from_axis_angle([1, 2, 3], 0.7), velocity=[1.0, 0.3, 2.0],
                   angular_velocity=[3.0, -2.0, 4.0])
    return DesignScene([b], [Plane([0, 0, 1]), Plane([-1, 0, 0.1], offset=-1.5)], restitution=0.6)


def ball_scene():
    from ..collision import Plane, Sphere
    from ..design import DesignBody, DesignScene

    b = DesignBody(Sphere(0.1), position=[0, 0, 1.0], velocity=[1.0, 0.3, 2.0])
    return DesignScene([b], [Plane([0, 0, 1]), Plane([-1, 0, 0], offset=-2.0)], restitution=0.8)


def run(quick: bool = False) -> Report:
    from ..design import simulate
    from ..design.check import analytic_jacobian, fd_jacobian
    from ..design.control import goal_system, min_norm_update, position_goal

    rep = Report("design")
    s, T = box_scene(), 0.68
    outs = [(0, T, "position"), (0, T, "orientation")]
    reps = 1 if quick else 3
    tr = simulate(s, T, NAMES)
    ref = fd_jacobian(s, NAMES, None, T, outs, delta=2e-4)            # Richardson reference
    A = analytic_jacobian(tr, outs)
    F = fd_jacobian(s, NAMES, None, T, outs, delta=1e-6, richardson=False)
    t_an = median_time(lambda: analytic_jacobian(simulate(s, T, NAMES), outs), reps)
    t_fd = median_time(lambda: fd_jacobian(s, NAMES, None, T, outs, delta=1e-6, richardson=False), reps)
    t_ri = t_fd * 2 if quick else median_time(lambda: fd_jacobian(s, NAMES, None, T, outs, delta=1e-4), reps)
    scale = float(np.abs(ref).max())
    e_an, e_fd = float(np.abs(A - ref).max()) / scale, float(np.abs(F - ref).max()) / scale
    rep.tables.append(Table(f"∂S/∂u of a tumbling box, 13 parameters, {len(tr.impacts)} impacts",
                            ["method", "simulations", "time (s)", "rel. error vs reference"],
                            [["analytic (variational + saltation)", 1, t_an, e_an],
                             ["centred FD, δ = 1e-6", 26, t_fd, e_fd],
                             ["Richardson FD, δ = 1e-4", 52, t_ri, float("nan")]]))
    b = ball_scene()
    goal = [position_goal(0, 2.0, [0.5, 1.2, 0.6])]
    n_imp = len(simulate(b, 2.0, ["x0", "v0"], h=0.02, sensitivities=False).impacts)

    def update(flight):
        r, Ag, _ = goal_system(b, ["x0", "v0"], None, goal, 2.0, h=0.02, flight=flight)
        return min_norm_update(Ag, r).du

    def residual(du):                      # the goal's residual after the update, on the exact S
        tr = simulate(b, 2.0, ["x0", "v0"], b.vector(["x0", "v0"]) + du, times=[2.0], sensitivities=False,
                      flight="exact")
        return float(np.abs(tr.position(0, 2.0) - goal[0].target).max())

    rows, times = [], {}
    du = {f: update(f) for f in ("rk4", "exact")}
    for f, label in (("rk4", "RK4 flight + variational equations"), ("exact", "exact flight (closed form, default)")):
        times[f] = median_time(lambda: update(f), 3 if quick else 9)
        rows.append([label, n_imp, 1e3 * times[f], residual(du[f]), float(np.abs(du[f] - du["exact"]).max())])
    rep.tables.append(Table("one interactive update of a three-bounce ball (h = 0.02 s, 6 parameters)",
                            ["flight", "impacts", "time (ms)", "residual after update (m)", "|δu − δu_exact|"],
                            rows))
    speed = t_fd / t_an if e_an <= e_fd else 0.0
    rep.goals.append(Goal("design-analytic-vs-fd", speed, 5.0, ">=", "x",
                          note=f"analytic rel. error {e_an:.1e} vs FD {e_fd:.1e} (0 if less accurate)"))
    same = abs(rows[1][3] - rows[0][3]) <= 1e-9 and rows[0][4] <= 1e-9
    rep.goals.append(Goal("design-update-ms", 1e3 * times["exact"] if same else float("nan"), 30.0, "<=", " ms",
                          note=f"{n_imp}-bounce trajectory, exact flight; RK4 path {1e3 * times['rk4']:.1f} ms, "
                               f"same update to {rows[0][4]:.1e}"))
    _drag_rate(rep, quick)
    return rep


def _drag_rate(rep, quick):
    """Issue 30, point 5: the update time of the sketching interface (:class:`pbanim.design.SketchEditor`),
    what one drag event costs before drawing — one Gauss–Newton update from the previous u and the new S(t, u)
    with ∂x(t*)/∂u (``exact``), or one update on the linearization made at press (``predicted``, no
    simulation) — for a ball with five bounces (exact flight) and a tumbling box (RK4, four impacts). The two
    modes are timed in alternating rounds on the same editor state; median and spread (min–max) of the rounds,
    wall and process time (the process time shows what a loaded machine adds). Goal ≥ 30 updates a second in
    the exact mode (the motion shown is S itself); the predicted mode is a row, not the goal. The Agg redraw
    of the figure (a window's backend coalesces redraws) is a separate row."""
    import time

    from matplotlib.figure import Figure

    from ..design.sketch_ui import SketchEditor

    cases = [("ball, 5 bounces (exact flight)", ball_scene(), 2.7, 0.02, "ball"),
             ("tumbling box, RK4", box_scene(), 1.0, 0.005, "box")]
    rounds = 3 if quick else 9
    rows = []
    for label, sc, T, h, key in cases:
        eds = {m: SketchEditor(sc, T, h=h, predict=m == "predicted", ax=Figure().subplots()) for m in
               ("exact", "predicted")}
        n_imp = 0
        for ed in eds.values():                               # grab the middle of the motion, aim 5 cm off
            i = len(ed.t) // 2
            ed.grab, ed.grab_index = float(ed.t[i]), i
            tr = ed._simulate(ed.grab)
            n_imp = len(tr.impacts)
            if ed.predict:
                ed._linearize()
            ed.target = ed.X[i] + np.array([0.05, 0.0, 0.05])
        wall, cpu = {m: [] for m in eds}, {m: [] for m in eds}
        for _ in range(rounds):
            for m, ed in eds.items():
                w0, c0 = time.perf_counter(), time.process_time()
                ed.step()
                wall[m].append(time.perf_counter() - w0)
                cpu[m].append(time.process_time() - c0)
        fig = eds["exact"].ax.figure
        from matplotlib.backends.backend_agg import FigureCanvasAgg
        FigureCanvasAgg(fig)
        t_draw = median_time(fig.canvas.draw, rounds)
        for m in eds:
            w, c = np.array(wall[m]), np.array(cpu[m])
            rows.append([label, m, n_imp, 1e3 * np.median(w), f"{1e3 * w.min():.1f}–{1e3 * w.max():.1f}",
                         1e3 * np.median(c), 1.0 / np.median(w), eds[m].residual])
        rows.append([label, "Agg redraw (not in the update)", n_imp, 1e3 * t_draw, "", float("nan"),
                     float("nan"), float("nan")])
        w = np.median(wall["exact"])
        rep.goals.append(Goal(f"design-drag-rate-{key}", 1.0 / w, 30.0, ">=", "/s",
                              note=f"{label}, {n_imp} impacts, one exact update {1e3 * w:.1f} ms wall "
                                   f"(spread {1e3 * min(wall['exact']):.1f}–{1e3 * max(wall['exact']):.1f}), "
                                   f"{1e3 * np.median(cpu['exact']):.1f} ms process; predicted "
                                   f"{1e3 * np.median(wall['predicted']):.2f} ms"))
    rep.tables.append(Table(f"sketching interface: one drag update ({rounds} alternating rounds)",
                            ["scene", "mode", "impacts", "median (ms, wall)", "spread (ms)",
                             "median (ms, process)", "updates / s", "residual after"], rows))
