"""Chapter 10 — design of rigid-body motion (Popović): S(t, u), ∂S/∂u, min-norm edits, shooting.

Figures:

* ``s_across_impact``: the height z(T) of a thrown ball as a function of its launch speed, across the
  speed where it gains a bounce before T: S(t, u) jumps (the deck's "not continuous"), and its analytic
  derivative is smooth on each side.
* ``derivative_vs_fd_step``: error of centred finite differences (plain and Richardson) against the
  analytic ∂S/∂u of a tumbling box through two impacts, vs the step δ (ORACLES H2).
* ``edit_sequence``: dragging a bouncing ball's position at t = 2 s to a target: the trajectory morphs
  frame by frame (one min-norm update per frame), then the residual of the Gauss–Newton edit (ORACLES H5).
* ``die_toss``: a die thrown off a wall so that after its corner impacts it shows a chosen face up at a
  chosen place: orientation and position goals at once.
* ``ball_into_target``: a ball bounced off a wall into a target (GIF of the edit).
* ``shooting``: single vs multiple shooting on a long, many-bounce sketch: constraint violation per
  SLSQP iterate.
"""

from __future__ import annotations

import numpy as np

from pbanim.collision import Box, Plane, Sphere
from pbanim.design import DesignBody, DesignScene, simulate
from pbanim.design.check import analytic_jacobian, fd_jacobian
from pbanim.design.control import drag, edit, orientation_goal, position_goal
from pbanim.design.shooting import multiple_shooting, single_shooting
from pbanim.plotting import figure
from pbanim.rigid import quat_from_axis_angle, quat_to_matrix


def _ball(v, x0=(0.0, 0.0, 1.0), eps=0.8, walls=True):
    planes = [Plane([0, 0, 1])] + ([Plane([-1, 0, 0], offset=-2.0)] if walls else [])
    return DesignScene([DesignBody(Sphere(0.1), position=x0, velocity=v)], planes, restitution=eps)


@figure("ch10", "s_across_impact", "S(t, u) jumps where a bounce appears")
def s_across_impact(ctx):
    """Height at T = 1.2 s vs launch speed: discontinuous where the ball gains a bounce before T."""
    T = 1.2
    vz = np.linspace(0.0, 3.0, 21 if ctx.quick else 61)
    z, dz, nimp = [], [], []
    for v in vz:
        tr = simulate(_ball([0.5, 0.0, v], walls=False), T, ["v0"], h=0.02, warn=False)
        z.append(tr.position(0, T)[2]), dz.append(tr.d_position(0, T)[2, 2]), nimp.append(len(tr.impacts))
    z, dz, nimp = np.array(z), np.array(dz), np.array(nimp)
    fig, axs = ctx.subplots(1, 2, figsize=(10, 3.6))
    for k in np.unique(nimp):
        sel = nimp == k
        axs[0].plot(vz[sel], z[sel], "o-", ms=3, label=f"{k} impact(s) before T")
        axs[1].plot(vz[sel], dz[sel], "o-", ms=3)
    axs[0].set_xlabel("launch speed v₀z (m/s)"), axs[0].set_ylabel("z(T) (m)"), axs[0].legend()
    axs[1].set_xlabel("launch speed v₀z (m/s)"), axs[1].set_ylabel("∂z(T)/∂v₀z (s)")
    ctx.save(fig)
    return {"vz": vz, "z": z, "dz": dz, "impacts": nimp, "T": T}


