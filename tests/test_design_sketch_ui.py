"""Chapter 10, issue 30 point 5: the sketching interface, driven by synthesized mouse events on Agg (ORACLES L5).

Every event goes through the canvas's callbacks as a window's would; after each one the editor's state is
checked against an independent run of S(t, u) (pbanim.design.simulate at the editor's u)."""

import matplotlib
import numpy as np
import pytest
from matplotlib.backend_bases import MouseEvent

from pbanim.collision import Box, Plane, Sphere
from pbanim.design import DesignBody, DesignScene, simulate
from pbanim.design.sketch_ui import SketchEditor
from pbanim.rigid import quat_from_axis_angle

matplotlib.use("Agg", force=True)


def send(ed, name, xd, yd):
    """A mouse event at data coordinates (xd, yd) of the editor's axes, processed by its canvas."""
    px, py = ed.ax.transData.transform((xd, yd))
    ed.canvas.callbacks.process(name, MouseEvent(name, ed.canvas, px, py, button=1))


def ball(v=(1.0, 0.0, 2.0)):
    return DesignScene([DesignBody(Sphere(0.1), position=[0, 0, 1.0], velocity=v)], [Plane([0, 0, 1])],
                       restitution=0.8)


def shown(ed, tol=1e-10):
    """The editor's drawn motion equals S(t, u) run afresh at its u at the drawn times (the replay)."""
    tr = simulate(ed.scene, ed.t_end, ed.names, ed.u, times=list(ed.t[1:]), h=ed.h, sensitivities=False, warn=False)
    xs, ys = ed.line.get_data()
    P = np.array([ed.scene.values(ed.names, ed.u)["x0"]] + [tr.position(0, t) for t in ed.t[1:]])
    return len(xs) == len(P) and np.abs(np.c_[xs, ys] - P[:, ed.view]).max() < tol


def test_drag_a_bouncing_ball_newton_while_the_pointer_holds():
    # ORACLES L5, H5: each motion event is one Gauss–Newton update from the previous u; with the pointer held
    # still the residual falls quadratically (each at most 10·r² + 1e-12 of the previous r) to 1e-9, and the
    # independent run at the final u puts the body at the pointer.
    ed = SketchEditor(ball(), 2.0, h=0.02)
    u0 = ed.u.copy()
    i = 60
    x = ed.X[i].copy()
    send(ed, "button_press_event", 5.0, 5.0)                  # far from the motion: nothing grabbed
    assert ed.grab is None and np.array_equal(ed.u, u0)
    send(ed, "button_press_event", x[0], x[2])
    assert ed.grab == pytest.approx(ed.t[i]) and ed.updates == 0 and shown(ed)
    goal = x + np.array([0.08, 0.0, 0.1])
    for a in (0.25, 0.5, 0.75, 1.0):
        send(ed, "motion_notify_event", x[0] + a * 0.08, x[2] + a * 0.1)
        assert ed.residual < 0.02 and shown(ed)
    res = [ed.residual]
    for _ in range(3):
        send(ed, "motion_notify_event", goal[0], goal[2])
        res.append(ed.residual)
        assert res[-1] <= 10 * res[-2] ** 2 + 1e-12
    assert res[-1] < 1e-9 and ed.updates == 7
    tr = simulate(ed.scene, 2.0, ed.names, ed.u, times=[ed.grab], sensitivities=False)
    assert np.abs(tr.position(0, ed.grab) - goal).max() < 1e-9
    send(ed, "button_release_event", goal[0], goal[2])
    assert ed.grab is None and shown(ed)


def test_drag_a_tumbling_box():
    # ORACLES L5: the same loop on a tumbling box (RK4 flight, corner impacts): every update lowers the residual
    # and the drawn motion is S at the editor's u.
    b = DesignBody(Box([0.2, 0.15, 0.1]), mass=1.3, position=[0, 0, 0.6], orientation=quat_from_axis_angle([1, 2, 3], 0.7),
                   velocity=[1.0, 0.3, 1.0], angular_velocity=[3.0, -2.0, 4.0])
    ed = SketchEditor(DesignScene([b], [Plane([0, 0, 1])], restitution=0.6), 0.5, h=0.01)
    i = 40
    x = ed.X[i].copy()
    send(ed, "button_press_event", x[0], x[2])
    assert ed.grab == pytest.approx(ed.t[i])
    res = []
    for _ in range(2):
        send(ed, "motion_notify_event", x[0] + 0.05, x[2] + 0.05)
        res.append(ed.residual)
    assert res[1] < 0.1 * res[0] and shown(ed)


