# %% [markdown]
# # Chapter 04 — reduced coordinates and Lagrangian mechanics: same physics, different cost and accuracy.
#
# This file is a module (imported by `pbanim figures`) and a notebook in jupytext's percent format:
# open it in Jupyter (with jupytext) or VS Code, or write an `.ipynb` with `pbanim notebook ch04 DIR`.
# Running it draws every figure of the chapter in quick mode into `figures/`.

# %%
"""Chapter 04 — reduced coordinates and Lagrangian mechanics: same physics, different cost and accuracy.

Figures:

* ``period_amplitude``: pendulum period vs amplitude, simulated in reduced coordinates (event-located
  zero crossings) against 4√(L/g)K(m), m = sin²(θ₀/2) (ORACLES A5), and the small-angle 2π√(L/g).
* ``double_pendulum_formulations``: the double pendulum as constrained particles (ch03), in reduced
  coordinates and from the Lagrangian: tip trajectories overlaid and their differences (ORACLES G1).
* ``energy_error``: relative energy error of the double pendulum per formulation and integrator
  (RK4 drifts, implicit midpoint stays bounded; symplectic Euler is not symplectic for M(u) ≠ const).
* ``cost_vs_n``: wall time per simulated second at equal accuracy (RK4, tip error ≤ 1e-8 m) for the
  n-link pendulum in maximal, reduced and Lagrangian form.
* ``derivation_time``: deriving and compiling the n-link pendulum's equations: pbanim.reduced.lagrangian vs
  sympy.physics.mechanics (KanesMethod, LagrangesMethod), each in a fresh process.
"""

from __future__ import annotations

import numpy as np

import pbanim
from pbanim.bench.reduced import CAP, cost_at_accuracy, derive_batch, derive_in_subprocess
from pbanim.contracts import unchecked
from pbanim.models.reduced import double_pendulum, maximal_chain, pendulum_period, simple_pendulum
from pbanim.plotting import figure
from pbanim.reduced import simulate_fixed


def _down(t, y):
    return y[0]


_down.direction = -1


# %% [markdown]
# ## Figure `ch04_period_amplitude`
#
# Pendulum period vs amplitude: simulated vs 4√(L/g)K(sin²(θ₀/2)).
#
# Pendulum period vs amplitude, simulated in reduced coordinates (event-located zero crossings)
# against 4√(L/g)K(m), m = sin²(θ₀/2) (ORACLES A5), and the small-angle 2π√(L/g).

# %%
@figure("ch04", "period_amplitude", "Pendulum period vs amplitude: simulated vs 4√(L/g)K(sin²(θ₀/2))")
def period_amplitude(ctx):
    degs = np.array([10, 60, 120, 170, 179] if ctx.quick else [5, 20, 40, 60, 80, 100, 120, 140, 160, 170, 175, 179])
    L, g = 1.0, 9.81
    T_sim = []
    for d in degs:
        mod = simple_pendulum(theta0=np.radians(d), length=L, g=g)
        T = mod.info["period"]
        res = pbanim.solve(mod.reduced().rhs, (0.0, 1.3 * T), mod.state(), method="dopri5", rtol=1e-10,
                           atol=1e-12, events=[_down])
        te = res.t_events[0]
        T_sim.append(te[1] - te[0])
    T_sim = np.array(T_sim)
    T_ex = pendulum_period(np.radians(degs), L, g)
    fine = np.linspace(1, 179.5, 300)
    T0 = 2 * np.pi * np.sqrt(L / g)
    fig, (ax, ax2) = ctx.subplots(1, 2, figsize=(10, 4))
    ax.plot(fine, pendulum_period(np.radians(fine), L, g), label="4√(L/g) K(m), m = sin²(θ₀/2)")
    ax.plot(degs, T_sim, "o", mfc="none", label="simulated (reduced coords, dopri5 rtol 1e-10)")
    ax.axhline(T0, ls="--", color="k", lw=0.8, label="small-angle 2π√(L/g)")
    ax.set(xlabel="amplitude θ₀ (deg)", ylabel="period T (s)", title="period vs amplitude (L = 1 m)")
    ax.legend(loc="upper left")
    rel = np.abs(T_sim / T_ex - 1)
    ax2.semilogy(degs, np.maximum(rel, 1e-17), "o-")
    ax2.set(xlabel="amplitude θ₀ (deg)", ylabel="|T_sim / T_exact − 1| (1)", title="relative period error")
    ctx.save(fig)
    return {"theta0_deg": degs, "T_sim": T_sim, "T_exact": T_ex, "rel_err": rel, "T_small": T0}


