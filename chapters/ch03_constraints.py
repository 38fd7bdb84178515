# %% [markdown]
# # Chapter 03 — constrained dynamics: Lagrange multipliers, the KKT system, Baumgarte stabilization.
#
# This file is a module (imported by `pbanim figures`) and a notebook in jupytext's percent format:
# open it in Jupyter (with jupytext) or VS Code, or write an `.ipynb` with `pbanim notebook ch03 DIR`.
# Running it draws every figure of the chapter in quick mode into `figures/`.

# %%
"""Chapter 03 — constrained dynamics: Lagrange multipliers, the KKT system, Baumgarte stabilization.

Figures:

* ``bead_tension``: bead on a wire released from horizontal; simulated −λR against m(v²/R + g cos θ) at the
  simulated state and the energy closed form 3mg cos θ (ORACLES B1).
* ``drift``: constraint error |C(t)| of a swinging chain for no feedback, Baumgarte and projection (B2).
* ``baumgarte_stability``: spectral radius of the discrete feedback map over (ω_b h, ζ) for symplectic
  Euler and RK4, with simulated outcomes overlaid (B2).
* ``chain_tension``: hanging chain, masses alternating 1 : 1000, tension vs g·Σ(masses below) (B3).
* ``swinging_chain``: a 100-link chain released horizontal (projection, linear-time solver).
* ``cloth``: a cloth patch of rods pinned at two corners, falling under gravity.
* ``solver_cost``: per-step cost (assembly + λ) vs n for every solver, log-log (Baraff 1996).
* ``work_precision``: drift and energy error vs wall time for none / Baumgarte / projection.
"""

from __future__ import annotations

import numpy as np

from pbanim.bench.constraints import SOLVER_LIST, loglog_slope, step_costs, work_precision
from pbanim.constraints import (Constraints, OnPlane, baumgarte_spectral_radius, baumgarte_stability_limit,
                                solve_multipliers)
from pbanim.errors import SimulationDiverged
from pbanim.models.constrained import bead_on_circle, cloth_patch, hanging_chain
from pbanim.particles import Gravity, ParticleSystem
from pbanim.plotting import figure
from pbanim.scene import Scene


# %% [markdown]
# ## Figure `ch03_bead_tension`
#
# Bead on a wire: simulated λ vs the analytic tension.
#
# Bead on a wire released from horizontal; simulated −λR against m(v²/R + g cos θ) at the simulated
# state and the energy closed form 3mg cos θ (ORACLES B1).

# %%
@figure("ch03", "bead_tension", "Bead on a wire: simulated λ vs the analytic tension", cost=5.0)
def bead_tension(ctx):
    h = 2e-3 if ctx.quick else 5e-4
    mod = bead_on_circle(radius=1.0, mass=1.0, g=9.81, theta0=np.pi / 2)
    res = Scene(mod.system, [Gravity(mod.g), Constraints(mod.constraints)]).simulate(3.0, h, "rk4")
    R = np.linalg.norm(res.y[:2].T, axis=1)
    T_sim = -res.diagnostics["lam"][:, 0] * R
    T_formula = np.array([mod.info["tension"](y) for y in res.y.T])
    theta = np.array([mod.info["theta"](y) for y in res.y.T])
    T_energy = 3 * 9.81 * np.cos(theta)  # m(v²/R + g cos θ) with v² = 2gR cos θ (released at θ₀ = π/2)
    fig, ax = ctx.subplots()
    ax.plot(res.t, T_energy, "k-", lw=2.5, alpha=0.3, label="closed form 3mg cos θ (energy)")
    ax.plot(res.t, T_formula, "C1--", label="m(v²/R + g cos θ) at the simulated state")
    ax.plot(res.t[::25], T_sim[::25], "o", ms=3, mfc="none", color="C0", label=f"simulated −λR (RK4, h = {h} s)")
    ax.axhline(3 * 9.81, color="C3", lw=0.8, ls=":", label="3mg (bottom)")
    ax.set(xlabel="t (s)", ylabel="rod tension (N)", title="Bead on a circle released from horizontal (m = 1 kg, R = 1 m)")
    ax.legend(loc="lower right")
    ctx.save(fig)
    return {"t": res.t, "T_sim": T_sim, "T_formula": T_formula, "T_energy": T_energy, "mg": 9.81,
            "rel_err_formula": float(np.max(np.abs(T_sim - T_formula)) / np.max(np.abs(T_formula))),
            "rel_err_energy": float(np.max(np.abs(T_sim - T_energy)) / (3 * 9.81)), "T_max": float(T_sim.max())}


