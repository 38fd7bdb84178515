"""Issue 28 point 5: projected Gauss–Seidel by wavefronts runs the readable sweep's iterates (ORACLES D21)."""

import numpy as np
import pytest

from pbanim.lcp.solve import pgs_sweeps, solve_lcp
from pbanim.lcp.sweeps import WAVEFRONT_FROM, pgs_sweeps_wavefront, wavefront_levels
from pbanim.models.contact import random_contact_lcp

EPS = np.finfo(float).eps


def _pile_lcp(n=40, steps=60):
    """The frictionless LCP of a settling sphere pile (contacts sharing a sphere are coupled, the others not)."""
    from pbanim.contact import TimeStepping
    from pbanim.models.contact import sphere_pour

    sc = sphere_pour(n)
    ts = TimeStepping(sc.system, sc.detect, sc.forces, friction=0.0, solver="pgs",
                      solver_options={"max_iter": 30}, tol=1e-6, accept_unconverged=True)
    ts.simulate(steps * 4e-3, 4e-3, diagnostics=False)
    return ts.last.A, ts.last.b


def _sparse_lcp(m, seed):
    """A sparse non-symmetric pattern with a dominant diagonal (rows coupled one way only, too)."""
    rng = np.random.default_rng(seed)
    A = np.where(rng.random((m, m)) < 0.05, rng.normal(size=(m, m)), 0.0)
    A[np.diag_indices(m)] = np.abs(A).sum(axis=1) + 1.0
    return A, rng.normal(size=m)


def _both(A, b, max_iter, omega=1.0, warm=None):
    f0 = np.zeros(b.size) if warm is None else warm
    diag, absA = np.diag(A).copy(), np.abs(A)
    r1 = pgs_sweeps(A, b, f0.copy(), diag, absA, 1e-10, max_iter, omega)
    r2 = pgs_sweeps_wavefront(A, b, f0.copy(), diag, absA, 1e-10, max_iter, omega)
    return r1, r2


def _case(case):
    """(A, b) of a named test problem: the pile's LCP, a redundant random contact LCP, or a sparse one."""
    if case == "pile":
        return _pile_lcp()
    if case == "redundant":
        c = random_contact_lcp(80, redundant=True, seed=3)
        return c.A, c.b
    return _sparse_lcp(120, 5)


# ORACLES D21: the same iterates, the products summed in another order: a few ulps of max|f| per sweep
@pytest.mark.parametrize("case", ["pile", "redundant", "sparse", "sor"])
def test_wavefront_sweeps_equal_the_readable_sweeps(case):
    A, b = _case(case)
    omega = 1.3 if case == "sor" else 1.0
    r1, r2 = _both(A, b, 25, omega)
    assert r1[1:3] == r2[1:3]                                    # same status after the same number of sweeps
    f1, f2 = r1[0], r2[0]
    assert np.abs(f1).max() > 0
    # measured ≤ 0.15 ulp of max|f| per sweep on the pile
    assert np.abs(f1 - f2).max() <= 4 * EPS * r1[2] * np.abs(f1).max()
    assert r2[3] == pytest.approx(r1[3], rel=1e-6, abs=1e-12)


def test_wavefront_levels_order_every_coupled_pair():
    A, _ = _sparse_lcp(60, 1)
    level = wavefront_levels(A)
    i, j = np.nonzero((A != 0) | (A.T != 0))
    off = i != j
    i, j = i[off], j[off]
    assert np.all(np.sign(level[i] - level[j]) == np.sign(i - j))    # coupled: the earlier row, the earlier level
    assert wavefront_levels(np.eye(5)).tolist() == [1] * 5           # diagonal: one level (a Jacobi step)
    dense = np.ones((4, 4)) + np.eye(4)
    assert wavefront_levels(dense).tolist() == [1, 2, 3, 4]          # dense: the readable order, row by row


def test_solve_lcp_pgs_takes_the_wavefronts_and_certifies():
    c = random_contact_lcp(WAVEFRONT_FROM + 20, redundant=False, seed=2)
    sol = solve_lcp(c.A, c.b, "pgs", tol=1e-8, max_iter=5000)
    assert sol.success and sol.residual <= sol.extra["threshold"]
    ref = solve_lcp(c.A, c.b, "lemke")                           # full rank: one answer
    assert np.abs(sol.f - ref.f).max() <= 1e-6 * max(1.0, np.abs(ref.f).max())


def _wavefront_every_sweep(A, b, f, diag, absA, tol_b, max_iter, omega=1.0):
    """The wavefront sweeps with the threshold tol_b + 1000 ε max(|A| f) made after every sweep (the stop test
    as the readable loop writes it)."""
    from pbanim.lcp.sweeps import _plan
    order, plan = _plan(A, b, diag, omega)
    fp = f[order]
    res = thresh = float("inf")
    for sweep in range(1, max_iter + 1):
        for s, e, ML, cL in plan:
            np.maximum(ML @ fp - cL, 0.0, out=fp[s:e])
        f[order] = fp
        thresh = tol_b + 1000 * EPS * float(np.max(absA @ f))
        res = float(np.abs(f - np.maximum(0.0, f - (A @ f + b))).max())
        if res <= thresh:
            return f, "converged", sweep, res, thresh
    return f, "max_iter", max_iter, res, thresh


# ORACLES D21: the threshold's product |A| f skipped on sweeps whose residual exceeds the bound
# tol_b + 1000 ε max rowsum|A| max f changes nothing: the same f, status, sweeps, residual and threshold, bit for bit
@pytest.mark.parametrize("case", ["pile", "redundant", "sparse"])
@pytest.mark.parametrize("tol_b", [1e-3, 1e-8, 1e-13, 0.0])
def test_wavefront_stop_test_bound_skips_nothing_it_needs(case, tol_b):
    A, b = _case(case)
    diag, absA = np.diag(A).copy(), np.abs(A)
    statuses = set()
    for max_iter in (1, 7, 60, 400):
        r1 = _wavefront_every_sweep(A, b, np.zeros(b.size), diag, absA, tol_b, max_iter)
        r2 = pgs_sweeps_wavefront(A, b, np.zeros(b.size), diag, absA, tol_b, max_iter)
        assert r1[1:] == r2[1:] and np.array_equal(r1[0], r2[0])
        statuses.add(r1[1])
    if tol_b >= 1e-8 and case != "redundant":             # PGS on the redundant case: slower than 400 sweeps
        assert "converged" in statuses
