"""Benchmark ``pbanim bench contact_large``: contact at scale against MuJoCo and PyBullet (issue 28, point 4).

Scenes (:mod:`pbanim.contact.scenes`): n rigid spheres (r = 0.05 m, 1 kg, μ = 0.5) poured into an open box
whose side grows with n so that the pile is about four layers deep at every n (``sphere_pile(n,
box_half=None)``), n = 100, 200, 500, 1000 (quick: 30, 60); and a running-bond brick wall of 50 boxes
(``brick_wall(50)``; quick: 20) dropped from 1 mm gaps. pbanim steps them with
:class:`pbanim.contact.split.SplitStepping`: the broad phase by a uniform grid
(:func:`pbanim.collision.broad.grid_pairs`), colored Gauss–Seidel on the bodies' velocities without the
Delassus matrix (:func:`pbanim.lcp.rows.pgs_box_friction_rows`), warm started from the last step's impulses
matched by contact key, stopped by its residual test; then a position correction by pseudo-velocities on the
normal rows (:func:`pbanim.lcp.rows.pgs_normal_rows`) that leaves at most 5e-5 m of (linearized) penetration
and adds no kinetic energy. The pile's contact margin grows with the step, max(0.1 r, h · 0.6 m/s), so a
contact closing at up to 0.6 m/s is in the step's problem before it closes.

Method (the contact benchmark's): each engine runs the same scene from the same start for the same simulated
time with its step h and its solver iterations swept, settings taken in order of increasing work (steps ×
iterations) until one reaches the accuracy; its cost per simulated second is the wall time of the stepping
calls alone divided by the simulated time. Accuracy: the deepest penetration over the last third of the run
(the pile or wall has settled), from each engine's own contact distances, ≤ 1e-4 m. Each engine has a time
budget per scene (:func:`budget`, seconds of stepping summed over its settings); a run that would exceed it
stops and its row says "over budget" (its cost per simulated second so far is printed). Every row is printed
as it finishes.

The settings are those that can reach 1e-4 m, cheapest first. pbanim: h = 1/30 … 1/120 with at most 10–20
velocity sweeps (the position sweeps reach the penetration at any step). MuJoCo's soft contacts rest at a depth
set by solref's time constant τ (≥ 2h) and solimp's impedance: its defaults (τ = 0.02 s, 0.9–0.95) rest
1–3 mm deep in a pile, so its later settings stiffen them with the step (τ = 2.4 h, impedance 0.99–0.999;
measured while writing: 5e-5 m on the 100-sphere pile at h = 1/960); its noslip iterations were tried and
made the pile diverge. PyBullet's depth is set by its ERP and margins: ERP 0.8 at h = 1/480, then its defaults
at h = 1/960 (8.6e-5 m on the 100-sphere pile). MuJoCo runs its CG solver: its default Newton solver factors a
Hessian that fills in on a pile (measured while writing this benchmark: 11 s per step at 1000 spheres, against
25–45 ms for CG). The full run adds, for comparison only, pbanim's step before the position correction
(Baumgarte erp 0.2, h = 1/120, 20 sweeps) on the largest pile and the wall.

Growth: each engine's cost per simulated second at its first setting at every n, and the least-squares slope
of log cost against log n (pbanim's is the goal, the peers' are printed). Goals: at 1000 spheres, pbanim's
cheapest cost at 1e-4 m ≤ the faster peer's; slope ≤ 1.2; the 50-box wall, the same comparison. Where no peer
reached 1e-4 m at any setting swept, the goal line says so and judges pbanim's cost against the cheapest run
of each peer at the smallest penetration it reached (stated in the note: a looser accuracy than pbanim's).
"""

from __future__ import annotations

import time

import numpy as np

from . import Goal, Report, Table, contact_peers
from ..ode.driver import check_finite

__all__ = ["run", "COUNTS", "ACCURACY", "ENGINES", "SETTINGS", "pbanim_run", "cheapest", "budget"]

