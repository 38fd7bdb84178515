"""The fused float run of a small particle scene: a whole run of symplectic Euler on Python floats (issue 28).

:class:`pbanim.particles.lean.FloatParticles` answers a step of a small particle scene on floats, but a step
called through the driver still pays around that arithmetic what it pays once per step: the state turned
into a list and back into an array, the driver's call, its store into the record, the response's call through
the plan. For a run with nothing to read during it (``diagnostics`` False or lazy with no effect read during
the run), :meth:`pbanim.scene.Scene.simulate` hands the whole run to :func:`fused_run`, chosen once per run:
the state converted once at the start and once at the end, and per step

    v₁ = v₀ + h (W Q),   x₁ = x₀ + h v₁                 the float plan's kick and drift (its ``stepper``)
    y₁ ← response(t + h, y₁)                           the post-step stage's float response
                                                       (:meth:`pbanim.collision.lean_spheres.LeanSpheres.floats`)

with the recorded states kept at the sample times only (every ``record_every``-th step and the last), as
:func:`pbanim.ode.drive_lean` keeps them. The arithmetic is the plan's and the response's, call for call: the
fused run equals the step-by-step run bit for bit (up to the sign of a zero velocity, where a kick of zero is
left out), and the readable step to roundoff
(``tests/test_particles_lean.py``, ORACLES D17). What the stepped plan hands to the readable step (a spring of
zero length, a response the floats cannot answer: resting contact, a failed certificate) is handed over here
in the same way, for that step only.

Non-finite states. Float arithmetic raises on none; the states are checked as :func:`~pbanim.ode.drive_lean`
checks them: every recorded state at the end of the run when every state is recorded (one sum of squares
over the record; the first bad step named), else |y|² every ``check_every`` steps and after the last. The
loop's cap is the grid's step count, known before it starts (``max_steps`` checked by
:func:`~pbanim.ode.step_grid`).
"""

from __future__ import annotations

from array import array
from math import inf, isfinite

import numpy as np

__all__: list = []


def fused_run(step, respond, handed, handoff, counter: list):
    """``run(grid, y0, record_every, check_every) -> Y`` (Y as :func:`pbanim.ode.drive_lean` returns it) of a
    float plan: ``step(y, h) -> y₁`` on lists (raising the plan's hand-over exception for the readable step),
    ``respond(t₁, y₁, h, margin, plastic, record) -> list | None`` the one post-step stage's float response
    (None for a scene with no post-step stage), ``handed(t, y, h)`` the readable kick–drift and its post-step
    stages (arrays), ``handoff(t₁, y₁, h)`` the readable response of a state the float one does not answer."""
    from .lean import _Handoff

    lean = getattr(respond, "__self__", None)
    if getattr(step, "kicks", None) is not None and respond is not None and callable(getattr(lean, "_finish", None)):
        return _spheres_run(step.kicks, lean, handoff, counter)

    @_quiet
    def run(grid, y0: np.ndarray, record_every: int, check_every: int | None) -> np.ndarray:
        from ..ode.driver import check_finite

        n, t0, H, hl = grid.n_steps, grid.t0, grid.h, grid.h_last
        r, last = int(record_every), n - 1
        every = r - 1
        y = y0.tolist()
        rows = [y]
        c = None if r == 1 and check_every is None else int(check_every or 1)
        evaluated = 0
        for k in range(n):
            h = H if k != last else hl
            t = t0 + k * H
            try:
                y1 = step(y, h)
            except _Handoff:
                y1 = handed(t, np.array(y), h).tolist()
            else:
                evaluated += 1
                if respond is not None:
                    out = respond(t + h, y1, h, 0.0, False, k == last)
                    y1 = handoff(t + h, y1, h).tolist() if out is None else out
            y = y1
            if c is not None and ((k + 1) % c == 0 or k == last):
                if not isfinite(sum([u * u for u in y])):
                    counter[0] += evaluated
                    check_finite(np.array(y), t, k, "state")
            if k % r == every or k == last:
                rows.append(y)
        counter[0] += evaluated
        return _checked(rows, grid, c)
    return run


