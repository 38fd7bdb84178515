"""Chapter 08 part 2 at its edges (issue 27, "Nothing silent"): each test is one defect the contracts or the
checks behind them fixed, with what happened before.

ORACLES F1 for the stability regions (checked here on their boundary, against the iterates of the step map
of pd_step), F10/F12 for the QP controller's flagged answers, F15 for named refusals.
"""

import time

import numpy as np
import pytest

from pbanim.articulated import ArticulatedTree, PlanarKernel
from pbanim.control import (FAST_WALK, WALK, InfeasibleControl, InvalidGains, InvalidMachine, PDServo, QPController,
                            Simbicon, StateMachine, Task, Transition, explicit_pd_stable, largest_stable_step, pd_step,
                            servo_track, simulate_balance, simulate_walk, stable_pd_acceleration, stable_pd_stable)
from pbanim.control.biped import biped_contact_points, planar_biped
from pbanim.control.qp_balance import balance_tasks, crouched_state
from pbanim.control.qp_features import centroidal
from pbanim.errors import InvalidInput, NonFiniteResult, StepLimitExceeded

BIPED = PlanarKernel(planar_biped())


# -- PD servos: stability regions (ORACLES F1) ------------------------------------------------------------
@pytest.mark.parametrize("fn", [explicit_pd_stable, stable_pd_stable])
def test_negative_gains_are_refused_not_called_stable(fn):
    # before: explicit_pd_stable(0.1, -1, 0) was True (a = −0.01 < 4), though a negative k_p pushes away
    with pytest.raises(InvalidInput, match=r"kp must be a finite number >= 0, got -1.0"):
        fn(0.1, -1.0, 0.0)
    with pytest.raises(InvalidInput, match=r"kv must be a finite number >= 0, got -2.0"):
        fn(0.1, 1.0, -2.0)
    with pytest.raises(InvalidInput, match=r"kp must be a finite number >= 0, got -1.0"):
        largest_stable_step(-1.0, 0.0)


def _bounded_by_iteration(h, kp, kv, servo) -> bool:
    """Whether the step map of pd_step stays bounded over 2³⁰ steps (repeated squaring of its matrix)."""
    A = np.array([pd_step(1.0, 0.0, h, kp, kv, servo=servo), pd_step(0.0, 1.0, h, kp, kv, servo=servo)]).T
    P = A.copy()
    for _ in range(30):
        P = P @ P
        if not np.abs(P).max() < 1e6:
            return False
    return True


# (h, k_p, k_v) at m = 1 on and next to the boundary of each region, k = 0 included; a = h²k_p, hc = h k_v
BOUNDARY = {
    "explicit": [(2.0, 0.0, 1.0), (1.0, 0.0, 1.0), (1.0, 0.0, 0.0), (1.0, 4.0, 0.0), (1.0, 3.99, 0.0),
                 (1.0, 2.0, 1.0), (1.0, 2.01, 1.0), (1.0, 1.0, 2.0), (2.01, 0.0, 1.0)],
    "stable": [(1.0, 0.0, 0.0), (1.0, 0.0, 1.0), (1.0, 2.0, 1.0), (1.0, 2.01, 1.0), (1.0, 1.3, 0.0),
               (1.0, 1.34, 0.0), (3.0, 0.0, 100.0)],
}


@pytest.mark.parametrize("servo", ["explicit", "stable"])
def test_closed_forms_are_exact_on_the_boundary_and_at_zero_gain(servo):
    # ORACLES F1 on its boundary: "stable" = the iterates stay bounded; the closed form answers as 2³⁰ steps of
    # the measured map do: a simple eigenvalue ±1 is stable (before: explicit hc = 2 with k_p = 0 was not),
    # a Jordan block is not (before: k_p = k_v = 0, where θ drifts by hθ̇ per step, was stable)
    rule = explicit_pd_stable if servo == "explicit" else stable_pd_stable
    for h, kp, kv in BOUNDARY[servo]:
        assert rule(h, kp, kv) == _bounded_by_iteration(h, kp, kv, servo), (servo, h, kp, kv)


