"""Articulated bodies: what each formulation costs per step (chapter 08).

Tables:

* cost of one forward-dynamics evaluation q̈(q, q̇, τ) vs the number of links n of a chain, for the
  readable ABA (O(n)), CRBA + bias forces + Cholesky solve (O(n²) to build, O(n³) to solve), and the
  batched ABA per state at K = 1024 states (the Python overhead paid once per batch);
* the same evaluation by Pinocchio (``pip install -e ".[pinocchio]"``) called once per state from Python,
  in the same run, when it is installed.

Goals (issue 15): batched ABA over K = 1024 states of a 10-link chain costs ≤ 1× per state what
Pinocchio's ABA costs per call; the single-state ABA ≤ 30× Pinocchio. Issue 31: the derivatives of ABA
(∂q̈/∂q, ∂q̈/∂q̇, H⁻¹, :func:`~pbanim.articulated.aba_derivatives_batch`) per state at K = 1024 states of the
10-link chain cost ≤ 2× Pinocchio's ``computeABADerivatives`` per call (its Python binding, one call per
state; the table prints what a call of the binding that does almost nothing costs, the floor of any per-call
figure, and the batched ABA alone for scale: the lean path below does not run it). That goal line is printed by the full
run only (the quick smoke run prints the table at small K), with the spread over its rounds and the same ratio
in process time (the machine may be shared). Trees without a floating joint, the benchmark's chain among them,
take the lean path of :mod:`pbanim.articulated.derivatives_batch` (batch axis last, the ABA kernel's buffers,
only the pairs of joints on a common path, H⁻¹ by Cholesky on the stacks). The table prints the fixed cost
of a batch (its Python and numpy calls: the batch at K = 8, divided by K), the floor of the batched figure;
at K = 1024 it is about a tenth of it, so it does not bound the goal.
All need Pinocchio; without it the goal lines say "not measured". The goals are measured on the world-frame
kernels of :mod:`pbanim.articulated.fast` (``aba_fast`` for one state on Python floats, ``aba_batch`` for K states
on arrays; for the chain its sweeps run on composite rigid inertias and rank-one terms,
:mod:`pbanim.articulated.fastcomposite`, with no 6 × 6 articulated inertia); the readable ABA is timed beside them.
The single-state goal is met with a wide margin; the batched one sits at its line (1.0–1.1× in full runs on a
2-core machine at loads 3–7, 1.3–1.6× before the composite sweeps).
The batched ABA's goal line also prints the spread of its rounds, the same ratio in process time and the batch's
fixed cost (its Python and numpy calls: the batch at K = 8, divided by K), the part of the per-state figure that a
larger K would not lower; the rest is the sweeps' arithmetic on arrays of K values, bound by memory traffic.
Equal work: the same tree, the same K states, and the
same q̈ (the agreement column). The maximal columns evaluate the same chain as rigid rods held by hinge
joints (multipliers by the dense J W Jᵀ solve, and by Baraff's leaves-first sparse elimination).
"""

from __future__ import annotations

import time

import numpy as np

from . import Goal, Report, Table, median_time
from ..articulated import aba, aba_batch, aba_derivatives, aba_derivatives_batch, aba_fast, bias_forces, crba
from ..contracts import unchecked
from ..models.articulated import pendulum_chain, rod_chain, to_urdf

__all__ = ["run", "chain", "pinocchio_aba", "derivative_table"]


def chain(n: int) -> "object":
    """An n-link chain of unit point masses (the benchmark's tree)."""
    return pendulum_chain(n, lengths=1.0, masses=1.0)


def _pinocchio(tree):
    """(pinocchio, model, data) of ``tree`` (through its URDF, with its gravity), or None without Pinocchio."""
    try:
        import pinocchio as pin
    except ImportError:
        return None
    model = pin.buildModelFromXML(to_urdf(tree, "bench"))
    model.gravity.linear = np.asarray(tree.gravity, dtype=float)
    return pin, model, model.createData()


def pinocchio_aba(tree):
    """A ``f(q, qd, tau)`` calling Pinocchio's ABA on ``tree``, or None when Pinocchio is not installed."""
    peer = _pinocchio(tree)
    if peer is None:
        return None
    pin, model, data = peer
    return lambda q, qd, tau: pin.aba(model, data, q, qd, tau)


def _crba_solve(tree, q, qd, tau):
    from scipy.linalg import cho_factor, cho_solve

    return cho_solve(cho_factor(crba(tree, q)), tau - bias_forces(tree, q, qd))