@figure("ch10", "derivative_vs_fd_step", "Analytic ∂S/∂u vs finite differences")
def derivative_vs_fd_step(ctx):
    """Max error of centred FD (plain, Richardson) vs the analytic derivative, against the step δ."""
    b = DesignBody(Box([0.2, 0.15, 0.1]), mass=1.3, position=[0, 0, 1.0],
                   orientation=quat_from_axis_angle([1, 2, 3], 0.7), velocity=[1.0, 0.3, 2.0],
                   angular_velocity=[3.0, -2.0, 4.0])
    s = DesignScene([b], [Plane([0, 0, 1])], restitution=0.6)
    names, T = ["v0", "omega0"], 0.68
    outs = [(0, T, "position"), (0, T, "orientation")]
    tr = simulate(s, T, names)
    A = analytic_jacobian(tr, outs)
    deltas = np.logspace(-7, -2, 4 if ctx.quick else 9)
    plain, rich = [], []
    for d in deltas:
        plain.append(np.abs(fd_jacobian(s, names, None, T, outs, delta=d, richardson=False) - A).max())
        rich.append(np.abs(fd_jacobian(s, names, None, T, outs, delta=d) - A).max())
    fig, ax = ctx.subplots()
    ax.loglog(deltas, plain, "o-", label="centred difference")
    ax.loglog(deltas, rich, "s-", label="Richardson (4D(δ/2) − D(δ))/3")
    ax.set_xlabel("step δ (1)"), ax.set_ylabel("max |FD − analytic| (m, rad per unit u)"), ax.legend()
    ctx.save(fig)
    return {"deltas": deltas, "plain": np.array(plain), "richardson": np.array(rich), "impacts": len(tr.impacts),
            "scale": float(np.abs(A).max())}


@figure("ch10", "edit_sequence", "Dragging a bouncing ball: the trajectory morphs")
def edit_sequence(ctx):
    """One min-norm update per frame while the target moves; then Gauss–Newton edits to 1e-6."""
    s, T, target = _ball([1.0, 0.3, 2.0]), 2.0, np.array([0.5, 1.2, 0.6])
    frames = drag(s, ["x0", "v0"], None, 0, T, target, T, frames=4 if ctx.quick else 8, h=0.02)
    res = edit(s, ["x0", "v0"], None, [position_goal(0, T, target)], T, h=0.02)
    fig, axs = ctx.subplots(1, 2, figsize=(10, 3.8))
    for k, (u, x) in enumerate(frames):
        tr = simulate(s, T, ["x0", "v0"], u, h=0.02, sensitivities=False, warn=False)
        P = tr.positions(0)
        axs[0].plot(P[:, 0], P[:, 2], color=(k / len(frames), 0.3, 1 - k / len(frames)), lw=1)
        axs[0].plot(*x[[0, 2]], "k.", ms=4)
    axs[0].plot(target[0], target[2], "r*", ms=10, label="target at t = 2 s")
    axs[0].set_xlabel("x (m)"), axs[0].set_ylabel("z (m)"), axs[0].legend()
    axs[1].semilogy([r for _, r in res.history], "o-")
    axs[1].axhline(1e-6, color="gray", ls="--")
    axs[1].set_xlabel("update (1)"), axs[1].set_ylabel("max |residual| (m)")
    ctx.save(fig)
    reached = np.array([x for _, x in frames])
    return {"reached": reached, "target": target, "edit_residuals": np.array([r for _, r in res.history]),
            "edit_success": res.success, "edit_iterations": res.iterations}


@figure("ch10", "die_toss", "A die thrown off a wall to show a chosen face at a chosen place")
def die_toss(ctx):
    """After its corners hit the wall the die is at (0.5, 0, 1.6) at T = 0.5 s with its −x face up."""
    b = DesignBody(Box([0.1, 0.1, 0.1]), mass=0.2, position=[0, 0, 2.0],
                   orientation=quat_from_axis_angle([1, 1, 0], 0.4), velocity=[3.0, 0.0, 1.0],
                   angular_velocity=[2.0, 5.0, 1.0])
    s = DesignScene([b], [Plane([-1, 0, 0], offset=-1.0)], restitution=0.7)
    T, names = 0.5, ["x0", "theta0", "v0", "omega0"]
    q_goal = quat_from_axis_angle([0, 1, 0], np.pi / 2)          # body −x turned to world +z
    goals = [position_goal(0, T, [0.5, 0.0, 1.6]), orientation_goal(0, T, q_goal)]
    res = edit(s, names, None, goals, T, max_iter=15)
    tr0 = simulate(s, T, names, sensitivities=False, warn=False)
    tr1 = simulate(s, T, names, res.u, times=[T], sensitivities=False, warn=False)
    up = quat_to_matrix(tr1.orientation(0, T)) @ [-1.0, 0, 0]
    fig, ax = ctx.subplots()
    ax.plot(tr0.positions(0)[:, 0], tr0.positions(0)[:, 2], "--", label="before the edit")
    ax.plot(tr1.positions(0)[:, 0], tr1.positions(0)[:, 2], label=f"after {res.iterations} updates")
    ax.plot(0.5, 1.6, "r*", ms=10, label="goal at T")
    ax.axvline(1.0, color="k", label="wall")
    ax.set_xlabel("x (m)"), ax.set_ylabel("z (m)"), ax.legend()
    ctx.save(fig)
    return {"success": res.success, "residual": res.residual, "face_up": up, "impacts": len(tr1.impacts),
            "position": tr1.position(0, T), "residuals": np.array([r for _, r in res.history])}


