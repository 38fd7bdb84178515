"""``pbanim bench constraints``: cost of λ per step vs chain length for every solver, and work-precision of
the stabilizations (chapter 03).

Per-step cost = assembly (C, J, J̇q̇, and JWJᵀ or its bands) + the λ solve, for a hanging chain of n links,
in steady state: the median of repeats, each repeat looping the step for at least 20 ms up to n = 10⁴
(single steps of a few 0.1 ms are dominated by timer and cache noise), all solvers in one run. "witkin-sparse" is the generic sparse LU (SuperLU with its
COLAMD ordering) of the same JWJᵀ; "linear" is Baraff's leaves-first elimination (tridiagonal for a chain).
The dense solve is skipped past n = 2000 (O(n³): ~8 s at n = 10⁴) and CG past n = 10⁴ (its iteration
count grows like n on a chain, cond(JWJᵀ) ~ n²).

The two n = 10⁴ goals (the linear step's cost, its speed-up over the sparse LU) are measured apart, in process
CPU time (the machine may be shared: wall time would measure the load), in alternating rounds of the linear step,
the sparse-LU step and the linear solve's floor: the bare calls it cannot avoid at equal accuracy (the kind's
evaluate of C, G, J̇q̇; LAPACK's dpttrf and the two dpttrs of the solve and its refinement step, each a
recurrence of n dependent divisions or multiply-adds; the four products J(WQ), Jᵀλ₀, J(WJᵀλ₀), Jᵀλ by scipy's
bare kernel). What the step costs above the floor are its vector passes (A's values, r, q̈) and Python. Both
steps solve the same JWJᵀλ = r from the same assembly and refine once; their λ agree to roundoff (printed).

Readings (6 full runs each, alternating with the code before the chain solve's lean twin, load 5.7-7.8):
linear 1.22, 1.29, 0.881, 1.23, 0.988, 0.981 ms (median 1.10; before 1.05, 1.19, 1.15, 1.40, 1.11, 1.32, median
1.17), floor 0.57-0.77 ms; speed-up 7.75, 7.73, 7.40, 7.98, 9.12, 7.85x (median 7.80; before 7.49), 10.2-13.8x
at the floor. Both lines are still missed at that load: the floor (LAPACK's three recurrences, ~7 ns a row
each, the kind's evaluate and the four products) is 60-75 % of the step, the rest one vector pass each. Tried
and not kept: the tridiagonal LU (dgttrf/dgttrs 121 + 148 µs at n = 10⁴) and banded Cholesky (dpbtrf/dpbtrs
417 + 199 µs) against dpttrf/dpttrs (79 + 71 µs); J's values copied as two strided slices instead of the
gather (27 µs): 101 µs, or 22 µs viewed as complex pairs (5 µs, not worth a special case).

Work-precision: a swinging chain (released horizontal, 1 s); for each integrator (RK4, symplectic Euler)
and stabilization (none, Baumgarte at ω_b ∈ {10, 30, 100} rad/s with ζ = 1, projection) a sweep over
h; errors are the constraint drift max|C| (units of C = ½(|d|² − L²), m²) and the energy error
max|E − E₀| / (M g L_chain); wall times are medians (``pbanim.accuracy.sweep``).
"""

from __future__ import annotations

import time

import numpy as np
import scipy.linalg as sla

from ..accuracy import sweep
from ..constraints import Constraints, ConstraintSet, solve_lambda
from ..contracts import unchecked
from ..errors import ConvergenceError, SimulationDiverged
from ..models.constrained import hanging_chain
from ..particles.system import Gravity
from ..scene import Scene
from ..sparse_kernel import product_of
from . import Goal, Report, Table, _alternating, median_time

__all__ = ["run", "SOLVER_LIST", "chain_step", "step_costs", "loglog_slope", "work_precision"]

SOLVER_LIST = ["linear", "witkin-sparse", "kkt", "witkin-cg", "witkin-dense"]
DENSE_MAX, CG_MAX = 2000, 10_000


