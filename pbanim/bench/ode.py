"""``pbanim bench ode``: what accuracy costs in time for the ODE solvers, against scipy in the same run.

1. Work-precision on the Kepler orbit (e = 0.5, 10 periods; error = max |y(t_end) − y*| from Kepler's
   equation) and on a stiff damped spring (k = 10⁶, c = 2·10⁵ per unit mass: rates −5 and −2·10⁵ 1/s,
   t ∈ [0, 1]; error = |x(1) − x*(1)|): at each error level 10⁻³ … 10⁻¹⁰, the cheapest pbanim run vs the
   cheapest ``solve_ivp`` run (RK45, DOP853, Radau, LSODA; BDF too on the stiff spring, where the explicit
   RK45/DOP853 are stability-limited and run once, at rtol 1e-3) reaching it. Goal ≤ 0.5×.
2. Overhead: ``solve(method="rk4")`` on a 2-state oscillator vs a hand-written numpy RK4 loop (same rhs,
   same stored trajectory). Goal ≤ 1.2×.
3. Batch: K pendulums (θ₀ from 5° to 175°) in one batch run vs a loop of K ``solve_ivp`` calls, the batch
   tolerance chosen so its error is no larger than the loop's. Goal ≥ 20×.
"""

from __future__ import annotations

import time

import numpy as np
from scipy.integrate import solve_ivp

from ..accuracy import best_at_error, rows_by_variant, sweep
from ..models.ode import damped_oscillator, harmonic_oscillator, kepler, pendulum
from ..ode import solve
from . import Goal, Report, Table, median_time

__all__ = ["run", "LEVELS", "kepler_problem", "stiff_problem", "runner"]

LEVELS = [10.0 ** -k for k in range(3, 11)]


def kepler_problem():
    """The Kepler work-precision problem: (model, t_end, error), e = 0.5 over 10 periods.

    ``error(y)`` = max |y − y*(t_end)| against the solution of Kepler's equation. Shared with the figure
    ``ch02_work_precision``.
    """
    kp = kepler(0.5)
    t_end = 10 * kp.period
    ref = kp.exact(t_end)[:, 0]
    return kp, t_end, lambda y: float(np.max(np.abs(y - ref)))


def stiff_problem():
    """The stiff work-precision problem: (model, t_end, error) for the damped spring k = 10⁶, c = 2·10⁵.

    Rates −5 and −2·10⁵ 1/s over t ∈ [0, 1]; ``error(y)`` = |x(1) − x*(1)|. Shared with ``ch02_work_precision``.
    """
    m = damped_oscillator(1e3, 2e5)
    ref = m.exact(1.0)[0, 0]
    return m, 1.0, lambda y: float(abs(y[0] - ref))


def runner(model, t_end):
    """A ``run(variant, param) -> (y(t_end), nfev)`` for :func:`pbanim.accuracy.sweep` on ``model``.

    ``variant`` is ``"pbanim:<method>"`` or ``"scipy:<solve_ivp method>"``; ``param`` is the tolerance rtol
    (scipy, dopri5; atol = rtol·10⁻²) or the number of steps over [0, t_end] (pbanim fixed-step methods). The
    analytic Jacobian is passed to the methods that use it.
    """
    J = model.jac

    def run(variant, param):
        lib, method = variant.split(":", 1)
        if lib == "scipy":
            opts = {"jac": J} if J is not None and method in ("Radau", "BDF", "LSODA") else {}
            r = solve_ivp(model.rhs, (0, t_end), model.y0, method=method, rtol=param, atol=param * 1e-2, **opts)
            return r.y[:, -1], r.nfev
        if method == "dopri5":
            r = solve(model.rhs, (0, t_end), model.y0, method=method, rtol=param, atol=param * 1e-2)
        else:
            r = solve(model.rhs, (0, t_end), model.y0, method=method, h=t_end / param, jac=J, split=model.split)
        return r.y[:, -1], r.nfev

    return run


