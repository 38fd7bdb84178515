"""Valid calls for pbanim.constraints (chapter 03)."""

import numpy as np

from pbanim.constraints import Constraints, Distance
from pbanim.constraints.assembly import ConstraintSet
from pbanim.constraints.kinds import Constraint
from pbanim.particles import ParticleSystem
from pbanim.scene import Scene


def _pendulum():
    """Two particles: a rod from the origin to the first, a rod between them (a double pendulum)."""
    return ParticleSystem([[1.0, 0.0], [2.0, 0.5]], [[0.0, 0.3], [0.1, 0.0]], masses=[1.0, 2.0])


def _rods():
    return [Distance([[0, -1], [0, 1]], anchors=[0.0, 0.0])]


def _effect():
    eff = Constraints(_rods(), stabilization="baumgarte", ks=4.0, kd=4.0)
    Scene(_pendulum(), [eff])     # binds it
    return eff


def _cset():
    ps = _pendulum()
    return ConstraintSet(_rods(), ps.N, ps.dim, ps.W, ps.x0)


INSTANCES = {
    ParticleSystem: _pendulum,
    Constraint: lambda: _rods()[0],
    Constraints: _effect,
    ConstraintSet: _cset,
}

CALLS = {
    "pbanim.constraints.effect.solve_multipliers": lambda: {"system": _pendulum(), "constraints": _rods()},
    "pbanim.constraints.effect.Constraints.__init__": lambda: {"constraints": _rods()},
}

INSTANCES[__import__("pbanim.constraints.effect", fromlist=["x"]).ConstraintProjection] = \
    lambda: _effect_with_projection()


def _effect_with_projection():
    eff = Constraints(_rods(), stabilization="projection")
    scene = Scene(_pendulum(), [eff])
    return scene.effects[-1]

ENFORCED = ("pbanim.constraints.effect.",)