COUNTS, QUICK_COUNTS = (100, 200, 500, 1000), (30, 60)
ACCURACY = 1e-4
T_END, QUICK_T_END = 1.5, 0.6
ENGINES = ("pbanim", "mujoco", "pybullet")
_STIFF = {"solimp": (0.99, 0.999, 0.001)}         # MuJoCo: impedance near 1 (a stiffer soft contact)
#: (h, sweeps / iterations, the engine's own contact options) per engine in order of increasing work (steps ×
#: iterations per simulated second); pbanim's options: ``SplitStepping``'s (velocity residual tolerance,
#: penetration left by the position sweeps), MuJoCo's solref/solimp, PyBullet's ERP (:func:`contact_peers.settle_scene`)
PB_OPTIONS = {"tol": 1e-3, "position_tol": 5e-5}
SETTINGS = {"pbanim": ((1 / 30, 10, PB_OPTIONS), (1 / 60, 10, PB_OPTIONS), (1 / 60, 20, PB_OPTIONS),
                       (1 / 120, 20, PB_OPTIONS)),
            "mujoco": ((1 / 120, 10, {}), (1 / 480, 20, {"solref": (0.005, 1.0), **_STIFF}),
                       (1 / 960, 20, {"solref": (0.0025, 1.0), **_STIFF})),
            "pybullet": ((1 / 120, 10, {}), (1 / 480, 50, {"erp": 0.8}), (1 / 960, 30, {}))}
#: pbanim's look-ahead: the narrow phase keeps pairs closer than max(0.1 r, h × this speed) (m/s), so that a
#: contact approaching at up to 0.6 m/s is in the step's problem before it closes (0.1 r = 5 mm at h = 1/120)
LOOKAHEAD_SPEED = 0.6
MJ_SOLVER = "cg"
HEADER = ["engine", "bodies", "h (s)", "sweeps / it.", "cost per step (ms)", "cost per sim. second (s)",
          "max penetration (m)", "drift (m)", f"≤ {ACCURACY:g} m"]


def budget(kind: str, n: int, quick: bool) -> float:
    """Seconds of stepping one engine may spend on one scene ("pile" of n spheres, "wall"), over all its
    settings (the same for every engine): 10 s + 70 s per 1000 spheres, 40 s for the wall (quick: 4 s + 4 s per
    100 bodies)."""
    if quick:
        return 4.0 + 0.04 * n
    return 40.0 if kind == "wall" else 10.0 + 0.07 * n


def _scene(kind: str, n: int, h: float | None = None):
    """The scene; with ``h`` (pbanim's runs) the pile's contact margin max(0.1 r, h·:data:`LOOKAHEAD_SPEED`)."""
    from ..contact.scenes import brick_wall, sphere_pile

    if kind == "wall":
        return brick_wall(n)
    return sphere_pile(n, box_half=None, margin=None if h is None else max(0.005, h * LOOKAHEAD_SPEED))


def pbanim_run(kind: str, n: int, t_end: float, h: float, sweeps: int, limit: float = np.inf,
               options: dict | None = None) -> dict:
    """One pbanim run (:class:`pbanim.contact.split.SplitStepping`, ``options`` its keywords; "baumgarte":
    True runs FrictionStepping's erp feedback instead, the state before the position correction): cost per step
    and per simulated second (the stepping calls alone, as for the peers), deepest penetration and drift of the
    highest centre (the wall: the last brick) over the last third, mean contacts, velocity sweeps and position
    sweeps per step. Stops after ``limit`` seconds of stepping ("over": True, penetration NaN)."""
    from ..contact.split import SplitStepping

    o = dict(PB_OPTIONS if options is None else options)
    baum = bool(o.pop("baumgarte", False))
    sc = _scene(kind, n, None if baum else h)
    ts = SplitStepping(sc.system, sc.detect, sc.forces, friction=sc.friction, iterations=sweeps,
                       correction=not baum, **({"tol": 1e-9} if baum else o))
    steps = max(1, int(round(t_end / h)))
    k0 = (2 * steps) // 3
    y = np.array(sc.system.state(), dtype=float)
    pens, tops = np.zeros(steps), np.zeros(steps)
    elapsed, done, step = 0.0, 0, ts.step
    for k in range(steps):
        start = time.perf_counter()
        y = step(k * h, y, h)
        elapsed += time.perf_counter() - start
        check_finite(y, k * h, k + 1)                  # a diverging run raises SimulationDiverged
        z = y[2:3 * n:3]
        pens[k], tops[k], done = ts.last_info["penetration"], z.max() if kind == "pile" else z[-1], k + 1
        if elapsed > limit:
            break
    st = ts.stats
    out = {"per_step": elapsed / done, "contacts": st["contacts"] / max(st["steps"], 1),
           "sweeps": st["rounds"] / max(st["contact_steps"], 1), "over": done < steps, "t_reached": done * h,
           "position_sweeps": st["position_sweeps"] / max(st["contact_steps"], 1)}
    if done < steps:
        return {**out, "cost": elapsed / (done * h), "pen": np.nan, "drift": np.nan}
    return {**out, "cost": elapsed / t_end, "pen": float(pens[k0:].max()),
            "drift": float(np.abs(tops[k0:] - tops[k0]).max())}


