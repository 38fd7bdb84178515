# %% [markdown]
# # Chapter 02 — ODE solvers: orders, stability regions, Kepler orbits, work-precision, stiff springs.
#
# This file is a module (imported by `pbanim figures`) and a notebook in jupytext's percent format:
# open it in Jupyter (with jupytext) or VS Code, or write an `.ipynb` with `pbanim notebook ch02 DIR`.
# Running it draws every figure of the chapter in quick mode into `figures/`.

# %%
"""Chapter 02 — ODE solvers: orders, stability regions, Kepler orbits, work-precision, stiff springs.

Each figure computes, plots and returns its data (checked in tests/test_ode_figures.py).
"""

from __future__ import annotations

import numpy as np

from pbanim.models.ode import damped_oscillator, kepler
from pbanim.ode import METHODS, solve
from pbanim.ode.implicit_run import THETA, NewtonSteps
from pbanim.plotting import figure
from pbanim.testing import fitted_order

ORDER = ["euler", "symplectic_euler", "implicit_euler", "midpoint", "verlet", "implicit_midpoint",
         "exponential_euler", "rk4", "rodas4", "dopri5", "radau5", "dprkn6", "vern7", "dop853", "dprkn8", "dprkn12"]
# the Nyström pairs solve q̈ = g(t, q) only: the damped test equation of the stability regions is not theirs
STABILITY_ORDER = [name for name in ORDER if not METHODS[name].nystrom]
# first step and span of the convergence sweep: in the asymptotic range, errors above the roundoff floor
H0 = {1: 2.0**-8, 2: 2.0**-4, 4: 2.0**-4, 5: 2.0**-4, 6: 2.0**-3, 7: 2.0**-1, 8: 2.0**-2, 12: 8.0 / 6}
H0_BY_NAME = {"rodas4": 2.0**-5}
SPAN = {5: 6.0, 7: 6.0, 12: 8.0}
# the fit skips errors below the roundoff floor: RODAS4's linear solves level off near 1e-11 (slope 2.9 if kept)
FIT_FLOOR = {8: 1e-13, 12: 1e-13}
# halvings of h in the full figure (default 6): implicit Euler's Newton steps cost 0.35 ms each, and its slope
# 1 is plain from four steps (2.7e-2 … 3.3e-3); its two finest steps were 8.6 of the figure's 24 s
N_H_BY_NAME = {"implicit_euler": 4,
               # five halvings where the sixth's error lies below the fit window (dopri5 3e-14, RODAS4 5e-12, on
               # its linear solves' floor; Radau IIA 2e-14: 0.9 s, the figure's costliest point) or where the
               # slope shown is the same without it (symplectic Euler 0.999, exponential Euler 1.98): 2.2 s of 7
               "radau5": 5, "rodas4": 5, "dopri5": 5, "symplectic_euler": 5, "exponential_euler": 5}


# %% [markdown]
# ## Figure `ch02_convergence`
#
# Global error vs step h on a Kepler orbit (e = 0.3, t = 2; orders 5 and 7: t = 6; order 12: t = 8): slopes = orders.

# %%
@figure("ch02", "convergence", "Global error vs step h on a Kepler orbit (e = 0.3, t = 2; orders 5 and 7: t = 6; order 12: t = 8): slopes = orders",
        cost=6.9)
def convergence(ctx):
    kp = kepler(0.3)
    n_h = 3 if ctx.quick else 6
    data = {"h": {}, "error": {}, "slope": {}, "order": {}}
    for name in ORDER:
        m = METHODS[name]
        T = SPAN.get(m.order, 2.0)  # Dormand–Prince and Verner reach their asymptotic range later
        exact = kp.exact(T)[:, 0]
        hs = H0_BY_NAME.get(name, H0[m.order]) / 2.0 ** np.arange(min(n_h, N_H_BY_NAME.get(name, n_h)))
        errs = []
        for h in hs:
            y = kp.y0.copy()
            # implicit Euler / midpoint: the Newton matrix kept across steps (the states to the Newton tolerance)
            step = NewtonSteps(kp.rhs, name).step if name in THETA else (lambda t, y, h: m.step(kp.rhs, t, y, h, 2))
            for k in range(int(round(T / h))):
                y = step(k * h, y, h)
            errs.append(float(np.max(np.abs(y - exact))))
        data["h"][name], data["error"][name], data["order"][name] = hs, np.array(errs), m.order
        data["slope"][name] = fitted_order(hs, errs, window=(FIT_FLOOR.get(m.order, 1e-10), 0.1))
    fig, ax = ctx.subplots()
    for name in ORDER:
        ax.loglog(data["h"][name], data["error"][name], "o-", ms=3,
                  label=f"{name} (slope {data['slope'][name]:.2f}, order {data['order'][name]})")
    ax.set_xlabel("step h [s]")
    ax.set_ylabel("max |y(t) − y*(t)| at the end (state units)")
    ax.legend(fontsize=7)
    ctx.save(fig)
    return data


