# %% [markdown]
# # Chapter 08 (part 2) — the optimization controller: one QP per step keeps the planar biped standing.
#
# This file is a module (imported by `pbanim figures`) and a notebook in jupytext's percent format:
# open it in Jupyter (with jupytext) or VS Code, or write an `.ipynb` with `pbanim notebook ch08 DIR`.
# Running it draws every figure of the file in quick mode into `figures/`.

# %%
"""Chapter 08 (part 2) — the optimization controller of de Lasa, Mordatch & Hertzmann (2010).

At every control step one QP over joint accelerations, torques and contact forces tracks the centre of
mass, the angular momentum about it and a posture, under the equations of motion, the friction cones
and the torque limits (:mod:`pbanim.control.qp`). The planar biped stands on both feet with bent knees
and is pushed on the torso (:func:`pbanim.control.qp_balance.simulate_balance`).

Figures:

* ``qp_push_balance``: a push of 20 N s is recovered and one of 30 N s is not (ORACLES F14), by the weighted
  controller and by the prioritized one (``BALANCE_FIRST``: the soles held flat on the top level, then the
  centre of mass and the angular momentum, then the posture): the centre of mass against the edges of the
  feet; the contact forces of every QP step inside their friction cones |fₜ| ≤ μ fₙ (ORACLES F10); the normal
  forces of heel and toe (the centre of pressure moves to the toe, then back: the ankle strategy). In full
  mode also the outcome against the impulse for both controllers on the same pushes, with the capture-point
  bound P = M √(g/z) d of a linear inverted pendulum.
"""

from __future__ import annotations

import numpy as np

from pbanim.control.biped import BIPED_JOINTS
from pbanim.control.qp_balance import BALANCE_FIRST, simulate_balance_pushes
from pbanim.models.biped import planar_biped
from pbanim.plotting import figure


def capture_impulse(run) -> float:
    """M √(g/z) d: the largest push a linear inverted pendulum of height z stops inside a half-foot d."""
    mass, g = sum(link.mass for link in planar_biped().links), 9.81
    return float(mass * np.sqrt(g / run.com_target[1]) * 0.5 * (run.support[1] - run.support[0]))


def _summary(run) -> dict:
    return {"t": run.t, "com": run.com, "forces": run.forces, "sim_forces": run.sim_forces, "outcome": run.outcome,
            "end_time": run.end_time, "cause": run.cause, "com_error": run.com_error(0.5), "push": run.push,
            "qp_ms_per_step": 1e3 * run.qp_time / max(len(run.t) * 5, 1),
            "torso_max": float(np.abs(run.q[:, BIPED_JOINTS["torso"]]).max())}


# %% [markdown]
# ## Figure `ch08_qp_push_balance`
#
# The QP controller's centre of mass and contact forces inside their cones during a push.

# %%
@figure("ch08", "qp_push_balance", "QP balance, weighted and prioritized: a push recovered, a larger one not; forces in cones",
        cost=39.5)
