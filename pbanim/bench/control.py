"""Characters: what a control step costs, and how fast the walking biped runs (chapter 08, part 2).

Tables:

* one control step of the planar biped [µs]: SIMBICON's servos explicit and stable (the controller alone),
  the contact step that integrates them (closed-form planar dynamics + velocity-level contact), and the
  QP controller per installed qpsolvers backend (building and solving one QP);
* the walking biped (SIMBICON walk, 10 s; quick: 2 s) for each servo at the steps where it walks:
  wall time, real-time factor, mean speed;
* the walk's lean step (:mod:`pbanim.control.walk_lean`, the default) against its readable step
  (``simulate_walk(lean=False)``) in alternating rounds: the same walk bit for bit, the real-time factors
  and their ratio (median and quartiles);
* the 3-D SIMBICON walk (:mod:`pbanim.control.simbicon3d_walk`) with the readable contact step
  (``WorldStep(lean=False)``) and the lean one (:mod:`pbanim.control.biped3d_lean`, the default) in three
  alternating rounds: real-time factors and their ratio (median, min–max), the lean step's cost split per
  step (kinematics, H, dynamics, contact, controller, runner) and the interpreter's floor (the Python and
  numpy calls one step makes, each at its bare dispatch cost; h / floor is the real-time factor a step
  could reach if its calls did no arithmetic).

Goals (issue 16): the SIMBICON biped simulates at least 5× faster than real time (Table 1's walk with
stable PD servos at h = 2 ms, the chapter's step, where the walk's speed is within 0.5 % of its h = 1 ms
value: measured 1.023 against 1.022 m/s; the paper's explicit PD with the paper's gains needs h ≤ 0.8 ms
and is not robust there, see :mod:`pbanim.control.simbicon`); one QP control step of the planar biped
solves in ≤ 1 ms with proxsuite. Issue 31: the 3-D walk at h = 2 ms runs at ≥ 1× real time, its lean step
≥ 4× the readable one's real-time factor.

Measured for issue 31 on a shared 2-core machine, 3 runs of ``--quick`` each time (medians of the runs'
medians; min–max over all rounds). With the contact solved by the hand-off (below), at load 3–4: the lean walk
1.47× real time per CPU second (1.20–2.04; the runs' medians 1.56, 1.47, 1.26), 1.02× on the wall clock
(0.75–2.04), lean / readable 4.0× in CPU (2.7–5.1); the CPU split per step, 1.37 ms (0.98–1.67): contact 0.56
(Jacobians, rows, A = J(H + hK)⁻¹Jᵀ, the hand-off, the update), kinematics 0.22, dynamics 0.22, controller 0.22,
runner 0.08, H 0.05; the floor 209 numpy calls, 100 builtins, 123 Python calls a step, 0.25–0.29 ms (h / floor
6.9–8.0×). The same code at load 8–11 (an hour earlier): 0.97× per CPU second (0.79–1.21; the runs' medians 1.00,
0.97, 0.93), 2.00–2.15 ms a step, the numpy call's bare cost 3 µs instead of 1: the CPU second itself slows
under load (two hardware threads per core, shared caches). The goal (≥ 1× per CPU second) is met at low load and
missed by 3 % at load 8–11, within 10 % of the line: judged by the medians above, it holds only on a machine
that is not saturated. Lean / readable (goal ≥ 4×): 4.0× at load 3–4, 3.2–3.7× at load 8–11 (the readable
step calls the library's hand-off, whose rounds are array calls). The cuts of issue 31, first the same walk bit for bit: the controller's rotation vectors on
floats, the sweep called without its argument checks, H + hK in place (3.52 → 2.86 ms CPU a step); the sweep
one contact at a time, the controller's calls bound unchecked, its servo table kept, the contact frames and
points kept, the Jacobians without ``np.stack`` (3.05 → 2.16 ms: 27.5 %, 11–37 %, 11 alternating rounds in
separate processes, the runs then at 0.81× per CPU second, 0.67–0.88, load 14–17). Then the contact law: PGS
stopped at tol (~12 sweeps a step on ~17 rows, a third of them in the 3 % of steps where four corners of one
sole carry load and A is nearly singular) replaced by the box-friction hand-off
(:func:`pbanim.lcp.box.box_friction_handoff`, ORACLES I12; its active set on floats,
:mod:`pbanim.lcp.handoff_lean`, the library's answer bit for bit, I14): the LCP solved exactly, 98 % of the
steps certified by one solve from the last step's contact states, no sweep; 17 steps in 1000 fall back to PGS
chunks, 5 of them to the 300-sweep cap, uncertified, as PGS alone reached it in 8 (~7 % of the CPU). The walk
moved little (20 s at 2 ms: 65 strikes and 0.8869 m/s over the last 5 s both ways; at 3.5 ms 0.9042 m/s; the
± 20 / 30 N s push table at 2 ms unchanged). With the controller's centre-of-mass velocity as one product and
the runner's finiteness check without its argument checks: against the code before the hand-off, 9 alternating
rounds in separate processes (1 s walk, process CPU): 2.13 ms a step (1.85–2.66) → 1.42 ms (0.98–1.78), the
per-round cut 33 % (10–53 %). Then the step on floats where numpy's calls outweighed the arithmetic: the
kinematics link by link (R, o, Sᵂ, c as nine floats a frame; 117 → 54 µs a state), the controller's servos on
those floats, J = v − [P]× a as one batched product, R Ī Rᵀ and J_ω once per state, C(q, q̇) by the
Newton–Euler sums on floats (:mod:`pbanim.control.biped3d_bias`), q⁺, the contact points and the runner's
tests on floats — equal to the readable step to a few ulps (ORACLES F20), the 20 s walk at 2 ms unchanged (65
strikes, 0.8869 m/s over the last 5 s), the ± 20 / 30 N s push table at 2 ms unchanged (+30 R0 falls at 2.99 s).
Against the code before, 6 alternating rounds in separate processes (1 s walk, 3 runs a process, process CPU)
at load 3.0–3.4: 778 µs a step (726–957) → 582 µs (550–692), the per-round cut 25 % (15–38 %), 2.57× → 3.44×
real time per CPU second; ``--quick``, 3 alternating rounds at load 2.0–2.5 (the controller timed unchecked in
both, as the runner calls it): the CPU goal line 2.23× (1.62–2.60) → 3.12× (2.07–3.81), lean / readable 3.42×
→ 4.58×; an earlier round of these cuts (before C, the contact points on floats) at load 1.0–1.4, the old
harness: 2.22× (2.20–2.46) → 3.24× (3.16–3.57). The split (a round at load ~4): contact 300 µs (the
hand-off ~200 of it), dynamics 96, controller 77, kinematics 56, runner 35, H 30. What is left: the hand-off's
rounds (:mod:`pbanim.lcp.handoff_lean`, ~1/3 of the step), ~180 numpy calls a step, the hard steps' PGS chunks.
At load 8–11 the step was not measured again: the earlier 0.97× there, scaled by the cut (778/582), gives ~1.3×
— an estimate, not a measurement.

The step h of the 3-D walk (20 s from the 0.5 m/s start, WALK3D; the mean speed of the centre of mass over
the last 5 s): h = 1, 1.25, 1.5, 2, 3, 3.5 ms give 0.8763, 0.8789, 0.8818, 0.8869, 0.8971, 0.9045 m/s (all
walk, 65 strikes): + 0.30 %, + 0.63 %, + 1.2 %, + 2.4 %, + 3.2 % of the h = 1 ms speed. By the planar
chapter's rule (the largest step within 0.5 % of the h = 1 ms speed) the step would be 1.25 ms, where the
tests' claims hold too (15 N s forward, ± 20 N s lateral, the turn: measured at 1, 1.25 and 1.5 ms) and the
walk costs 1.6 times the CPU a simulated second takes at 2 ms (measured with PGS as the contact solve, at
0.81× then: ≈ 0.5× real time per CPU second at 1.25 ms; a single loaded 20 s run measured 0.66×). The goal line stays at h = 2 ms, as the issue sets it.
"""

