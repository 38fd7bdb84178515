# %% [markdown]
# # Chapter 10 — design of an articulated motion: a chain thrown so that its tip lands on a target.
#
# This file is a module (imported by `pbanim figures`) and a notebook in jupytext's percent format.
# Running it draws the figure in quick mode into `figures/`.

# %%
"""Chapter 10 — design of an articulated motion (issue 31): ∂S/∂u of a chain in flight from the derivatives
of ABA, and a shooting design.

Figures:

* ``thrown_chain``: a planar chain of rods on a free base (two sliders and a hinge), with springy joints,
  thrown so that the tip of its last rod is at a target at time T. S(t, u) and ∂S/∂u (u: the launch
  velocity and spin) come from RK4 on the state and its variational equation, whose blocks are the
  analytical derivatives ∂q̈/∂q, ∂q̈/∂q̇, H⁻¹ of ABA (:func:`pbanim.articulated.aba_derivatives`); the
  derivative is checked against a centred difference of S (δ = 1e-3), and min-norm updates (chapter 10's
  differential control) aim the throw. A strip (the chain at eight times of the designed flight, the tip
  paths of every iterate) and a GIF of the flight (ORACLES H9, L1).
"""

from __future__ import annotations

import numpy as np

from pbanim.articulated import PlanarKernel
from pbanim.derivatives import central_jacobian
from pbanim.design.articulated import aim_chain, simulate_chain, thrown_chain
from pbanim.plotting import figure
from pbanim.plotting_gif import blit_canvas

LINKS, LENGTH = 3, 0.3
TIP = (LINKS + 1, np.array([LENGTH, 0.0, 0.0]))       # the end of the last rod (link index, link-frame point)
TARGET = np.array([1.5, 1.5])                          # a bar the tip must reach at T


def chain_problem(quick: bool = True):
    """The figure's throw: tree, start (q0, q̇0), springs, T, h (quick: a coarser RK4 step)."""
    tree = thrown_chain(LINKS, LENGTH)
    q0 = np.array([0.0, 1.0, 0.3, 0.4, -0.3])
    qd0 = np.array([2.0, 3.0, 2.0, 0.0, 0.0])
    stiffness = np.array([0.0, 0.0, 0.0, 5.0, 5.0])
    return tree, q0, qd0, stiffness, 0.8, (0.05 if quick else 0.01)


def _polyline(kernel, q):
    """The chain's joints and tip in the plane (LINKS + 1, 2)."""
    o = kernel.kinematics(q)["o"][2:]
    tip = kernel.points(q, [TIP[0]], TIP[1][None])
    return np.vstack([o, tip])


# %% [markdown]
# ## Figure `ch10_thrown_chain`
#
# A chain thrown so that its tip is at a target at T.

# %%
@figure("ch10", "thrown_chain", "A chain thrown so that its tip is at a target at T (∂S/∂u from ABA's derivatives)",
        cost=3.0)
def thrown_chain_figure(ctx):
    """Aim a springy 3-rod chain: min-norm updates of (vx, vy, ω) until |p_tip(T) − p*| ≤ 1e-8."""
    tree, q0, qd0, k, T, h = chain_problem(ctx.quick)
    res = aim_chain(tree, q0, qd0, T, h, TIP[0], TIP[1], TARGET, tol=1e-8, stiffness=k)
    first = res.flights[0]                               # the throw from qd0, with ∂S/∂u (aim_chain's first iterate)

    def S(u):
        qd = qd0.copy()
        qd[:3] = u
        fl = simulate_chain(tree, q0, qd, T, h, stiffness=k, sensitivities=False)
        return fl.y[-1]

    fd_error = float(np.abs(central_jacobian(S, qd0[:3], eps=1e-3) - first.dy_du[-1]).max())
    kernel = PlanarKernel(tree)
    nq = tree.nq
    fig, ax = ctx.subplots(figsize=(8, 4))
    for j, fl in enumerate(res.flights):                 # the tip path of every iterate, the last darkest (the
        P, _ = fl.point(TIP[0], TIP[1])                  # states of a run with ∂S/∂u are those of one without)
        ax.plot(P[:, 0], P[:, 1], lw=1, color="C0", alpha=0.3 + 0.7 * j / max(1, len(res.history) - 1))
    fl = res.flight
    for i, a in zip(np.linspace(0, len(fl.t) - 1, 8).astype(int), np.linspace(0.25, 1.0, 8)):
        L = _polyline(kernel, fl.y[i, :nq])
        ax.plot(L[:, 0], L[:, 1], "-o", color="C1", ms=3, lw=2, alpha=a)
    ax.plot(*TARGET, "r*", ms=14)
    ax.set_xlim(-0.6, 2.6), ax.set_ylim(0.0, 2.6)
    ax.set_aspect("equal"), ax.set_xlabel("x (m)"), ax.set_ylabel("y (m)")
    ctx.save(fig, "_strip")
    fig, ax = ctx.subplots(figsize=(8, 4))
    ax.set_xlim(-0.6, 2.6), ax.set_ylim(0.0, 2.6), ax.set_aspect("equal")
    ax.set_xlabel("x (m)"), ax.set_ylabel("y (m)")
    ax.plot(*TARGET, "r*", ms=14)
    line, = ax.plot([], [], "-o", color="C1", ms=3, lw=2)
    trail, = ax.plot([], [], lw=1, color="C0")
    # the view never moves and the chain and its trail are the last artists drawn, inside the axes: the rest
    # (axes, ticks, labels, target) is rendered once and restored, a frame draws only the two lines (the bytes
    # of a full draw, ORACLES G5)
    blit_canvas(fig, lambda: [line, trail])
    Ptip, _ = fl.point(TIP[0], TIP[1])
    frames = 8 if ctx.quick else 48

    def update(j):
        i = min(int(j / (frames - 1) * (len(fl.t) - 1)), len(fl.t) - 1)
        L = _polyline(kernel, fl.y[i, :nq])
        line.set_data(L[:, 0], L[:, 1]), trail.set_data(Ptip[:i + 1, 0], Ptip[:i + 1, 1])
        return line, trail

    ctx.save_gif(fig, update, frames=frames, fps=10)
    return {"u": res.u, "residuals": np.array(res.residuals), "success": res.success, "tip": Ptip[-1],
            "target": TARGET, "fd_error": fd_error, "T": T, "h": h,
            "dS_du_scale": float(np.abs(first.dy_du[-1]).max())}
