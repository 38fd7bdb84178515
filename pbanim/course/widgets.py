"""Live controls in the chapter notebooks: a slider or a menu, and the chapter's demo redrawn.

A :class:`LiveDemo` is a chapter's demo scene as a function of a few parameters — the step size and the
method of chapter 02, the Baumgarte gains ω_b and ζ of chapter 03, the restitution ε of chapter 06, the
gains and the push of chapter 08, the viscosity ν of chapter 09, the dragged target of chapter 10 (the
demos are in :mod:`pbanim.course.live_demos`). ``demo.redraw(**params)`` computes the scene, draws it on
a fresh matplotlib ``Figure`` (no pyplot state) and returns the figure and the computed data; that is the
callback a control calls, and what the tests call without any widget library.

In a notebook, ``live(name)`` shows the controls (ipywidgets, the optional extra ``pbanim[widgets]``) and
the figure, redrawn as PNG when a control is released; without ipywidgets it draws the figure once at the
default values and says how to get the controls, so the notebook runs unchanged. ``pbanim notebook chNN
DIR`` puts a ``live(...)`` cell after the figure each demo belongs to (:func:`live_cells`).

Each redraw must take under 0.2 s for a lecture (compute, draw and PNG encoding, measured by
:func:`redraw_times` and printed by ``python -m pbanim.course.widgets``).

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

__all__ = ["Control", "LiveDemo", "DEMOS", "register_demo", "get_demo", "live", "live_cells", "redraw_times"]


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
        """The callback: compute the scene at these parameters and draw it; returns (Figure, data)."""
        from matplotlib.figure import Figure
        from matplotlib.ticker import NullLocator

        p = self.params(**given)
        data = self.compute(self, **p)
        fig = Figure(figsize=self.figsize, dpi=72)
        self.draw(fig, data, p)
        # speed: a log axis's minor ticks are most of a redraw (hundreds of tick objects); a fixed layout
        # instead of a constrained one saves a second draw
        for ax in fig.axes:
            for axis in (ax.xaxis, ax.yaxis):
                if axis.get_scale() == "log":
                    axis.set_minor_locator(NullLocator())
        fig.subplots_adjust(left=0.1, right=0.97, bottom=0.15, top=0.88, wspace=0.3)
        return fig, data

    def png(self, **given) -> bytes:
        """The redrawn figure as PNG bytes (what the notebook shows)."""
        fig, _ = self.redraw(**given)
        buf = io.BytesIO()
        fig.savefig(buf, format="png")
        return buf.getvalue()


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
    """(demo, control moved, median, min, max seconds of a whole redraw to PNG, median seconds of its
    compute alone) for each control of each demo: the control set to its low end, its high end and back
    (choices: each option), ``repeats`` rounds; the rest of a redraw is matplotlib drawing the figure."""
    rows = []
    for d in _load().values():
        d.png()                                   # warm: imports, caches
        for c in d.controls:
            values = list(c.options) if c.kind == "choice" else [c.lo, c.hi, c.value]
            ts, tc = [], []
            for _ in range(repeats):
                for v in values:
                    t0 = time.perf_counter()
                    d.png(**{c.name: v})
                    t1 = time.perf_counter()
                    d.compute(d, **d.params(**{c.name: v}))
                    ts.append(t1 - t0)
                    tc.append(time.perf_counter() - t1)
            rows.append((d.name, c.name, float(np.median(ts)), float(min(ts)), float(max(ts)), float(np.median(tc))))
        d.state.clear()
    return rows


if __name__ == "__main__":      # the redraw table (the registry lives in the imported module, not __main__)
    from pbanim.course.widgets import redraw_times as _times

    print(f"{'demo':18s} {'control':12s} {'redraw median s':>15s} {'min':>6s} {'max':>6s} {'compute s':>9s}  goal < 0.2 s")
    for name, ctl, med, lo, hi, comp in _times():
        print(f"{name:18s} {ctl:12s} {med:15.3f} {lo:6.3f} {hi:6.3f} {comp:9.3f}  {'met' if med < 0.2 else 'MISSED'}")
    from matplotlib.figure import Figure

    def _empty() -> None:                # the floor: matplotlib drawing two labelled axes, no data, to PNG
        fig = Figure(figsize=(9.0, 3.4), dpi=72)
        for ax in fig.subplots(1, 2):
            ax.set(xlabel="t (s)", ylabel="y", title="floor")
        fig.savefig(io.BytesIO(), format="png")
    floor = []
    for _ in range(7):
        t0 = time.perf_counter()
        _empty()
        floor.append(time.perf_counter() - t0)
    print(f"floor (matplotlib: two empty axes to PNG, not pbanim's): median {np.median(floor):.3f} s, "
          f"min {min(floor):.3f}, max {max(floor):.3f}")