def _work_precision(name, model, t_end, error, ours, theirs, repeats):
    run = runner(model, t_end)
    rows = sweep(run, list(ours) + list(theirs), {**ours, **theirs}, error, repeats=repeats)
    table = Table(f"work-precision: {name}", ["variant", "param", "error", "wall_time_s", "nfev"],
                  [r.as_list() for r in rows])
    by = rows_by_variant(rows)
    pb = [r for v in ours for r in by[v]]
    sc = [r for v in theirs for r in by[v]]
    y0 = np.asarray(model.y0, dtype=float)
    t_rhs = median_time(lambda: model.rhs(0.0, y0), 5, min_time=0.01)  # one right-hand-side evaluation
    lv = Table(f"{name}: cheapest run per error level (rhs share = nfev × t_rhs / t_scipy: the part of "
               f"scipy's time spent in fun itself, t_rhs = {1e6 * t_rhs:.2f} us)",
               ["level", "pbanim", "t_pbanim_s", "scipy", "t_scipy_s", "ratio", "rhs_share_scipy"])
    ratios, missing = [], []
    for L in LEVELS:
        a, b = best_at_error(pb, L), best_at_error(sc, L)
        if b is None:  # scipy does not reach this level in the sweep: nothing to compare
            lv.rows.append([L, a.variant if a else "-", a.wall_time if a else np.nan, "-", np.nan, np.nan, np.nan])
            continue
        ratio = a.wall_time / b.wall_time if a else np.inf
        if a:
            ratios.append(ratio)
        else:
            missing.append(L)
        lv.rows.append([L, f"{a.variant}@{a.param:g}" if a else "not reached", a.wall_time if a else np.inf,
                        f"{b.variant}@{b.param:g}", b.wall_time, ratio, b.nfev * t_rhs / b.wall_time])
    n_sc = len(ratios) + len(missing)
    return rows, [table, lv], (max(ratios) if ratios else np.nan), (len(ratios) / n_sc if n_sc else np.nan), missing


def _overhead(quick):
    osc = harmonic_oscillator(1.0)
    f = osc.rhs
    h, N = 1e-3, (2000 if quick else 20000)

    def hand():
        y = osc.y0.copy()
        Y = np.empty((N + 1, 2))
        Y[0] = y
        t = 0.0
        for k in range(N):
            k1 = f(t, y)
            k2 = f(t + h / 2, y + h / 2 * k1)
            k3 = f(t + h / 2, y + h / 2 * k2)
            k4 = f(t + h, y + h * k3)
            y = y + h / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
            Y[k + 1] = y
            t += h
        return Y

    ours = lambda: solve(f, (0, N * h), osc.y0, method="rk4", h=h)  # noqa: E731
    assert np.max(np.abs(ours().y[:, -1] - hand()[-1])) < 1e-12
    reps = 3 if quick else 7
    t_hand, t_ours = [], []
    for _ in range(reps):  # interleaved, so both sides see the same machine load
        t_hand.append(median_time(hand, 1))
        t_ours.append(median_time(ours, 1))
    th, to = float(np.median(t_hand)), float(np.median(t_ours))
    return Table("overhead: fixed-step RK4, 2-state oscillator", ["variant", "steps", "wall_time_s", "per_step_us"],
                 [["hand-written numpy loop", N, th, 1e6 * th / N], ["pbanim.solve rk4", N, to, 1e6 * to / N]]), to / th


