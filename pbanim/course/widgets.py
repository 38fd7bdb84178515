"""Live controls in the chapter notebooks: a slider or a menu, and the chapter's demo redrawn.

A :class:`LiveDemo` is a chapter's demo scene as a function of a few parameters — the step size and the
method of chapter 02, the Baumgarte gains ω_b and ζ of chapter 03, the restitution ε of chapter 06, the
gains and the push of chapter 08, the viscosity ν of chapter 09, the dragged target of chapter 10 (the
demos are in :mod:`pbanim.course.live_demos`). ``demo.redraw(**params)`` computes the scene and shows it on
the demo's matplotlib ``Figure`` (no pyplot state; an Agg canvas), built once by the demo's ``draw``; a later
call sets the artists' data, texts and limits (the demo's ``update``: ``set_data``, titles, ``relim``)
instead of building another, so a control change pays the compute and one draw — of the data alone when
the limits stay (ch03, ch09, ch10 fix theirs over the controls' range). It returns the figure and
the computed data; that is the callback a control calls, and what the tests call without any widget library
(an updated figure shows what a new one built from the same data shows, ``tests/test_course_live.py``).

In a notebook, ``live(name)`` shows the controls (ipywidgets, the optional extra ``pbanim[widgets]``) and
the figure, redrawn as PNG when a control is released; without ipywidgets it draws the figure once at the
default values and says how to get the controls, so the notebook runs unchanged. ``pbanim notebook chNN
DIR`` puts a ``live(...)`` cell after the figure each demo belongs to (:func:`live_cells`).

Each redraw must take under 0.2 s for a lecture (compute, the artists updated and the Agg draw, measured by
:func:`redraw_times`, printed by ``python -m pbanim.course.widgets`` and as rows of ``pbanim bench course``;
the notebook adds the PNG encoding of the drawn canvas).

Bad input: a parameter outside its control's range or not one of its options, or an unknown name, is an
:class:`~pbanim.errors.InvalidInput` naming it (closest demo names suggested).
"""

from __future__ import annotations

import io
import time
from dataclasses import dataclass, field
from typing import Callable

import numpy as np

from ..contracts import Int, Obj, Seq, Text, contract
from ..errors import InvalidInput

__all__ = ["Control", "LiveDemo", "DEMOS", "register_demo", "get_demo", "live", "live_cells", "redraw_times",
           "draw_floor"]


@dataclass(frozen=True)
class Control:
    """One control: ``kind`` "float" (linear slider), "log" (logarithmic slider), "int" or "choice"."""

    name: str
    label: str
    kind: str
    value: object
    lo: float | None = None
    hi: float | None = None
    options: tuple = ()

    def check(self, value):
        """``value`` if the control can take it, else InvalidInput naming the control."""
        if self.kind == "choice":
            if value not in self.options:
                raise InvalidInput(f"{self.name} must be one of {list(self.options)}, got {value!r}")
            return value
        v = float(value)
        if not (np.isfinite(v) and self.lo <= v <= self.hi):
            raise InvalidInput(f"{self.name} must be in [{self.lo:g}, {self.hi:g}], got {value!r}")
        return int(round(v)) if self.kind == "int" else v


