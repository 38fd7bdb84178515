"""One body's augmented flight step without the 13 × 13 matrix (pbanim.design.lean_tangent) against the
readable step (pbanim.design.flight.augmented_step with ``lean_path = False``).

Each test cites its oracle from ORACLES.md section H; tolerances are in ulps of the quantity compared.
"""

import numpy as np
import pytest
from pbanim.collision import Box, Plane
from pbanim.contracts import unchecked
from pbanim.design import DesignBody, DesignScene, simulate
from pbanim.design.check import analytic_jacobian
from pbanim.design.flight import FlightModel, augmented_step
from pbanim.design import lean_tangent
from pbanim.design.lean_tangent import one_body_augmented
from pbanim.rigid import quat_from_axis_angle

EPS = np.finfo(float).eps
step = unchecked(augmented_step)


def _model(rng, p, mass, inertia, N=1):
    W = rng.uniform(0.2, 3.0, N)
    dm = rng.standard_normal((p, N)) if mass else np.zeros((p, N))
    dI = rng.standard_normal((p, N, 3)) if inertia else np.zeros((p, N, 3))
    return FlightModel(N, W, 1.0 / W, rng.uniform(0.1, 10.0, (N, 3)), 5.0 * rng.standard_normal(3),
                       -dm * W * W, dm, dI)


def _readable(model, y, T, h):
    model.lean_path = False
    try:
        return step(model, y.copy(), T.copy(), h)
    finally:
        model.lean_path = True


def test_lean_augmented_step_is_the_readable_step():
    # ORACLES H12: random states, tangents and steps, with and without mass and inertia parameters: the state
    # bit for bit (the same f, the same stage sums), the tangent rows within 8 ε max|T₁| (the seven products
    # of each δq̇ entry summed in another order; measured 1.7 ε at worst, bit for bit in 286 of 300)
    rng = np.random.default_rng(11)
    for trial in range(120):
        model = _model(rng, int(rng.integers(1, 15)), trial % 3 >= 1, trial % 3 == 2)
        y = rng.standard_normal(13) * rng.uniform(0.1, 10.0)
        y[3:7] /= np.linalg.norm(y[3:7]) * rng.uniform(0.999, 1.001)
        T = rng.standard_normal((model.n_params, 13))
        h = rng.uniform(1e-3, 0.05)
        y1, T1 = one_body_augmented(model)(y.copy(), T.copy(), h)
        y2, T2 = _readable(model, y, T, h)
        np.testing.assert_array_equal(y1, y2)
        assert np.abs(T1 - T2).max() <= 8 * EPS * np.abs(T2).max()
        np.testing.assert_array_equal(T1[:, 10:], T2[:, 10:])         # δL̇ = 0: δL rows unchanged


def test_lean_augmented_step_carries_the_parameter_terms():
    # ORACLES H12: with T = 0 the step's tangent is ∂f/∂u integrated alone: not zero when a mass or inertia
    # parameter is present, and the lean step must carry it as the readable one does
    rng = np.random.default_rng(12)
    for mass, inertia in ((True, False), (False, True)):
        model = _model(rng, 3, mass, inertia)
        y = rng.standard_normal(13)
        y[3:7] /= np.linalg.norm(y[3:7])
        T = np.zeros((3, 13))
        y1, T1 = one_body_augmented(model)(y.copy(), T.copy(), 0.01)
        _, T2 = _readable(model, y, T, 0.01)
        assert np.abs(T2).max() > 0
        assert np.abs(T1 - T2).max() <= 8 * EPS * np.abs(T2).max()


def test_two_bodies_keep_the_readable_step():
    # ORACLES H12: the lean step is for one body only
    assert one_body_augmented(_model(np.random.default_rng(0), 2, False, False, N=2)) is None


def _tumbling_box():
    b = DesignBody(Box([0.2, 0.15, 0.1]), mass=1.3, position=[0, 0, 1.0],
                   orientation=quat_from_axis_angle([1, 2, 3], 0.7), velocity=[1.0, 0.3, 2.0],
                   angular_velocity=[3.0, -2.0, 4.0])
    return DesignScene([b], [Plane([0, 0, 1]), Plane([-1, 0, 0.1], offset=-1.5)], restitution=0.6)


@pytest.mark.parametrize("names", [["x0", "theta0", "v0", "omega0", "restitution"], ["v0", "mass0", "inertia0"]])
def test_lean_sensitivities_of_a_tumbling_box_are_the_readable_ones(monkeypatch, names):
    # ORACLES H12: ∂S/∂u of the design benchmark's box through its impacts (13 parameters), and with mass and
    # inertia parameters: the same impacts and states bit for bit, ∂S/∂u within 1e-12 relative (measured bit
    # for bit in both)
    s, T = _tumbling_box(), 0.68
    outs = [(0, T, "position"), (0, T, "orientation")]
    calls = []
    make = lean_tangent._make_step
    monkeypatch.setattr(lean_tangent, "_make_step", lambda m, f: calls.append(1) or make(m, f))
    a = simulate(s, T, names)
    assert calls                                                  # the lean step ran
    monkeypatch.setattr(FlightModel, "lean_path", False)
    monkeypatch.setattr(lean_tangent, "one_body_augmented", None)  # the readable run never reaches it
    b = simulate(s, T, names)
    assert len(a.impacts) >= 2 and [i.t for i in a.impacts] == [i.t for i in b.impacts]
    np.testing.assert_array_equal(a.y, b.y)
    A, B = analytic_jacobian(a, outs), analytic_jacobian(b, outs)
    assert np.abs(A - B).max() <= 1e-12 * np.abs(B).max()
