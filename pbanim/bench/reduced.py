"""``pbanim bench reduced``: deriving, compiling and running reduced-coordinate models (ch04).

Measured in one run, so both sides of every ratio share the machine's load:

1. **Derivation + compilation** of the planar n-link pendulum (n = 2, 5, 10, 20; quick: 2, 3):
   :mod:`pbanim.reduced.lagrangian` (kinematic route, CSE-compiled) against sympy.physics.mechanics'
   ``KanesMethod`` and ``LagrangesMethod`` (equations, then ``lambdify`` of ``mass_matrix_full`` and
   ``forcing_full``, the way their documentation simulates). Every side runs in a fresh subprocess (cold
   sympy caches, same start) capped at ``CAP`` = 60 s; a capped run is reported as ">60 s (cap)".
2. **RHS evaluation** per call at n = 10 (quick: 3): ours (Lagrangian and reduced) against the lambdified
   KanesMethod equations (solve of the full 2n × 2n mass matrix, as in their examples).
3. **Maximal vs reduced vs Lagrangian** at equal accuracy: wall time per simulated second of the
   n-link pendulum (n = 2, 5, 10, 20, 50; quick: 2, 3) with RK4, each at the largest step
   h = 0.05·2^(−k/2) whose tip-position error at t = 1 s is ≤ 1e-8 m (reference: dop853 at rtol 1e-12).
   Maximal: chapter 03's ``Constraints`` (Distance rods, solver "auto", no stabilization).

Goals (issue 4): derivation + compilation ≥ 10× faster than KanesMethod at n = 10; RHS ≥ 4× faster than
the lambdified KanesMethod equations at n = 10.
"""

from __future__ import annotations

import json
import subprocess
import sys
import time

import numpy as np

from . import Goal, Report, Table, median_time

__all__ = ["run", "CAP", "derive_worker", "derive_in_subprocess", "derive_batch", "cost_at_accuracy",
           "derivation_times"]

CAP = 60.0


def _mechanics_chain(n: int, method: str, L: float = 1.0, m: float = 1.0, g: float = 9.81):
    """The n-link pendulum in sympy.physics.mechanics; returns (mass_matrix_full, forcing_full, q, u, t)."""
    import sympy as sm
    import sympy.physics.mechanics as me

    q = me.dynamicsymbols(f"q0:{n}")
    u = me.dynamicsymbols(f"u0:{n}")
    N = me.ReferenceFrame("N")
    O = me.Point("O")
    O.set_vel(N, 0)
    P, particles, loads, kd = O, [], [], []
    for i in range(n):
        B = N.orientnew(f"B{i}", "Axis", [q[i], N.z])          # absolute angle from the downward vertical
        Pi = P.locatenew(f"P{i}", -L * B.y)
        if method == "kane":
            B.set_ang_vel(N, u[i] * N.z)
        Pi.v2pt_theory(P, N, B)
        pa = me.Particle(f"Pa{i}", Pi, sm.Float(m))
        particles.append(pa)
        loads.append((Pi, -m * g * N.y))
        kd.append(q[i].diff() - u[i])
        P = Pi
    if method == "kane":
        km = me.KanesMethod(N, q_ind=q, u_ind=u, kd_eqs=kd)
        km.kanes_equations(particles, loads)
        return km.mass_matrix_full, km.forcing_full, q, u
    lag = me.Lagrangian(N, *particles)
    lm = me.LagrangesMethod(lag, q, forcelist=loads, frame=N)
    lm.form_lagranges_equations()
    qd = [qi.diff() for qi in q]
    return lm.mass_matrix_full, lm.forcing_full, q, qd


def derive_worker(kind: str, n: int, rhs_calls: int = 0, rhs_time: bool = True) -> dict:
    """Run in a subprocess: time model building, derivation and compilation (and optionally the rhs).

    Imports (sympy, sympy.physics.mechanics, pbanim.reduced.lagrangian) happen before the clock starts.
    ``rhs_calls``: also the rhs at one state (``rhs_value``) and, with ``rhs_time``, its median time per call
    (``rhs``: five repeats of at least 0.05 s each); a figure that only compares the values skips the timing.
    """
    import sympy as sm
    import sympy.physics.mechanics  # noqa: F401

    from ..reduced.lagrangian import compile_equations, derive_equations
    from ..models.reduced import n_link_pendulum

    t0 = time.perf_counter()
    if kind == "pbanim":
        mod = n_link_pendulum(n)
        coords, pos, _ = mod.build()
        eqs = derive_equations(list(coords), list(zip(mod.masses.tolist(), pos)), gravity=mod.g.tolist())
        t1 = time.perf_counter()
        sysl = compile_equations(eqs)
        t2 = time.perf_counter()
        fun = sysl.rhs
    else:
        MM, F, q, u = _mechanics_chain(n, kind)
        t1 = time.perf_counter()
        f = sm.lambdify([q, u], [MM, F])     # what the sympy.physics.mechanics docs do
        t2 = time.perf_counter()

        def fun(t, y):
            Mn, Fn = f(y[:n], y[n:])
            return np.linalg.solve(Mn, Fn).ravel()
    out = {"derive": t1 - t0, "compile": t2 - t1, "total": t2 - t0}
    if rhs_calls:
        y = np.concatenate([0.5 + 0.1 * np.arange(n), 0.3 * np.ones(n)])
        if rhs_time:
            out["rhs"] = median_time(lambda: fun(0.0, y), repeats=5, min_time=0.05)
        out["rhs_value"] = np.asarray(fun(0.0, y)).tolist()
    return out