# %% [markdown]
# ## Figure `ch03_drift`
#
# Constraint drift |C(t)|: none vs Baumgarte vs projection.
#
# Constraint error |C(t)| of a swinging chain for no feedback, Baumgarte and projection (B2).

# %%
@figure("ch03", "drift", "Constraint drift |C(t)|: none vs Baumgarte vs projection")
def drift(ctx):
    n, t_end, h = (3, 2.0, 1e-2) if ctx.quick else (5, 5.0, 1e-2)
    mod = hanging_chain(n, link_length=1.0 / n, angle=np.pi / 2)
    out, series = {}, {}
    for label, kw in (("none", {}), ("baumgarte", {"natural_frequency": 20.0, "damping_ratio": 1.0}),
                      ("projection", {})):
        eff = Constraints(mod.constraints, stabilization=label, **kw)
        res = Scene(mod.system, [Gravity(mod.g), eff]).simulate(t_end, h, "rk4")
        series[label] = (res.t, res.diagnostics["C_max"])
        out[f"C_{label}"] = res.diagnostics["C_max"]
        out[f"final_{label}"] = float(res.diagnostics["C_max"][-1])
        out[f"max_{label}"] = float(res.diagnostics["C_max"].max())
    fig, ax = ctx.subplots()
    names = {"none": "none (k_s = k_d = 0)", "baumgarte": "Baumgarte ω_b = 20 rad/s, ζ = 1",
             "projection": "post-step projection"}
    for label, (t, C) in series.items():
        ax.semilogy(t, np.maximum(C, 1e-18), label=names[label])
    ax.set(xlabel="t (s)", ylabel="max |C| with C = ½(|d|² − L²) (m²)", ylim=(1e-18, 1),
           title=f"Swinging {n}-link chain, RK4 h = {h} s")
    ax.legend(loc="center right")
    ctx.save(fig)
    out["t"] = series["none"][0]
    return out


def _plane_outcome(method, wh, zeta, steps, h=0.01, C0=1e-3):
    ps = ParticleSystem([[0.0, C0]], [[0.3, 0.0]], masses=1.0)
    eff = Constraints([OnPlane([0], [0.0, 0.0], [0.0, 1.0])], stabilization="baumgarte",
                      natural_frequency=wh / h, damping_ratio=zeta, max_violation=1.0)
    try:
        res = Scene(ps, [Gravity(), eff]).simulate(steps * h, h, method, record_every=steps)
    except SimulationDiverged:
        return True
    return bool(res.diagnostics["C_max"][-1] > C0)


# %% [markdown]
# ## Figure `ch03_baumgarte_stability`
#
# Baumgarte feedback's own stability: ρ of the discrete map vs simulation.
#
# Spectral radius of the discrete feedback map over (ω_b h, ζ) for symplectic Euler and RK4, with
# simulated outcomes overlaid (B2).

# %%
@figure("ch03", "baumgarte_stability", "Baumgarte feedback's own stability: ρ of the discrete map vs simulation",
        cost=6.0)