def _chain(n: int):
    """(constraint set, x, v, Q flat) of a hanging chain of n links tilted 0.3 rad."""
    mod = hanging_chain(n, link_length=1.0 / n, angle=0.3)
    ps = mod.system
    cs = ConstraintSet(mod.constraints, ps.N, ps.dim, ps.W, ps.x0)
    x, v = ps.unpack(ps.state())
    return cs, x, v, (ps.m[:, None] * mod.g).ravel()


def chain_step(n: int, solver: str):
    """A closure doing one step's assembly + λ solve for a hanging chain of n links (tilted 0.3 rad)."""
    cs, x, v, Qf = _chain(n)
    pairs = solver not in ("kkt", "witkin-cg")
    kw = {"tol": 1e-8, "max_iter": 4 * n + 100} if solver == "witkin-cg" else {}

    def step():
        asm = cs.assemble(x, v, pairs=pairs)
        return solve_lambda(asm.J, cs.Wq, Qf, -asm.Jdv, solver, cset=cs, asm=asm, **kw)

    return step


def step_costs(ns, solvers=SOLVER_LIST, repeats: int = 5, warm_enough: float = float("inf")) -> dict:
    """{solver: [seconds per step or nan (skipped / failed)]} over ``ns``.

    ``warm_enough``: a point whose warm-up solve takes longer (s) is timed by that solve alone, with
    ``repeats`` = 1 (a solve that long is its arithmetic: CG at n = 10⁴ 2 s, the dense Cholesky at n = 10³
    1.3 s, first and second calls within the machine's spread; the second call was half the figure's time).
    """
    out = {s: [] for s in solvers}
    for n in ns:
        for s in solvers:
            if (s == "witkin-dense" and n > DENSE_MAX) or (s == "witkin-cg" and n > CG_MAX):
                out[s].append(float("nan"))
                continue
            fn = chain_step(n, s)
            try:
                start = time.perf_counter()
                fn()  # warm up (and check it converges)
                warm = time.perf_counter() - start
            except ConvergenceError:
                out[s].append(float("nan"))
                continue
            if warm > warm_enough and repeats == 1:
                out[s].append(warm)
                continue
            reps = repeats if n <= 10_000 else max(3, repeats // 2)
            out[s].append(median_time(fn, repeats=reps, min_time=0.02 if n <= 10_000 else 0.0))
    return out


def _floor(n: int):
    """A closure doing the bare calls of one linear solve at n (see the module docstring): the floor."""
    cs, x, v, Qf = _chain(n)
    asm = cs.assemble(x, v)
    evaluate = unchecked(cs.constraints[0].evaluate)
    d, e = cs.tridiagonal(asm)
    dpttrf, dpttrs = sla.lapack.dpttrf, sla.lapack.dpttrs
    D, E, _ = dpttrf(d, e)
    J, JT = asm.J, asm.JT
    Jx = product_of("csr", (J.data, J.indices, J.indptr), J.shape)
    JTx = product_of(JT.format, (JT.data, JT.indices, JT.indptr), JT.shape)
    u, t_n, lam, t_m = cs.Wq * Qf, np.empty(cs.n), -asm.Jdv, np.empty(cs.m)

    def floor():
        evaluate(x, v)
        dpttrf(d, e)
        dpttrs(D, E, lam)
        dpttrs(D, E, lam)
        Jx(u, t_m)
        JTx(lam, t_n)
        Jx(t_n, t_m)
        JTx(lam, t_n)

    return floor


def _goal_rounds(n: int = 10_000, rounds: int = 7, min_cpu: float = 0.05) -> dict:
    """Process CPU seconds per call of the linear step, the sparse-LU step and the floor at n, in ``rounds``
    alternating rounds (each call looped for ``min_cpu`` s), and max|λ_linear − λ_LU| / max|λ_LU|."""
    fns = {"linear": chain_step(n, "linear"), "witkin-sparse": chain_step(n, "witkin-sparse"), "floor": _floor(n)}
    a, b = fns["linear"](), fns["witkin-sparse"]()
    out: dict = {k: [cpu for _, cpu in t] for k, t in _alternating(fns, rounds, min_cpu).items()}
    out["lam_diff"] = float(np.abs(a.lam - b.lam).max() / np.abs(b.lam).max())
    return out


def loglog_slope(ns, ts) -> float:
    """Slope of log t against log n over the finite times (the empirical cost exponent; nan if < 2 points)."""
    ns, ts = np.asarray(ns, float), np.asarray(ts, float)
    ok = np.isfinite(ts)
    return float(np.polyfit(np.log(ns[ok]), np.log(ts[ok]), 1)[0]) if ok.sum() >= 2 else float("nan")


STABS = [("none", {}), ("baumgarte ω=10", {"natural_frequency": 10.0}),
         ("baumgarte ω=30", {"natural_frequency": 30.0}), ("baumgarte ω=100", {"natural_frequency": 100.0}),
         ("projection", {})]


def _energy_and_drift(scene, eff, Y):
    """(E at each recorded state, max |C| over them): the two series of ``res.diagnostics`` the sweep reads,
    without the λ solve at every recorded state that the full diagnostics do (as much again as the run's own
    solves). E = T + V as :meth:`pbanim.scene.Scene.diagnostics` sums it; C from each kind's ``evaluate`` at the
    state's (x, v), the function the effect's diagnostics take C from: the same numbers."""
    evaluate = [unchecked(c.evaluate) for c in eff.cset.constraints]
    E, drift = np.empty(len(Y)), 0.0
    for k, y in enumerate(Y):
        x, v = scene.system.unpack(y)
        E[k] = float(scene.system.kinetic_energy(y)) + scene.potential_energy(y)
        for f in evaluate:
            drift = max(drift, float(np.max(np.abs(f(x, v)[0]), initial=0.0)))
    return E, drift


def work_precision(quick: bool = False, links: int | None = None) -> dict:
    """Rows (variant, h, drift, energy error, wall time) for the swinging chain; see the module docstring."""
    n = links or (3 if quick else 8)
    t_end = 0.3 if quick else 1.0
    hs = [0.01, 0.005] if quick else [0.01, 0.005, 0.0025, 0.00125]
    mod = hanging_chain(n, link_length=1.0 / n, angle=np.pi / 2)
    scale = float(mod.system.m.sum() * 9.81 * 1.0)
    energy_err: dict = {}

    def run(variant, h):
        method, (label, kw) = variant
        stab = label.split()[0]
        eff = Constraints(mod.constraints, stabilization=stab, max_violation=1.0, **kw)
        scene = Scene(mod.system, [Gravity(mod.g), eff])
        try:
            res = scene.simulate(t_end, h, method)
        except SimulationDiverged:
            energy_err[(method, label, h)] = float("inf")
            return {"drift": float("inf")}, 0
        E, drift = _energy_and_drift(scene, eff, res.y.T)
        energy_err[(method, label, h)] = float(np.max(np.abs(E - E[0])) / scale)
        return {"drift": drift}, res.nfev

    variants = [(m, s) for m in ("rk4", "symplectic_euler") for s in STABS]
    rows = sweep(run, variants, hs, lambda val: val["drift"], repeats=1)
    out = []
    for r in rows:
        method, (label, _) = r.variant
        out.append({"method": method, "stabilization": label, "h": r.param, "drift": r.error,
                    "energy_error": energy_err[(method, label, r.param)], "wall_time": r.wall_time, "nfev": r.nfev})
    return {"rows": out, "links": n, "t_end": t_end, "hs": hs}


def run(quick: bool = False) -> Report:
    """Run the constraint benchmarks and return the report (``quick``: small sizes, the test suite's smoke run)."""
    ns = [10, 100, 1000, 10_000] if quick else [10, 100, 1000, 10_000, 100_000]
    solvers = SOLVER_LIST if not quick else ["linear", "witkin-sparse", "kkt", "witkin-dense"]
    costs = step_costs(ns if not quick else ns[:3], solvers, repeats=2 if quick else 5)
    if quick:  # the n = 10⁴ goal points: linear and sparse LU only
        for s in solvers:
            costs[s].append(median_time(chain_step(10_000, s), repeats=3) if s in ("linear", "witkin-sparse")
                            else float("nan"))
    rep = Report("constraints")
    tab = Table("per-step cost (assembly + λ solve), hanging chain, ms", ["n"] + solvers)
    for i, n in enumerate(ns):
        tab.rows.append([n] + [costs[s][i] * 1e3 for s in solvers])
    rep.tables.append(tab)
    lin, lu = dict(zip(ns, costs["linear"])), dict(zip(ns, costs["witkin-sparse"]))
    big = [n for n in ns if n >= 1000]
    slope = loglog_slope(big, [lin[n] for n in big])
    wp = work_precision(quick)
    t2 = Table(f"work-precision, swinging chain of {wp['links']} links over {wp['t_end']} s",
               ["method", "stabilization", "h", "max|C|", "energy err", "wall s"])
    for r in wp["rows"]:
        t2.rows.append([r["method"], r["stabilization"], r["h"], r["drift"], r["energy_error"], r["wall_time"]])
    rep.tables.append(t2)
    rep.notes.append(f"witkin-dense skipped past n = {DENSE_MAX} (O(n³)); witkin-cg past n = {CG_MAX} and "
                     "reported nan where it does not reach tol 1e-8 in 4n + 100 iterations")
    if quick:
        rep.notes.append("quick mode: n ≤ 10⁴, kkt/dense only to 10³; the slope is fitted on 10³…10⁴")
    proj = max(r["drift"] for r in wp["rows"] if r["stabilization"] == "projection")
    g = _goal_rounds(rounds=3 if quick else 7, min_cpu=0.01 if quick else 0.05)
    ms = {k: np.array(g[k]) * 1e3 for k in ("linear", "witkin-sparse", "floor")}
    ratio = ms["witkin-sparse"] / ms["linear"]
    t3 = Table("n = 10⁴, process CPU ms per step in alternating rounds (the goals' numbers)",
               ["round", "linear", "sparse LU", "LU / linear", "floor", "linear − floor"])
    for i in range(len(ratio)):
        t3.rows.append([i + 1, ms["linear"][i], ms["witkin-sparse"][i], ratio[i], ms["floor"][i],
                        ms["linear"][i] - ms["floor"][i]])
    rep.tables.append(t3)
    med = {k: float(np.median(a)) for k, a in ms.items()}
    span = lambda a: f"{a.min():.3g}–{a.max():.3g}"  # noqa: E731
    rep.goals += [
        Goal("constraints-linear-1e4", med["linear"], 1.0, "<=", " ms",
             f"linear-time solver, n = 10⁴, process CPU, median of {len(ratio)} alternating rounds "
             f"({span(ms['linear'])} ms); floor of its bare calls {med['floor']:.3g} ms ({span(ms['floor'])}: "
             "evaluate, dpttrf + 2 dpttrs, 4 sparse products), the rest vector passes and Python"),
        Goal("constraints-linear-slope", slope, 1.15, "<=", "",
             f"log-log slope of the linear solver, n = {big[0]}…{big[-1]}"),
        Goal("constraints-linear-vs-sparse-lu", float(np.median(ratio)), 10.0, ">=", "x",
             f"speed-up over the generic sparse LU at n = 10⁴, process CPU, median of the rounds' ratios "
             f"({span(ratio)}); at the floor it would be {med['witkin-sparse'] / med['floor']:.3g}x; "
             f"max|Δλ|/max|λ| = {g['lam_diff']:.1e}"),
        Goal("constraints-projection-drift", proj, 1e-12, "<=", "", "max|C| with projection, all runs"),
    ]
    return rep
