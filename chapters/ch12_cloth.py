# %% [markdown]
# # Chapter 12 — cloth: stiff systems at scale, by large steps, small steps and stiff solvers.
#
# This file is a module (imported by `pbanim figures`) and a notebook in jupytext's percent format:
# open it in Jupyter (with jupytext) or VS Code, or write an `.ipynb` with `pbanim notebook ch12 DIR`.
# Running it draws every figure of the chapter in quick mode into `figures/`.

# %%
"""Chapter 12 — cloth: stiff systems at scale, by large steps, small steps and stiff solvers.

Figures:

* ``drape``: a sheet pinned at two corners falls onto a sphere above the ground, by Baraff & Witkin's
  large steps at h = 1/60 s (stretch, shear and bend conditions; the constraint filter holds the pins and
  the contacts): an animation and a strip of frames (ORACLES J3).
* ``work_precision``: final-position error against wall time for large steps, Newton, XPBD with substeps,
  pbanim's RODAS4 and Radau IIA and scipy's BDF, Radau and odeint, on the benchmark's stiff spring sheet
  (``pbanim bench cloth``; ORACLES J4 for XPBD's approach to implicit Euler).
* ``stable_step``: the largest stable step of symplectic Euler, XPBD and large steps against the stretch
  stiffness: the explicit step shrinks like k^(−1/2), the two others do not (the point of large steps).
* ``step_cost``: wall time per step at h = 1/60 s against N² for large steps (with their CG iterations) and
  XPBD.
"""

from __future__ import annotations

import numpy as np

from pbanim.bench import one_blas_thread
from pbanim.bench.cloth import METHODS, largest_stable_step, step_costs, work_precision
from pbanim.cloth import Cloth, Ground, Sheet, Sphere, large_step
from pbanim.plotting import figure
from pbanim.plotting_gif import frozen_backdrop


def _frozen_axes3d(fig, ax, moving):
    """The figure, the 3-D axes' face, panes, grid, ticks and labels — drawn before the data and the title and
    the same in every frame of a fixed view — rendered once at the figure's resolution (``frozen_backdrop``,
    ORACLES G5) and copied back first in each frame, the 3-D axis then switched off: a frame draws only
    ``moving`` (and what the axes hold besides) over them, the pixels of a full draw without laying out the
    three axes again. Called again at another resolution (its backdrop replaces the one before)."""
    for art in list(fig.artists):                                # the backdrop of another resolution
        art.remove()
    ax.set_axis_on(), fig.patch.set_visible(True), ax.patch.set_visible(True)
    frozen_backdrop(fig, [fig.patch, ax.patch], moving)()
    ax.set_axis_off()


# %% [markdown]
# ## Figure `ch12_drape`
#
# A 1 m sheet of Baraff–Witkin triangles, pinned at its two top corners, falls onto a sphere. Each step
# solves (M − hD − h²K) Δv = h(f₀ + hKv₀) by conjugate gradients in the filtered subspace: pinned
# particles have S = 0, particles touching the sphere or the ground S = I − nnᵀ. The pins do not move (bit
# for bit) and no particle ends inside the sphere by more than a step's approach.

# %%
# The CG's stop, a relative preconditioned residual: 5·10⁻⁴, not large_step's default 10⁻⁴, 191 iterations a
# step on the 24 × 24 sheet instead of 248. Its error is far below the step's own truncation error (ORACLES J15:
# ≤ 0.4 % of it in x and v at six states of the run); the frames move by what roundoff already moves them: at 10⁻⁴ one ulp
# added to one coordinate at t = 0 moves the sheet by up to 3.1 cm (6.5 mm mean over the particles) within
# the 6 s, 5·10⁻⁴ moves it by up to 3.2 cm (8.9 mm mean), 10⁻³ by up to 7.9 cm (12 mm mean).
DRAPE_TOL = 5e-4