def test_predicted_drag_is_replaced_by_s_on_release():
    # ORACLES L5: with predict=True an event updates u on the linearization made at press (no simulation); the
    # release draws S at the final u and reports how far the prediction was from it.
    ed = SketchEditor(ball(), 2.0, h=0.02, predict=True)
    x = ed.X[60].copy()
    send(ed, "button_press_event", x[0], x[2])
    send(ed, "motion_notify_event", x[0] + 0.01, x[2] + 0.01)
    # the linear model is met up to the damping: |r⁺| ≤ λ²/(σ_min² + λ²)·|r| (+ roundoff)
    sig = np.linalg.svd(ed.lin_D[60], compute_uv=False).min()
    assert ed.residual <= ed.damping ** 2 / (sig ** 2 + ed.damping ** 2) * np.hypot(0.01, 0.01) * 1.01 + 1e-14
    pred = ed.X.copy()
    send(ed, "button_release_event", x[0] + 0.01, x[2] + 0.01)
    assert shown(ed) and ed.prediction_error == pytest.approx(np.abs(ed.X - pred).max(), abs=0)
    assert 0 < ed.prediction_error < 0.05


def test_draw_a_sketch_and_run_multiple_shooting():
    # ORACLES L5, H8: a stroke drawn over a two-bounce motion (press, 30 moves, release) becomes a sketch with
    # even times; multiple shooting on release recovers the motion: the independent run at the new u passes
    # through the stroke's points to 1e-3 m and ends on its last point.
    true = ball(v=(0.8, 0.0, 1.5))
    T = 1.6
    ts = np.linspace(0.0, T, 32)
    tr = simulate(true, T, ["x0", "v0"], times=list(ts[1:]), sensitivities=False)
    P = np.array([true.nominal["x0"]] + [tr.position(0, t) for t in ts[1:]])
    ed = SketchEditor(ball(v=(0.5, 0.0, 1.0)), T, h=0.02, mode="sketch")
    ed.ax.set_xlim(-0.2, 1.6), ed.ax.set_ylim(-0.1, 1.3)
    send(ed, "button_press_event", P[0, 0], P[0, 2])
    assert len(ed.stroke) == 1
    for k, p in enumerate(P[1:], start=2):
        send(ed, "motion_notify_event", p[0], p[2])
        assert len(ed.stroke) == k
    send(ed, "button_release_event", P[-1, 0], P[-1, 2])
    assert ed.result is not None and ed.result.success and shown(ed)
    run = simulate(ed.scene, T, ed.names, ed.u, times=list(ts[1:]), sensitivities=False)
    Q = np.array([run.position(0, t) for t in ts[1:]])
    assert np.abs(Q - P[1:]).max() < 1e-3 and np.abs(Q[-1] - P[-1]).max() < 1e-6


def test_the_chapter_opens_the_editor():
    # ORACLES L5: the chapter's editor (a ball with five bounces) draws S and answers a drag like the others.
    import matplotlib.pyplot as plt

    from chapters.ch10_design_search import sketch_editor

    ed = sketch_editor()
    try:
        assert shown(ed) and ed.mode == "drag"
        x = ed.X[70].copy()
        send(ed, "button_press_event", x[0], x[2])
        send(ed, "motion_notify_event", x[0] + 0.02, x[2] + 0.02)
        assert ed.grab == pytest.approx(ed.t[70]) and ed.residual < 1e-3 and shown(ed)
    finally:
        plt.close(ed.ax.figure)


def test_the_chapter_opens_the_box_editor():
    # ORACLES L5, L7: the chapter's box editor draws the lean twin's S (flight step 0.02 s under a drawing every
    # 5 ms: within 1e-4 m of the readable S) and a drag lowers the residual at the pointer.
    import matplotlib.pyplot as plt

    from chapters.ch10_design_search import sketch_editor

    ed = sketch_editor(scene="box")
    try:
        assert ed.path == "lean" and shown(ed, tol=1e-4)
        x = ed.X[100].copy()
        send(ed, "button_press_event", x[0], x[2])
        res = []
        for _ in range(2):
            send(ed, "motion_notify_event", x[0] + 0.03, x[2] + 0.03)
            res.append(ed.residual)
        assert ed.grab is not None and abs(ed.grab - ed.t[100]) <= 0.02     # the nearest drawn point (pixels)
        assert res[1] < 0.1 * res[0] and ed.path == "lean"
    finally:
        plt.close(ed.ax.figure)


# ---------------------------------------------------------------- the lean twins and the blitted redraw (ORACLES L7)
def twins(scene, T, h, i, **kw):
    """The lean editor and the readable one on the same scene, both grabbed at drawn time index i."""
    from matplotlib.figure import Figure

    eds = [SketchEditor(scene, T, h=h, ax=Figure().subplots(), lean=lean, **kw) for lean in (True, False)]
    for ed in eds:
        ed.grab, ed.grab_index = float(ed.t[i]), i
        ed._simulate(ed.grab)
    return eds


