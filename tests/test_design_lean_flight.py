"""One body's free flight on floats (pbanim.design.lean_flight) against the readable numpy code.

Each test cites its oracle from ORACLES.md section H; tolerances are in ulps of the quantity compared.
"""

import sys

import numpy as np
from pbanim.collision import Box, Plane, Sphere
from pbanim.contracts import unchecked
from pbanim.design import DesignBody, DesignScene, simulate
from pbanim.design.flight import FlightModel, flight_rhs
from pbanim.design.impact import Features, gaps
from pbanim.design.lean_flight import one_body_gaps, one_body_rhs
from pbanim.design.rest import gap_rates
from pbanim.rigid import quat_from_axis_angle

EPS = np.finfo(float).eps


def _model(W, Iinv, N=1):
    return FlightModel(N, np.full(N, W), np.full(N, 1.0 / W), np.tile(Iinv, (N, 1)), np.array([0.0, 0.0, -9.81]),
                       np.zeros((1, N)), np.zeros((1, N)), np.zeros((1, N, 3)))


def _states(rng, k):
    y = rng.standard_normal((k, 13)) * rng.uniform(0.1, 10.0, (k, 1))
    y[:, 3:7] /= np.linalg.norm(y[:, 3:7], axis=1)[:, None] * rng.uniform(0.999, 1.001, (k, 1))
    return y


def test_one_body_rhs_is_the_readable_rhs():
    # ORACLES H10: the same products in numpy's orders: a few ulps at most on any build (measured bit for bit
    # on 20 000 states); ẋ, Ṗ, L̇ exactly
    rng = np.random.default_rng(1)
    readable = unchecked(flight_rhs)
    for _ in range(40):
        model = _model(rng.uniform(0.2, 3.0), rng.uniform(0.1, 10.0, 3))
        f = one_body_rhs(model)
        assert one_body_rhs(model) is f                      # made once per model
        for y in _states(rng, 50):
            a, b = f(0.0, y), readable(model, y)
            np.testing.assert_array_equal(a[[0, 1, 2, 7, 8, 9, 10, 11, 12]], b[[0, 1, 2, 7, 8, 9, 10, 11, 12]])
            assert np.abs(a - b).max() <= 8 * EPS * np.abs(b).max()


def test_one_body_rhs_refuses_more_bodies_and_overflows_as_the_readable_one():
    # ORACLES H10: two bodies keep the readable f; a derivative that overflows has the readable f's inf and NaN
    # entries (the run's finiteness check names it)
    assert one_body_rhs(_model(1.0, np.ones(3), N=2)) is None
    y = np.zeros(13)
    y[3], y[10:] = 1.0, 1e300
    model = _model(1.0, np.array([1e10, 1.0, 2.0]))
    with np.errstate(over="ignore", invalid="ignore"):
        a, b = one_body_rhs(model)(0.0, y), unchecked(flight_rhs)(model, y)
    assert not np.isfinite(a).all()
    np.testing.assert_array_equal(a, b)


def test_one_body_gaps_and_rates_are_the_readable_ones():
    # ORACLES H10: a box's eight vertices on two planes: gaps to a few ulps (measured bit for bit), ġ to a few
    # ulps of its terms (|v| + |ω| |s|)
    s = DesignScene([DesignBody(Box([0.2, 0.15, 0.1]), position=[0, 0, 1.0])],
                    [Plane([0, 0, 1]), Plane([-0.6, 0, 0.8], offset=-2.0)])
    feat = Features(s)
    nrm = np.array([p.normal for p in s.planes])
    rng = np.random.default_rng(2)
    for _ in range(20):
        model = _model(rng.uniform(0.2, 3.0), rng.uniform(0.1, 10.0, 3))
        gap, rate = one_body_gaps(feat, model, nrm)
        for y in _states(rng, 20):
            g = gaps(feat, y, 1, nrm)
            assert np.abs(gap(y) - g).max() <= 8 * EPS * (np.abs(y[:3]).max() + 2.0 + 0.2)
            d = gap_rates(feat, model, y, nrm, np.zeros((1, 3)))[0]
            scale = model.W[0] * np.abs(y[7:10]).max() + np.abs(model.Iinv).max() * np.abs(y[10:]).max() * 0.2
            assert np.abs(rate(y) - d).max() <= 32 * EPS * scale


def test_one_body_gaps_refuse_sphere_pairs():
    # ORACLES H10: two spheres (a pair feature) keep the readable gaps
    s = DesignScene([DesignBody(Sphere(0.1), position=[0, 0, 1.0]), DesignBody(Sphere(0.1), position=[1, 0, 1.0])],
                    [Plane([0, 0, 1])])
    model = _model(1.0, np.ones(3), N=2)
    assert one_body_gaps(Features(s), model, np.array([[0.0, 0.0, 1.0]])) is None


def test_tumbling_box_run_equals_the_readable_run(monkeypatch):
    # ORACLES H10, H2: the derivative figure's box through two impacts, S(t, u) with the lean f and gaps against
    # the readable ones: the same impacts, positions to a few ulps × steps (measured bit for bit)
    b = DesignBody(Box([0.2, 0.15, 0.1]), mass=1.3, position=[0, 0, 1.0],
                   orientation=quat_from_axis_angle([1, 2, 3], 0.7), velocity=[1.0, 0.3, 2.0],
                   angular_velocity=[3.0, -2.0, 4.0])
    scene = DesignScene([b], [Plane([0, 0, 1])], restitution=0.6)
    lean = simulate(scene, 0.68, ["v0", "omega0"], times=[0.68], sensitivities=False, warn=False)
    import pbanim.design.lean_flight as lf
    monkeypatch.setattr(lf, "one_body_rhs", lambda model: None)
    monkeypatch.setattr(sys.modules["pbanim.design.simulate"], "one_body_gaps", lambda *a: None)
    readable = simulate(scene, 0.68, ["v0", "omega0"], times=[0.68], sensitivities=False, warn=False)
    assert len(lean.impacts) == len(readable.impacts) == 2
    assert np.abs(np.array([i.t for i in lean.impacts]) - [i.t for i in readable.impacts]).max() <= 1e-12
    steps = len(readable.t)
    assert np.abs(lean.positions(0) - readable.positions(0)).max() <= 8 * EPS * steps
    assert np.abs(lean.position(0, 0.68) - readable.position(0, 0.68)).max() <= 8 * EPS * steps
