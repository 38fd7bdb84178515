"""Chapter 10, issue 27: results certify themselves. A ball whose bounces die out rests on the floor at the
Zeno time (ORACLES D1) instead of sinking through it; tangent touches are reported (H4); every trajectory
certifies that no recorded state lies inside an obstacle; an edit reports success only on a certified
trajectory (H5)."""

import warnings

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

from pbanim.collision import Box, Plane, Sphere
from pbanim.design import (DesignBody, DesignScene, GrazingImpactWarning, PenetrationError, RestingContactError,
                           UncertifiedTrajectory, simulate)
from pbanim.design.check import analytic_jacobian, fd_jacobian
from pbanim.design.control import edit, position_goal
from pbanim.rigid import quat_from_axis_angle

G, R = 10.0, 0.1


def dropped(h0=1.0, eps=0.5, vx=0.0, normal=(0.0, 0.0, 1.0)):
    b = DesignBody(Sphere(R), position=[0.0, 0.0, h0 + R], velocity=[vx, 0.0, 0.0])
    return DesignScene([b], [Plane(list(normal))], gravity=[0.0, 0.0, -G], restitution=eps)


def quiet(f, *a, **kw):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", GrazingImpactWarning)
        return f(*a, **kw)


@pytest.mark.parametrize("flight", ["exact", "rk4"])
@pytest.mark.parametrize("eps", [0.0, 0.5, 0.8])
def test_ball_comes_to_rest_at_the_zeno_time(flight, eps):
    # ORACLES D1: impact k at speed ε^k √(2gh₀), bounces end at t∞ = √(2h₀/g)(1 + ε)/(1 − ε); after t∞ the
    # ball rests on the floor (it used to sink: z(5) = −67 m for ε = 0.5, with differentiable=True)
    h0, T = 1.0, 5.0
    tr = simulate(dropped(h0, eps, vx=0.3), T, ["x0", "v0", "restitution"], h=0.01, flight=flight)
    t_inf = np.sqrt(2 * h0 / G) * (1 + eps) / (1 - eps)
    v1 = np.sqrt(2 * G * h0)
    speeds = np.array([i.speed for i in tr.impacts])
    assert np.abs(speeds / (v1 * eps ** np.arange(len(speeds))) - 1).max() < 1e-9        # measured 3e-11
    (rest,) = tr.rests
    assert abs(rest.zeno_time - t_inf) < 1e-9 * t_inf                                       # measured 2e-14
    assert rest.t <= t_inf * (1 + 1e-12) and t_inf - rest.t <= 2 * 1e-3 / (G * (1 - eps)) + 1e-12  # bounces dropped
    assert abs(tr.position(0, T)[2] - R) < 1e-12 and abs(tr.velocities(0, T)[0][2]) < 1e-12
    assert tr.y[:, 2].min() > R - 1e-12 and tr.certified and tr.clearance > -1e-12
    # the resting derivative: normal rows zero, the frictionless slide x = x₀ + v₀ t untouched
    assert tr.differentiable and any("resting derivative" in n for n in tr.notes)
    J = tr.d_position(0, T)
    assert np.abs(J[2]).max() < 1e-12
    assert abs(J[0, 0] - 1.0) < 1e-12 and abs(J[0, 3] - T) < 1e-9                       # ∂x/∂x₀, ∂x/∂v₀ₓ


@settings(max_examples=20, deadline=None)
@given(st.floats(0.05, 2.0), st.floats(0.0, 0.9), st.floats(-2.0, 2.0))
def test_property_never_below_the_floor_and_rests_after_the_zeno_time(h0, eps, vx):
    # ORACLES D1 (hypothesis): every recorded state above the floor; after t∞ the ball lies on it, at rest
    t_inf = np.sqrt(2 * h0 / G) * (1 + eps) / (1 - eps)
    T = t_inf + 0.5
    tr = quiet(simulate, dropped(h0, eps, vx), T, ["x0", "v0"], h=0.02, sensitivities=False, max_impacts=400)
    assert tr.y[:, 2].min() > R - 1e-12 and tr.certified
    assert abs(tr.position(0, T)[2] - R) < 1e-12 and abs(tr.velocities(0, T)[0][2]) < 1e-12
    assert abs(tr.rests[0].zeno_time - t_inf) < 1e-9 * (1 + t_inf)
    assert abs(tr.position(0, T)[0] - vx * T) < 1e-9                                     # frictionless slide