def _three(mod, t_end, n_out, rtol=1e-10):
    t_eval = np.linspace(0, t_end, n_out)
    kw = dict(method="dopri5", rtol=rtol, atol=rtol * 1e-2, t_eval=t_eval)
    mx = maximal_chain(mod)
    red, lag = mod.reduced(), mod.lagrangian()
    a = pbanim.solve(mx.scene.rhs, (0, t_end), mx.state(), **kw)
    b = pbanim.solve(red.rhs, (0, t_end), mod.state(), **kw)
    c = pbanim.solve(lag.rhs, (0, t_end), mod.state(), **kw)
    n2 = 2 * mod.n
    xa = a.y[:n2]
    xb = np.array([red.particle_state(b.y[:, k])[:n2] for k in range(b.t.size)]).T
    xc = np.array([red.particle_state(c.y[:, k])[:n2] for k in range(c.t.size)]).T
    return t_eval, xa, xb, xc


# %% [markdown]
# ## Figure `ch04_double_pendulum_formulations`
#
# Double pendulum: maximal vs reduced vs Lagrangian.
#
# The double pendulum as constrained particles (ch03), in reduced coordinates and from the
# Lagrangian: tip trajectories overlaid and their differences (ORACLES G1).

# %%
@figure("ch04", "double_pendulum_formulations", "Double pendulum: maximal vs reduced vs Lagrangian",
        group="ch04_double_pendulum")   # one process: the double pendulum's Lagrangian derived once
def double_pendulum_formulations(ctx):
    t_end = 2.0 if ctx.quick else 6.0
    mod = double_pendulum(theta0=(1.0, 1.5))
    t, xa, xb, xc = _three(mod, t_end, 200 if ctx.quick else 600)
    d_ab = np.max(np.abs(xa - xb), axis=0)
    d_bc = np.max(np.abs(xb - xc), axis=0)
    fig, (ax, ax2) = ctx.subplots(1, 2, figsize=(10, 4.2))
    ax.plot(xa[2], xa[3], lw=3, alpha=0.4, label="(a) constrained particles (ch03)")
    ax.plot(xb[2], xb[3], lw=1.6, label="(b) reduced coordinates")
    ax.plot(xc[2], xc[3], "k:", lw=1.2, label="(c) Euler–Lagrange (sympy)")
    ax.plot([0, xa[0, 0], xa[2, 0]], [0, xa[1, 0], xa[3, 0]], "o-", color="gray", label="start")
    ax.set(xlabel="x (m)", ylabel="y (m)", title=f"tip trajectory, t ∈ [0, {t_end:g}] s", aspect="equal")
    ax.legend(loc="lower left", fontsize=7)
    ax2.semilogy(t[1:], np.maximum(d_ab[1:], 1e-17), label="|(a) − (b)| max over particles")
    ax2.semilogy(t[1:], np.maximum(d_bc[1:], 1e-17), label="|(b) − (c)|")
    ax2.set(xlabel="t (s)", ylabel="position difference (m)", title="dopri5, rtol 1e-10, atol 1e-12")
    ax2.legend()
    ctx.save(fig)
    return {"t": t, "tip_maximal": xa[2:4], "tip_reduced": xb[2:4], "tip_lagrangian": xc[2:4],
            "max_diff_maximal_reduced": float(d_ab.max()), "max_diff_reduced_lagrangian": float(d_bc.max())}


# %% [markdown]
# ## Figure `ch04_energy_error`
#
# Double pendulum: energy error per formulation and integrator.
#
# Relative energy error of the double pendulum per formulation and integrator (RK4 drifts, implicit
# midpoint stays bounded; symplectic Euler is not symplectic for M(u) ≠ const).

# %%
@figure("ch04", "energy_error", "Double pendulum: energy error per formulation and integrator",
        cost=14.0, group="ch04_double_pendulum")