def test_closed_forms_do_not_overflow_at_zero_gain():
    # before: a = h·h·k_p/m = inf·0 = NaN at h = 1e300, k_p = 0, and NaN < 4/3 made both forms say False
    assert stable_pd_stable(1e300, 0.0, 1.0)                 # eigenvalues 1 and 1/(1 + hc): bounded
    assert explicit_pd_stable(1e200, 0.0, 1e-200)            # hc = 1: eigenvalues 1 and 0
    assert not explicit_pd_stable(1e300, 1e-300, 0.0)        # a = 1e300 > 4


def test_largest_stable_step_with_no_servo_is_zero_and_overflow_is_named():
    # before: k_p = k_v = 0 gave h_max (spectral radius 1), though the mass drifts at every step
    for servo in ("explicit", "stable", "implicit"):
        assert largest_stable_step(0.0, 0.0, servo=servo) == 0.0
    assert largest_stable_step(0.0, 1.0) == pytest.approx(2.0, rel=1e-9)    # hc ≤ 2 with k_p = 0
    with pytest.raises(NonFiniteResult, match="h_max = 1e\\+300"):
        largest_stable_step(1.0, 1.0, h_max=1e300)


def test_pd_step_names_an_overflow():
    # before: (nan, nan) from −inf + inf
    with pytest.raises(NonFiniteResult, match="pd_step"):
        pd_step(1e300, -1e300, 1.0, 1e300, 1e300)


# -- PD servos: targets, states, matrices ------------------------------------------------------------------
def _servo():
    return PDServo({"hip": 1, "knee": 3}, nv=5, kp=100.0, kv=10.0)


def test_servo_refuses_a_nan_target_a_batch_and_a_string():
    s = _servo()
    # before: array([0., nan, 0., 0., 0.])
    with pytest.raises(InvalidInput, match=r"PDServo.explicit: targets must be .* got \{'hip': nan\}"):
        s.explicit(np.zeros(5), np.zeros(5), {"hip": np.nan})
    with pytest.raises(InvalidInput, match=r"PDServo.stable: targets must be .* got array\(\[nan"):
        s.stable(np.zeros(5), np.zeros(5), np.array([np.nan, 0.0]), 0.01)
    # before: a bare ValueError (shape mismatch) deep inside
    with pytest.raises(InvalidInput, match=r"q must be .*a batch of states is not accepted here \(shape \(5, 2\)\)"):
        s.explicit(np.zeros((5, 2)), np.zeros((5, 2)), {"hip": 0.1})
    with pytest.raises(InvalidInput, match=r"targets must be .* got '0.5'"):
        s.target_vector("0.5")
    with pytest.raises(InvalidGains, match=r"limits must be .* got -1.0"):
        PDServo({"hip": 1}, nv=5, kp=1.0, kv=1.0, limits=-1.0)


def test_servo_refuses_rows_for_joints_that_are_not_world_servos():
    # before: the row was silently ignored and the servo measured the joint angle
    with pytest.raises(InvalidInput, match=r"angles gives rows for \['hip'\], which world does not list"):
        PDServo({"hip": 1}, nv=5, kp=1.0, kv=1.0, angles={"hip": np.ones(5)})
    with pytest.raises(InvalidInput, match=r"angles\['hip'\] is missing"):
        PDServo({"hip": 1}, nv=5, kp=1.0, kv=1.0, world=["hip"])


def test_stable_pd_acceleration_refuses_what_is_not_a_mass_matrix():
    z = np.zeros(2)
    # before: answered with a non-symmetric M (q̈ = [3.91, −0.99]) and raised a bare LinAlgError for a singular one
    with pytest.raises(InvalidInput, match=r"M must be a symmetric positive definite mass matrix, got one with "
                                           r"\|M − Mᵀ\| up to 5"):
        stable_pd_acceleration(np.array([[1.0, 5.0], [0.0, 1.0]]), z, np.ones(2), z, z, 1.0, 1.0, 0.01)
    for M in (np.ones((2, 2)), np.full((2, 2), 1e300), np.diag([1.0, -1.0])):
        with pytest.raises(InvalidInput, match="not positive definite"):
            stable_pd_acceleration(M, z, np.ones(2), z, z, 1.0, 0.0, 0.01)
    with pytest.raises(InvalidInput, match=r"kv must be .* got array\(\[ 1., -1.\]\)"):
        stable_pd_acceleration(np.eye(2), z, z, z, z, 1.0, np.array([1.0, -1.0]), 0.01)


