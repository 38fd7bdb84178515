# %% [markdown]
# # Chapter 11 — engines side by side: the same scenes in pbanim, PyBullet and MuJoCo, against the exact answer.
#
# This file is a module (imported by `pbanim figures`) and a notebook in jupytext's percent format:
# open it in Jupyter (with jupytext) or VS Code, or write an `.ipynb` with `pbanim notebook ch11 DIR`.
# Running it draws every figure of the chapter in quick mode into `figures/`.

# %%
"""Chapter 11 — engines side by side: the same scenes in pbanim, PyBullet and MuJoCo, against the exact answer.

"How to start": write your own engine, or start from an existing one. Each scene of
:data:`pbanim.compare.SCENES` (free fall, projectile, a bouncing ball, a box on an incline below and above
tan θ = μ, a sphere that starts rolling, a pendulum chain, Newton's cradle, a stack, a spinning top) is
described once and run in every installed engine (PyBullet and MuJoCo are the optional ``peers`` extra:
without them only pbanim and the exact answer are drawn).

Figures:

* ``trajectories``: per scene, the observable of each engine at the finest step of the sweep (height,
  downhill displacement, speed, energy error, precession angle …) drawn over its exact curve (black,
  dashed): where a peer trades accuracy for speed (soft contacts creep, restitution is a spring, an
  explicit gyroscopic term makes the top fall) shows at a glance (ORACLES K1–K8).
* ``error_vs_cost``: per scene, each engine's error against the closed form vs its cost (µs per step of
  the stepping call alone) as the step h shrinks along the sweep; an error of exactly 0 is drawn at 1e-16,
  and an engine whose error is at roundoff (≤ 1e-13: pbanim's free flight, bounce and rolling measure
  1e-15 … 3e-14 at every step) stops its sweep there (finer steps only redraw roundoff, at more cost).
"""

from __future__ import annotations

from functools import lru_cache

import numpy as np

from pbanim.compare import run_compare
from pbanim.plotting import figure

COLORS = {"pbanim": "C0", "pybullet": "C1", "mujoco": "C2"}
FLOOR = 1e-16
ROUNDOFF = 1e-13        # an error at or below it is roundoff: the engine's finer steps are not run


@lru_cache(maxsize=2)
def comparison(quick: bool):
    """One run of every scene in every engine (shared by both figures: one group, run in one process)."""
    # the sweeps only (the figures' points), each engine's capped where its error reaches roundoff
    return run_compare(quick=quick, keep_curves=True, own_steps=False, stop_below=ROUNDOFF)


def _layout(fig, title: str) -> None:
    """A fixed grid (tight_layout on ten log axes costs seconds) and a title above the panel titles."""
    fig.subplots_adjust(left=0.05, right=0.99, bottom=0.08, top=0.9, wspace=0.38, hspace=0.42)
    fig.suptitle(title)


def _log_ticks(ax) -> None:
    """Few plain-text ticks on log axes (mathtext labels on twenty log axes cost seconds to draw)."""
    from matplotlib.ticker import FuncFormatter, LogLocator, NullLocator

    for axis in (ax.xaxis, ax.yaxis):
        axis.set_major_locator(LogLocator(numticks=5))
        axis.set_minor_locator(NullLocator())
        axis.set_major_formatter(FuncFormatter(lambda v, _: f"{v:.0e}"))


def _engines(cmp) -> list[str]:
    return list(dict.fromkeys(r.engine for r in cmp.rows))


# %% [markdown]
# ## Figure `ch11_trajectories`
#
# Each engine's trajectory over the exact answer, one panel per scene.

