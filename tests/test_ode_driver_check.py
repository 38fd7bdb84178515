"""The driver's small-state finiteness check against the readable check_finite (ORACLES A18)."""

import numpy as np
import pytest

from pbanim.errors import SimulationDiverged
from pbanim.ode import driver
from pbanim.contracts import unchecked
from pbanim.ode.driver import check_finite, drive, step_grid


def _outcome(check, y):
    try:
        check(y, 0.5, 3, "state")
    except SimulationDiverged as exc:
        return "raised", str(exc)
    except Exception as exc:    # noqa: BLE001 (any other error must be the same too)
        return type(exc).__name__, str(exc)
    return "passed", ""


def _cases():
    rng = np.random.default_rng(7)
    yield rng.normal(size=4)
    yield rng.normal(size=32) * 1e150          # |y|² ≈ 3e301: finite
    yield np.full(4, 1e154)                    # |y|² = 4e308: overflows with finite entries
    yield np.full(2, 9.4e153)                  # |y|² ≈ 1.77e308: finite, past 1e307 (the readable check)
    yield np.array([1.0, np.nan, 2.0])
    yield np.array([np.inf, 0.0])
    yield np.array([-np.inf, np.inf])
    yield np.zeros(0)
    yield np.ones((2, 3))
    yield np.array(3.0)
    yield rng.normal(size=33)                  # larger: the readable check
    yield np.array([1e200] + [0.0] * 40)
    yield np.array([1.0 + 2.0j, 0.0])          # complex: the readable check and its contract
    yield np.ones(3, dtype=np.float32)
    yield [1.0, float("nan")]                  # not an array


@pytest.mark.parametrize("y", list(_cases()), ids=lambda y: str(np.asarray(y).shape))
def test_small_check_equals_check_finite(y):
    # ORACLES A18: the same pass / raise (and message) as check_finite, case by case, as drive calls it
    # (from inside pbanim, where contracts are not re-checked: its unchecked body)
    assert _outcome(driver.check_finite_quick, y) == _outcome(unchecked(check_finite), y)
    # the 3-D walk's loop calls it on its 37 numbers with max_size = 64: the same outcome there too
    quick64 = lambda *a: driver.check_finite_quick(*a, max_size=64)          # noqa: E731
    assert _outcome(quick64, y) == _outcome(unchecked(check_finite), y)


def test_drive_still_stops_a_diverging_run():
    # ORACLES A18: a state overflowing to inf within a few steps raises SimulationDiverged at the bad step
    grid = step_grid(0.0, 1.0, 0.1)
    # |y|² = 5e240 after step 0, overflows after step 1 (finite entries: "norm overflowed")
    with pytest.raises(SimulationDiverged, match=r"t = 0.1 \(step 1\).*norm overflowed"):
        drive(lambda t, y, h: y * 1e120, grid, np.array([1.0, 2.0]))
