"""``pbanim bench contracts``: what the argument contracts cost (issue 27, point 1).

1. **Per call.** A call from user code pays the boundary check once: the time of the checked call minus
   the unchecked function (``fn.__wrapped__``), in µs, for public callables with numbers, arrays, references
   to another argument and registry names. The same signature checked by ``jaxtyping`` with ``beartype`` (the
   ecosystem's runtime pair for array shapes; ``pip install -e ".[typecheck]"``) is timed beside it when
   installed: it checks dtype and shape only (no finiteness, sign, range or conversion from lists) and
   raises its own ``TypeCheckError``. Goals: a three-argument check (a number, an (n, 3) array, an (n,)
   array of positive entries) ≤ 10 µs, and ≤ 1.25× jaxtyping + beartype on the same signature, timed in
   alternating rounds — pbanim's check does strictly more (every entry finite, the entries of m > 0, lists
   converted, the argument named in a PbanimError); a comparison at equal work would have to strip those.
2. **Per step.** Calls from inside the package skip the checks: a 1000-step scene run from user code
   performs one boundary check (``Scene.simulate``), whatever its length. Counted, and timed per step with
   checks at the boundary only (the default) against checks forced on every call inside the package
   (:class:`pbanim.contracts.boundary_checks`, what a check in the loop would cost). Goal: checks per step
   = 0.

The user's calls are made through a function compiled outside the package (its code object carries a
file name outside ``pbanim/``), exactly as a student's script calls pbanim.
"""

from __future__ import annotations

import time
import types

import numpy as np

from . import Goal, Report, Table, median_time

__all__ = ["run", "user_call", "per_call_rows", "per_step_rows"]


def _call(f, args, kwargs):
    return f(*args, **kwargs)


#: ``user_call(f, args, kwargs)``: f(*args, **kwargs) from a caller outside the package (checked)
user_call = types.FunctionType(_call.__code__.replace(co_filename="<user code>"), {}, "user_call")


def _signature_cases():
    """(name, checked callable, raw callable, args) for the per-call table."""
    from ..constraints import baumgarte_gains
    from ..contracts import Array, Real, contract
    from ..geometry import cross
    from ..particles import AnchorSprings, Gravity, ParticleSystem
    from ..scene import Scene

    @contract(k=Real(ge=0), x=Array(("n", 3)), m=Array(("n",), gt=0))
    def spring_energy(k, x, m):
        return k

    rng = np.random.default_rng(0)
    x, m = rng.normal(size=(10, 3)), rng.uniform(1, 2, 10)
    ps = ParticleSystem(rng.normal(size=(10, 3)), masses=m)
    scene = Scene(ps, [Gravity(), AnchorSprings(list(range(10)), np.zeros((10, 3)), 5.0)])
    y = ps.state()
    a, b = np.array([1.0, 2.0, 3.0]), np.array([0.5, -1.0, 2.0])
    return [
        ("2 numbers: baumgarte_gains(ω, ζ)", baumgarte_gains, baumgarte_gains.__wrapped__, (10.0, 1.0)),
        ("2 arrays (3,): geometry.cross(a, b)", cross, cross.__wrapped__, (a, b)),
        ("number, (n, 3), (n,) > 0 (a spring energy)", spring_energy, spring_energy.__wrapped__, (2.0, x, m)),
        ("number, state of length self.n_state: Scene.rhs", scene.rhs, scene.rhs.__wrapped__.__get__(scene),
         (0.0, y)),
    ], (2.0, x, m)


def _jaxtyping_case():
    """The spring-energy signature under jaxtyping + beartype, or None when they are not installed."""
    try:
        from beartype import beartype
        from jaxtyping import Float64, jaxtyped
    except ImportError:
        return None

    @jaxtyped(typechecker=beartype)
    def spring_energy(k: float, x: Float64[np.ndarray, "n 3"], m: Float64[np.ndarray, "n"]) -> float:  # noqa: F821
        return k

    return spring_energy


