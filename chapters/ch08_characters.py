# %% [markdown]
# # Chapter 08 (part 2) — characters: PD servos, a state machine and SIMBICON's planar biped.
#
# This file is a module (imported by `pbanim figures`) and a notebook in jupytext's percent format:
# open it in Jupyter (with jupytext) or VS Code, or write an `.ipynb` with `pbanim notebook ch08 DIR`.
# Running it draws every figure of the chapter in quick mode into `figures/`.

# %%
"""Chapter 08 (part 2) — characters: PD servos, a state machine and SIMBICON's planar biped.

Figures:

* ``pd_stability_map``: the largest stable step against the gain k_p for explicit, stable and implicit PD
  (measured from each servo's step map, with the closed forms of ORACLES F1 as lines), and what tracking
  costs: the error of a servo following a sine against the work (steps per second) for each servo.
* ``biped_walk``: SIMBICON's walk on flat ground — Table 1 of Yin, Loken & van de Panne 2007, every
  number the paper's — and a faster gait of ours (ORACLES F4): an animation and a strip of stick figures,
  the centre of mass's speed over time.
* ``walk_targets``: the joint angles against their targets with the machine's states shaded (the swing
  hip's target moves with the balance feedback).
* ``push_envelope``: pushes on the torso of several impulses at several phases of a step: recovered or
  fell (ORACLES F6; the tests check ±100 recovered and −150 N s not at h = 2, 4 and 8 ms).
"""

from __future__ import annotations

import time

import numpy as np

from pbanim.control import FAST_WALK, SERVOS, WALK, Push, largest_stable_step, servo_track, simulate_walk
from pbanim.control.walk import stick_figure
from pbanim.control.walk_branch import simulate_pushes
from pbanim.plotting import figure
from pbanim.plotting_gif import frozen_backdrop

STATE_COLOURS = {"R0": "#dbe9f6", "R1": "#9ecae1", "L0": "#fde0c5", "L1": "#fdae6b"}


# %% [markdown]
# ## Figure `ch08_pd_stability_map`
#
# The largest stable step against k_p for explicit, stable and implicit PD (measured from each servo's
# step map; lines: the closed forms of ORACLES F1), and the error of each servo against the exact
# servo's response as the step shrinks.

# %%
@figure("ch08", "pd_stability_map", "Explicit, stable and implicit PD: largest stable step and tracking cost")
def pd_stability_map(ctx):
    kps = np.logspace(0, 8, 9 if ctx.quick else 33)
    rows = {s: np.array([largest_stable_step(kp, 2 * np.sqrt(kp), servo=s, h_max=10.0) for kp in kps]) for s in SERVOS}
    # closed forms at critical damping (x = h √k_p): explicit x² + 4x = 4, stable x² − (4/3)x = 4/3
    closed = {"explicit": (-2 + np.sqrt(8)) / np.sqrt(kps), "stable": 2.0 / np.sqrt(kps)}
    # tracking a sine θ̄ = sin ωt (ω = 2π) with k_p = 1e4, critical damping, unit mass, for 1 s, started on
    # the exact servo's steady state x = |G| sin(ωt + arg G), G = k_p / (k_p − ω² + i k_v ω): the error is the
    # discretization error of each servo, not the lag every PD servo has
    kp, kv, w = 1e4, 200.0, 2 * np.pi
    G = kp / (kp - w * w + 1j * kv * w)
    exact = lambda tt: abs(G) * np.sin(w * tt + np.angle(G))  # noqa: E731
    hs = np.logspace(-4.5, -1.3, 6 if ctx.quick else 14)
    track = {}
    for s in SERVOS:
        errs, walls = [], []
        for h in hs:
            start = time.perf_counter()
            t, x = servo_track(s, lambda tt: np.sin(w * tt), kp, kv, h, 1.0, x0=exact(0.0),
                               v0=abs(G) * w * np.cos(np.angle(G)))
            walls.append(time.perf_counter() - start)
            errs.append(float(np.max(np.abs(x - exact(t)))))
        track[s] = (np.array(errs), np.array(walls))
    fig, (a, b) = ctx.subplots(1, 2, figsize=(11, 4))
    for s, c in zip(SERVOS, ("C0", "C1", "C2")):
        a.loglog(kps, np.minimum(rows[s], 10.0), "o", color=c, ms=4, label=f"{s} PD (measured)")
        if s in closed:
            a.loglog(kps, closed[s], "-", color=c, lw=1, label=f"{s} PD (closed form, F1)")
    a.set(xlabel="k_p [N m/rad] (unit inertia, k_v = 2√k_p)", ylabel="largest stable step h [s]")
    a.legend(fontsize=7, loc="lower left")
    for s, c in zip(SERVOS, ("C0", "C1", "C2")):
        e, _ = track[s]
        ok = np.isfinite(e)
        b.loglog(1.0 / hs[ok], e[ok], "o-", color=c, ms=4, label=f"{s} PD")
    b.set(xlabel="steps per simulated second (1/h)", ylabel="error against the exact servo [rad]")
    b.legend(fontsize=8, loc="upper right")
    ctx.save(fig)
    return {"kp": kps, "h_max": rows, "h_closed": closed, "track_h": hs,
            "track_error": {s: track[s][0] for s in SERVOS}, "track_wall": {s: track[s][1] for s in SERVOS}}