def test_servo_track_names_a_bad_target_caps_its_steps_and_tracks_large_targets():
    # before: a NaN target came back as θ = inf from the first step, read as an unstable servo
    with pytest.raises(InvalidInput, match="target must return a finite number, got nan at t = 0.01"):
        servo_track("stable", lambda t: np.nan, 100.0, 20.0, 0.01, 0.05)
    with pytest.raises(InvalidInput, match="target must return one number"):
        servo_track("explicit", lambda t: "up", 100.0, 20.0, 0.01, 0.05)
    # before: np.arange of 10¹² steps (MemoryError); now refused before the first step
    with pytest.raises(StepLimitExceeded, match="max_steps = 1000000"):
        servo_track("stable", lambda t: 0.0, 100.0, 20.0, 1e-12, 1.0)
    # before: a stable servo tracking θ̄ = 10⁷ crossed the fixed |θ| < 10⁶ and was cut off as diverged (inf)
    t, x = servo_track("stable", lambda t: 1e7, 100.0, 20.0, 0.01, 3.0)
    assert np.all(np.isfinite(x)) and x[-1] == pytest.approx(1e7, rel=1e-3)
    # an unstable servo is still cut off (explicit PD, h√k_p = 3 > 2)
    t, x = servo_track("explicit", lambda t: 1.0, 100.0, 0.0, 0.3, 30.0)
    assert np.isinf(x[-1])


# -- state machines, SIMBICON, the walk ----------------------------------------------------------------------
def test_machines_refuse_unknown_final_states_backward_time_and_event_strings():
    with pytest.raises(InvalidMachine, match=r"final names the unknown states \['Z'\]"):      # before: ignored
        StateMachine({"A": 0}, [Transition("A", "A", after=1.0)], "A", final=["Z"])
    m = StateMachine({"A": 0, "B": 1}, [Transition("A", "B", on="left_strike"), Transition("B", "A", on="e")], "A")
    # before: set("left_strike") is a set of letters, so the event never fired and nothing said why
    with pytest.raises(InvalidInput, match="events must be a list, tuple or set of strings, got 'left_strike'"):
        m.update(0.5, "left_strike")
    assert m.update(5.0, ["left_strike"]) and m.state == "B"
    # before: a later call at t = 1 fired and the trace read (5, B), (1, A): an interval of −4 s
    with pytest.raises(InvalidInput, match=r"t must be a finite time >= self.entered = 5, got 1.0"):
        m.update(1.0, {"e"})
    with pytest.raises(InvalidInput, match=r"t_end must be a finite time >= self.entered = 5, got 3.0"):
        m.intervals(3.0)


def test_simbicon_refuses_other_models_unknown_gait_fields_and_stale_kinematics():
    tree = ArticulatedTree(gravity=(0.0, -9.81, 0.0))
    tree.add("l", -1, "revolute", axis=[0, 0, 1], mass=1.0, com=[0, -0.5, 0], inertia=[0.1, 0.1, 0.1])
    # before: a bare ValueError ("'left_foot' is not in list")
    with pytest.raises(InvalidInput, match="kernel must be the planar biped's"):
        Simbicon(PlanarKernel(tree))
    ctrl = Simbicon(BIPED)
    with pytest.raises(InvalidInput, match=r"\['foo'\] are not gait fields"):                 # before: TypeError
        ctrl.with_gait(foo=1)
    with pytest.raises(InvalidInput, match="dt must be a finite number > 0 and <= 5, got -1.0"):
        ctrl.with_gait(dt=-1.0)
    q = np.zeros(9)
    # before: the torques of the state the kinematics were computed at, silently
    with pytest.raises(InvalidInput, match="kin must be the dict kernel.kinematics.*another state"):
        ctrl.torques(0.0, q, q, kin=BIPED.kinematics(np.ones(9)))
    tau, k = ctrl.torques(0.0, q, q, kin=BIPED.kinematics(q))
    assert np.all(np.isfinite(tau))


