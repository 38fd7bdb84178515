# %% [markdown]
# # Chapter 10 — design of rigid-body motion (Popović): S(t, u), ∂S/∂u, min-norm edits, shooting.
#
# This file is a module (imported by `pbanim figures`) and a notebook in jupytext's percent format:
# open it in Jupyter (with jupytext) or VS Code, or write an `.ipynb` with `pbanim notebook ch10 DIR`.
# Running it draws every figure of the chapter in quick mode into `figures/`.

# %%
"""Chapter 10 — design of rigid-body motion (Popović): S(t, u), ∂S/∂u, min-norm edits, shooting.

Figures:

* ``s_across_impact``: the height z(T) of a thrown ball as a function of its launch speed, across the
  speed where it gains a bounce before T: S(t, u) jumps (the deck's "not continuous"), and its analytic
  derivative is smooth on each side.
* ``derivative_vs_fd_step``: error of centred finite differences (plain and Richardson) against the
  analytic ∂S/∂u of a tumbling box through two impacts, vs the step δ (ORACLES H2).
* ``edit_sequence``: dragging a bouncing ball's position at t = 2 s to a target: the trajectory morphs
  frame by frame (one min-norm update per frame), then the residual of the Gauss–Newton edit (ORACLES H5).
* ``die_toss``: a die thrown off a wall so that after its corner impacts it shows a chosen face up at a
  chosen place: orientation and position goals at once.
* ``ball_into_target``: a ball bounced off a wall into a target (GIF of the edit).
* ``shooting``: single vs multiple shooting on a noisy sketch of six impacts in 4 s, from the same start:
  single shooting ends at another impact sequence, multiple shooting (nodes midway between the sketch's
  impacts) recovers the sketched motion; the trajectories, max |C| and E per SLSQP iterate (ORACLES H8).

The chapter goes on in :mod:`chapters.ch10_design_contact` (designs through resting and sliding contact),
:mod:`chapters.ch10_design_search` (the search over impact sequences, the sketching interface) and
:mod:`chapters.ch10_design_articulated` (a chain thrown through flight).
"""

from __future__ import annotations

import numpy as np

from pbanim.collision import Box, Plane, Sphere
from pbanim.design import DesignBody, DesignScene, simulate
from pbanim.design.check import analytic_jacobian, fd_differences
from pbanim.design.control import drag, edit, orientation_goal, position_goal
from pbanim.design.multiple import (multiple_shooting, nodes_from_sketch, refine_states,
                                    states_from_sketch)
from pbanim.design.shooting import single_shooting
from pbanim.plotting import figure
from pbanim.rigid import quat_from_axis_angle, quat_to_matrix


def _ball(v, x0=(0.0, 0.0, 1.0), eps=0.8, walls=True):
    planes = [Plane([0, 0, 1])] + ([Plane([-1, 0, 0], offset=-2.0)] if walls else [])
    return DesignScene([DesignBody(Sphere(0.1), position=x0, velocity=v)], planes, restitution=eps)


# %% [markdown]
# ## Figure `ch10_s_across_impact`
#
# S(t, u) jumps where a bounce appears.

# %%
@figure("ch10", "s_across_impact", "S(t, u) jumps where a bounce appears")
def s_across_impact(ctx):
    """Height at T = 1.2 s vs launch speed: discontinuous where the ball gains a bounce before T."""
    T = 1.2
    vz = np.linspace(0.0, 3.0, 21 if ctx.quick else 61)
    z, dz, nimp = [], [], []
    for v in vz:
        tr = simulate(_ball([0.5, 0.0, v], walls=False), T, ["v0"], h=0.02, warn=False)
        z.append(tr.position(0, T)[2]), dz.append(tr.d_position(0, T)[2, 2]), nimp.append(len(tr.impacts))
    z, dz, nimp = np.array(z), np.array(dz), np.array(nimp)
    fig, axs = ctx.subplots(1, 2, figsize=(10, 3.6))
    for k in np.unique(nimp):
        sel = nimp == k
        axs[0].plot(vz[sel], z[sel], "o-", ms=3, label=f"{k} impact(s) before T")
        axs[1].plot(vz[sel], dz[sel], "o-", ms=3)
    axs[0].set_xlabel("launch speed v₀z (m/s)"), axs[0].set_ylabel("z(T) (m)"), axs[0].legend()
    axs[1].set_xlabel("launch speed v₀z (m/s)"), axs[1].set_ylabel("∂z(T)/∂v₀z (s)")
    ctx.save(fig)
    return {"vz": vz, "z": z, "dz": dz, "impacts": nimp, "T": T}


