# %% [markdown]
# # Chapter 08 (part 4) — SIMBICON's walk in 3-D.
#
# This file is a module (imported by `pbanim figures`) and a notebook in jupytext's percent format:
# open it in Jupyter (with jupytext) or VS Code, or write an `.ipynb` with `pbanim notebook ch08 DIR`.
# Running it draws every figure of the chapter in quick mode into `figures/`.

# %%
"""Chapter 08 (part 4) — SIMBICON's walk in 3-D.

Figures:

* ``biped3d_walk``: the 3-D biped (:mod:`pbanim.control.biped3d`) walking under the 3-D SIMBICON controller
  (:mod:`pbanim.control.simbicon3d`, gait ``WALK3D``, ours: Table 1's sagittal numbers, our coronal ones;
  ORACLES F18): an animation in two projections (side x–z, top x–y), a strip of key frames, and the centre
  of mass's horizontal speed and the pelvis's heading ψ over time. Full run: 20 s at h = 2 ms with the heading
  target turned to 0.5 rad from t = 8 s (measured: no fall, 65 strikes, 0.88 m/s over the last 5 s, ψ within
  0.45–0.56 rad over the last 5 s); the GIF one frame per 0.2 s at 5 fps (real time, 101 frames). 23.7 s of
  CPU (the walk 11.4 s, the GIF and strip 12.2 s), against 42.9 s (walk 16.8 s, GIF and strip 26.1 s) for the
  code before (PGS as the contact solve, 201 GIF frames at 10 fps), the two run back to back at load ~1.5 (the
  same walk outcome: 65 strikes, 0.879 m/s); 52, 58.6 and 74 s before the earlier cuts of issue 31, on a loaded
  machine. With the lean step's kinematics, controller and C(q, q̇) on floats (``pbanim bench control``): 15.2 s
  (14.8–17.6) → 13.1 s (12.2–13.5) of the figure's CPU, 3 alternating rounds at load 2.2–2.7 (the 20 s walk
  alone without the turn: 8.5 → 5.4–5.8 s CPU, single runs; 65 strikes, 0.8869 m/s both); quick: 2.5 s at
  h = 3.5 ms. The GIF drawn over a frozen backdrop (the figure and the side view's face, ORACLES G5; the same
  bytes): about 1 s less of the figure's CPU (paired runs at load ~4: 19.2 → 18.1, 19.9 → 18.8 s).
"""

from __future__ import annotations

import numpy as np

from pbanim.control.biped3d import biped3d
from pbanim.control.simbicon3d_walk import simulate_walk3d
from pbanim.plotting import figure
from pbanim.plotting_gif import frozen_backdrop

# the bones of the stick figure: (from, to) as (link name, point in its frame), "o" the link's joint origin
_HALF = 0.09


def _bones(tree):
    names = [lk.name for lk in tree.links]
    top = (names.index("torso"), np.array([0.0, 0.0, 0.65]))
    pelvis = names.index("pelvis")
    out = [((pelvis, np.array([0.0, 0.0, -0.075])), top),
           ((pelvis, np.array([0.0, _HALF, -0.075])), (pelvis, np.array([0.0, -_HALF, -0.075])))]
    for s in ("left", "right"):
        th, sh, ft = (names.index(f"{s}_{x}") for x in ("thigh", "shin", "foot"))
        z = np.zeros(3)
        out += [((th, z), (sh, z)), ((sh, z), (ft, z)),
                ((ft, np.array([-0.06, 0.0, -0.06])), (ft, np.array([0.19, 0.0, -0.06]))),
                ((ft, z), (ft, np.array([0.19, 0.0, -0.06])))]
    return out


def _points(ws, q, bones) -> np.ndarray:
    """(bones, 2, 3) world end points of the bones at q."""
    kin = ws.kinematics(q)
    P = [[kin["o"][lk] + kin["R"][lk] @ p for lk, p in ends] for ends in bones]
    return np.array(P)


# %% [markdown]
# ## Figure `ch08_biped3d_walk`
#
# The 3-D walk from a 0.5 m/s start at h = 2 ms (20 s; quick: 2.5 s at h = 3.5 ms, the largest stable step), the heading target turned to
# 0.5 rad from t = 8 s (quick: none). The ranges of h measured are in ORACLES F18.

# %%
@figure("ch08", "biped3d_walk", "SIMBICON's 3-D biped walking: side and top views, speed and heading",
        cost=16.0)
