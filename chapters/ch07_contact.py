# %% [markdown]
# # Chapter 07 — resting contact: contact forces by QP and LCP, friction, stacks.
#
# This file is a module (imported by `pbanim figures`) and a notebook in jupytext's percent format:
# open it in Jupyter (with jupytext) or VS Code, or write an `.ipynb` with `pbanim notebook ch07 DIR`.
# Running it draws every figure of the chapter in quick mode into `figures/`.

# %%
"""Chapter 07 — resting contact: contact forces by QP and LCP, friction, stacks.

Figures: interface forces in a box stack vs the weights above (every solver); a box on an incline,
stick/slip vs angle against the analytic threshold tan θ = μ; residual vs time for every LCP solver (what
accuracy costs); GIFs of a box stack and of a pile of spheres settling (velocity-level time stepping).
"""

from __future__ import annotations

import time

import numpy as np

from pbanim.contact import TimeStepping, assemble_rigid, solve_lcp
from pbanim.models.contact import (box_on_incline, box_stack, incline_expected, random_contact_lcp,
                                   sphere_pour)
from pbanim.plotting import figure
from pbanim.plotting_gif import frozen_backdrop
from pbanim.scene import Scene

SOLVER_STYLE = {"qp": ("o", "C0"), "lemke": ("s", "C1"), "dantzig": ("^", "C2"), "pgs": ("x", "C3"), "bpp": ("D", "C4")}


# %% [markdown]
# ## Figure `ch07_stack_forces`
#
# Box stack (10 boxes, masses 1:100 alternating): interface force vs weight above.

# %%
@figure("ch07", "stack_forces", "Box stack (10 boxes, masses 1:100 alternating): interface force vs weight above")
def stack_forces(ctx):
    sc = box_stack(10, 100.0)
    bodies = sc.system
    y = bodies.state()
    Q = Scene(bodies, sc.forces).forces(0.0, y)
    c = sc.detect(y)
    prob = assemble_rigid(bodies, y, c, Q)
    W = sc.exact["weights_above"]
    out = {"weights_above": W}
    fig, ax = ctx.subplots()
    k = np.arange(10)
    ax.semilogy(k, W, "k-", lw=2.5, alpha=0.35, label="weight above, g Σ_{j≥k} m_j")
    for i, solver in enumerate(("qp", "lemke", "dantzig", "pgs")):
        sol = solve_lcp(prob.A, prob.b, solver, raise_on_failure=False, max_iter=2000 if solver == "pgs" else None)
        F = np.bincount(c.a, weights=sol.f, minlength=10)
        out[f"forces_{solver}"] = F
        out[f"success_{solver}"] = sol.success
        out[f"rel_err_{solver}"] = float(np.max(np.abs(F / W - 1)))
        mk, col = SOLVER_STYLE[solver]
        lab = f"{solver}: max rel. error {out[f'rel_err_{solver}']:.1e}" + ("" if sol.success else f" ({sol.status})")
        ax.semilogy(k + 0.08 * (i - 1.5), np.maximum(F, 1e-3), mk, color=col, mfc="none", label=lab)
    ax.set_xlabel("interface k (0 = ground, under box k)")
    ax.set_ylabel("total contact force on the interface (N)")
    ax.legend()
    ctx.save(fig)
    return out


# %% [markdown]
# ## Figure `ch07_incline_stick_slip`
#
# Box on an incline (μ = 0.5): stick/slip vs angle, velocity-level time stepping.