@figure("ch12", "drape", "A sheet draping over a sphere by large steps (h = 1/60 s)", cost=16.3)
def drape(ctx):
    n, frames, every = (10, 12, 6) if ctx.quick else (24, 90, 4)
    sphere = Sphere([0.0, 0.0, -0.45], 0.3)
    cloth = Cloth(Sheet(n, pins="corners"), model="bw", stretch=500.0, shear=50.0, bend=1e-3, damping=0.02,
                  colliders=[sphere, Ground(-0.9)])
    y, h = cloth.state(), 1.0 / 60.0
    xs, energy, iters = [cloth.sheet.x0.copy()], [cloth.energy(y)], []
    for k in range(frames * every):
        y, sol = large_step(cloth, y, h, tol=DRAPE_TOL)
        iters.append(sol.iterations)
        if (k + 1) % every == 0:
            xs.append(y[:cloth.n].reshape(-1, 3).copy())
            energy.append(cloth.energy(y))
    xs = np.array(xs)
    tri = cloth.sheet.triangles
    u, w = np.meshgrid(np.linspace(0, 2 * np.pi, 16), np.linspace(0, np.pi, 9))
    ball = [sphere.center[i] + sphere.radius * c for i, c in
            enumerate((np.cos(u) * np.sin(w), np.sin(u) * np.sin(w), np.cos(w)))]

    def panel(a, i):
        a.plot_wireframe(*ball, color="0.5", linewidth=0.4)
        a.plot_trisurf(xs[i][:, 0], xs[i][:, 1], xs[i][:, 2], triangles=tri, color="tab:blue", alpha=0.8,
                       linewidth=0.2, edgecolor="k")
        a.set_xlim(-0.6, 0.6), a.set_ylim(-0.6, 0.6), a.set_zlim(-0.9, 0.1)
        a.set_xlabel("x (m)"), a.set_ylabel("y (m)"), a.set_zlabel("z (m)")
        a.set_title(f"t = {i * every * h:.2f} s")
    fig, ax = ctx.subplots(figsize=(4.4, 4.0), subplot_kw={"projection": "3d"})

    backdrop = {}

    def draw(i):
        # the sheet and the ball of the frame before are removed, the axes stay: their ticks, panes and labels
        # are not made anew per frame (clearing the axes did: half of the GIF's time), the pixels are the same
        for art in list(ax.collections):
            art.remove()
        panel(ax, i)
        if backdrop.get("dpi") != fig.dpi:
            _frozen_axes3d(fig, ax, [*ax.collections, ax.title])
            backdrop["dpi"] = fig.dpi
        return ()

    # the GIF shows every other recorded frame at half the rate (the same 6 s of motion; each 3-D frame costs
    # about 0.2 s to render, 91 frames were a third of the figure's time); the data keep every recorded frame
    gif = range(0, len(xs), 2) if not ctx.quick else range(len(xs))
    ctx.save_gif(fig, lambda j: draw(gif[j]), len(gif), fps=5 if not ctx.quick else 10)
    picks = np.unique(np.linspace(0, len(xs) - 1, 4).astype(int))
    fig2, axs = ctx.subplots(1, len(picks), figsize=(3.0 * len(picks), 3.0), subplot_kw={"projection": "3d"})
    for ax2, i in zip(axs, picks):
        panel(ax2, i)
    ctx.save(fig2)
    pins = cloth.pinned
    return {"times": np.arange(len(xs)) * every * h, "energy": np.array(energy),
            "cg_iterations": np.array(iters),
            "pin_motion": float(np.abs(xs[:, pins] - cloth.sheet.x0[pins]).max()),
            "min_sphere_distance": float(min(sphere.signed_distance(x)[0].min() for x in xs)),
            "min_height": float(xs[:, :, 2].min())}


# %% [markdown]
# ## Figure `ch12_work_precision`
#
# Error of the final free positions against a scipy Radau reference (rtol 10⁻⁸), against wall time. Large
# steps and XPBD are first order (implicit Euler and its position-based cousin); the stiff ODE solvers
# reach small errors, at a cost per step set by a sparse factorization. Runs past their budget are left off.

