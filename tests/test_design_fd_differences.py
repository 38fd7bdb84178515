"""The finite differences at several steps around one nominal run are fd_jacobian's (ORACLES H2)."""

import numpy as np

from pbanim.collision import Box, Plane
from pbanim.design import DesignBody, DesignScene
from pbanim.design.check import fd_differences, fd_jacobian
from pbanim.rigid import quat_from_axis_angle


def _box():
    """A tumbling box through one impact (the figure's box, a shorter flight)."""
    b = DesignBody(Box([0.2, 0.15, 0.1]), mass=1.3, position=[0, 0, 0.4], velocity=[1.0, 0.3, 0.5],
                   orientation=quat_from_axis_angle([1, 2, 3], 0.7), angular_velocity=[3.0, -2.0, 4.0])
    return DesignScene([b], [Plane([0, 0, 1])], restitution=0.6)


def test_differences_around_one_base_equal_fd_jacobian_bit_for_bit():
    s, names, T = _box(), ["restitution"], 0.4          # one parameter: two runs per difference
    outs = [(0, T, "position"), (0, T, "orientation")]
    d = 1e-3
    D1, D2 = fd_differences(s, names, None, T, outs, [d, d / 2], h=0.01)
    assert np.array_equal(D1, fd_jacobian(s, names, None, T, outs, delta=d, richardson=False, h=0.01))
    assert np.array_equal((4.0 * D2 - D1) / 3.0, fd_jacobian(s, names, None, T, outs, delta=d, h=0.01))
    # the steps differ: so do the differences (one difference handed back twice would fail here)
    assert not np.array_equal(D1, D2) and np.abs(D1 - D2).max() < 1e-3 * np.abs(D1).max()
