"""Peer comparisons of ``pbanim bench contact`` (issue 7): PyBullet and MuJoCo rows and the cost goal.

CI does not install the optional extra ``[peers]``: the not-installed path is tested everywhere by
patching the one import check (``contact_peers.have``); the peer runs themselves are skipped without
the engines.
"""

import json

import numpy as np
import pytest

from pbanim.bench import Goal, Report, available, format_report
from pbanim.bench import contact as bench
from pbanim.bench import contact_peers

COST_GOAL = "contact-equal-step-vs-pybullet"
PEER_GOALS = ("contact-equal-step-vs-pybullet", "contact-stack-cost-at-0.0001m-vs-peers",
              "contact-stack-cost-at-1e-06m-vs-peers", "contact-pile-cost-at-0.0001m-vs-peers",
              "contact-pile-cost-at-1e-06m-vs-peers")


def _table(rep: Report, title_start: str):
    return next(t for t in rep.tables if t.title.startswith(title_start))


def _rows(rep: Report, title_start: str) -> dict:
    """Rows by their first cell (scheme)."""
    tab = _table(rep, title_start)
    return {r[0]: dict(zip(tab.header, r)) for r in tab.rows}


def test_skipped_goal_is_never_met_and_says_why():
    g = Goal("x", np.nan, 1.0, "<=", "x", "a note", skipped="pybullet not installed")
    assert not g.met
    assert g.line() == "goal x: not measured (pybullet not installed) (target <= 1x) — a note"
    assert Goal("x", 0.5, 1.0).line().endswith(" met") and not Goal("x", np.nan, 1.0).met


def test_helper_module_is_not_a_benchmark_family():
    assert "contact" in available() and "contact_peers" not in available()


def test_bench_without_peers_skips_with_notes_and_no_fake_goal(monkeypatch):
    # the not-installed path (what CI runs): no peer row, notes say what was skipped, the cost goal is
    # reported as not measured, and no peer function is ever called
    def boom(*args, **kwargs):
        raise AssertionError("a peer ran although it is 'not installed'")

    monkeypatch.setattr(contact_peers, "have", lambda name: False)
    for fn in ("pybullet_stack", "mujoco_stack", "mujoco_pour", "settle_run"):
        monkeypatch.setattr(contact_peers, fn, boom)
    rep = bench.run(quick=True)
    stack, pour = _rows(rep, "10-box stack"), _rows(rep, "20 spheres")
    assert not any("peer" in k for k in list(stack) + list(pour))
    assert any(n.startswith("pybullet not installed") for n in rep.notes)
    assert any(n.startswith("mujoco not installed") and "stack" in n for n in rep.notes)
    assert any(n.startswith("mujoco not installed") and "sphere-pour" in n for n in rep.notes)
    goal = next(g for g in rep.goals if g.id == COST_GOAL)
    assert goal.skipped == "pybullet not installed" and not goal.met
    line = next(ln for ln in format_report(rep).splitlines() if ln.startswith(f"goal {COST_GOAL}:"))
    assert "not measured (pybullet not installed)" in line and not line.rstrip().endswith(("met", "missed"))
    js = next(g for g in rep.to_json()["goals"] if g["id"] == COST_GOAL)
    assert js["met"] is False and js["skipped"] == "pybullet not installed"
    # every peer goal says why it was not measured; the other goals are measured
    assert all(g.skipped and not g.met for g in rep.goals if g.id in PEER_GOALS)
    assert all(np.isfinite(g.measured) for g in rep.goals if g.id not in PEER_GOALS)
    # the work-precision tables hold pbanim rows only, each with a finite cost and accuracy
    for scene in ("10-box stack dropped", "20 rigid spheres"):
        tab = _table(rep, f"work-precision for contact: {scene}")
        assert tab.rows and all(r[0] == "pbanim" and np.isfinite(r[4]) and np.isfinite(r[7]) for r in tab.rows)


@pytest.fixture(scope="module")
def peer_report():
    pytest.importorskip("pybullet")
    pytest.importorskip("mujoco")
    return bench.run(quick=True)


