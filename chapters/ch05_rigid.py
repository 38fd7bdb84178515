# %% [markdown]
# # Chapter 05 — rigid bodies: Baraff's state (x, q, P, L), torque-free tumbling, quaternion drift.
#
# This file is a module (imported by `pbanim figures`) and a notebook in jupytext's percent format:
# open it in Jupyter (with jupytext) or VS Code, or write an `.ipynb` with `pbanim notebook ch05 DIR`.
# Running it draws every figure of the chapter in quick mode into `figures/`.

# %%
"""Chapter 05 — rigid bodies: Baraff's state (x, q, P, L), torque-free tumbling, quaternion drift.

Figures:

* ``tumbling_omega``: body ω(t) of a torque-free asymmetric body, RK4 simulation vs the Jacobi elliptic
  closed form (ORACLES C1).
* ``polhode``: body angular momentum L = Iω on the momentum sphere |L| = const and the energy ellipsoid
  Σ Lᵢ²/Iᵢ = 2T: the polhodes are their intersections; the separatrix passes through the middle axis.
* ``t_handle_flip``: the T-handle spun about its intermediate axis flips every half period 2K(m)/λ while T
  and |L| stay constant (ORACLES C2); spins about the other axes stay put.
* ``quat_drift``: ||q| − 1| per integrator without renormalization, explicit Euler on its exact law
  (1 + h²|ω|²/4)^(n/2), and with renormalization / the exponential map (ORACLES C3). |q|² is a quadratic
  invariant of q̇ = ½(0, ω)⊗q (the map is skew), so implicit midpoint keeps it to its Newton tolerance;
  symplectic Euler coincides with explicit Euler on q here (L̇ = 0 makes the kick trivial); Verlet is the
  rigid-body splitting (exact rotations about the principal axes) and keeps |q| = 1 to roundoff.
* ``work_precision``: error of ω(t) vs wall time per integrator and quaternion policy.
* ``tumbling_box``: an animation (GIF) of a box tumbling about an axis near its intermediate axis.
"""

from __future__ import annotations

import numpy as np

from pbanim.models.rigid import t_handle, torque_free_body
from pbanim.plotting import figure
from pbanim.rigid import RigidBodies, RigidScene, box_inertia, box_mesh, quat_to_matrix

I3 = (1.0, 2.0, 3.0)
OMEGA0 = (1.0, 0.1, 2.0)


# %% [markdown]
# ## Figure `ch05_tumbling_omega`
#
# Torque-free asymmetric body: body ω(t), RK4 vs Jacobi elliptic closed form.
#
# Body ω(t) of a torque-free asymmetric body, RK4 simulation vs the Jacobi elliptic closed form
# (ORACLES C1).