@dataclass
class LiveDemo:
    """A chapter's demo with controls: ``compute(**params) -> dict`` and ``draw(fig, data, params)``."""

    name: str
    chapter: str                  # the chapter module, e.g. "ch02_ode"
    after: str                    # the figure whose cell the live cell follows
    title: str
    controls: tuple
    compute: Callable
    draw: Callable
    figsize: tuple = (9.0, 3.4)
    notes: str = ""
    state: dict = field(default_factory=dict)    # what a stateful demo (a drag) keeps between redraws
    # update(arts, data, params): the figure built by ``draw`` (which returned ``arts``) set to new data
    update: Callable | None = None
    _built: dict | None = field(default=None, init=False, repr=False, compare=False)   # the figure, its artists

    def defaults(self) -> dict:
        return {c.name: c.value for c in self.controls}

    def params(self, **given) -> dict:
        """The defaults updated by ``given``, each checked against its control."""
        names = {c.name: c for c in self.controls}
        unknown = sorted(set(given) - set(names))
        if unknown:
            raise InvalidInput(f"{self.name}: parameters must be among {sorted(names)}, got {unknown}")
        return {k: names[k].check(v) for k, v in {**self.defaults(), **given}.items()}

    def redraw(self, **given):
        """The callback: compute the scene at these parameters and show it; returns (Figure, data). The figure
        is built once (``draw``, on an Agg canvas); a later call updates its artists' data, texts and limits
        (``update``) instead of building another, and keeps the limits it had when the new ones lie inside them
        and span at least half of them (:func:`_keep_limits`), so that the axes, ticks and labels drawn before
        can be reused by :meth:`frame`."""
        p = self.params(**given)
        data = self.compute(self, **p)
        built = self._built
        if built is None or self.update is None:
            fig, arts = self.build(data, p)
            self._built = {"fig": fig, "arts": arts, "bg": None, "limits": None,
                           "dynamic": _dynamic(fig, arts) if self.update is not None else []}
        else:
            fig = built["fig"]
            self.update(built["arts"], data, p)
            if built["limits"] is None or not _keep_limits(fig.axes, built["limits"]):
                built["bg"] = None                # new limits: the axes are drawn again
        return fig, data

    def build(self, data: dict, p: dict):
        """A new figure of ``data`` at parameters ``p``: (Figure, the artists ``draw`` returned)."""
        from matplotlib.backends.backend_agg import FigureCanvasAgg
        from matplotlib.figure import Figure
        from matplotlib.ticker import NullLocator

        fig = Figure(figsize=self.figsize, dpi=72)
        FigureCanvasAgg(fig)
        arts = self.draw(fig, data, p)
        # speed: a log axis's minor ticks are most of a redraw (hundreds of tick objects); a fixed layout
        # instead of a constrained one saves a second draw
        for ax in fig.axes:
            for axis in (ax.xaxis, ax.yaxis):
                if axis.get_scale() == "log":
                    axis.set_minor_locator(NullLocator())
        fig.subplots_adjust(left=0.1, right=0.97, bottom=0.15, top=0.88, wspace=0.3)
        return fig, arts

    def frame(self, **given):
        """One control change as the notebook shows it: :meth:`redraw`, then the figure drawn on its Agg canvas
        — in full when the limits changed (the axes, ticks and labels kept as a background), else the kept
        background restored and only the data, titles and legends drawn on it (the text of the tick labels is
        most of a full draw); returns (Figure, data)."""
        fig, data = self.redraw(**given)
        built, canvas = self._built, fig.canvas
        if built["bg"] is None or not built["dynamic"]:
            canvas.draw()                         # the animated artists (data, titles, legends) left out
            built["bg"] = canvas.copy_from_bbox(fig.bbox) if built["dynamic"] else None
            built["limits"] = _limits(fig.axes)
        else:
            canvas.restore_region(built["bg"])
        for artist in built["dynamic"]:
            fig.draw_artist(artist)
        return fig, data

    def png(self, **given) -> bytes:
        """The redrawn figure as PNG bytes (what the notebook shows): :meth:`frame`'s canvas encoded."""
        from matplotlib.image import imsave

        fig, _ = self.frame(**given)
        buf = io.BytesIO()
        imsave(buf, np.asarray(fig.canvas.buffer_rgba()), format="png")
        return buf.getvalue()


def _dynamic(fig, arts: dict) -> list:
    """The artists a redraw changes, marked animated (a full draw leaves them out): the demo's artists (all
    but its ``axes`` and the ``walls`` that never move), then every legend and title, drawn in that order."""
    from matplotlib.artist import Artist

    out = [v for k, v in arts.items() if k not in ("axes", "walls", "legend") and isinstance(v, Artist)]
    out += [ax.get_legend() for ax in fig.axes if ax.get_legend() is not None]
    out += [ax.title for ax in fig.axes]
    for a in out:
        a.set_animated(True)
    return out


def _limits(axes) -> list:
    return [(ax.get_xlim(), ax.get_ylim()) for ax in axes]


def _keep_limits(axes, old: list) -> bool:
    """Whether every axes' new (autoscaled) limits lie inside its ``old`` ones and span at least half of them
    (in the axis's scale: decades on a log axis); if so the old limits are set back (autoscaling left on)."""
    def inside(new, was, log):
        f = np.log10 if log else (lambda v: np.asarray(v, float))
        with np.errstate(divide="ignore", invalid="ignore"):
            (n0, n1), (w0, w1) = sorted(f(new)), sorted(f(was))
        return bool(np.isfinite([n0, n1, w0, w1]).all() and w0 <= n0 and n1 <= w1 and n1 - n0 >= 0.5 * (w1 - w0))

    if not all(inside(ax.get_xlim(), xo, ax.get_xscale() == "log") and inside(ax.get_ylim(), yo, ax.get_yscale() == "log")
               for ax, (xo, yo) in zip(axes, old)):
        return False
    for ax, (xo, yo) in zip(axes, old):
        ax.set_xlim(xo, auto=None)
        ax.set_ylim(yo, auto=None)
    return True


DEMOS: dict[str, LiveDemo] = {}


@contract(demo=Obj(LiveDemo))
def register_demo(demo: LiveDemo) -> LiveDemo:
    DEMOS[demo.name] = demo
    return demo


def _load() -> dict:
    from . import live_demos  # noqa: F401  (registers the demos)

    return DEMOS


@contract(name=Text(nonempty=True))
def get_demo(name: str) -> LiveDemo:
    """The demo ``name``, or InvalidInput with the closest names."""
    from .registry import closest

    demos = _load()
    if name not in demos:
        raise InvalidInput(f"unknown live demo {name!r}{closest(name, demos)}; available: {sorted(demos)}")
    return demos[name]