from __future__ import annotations

import numpy as np

from . import Goal, Report, Table, median_time
from ..articulated.planar import PlanarKernel
from ..articulated.planar_step import PlanarContactStep
from ..control import WALK, Simbicon, simulate_walk
from ..control.biped import biped_contact_points, planar_biped

__all__ = ["run"]


def _walking_state(h: float = 2e-3):
    """A state in the middle of a walk (the controller's machine in step with it)."""
    r = simulate_walk(WALK, 2.0, h, servo="stable", record_every=1)
    return r.q[-1], r.qd[-1]


_WALK3D_RT = [np.nan, np.nan, np.nan, np.nan]     # wall and CPU real-time factors (lean), their lean/readable ratios
_SPLIT = ("kinematics", "H", "dynamics", "contact", "controller")


def _count_calls(fn) -> tuple[int, int, int]:
    """(Python calls, calls of Python's builtins and of :mod:`math`, other C calls: numpy's) that one ``fn()``
    makes, counted by the interpreter's profile hook (operators on arrays, a + b, ufuncs called by name,
    np.abs(a), and extension functions outside CPython's C-function type, e.g. LAPACK's wrappers and ProxQP,
    are not seen: the count is a lower bound of the numpy work; math.cos on a float costs a builtin's call, not
    a numpy call's)."""
    import sys

    n = {"call": 0, "builtin": 0, "c_call": 0}

    def hook(frame, event, arg):
        if event == "c_call":
            n["builtin" if getattr(arg, "__module__", None) in ("builtins", "math") else "c_call"] += 1
        elif event == "call":
            n["call"] += 1

    sys.setprofile(hook)
    try:
        fn()
    finally:
        sys.setprofile(None)
    return n["call"], n["builtin"], n["c_call"]