# %%
@figure("ch07", "incline_stick_slip", "Box on an incline (μ = 0.5): stick/slip vs angle, velocity-level time stepping")
def incline_stick_slip(ctx):
    mu, h = 0.5, 1e-3
    angles = np.radians(np.linspace(2, 50, 7 if ctx.quick else 25))
    acc, fric = [], []
    for th in angles:
        sc = box_on_incline(th, mu)
        ts = TimeStepping(sc.system, sc.detect, sc.forces, friction=mu, facets=4)
        res = ts.simulate(0.02, h)
        vd = (res.y[7:10]).T @ sc.exact["downhill"]
        acc.append((vd[-1] - vd[-2]) / h)
        fric.append(-(ts.last_info["friction_impulse"][0, :3] / h) @ sc.exact["downhill"])
    acc, fric = np.array(acc), np.array(fric)
    fine = np.radians(np.linspace(0, 52, 400))
    a_ex = np.array([incline_expected(t, mu)["acceleration"] for t in fine])
    f_ex = np.array([incline_expected(t, mu)["friction_per_mass"] for t in fine])
    fig, (ax1, ax2) = ctx.subplots(1, 2, figsize=(9.5, 3.8))
    thr = np.degrees(np.arctan(mu))
    for ax in (ax1, ax2):
        ax.axvline(thr, color="k", ls=":", lw=1, label=f"tan θ = μ ({thr:.1f}°)")
    ax1.plot(np.degrees(fine), a_ex, "k-", label="g (sin θ − μ cos θ), 0 if static")
    ax1.plot(np.degrees(angles), acc, "o", mfc="none", label="velocity-level LCP (4-facet cone)")
    ax1.set_xlabel("incline angle θ (deg)")
    ax1.set_ylabel("acceleration down the slope (m/s²)")
    ax1.legend()
    ax2.plot(np.degrees(fine), f_ex, "k-", label="m g sin θ (stick), μ m g cos θ (slip)")
    ax2.plot(np.degrees(angles), fric, "o", mfc="none", label="friction impulse / h")
    ax2.set_xlabel("incline angle θ (deg)")
    ax2.set_ylabel("friction force, m = 1 kg (N)")
    ax2.legend()
    ctx.save(fig)
    return {"angles": angles, "acceleration": acc, "friction": fric, "friction_coefficient": mu,
            "acceleration_exact": np.array([incline_expected(t, mu)["acceleration"] for t in angles]),
            "friction_exact": np.array([incline_expected(t, mu)["friction_per_mass"] for t in angles])}


# %% [markdown]
# ## Figure `ch07_solver_residual_time`
#
# What accuracy costs: natural-map residual vs time for every LCP solver.

# %%
@figure("ch07", "solver_residual_time", "What accuracy costs: natural-map residual vs time for every LCP solver",
        cost=4.5)
def solver_residual_time(ctx):
    m = 60 if ctx.quick else 200
    case = random_contact_lcp(m, redundant=True, seed=7)
    A, b = case.A, case.b
    out = {"m": m}
    # PGS by sweeps: one run, residual after each sweep, time measured along the way
    sweeps = 300 if ctx.quick else 3000
    f = np.zeros(m)
    diag = np.diag(A)
    t_pgs, r_pgs = [], []
    start = time.perf_counter()
    for _ in range(sweeps):
        for i in range(m):
            f[i] = max(0.0, f[i] - (A[i] @ f + b[i]) / diag[i])
        t_pgs.append(time.perf_counter() - start)
        r_pgs.append(np.max(np.abs(f - np.maximum(0.0, f - (A @ f + b)))))
    out["pgs_time"], out["pgs_residual"] = np.array(t_pgs), np.array(r_pgs)
    # ProxQP at decreasing eps_abs, unpolished (its own accuracy), and the polished default
    eps = [1e-2, 1e-4, 1e-6, 1e-8, 1e-10]
    # warm-up: the first call imports proxsuite (on one contact: the full-size default solve is timed below)
    solve_lcp(A[:1, :1], b[:1], "qp")
    qt, qr = [], []
    for e in eps:                       # each point timed once, on the call whose residual it plots
        sol, seconds = _timed(lambda: solve_lcp(A, b, "qp", eps_abs=e, polish=False, raise_on_failure=False))
        qt.append(seconds)
        qr.append(sol.residual)
    out["qp_eps"], out["qp_eps_time"], out["qp_eps_residual"] = np.array(eps), np.array(qt), np.array(qr)
    fig, ax = ctx.subplots()
    ax.loglog(out["pgs_time"], np.maximum(out["pgs_residual"], 1e-17), "-", color=SOLVER_STYLE["pgs"][1],
              label="PGS, sweep by sweep")
    ax.loglog(qt, np.maximum(qr, 1e-17), "o-", color=SOLVER_STYLE["qp"][1], mfc="none",
              label="ProxQP, eps_abs = 1e-2 … 1e-10 (unpolished)")
    for solver in ("qp", "lemke", "dantzig", "bpp"):
        sol, out[f"{solver}_time"] = _timed(lambda: solve_lcp(A, b, solver))
        out[f"{solver}_residual"] = sol.residual
        mk, col = SOLVER_STYLE[solver]
        name = {"qp": "ProxQP + polish (default)", "bpp": f"active set ({sol.status})"}.get(solver, solver)
        ax.loglog([out[f"{solver}_time"]], [max(sol.residual, 1e-17)], mk, color=col, ms=9, label=f"{name}: {sol.residual:.0e}")
    ax.axhline(1e-10, color="k", ls=":", lw=1, label="tol 1e-10")
    ax.set_xlabel("wall time (s)")
    ax.set_ylabel("natural-map residual ‖f − max(0, f − w)‖∞ (force units)")
    ax.set_title(f"Residual vs wall time, m = {m} redundant frictionless contacts (rank {m // 2 + 1})")
    ax.legend(fontsize=7, loc="upper left", bbox_to_anchor=(1.01, 1.0))
    ctx.save(fig)
    return out


