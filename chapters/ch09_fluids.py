# %% [markdown]
# # Chapter 09 — fluids: Stam's Stable Fluids, stage by stage, and what each choice costs.
#
# This file is a module (imported by `pbanim figures`) and a notebook in jupytext's percent format:
# open it in Jupyter (with jupytext) or VS Code, or write an `.ipynb` with `pbanim notebook ch09 DIR`.
# Running it draws every figure of the chapter in quick mode into `figures/`.

# %%
"""Chapter 09 — fluids: Stam's Stable Fluids, stage by stage, and what each choice costs.

Figures:

* ``smoke_plume``: hot smoke rising around a disc in a closed box (sources, buoyancy, vorticity
  confinement, MacCormack advection, projection with the obstacle): an animation and a strip of frames.
* ``taylor_green_decay``: the kinetic energy of the Taylor–Green vortex against the closed form
  E(0) e^(−4νk²t), with and without advection, at several grid sizes (ORACLES E1).
* ``projection_cost``: the divergence each projection method leaves against its time per step —
  Stam's 20 Gauss–Seidel sweeps, Jacobi, conjugate gradients, multigrid, the DCT and the sparse LU
  (ORACLES E2).
* ``advection_dissipation``: how much of a smooth blob each advection scheme loses over one trip
  across a periodic box, against the grid size (ORACLES E5).
* ``collocated_vs_mac``: the divergence Stam's collocated projection leaves (compact Laplacian, exact or 20
  Gauss–Seidel sweeps; the wide stencil) against the staggered MAC grid's, vs the grid size (ORACLES E13).
* ``lid_cavity``: the lid-driven cavity at Re = 100 settling to its steady state, and its centre-line
  velocity against Ghia, Ghia and Shin's table (ORACLES E8).
"""

from __future__ import annotations

import time

import numpy as np

from pbanim.fluids import (
    GHIA_RE100,
    Advection,
    Diffusion,
    FluidScene,
    Grid,
    Projection,
    advect_scalar_steps,
    centreline_u,
    collocated_divergence,
    lid_driven_cavity,
    project_collocated,
    smoke_plume,
    solve_cells,
    taylor_green,
    taylor_green_energy,
)
from pbanim.plotting import figure
from pbanim.plotting_gif import pinned_labels

ADVECTION_SCHEMES = ("semi_lagrangian", "cubic", "bfecc", "maccormack")
PROJECTIONS = (("gauss_seidel", {"iterations": 20}, "Gauss–Seidel 20 (Stam)"),
               ("gauss_seidel", {"iterations": 100}, "Gauss–Seidel 100"),
               ("jacobi", {"iterations": 20}, "Jacobi 20"),
               ("jacobi", {"iterations": 100}, "Jacobi 100"),
               ("cg", {"tol": 1e-6}, "CG 1e-6"),
               ("cg", {"tol": 1e-12}, "CG 1e-12"),
               ("multigrid", {"tol": 1e-12}, "multigrid 1e-12"),
               ("mgpcg", {"tol": 1e-12}, "MGPCG 1e-12"),
               ("dct", {}, "DCT (exact)"),
               ("direct", {}, "sparse LU (exact)"))


# %% [markdown]
# ## Figure `ch09_smoke_plume`
#
# Smoke and heat are injected near the floor; buoyancy lifts the hot gas, the disc splits the plume,
# vorticity confinement keeps the curls that advection would smear. The projection (conjugate gradients
# preconditioned by a multigrid V-cycle: the disc makes the DCT inapplicable) keeps the flow
# divergence-free to the solver's tolerance, in about 10 iterations whatever the grid.

