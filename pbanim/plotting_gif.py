"""GIF frames without redrawing what does not move (every chapter's animations).

A frame of a GIF is the Agg buffer after drawing the figure's artists in matplotlib's order (the figure, then
each axes: its children by z-order, then by order of addition; the axes' spines, axis and title among
them)::

    B_i = a_n ∘ … ∘ a_2 ∘ a_1 (blank)          each a_j composites over the buffer as it stands

Agg writes every pixel of an artist from the buffer it finds, so two splits of that product give the same
bytes at a fraction of the cost when most artists are the same in every frame:

==================  ==========================================================================================
helper              what is rendered once; what each frame draws; when to use it
==================  ==========================================================================================
frozen_backdrop     the *prefix* P = a_k ∘ … ∘ a_1 (the still artists, drawn before every moving one), its
                    pixels copied back first; a frame is a full draw of the others (their layout is
                    redone). Use it when the view moves (x limits following a walker: the ticks move) or
                    when still artists are drawn after moving ones (a terrain's edge over the limbs).
blit_canvas         everything but the *suffix* (the moving artists, drawn last in their axes), restored as
                    pixels; a frame draws only the suffix (nothing is laid out again). Use it when the
                    moving artists are the last data artists of a fixed view (a body's outline over the
                    scenery); anything else makes it fall back to full draws, frame by frame.
pinned_labels       no pixels; the axis labels' places, laid out by one draw and kept: a frame does not
                    place them again from the tick labels' boxes. Use it under a moving image (a field
                    drawn first, under the grid and the spines: neither helper above applies) with a view
                    and tick labels that do not move.
==================  ==========================================================================================

All three leave each frame's pixels those of drawing every artist (ORACLES G5, L7: the GIF's bytes are those of
full draws); all follow the resolution (the GIF writer draws once at the figure's dpi, then at its own).

Limits: artists in neither list of :func:`frozen_backdrop` must not overlap the frozen ones' pixels (they
would be drawn over the image instead of under the still artists in between); an artist whose look changes
must never be frozen (freezing the x axis of a moving view shows the first frame's ticks throughout).
Reference: matplotlib's "Faster rendering by using blitting" (``copy_from_bbox`` / ``restore_region``);
Anti-Grain Geometry's scanline compositing.
"""

from __future__ import annotations

import functools
from typing import Callable

import numpy as np

from .contracts import Func, Obj, Seq, contract

__all__ = ["frozen_backdrop", "blit_canvas", "pinned_labels"]

_FIG = Obj("matplotlib.figure:Figure", what="a matplotlib Figure")
_ARTISTS = Seq(Obj("matplotlib.artist:Artist", what="a matplotlib Artist"))


def _agg_canvas(fig):
    from matplotlib.backends.backend_agg import FigureCanvasAgg

    return fig.canvas if isinstance(fig.canvas, FigureCanvasAgg) else FigureCanvasAgg(fig)


@contract(fig=_FIG, still=_ARTISTS, moving=_ARTISTS)
def frozen_backdrop(fig, still, moving) -> Callable[[], None]:
    """``show()``, to be called first in each frame's update of a GIF of ``fig``: the artists ``still`` — the
    same in every frame and drawn in a frame before every one of ``moving`` — rendered once per resolution
    (with ``moving`` hidden) and its pixels copied back before the rest, hidden themselves, so that a frame draws
    only ``moving`` (and what is in neither list). The frame's pixels are those of drawing everything (each
    pixel is written in the same order); artists in neither list must not overlap the still ones.

    Invisible artists are left out of both lists (as a full draw leaves them out)."""
    still = [a for a in still if a.get_visible()]
    moving = [a for a in moving if a.get_visible()]
    made: dict = {}

    def show() -> None:
        if made.get("dpi") == fig.dpi:
            return
        if "image" in made:                                     # rendered at another resolution: again
            made.pop("image").remove()
        for a in still:
            a.set_visible(True)
        for a in moving:
            a.set_visible(False)
        canvas = _agg_canvas(fig)
        canvas.draw()
        backdrop = _backdrop_class()(canvas.copy_from_bbox(fig.bbox), canvas.get_width_height(physical=True))
        for a in moving:
            a.set_visible(True)
        for a in still:
            a.set_visible(False)
        made["image"], made["dpi"] = fig.add_artist(backdrop), fig.dpi

    return show


