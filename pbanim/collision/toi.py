"""Time of impact: event location on the signed distance vs fixed-step detection (chapter 06).

:func:`simulate_collisions` runs a scene holding one :class:`~pbanim.collision.scene.Collisions` effect
and chooses the time of impact by name:

``toi="fixed"``  the plain step, then the post-step effect: the collision is noticed after the step, when
                 the bodies already overlap, so the impact happens up to h late (apex errors O(h)).
``toi="event"``  the signed distances g(y) of the features that are apart at the step's start are an
                 event of :func:`pbanim.solve` (terminal, direction −1, bracketing root finder): the step
                 is split at g = 0, the impulse applied there, and the solver restarted for the rest of
                 the step. Features touching at the step's start, or nearer than v_rest·h and approaching
                 slower than v_rest (the restitution threshold), are resting contacts: the post-step
                 stage stops them plastically (ε = 0), so a resting body never rises and energy never grows.

Signed distances are exact for sphere/particle–plane, sphere–sphere and box/capsule–plane (vertices and
end spheres); box–box, sphere–box and capsule–sphere pairs are handled by the post-step detection only.

References: Baraff, *Rigid body simulation* (SIGGRAPH course notes) §8 — find the collision time,
apply the impulse, restart the solver; Hairer, Nørsett & Wanner I §II.6 (dense output and events).
"""

from __future__ import annotations

import math
import time

import numpy as np

from .lean import lean_ball
from .scene import Collisions
from ..contracts import Array, Choice, Flag, Int, Obj, Opt, Real, contract, unchecked
from ..ode import METHODS, get_method, solve
from ..results import LazyDiagnostics, SimResult
from ..ode.driver import MAX_STEPS, check_finite, drive, drive_lean, step_grid
from ..errors import InvalidInput

__all__ = ["simulate_collisions"]


def _solve_segment(fun, t0, y0, t1, method, events, split):
    """One (partial) step from t0 to t1 with terminal events, by :func:`pbanim.solve`'s event location.

    Returns (t, y, hit): the event time and state when an event fired inside the step, else (t1, y(t1)).
    """
    res = solve(fun, (t0, t1), y0, method=method, h=t1 - t0, events=events, split=split)
    if res.status == 1 and len(res.t_events[0]):
        return float(res.t_events[0][0]), np.asarray(res.y_events[0][0]), True
    return t1, np.asarray(res.y[:, -1]), False


def _n_state(env) -> int:
    system = env.resolve("scene").system
    n = getattr(system, "n_state", None)
    return int(n) if n is not None else int(np.size(system.state()))


@contract(scene=Obj("pbanim.scene:Scene"), t_end=Real(), h=Real(gt=0), method=Choice(lambda: METHODS),
          toi=Choice(("event", "fixed")), t0=Real(), y0=Opt(Array((_n_state,))), record_every=Int(ge=1),
          max_events_per_step=Int(ge=1), gap_tol=Real(ge=0), max_steps=Int(ge=1), lean=Flag())
