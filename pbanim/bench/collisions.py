"""Benchmark ``pbanim bench collisions``: broad-phase scaling and time-of-impact accuracy vs cost.

1. Broad phase: N spheres at a fixed density (about 0.5 neighbours each); the uniform grid against
   all-pairs, both run on the same configurations in this run: candidate pairs tested and median wall
   time. Goal: near-linear growth of the grid, stated as the fitted log-log slope of its wall time vs N
   (≤ 1.3); all-pairs grows as N².
2. Time of impact: the bouncing ball (ε = 0.8, h₀ = 1 m) to just after its 4th impact; error of the 3rd
   apex height against ε⁶h₀, for event location and for fixed-step detection at several h, with wall times.
"""

from __future__ import annotations

import time

import numpy as np

from . import Goal, Report, Table, median_time

__all__ = ["run"]


def _spheres(N: int, rng) -> tuple[np.ndarray, float]:
    r = 0.05
    side = (N * (4 / 3) * np.pi * (2 * r) ** 3 / 0.5) ** (1 / 3)   # ~0.5 expected neighbours per sphere
    return rng.uniform(0, side, (N, 3)), r


def run(quick: bool = False) -> Report:
    """Run the collision benchmarks and return the report (``quick``: small sizes, the test suite's smoke run)."""
    from ..collision.broad import all_pairs, grid_pairs
    from ..collision.toi import simulate_collisions
    from ..models.collision import bouncing_ball

    rng = np.random.default_rng(2024)
    Ns = [100, 300, 1000, 3000] if quick else [100, 300, 1000, 3000, 10000]
    broad = Table("broad phase: uniform grid vs all pairs (same spheres)",
                  ["N", "pairs found", "grid tested", "grid time (s)", "all-pairs tested", "all-pairs time (s)",
                   "speed-up"])
    tg = []
    for N in Ns:
        c, r = _spheres(N, rng)
        g = grid_pairs(c, r)
        a = all_pairs(c, r, block=128)
        if not np.array_equal(g.pairs, a.pairs):
            raise AssertionError(f"grid and all-pairs disagree at N = {N}")
        reps = 3 if quick else 5
        t_grid = median_time(lambda: grid_pairs(c, r), repeats=reps + 2, min_time=0.05)
        t_all = median_time(lambda: all_pairs(c, r, block=128), repeats=1 if N >= 3000 else reps)
        tg.append(t_grid)
        broad.rows.append([N, len(g.pairs), g.tested, t_grid, a.tested, t_all, t_all / t_grid])
    # fit where the work, not the fixed per-call overhead, dominates: N ≥ 1000 (N ≥ 300 in quick mode)
    big = [i for i, N in enumerate(Ns) if N >= (300 if quick else 1000)]
    slope = float(np.polyfit(np.log(np.array(Ns)[big]), np.log(np.array(tg)[big]), 1)[0])
    tested_slope = float(np.polyfit(np.log(Ns), np.log([row[2] for row in broad.rows]), 1)[0])

    bb = bouncing_ball(1.0, 0.8)
    T = 1.02 * float(bb.impact_times(4))
    exact = float(bb.apex_heights(3))
    hs = [0.02, 0.0125, 0.005] if quick else [0.02, 0.0125, 0.008, 0.005, 0.003, 0.002]
    toi = Table("time of impact: error of the 3rd apex height vs wall time (bouncing ball, RK4)",
                ["toi", "h (s)", "|h3 - eps^6 h0| (m)", "wall time (s)", "impacts located by events"])
    worst_event, best_fixed = 0.0, np.inf
    for mode in ("event", "fixed"):
        for h in hs:
            start = time.perf_counter()
            res = simulate_collisions(bb.scene(), T, h, toi=mode)
            wall = time.perf_counter() - start
            err = abs(bb.measured_apex_heights(res)[2] - exact)
            toi.rows.append([mode, h, err, wall, len(res.t_events[0])])
            if mode == "event":
                worst_event = max(worst_event, err)
            else:
                best_fixed = min(best_fixed, err)
    rep = Report("collisions", tables=[broad, toi])
    rep.notes.append(f"grid: pairs tested grow with slope {tested_slope:.2f} in N; all-pairs tests N(N-1)/2")
    rep.notes.append("fixed-step detection: the impact is seen up to h late (penetration, then impulse), "
                     "so the apex error is O(h) and large; event location splits the step at the root")
    rep.goals.append(Goal("collisions-broad-grid-slope", slope, 1.3, "<=", "",
                          f"fitted log-log slope of grid wall time vs N over N = {Ns[big[0]]}..{Ns[-1]}"))
    rep.goals.append(Goal("collisions-toi-event-apex-error", worst_event, 1e-9, "<=", " m",
                          "worst 3rd-apex error with event location over all h"))
    rep.goals.append(Goal("collisions-toi-fixed-vs-event", best_fixed / max(worst_event, 1e-16), 1e3, ">=", "x",
                          "best fixed-step error / worst event-location error"))
    return rep
