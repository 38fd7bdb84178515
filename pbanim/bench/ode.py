"""``pbanim bench ode``: what accuracy costs in time for the ODE solvers, against scipy in the same run.

1. Work-precision on five problems — Kepler (e = 0.5, 10 periods), Pleiades, a stiff damped spring
   (k = 10⁶, c = 2·10⁵ per unit mass), Van der Pol (μ = 1000, t ∈ [0, 3000]) and Robertson's kinetics
   (t ∈ [0, 40]): every adaptive method of each library sweeps the same tolerances (rtol = 10⁻² …,
   atol = rtol·scale of the problem, the same pairs for everyone, the analytic Jacobian for every
   method that uses one — pbanim's, solve_ivp's and odeint's ``Dfun``). A variant stops going tighter once
   its error is below 10⁻¹¹ or one run exceeds the time budget (the same rule for every variant).
   Each variant's (error, wall time) points are joined by straight lines in log–log, and at each
   error level 10⁻³ … 10⁻¹⁰ the time needed is read off the lower envelope; the library's time is
   its best method's. Goals: pbanim ≤ 0.5× the best ``solve_ivp`` method and ≤ 1× ``odeint`` at every
   level of every problem (a level pbanim does not reach while the baseline does counts as ∞).
   The tables give the evaluations of f at each level too, so a ratio reads as (fewer evaluations) ×
   (less time per evaluation).
   *The floor.* One call of f takes t_f (median over states along the solution, measured in the same
   run, the evaluation counter included). A library's floor at a level is N_min·t_f, N_min the fewest
   evaluations any of its methods needs there: the time it would take if its integrator cost nothing.
   ``floor/ivp`` = pbanim's floor / solve_ivp's actual time; when it exceeds the goal's 0.5 (or
   ``floor/odeint`` exceeds 1), no implementation of pbanim's present methods with this f, in any
   language, meets the goal — only fewer evaluations can; a note per problem says which. ``over_pb_us``
   is what pbanim's integrator adds per evaluation, t/N − t_f.
2. Overhead: ``solve(method="rk4")`` on a 2-state oscillator vs a hand-written numpy RK4 loop. Goal ≤ 1.2×.
3. Batch: K pendulums in one batch run vs a loop of K ``solve_ivp`` calls, at no larger error. Goal ≥ 20×.
"""

from __future__ import annotations

import time

import numpy as np
from scipy.integrate import odeint, solve_ivp

from ..models.ode import damped_oscillator, harmonic_oscillator, kepler, pendulum
from ..ode import solve
from ..ode.problems import pleiades, robertson, van_der_pol
from ..errors import InvalidInput, check_count, check_positive
from . import Goal, Report, Table, median_time

__all__ = ["run", "LEVELS", "PROBLEMS", "kepler_problem", "stiff_problem", "runner", "sweep_problem",
           "time_at_error", "library_curve", "counting", "f_time", "nfev_at_error", "floor_ratios",
           "numpy_call_time"]

LEVELS = [10.0 ** -k for k in range(3, 11)]
FLOOR = 1e-11          # a variant whose error is below this covers every level: it stops sweeping


def kepler_problem():
    """The Kepler work-precision problem: (model, t_end, error), e = 0.5 over 10 periods."""
    kp = kepler(0.5)
    t_end = 10 * kp.period
    ref = kp.exact(t_end)[:, 0]
    return kp, t_end, lambda y: float(np.max(np.abs(y - ref)))


def stiff_problem():
    """The stiff spring k = 10⁶, c = 2·10⁵ (rates −5 and −2·10⁵ 1/s) on [0, 1]: (model, t_end, error)."""
    m = damped_oscillator(1e3, 2e5)
    ref = m.exact(1.0)[0, 0]
    return m, 1.0, lambda y: float(abs(y[0] - ref))


def _problem(key):
    """(rhs, jac, y0, t_end, error, atol scale) of a benchmark problem."""
    if key == "kepler":
        kp, t_end, err = kepler_problem()
        return kp.rhs, None, kp.y0, t_end, err, 1e-2
    if key == "stiff_spring":
        m, t_end, err = stiff_problem()
        return m.rhs, m.jac, m.y0, t_end, err, 1e-3
    p = {"pleiades": pleiades, "van_der_pol": van_der_pol, "robertson": robertson}[key]()
    return p.rhs, p.jac, p.y0, p.t_end, p.error, (1e-10 if p.relative else 1e-3 if key == "van_der_pol" else 1e-2)