def qp_push_balance(ctx):
    t_end = 2.5
    impulses = np.arange(-32.0, 33.0, 4.0)
    # every run is the same stance until its push lands at 0.5 s: that stance is simulated once and each push
    # continues from it (simulate_balance_pushes: the runs of simulate_balance(P) one by one); the run at
    # 20 N s is the recovered one drawn and also a point of the envelope (full mode), not run twice. The QPs are
    # solved on the lean path (qp_lean.LeanQP, ORACLES F23: the last step's active set, ProxQP when it does not
    # certify); the 18 runs measured 48.3 -> 29.3 CPU s in one process at load ~12 (hint: 37.9 quiet x 0.61)
    pushes = [20.0, 30.0] + ([] if ctx.quick else [float(p) for p in impulses if p != 20.0])
    runs = dict(zip(pushes, simulate_balance_pushes(pushes, t_end)))
    # the prioritized controller (BALANCE_FIRST) on the same pushes: ±20 N s, in full mode also ±24, the largest
    # the weighted one recovers (its levels on their lean path, qp_lean_levels.LeanLevels, ORACLES F25: the levels
    # the constraints fix skipped, one ProxQP a step for the centre of mass and momentum, the last level from the
    # active set; still ~2x a weighted run, so not the whole grid; measured on the grid −32 … 32: it recovers
    # every push the weighted one recovers and falls beyond the capture point, ±28 and ±32, as the weighted one
    # does: ORACLES F14)
    prio_pushes = [20.0, -20.0] + ([] if ctx.quick else [-24.0, 24.0])
    prio = dict(zip(prio_pushes, simulate_balance_pushes(prio_pushes, t_end, **BALANCE_FIRST)))
    small, large = runs[20.0], runs[30.0]
    mu = small.mu
    f = small.forces.reshape(-1, 2)
    loaded = f[:, 0] > 1.0
    ratio = float(np.max(np.abs(f[loaded, 1]) / f[loaded, 0])) if loaded.any() else 0.0
    fs = small.sim_forces.reshape(-1, 2)
    sim_loaded = fs[:, 0] > 1.0
    sim_ratio = float(np.max(np.abs(fs[sim_loaded, 1]) / fs[sim_loaded, 0])) if sim_loaded.any() else 0.0
    envelope = None
    if not ctx.quick:
        envelope = {"impulse": impulses, "recovered": np.array([runs[float(p)].recovered for p in impulses]),
                    "prioritized_impulse": np.array(sorted(prio)),
                    "prioritized_recovered": np.array([prio[p].recovered for p in sorted(prio)])}
    ncols = 3 if ctx.quick else 4
    fig, axs = ctx.subplots(1, ncols, figsize=(4.2 * ncols, 3.8))
    a, b, c = axs[:3]
    lo, hi = np.array(small.support) - small.com_target[0]
    for run, col in ((small, "C0"), (large, "C3")):
        a.plot(run.t, run.com[:, 0] - run.com_target[0], color=col,
               label=f"P = {run.push:g} N s: {run.outcome}" + (f" at {run.end_time:.2f} s" if not run.recovered else ""))
    p20 = prio[20.0]
    a.plot(p20.t, p20.com[:, 0] - p20.com_target[0], color="C2", ls="--",
           label=f"P = 20 N s, prioritized: {p20.outcome}" + (f" at {p20.end_time:.2f} s" if not p20.recovered else ""))
    a.axhline(lo, color="0.4", ls="--", lw=1, label="heel / toe")
    a.axhline(hi, color="0.4", ls="--", lw=1)
    a.axvline(small.push_time, color="0.6", lw=0.8)
    a.set(xlabel="t [s]", ylabel="centre of mass x − target [m]", ylim=(1.6 * lo, 1.6 * hi))
    a.legend(fontsize=7, loc="lower left")
    fn = np.linspace(0.0, 1.05 * f[:, 0].max(), 2)
    b.fill_between(fn, -mu * fn, mu * fn, color="C2", alpha=0.15, label=f"friction cone μ = {mu:g}")
    names = ("left heel", "left toe", "right heel", "right toe")
    for j in (0, 1):
        b.plot(small.forces[:, j, 0], small.forces[:, j, 1], ".", ms=2, label=f"{names[j]} (QP)")
    b.set(xlabel="normal force fₙ [N]", ylabel="tangential force fₜ [N]")
    b.legend(fontsize=7, loc="upper left")
    for j, col in ((0, "C0"), (1, "C1")):
        c.plot(small.t, small.forces[:, j, 0], color=col, label=f"{names[j]}, QP")
        c.plot(small.t, small.sim_forces[:, j, 0], color=col, ls=":", label=f"{names[j]}, simulated")
    c.axvline(small.push_time, color="0.6", lw=0.8)
    c.set(xlabel="t [s]", ylabel="normal force [N]")
    c.legend(fontsize=7)
    if envelope is not None:
        d = axs[3]
        for row, (P, ok) in enumerate(((envelope["prioritized_impulse"], envelope["prioritized_recovered"]),
                                       (envelope["impulse"], envelope["recovered"]))):
            d.plot(P[ok], np.full(ok.sum(), row), "o", color="C0", label="recovered" if row else None)
            d.plot(P[~ok], np.full((~ok).sum(), row), "x", color="C3", label="fell / infeasible" if row else None)
        for sgn in (-1, 1):
            d.axvline(sgn * capture_impulse(small), color="0.4", ls="--", lw=1,
                      label="capture-point bound" if sgn > 0 else None)
        d.set_yticks([0, 1], ["prioritized", "weighted"], rotation=90, va="center")
        d.set(xlabel="push P [N s]", ylabel="controller [–]", ylim=(-0.6, 1.8),
              title="outcome of each push, by controller")
        d.legend(fontsize=7, loc="upper left", ncol=3)
    ctx.save(fig)
    return {"recovered": _summary(small), "fallen": _summary(large), "mu": mu, "max_cone_ratio": ratio,
            "prioritized": {p: _summary(prio[p]) for p in (20.0, -20.0)},
            "max_sim_cone_ratio": sim_ratio, "capture_impulse": capture_impulse(small), "support": small.support,
            "envelope": envelope}


