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


def _split_pair(sc, y, **kw):
    """One step from y with the position correction and one with it never triggered (position_tol 1 m): the same
    velocity solve, so any difference is the correction's."""
    from pbanim.contact.split import SplitStepping

    out = []
    for ptol in (1e-5, 1.0):
        ts = SplitStepping(sc.system, sc.detect, sc.forces, friction=sc.friction, iterations=200, tol=1e-10,
                           position_tol=ptol, **kw)
        out.append((ts.step(0.0, y.copy(), 1 / 60), ts))
    return out


def _deepest(sc, y):
    return float(np.max(sc.detect(y)[0].depth, initial=0.0))


# ORACLES D19: the position correction moves the bodies out of penetration and adds no kinetic energy (the
# momenta are the velocity solve's, P bit for bit); Baumgarte feedback on the same state adds kinetic energy
def test_split_correction_removes_penetration_and_adds_no_kinetic_energy():
    from pbanim.contact.split import SplitStepping

    sc = sphere_pile(3, box_half=0.3)
    s, r = sc.system, sc.info["radius"]
    y = s.state()
    x, _, P, _ = s.unpack(y)
    x[:] = [[0.0, 0.0, r - 3e-3], [0.001, 0.0, 3 * r - 6e-3], [0.0, 0.001, 5 * r - 9e-3]]   # a column, 3 mm into each
    P[:] = [[0.2, 0.0, 0.0], [0.0, -0.1, 0.0], [0.0, 0.0, -0.3]]
    (y_fix, ts), (y_raw, _) = _split_pair(sc, y)
    assert ts.stats["position_steps"] == 1 and _deepest(sc, y) > 2.9e-3 and _deepest(sc, y_raw) > 2.5e-3
    assert _deepest(sc, y_fix) <= 2e-5                     # 1e-5 linearized; measured 1e-5
    assert np.array_equal(y_fix[21:30], y_raw[21:30])      # P: the velocity solve's, untouched
    assert np.allclose(y_fix[30:], y_raw[30:], rtol=0, atol=1e-14)   # L: turned by roundoff (r × n ≈ 0 on a sphere)
    assert s.kinetic_energy(y_fix) == pytest.approx(s.kinetic_energy(y_raw), rel=1e-13)
    baum = SplitStepping(s, sc.detect, sc.forces, friction=sc.friction, iterations=200, tol=1e-10, correction=False)
    assert s.kinetic_energy(baum.step(0.0, y.copy(), 1 / 60)) > 1.5 * s.kinetic_energy(y_fix)


# ORACLES D19: boxes turned by the correction keep their kinetic energy (the spin turned with the body)
def test_split_correction_turns_boxes_without_kinetic_energy():
    from pbanim.contact.scenes import brick_wall
    from pbanim.rigid.quat import quat_from_axis_angle

    sc = brick_wall(3, per_row=2)
    s = sc.system
    y = s.state()
    x, q, P, L = s.unpack(y)
    x[:, 2] -= 4e-3                                        # every brick 3 mm into what is under it
    q[:] = quat_from_axis_angle(np.array([[1.0, 0.3, 0.0]] * 3), np.array([0.004, -0.003, 0.002]))
    L[:] = [[0.01, -0.02, 0.005], [0.0, 0.01, 0.02], [-0.01, 0.0, 0.01]]
    (y_fix, ts), (y_raw, _) = _split_pair(sc, y)
    N = s.N
    turned = np.abs(y_fix[3 * N:7 * N] - y_raw[3 * N:7 * N]).max()
    assert ts.stats["position_steps"] == 1 and turned > 1e-6 and _deepest(sc, y_raw) > 1e-3
    assert _deepest(sc, y_fix) <= 1e-4
    assert np.array_equal(y_fix[7 * N:10 * N], y_raw[7 * N:10 * N])
    assert s.kinetic_energy(y_fix) == pytest.approx(s.kinetic_energy(y_raw), rel=1e-13)    # measured ≤ 1e-16


# ORACLES D19: a pile dropped at h = 1/60 rests within the accuracy of the large-scene benchmark, warm started from
# the last step's impulses (matched by key) or not
def test_split_pile_rests_within_the_accuracy():
    from pbanim.contact.split import SplitStepping

    for warm in (True, False):
        sc = sphere_pile(12, box_half=0.12, margin=0.01)
        ts = SplitStepping(sc.system, sc.detect, sc.forces, friction=sc.friction, iterations=200, tol=1e-4,
                           position_tol=5e-5, warm_start=warm)
        y, pens = sc.system.state(), []
        for k in range(45):
            y = ts.step(k / 60, y, 1 / 60)
            pens.append(ts.last_info["penetration"])
        assert max(pens[30:]) <= contact_large.ACCURACY and ts.stats["position_steps"] > 0
        assert ts.stats["persisted"] > 0 if warm else ts.stats["persisted"] == 0
