# %% [markdown]
# # Chapter 01 — particle systems: forces as objects, energy per integrator, stiff springs.
#
# This file is a module (imported by `pbanim figures`) and a notebook in jupytext's percent format:
# open it in Jupyter (with jupytext) or VS Code, or write an `.ipynb` with `pbanim notebook ch01 DIR`.
# Running it draws every figure of the chapter in quick mode into `figures/`.

# %%
"""Chapter 01 — particle systems: forces as objects, energy per integrator, stiff springs.

Figures:

* ``projectile_drag``: a projectile with and without linear drag, simulated (RK4) against the closed
  forms v(t) = v_T + (v₀ − v_T)e^(−kt/m) and free fall.
* ``spring_energy``: a mass on a spring, relative energy error per integrator (ORACLES A1: explicit
  Euler gains exactly (1 + h²ω²) per step, symplectic Euler oscillates within O(hω), RK4 slowly loses).
* ``hanging_net``: a stiff hanging mass-spring net at a large step: explicit Euler diverges, implicit
  Euler with the sparse spring Jacobians stays bounded (Baraff & Witkin 1998).
"""

from __future__ import annotations

import numpy as np

from pbanim.errors import SimulationDiverged
from pbanim.models.particles import hanging_net, projectile_drag_model
from pbanim.ode import METHODS
from pbanim.particles import AnchorSprings, ParticleSystem
from pbanim.plotting import figure
from pbanim.scene import Scene, check_finite


def _ground_range(x: np.ndarray, y: np.ndarray) -> float:
    """x where the trajectory first comes back to y = 0 (linear interpolation)."""
    i = np.flatnonzero((y[:-1] > 0) & (y[1:] <= 0))[0]
    return float(x[i] + (x[i + 1] - x[i]) * y[i] / (y[i] - y[i + 1]))


# %% [markdown]
# ## Figure `ch01_projectile_drag`
#
# Projectile with and without linear drag: RK4 vs exact.
#
# A projectile with and without linear drag, simulated (RK4) against the closed forms v(t) = v_T +
# (v₀ − v_T)e^(−kt/m) and free fall.

# %%
@figure("ch01", "projectile_drag", "Projectile with and without linear drag: RK4 vs exact")
def projectile_drag(ctx):
    h = 0.05 if ctx.quick else 0.01
    t_end = 2.2
    out, curves = {}, {}
    for label, k in (("nodrag", 0.0), ("drag", 0.5)):
        model = projectile_drag_model(mass=1.0, drag=k, velocity=(10.0, 10.0))
        res = model.scene().simulate(t_end, h, "rk4")
        ex = model.exact(res.t)
        out[f"max_err_{label}"] = float(np.abs(res.y[:2].T - ex["x"]).max())
        out[f"range_{label}"] = _ground_range(res.y[0], res.y[1])
        tt = np.linspace(0, t_end, 400)
        curves[label] = (res, model.exact(tt), tt, model)
    fig, (ax, ax2) = ctx.subplots(1, 2, figsize=(10, 4))
    for label, color in (("nodrag", "C0"), ("drag", "C1")):
        res, ex, tt, model = curves[label]
        name = "no drag" if label == "nodrag" else f"drag k = {model.params['drag']} kg/s"
        ax.plot(ex["x"][:, 0], ex["x"][:, 1], color=color, label=f"exact, {name}")
        ax.plot(res.y[0, ::4], res.y[1, ::4], "o", ms=3, color=color, mfc="none", label=f"RK4 h = {h} s, {name}")
        ax2.plot(tt, np.linalg.norm(ex["v"], axis=1), color=color, label=f"exact, {name}")
        ax2.plot(res.t[::4], np.linalg.norm(res.y[2:, ::4], axis=0), "o", ms=3, color=color, mfc="none")
    vT = float(np.linalg.norm(curves["drag"][3].params["v_terminal"]))
    ax2.axhline(vT, ls="--", color="C1", lw=0.8, label=f"terminal speed mg/k = {vT:.1f} m/s")
    ax.axhline(0.0, color="k", lw=0.6)
    ax.set(xlabel="x (m)", ylabel="y (m)", title="trajectory")
    ax2.set(xlabel="t (s)", ylabel="|v| (m/s)", title="speed")
    ax.legend(loc="lower left")
    ax2.legend(loc="lower left")
    ctx.save(fig)
    out["h"] = h
    out["v_terminal"] = vT
    return out