def _peer_run(engine: str, kind: str, n: int, t_end: float, h: float, it: int, limit: float,
              options: dict | None = None) -> dict:
    S = contact_peers.scene_numbers(_scene(kind, n), t_end)
    return contact_peers.settle_scene(engine, "pile" if kind == "pile" else "stack", S, h, it, budget=limit,
                                      solver=MJ_SOLVER if engine == "mujoco" else None, options=options)


def _emit(title: str, row: list, printed: set) -> None:
    """Print a table row as soon as it is measured (the table's title before its first row)."""
    if title not in printed:
        printed.add(title)
        print(f"## {title}\n" + "  ".join(HEADER), flush=True)
    print("  ".join(Table("", HEADER, [row]).format().splitlines()[-1:]), flush=True)


def _setting(it: int, options: dict | None = None) -> str:
    """The table's "sweeps / it." cell: the count, and the engine's options beyond its defaults."""
    if not options:
        return str(it)
    said = ", ".join(f"{k} {' '.join(f'{x:g}' for x in np.atleast_1d(v))}" for k, v in options.items())
    return f"{it} ({said})"


def cheapest(runner, settings, tab: Table, label: list, limit: float = np.inf, printed: set | None = None) -> dict:
    """Run ``runner(h, it, remaining budget)`` over ``settings`` (increasing work), a table row each, until one
    reaches :data:`ACCURACY` or the budget ``limit`` (seconds of stepping) is spent. Returns the cheapest cost at
    the accuracy ("cost", inf if none), the smallest penetration reached and the cost of that run ("best_pen",
    "best_cost"), the first setting's run ("first") and whether the budget ran out ("over")."""
    out = {"cost": np.inf, "best_pen": np.inf, "best_cost": np.inf, "first": None, "over": False}
    spent = 0.0
    for h, it, *opts in settings:
        cell = _setting(it, *opts)
        if spent >= limit:
            out["over"] = True
            row = [*label, f"1/{round(1 / h)}", cell, np.nan, np.nan, np.nan, np.nan, "over budget (not run)"]
        else:
            r = runner(h, it, limit - spent, *opts)
            spent += r["per_step"] * round(r["t_reached"] / h)
            out["first"] = out["first"] or r
            ok = bool(r["pen"] <= ACCURACY)
            verdict = (f"over budget (stopped at t = {r['t_reached']:.2f} s)" if r["over"] else "yes" if ok else "no")
            out["over"] |= r["over"]
            row = [*label, f"1/{round(1 / h)}", cell, 1e3 * r["per_step"], r["cost"], r["pen"], r["drift"], verdict]
            if not r["over"] and (r["pen"], r["cost"]) < (out["best_pen"], out["best_cost"]):
                out["best_pen"], out["best_cost"] = r["pen"], r["cost"]
            if ok:
                out["cost"] = min(out["cost"], r["cost"])
        tab.rows.append(row)
        if printed is not None:
            _emit(tab.title, row, printed)
        if np.isfinite(out["cost"]):
            break
    return out


def _compare(kind: str, n: int, t_end: float, quick: bool, rep: Report, tab: Table, printed: set) -> dict:
    """Per engine the outcome of :func:`cheapest` (None: not installed)."""
    out = {}
    for engine in ENGINES:
        if engine != "pbanim" and not contact_peers.have(engine):
            out[engine] = None
            note = f"{engine} not installed — its rows are skipped"
            if note not in rep.notes:
                rep.notes.append(note)
            continue
        settings = SETTINGS[engine][:1] if quick else SETTINGS[engine]
        if engine == "pbanim":
            runner = lambda h, it, lim, o=None: pbanim_run(kind, n, t_end, h, it, lim, o)  # noqa: E731
        else:
            runner = lambda h, it, lim, o=None, e=engine: _peer_run(e, kind, n, t_end, h, it, lim, o)  # noqa: E731
        out[engine] = cheapest(runner, settings, tab, [engine, n], budget(kind, n, quick), printed)
    return out


