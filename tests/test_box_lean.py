"""The box-friction sweep on floats computes the readable sweep (ORACLES D20)."""

import numpy as np
import pytest

from pbanim.lcp import pgs_box_friction
from pbanim.lcp.box import _box_residual, _box_sweeps, _warm_impulses
from pbanim.lcp.box_lean import LEAN_ROWS, box_residual_floats, box_sweeps_floats
from pbanim.lcp.pivoting import _scale


def _problem(rng, m, dof):
    """A = J W Jᵀ (+ a little mixing) of m contacts on dof velocities, b = J u + gaps, μ per contact."""
    J = rng.normal(size=(3 * m, dof))
    W = np.diag(rng.uniform(0.2, 3.0, dof))
    A = J @ W @ J.T
    A += 1e-6 * np.max(np.diag(A)) * np.eye(3 * m)
    b = J @ rng.normal(size=dof) + np.repeat(rng.uniform(-0.05, 0.01, m), 3) * np.tile([1.0, 0, 0], m)
    return A, b, rng.uniform(0.0, 1.2, m)


@pytest.mark.parametrize("m", [1, 2, 5, 11, LEAN_ROWS // 3])
def test_float_sweeps_equal_the_readable_sweeps_bit_for_bit(m):
    """D20: the same iterates after 1, 2, 7 sweeps and at convergence, the same sweep count and residual,
    cold and warm started, for redundant (3m > dof) and full-rank problems."""
    rng = np.random.default_rng(100 + m)
    for trial in range(4):
        dof = 3 * m + 2 if trial % 2 else max(3, 3 * m // 2)
        A, b, mu = _problem(rng, m, dof)
        warm = None if trial < 2 else rng.normal(size=3 * m)
        diag = np.diag(A).copy()
        for sweeps, tol in ((1, 1e-300), (2, 1e-300), (7, 1e-300), (400 if m < 20 else 30, 1e-8)):
            z0 = _warm_impulses(warm, 3 * m, mu)
            za, ra, ka = _box_sweeps(A, b, mu, diag, z0.copy(), sweeps, tol)
            zb, rb, kb = box_sweeps_floats(A, b, mu, diag, z0.copy(), sweeps, tol * _scale(b))
            assert ka == kb
            assert np.array_equal(za, zb), np.max(np.abs(za - zb))
            assert ra == rb


def test_float_residual_is_the_readable_residual():
    """D20: the box residual on floats equals the array form on iterates at, inside and beyond the bounds."""
    rng = np.random.default_rng(7)
    for _ in range(50):
        m = int(rng.integers(1, 9))
        z, w, mu = rng.normal(size=3 * m), rng.normal(size=3 * m), rng.uniform(0, 1, m)
        z[0::3] = np.abs(z[0::3]) * (rng.uniform(size=m) < 0.7)
        z[1::3] = np.where(rng.uniform(size=m) < 0.5, mu * z[0::3], z[1::3])        # some on the bound
        assert box_residual_floats(z.tolist(), w.tolist(), mu.tolist()) == _box_residual(z, w, mu)


def test_pgs_box_friction_answers_on_both_sides_of_the_switch():
    """D11, D20: below and above LEAN_ROWS the public sweep meets the box-friction conditions (the
    residual it reports is recomputed here from A z + b)."""
    rng = np.random.default_rng(3)
    for m in (4, LEAN_ROWS // 3 + 1):
        A, b, mu = _problem(rng, m, 3 * m + 1)
        z, res, sweeps = pgs_box_friction(A, b, mu, max_iter=3000, tol=1e-9)
        assert res <= 1e-9 * _scale(b) and _box_residual(z, A @ z + b, mu) <= 1.01e-9 * _scale(b)
        f, t = z[0::3], np.stack([z[1::3], z[2::3]], axis=1)
        assert np.all(f >= 0) and np.all(np.abs(t) <= (mu * f)[:, None] * (1 + 1e-15))
