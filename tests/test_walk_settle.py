"""A pushed run stopped once it has recovered has the outcome of its full run (ORACLES F6, F19)."""

import numpy as np

from pbanim.control import WALK, Push
from pbanim.control.biped import BIPED_JOINTS
from pbanim.control.walk_branch import simulate_pushes

# the 2nd right step pushed at phase 0.1: −150 N s falls, +100 N s recovers (tests/test_walk_branch.py)
PUSHES = [Push(-150.0, 0.1, 2), Push(100.0, 0.1, 2)]
T_END, H = 4.0, 2e-3


def test_settled_runs_keep_the_outcome_and_are_the_full_runs_up_to_their_stop():
    full = simulate_pushes(WALK, T_END, H, PUSHES, servo="stable", record_every=5)
    short = simulate_pushes(WALK, T_END, H, PUSHES, servo="stable", record_every=5, settle=6)
    assert [r.fell for r in full] == [True, False]
    assert [r.fell for r in short] == [r.fell for r in full]
    assert all(r.settled is None for r in full)
    fallen, (rec_full, rec) = short[0], (full[1], short[1])
    # the fallen run never reached 6 strikes after its push: it is the full run, bit for bit
    assert fallen.settled is None and fallen.fall_time == full[0].fall_time
    assert np.array_equal(fallen.q, full[0].q) and fallen.strikes == full[0].strikes
    # the recovered run stopped at its 6th strike after the push, torso upright, before t_end ...
    after = [t for t, _ in rec.strikes if t > rec.push_time]
    assert rec.settled is not None and rec.settled < T_END - 0.1
    assert len(after) == 6 and after[-1] == rec.settled
    assert abs(rec.q[-1, BIPED_JOINTS["torso"]]) <= 0.5
    # ... and everything it recorded is the full run's (the same steps, bit for bit)
    k = rec.t.size
    assert k < rec_full.t.size
    assert np.array_equal(rec.t, rec_full.t[:k]) and np.array_equal(rec.q, rec_full.q[:k])
    assert rec.strikes == rec_full.strikes[:len(rec.strikes)] and rec.push_time == rec_full.push_time


def test_five_strikes_decide_the_late_fall_that_four_strikes_miss():
    # ORACLES F26: −120 N s at phase 0.9 of the 4th right step strikes four times upright after its push, then
    # falls; settle=4 stops it as recovered, settle=5 (the chapter's figure) keeps the fall of the full run
    push = [Push(-120.0, 0.9, 4)]
    full = simulate_pushes(WALK, 4.5, H, push, servo="stable", record_every=50)[0]
    five = simulate_pushes(WALK, 4.5, H, push, servo="stable", record_every=50, settle=5)[0]
    four = simulate_pushes(WALK, 4.5, H, push, servo="stable", record_every=50, settle=4)[0]
    assert full.fell and len([t for t, _ in full.strikes if t > full.push_time]) == 4
    assert five.fell and five.settled is None and five.fall_time == full.fall_time
    assert not four.fell and four.settled is not None
