"""Valid calls for pbanim.rigid (chapter 05): two small bodies, one of them tilted and spinning."""

import numpy as np

from pbanim.rigid import (AngularDrag, LinearDrag, PointForce, QuaternionRenormalize, RigidBodies, RigidGravity,
                          RigidScene, RigidSprings, box_mesh)
from pbanim.rigid.inertia import MassProperties


def _bodies():
    return RigidBodies([1.0, 2.0], [[1.0, 2.0, 2.5], [0.5, 0.5, 0.8]], positions=[[0.0, 0.0, 1.0], [1.0, 0.5, 0.0]],
                       orientations=[[0.9, 0.3, -0.2, 0.25], [1.0, 0.0, 0.0, 0.0]],
                       velocities=[[0.3, 0.0, -1.0], [0.0, 1.0, 0.0]], angular_velocities=[[1.0, -0.5, 2.0], [0, 0, 3.0]])


def _bound(effect):
    RigidScene(_bodies(), [effect], quaternions="none")      # binds it
    return effect


def _springs():
    return RigidSprings([0, 1], [[0.1, 0.0, 0.0], [0.0, 0.2, 0.0]], [1, -1], [[0.0, 0.0, 0.1], [0.0, 0.0, 2.0]],
                        stiffness=10.0, damping=0.5)


def _zero_forces(t, y):
    return np.zeros((2, 6))


INSTANCES = {
    RigidBodies: _bodies,
    RigidScene: lambda: RigidScene(_bodies(), [RigidGravity(), _springs()]),
    RigidGravity: lambda: _bound(RigidGravity()),
    PointForce: lambda: _bound(PointForce([0, 1], [[0.1, 0.0, 0.0], [0.0, 0.0, 0.2]], [[0.0, 1.0, 0.0], [1.0, 0, 0]])),
    RigidSprings: lambda: _bound(_springs()),
    LinearDrag: lambda: _bound(LinearDrag(0.3)),
    AngularDrag: lambda: _bound(AngularDrag([0.1, 0.2])),
    QuaternionRenormalize: lambda: _bound(QuaternionRenormalize()),
    MassProperties: lambda: MassProperties(1.0, np.zeros(3), np.diag([1.0, 2.0, 2.5]), 1.0),
}

CALLS = {
    "pbanim.rigid.scene.exp_map_step": lambda: {"system": _bodies(), "forces": _zero_forces},
    # a run's length is set by t_end/h: capped small here, so that no draw asks for millions of steps
    "pbanim.rigid.scene.RigidScene.simulate": lambda scene: {"max_steps": 100},
    "pbanim.rigid.inertia.mesh_mass_properties": lambda: dict(zip(("vertices", "faces"), box_mesh([1.0, 2.0, 3.0]))),
    "pbanim.rigid.effects.PointForce.__init__": lambda: {"force": lambda t, y: np.ones((2, 3))},
    "pbanim.rigid.inertia.validate_inertia": lambda: {"inertia": np.diag([1.0, 2.0, 2.5])},
}