def test_ball_rests_and_slides_down_an_incline():
    # a resting sphere slides without friction: gap 0 at every recorded state, acceleration g sin α down the
    # slope; the resting derivative equals Richardson differences of S (ORACLES D1, H2)
    a = 0.3
    s = dropped(0.5, 0.3, normal=(-np.sin(a), 0.0, np.cos(a)))
    T = 2.0
    tr = simulate(s, T, ["x0", "v0"], times=[1.5, 1.8], h=0.01)
    n = np.array([-np.sin(a), 0.0, np.cos(a)])
    assert tr.rests and tr.rests[0].t < 1.5
    after = tr.t > tr.rests[0].t
    assert np.abs(tr.y[after, :3] @ n - R).max() < 1e-12
    dv = (tr.velocities(0, 1.8)[0] - tr.velocities(0, 1.5)[0]) / 0.3
    g_t = np.array([0.0, 0.0, -G]) - n * (n @ [0.0, 0.0, -G])
    assert np.abs(dv - g_t).max() < 1e-9                                    # |g_t| = g sin α; measured 2e-15
    outs = [(0, T, "position")]
    A = analytic_jacobian(tr, outs)
    F = fd_jacobian(s, ["x0", "v0"], None, T, outs, delta=1e-5)
    assert np.abs(A - F).max() < 1e-6 * max(1.0, np.abs(F).max())                          # measured 3e-10


def test_box_coming_to_rest_is_a_named_error_not_a_sinking_box():
    # resting contact of a box is not in the design model: a named error (it used to end 47 m below the floor)
    b = DesignBody(Box([0.2, 0.15, 0.1]), mass=1.3, position=[0, 0, 1.0], orientation=quat_from_axis_angle([1, 2, 3], 0.7),
                   velocity=[1.0, 0.3, 2.0], angular_velocity=[3.0, -2.0, 4.0])
    s = DesignScene([b], [Plane([0, 0, 1])], restitution=0.0)
    with pytest.raises(RestingContactError, match="come to rest"):
        quiet(simulate, s, 4.0, ["x0"])
    # an edit started there reports the failure, never raises it
    res = quiet(edit, s, ["x0"], None, [position_goal(0, 4.0, [0.0, 0.0, 0.1])], 4.0)
    assert not res.success and res.residual == np.inf and "certified" in res.message
    assert issubclass(RestingContactError, UncertifiedTrajectory)


def test_edit_below_the_floor_is_unreachable():
    # ORACLES H5: with ε = 0 the ball lies on the floor after its impact; a target 3 m below the floor used to be
    # "met" (success True, residual 2e-11: the ball sank to it); now it is unreachable, and says so
    s = dropped(1.0, 0.0)
    res = edit(s, ["x0", "v0"], None, [position_goal(0, 2.0, [0.0, 0.0, -3.0])], 2.0, h=0.02)
    assert not res.success and res.residual >= 3.0 + R - 1e-9
    assert res.trajectory.certified and res.trajectory.position(0, 2.0)[2] >= R - 1e-12