def test_bench_with_peers_has_rows_and_the_cost_goal(peer_report):
    rep = peer_report
    stack, pour = _rows(rep, "10-box stack"), _rows(rep, "20 spheres")
    for name in ("PyBullet (peer)", "MuJoCo (peer)"):
        row = stack[name]
        assert row["cost per step (ms)"] > 0 and row["status"] == "ok"
        assert np.isclose(row["cost per sim. second (s)"], row["cost per step (ms)"])      # h = 1 ms
        # a stack at rest: the engine's boxes stay put to well under a box height, speeds stay small
        assert 0 <= row["top drift (m)"] < 0.05 and 0 <= row["max penetration (m)"] < 0.05
        assert row["jitter max|v| (m/s)"] < 1.0
    mj = pour["MuJoCo (peer)"]
    assert mj["cost per step (ms)"] > 0 and mj["status"] == "ok"
    assert mj["steps"] == pour["pbanim (velocity level, pgs)"]["steps"]
    # the equal-step goal is the ratio of the work-precision table's numbers at h = 1e-3, measured in this run
    goal = next(g for g in rep.goals if g.id == COST_GOAL)
    tab = _table(rep, "work-precision for contact: 10-box stack dropped")
    rows = [dict(zip(tab.header, r)) for r in tab.rows if r[2] == 1e-3]
    ours = next(r for r in rows if r["engine"] == "pbanim" and r["solver"] == "active_set")
    theirs = next(r for r in rows if r["engine"] == "pybullet" and r["solver"].endswith("50 it."))
    assert goal.measured == pytest.approx(ours["cost per step (ms)"] / theirs["cost per step (ms)"], rel=1e-9)
    assert all(not g.skipped for g in rep.goals)
    assert not any("not installed" in n for n in rep.notes)
    json.dumps(rep.to_json(), default=float)           # the peer rows serialize for --json


def test_mujoco_scenes_are_the_pbanim_models():
    # the MJCF built in code carries box_stack(10, 1.0)'s and sphere_pour(n)'s geometry, masses and start
    mujoco = pytest.importorskip("mujoco")
    from pbanim.models.contact import box_stack, sphere_pour

    sc = box_stack(10, 1.0)
    half, masses, x0 = contact_peers._stack_scene(10)
    np.testing.assert_array_equal(half, sc.half_extents)
    m = mujoco.MjModel.from_xml_string(contact_peers._mjcf_stack(half, masses, x0, 1e-3))
    assert m.opt.timestep == 1e-3 and m.nbody == 11
    np.testing.assert_allclose(m.body_mass[1:], sc.system.mass, rtol=1e-12)
    np.testing.assert_allclose(m.body_pos[1:], sc.system.unpack(sc.system.state())[0], atol=1e-15)
    np.testing.assert_allclose(m.geom_size[1:], np.tile(sc.half_extents, (10, 1)))
    sp = sphere_pour(7)
    x = sp.system.state()[:21].reshape(7, 3)
    m = mujoco.MjModel.from_xml_string(contact_peers._mjcf_pour(x, 0.05, 0.3, 1.0, 4e-3))
    assert m.ngeom == 5 + 7 and np.all(m.geom_condim == 1)                    # frictionless everywhere
    np.testing.assert_allclose(m.body_pos[1:], x, atol=1e-15)
    np.testing.assert_allclose(m.geom_size[5:, 0], sp.exact["radius"])
    assert np.allclose(np.abs(m.geom_pos[1:5, :2]).max(axis=1), sp.exact["box_half"])   # the four walls


def test_pybullet_stack_measures_the_same_stack():
    pytest.importorskip("pybullet")
    out = contact_peers.pybullet_stack(3, 0.02, 1e-3)
    assert out["steps"] == 20 and out["per_step"] > 0
    assert 0 <= out["drift"] < 0.01 and 0 <= out["penetration"] < 0.01 and out["jitter"] < 1.0
    with pytest.raises(ValueError, match="positive"):
        contact_peers.pybullet_stack(3, 0.02, -1e-3)


def test_contact_large_smoke():
    """``pbanim bench contact_large --quick`` runs and prints its goal lines (the slope, the pile and the wall
    against the peers, or "not measured" without them)."""
    from pbanim.bench import contact_large, format_report

    rep = contact_large.run(quick=True)
    ids = [g.id for g in rep.goals]
    assert ids == ["contact-large-slope", "contact-large-60-spheres-vs-peers", "contact-large-wall-20-vs-peers"]
    text = format_report(rep)
    assert all(f"goal {i}:" in text for i in ids)
    grow = rep.tables[0]
    assert [r[0] for r in grow.rows] == list(contact_large.QUICK_COUNTS) and all(r[2] > 0 for r in grow.rows)
