"""Valid calls for pbanim.particles (chapter 01)."""

import numpy as np

from pbanim.particles import (AnchorSprings, DampedSprings, Drag, ForceJacobian, Gravity, ParticleSystem,
                              UserForce)
from pbanim.scene import Scene


def _system():
    """Three particles in 2-D (ParticleSystem's own factory lives in contract_examples.constraints)."""
    return ParticleSystem([[0.0, 0.0], [1.0, 0.0], [0.5, 0.8]], [[0.1, 0.0], [0.0, -0.2], [0.3, 0.1]],
                          masses=[1.0, 2.0, 0.5])


def _bound(effect):
    Scene(_system(), [effect])     # binds it
    return effect


def _user():
    return UserForce(lambda t, x, v: -2.0 * x, name="pull", potential=lambda x: float(np.sum(x * x)),
                     jacobian=lambda t, x, v: (-2.0 * np.eye(x.size), None))


INSTANCES = {
    Gravity: lambda: _bound(Gravity()),
    Drag: lambda: _bound(Drag(0.3)),
    DampedSprings: lambda: _bound(DampedSprings([[0, 1], [1, 2]], stiffness=5.0, damping=0.2)),
    AnchorSprings: lambda: _bound(AnchorSprings([0], stiffness=3.0, damping=0.1)),
    UserForce: lambda: _bound(_user()),
    ForceJacobian: lambda: ForceJacobian(None, None),
}

CALLS = {
    "pbanim.particles.forces.UserForce.__init__": lambda: {"force": lambda t, x, v: -x,
                                                           "potential": lambda x: 0.5 * float(np.sum(x * x)),
                                                           "jacobian": lambda t, x, v: (-np.eye(x.size), None)},
    # two particles in 2-D joined by two springs (N = dim = S = 2: the contract's own sizes for those symbols)
    "pbanim.particles.springs.spring_forces_loop": lambda: {
        "x": _system().x0[:2], "v": _system().v0[:2], "pairs": np.array([[0, 1], [1, 0]]),
        "ks": np.array([5.0, 1.0]), "kd": np.array([0.2, 0.0]), "rest": np.array([1.0, 0.5])},
    "pbanim.particles.system.ParticleSystem.point_velocity": lambda ps: {
        "body_idx": np.array([0, -1]), "points_world": np.zeros((2, 3))},
    "pbanim.particles.system.ParticleSystem.apply_impulses": lambda ps: {
        "body_idx": np.array([0, -1]), "points_world": np.zeros((2, 3)), "impulses": np.ones((2, 3))},
}