def simulate_collisions(scene, t_end: float, h: float, method: str = "rk4", toi: str = "event", *,
                        t0: float = 0.0, y0: np.ndarray | None = None, record_every: int = 1,
                        max_events_per_step: int = 100, gap_tol: float = 1e-12,
                        max_steps: int = MAX_STEPS, lean: bool = True) -> SimResult:
    """Simulate a scene holding one :class:`Collisions` effect, with the time of impact chosen by ``toi``.

    Returns a :class:`~pbanim.results.SimResult` whose ``t_events[0]`` are the located impact times and
    ``y_events[0]`` the states just after the impulses (``toi="event"``), and ``diagnostics`` as in
    ``Scene.simulate`` (computed from the recorded states when first read; the effects' own diagnostics,
    which describe the last response, read at the recorded times). One particle under constant forces
    among planes with RK4 (the bouncing ball) takes the float step of :mod:`pbanim.collision.lean` for
    every step it covers (``lean=False``: the readable step always; the two agree to the root finder's
    tolerance; ``nfev`` then counts four evaluations per RK4 step the lean step takes, none for the roots).

    >>> from pbanim.particles import ParticleSystem, Gravity
    >>> from pbanim.scene import Scene
    >>> ps = ParticleSystem([[0.0, 1.0]])
    >>> from pbanim.collision import Plane
    >>> scene = Scene(ps, [Gravity([0, -10.0]), Collisions(obstacles=[Plane([0, 1])], restitution=0.5)])
    >>> res = simulate_collisions(scene, 0.6, 0.01, toi="event")
    >>> bool(abs(res.t_events[0][0] - np.sqrt(0.2)) < 1e-12)    # √(2h₀/g)
    True
    """
    grid = step_grid(t0, t_end, h, max_steps=max_steps, record_every=record_every)   # t_end after t0, the cap
    coll = [e for e in scene.effects if isinstance(e, Collisions)]
    if len(coll) != 1:
        raise InvalidInput(f"scene must hold exactly one Collisions effect, found {len(coll)}")
    col = coll[0]
    col.last = None                 # diagnostics at t0 describe this run, not the effect's previous one
    others = [e for e in scene.effects if e.phase == "post_step" and e is not col]
    m = get_method(method)
    split = scene.system.split
    y = np.array(scene.system.state() if y0 is None else y0, dtype=float, copy=True)
    if y.size > 64 or not sum([u * u for u in y.tolist()]) < math.inf:
        check_finite(y, t0, 0, "initial state")      # NaN, inf or |y|² overflowing: named there
    # the effects whose diagnostics describe the last response are read at the recorded times; the rest later
    history = [unchecked(e.diagnostics) for e in scene.effects if getattr(e, "history_diagnostics", False)]

    def recorded(t, yy):
        out = {}
        for read in history:
            out.update(read(t, yy))
        return out

    ts, ys, diags = [t0], [y.copy()], [recorded(t0, y)]
    impact_t, impact_y = [], []
    nfev = [0]
    rhs, threshold, respond = unchecked(scene.rhs), unchecked(col.threshold), unchecked(col.respond)
    gaps, sphere_pairs = unchecked(col.gaps), unchecked(col.sphere_pairs)

    def fun(t, yy):
        nfev[0] += 1
        return rhs(t, yy)

    def fixed(t, y, hk):
        return m.step(fun, t, y, hk, split=split)

    def located(t, y, hk):
        """The step from t to t + hk, split at every located impact (at most max_events_per_step)."""
        t1 = t + hk
        vrest = threshold(hk)
        settled = None          # the time at which the boundary check found nothing colliding
        for _ in range(max_events_per_step):
            vmax = float(np.abs(y[split:]).max()) if y.size > split else 0.0
            pairs = sphere_pairs(y, 2 * (vmax + col.gravity * hk) * hk + gap_tol)
            g = gaps(y, pairs)
            # rate of each gap along the flow (one rhs call): near and slow features are resting
            # contacts, left to the post-step stage; far or fast ones are located as events
            f0 = fun(t, y)
            dlt = 1e-7 * max(1.0, float(np.abs(y[:split]).max())) / max(float(np.abs(f0[:split]).max()), 1.0)
            gdot = (gaps(y + dlt * f0, pairs) - g) / dlt
            # a pair already touching at the start of the step but approaching fast is an impact that
            # fell on the step boundary: respond elastically now (not plastically after the step). ġ is a
            # difference quotient: the impact counts only when the response finds a contact colliding
            # (a grazing touch, ġ = 0 with a zero threshold, was taken for max_events_per_step impacts)
            if t != settled and np.any((g <= gap_tol) & (-gdot > vrest)):
                y_new = respond(t, y, hk, 10 * gap_tol)
                if col.last is not None and np.any(col.last.regime == "colliding"):
                    y = y_new
                    impact_t.append(t)
                    impact_y.append(y.copy())
                    continue
                settled = t
            active = (g > gap_tol) & ~((g < vrest * hk) & (-gdot < vrest))
            if not active.any():
                return m.step(fun, t, y, t1 - t, split=split)

            def event(tt, yy, active=active, pairs=pairs):
                return float(np.min(gaps(yy, pairs)[active]))

            event.terminal, event.direction = True, -1
            tc, yc, hit = _solve_segment(fun, t, y, t1, method, [event], split)
            if not hit:
                return yc
            g_c = abs(event(tc, yc))
            y = respond(tc, yc, hk, max(10 * gap_tol, 2 * g_c))
            impact_t.append(tc)
            impact_y.append(y.copy())
            t = tc
            if t1 - t <= 1e-14 * max(1.0, abs(t1)):
                return y
        # too many impacts in one step: finish it plainly, the post-step stage takes over
        return m.step(fun, t, y, t1 - t, split=split)

    plan = lean_ball(scene, col, m, gap_tol, max_events_per_step) if lean and toi == "event" else None
    took = [False]              # whether the lean step took the last step (then nothing touches at its end)

    def lean_located(t, y, hk):
        out = plan.step(t, y.tolist(), hk, threshold(hk))
        took[0] = out is not None
        if out is None:
            return located(t, y, hk)
        y1, impacts, logs = out
        for tc, yc in impacts:
            impact_t.append(tc)
            impact_y.append(np.array(yc))
        col.log += logs
        nfev[0] += 4 * (1 + len(impacts))
        return np.array(y1)

    post = [unchecked(e.post_step) for e in others]

    def between(k, t, y, t1, y1, hk):
        if took[0]:                 # the lean step checked that no contact is left: the response finds none
            col.last = None
            return t1, y1, False
        for post_step in post:
            y1 = post_step(t1, y1, hk)
        # after event location every fast impact has been located: what still touches is resting (ε = 0)
        return t1, respond(t1, y1, hk, 0.0, toi == "event"), False

    def record(t1, y1):
        ts.append(t1)
        ys.append(y1.copy())
        diags.append(recorded(t1, y1))

    start = time.perf_counter()
    if plan is not None and all(getattr(read, "__self__", None) is col for read in history):
        # the whole run on floats (LeanBall.run): flights and located impacts there, any other step readable
        quiet, special = diags[0], {}             # col.last is None: what every lean step leaves

        def readable(k, t, yl, hk):
            ya = np.array(yl)
            y1 = located(t, ya, hk)
            check_finite(y1, t, k, "state")
            y1 = between(0, t, ya, t + hk, y1, hk)[1]
            check_finite(y1, t, k, "state")
            special[k] = recorded(t + hk, y1)
            return y1.tolist()

        plan.impacts = (impact_t, impact_y)         # in time order, with the readable steps' impacts
        rows, lean_steps, lean_impacts = plan.run(grid, y.tolist(), record_every, threshold, readable)
        nfev[0] += 4 * (lean_steps + lean_impacts)
        col.last = None if grid.n_steps - 1 not in special else col.last
        Y = np.array(rows)
        n, r = grid.n_steps, record_every
        T = np.empty(len(rows))                     # the times grid.times() gives, every r-th, and t_end
        np.multiply(np.arange(0, n, r), grid.h, out=T[:-1])
        T[:-1] += grid.t0
        T[-1] = grid.t_end
        diags += [special.get(k, quiet) for k in range(r - 1, n - 1, r)] + [special.get(n - 1, quiet)]
    else:
        drive(fixed if toi == "fixed" else located, grid, y, hooks=[between], record=record,
              record_every=record_every)
        T, Y = np.array(ts), np.array(ys)
    wall = time.perf_counter() - start
    diagnose = unchecked(scene.diagnostics)

    def series():
        hist = {key: np.array([d[key] for d in diags]) for key in diags[0]}
        full = [diagnose(t, yy) for t, yy in zip(T, Y)]
        return {**{key: np.array([d[key] for d in full]) for key in full[0]}, **hist}

    return SimResult(t=T, y=Y.T, nfev=nfev[0], status=0, wall_time=wall,
                     method=f"{method}+{toi}", nsteps=grid.n_steps, diagnostics=LazyDiagnostics(series),
                     t_events=[np.array(impact_t)], y_events=[np.array(impact_y).reshape(len(impact_t), y.size)])