# %%
@figure("ch05", "tumbling_omega", "Torque-free asymmetric body: body ω(t), RK4 vs Jacobi elliptic closed form")
def tumbling_omega(ctx):
    h = 0.05 if ctx.quick else 0.01
    t_end = 10.0 if ctx.quick else 20.0
    body = torque_free_body(I3, OMEGA0)
    rb = body.bodies(orientation=[0.3, 0.5, -0.2, 0.8])
    res = RigidScene(rb).simulate(t_end, h, method="rk4")
    w_sim = np.array([rb.body_angular_velocity(y)[0] for y in res.y.T])
    tt = np.linspace(0, t_end, 800)
    w_ex = body.omega(tt)
    err = np.abs(w_sim - body.omega(res.t)).max(axis=1)
    fig, (ax, ax2) = ctx.subplots(2, 1, figsize=(7, 6), sharex=True)
    for k in range(3):
        ax.plot(tt, w_ex[:, k], color=f"C{k}", label=f"ω{k + 1} closed form (I{k + 1} = {I3[k]:g} kg·m²)")
        ax.plot(res.t[::max(1, len(res.t) // 80)], w_sim[::max(1, len(res.t) // 80), k], "o", ms=3, mfc="none",
                color=f"C{k}")
    ax.plot([], [], "ko", mfc="none", ms=3, label=f"RK4, h = {h} s (renormalized)")
    ax.set(ylabel="body ω (rad/s)", title=f"ω(t) in Jacobi elliptic functions, m = k² = {body.m:.3f}, "
                                         f"period 4K(m)/λ = {body.period:.3f} s")
    ax.set_ylim(-1.2, 3.2)
    ax.legend(loc="upper right", ncol=2)
    ax2.semilogy(res.t[1:], err[1:])
    ax2.set(xlabel="t (s)", ylabel="max |ω_sim − ω_exact| (rad/s)", title="error")
    ctx.save(fig)
    return {"t": res.t, "omega_sim": w_sim, "omega_exact": body.omega(res.t), "max_err": float(err.max()),
            "h": h, "period": body.period, "energy": res.diagnostics["kinetic"],
            "angular_momentum": res.diagnostics["angular_momentum"]}


# %% [markdown]
# ## Figure `ch05_polhode`
#
# Polhodes: body L on the momentum sphere ∩ energy ellipsoid.
#
# Body angular momentum L = Iω on the momentum sphere |L| = const and the energy ellipsoid Σ Lᵢ²/Iᵢ
# = 2T: the polhodes are their intersections; the separatrix passes through the middle axis.

# %%
@figure("ch05", "polhode", "Polhodes: body L on the momentum sphere ∩ energy ellipsoid")
def polhode(ctx):
    I = np.array(I3)
    Lmag = 2.0
    n = 6 if ctx.quick else 12
    # body L(0) on the sphere |L| = Lmag, swept from near the min axis to near the max axis
    angles = np.linspace(0.08, np.pi / 2 - 0.08, n)
    curves, checks = [], []
    for a in angles:
        for axis in (0, 2):
            L0 = np.zeros(3)
            L0[axis] = Lmag * np.cos(a)
            L0[1] = Lmag * np.sin(a)
            b = torque_free_body(I, L0 / I)
            t = np.linspace(0, b.period if np.isfinite(b.period) else 50.0, 200)
            Lb = b.angular_momentum_body(t)
            curves.append(Lb)
            checks.append((np.abs(np.linalg.norm(Lb, axis=1) - Lmag).max(),
                           np.abs(np.sum(Lb ** 2 / I, axis=1) - 2 * b.energy).max() / (2 * b.energy)))
    # one simulated polhode (full rigid body, RK4) on top of the closed forms
    b = torque_free_body(I, np.array([0.2, 1.0, 1.2]) * Lmag / np.linalg.norm([0.2, 2.0, 3.6]))
    rb = b.bodies(orientation=[0.9, 0.1, 0.3, -0.2])
    res = RigidScene(rb).simulate(b.period, b.period / (100 if ctx.quick else 400), method="rk4")
    Lsim = np.array([rb.body_angular_velocity(y)[0] for y in res.y.T]) * I
    fig, ax = ctx.subplots(figsize=(6.4, 6.0), subplot_kw={"projection": "3d"})
    u, v = np.meshgrid(np.linspace(0, 2 * np.pi, 40), np.linspace(0, np.pi, 20))
    sph = Lmag * np.stack([np.cos(u) * np.sin(v), np.sin(u) * np.sin(v), np.cos(v)])
    ax.plot_wireframe(*sph, color="0.8", lw=0.4, label="momentum sphere |L| = 2 kg·m²/s")
    E2 = 2 * b.energy
    ell = np.sqrt(E2 * I)[:, None, None] * np.stack([np.cos(u) * np.sin(v), np.sin(u) * np.sin(v), np.cos(v)])
    ax.plot_wireframe(*ell, color="C1", lw=0.3, alpha=0.5, label=f"energy ellipsoid 2T = {E2:.2f} J")
    for k, Lb in enumerate(curves):
        ax.plot(*Lb.T, color="C0", lw=0.8, label="polhodes, closed form (|L| = 2, varying T)" if k == 0 else None)
    ax.plot(*Lsim.T, "k.", ms=2, label="RK4 simulation (full rigid body)")
    ax.set(xlabel="L₁ (kg·m²/s)", ylabel="L₂ (kg·m²/s)", zlabel="L₃ (kg·m²/s)")
    ax.set_box_aspect((1, 1, 1))
    ax.legend(loc="upper left")
    ctx.save(fig)
    checks = np.array(checks)
    return {"curves": curves, "sphere_err": checks[:, 0], "ellipsoid_err": checks[:, 1], "L_sim": Lsim,
            "L_mag": Lmag, "moments": I, "energy_sim": 2 * b.energy}


# %% [markdown]
# ## Figure `ch05_t_handle_flip`
#
# T-handle (Dzhanibekov): the intermediate-axis flip, T and |L| conserved.
#
# The T-handle spun about its intermediate axis flips every half period 2K(m)/λ while T and |L| stay
# constant (ORACLES C2); spins about the other axes stay put.

# %%
@figure("ch05", "t_handle_flip", "T-handle (Dzhanibekov): the intermediate-axis flip, T and |L| conserved")
def t_handle_flip(ctx):
    h = 0.01
    th = t_handle(spin=6.0, perturbation=1e-3, axis=1)
    b = th.body
    t_end = round((1.3 if ctx.quick else 2.5) * b.period / h) * h    # whole steps of h
    rb = b.bodies()
    res = RigidScene(rb).simulate(t_end, h, method="rk4", record_every=2)
    w = np.array([rb.body_angular_velocity(y)[0] for y in res.y.T])
    T = res.diagnostics["kinetic"]
    Lnorm = np.linalg.norm(res.diagnostics["angular_momentum"], axis=1)
    flips = res.t[1:][np.sign(w[1:, 1]) != np.sign(w[:-1, 1])]
    stable = {}
    for axis in (0, 2):
        s = t_handle(spin=6.0, perturbation=1e-3, axis=axis).body
        rs = RigidScene(s.bodies()).simulate(t_end, 2 * h, method="rk4", record_every=5, diagnostics=False)
        ws = np.array([s.bodies().body_angular_velocity(y)[0] for y in rs.y.T])
        stable[axis] = float(np.abs(np.delete(ws, axis, axis=1)).max())
    fig, (ax, ax2) = ctx.subplots(2, 1, figsize=(7, 6), sharex=True)
    for k in range(3):
        ax.plot(res.t, w[:, k], color=f"C{k}", label=f"ω{k + 1} (I{k + 1} = {th.moments[k]:.4f} kg·m²)")
    ax.plot(res.t, b.omega(res.t)[:, 1], "k:", lw=1, label="ω₂ closed form")
    for f in flips:
        ax.axvline(f, color="0.6", lw=0.6)
    ax.set(ylabel="body ω (rad/s)", title=f"spin 6 rad/s about the intermediate axis, perturbation 1e-3; "
                                         f"half period 2K(m)/λ = {b.period / 2:.2f} s")
    ax.legend(loc="lower left", ncol=2)
    ax2.plot(res.t, T / T[0] - 1, label="T/T₀ − 1")
    ax2.plot(res.t, Lnorm / Lnorm[0] - 1, label="|L|/|L₀| − 1 (exact: Baraff's state)")
    ax2.set(xlabel="t (s)", ylabel="relative change (1)", title="invariants through the flips (RK4, h = 0.01 s)")
    ax2.legend()
    ctx.save(fig)
    return {"t": res.t, "omega": w, "omega2_exact": b.omega(res.t)[:, 1], "flips": flips, "period": b.period,
            "kinetic": T, "L_norm": Lnorm, "stable_offaxis_max": np.array([stable[0], stable[2]]),
            "spin": 6.0, "perturbation": 1e-3}


# %% [markdown]
# ## Figure `ch05_quat_drift`
#
# Quaternion norm drift per integrator; renormalization; exponential map.
#
# ||q| − 1| per integrator without renormalization, explicit Euler on its exact law (1 +
# h²|ω|²/4)^(n/2), and with renormalization / the exponential map (ORACLES C3). |q|² is a quadratic
# invariant of q̇ = ½(0, ω)⊗q (the map is skew), so implicit midpoint keeps it to its Newton
# tolerance; symplectic Euler coincides with explicit Euler on q here (L̇ = 0 makes the kick
# trivial); Verlet is the rigid-body splitting (exact rotations about the principal axes) and keeps
# |q| = 1 to roundoff.

# %%
@figure("ch05", "quat_drift", "Quaternion norm drift per integrator; renormalization; exponential map", cost=2.5)
def quat_drift(ctx):
    h = 0.05
    t_end = 10.0 if ctx.quick else 40.0
    body = torque_free_body(I3, OMEGA0)
    rb = body.bodies()
    methods = ["euler", "symplectic_euler", "midpoint", "rk4", "implicit_midpoint"] if ctx.quick else \
        ["euler", "symplectic_euler", "midpoint", "verlet", "rk4", "implicit_midpoint"]
    out = {"t": None, "drift": {}, "h": h}
    fig, ax = ctx.subplots(figsize=(7, 4.5))
    for m in methods:
        res = RigidScene(rb, quaternions="none").simulate(t_end, h, method=m)
        d = np.abs(np.linalg.norm(res.y[3:7], axis=0) - 1)
        out["drift"][m] = d
        out["t"] = res.t
        note = " = euler here (L̇ = 0)" if m == "symplectic_euler" else ""
        ax.semilogy(res.t[1:], d[1:], ls="--" if note else "-", label=f"{m} (no renormalization){note}")
    # explicit Euler's exact law, step by step: |q_{n+1}| = |q_n| √(1 + h²|ω_n|²/4)
    res = RigidScene(rb, quaternions="none").simulate(t_end, h, method="euler")
    wn = np.array([np.linalg.norm(rb.velocities(y)[1][0]) for y in res.y.T])
    law = np.concatenate([[1.0], np.cumprod(np.sqrt(1 + h * h * wn[:-1] ** 2 / 4))])
    out["euler_law"] = law
    ax.semilogy(res.t[1:], law[1:] - 1, "k:", lw=1.5, label="Euler law Π√(1 + h²|ω|²/4) − 1")
    for mode, style in (("renormalize", "--"), ("exponential", "-.")):
        r = RigidScene(rb, quaternions=mode).simulate(t_end, h, method="rk4")
        d = np.maximum(r.diagnostics["quat_norm_error"], 1e-17)
        out["drift"][f"rk4+{mode}"] = d
        ax.semilogy(r.t, d, style, label=f"rk4 + {mode}")
    ax.axhline(np.finfo(float).eps, color="0.5", lw=0.6)
    ax.text(0.2, 3e-16, "machine ε", fontsize=7, color="0.4")
    ax.set(xlabel="t (s)", ylabel="||q| − 1| (1)", title=f"quaternion drift, torque-free body, h = {h} s",
           ylim=(1e-17, 10))
    ax.legend(loc="center right", fontsize=7)
    ctx.save(fig)
    return out


# %% [markdown]
# ## Figure `ch05_work_precision`
#
# Torque-free body: error of ω(t) vs wall time per integrator and quaternion policy.
#
# Error of ω(t) vs wall time per integrator and quaternion policy.

# %%
@figure("ch05", "work_precision", "Torque-free body: error of ω(t) vs wall time per integrator and quaternion policy",
        cost=5.0)
def work_precision(ctx):
    from pbanim.bench.rigid import work_precision as wp

    rows = wp(ctx.quick)
    fig, ax = ctx.subplots(figsize=(7, 5))
    styles = {"renormalize": "-", "none": ":", "exponential": "--"}
    variants = sorted({r.variant for r in rows})
    methods = sorted({v[0] for v in variants})
    data = {}
    for v in variants:
        rr = [r for r in rows if r.variant == v]
        err = np.array([r.error for r in rr])
        wall = np.array([r.wall_time for r in rr])
        data[f"{v[0]}+{v[1]}"] = {"h": np.array([r.param for r in rr]), "error": err, "wall_time": wall,
                                  "nfev": np.array([r.nfev for r in rr])}
        ax.loglog(wall, err, styles[v[1]], marker="o", ms=3, color=f"C{methods.index(v[0])}",
                  label=f"{v[0]}, {v[1]}")
    ax.set(xlabel="wall time (s)", ylabel="max |ω(t_end) − ω_exact| (rad/s)",
           title="work-precision, torque-free asymmetric body (ORACLES C1)")
    ax.legend(fontsize=6, ncol=2)
    ctx.save(fig)
    return {"rows": data}


# %% [markdown]
# ## Figure `ch05_tumbling_box`
#
# A box tumbling near its intermediate axis (animation).
#
# An animation (GIF) of a box tumbling about an axis near its intermediate axis.

# %%
@figure("ch05", "tumbling_box", "A box tumbling near its intermediate axis (animation)", cost=5.0)
def tumbling_box(ctx):
    ext = np.array([0.4, 1.0, 1.6])
    I = box_inertia(1.0, ext)
    w0 = np.array([0.05, 4.0, 0.05])
    rb = RigidBodies(1.0, I, angular_velocities=[w0])
    frames = 8 if ctx.quick else 56
    t_end = 6.0
    every = int(np.ceil(t_end / 0.01 / frames))             # ≤ frames + 1 recorded states (≤ 60 GIF frames)
    res = RigidScene(rb).simulate(t_end, 0.01, method="rk4", record_every=every)
    v, f = box_mesh(ext)
    Rs = [quat_to_matrix(rb.unpack(y)[1])[0] for y in res.y.T]
    fig, ax = ctx.subplots(figsize=(4, 4), subplot_kw={"projection": "3d"})
    from mpl_toolkits.mplot3d.art3d import Poly3DCollection

    # the axes and the box's faces are made once; a frame moves the faces and retitles (the same pixels as
    # clearing the axes and adding the faces anew)
    faces = ax.add_collection3d(Poly3DCollection((v @ Rs[0].T)[f], facecolor="C0", edgecolor="k", alpha=0.7, lw=0.3))
    ax.set(xlim=(-1, 1), ylim=(-1, 1), zlim=(-1, 1), xlabel="x (m)", ylabel="y (m)", zlabel="z (m)",
           xticks=[-1, 0, 1], yticks=[-1, 0, 1], zticks=[-1, 0, 1])
    ax.set_box_aspect((1, 1, 1))

    def update(i):
        faces.set_verts((v @ Rs[i].T)[f])
        ax.set_title(f"t = {res.t[i]:.2f} s")
        return ()

    ctx.save_gif(fig, update, frames=len(Rs), fps=10)
    qn = np.linalg.norm(res.y[3:7], axis=0)
    return {"t": res.t, "frames": len(Rs), "quat_norm": qn, "energy": res.diagnostics["kinetic"],
            "L": res.diagnostics["angular_momentum"], "body_y_axis_world": np.array([R[:, 1] for R in Rs])}


# %% [markdown]
# ## Draw the figures
#
# As a script or in a notebook kernel, draw this chapter's figures (quick mode) into `figures/`.

# %%
if __name__ == "__main__":
    from pathlib import Path

    from pbanim.plotting import figures_of, run_figure

    for _key, _spec in figures_of({"ch05"}).items():
        print(_key, [p.name for p in run_figure(_spec, Path("figures"), quick=True)[1]])