@figure("ch10", "ball_into_target", "A ball bounced off a wall into a target")
def ball_into_target(ctx):
    """The launch velocity is edited so that after the floor and the wall the ball is at the target."""
    s, T, target = _ball([2.0, 0.0, 2.5], x0=(-1.0, 0.0, 1.0)), 2.0, np.array([0.6, 0.0, 1.2])
    res = edit(s, ["v0"], None, [position_goal(0, T, target)], T, h=0.02)
    trs = [simulate(s, T, ["v0"], u, h=0.02, sensitivities=False, warn=False) for u, _ in res.history]
    fig, ax = ctx.subplots()
    ax.set_xlim(-1.2, 2.2), ax.set_ylim(0, 3.0), ax.set_aspect("equal")
    ax.axvline(2.0, color="k"), ax.axhline(0.0, color="k")
    ax.plot(*target[[0, 2]], "r*", ms=14)
    ax.set_xlabel("x (m)"), ax.set_ylabel("z (m)")
    line, = ax.plot([], [], lw=1.5)
    dot, = ax.plot([], [], "o", ms=8)

    def update(i):
        tr = trs[min(i // 6, len(trs) - 1)]
        P = tr.positions(0)
        k = min(int((i % 6 + 1) / 6 * len(P)), len(P) - 1)
        line.set_data(P[:, 0], P[:, 2]), dot.set_data([P[k, 0]], [P[k, 2]])
        return line, dot

    ctx.save_gif(fig, update, frames=6 * len(trs), fps=8)
    return {"success": res.success, "residual": res.residual, "impacts": [len(t.impacts) for t in trs],
            "final": trs[-1].positions(0)[-1]}


@figure("ch10", "shooting", "Single vs multiple shooting on a many-bounce sketch")
def shooting(ctx):
    """Constraint violation per SLSQP iterate; multiple shooting starts from the sketch."""
    T = 1.6 if ctx.quick else 3.0
    true = _ball([3.0, 0.0, 2.0], x0=(-1.5, 0.0, 1.0), eps=0.85)
    ts = np.linspace(0.2, T, 8)
    ref = simulate(true, T, times=list(ts), sensitivities=False, h=0.02)
    sketch = [(t, ref.position(0, t)) for t in ts]
    goals = [position_goal(0, T, ref.position(0, T))]
    guess = _ball([1.5, 0.0, 4.5], x0=(-1.5, 0.0, 1.0), eps=0.85)
    r1 = single_shooting(guess, None, goals, T, names=["v0"], sketch=sketch, maxiter=30, h=0.02)
    nodes = 3 if ctx.quick else 5
    nt = np.linspace(0, T, nodes + 1)[:-1]
    nt_ref = simulate(true, T, times=list(nt), sensitivities=False, h=0.02)
    init = [(nt_ref.position(0, t), np.array([1.0, 0, 0, 0]), nt_ref.velocities(0, t)[0], np.zeros(3)) for t in nt]
    r2 = multiple_shooting(guess, goals, T, nodes=nodes, initial_states=init, sketch=sketch, maxiter=30, h=0.02,
                           slide=False)
    fig, ax = ctx.subplots()
    ax.semilogy(np.maximum(r1.history, 1e-16) if r1.history else [r1.violation], "o-", label="single shooting")
    ax.semilogy(np.maximum(r2.history, 1e-16) if r2.history else [r2.violation], "s-", label="multiple shooting")
    ax.set_xlabel("SLSQP iterate (1)"), ax.set_ylabel("max |C| (m)"), ax.legend()
    ctx.save(fig)
    return {"single_violation": r1.violation, "multiple_violation": r2.violation, "single_success": r1.success,
            "multiple_success": r2.success, "single_sims": r1.simulations, "multiple_sims": r2.simulations,
            "single_objective": r1.objective, "multiple_objective": r2.objective}
