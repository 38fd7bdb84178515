"""Articulated bodies: what each formulation costs per step (chapter 08).

Tables:

* cost of one forward-dynamics evaluation q̈(q, q̇, τ) vs the number of links n of a chain, for the
  readable ABA (O(n)), CRBA + bias forces + Cholesky solve (O(n²) to build, O(n³) to solve), and the
  batched ABA per state at K = 1024 states (the Python overhead paid once per batch);
* the same evaluation by Pinocchio (``pip install -e ".[pinocchio]"``) called once per state from Python,
  in the same run, when it is installed.

Goals (issue 15): batched ABA over K = 1024 states of a 10-link chain costs ≤ 1× per state what
Pinocchio's ABA costs per call; the single-state ABA ≤ 30× Pinocchio. Both need Pinocchio; without it the
goal lines say "not measured". The maximal columns evaluate the same chain as rigid rods held by hinge
joints (multipliers by the dense J W Jᵀ solve, and by Baraff's leaves-first sparse elimination).
"""

from __future__ import annotations

import numpy as np

from . import Goal, Report, Table, median_time
from ..articulated import aba, aba_batch, bias_forces, crba
from ..models.articulated import pendulum_chain, rod_chain, to_urdf

__all__ = ["run", "chain", "pinocchio_aba"]


def chain(n: int) -> "object":
    """An n-link chain of unit point masses (the benchmark's tree)."""
    return pendulum_chain(n, lengths=1.0, masses=1.0)


def pinocchio_aba(tree):
    """A ``f(q, qd, tau)`` calling Pinocchio's ABA on ``tree``, or None when Pinocchio is not installed."""
    try:
        import pinocchio as pin
    except ImportError:
        return None
    model = pin.buildModelFromXML(to_urdf(tree, "bench"))
    model.gravity.linear = np.asarray(tree.gravity, dtype=float)
    data = model.createData()
    return lambda q, qd, tau: pin.aba(model, data, q, qd, tau)


def _crba_solve(tree, q, qd, tau):
    from scipy.linalg import cho_factor, cho_solve

    return cho_solve(cho_factor(crba(tree, q)), tau - bias_forces(tree, q, qd))


def run(quick: bool = False) -> Report:
    """Run the articulated benchmarks (``quick``: small sizes, the test suite's smoke run)."""
    rep = Report("articulated")
    ns = [2, 5, 10] if quick else [2, 5, 10, 20, 50]
    K = 64 if quick else 1024
    repeats = 3 if quick else 7
    rng = np.random.default_rng(0)
    rows, at10 = [], {}
    for n in ns:
        tree = chain(n)
        q, qd, tau = (rng.normal(size=(K, n)) for _ in range(3))
        t_aba = median_time(lambda: aba(tree, q[0], qd[0], tau[0]), repeats)
        t_crba = median_time(lambda: _crba_solve(tree, q[0], qd[0], tau[0]), repeats)
        t_batch = median_time(lambda: aba_batch(tree, q, qd, tau), repeats) / K
        pin_aba = pinocchio_aba(tree)
        if pin_aba is not None:
            def calls():
                for k in range(K):
                    pin_aba(q[k], qd[k], tau[k])
            t_pin = median_time(calls, repeats) / K
            err = max(float(np.abs(pin_aba(q[k], qd[k], tau[k]) - aba(tree, q[k], qd[k], tau[k])).max())
                      for k in range(3))
        else:
            t_pin, err = float("nan"), float("nan")
        scene, rb, _ = rod_chain(n)
        y = rb.state()
        t_max = median_time(lambda: scene.rhs(0.0, y), repeats)
        scene.effects[-1].solver = "linear"
        t_lin = median_time(lambda: scene.rhs(0.0, y), repeats)
        rows.append([n, t_aba * 1e6, t_crba * 1e6, t_batch * 1e6, t_max * 1e6, t_lin * 1e6, t_pin * 1e6, err])
        if n == 10:
            at10 = dict(aba=t_aba, batch=t_batch, pin=t_pin)
    rep.tables.append(Table(f"one forward-dynamics evaluation of an n-link chain [µs] (batched: per state, K = {K})",
                            ["n", "ABA", "CRBA + solve", "batched ABA", "maximal (dense)", "maximal (linear)",
                             "Pinocchio ABA", "max |Δq̈| vs Pinocchio"],
                            rows))
    missing = "" if np.isfinite(at10.get("pin", np.nan)) else "pinocchio not installed"
    rep.goals.append(Goal("articulated-batched-aba-vs-pinocchio", at10["batch"] / at10["pin"] if not missing else np.nan,
                          1.0, "<=", "x", f"batched ABA per state (K = {K}) / Pinocchio ABA per call, 10 links",
                          skipped=missing))
    rep.goals.append(Goal("articulated-aba-vs-pinocchio", at10["aba"] / at10["pin"] if not missing else np.nan,
                          30.0, "<=", "x", "single-state ABA / Pinocchio ABA per call, 10 links", skipped=missing))
    slope = np.polyfit(np.log([r[0] for r in rows]), np.log([r[1] for r in rows]), 1)[0]
    rep.notes.append(f"readable ABA cost grows as n^{slope:.2f} over n = {ns[0]}..{ns[-1]} (O(n) with a large "
                     "per-link Python constant)")
    return rep