# %%
@figure("ch12", "work_precision", "Work-precision on a stiff spring sheet: large steps, XPBD, stiff solvers",
        cost=14.3)
def work_precision_figure(ctx):
    # the budget (CPU s per run) only stops a runaway method: quick runs take 0.01-0.3 s each here, and a 1.5 s
    # budget once cut the large steps' second point in a loaded test run (the test needs two points)
    n, budget = (8, 10.0) if ctx.quick else (16, 20.0)
    with one_blas_thread():          # as the benchmark times them: a second BLAS thread only waits for a busy core
        wp = work_precision(n, budget, ctx.quick)
    fig, ax = ctx.subplots(figsize=(5.2, 3.8))
    out = {"n": n}
    for m in METHODS:
        pts = [(t, e) for _, e, t in wp.get(m, []) if e is not None]
        if pts:
            t, e = np.array(pts).T
            ax.loglog(t, np.maximum(e, 1e-16), "o-" if m.startswith(("large", "Newton", "XPBD", "pbanim")) else "s--",
                      label=m)
            out[m] = {"time": t, "error": e}
    ax.set_xlabel("wall time (s)"), ax.set_ylabel("max position error (m)")
    ax.set_title(f"N = {n} ({3 * n * n} unknowns)")
    ax.legend(fontsize=6)
    ctx.save(fig)
    return out


# %% [markdown]
# ## Figure `ch12_stable_step`
#
# Symplectic Euler is stable below h ≈ 2/ω_max, ω_max ∝ √k: ten times stiffer, about three times
# smaller step. Large steps (implicit Euler, linearized) and XPBD do not care.

# %%
@figure("ch12", "stable_step", "Largest stable step vs stiffness per method", cost=4.4)
def stable_step(ctx):
    ks = (1e2, 1e3, 1e4) if ctx.quick else (1e1, 1e2, 1e3, 1e4, 1e5)
    n = 6 if ctx.quick else 8
    out = {"k": np.array(ks)}
    fig, ax = ctx.subplots(figsize=(4.6, 3.4))
    for m in ("symplectic Euler", "XPBD", "large steps"):
        hs = np.array([largest_stable_step(m, k, n) for k in ks])
        out[m] = hs
        ax.loglog(ks, hs, "o-", label=m)
    ax.set_xlabel("stretch stiffness k (N/m)"), ax.set_ylabel("largest stable h (s)")
    ax.legend(fontsize=7)
    ctx.save(fig)
    return out


# %% [markdown]
# ## Figure `ch12_step_cost`
#
# The cost of one step at h = 1/60 s against the number of particles. XPBD's sweeps are linear in N²
# (plus a fixed Python cost per colour); the large step's CG needs more iterations on a finer sheet
# (Jacobi preconditioning: ∝ N), so its cost grows faster than N² while each iteration is linear.

# %%
@figure("ch12", "step_cost", "Cost per step vs N² (large steps, XPBD)", cost=5.0)
def step_cost(ctx):
    sizes = (8, 16, 24) if ctx.quick else (16, 32, 64)
    with one_blas_thread():          # as the benchmark times them
        costs = step_costs(sizes, repeats=1 if ctx.quick else 3)
    n2 = np.array(sizes, dtype=float) ** 2
    ls = np.array([costs[n][0] for n in sizes])
    its = np.array([costs[n][1] for n in sizes], dtype=float)
    xp = np.array([costs[n][2] for n in sizes])
    fig, ax = ctx.subplots(figsize=(4.6, 3.4))
    ax.loglog(n2, ls, "o-", label="large step")
    ax.loglog(n2, ls / its, "o:", label="large step per CG iteration")
    ax.loglog(n2, xp, "s-", label="XPBD 1 × 10 sweeps")
    ax.set_xlabel("particles N² (count)"), ax.set_ylabel("wall time per step (s)")
    ax.legend(fontsize=7)
    ctx.save(fig)
    return {"n2": n2, "large_step": ls, "cg_iterations": its, "xpbd": xp}