# %%
@figure("ch11", "trajectories", "Each engine's trajectory over the exact answer", group="ch11_comparison")
def trajectories(ctx):
    cmp = comparison(ctx.quick)
    names = list(cmp.scenes)
    fig, axs = ctx.subplots(2, (len(names) + 1) // 2, figsize=(17, 6.6))
    data = {"installed": {e: any(r.status == "ok" for r in cmp.rows if r.engine == e) for e in _engines(cmp)}}
    for ax, name in zip(axs.ravel(), names):
        sc = cmp.scenes[name]
        h = min(r.h for r in cmp.rows_of(name))
        t_exact = np.linspace(0.0, sc.spec.time(ctx.quick), 400)
        y_exact = sc.exact(t_exact)
        entry = {"h": h, "t_exact": t_exact, "exact": y_exact}
        shown = [y_exact]
        for e in _engines(cmp):
            mine = cmp.rows_of(name, e, True)              # an engine at the error floor stopped its sweep early:
            curve = cmp.curves.get((name, e, min(r.h for r in mine))) if mine else None   # its finest step
            if curve is None:
                continue
            t, y = curve
            entry[e] = {"t": t, "y": y, "exact_at_t": sc.exact(t)}
            ax.plot(t, y, color=COLORS.get(e.split(":")[0]), lw=1.2, label=e)
            shown.append(y[np.isfinite(y)])
        ax.plot(t_exact, y_exact, "k--", lw=1.0, label="exact")
        lo, hi = float(np.min(y_exact)), float(np.max(y_exact))
        span = hi - lo
        if span == 0:                              # exact answer constant: show the engines' deviation
            dev = max(float(np.max(np.abs(np.concatenate(shown) - lo))), 1e-12)
            ax.set_ylim(lo - 1.2 * dev, lo + 1.2 * dev)
        else:                                      # keep a diverged run from flattening the exact curve
            ax.set_ylim(lo - 0.3 * span, hi + 0.3 * span)
        ax.set_title(f"{name} (h = {h:g} s)", fontsize=8)
        ax.set_xlabel("t (s)")
        ax.set_ylabel(sc.ylabel, fontsize=7)
        data[name] = entry
    for ax in axs.ravel()[len(names):]:
        ax.axis("off")
    axs.ravel()[0].legend(fontsize=7)
    _layout(fig, "Each engine's trajectory over the exact answer")
    ctx.save(fig)
    return data


# %% [markdown]
# ## Figure `ch11_error_vs_cost`
#
# Error against the closed form vs cost per step, for each engine as the step changes.

# %%
@figure("ch11", "error_vs_cost", "Error vs cost per engine as the step changes", cost=19.5, group="ch11_comparison")
def error_vs_cost(ctx):
    cmp = comparison(ctx.quick)
    names = list(cmp.scenes)
    fig, axs = ctx.subplots(2, (len(names) + 1) // 2, figsize=(17, 6.6))
    rows = [r.to_json() for r in cmp.rows]
    for ax, name in zip(axs.ravel(), names):
        for e in _engines(cmp):
            ok = sorted((r for r in cmp.rows_of(name, e) if r.status == "ok"), key=lambda r: -r.h)
            if not ok:
                continue
            cost = [r.us_per_step for r in ok]
            err = [max(r.error, FLOOR) for r in ok]
            ax.loglog(cost, err, "o-", color=COLORS.get(e.split(":")[0]), ms=3, label=e)
        _log_ticks(ax)
        ax.set_title(name, fontsize=8)
        ax.set_xlabel("cost (µs/step)")
        ax.set_ylabel(f"error: {cmp.scenes[name].error_name}", fontsize=6)
    for ax in axs.ravel()[len(names):]:
        ax.axis("off")
    axs.ravel()[0].legend(fontsize=7)
    _layout(fig, "Error vs cost per engine as the step changes")
    ctx.save(fig)
    return {"rows": rows, "versions": cmp.versions,
            "orders": {f"{n}/{e}": cmp.order(n, e) for n in names for e in _engines(cmp)}}


# %% [markdown]
# ## Draw the figures
#
# As a script or in a notebook kernel, draw this file's figures (quick mode) into `figures/`.

# %%
if __name__ == "__main__":
    from pathlib import Path

    from pbanim.plotting import figures_of, run_figure

    for _key, _spec in figures_of({"ch11"}).items():
        print(_key, [p.name for p in run_figure(_spec, Path("figures"), quick=True)[1]])