@pytest.mark.parametrize("flight", ["exact", "rk4"])
def test_tangent_touches_are_reported(flight):
    # ORACLES H4: a ball rising exactly to a ceiling (apex at t = 0.4), a sphere passing another at exactly the
    # sum of the radii (t = 1), a ball lying on a plane in zero gravity: S is not differentiable — a warning, a
    # flag, the touch (the last two used to pass silently with differentiable=True)
    up = DesignScene([DesignBody(Sphere(R), position=[0, 0, 1.1], velocity=[0, 0, 4.0])], [Plane([0, 0, -1], offset=-2.0)],
                     gravity=[0, 0, -G])
    passing = DesignScene([DesignBody(Sphere(R), position=[0, 0, 0], velocity=[1.0, 0, 0]),
                           DesignBody(Sphere(R), position=[1.0, 2 * R, 0])], [], gravity=[0, 0, 0])
    lying = DesignScene([DesignBody(Sphere(R), position=[0, 0, R], velocity=[1.0, 0, 0])], [Plane([0, 0, 1])],
                        gravity=[0, 0, 0])
    for scene, t_touch in ((up, 0.4), (passing, 1.0), (lying, 0.0)):
        with pytest.warns(GrazingImpactWarning, match="not differentiable"):
            tr = simulate(scene, 1.5, ["x0"], h=0.007, flight=flight)
        assert not tr.differentiable
        hits = [i.t for i in tr.touches + tr.impacts if i.grazing]
        assert hits and abs(hits[0] - t_touch) < 1e-6


@pytest.mark.parametrize("h", [0.005, 0.007])
def test_an_exact_touch_is_grazing_whatever_graze_speed_says(h):
    # ORACLES H4: the apex meets the ceiling exactly (a double root: the located impact has a roundoff speed
    # of 4e-8 m/s, or none is located); graze_speed = 0 does not hide it
    up = DesignScene([DesignBody(Sphere(R), position=[0, 0, 1.1], velocity=[0, 0, 4.0])], [Plane([0, 0, -1], offset=-2.0)],
                     gravity=[0, 0, -G])
    for flight in ("exact", "rk4"):
        tr = quiet(simulate, up, 1.0, ["x0"], h=h, flight=flight, graze_speed=0.0)
        assert not tr.differentiable


def test_touching_and_approaching_at_the_start_is_an_impact():
    # a ball starting on the floor moving into it used to fly through (z(1) = −5.9 m): an impact at t0 now
    s = DesignScene([DesignBody(Sphere(R), position=[0, 0, R], velocity=[1.0, 0, -1.0])], [Plane([0, 0, 1])],
                    gravity=[0, 0, -G], restitution=0.8)
    for flight in ("exact", "rk4"):
        tr = quiet(simulate, s, 1.0, ["x0"], flight=flight)
        assert tr.impacts[0].t == 0.0 and abs(tr.impacts[0].speed - 1.0) < 1e-12
        assert tr.y[:, 2].min() > R - 1e-12 and not tr.differentiable


def test_rk4_finds_a_sphere_passed_within_one_step():
    # two spheres overlap for 0.035 s inside one 0.05 s step: the RK4 path used to fly through (no impact);
    # the minimum of the gap along the step finds the impact the closed form finds
    s = DesignScene([DesignBody(Sphere(R), position=[0.3, 0, 0], velocity=[10.0, 0, 0]),
                     DesignBody(Sphere(R), position=[1.0, R, 0])], [], gravity=[0, 0, 0])
    ex = simulate(s, 0.2, ["x0"], h=0.05, flight="exact")
    rk = simulate(s, 0.2, ["x0"], h=0.05, flight="rk4")
    assert len(rk.impacts) == len(ex.impacts) == 1
    assert abs(rk.impacts[0].t - ex.impacts[0].t) < 1e-12                                # measured 0
    assert np.abs(rk.position(0, 0.2) - ex.position(0, 0.2)).max() < 1e-12


def test_the_certificate(monkeypatch):
    # a run started inside the floor (allowed for shooting iterates) is flagged, not certified; a ball that
    # could not rest (resting switched off by force) sinks, and the certificate refuses the run by name
    s = dropped(1.0, 0.5)
    tr = simulate(s, 0.5, ["x0"], [0.0, 0.0, -0.5], check_start=False)
    assert not tr.certified and tr.clearance < -0.5 and any("not certified" in n for n in tr.notes)
    import pbanim.design.rest as rest

    monkeypatch.setattr(rest.ContactState, "_start_rest", lambda self, *a: None)
    with pytest.raises(PenetrationError, match="inside an obstacle"):
        quiet(simulate, dropped(1.0, 0.0), 2.0, ["x0"])
