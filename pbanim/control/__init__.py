"""Characters and controllers (chapter 08, part 2): PD servos, state machines, SIMBICON, QP control.

=====================  =====================================================================================
module                 what it holds
=====================  =====================================================================================
:mod:`.pd`             explicit, stable and implicit PD servos; their stability regions (ORACLES F1)
:mod:`.fsm`            state machines with timed and event transitions, checked when built
:mod:`.biped`          the 7-link planar biped (SIMBICON's 2-D model), also as URDF
:mod:`.simbicon`       SIMBICON's controller and two gaits; :mod:`.walk` runs it with contact and pushes
                       (:mod:`.walk_branch`: many pushes on one walk, simulated once up to each push)
:mod:`.qp`             the optimization controller after de Lasa et al. 2010 (weighted or prioritized QPs),
                       with :mod:`.qp_tasks`, :mod:`.qp_features`, :mod:`.qp_solve`, :mod:`.qp_balance`
:mod:`.biped3d`        the 3-D biped (SIMBICON's 3-D model, masses ours), its lean contact step :mod:`.biped3d_step`
:mod:`.simbicon3d`     SIMBICON in 3-D (coronal feedback, heading); :mod:`.simbicon3d_walk` runs it
:mod:`.qp_biped3d`     the QP controller of the 3-D biped; :mod:`.qp_biped3d_run` stands, pushes and steps it
:mod:`.specs`          the argument specs the contracts of this chapter need beyond :mod:`pbanim.contracts`
=====================  =====================================================================================

Every public callable declares what its arguments must be (:func:`pbanim.contracts.contract`), checked at
calls from outside the package; the step loops (the walk, the balance) call the unchecked functions.

qpsolvers and proxsuite load the first time a QP is solved.
"""

from __future__ import annotations

from .fsm import InvalidMachine, StateMachine, Transition
from .pd import (SERVOS, InvalidGains, PDServo, UnknownJoint, explicit_pd_stable, largest_stable_step, pd_step,
                 servo_track, stable_pd_acceleration, stable_pd_stable)
from .qp import InfeasibleControl, InvalidTask, QPController, QPResult, Task, UnknownTask
from .qp_balance import BalanceResult, simulate_balance
from .qp_biped3d import QPBiped3D, QPResult3D
from .qp_biped3d_run import Biped3DRun, simulate_stand3d, simulate_step
from .simbicon import FAST_WALK, WALK, Gait, Phase, Simbicon
from .simbicon3d import WALK3D, Gait3D, Phase3D, Simbicon3D
from .simbicon3d_walk import Walk3DResult, simulate_walk3d
from .walk import Push, WalkResult, simulate_walk

__all__ = ["PDServo", "InvalidGains", "UnknownJoint", "SERVOS", "pd_step", "explicit_pd_stable", "stable_pd_stable",
           "largest_stable_step", "stable_pd_acceleration", "servo_track", "StateMachine", "Transition", "InvalidMachine",
           "Gait", "Phase", "WALK", "FAST_WALK", "Simbicon", "Push", "WalkResult", "simulate_walk",
           "QPController", "QPResult", "Task", "InfeasibleControl", "InvalidTask", "UnknownTask", "BalanceResult",
           "simulate_balance",
           "Gait3D", "Phase3D", "WALK3D", "Simbicon3D", "Walk3DResult", "simulate_walk3d",
           "QPBiped3D", "QPResult3D", "Biped3DRun", "simulate_stand3d", "simulate_step"]