NONSTIFF = (["pbanim:dop853", "pbanim:vern7", "pbanim:dopri5", "pbanim:dprkn6", "pbanim:dprkn8", "pbanim:dprkn12"],
            ["RK45", "DOP853", "LSODA"])
STIFF = (["pbanim:radau5", "pbanim:rodas4"], ["Radau", "BDF", "LSODA"])
#: key → (title, pbanim variants, solve_ivp methods)
PROBLEMS = {
    "kepler": ("Kepler e = 0.5, 10 periods", *NONSTIFF),
    "pleiades": ("Pleiades, t in [0, 3]", *NONSTIFF),
    "stiff_spring": ("stiff spring k = 1e6, c = 2e5, t in [0, 1]", *STIFF),
    "van_der_pol": ("Van der Pol mu = 1000, t in [0, 3000]", *STIFF),
    "robertson": ("Robertson, t in [0, 40]", *STIFF),
}


class _Cap(Exception):
    """Raised inside f when a run passes :data:`MAX_EVALS` (the same cap for every library)."""


#: most evaluations of f in one run, for every variant (LSODA can stall for minutes at rtol ~ 0.1)
MAX_EVALS = 2_000_000


def counting(rhs):
    """(f, count): ``rhs`` behind the evaluation counter every library calls (stops a run at :data:`MAX_EVALS`).

    The wrapper keeps ``rhs.autonomous`` (f does not depend on t), so that RODAS4 skips its ∂f/∂t
    difference (one evaluation per step) on the autonomous problems; the scipy methods never need ∂f/∂t.
    """
    if not callable(rhs):
        raise InvalidInput(f"rhs must be a callable rhs(t, y), got {type(rhs).__name__}")
    count = [0]

    def f(t, y):
        count[0] += 1
        if count[0] > MAX_EVALS:
            raise _Cap
        return rhs(t, y)

    f.autonomous = getattr(rhs, "autonomous", False)
    return f, count


def f_time(key, samples=40, blocks=15):
    """Median wall time (s) of one call of problem ``key``'s f as every library calls it (counter included), on
    ``samples`` states along the solution: the median over ``blocks`` blocks of (block time / samples)."""
    _check_key(key)
    samples, blocks = check_count("samples", samples), check_count("blocks", blocks)
    rhs, jac, y0, t_end, _, scale = _problem(key)
    method = "radau5" if key in ("stiff_spring", "van_der_pol", "robertson") else "dop853"
    states = solve(rhs, (0.0, t_end), y0, method=method, rtol=1e-6, atol=1e-6 * scale, jac=jac,
                   t_eval=np.linspace(0.0, t_end, samples)).y.T.copy()
    f, _ = counting(rhs)
    per_call = []
    for _ in range(blocks):
        start = time.perf_counter()
        for y in states:
            f(0.0, y)
        per_call.append((time.perf_counter() - start) / len(states))
    return float(np.median(per_call))


def _check_key(key):
    if key not in PROBLEMS:
        raise InvalidInput(f"problem must be one of {list(PROBLEMS)}, got {key!r}")


def nfev_at_error(points, level):
    """The fewest evaluations of f a variant needs for error ``level`` (log–log interpolation, as for time)."""
    check_positive("level", level)
    return time_at_error([(r, e, nf, nf) for r, e, _, nf in points], level)[0]


def runner(rhs, jac, y0, t_end, atol_scale):
    """``run(variant, rtol) -> (y(t_end), nfev)`` for ``pbanim:<method>``, ``scipy:<solve_ivp method>``, ``odeint``.

    A run that passes :data:`MAX_EVALS` evaluations of f is stopped and returns a NaN state (a failure).
    """
    failed = np.full(len(y0), np.nan)

    def run(variant, rtol):
        atol = rtol * atol_scale
        f, count = counting(rhs)

        try:
            if variant == "odeint":
                kw = {"Dfun": jac} if jac is not None else {}
                ys, info = odeint(f, y0, [0.0, t_end], rtol=rtol, atol=atol, tfirst=True, full_output=True,
                                  mxstep=MAX_EVALS, **kw)
                ok = info["message"].startswith("Integration successful") and count[0] <= MAX_EVALS
                return (ys[-1] if ok else failed), int(info["nfe"][-1])
            lib, method = variant.split(":", 1)
            if lib == "scipy":
                kw = {"jac": jac} if jac is not None and method in ("Radau", "BDF", "LSODA") else {}
                r = solve_ivp(f, (0.0, t_end), y0, method=method, rtol=rtol, atol=atol, **kw)
                return (r.y[:, -1] if r.success else failed), r.nfev
            r = solve(f, (0.0, t_end), y0, method=method, rtol=rtol, atol=atol, jac=jac, max_steps=MAX_EVALS)
            return (r.y[:, -1] if r.success else failed), r.nfev
        except _Cap:
            return failed, count[0]

    return run