def _oscillator_batch(w2, c):
    """ẍ = −ω²x − cẋ for a batch of (ω², c): the linear system whose eigenvalues are z and z̄."""

    def rhs(t, y):
        return np.stack([y[..., 1], -w2 * y[..., 0] - c * y[..., 1]], axis=-1)

    J = np.zeros((len(w2), 2, 2))
    J[:, 0, 1], J[:, 1, 0], J[:, 1, 1] = 1.0, -w2, -c
    return rhs, (lambda t, y: J)


def stability_radius(name, z):
    """Spectral radius of one step (h = 1) on the real system with eigenvalues z, z̄ (batch over z).

    For a Runge–Kutta method this is |R(z)|; for split methods (symplectic Euler, Verlet) it is their
    stability function on the damped oscillator, the natural test equation of a partitioned method.
    """
    z = np.asarray(z, dtype=complex).ravel()
    w2, c = np.abs(z) ** 2, -2 * z.real
    rhs, jac = _oscillator_batch(w2, c)
    step = METHODS[name].step
    cols = [step(rhs, 0.0, np.tile(e, (len(z), 1)), 1.0, 1, jac) for e in np.eye(2)]
    P = np.stack(cols, axis=-1)  # (K, 2, 2): columns are the images of e₁, e₂
    tr, det = P[:, 0, 0] + P[:, 1, 1], P[:, 0, 0] * P[:, 1, 1] - P[:, 0, 1] * P[:, 1, 0]
    disc = np.sqrt(tr.astype(complex) ** 2 / 4 - det)
    return np.maximum(np.abs(tr / 2 + disc), np.abs(tr / 2 - disc))


# %% [markdown]
# ## Figure `ch02_stability`
#
# Absolute stability regions |R(z)| ≤ 1 (shaded), z = hλ (the Nyström pairs, for q̈ = g(q) only, are not drawn).

# %%
@figure("ch02", "stability", "Absolute stability regions |R(z)| ≤ 1 (shaded), z = hλ (the Nyström pairs, for q̈ = g(q) only, are not drawn)")
def stability(ctx):
    n = 80 if ctx.quick else 240  # even: the grid avoids the poles z = 1, 2 of the implicit methods
    x = np.linspace(-5.0, 3.0, n)
    yv = np.linspace(-4.0, 4.0, n)
    Z = x[None, :] + 1j * yv[:, None]
    data = {"x": x, "y": yv, "rho": {}, "R_direct": {}}
    for name in STABILITY_ORDER:
        data["rho"][name] = stability_radius(name, Z).reshape(Z.shape)
        if name in ("euler", "midpoint", "rk4", "dopri5", "vern7", "dop853"):  # R(z): one step of y' = zy, complex y
            step = METHODS[name].step
            data["R_direct"][name] = np.abs(step(lambda t, u: Z * u, 0.0, np.ones_like(Z), 1.0))
    plt_fig, axes = ctx.subplots(4, 4, figsize=(11, 11), sharex=True, sharey=True)
    for ax in axes.ravel()[len(STABILITY_ORDER):]:
        ax.set_visible(False)
    for ax, name in zip(axes.ravel(), STABILITY_ORDER):
        rho = data["rho"][name]
        ax.contourf(x, yv, (rho <= 1.0).astype(float), levels=[0.5, 1.5], colors=["#8ecae6"])
        ax.contour(x, yv, rho, levels=[1.0], colors="k", linewidths=0.8)
        ax.axhline(0, color="0.5", lw=0.5)
        ax.axvline(0, color="0.5", lw=0.5)
        ax.set_title(name, fontsize=8)
        ax.set_aspect("equal")
    for ax in axes[-1]:
        ax.set_xlabel("Re z = h Re λ (1)")
    for ax in axes[:, 0]:
        ax.set_ylabel("Im z = h Im λ (1)")
    ctx.save(plt_fig)
    return data


# %% [markdown]
# ## Figure `ch02_kepler`
#
# Kepler orbit (e = 0.5): trajectories and energy error per method, h = T/400.

# %%
@figure("ch02", "kepler", "Kepler orbit (e = 0.5): trajectories and energy error per method, h = T/400")
def kepler_orbits(ctx):
    kp = kepler(0.5)
    T = kp.period
    orbits = 3 if ctx.quick else 10
    names = ["euler", "symplectic_euler", "verlet", "implicit_midpoint", "rk4", "dopri5"]
    data = {"t": {}, "energy_error": {}, "L_error": {}, "orbit": {}, "E_exact": kp.params["E"]}
    for name in names:
        if name == "dopri5":
            r = solve(kp.rhs, (0, orbits * T), kp.y0, method=name, rtol=1e-6, atol=1e-9)
        else:
            r = solve(kp.rhs, (0, orbits * T), kp.y0, method=name, h=T / 400, split=2)
        data["t"][name] = r.t
        data["orbit"][name] = r.y[:2]
        data["energy_error"][name] = kp.invariants["energy"](r.y) - kp.params["E"]
        data["L_error"][name] = kp.invariants["angular_momentum"](r.y) - kp.params["L"]
    fig, (a1, a2) = ctx.subplots(1, 2, figsize=(11, 4.4))
    for name in names:
        a1.plot(*data["orbit"][name], lw=0.7, label=name)
        a2.semilogy(data["t"][name] / T, np.abs(data["energy_error"][name]) + 1e-17, lw=0.7, label=name)
    a1.set_aspect("equal")
    a1.set_xlabel("x [GM = a = 1 units]")
    a1.set_ylabel("y [GM = a = 1 units]")
    a1.set_title("orbits")
    a1.legend(fontsize=7)
    a2.set_xlabel("t / T (orbits)")
    a2.set_ylabel("|E(t) − E*| [GM = a = 1 units]")
    a2.set_title("energy error")
    ctx.save(fig)
    return data