def energy_error(ctx):
    t_end, h = (5.0, 0.02) if ctx.quick else (30.0, 0.01)
    mod = double_pendulum(theta0=(0.6, 0.9))
    red, lag = mod.reduced(), mod.lagrangian()
    mx = maximal_chain(mod)
    # the energies recorded every few steps without their argument checks (pbanim.contracts.unchecked: the
    # same function; simulate_fixed already holds the rhs unchecked), 15-20 µs a call
    forms = {"maximal": (mx.scene.rhs, mx.state(), unchecked(mx.scene.energy)),
             "reduced": (red.rhs, mod.state(), unchecked(red.energy)),
             "lagrangian": (lag.rhs, mod.state(), unchecked(lag.energy))}
    methods = ("rk4", "implicit_midpoint", "symplectic_euler")
    every = max(1, int(round(0.05 / h)))
    out, curves = {}, {}
    for f, (rhs, y0, en) in forms.items():
        for m in methods:
            res = simulate_fixed(rhs, y0, t_end, h, m, energy=lambda y, t, en=en: en(y), record_every=every)
            E = res.diagnostics["energy"]
            rel = np.abs(E - E[0]) / abs(E[0])
            curves[(f, m)] = (res.t, rel)
            out[f"{f}_{m}"] = float(rel.max())
    fig, axes = ctx.subplots(1, 3, figsize=(12, 3.8), sharey=True)
    for ax, m in zip(axes, methods):
        for f, style in zip(forms, ("-", "--", ":")):
            t, rel = curves[(f, m)]
            ax.semilogy(t[1:], np.maximum(rel[1:], 1e-17), style, label=f)
        ax.set(xlabel="t (s)", title=f"{m}, h = {h} s")
    axes[0].set_ylabel("|E − E₀| / |E₀| (1)")
    axes[0].legend()
    ctx.save(fig)
    out.update(h=h, t_end=t_end)
    return out


# %% [markdown]
# ## Figure `ch04_cost_vs_n`
#
# n-link pendulum: cost per simulated second at equal accuracy.
#
# Wall time per simulated second at equal accuracy (RK4, tip error ≤ 1e-8 m) for the n-link pendulum
# in maximal, reduced and Lagrangian form.

# %%
@figure("ch04", "cost_vs_n", "n-link pendulum: cost per simulated second at equal accuracy", cost=9.0)
def cost_vs_n(ctx):
    ns = [2, 3] if ctx.quick else [2, 5, 10, 20, 50]
    tol = 1e-8
    rows = {f: [] for f in ("maximal", "reduced", "lagrangian")}
    hs = {f: [] for f in rows}
    errs = {f: [] for f in rows}
    for n in ns:
        c = cost_at_accuracy(n, tol=tol)
        for f in rows:
            rows[f].append(c[f][0])
            hs[f].append(c[f][1])
            errs[f].append(c[f][2])
    fig, (ax, ax2) = ctx.subplots(1, 2, figsize=(10, 4))
    for f, mk in zip(rows, "osd"):
        ax.loglog(ns, rows[f], mk + "-", label=f)
        ax2.loglog(ns, np.array(rows[f]) * np.array(hs[f]), mk + "-", label=f)   # s per RK4 step
    ax.set(xlabel="number of links n (count)", ylabel="wall time per simulated second (s)",
           title=f"RK4 at tip error ≤ {tol:g} m after 1 s")
    ax2.set(xlabel="number of links n (count)", ylabel="wall time per RK4 step (s)",
            title="per step (4 rhs evaluations)")
    for a in (ax, ax2):
        a.set_xticks(ns, [str(n) for n in ns])
        a.tick_params(axis="x", which="minor", bottom=False, labelbottom=False)
        a.legend()
    ctx.save(fig)
    return {"n": np.array(ns), "tol": tol, **{f"cost_{f}": np.array(v) for f, v in rows.items()},
            **{f"h_{f}": np.array(v) for f, v in hs.items()}, **{f"err_{f}": np.array(v) for f, v in errs.items()}}


# One job per fresh process, the imports paid once: a server process imports sympy, sympy.physics.mechanics
# and pbanim, then forks a child per job (the child starts from the state right after the imports, as a new
# interpreter would after its own, and is killed at the cap); one JSON line per job.
_FORK_SERVER = """
import json, os, select, signal, sys
import sympy, sympy.physics.mechanics
import pbanim.bench.reduced as b
from pbanim.reduced.lagrangian import compile_equations, derive_equations
jobs, cap = json.loads(sys.argv[1]), float(sys.argv[2])
for job in jobs:
    r, w = os.pipe()
    pid = os.fork()
    if pid == 0:
        os.close(r)
        try:
            os.write(w, json.dumps(b.derive_worker(*job)).encode())
        finally:
            os._exit(0)
    os.close(w)
    ready, _, _ = select.select([r], [], [], cap)
    if ready:
        chunks = []
        while True:
            c = os.read(r, 1 << 16)
            if not c:
                break
            chunks.append(c)
        out = b"".join(chunks).decode() or json.dumps({"error": "no result"})
    else:
        os.kill(pid, signal.SIGKILL)
        out = json.dumps({"capped": True})
    os.close(r)
    os.waitpid(pid, 0)
    print(out, flush=True)
"""