def baumgarte_stability(ctx):
    nw, nz = (40, 25) if ctx.quick else (90, 50)
    sims = (5, 3, 150) if ctx.quick else (9, 5, 400)
    zetas = np.linspace(0.0, 2.0, nz)
    fig, axes = ctx.subplots(1, 2, figsize=(12, 5))
    fig.subplots_adjust(wspace=0.35, bottom=0.25)
    out = {}
    for ax, method, wmax in zip(axes, ("symplectic_euler", "rk4"), (2.2, 3.4)):
        whs = np.linspace(0.02, wmax, nw)
        WH, Z = np.meshgrid(whs, zetas)
        rho = baumgarte_spectral_radius(method, WH, Z)
        im = ax.pcolormesh(WH, Z, np.log10(rho), cmap="RdBu_r", vmin=-1, vmax=1, shading="auto")
        ax.contour(WH, Z, rho, levels=[1.0 + 1e-9], colors="k", linewidths=1.5)  # ζ = 0 symplectic: ρ ≡ 1
        pts = []
        for wh in np.linspace(0.15, wmax - 0.1, sims[0]):
            for z in np.linspace(0.1, 1.9, sims[1]):
                r = float(baumgarte_spectral_radius(method, wh, z))
                grew = _plane_outcome(method, wh, z, sims[2])
                pts.append((wh, z, r, grew))
        pts = np.array(pts, float)
        grew = pts[:, 3] > 0
        ax.plot(pts[~grew, 0], pts[~grew, 1], "o", mfc="none", mec="k", label="simulated: |C| decays")
        ax.plot(pts[grew, 0], pts[grew, 1], "x", color="k", label="simulated: |C| grows / diverges")
        lim = baumgarte_stability_limit(method, 1.0)
        ax.axvline(lim, color="C2", ls="--", lw=1, label=f"ζ = 1 limit ω_b h = {lim:.3f}")
        ax.set(xlabel="ω_b h (1)", ylabel="damping ratio ζ (1)", title=f"{method}: log₁₀ ρ (black: ρ = 1)")
        ax.legend(loc="upper center", bbox_to_anchor=(0.5, -0.14), ncol=2, fontsize=7)
        fig.colorbar(im, ax=ax, label="log₁₀ spectral radius (1)")
        clear = np.abs(pts[:, 2] - 1) > 0.02
        out[method] = {"rho": rho, "omega_h": whs, "zeta": zetas, "points": pts, "limit_zeta1": lim,
                       "agreement": float(np.mean((pts[clear, 2] > 1) == grew[clear]))}
    ctx.save(fig)
    return out


# %% [markdown]
# ## Figure `ch03_chain_tension`
#
# Hanging chain (masses 1 : 1000): tension vs g·Σ(masses below).
#
# Hanging chain, masses alternating 1 : 1000, tension vs g·Σ(masses below) (B3).

# %%
@figure("ch03", "chain_tension", "Hanging chain (masses 1 : 1000): tension vs g·Σ(masses below)")
def chain_tension(ctx):
    n = 200 if ctx.quick else 1000
    mod = hanging_chain(n, link_length=1.0 / n, mass_ratio=1000.0)
    ps = mod.system
    out = {}
    fig, (ax, ax2) = ctx.subplots(1, 2, figsize=(11, 4))
    exact = mod.info["tension_at_rest"]
    k = np.arange(n)
    ax.semilogy(k, exact, "k-", lw=3, alpha=0.3, label="g·Σ(masses below link k)")
    for i, solver in enumerate(("linear", "witkin-sparse", "kkt")):
        sol = solve_multipliers(mod.constraints, ps, ps.state(), ps.m[:, None] * mod.g, solver=solver)
        T = mod.info["rods"].tension(ps.x0, sol.lam)
        rel = np.abs(T - exact) / exact
        out[f"rel_err_{solver}"] = float(rel.max())
        out[f"T_{solver}"] = T
        ax.semilogy(k[i::7], T[i::7], ".", ms=3, label=f"{solver}")
        ax2.semilogy(k, np.maximum(rel, 1e-18), lw=0.8, label=solver)
    ax.set(xlabel="link k (0 = top)", ylabel="tension (N)", title=f"n = {n}, masses 1, 1000, 1, …")
    ax2.axhline(1e-8, color="C3", ls=":", label="test bound 1e-8")
    ax2.set(xlabel="link k (index)", ylabel="relative error (1)", title="|T − exact| / exact")
    ax.legend()
    ax2.legend(loc="upper left")
    ctx.save(fig)
    out["exact"] = exact
    return out


# %% [markdown]
# ## Figure `ch03_swinging_chain`
#
# A 100-link chain released horizontal (projection, linear-time λ).
#
# A 100-link chain released horizontal (projection, linear-time solver).