# %% [markdown]
# ## Figure `ch10_derivative_vs_fd_step`
#
# Analytic ∂S/∂u vs finite differences.

# %%
@figure("ch10", "derivative_vs_fd_step", "Analytic ∂S/∂u vs finite differences", cost=7.0)
def derivative_vs_fd_step(ctx):
    """Max error of centred FD (plain, Richardson) vs the analytic derivative, against the step δ."""
    b = DesignBody(Box([0.2, 0.15, 0.1]), mass=1.3, position=[0, 0, 1.0],
                   orientation=quat_from_axis_angle([1, 2, 3], 0.7), velocity=[1.0, 0.3, 2.0],
                   angular_velocity=[3.0, -2.0, 4.0])
    s = DesignScene([b], [Plane([0, 0, 1])], restitution=0.6)
    names, T = ["v0", "omega0"], 0.68
    outs = [(0, T, "position"), (0, T, "orientation")]
    tr = simulate(s, T, names)
    A = analytic_jacobian(tr, outs)
    deltas = np.logspace(-7, -2, 4 if ctx.quick else 9)
    # D(δ) and D(δ/2) once each (the plain point and Richardson's, as fd_jacobian forms it), every δ around one
    # nominal run S(t, u) (fd_differences: the same differences as fd_jacobian's, the base simulated once)
    Ds = fd_differences(s, names, None, T, outs, [e for d in deltas for e in (d, d / 2)])
    plain, rich = [], []
    for D1, D2 in zip(Ds[0::2], Ds[1::2]):
        plain.append(np.abs(D1 - A).max())
        rich.append(np.abs((4.0 * D2 - D1) / 3.0 - A).max())
    fig, ax = ctx.subplots()
    ax.loglog(deltas, plain, "o-", label="centred difference")
    ax.loglog(deltas, rich, "s-", label="Richardson (4D(δ/2) − D(δ))/3")
    ax.set_xlabel("step δ (1)"), ax.set_ylabel("max |FD − analytic| (m, rad per unit u)"), ax.legend()
    ctx.save(fig)
    return {"deltas": deltas, "plain": np.array(plain), "richardson": np.array(rich), "impacts": len(tr.impacts),
            "scale": float(np.abs(A).max())}


# %% [markdown]
# ## Figure `ch10_edit_sequence`
#
# Dragging a bouncing ball: the trajectory morphs.

# %%
@figure("ch10", "edit_sequence", "Dragging a bouncing ball: the trajectory morphs")
def edit_sequence(ctx):
    """One min-norm update per frame while the target moves; then Gauss–Newton edits to 1e-6."""
    s, T, target = _ball([1.0, 0.3, 2.0]), 2.0, np.array([0.5, 1.2, 0.6])
    frames = drag(s, ["x0", "v0"], None, 0, T, target, T, frames=4 if ctx.quick else 8, h=0.02)
    res = edit(s, ["x0", "v0"], None, [position_goal(0, T, target)], T, h=0.02)
    fig, axs = ctx.subplots(1, 2, figsize=(10, 3.8))
    for k, (u, x) in enumerate(frames):
        tr = simulate(s, T, ["x0", "v0"], u, h=0.02, sensitivities=False, warn=False)
        P = tr.positions(0)
        axs[0].plot(P[:, 0], P[:, 2], color=(k / len(frames), 0.3, 1 - k / len(frames)), lw=1)
        axs[0].plot(*x[[0, 2]], "k.", ms=4)
    axs[0].plot(target[0], target[2], "r*", ms=10, label="target at t = 2 s")
    axs[0].set_xlabel("x (m)"), axs[0].set_ylabel("z (m)"), axs[0].legend()
    axs[1].semilogy([r for _, r in res.history], "o-")
    axs[1].axhline(1e-6, color="gray", ls="--")
    axs[1].set_xlabel("update (1)"), axs[1].set_ylabel("max |residual| (m)")
    ctx.save(fig)
    reached = np.array([x for _, x in frames])
    return {"reached": reached, "target": target, "edit_residuals": np.array([r for _, r in res.history]),
            "edit_success": res.success, "edit_iterations": res.iterations}


# %% [markdown]
# ## Figure `ch10_die_toss`
#
# A die thrown off a wall to show a chosen face at a chosen place.

