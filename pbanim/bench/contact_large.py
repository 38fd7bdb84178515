"""Benchmark ``pbanim bench contact_large``: contact at scale against MuJoCo and PyBullet (issue 28, point 4).

Scenes (:mod:`pbanim.contact.scenes`): n rigid spheres (r = 0.05 m, 1 kg, μ = 0.5) poured into an open box
whose side grows with n so that the pile is about four layers deep at every n (``sphere_pile(n,
box_half=None)``), n = 100, 200, 500, 1000 (quick: 30, 60); and a running-bond brick wall of 50 boxes
(``brick_wall(50)``) dropped from 1 mm gaps. pbanim steps them with
:class:`pbanim.contact.stepping.FrictionStepping`, ``solver="pgs"``: the broad phase by a uniform grid
(:func:`pbanim.collision.broad.grid_pairs`), colored Gauss–Seidel on the bodies' velocities without the
Delassus matrix (:func:`pbanim.lcp.rows.pgs_box_friction_rows`), warm started from the last step's impulses.

Method (the contact benchmark's): each engine runs the same scene from the same start for the same simulated
time with its step h and its solver iterations swept, settings taken in order of increasing work (steps ×
iterations) until one reaches the accuracy; its cost per simulated second is the wall time of the stepping call
alone divided by the simulated time. Accuracy: the deepest penetration over the last third of the run (the
pile or wall has settled), from each engine's own contact distances, ≤ 1e-4 m. A setting that never
reaches it is a table row; an engine that reaches it at no setting is said so (its goal "not reached").

Growth: pbanim's cost per simulated second at one fixed setting (h = 1/60, 20 sweeps) at every n, and the
least-squares slope of log cost against log n. Goals: at 1000 spheres, pbanim's cheapest cost at 1e-4 m ≤ the
faster peer's; slope ≤ 1.2. The 50-box wall: the same comparison, printed, with its own goal line.
"""

from __future__ import annotations

import time

import numpy as np

from . import Goal, Report, Table, contact_peers

__all__ = ["run", "COUNTS", "ACCURACY", "pbanim_run", "cheapest"]

COUNTS, QUICK_COUNTS = (100, 200, 500, 1000), (30, 60)
ACCURACY = 1e-4
T_END, QUICK_T_END = 1.5, 0.6
SLOPE_SETTING = (1 / 60, 20)
#: (h, sweeps / iterations) in order of increasing work (steps × iterations per simulated second)
PBANIM_SETTINGS = ((1 / 60, 10), (1 / 60, 20), (1 / 120, 10), (1 / 120, 20), (1 / 240, 20), (1 / 240, 50))
PEER_SETTINGS = ((1 / 60, 10), (1 / 120, 10), (1 / 60, 50), (1 / 240, 10), (1 / 120, 50), (1 / 240, 50),
                 (1 / 480, 50))


def _scene(kind: str, n: int):
    from ..contact.scenes import brick_wall, sphere_pile

    return sphere_pile(n, box_half=None) if kind == "pile" else brick_wall(n)


def pbanim_run(kind: str, n: int, t_end: float, h: float, sweeps: int) -> dict:
    """One pbanim run: cost per simulated second (the whole ``simulate``), deepest penetration and drift of the
    highest centre over the last third, mean contacts and sweeps per step."""
    from ..contact.stepping import FrictionStepping

    sc = _scene(kind, n)
    ts = FrictionStepping(sc.system, sc.detect, sc.forces, friction=sc.friction, solver="pgs", iterations=sweeps)
    start = time.perf_counter()
    res = ts.simulate(t_end, h)
    wall = time.perf_counter() - start
    k0 = int(np.searchsorted(res.t, 2 * t_end / 3))
    z = res.y[2:3 * n:3]
    top = z.max(axis=0) if kind == "pile" else z[-1]
    st = ts.stats
    return {"cost": wall / t_end, "per_step": wall / res.nsteps, "pen": float(res.diagnostics["max_penetration"][k0:].max()),
            "drift": float(np.abs(top[k0:] - top[k0]).max()), "contacts": st["contacts"] / max(st["steps"], 1),
            "sweeps": st["rounds"] / max(st["contact_steps"], 1)}


def _peer_run(engine: str, kind: str, n: int, t_end: float, h: float, it: int) -> dict:
    S = contact_peers.scene_numbers(_scene(kind, n), t_end)
    r = contact_peers.settle_scene(engine, "pile" if kind == "pile" else "stack", S, h, it)
    return {"cost": r["cost"], "per_step": r["per_step"], "pen": r["pen"], "drift": r["drift"], "solver": r["solver"]}


def cheapest(runner, settings, tab: Table, label: list, stop: bool = True) -> float:
    """Run ``runner(h, it)`` over ``settings`` (increasing work), a table row each, until one reaches
    :data:`ACCURACY` (all of them with ``stop`` False); the cheapest cost that reached it, or inf."""
    best = np.inf
    for h, it in settings:
        r = runner(h, it)
        ok = r["pen"] <= ACCURACY
        tab.rows.append([*label, f"1/{round(1 / h)}", it, 1e3 * r["per_step"], r["cost"], r["pen"], r["drift"],
                         "yes" if ok else "no"])
        if ok:
            best = min(best, r["cost"])
            if stop:
                break
    return best


