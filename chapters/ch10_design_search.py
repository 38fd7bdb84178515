# %% [markdown]
# # Chapter 10 — searching impact sequences, and the sketching interface
#
# This file is a module (imported by `pbanim figures`) and a notebook in jupytext's percent format.
# Running it draws every figure of this part of the chapter in quick mode into `figures/`.

# %%
"""Chapter 10 — the discrete search over impact sequences and the sketching interface (issue 30).

Figures ``sequence_search`` (ORACLES L4) and ``two_ball_search`` (ORACLES L8); :func:`sketch_editor` opens the editor (ORACLES L5). The chapter's
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


@figure("ch10", "sequence_search", "Searching impact sequences where multiple shooting stays at a wrong one",
        cost=10.0)
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
# ## Figure `ch10_two_ball_search` (issue 30, point 3, several bodies)
#
# Ball 0 thrown at ball 1, both in flight: two collisions, then bounces on the floor and a wall, twelve events
# in 1.25 s, some 37 ms apart on a sketch every 50 ms. The sketch's first proposal misses a floor bounce; the
# search over event sequences (which body, which surface — a plane or the other ball — in which order;
# pbanim.design.body_sequences) finds the true sequence.

# %%
def two_ball_problem(dt: float = 0.05, sigma: float = 0.005, T: float = 1.25, seed: int = 1):
    """Two 5 cm balls (unit mass, ε = 0.9, floor z ≥ 0, wall x ≤ 0.4): ball 0 from (−0.4, 0, 0.35) at
    (3, 0, 1) m/s, ball 1 from (0.1, 0, 0.3) at (0, 0, 1.2) m/s. The sketches are their positions every
    ``dt`` with noise ``sigma`` (seeded), the goals their true end positions, the guess slower throws."""
    def balls(v0, v1):
        return DesignScene([DesignBody(Sphere(0.05), position=[-0.4, 0.0, 0.35], velocity=v0),
                            DesignBody(Sphere(0.05), position=[0.1, 0.0, 0.3], velocity=v1)],
                           [Plane([0, 0, 1]), Plane([-1, 0, 0], offset=-0.4)], restitution=0.9)
    true = balls([3.0, 0.0, 1.0], [0.0, 0.0, 1.2])
    names = ["x0", "v0", "x1", "v1"]
    ts = list(np.round(np.arange(0.0, T + 1e-9, dt), 10))
    ref = simulate(true, T, names, times=ts, sensitivities=False, flight="exact")
    rng = np.random.default_rng(seed)
    sketches = [[(t, ref.position(b, t) + sigma * rng.normal(size=3)) for t in ts] for b in range(2)]
    goals = [position_goal(b, T, ref.position(b, T)) for b in range(2)]
    return true, ref, sketches, goals, balls([2.5, 0.0, 0.5], [0.0, 0.0, 0.8])


def _event_label(e):
    return f"{e[0]}{'FW'[e[2]]}" if e[1] == "plane" else "P"


@figure("ch10", "two_ball_search", "Searching event sequences of two balls: which body, which surface, in which order",
        cost=4.0)
def two_ball_search(ctx):
    """x–z paths of the two balls: the sketches, the motion of the search's best sequence with its events;
    what the search tried (the sketch's first proposal misses a floor bounce 37 ms before the second
    collision). ORACLES L8."""
    from pbanim.design.body_sequences import propose_body_sequences, search_body_sequences

    T, sigma = 1.25, 0.005
    true, ref, sketches, goals, guess = two_ball_problem(sigma=sigma, T=T)
    events = tuple((i.body, "plane", i.other) if i.kind == "plane" else (0, "body", 1) for i in ref.impacts)
    first = propose_body_sequences(guess, sketches)[0]
    res = search_body_sequences(guess, goals, T, sketches, max_proposals=4, maxiter=40)
    tt = np.linspace(0.0, T, 501)
    run = simulate(guess, T, ["x0", "v0", "x1", "v1"], res.u, times=sorted(set(tt[1:]) | set(res.times)),
                   sensitivities=False, flight="exact")
    fig, axs = ctx.subplots(1, 2, figsize=(12, 3.8), gridspec_kw={"width_ratios": [2, 1]})
    ax = axs[0]
    for b, c in ((0, "C0"), (1, "C3")):
        P = np.array([x for _, x in sketches[b]])
        ax.plot(P[:, 0], P[:, 2], ".", color=c, ms=4, label=f"sketch of ball {b} (every 50 ms)")
        X = np.array([run.position(b, t) for t in tt[1:]])
        ax.plot(X[:, 0], X[:, 2], "-", color=c, lw=1.0, label=f"ball {b}, the search's motion")
    for i in run.impacts:                      # the events: × on a surface, * at the contact point of the pair
        x = run.position(i.body, i.t) if i.kind == "plane" else 0.5 * (run.position(0, i.t) + run.position(1, i.t))
        ax.plot(x[0], x[2], "k*" if i.kind == "pair" else "kx", ms=6)
    ax.axhline(0.05, color="gray", lw=0.8), ax.axvline(0.35, color="gray", lw=0.8)
    ax.set_xlabel("x (m)"), ax.set_ylabel("z (m)  (centres; floor and wall one radius away)")
    ax.legend(fontsize=7, loc="upper left")
    ax = axs[1]
    ax.axis("off")
    lines = [f"true:   {' '.join(_event_label(e) for e in events)}",
             f"sketch: {' '.join(_event_label(e) for e in first.events)}  (first proposal)", "",
             f"search (cap {res.cap}):"]
    for row in res.tried:
        lines.append(f"  {row['origin']:<9} {len(row['events'])} events, residual {row['residual']:.1e}, "
                     f"{'confirmed' if row['confirmed'] else 'replay differs'}")
    lines += ["", f"E = {res.objective:.2e} m², noise ½·2N·3σ² = {0.5 * 2 * len(sketches[0]) * 3 * sigma ** 2:.2e} m²",
              "0F, 1W: ball 0 on the floor, ball 1 on the wall; P: the balls collide"]
    ax.text(0.0, 1.0, "\n".join(lines), va="top", family="monospace", fontsize=7, transform=ax.transAxes)
    ctx.save(fig)
    return {"events": events, "first_proposal": first.events, "sequence": res.sequence, "success": res.success,
            "u": res.u, "u_true": np.concatenate([true.nominal[k] for k in ("x0", "v0", "x1", "v1")]),
            "objective": res.objective, "proposals": res.proposals, "cap": res.cap,
            "tried": [(row["origin"], row["events"], row["confirmed"]) for row in res.tried]}


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
