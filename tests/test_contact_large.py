"""Issue 28 point 4: the large-scene machinery equals the readable one on small scenes (ORACLES D18) — the grid
broad phase against all pairs, the batched sphere narrow phase against a loop over spheres, walls and pairs, the
row-wise colored sweep is tested against the readable sweep in color order in ``tests/test_lcp_rows.py`` — and the
benchmark's bookkeeping (budget, goal lines) on made-up runs (no timing is asserted)."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from pbanim.bench import contact_large
from pbanim.bench.contact_large import _goal, cheapest
from pbanim.bench import Table
from pbanim.collision.broad import all_pairs, grid_pairs
from pbanim.contact.scenes import sphere_pile
from pbanim.errors import InvalidInput


# ORACLES D18: a uniform grid finds exactly the overlapping pairs all-pairs testing finds, whatever the radii
@settings(max_examples=40, deadline=None)
@given(seed=st.integers(0, 10**6), n=st.integers(2, 120), spread=st.floats(0.1, 10.0), margin=st.floats(0.0, 0.3))
def test_grid_pairs_equal_all_pairs(seed, n, spread, margin):
    rng = np.random.default_rng(seed)
    c = rng.uniform(0.0, spread, (n, 3))
    r = rng.uniform(0.05, 0.5, n)
    g, a = grid_pairs(c, r, margin), all_pairs(c, r, margin)
    assert np.array_equal(g.pairs, a.pairs) and g.method == "grid"


def _pile_contacts_loop(x, r, L, margin):
    """Readable narrow phase of the pile: every sphere against the five planes, then every pair i < j."""
    walls = [((0, 0, 1.0), 0.0), ((1.0, 0, 0), -L), ((-1.0, 0, 0), -L), ((0, 1.0, 0), -L), ((0, -1.0, 0), -L)]
    out = []
    for i in range(len(x)):
        for w, (nrm, d) in enumerate(walls):
            s = float(np.dot(nrm, x[i]) - d - r)
            if s <= margin:
                out.append((i, -1, x[i] - r * np.array(nrm), np.array(nrm), s, w))
    for i in range(len(x)):
        for j in range(i + 1, len(x)):
            dist = float(np.linalg.norm(x[i] - x[j]))
            if dist - 2 * r <= margin:
                nrm = (x[i] - x[j]) / dist
                out.append((i, j, x[j] + r * nrm, nrm, dist - 2 * r, 0))
    return out


# ORACLES D18: the batched sphere–plane and sphere–sphere narrow phase returns the loop's contacts in its order
@pytest.mark.parametrize("seed", [0, 1])
def test_batched_sphere_narrow_phase_equals_the_loop(seed):
    sc = sphere_pile(50, box_half=0.25, seed=seed)
    r, L, margin = sc.info["radius"], sc.info["box_half"], 0.1 * sc.info["radius"]
    rng = np.random.default_rng(seed)
    y = sc.system.state()
    x = np.column_stack([rng.uniform(-L, L, (50, 2)), rng.uniform(0.0, 0.35, 50)])   # a jumble, walls included
    y[:150] = x.ravel()
    A, B, p, nrm, s, keys = sc.detect.arrays(y, None)
    loop = _pile_contacts_loop(x, r, L, margin)
    assert A.size == len(loop) > 60 and np.sum(B < 0) > 10          # sphere–sphere and sphere–wall contacts
    # the batched pairs come sorted (i, j), the loop's too: same contacts in the same order
    for k, (i, j, pt, n_, sep, feat) in enumerate(loop):
        assert (A[k], B[k]) == (i, j) and keys[k] == (i * 51 + j + 1) * 8 + feat
        np.testing.assert_allclose(p[k], pt, rtol=0, atol=1e-15)
        np.testing.assert_allclose(nrm[k], n_, rtol=0, atol=1e-15)
        assert abs(s[k] - sep) <= 1e-15


def _fake(pens, costs, over=()):
    """A runner that returns the made-up runs in turn (per step 1 s, so the budget counts steps × h)."""
    runs = iter(range(len(pens)))

    def runner(h, it, lim):
        k = next(runs)
        return {"pen": pens[k], "cost": costs[k], "drift": 0.0, "per_step": 1.0, "over": k in over,
                "t_reached": h * 10}
    return runner


def test_cheapest_stops_at_the_accuracy_and_at_the_budget():
    tab = Table("t", contact_large.HEADER)
    out = cheapest(_fake([3e-4, 5e-5, 1e-5], [1.0, 2.0, 3.0]), ((0.1, 1), (0.1, 2), (0.1, 3)), tab, ["x", 1])
    assert out["cost"] == 2.0 and len(tab.rows) == 2 and tab.rows[-1][-1] == "yes"      # stopped at the first hit
    tab = Table("t", contact_large.HEADER)
    out = cheapest(_fake([3e-4, 2e-4], [1.0, 2.0], over={1}), ((0.1, 1), (0.1, 2), (0.1, 3)), tab, ["x", 1], limit=15)
    assert out["cost"] == np.inf and out["over"] and (out["best_pen"], out["best_cost"]) == (3e-4, 1.0)
    assert tab.rows[1][-1].startswith("over budget (stopped") and tab.rows[2][-1] == "over budget (not run)"


def test_goal_line_says_when_no_peer_reached_the_accuracy():
    peer = lambda pen, cost: {"cost": np.inf, "best_pen": pen, "best_cost": cost}  # noqa: E731
    g = _goal("g", {"pbanim": {"cost": 2.0, "best_pen": 5e-5, "best_cost": 2.0}, "mujoco": peer(2e-3, 0.5),
                    "pybullet": peer(8e-4, 1.0)}, "note")
    assert g.measured == 4.0 and not g.met and "no peer reached 0.0001 m at any setting swept" in g.line()
    g = _goal("g", {"pbanim": {"cost": 2.0, "best_pen": 5e-5, "best_cost": 2.0},
                    "mujoco": {"cost": 4.0, "best_pen": 9e-5, "best_cost": 4.0}, "pybullet": peer(8e-4, 1.0)}, "n")
    assert g.measured == 0.5 and g.met
    g = _goal("g", {"pbanim": {"cost": np.inf, "best_pen": 3e-4, "best_cost": 1.0}, "mujoco": peer(2e-3, 0.5),
                    "pybullet": None}, "n")
    assert g.skipped


def test_peer_run_stops_over_budget():
    pytest.importorskip("mujoco")
    from pbanim.bench import contact_peers

    S = contact_peers.scene_numbers(sphere_pile(8, box_half=None), 0.5)
    r = contact_peers.settle_scene("mujoco", "pile", S, 1 / 120, 5, solver="cg", budget=1e-9)
    assert r["over"] and r["steps"] == 1 and np.isnan(r["pen"])
    full = contact_peers.settle_scene("mujoco", "pile", S, 1 / 120, 5, solver="cg")
    assert not full["over"] and full["steps"] == 60 and full["pen"] >= 0
    with pytest.raises(InvalidInput, match="solver"):
        contact_peers.settle_scene("pybullet", "pile", S, 1 / 120, 5, solver="cg")
