# %% [markdown]
# # Chapter 06 — collisions: detection, impulses with restitution ε and friction, time of impact.
#
# This file is a module (imported by `pbanim figures`) and a notebook in jupytext's percent format:
# open it in Jupyter (with jupytext) or VS Code, or write an `.ipynb` with `pbanim notebook ch06 DIR`.
# Running it draws every figure of the chapter in quick mode into `figures/`.

# %%
"""Chapter 06 — collisions: detection, impulses with restitution ε and friction, time of impact.

Figures: bouncing-ball apex heights vs ε^(2k) h₀; Newton's cradle, sequential vs simultaneous impulses; a
billiards break with its momentum and energy; time-of-impact accuracy vs cost (event location vs fixed
steps); boxes tumbling onto the ground (GIF).
"""

from __future__ import annotations

import time

import numpy as np

from pbanim.collision import (Box, Collisions, ImpulseBodies, Plane, resolve_collisions, simulate_collisions,
                              sphere_sphere)
from pbanim.models.collision import bouncing_ball, newtons_cradle
from pbanim.plotting import figure
from pbanim.plotting_gif import frozen_backdrop


# %% [markdown]
# ## Figure `ch06_bouncing_heights`
#
# Bouncing ball: apex heights vs ε^(2k) h₀ (event location vs fixed steps).

# %%
@figure("ch06", "bouncing_heights", "Bouncing ball: apex heights vs ε^(2k) h₀ (event location vs fixed steps)")
def bouncing_heights(ctx):
    bb = bouncing_ball(h0=1.0, restitution=0.8)
    K = 6 if ctx.quick else 12
    T = 1.01 * float(bb.impact_times(K + 1))
    h = 0.01
    ev = simulate_collisions(bb.scene(), T, h, toi="event")
    fx = simulate_collisions(bb.scene(), T, h, toi="fixed")
    k = np.arange(1, K + 1)
    post = ev.y_events[0][:K]
    apex_event = post[:, 1] + post[:, 3] ** 2 / (2 * bb.g)
    apex_fixed = bb.measured_apex_heights(fx)[:K]
    fig, ax = ctx.subplots()
    ax.semilogy(k, bb.apex_heights(k), "k-", label="exact ε^(2k) h₀")
    ax.semilogy(k, apex_event, "o", label="event location (RK4)")
    ax.semilogy(np.arange(1, len(apex_fixed) + 1), apex_fixed, "x", label=f"fixed-step detection, h = {h} s")
    ax.set_xlabel("bounce k (index)")
    ax.set_ylabel("apex height h_k (m)")
    ax.legend()
    ctx.save(fig)
    return {"k": k, "apex_event": apex_event, "apex_fixed": apex_fixed, "h0": bb.h0, "restitution": bb.restitution}


# %% [markdown]
# ## Figure `ch06_newtons_cradle`
#
# Newton's cradle: sequential vs simultaneous impulses (3 balls, ε = 1).

# %%
@figure("ch06", "newtons_cradle", "Newton's cradle: sequential vs simultaneous impulses (3 balls, ε = 1)")
def newtons_cradle_fig(ctx):
    model = newtons_cradle(3, v0=1.0)
    x, v = model.positions(), model.velocities()
    i = np.arange(1, 3)
    c = sphere_sphere(x[i], model.radius, x[i - 1], model.radius, i, i - 1)
    out = {}
    for mode in ("sequential", "simultaneous"):
        res = resolve_collisions(ImpulseBodies.make(x, v, 1 / model.mass), c, restitution=1.0, mode=mode)
        out[mode] = res.v[:, 0]
        out[f"energy_{mode}"] = 0.5 * model.mass * float((res.v**2).sum())
        out[f"momentum_{mode}"] = model.mass * float(res.v[:, 0].sum())
    fig, ax = ctx.subplots()
    w = 0.25
    ax.bar(np.arange(3) - w, v[:, 0], w, label="before")
    ax.bar(np.arange(3), out["sequential"], w, label="sequential (propagating): (0, 0, v₀)")
    ax.bar(np.arange(3) + w, out["simultaneous"], w, label="simultaneous (LCP): (−1, 2, 2) v₀/3")
    ax.axhline(0, color="k", lw=0.8)
    ax.set_xticks(range(3), ["ball 1", "ball 2", "ball 3"])
    ax.set_xlabel("ball (index)")
    ax.set_ylabel("x-velocity (m/s)")
    ax.set_ylim(-0.5, 1.6)
    ax.legend(loc="upper center", ncol=1)
    ctx.save(fig)
    out.update(v0=model.v0, energy_before=0.5 * model.mass * model.v0**2)
    return out


