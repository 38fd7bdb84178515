# %% [markdown]
# # Chapter 08 (part 1) — articulated bodies: the same chain in maximal and in reduced coordinates.
#
# This file is a module (imported by `pbanim figures`) and a notebook in jupytext's percent format:
# open it in Jupyter (with jupytext) or VS Code, or write an `.ipynb` with `pbanim notebook ch08 DIR`.
# Running it draws every figure of the chapter in quick mode into `figures/`.

# %%
"""Chapter 08 (part 1) — articulated bodies: the same chain in maximal and in reduced coordinates.

Figures:

* ``chain_maximal_vs_reduced``: a chain of n rods swinging under gravity, simulated as rigid bodies held
  by hinge joints (maximal coordinates, multipliers, with and without Baumgarte feedback) and as an
  articulated tree (reduced coordinates, ABA): the tip trajectories agree (ORACLES G1), the energy
  error of each, and the joint drift that only the maximal form has.
* ``ragdoll_fall``: the 11-link ragdoll of :func:`pbanim.models.articulated.ragdoll` thrown forward
  over the top of a staircase (contact with friction at the ends of every segment, damped hinges): an
  animation, its energy (never growing) and the height of its lowest point above the tread under it.
* ``cost_vs_links``: the cost of one forward-dynamics evaluation vs the number of links for ABA (O(n)),
  CRBA + Cholesky solve, the batched ABA per state, and the maximal-coordinate joint solve (5 rows per
  hinge: the dense J W Jᵀ solve and Baraff's leaves-first sparse elimination).
"""

from __future__ import annotations

import time

import numpy as np

from pbanim.articulated import RigidJoints, aba, aba_batch, bias_forces, crba
from pbanim.models.articulated import rod_chain
from pbanim.contracts import unchecked
from pbanim.plotting import figure
from pbanim.plotting_gif import frozen_backdrop
from pbanim.rigid import quat_to_matrix

L, M, G = 0.5, 1.0, 9.81


def chain_models(n: int, theta0: float = 0.9, ks: float = 0.0, kd: float = 0.0):
    """(maximal RigidScene, its RigidBodies, reduced ArticulatedSystem) for n rods released at rest."""
    return rod_chain(n, L, M, theta0, G, ks=ks, kd=kd)


def _tip_maximal(rb, Y):
    """The last rod's tip x + R(q) (0, −L/2, 0) at every recorded state (columns of Y, (13N, K))."""
    N = rb.N
    x, q = Y[3 * (N - 1):3 * N].T, Y[3 * N + 4 * (N - 1):7 * N].T
    return x + quat_to_matrix(q) @ np.array([0, -L / 2, 0])


def _joints(scene):
    return next(e for e in scene.effects if isinstance(e, RigidJoints))


def _tip_reduced(Q):
    """The chain's tip (Σ L sin θ, −Σ L cos θ, 0), θ the cumulative joint angles, at every row of Q (K, n)."""
    th = np.cumsum(Q, axis=1)
    return np.stack([L * np.sin(th).sum(axis=1), -L * np.cos(th).sum(axis=1), np.zeros(len(Q))], axis=1)


# %% [markdown]
# ## Figure `ch08_chain_maximal_vs_reduced`
#
# A chain of rods in maximal and in reduced coordinates.
#
# A chain of n rods swinging under gravity, simulated as rigid bodies held by hinge joints (maximal
# coordinates, multipliers, with and without Baumgarte feedback) and as an articulated tree (reduced
# coordinates, ABA): the tip trajectories agree (ORACLES G1), the energy error of each, and the
# joint drift that only the maximal form has.