def _spring_energy_methods():
    return [name for name in ("euler", "midpoint", "rk4", "symplectic_euler", "verlet", "implicit_euler",
                              "implicit_midpoint") if name in METHODS]


# %% [markdown]
# ## Figure `ch01_spring_energy`
#
# Mass on a spring: relative energy error per integrator.
#
# A mass on a spring, relative energy error per integrator (ORACLES A1: explicit Euler gains exactly
# (1 + h²ω²) per step, symplectic Euler oscillates within O(hω), RK4 slowly loses).

# %%
@figure("ch01", "spring_energy", "Mass on a spring: relative energy error per integrator", cost=1.5)
def spring_energy(ctx):
    k, m = 4.0, 1.0                       # ω = 2 rad/s
    omega = np.sqrt(k / m)
    h = 0.05
    periods = 5 if ctx.quick else 20
    t_end = round(periods * 2 * np.pi / omega / h) * h   # whole steps: the one-step factors compound exactly
    ps = ParticleSystem([[1.0, 0.0]], masses=m)
    scene = Scene(ps, [AnchorSprings([0], [[0.0, 0.0]], stiffness=k)])
    rel, times = {}, None
    for name in _spring_energy_methods():
        res = scene.simulate(t_end, h, name)
        E = res.diagnostics["energy"]
        rel[name] = (E - E[0]) / E[0]
        times = res.t
    fig, ax = ctx.subplots()
    for name, r in rel.items():
        ax.plot(times, np.abs(r) + 1e-17, label=name)
    ax.set_yscale("log")
    ax.set(xlabel="t (s)", ylabel="|E(t) − E₀| / E₀ (1)",
           title=f"mass on a spring, hω = {h * omega:.2g}: relative energy error per method")
    ax.legend(ncol=2)
    ctx.save(fig)
    return {"rel_energy": rel, "t": times, "h_omega": float(h * omega)}


def _static_sag(net) -> np.ndarray:
    """Linear static equilibrium in the net's plane: K u = −Q(x₀) with K = ∂Q/∂x (x, y components)."""
    from scipy.sparse.linalg import spsolve

    scene = net.scene()
    y0 = net.system.state()
    s = net.system.split
    K = sum(e.jacobian(0.0, y0).dQdx for e in net.effects if e.jacobian(0.0, y0).dQdx is not None)
    Q0 = scene.forces(0.0, y0).ravel()
    inplane = np.flatnonzero(np.arange(s) % 3 < 2)  # out of plane, a straight net has no stiffness
    u = np.zeros(s)
    u[inplane] = spsolve(K[inplane][:, inplane].tocsc(), -Q0[inplane])
    return u.reshape(-1, 3)


# %% [markdown]
# ## Figure `ch01_hanging_net`
#
# Stiff hanging net at a large step: explicit vs implicit Euler.
#
# A stiff hanging mass-spring net at a large step: explicit Euler diverges, implicit Euler with the
# sparse spring Jacobians stays bounded (Baraff & Witkin 1998).