def _compare(kind: str, n: int, t_end: float, quick: bool, rep: Report, tab: Table) -> dict:
    """Cheapest cost at the accuracy per engine (inf: not reached; NaN: not installed)."""
    out = {"pbanim": cheapest(lambda h, it: pbanim_run(kind, n, t_end, h, it),
                              PBANIM_SETTINGS[:2] if quick else PBANIM_SETTINGS, tab, ["pbanim", n])}
    for engine in ("mujoco", "pybullet"):
        if not contact_peers.have(engine):
            out[engine] = np.nan
            rep.notes.append(f"{engine} not installed — its {kind} rows are skipped")
            continue
        out[engine] = cheapest(lambda h, it: _peer_run(engine, kind, n, t_end, h, it),
                               PEER_SETTINGS[:2] if quick else PEER_SETTINGS, tab, [engine, n])
    return out


def _goal(gid: str, costs: dict, note: str) -> Goal:
    peers = [costs[e] for e in ("mujoco", "pybullet")]
    if any(np.isnan(p) for p in peers):
        return Goal(gid, np.nan, 1.0, "<=", "x", note, skipped="mujoco or pybullet not installed")
    faster = min(peers)
    if not np.isfinite(costs["pbanim"]):
        return Goal(gid, np.inf, 1.0, "<=", "x", note + " — pbanim reached the accuracy at no setting of its sweep")
    if not np.isfinite(faster):
        return Goal(gid, 0.0, 1.0, "<=", "x", note + " — no peer reached the accuracy at any setting of its sweep "
                    "(the ratio printed as 0: pbanim is the only engine that reached it)")
    return Goal(gid, costs["pbanim"] / faster, 1.0, "<=", "x", note)


def run(quick: bool = False) -> Report:
    """Run the large-scene benchmark (``quick``: small piles, short runs, two settings: a smoke run)."""
    rep = Report("contact_large")
    counts, t_end = (QUICK_COUNTS, QUICK_T_END) if quick else (COUNTS, T_END)
    header = ["engine", "bodies", "h (s)", "sweeps / it.", "cost per step (ms)", "cost per sim. second (s)",
              "max penetration (m)", "drift (m)", f"≤ {ACCURACY:g} m"]
    # growth with n at one setting
    grow = Table(f"growth: pbanim's cost per simulated second at h = 1/{round(1 / SLOPE_SETTING[0])}, "
                 f"{SLOPE_SETTING[1]} sweeps, spheres poured into a box (about four layers deep), {t_end} s",
                 ["spheres", "cost per step (ms)", "cost per sim. second (s)", "mean contacts", "sweeps per step",
                  "max penetration (m)"])
    costs = []
    for n in counts:
        r = pbanim_run("pile", n, t_end, *SLOPE_SETTING)
        costs.append(r["cost"])
        grow.rows.append([n, 1e3 * r["per_step"], r["cost"], r["contacts"], r["sweeps"], r["pen"]])
    slope = float(np.polyfit(np.log(counts), np.log(costs), 1)[0])
    rep.tables.append(grow)
    rep.goals.append(Goal("contact-large-slope", slope, 1.2, "<=", "", f"least-squares slope of log cost vs log n, "
                          f"n = {', '.join(map(str, counts))}"))
    # the comparison at the largest pile and on the wall
    n = counts[-1]
    tab = Table(f"{n} spheres poured into a box, {t_end} s: each engine's settings in order of work until one "
                f"reaches penetration ≤ {ACCURACY:g} m (last third of the run)", header)
    pile = _compare("pile", n, t_end, quick, rep, tab)
    rep.tables.append(tab)
    rep.goals.append(_goal(f"contact-large-{n}-spheres-vs-peers", pile,
                           f"{n} spheres: pbanim's cheapest cost per simulated second at {ACCURACY:g} m / the faster "
                           "peer's (MuJoCo, PyBullet), same scene, same run"))
    nw = 20 if quick else 50
    wt = Table(f"a running-bond wall of {nw} boxes dropped from 1 mm, {t_end} s, the same method", header)
    wall = _compare("wall", nw, t_end, quick, rep, wt)
    rep.tables.append(wt)
    rep.goals.append(_goal(f"contact-large-wall-{nw}-vs-peers", wall,
                           f"{nw}-box wall: pbanim's cheapest cost per simulated second at {ACCURACY:g} m / the "
                           "faster peer's"))
    rep.notes.append("peers: MuJoCo (default Newton solver, pyramidal cones, default soft contacts solref 0.02) and "
                     "PyBullet (sequential impulse, default ERP and margins) with only their step and iteration "
                     "count changed; cost = their stepping call alone, pbanim's = its whole simulate loop")
    return rep
