"""Floor rows of chapter 06: the bouncing ball with its impacts located, Newton's cradle (``pbanim bench floors``).

pbanim runs the ball of ORACLES D1 (a point mass dropped from h₀ = 1 m onto the plane y = 0 in 2-D,
ε = 0.8, g = 9.81) as chapter 06 does: ``simulate_collisions(bb.scene(), T, h, "rk4", toi="event")``, to
just after the 4th impact. The hand loop is the same law written for this one ball, as a student would:

    one RK4 step of ẋ = v, v̇ = (0, −g) on floats;  if it ends below the plane (y₁ < 0), the impact time τ
    inside the step is the root of the gap y(t + τ) = y + v_y τ − ½gτ² (RK4 is exact on the parabola, so
    this is the root the event location finds), the state there is the parabola's, the normal velocity
    is reflected, v_y ← −ε v_y (faster than the restitution threshold 3gh: every impact of this run), and
    the rest of the step, h − τ, is one more RK4 step.

Both return the final state (x, v); they agree to the root finder's roundoff. pbanim runs the whole run on
floats (:meth:`pbanim.collision.lean.LeanBall.run`, chosen once per run: the flights as the readable RK4 bit
for bit, the impacts located by the same law; before it: a float step per step inside the driver, 8.6x,
and before that the general machinery, about 1600x). What bounds the row now is a run's fixed cost (the
call's contract check, the plan, the result record): the row prints it, measured in the run, as the cost of
a run of one step spread over the row's steps.

Newton's cradle (ORACLES D2): three balls in a row, the last two touching, the first arriving at 1 m/s,
ε = 1, run by ``Scene.simulate`` with the ``Collisions`` post-step effect (fixed-step detection, Baraff's
sequential impulses, the projection), symplectic Euler; the hand loop is that law for balls on a line (see
:func:`_cradle_hand`). The touching pair is a contact at every step. The whole run is one loop on Python floats,
chosen at ``simulate`` (:mod:`pbanim.particles.lean_run`): the state converted once at each end, the kick and
drift of :mod:`pbanim.particles.lean` in place, the float response of :mod:`pbanim.collision.lean_spheres`
(contacts from the pairs bound once; where none approaches, the projection alone; the impulse loop and its
certificate only at the impact), the record filled at the sample times (before it: a float step per step
through the driver, 3.1–3.5x; before that the float response after the kick–drift on arrays, 6.9x; the
general response at every step, about 270x). The row prints what bounds it now, measured in the run: the
run's fixed cost (a run of one step: the call's contract check, the grid, the plan, the result record)
spread over the row's steps, and the same three balls without the effect (the fused kick and drift and that
fixed cost: what any response adds to).
"""

from __future__ import annotations

from math import sqrt

import numpy as np

from .floors import Floor

__all__ = ["FLOORS", "bouncing_ball_event", "newtons_cradle"]

H0, EPS, G, H = 1.0, 0.8, 9.81, 0.01


def _rk4(x, y, vx, vy, h):
    """One RK4 step of ẋ = v, v̇ = (0, −g) from (x, y, vx, vy): four stages written out."""
    k1x, k1y, k1u, k1v = vx, vy, 0.0, -G
    k2x, k2y, k2u, k2v = vx + 0.5 * h * k1u, vy + 0.5 * h * k1v, 0.0, -G
    k3x, k3y, k3u, k3v = vx + 0.5 * h * k2u, vy + 0.5 * h * k2v, 0.0, -G
    k4x, k4y, k4u, k4v = vx + h * k3u, vy + h * k3v, 0.0, -G
    h6 = h / 6
    return (x + h6 * (k1x + 2 * k2x + 2 * k3x + k4x), y + h6 * (k1y + 2 * k2y + 2 * k3y + k4y),
            vx + h6 * (k1u + 2 * k2u + 2 * k3u + k4u), vy + h6 * (k1v + 2 * k2v + 2 * k3v + k4v))


def _hand(steps: int, h_last: float) -> np.ndarray:
    x, y, vx, vy = 0.0, H0, 0.0, 0.0
    for k in range(steps):
        h = H if k < steps - 1 else h_last
        x1, y1, vx1, vy1 = _rk4(x, y, vx, vy, h)
        if y1 < 0.0:                                 # the impact inside the step: y + vy τ − ½gτ² = 0
            tau = (vy + sqrt(vy * vy + 2.0 * G * y)) / G
            x, y, vx, vy = x + vx * tau, 0.0, vx, vy - G * tau
            vy = -EPS * vy
            x1, y1, vx1, vy1 = _rk4(x, y, vx, vy, h - tau)
        x, y, vx, vy = x1, y1, vx1, vy1
    return np.array([x, y, vx, vy])


def bouncing_ball_event() -> Floor:
    """The ball of ORACLES D1 to just after its 4th impact, h = 10 ms (RK4, impacts located)."""
    from ..collision.toi import simulate_collisions
    from ..models.collision import bouncing_ball
    from ..ode.driver import step_grid

    bb = bouncing_ball(H0, EPS, G)
    T = 1.02 * float(bb.impact_times(4))
    grid = step_grid(0.0, T, H)

    scene = bb.scene()

    def t_end():                 # a quick run (fewer steps) stops earlier: the same steps on both sides
        return T if fl.steps >= grid.n_steps else fl.steps * H

    def pbanim():
        return simulate_collisions(scene, t_end(), H, "rk4", toi="event").y[:, -1]

    def hand():
        run = step_grid(0.0, t_end(), H)
        return _hand(run.n_steps, run.h_last)

    fl = Floor("collisions", "bouncing ball on a plane, impacts located (2-D, ε = 0.8)", "rk4+event",
               grid.n_steps, pbanim, hand)
    setup = _setup_us(scene, H)
    fl.notes.append(f"collisions (ball): a run's fixed cost (simulate_collisions of one step: the step grid, the "
                    f"plan, the result record) is {setup:.0f} µs, {setup / grid.n_steps:.2f} µs per step of this "
                    f"row's {grid.n_steps} (the hand loop has none)")
    return fl