def biped3d_walk(ctx):
    from pbanim.control.biped3d_step import WorldStep
    from pbanim.control.biped3d import biped3d_contact_points

    t_end, h = (2.5, 3.5e-3) if ctx.quick else (20.0, 2e-3)
    turn = None if ctx.quick else np.array([8.0, 0.5])
    r = simulate_walk3d(t_end=t_end, h=h, turn=turn, record_every=max(1, int(round(0.02 / h))))
    tree = biped3d()
    ws = WorldStep(tree, biped3d_contact_points(tree))
    bones = _bones(tree)
    # quick: every 2nd record (0.04 s) at 25 fps; full: every 10th (0.2 s) at 5 fps, real time, 101 frames
    frames = np.arange(0, len(r.t), 2 if ctx.quick else 10)[:40 if ctx.quick else 200]
    fig, (side, top) = ctx.subplots(2, 1, figsize=(6, 5))
    # the artists made once and moved each frame
    lines = [(side.plot([], [], "-", lw=2, color="k")[0], top.plot([], [], "-", lw=2, color="k")[0]) for _ in bones]
    floor = side.plot([], [], color="0.5", lw=1)[0]
    path = top.plot([], [], color="C0", lw=1)[0]
    side.set(ylim=(-0.1, 1.8), aspect="equal", ylabel="z [m]")
    top.set(aspect="equal", xlabel="x [m]", ylabel="y [m]")
    # both views follow the walker (new x ticks in both, new y ticks in the top one): what does not move — the
    # figure, the side view's face and its y axis — is rendered once and copied back under the rest (the
    # same pixels as drawing every artist, ORACLES G5)
    backdrop = frozen_backdrop(fig, [fig.patch, side.patch],
                               [a for pair in lines for a in pair] + [floor, path, side.xaxis, side.yaxis, side.title,
                                                                      *side.spines.values(), top.patch, top.xaxis,
                                                                      top.yaxis, top.title, *top.spines.values()])

    def draw(i):
        backdrop()
        k = frames[i]
        P = _points(ws, r.q[k], bones)
        for (a, b), seg in zip(lines, P):
            a.set_data(seg[:, 0], seg[:, 2])
            b.set_data(seg[:, 0], seg[:, 1])
        cx, cy = r.com[k, 0], r.com[k, 1]
        floor.set_data([cx - 2, cx + 2], [0, 0])
        path.set_data(r.com[:k + 1, 0], r.com[:k + 1, 1])
        side.set(xlim=(cx - 1.2, cx + 1.2), title=f"t = {r.t[k]:.2f} s (side, top)")
        top.set(xlim=(cx - 1.2, cx + 1.2), ylim=(cy - 0.6, cy + 0.6))

    ctx.save_gif(fig, draw, len(frames), fps=25 if ctx.quick else 5)
    fig2, (a, b, c) = ctx.subplots(3, 1, figsize=(11, 8))
    dt_rec = r.t[1] - r.t[0]
    strip = np.arange(max(0, len(r.t) - 1 - int(2.4 / dt_rec)), len(r.t), max(1, int(round(0.2 / dt_rec))))
    for k in strip:
        alpha = 0.3 + 0.7 * (k - strip[0]) / max(strip[-1] - strip[0], 1)
        for seg in _points(ws, r.q[k], bones):
            a.plot(seg[:, 0], seg[:, 2], "-", lw=1.5, color="k", alpha=alpha)
    a.axhline(0, color="0.5", lw=1)
    a.set(aspect="equal", xlabel="x [m]", ylabel="z [m]", title="side view every 0.2 s over the last 2.4 s")
    v = np.hypot(np.gradient(r.com[:, 0], r.t), np.gradient(r.com[:, 1], r.t))
    b.plot(r.t, v, lw=1, label=f"mean {r.speed(min(5.0, t_end / 2)):.2f} m/s over the last {min(5.0, t_end / 2):.1f} s")
    b.set(xlabel="t [s]", ylabel="horizontal speed |ċ_xy| [m/s]")
    b.legend(fontsize=8, loc="lower right")
    c.plot(r.t, r.heading, lw=1, label="pelvis heading ψ")
    if turn is not None:
        c.axhline(turn[1], color="0.5", ls="--", lw=1, label="target ψ̄")
    c.set(xlabel="t [s]", ylabel="ψ [rad]")
    c.legend(fontsize=8, loc="upper left")
    ctx.save(fig2, "_strip")
    return {"t": r.t, "com": r.com, "heading": r.heading, "fell": r.fell, "strikes": r.steps, "h": h,
            "speed": r.speed(min(5.0, t_end / 2)), "trace": [s for _, s in r.trace],
            "realtime_factor": r.realtime_factor}


# %% [markdown]
# As a script or in a notebook kernel, draw this chapter's figures (quick mode) into `figures/`.

# %%
if __name__ == "__main__":
    from pathlib import Path

    from pbanim.plotting import figures_of, run_figure

    for _key, _spec in figures_of({"ch08"}).items():
        print(_key, [p.name for p in run_figure(_spec, Path("figures"), quick=True)[1]])