# %%
@figure("ch01", "hanging_net", "Stiff hanging net at a large step: explicit vs implicit Euler", cost=3.0)
def hanging_net_figure(ctx):
    n = 6 if ctx.quick else 12
    net = hanging_net(n, n, spacing=0.1, mass=0.01, stiffness=1e4, damping=0.0)
    h = 1e-2
    t_end = 1.5 if ctx.quick else 2.0
    s = net.system.split
    # stiffest frequency at rest: ω_max² = largest eigenvalue of −W ∂Q/∂x
    A = net.scene().jac(0.0, net.system.state())[s:, :s].toarray()
    omega_max = float(np.sqrt(np.max(np.abs(np.linalg.eigvals(A)))))
    h_omega = h * omega_max
    bottom = (n - 1) * n + n // 2                      # bottom row, middle particle
    sag = _static_sag(net)[bottom, 1]
    # explicit Euler, step by step until the state stops being finite (SimulationDiverged)
    scene = net.scene()
    y = net.system.state()
    E0 = scene.energy(y)
    ex_t, ex_E, ex_dy, diverged_at = [0.0], [E0], [0.0], None
    for k in range(int(round(t_end / h))):
        try:
            y = scene.step(k * h, y, h, "euler")
            check_finite(y, k * h, k)
        except SimulationDiverged as exc:
            diverged_at = exc.t
            break
        ex_t.append((k + 1) * h)
        ex_E.append(scene.energy(y))
        ex_dy.append(y[3 * bottom + 1] - net.system.x0[bottom, 1])
    imp = net.scene().simulate(t_end, h, "implicit_euler")
    springs = net.effects[0]
    strain = imp.diagnostics[f"{springs.name}_max_strain"]
    imp_dy = imp.y[3 * bottom + 1] - net.system.x0[bottom, 1]
    fig, (ax, ax2) = ctx.subplots(1, 2, figsize=(10, 4))
    dE = lambda E: np.clip(np.abs(np.asarray(E) - E0), 1e-12, 1e200)  # noqa: E731  (plot only)
    ax.plot(ex_t, dE(ex_E), "o-", ms=2, label="explicit Euler (clipped at 1e200)" + (f" (diverged at t = {diverged_at:.2g} s)"
                                                                   if diverged_at is not None else ""))
    ax.plot(imp.t, dE(imp.diagnostics["energy"]), label="implicit Euler (sparse Jacobian)")
    ax.set_yscale("log")
    ax.set(xlabel="t (s)", ylabel="|E(t) − E₀| (J)",
           title=f"{n}×{n} net, k_s = 1e4 N/m, h = {h} s, h·ω_max = {h_omega:.0f}")
    ax.legend()
    ax2.plot(imp.t, 1e3 * imp_dy, color="C1", label="implicit Euler")
    ax2.plot(ex_t, 1e3 * np.clip(ex_dy, -1.0, 1.0), "o", ms=2, color="C0", label="explicit Euler (clipped at ±1 m)")
    ax2.axhline(1e3 * sag, ls="--", color="k", lw=0.8, label=f"static equilibrium K u = −Q: {1e3 * sag:.3f} mm")
    ax2.set(xlabel="t (s)", ylabel="vertical displacement (mm)", title="bottom-centre particle",
            ylim=(3e3 * sag, -1e3 * sag))
    ax2.legend(loc="upper right")
    ctx.save(fig)
    return {"explicit_diverged": diverged_at is not None,
            "diverged_at": diverged_at if diverged_at is not None else np.nan,
            "explicit_energy": np.array(ex_E), "implicit_energy": imp.diagnostics["energy"],
            "implicit_t": imp.t, "implicit_max_strain": float(np.max(strain)), "h_omega": float(h_omega),
            "omega_max_bound": net.params["omega_max_bound"], "omega_max": omega_max,
            "implicit_final_sag": float(imp_dy[-1]), "static_sag": float(sag), "njev": imp.njev}


# %% [markdown]
# ## Draw the figures
#
# As a script or in a notebook kernel, draw this chapter's figures (quick mode) into `figures/`.

# %%
if __name__ == "__main__":
    from pathlib import Path

    from pbanim.plotting import figures_of, run_figure

    for _key, _spec in figures_of({"ch01"}).items():
        print(_key, [p.name for p in run_figure(_spec, Path("figures"), quick=True)[1]])
