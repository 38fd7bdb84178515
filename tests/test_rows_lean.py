"""The sweeps of pbanim.lcp.rows with scipy's sparse kernels bound once per color (issue 28 point 4; ORACLES D18)."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from pbanim import sparse_kernel
from pbanim.lcp import rows
from pbanim.lcp.colored import colors_by_bodies
from test_lcp_rows import _rows_problem as _problem     # random rows (3 per contact) between bodies and the world


def _both(monkeypatch, call):
    """``call()`` with the bound kernels, then with scipy's operator (``_sparsetools`` absent from
    :mod:`pbanim.sparse_kernel`, where lcp.rows binds its products)."""
    fast = call()
    with monkeypatch.context() as m:
        m.setattr(sparse_kernel, "_sparsetools", None)
        slow = call()
    return fast, slow


# ORACLES D18: a color's products J_K u and (W Jᵀ)_K Δz through scipy's kernels into zeroed buffers are the
# operator's products (the same kernel into a zeroed result): the sweeps' iterates, counts, residuals and
# velocities equal bit for bit, for the box-friction sweep (cold and warm) and the normal-row sweep
@settings(max_examples=25, deadline=None)
@given(seed=st.integers(0, 10**6), bodies=st.integers(1, 8), contacts=st.integers(1, 14),
       sweeps=st.integers(1, 6), warm=st.booleans())
def test_bound_kernels_give_the_operators_sweeps_bit_for_bit(seed, bodies, contacts, sweeps, warm):
    if sparse_kernel._sparsetools is None:
        pytest.skip("scipy's sparse kernels are not where pbanim.sparse_kernel looks: the operator runs both sides")
    ra, rb, Ga, Gb, Wb, u, bias, mu, (a, b) = _problem(seed, bodies, contacts)
    colors = colors_by_bodies(a, b, static=[bodies])
    z0 = np.abs(np.random.default_rng(seed + 1).normal(size=3 * contacts)) if warm else None
    mp = pytest.MonkeyPatch()
    try:
        fast, slow = _both(mp, lambda: rows.pgs_box_friction_rows(ra, rb, Ga, Gb, Wb, u, bias, mu, colors,
                                                                  max_iter=sweeps, tol=1e-300, warm_start=z0))
        nf, ns = _both(mp, lambda: rows.pgs_normal_rows(a, b, Ga[0::3], Gb[0::3], Wb, bias[0::3], colors,
                                                        max_iter=sweeps, tol=1e-300))
    finally:
        mp.undo()
    for x, y in ((fast, slow), (nf, ns)):
        np.testing.assert_array_equal(x[0], y[0])
        assert x[1] == y[1] and x[2] == y[2]
        np.testing.assert_array_equal(x[3], y[3])
    assert fast[2] >= 1                                     # the box sweep ran


def test_the_wall_steps_the_same_with_the_operator():
    # ORACLES D18: a few steps of the 20-box wall (SplitStepping: broad phase, box–box narrow phase, warm start,
    # both sweeps, the position pass) end in the same state, bit for bit, with the bound kernels and with scipy's
    # operator
    from pbanim.contact.scenes import brick_wall
    from pbanim.contact.split import SplitStepping

    def run():
        sc = brick_wall(20)
        ts = SplitStepping(sc.system, sc.detect, sc.forces, friction=sc.friction, iterations=10, tol=1e-3,
                           position_tol=5e-5)
        y = np.array(sc.system.state(), float)
        for k in range(6):
            y = ts.step(k / 60, y, 1 / 60)
        return y, ts.stats["contacts"]

    mp = pytest.MonkeyPatch()
    try:
        (ya, ca), (yb, cb) = _both(mp, run)
    finally:
        mp.undo()
    assert ca == cb > 0
    np.testing.assert_array_equal(ya, yb)