def _calls_per_step(W, t_end: float = 0.1, h: float = 2e-3) -> tuple[float, float, float]:
    """(Python calls, builtins, numpy calls) per step of the lean walk (:func:`_count_calls`)."""
    steps = round(t_end / h)
    return tuple(c / steps for c in _count_calls(lambda: W.simulate_walk3d(t_end=t_end, h=h, record_every=1000)))


def _bare_calls() -> dict:
    """name → 1000 bare calls of one kind: a Python function, a builtin (min of two floats), a numpy call on
    3-vectors (the interpreter's per-call cost, timed by the caller's clock)."""
    a, b = np.ones(3), np.ones(3)

    def f():
        return None

    return {"Python call": lambda: [f() for _ in range(1000)], "builtin": lambda: [min(0.5, 1.5) for _ in range(1000)],
            "numpy call": lambda: [np.add(a, b) for _ in range(1000)]}


def _call_costs(repeats: int) -> tuple[float, float, float]:
    """(one Python function call, one builtin (min of two floats), one numpy call on 3-vectors) [s]: the
    interpreter's per-call cost."""
    return tuple(median_time(fn, repeats, min_time=0.02) / 1000 for fn in _bare_calls().values())


def _walk3d_table(quick: bool, repeats: int) -> list:
    """The 3-D walk (1 s; full: 2 s) through the runner with the readable step (``lean=False``) and the lean
    one (the default), in alternating rounds: real-time factors (wall and process CPU), their ratios, the lean
    step's split per step in CPU seconds (kinematics, H, dynamics = C(q, q̇) and the Cholesky solve, contact =
    Jacobians, rows, PGS and the update, controller = :meth:`Simbicon3D.torques`, runner = the rest of the
    round's CPU time) and the interpreter's floor (the Python and numpy calls one step makes, each at its bare
    dispatch cost)."""
    import functools
    from time import process_time

    from ..control import simbicon3d_walk as W
    from ..control.biped3d_step import WorldStep
    from ..control.simbicon3d import Simbicon3D

    h, t_end = 2e-3, (1.0 if quick else 2.0)
    clock = dict.fromkeys(_SPLIT + ("steps",), 0.0)

    from ..contracts import unchecked

    raw_torques = unchecked(Simbicon3D.torques)   # what the walk calls: the runner binds torques unchecked

    class Timed(Simbicon3D):                      # the controller's share of the step, timed where it is called
        def torques(self, *args, **kwargs):
            t0 = process_time()
            out = raw_torques(self, *args, **kwargs)
            clock["controller"] += process_time() - t0
            return out

    def lean_step(*args, **kwargs):
        ws = WorldStep(*args, **kwargs)
        ws.clock = clock
        return ws

    rt, split, outcome = {False: [], True: []}, [], set()
    rt_cpu = {False: [], True: []}
    saved = W.WorldStep, W.Simbicon3D
    try:
        W.Simbicon3D = Timed
        for _ in range(3):                        # alternating rounds: readable, lean
            for lean in (False, True):
                W.WorldStep = lean_step if lean else functools.partial(WorldStep, lean=False)
                for key in clock:
                    clock[key] = 0.0
                c0 = process_time()
                res = W.simulate_walk3d(t_end=t_end, h=h, record_every=100)
                cpu = process_time() - c0
                rt_cpu[lean].append(t_end / cpu)
                rt[lean].append(res.realtime_factor)
                outcome.add("fell" if res.fell else "walked")
                if lean:
                    per = {k: clock[k] / clock["steps"] for k in _SPLIT}
                    per["runner"] = cpu / clock["steps"] - sum(per.values())
                    split.append(per)
        W.WorldStep = lean_step
        calls_py, calls_bi, calls_c = _calls_per_step(W)
    finally:
        W.WorldStep, W.Simbicon3D = saved
    t_py, t_bi, t_np = _call_costs(repeats)
    floor = calls_py * t_py + calls_bi * t_bi + calls_c * t_np
    ratio = np.array(rt[True]) / np.array(rt[False])
    ratio_cpu = np.array(rt_cpu[True]) / np.array(rt_cpu[False])
    _WALK3D_RT[:] = [float(np.median(rt[True])), float(np.median(ratio)), float(np.median(rt_cpu[True])),
                     float(np.median(ratio_cpu))]
    spread = lambda x: f"{np.min(x):.3g}–{np.max(x):.3g}"  # noqa: E731
    t1 = Table(f"3-D SIMBICON walk through the runner, h = {h * 1e3:g} ms, {t_end:g} s simulated, 3 alternating "
               f"rounds (median, min–max): the readable step (lean=False) against the lean one (the default)",
               ["step", "real-time factor (wall)", "spread", "lean / readable", "spread",
                "real-time factor (CPU)", "spread", "lean / readable (CPU)", "spread", "outcome"],
               [["readable", float(np.median(rt[False])), spread(rt[False]), "", "", float(np.median(rt_cpu[False])),
                 spread(rt_cpu[False]), "", "", "/".join(sorted(outcome))],
                ["lean", float(np.median(rt[True])), spread(rt[True]), float(np.median(ratio)), spread(ratio),
                 float(np.median(rt_cpu[True])), spread(rt_cpu[True]), float(np.median(ratio_cpu)), spread(ratio_cpu),
                 "/".join(sorted(outcome))]])
    parts = list(_SPLIT) + ["runner"]
    rows = [[p, float(np.median([s[p] for s in split])) * 1e6, spread([s[p] * 1e6 for s in split])] for p in parts]
    total = [sum(s[p] for p in parts) for s in split]
    rows.append(["whole step", float(np.median(total)) * 1e6, spread(np.array(total) * 1e6)])
    rows.append([f"floor: {calls_py:.0f} Python calls x {t_py * 1e9:.0f} ns + {calls_bi:.0f} builtins x "
                 f"{t_bi * 1e9:.0f} ns + {calls_c:.0f} numpy calls x {t_np * 1e9:.0f} ns", floor * 1e6,
                 f"h / floor = {h / floor:.2f}x real time"])
    t2 = Table("the lean walk step's split [CPU µs per step] (3 rounds: median, min–max) and the interpreter's "
               "floor (the calls one step makes, each at its bare cost: no arithmetic; timed on the wall clock)",
               ["part", "µs", "spread"], rows)
    return [t1, t2]


