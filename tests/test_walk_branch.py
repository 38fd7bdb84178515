"""The push envelope's branched walks equal the pushed walks run from the start (ORACLES F19)."""

import numpy as np
import pytest

from pbanim.control import WALK, Push, simulate_walk
from pbanim.control.walk_branch import simulate_pushes

# pushes at two phases of the 2nd right step (one falls, two recover), and one whose step never comes in 2.4 s
PUSHES = [Push(-150.0, 0.1, 2), Push(100.0, 0.1, 2), Push(60.0, 0.7, 2), Push(30.0, 0.5, 40)]


def _same(a, b):
    return (all(np.array_equal(getattr(a, f), getattr(b, f)) for f in ("t", "q", "qd", "com"))
            and (a.trace, a.fell, a.fall_time, a.fall_cause, a.strikes, a.push_time)
            == (b.trace, b.fell, b.fall_time, b.fall_cause, b.strikes, b.push_time)
            and repr(a.targets) == repr(b.targets))       # repr: the stance hip's NaN target compares equal


@pytest.mark.parametrize("lean", [True, False])
def test_branched_pushes_equal_the_runs_from_the_start(lean):
    # F19: bit for bit, on the lean and on the readable step
    branched = simulate_pushes(WALK, 2.4, 2e-3, PUSHES, servo="stable", record_every=7, lean=lean)
    alone = [simulate_walk(WALK, 2.4, 2e-3, servo="stable", record_every=7, push=p, lean=lean) for p in PUSHES]
    assert [r.fell for r in alone] == [True, False, False, False]   # both outcomes compared
    assert alone[-1].push_time is None and all(r.push_time is not None for r in alone[:-1])
    for p, b, a in zip(PUSHES, branched, alone):
        assert _same(b, a), f"push {p}: the branched walk differs from the pushed walk"


def test_a_wrong_snapshot_is_seen():
    # the comparison can fail: another push's run is not this push's
    branched = simulate_pushes(WALK, 2.4, 2e-3, PUSHES[1:3], servo="stable", record_every=7)
    assert not _same(branched[0], branched[1])