# %%
@figure("ch03", "swinging_chain", "A 100-link chain released horizontal (projection, linear-time λ)")
def swinging_chain(ctx):
    # RK4: symplectic Euler is unstable here at these steps (the whip's J̇q̇ = |ḋ|² term is velocity-dependent)
    n, t_end, h = (30, 0.5, 2e-3) if ctx.quick else (100, 1.0, 1e-3)
    mod = hanging_chain(n, link_length=1.0 / n, angle=np.pi / 2)
    eff = Constraints(mod.constraints, solver="auto", stabilization="projection")
    res = Scene(mod.system, [Gravity(mod.g), eff]).simulate(t_end, h, "rk4",
                                                           record_every=max(1, int(0.05 / h)))
    fig, ax = ctx.subplots(figsize=(6, 5.5))
    X = res.y[: 2 * n]
    frames = np.linspace(0, X.shape[1] - 1, 8).astype(int)
    for j, f in enumerate(frames):
        xy = np.vstack([[0.0, 0.0], X[:, f].reshape(n, 2)])
        ax.plot(xy[:, 0], xy[:, 1], "-", color=f"C{j % 10}", lw=1.2, label=f"t = {res.t[f]:.2f} s")
    ax.plot([0], [0], "k^", ms=8)
    ax.set(xlabel="x (m)", ylabel="y (m)", aspect="equal", title=f"{n} links of {1.0 / n:.3g} m, RK4 + projection, h = {h} s")
    ax.legend(loc="lower left", ncol=2)
    ctx.save(fig)
    lengths = np.linalg.norm(np.diff(np.vstack([np.zeros((1, 2)), X[:, -1].reshape(n, 2)]), axis=0), axis=1)
    E = res.diagnostics["energy"]
    return {"C_max": float(res.diagnostics["C_max"].max()), "lengths_final": lengths, "link_length": 1.0 / n,
            "tip_y": X[2 * n - 1], "t": res.t, "solver": eff.last.solver,
            "energy_change": float((E.max() - E[0]) / (mod.system.m.sum() * 9.81))}


# %% [markdown]
# ## Figure `ch03_cloth`
#
# A cloth patch of rods pinned at two corners.
#
# A cloth patch of rods pinned at two corners, falling under gravity.

# %%
@figure("ch03", "cloth", "A cloth patch of rods pinned at two corners", cost=6.5)
def cloth(ctx):
    nx, t_end, h = (7, 0.4, 4e-3) if ctx.quick else (12, 1.0, 2e-3)
    mod = cloth_patch(nx, nx, spacing=1.0 / (nx - 1), mass=0.01)
    eff = Constraints(mod.constraints, stabilization="projection")
    res = Scene(mod.system, [Gravity(mod.g), eff]).simulate(t_end, h, "rk4", record_every=max(1, int(0.1 / h)))
    fig, ax = ctx.subplots(subplot_kw={"projection": "3d"}, figsize=(6.5, 5))
    N = mod.system.N
    frames = np.linspace(0, res.y.shape[1] - 1, 4).astype(int)
    for j, f in enumerate(frames):
        P = res.y[: 3 * N, f].reshape(nx, nx, 3)
        ax.plot_wireframe(P[..., 0], P[..., 1], P[..., 2], color=f"C{j}", lw=0.7, label=f"t = {res.t[f]:.2f} s")
    pins = mod.info["pins"]
    x0 = mod.system.x0[pins]
    ax.scatter(x0[:, 0], x0[:, 1], x0[:, 2], color="k", s=30, label="pins")
    ax.set(xlabel="x (m)", ylabel="y (m)", zlabel="z (m)", title=f"{nx}×{nx} cloth, rods + 2 nails, RK4 + projection")
    ax.legend(loc="upper left", fontsize=7)
    ctx.save(fig)
    Pend = res.y[: 3 * N, -1].reshape(N, 3)
    E = res.diagnostics["energy"]
    return {"energy_change": float((E.max() - E[0]) / (mod.system.m.sum() * 9.81)), "C_max": float(res.diagnostics["C_max"].max()), "pin_shift": float(np.abs(Pend[pins] - x0).max()),
            "z_min": float(Pend[:, 2].min()), "t_end": t_end}