# %%
@figure("ch09", "smoke_plume", "Smoke rising around an obstacle", cost=16.1)
def smoke_plume_figure(ctx):
    shape, t_end, h = ((40, 60), 1.2, 0.02) if ctx.quick else ((128, 192), 3.0, 0.01)
    every = 10
    scene = smoke_plume(shape)
    res = scene.simulate(t_end, h, frame_every=every, keep=("density",))
    frames = res.frames["density"]
    g = scene.grid
    X, Y = g.positions()
    centroid = np.array([(f * Y).sum() / max(f.sum(), 1e-300) for f in frames])
    vmax = float(frames.max())
    fig, ax = ctx.subplots(figsize=(3.6, 5.0))
    extent = (0, g.extent[0], 0, g.extent[1])
    im = ax.imshow(frames[0].T, origin="lower", extent=extent, cmap="magma", vmin=0, vmax=vmax)
    ax.contour(X, Y, g.solid.astype(float), levels=[0.5], colors="w", linewidths=1)
    ax.set_xlabel("x (m)"), ax.set_ylabel("y (m)")
    ax.set_title(" ", y=1.0)              # where matplotlib puts it (nothing above the axes), without asking
    labels = pinned_labels(fig)           # the view never moves: the axis labels placed once per resolution

    def draw(i):
        labels()
        im.set_data(frames[i].T)
        ax.set_title(f"t = {res.frame_times[i]:.2f} s")
        return (im,)

    ctx.save_gif(fig, draw, len(frames), fps=10)
    picks = np.unique(np.linspace(0, len(frames) - 1, 5).astype(int))
    fig2, axs = ctx.subplots(1, len(picks), figsize=(2.2 * len(picks), 3.4))
    for ax2, i in zip(axs, picks):
        ax2.imshow(frames[i].T, origin="lower", extent=extent, cmap="magma", vmin=0, vmax=vmax)
        ax2.contour(X, Y, g.solid.astype(float), levels=[0.5], colors="w", linewidths=0.8)
        ax2.set_title(f"t = {res.frame_times[i]:.2f} s")
        ax2.set_xlabel("x (m)"), ax2.set_ylabel("y (m)")
    ctx.save(fig2)
    d = res.diagnostics
    src = scene.stages[0]                                  # source[density]: rate × region
    injected = src.rate * g.total(src.weights) * res.t
    return {"t": res.t, "injected": injected, "frame_times": res.frame_times, "centroid_height": centroid,
            "density_in_obstacle": float(np.abs(frames[:, g.solid]).max()),
            "max_divergence": d["max_divergence"][1:], "projection_iterations": d["projection_iterations"][1:],
            "total_density": d["total_density"], "pipeline": list(scene.pipeline),
            "min_density": float(frames.min())}


# %% [markdown]
# ## Figure `ch09_taylor_green_decay`
#
# The Taylor–Green vortex decays as e^(−2νk²t): only viscosity acts, since the advection term is a
# gradient the projection removes. With diffusion and projection alone (Stokes flow) the measured rate
# matches 2νk²; with semi-Lagrangian advection the numerical dissipation adds a rate that halves with Δx.
# MacCormack's excess hardly depends on Δx: at this fixed Δt = 0.05 it is the O(Δt) error of the splitting
# (on 32²: 0.0093, 0.0046, 0.0021 for Δt = 0.05, 0.025, 0.0125).

# %%
@figure("ch09", "taylor_green_decay", "Taylor–Green vortex: kinetic energy against the closed form", cost=3.0)
def taylor_green_decay(ctx):
    nu, h, t_end = 0.05, 0.05, 2.0
    sizes = (16, 32) if ctx.quick else (16, 32, 64, 128)
    fig, ax = ctx.subplots()
    out = {"nu": nu, "k": 1.0, "sizes": list(sizes), "rate_stokes": [], "rate_advected": [],
           "rate_maccormack": []}
    for n in sizes:
        g = Grid((n, n), 2 * np.pi / n, "periodic")
        for key, adv in (("rate_stokes", None), ("rate_advected", "semi_lagrangian"),
                         ("rate_maccormack", "maccormack")):
            effects = ([Advection(adv)] if adv else []) + [Diffusion(nu, "fft"), Projection("fft")]
            res = FluidScene(g, effects, u=taylor_green(g)).simulate(t_end, h)
            e = res.diagnostics["kinetic_energy"]
            out[key].append(float(-np.polyfit(res.t, np.log(e), 1)[0] / 2))   # velocity rate = energy rate / 2
            style = {"rate_stokes": ("--", "Stokes"), "rate_advected": ("-", "semi-Lagrangian"),
                     "rate_maccormack": ("-.", "MacCormack")}[key]
            ax.semilogy(res.t, e / e[0], ls=style[0], label=f"{n}², {style[1]}")
        out.setdefault("max_divergence", []).append(float(res.diagnostics["max_divergence"].max()))
    t = np.linspace(0, t_end, 50)
    ax.semilogy(t, taylor_green_energy(1.0, nu, 1.0, t), "k:", lw=2, label="e^(−4νk²t)")
    ax.set_xlabel("t (s)"), ax.set_ylabel("E / E(0) (1)")
    ax.legend()
    ctx.save(fig)
    out["rate_exact"] = 2 * nu
    return out


# %% [markdown]
# ## Figure `ch09_projection_cost`
#
# The divergence left after one projection against its cost: Stam's fixed 20 sweeps are cheap and
# leave most of the divergence of the smooth modes; conjugate gradients buy accuracy with iterations;
# the DCT is exact at the price of two transforms.

