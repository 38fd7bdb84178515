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
  box, exact (S and ∂S/∂u per event) and predicted (the linearization made at press), and the Agg redraw;
  for the box, the interpreter's floor of one event: the lean RK4 flight step on floats times the steps the
  event takes, plus the Agg draw of the blitted artists (what no change of algorithm in Python removes).

The Richardson row's error is measured against the reference (it shares the centred difference at 1e-4
with it); where a run within ±2δ of u changes the impact sequence, the row says so in words ("straddles an
impact: not comparable") instead of a number.

Goals: analytic ≥ 5× faster than the plain centred difference *and* more accurate than it
(``design-analytic-vs-fd``); one update of a three-bounce trajectory ≤ 30 ms (``design-update-ms``); ≥ 30 drag updates a second for
the five-bounce ball and the tumbling box (``design-drag-rate-ball``, ``design-drag-rate-box``); the die of chapter
10 designed to rest on a chosen face at a chosen place from ≥ 8 of 10 random throws (``design-die-successes``, the
full run only: ≈ 45 s a throw).
"""

from __future__ import annotations

import numpy as np

from ..contracts import Int, Obj, contract
from . import Goal, Report, Table, median_time

__all__ = ["run", "box_scene", "ball_scene", "die_scene", "die_designs", "DIE_PLACE", "DIE_FACE", "DIE_STARTS"]

NAMES = ["x0", "theta0", "v0", "omega0", "restitution"]
H_FLIGHT = 0.02         # s: the lean box's flight grid in the drag rows (the drawing's accuracy is printed)


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


DIE_PLACE, DIE_FACE = np.array([0.6, 0.2, 0.05]), 4
DIE_STARTS = 10         # random throws of the die design's success count (issue 30, point 2: ≥ 8 of 10)


@contract(rng=Obj(np.random.Generator))
def die_scene(rng):
    """A die (10 cm cube) thrown from 0.3 m with a random velocity and spin drawn from ``rng``."""
    from ..collision import Box, Plane
    from ..design import DesignBody
    from ..design.stepped import ContactScene

    v0, w0 = np.array([rng.uniform(0.5, 1.5), rng.uniform(-0.5, 0.5), rng.uniform(0, 1)]), rng.uniform(-8, 8, 3)
    return ContactScene(DesignBody(Box([0.05, 0.05, 0.05]), position=[0, 0, 0.3], velocity=v0,
                                   angular_velocity=w0), [Plane()], friction=0.5)


@contract(starts=Int(ge=1, le=100), seed=Int(ge=0))
def die_designs(starts: int = 1, seed: int = 0) -> list:
    """A die (10 cm cube) thrown from 0.3 m with a random velocity and spin (``starts`` throws drawn from
    ``default_rng(seed)``), each designed by Gauss–Newton on v₀ through its corner impacts and rolling to rest on
    face ``DIE_FACE`` at ``DIE_PLACE`` at T = 1.5 s (up to six seeded kicks where the place lies across a jump
    of S; the kink-crossing step, on by default for these exact goals: ORACLES L9). Returns
    ``[(scene, design), ...]`` in the order drawn: the first is the chapter's figure (``ch10_contact_die``)."""
    from ..design.control import position_goal
    from ..design.stepped_design import design_contact

    rng = np.random.default_rng(seed)
    out = []
    for _ in range(starts):
        scene = die_scene(rng)
        d = design_contact(scene, 1.5, ["v0"], [position_goal(0, 1.5, DIE_PLACE)], rest=True, face=DIE_FACE,
                           h=0.01, max_iter=40, components=(0, 1), kicks=6)
        out.append((scene, d))
    return out


def _die_successes(rep) -> None:
    """Issue 30, point 2: the die designed from ``DIE_STARTS`` random throws (≈ 45 s each on this machine: the
    full run only), how many reach the place at rest on the face (residual ≤ 1e-6)."""
    import time

    t0 = time.process_time()
    out = die_designs(DIE_STARTS)
    cpu = time.process_time() - t0
    rows = [[i, d.success, d.face, d.at_rest, d.residual, len(d.history)] for i, (_, d) in enumerate(out)]
    n = sum(bool(d.success and d.face == DIE_FACE and d.at_rest and d.residual <= 1e-6) for _, d in out)
    rep.tables.append(Table(f"die thrown to rest on face {DIE_FACE} at {DIE_PLACE.tolist()} from {DIE_STARTS} random "
                            f"throws ({cpu:.0f} s process)", ["throw", "success", "face", "at rest", "residual",
                                                                 "iterations"], rows))
    rep.goals.append(Goal("design-die-successes", float(n), 0.8 * DIE_STARTS, ">=", f" of {DIE_STARTS}",
                          note="designs that reach the place at rest on the chosen face"))


def run(quick: bool = False) -> Report:
    from ..design import simulate
    from ..design.check import analytic_jacobian, fd_jacobian
    from ..design.control import goal_system, min_norm_update, position_goal
    from ..errors import InvalidInput

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
    ri = {}

    def richardson():
        try:
            ri["R"] = fd_jacobian(s, NAMES, None, T, outs, delta=1e-4)
        except InvalidInput:                      # a perturbed run changed the impact count
            ri["R"] = None

    t_ri = median_time(richardson, reps)
    scale = float(np.abs(ref).max())
    e_an, e_fd = float(np.abs(A - ref).max()) / scale, float(np.abs(F - ref).max()) / scale
    e_ri = _richardson_error(s, T, ri["R"], ref, scale, tr)
    rep.tables.append(Table(f"∂S/∂u of a tumbling box, 13 parameters, {len(tr.impacts)} impacts",
                            ["method", "simulations", "time (s)", "rel. error vs reference"],
                            [["analytic (variational + saltation)", 1, t_an, e_an],
                             ["centred FD, δ = 1e-6", 26, t_fd, e_fd],
                             ["Richardson FD, δ = 1e-4", 52, t_ri, e_ri]]))
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
    if not quick:
        _die_successes(rep)
    return rep


def _richardson_error(s, T, R, ref, scale, tr):
    """The Richardson difference R at δ = 1e-4 against the reference (Richardson at 2e-4; the two share the
    centred difference at 1e-4), or in words why it is not comparable: the nominal run not differentiable (a
    graze, simultaneous contacts), or a perturbed run within ±2δ whose impact sequence differs from the
    nominal one (the difference straddles an impact; R None: the impact count changed)."""
    from ..design import simulate

    if not tr.differentiable:
        return "nominal run not differentiable (graze or simultaneous contacts): not comparable"
    u, seq = s.vector(NAMES), [(i.kind, i.other) for i in tr.impacts]
    for k in range(u.size):                       # 2·13 runs, state only: half of one difference
        for d in (-2e-4, 2e-4):
            uu = u.copy()
            uu[k] += d * max(1.0, abs(u[k]))
            if [(i.kind, i.other) for i in simulate(s, T, NAMES, uu, sensitivities=False, warn=False).impacts] != seq:
                return f"straddles an impact (u[{k}] {d:+.0e}): not comparable"
    if R is None:
        return "straddles an impact (the impact count changes): not comparable"
    return float(np.abs(R - ref).max()) / scale


def _drag_rate(rep, quick):
    """Issue 30, point 5: the update time of the sketching interface (:class:`pbanim.design.SketchEditor`), one
    drag event end to end — the motion event through the canvas's callbacks, one Gauss–Newton update from the
    previous u, the new S(t, u) with ∂x(t*)/∂u, the artists and the Agg rendering — for a ball with five
    bounces and a tumbling box (four corner impacts). Three editors on the same scene, timed in alternating
    rounds: the readable S (:func:`pbanim.design.simulate` on the grid h, a full Agg redraw: the editor
    before its lean twins), the lean S (:mod:`pbanim.design.lean_ball`, :mod:`pbanim.design.lean_box`) with
    the blitted redraw (the default), and the predicted mode (the linearization made at press: not S, a row,
    not the goal). The lean box flies on a coarser flight grid (``H_FLIGHT``); its drawn positions are
    compared with the readable S at h (metres and pixels of the figure). Median and spread (min–max) of the
    rounds, wall and process time (on a shared machine the process time shows what the load adds). Goal:
    one exact update ≤ 33 ms (≥ 30 a second) for both scenes."""
    import time

    from matplotlib.backend_bases import MouseEvent
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    from ..design import simulate
    from ..design.sketch_ui import SketchEditor

    cases = [("ball, 5 bounces", ball_scene(), 2.7, 0.02, None, "ball"),
             ("tumbling box", box_scene(), 1.0, 0.005, H_FLIGHT, "box")]
    rounds = 3 if quick else 9
    modes = (("readable S, full redraw", dict(lean=False, blit=False)), ("lean S, blit", dict()),
             ("predicted, blit", dict(predict=True)))
    rows = []
    for label, sc, T, h, hf, key in cases:
        eds, events = {}, {}
        for m, kw in modes:
            fig = Figure(figsize=(7, 4))
            FigureCanvasAgg(fig)
            ed = SketchEditor(sc, T, h=h, h_flight=hf, ax=fig.subplots(), **kw)
            fig.canvas.draw()
            i = len(ed.t) // 2                          # grab the middle of the motion, pull 5 cm off
            x = ed.X[i]
            px = ed.ax.transData.transform((x[0], x[2]))
            fig.canvas.callbacks.process("button_press_event", MouseEvent("button_press_event", fig.canvas, *px,
                                                                          button=1))
            tx = ed.ax.transData.transform((x[0] + 0.05, x[2] + 0.05))
            eds[m], events[m] = ed, MouseEvent("motion_notify_event", fig.canvas, *tx, button=1)
        wall, cpu = {m: [] for m in eds}, {m: [] for m in eds}
        for _ in range(rounds):
            for m, ed in eds.items():
                w0, c0 = time.perf_counter(), time.process_time()
                ed.canvas.callbacks.process("motion_notify_event", events[m])
                wall[m].append(time.perf_counter() - w0)
                cpu[m].append(time.process_time() - c0)
        lean = eds["lean S, blit"]
        fine = simulate(lean.scene, T, lean.names, lean.u, times=list(lean.t[1:]), h=h, sensitivities=False, warn=False)
        P = np.array([fine.position(0, t) for t in lean.t[1:]])
        err = float(np.abs(lean.X[1:] - P).max())
        ppm = float(np.abs(np.diff(lean.ax.transData.transform([(0.0, 0.0), (1.0, 1.0)]), axis=0)).max())
        for m, ed in eds.items():
            w, c = 1e3 * np.array(wall[m]), 1e3 * np.array(cpu[m])
            rows.append([label, m, ed.path, ed.n_impacts, np.median(w), f"{w.min():.1f}–{w.max():.1f}", np.median(c),
                         f"{c.min():.1f}–{c.max():.1f}", ed.residual])
        w, c = 1e3 * np.array(wall["lean S, blit"]), 1e3 * np.array(cpu["lean S, blit"])
        wr = 1e3 * np.median(wall["readable S, full redraw"])
        floor = ""
        if key == "box":
            n_st, (st_w, st_c), (dr_w, dr_c) = _box_floor(lean, events["lean S, blit"])
            fw, fc = 1e3 * (n_st * st_w + dr_w), 1e3 * (n_st * st_c + dr_c)
            mw, mc = float(np.median(w)), float(np.median(c))
            rep.tables.append(Table(f"tumbling box, one drag event: the interpreter's floor (CPython per-call cost; "
                                    f"the event's median {mw:.1f} ms wall, {mc:.1f} ms process)",
                                    ["piece", "calls per event", "per call wall (µs)", "per call process (µs)",
                                     "per event wall (ms)", "per event process (ms)"],
                                    [["lean RK4 flight step on floats (state only)", n_st, 1e6 * st_w, 1e6 * st_c,
                                      1e3 * n_st * st_w, 1e3 * n_st * st_c],
                                     ["Agg draw of the blitted artists (restore, 3 draw_artist, blit)", 1, 1e6 * dr_w,
                                      1e6 * dr_c, 1e3 * dr_w, 1e3 * dr_c],
                                     ["floor: steps + draw", "", "", "", fw, fc],
                                     ["rest: tangent stages, impacts, Gauss-Newton update, callbacks", "", "", "",
                                      mw - fw, mc - fc]]))
            floor = f"; interpreter's floor {fc:.1f} ms process ({n_st} RK4 steps on floats x {1e6 * st_c:.0f} us + " \
                    f"Agg blit {1e3 * dr_c:.1f} ms) = {100 * fc / mc:.0f} % of the median process time"
        flight = f"flight step {hf:g} s, drawn positions within {err:.1e} m = {err * ppm:.1e} px of the readable S " \
                 f"at h = {h:g}" if hf else f"drawn positions within {err:.1e} m of the readable S"
        rep.goals.append(Goal(f"design-drag-rate-{key}", float(np.median(w)), 1e3 / 30, "<=", " ms",
                              note=f"{label}, {lean.n_impacts} impacts, one drag event end to end (update + artists + "
                                   f"Agg): median {np.median(w):.1f} ms wall (spread {w.min():.1f}–{w.max():.1f}), "
                                   f"{np.median(c):.1f} ms process ({c.min():.1f}–{c.max():.1f}), {rounds} alternating "
                                   f"rounds on a shared machine; readable S + full redraw {wr:.0f} ms wall "
                                   f"({wr / np.median(w):.0f}x); {flight}{floor}"))
    rep.tables.append(Table(f"sketching interface: one drag event end to end ({rounds} alternating rounds, ms)",
                            ["scene", "editor", "S by", "impacts", "median wall", "spread wall", "median process",
                             "spread process", "residual after"], rows))


def _box_floor(ed, event):
    """The interpreter's floor of one drag event of the lean box editor ``ed``: (flight steps per event, the
    (wall, process) cost of one step (:meth:`pbanim.design.lean_box._Flight._advance`, the RK4 step of the
    state on floats) timed on the event's own middle step, that of the Agg draw of the blitted artists). The
    steps are counted by replaying ``event`` once with the step wrapped by a counter (restored after)."""
    from ..design import lean_box

    calls, orig = [], lean_box._Flight._advance

    def counted(self, y, h):
        calls.append((self, y.copy(), h))
        return orig(self, y, h)

    lean_box._Flight._advance = counted
    try:
        ed.canvas.callbacks.process("motion_notify_event", event)
    finally:
        lean_box._Flight._advance = orig
    if not calls:
        return 0, 0.0, 0.0
    fl, y, h = calls[len(calls) // 2]
    c = ed.canvas

    def draw():
        c.restore_region(ed._bg)
        for art in (ed.line, ed.marker, ed.ink):
            ed.ax.draw_artist(art)
        c.blit(ed.ax.bbox)

    return len(calls), _wall_and_process(lambda: orig(fl, y, h), 200), _wall_and_process(draw, 10)


def _wall_and_process(fn, n, repeats=5):
    """Medians over ``repeats`` of (wall, process) seconds per call of ``fn``, each repeat ``n`` calls."""
    import time

    w, c = [], []
    for _ in range(repeats):
        w0, c0 = time.perf_counter(), time.process_time()
        for _ in range(n):
            fn()
        w.append((time.perf_counter() - w0) / n)
        c.append((time.process_time() - c0) / n)
    return float(np.median(w)), float(np.median(c))
