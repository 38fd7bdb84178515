# %% [markdown]
# # Chapter 10 — designs through contact
#
# This file is a module (imported by `pbanim figures`) and a notebook in jupytext's percent format.
# Running it draws every figure of this part of the chapter in quick mode into `figures/`.

# %%
"""Chapter 10 — designs through contact (issue 30): S(t, u) of a rigid body stepped by chapter 07's
velocity-level contact, differentiated on each step's active set, drives differential control.

Figures: ``contact_box_slide``, ``contact_ball_cup``, ``contact_die`` (strip and GIF each; ORACLES L2);
the chapter's other figures are in :mod:`chapters.ch10_design`."""

from __future__ import annotations

import numpy as np

from pbanim.bench.design import DIE_FACE, DIE_PLACE, die_designs, die_scene  # noqa: F401 (DIE_FACE: re-exported)
from pbanim.collision import Box, Plane, Sphere
from pbanim.design import DesignBody
from pbanim.design.control import position_goal
from pbanim.design.stepped import ContactScene, StaticBox
from pbanim.design.stepped_design import design_contact
from pbanim.plotting import figure
from pbanim.plotting_gif import blit_canvas
from pbanim.rigid import quat_to_matrix


# %% [markdown]
# ## Designs through contact (issue 30)
#
# S(t, u) stepped by chapter 07's velocity-level contact with box friction, differentiated on each step's
# active set (pbanim.design.stepped_run), drives differential control (pbanim.design.stepped_design):
# a box pushed to slide and stop on a spot, a ball rolled off a table into a cup, a die thrown to rest on a
# chosen face at a chosen place. Each figure is a strip (the path and the body at six times) and a GIF.

# %%
_EDGES = [(a, b) for a in range(8) for b in range(a + 1, 8) if bin(a ^ b).count("1") == 1]


def _outline(ax, shape, x, q, **kw):
    """The body seen along y: a sphere's circle, or a box's twelve edges projected on x–z."""
    import matplotlib.patches as mpatches

    if isinstance(shape, Sphere):
        return [ax.add_patch(mpatches.Circle((x[0], x[2]), shape.radius, fill=False, **kw))]
    c = x + shape.vertices() @ quat_to_matrix(q).T
    return [ax.plot(c[[a, b], 0], c[[a, b], 2], **kw)[0] for a, b in _EDGES]


def _strip_and_gif(ctx, scene, tr, decor, goal):
    """A strip (the path and the body at six times) and a GIF of the designed motion, seen along y."""
    P = tr.positions()
    fig, ax = ctx.subplots(figsize=(8, 3.2))
    decor(ax)
    ax.plot(P[:, 0], P[:, 2], lw=1, color="C0")
    for k, i in enumerate(np.linspace(0, len(P) - 1, 6).astype(int)):
        _outline(ax, scene.body.shape, P[i], tr.y[i, 3:7], color="C1", alpha=0.3 + 0.14 * k)
    ax.plot(goal[0], goal[2], "r*", ms=12)
    ax.set_aspect("equal"), ax.set_xlabel("x (m)"), ax.set_ylabel("z (m)")
    ctx.save(fig, "_strip")
    fig, ax = ctx.subplots(figsize=(8, 3.2))
    decor(ax)
    ax.set_aspect("equal"), ax.set_xlabel("x (m)"), ax.set_ylabel("z (m)")
    ax.plot(goal[0], goal[2], "r*", ms=12)
    ax.set_xlim(*ax.get_xlim()), ax.set_ylim(*ax.get_ylim())
    drawn = []
    frames = 24 if ctx.quick else 60

    def update(j):
        i = min(int(j / (frames - 1) * (len(P) - 1)), len(P) - 1)
        if drawn and not isinstance(scene.body.shape, Sphere):
            # a box's twelve edges are made once and moved (the pixels of plotting them anew, without 12 new
            # lines per frame)
            c = P[i] + scene.body.shape.vertices() @ quat_to_matrix(tr.y[i, 3:7]).T
            for line, (a, b) in zip(drawn, _EDGES):
                line.set_data(c[[a, b], 0], c[[a, b], 2])
            return drawn
        for a in drawn:
            a.remove()
        drawn[:] = _outline(ax, scene.body.shape, P[i], tr.y[i, 3:7], color="C1")
        return drawn

    blit_canvas(fig, lambda: drawn)
    ctx.save_gif(fig, update, frames=frames, fps=12)


def contact_box_scene():
    return ContactScene(DesignBody(Box([0.2, 0.1, 0.05]), position=[0, 0, 0.05], velocity=[1.0, 0, 0]),
                        [Plane()], friction=0.3)


