"""Issue 28: the lean frictionless step of TimeStepping equals the readable step (ORACLES D14), diagnostics only
when asked, and the floor row's hand loop computes what pbanim computes."""

import numpy as np
import pytest

from pbanim.contact.friction import TimeStepping
from pbanim.contact.lean import DENSE_BODIES, lean_applies
from pbanim.contact.scenes import dropped_stack, sphere_pile


def _run(make, solver, lean, t_end=0.3, h=1e-3, **kw):
    sc = make()
    ts = TimeStepping(sc.system, sc.detect, sc.forces, friction=0.0, solver=solver, lean=lean, tol=1e-12, **kw)
    return ts, ts.simulate(t_end, h)


# ORACLES D14: the cheap contact step computes what the readable one computes — with a direct solver (one
# answer) the trajectories agree to roundoff; dense J W Jᵀ (few bodies) and the per-contact Delassus route
@pytest.mark.parametrize("make, solver", [
    (lambda: dropped_stack(1, gap=1e-3, offset=0.0), "lemke"),
    (lambda: dropped_stack(3, offset=0.0), "lemke"),
    (lambda: dropped_stack(3, offset=0.0), "dantzig"),
    (lambda: sphere_pile(DENSE_BODIES + 4), "lemke"),          # above DENSE_BODIES: the Delassus route
    # ORACLES D17: PGS called unchecked (pbanim.lcp.solve.lean_pgs), rotations and quaternions on floats
    (lambda: dropped_stack(1, gap=1e-3, offset=0.0), "pgs"),
    (lambda: dropped_stack(3, offset=0.0), "pgs"),
])
def test_lean_step_equals_readable(make, solver):
    ts, lean = _run(make, solver, True)
    assert lean_applies(ts)
    _, readable = _run(make, solver, False)
    assert lean.diagnostics["contact_count"].max() > 0
    scale = max(1.0, float(np.abs(readable.y).max()))
    # measured: ≤ 6e-17 (stack), 0 (pile); bound a few ulps per step over 300 steps. PGS stops at its tolerance
    # (tol = 1e-12): A equal to roundoff can stop one sweep apart, so its bound is in units of tol (measured
    # 2.5 tol on one box, on three boxes)
    bound = 20 * ts.tol if solver == "pgs" else 1e-13
    assert np.abs(lean.y - readable.y).max() <= bound * scale
    for k in ("contact_count", "max_penetration", "lcp_unconverged"):
        np.testing.assert_allclose(lean.diagnostics[k], readable.diagnostics[k], atol=1e-13)
    np.testing.assert_allclose(lean.diagnostics["normal_impulse_total"], readable.diagnostics["normal_impulse_total"],
                               atol=1e-12)


def test_lean_does_not_apply_with_friction_or_a_plain_detect():
    sc = dropped_stack(2)
    assert not lean_applies(TimeStepping(sc.system, sc.detect, sc.forces, friction=0.5))
    plain = lambda y: sc.detect(y)[0]                                      # noqa: E731 — no raw arrays
    assert not lean_applies(TimeStepping(sc.system, plain, sc.forces))


def test_diagnostics_only_when_asked():
    sc = dropped_stack(2, offset=0.0)
    ts = TimeStepping(sc.system, sc.detect, sc.forces, solver="lemke")
    res = ts.simulate(0.05, 1e-3)
    assert not res.diagnostics.computed                      # nothing computed until read
    assert res.diagnostics["max_penetration"].shape == res.t.shape
    assert res.diagnostics.computed
    bare = ts.simulate(0.05, 1e-3, diagnostics=False)
    assert dict(bare.diagnostics) == {} and np.array_equal(bare.y, res.y)


def test_floor_hand_loop_agrees():
    """The floor row's two sides run the same step (ORACLES D14): final states to PGS tolerance."""
    from pbanim.bench._floor_contact import box_on_ground

    fl = box_on_ground()
    fl.steps = 200
    a, b = fl.pbanim(), fl.hand()
    assert np.abs(a - b).max() <= fl.tol
    assert abs(a[2] - 0.25) < 1e-3                           # landed on the ground, centre at h_z


def test_lean_pgs_failure_is_the_readable_failure():
    """ORACLES D17: a step the lean PGS cannot certify goes to the readable solve, which names the failure
    (one sweep cannot reach 1e-14 on a landing box) — or, accepting unconverged steps, returns the same run."""
    from pbanim.errors import InfeasibleContact

    for lean in (True, False):
        sc = dropped_stack(1, gap=1e-3, offset=0.0)
        ts = TimeStepping(sc.system, sc.detect, sc.forces, friction=0.0, solver="pgs", lean=lean, tol=1e-14,
                          solver_options={"max_iter": 1})
        with pytest.raises(InfeasibleContact, match="pgs"):
            ts.simulate(0.05, 1e-3, diagnostics=False)
    runs = []
    for lean in (True, False):
        sc = dropped_stack(1, gap=1e-3, offset=0.0)
        ts = TimeStepping(sc.system, sc.detect, sc.forces, friction=0.0, solver="pgs", lean=lean, tol=1e-14,
                          solver_options={"max_iter": 1}, accept_unconverged=True)
        runs.append(ts.simulate(0.05, 1e-3))
    assert runs[0].diagnostics["lcp_unconverged"].max() == 1.0
    np.testing.assert_array_equal(runs[0].diagnostics["lcp_unconverged"], runs[1].diagnostics["lcp_unconverged"])
    assert np.abs(runs[0].y - runs[1].y).max() <= 1e-13 * max(1.0, float(np.abs(runs[1].y).max()))