def _goal(gid: str, res: dict, note: str) -> Goal:
    """pbanim's cheapest cost at the accuracy over the faster peer's; if no peer reached it, over the cheapest
    run of each peer at the smallest penetration it reached (said in the note)."""
    peers = {e: res[e] for e in ENGINES[1:]}
    if any(p is None for p in peers.values()):
        return Goal(gid, np.nan, 1.0, "<=", "x", note, skipped="mujoco or pybullet not installed")
    mine = res["pbanim"]
    if not np.isfinite(mine["cost"]):
        best = "; ".join(f"{e} {p['best_cost']:.3g} s per sim. s at {p['best_pen']:.2g} m" for e, p in res.items()
                         if np.isfinite(p["best_cost"]))
        return Goal(gid, np.inf, 1.0, "<=", "x", note + f" — pbanim reached {ACCURACY:g} m at no setting swept "
                    f"within its budget; the smallest penetration each engine reached: {best or 'none finished'}")
    if any(np.isfinite(p["cost"]) for p in peers.values()):
        return Goal(gid, mine["cost"] / min(p["cost"] for p in peers.values()), 1.0, "<=", "x", note)
    best = {e: p for e, p in peers.items() if np.isfinite(p["best_cost"])}
    if not best:
        return Goal(gid, np.nan, 1.0, "<=", "x", note, skipped="no peer finished a run within its budget")
    said = "; ".join(f"{e} {p['best_cost']:.3g} s per sim. s at {p['best_pen']:.2g} m" for e, p in best.items())
    return Goal(gid, mine["cost"] / min(p["best_cost"] for p in best.values()), 1.0, "<=", "x",
                note + f" — no peer reached {ACCURACY:g} m at any setting swept: judged against the best each "
                f"reached ({said}), pbanim {mine['cost']:.3g} s per sim. s at ≤ {ACCURACY:g} m")


def _before(n: int, nw: int, t_end: float, tab: Table, wt: Table, printed: set) -> None:
    """pbanim as it stepped before the position correction (FrictionStepping, Baumgarte erp 0.2, h = 1/120,
    20 sweeps) on the largest pile and the wall: a row each, for comparison only (no goal reads it)."""
    for kind, count, t in (("pile", n, tab), ("wall", nw, wt)):
        r = pbanim_run(kind, count, t_end, 1 / 120, 20, options={"baumgarte": True})
        row = ["pbanim Baumgarte erp 0.2 (before)", count, "1/120", "20", 1e3 * r["per_step"], r["cost"], r["pen"],
               r["drift"], "yes" if r["pen"] <= ACCURACY else "no"]
        t.rows.append(row)
        _emit(t.title, row, printed)


def _slope(counts, costs) -> float:
    ok = [(n, c) for n, c in zip(counts, costs) if np.isfinite(c) and c > 0]
    if len(ok) < 2:
        return np.nan
    return float(np.polyfit(np.log([n for n, _ in ok]), np.log([c for _, c in ok]), 1)[0])


def _wall(quick: bool, t_end: float, rep: Report, printed: set) -> tuple:
    """The wall's comparison: its table and goal appended to ``rep``; (its box count, its table)."""
    nw = 20 if quick else 50
    wt = Table(f"a running-bond wall of {nw} boxes dropped from 1 mm, {t_end} s, the same method", HEADER)
    wall = _compare("wall", nw, t_end, quick, rep, wt, printed)
    rep.tables.append(wt)
    rep.goals.append(_goal(f"contact-large-wall-{nw}-vs-peers", wall,
                           f"{nw}-box wall: pbanim's cheapest cost per simulated second at {ACCURACY:g} m / the "
                           "faster peer's"))
    return nw, wt


