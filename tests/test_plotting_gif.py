"""GIF frames drawn by pbanim.plotting_gif against frames drawn whole: the same bytes (ORACLES G5: a frozen
backdrop; ORACLES L7: blitting the moving artists over a restored background)."""

import numpy as np

from pbanim.plotting import _write_gif, pyplot
from pbanim.plotting_gif import blit_canvas, frozen_backdrop


def _gif(path, freeze, *, still_x=False):
    """Five frames of a scene like the walk's: a line moving right, the view following it (the x ticks change
    every frame), a fixed floor, a title per frame; with ``freeze`` the unchanging artists as a backdrop."""
    plt = pyplot()
    fig, ax = plt.subplots(figsize=(3, 2))
    walker = ax.plot([0, 0.3], [0, 1], "o-", lw=2)[0]
    floor = ax.plot([-10, 10], [0.02, 0.02], color="0.5")[0]
    ax.set_ylim(-0.1, 1.2)
    show = lambda: None                                                           # noqa: E731
    if freeze:
        still = [fig.patch, ax.patch, ax.yaxis] + ([ax.xaxis] if still_x else [])
        moving = [walker, floor, ax.title, *ax.spines.values()] + ([] if still_x else [ax.xaxis])
        show = frozen_backdrop(fig, still, moving)

    def draw(i):
        show()
        x = 0.37 * i
        walker.set_data([x, x + 0.3], [0.0, 1.0])
        ax.set(xlim=(x - 1.0, x + 1.0), title=f"t = {0.1 * i:.1f} s")

    _write_gif(fig, draw, 5, 10, 40, path)                # the writer's first draw at the figure's own dpi
    plt.close(fig)
    return path.read_bytes()


def test_frames_over_a_frozen_backdrop_are_the_frames_drawn_whole(tmp_path):
    # ORACLES G5: the y axis (ticks, labels, grid), the axes' face and the figure drawn once per resolution
    # under the moving line, the floor, the x axis (its ticks move with the view), the spines and the title
    whole = _gif(tmp_path / "whole.gif", False)
    assert _gif(tmp_path / "frozen.gif", True) == whole
    # the check can fail: the x axis frozen although the view moves draws the first frame's ticks throughout
    assert _gif(tmp_path / "wrong.gif", True, still_x=True) != whole


def test_the_backdrop_is_made_again_at_another_resolution():
    # ORACLES G5: the writer draws once at the figure's dpi, then at its own; the backdrop follows (one copy)
    from matplotlib.backends.backend_agg import FigureCanvasAgg

    plt = pyplot()
    fig, ax = plt.subplots(figsize=(2, 2))
    line = ax.plot([0, 1], [0, 1])[0]
    show = frozen_backdrop(fig, [fig.patch, ax.patch, ax.xaxis, ax.yaxis], [line, *ax.spines.values()])
    canvas = FigureCanvasAgg(fig)
    for dpi in (50, 50, 30):
        fig.dpi = dpi
        show()
        canvas.draw()
        assert len(fig.artists) == 1 and fig.artists[0].size == (2 * dpi, 2 * dpi)
    assert not ax.xaxis.get_visible() and line.get_visible()
    assert np.asarray(canvas.buffer_rgba()).shape == (60, 60, 4)
    plt.close(fig)


def _blit_gif(path, blit, *, circle=False):
    """Six frames of a fixed view (scenery: a floor line, a filled region, a star) with a box's outline made
    anew each frame; with ``circle`` a circle patch moves as well (a patch: drawn before the lines)."""
    import matplotlib.patches as mpatches

    plt = pyplot()
    fig, ax = plt.subplots(figsize=(3, 2))
    ax.fill_between([0.0, 0.4], 0.0, 0.3, color="0.85")
    ax.axhline(0.0, color="k"), ax.plot(0.8, 0.1, "r*", ms=12)
    ax.set_xlim(-0.2, 1.2), ax.set_ylim(-0.05, 0.5), ax.set_xlabel("x (m)"), ax.set_ylabel("z (m)")
    drawn = []

    def update(j):
        for a in drawn:
            a.remove()
        x = 0.15 * j
        drawn[:] = [ax.plot([x, x + 0.2, x + 0.2, x, x], [0.0, 0.0, 0.1, 0.1, 0.0], color="C1")[0]]
        if circle:
            drawn.append(ax.add_patch(mpatches.Circle((x, 0.3), 0.05, fill=False)))
        return drawn

    if blit:
        blit_canvas(fig, lambda: drawn)
    _write_gif(fig, update, 6, 10, 40, path)
    plt.close(fig)
    return path.read_bytes()