def derive_in_subprocess(kind: str, n: int, rhs_calls: int = 0, cap: float = CAP) -> dict:
    """One :func:`derive_worker` job in a fresh interpreter, killed after ``cap`` seconds."""
    return derive_batch([(kind, n, rhs_calls)], cap)[0]


def derive_batch(jobs, cap: float = CAP) -> list[dict]:
    """Several jobs in one fresh interpreter (quick mode: one sympy import for all; caches then warm).

    A job that does not finish within ``cap`` seconds (the whole batch's budget) reports
    ``{"total": nan, "capped": True}``.
    """
    code = ("import json, sys, pbanim.bench.reduced as b\n"
            f"for job in {list(jobs)!r}:\n"
            "    print(json.dumps(b.derive_worker(*job)), flush=True)\n")
    try:
        out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=cap)
        lines, err = out.stdout.strip().splitlines(), (out.stderr.strip().splitlines()[-1:] if out.returncode else [])
    except subprocess.TimeoutExpired as exc:
        so = exc.stdout.decode() if isinstance(exc.stdout, bytes) else (exc.stdout or "")
        lines, err = so.strip().splitlines(), ["capped"]
    res = [json.loads(line) | {"capped": False} for line in lines if line.startswith("{")]
    while len(res) < len(jobs):
        res.append({"total": np.nan, "derive": np.nan, "compile": np.nan, "capped": err == ["capped"],
                    "error": err})
    return res


def derivation_times(ns, kinds=("pbanim", "kane", "lagrange"), cap: float = CAP) -> dict:
    """{kind: [seconds or nan (capped)]} for derivation + compilation of the n-link pendulum."""
    res = {k: [] for k in kinds}
    for n in ns:
        for k in kinds:
            r = derive_in_subprocess(k, n, 0, cap)
            res[k].append(r["total"])
    return res


def _tip_error(rhs, y0, tip, h, t_end, ref_tip, method="rk4"):
    from ..reduced.system import simulate_fixed

    res = simulate_fixed(rhs, y0, t_end, h, method, record_every=10 ** 9)
    return float(np.linalg.norm(tip(res.y[:, -1]) - ref_tip)), res.wall_time / t_end


def cost_at_accuracy(n: int, tol: float = 1e-8, t_end: float = 1.0, h0: float = 0.05,
                     formulations=("maximal", "reduced", "lagrangian")) -> dict:
    """Wall seconds per simulated second with RK4 at the largest h = h0·2^(−k/2) whose tip error ≤ tol.

    The tip error at t_end is measured against dop853 at rtol 1e-12. The ladder is entered at the step
    that RK4's h⁴ error law predicts from one trial at h0, then walked down until the error is met.
    Returns {formulation: (cost, h, error)} and "lagrangian_setup" (derivation + compilation, s).
    """
    from .. import solve
    from ..models.reduced import maximal_chain, n_link_pendulum

    mod = n_link_pendulum(n, theta0=0.3 + 0.4 * np.arange(n) / max(n - 1, 1))
    red = mod.reduced()
    mx = maximal_chain(mod)
    # the reference: dop853 at rtol 1e-12 (it was dopri5 at the same tolerances: 3x the evaluations, 1.5 s of the
    # figure's 2.2 s of references; the two tips agree to 1e-13 m for n = 2 … 50, 1e-5 of tol)
    ref = solve(red.rhs, (0.0, t_end), mod.state(), method="dop853", rtol=1e-12, atol=1e-13)
    ref_tip = red.particle_state(ref.y[:, -1])[2 * n - 2: 2 * n]
    out = {}
    for f in formulations:
        if f == "maximal":
            rhs, y0, tip = mx.scene.rhs, mx.state(), (lambda y: y[2 * n - 2: 2 * n])
        elif f == "reduced":
            rhs, y0, tip = red.rhs, mod.state(), (lambda y: red.particle_state(y)[2 * n - 2: 2 * n])
        else:
            t0 = time.perf_counter()
            lag = mod.lagrangian()
            out["lagrangian_setup"] = time.perf_counter() - t0
            rhs, y0, tip = lag.rhs, mod.state(), (lambda y: red.particle_state(y)[2 * n - 2: 2 * n])
        err0, cost0 = _tip_error(rhs, y0, tip, h0, t_end, ref_tip)
        k = 0 if err0 <= tol else max(1, int(np.floor(2 * np.log2((err0 / tol) ** 0.25))))
        best = (cost0, h0, err0) if err0 <= tol else (np.nan, np.nan, np.nan)
        for kk in range(k, k + 12) if k else ():
            h = t_end / np.ceil(t_end / (h0 * 2.0 ** (-kk / 2)))   # a whole number of steps
            err, cost = _tip_error(rhs, y0, tip, h, t_end, ref_tip)
            if err <= tol:
                best = (cost, h, err)
                break
        out[f] = best
    return out


