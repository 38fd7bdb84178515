"""``pbanim figures``: GIF frames drawn by moving artists, and the schedule line printed at the end of a run.

Issue 28 (point 5): the chapters' GIFs make their axes and artists once and move them per frame instead of
clearing the axes; ORACLES G4 asks for the same pixels. The run's closing line names each worker's busy
time and the idle tail (how long the last worker ran alone), read from the figures' wall-clock spans.
"""

import numpy as np
import pytest

from pbanim.cli import workers_line


def _frame(fig):
    fig.canvas.draw()
    return np.asarray(fig.canvas.buffer_rgba()).copy()


def test_moved_discs_and_polygons_draw_the_pixels_of_a_redrawn_frame():
    # ORACLES G4: the frame of ch07_sphere_pile / ch07_stack_settling both ways, at a second position
    pytest.importorskip("matplotlib")
    from matplotlib.patches import Circle

    from pbanim.plotting import pyplot

    plt = pyplot()
    rng = np.random.default_rng(3)
    first, second = rng.uniform(-0.4, 0.4, (2, 6, 2))
    square = np.array([[0.0, 0.0], [0.2, 0.0], [0.2, 0.2], [0.0, 0.2]])

    def axes_setup(ax):
        ax.plot([-0.5, -0.5, 0.5, 0.5], [0.6, 0, 0, 0.6], "k-")
        ax.set_xlim(-0.55, 0.55)
        ax.set_ylim(-0.55, 0.7)
        ax.set_aspect("equal")
        ax.set_xlabel("x (m)")

    fresh, ax = plt.subplots(figsize=(2, 2), dpi=60)
    for p in second:
        ax.add_patch(Circle(p, 0.05, alpha=0.5))
    ax.fill(*(square + second[0]).T, alpha=0.6, color="C1")
    axes_setup(ax)
    ax.set_title("t = 1.00 s")
    moved, bx = plt.subplots(figsize=(2, 2), dpi=60)
    discs = [bx.add_patch(Circle(p, 0.05, alpha=0.5)) for p in first]
    poly = bx.fill(*(square + first[0]).T, alpha=0.6, color="C1")[0]
    axes_setup(bx)
    bx.set_title("t = 0.00 s")
    before = _frame(moved)
    for d, p in zip(discs, second):
        d.set_center(p)
    poly.set_xy(square + second[0])
    bx.set_title("t = 1.00 s")
    after = _frame(moved)
    assert not np.array_equal(before, after)              # the frame did change
    assert np.array_equal(after, _frame(fresh))
    plt.close(fresh), plt.close(moved)


def test_workers_line_reads_busy_times_and_the_idle_tail():
    # ORACLES G4: worker 1 ends at 100 s, worker 2 at 130 s: the last ran alone for 30 s after its figure "c"
    timeline = {"a": (1, 0.0, 60.0), "b": (1, 60.0, 100.0), "c": (2, 10.0, 130.0), "d": (2, 0.0, 10.0)}
    line = workers_line(timeline)
    assert "busy 100s, 130s" in line
    assert "final 30.0s (its last figure: c, 120.0s)" in line
    # the longest figure (120 s) exceeds an even share of the 230 s of work (115 s): said, not hidden
    assert "exceeds an even share (115s)" in line
    balanced = {"a": (1, 0.0, 50.0), "b": (1, 50.0, 99.0), "c": (2, 0.0, 60.0), "d": (2, 60.0, 100.0)}
    assert "final 1.0s" in workers_line(balanced) and "exceeds" not in workers_line(balanced)
    assert workers_line({"a": (7, 0.0, 5.0), "b": (7, 5.0, 9.0)}) == ""      # one worker: no line
