"""Valid calls for pbanim.plotting_gif: a small figure with one line, its still and its moving artists."""

from matplotlib.artist import Artist
from matplotlib.figure import Figure


def _scene():
    fig = Figure(figsize=(1.0, 1.0))
    ax = fig.add_subplot()
    line = ax.plot([0.0, 1.0], [0.0, 1.0])[0]
    return fig, ax, line


def _backdrop():
    fig, ax, line = _scene()
    return {"fig": fig, "still": [fig.patch, ax.patch, ax.xaxis, ax.yaxis], "moving": [line, *ax.spines.values()]}


def _blit():
    fig, _, line = _scene()
    return {"fig": fig, "moving": lambda: [line]}


INSTANCES = {
    Artist: lambda: Figure(figsize=(1.0, 1.0)).add_subplot().plot([0.0], [0.0])[0],
}

CALLS = {
    "pbanim.plotting_gif.frozen_backdrop": _backdrop,
    "pbanim.plotting_gif.blit_canvas": _blit,
}
