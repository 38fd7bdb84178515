"""A few spheres' broad phase by one all-pairs product is the grid's (ORACLES D24).

``pbanim.collision.broad._grid_pairs_small`` (the route of ``Collisions.sphere_pairs`` up to SMALL_PAIRS bodies on
the lean path) keeps the pairs within a slightly wider margin, then applies the grid's own overlap test: the
same pairs as ``grid_pairs``, in the same order, also for pairs placed at the margin to the last bit. The event
runs of chapter 06 (the billiards break, a ball pile in 3-D) are then the grid's runs bit for bit.
"""

from __future__ import annotations

import numpy as np
import pytest

from pbanim.collision import Collisions, Plane, simulate_collisions
from pbanim.collision.broad import _grid_pairs_small, all_pairs, grid_pairs
from pbanim.particles import Gravity, ParticleSystem
from pbanim.scene import Scene


def _cloud(rng, n, dim, radii):
    c = rng.uniform(-1.0, 1.0, (n, dim))
    r = rng.uniform(0.05, 0.3, n) if radii == "varied" else np.full(n, 0.15)
    return c, r


@pytest.mark.parametrize("dim", [2, 3])
@pytest.mark.parametrize("radii", ["equal", "varied"])
def test_small_route_is_the_grid_on_random_clouds(dim, radii):
    rng = np.random.default_rng(11 + dim)
    for n in (2, 3, 7, 16, 40, 64):
        for margin in (0.0, 1e-3, 0.05, 0.4):
            c, r = _cloud(rng, n, dim, radii)
            got, ref = _grid_pairs_small(c, r, margin), grid_pairs(c, r, margin).pairs
            assert got.dtype == ref.dtype and got.shape == ref.shape and np.array_equal(got, ref)


def test_small_route_keeps_the_grid_verdict_at_the_margin():
    # pairs placed at the overlap distance r_i + r_j + margin and a few ulps either side: the grid's own test
    # decides each; the wider candidate margin alone would keep them all (so this can fail)
    rng = np.random.default_rng(5)
    margin, kept_by_wider = 0.01, 0
    for trial in range(200):
        r = rng.uniform(0.1, 0.2, 2)
        u = rng.normal(size=3)
        u /= np.linalg.norm(u)
        d = (r[0] + r[1] + margin) * (1.0 + (trial % 9 - 4) * np.finfo(float).eps)
        c = np.array([rng.uniform(-1, 1, 3), np.zeros(3)])
        c[1] = c[0] + d * u
        got, ref = _grid_pairs_small(c, r, margin), grid_pairs(c, r, margin).pairs
        assert np.array_equal(got, ref)
        kept_by_wider += len(all_pairs(c, r, margin + 1e-6).pairs) - len(ref)
    assert kept_by_wider > 0              # some of these pairs are outside the margin: the filter decided them


def _billiards(lean):
    R = 0.0285
    x = [[-0.6, 0.0]] + [[0.4 + 2 * R * k * np.sqrt(0.75), 2 * R * (j - 0.5 * k)] for k in range(4) for j in range(k + 1)]
    v = np.zeros((len(x), 2))
    v[0] = (6.0, 0.02)
    walls = [Plane([1, 0], -1.3), Plane([-1, 0], -1.3), Plane([0, 1], -0.65), Plane([0, -1], -0.65)]
    col = Collisions(obstacles=walls, radius=R, restitution=1.0, gravity=0.0)
    if not lean:
        col.SMALL_PAIRS = 0                 # the grid, as before the small route
    res = simulate_collisions(Scene(ParticleSystem(x, v, masses=0.17), [col]), 0.6, 1e-3, method="rk4", toi="event")
    return res, col


def _pile(lean):
    rng = np.random.default_rng(2)
    col = Collisions(obstacles=[Plane([0, 0, 1])], radius=rng.uniform(0.05, 0.08, 12), restitution=0.6)
    if not lean:
        col.SMALL_PAIRS = 0
    x = rng.uniform(-0.3, 0.3, (12, 3)) + [0, 0, 0.5]
    res = simulate_collisions(Scene(ParticleSystem(x, rng.normal(size=(12, 3))), [Gravity([0, 0, -9.81]), col]),
                              0.5, 2e-3, method="rk4", toi="event")
    return res, col


@pytest.mark.parametrize("run", [_billiards, _pile])
def test_event_runs_on_the_small_route_are_the_grid_runs(run):
    few, _ = run(True)
    grid, _ = run(False)
    assert np.array_equal(few.t, grid.t) and np.array_equal(few.y, grid.y)
    assert len(few.t_events[0]) == len(grid.t_events[0]) > 0
    for a, b in zip(few.t_events[0], grid.t_events[0]):
        assert a == b
