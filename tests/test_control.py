"""PD servos (explicit, stable, implicit) and state machines (chapter 08, part 2).

ORACLES F1: the stability regions of the three servos on m θ̈ = τ, derived from the 2 × 2 step map,
against the measured largest stable step; stable PD against Tan et al.'s formula on a coupled system.
"""

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

from pbanim.control import (InvalidGains, InvalidMachine, PDServo, StateMachine, Transition, UnknownJoint,
                            explicit_pd_stable, largest_stable_step, pd_step, stable_pd_acceleration,
                            stable_pd_stable)
from pbanim.errors import InvalidInput


@pytest.mark.parametrize("kp", [1.0, 100.0, 1e4, 1e6])
@pytest.mark.parametrize("zeta", [0.0, 0.5, 1.0, 3.0])
def test_measured_stability_limit_matches_the_closed_form(kp, zeta):
    # ORACLES F1: explicit PD h_max solves a + 2hc = 4 or hc = 2; stable PD a = 4/3 + (2/3) hc
    kv = 2 * zeta * np.sqrt(kp)
    h_e = largest_stable_step(kp, kv, servo="explicit")
    h_s = largest_stable_step(kp, kv, servo="stable")
    # closed forms: explicit  h²kp + 2h kv = 4 (the binding condition for these damping ratios)
    h_e_exact = (-2 * kv + np.sqrt(4 * kv ** 2 + 16 * kp)) / (2 * kp)
    h_s_exact = ((2 / 3) * kv + np.sqrt((4 / 9) * kv ** 2 + (16 / 3) * kp)) / (2 * kp)
    assert h_e == pytest.approx(h_e_exact, rel=1e-9)                 # bisection to 2⁻⁵⁰ of the bracket
    assert h_s == pytest.approx(h_s_exact, rel=1e-9)
    assert explicit_pd_stable(0.99 * h_e, kp, kv) and not explicit_pd_stable(1.01 * h_e, kp, kv)
    assert stable_pd_stable(0.99 * h_s, kp, kv) and not stable_pd_stable(1.01 * h_s, kp, kv)
    # with damping stable PD allows the longer step (2.4× at critical damping); without damping it is
    # *less* stable than explicit PD: h√k_p = √(4/3) against 2
    assert (h_s > h_e) if zeta >= 0.5 else (h_s < h_e)
    # implicit PD: stable at every step up to the search's bound
    assert largest_stable_step(kp, kv, servo="implicit", h_max=100.0) == 100.0


def test_stable_pd_is_unconditionally_stable_with_enough_damping():
    # ORACLES F1: k_v ≥ 1.5 h k_p makes stable PD stable at that h, for any k_p
    for kp in (1e2, 1e5, 1e8):
        for h in (1e-3, 1e-1, 1.0):
            kv = 1.5 * h * kp
            x, v = 1.0, 0.0
            for _ in range(200):
                x, v = pd_step(x, v, h, kp, kv, servo="stable")
            assert abs(x) <= 1.0 + 1e-12


def test_stable_pd_matches_the_implicit_solve_on_a_coupled_system():
    # ORACLES F1: τ = −K_p(q + h q̇ − q̄) − K_v(q̇ + h q̈) with q̈ from the formula satisfies M q̈ + C = τ
    rng = np.random.default_rng(0)
    G = rng.normal(size=(4, 4))
    M, C = G @ G.T + 4 * np.eye(4), rng.normal(size=4)
    q, qd, target = rng.normal(size=4), rng.normal(size=4), rng.normal(size=4)
    kp, kv, h = np.array([100.0, 200, 50, 10]), np.array([10.0, 5, 20, 1]), 0.01
    qdd, tau = stable_pd_acceleration(M, C, q, qd, target, kp, kv, h)
    np.testing.assert_allclose(M @ qdd + C, tau, atol=1e-12)
    np.testing.assert_allclose(tau, -kp * (q + h * qd - target) - kv * (qd + h * qdd), atol=1e-12)


def test_servo_torques_explicit_and_split_forms():
    servo = PDServo({"hip": 1, "knee": 3}, nv=5, kp=[100.0, 50.0], kv=[10.0, 5.0], limits=[1e9, 20.0])
    q, qd = np.array([0, 0.1, 0, -0.2, 0]), np.array([0, 1.0, 0, 2.0, 0])
    tau = servo.explicit(q, qd, {"hip": 0.5, "knee": 0.0})
    assert tau[1] == pytest.approx(100 * 0.4 - 10 * 1.0) and tau[3] == pytest.approx(50 * 0.2 - 5 * 2.0)
    tau = servo.explicit(q, qd, {"hip": 0.5, "knee": -1.0})
    assert tau[3] == pytest.approx(-20.0)                            # 50·(−0.8) − 10 = −50, clipped to −20
    tau0, k = servo.stable(q, qd, {"hip": 0.5}, h=0.01)
    assert tau0[1] == pytest.approx(100 * (0.5 - 0.1 - 0.01 * 1.0)) and k[1] == 10.0 and k[0] == 0.0
    tau0, k = servo.stable(q, qd, {"hip": 0.5}, h=0.01, implicit=True)
    assert tau0[1] == pytest.approx(100 * 0.4) and k[1] == pytest.approx(10.0 + 0.01 * 100)


