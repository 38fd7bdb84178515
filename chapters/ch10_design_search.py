# %% [markdown]
# # Chapter 10 — searching impact sequences, and the sketching interface
#
# This file is a module (imported by `pbanim figures`) and a notebook in jupytext's percent format.
# Running it draws every figure of this part of the chapter in quick mode into `figures/`.

# %%
"""Chapter 10 — the discrete search over impact sequences and the sketching interface (issue 30).

Figure ``sequence_search`` (ORACLES L4); :func:`sketch_editor` opens the editor (ORACLES L5). The chapter's
other figures are in :mod:`chapters.ch10_design`."""

from __future__ import annotations

import numpy as np

from pbanim.collision import Plane, Sphere
from pbanim.design import DesignBody, DesignScene, simulate
from pbanim.design.control import position_goal
from pbanim.design.multiple import multiple_shooting
from pbanim.plotting import figure

from chapters.ch10_design import _ball


# %% [markdown]
# ## Figure `ch10_sequence_search` (issue 30, point 3)
#
# A ball rattling down between two walls: eleven impacts in 1.2 s, 1.7 to 2.7 sketch samples apart. Multiple
# shooting from the impacts the sketch shows stays at a wrong sequence; the discrete search over impact
# sequences (pbanim.design.sequences) reaches the sketch.

# %%
def rattle_problem(dt: float = 0.05, sigma: float = 0.005, T: float = 1.2, seed: int = 1):
    """The shaft (walls at x = ±0.25, a 5 cm ball, ε = 0.95) thrown at 5 m/s across it; the sketch is its
    positions every ``dt`` with Gaussian noise ``sigma`` (seeded), the goal its true end position, the guess
    a slower throw."""
    def shaft(v0):
        return DesignScene([DesignBody(Sphere(0.05), position=[0.0, 0.0, 2.0], velocity=v0)],
                           [Plane([1, 0, 0], offset=-0.25), Plane([-1, 0, 0], offset=-0.25)], restitution=0.95)
    true = shaft([5.0, 0.0, 0.5])
    ts = list(np.round(np.arange(0.0, T + 1e-9, dt), 10))
    ref = simulate(true, T, ["x0", "v0"], times=ts[1:], sensitivities=False)
    rng = np.random.default_rng(seed)
    sketch = [(t, (true.nominal["x0"] if t == 0 else ref.position(0, t)) + sigma * rng.normal(size=3)) for t in ts]
    return true, ref, sketch, [position_goal(0, T, ref.position(0, T))], shaft([4.0, 0.0, 0.0])