def per_call_rows(quick: bool = False) -> tuple[list, dict]:
    """Rows (case, unchecked µs, checked µs, check µs) and the spring-energy figures by library."""
    reps, loop = (3, 0.02) if quick else (7, 0.1)
    cases, spring_args = _signature_cases()
    rows, spring = [], {}
    for name, checked, raw, args in cases:
        t_raw = median_time(lambda: user_call(raw, args, {}), reps, loop) * 1e6
        t_chk = median_time(lambda: user_call(checked, args, {}), reps, loop) * 1e6
        rows.append([name, t_raw, t_chk, t_chk - t_raw])
        if name.startswith("number, (n, 3)"):
            spring["pbanim"] = t_chk - t_raw
            spring["raw"] = t_raw
    jt = _jaxtyping_case()
    if jt is not None:
        # the two checks of one signature timed in alternating rounds (a shared machine's load drifts between
        # two measurements taken one after the other): the median over rounds of each, and of their ratio
        raw, chk = cases[2][2], cases[2][1]
        t_raw, t_pb, t_jt = [], [], []
        for _ in range(7 if quick else 31):
            for fn, out in ((raw, t_raw), (chk, t_pb), (jt, t_jt)):
                n, start = 500, time.perf_counter()
                for _ in range(n):
                    user_call(fn, spring_args, {})
                out.append((time.perf_counter() - start) / n * 1e6)
        pb = np.array(t_pb) - np.array(t_raw)
        jx = np.array(t_jt) - np.array(t_raw)
        spring.update(pbanim=float(np.median(pb)), jaxtyping=float(np.median(jx)),
                      ratio=float(np.median(pb / jx)), spread=(float(np.percentile(pb / jx, 25)),
                                                               float(np.percentile(pb / jx, 75))))
        rows.append(["the same, alternating rounds: pbanim", float(np.median(t_raw)), float(np.median(t_pb)),
                     spring["pbanim"]])
        rows.append(["the same, alternating rounds: jaxtyping + beartype (dtype and shape only)",
                     float(np.median(t_raw)), float(np.median(t_jt)), spring["jaxtyping"]])
    return rows, spring


def per_step_rows(quick: bool = False) -> tuple[list, float]:
    """Rows (run, steps, checks performed, checks per step, µs per step) and the checks per step."""
    from ..contracts import boundary_checks
    from ..contracts.declare import Contract
    from ..particles import DampedSprings, Gravity, ParticleSystem
    from ..scene import Scene

    n_steps = 200 if quick else 1000
    rng = np.random.default_rng(1)
    ps = ParticleSystem(rng.normal(size=(8, 3)), masses=rng.uniform(1, 2, 8))
    scene = Scene(ps, [Gravity(), DampedSprings([[i, i + 1] for i in range(7)], 20.0, 0.1)])
    h = 1e-3

    def run_scene():
        return user_call(scene.simulate, (n_steps * h, h, "rk4"), {"diagnostics": False})

    count = [0]
    original = Contract.check

    def counting(self, args, kwargs):
        count[0] += 1
        return original(self, args, kwargs)

    rows, per_step = [], {}
    for label, forced in (("checks at the boundary (default)", False), ("checks forced on every inner call", True)):
        Contract.check = counting
        try:
            count[0] = 0
            if forced:
                with boundary_checks():
                    run_scene()
            else:
                run_scene()
            n_checks = count[0]
        finally:
            Contract.check = original
        if forced:
            with boundary_checks():
                t = median_time(run_scene, 3 if quick else 5) / n_steps * 1e6
        else:
            t = median_time(run_scene, 3 if quick else 5) / n_steps * 1e6
        per_step[label] = (n_checks - 1) / n_steps
        rows.append([f"8 particles, springs, rk4: {label}", n_steps, n_checks, (n_checks - 1) / n_steps, t])
    return rows, per_step["checks at the boundary (default)"]


def run(quick: bool = False) -> Report:
    rep = Report("contracts")
    rows, spring = per_call_rows(quick)
    rep.tables.append(Table("Boundary check per call from user code (µs; median of repeats)",
                            ["call", "unchecked", "checked", "check"], rows))
    steps, per_step = per_step_rows(quick)
    rep.tables.append(Table("Checks inside a step loop (a run called once from user code)",
                            ["run", "steps", "checks", "checks/step (beyond the call)", "µs/step"], steps))
    rep.goals.append(Goal("contracts-check-3-arguments", spring["pbanim"], 10.0, "<=", " µs",
                          "a number, an (n, 3) array, an (n,) array > 0"))
    if "jaxtyping" in spring:
        rep.goals.append(Goal("contracts-check-vs-jaxtyping-beartype", spring["ratio"], 1.25, "<=", "x",
                              f"median of per-round ratios, quartiles {spring['spread'][0]:.2f}–{spring['spread'][1]:.2f}; "
                              "jaxtyping checks dtype and shape only"))
    else:
        rep.goals.append(Goal("contracts-check-vs-jaxtyping-beartype", float("nan"), 1.25, "<=", "x",
                              skipped='jaxtyping and beartype not installed: pip install -e ".[typecheck]"'))
    rep.goals.append(Goal("contracts-checks-per-step", per_step, 0.0, "<=", "", "Scene.simulate called once"))
    rep.notes.append("The checked call converts what it checks (lists to float arrays, numpy scalars to floats) "
                     "and refuses NaN, ±inf, signs, ranges, shapes, batches and unknown names by name.")
    return rep
