"""The data of chapter 12's figures (cloth), checked against ORACLES J3 and J4 and the benchmark's claims.

The figures run once per session in quick mode (the ``figure_data`` fixture of conftest.py).
"""

import numpy as np


def test_figure_drape(figure_data):
    # ORACLES J3: the filter leaves the pins where they are; contacts keep the sheet out of the sphere
    d = figure_data("ch12_drape")
    assert d["pin_motion"] == 0.0
    assert d["min_sphere_distance"] > -0.05          # measured −0.021 m: one step of approach, |v| h ≈ 1.3 m/s × 1/60 s
    assert d["min_height"] > -0.92                   # above the ground (−0.9 m) to a step's approach
    assert np.all(np.isfinite(d["energy"])) and d["energy"][-1] < d["energy"][0]


def test_figure_work_precision(figure_data):
    # first-order methods: errors fall as their step or substep shrinks (ORACLES J4 for XPBD)
    d = figure_data("ch12_work_precision")
    for m in ("large steps", "XPBD"):
        e = d[m]["error"]
        assert len(e) >= 2 and e[-1] < e[0], (m, e)


def test_figure_stable_step(figure_data):
    # the explicit step shrinks with the stiffness; large steps and XPBD keep the largest step of the grid
    d = figure_data("ch12_stable_step")
    se = d["symplectic Euler"]
    assert np.all(np.diff(se) <= 0) and se[-1] < se[0]
    assert np.all(d["large steps"] >= 0.05) and np.all(d["XPBD"] >= 0.05)


def test_figure_step_cost(figure_data):
    d = figure_data("ch12_step_cost")
    assert np.all(d["large_step"] > 0) and np.all(d["xpbd"] > 0) and np.all(d["cg_iterations"] >= 1)