def test_bad_gains_and_targets_are_named():
    with pytest.raises(InvalidGains, match="kp"):
        PDServo({"a": 0}, 2, kp=-1.0, kv=1.0)
    with pytest.raises(InvalidGains, match="kv"):
        PDServo({"a": 0}, 2, kp=1.0, kv=np.nan)
    with pytest.raises(InvalidGains, match="kp"):
        PDServo({"a": 0}, 2, kp=[1.0, 2.0, 3.0], kv=1.0)
    with pytest.raises(InvalidInput, match=r"joints\['a'\] must be an index in 0 … 1, got 5"):
        PDServo({"a": 5}, 2, kp=1.0, kv=1.0)
    servo = PDServo({"a": 0}, 2, kp=1.0, kv=1.0)
    with pytest.raises(UnknownJoint, match="elbow"):
        servo.explicit(np.zeros(2), np.zeros(2), {"elbow": 1.0})
    with pytest.raises(InvalidInput, match="servo"):
        pd_step(0.0, 0.0, 0.1, 1.0, 1.0, servo="magic")


@settings(max_examples=40, deadline=None)
@given(st.floats(1e-2, 1e6), st.floats(0, 1e4), st.floats(1e-4, 1.0))
def test_closed_form_agrees_with_the_step_map_everywhere(kp, kv, h):
    # ORACLES F1 (property): spectral radius of the measured step map ≤ 1 ⇔ the closed-form condition
    for servo, rule in (("explicit", explicit_pd_stable), ("stable", stable_pd_stable)):
        cols = [pd_step(1.0, 0.0, h, kp, kv, servo=servo), pd_step(0.0, 1.0, h, kp, kv, servo=servo)]
        rho = float(np.max(np.abs(np.linalg.eigvals(np.array(cols).T))))
        if abs(rho - 1.0) > 1e-6:                                     # away from the boundary
            assert (rho < 1.0) == rule(h, kp, kv), (servo, kp, kv, h, rho)


def _walk_machine():
    return StateMachine({"R0": 0, "R1": 1, "L0": 2, "L1": 3},
                        [Transition("R0", "R1", after=0.3), Transition("R1", "L0", on="left_strike"),
                         Transition("L0", "L1", after=0.3), Transition("L1", "R0", on="right_strike")], "R0")


def test_machine_fires_timed_and_event_transitions_and_traces_them():
    m = _walk_machine()
    assert not m.update(0.1) and m.state == "R0"
    assert not m.update(0.2, {"right_strike"})                       # an event R0 does not listen to
    assert m.update(0.3) and m.state == "R1"
    assert not m.update(0.9)                                         # R1 waits for the left foot
    assert m.update(1.0, {"left_strike"}) and m.state == "L0"
    m.update(1.3), m.update(1.35, {"right_strike"})
    assert [s for _, s in m.trace] == ["R0", "R1", "L0", "L1", "R0"]
    assert m.intervals(2.0)[-1] == (1.35, 2.0, "R0")


def test_machines_with_wrong_graphs_are_refused():
    with pytest.raises(InvalidMachine, match="unknown state 'X'"):
        StateMachine({"A": 0}, [Transition("A", "X", after=1.0)], "A")
    with pytest.raises(InvalidMachine, match="not reachable"):
        StateMachine({"A": 0, "B": 1}, [Transition("A", "A", after=1.0), Transition("B", "A", after=1.0)], "A")
    with pytest.raises(InvalidMachine, match="no way out"):
        StateMachine({"A": 0, "B": 1}, [Transition("A", "B", after=1.0)], "A")
    StateMachine({"A": 0, "B": 1}, [Transition("A", "B", after=1.0)], "A", final=["B"])
    with pytest.raises(InvalidMachine, match="exactly one trigger"):
        Transition("A", "B")
    with pytest.raises(InvalidInput, match="after"):
        Transition("A", "B", after=-1.0)
    with pytest.raises(InvalidMachine, match="initial"):
        StateMachine({"A": 0}, [Transition("A", "A", after=1.0)], "Z")


def test_world_frame_servo_on_a_planar_biped_matches_simbicons_swing_hip():
    # a world-frame hip servo measures φ_torso + θ_hip (the thigh's absolute angle), as SIMBICON does
    from pbanim.articulated import PlanarKernel
    from pbanim.control.biped import BIPED_JOINTS, planar_biped

    k = PlanarKernel(planar_biped())
    thigh = [lk.name for lk in k.tree.links].index("left_thigh")
    hip = BIPED_JOINTS["left_hip"]
    servo = PDServo({"left_hip": hip}, 9, kp=300.0, kv=30.0, world=["left_hip"], angles={"left_hip": k.Phi[thigh]})
    q, qd = np.zeros(9), np.zeros(9)
    q[2], q[hip], qd[2], qd[hip] = 0.2, 0.1, 1.0, -0.5
    assert servo.angles(q)[0] == pytest.approx(0.3)
    tau = servo.explicit(q, qd, {"left_hip": 0.5})
    assert tau[hip] == pytest.approx(300 * (0.5 - 0.3) - 30 * 0.5)
    tau0, kk = servo.stable(q, qd, {"left_hip": 0.5}, h=0.01)      # τ = τ₀ − k θ̇⁺_hip reproduces it at θ̇⁺ = θ̇
    assert tau0[hip] - kk[hip] * qd[hip] == pytest.approx(300 * (0.5 - 0.3 - 0.01 * 0.5) - 30 * 0.5)
    with pytest.raises(UnknownJoint, match="knee"):
        PDServo({"left_hip": hip}, 9, 1.0, 1.0, world=["knee"])
    with pytest.raises(InvalidInput, match="angles"):
        PDServo({"left_hip": hip}, 9, 1.0, 1.0, world=["left_hip"], angles={"left_hip": [1.0]})
