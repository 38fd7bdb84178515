"""Chapter 10, issue 30, point 4: infeasible sketches. fit_sketch returns the simulated motion nearest the
sketch in E = Σ|x(tᵢ) − pᵢ|², its residual, and the parts no motion can follow, with the reason read from
the sketch's own kinematics — never an exception, never a success for a sketch it does not follow
(ORACLES L2 for the stepped S it fits)."""

import numpy as np

from pbanim.collision import Box, Plane, Sphere
from pbanim.design import DesignBody
from pbanim.design.stepped import ContactScene
from pbanim.design.stepped_run import simulate_contact
from pbanim.design.stepped_sketch import fit_sketch

G = 9.81
T = np.linspace(0.05, 0.4, 8)


def box():
    return ContactScene(DesignBody(Box([0.2, 0.1, 0.05]), position=[0, 0, 0.05], velocity=[0.5, 0, 0]),
                        [Plane()], friction=0.3)


def test_a_ball_that_rises_after_losing_contact_gets_the_nearest_flight_and_a_report():
    # flying from 1 m, the sketch turns upward at 40 m/s² from t = 0.25 s: no motion follows; the fit is a
    # real flight (its final state replays), its E is below the sketch's start's, and the report names the
    # flight with a ≠ g in the missed interval
    scene = ContactScene(DesignBody(Sphere(0.1), position=[0, 0, 1.0], velocity=[1.0, 0, 0]), [Plane()])
    P = np.stack([T, 0 * T, 1.0 - 0.5 * G * T ** 2], axis=1)
    late = T > 0.25
    P[late, 2] = P[~late][-1, 2] + 20.0 * (T[late] - T[~late][-1]) ** 2
    f = fit_sketch(scene, T, P, ["v0"], max_iter=5)
    assert not f.success and f.rms > 0.01 and f.infeasible
    reasons = [r for _, _, rs in f.infeasible for r in rs]
    assert any(r.startswith("flight with a ≠ g") for r in reasons), f.infeasible
    assert any(a <= 0.3 <= b for a, b, _ in f.infeasible)
    start = simulate_contact(scene, T[-1], ["v0"], times=list(T[:-1]), h=0.01, sensitivities=False)
    e0 = sum(np.sum((start.position(t) - p) ** 2) for t, p in zip(T, P))
    assert np.sum(f.distances ** 2) < e0
    again = simulate_contact(scene, T[-1], f.names, f.u, h=0.01, sensitivities=False)
    assert np.allclose(again.y[-1], f.trajectory.y[-1], rtol=0, atol=1e-12)


def test_a_box_that_speeds_up_with_no_force_is_reported():
    # x = 0.5t + 1.5t² on the floor: friction only decelerates, so the report says so and success is False
    P = np.stack([0.5 * T + 1.5 * T ** 2, 0 * T, 0.05 + 0 * T], axis=1)
    f = fit_sketch(box(), T, P, ["v0"], max_iter=4)
    assert not f.success and f.infeasible and np.isfinite(f.rms)
    assert any("accelerates with no force" in r for _, _, rs in f.infeasible for r in rs), f.infeasible


def test_a_feasible_sketch_is_followed():
    # a sketch drawn from a simulated slide (v0 = (1.2, 0.1, 0)) is met to roundoff, with nothing reported
    tr = simulate_contact(box(), T[-1], ["v0"], np.array([1.2, 0.1, 0.0]), times=list(T[:-1]), h=0.01,
                          sensitivities=False)
    P = np.array([tr.position(t) for t in T])
    f = fit_sketch(box(), T, P, ["v0"], max_iter=6)
    assert f.success and f.rms < 1e-9 and not f.infeasible
    assert np.allclose(f.u, [1.2, 0.1, 0.0], atol=1e-6)


def test_no_exception_for_a_sketch_inside_the_floor():
    # a sketch under the floor, fitted from a start inside it: a report, not an exception
    P = np.stack([T, 0 * T, -0.5 + 0 * T], axis=1)
    f = fit_sketch(box(), T, P, ["x0"], u=np.array([0.0, 0.0, -0.5]), max_iter=2)
    assert not f.success and f.infeasible and f.notes