# %%
@figure("ch09", "projection_cost", "Divergence left vs time per projection, per method", cost=4.0)
def projection_cost(ctx):
    n = 64 if ctx.quick else 256
    g = Grid((n, n), 1.0 / n, "walls")
    rng = np.random.default_rng(7)
    X, Y = g.positions()
    phi = np.sin(2 * np.pi * X) * np.cos(3 * np.pi * Y) / n + 0.1 * rng.standard_normal(X.shape) / n
    u = g.gradient(phi)              # a pure gradient (smooth + rough modes): the projection removes all of it
    b = -g.divergence(u)
    div0 = float(np.abs(b).max())
    names, divs, times, iters = [], [], [], []
    for method, opts, label in PROJECTIONS:
        # one timed solve; two (the faster kept) where the first builds a cache the second finds: the LU
        # factorization, the DCT's eigenvalues, the multigrid hierarchy. The same p every time (the figure plots
        # its divergence once; the time is a point on a log axis: it was the mean of 3 after a warm-up solve)
        dt = float("inf")
        for _ in range(2 if method in ("direct", "dct", "multigrid", "mgpcg") else 1):
            t0 = time.perf_counter()
            p, info = solve_cells(g, b, 0.0, 1.0, method, **opts)
            dt = min(dt, time.perf_counter() - t0)
        w = [c - gp for c, gp in zip(u, g.gradient(p))]
        names.append(label), divs.append(float(np.abs(g.divergence(w)).max())), times.append(dt)
        iters.append(info.iterations)
    fig, ax = ctx.subplots()
    ax.loglog(np.array(times) * 1e3, np.maximum(divs, 1e-17), "o")
    for x, y, s in zip(times, divs, names):
        ax.annotate(s, (x * 1e3, max(y, 1e-17)), textcoords="offset points", xytext=(4, 3), fontsize=7)
    ax.axhline(div0, color="grey", ls=":", label="before projection")
    ax.set_xlabel("time per projection (ms)"), ax.set_ylabel("‖D u‖∞ left (1/s)")
    ax.legend()
    ctx.save(fig)
    return {"n": n, "methods": names, "divergence": np.array(divs), "time": np.array(times),
            "iterations": np.array(iters), "divergence_before": div0}


# %% [markdown]
# ## Figure `ch09_advection_dissipation`
#
# A Gaussian blob crosses a periodic box once (diagonal velocity, CFL 0.4, so no step is a whole-cell
# shift). Linear semi-Lagrangian advection loses amplitude at first order in Δx; the monotone cubic,
# BFECC and MacCormack much less.

# %%
def blob_crossing(n: int, method: str, cfl: float = 0.4):
    """(error ‖s − s_exact‖∞, relative loss of ∫s², ∫s drift) after one crossing of the unit periodic box."""
    g = Grid((n, n), 1.0 / n, "periodic")
    X, Y = g.positions()
    s0 = np.exp(-((X - 0.5) ** 2 + (Y - 0.5) ** 2) / (2 * 0.1 ** 2))
    u = [np.full(g.face_shape(0), 1.0), np.full(g.face_shape(1), 1.0)]
    h = cfl / n
    steps = int(round(1.0 / h))
    h = 1.0 / steps
    s = advect_scalar_steps(g, s0, u, h, steps, method)   # advect_scalar `steps` times, its departure points once
    return (float(np.abs(s - s0).max()), float(1 - (s ** 2).sum() / (s0 ** 2).sum()),
            float(abs(s.sum() - s0.sum()) / s0.sum()))


@figure("ch09", "advection_dissipation", "Numerical dissipation of each advection scheme vs grid size", cost=3.9)
def advection_dissipation(ctx):
    # full: up to 128² (the slopes in Δx are plain over three octaves; 256², 4 096 steps on 65 536 cells, was
    # 7/8 of the figure's 36 s: the cost grows as n³)
    sizes = (16, 32, 64) if ctx.quick else (16, 32, 64, 128)
    out = {"sizes": list(sizes)}
    fig, (ax, ax2) = ctx.subplots(1, 2, figsize=(10, 3.8))
    for m in ADVECTION_SCHEMES:
        runs = np.array([blob_crossing(n, m) for n in sizes])
        out[m] = {"error": runs[:, 0], "energy_loss": runs[:, 1], "mass_drift": runs[:, 2]}
        ax.loglog(1.0 / np.array(sizes), runs[:, 1], "o-", label=m)
        ax2.loglog(1.0 / np.array(sizes), runs[:, 0], "o-", label=m)
    ax.set_xlabel("Δx (m)"), ax.set_ylabel("lost fraction of ∫s² (1)")
    ax2.set_xlabel("Δx (m)"), ax2.set_ylabel("max error after one crossing (1)")
    ax.legend(), ax2.legend()
    ctx.save(fig)
    return out


# %% [markdown]
# ## Figure `ch09_collocated_vs_mac`
#
# The same field — the Taylor–Green vortex plus a gradient — projected on Stam's collocated grid and on
# the MAC grid. With centred D and G, solving the compact Laplacian (even exactly) leaves an O(Δx²)
# divergence, and Stam's 20 sweeps leave most of it at fine grids; the wide stencil D_c G_c removes it but
# decouples odd and even cells; the MAC grid's D G is the compact Laplacian and its projection is exact.