# %% [markdown]
# ## Figure `ch03_solver_cost`
#
# Per-step cost of λ vs chain length for every solver (log-log).
#
# Per-step cost (assembly + λ) vs n for every solver, log-log (Baraff 1996).

# %%
@figure("ch03", "solver_cost", "Per-step cost of λ vs chain length for every solver (log-log)", cost=5.6)
def solver_cost(ctx):
    ns = [10, 100, 1000] if ctx.quick else [10, 100, 1000, 10_000, 100_000]
    solvers = ["linear", "witkin-sparse", "kkt", "witkin-dense"] if ctx.quick else SOLVER_LIST
    # full: each point timed once (after its warm-up solve; a point under 0.02 s looped to 0.02 s): CG's solves
    # at n = 10⁴ were most of the figure, six of them per point with 5 repeats (18.2 s CPU), two now
    # at n = 10⁴ (CG) and 10³ (dense), whose solves take over a second, the warm-up solve is the measurement
    costs = step_costs(ns, solvers, repeats=3 if ctx.quick else 1, warm_enough=0.5)
    fig, ax = ctx.subplots()
    for s in solvers:
        ax.loglog(ns, np.array(costs[s]) * 1e3, "o-", label=s)
    ax.loglog(ns, 1e-3 * np.array(ns, float) * costs["linear"][-1] * 1e3 / (1e-3 * ns[-1]), "k:", lw=0.8,
              label="∝ n")
    ax.set(xlabel="chain links n (count)", ylabel="ms per step (assembly + λ)",
           title="Hanging chain: dense skipped past n = 2000, CG past 10⁴")
    ax.legend()
    ctx.save(fig)
    return {"n": np.array(ns), "costs": {s: np.array(v) for s, v in costs.items()},
            "slope_linear": loglog_slope(ns[-3:], costs["linear"][-3:])}


# %% [markdown]
# ## Figure `ch03_work_precision`
#
# Work-precision: drift and energy error vs wall time per stabilization.
#
# Drift and energy error vs wall time for none / Baumgarte / projection.

# %%
@figure("ch03", "work_precision", "Work-precision: drift and energy error vs wall time per stabilization", cost=7.9)
def work_precision_fig(ctx):
    wp = work_precision(ctx.quick)
    rows = wp["rows"]
    fig, (ax, ax2) = ctx.subplots(1, 2, figsize=(11, 4.2))
    styles = {"rk4": "-", "symplectic_euler": "--"}
    labels = sorted({r["stabilization"] for r in rows}, key=lambda s: (s != "none", s != "projection", s))
    colors = {lab: f"C{i}" for i, lab in enumerate(labels)}
    for method in ("rk4", "symplectic_euler"):
        for lab in labels:
            rr = [r for r in rows if r["method"] == method and r["stabilization"] == lab and np.isfinite(r["drift"])]
            if not rr:
                continue
            w = [r["wall_time"] for r in rr]
            ax.loglog(w, [max(r["drift"], 1e-17) for r in rr], "o" + styles[method], color=colors[lab], ms=4,
                      label=f"{method}, {lab}")
            ax2.loglog(w, [max(r["energy_error"], 1e-17) for r in rr], "o" + styles[method], color=colors[lab], ms=4)
    ax.set(xlabel="wall time (s)", ylabel="max |C| (m²)", title=f"drift, {wp['links']}-link chain, {wp['t_end']} s")
    ax2.set(xlabel="wall time (s)", ylabel="max |E − E₀| / (M g L)", title="energy error")
    ax.legend(fontsize=6, loc="lower left", ncol=2)
    ctx.save(fig)
    return {"rows": rows, "hs": wp["hs"]}


# %% [markdown]
# ## Draw the figures
#
# As a script or in a notebook kernel, draw this chapter's figures (quick mode) into `figures/`.

# %%
if __name__ == "__main__":
    from pathlib import Path

    from pbanim.plotting import figures_of, run_figure

    for _key, _spec in figures_of({"ch03"}).items():
        print(_key, [p.name for p in run_figure(_spec, Path("figures"), quick=True)[1]])