# %% [markdown]
# ## Figure `ch08_qp_biped3d_step`
#
# The 3-D biped takes one scripted step of 0.2 m under the QP controller (:func:`pbanim.control.qp_biped3d_run.
# simulate_step`, h = 8 ms, quick 10 ms; ProxQP alone; ORACLES F21): shift over the right sole, lift and swing the left foot,
# land, shift to the middle. A strip of side (x–z) and front (y–z) views at key times with the centre of mass
# (its ground projection marked) and the support polygon (the sole corners on the ground, its extent in each
# view); a top view of the support polygons and the centre of mass's path. Quick: the weighted controller; full:
# also the prioritized one (its path in the top view) and a GIF. Measured CPU (matplotlib loaded): quick 4.5–4.7 s,
# full 13.2 s.

# %%
def _support(ctrl, q, tol: float) -> np.ndarray:
    """(k, 2) the x, y of the sole corners on the ground (z ≤ tol) at q, ordered round their hull."""
    from scipy.spatial import ConvexHull

    kin = ctrl.world.kinematics(q)
    P = ctrl.world.point_jacobians(kin, ctrl.links, ctrl.local)[0]
    xy = P[P[:, 2] <= tol, :2]
    return xy[ConvexHull(xy).vertices] if len(xy) >= 3 else xy


@figure("ch08", "qp_biped3d_step", "3-D biped stepping under the QP controller: side and front views, COM, support",
        cost=12.0)