def _widget(W, c: Control):
    common = dict(description=c.label, continuous_update=False, style={"description_width": "initial"})
    if c.kind == "choice":
        return W.Dropdown(options=list(c.options), value=c.value, description=c.label)
    if c.kind == "log":
        return W.FloatLogSlider(value=c.value, base=10, min=np.log10(c.lo), max=np.log10(c.hi), step=0.05, **common)
    if c.kind == "int":
        return W.IntSlider(value=c.value, min=int(c.lo), max=int(c.hi), **common)
    return W.FloatSlider(value=c.value, min=c.lo, max=c.hi, step=(c.hi - c.lo) / 100, **common)


@contract(name=Text(nonempty=True))
def live(name: str):
    """Show the demo ``name`` with its controls (ipywidgets), or once at its defaults without them.
    Returns the widget box, or the PNG bytes drawn without ipywidgets."""
    demo = get_demo(name)
    try:
        import ipywidgets as W
        from IPython.display import Image, display
    except ImportError:
        png = demo.png()
        try:
            from IPython.display import Image, display
        except ImportError:
            return png
        print(f"{demo.title}: the controls need ipywidgets (pip install pbanim[widgets]); drawn at the defaults")
        display(Image(data=png))
        return png
    ws = {c.name: _widget(W, c) for c in demo.controls}
    out = W.Output()

    def on_change(change=None):
        png = demo.png(**{k: w.value for k, w in ws.items()})
        with out:
            out.clear_output(wait=True)
            display(Image(data=png))

    for w in ws.values():
        w.observe(on_change, names="value")
    on_change()
    box = W.VBox([W.HTML(f"<b>{demo.title}</b>"), W.HBox(list(ws.values())), out])
    display(box)
    return box


@contract(chapter=Text(nonempty=True), cells=Seq(Obj("pbanim.course.notebook:Cell")))
def live_cells(chapter: str, cells: list) -> list:
    """``cells`` of the chapter module ``chapter`` with a markdown and a code cell after each figure that
    has a live demo (the figure's code cell holds ``@figure("chNN", "<after>"``)."""
    from .notebook import Cell

    demos = [d for d in _load().values() if d.chapter == chapter]
    out = list(cells)
    for d in demos:
        tag = f'"{chapter[:4]}", "{d.after}"'
        at = next((k for k, c in enumerate(out) if c.kind == "code" and tag in c.source), len(out) - 1)
        controls = ", ".join(c.label for c in d.controls)
        out[at + 1:at + 1] = [
            Cell("markdown", f"### Live: {d.title}\n\nControls: {controls}. {d.notes}\n\n"
                             "The controls need the optional extra `pip install pbanim[widgets]`; without it the "
                             "cell draws the figure once at the default values."),
            Cell("code", f'from pbanim.course.widgets import live\n\nlive("{d.name}")')]
    return out


@contract(repeats=Int(ge=1, le=50))
def redraw_times(repeats: int = 5) -> list[tuple[str, str, float, float, float, float]]:
    """(demo, control moved, median, min, max seconds of a whole redraw — compute, the artists updated, the
    Agg ``canvas.draw()`` —, median seconds of its compute alone) for each control of each demo: the control
    set to its low end, its high end and back (choices: each option), ``repeats`` rounds, the redraw and the
    compute alternating; the rest of a redraw is matplotlib drawing the figure."""
    rows = []
    for d in _load().values():
        d.frame()                                 # warm: imports, caches, the figure built
        for c in d.controls:
            values = list(c.options) if c.kind == "choice" else [c.lo, c.hi, c.value]
            ts, tc = [], []
            for _ in range(repeats):
                for v in values:
                    t0 = time.perf_counter()
                    d.frame(**{c.name: v})
                    t1 = time.perf_counter()
                    d.compute(d, **d.params(**{c.name: v}))
                    ts.append(t1 - t0)
                    tc.append(time.perf_counter() - t1)
            rows.append((d.name, c.name, float(np.median(ts)), float(min(ts)), float(max(ts)), float(np.median(tc))))
        d.state.clear()
    return rows


@contract(repeats=Int(ge=1, le=50))
def draw_floor(repeats: int = 7) -> tuple[float, float, float]:
    """(median, min, max) seconds of matplotlib's Agg draw of a built demo figure that nothing changed (ch06's
    two axes): what any redraw pays after its compute, not pbanim's."""
    d = _load()["ch06_restitution"]
    fig, _ = d.frame()
    ts = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        fig.canvas.draw()
        ts.append(time.perf_counter() - t0)
    return float(np.median(ts)), float(min(ts)), float(max(ts))


if __name__ == "__main__":      # the redraw table (the registry lives in the imported module, not __main__)
    from pbanim.course.widgets import draw_floor as _floor, redraw_times as _times

    print(f"{'demo':18s} {'control':12s} {'redraw median s':>15s} {'min':>6s} {'max':>6s} {'compute s':>9s}  goal < 0.2 s")
    for name, ctl, med, lo, hi, comp in _times():
        print(f"{name:18s} {ctl:12s} {med:15.3f} {lo:6.3f} {hi:6.3f} {comp:9.3f}  {'met' if med < 0.2 else 'MISSED'}")
    med, lo, hi = _floor()
    print(f"floor (matplotlib: the Agg draw of a built figure, nothing changed; not pbanim's): median {med:.3f} s, "
          f"min {lo:.3f}, max {hi:.3f}")