# %% [markdown]
# ## Figure `ch02_work_precision`
#
# Work-precision: error vs wall time, pbanim (solid) vs scipy solve_ivp (dashed) and odeint (dotted).

# %%
@figure("ch02", "work_precision", "Work-precision: error vs wall time, pbanim (solid) vs scipy solve_ivp (dashed) and odeint (dotted)",
        cost=27.0)
def work_precision(ctx):
    from pbanim.bench.ode import PROBLEMS, sweep_problem

    quick = ctx.quick
    keys = ["kepler", "robertson"] if quick else ["kepler", "pleiades", "van_der_pol", "robertson"]
    # full: one tolerance per decade (the curves are straight in log-log between them), runs past 0.5 s end a
    # variant's sweep; a point is the best of 2 runs below 0.05 s, of 1 above (before: half decades, 5 s, 3
    # runs below 0.5 s: 165 s; then 1.5 s and 3 runs below 0.05 s: 57 s CPU; the runs themselves are the cost,
    # each a decade tighter costs 1.5-2x more, so the budget sets it: the slowest variants now stop about one
    # decade of error earlier, the ordering and the slopes of the curves are those of the longer sweep)
    tols = [1e-3, 1e-5, 1e-7] if quick else [10.0 ** -k for k in range(3, 13)]
    fig, axes = ctx.subplots(1, len(keys), figsize=(5.2 * len(keys), 4.4))
    out = {}
    for ax, key in zip(np.atleast_1d(axes), keys):
        title = PROBLEMS[key][0]
        # each point timed once (it was the best of 2 below 0.05 s: those short runs were timed twice)
        sweeps = sweep_problem(key, tols, repeats=1, budget=0.3 if quick else 0.5)
        out[title] = sweeps
        for v, pts in sweeps.items():
            style = "o-" if v.startswith("pbanim") else ("k:" if v == "odeint" else "s--")
            ax.loglog([p[2] for p in pts], [max(p[1], 1e-16) for p in pts], style, ms=3, label=v)
        ax.set_xlabel("wall time [s]")
        ax.set_ylabel("error at t_end (state units)")
        ax.set_title(title, fontsize=9)
        ax.legend(fontsize=6)
    ctx.save(fig)
    return {"sweeps": out}


# %% [markdown]
# ## Figure `ch02_stiff_spring`
#
# Stiff spring k = 1e6 at hω = 2.5: Euler and symplectic Euler explode (limit hω < 2), RK4 (limit 2√2) and implicit methods do not.

# %%
@figure("ch02", "stiff_spring", "Stiff spring k = 1e6 at hω = 2.5: Euler and symplectic Euler explode (limit hω < 2), RK4 (limit 2√2) and implicit methods do not")
def stiff_spring(ctx):
    m = damped_oscillator(1e3, 20.0)
    h = 2.5e-3
    t_end = 0.5 if ctx.quick else 1.0
    data = {"h": h, "omega": 1e3, "t": {}, "x": {}, "diverged_at": {}}
    for name in ["euler", "symplectic_euler", "rk4", "implicit_euler", "implicit_midpoint", "exponential_euler",
                 "rodas4", "radau5"]:
        meth = METHODS[name]
        ts, xs, y = [0.0], [m.y0[0]], m.y0.copy()
        for k in range(int(round(t_end / h))):  # the method's own steps, stopped at a visible blow-up
            y = meth.step(m.rhs, k * h, y, h, 1, m.jac)
            ts.append((k + 1) * h), xs.append(y[0])
            if abs(y[0]) > 1e3:  # a thousand times the initial amplitude: diverged
                data["diverged_at"][name] = (k + 1) * h
                break
        data["t"][name], data["x"][name] = np.asarray(ts), np.asarray(xs)
    fig, ax = ctx.subplots()
    for name in data["t"]:
        ax.semilogy(data["t"][name], np.abs(data["x"][name]) + 1e-300, lw=0.9, label=name)
    ax.set_xlabel("t [s]")
    ax.set_ylabel("|x(t)| [m]")
    ax.set_ylim(1e-12, 1e4)
    ax.legend()
    ctx.save(fig)
    return data


# %% [markdown]
# ## Draw the figures
#
# As a script or in a notebook kernel, draw this chapter's figures (quick mode) into `figures/`.

# %%
if __name__ == "__main__":
    from pathlib import Path

    from pbanim.plotting import figures_of, run_figure

    for _key, _spec in figures_of({"ch02"}).items():
        print(_key, [p.name for p in run_figure(_spec, Path("figures"), quick=True)[1]])