def test_blitted_frames_are_the_frames_drawn_whole(tmp_path):
    # ORACLES L7: the outline is the last data artist drawn: restored background + outline = a full draw
    assert _blit_gif(tmp_path / "blit.gif", True) == _blit_gif(tmp_path / "full.gif", False)
    # a moving patch is drawn before the lines (the star, the floor): the canvas falls back to full draws
    assert _blit_gif(tmp_path / "blit_c.gif", True, circle=True) == _blit_gif(tmp_path / "full_c.gif", False,
                                                                               circle=True)


def test_a_stale_background_would_show(tmp_path):
    # ORACLES L7: the check can fail — the background kept although the scenery changes between frames
    plt = pyplot()
    fig, ax = plt.subplots(figsize=(2, 2))
    ax.set_xlim(0, 1), ax.set_ylim(0, 1)
    scenery = ax.plot([0.1, 0.9], [0.5, 0.5], color="k")[0]
    mover = ax.plot([0.5], [0.2], "o")[0]
    canvas = blit_canvas(fig, lambda: [mover])
    assert fig.canvas is canvas
    canvas.draw()
    scenery.set_ydata([0.8, 0.8])                          # not a moving artist: the blitted frame misses it
    canvas.draw()
    blitted = np.asarray(canvas.buffer_rgba()).copy()
    from matplotlib.backends.backend_agg import FigureCanvasAgg

    FigureCanvasAgg.draw(canvas)
    assert not np.array_equal(blitted, np.asarray(canvas.buffer_rgba()))
    plt.close(fig)


def _field_gif(path, pin):
    """Five frames of a field drawn first (an image under the grid, a contour and the spines), a fixed view,
    labelled axes and a title per frame; ``pin``: None (labels placed every frame), "each" (pinned_labels at
    every frame's update) or "once" (pinned at the figure's own dpi only, before the writer changes it)."""
    from pbanim.plotting_gif import pinned_labels

    plt = pyplot()
    fig, ax = plt.subplots(figsize=(2.4, 3.0))
    X, Y = np.meshgrid(np.linspace(0, 1, 20), np.linspace(0, 1.5, 30), indexing="ij")
    im = ax.imshow(np.zeros((30, 20)), origin="lower", extent=(0, 1, 0, 1.5), vmin=0, vmax=1)
    ax.contour(X, Y, (X - 0.5) ** 2 + (Y - 0.7) ** 2, levels=[0.04], colors="w")
    ax.set_xlabel("x (m)"), ax.set_ylabel("y (m)"), ax.set_title(" ", y=1.0)
    show = pinned_labels(fig) if pin else (lambda: None)
    if pin == "once":
        show()
        show = lambda: None                                                       # noqa: E731

    def draw(i):
        show()
        im.set_data(np.sin(X.T * (i + 1) + Y.T) ** 2)
        ax.set_title(f"t = {0.1 * i:.1f} s")

    _write_gif(fig, draw, 5, 10, 40, path)                # the writer's first draw at the figure's own dpi
    plt.close(fig)
    return path.read_bytes()


def test_pinned_labels_leave_the_frames_drawn_whole(tmp_path):
    # ORACLES G5: the axis labels pinned where one layout put them (at each resolution): the same bytes
    whole = _field_gif(tmp_path / "whole.gif", None)
    assert _field_gif(tmp_path / "pinned.gif", "each") == whole
    # the check can fail: labels pinned at the figure's dpi and kept at the writer's are misplaced
    assert _field_gif(tmp_path / "wrong.gif", "once") != whole