def test_lean_ball_equals_the_readable_s_through_five_bounces():
    # ORACLES L7: a ball between a floor and a wall, five bounces: the lean twin's drawn motion, x(t*) and
    # ∂x(t*)/∂u equal the readable S (simulate on the grid h) to 1e-12 (measured 2e-15), at the start and
    # after three drag updates have moved u.
    from pbanim.bench.design import ball_scene

    lean, ref = twins(ball_scene(), 2.7, 0.02, 70)
    for _ in range(2):
        assert (lean.path, ref.path, lean.n_impacts, ref.n_impacts) == ("lean", "readable", 5, 5)
        assert np.abs(lean.t - ref.t).max() < 1e-12 and np.abs(lean.X - ref.X).max() < 1e-12
        assert np.abs(lean.x_star - ref.x_star).max() < 1e-12 and np.abs(lean.A - ref.A).max() < 1e-12
        for ed in (lean, ref):
            ed.target = ed.X[70] + np.array([0.05, 0.0, 0.04])
            for _ in range(3):
                ed.step()
        assert np.abs(lean.u - ref.u).max() < 1e-10


def test_lean_box_equals_the_readable_s_at_the_same_flight_step():
    # ORACLES L7: a tumbling box (anisotropic inertia, four corner impacts on a floor and a wall): at the
    # same grid step the lean twin (RK4 of the rotation alone, the readable event and impact laws) equals
    # simulate to 1e-11 in the drawn motion, x(t*) and ∂x(t*)/∂u (measured 4e-14).
    from pbanim.bench.design import box_scene

    lean, ref = twins(box_scene(), 1.0, 0.01, 50)
    assert (lean.path, ref.path, lean.n_impacts, ref.n_impacts) == ("lean", "readable", 4, 4)
    assert np.abs(lean.t - ref.t).max() < 1e-12 and np.abs(lean.X - ref.X).max() < 1e-11
    assert np.abs(lean.x_star - ref.x_star).max() < 1e-11 and np.abs(lean.A - ref.A).max() < 1e-11


def test_lean_box_on_a_coarse_flight_grid():
    # ORACLES L7: with a flight step of 0.02 s under a drawing every 5 ms, x(t*) and ∂x(t*)/∂u equal
    # simulate at h = 0.02 to 1e-11 (the same discrete flow; measured 6e-16) and the drawn positions (the
    # parabolas between the located impacts) lie within 1e-4 m of the readable S at h = 5 ms (measured 6e-6).
    from pbanim.bench.design import box_scene

    from matplotlib.figure import Figure

    sc = box_scene()
    ed = SketchEditor(sc, 1.0, h=0.005, h_flight=0.02, ax=Figure().subplots())
    i = 100
    ed.grab, ed.grab_index = float(ed.t[i]), i
    ed._simulate(ed.grab)
    assert ed.path == "lean" and ed.n_impacts == 4
    tr = simulate(sc, 1.0, ed.names, ed.u, times=[ed.grab], h=0.02, warn=False)
    assert np.abs(tr.position(0, ed.grab) - ed.x_star).max() < 1e-11
    assert np.abs(tr.d_position(0, ed.grab) - ed.A).max() < 1e-11
    assert shown(ed, tol=1e-4) and not shown(ed, tol=1e-9)       # a coarse flight, not the fine grid's S


def test_the_lean_ball_declines_a_rest_and_the_readable_s_is_drawn():
    # ORACLES L7, D1: a ball whose bounces die out (ε = 0.3) comes to rest on the floor: the lean twin
    # declines (its chain rule has no resting contact) and the editor draws the readable S, which rests.
    b = DesignScene([DesignBody(Sphere(0.1), position=[0, 0, 0.5], velocity=[0.5, 0.0, 0.0])], [Plane([0, 0, 1])],
                    restitution=0.3)
    ed = SketchEditor(b, 2.0, h=0.02)
    assert ed.path == "readable" and shown(ed)
    assert abs(ed.X[-1, 2] - 0.1) < 1e-9                     # resting: the centre one radius above the floor


def test_blitted_drag_shows_the_same_pixels_as_a_full_redraw():
    # ORACLES L7: a drag event redraws by blitting (the axes cached without the motion, the three artists
    # drawn over it); the canvas then holds the picture a full redraw makes, pixel for pixel up to the
    # antialiased crossings of the motion with the plane lines (< 0.1 % of the pixels differ; measured 0).
    import matplotlib.pyplot as plt

    ed = SketchEditor(ball(), 2.0, h=0.02)
    try:
        ed.canvas.draw()
        x = ed.X[60].copy()
        send(ed, "button_press_event", x[0], x[2])
        send(ed, "motion_notify_event", x[0] + 0.05, x[2] + 0.05)
        assert ed._bg is not None                              # the blit path ran
        blit = np.asarray(ed.canvas.buffer_rgba()).copy()
        ed.canvas.draw()
        full = np.asarray(ed.canvas.buffer_rgba())
        assert np.any(blit != 0) and np.mean(np.any(blit != full, axis=2)) < 1e-3
        ed.line.set_data([], [])                               # and the test can see a missing motion
        ed.canvas.draw()
        assert np.mean(np.any(np.asarray(ed.canvas.buffer_rgba()) != blit, axis=2)) > 1e-3
    finally:
        plt.close(ed.ax.figure)