@figure("ch10", "contact_box_slide", "A box pushed to slide and stop on a spot (v₀ and μ designed)",
        cost=3.2)
def contact_box_slide(ctx):
    """The push and μ found together (a vertical push weighted 10⁶ in M) so that the box stops on the spot."""
    scene, T, spot = contact_box_scene(), 1.0, np.array([0.8, -0.3, 0.05])
    d = design_contact(scene, T, ["v0", "friction"], [position_goal(0, T, spot)], rest=True, h=0.01,
                       M=np.diag([1.0, 1.0, 1e6, 1.0]))

    def decor(ax):
        ax.axhline(0.0, color="k"), ax.set_xlim(-0.4, 1.2), ax.set_ylim(-0.05, 0.3)
    _strip_and_gif(ctx, scene, d.trajectory, decor, spot)
    return {"u": d.u, "names": d.names, "success": d.success, "residual": d.residual, "at_rest": d.at_rest,
            "history": np.array(d.history), "final": d.trajectory.y[-1], "T": T, "spot": spot}


CUP, CUP_INNER, CUP_HEIGHT = np.array([1.05, 0.1]), 0.07, 0.2


def contact_cup_scene():
    """A ball on a table (top at 0.8 m, edge at x = 0.5) and a cup of four walls on the floor."""
    th, (cx, cy), w, H = 0.01, CUP, CUP_INNER, CUP_HEIGHT
    walls = [StaticBox([th, w + 2 * th, H / 2], [cx + s * (w + th), cy, H / 2]) for s in (1, -1)]
    walls += [StaticBox([w, th, H / 2], [cx, cy + s * (w + th), H / 2]) for s in (1, -1)]
    body = DesignBody(Sphere(0.05), position=[0.2, 0, 0.85], velocity=[1.5, 0.0, 0])
    return ContactScene(body, [Plane()], [StaticBox([0.5, 0.5, 0.4], [0, 0, 0.4])] + walls, friction=0.4)


@figure("ch10", "contact_ball_cup", "A ball rolled off a table edge into a cup", cost=4.9)
def contact_ball_cup(ctx):
    """The push v₀ is designed so that, rolling to the edge and flying, the ball passes over the cup's centre
    at t = 0.62 s (goal on x and y) and drops in."""
    scene, T, tg = contact_cup_scene(), 1.0, 0.62
    d = design_contact(scene, T, ["v0"], [position_goal(0, tg, [*CUP, 0.0])], components=(0, 1), h=0.01)

    def decor(ax):
        import matplotlib.patches as mpatches
        ax.add_patch(mpatches.Rectangle((-0.5, 0), 1.0, 0.8, color="0.85"))
        for s in (1, -1):
            ax.add_patch(mpatches.Rectangle((CUP[0] + s * (CUP_INNER + 0.01) - 0.01, 0), 0.02, CUP_HEIGHT,
                                            color="0.5"))
        ax.axhline(0.0, color="k"), ax.set_xlim(-0.1, 1.3), ax.set_ylim(-0.05, 1.0)
    _strip_and_gif(ctx, scene, d.trajectory, decor, [CUP[0], 0.0, 0.05])
    return {"u": d.u, "names": d.names, "success": d.success, "residual": d.residual, "T": T,
            "final": d.trajectory.y[-1], "history": np.array(d.history)}


contact_die_scene = die_scene          # the die thrown (its old name in this chapter)


@figure("ch10", "contact_die", "A die thrown to rest on a chosen face at a chosen place", cost=5.3)
def contact_die(ctx):
    """Gauss–Newton on v₀ through the corner impacts and the rolling (with up to six seeded kicks where the
    place lies across a jump of S); the face by the cube's symmetry on θ₀. The figure designs the first random
    throw (seed 0); how many of 10 random throws reach the place is a row of ``pbanim bench design``
    (``design-die-successes``), not redone by every figure run."""
    out = die_designs(1)
    scene, d = out[0]

    def decor(ax):
        ax.axhline(0.0, color="k"), ax.set_xlim(-0.2, 1.0), ax.set_ylim(-0.05, 0.45)
    _strip_and_gif(ctx, scene, d.trajectory, decor, DIE_PLACE)
    return {"u": d.u, "names": d.names, "success": d.success, "residual": d.residual, "face": d.face,
            "at_rest": d.at_rest, "final": d.trajectory.y[-1], "T": 1.5, "history": np.array(d.history),
            "successes": sum(dd.success for _, dd in out), "starts": len(out)}



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