def test_walk_refuses_a_controller_with_a_gait_it_would_ignore():
    # before: the controller's WALK ran and FAST_WALK was silently ignored
    with pytest.raises(InvalidInput, match="give either controller .* or gait, feedback and servo, not both"):
        simulate_walk(FAST_WALK, 0.01, 2e-3, controller=Simbicon(BIPED, WALK))
    r = simulate_walk(t_end=0.01, h=2e-3, controller=Simbicon(BIPED, FAST_WALK))
    assert r.t[-1] == pytest.approx(0.01)


# -- the QP controller: backend failures and ill-scaled data come back flagged (ORACLES F10, F12) -----------
def _controller(**kw):
    q, _ = crouched_state(BIPED, 0.3)
    tasks = kw.pop("tasks", None) or balance_tasks(BIPED.centre_of_mass(q), {"left_knee": -0.3, "right_knee": -0.3})
    return QPController(BIPED, biped_contact_points(BIPED.tree), tasks=tasks, torque_limits=300.0, **kw), q


def test_a_backend_that_raises_gives_a_flagged_answer(monkeypatch):
    pytest.importorskip("proxsuite")
    import pbanim.control.qp_solve as qs

    def broken(*args):
        raise RuntimeError("the solver broke")

    monkeypatch.setattr(qs, "_solve", broken)
    ctrl, q = _controller()
    res = ctrl.solve(q, np.zeros(9))                  # before: the RuntimeError went through bare
    assert res.status == "infeasible" and not res.success
    assert "backend proxqp failed: RuntimeError: the solver broke" in res.message
    assert np.all(np.isfinite(res.tau)) and np.all(np.isfinite(res.qdd))
    with pytest.raises(InfeasibleControl, match="the solver broke"):
        ctrl.torques(q, np.zeros(9))


def test_data_whose_squares_overflow_are_not_sent_to_the_solver():
    pytest.importorskip("proxsuite")
    # before: k_p = 1e200 made ProxQP stall for 3·10⁶ inner iterations (84 s) before MAX_ITER_REACHED
    q, _ = crouched_state(BIPED, 0.3)
    ctrl, q = _controller(tasks=[Task("com", target=BIPED.centre_of_mass(q) + [0.01, 0.0], kp=1e200)])
    start = time.perf_counter()
    res = ctrl.solve(q, np.zeros(9))
    assert time.perf_counter() - start < 1.0
    assert res.status == "infeasible" and "beyond 1e+150" in res.message
    with pytest.raises(InvalidInput, match=r"kp must be a finite number >= 0, got -1.0"):
        simulate_balance(0.0, 0.01, kp=-1.0)


def test_controller_refuses_tolerances_that_would_call_anything_met_and_runs_without_contacts():
    pytest.importorskip("proxsuite")
    # before: feasibility_tol = 10 was accepted (every violation below 10 M|g| called feasible)
    with pytest.raises(InvalidInput, match=r"feasibility_tol must be a finite number > 0 and < 1, got 10.0"):
        _controller(feasibility_tol=10.0)
    # before: no contact points raised a bare ValueError (reshape of an empty array); now a flying body
    ctrl = QPController(BIPED, [], tasks=[Task("com", target=(0.0, 1.0))])
    res = ctrl.solve(np.zeros(9), np.zeros(9))
    assert res.success and res.forces.shape == (0, 2)
    cf = centroidal(BIPED, np.zeros(9), np.zeros(9))          # F10: M c̈ = M g with no contact force
    np.testing.assert_allclose(cf.J @ res.qdd + cf.bias, [0.0, -9.81], atol=1e-8)