def run(quick: bool = False) -> Report:
    """Run the reduced-coordinate benchmarks and return the report (``quick``: small sizes, the test suite's smoke run)."""
    rep = Report("reduced")
    ns = [2, 3] if quick else [2, 5, 10, 20]
    n_rhs = 3 if quick else 10
    cap = 20.0 if quick else CAP
    # 1. derivation + compilation, each side in a fresh subprocess (quick: one subprocess for all)
    kinds = ("pbanim", "kane", "lagrange")
    if quick:
        flat = derive_batch([(k, n, 0) for n in ns for k in kinds] + [("kane", n_rhs, 1)], cap)
        at = {n: dict(zip(kinds, flat[3 * i: 3 * i + 3])) for i, n in enumerate(ns)}
        kr = flat[-1]
    else:
        at = {n: {k: derive_in_subprocess(k, n, 0, cap) for k in kinds} for n in ns}
        kr = derive_in_subprocess("kane", n_rhs, 1, cap)
    rows = []
    for n in ns:
        r = at[n]

        def cell(x):
            return f">{cap:.0f} (cap)" if x.get("capped") else x["total"]

        rows.append([n, r["pbanim"]["derive"], r["pbanim"]["compile"], cell(r["pbanim"]), cell(r["kane"]),
                     cell(r["lagrange"]), r["kane"]["total"] / r["pbanim"]["total"],
                     r["lagrange"]["total"] / r["pbanim"]["total"]])
    rep.tables.append(Table(f"n-link pendulum: derivation + compilation [s] ("
                            + ("one process for all (quick)" if quick else "fresh process each")
                            + f", cap {cap:.0f} s)",
                            ["n", "pbanim derive", "pbanim compile", "pbanim total", "KanesMethod",
                             "LagrangesMethod", "Kane/pbanim", "Lagrange/pbanim"], rows))
    n_goal = ns[-1] if quick else 10
    ratio_derive = at[n_goal]["kane"]["total"] / at[n_goal]["pbanim"]["total"]
    kane_capped = at[n_goal]["kane"].get("capped", False)
    # 2. rhs per call (ours here, the Kane baseline in its subprocess)
    from ..models.reduced import n_link_pendulum

    mod = n_link_pendulum(n_rhs)
    lag, red = mod.lagrangian(), mod.reduced()
    y = np.concatenate([0.5 + 0.1 * np.arange(n_rhs), 0.3 * np.ones(n_rhs)])
    t_lag = median_time(lambda: lag.rhs(0.0, y), repeats=5, min_time=0.05)
    t_red = median_time(lambda: red.rhs(0.0, y), repeats=5, min_time=0.05)
    t_kane = kr.get("rhs", np.nan)
    agree = (float(np.max(np.abs(np.asarray(kr["rhs_value"])[n_rhs:] - lag.rhs(0.0, y)[n_rhs:])))
             if "rhs_value" in kr else np.nan)
    rep.tables.append(Table(f"rhs evaluation at n = {n_rhs} [s per call]",
                            ["pbanim Lagrangian", "pbanim reduced", "lambdified KanesMethod", "Kane/Lagrangian",
                             "max |ü difference|"],
                            [[t_lag, t_red, t_kane, t_kane / t_lag, agree]]))
    # 3. cost at equal accuracy
    rows = []
    for n in ([2, 3] if quick else [2, 5, 10, 20, 50]):
        c = cost_at_accuracy(n)
        rows.append([n] + [c.get(f, (np.nan,) * 3)[0] for f in ("maximal", "reduced", "lagrangian")]
                    + [c.get(f, (np.nan,) * 3)[1] for f in ("maximal", "reduced", "lagrangian")]
                    + [c.get("lagrangian_setup", np.nan)])
    rep.tables.append(Table("n-link pendulum, RK4 at tip error ≤ 1e-8 m after 1 s: wall s per simulated s",
                            ["n", "maximal", "reduced", "lagrangian", "h max.", "h red.", "h lag.",
                             "lagrangian setup [s] (≈0: cached)"], rows))
    rep.goals.append(Goal("reduced-derive-vs-kane", ratio_derive, 10.0, ">=", "x",
                          f"n = {n_goal}, derivation + lambdify, "
                          + ("one process (quick)" if quick else "fresh processes")
                          + ("; Kane hit the cap, ratio is a lower bound" if kane_capped else "")))
    rep.goals.append(Goal("reduced-rhs-vs-kane", t_kane / t_lag, 4.0, ">=", "x",
                          f"n = {n_rhs}, Lagrangian rhs vs lambdified KanesMethod + solve"))
    return rep


if __name__ == "__main__":  # pragma: no cover
    from . import format_report

    print(format_report(run(quick="--quick" in sys.argv)))