def run(quick: bool = False) -> Report:
    rep = Report("control")
    repeats = 3 if quick else 7
    tree = planar_biped()
    kernel = PlanarKernel(tree)
    step = PlanarContactStep(kernel, biped_contact_points(tree))
    q, qd = _walking_state()
    rows = []
    for servo in ("explicit", "stable"):
        ctrl = Simbicon(kernel, WALK, servo=servo)
        kin = kernel.kinematics(q)
        kernel.com_jacobians(kin)
        t_ctrl = median_time(lambda: ctrl.torques(0.0, q, qd, (), kin, 1e-3), repeats, min_time=0.05)
        tau, k = ctrl.torques(0.0, q, qd, (), kin, 1e-3)
        t_step = median_time(lambda: step.step(q, qd, 1e-3, tau, k if np.any(k) else None), repeats, min_time=0.05)
        rows.append([f"SIMBICON, {servo} PD", t_ctrl * 1e6, t_step * 1e6, (t_ctrl + t_step) * 1e6])
    rep.tables.append(Table("one control step of the planar biped [µs] (SIMBICON's servos)",
                            ["controller", "controller", "contact step (h = 1 ms)", "total"], rows))
    qp_time, qp_skip = np.nan, ""
    qp_note = "one QP control step of the planar biped (build + solve)"
    try:
        import proxsuite  # noqa: F401
    except ImportError:
        qp_skip = "proxsuite is not installed"
    from ._qp import QP_STEP_HEADER, qp_step_goal, qp_step_rows

    rep.tables.append(Table("one QP control step of the planar biped (build + solve), per backend", QP_STEP_HEADER,
                            qp_step_rows(quick)))
    if not qp_skip:
        qp_table, qp_time, qp_note = qp_step_goal(quick)
        rep.tables.append(qp_table)
    t_end = 2.0 if quick else 10.0
    walk_rows, rt = [], {}
    for servo, h in (("explicit", 5e-4), ("explicit", 2e-3), ("stable", 1e-3), ("stable", 2e-3), ("stable", 8e-3)):
        res = simulate_walk(WALK, t_end, h, servo=servo, record_every=100)
        rt[(servo, h)] = res.realtime_factor
        walk_rows.append([f"{servo} PD", h * 1e3, res.wall_time, res.realtime_factor,
                          res.speed(min(5.0, t_end / 2)), "fell" if res.fell else "walked"])
    rep.tables.append(Table(f"SIMBICON walk, {t_end:g} s simulated", ["servos", "h [ms]", "wall [s]",
                                                                      "real-time factor", "speed [m/s]", "outcome"],
                            walk_rows))
    lean_rows, ratios = [], []
    for servo, h in (("explicit", 1e-3), ("stable", 2e-3)):
        rts = {True: [], False: []}
        for _ in range(2 if quick else 5):
            for lean in (False, True):
                rts[lean].append(simulate_walk(WALK, 1.0 if quick else 2.0, h, servo=servo, record_every=100,
                                               lean=lean).realtime_factor)
        r = np.array(rts[True]) / np.array(rts[False])
        ratios.append(float(np.median(r)))
        lean_rows.append([f"{servo} PD", h * 1e3, float(np.median(rts[False])), float(np.median(rts[True])),
                          float(np.median(r)), f"{np.percentile(r, 25):.2f}–{np.percentile(r, 75):.2f}"])
    rep.tables.append(Table("the walk's lean step against its readable step (alternating rounds; the same walk bit "
                            "for bit)", ["servos", "h [ms]", "real-time factor, readable", "real-time factor, lean",
                                         "lean / readable", "quartiles"], lean_rows))
    rep.notes.append("Table 1's gains (300/30 on every joint, the 1 kg feet included) ask explicit PD for h ≤ 0.8 ms "
                     "(falls at 2 ms after 2.3 s); stable PD walks at every step measured from 0.5 to 25 ms")
    rep.goals.append(Goal("control-simbicon-realtime", rt[("stable", 2e-3)], 5.0, ">=", "x",
                          "simulated seconds per wall-clock second, Table 1's walk, stable PD servos at h = 2 ms"))
    rep.tables.extend(_walk3d_table(quick, repeats))
    rep.goals.append(Goal("control-simbicon3d-realtime", _WALK3D_RT[0], 1.0, ">=", "x",
                          "simulated seconds per wall-clock second, the 3-D SIMBICON walk at h = 2 ms (lean step; "
                          "median of 3 rounds)"))
    rep.goals.append(Goal("control-simbicon3d-realtime-cpu", _WALK3D_RT[2], 1.0, ">=", "x",
                          "simulated seconds per CPU second of the process (the wall factor on an unloaded core), "
                          "the 3-D SIMBICON walk at h = 2 ms (lean step; median of 3 rounds)"))
    rep.goals.append(Goal("control-simbicon3d-lean-speedup", _WALK3D_RT[1], 4.0, ">=", "x",
                          "the 3-D walk's real-time factor, lean step over readable step (alternating rounds)"))
    rep.goals.append(Goal("control-qp-step-proxsuite", qp_time * 1e3 if np.isfinite(qp_time) else np.nan, 1.0, "<=",
                          " ms", qp_note, skipped=qp_skip))
    return rep
