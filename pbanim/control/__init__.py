"""Characters and controllers (chapter 08, part 2): PD servos, state machines, SIMBICON, QP control."""

from __future__ import annotations

from .fsm import InvalidMachine, StateMachine, Transition
from .pd import (SERVOS, InvalidGains, PDServo, UnknownJoint, explicit_pd_stable, largest_stable_step, pd_step,
                 servo_track, stable_pd_acceleration, stable_pd_stable)
from .simbicon import FAST_WALK, WALK, Gait, Phase, Simbicon
from .walk import Push, WalkResult, simulate_walk

__all__ = ["PDServo", "InvalidGains", "UnknownJoint", "SERVOS", "pd_step", "explicit_pd_stable", "stable_pd_stable",
           "largest_stable_step", "stable_pd_acceleration", "servo_track", "StateMachine", "Transition", "InvalidMachine",
           "Gait", "Phase", "WALK", "FAST_WALK", "Simbicon", "Push", "WalkResult", "simulate_walk"]
