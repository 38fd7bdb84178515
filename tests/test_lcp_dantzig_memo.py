"""Dantzig's pivoting with each direction solved once per (clamped set, entering index) is the readable
pivoting (ORACLES D25).

Redundant contacts make Baraff's principal pivoting cycle between a few clamped sets until its step cap; the
lean route (``_dantzig(..., lean=True)``, the default of ``solve_lcp(A, b, "dantzig")``) keeps the
least-squares direction of each pair (C, d) it met and reuses it. The answer, the status and the step count
must equal the readable route's (``lean=False``: one least-squares solve per step) bit for bit.
"""

import functools

import numpy as np
import pytest

import pbanim.lcp.pivoting as pivoting
import pbanim.lcp.solve as solve_module
from pbanim.lcp import solve_lcp
from pbanim.models.contact import random_contact_lcp


def _same(a, b):
    return a.shape == b.shape and np.array_equal(a, b) and np.array_equal(np.signbit(a), np.signbit(b))


def _counted(monkeypatch):
    calls = [0]
    real = np.linalg.lstsq

    def spy(*args, **kwargs):
        calls[0] += 1
        return real(*args, **kwargs)

    monkeypatch.setattr(pivoting.np.linalg, "lstsq", spy)
    return calls


def test_cycling_at_the_cap_reuses_directions_and_gives_the_readable_answer(monkeypatch):
    # m = 60 redundant contacts (rank 31), seed 5: the pivots cycle until the cap of 20(m + 1) + 100 steps
    case = random_contact_lcp(60, redundant=True, seed=5)
    calls = _counted(monkeypatch)
    f0, status0, it0 = pivoting._dantzig(case.A, case.b, lean=False)
    readable_solves, calls[0] = calls[0], 0
    f1, status1, it1 = pivoting._dantzig(case.A, case.b)
    assert status0 == status1 == "max_iter" and it0 == it1
    assert _same(f0, f1)
    assert calls[0] < readable_solves / 4          # the memo is hit: the cycle revisits its clamped sets


@pytest.mark.parametrize("m, seed, redundant", [(30, 1, True), (60, 7, True), (40, 3, False), (12, 0, False)])
def test_lean_route_is_the_readable_route(m, seed, redundant):
    case = random_contact_lcp(m, redundant=redundant, seed=seed)
    f0, status0, it0 = pivoting._dantzig(case.A, case.b, lean=False)
    f1, status1, it1 = pivoting._dantzig(case.A, case.b)
    assert (status0, it0) == (status1, it1)
    assert _same(f0, f1)


def test_solve_lcp_dantzig_is_the_readable_route(monkeypatch):
    # what ch07_solver_residual_time plots for Dantzig: the certified answer of solve_lcp's default route
    case = random_contact_lcp(60, redundant=True, seed=5)
    calls = _counted(monkeypatch)
    lean = solve_lcp(case.A, case.b, "dantzig", raise_on_failure=False)
    lean_solves, calls[0] = calls[0], 0
    monkeypatch.setitem(solve_module._IMPL, "dantzig", functools.partial(pivoting._dantzig, lean=False))
    readable = solve_lcp(case.A, case.b, "dantzig", raise_on_failure=False)
    assert (lean.status, lean.iterations, lean.residual) == (readable.status, readable.iterations, readable.residual)
    assert _same(lean.f, readable.f)
    assert lean_solves < calls[0]