# %% [markdown]
# ## Figure `ch08_biped_walk`
#
# SIMBICON's walk (Table 1 of Yin, Loken & van de Panne 2007, every number the paper's) and a fast walk of
# ours on flat ground: an animation, a strip of stick figures and the centre of mass's speed (ORACLES F4).

# %%
def _draw_biped(ax, segments, **kw):
    for seg in segments:
        ax.plot(seg[:, 0], seg[:, 1], "-", lw=kw.get("lw", 2), color=kw.get("color", "k"), alpha=kw.get("alpha", 1))


@figure("ch08", "biped_walk", "SIMBICON's planar biped walking (stable PD servos, h = 2 ms, 4-state machine)",
        cost=10.7)
def biped_walk(ctx):
    t_end = 4.0 if ctx.quick else 20.0
    res = {g.name: simulate_walk(g, t_end, 2e-3, servo="stable", record_every=10) for g in (WALK, FAST_WALK)}
    r = res[WALK.name]
    from pbanim.articulated import PlanarKernel
    from pbanim.models.biped import planar_biped

    kernel = PlanarKernel(planar_biped())
    # the animation: every second recorded state (0.04 s apart: real time at fps = 25) over the first 4 s of
    # the walk, from the start through five gait cycles (right strike to right strike: 0.7 s). The gait repeats:
    # 16 s of it (400 frames) cost ~30 of the figure's 42 CPU s and showed the same cycle 23 times
    plt_frames = np.arange(0, len(r.t), 5 if ctx.quick else 2)[:40 if ctx.quick else 100]
    fig, ax = ctx.subplots(figsize=(6, 3))
    # the artists made once and moved each frame (clearing the axes and drawing anew cost 10x more per frame)
    bones = [ax.plot([], [], "-", lw=2, color="k")[0] for _ in stick_figure(kernel, r.q[0])]
    floor = ax.plot([], [], color="0.5", lw=1)[0]
    ax.set(ylim=(-0.1, 1.6), aspect="equal")
    # the view follows the walker, so every frame lays out new x tick labels; the title and the (empty) axis
    # labels are placed once instead of from the tick labels' boxes at every frame, and what does not move
    # (the figure, the axes' face, the y axis with its grid) is drawn once (the same pixels; 100 frames in
    # ~45 % of the drawing time)
    ax.set_title(" ", y=1.0)
    ax.xaxis.set_label_coords(0.5, -0.2), ax.yaxis.set_label_coords(-0.1, 0.5)
    backdrop = frozen_backdrop(fig, [fig.patch, ax.patch, ax.yaxis],
                                bones + [floor, ax.xaxis, ax.title, *ax.spines.values()])

    def draw(i):
        backdrop()
        k = plt_frames[i]
        for line, seg in zip(bones, stick_figure(kernel, r.q[k])):
            line.set_data(seg[:, 0], seg[:, 1])
        cx = r.com[k, 0]
        floor.set_data([cx - 2, cx + 2], [0, 0])
        ax.set(xlim=(cx - 1.5, cx + 1.5), title=f"t = {r.t[k]:.2f} s")

    ctx.save_gif(fig, draw, len(plt_frames), fps=25)
    fig2, (a, b) = ctx.subplots(2, 1, figsize=(11, 5))
    dt_rec = r.t[1] - r.t[0]
    strip = np.arange(max(0, len(r.t) - 1 - int(4.0 / dt_rec)), len(r.t), int(round(0.4 / dt_rec)))
    for k in strip:
        _draw_biped(a, stick_figure(kernel, r.q[k]), lw=1.5, color="k", alpha=0.3 + 0.7 * (k - strip[0]) / max(strip[-1] - strip[0], 1))
    a.axhline(0, color="0.5", lw=1)
    a.set(aspect="equal", xlabel="x [m]", ylabel="y [m]", title="walk: stick figures every 0.4 s over the last 4 s")
    for name, rr in res.items():
        v = np.gradient(rr.com[:, 0], rr.t)
        b.plot(rr.t, v, lw=1, label=f"{name}: mean {rr.speed(min(5.0, t_end / 2)):.2f} m/s")
    b.set(xlabel="t [s]", ylabel="centre-of-mass speed [m/s]")
    b.legend(fontsize=8, loc="upper left")
    ctx.save(fig2, "_strip")
    return {name: {"t": rr.t, "com": rr.com, "fell": rr.fell, "speed": rr.speed(min(5.0, t_end / 2)),
                   "trace": [s for _, s in rr.trace], "realtime_factor": rr.realtime_factor}
            for name, rr in res.items()}