def _timed(call):
    """(result, wall seconds) of one call: the figure plots each solver's residual against the time of the
    very call that reached it (one timing per point, not a median of repeats)."""
    start = time.perf_counter()
    result = call()
    return result, time.perf_counter() - start


def _box_outline(x, R, h):
    c = np.array([[-1, -1, -1], [1, -1, -1], [1, -1, 1], [-1, -1, 1], [-1, -1, -1]]) * h
    p = x + c @ R.T
    return p[:, 0], p[:, 2]


# %% [markdown]
# ## Figure `ch07_stack_settling`
#
# A stack of boxes dropped with 5 mm gaps settles (velocity level, μ = 0.5).

# %%
@figure("ch07", "stack_settling", "A stack of boxes dropped with 5 mm gaps settles (velocity level, μ = 0.5)",
        cost=4.4)
def stack_settling(ctx):
    n = 3 if ctx.quick else 6
    sc = box_stack(n, 1.0)
    bodies = sc.system
    y0 = bodies.state()
    y0[2:3 * n:3] += 0.005 * (np.arange(n) + 1)          # gaps of 5 mm between the boxes
    y0[0:3 * n:3] += 0.02 * np.sin(np.arange(n))          # a slightly staggered stack

    sc_margin = box_stack(n, 1.0, margin=0.02)
    ts = TimeStepping(bodies, sc_margin.detect, sc.forces, friction=0.5, facets=4)
    # the stack is at rest (every speed below 1e-12 m/s) from t = 0.2 s on: 0.4 s shows the drop and the rest,
    # the GIF's frames 25 ms apart as before (the run was 1.0 s, 40 frames: 0.6 s more of the same rest)
    T, h = (0.25, 2e-3) if ctx.quick else (0.4, 1e-3)
    res = ts.simulate(T, h, y0=y0, record_every=2)
    frames = np.unique(np.linspace(0, res.y.shape[1] - 1, 6 if ctx.quick else 16).astype(int))
    hext = sc.half_extents
    fig, ax = ctx.subplots(figsize=(4, 4))

    # the axes and the n outlines are made once; a frame moves the outlines (the same pixels as clearing the
    # axes and filling anew, in a fraction of the time)
    outlines = [ax.fill(*_box_outline(np.zeros(3), np.eye(3), hext), alpha=0.6, color=f"C{k % 10}")[0]
                for k in range(n)]
    ground = ax.axhline(0, color="k")
    ax.set_xlim(-1.2, 1.2)
    ax.set_ylim(-0.1, 2 * hext[2] * n + 0.3)
    ax.set_aspect("equal")
    ax.set_xlabel("x (m)")
    ax.set_ylabel("z (m)")
    # the grid under the boxes (it was drawn over them): the axes, ticks and labels are then drawn before every
    # box and rendered once (frozen_backdrop), a frame draws the boxes, the ground, the spines and the title
    ax.set_axisbelow(True)
    show_backdrop = frozen_backdrop(fig, [fig.patch, ax.patch, ax.xaxis, ax.yaxis],
                                    outlines + [ground, ax.title, *ax.spines.values()])

    def draw(j):
        show_backdrop()
        i = frames[j]
        yy = res.y[:, i]
        x = bodies.unpack(yy)[0]
        R = bodies.rotations(yy)
        for k in range(n):
            outlines[k].set_xy(np.column_stack(_box_outline(x[k], R[k], hext)))
        ax.set_title(f"t = {res.t[i]:.3f} s", y=1.0)

    ctx.save_gif(fig, draw, len(frames), fps=10)
    fig2, ax2 = ctx.subplots()
    for k in range(n):
        ax2.plot(res.t, res.y[3 * k + 2] - hext[2] * (2 * k + 1), label=f"box {k}")
    ax2.set_xlabel("time (s)")
    ax2.set_ylabel("height above its resting height (m)")
    ax2.legend()
    ctx.save(fig2)
    final = res.y[:, -1]
    return {"final_heights": final[2:3 * n:3], "rest_heights": hext[2] * (2 * np.arange(n) + 1),
            "max_penetration": float(res.diagnostics["max_penetration"].max()),
            "final_speed": float(np.abs(final[7 * n:10 * n]).max()), "frames": len(frames)}


