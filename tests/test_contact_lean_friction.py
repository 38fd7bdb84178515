"""Issue 28 point 5: the lean friction step of TimeStepping equals the readable step (ORACLES D21), and the
stepping loop's Lemke route (lean_lemke) is solve_lcp's."""

import numpy as np
import pytest

from pbanim.contact.friction import TimeStepping
from pbanim.contact.lean_friction import DENSE_BODIES, lean_friction_applies
from pbanim.lcp.solve import lean_lemke, solve_lcp
from pbanim.models.contact import box_on_incline, box_stack, incline_expected


def _incline(angle, lean, t_end=0.1, h=1e-3):
    sc = box_on_incline(angle, 0.5)
    ts = TimeStepping(sc.system, sc.detect, sc.forces, friction=0.5, facets=4, lean=lean)
    return ts, ts.simulate(t_end, h), sc


def _stack(lean, n=3, t_end=0.12, h=1e-3):
    sc = box_stack(n, 1.0, margin=0.02)
    y0 = sc.system.state()
    y0[2:3 * n:3] += 0.005 * (np.arange(n) + 1)
    y0[0:3 * n:3] += 0.02 * np.sin(np.arange(n))
    ts = TimeStepping(sc.system, sc.detect, sc.forces, friction=0.5, facets=4, lean=lean)
    return ts, ts.simulate(t_end, h, y0=y0)


# ORACLES D21: the lean friction step is the readable step with J W Jᵀ and J u as dense products — the same
# trajectory to roundoff. Measured: incline 3e-16 (slide), 1e-17 (stick); three boxes landing 2e-14 over 120 steps
@pytest.mark.parametrize("which", ["stick", "slide", "stack"])
def test_lean_friction_step_equals_readable(which):
    if which == "stack":
        (ts, lean), (_, readable) = _stack(True), _stack(False)
    else:
        angle = np.arctan(0.5) + (0.1 if which == "slide" else -0.1)
        (ts, lean, _), (_, readable, _) = _incline(angle, True), _incline(angle, False)
    assert lean_friction_applies(ts)
    assert lean.diagnostics["contact_count"].max() > 0
    scale = max(1.0, float(np.abs(readable.y).max()))
    assert np.abs(lean.y - readable.y).max() <= 2e-12 * scale
    for k in ("contact_count", "max_penetration", "lcp_unconverged"):
        np.testing.assert_allclose(lean.diagnostics[k], readable.diagnostics[k], atol=1e-12)
    np.testing.assert_allclose(lean.diagnostics["normal_impulse_total"], readable.diagnostics["normal_impulse_total"],
                               rtol=1e-9, atol=1e-12)


def test_lean_friction_keeps_the_incline_law():
    """ORACLES D6 through the lean step: static below tan θ = μ, a = g(sin θ − μ cos θ) above (velocity level:
    the acceleration of the last steps, exact for the sliding box up to the solver's tolerance)."""
    h = 1e-3
    for angle in (np.arctan(0.5) - 0.1, np.arctan(0.5) + 0.1):
        ts, res, sc = _incline(angle, True, t_end=0.05, h=h)
        vd = res.y[7:10].T @ sc.exact["downhill"]
        acc = (vd[-1] - vd[-2]) / h
        assert acc == pytest.approx(incline_expected(angle, 0.5)["acceleration"], abs=1e-6)


def test_lean_friction_applies_only_where_it_can():
    sc = box_stack(2, 1.0)
    assert lean_friction_applies(TimeStepping(sc.system, sc.detect, sc.forces, friction=0.5))
    assert not lean_friction_applies(TimeStepping(sc.system, sc.detect, sc.forces, friction=0.0))
    assert not lean_friction_applies(TimeStepping(sc.system, sc.detect, sc.forces, friction=0.0, solver="pgs"))
    big = box_stack(DENSE_BODIES + 1, 1.0)
    assert not lean_friction_applies(TimeStepping(big.system, big.detect, big.forces, friction=0.5))


def _friction_lcp(seed):
    """A Stewart–Trinkle LCP of a box on a plane (4 contacts, 4 facets), from one readable step."""
    sc = box_on_incline(0.3 + 0.1 * seed, 0.5)
    ts = TimeStepping(sc.system, sc.detect, sc.forces, friction=0.5, facets=4, lean=False)
    ts.simulate(0.003, 1e-3)
    return ts.last.A, ts.last.b, ts.last.f


@pytest.mark.parametrize("seed", [0, 1, 2])
@pytest.mark.parametrize("warm", [False, True])
def test_lean_lemke_is_solve_lcp(seed, warm):
    """The same route, pivots and polish as solve_lcp(..., "lemke"): bit for bit."""
    A, b, f_last = _friction_lcp(seed)
    ws = f_last if warm else None
    got = lean_lemke(A, b, ws, 1e-10)
    ref = solve_lcp(A, b, "lemke", tol=1e-10, warm_start=ws, validate=False)
    assert ref.success and got is not None
    assert np.array_equal(got.f, ref.f)
    assert got.status == ref.status and got.iterations == ref.iterations
    assert got.extra["threshold"] == ref.extra["threshold"]
    assert got.extra.get("warm_start_hit") == ref.extra.get("warm_start_hit")


def test_lean_lemke_hands_back_what_it_cannot_certify():
    assert lean_lemke(np.array([[-1.0]]), np.array([-1.0]), None, 1e-10) is None        # infeasible: a ray
    assert lean_lemke(np.eye(2), np.array([-1.0, np.nan]), None, 1e-10) is None          # not finite
    assert lean_lemke(np.eye(0), np.zeros(0), None, 1e-10) is None                       # nothing to solve