def _interleaved(fns: dict, repeats: int, K: int, cpu: dict | None = None) -> dict:
    """Per-state times of each ``fns[name] = (fn, states_per_call)``, measured in turn within each repeat,
    so every competitor sees the same machine load; returns the per-repeat lists (``cpu``, when given, receives
    the same lists in process time)."""
    out = {name: [] for name in fns}
    for _ in range(repeats):
        for name, (fn, per) in fns.items():
            calls = max(1, K // per // 16) if per == 1 else 1          # single-state calls: a few hundred
            start, cpu0 = time.perf_counter(), time.process_time()
            for _ in range(calls):
                fn()
            out[name].append((time.perf_counter() - start) / (calls * per))
            if cpu is not None:
                cpu.setdefault(name, []).append((time.process_time() - cpu0) / (calls * per))
    return out


def _pinocchio_derivatives(tree):
    """(``f(q, qd, tau)`` calling Pinocchio's computeABADerivatives, the floor call, the three results) or None."""
    peer = _pinocchio(tree)
    if peer is None:
        return None
    pin, model, data = peer
    return (lambda q, qd, tau: pin.computeABADerivatives(model, data, q, qd, tau), lambda: pin.neutral(model),
            lambda: (data.ddq_dq.copy(), data.ddq_dv.copy(), np.triu(data.Minv) + np.triu(data.Minv, 1).T))


def derivative_table(ns, K: int, repeats: int, cpu_ratios: dict | None = None) -> tuple[Table, dict]:
    """∂q̈/∂(q, q̇, τ) of an n-link chain per state: batched over K states, readable one state, and Pinocchio's
    computeABADerivatives per call (when installed), timed in turn; returns the table and the per-repeat
    ratio lists {n: (batched / Pinocchio)} (wall clock; ``cpu_ratios``, when given, receives the same in process
    time). The batched ABA alone (q̈ only) is timed beside them for scale."""
    rng = np.random.default_rng(1)
    batch, one = unchecked(aba_derivatives_batch), unchecked(aba_derivatives)
    rows, ratios = [], {}
    for n in ns:
        tree = chain(n)
        q, qd, tau = (rng.normal(size=(K, n)) for _ in range(3))
        fns = {"batch": (lambda: batch(tree, q, qd, tau), K), "one": (lambda: one(tree, q[0], qd[0], tau[0]), 1),
               "aba": (lambda: aba_batch(tree, q, qd, tau), K)}
        pin = _pinocchio_derivatives(tree)
        err = float("nan")
        if pin is not None:
            call, floor, results = pin

            def calls():
                for k in range(K):
                    call(q[k], qd[k], tau[k])
            fns["pin"], fns["floor"] = (calls, K), (floor, 1)
            ours = batch(tree, q[:8], qd[:8], tau[:8])
            err = 0.0
            for k in range(8):
                call(q[k], qd[k], tau[k])
                for a, b in zip(ours, results()):
                    err = max(err, float(np.abs(a[k] - b).max() / (1.0 + np.abs(b).max())))
        # the per-batch fixed cost (Python and numpy calls), per state at K: the batch at K = 8, divided by K; timed
        # apart (the kernels keep buffers per K), then one call at K to restore them
        floor_batch = median_time(lambda: batch(tree, q[:8], qd[:8], tau[:8]), repeats) / K
        batch(tree, q, qd, tau)
        cpu: dict = {}
        times = _interleaved(fns, 2 * repeats + 1, K, cpu)
        med = {k: float(np.median(t)) for k, t in times.items()}
        if "pin" in times:
            ratios[n] = list(np.divide(times["batch"], times["pin"]))
            if cpu_ratios is not None:
                cpu_ratios[n] = list(np.divide(cpu["batch"], np.maximum(cpu["pin"], 1e-12)))
        rows.append([n, med["one"] * 1e6, med["batch"] * 1e6, med["aba"] * 1e6, floor_batch * 1e6,
                     med.get("pin", np.nan) * 1e6,
                     med.get("floor", np.nan) * 1e6, float(np.median(ratios[n])) if n in ratios else np.nan, err])
    return Table(f"derivatives of ABA (∂q̈/∂q, ∂q̈/∂q̇, H⁻¹) of an n-link chain [µs per state] (batched: K = {K})",
                 ["n", "readable (one state)", "batched", "batched ABA alone (q̈ only, for scale)",
                  "of which fixed per-batch cost (the batch at K = 8, / K)", "Pinocchio per call",
                  "binding floor (a call doing ~nothing)",
                  "batched / Pinocchio", "max rel. diff vs Pinocchio"], rows), ratios


def run(quick: bool = False) -> Report:
    """Run the articulated benchmarks (``quick``: small sizes, the test suite's smoke run)."""
    rep = Report("articulated")
    ns = [2, 5, 10] if quick else [2, 5, 10, 20, 50]
    K = 64 if quick else 1024
    repeats = 3 if quick else 7
    rng = np.random.default_rng(0)
    rows, ratios, batch_spread = [], {}, ""
    for n in ns:
        tree = chain(n)
        q, qd, tau = (rng.normal(size=(K, n)) for _ in range(3))
        t_aba = median_time(lambda: aba(tree, q[0], qd[0], tau[0]), repeats)
        t_crba = median_time(lambda: _crba_solve(tree, q[0], qd[0], tau[0]), repeats)
        pin_aba = pinocchio_aba(tree)
        fns = {"batch": (lambda: aba_batch(tree, q, qd, tau), K), "fast": (lambda: aba_fast(tree, q[0], qd[0], tau[0]), 1)}
        err = float("nan")
        if pin_aba is not None:
            def calls():
                for k in range(K):
                    pin_aba(q[k], qd[k], tau[k])
            fns["pin"] = (calls, K)
            ref = np.array([pin_aba(q[k], qd[k], tau[k]) for k in range(K)])
            err = max(float(np.abs(aba_batch(tree, q, qd, tau) - ref).max()),
                      max(float(np.abs(aba_fast(tree, q[k], qd[k], tau[k]) - ref[k]).max()) for k in range(8)),
                      max(float(np.abs(aba(tree, q[k], qd[k], tau[k]) - ref[k]).max()) for k in range(3)))
        # the per-batch fixed cost (Python and numpy calls) per state at K: the batch at K = 8, / K; timed apart (the
        # kernels keep buffers per K), then one call at K to restore them
        fixed = median_time(lambda: aba_batch(tree, q[:8], qd[:8], tau[:8]), repeats) / K if n == 10 else np.nan
        aba_batch(tree, q, qd, tau)
        cpu: dict = {}
        times = _interleaved(fns, 2 * repeats + 1, K, cpu)
        t_batch, t_fast = float(np.median(times["batch"])), float(np.median(times["fast"]))
        t_pin = float(np.median(times["pin"])) if "pin" in times else float("nan")
        if n == 10 and "pin" in times:
            ratios = {k: float(np.median(np.divide(times[k], times["pin"]))) for k in ("batch", "fast")}
            rounds = np.divide(times["batch"], times["pin"])
            in_cpu = np.divide(cpu["batch"], np.maximum(cpu["pin"], 1e-12))
            batch_spread = (f"; spread over {len(rounds)} rounds {rounds.min():.2f}..{rounds.max():.2f}; "
                            f"in process time {np.median(in_cpu):.2f} ({in_cpu.min():.2f}..{in_cpu.max():.2f}); "
                            f"{t_batch * 1e6:.2f} µs per state against {t_pin * 1e6:.2f}, of which the fixed per-batch "
                            f"cost (the batch at K = 8, / K) {fixed * 1e6:.2f}")
        scene, rb, _ = rod_chain(n)
        y = rb.state()
        t_max = median_time(lambda: scene.rhs(0.0, y), repeats)
        scene.effects[-1].solver = "linear"
        t_lin = median_time(lambda: scene.rhs(0.0, y), repeats)
        rows.append([n, t_aba * 1e6, t_crba * 1e6, t_batch * 1e6, t_max * 1e6, t_lin * 1e6, t_pin * 1e6, err,
                     t_fast * 1e6])
    rep.tables.append(Table(f"one forward-dynamics evaluation of an n-link chain [µs] (batched: per state, K = {K})",
                            ["n", "ABA (readable)", "CRBA + solve", "batched ABA", "maximal (dense)",
                             "maximal (linear)", "Pinocchio ABA", "max |Δq̈| vs Pinocchio", "fast ABA (one state)"],
                            rows))
    missing = "" if ratios else "pinocchio not installed"
    rep.goals.append(Goal("articulated-batched-aba-vs-pinocchio", ratios.get("batch", np.nan), 1.0, "<=", "x",
                          f"batched ABA per state (K = {K}) / Pinocchio ABA per call, 10 links{batch_spread}",
                          skipped=missing))
    rep.goals.append(Goal("articulated-aba-vs-pinocchio", ratios.get("fast", np.nan), 30.0, "<=", "x",
                          "single-state ABA (aba_fast) / Pinocchio ABA per call, 10 links", skipped=missing))
    cpu_ratios: dict = {}
    dtable, dratios = derivative_table([3, 10] if quick else [5, 10, 20], K, repeats, cpu_ratios)
    rep.tables.append(dtable)
    if not quick:
        spread = (f"; spread over {len(dratios[10])} rounds {min(dratios[10]):.2f}..{max(dratios[10]):.2f}; "
                  f"in process time {np.median(cpu_ratios[10]):.2f} ({min(cpu_ratios[10]):.2f}.."
                  f"{max(cpu_ratios[10]):.2f})" if 10 in dratios else "")
        rep.goals.append(Goal("articulated-aba-derivatives-vs-pinocchio",
                              float(np.median(dratios[10])) if 10 in dratios else np.nan, 2.0, "<=", "x",
                              f"batched ∂ABA per state (K = {K}) / Pinocchio computeABADerivatives per call, 10 links"
                              f"{spread}", skipped=missing))
    slope = np.polyfit(np.log([r[0] for r in rows]), np.log([r[1] for r in rows]), 1)[0]
    slope_fast = np.polyfit(np.log([r[0] for r in rows]), np.log([r[8] for r in rows]), 1)[0]
    rep.notes.append(f"readable ABA cost grows as n^{slope:.2f}, the single-state aba_fast as n^{slope_fast:.2f} over "
                     f"n = {ns[0]}..{ns[-1]} (O(n) with a per-link Python constant)")
    rep.notes.append("goal ratios are medians over repeats of (time / Pinocchio's time in the same repeat): the "
                     "competitors are timed in turn so that each sees the same machine load; every q̈ is checked "
                     "against Pinocchio's (last column but one)")
    return rep