def _setup_us(scene, h) -> float:
    """µs of a run of one step of :func:`pbanim.collision.simulate_collisions` (median of 7)."""
    import time

    from ..collision.toi import simulate_collisions

    times = []
    for _ in range(7):
        start = time.process_time()
        simulate_collisions(scene, h, h, "rk4", toi="event")
        times.append((time.process_time() - start) * 1e6)
    return float(np.median(times))


# Newton's cradle (ORACLES D2): three balls of radius 1/2 in a row on the x axis, the second and third
# touching, the first arriving at 1 m/s; ε = 1, no gravity, symplectic Euler, 300 steps of 1 ms
CR_X, CR_V, CR_R, CR_H, CR_STEPS = (0.0, 1.05, 2.05), (1.0, 0.0, 0.0), 0.5, 1e-3, 300


def _cradle_hand(steps: int) -> np.ndarray:
    """The cradle as a student writes the chapter's law for balls on a line: drift x += h v; the contacts
    (i < j with d = x_j − x_i ≤ 2r, normal +x, depth 2r − d); Baraff's sequential loop over the contacts
    approaching (v_j − v_i < 0), j = −(1 + ε)(v_j − v_i)/(W_i + W_j), until none approaches; then each ball
    moved along its deepest contact's normal by its share of the depth (equal masses: half)."""
    x, v = list(CR_X), list(CR_V)
    n, two_r = len(x), 2 * CR_R
    for _ in range(steps):
        x = [xi + vi * CR_H for xi, vi in zip(x, v)]
        contacts = [(i, j, two_r - (x[j] - x[i])) for i in range(n) for j in range(i + 1, n)
                    if x[j] - x[i] <= two_r]
        if not contacts:
            continue
        u = list(v)
        while True:
            hit = False
            for i, j, _ in contacts:
                vn = u[j] - u[i]
                if vn < 0.0:
                    J = -2.0 * vn / 2.0                 # ε = 1, W_i = W_j = 1
                    u[j] += J
                    u[i] -= J
                    hit = True
            if not hit:
                break
        v = u
        move = [0.0] * n                                # each ball: its deepest contact's share, with a sign
        for i, j, depth in contacts:
            if depth > 0.0:
                if depth / 2 >= abs(move[j]):
                    move[j] = depth / 2
                if depth / 2 >= abs(move[i]):
                    move[i] = -depth / 2
        x = [xi + mi for xi, mi in zip(x, move)]
    return np.array(x + v)


def newtons_cradle() -> Floor:
    """Three balls, the first arriving at 1 m/s (ORACLES D2: the sequential law leaves (0, 0, v₀))."""
    from ..collision.scene import Collisions
    from ..particles import ParticleSystem
    from ..scene import Scene

    scene = Scene(ParticleSystem([[x, 0.0] for x in CR_X], [[v, 0.0] for v in CR_V]),
                  [Collisions(radius=CR_R, restitution=1.0, gravity=0.0)])

    def pbanim():
        y = scene.simulate(fl.steps * CR_H, CR_H, "symplectic_euler", diagnostics=False).y[:, -1]
        return np.concatenate([y[0:6:2], y[6:12:2]])          # the x components (y stays 0)

    def hand():
        return _cradle_hand(fl.steps)

    fl = Floor("collisions", "Newton's cradle, 3 balls on a line (2-D, ε = 1)", "symplectic_euler", CR_STEPS,
               pbanim, hand)
    bare, ratio, fixed = _scene_floor(fl.steps)
    fl.notes.append(f"collisions (cradle): the fused float run without the collision effect (kick and drift in "
                    f"place, the run's fixed cost) costs {bare:.1f} µs per step, {ratio:.2f}x the hand loop in the "
                    f"same rounds, of which the run's fixed cost (a run of one step with the effect) is "
                    f"{fixed / fl.steps:.2f} µs per step of {fl.steps}: the floor of this plan; the float "
                    "response (contacts, approach speeds, the projection of the touching pair) is the rest")
    return fl


def _scene_floor(steps: int) -> tuple[float, float, float]:
    """(µs per step, ratio to the hand loop) of the cradle's three balls with no effect (the fused float run
    alone), both timed in alternating rounds (medians of 7), and the µs of a run of one step of the cradle."""
    import time

    from ..collision.scene import Collisions
    from ..particles import ParticleSystem
    from ..scene import Scene

    def balls(*effects):
        return Scene(ParticleSystem([[x, 0.0] for x in CR_X], [[v, 0.0] for v in CR_V]), list(effects))

    scene, full = balls(), balls(Collisions(radius=CR_R, restitution=1.0, gravity=0.0))
    tp, th, tf = [], [], []
    for _ in range(7):
        start = time.process_time()
        scene.simulate(steps * CR_H, CR_H, "symplectic_euler", diagnostics=False)
        tp.append(time.process_time() - start)
        start = time.process_time()
        _cradle_hand(steps)
        th.append(time.process_time() - start)
        start = time.process_time()
        full.simulate(CR_H, CR_H, "symplectic_euler", diagnostics=False)
        tf.append(time.process_time() - start)
    return (float(np.median(tp)) / steps * 1e6, float(np.median(np.array(tp) / np.array(th))),
            float(np.median(tf)) * 1e6)


FLOORS = [bouncing_ball_event, newtons_cradle]