def qp_biped3d_step(ctx):
    from chapters.ch08_biped3d import _bones, _points
    from pbanim.control.qp_biped3d import QPBiped3D
    from pbanim.control.qp_biped3d_run import simulate_step

    from matplotlib.collections import LineCollection

    h = 1e-2 if ctx.quick else 8e-3
    runs = {"weighted": simulate_step(length=0.2, h=h, mode="weighted")}
    if not ctx.quick:
        runs["prioritized"] = simulate_step(length=0.2, h=h, mode="prioritized")
    r = runs["weighted"]
    ctrl = QPBiped3D([])
    bones = _bones(ctrl.kernel)
    keys = (0.0, 0.6, 0.72, 0.8, 0.88, 1.0, 1.3, 1.8)
    frames = [int(np.argmin(np.abs(r.t - t))) for t in keys]
    fig, (side, front, top) = ctx.subplots(3, 1, figsize=(11, 10), gridspec_kw={"height_ratios": [2, 2, 1.5],
                                                                                       "hspace": 0.35})
    gap = 0.55
    for j, k in enumerate(frames):
        P = _points(ctrl.world, r.q[k], bones)
        sup = _support(ctrl, r.q[k], ctrl.contact_tol)
        c = r.com[k]
        for ax, axis in ((side, 0), (front, 1)):
            off = j * gap
            ax.add_collection(LineCollection(P[:, :, [axis, 2]] + [off, 0.0], colors="k", linewidths=1.5))
            ax.plot([sup[:, axis].min() + off, sup[:, axis].max() + off], [0.0, 0.0], "-", lw=5, color="C2",
                    alpha=0.6, label="support polygon (its extent)" if j == 0 else None)
            ax.plot([c[axis] + off] * 2, [c[2], 0.0], ":", color="C3", lw=0.8)
            ax.plot([c[axis] + off] * 2, [c[2], 0.0], "o", color="C3", ms=4,
                    label="centre of mass and its ground point" if j == 0 else None)
        side.text(j * gap, -0.14, f"t = {r.t[k]:.2f} s", ha="center", fontsize=7)
    for ax, label, title in ((side, "x, each frame shifted 0.55 m [m]", "side view (x forward)"),
                             (front, "y, each frame shifted 0.55 m [m]", "front view (y to the biped's left)")):
        ax.axhline(0, color="0.5", lw=0.8)
        ax.set(aspect="equal", xlim=(-0.35, (len(frames) - 1) * gap + 0.45), ylim=(-0.2, 2.0), ylabel="z [m]",
               xlabel=label, title=title)
        ax.legend(fontsize=7, loc="upper right", ncol=2)
    for k, col, lab in ((frames[0], "C2", "double support"), (frames[3], "C1", "single support (right sole)"),
                        (frames[-1], "C4", "double support after the step")):
        sup = _support(ctrl, r.q[k], ctrl.contact_tol)
        top.fill(sup[:, 0], sup[:, 1], facecolor=col, alpha=0.2, edgecolor=col, lw=1.2,
                 label=f"{lab}, t = {r.t[k]:.2f} s")
    for (name, run), col in zip(runs.items(), ("C3", "C0")):
        top.plot(run.com[:, 0], run.com[:, 1], "-", color=col, lw=1.2,
                 label=f"centre of mass, {name}: step {run.extra['length']:.4f} m")
    top.plot(r.com_target[:, 0], r.com_target[:, 1], "--", color="0.4", lw=0.8, label="its target c̄")
    top.set(aspect="equal", xlabel="x [m]", ylabel="y [m]", xlim=(-0.2, 0.75),
            title=f"top view: support polygons and the centre of mass (h = {h * 1e3:g} ms)")
    top.legend(fontsize=7, loc="center right")
    ctx.save(fig)
    if not ctx.quick:
        gfig, (gs, gf) = ctx.subplots(1, 2, figsize=(7, 4))
        lines = [(gs.plot([], [], "-", lw=2, color="k")[0], gf.plot([], [], "-", lw=2, color="k")[0]) for _ in bones]
        dots = (gs.plot([], [], "o", color="C3")[0], gf.plot([], [], "o", color="C3")[0])
        for ax, lab, lim in ((gs, "x [m]", (-0.5, 0.8)), (gf, "y [m]", (-0.6, 0.6))):
            ax.axhline(0, color="0.5", lw=0.8)
            ax.set(aspect="equal", xlim=lim, ylim=(-0.05, 1.5), xlabel=lab, ylabel="z [m]")

        def draw(i):
            k = i * 2
            for (a, b), seg in zip(lines, _points(ctrl.world, r.q[k], bones)):
                a.set_data(seg[:, 0], seg[:, 2])
                b.set_data(seg[:, 1], seg[:, 2])
            dots[0].set_data([r.com[k, 0]], [r.com[k, 2]])
            dots[1].set_data([r.com[k, 1]], [r.com[k, 2]])
            gs.set_title(f"t = {r.t[k]:.2f} s (side, front)")

        ctx.save_gif(gfig, draw, len(r.t) // 2, fps=12)
    out = {"h": h, "frames_t": r.t[frames]}
    for name, run in runs.items():
        out[name] = {"outcome": run.outcome, "cause": run.cause, "t": run.t, "com": run.com, "com_target": run.com_target,
                     "residuals": run.residuals, "newton_euler": run.newton_euler, "mass": run.mass,
                     "com_error": run.com_error(0.1), **{k: v for k, v in run.extra.items() if k != "mode"}}
    return out


# %% [markdown]
# ## Draw the figures
#
# As a script or in a notebook kernel, draw this file's figures (quick mode) into `figures/`.

# %%
if __name__ == "__main__":
    from pathlib import Path

    from pbanim.plotting import figures_of, run_figure

    for _key, _spec in figures_of({"ch08"}).items():
        print(_key, [p.name for p in run_figure(_spec, Path("figures"), quick=True)[1]])