def sweep_problem(key, tols, repeats=1, budget=2.0, variants=None, repeat_below=0.5):
    """Sweep every variant of problem ``key`` over ``tols`` (loose to tight): {variant: [(rtol, error, time, nfev)]}.

    The variants take turns at each tolerance (so a change of machine load hits both libraries alike);
    each point is the best of ``repeats`` runs (one run when it takes over ``repeat_below`` seconds); a
    variant stops at its first run below :data:`FLOOR` or over ``budget`` seconds.
    """
    rhs, jac, y0, t_end, error, scale = _problem(key)
    _, ours, theirs = PROBLEMS[key]
    variants = variants or ours + [f"scipy:{m}" for m in theirs] + ["odeint"]
    run = runner(rhs, jac, y0, t_end, scale)
    out = {v: [] for v in variants}
    active = list(variants)
    for rtol in tols:
        for v in list(active):
            times, value, nfev = [], None, 0
            while len(times) < repeats and (not times or times[0] < repeat_below):   # long runs: timed once
                start = time.perf_counter()
                value, nfev = run(v, rtol)
                times.append(time.perf_counter() - start)
            err, wall = error(value), float(np.min(times))
            out[v].append((rtol, err if np.isfinite(err) else np.inf, wall, nfev))
            if err <= FLOOR or wall > budget:
                active.remove(v)
    return out


def time_at_error(points, level):
    """(time, nfev) a variant needs for error ``level``: the lower envelope of its log–log segments.

    ``points`` are (rtol, error, time, nfev) in sweep order; a point with error ≤ level qualifies as is,
    a segment whose errors bracket the level is interpolated linearly in (log error, log time).
    Returns (inf, nan) when no point reaches the level.
    """
    best = (np.inf, np.nan)
    for i, (_, e, t, nf) in enumerate(points):
        if e <= level and t < best[0]:
            best = (t, nf)
        if i and e <= level < points[i - 1][1] and e > 0:
            _, e0, t0, n0 = points[i - 1]
            w = (np.log(level) - np.log(e0)) / (np.log(e) - np.log(e0))
            ti = float(np.exp(np.log(t0) + w * (np.log(t) - np.log(t0))))
            if ti < best[0]:
                best = (ti, float(np.exp(np.log(n0) + w * (np.log(nf) - np.log(n0)))))
    return best


def library_curve(sweeps, variants, level):
    """(time, nfev, variant) of the cheapest of ``variants`` at ``level``."""
    best = (np.inf, np.nan, "-")
    for v in variants:
        t, nf = time_at_error(sweeps[v], level)
        if t < best[0]:
            best = (t, nf, v)
    return best


