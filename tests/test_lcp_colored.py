"""Colored projected Gauss–Seidel for box friction equals the readable sweep in color order (chapter 07)."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from pbanim.errors import InvalidInput
from pbanim.lcp import delassus, pgs_box_friction
from pbanim.lcp.colored import colors_by_bodies, contact_colors, pgs_box_friction_colored


def _friction_lcp(seed, bodies, contacts, with_bodies=False):
    """A = J W Jᵀ of ``contacts`` random contacts (3 rows each) between ``bodies`` bodies and the world
    (index ``bodies``, zero block of W), b random: the sparsity of a real pile."""
    rng = np.random.default_rng(seed)
    a = rng.integers(0, bodies, size=contacts)
    other = rng.integers(0, bodies + 1, size=contacts)
    other = np.where(other == a, bodies, other)                 # a body never touches itself
    G = rng.normal(size=(3 * contacts, 6))
    H = rng.normal(size=(3 * contacts, 6))
    W = np.zeros((bodies + 1, 6, 6))
    for k in range(bodies):
        B = rng.normal(size=(6, 6))
        W[k] = B @ B.T / 6 + 0.2 * np.eye(6)
    A = delassus(np.repeat(a, 3), np.repeat(other, 3), G, H, W)
    A = 0.5 * (A + A.T) + 1e-9 * np.eye(3 * contacts)
    out = (A, rng.normal(size=3 * contacts), rng.uniform(0.1, 1.0, size=contacts))
    return out + ((a, other),) if with_bodies else out


# ORACLES D16: the colored sweep is the readable sweep with the contacts in color order
@settings(max_examples=30, deadline=None)
@given(seed=st.integers(0, 10**6), bodies=st.integers(1, 12), contacts=st.integers(1, 30),
       sweeps=st.integers(1, 15), warm=st.booleans())
def test_colored_sweep_equals_readable_in_color_order(seed, bodies, contacts, sweeps, warm):
    A, b, mu = _friction_lcp(seed, bodies, contacts)
    colors = contact_colors(A)
    order = np.concatenate(colors)
    assert sorted(order.tolist()) == list(range(contacts))           # a partition of the contacts
    rows = (3 * order[:, None] + np.arange(3)).ravel()
    z0 = np.random.default_rng(seed + 1).normal(size=3 * contacts) if warm else None
    z1, r1, s1 = pgs_box_friction(A[np.ix_(rows, rows)], b[rows], mu[order], max_iter=sweeps, tol=1e-300,
                                  warm_start=None if z0 is None else z0[rows])
    z2, r2, s2 = pgs_box_friction_colored(A, b, mu, max_iter=sweeps, tol=1e-300, warm_start=z0, colors=colors)
    # measured ≤ 2e-16 (relative to max |z|); bound 1e-12
    assert s1 == s2 <= sweeps                 # both stop at the same sweep (early only at an exact answer)
    np.testing.assert_allclose(z2[rows], z1, atol=1e-12 * max(1.0, float(np.abs(z1).max())))
    assert r2 == pytest.approx(r1, rel=1e-9, abs=1e-12)


def test_colors_are_decoupled_and_few():
    # ORACLES D16: no two contacts of a color share a moving body (their block of A is zero), and greedy
    # coloring needs at most (largest degree + 1) colors
    A, b, mu = _friction_lcp(3, 10, 40)
    m = 40
    coupled = np.abs(A).reshape(m, 3, m, 3).sum(axis=(1, 3)) > 0
    np.fill_diagonal(coupled, False)
    colors = contact_colors(A)
    for K in colors:
        assert not coupled[np.ix_(K, K)].any()
    assert len(colors) <= coupled.sum(axis=1).max() + 1


def test_colored_pgs_converges_to_the_box_friction_conditions():
    # ORACLES D11, D16: run to convergence, the colored sweep meets the conditions the readable one meets
    A, b, mu = _friction_lcp(5, 6, 12)
    A = A + 0.5 * np.eye(A.shape[0])                     # well conditioned: Gauss–Seidel converges
    z, res, sweeps = pgs_box_friction_colored(A, b, mu, max_iter=5000, tol=1e-12)
    assert res <= 1e-12 * max(1.0, float(np.abs(b).max())) and sweeps < 5000
    zr, resr, _ = pgs_box_friction(A, b, mu, max_iter=5000, tol=1e-12)
    np.testing.assert_allclose(z, zr, atol=1e-9)         # A positive definite: one answer


def test_colored_pgs_validates_its_input():
    A, b, mu = _friction_lcp(1, 2, 3)
    with pytest.raises(InvalidInput, match="3 rows per contact"):
        pgs_box_friction_colored(A[:8, :8], b[:8], 0.5)
    with pytest.raises(InvalidInput, match="positive diagonal"):
        pgs_box_friction_colored(np.zeros((3, 3)), np.ones(3), 0.5)
    with pytest.raises(InvalidInput, match="warm_start"):
        pgs_box_friction_colored(A, b, mu, warm_start=np.ones(4))
    with pytest.raises(InvalidInput, match="3 rows per contact"):
        contact_colors(np.eye(4))
    with pytest.raises(InvalidInput, match="partition"):
        pgs_box_friction_colored(A, b, mu, colors=[np.array([0, 1])])
    with pytest.raises(InvalidInput, match="finite"):
        pgs_box_friction_colored(np.where(np.eye(9) > 0, np.nan, A), b, mu)


# ORACLES D16: the coloring from the contacts' bodies is as valid as the one read from A
@settings(max_examples=30, deadline=None)
@given(seed=st.integers(0, 10**6), bodies=st.integers(1, 12), contacts=st.integers(1, 40))
def test_colors_by_bodies_are_decoupled_and_few(seed, bodies, contacts):
    A, b, mu, (a, other) = _friction_lcp(seed, bodies, contacts, with_bodies=True)
    colors = colors_by_bodies(a, other, static=[bodies])
    order = np.sort(np.concatenate(colors))
    assert np.array_equal(order, np.arange(contacts))                     # a partition
    m = contacts
    coupled = np.abs(A - 1e-9 * np.eye(3 * m)).reshape(m, 3, m, 3).sum(axis=(1, 3)) > 0
    np.fill_diagonal(coupled, False)
    for K in colors:
        assert not coupled[np.ix_(K, K)].any()                            # no shared moving body in a color
    per_body = np.bincount(np.concatenate([a, other[other < bodies]]), minlength=bodies)
    assert len(colors) <= max(1, 2 * per_body.max() - 1)                  # greedy edge coloring bound
    z1, r1, _ = pgs_box_friction_colored(A, b, mu, max_iter=5, tol=1e-300, colors=colors)
    order = np.concatenate(colors)
    rows = (3 * order[:, None] + np.arange(3)).ravel()
    z2, r2, _ = pgs_box_friction(A[np.ix_(rows, rows)], b[rows], mu[order], max_iter=5, tol=1e-300)
    np.testing.assert_allclose(z1[rows], z2, atol=1e-12 * max(1.0, float(np.abs(z2).max())))


def test_colors_by_bodies_validates():
    with pytest.raises(InvalidInput, match="same length"):
        colors_by_bodies([0, 1], [1])
    assert colors_by_bodies([], []) == []