@functools.cache
def _backdrop_class():
    """The artist that shows a backdrop (a class made on first use: matplotlib loads lazily)."""
    from matplotlib.artist import Artist

    class Backdrop(Artist):
        """The figure's pixels as they stood, copied back first at each draw (``restore_region``: the bytes,
        where a figure image of them goes through the image resampler every frame); nothing at another size."""

        def __init__(self, region, size) -> None:
            super().__init__()
            self.region, self.size = region, tuple(size)
            self.set_zorder(-np.inf)

        def draw(self, renderer) -> None:
            if self.get_visible() and (int(renderer.width), int(renderer.height)) == self.size:
                renderer.restore_region(self.region)

    return Backdrop


@contract(fig=_FIG)
def pinned_labels(fig) -> Callable[[], None]:
    """``show()``, to be called first in each frame's update of a GIF of ``fig`` whose axes' limits and tick
    labels are the same in every frame: at the first call at each resolution one draw lays the figure out,
    and each visible axis label is pinned where it was put (its own position and transform), so that a frame
    does not place it again from the tick labels' boxes (the same position: the same pixels). At another
    resolution the labels are placed by matplotlib again, then pinned."""
    made: dict = {}

    def show() -> None:
        if made.get("dpi") == fig.dpi:
            return
        for axis in made.pop("pinned", []):
            axis._autolabelpos = True                       # placed from the tick labels again (next draw)
        _agg_canvas(fig).draw()
        pinned = []
        for ax in fig.axes:
            for axis in (ax.xaxis, ax.yaxis):
                if axis._autolabelpos and axis.get_visible() and axis.label.get_visible():
                    x, y = axis.label.get_position()
                    axis.set_label_coords(x, y, transform=axis.label.get_transform())
                    pinned.append(axis)
        made["pinned"], made["dpi"] = pinned, fig.dpi

    return show


def _last_drawn(arts) -> bool:
    """Whether the artists ``arts`` are drawn after every other visible data artist (line, patch, collection,
    image, text) of their axes, in matplotlib's order (z-order, then order of addition)."""
    for ax in {a.axes for a in arts}:
        order = {id(k): (k.get_zorder(), i) for i, k in enumerate(ax.get_children())}
        first = min(order[id(a)] for a in arts if a.axes is ax)
        data = [*ax.lines, *ax.patches, *ax.collections, *ax.images, *ax.texts]
        if any(order[id(o)] > first for o in data if o.get_visible() and all(o is not a for a in arts)):
            return False
    return True


@contract(fig=_FIG, moving=Func())
def blit_canvas(fig, moving: Callable[[], list]):
    """An Agg canvas for ``fig`` (it becomes ``fig.canvas``) that renders everything but the artists
    ``moving()`` once per resolution and size, then per draw restores that background and draws only them:
    the bytes of a full draw when the moving artists are the last data artists drawn (after every other
    line, patch, collection, image and text of their axes in matplotlib's order: z-order, then order of
    addition) and lie inside the axes under no spine, tick or label, at a fraction of its cost (the ticks
    and labels are not laid out again). Otherwise (e.g. a circle is a patch, drawn before the lines) the draw
    is a full one. ``moving`` is called at every draw: the artists may be made anew for each frame."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg

    class Blit(FigureCanvasAgg):
        background = None

        def draw(self):
            arts = [a for a in moving() if a.get_visible()]
            if not arts or not _last_drawn(arts):
                return super().draw()
            key = (self.figure.dpi, tuple(self.figure.bbox.bounds))
            if self.background is None or self.background[0] != key:
                for a in arts:
                    a.set_visible(False)
                super().draw()
                for a in arts:
                    a.set_visible(True)
                self.background = (key, self.copy_from_bbox(self.figure.bbox))
            else:
                self.restore_region(self.background[1])
            renderer = self.get_renderer()
            for a in arts:
                a.draw(renderer)

    return Blit(fig)