def _compare(key, sweeps, tf):
    """Tables, the worst ratios (vs solve_ivp, vs odeint), the worst floor ratios and the overhead budgets of
    one problem; ``tf`` is one call of f (:func:`f_time`), the floors are as in the module's docstring."""
    title, ours, theirs = PROBLEMS[key]
    ivp = [f"scipy:{m}" for m in theirs]
    raw = Table(f"{title}: every run (rtol, error, wall time, evaluations of f)",
                ["variant", "rtol", "error", "wall_time_s", "nfev"],
                [[v, *p] for v, pts in sweeps.items() for p in pts])
    lv = Table(f"{title}: time to reach each error level (interpolated), best method per library; "
               f"floor = fewest nfev x one call of f ({tf * 1e6:.2f} us)",
               ["level", "pbanim", "t_pbanim_s", "nfev_pb", "solve_ivp", "t_ivp_s", "nfev_ivp", "t_odeint_s",
                "nfev_odeint", "pb/ivp", "pb/odeint", "floor_pb_s", "floor_ivp_s", "floor_odeint_s", "floor/ivp",
                "floor/odeint", "over_pb_us"])
    worst = {"ivp": [], "odeint": [], "floor_ivp": [], "floor_odeint": [], "allow_ivp": [], "allow_odeint": []}
    unreached = []
    for L in LEVELS:
        tp, np_, vp = library_curve(sweeps, ours, L)
        ti, ni, vi = library_curve(sweeps, ivp, L)
        to, no, _ = library_curve(sweeps, ["odeint"], L)
        fp, fi, fo = (tf * min(nfev_at_error(sweeps[v], L) for v in vs) for vs in (ours, ivp, ["odeint"]))
        r_i = tp / ti if np.isfinite(ti) else np.nan
        r_o = tp / to if np.isfinite(to) else np.nan
        f_i = fp / ti if np.isfinite(ti) else np.nan
        f_o = fp / to if np.isfinite(to) else np.nan
        n_min = fp / tf
        for k, r in (("ivp", r_i), ("odeint", r_o), ("floor_ivp", f_i), ("floor_odeint", f_o),
                     ("allow_ivp", -1e6 * (0.5 * ti - fp) / n_min), ("allow_odeint", -1e6 * (to - fp) / n_min)):
            if not np.isnan(r) and np.isfinite(r if k.startswith("allow") else 0.0):   # nan: baseline unreached
                worst[k].append(r)
        if not np.isfinite(tp):
            unreached.append(L)
        over = 1e6 * (tp / np_ - tf) if np.isfinite(tp) else np.nan
        if np.isfinite(over):
            worst.setdefault("over_pb", []).append(over)
        lv.rows.append([L, vp, tp, np_, vi, ti, ni, to, no, r_i, r_o, fp, fi, fo, f_i, f_o, over])
    # allow_*: the integrator overhead per evaluation (us) that would still meet the goal at every level
    # (stored negated, so that max() picks the tightest level)
    out = {k: (max(v) if v else np.nan) for k, v in worst.items() if k != "over_pb"}
    out["allow_ivp"], out["allow_odeint"] = -out["allow_ivp"], -out["allow_odeint"]
    out["over_pb"] = float(np.median(worst["over_pb"])) if worst.get("over_pb") else np.nan
    return [raw, lv], out, unreached


def numpy_call_time(n=4, calls=2000, blocks=7):
    """Median wall time (s) of one small numpy call, ``np.add(a, b, out=c)`` on n-vectors: the unit of a
    Python integrator's overhead (each stage costs at least a stage sum and a copy of f)."""
    n, calls, blocks = (check_count(k, v) for k, v in (("n", n), ("calls", calls), ("blocks", blocks)))
    a, b, c = np.ones(n), np.ones(n), np.empty(n)
    add, per_call = np.add, []
    for _ in range(blocks):
        start = time.perf_counter()
        for _ in range(calls):
            add(a, b, out=c)
        per_call.append((time.perf_counter() - start) / calls)
    return float(np.median(per_call))


def floor_ratios(key, worst, t_np=None):
    """The note saying whether problem ``key``'s goals are reachable at all by pbanim's current methods, from
    :func:`_compare`'s worst floor ratios and overhead budgets (us per evaluation; ``t_np``: one numpy call)."""
    _check_key(key)
    missing = {"floor_ivp", "floor_odeint", "allow_ivp", "allow_odeint"} - set(worst)
    if missing:
        raise InvalidInput(f"worst must hold the keys floor_ivp, floor_odeint, allow_ivp, allow_odeint; missing "
                           f"{sorted(missing)}")
    parts = []
    for k, lib, target in (("floor_ivp", "solve_ivp", 0.5), ("floor_odeint", "odeint", 1.0)):
        r = worst[k]
        if np.isnan(r):
            parts.append(f"vs {lib}: no level reached by both")
        elif r > target:
            parts.append(f"vs {lib}: UNREACHABLE with these methods (worst floor/{lib} = {r:.2f} > {target:g}: "
                         "even a zero-cost integrator making pbanim's evaluations of f is too slow; only fewer "
                         "evaluations can meet it)")
        else:
            budget = worst["allow_" + k[6:]]
            calls = f" = {budget / (1e6 * t_np):.1f} numpy calls of {1e6 * t_np:.2f} us" if t_np else ""
            parts.append(f"vs {lib}: reachable in principle (worst floor/{lib} = {r:.2f} <= {target:g}), if pbanim's "
                         f"integrator adds at most {budget:.2f} us per evaluation of f{calls}")
    now = worst.get("over_pb", np.nan)
    tail = f" (it adds {now:.2f} us now, median over the levels)" if np.isfinite(now) else ""
    return f"{PROBLEMS[key][0]}: " + "; ".join(parts) + tail