# %%
@figure("ch10", "die_toss", "A die thrown off a wall to show a chosen face at a chosen place")
def die_toss(ctx):
    """After its corners hit the wall the die is at (0.5, 0, 1.6) at T = 0.5 s with its −x face up."""
    b = DesignBody(Box([0.1, 0.1, 0.1]), mass=0.2, position=[0, 0, 2.0],
                   orientation=quat_from_axis_angle([1, 1, 0], 0.4), velocity=[3.0, 0.0, 1.0],
                   angular_velocity=[2.0, 5.0, 1.0])
    s = DesignScene([b], [Plane([-1, 0, 0], offset=-1.0)], restitution=0.7)
    T, names = 0.5, ["x0", "theta0", "v0", "omega0"]
    q_goal = quat_from_axis_angle([0, 1, 0], np.pi / 2)          # body −x turned to world +z
    goals = [position_goal(0, T, [0.5, 0.0, 1.6]), orientation_goal(0, T, q_goal)]
    res = edit(s, names, None, goals, T, max_iter=15)
    tr0 = simulate(s, T, names, sensitivities=False, warn=False)
    tr1 = simulate(s, T, names, res.u, times=[T], sensitivities=False, warn=False)
    up = quat_to_matrix(tr1.orientation(0, T)) @ [-1.0, 0, 0]
    fig, ax = ctx.subplots()
    ax.plot(tr0.positions(0)[:, 0], tr0.positions(0)[:, 2], "--", label="before the edit")
    ax.plot(tr1.positions(0)[:, 0], tr1.positions(0)[:, 2], label=f"after {res.iterations} updates")
    ax.plot(0.5, 1.6, "r*", ms=10, label="goal at T")
    ax.axvline(1.0, color="k", label="wall")
    ax.set_xlabel("x (m)"), ax.set_ylabel("z (m)"), ax.legend()
    ctx.save(fig)
    return {"success": res.success, "residual": res.residual, "face_up": up, "impacts": len(tr1.impacts),
            "position": tr1.position(0, T), "residuals": np.array([r for _, r in res.history])}


# %% [markdown]
# ## Figure `ch10_ball_into_target`
#
# A ball bounced off a wall into a target.