# %%
@figure("ch08", "chain_maximal_vs_reduced", "A chain of rods in maximal and in reduced coordinates", cost=9.9)
def chain_maximal_vs_reduced(ctx):
    n, h = (3, 2e-3) if ctx.quick else (5, 1e-3)
    t_end = 1.0 if ctx.quick else 4.0
    scene, rb, red = chain_models(n)
    stab_scene, stab_rb, _ = chain_models(n, ks=400.0, kd=40.0)
    rm = scene.simulate(t_end, h, "rk4")
    rs = stab_scene.simulate(t_end, h, "rk4")
    rr = red.simulate(t_end, h, "rk4")
    tip_m = _tip_maximal(rb, rm.y)
    tip_r = _tip_reduced(rr.y[:n].T)
    # only the series drawn, from the recorded states (the runs' full diagnostics cost some 6 CPU s more)
    energy, drift, drift_stab = (unchecked(f) for f in (scene.energy, _joints(scene).diagnostics,
                                                        _joints(stab_scene).diagnostics))
    data = {"t": rm.t, "n": n, "h": h, "tip_difference": float(np.abs(tip_m - tip_r).max()),
            "energy_maximal": np.array([energy(y) for y in rm.y.T]), "energy_reduced": rr.diagnostics["energy"],
            "joint_error": np.array([drift(t, y)["joint_error"] for t, y in zip(rm.t, rm.y.T)]),
            "joint_error_baumgarte": np.array([drift_stab(t, y)["joint_error"] for t, y in zip(rs.t, rs.y.T)])}
    fig, axs = ctx.subplots(1, 3, figsize=(12, 3.6))
    axs[0].plot(tip_r[:, 0], tip_r[:, 1], lw=2, label="reduced (ABA)")
    axs[0].plot(tip_m[:, 0], tip_m[:, 1], "--", lw=1, label="maximal (hinges)")
    axs[0].set_aspect("equal"), axs[0].set_title("tip path"), axs[0].legend()
    axs[0].set(xlabel="x [m]", ylabel="y [m]")
    for key, lab in (("energy_maximal", "maximal"), ("energy_reduced", "reduced")):
        E = data[key]
        axs[1].semilogy(rm.t, np.abs(E - E[0]) + 1e-18, label=lab)
    axs[1].set(xlabel="t [s]", ylabel="|E − E₀| [J]", title="energy error"), axs[1].legend()
    axs[2].semilogy(rm.t, data["joint_error"] + 1e-18, label="no feedback")
    axs[2].semilogy(rs.t, data["joint_error_baumgarte"] + 1e-18, label="Baumgarte k_s = 400, k_d = 40")
    axs[2].set(xlabel="t [s]", ylabel="max |C| of the joints [m]", title="joint drift"), axs[2].legend()
    ctx.save(fig)
    return data


def _median(fn, repeats=5):
    ts = []
    for _ in range(repeats):
        s = time.perf_counter()
        fn()
        ts.append(time.perf_counter() - s)
    return float(np.median(ts))


# %% [markdown]
# ## Figure `ch08_cost_vs_links`
#
# Cost of one forward-dynamics evaluation vs number of links.
#
# The cost of one forward-dynamics evaluation vs the number of links for ABA (O(n)), CRBA + Cholesky
# solve, the batched ABA per state, and the maximal-coordinate joint solve (5 rows per hinge: the
# dense J W Jᵀ solve and Baraff's leaves-first sparse elimination).

# %%
@figure("ch08", "cost_vs_links", "Cost of one forward-dynamics evaluation vs number of links")
def cost_vs_links(ctx):
    ns = [2, 4, 8] if ctx.quick else [2, 4, 8, 16, 32]
    K = 32 if ctx.quick else 256
    rows = {"n": ns, "aba": [], "crba_solve": [], "aba_batched": [], "maximal": [], "maximal_linear": []}
    rng = np.random.default_rng(0)
    for n in ns:
        scene, rb, red = chain_models(n)
        tree = red.tree
        q, qd, tau = (rng.normal(size=(K, n)) for _ in range(3))
        rows["aba"].append(_median(lambda: aba(tree, q[0], qd[0], tau[0])))
        rows["crba_solve"].append(_median(lambda: np.linalg.solve(crba(tree, q[0]), tau[0] - bias_forces(tree, q[0], qd[0]))))
        rows["aba_batched"].append(_median(lambda: aba_batch(tree, q, qd, tau)) / K)
        y = rb.state()
        rows["maximal"].append(_median(lambda: scene.rhs(0.0, y)))
        joints = [e for e in scene.effects if isinstance(e, RigidJoints)][0]
        joints.solver = "linear"
        rows["maximal_linear"].append(_median(lambda: scene.rhs(0.0, y)))
    fig, ax = ctx.subplots()
    for key, lab in (("aba", "ABA"), ("crba_solve", "CRBA + solve"), ("aba_batched", f"batched ABA (per state, K = {K})"),
                     ("maximal", "maximal: hinge rows + dense J W Jᵀ solve"),
                     ("maximal_linear", "maximal: leaves-first sparse solve (Baraff 1996)")):
        ax.loglog(ns, np.array(rows[key]) * 1e6, "o-", label=lab)
    ax.set_xlabel("links n [count]"), ax.set_ylabel("time per evaluation [µs]")
    ax.legend(fontsize=7, loc="upper left", bbox_to_anchor=(1.01, 1.0))     # outside: never over the data
    ctx.save(fig)
    return {k: np.asarray(v, dtype=float) for k, v in rows.items()}


