"""The one fixed-step driver: one step rule, one cap, one finiteness check, for every chapter.

The rule under test (pbanim/ode/driver.py): N = max(1, ⌈span/h − 1e-9⌉) steps, all of size h except
the last, which ends exactly at t_end and is exactly h when span/h is whole to 1e-9.
"""

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from pbanim import solve
from pbanim.collision import Collisions, Plane, simulate_collisions
from pbanim.contact import TimeStepping, make_contacts
from pbanim.errors import SimulationDiverged, StepLimitExceeded
from pbanim.models.reduced import n_link_chart, n_link_pendulum
from pbanim.ode.driver import drive, drive_lean, step_grid
from pbanim.particles import Gravity, ParticleSystem
from pbanim.reduced import ReducedSystem
from pbanim.rigid import RigidBodies, RigidGravity, RigidScene
from pbanim.scene import Scene


# --- the rule itself ---------------------------------------------------------------------------------
@settings(max_examples=200, deadline=None)
@given(t0=st.floats(-1e3, 1e3), span=st.floats(1e-6, 1e3), ratio=st.floats(0.01, 1e4))
def test_step_rule_covers_the_span_and_ends_exactly_at_t_end(t0, span, ratio):
    h = span / ratio
    g = step_grid(t0, t0 + span, h)
    t_end = t0 + span
    assert g.n_steps == max(1, math.ceil(span / h - 1e-9))
    assert g.time(g.n_steps) == t_end and g.times()[-1] == t_end
    assert 0 < g.h_last <= h * (1 + 1e-9) + 1e-12 * abs(t_end)
    assert np.all(np.diff(g.times()) > 0)
    assert [g.size(k) for k in range(g.n_steps - 1)] == [h] * (g.n_steps - 1)


@pytest.mark.parametrize("span, h, n, whole", [(1.0, 0.1, 10, True), (0.3, 0.1, 3, True), (0.25, 0.1, 3, False),
                                                (1.0, 0.3, 4, False), (0.05, 0.1, 1, False), (2.0, 2.0, 1, True)])
def test_step_rule_table(span, h, n, whole):
    g = step_grid(0.0, span, h)
    assert g.n_steps == n
    assert (g.h_last == h) == whole            # whole number of steps: the last step is h itself
    assert g.h_last == pytest.approx(span - (n - 1) * h, abs=1e-15)


def test_backward_grid_mirrors_forward():
    g = step_grid(1.0, 0.0, 0.3, backward=True)
    assert g.n_steps == 4 and g.h == -0.3 and g.time(4) == 0.0
    assert g.h_last == pytest.approx(-0.1, abs=1e-15)


@pytest.mark.parametrize("kwargs, match", [
    (dict(t0=0.0, t_end=1.0, h=0.0), "h must be a positive finite step, got 0.0"),
    (dict(t0=0.0, t_end=1.0, h=float("nan")), "h must be a positive finite step"),
    (dict(t0=0.0, t_end=0.0, h=0.1), "t_end must be a finite time after t0 = 0.0, got 0.0"),
    (dict(t0=1.0, t_end=0.0, h=0.1), "t_end must be a finite time after t0 = 1.0"),
    (dict(t0=float("inf"), t_end=1.0, h=0.1), "t0 must be a finite time"),
    (dict(t0=0.0, t_end=1.0, h=0.1, record_every=0), "record_every must be a positive integer"),
    (dict(t0=0.0, t_end=1.0, h=0.1, max_steps=0), "max_steps must be a positive integer"),
])
def test_step_grid_names_the_bad_argument(kwargs, match):
    with pytest.raises(ValueError, match=match):
        step_grid(**kwargs)


def test_cap_is_checked_before_the_first_step():
    calls = []
    with pytest.raises(StepLimitExceeded, match="needs 1001 steps over t_span, more than max_steps = 1000"):
        drive(lambda t, y, h: calls.append(t) or y, step_grid(0.0, 1.0001, 1e-3, max_steps=1000), np.zeros(2))
    assert calls == []
    with pytest.raises(StepLimitExceeded, match="needs inf steps"):
        step_grid(0.0, 1e308, 1e-300)


def test_divergence_names_time_step_and_quantity():
    # the step starting at t = 7 turns the state to NaN: the error names that step, its start time and
    # what was checked, in the hooked and the lean loop alike
    grid = step_grid(0.0, 2000.0, 1.0)
    step = lambda t, y, h: y + (np.nan if t == 7.0 else h)  # noqa: E731
    with pytest.raises(SimulationDiverged) as exc:
        drive(step, grid, np.ones(3), quantity="velocity")
    assert (exc.value.step, exc.value.t, exc.value.quantity) == (7, 7.0, "velocity")
    with pytest.raises(SimulationDiverged) as lean:
        drive_lean(step, grid, np.ones(3))
    assert (lean.value.step, lean.value.t) == (7, 7.0)
    # check_every > 1 still stops within one check period, never lets NaN reach the end
    with pytest.raises(SimulationDiverged) as late:
        drive(step, grid, np.ones(3), check_every=5)
    assert late.value.step == 9


