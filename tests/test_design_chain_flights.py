"""aim_chain keeps every iterate's flight: the states are those of the run without ∂S/∂u (ORACLES H9)."""

import numpy as np

from pbanim.design import aim_chain, simulate_chain, thrown_chain

LINK, LOCAL, TARGET = 4, np.array([0.3, 0.0, 0.0]), np.array([1.5, 1.5])


def test_every_iterate_flight_is_its_run_and_its_states_the_run_without_sensitivities():
    tree = thrown_chain(3, 0.3)
    q0, qd0 = np.array([0.0, 1.0, 0.3, 0.4, -0.3]), np.array([2.0, 3.0, 2.0, 0.0, 0.0])
    k, T, h = np.array([0.0, 0.0, 0.0, 5.0, 5.0]), 0.8, 0.05
    res = aim_chain(tree, q0, qd0, T, h, LINK, LOCAL, TARGET, tol=1e-8, stiffness=k)
    assert len(res.flights) == len(res.history) >= 3 and res.flights[-1] is res.flight
    first = simulate_chain(tree, q0, qd0, T, h, stiffness=k)
    assert np.array_equal(res.flights[0].y, first.y) and np.array_equal(res.flights[0].dy_du, first.dy_du)
    for u, fl in zip(res.history, res.flights):
        plain = simulate_chain(tree, q0, np.concatenate([u, qd0[3:]]), T, h, stiffness=k, sensitivities=False)
        assert np.array_equal(fl.t, plain.t) and np.array_equal(fl.y, plain.y)      # bit for bit
    # the iterates differ (a list of one flight repeated would fail above or here)
    assert not np.array_equal(res.flights[0].y[-1], res.flights[-1].y[-1])