def _rack(radius: float):
    """A cue ball and a triangle of 10 (quick) or 15 balls, touching, on a 2-D table."""
    pos = [[-1.0, 0.0]]
    rows = 4
    for r in range(rows):
        for j in range(r + 1):
            pos.append([0.5 + r * np.sqrt(3) * radius * 1.0001, (j - r / 2) * 2 * radius * 1.0001])
    return np.array(pos)


# %% [markdown]
# ## Figure `ch06_billiards_break`
#
# Billiards break: momentum and energy through the impacts (ε = 1, μ = 0).

# %%
@figure("ch06", "billiards_break", "Billiards break: momentum and energy through the impacts (ε = 1, μ = 0)", cost=2.4)
def billiards_break(ctx):
    from pbanim.particles import ParticleSystem
    from pbanim.scene import Scene

    R = 0.0285
    x = _rack(R)
    v = np.zeros_like(x)
    v[0] = (6.0, 0.02)
    ps = ParticleSystem(x, v, masses=0.17)
    walls = [Plane([1, 0], -1.3), Plane([-1, 0], -1.3), Plane([0, 1], -0.65), Plane([0, -1], -0.65)]
    col = Collisions(obstacles=walls, radius=R, restitution=1.0, gravity=0.0)
    T, h = (0.8, 2e-3) if ctx.quick else (2.5, 1e-3)
    res = simulate_collisions(Scene(ps, [col]), T, h, method="rk4", toi="event")
    X = res.y[: ps.split].reshape(ps.N, 2, -1)
    V = res.y[ps.split:].reshape(ps.N, 2, -1)
    # a ball can reach a cushion within the next step when its gap is below its speed times h
    gap = np.minimum(1.3 - np.abs(X[:, 0]), 0.65 - np.abs(X[:, 1])) - R
    near = np.flatnonzero(np.any(gap <= np.linalg.norm(V, axis=1) * h + 1e-9, axis=0))
    first_wall = float(res.t[max(near[0] - 1, 0)]) if near.size else float(res.t[-1]) + 1.0
    p = res.diagnostics["momentum"]
    E = res.diagnostics["energy"]
    fig, (ax1, ax2) = ctx.subplots(1, 2, figsize=(9, 3.6))
    ax1.plot(X[0, 0], X[0, 1], "k-", lw=0.8)
    for i in range(1, ps.N):
        ax1.plot(X[i, 0], X[i, 1], "-", lw=0.8)
    ax1.plot(X[:, 0, -1], X[:, 1, -1], "o", ms=3)
    ax1.plot([-1.3, 1.3, 1.3, -1.3, -1.3], [-0.65, -0.65, 0.65, 0.65, -0.65], "k-", lw=1.5)
    ax1.set_aspect("equal")
    ax1.set_xlabel("x (m)")
    ax1.set_ylabel("y (m)")
    ax1.set_title("trajectories")
    ax2.plot(res.t, p[:, 0] / p[0, 0], label="p_x / p_x(0)")
    ax2.plot(res.t, E / E[0], "--", label="E / E(0)")
    ax2.axvline(first_wall, color="grey", lw=0.8, label="first cushion")
    ax2.set_xlabel("t (s)")
    ax2.set_ylabel("relative value (1)")
    ax2.legend()
    ctx.save(fig)
    return {"t": res.t, "momentum": p, "energy": E, "first_wall_time": first_wall,
            "impacts": int(len(res.t_events[0]) + len(col.log))}


# %% [markdown]
# ## Figure `ch06_toi_accuracy`
#
# Time of impact: error in the 3rd apex height vs wall time.

# %%
@figure("ch06", "toi_accuracy", "Time of impact: error in the 3rd apex height vs wall time")
def toi_accuracy(ctx):
    bb = bouncing_ball(h0=1.0, restitution=0.8)
    hs = [0.02, 0.0125, 0.005] if ctx.quick else [0.02, 0.0125, 0.008, 0.005, 0.003, 0.002]
    T = 1.02 * float(bb.impact_times(4))
    out = {"h": hs}
    for toi in ("event", "fixed"):
        errs, walls = [], []
        for h in hs:
            start = time.perf_counter()
            res = simulate_collisions(bb.scene(), T, h, toi=toi)
            walls.append(time.perf_counter() - start)
            errs.append(abs(bb.measured_apex_heights(res)[2] - float(bb.apex_heights(3))))
        out[f"{toi}_error"], out[f"{toi}_wall"] = errs, walls
    fig, ax = ctx.subplots()
    floor = 1e-17
    ax.loglog(out["event_wall"], np.maximum(out["event_error"], floor), "o-", label="event location (root finder)")
    ax.loglog(out["fixed_wall"], out["fixed_error"], "s-", label="fixed-step detection")
    for h, w, e in zip(hs, out["fixed_wall"], out["fixed_error"]):
        ax.annotate(f"h={h:g}", (w, e), fontsize=7)
    ax.set_xlabel("wall time (s)")
    ax.set_ylabel("|h₃ − ε⁶ h₀| (m)  (floored at 1e-17)")
    ax.legend()
    ctx.save(fig)
    return out