# %% [markdown]
# ## Figure `ch08_walk_targets`
#
# Joint angles against their targets with the machine's states shaded; the swing hip's target moves
# with the balance feedback θ̄ = θ̄₀ + c_d d + c_v v.

# %%
@figure("ch08", "walk_targets", "Joint angles and their targets, machine states shaded")
def walk_targets(ctx):
    r = simulate_walk(WALK, 3.0, 2e-3, servo="stable", record_every=5)
    t0 = 1.0
    hist = [h for h in r.targets if h[0] >= t0]
    t = np.array([h[0] for h in hist])
    fig, axs = ctx.subplots(3, 1, figsize=(12, 7), sharex=True, layout="constrained")
    joints = (("left_hip", "right_hip", "hip (world frame)"), ("left_knee", "right_knee", "knee"),
              ("torso", None, "torso (world frame)"))
    out = {"t": t, "states": [h[1] for h in hist]}
    for ax, (j1, j2, label) in zip(axs, joints):
        for j, c in ((j1, "C0"), (j2, "C3")):
            if j is None:
                continue
            tgt = np.array([h[4].get(j, (np.nan, np.nan))[0] for h in hist])
            ang = np.array([h[4].get(j, (np.nan, np.nan))[1] for h in hist])
            ax.plot(t, ang, color=c, lw=1.5, label=f"{j} angle")
            ax.plot(t, tgt, "--", color=c, lw=1, label=f"{j} target")
            out[j] = {"angle": ang, "target": tgt}
        for a0, a1, s in [(max(a, t0), b, s) for a, b, s in _intervals(r.trace, r.t[-1]) if b > t0]:
            ax.axvspan(a0, a1, color=STATE_COLOURS[s], alpha=0.5, lw=0)
        ax.set(ylabel=f"{label} [rad]")
        ax.legend(fontsize=7, loc="upper left", bbox_to_anchor=(1.0, 1.0))
    axs[-1].set(xlabel="t [s] (shading: R0, R1 right stance; L0, L1 left stance)")
    ctx.save(fig)
    return out


def _intervals(trace, t_end):
    return [(t0, trace[k + 1][0] if k + 1 < len(trace) else t_end, s) for k, (t0, s) in enumerate(trace)]


# %% [markdown]
# ## Figure `ch08_push_envelope`
#
# Pushes on the torso at several impulses and phases of a step: recovered or fell (ORACLES F6).

# %%
@figure("ch08", "push_envelope", "Push recovery: impulse on the torso against the phase of the step", cost=16.5)
def push_envelope(ctx):
    if ctx.quick:
        phases, impulses, count, t_end = [0.4], [-150.0, 100.0], 3, 4.0
    else:
        phases, impulses, count, t_end = [0.1, 0.3, 0.5, 0.7, 0.9], [-200, -150, -120, -100, -80, -60, -30, 30, 60,
                                                                    80, 100, 120, 150, 200], 4, 7.0
    # every run is the unpushed walk until its push lands: that walk is simulated once and branched
    # (simulate_pushes: the same runs as simulate_walk(push=...) one by one, bit for bit); a run that has taken
    # 5 strikes after its push with the torso upright has recovered and stops there (settle: every fallen run of
    # this grid fell within 4 strikes, every recovered one walked 11-12 to t_end; the same 70 outcomes as the
    # full runs, ORACLES F6, F26; 6 strikes cost a fifth more steps, 4 call one fall recovered)
    runs = simulate_pushes(WALK, t_end, 2e-3, [Push(float(p), ph, count) for ph in phases for p in impulses],
                           servo="stable", record_every=50, settle=5)
    grid = np.array([not r.fell for r in runs], dtype=bool).reshape(len(phases), len(impulses)).T
    fig, ax = ctx.subplots(figsize=(6, 4))
    P, F = np.meshgrid(phases, impulses)
    ax.scatter(P[grid], F[grid], marker="o", color="C2", label="recovered")
    ax.scatter(P[~grid], F[~grid], marker="x", color="C3", label="fell")
    ax.set(xlabel="phase of the step (0: right foot strikes, 1: left foot strikes)",
           ylabel="impulse on the torso [N s] (+ forward)")
    ax.legend(fontsize=8, loc="center right")
    ctx.save(fig)
    return {"phases": np.array(phases), "impulses": np.array(impulses, float), "recovered": grid}


# %% [markdown]
# ## Draw the figures
#
# As a script or in a notebook kernel, draw this chapter's figures (quick mode) into `figures/`.

# %%
if __name__ == "__main__":
    from pathlib import Path

    from pbanim.plotting import figures_of, run_figure

    for _key, _spec in figures_of({"ch08"}).items():
        print(_key, [p.name for p in run_figure(_spec, Path("figures"), quick=True)[1]])