def _floor_verdict(r, target, lib):
    """The tail of a goal line: whether any pure-Python integrator can meet it, by the floor ratio ``r``."""
    if not np.isfinite(r):
        return ""
    if r > target:
        return (f"; NOT MEETABLE in pure Python: the floor (pbanim's fewest calls of f × one call) is already "
                f"{r:.2f}× {lib}'s whole run (> {target:g}), before any integrator work — a CPython bound, not a "
                "defect of the method")
    return f"; meetable in principle (floor/{lib} = {r:.2f} ≤ {target:g})"


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
    t_hand, t_ours = [], []
    for _ in range(3 if quick else 7):  # interleaved, so both sides see the same machine load
        t_hand.append(median_time(hand, 1))
        t_ours.append(median_time(ours, 1))
    th, to = float(np.median(t_hand)), float(np.median(t_ours))
    return Table("overhead: fixed-step RK4, 2-state oscillator", ["variant", "steps", "wall_time_s", "per_step_us"],
                 [["hand-written numpy loop", N, th, 1e6 * th / N], ["pbanim.solve rk4", N, to, 1e6 * to / N]]), to / th


def _batch(quick):
    K = 40 if quick else 1000
    p = pendulum(np.radians(np.linspace(5, 175, K)))
    t_end = 5.0
    ref = solve(p.rhs, (0, t_end), p.y0, method="dop853", rtol=1e-12, atol=1e-13).y[:, :, -1]
    start = time.perf_counter()
    yl = np.array([solve_ivp(p.rhs, (0, t_end), p.y0[k], method="RK45", rtol=1e-6, atol=1e-9).y[:, -1]
                   for k in range(K)])
    t_loop = time.perf_counter() - start
    err_loop = float(np.max(np.abs(yl - ref)))
    table = Table(f"batch: {K} pendulums, t in [0, {t_end}]", ["variant", "error", "wall_time_s"],
                  [[f"loop of {K} solve_ivp RK45 (rtol 1e-6)", err_loop, t_loop]])
    best = None
    for rtol in (1e-6, 1e-7, 1e-8, 1e-9, 1e-10):
        fn = lambda rtol=rtol: solve(p.rhs, (0, t_end), p.y0, method="dop853", rtol=rtol, atol=rtol * 1e-3)  # noqa: E731
        err = float(np.max(np.abs(fn().y[:, :, -1] - ref)))
        tb = median_time(fn, 3)
        table.rows.append([f"pbanim batch dop853 (rtol {rtol:g})", err, tb])
        if err <= err_loop:
            best = tb
            break
    return table, (t_loop / best if best else 0.0)


def run(quick: bool = False, problems=None) -> Report:
    """Run the ODE benchmarks (``quick``: fewer tolerances, one repeat; ``problems``: a subset of keys)."""
    rep = Report("ode")
    tols = [10.0 ** -k for k in (2, 4, 6, 8, 10)] if quick else [10.0 ** (-k / 2) for k in range(4, 27)]
    t_np = numpy_call_time()
    for key in problems or PROBLEMS:
        sweeps = sweep_problem(key, tols, repeats=1 if quick else 3, budget=0.4 if quick else 3.0)
        tables, worst, unreached = _compare(key, sweeps, f_time(key, blocks=5 if quick else 15))
        rep.tables += tables
        rep.notes.append(floor_ratios(key, worst, t_np))
        if unreached:
            rep.notes.append(f"{PROBLEMS[key][0]}: levels no pbanim method reached in the sweep: "
                             + ", ".join(f"{L:.0e}" for L in unreached))
        rep.goals += [
            Goal(f"ode-{key}-vs-solve_ivp", worst["ivp"], 0.5, "<=", "x",
                 "worst level of 1e-3..1e-10: pbanim best / solve_ivp best, equal error"
                 + _floor_verdict(worst["floor_ivp"], 0.5, "solve_ivp")),
            Goal(f"ode-{key}-vs-odeint", worst["odeint"], 1.0, "<=", "x",
                 "worst level of 1e-3..1e-10: pbanim best / odeint, equal error"
                 + _floor_verdict(worst["floor_odeint"], 1.0, "odeint")),
        ]
    t_over, r_over = _overhead(quick)
    t_batch, r_batch = _batch(quick)
    rep.tables += [t_over, t_batch]
    rep.notes.append("times are the best of 3 runs (1 in quick mode), all variants taking turns at each tolerance "
                     "in this run; the machine is shared, so expect noise")
    rep.goals += [Goal("ode-rk4-overhead", r_over, 1.2, "<=", "x", "solve(rk4) / hand-written numpy loop"),
                  Goal("ode-batch-vs-loop", r_batch, 20.0, ">=", "x", "loop of solve_ivp / batch dop853 at equal error")]
    return rep