def _batch(quick):
    K = 40 if quick else 1000
    th0 = np.radians(np.linspace(5, 175, K))
    p = pendulum(th0)
    t_end = 5.0
    ref = solve(p.rhs, (0, t_end), p.y0, method="dopri5", rtol=1e-12, atol=1e-13).y[:, :, -1]

    def loop():
        return np.array([solve_ivp(p.rhs, (0, t_end), p.y0[k], method="RK45", rtol=1e-6, atol=1e-9).y[:, -1]
                         for k in range(K)])

    start = time.perf_counter()
    yl = loop()
    t_loop = time.perf_counter() - start
    err_loop = float(np.max(np.abs(yl - ref)))
    table = Table(f"batch: {K} pendulums, t ∈ [0, {t_end}]", ["variant", "error", "wall_time_s"],
                  [[f"loop of {K} solve_ivp RK45 (rtol 1e-6)", err_loop, t_loop]])
    best = None
    for rtol in (1e-6, 1e-7, 1e-8, 1e-9, 1e-10):
        fn = lambda rtol=rtol: solve(p.rhs, (0, t_end), p.y0, method="dopri5", rtol=rtol, atol=rtol * 1e-3)  # noqa: E731
        err = float(np.max(np.abs(fn().y[:, :, -1] - ref)))
        tb = median_time(fn, 3)
        table.rows.append([f"pbanim batch dopri5 (rtol {rtol:g})", err, tb])
        if err <= err_loop:
            best = tb
            break
    return table, (t_loop / best if best else 0.0)


def run(quick: bool = False) -> Report:
    """Run the ODE benchmarks and return the report (``quick``: small sizes, the test suite's smoke run)."""
    rep = Report("ode")
    reps = 1 if quick else 3
    kp, t_end, err = kepler_problem()
    tols = [1e-4, 1e-7] if quick else [10.0 ** -k for k in range(3, 15)]
    hs = [2000] if quick else [1000, 2000, 4000, 8000, 16000, 32000]
    _, tables, r_kep, f_kep, m_kep = _work_precision("Kepler e = 0.5, 10 periods", kp, t_end, err,
                                       {"pbanim:dopri5": tols, "pbanim:rk4": hs},
                                       {"scipy:RK45": tols, "scipy:DOP853": tols, "scipy:LSODA": tols,
                                        "scipy:Radau": tols[:2] if quick else [1e-3, 1e-5, 1e-7]}, reps)
    rep.tables += tables
    sm, s_end, serr = stiff_problem()
    stols = [1e-4, 1e-8] if quick else [10.0 ** -k for k in range(3, 13)]
    steps = [100, 1000] if quick else [100, 300, 1000, 3000, 10000, 30000]
    _, tables, r_stiff, f_stiff, m_stiff = _work_precision("stiff damped spring k = 1e6, c = 2e5", sm, s_end, serr,
                                         {"pbanim:implicit_euler": steps, "pbanim:implicit_midpoint": steps,
                                          "pbanim:exponential_euler": [1, 10] if quick else [1, 3, 10, 100]},
                                         {"scipy:Radau": stols, "scipy:BDF": stols, "scipy:LSODA": stols,
                                          **({} if quick else {"scipy:RK45": [1e-3], "scipy:DOP853": [1e-3]})},
                                         reps)
    rep.tables += tables
    t_over, r_over = _overhead(quick)
    rep.tables.append(t_over)
    t_batch, r_batch = _batch(quick)
    rep.tables.append(t_batch)
    rep.notes.append("ratios are wall-time medians measured in this run; the machine is shared, so expect noise")
    for name, miss in (("Kepler", m_kep), ("stiff spring", m_stiff)):
        if miss:
            rep.notes.append(f"{name}: error levels reached by scipy but not by any pbanim run of the sweep: "
                             + ", ".join(f"{L:.0e}" for L in miss))
    rep.goals += [
        Goal("ode-kepler-vs-scipy", r_kep, 0.5, "<=", "x", "worst level of 1e-3..1e-10 reached by both"),
        Goal("ode-kepler-levels", f_kep, 1.0, ">=", "", "fraction of scipy's error levels pbanim reaches"),
        Goal("ode-stiff-vs-scipy", r_stiff, 0.5, "<=", "x", "worst level of 1e-3..1e-10 reached by both"),
        Goal("ode-stiff-levels", f_stiff, 1.0, ">=", "", "fraction of scipy's error levels pbanim reaches"),
        Goal("ode-rk4-overhead", r_over, 1.2, "<=", "x", "solve(rk4) / hand-written numpy loop"),
        Goal("ode-batch-vs-loop", r_batch, 20.0, ">=", "x", "loop of solve_ivp / batch dopri5 at equal error"),
    ]
    return rep