def test_hooks_can_stop_and_change_the_state():
    seen = []

    def hook(k, t, y, t1, y1, h):
        return (t + 0.5 * h, y1 * 0.0, True) if k == 2 else None

    t, y, steps, stopped = drive(lambda t, y, h: y + h, step_grid(0.0, 1.0, 0.1), np.zeros(1), hooks=[hook],
                                 record=lambda t, y: seen.append(t), record_every=5)
    assert stopped and steps == 3 and t == pytest.approx(0.25) and y[0] == 0.0
    assert seen == [pytest.approx(0.25)]        # a stop is always recorded


def test_lean_and_hooked_paths_agree():
    grid = step_grid(0.0, 1.0, 0.3)
    step = lambda t, y, h: y + h * np.array([y[1], -y[0]])  # noqa: E731
    Y = drive_lean(step, grid, np.array([1.0, 0.0]))
    out = []
    drive(step, grid, np.array([1.0, 0.0]), record=lambda t, y: out.append(y))
    np.testing.assert_array_equal(Y[1:], np.array(out))



@pytest.mark.parametrize("record_every, check_every", [(1, 1), (3, None), (4, 2), (10, 7)])
def test_lean_loop_records_every_rth_state_into_one_array(record_every, check_every):
    # drive_lean(record_every=r) stores y0, every r-th state and the last (the times grid.times()[::r] and
    # t_end), the same states drive records: bit for bit, the same steps in the same order
    grid = step_grid(0.0, 1.0, 0.07)                     # 15 steps, the last one shortened
    step = lambda t, y, h: y + h * np.array([y[1], -y[0]])  # noqa: E731
    Y = drive_lean(step, grid, np.array([1.0, 0.0]), record_every=record_every, check_every=check_every)
    out = [np.array([1.0, 0.0])]
    drive(step, grid, np.array([1.0, 0.0]), record=lambda t, y: out.append(y), record_every=record_every)
    assert Y.shape == (-(-grid.n_steps // record_every) + 1, 2)
    np.testing.assert_array_equal(Y, np.array(out))


def test_lean_loop_with_a_check_period_names_the_step_it_caught():
    # check_every = c: the state is checked after every c-th step and after the last, as drive checks it
    grid = step_grid(0.0, 20.0, 1.0)
    step = lambda t, y, h: y + (np.nan if t == 7.0 else h)  # noqa: E731
    with pytest.raises(SimulationDiverged) as every:
        drive_lean(step, grid, np.ones(3), record_every=2, check_every=1)
    assert (every.value.step, every.value.t) == (7, 7.0)
    with pytest.raises(SimulationDiverged) as late:
        drive_lean(step, grid, np.ones(3), record_every=4, check_every=5)
    assert late.value.step == 9


# --- every chapter takes the same steps ----------------------------------------------------------------
SPANS = [(0.3, 0.1), (0.25, 0.1), (0.07, 0.02)]


def _particle(t_end, h):
    return Scene(ParticleSystem([[0.0, 1.0, 0.0]]), [Gravity()]).simulate(t_end, h)


def _rigid(t_end, h, quaternions="renormalize"):
    rb = RigidBodies(1.0, [1.0, 2.0, 3.0], angular_velocities=[[0.1, 1.0, 0.2]])
    return RigidScene(rb, [RigidGravity()], quaternions=quaternions).simulate(t_end, h, "rk4")


def _contact(t_end, h):
    ps = ParticleSystem([[0.0, 0.0, 0.0]], [[1.0, 0.0, 0.0]], masses=2.0)
    floor = lambda y: make_contacts([0], [-1], [y[:3]], [[0.0, 0.0, 1.0]], [-y[2]])  # noqa: E731
    return TimeStepping(ps, floor, [Gravity()], friction=0.25).simulate(t_end, h)


def _reduced(t_end, h):
    L = np.array([1.0, 0.5])
    mod = n_link_pendulum(2, lengths=L)
    q, J, Jd = n_link_chart(L)
    return ReducedSystem(q, J, Jd, mod.masses, 2, [Gravity(mod.g)], u0=mod.u0).simulate(t_end, h)


def _collisions(t_end, h):
    scene = Scene(ParticleSystem([[0.0, 1.0]]), [Gravity([0, -10.0]), Collisions(obstacles=[Plane([0, 1])])])
    return simulate_collisions(scene, t_end, h, toi="fixed")


def _solve(t_end, h):
    return solve(lambda t, y: np.array([y[1], -y[0]]), (0.0, t_end), [1.0, 0.0], method="rk4", h=h)


def _solve_hooked(t_end, h):   # the event/t_eval path of solve (hooks), not the lean one
    ev = lambda t, y: y[0] + 10.0  # noqa: E731  never fires
    return solve(lambda t, y: np.array([y[1], -y[0]]), (0.0, t_end), [1.0, 0.0], method="rk4", h=h, events=[ev])


@pytest.mark.parametrize("t_end, h", SPANS)
def test_same_t_span_and_h_give_the_same_steps_in_every_chapter(t_end, h):
    runs = {"particle scene": _particle, "rigid scene": _rigid,
            "rigid scene (exp map)": lambda a, b: _rigid(a, b, "exponential"), "contact time stepping": _contact,
            "reduced system": _reduced, "collisions": _collisions, "solve": _solve, "solve (hooks)": _solve_hooked}
    g = step_grid(0.0, t_end, h)
    for name, run in runs.items():
        res = run(t_end, h)
        assert res.nsteps == g.n_steps, name
        assert res.t[-1] == t_end, name
        np.testing.assert_array_equal(res.t, g.times(), err_msg=name)
