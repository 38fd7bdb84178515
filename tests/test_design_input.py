"""Chapter 10, issue 27: what each argument must be, declared once (pbanim.contracts), and the defects the
declarations and the fuzz found (ORACLES G3: invalid input gives a named error)."""

import time

import numpy as np
import pytest

from pbanim.collision import Plane, Sphere
from pbanim.design import (DesignBody, DesignScene, UnknownParameter, apply_impact, flight_map, left_jacobian,
                           simulate)
from pbanim.design.control import SingularMetric, min_norm_update
from pbanim.design.impact import Features
from pbanim.errors import InvalidInput, NonFiniteResult, StepLimitExceeded


def ball(vz=0.0):
    return DesignScene([DesignBody(Sphere(0.1), position=[0, 0, 1.1], velocity=[0.5, 0, vz])], [Plane([0, 0, 1])],
                       gravity=[0, 0, -10.0], restitution=0.5)


def test_names_and_u_are_checked_against_the_scene():
    s = ball()
    with pytest.raises(InvalidInput, match="simulate: names must be a list"):       # was a bare TypeError
        simulate(s, 1.0, 5)
    with pytest.raises(UnknownParameter, match="'x7' does not exist"):
        simulate(s, 1.0, ["x0", "x7"])
    with pytest.raises(InvalidInput, match=r"simulate: u must be a float array of shape \(6,\)"):
        simulate(s, 1.0, ["x0", "v0"], [0.0, 0.0, 1.0])
    with pytest.raises(InvalidInput, match="values: names must be .*a name repeats"):
        s.values(["x0", "x0"], np.zeros(6))
    with pytest.raises(InvalidInput, match="mass0 must be positive"):              # a value inside u: kept
        s.values(["mass0"], [0.0])


def test_bodies_refuse_what_is_not_a_body():
    with pytest.raises(InvalidInput, match="DesignBody: mass must be a finite number > 0, got '1'"):
        DesignBody(Sphere(0.1), mass="1")                                         # was accepted as a string
    with pytest.raises(InvalidInput, match="orientation must be .*a zero quaternion has no orientation"):
        DesignBody(Sphere(0.1), orientation=[0, 0, 0, 0])
    with pytest.raises(InvalidInput, match="inertia violates the triangle inequality"):
        DesignBody(Sphere(0.1), inertia=[1.0, 1.0, 3.0])
    with pytest.raises(InvalidInput, match="restitution must be a finite number >= 0 and <= 1, got 1.5"):
        DesignScene([DesignBody(Sphere(0.1))], restitution=1.5)


def test_a_long_run_is_refused_before_it_starts():
    # t_end = 10⁴ s at h = 0.005 used to start 2·10⁶ steps (minutes); the cap is known before the first step
    t = time.perf_counter()
    with pytest.raises(StepLimitExceeded, match="max_steps = 100000"):
        simulate(ball(), 1e4, ["x0"], sensitivities=False)
    assert time.perf_counter() - t < 1.0
    with pytest.raises(InvalidInput, match="t_end must be after t0 = 1"):
        simulate(ball(), 0.5, ["x0"], t0=1.0)


def test_overflow_is_named_not_nan():
    # left_jacobian and flight_map returned NaN for a huge angle or flight time
    with pytest.raises(NonFiniteResult, match="left_jacobian"):
        left_jacobian([1e300, 0.0, 0.0])
    tr = simulate(ball(), 0.1, ["x0"])
    with pytest.raises(NonFiniteResult, match="flight_map"):
        flight_map(tr.model, tr.y[0], None, 1e300)
    with pytest.raises(NonFiniteResult, match="min_norm_update"):
        min_norm_update(np.array([[1e300, 1e300], [1e-300, 1e300]]), np.array([1e300, -1e300]),
                        np.array([[1e-200, 0.0], [0.0, 1e-200]]))


def test_trajectory_readers_name_their_arguments():
    tr = simulate(ball(), 0.5, ["x0"], times=[0.25])
    with pytest.raises(InvalidInput, match=r"position: i must be an index in 0 … 0, got 1"):
        tr.position(1, 0.25)
    with pytest.raises(InvalidInput, match="t must be an output time of this trajectory.*got 0.3"):
        tr.position(0, 0.3)


def test_a_separating_feature_gets_no_impulse():
    # apply_impact on a contact that separates left the state alone but gave its tangents the derivative of a
    # negative (pulling) impulse: state and derivative disagreed; now neither changes
    s = DesignScene([DesignBody(Sphere(0.1), position=[0, 0, 0.1], velocity=[0.5, 0, 2.0])], [Plane([0, 0, 1])],
                    gravity=[0, 0, -10.0])
    tr = simulate(s, 0.1, ["x0", "v0", "restitution"], times=[0.0])
    y, T = tr.outputs[0.0]
    y1, T1, imp, dtau = apply_impact(tr.model, Features(s), 0, 0.0, y, T, np.array([[0, 0, 1.0]]),
                                     np.zeros((7, 1, 3)), 0.5, np.r_[np.zeros(6), 1.0])
    assert np.array_equal(y1, y) and np.array_equal(T1, T) and not np.any(dtau)
    assert imp.speed == -2.0 and imp.impulse == 0.0
    with pytest.raises(InvalidInput, match="normals must be .*unit rows"):
        apply_impact(tr.model, Features(s), 0, 0.0, y, T, np.array([[0, 0, 2.0]]), None, 0.5, None)


def test_min_norm_update_checks_its_shapes_and_metric():
    # ORACLES H6 (G3)
    with pytest.raises(InvalidInput, match=r"r must be a float array of shape \(m,\) \(m = 2\)"):
        min_norm_update(np.eye(2), np.ones(3))
    with pytest.raises(SingularMetric, match="M must be symmetric"):
        min_norm_update(np.eye(2), np.ones(2), np.array([[1.0, 0.5], [0.0, 1.0]]))


def test_shooting_helpers_name_what_they_cannot_compute():
    # clearance returned NaN for θ = 1e300, states_from_sketch NaN for a node far from the sketch, and
    # output_vector raised a bare IndexError for a reference list shorter than the outputs
    from pbanim.design.check import output_vector
    from pbanim.design.multiple import states_from_sketch
    from pbanim.design.shooting import clearance

    s = ball()
    with pytest.raises(NonFiniteResult, match="clearance"):
        clearance(s, [0.0, 0.0, 1.0], [1e300, 0.0, 0.0])
    sketch = [(0.1 * k, [0.0, 0.0, 1.0 - 0.05 * k * k]) for k in range(5)]
    with pytest.raises(NonFiniteResult, match="states_from_sketch"):
        states_from_sketch(s, sketch, [1e300], 0.2)
    tr = simulate(s, 0.5, ["x0"], times=[0.25])
    with pytest.raises(InvalidInput, match="reference must hold one quaternion"):
        output_vector(tr, [(0, 0.25, "orientation"), (0, 0.5, "orientation")], [[1.0, 0.0, 0.0, 0.0]])