# %% [markdown]
# ## Figure `ch06_boxes_tumbling`
#
# Boxes tumbling onto the ground (ε = 0.3, μ = 0.5).

# %%
@figure("ch06", "boxes_tumbling", "Boxes tumbling onto the ground (ε = 0.3, μ = 0.5)", cost=4.8)
def boxes_tumbling(ctx):
    from pbanim.rigid import RigidBodies, RigidGravity, RigidScene
    from pbanim.rigid.quat import quat_from_axis_angle
    from scipy.spatial import ConvexHull

    rng = ctx.rng
    n = 3
    shapes = [Box(rng.uniform(0.15, 0.3, 3)) for _ in range(n)]
    q = np.array([quat_from_axis_angle(rng.normal(size=3), rng.uniform(0, np.pi)) for _ in range(n)])
    x = np.array([[-0.9 + 0.9 * i, 0.0, 0.8 + 0.6 * i] for i in range(n)])
    masses = np.array([8 * np.prod(s.half_extents) * 500 for s in shapes])
    rb = RigidBodies(masses, np.array([s.inertia(m) for s, m in zip(shapes, masses)]), positions=x,
                     orientations=q, velocities=[[0.5, 0, 0], [0, 0, 0], [-0.5, 0, 0]],
                     angular_velocities=rng.normal(size=(n, 3)))
    col = Collisions(shapes, obstacles=[Plane()], restitution=0.3, friction=0.5, mode="simultaneous")
    # the boxes are at rest (momenta below 1e-15) from t = 1.2 s on: 1.5 s shows the tumbling and the rest, the
    # GIF's frames 42 ms apart as before (the run was 2.5 s, 60 frames: 1 s more of the same rest)
    T, h = (0.8, 0.004) if ctx.quick else (1.5, 0.002)
    res = RigidScene(rb, [RigidGravity(), col]).simulate(T, h)
    Y = res.y
    verts = []
    for k in range(Y.shape[1]):
        R = rb.rotations(Y[:, k])
        xs = rb.unpack(Y[:, k])[0]
        verts.append(np.array([xs[i] + shapes[i].vertices() @ R[i].T for i in range(n)]))
    verts = np.array(verts)                                     # (frames, n, 8, 3)
    speed = np.linalg.norm(Y[7 * n: 10 * n].reshape(n, 3, -1), axis=1) / masses[:, None]
    fig, ax = ctx.subplots(figsize=(4.5, 3.2))
    fig.subplots_adjust(left=0.16, bottom=0.2, right=0.97, top=0.9)
    frames = np.linspace(0, Y.shape[1] - 1, 8 if ctx.quick else 36).astype(int)

    # the axes and the n outlines are made once; a frame moves the outlines (the same pixels as clearing the
    # axes and filling anew, in a fraction of the time)
    ground = ax.axhline(0, color="k")
    outlines = [ax.fill([0.0, 1.0, 0.0], [0.0, 0.0, 1.0], alpha=0.6)[0] for _ in range(n)]
    ax.set_xlim(-1.6, 1.6)
    ax.set_ylim(-0.1, 2.2)
    ax.set_aspect("equal")
    ax.set_xlabel("x (m)")
    ax.set_ylabel("z (m)")
    # the grid under the boxes (it was drawn over them): the axes, ticks and labels are then drawn before every
    # box and rendered once (frozen_backdrop), a frame draws the boxes, the ground, the spines and the title
    ax.set_axisbelow(True)
    show_backdrop = frozen_backdrop(fig, [fig.patch, ax.patch, ax.xaxis, ax.yaxis],
                                    outlines + [ground, ax.title, *ax.spines.values()])

    def update(f):
        show_backdrop()
        for i in range(n):
            P = verts[frames[f], i][:, [0, 2]]
            outlines[i].set_xy(P[ConvexHull(P).vertices])
        ax.set_title(f"t = {res.t[frames[f]]:.2f} s", y=1.0)

    ctx.save_gif(fig, update, frames=len(frames), fps=8)
    return {"min_height": float(verts[..., 2].min()), "final_speed": float(speed[:, -1].max()),
            "max_speed": float(speed.max()), "t": res.t}


# %% [markdown]
# ## Draw the figures
#
# As a script or in a notebook kernel, draw this chapter's figures (quick mode) into `figures/`.

# %%
if __name__ == "__main__":
    from pathlib import Path

    from pbanim.plotting import figures_of, run_figure

    for _key, _spec in figures_of({"ch06"}).items():
        print(_key, [p.name for p in run_figure(_spec, Path("figures"), quick=True)[1]])