def _quiet(run):
    """``run`` under ``np.errstate(over="ignore", invalid="ignore")``, as :func:`pbanim.ode.drive_lean` steps: a
    state gone non-finite reaches the readable step of a hand-over without a warning, and is named by the check."""
    def quiet(*args):
        with np.errstate(over="ignore", invalid="ignore"):
            return run(*args)
    quiet.__doc__ = run.__doc__
    return quiet


def _checked(rows, grid, c) -> np.ndarray:
    """The recorded states as one array; when every state is recorded (``c`` None) each is checked as
    :func:`pbanim.ode.drive_lean` checks them (|y|² finite) and the first bad step is named as it names it."""
    from ..ode.driver import check_finite

    Y = np.array(rows)
    flat = Y.reshape(-1)
    if c is None and not isfinite(flat @ flat):      # Σ|y|² over the run: finite when every |y|² is (else look)
        bad = np.flatnonzero(~np.isfinite(np.einsum("ij,ij->i", Y, Y)))
        k = int(bad[0]) - 1 if bad.size else grid.n_steps - 1      # the step that went from Y[k] to Y[k + 1]
        check_finite(Y[k + 1], grid.time(k), k, "state")
    return Y


def _spheres_run(kicks, lean, handoff, counter: list):
    """The fused run of constant forces and a sphere response (the cradle's plan): the kick and drift of the
    float plan written in place on the run's own list (v += h (Q W), x += h v: the same roundings; a kick of
    zero is left out, which changes no value, at most the sign of a zero velocity), then
    :meth:`~pbanim.collision.lean_spheres.LeanSpheres.floats`' own first test, in the same calls: no contact, or
    contacts none of which approaches, is answered by the projection alone (``_finish``) and leaves
    ``col.last`` to the run's last step; any other step (an impact, the last step) is
    :meth:`~pbanim.collision.lean_spheres.LeanSpheres.floats` itself."""
    contacts, approach, finish, floats = lean.contacts, lean.approach, lean._finish, lean.floats
    tol = lean.tol

    @_quiet
    def run(grid, y0: np.ndarray, record_every: int, check_every: int | None) -> np.ndarray:
        from ..ode.driver import check_finite

        n, t0, H, hl = grid.n_steps, grid.t0, grid.h, grid.h_last
        r, last = int(record_every), n - 1
        every, c = r - 1, (None if r == 1 and check_every is None else int(check_every or 1))
        y = y0.tolist()
        m = len(y) // 2
        rows = array("d", y)                # the recorded states, one after the other
        keep = rows.extend
        R = range(m)
        h0 = kick = None
        for k in range(n):
            h = H if k != last else hl
            if h != h0:
                h0, kick = h, kicks(h)
                if not any(kick):
                    kick = None
            if kick is None:
                for i in R:
                    y[i] += h * y[m + i]
            else:
                for i in R:
                    v = y[m + i] + kick[i]
                    y[m + i] = v
                    y[i] += h * v
            out = None
            if k != last:
                cs = contacts(y, 0.0)
                if not cs:
                    out = y
                else:
                    u0n, speed = approach(y, cs)
                    if speed < inf and min(u0n) >= -tol * speed:
                        out = finish(y, cs, None)
            if out is None:
                t1 = t0 + k * H + h
                out = floats(t1, y, h, 0.0, False, k == last)
                if out is None:
                    out = handoff(t1, y, h).tolist()
            y = out
            if c is not None and ((k + 1) % c == 0 or k == last):
                if not isfinite(sum([u * u for u in y])):
                    counter[0] += k + 1
                    check_finite(np.array(y), t0 + k * H, k, "state")
            if k % r == every or k == last:
                keep(y)
        counter[0] += n
        return _checked(np.frombuffer(rows, float).reshape(-1, len(y)), grid, c)
    return run