@figure("ch10", "sequence_search", "Searching impact sequences where multiple shooting stays at a wrong one")
def sequence_search(ctx):
    """x(t) of the sketch, of multiple shooting from the sketch's impacts (nodes midway between them) and of
    the search's best sequence; what the search tried on this sketch and on one sampled every 80 ms (1.05 to
    1.7 samples per flight), whose own proposal hits a wall twice in a row and is repaired by a move.
    ORACLES L4."""
    from pbanim.design.sequences import propose_sequences, search_sequences

    T, sigma = 1.2, 0.005
    true, ref, sketch, goals, guess = rattle_problem(sigma=sigma, T=T)
    old = multiple_shooting(guess, goals, T, sketch=sketch[1:], maxiter=10 if ctx.quick else 40, max_slides=0)
    new = search_sequences(guess, goals, T, sketch, max_proposals=10)
    hits = tuple(i.other for i in ref.impacts)
    _, _, coarse, goals80, guess80 = rattle_problem(dt=0.08, sigma=sigma, T=T)     # 1.05–1.7 samples per flight
    gap = propose_sequences(guess80, coarse)[0]
    fix = search_sequences(guess80, goals80, T, coarse, max_proposals=6)
    tt = np.linspace(0.0, T, 481)
    runs = {k: simulate(guess, T, names, u, times=list(tt[1:]), sensitivities=False, warn=False, check_start=False)
            for k, names, u in (("old", old.names, old.u), ("new", ["x0", "v0"], new.u))}
    fig, axs = ctx.subplots(1, 2, figsize=(12, 3.8), gridspec_kw={"width_ratios": [2, 1]})
    ax = axs[0]
    P = np.array([x for _, x in sketch])
    ax.plot([t for t, _ in sketch], P[:, 0], "k.", ms=5, label=f"sketch (every 50 ms, σ = {1e3 * sigma:.0f} mm)")
    for k, style, lab in (("old", "--", f"multiple shooting (run from its u): {len(runs['old'].impacts)} impacts, max |C| = "
                                        f"{old.violation:.2f}"),
                          ("new", "-", f"sequence search: {len(runs['new'].impacts)} impacts, E = {new.objective:.1e} m²")):
        X = np.array([runs[k].position(0, t) for t in tt[1:]])
        ax.plot(tt[1:], X[:, 0], style, lw=1.2, label=lab)
    for w in (-0.2, 0.2):
        ax.axhline(w, color="gray", lw=0.8)
    ax.set_xlabel("t (s)"), ax.set_ylabel("x (m)  (centre; walls at ±0.2)"), ax.legend(fontsize=7, loc="lower left")
    ax = axs[1]
    ax.axis("off")
    lines = []
    for res, lab in ((new, "sketch every 50 ms"), (fix, "sketch every 80 ms")):
        lines.append(f"search, {lab} (cap {res.cap}):")
        if res is fix:
            lines.append(f"  {''.join('LR'[j] for j in gap.planes)}  sketch  not solved: a wall twice in a row")
        for row in res.tried:
            seq = "".join("LR"[j] for j in row["planes"])
            lines.append(f"  {seq}  {row['origin']:<7} residual {row['residual']:.1e}"
                         f"  {'confirmed' if row['confirmed'] else 'replay differs'}")
        lines.append("")
    lines.append(f"noise level ½·N·3σ²: {0.5 * len(sketch) * 3 * sigma ** 2:.1e} m² (50 ms), "
                 f"{0.5 * len(coarse) * 3 * sigma ** 2:.1e} m² (80 ms)")
    lines.append("L, R: left, right wall")
    ax.text(0.0, 1.0, "\n".join(lines), va="top", family="monospace", fontsize=7, transform=ax.transAxes)
    ctx.save(fig)
    return {"old_violation": old.violation, "old_success": old.success, "old_impacts": len(runs["old"].impacts),
            "new_success": new.success, "new_impacts": len(runs["new"].impacts), "true_impacts": len(hits),
            "new_sequence_true": new.sequence == hits, "new_objective": new.objective,
            "noise_E": 0.5 * len(sketch) * 3 * sigma ** 2, "proposals": new.proposals,
            "goal_error": float(np.abs(runs["new"].position(0, T) - goals[0].target).max()),
            "v0_error": float(np.abs(new.u[3:] - true.nominal["v0"]).max()),
            "repair_success": fix.success, "repair_sequence_true": fix.sequence == hits, "repair_proposals": fix.proposals,
            "repair_origins": [row["origin"] for row in fix.tried], "coarse_proposal_true": gap.key() == hits,
            "repair_objective": fix.objective, "coarse_noise_E": 0.5 * len(coarse) * 3 * sigma ** 2}


# %% [markdown]
# ## The sketching interface (issue 30, point 5)
#
# `sketch_editor()` opens the editor on a bouncing ball in a matplotlib window (`python -c "from
# chapters.ch10_design_search import sketch_editor; sketch_editor(show=True)"`) or in a notebook cell run with an
# interactive backend (`%matplotlib widget`): drag a point of the motion and it follows (one Gauss–Newton update
# per mouse event); with `mode="sketch"`, draw a stroke and multiple shooting fits a motion to it on release.
# `scene="box"` edits a tumbling box instead (its corner impacts on a floor and a wall). Each event re-runs
# S(t, u) and ∂x(t*)/∂u by the scene's lean twin and redraws by blitting: `pbanim bench design` times one
# event end to end (≥ 30 a second is the goal).

# %%
def sketch_editor(mode: str = "drag", show: bool = False, solver: str = "multiple", scene: str = "ball"):
    """The editor (pbanim.design.SketchEditor) on a ball with five bounces between a floor and a wall, or
    (``scene="box"``) on the benchmark's tumbling box (drawn every 5 ms, its rotation stepped every 20 ms)."""
    from pbanim.design import SketchEditor

    if scene == "box":
        from pbanim.bench.design import H_FLIGHT, box_scene

        ed = SketchEditor(box_scene(), 1.0, h=0.005, h_flight=H_FLIGHT, mode=mode, solver=solver)
    else:
        ed = SketchEditor(_ball([1.0, 0.3, 2.0]), 2.7, h=0.02, mode=mode, solver=solver)
    ed.ax.set_title("drag the motion" if mode == "drag" else "draw a sketch (press, move, release)")
    ed.ax.set_aspect("equal", adjustable="datalim")
    if show:
        import matplotlib.pyplot as plt
        plt.show()
    return ed


# %% [markdown]
# ## Draw the figures
#
# As a script or in a notebook kernel, draw this chapter's figures (quick mode) into `figures/`.

# %%
if __name__ == "__main__":
    from pathlib import Path

    from pbanim.plotting import figures_of, run_figure

    for _key, _spec in figures_of({"ch10"}).items():
        print(_key, [p.name for p in run_figure(_spec, Path("figures"), quick=True)[1]])