def run(quick: bool = False, only: str | None = None) -> Report:
    """Run the large-scene benchmark (``quick``: small piles, short runs, one setting per engine: a smoke run;
    ``only="wall"``: the wall's comparison and goal alone, ``python -m pbanim.bench.contact_large --only wall``)."""
    rep = Report("contact_large")
    counts, t_end = (QUICK_COUNTS, QUICK_T_END) if quick else (COUNTS, T_END)
    printed: set = set()
    if only == "wall":
        _wall(quick, t_end, rep, printed)
        return rep
    tab = Table(f"spheres poured into a box (about four layers deep), {t_end} s: each engine's settings in order "
                f"of work until one reaches penetration ≤ {ACCURACY:g} m (last third of the run)", HEADER)
    piles = {}
    for n in counts:
        piles[n] = _compare("pile", n, t_end, quick, rep, tab, printed)
    firsts = ", ".join(f"{e} h = 1/{round(1 / SETTINGS[e][0][0])}, {SETTINGS[e][0][1]} it." for e in ENGINES)
    grow = Table(f"growth: each engine's cost per simulated second at its first setting ({firsts}), {t_end} s",
                 ["spheres", "pbanim cost per step (ms)", "pbanim (s)", "mujoco (s)", "pybullet (s)",
                  "pbanim mean contacts", "pbanim sweeps per step", "pbanim position sweeps per step"])
    first = {e: [] for e in ENGINES}
    for n in counts:
        f = {e: (piles[n][e] or {}).get("first") or {} for e in ENGINES}
        for e in ENGINES:
            first[e].append(np.nan if not f[e] or f[e]["over"] else f[e]["cost"])
        grow.rows.append([n, 1e3 * f["pbanim"].get("per_step", np.nan), first["pbanim"][-1], first["mujoco"][-1],
                          first["pybullet"][-1], f["pbanim"].get("contacts", np.nan), f["pbanim"].get("sweeps", np.nan),
                          f["pbanim"].get("position_sweeps", np.nan)])
    slopes = {e: _slope(counts, first[e]) for e in ENGINES}
    at_acc = [piles[n]["pbanim"]["cost"] for n in counts]
    rep.tables += [grow, tab]
    rep.notes.append("slope of log cost vs log n at each engine's first setting: " + ", ".join(
        f"{e} {slopes[e]:.3g}" for e in ENGINES) + f"; pbanim's at {ACCURACY:g} m (its cheapest setting per n): "
        f"{_slope(counts, at_acc):.3g}")
    h0, it0 = SETTINGS["pbanim"][0][:2]
    rep.goals.append(Goal("contact-large-slope", slopes["pbanim"], 1.2, "<=", "", "least-squares slope of pbanim's "
                          f"log cost vs log n at h = 1/{round(1 / h0)}, at most {it0} sweeps, n = "
                          f"{', '.join(map(str, counts))}"))
    n = counts[-1]
    rep.goals.append(_goal(f"contact-large-{n}-spheres-vs-peers", piles[n],
                           f"{n} spheres: pbanim's cheapest cost per simulated second at {ACCURACY:g} m / the faster "
                           "peer's (MuJoCo, PyBullet), same scene, same run"))
    nw, wt = _wall(quick, t_end, rep, printed)
    if not quick:
        _before(n, nw, t_end, tab, wt, printed)
    rep.notes.append(f"peers: MuJoCo ({MJ_SOLVER.upper()} solver, pyramidal cones; its soft contacts stiffened "
                     "with the step: solimp 0.99–0.999 and solref time constant 2.4 h) and PyBullet (sequential "
                     "impulse; ERP 0.8, then its defaults at h = 1/960), their settings in the rows; pbanim: "
                     "SplitStepping (velocity sweeps stopped at residual 1e-3 or the cap, position sweeps until "
                     "≤ 5e-5 m); cost = the stepping calls alone for every engine; budget per engine "
                     f"per scene {budget('pile', counts[0], quick):.0f}–{budget('pile', counts[-1], quick):.0f} s "
                     f"of stepping (the wall {budget('wall', nw, quick):.0f} s)")
    return rep


if __name__ == "__main__":              # one scene alone: python -m pbanim.bench.contact_large --only wall
    import argparse

    from . import format_report, one_blas_thread

    cli = argparse.ArgumentParser(prog="python -m pbanim.bench.contact_large")
    cli.add_argument("--only", choices=["wall"], default=None, help="run only this scene's comparison")
    cli.add_argument("--quick", action="store_true")
    args = cli.parse_args()
    with one_blas_thread():
        print(format_report(run(quick=args.quick, only=args.only)))
