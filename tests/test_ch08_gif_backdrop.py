"""GIF frames drawn over a frozen backdrop (chapters.ch08_characters._frozen_backdrop) against frames drawn
whole: the same bytes (ORACLES G5)."""

import numpy as np

from pbanim.plotting import _write_gif, pyplot


def _gif(path, freeze, *, still_x=False):
    """Five frames of a scene like the walk's: a line moving right, the view following it (the x ticks change
    every frame), a fixed floor, a title per frame; with ``freeze`` the unchanging artists as a backdrop."""
    from chapters.ch08_characters import _frozen_backdrop

    plt = pyplot()
    fig, ax = plt.subplots(figsize=(3, 2))
    walker = ax.plot([0, 0.3], [0, 1], "o-", lw=2)[0]
    floor = ax.plot([-10, 10], [0.02, 0.02], color="0.5")[0]
    ax.set_ylim(-0.1, 1.2)
    show = lambda: None                                                           # noqa: E731
    if freeze:
        still = [fig.patch, ax.patch, ax.yaxis] + ([ax.xaxis] if still_x else [])
        moving = [walker, floor, ax.title, *ax.spines.values()] + ([] if still_x else [ax.xaxis])
        show = _frozen_backdrop(fig, still, moving)

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


def test_the_backdrop_is_made_again_at_another_resolution(tmp_path):
    # ORACLES G5: the writer draws once at the figure's dpi, then at its own; the backdrop follows (one image)
    from chapters.ch08_characters import _frozen_backdrop

    plt = pyplot()
    fig, ax = plt.subplots(figsize=(2, 2))
    line = ax.plot([0, 1], [0, 1])[0]
    show = _frozen_backdrop(fig, [fig.patch, ax.patch, ax.xaxis, ax.yaxis], [line, *ax.spines.values()])
    from matplotlib.backends.backend_agg import FigureCanvasAgg

    canvas = FigureCanvasAgg(fig)
    for dpi in (50, 50, 30):
        fig.dpi = dpi
        show()
        canvas.draw()
        assert len(fig.images) == 1 and fig.images[0].get_array().shape[:2] == (2 * dpi, 2 * dpi)
    assert not ax.xaxis.get_visible() and line.get_visible()
    assert np.asarray(canvas.buffer_rgba()).shape == (60, 60, 4)
    plt.close(fig)