# %%
@figure("ch09", "collocated_vs_mac", "Divergence left by the collocated and the MAC projections vs grid size")
def collocated_vs_mac(ctx):
    sizes = (16, 32, 64) if ctx.quick else (16, 32, 64, 128, 256)
    k = 2 * np.pi
    rows = {"collocated, compact, exact": [], "collocated, compact, GS 20 (Stam)": [],
            "collocated, wide, exact": [], "MAC, exact": []}
    before = []
    for n in sizes:
        g = Grid((n, n), 1.0 / n, "periodic")
        X, Y = g.positions()
        u = [-k * np.sin(k * X) * np.cos(k * Y) - k * np.sin(2 * k * X) + np.cos(k * X) * np.sin(k * Y),
             -k * np.cos(k * X) * np.sin(k * Y) - np.sin(k * X) * np.cos(k * Y)]
        before.append(float(np.abs(collocated_divergence(g, u)).max()))
        for key, (m, stencil, kw) in zip(list(rows)[:3], (("spectral", "compact", {}),
                                                          ("gauss_seidel", "compact", {"iterations": 20}),
                                                          ("spectral", "wide", {}))):
            w, _ = project_collocated(g, u, m, stencil, **kw)
            rows[key].append(float(np.abs(collocated_divergence(g, w)).max()))
        phi = np.cos(k * X) * np.cos(k * Y) + 0.5 * np.cos(2 * k * X)
        um = [a + b for a, b in zip(taylor_green(g), g.gradient(phi))]
        p, _ = solve_cells(g, -g.divergence(um), 0.0, 1.0, "fft")
        rows["MAC, exact"].append(float(np.abs(g.divergence([a - b for a, b in zip(um, g.gradient(p))])).max()))
    fig, ax = ctx.subplots()
    dx = 1.0 / np.array(sizes)
    for key, v in rows.items():
        ax.loglog(dx, np.maximum(v, 1e-16), "o-", label=key)
    ax.loglog(dx, before, "k:", label="before projection")
    ax.set_xlabel("Δx (m)"), ax.set_ylabel("‖D u‖∞ left (1/s)")
    ax.legend()
    ctx.save(fig)
    return {"sizes": list(sizes), "before": before, **{k_: np.array(v) for k_, v in rows.items()}}


# %% [markdown]
# ## Figure `ch09_lid_cavity`
#
# The unit box whose top wall slides at 1 m/s, Re = 100, from rest. The change per step dies out (a
# steady state) and the velocity on the vertical centre line follows Ghia, Ghia and Shin's table.

# %%
@figure("ch09", "lid_cavity", "Lid-driven cavity, Re = 100: steady centre-line velocity vs Ghia et al.", cost=6.1)
def lid_cavity(ctx):
    n, h, t_end = (24, 0.04, 10.0) if ctx.quick else (64, 0.01, 20.0)
    scene = lid_driven_cavity(n, 100.0)
    steps = int(round(t_end / h))
    change, times = [], []
    for k in range(steps):
        before = [c.copy() for c in scene.state.u]
        scene.step(h)
        change.append(max(float(np.abs(a - b).max()) for a, b in zip(scene.state.u, before)) / h)
        times.append(scene.state.t)
    y, u = centreline_u(scene)
    ref = np.interp(GHIA_RE100[:, 0], y, u)
    fig, (ax, ax2) = ctx.subplots(1, 2, figsize=(10, 3.8))
    ax.plot(u, y, "-", label=f"pbanim {n}²")
    ax.plot(GHIA_RE100[:, 1], GHIA_RE100[:, 0], "ks", ms=4, label="Ghia et al. 1982")
    ax.set_xlabel("u at x = 0.5 (m/s)"), ax.set_ylabel("y (m)")
    ax.legend()
    ax2.semilogy(times, change)
    ax2.set_xlabel("t (s)"), ax2.set_ylabel("‖u¹ − u⁰‖∞ / Δt (m/s²)")
    ctx.save(fig)
    return {"n": n, "y": y, "u": u, "ghia_y": GHIA_RE100[:, 0], "ghia_u": GHIA_RE100[:, 1], "u_at_ghia": ref,
            "change_per_step": np.array(change), "t": np.array(times),
            "max_divergence": float(np.abs(scene.grid.divergence(scene.state.u)).max())}


# %% [markdown]
# ## Draw the figures
#
# As a script or in a notebook kernel, draw this chapter's figures (quick mode) into `figures/`.

# %%
if __name__ == "__main__":
    from pathlib import Path

    from pbanim.plotting import figures_of, run_figure

    for _key, _spec in figures_of({"ch09"}).items():
        print(_key, [p.name for p in run_figure(_spec, Path("figures"), quick=True)[1]])