# %%
@figure("ch10", "ball_into_target", "A ball bounced off a wall into a target")
def ball_into_target(ctx):
    """The launch velocity is edited so that after the floor and the wall the ball is at the target."""
    s, T, target = _ball([2.0, 0.0, 2.5], x0=(-1.0, 0.0, 1.0)), 2.0, np.array([0.6, 0.0, 1.2])
    res = edit(s, ["v0"], None, [position_goal(0, T, target)], T, h=0.02)
    trs = [simulate(s, T, ["v0"], u, h=0.02, sensitivities=False, warn=False) for u, _ in res.history]
    fig, ax = ctx.subplots()
    ax.set_xlim(-1.2, 2.2), ax.set_ylim(0, 3.0), ax.set_aspect("equal")
    ax.axvline(2.0, color="k"), ax.axhline(0.0, color="k")
    ax.plot(*target[[0, 2]], "r*", ms=14)
    ax.set_xlabel("x (m)"), ax.set_ylabel("z (m)")
    line, = ax.plot([], [], lw=1.5)
    dot, = ax.plot([], [], "o", ms=8)

    def update(i):
        tr = trs[min(i // 6, len(trs) - 1)]
        P = tr.positions(0)
        k = min(int((i % 6 + 1) / 6 * len(P)), len(P) - 1)
        line.set_data(P[:, 0], P[:, 2]), dot.set_data([P[k, 0]], [P[k, 2]])
        return line, dot

    ctx.save_gif(fig, update, frames=6 * len(trs), fps=8)
    return {"success": res.success, "residual": res.residual, "impacts": [len(t.impacts) for t in trs],
            "final": trs[-1].positions(0)[-1]}


def shooting_problem(seed: int = 1, T: float = 4.0, sigma: float = 0.03, dt: float = 0.1):
    """The sketching problem of the ``shooting`` figure: a ball bouncing five times on a floor and once off a
    wall in T = 4 s; the sketch is its positions every ``dt`` with Gaussian noise ``sigma`` (seeded), the
    goal its true end position; the guess reads the initial state off the sketch (gravity-aware fit)."""
    from pbanim.design.multiple import states_from_sketch

    true = _ball([1.0, 0.0, 3.0], x0=(-1.5, 0.0, 1.0), eps=0.85)
    ts = np.round(np.arange(dt, T + 1e-9, dt), 10)
    ref = simulate(true, T, times=list(ts), sensitivities=False)
    rng = np.random.default_rng(seed)
    sketch = [(t, ref.position(0, t) + sigma * rng.normal(size=3)) for t in ts]
    x0, v0 = states_from_sketch(true, sketch, [0.0], 0.15)[0]
    guess = _ball(v0, x0=np.maximum(x0, [-np.inf, -np.inf, 0.2]), eps=0.85)
    return true, ref, sketch, [position_goal(0, T, ref.position(0, T))], guess


# %% [markdown]
# ## Figure `ch10_shooting`
#
# Single vs multiple shooting on a many-bounce sketch.

# %%
@figure("ch10", "shooting", "Single vs multiple shooting on a many-bounce sketch")
def shooting(ctx):
    """A noisy sketch of six impacts in 4 s, one start s₀ (the state the sketch shows at t = 0): single
    shooting ends at a motion with another impact sequence; multiple shooting, whose other nodes sit midway
    between the sketch's impacts with states fitted to it, recovers the sketched motion (ORACLES H8)."""
    T, sigma = 4.0, 0.03
    true, ref, sketch, goals, guess = shooting_problem(T=T, sigma=sigma)
    s0 = (guess.nominal["x0"], guess.nominal["v0"])            # the same start s₀ for both
    r1 = single_shooting(guess, np.concatenate(s0), goals, T, sketch=sketch, maxiter=60)
    nodes = nodes_from_sketch(guess, sketch, T)
    states = refine_states(guess, sketch, nodes, states_from_sketch(guess, sketch, nodes, 0.15), T)
    r2 = multiple_shooting(guess, goals, T, sketch=sketch, maxiter=60, node_times=nodes, initial_states=[s0] + states[1:])
    runs = {k: simulate(guess, T, r.names, r.u, times=[T], sensitivities=False, warn=False) for k, r in
            (("single", r1), ("multiple", r2))}
    fig, axs = ctx.subplots(1, 3, figsize=(14, 3.8))
    P = np.array([x for _, x in sketch])
    axs[0].plot(P[:, 0], P[:, 2], "k.", ms=4, label="sketch (σ = 3 cm)")
    axs[0].plot(*runs["single"].positions(0)[:, [0, 2]].T, "--", color="C0",
                label=f"single: {len(runs['single'].impacts)} impacts, E = {r1.objective:.2g} m²")
    axs[0].plot(*runs["multiple"].positions(0)[:, [0, 2]].T, color="C1",
                label=f"multiple: {len(runs['multiple'].impacts)} impacts, E = {r2.objective:.2g} m²")
    axs[0].axvline(2.0, color="gray"), axs[0].axhline(0.0, color="gray")
    axs[0].set_xlabel("x (m)"), axs[0].set_ylabel("z (m)"), axs[0].legend(fontsize=7, loc="upper right")
    for r, mk, lab in ((r1, "o-", "single shooting"), (r2, "s-", f"multiple shooting ({len(r2.node_times)} nodes)")):
        axs[1].semilogy(np.maximum(r.history, 1e-16), mk, ms=3, label=lab)
        axs[2].semilogy(r.objectives, mk, ms=3, label=lab)
    axs[1].set_xlabel("SLSQP iterate (1)"), axs[1].set_ylabel("max |C| (m, m/s)"), axs[1].legend(fontsize=7)
    axs[2].set_xlabel("SLSQP iterate (1)"), axs[2].set_ylabel("sketch distance E (m²)")
    ctx.save(fig)
    tr2 = runs["multiple"]
    return {"single_violation": r1.violation, "multiple_violation": r2.violation, "single_success": r1.success,
            "multiple_success": r2.success, "single_converged": r1.converged, "single_sims": r1.simulations,
            "multiple_sims": r2.simulations, "single_objective": r1.objective, "multiple_objective": r2.objective,
            "single_impacts": len(runs["single"].impacts), "multiple_impacts": len(tr2.impacts),
            "true_impacts": len(ref.impacts), "noise_E": 0.5 * len(sketch) * 3 * sigma ** 2,
            "multiple_goal_error": float(np.abs(tr2.position(0, T) - goals[0].target).max()),
            "single_v0_error": float(np.abs(r1.u[3:6] - true.nominal["v0"]).max()),
            "multiple_v0_error": float(np.abs(r2.u[3:6] - true.nominal["v0"]).max()),
            "node_times": r2.node_times, "single_history": np.array(r1.history), "multiple_history": np.array(r2.history)}


def __getattr__(name: str):
    """The figures and scenes of issue 30 moved to their own modules; their old import path still works."""
    import importlib

    for module in ("chapters.ch10_design_contact", "chapters.ch10_design_search"):
        mod = importlib.import_module(module)
        if hasattr(mod, name):
            return getattr(mod, name)
    raise AttributeError(f"module 'chapters.ch10_design' has no attribute {name!r}")


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

