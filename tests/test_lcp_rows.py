"""Issue 28 point 4: the large-scene machinery equals the readable one on small scenes — colored Gauss–Seidel on
the bodies' velocities (no Delassus matrix) against the colored sweep on A (ORACLES D16), the grid broad phase
against all pairs in the narrow phase (D13), the rows route of the time stepper against the dense one (D14)."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from pbanim.contact.scenes import brick_wall, sphere_pile
from pbanim.contact.stepping import FrictionStepping
from pbanim.errors import InvalidInput
from pbanim.lcp import delassus
from pbanim.lcp.box import _box_residual
from pbanim.lcp.colored import colors_by_bodies, pgs_box_friction_colored
from pbanim.lcp.rows import delassus_diagonal, pgs_box_friction_rows
from pbanim.lcp.solve import pgs_box_friction


def _rows_problem(seed, bodies, contacts):
    """Random contact rows (3 per contact) between bodies and the world (index ``bodies``, zero W block)."""
    rng = np.random.default_rng(seed)
    a = rng.integers(0, bodies, size=contacts)
    b = rng.integers(0, bodies + 1, size=contacts)
    b = np.where(b == a, bodies, b)
    Ga, Gb = rng.normal(size=(3 * contacts, 6)), rng.normal(size=(3 * contacts, 6))
    Wb = np.zeros((bodies + 1, 6, 6))
    for k in range(bodies):
        B = rng.normal(size=(6, 6))
        Wb[k] = B @ B.T / 6 + 0.2 * np.eye(6)
    u = np.vstack([rng.normal(size=(bodies, 6)), np.zeros((1, 6))])
    bias = np.zeros(3 * contacts)
    bias[0::3] = rng.normal(size=contacts)
    return np.repeat(a, 3), np.repeat(b, 3), Ga, Gb, Wb, u, bias, rng.uniform(0.1, 1.0, size=contacts), (a, b)


# ORACLES D16: colored Gauss–Seidel is Gauss–Seidel in color order — on velocities as on A
@settings(max_examples=40, deadline=None)
@given(seed=st.integers(0, 10**6), bodies=st.integers(1, 8), contacts=st.integers(1, 14),
       sweeps=st.integers(1, 6), warm=st.booleans())
def test_rows_sweep_equals_colored_sweep_on_A(seed, bodies, contacts, sweeps, warm):
    ra, rb, Ga, Gb, Wb, u, bias, mu, (a, b) = _rows_problem(seed, bodies, contacts)
    A = delassus(ra, rb, Ga, Gb, Wb)
    A = 0.5 * (A + A.T)
    bb = np.einsum("ij,ij->i", Ga, u[ra]) - np.einsum("ij,ij->i", Gb, u[rb]) + bias
    colors = colors_by_bodies(a, b, static=[bodies])
    z0 = np.abs(np.random.default_rng(seed + 1).normal(size=3 * contacts)) if warm else None
    z, res, k, u1 = pgs_box_friction_rows(ra, rb, Ga, Gb, Wb, u, bias, mu, colors, max_iter=sweeps, tol=1e-300,
                                          warm_start=z0)
    zc, resc, kc = pgs_box_friction_colored(A, bb, mu, max_iter=sweeps, tol=1e-300, warm_start=z0, colors=colors)
    scale = max(1.0, float(np.abs(zc).max()))
    # measured ≤ 3e-15 relative; bound 1e-11 (an ill-conditioned draw amplifies the roundoff of the two orders)
    assert np.abs(z - zc).max() <= 1e-11 * scale and k == kc <= sweeps
    # u = ũ + W Jᵀ z, and the residual is the box-friction residual of w = J u + β = A z + b
    imp = np.zeros_like(u)
    np.add.at(imp, ra, Ga * z[:, None])
    np.add.at(imp, rb, -Gb * z[:, None])
    assert np.allclose(u1, u + np.einsum("nij,nj->ni", Wb, imp), atol=1e-10 * scale)
    assert res == pytest.approx(_box_residual(z, A @ z + bb, mu), abs=1e-9 * scale)


def test_delassus_diagonal_is_the_diagonal_of_A():
    ra, rb, Ga, Gb, Wb, *_ = _rows_problem(3, 5, 9)
    A = delassus(ra, rb, Ga, Gb, Wb)
    np.testing.assert_allclose(delassus_diagonal(ra, rb, Ga, Gb, Wb), np.diag(A), rtol=1e-13)


def test_rows_sweep_validates():
    ra, rb, Ga, Gb, Wb, u, bias, mu, (a, b) = _rows_problem(0, 3, 4)
    with pytest.raises(InvalidInput, match="colors"):
        pgs_box_friction_rows(ra, rb, Ga, Gb, Wb, u, bias, mu, [np.array([0, 7])])
    with pytest.raises(InvalidInput, match="3 rows"):
        pgs_box_friction_rows(ra[:4], rb[:4], Ga[:4], Gb[:4], Wb, u, bias[:4], mu, [np.array([0])])


# ORACLES D13: the narrow phase's contacts do not depend on how the pairs were found (grid vs all pairs)
@pytest.mark.parametrize("seed", [0, 1, 2])
def test_grid_broad_phase_gives_the_all_pairs_contacts(seed):
    grid, every = sphere_pile(40, box_half=0.2, seed=seed), sphere_pile(40, box_half=0.2, seed=seed, broad="all_pairs")
    rng = np.random.default_rng(seed)
    y = grid.system.state()
    y[:120] = np.column_stack([rng.uniform(-0.2, 0.2, (40, 2)), rng.uniform(0.0, 0.4, 40)]).ravel()  # a dense jumble
    out_g, out_a = grid.detect.arrays(y, None), every.detect.arrays(y, None)
    assert out_g[0].size > 40                               # sphere–sphere contacts present
    for g, a in zip(out_g, out_a):
        assert np.array_equal(g, a)


# ORACLES D14: the rows route (no A) steps what the dense route steps, on a pile and on a wall
@pytest.mark.parametrize("make, t_end", [(lambda: sphere_pile(30, box_half=None), 0.5),
                                         (lambda: brick_wall(12, per_row=5), 0.3)])
def test_rows_route_equals_dense_route(make, t_end):
    out = {}
    for assembly in ("dense", "rows"):
        sc = make()
        ts = FrictionStepping(sc.system, sc.detect, sc.forces, friction=sc.friction, solver="pgs", iterations=20,
                              assembly=assembly)
        out[assembly] = (ts.simulate(t_end, 1 / 120), ts.stats)
    (yd, sd), (yr, sr) = ((out[k][0].y, out[k][1]) for k in ("dense", "rows"))
    assert sd["rounds"] == sr["rounds"] and sd["contacts"] == sr["contacts"] > 0
    # measured: 9e-14 (pile, 60 steps), 3e-14 (wall); bound 1e-10 (a pile is chaotic: roundoff grows)
    assert np.abs(yd - yr).max() <= 1e-10


def test_wall_stands():
    """A 12-brick running-bond wall dropped from 1 mm lands and stays: every brick near its course height."""
    sc = brick_wall(12, per_row=5)
    ts = FrictionStepping(sc.system, sc.detect, sc.forces, friction=sc.friction, solver="pgs", iterations=30)
    res = ts.simulate(0.5, 1 / 120)
    z0, z1 = res.y[2:36:3, 0], res.y[2:36:3, -1]
    assert np.abs(z1 - z0).max() < 5e-3 and np.abs(res.y[0:36:3, -1] - res.y[0:36:3, 0]).max() < 5e-3
    with pytest.raises(InvalidInput, match="at most"):
        brick_wall(16, per_row=5)


# ORACLES D16: a coloring extended around the persisting contacts' colors stays decoupled and within 2Δ − 1
@settings(max_examples=40, deadline=None)
@given(seed=st.integers(0, 10**6), bodies=st.integers(2, 10), contacts=st.integers(1, 40))
def test_extended_coloring_is_decoupled(seed, bodies, contacts):
    from pbanim.lcp.colored import color_groups, extend_colors

    rng = np.random.default_rng(seed)
    a = rng.integers(0, bodies, size=contacts)
    b = rng.integers(0, bodies + 1, size=contacts)
    b = np.where(b == a, bodies, b)
    full = np.empty(contacts, dtype=np.intp)
    for c, K in enumerate(colors_by_bodies(a, b, static=[bodies])):
        full[K] = c
    keep = np.where(rng.random(contacts) < 0.6, full, -1)
    color = extend_colors(a, b, keep, static=[bodies])
    assert np.array_equal(color[keep >= 0], keep[keep >= 0])
    for K in color_groups(color):
        ends = np.concatenate([a[K], b[K]])
        ends = ends[ends != bodies]
        assert ends.size == np.unique(ends).size                  # no moving body twice in a color
    degree = np.bincount(np.concatenate([a, b[b != bodies]]), minlength=bodies)
    assert color.max() + 1 <= 2 * degree.max() - 1


# ORACLES D16, D18: the row-wise sweep (sparse products per color, contacts in color order) is the readable
# projected Gauss–Seidel sweep on A with the contacts renumbered in color order
@settings(max_examples=30, deadline=None)
@given(seed=st.integers(0, 10**6), bodies=st.integers(1, 8), contacts=st.integers(1, 12), sweeps=st.integers(1, 4))
def test_rows_sweep_is_the_readable_sweep_in_color_order(seed, bodies, contacts, sweeps):
    ra, rb, Ga, Gb, Wb, u, bias, mu, (a, b) = _rows_problem(seed, bodies, contacts)
    colors = colors_by_bodies(a, b, static=[bodies])
    z, res, k, _ = pgs_box_friction_rows(ra, rb, Ga, Gb, Wb, u, bias, mu, colors, max_iter=sweeps, tol=1e-300)
    order = np.concatenate(colors)
    rows = (3 * order[:, None] + np.arange(3)).ravel()
    A = delassus(ra[rows], rb[rows], Ga[rows], Gb[rows], Wb)
    A = 0.5 * (A + A.T)
    bb = np.einsum("ij,ij->i", Ga[rows], u[ra[rows]]) - np.einsum("ij,ij->i", Gb[rows], u[rb[rows]]) + bias[rows]
    zr, _, kr = pgs_box_friction(A, bb, mu[order], max_iter=sweeps, tol=1e-300)
    # both stop early only at an exact fixed point (one decoupled contact); measured ≤ 1e-15 relative, 1e-11
    # allows the roundoff of two evaluation orders on an ill-conditioned draw
    assert k <= sweeps and kr <= sweeps and np.abs(z[rows] - zr).max() <= 1e-11 * max(1.0, float(np.abs(zr).max()))


def test_rows_sweep_refuses_a_contact_in_two_colors_and_keeps_an_uncolored_one():
    ra, rb, Ga, Gb, Wb, u, bias, mu, _ = _rows_problem(0, 4, 3)
    with pytest.raises(InvalidInput, match="partition"):
        pgs_box_friction_rows(ra, rb, Ga, Gb, Wb, u, bias, mu, [np.array([0, 1]), np.array([1])])
    warm = np.abs(np.random.default_rng(1).normal(size=9))
    z, *_ = pgs_box_friction_rows(ra, rb, Ga, Gb, Wb, u, bias, mu, [np.array([0])], max_iter=2, warm_start=warm)
    lim = mu[1:] * warm[3::3]                       # contacts 1, 2 in no color: their warm start, projected
    np.testing.assert_array_equal(z[3:].reshape(2, 3), np.column_stack([warm[3::3], np.clip(warm[4::3], -lim, lim),
                                                                        np.clip(warm[5::3], -lim, lim)]))


# ORACLES D18: the normal rows alone (the position correction's LCP) — the colored sweep on velocities against the
# readable projected Gauss–Seidel on A = J W Jᵀ in color order, and converged, the frictionless LCP's conditions
@settings(max_examples=20, deadline=None)
@given(seed=st.integers(0, 10**6), bodies=st.integers(1, 8), contacts=st.integers(1, 14), sweeps=st.integers(1, 5))
def test_normal_rows_sweep_equals_gauss_seidel_on_A(seed, bodies, contacts, sweeps):
    from pbanim.lcp.rows import pgs_normal_rows
    from pbanim.lcp.solve import pgs

    ra, rb, Ga, Gb, Wb, u, bias, mu, (a, b) = _rows_problem(seed, bodies, contacts)
    Gn_a, Gn_b, beta = Ga[0::3], Gb[0::3], bias[0::3] - 0.5        # at least one row pushed (β < 0) on average
    colors = colors_by_bodies(a, b, static=[bodies])
    order = np.concatenate([np.asarray(K, dtype=np.intp) for K in colors])
    A = delassus(a, b, Gn_a, Gn_b, Wb)
    A = 0.5 * (A + A.T)
    p, res, k, v = pgs_normal_rows(a, b, Gn_a, Gn_b, Wb, beta, colors, max_iter=sweeps, tol=1e-300)
    if not np.any(beta < 0):
        assert k == 0 and not np.any(p) and not np.any(v)
        return
    pr, _, _ = pgs(A[np.ix_(order, order)], beta[order], max_iter=sweeps, tol=1e-300)   # readable, color order
    scale = max(1.0, float(np.abs(pr).max()))
    assert np.abs(p[order] - pr).max() <= 1e-11 * scale and 1 <= k <= sweeps        # stops early only at res = 0
    imp = np.zeros((bodies + 1, 6))
    np.add.at(imp, a, Gn_a * p[:, None])
    np.add.at(imp, b, -Gn_b * p[:, None])
    assert np.allclose(v, np.einsum("nij,nj->ni", Wb, imp), atol=1e-10 * scale)
    if np.linalg.eigvalsh(A).min() < 1e-2:          # converged answers only where unique (A positive definite)
        return
    p, res, k, v = pgs_normal_rows(a, b, Gn_a, Gn_b, Wb, beta, colors, max_iter=5000, tol=1e-10)
    w = A @ p + beta
    assert res <= 1e-10 and np.all(p >= 0) and w.min() >= -1e-9 and np.abs(np.minimum(p, w)).max() <= 1e-9


# ORACLES D11: warm started from any nearby impulses, the colored sweep on velocities reaches the cold start's answer
# (unique on a positive definite A) within its tolerance, in fewer sweeps from the answer itself
@pytest.mark.parametrize("seed", [0, 1, 2])
def test_rows_warm_start_reaches_the_cold_answer(seed):
    ra, rb, Ga, Gb, Wb, u, bias, mu, (a, b) = _rows_problem(seed, 8, 4)   # 12 rows on 48 dofs: A positive definite
    A = delassus(ra, rb, Ga, Gb, Wb)
    assert np.linalg.eigvalsh(0.5 * (A + A.T)).min() > 1e-3
    colors = colors_by_bodies(a, b, static=[8])
    tol = 1e-11
    z, res, k, u1 = pgs_box_friction_rows(ra, rb, Ga, Gb, Wb, u, bias, mu, colors, max_iter=20000, tol=tol)
    near = z * np.random.default_rng(seed).uniform(0.5, 1.5, z.size)            # last step's impulses, say
    zw, resw, kw, uw = pgs_box_friction_rows(ra, rb, Ga, Gb, Wb, u, bias, mu, colors, max_iter=20000, tol=tol,
                                             warm_start=near)
    cond = np.linalg.cond(0.5 * (A + A.T))
    scale_b = max(1.0, float(np.abs(np.einsum("ij,ij->i", Ga, u[ra]) - np.einsum("ij,ij->i", Gb, u[rb]) + bias).max()))
    assert res <= tol * scale_b and resw <= tol * scale_b          # the stopping test, relative to max(1, ‖b‖∞)
    assert np.abs(zw - z).max() <= 10 * cond * tol * max(1.0, np.abs(z).max())
    z2, _, k2, _ = pgs_box_friction_rows(ra, rb, Ga, Gb, Wb, u, bias, mu, colors, max_iter=20000, tol=tol,
                                         warm_start=z)
    assert k2 <= 2 < k