def derive_forked(jobs, cap: float) -> list[dict]:
    """:func:`~pbanim.bench.reduced.derive_worker` for each job in a fresh process (forked after the
    imports), each capped at ``cap`` s; a capped or failed job gives ``{"total": nan, "capped": ...}`` as
    :func:`~pbanim.bench.reduced.derive_batch` does. Without ``os.fork``: one new interpreter per job."""
    import json
    import os
    import subprocess
    import sys

    if not hasattr(os, "fork"):
        return [derive_in_subprocess(*job, cap) for job in jobs]
    out = subprocess.run([sys.executable, "-c", _FORK_SERVER, json.dumps([list(j) for j in jobs]), str(cap)],
                         capture_output=True, text=True, timeout=cap * len(jobs) + 120.0)
    lines = [json.loads(line) for line in out.stdout.splitlines() if line.startswith("{")]
    res = []
    for k in range(len(jobs)):
        r = lines[k] if k < len(lines) else {"error": out.stderr.strip().splitlines()[-1:]}
        res.append(r | {"capped": bool(r.get("capped", False))} if "total" in r else
                   {"total": np.nan, "derive": np.nan, "compile": np.nan, "capped": bool(r.get("capped")),
                    "error": r.get("error", "")})
    return res


# %% [markdown]
# ## Figure `ch04_derivation_time`
#
# Deriving + compiling the n-link pendulum: pbanim vs sympy.physics.mechanics.
#
# Deriving and compiling the n-link pendulum's equations: pbanim.reduced.lagrangian vs
# sympy.physics.mechanics (KanesMethod, LagrangesMethod), each in a fresh process.

# %%
@figure("ch04", "derivation_time", "Deriving + compiling the n-link pendulum: pbanim vs sympy.physics.mechanics",
        cost=9.6)
def derivation_time(ctx):
    # full: n up to 6, where sympy is already 5-10x slower and its curves steeper; beyond, only sympy's own
    # time grows (n = 20: 13 s Kane, 27 s Lagrange, of the 136 s the figure took with n = 2, 5, 10, 20)
    ns = [2, 3] if ctx.quick else [2, 3, 4, 6]
    cap = 20.0 if ctx.quick else CAP
    kinds = ("pbanim", "kane", "lagrange")
    times = {k: [] for k in kinds}
    values = {}
    # the first n's jobs also give the rhs at one state (the three formulations agree: tests/test_reduced.py),
    # not its time (five repeats of ≥ 0.05 s each, 0.8 s of the child's time nobody plotted)
    jobs = [(k, n, 1 if n == ns[0] else 0, False) for n in ns for k in kinds]
    # quick: one process for all (a single sympy import); full: a fresh process per job, forked from one that
    # has only imported (cold caches as in a new interpreter; the imports, ≈2 s each, paid once)
    results = derive_batch(jobs, cap) if ctx.quick else derive_forked(jobs, cap)
    for (k, n, _, _), r in zip(jobs, results):
        times[k].append(r["total"])
        if "rhs_value" in r:
            values[k] = np.array(r["rhs_value"])
    fig, ax = ctx.subplots()
    for k, mk in zip(kinds, "osd"):
        label = {"pbanim": "pbanim.reduced.lagrangian (kinematic route + CSE)", "kane": "sympy KanesMethod + lambdify",
                 "lagrange": "sympy LagrangesMethod + lambdify"}[k]
        ax.semilogy(ns, times[k], mk + "-", label=label)
    ax.set(xlabel="number of links n (count)", ylabel="derivation + compilation (s)", xticks=ns,
           title=(f"{'one process for all' if ctx.quick else 'fresh process each'}, cap {cap:g} s "
                  "(missing point = capped)"))
    ax.legend()
    ctx.save(fig)
    return {"n": np.array(ns), **{f"time_{k}": np.array(v) for k, v in times.items()},
            **{f"rhs_{k}": v for k, v in values.items()}}


# %% [markdown]
# ## Draw the figures
#
# As a script or in a notebook kernel, draw this chapter's figures (quick mode) into `figures/`.

# %%
if __name__ == "__main__":
    from pathlib import Path

    from pbanim.plotting import figures_of, run_figure

    for _key, _spec in figures_of({"ch04"}).items():
        print(_key, [p.name for p in run_figure(_spec, Path("figures"), quick=True)[1]])