# %% [markdown]
# ## Figure `ch07_sphere_pile`
#
# Spheres poured into a box settle into a pile (velocity level, frictionless, PGS ≤ 30 sweeps).

# %%
@figure("ch07", "sphere_pile", "Spheres poured into a box settle into a pile (velocity level, frictionless, PGS ≤ 30 sweeps)",
        cost=7.4)
def sphere_pile(ctx):
    n, T, h = (20, 0.4, 4e-3) if ctx.quick else (100, 1.2, 4e-3)
    sc = sphere_pour(n)
    ts = TimeStepping(sc.system, sc.detect, sc.forces, friction=0.0, solver="pgs",
                      solver_options={"max_iter": 30}, tol=1e-6, accept_unconverged=True)
    res = ts.simulate(T, h, record_every=2)
    frames = np.unique(np.linspace(0, res.y.shape[1] - 1, 6 if ctx.quick else 40).astype(int))
    r, L = sc.exact["radius"], sc.exact["box_half"]
    fig, ax = ctx.subplots(figsize=(4, 4))
    from matplotlib.patches import Circle

    # the axes, the box and the n discs are made once; a frame moves the discs and retitles (clearing the
    # axes and adding n patches per frame was 60 % of the figure's time; the frames are the same pixels)
    discs = [ax.add_patch(Circle((0.0, 0.0), r, alpha=0.5)) for _ in range(n)]
    walls = ax.plot([-L, -L, L, L], [0.6, 0, 0, 0.6], "k-")[0]
    ax.set_xlim(-L - 0.05, L + 0.05)
    ax.set_ylim(-0.05, 0.7)
    ax.set_aspect("equal")
    ax.set_xlabel("x (m)")
    ax.set_ylabel("z (m)")
    # the grid under the discs (it was drawn over them): the axes, ticks and labels are then drawn before every
    # disc and rendered once (frozen_backdrop), a frame draws the discs, the walls, the spines and the title
    ax.set_axisbelow(True)
    show_backdrop = frozen_backdrop(fig, [fig.patch, ax.patch, ax.xaxis, ax.yaxis],
                                    discs + [walls, ax.title, *ax.spines.values()])

    def draw(j):
        show_backdrop()
        i = frames[j]
        x = res.y[:3 * n, i].reshape(n, 3)
        for disc, p in zip(discs, x):
            disc.set_center((p[0], p[2]))
        ax.set_title(f"t = {res.t[i]:.2f} s", y=1.0)

    ctx.save_gif(fig, draw, len(frames), fps=10)
    v = res.y[3 * n:, :].reshape(n, 3, -1)
    ke = 0.5 * np.sum(v ** 2, axis=(0, 1))
    fig2, ax2 = ctx.subplots()
    ax2.semilogy(res.t, np.maximum(ke, 1e-16), label="kinetic energy (J)")
    ax2.semilogy(res.t, np.maximum(res.diagnostics["max_penetration"], 1e-16), label="max penetration (m)")
    ax2.set_xlabel("time (s)")
    ax2.set_ylabel("kinetic energy (J), max penetration (m)")
    ax2.legend()
    ctx.save(fig2)
    z = res.y[2:3 * n:3, -1]
    return {"kinetic_energy": ke, "max_penetration": float(res.diagnostics["max_penetration"].max()), "radius": r,
            "unconverged_fraction": float(np.mean(res.diagnostics["lcp_unconverged"][1:])),
            "final_z": z, "box_half": L, "final_x": res.y[0:3 * n:3, -1], "final_y": res.y[1:3 * n:3, -1]}


# %% [markdown]
# ## Draw the figures
#
# As a script or in a notebook kernel, draw this chapter's figures (quick mode) into `figures/`.

# %%
if __name__ == "__main__":
    from pathlib import Path

    from pbanim.plotting import figures_of, run_figure

    for _key, _spec in figures_of({"ch07"}).items():
        print(_key, [p.name for p in run_figure(_spec, Path("figures"), quick=True)[1]])