# %% [markdown]
# ## Figure `ch08_ragdoll_fall`
#
# A ragdoll (11 links, damped hinges) thrown down a staircase.
#
# The 11-link ragdoll of :func:`pbanim.models.articulated.ragdoll` thrown forward over the top of a
# staircase (contact with friction at the ends of every segment, damped hinges): an animation, its
# energy (never growing) and the height of its lowest point above the tread under it.

# %%
@figure("ch08", "ragdoll_fall", "A ragdoll (11 links, damped hinges) thrown down a staircase", cost=8.5)
def ragdoll_fall(ctx):
    from pbanim.articulated.contact import ArticulatedContact, Staircase
    from pbanim.models.articulated import ragdoll_contact_points, ragdoll_down_stairs

    thrown, stairs = ragdoll_down_stairs()
    # the same scene, its impulses by the active set from the last step's contact states (PGS sweeps finding
    # the guess when the exchanges cycle: the lying ragdoll's redundant contacts left PGS at its sweep cap),
    # and a point that moves back into a riser pushed out of the riser, not lifted up to its tread
    stairs = Staircase(rise=stairs.rise, run=stairs.run, steps=stairs.steps, start=stairs.start, risers=True)
    ac = ArticulatedContact(thrown.system, list(zip(thrown.links, thrown.points)), friction=thrown.mu,
                            terrain=stairs, solver="active_set")
    tree = ac.tree
    t_end, h = (1.0, 5e-3) if ctx.quick else (3.0, 2e-3)
    res = ac.simulate(t_end, h, record_every=10 if ctx.quick else 20)
    frames = np.unique(np.linspace(0, res.y.shape[1] - 1, 6 if ctx.quick else 50).astype(int))

    def segments(y):
        from pbanim.articulated.contact import point_jacobians

        pts = ragdoll_contact_points(tree)
        P, _ = point_jacobians(tree, y[:tree.nq], [lk for lk, _ in pts], [p for _, p in pts])
        return P

    fig, ax = ctx.subplots(figsize=(5, 4))
    xs = np.linspace(-1.0, 2.8, 800)

    # the axes, the stairs and the limbs' lines are made once, in the order a fresh frame draws them; a frame
    # moves the lines and retitles (ORACLES G4: the same pixels as clearing the axes and plotting anew)
    P0 = segments(res.y[:, frames[0]])
    limbs = [ax.plot(P0[a:a + 2, 0], P0[a:a + 2, 2], "o-", color="C0", lw=3, ms=3)[0] for a in range(4, len(P0), 2)]
    pelvis = ax.plot(P0[:4, 0], P0[:4, 2], "s", color="C1", ms=4)[0]
    ax.fill_between(xs, stairs.height(xs), -1.2, step="post", color="0.8")
    edge = ax.plot(xs, stairs.height(xs), color="k", lw=1)[0]
    ax.set_xlim(-1.0, 2.8), ax.set_ylim(-1.1, 1.6), ax.set_aspect("equal")
    ax.set_xlabel("x (m)"), ax.set_ylabel("z (m)")
    ax.set_title(" ", y=1.0)              # where matplotlib puts it (nothing above the axes), without asking
    # the view never moves: what is drawn before the limbs (the figure, the axes, the stairs' fill, the ticks
    # and labels) is rendered once per resolution and shown as an image under them; the limbs, the stairs'
    # edge and the spines (drawn over the limbs) and the title stay live, in their order. The same pixels as
    # drawing every artist at every frame (checked frame by frame), a quarter of the drawing time
    show_backdrop = frozen_backdrop(fig, [fig.patch, ax.patch, *ax.collections, ax.xaxis, ax.yaxis],
                                     limbs + [pelvis, edge, ax.title, *ax.spines.values()])

    def draw(j):
        show_backdrop()
        P = segments(res.y[:, frames[j]])
        for line, a in zip(limbs, range(4, len(P), 2)):       # each limb segment: its two end points
            line.set_data(P[a:a + 2, 0], P[a:a + 2, 2])
        pelvis.set_data(P[:4, 0], P[:4, 2])
        ax.set_title(f"t = {res.t[frames[j]]:.2f} s")

    ctx.save_gif(fig, draw, len(frames), fps=10)
    fig2, ax2 = ctx.subplots()
    ax2.plot(res.t, res.diagnostics["energy"], label="energy")
    ax2.set_xlabel("t (s)"), ax2.set_ylabel("E (J)")
    ax3 = ax2.twinx()
    ax3.plot(res.t, 1e3 * res.diagnostics["min_gap"], color="C1", label="lowest point (mm)")
    ax3.set_ylabel("lowest contact point above its tread (mm)")
    ctx.save(fig2)
    return {"t": res.t, "energy": res.diagnostics["energy"], "min_gap": res.diagnostics["min_gap"],
            "frames": len(frames)}


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
