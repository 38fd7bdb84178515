"""Valid calls for pbanim.articulated (chapter 08, part 1): small trees (a floating root with a hinge, a
slider and a weld under it; a three-coordinate planar tree), a hinged rigid body, short runs."""

import numpy as np

from pbanim.articulated import (ArticulatedSystem, ArticulatedTree, Joint, Link, PlanarContactStep, PlanarGround,
                                PlanarKernel, RigidJoint, RigidJoints)
from pbanim.models.articulated import urdf_path
from pbanim.rigid import RigidBodies, RigidGravity, RigidScene


def _tree():
    """A floating root with a hinge (limited), a slider and a weld below it: every kind of joint, 4 links."""
    t = ArticulatedTree()
    t.add("base", -1, "floating", mass=2.0, inertia=[0.2, 0.3, 0.4])
    t.add("arm", 0, "revolute", axis=[0, 1, 0], p=[0.1, 0.0, 0.0], mass=1.0, com=[0.0, 0.0, -0.3],
          inertia=[0.02, 0.02, 0.01], damping=0.1, lower=-1.0, upper=1.0)
    t.add("slide", 1, "prismatic", axis=[0, 0, 1], p=[0.0, 0.0, -0.6], mass=0.5, com=[0.05, 0.0, 0.0],
          inertia=[0.01, 0.01, 0.01])
    t.add("tool", 2, "fixed", p=[0.0, 0.0, -0.1], mass=0.2, com=[0.0, 0.0, -0.05], inertia=[1e-3, 1e-3, 1e-3])
    return t


def _planar_tree():
    """A slider along x carrying a two-link leg hinged about z, gravity in the plane."""
    t = ArticulatedTree(gravity=(0.0, -9.81, 0.0))
    t.add("cart", -1, "prismatic", axis=[1, 0, 0], mass=2.0, inertia=[0.1, 0.1, 0.1])
    t.add("thigh", 0, "revolute", axis=[0, 0, 1], mass=1.0, com=[0.0, -0.25, 0.0], inertia=[0.02, 0.001, 0.02])
    t.add("shin", 1, "continuous", axis=[0, 0, 1], p=[0.0, -0.5, 0.0], mass=0.8, com=[0.0, -0.25, 0.0],
          inertia=[0.02, 0.001, 0.02])
    return t


def _system():
    return ArticulatedSystem(_tree(), torque=lambda t, q, qd: np.zeros(6 + 2))


def _hinge():
    rb = RigidBodies(1.0, [0.1, 0.02, 0.1], positions=[[0.0, -0.5, 0.0]], angular_velocities=[[0.0, 0.0, 0.5]])
    joints = RigidJoints([dict(kind="hinge", a=0, b=-1, anchor_a=[0.0, 0.5, 0.0], axis_a=[0, 0, 1],
                               limits=(-1.0, 1.0))], ks=10.0, kd=2.0)
    RigidScene(rb, [RigidGravity([0.0, -9.81, 0.0]), joints])          # binds it
    return joints


def _step():
    k = PlanarKernel(_planar_tree())
    return PlanarContactStep(k, [(2, [0.0, -0.5, 0.0])], PlanarGround(0.1, 0.8))


INSTANCES = {
    ArticulatedTree: _tree,
    ArticulatedSystem: _system,
    RigidJoints: _hinge,
    RigidJoint: lambda: RigidJoint("hinge", 0, -1, np.array([0.0, 0.5, 0.0]), np.zeros(3), np.array([0.0, 0.0, 1.0]),
                                   np.array([0.0, 0.0, 1.0])),
    PlanarKernel: lambda: PlanarKernel(_planar_tree()),
    PlanarGround: lambda: PlanarGround(0.1, 0.8),
    PlanarContactStep: _step,
    Joint: lambda: Joint("revolute"),
    Link: lambda: Link("a", 1.0, np.zeros(3), np.eye(3)),
}

_A = "pbanim.articulated."
CALLS = {
    _A + "urdf.load_urdf": lambda: {"source": str(urdf_path("pendulum3"))},
    _A + "system.ArticulatedSystem.__init__": lambda: {"tree": _tree(), "torque": lambda t, q, qd: np.zeros(8)},
    _A + "joints.RigidJoints.__init__": lambda: {"joints": [dict(kind="ball", a=0, b=-1)]},
    _A + "joints.RigidJoints.bind": lambda inst: {"system": RigidBodies(1.0, [0.1, 0.1, 0.1])},
    _A + "joints.RigidJoints.coordinate": lambda inst: {"j": inst.joints[0], "qrel0": inst._qrel0[0]},
    _A + "joints.RigidJoints.rows": lambda inst: {"y": inst.system.state()},
    _A + "joints.RigidJoints.constrain": lambda inst: {"y": inst.system.state(), "Q": np.zeros((1, 6))},
    _A + "joints.RigidJoints.diagnostics": lambda inst: {"y": inst.system.state()},
    _A + "planar_step.PlanarContactStep.__init__": lambda: {"kernel": PlanarKernel(_planar_tree()),
                                                           "points": [(2, [0.0, -0.5, 0.0])]},
    _A + "planar_step.PlanarContactStep.step": lambda inst: {"q": np.array([0.0, 0.2, -0.3]),
                                                            "qd": np.array([0.1, 0.0, 0.5]), "h": 1e-3,
                                                            "tau": np.zeros(3)},
}

# issue 31: derivatives of RNEA and ABA (the contracts invent valid trees and states; these add a floating root,
# a weld and external forces)
CALLS.update({
    _A + "derivatives.rnea_derivatives": lambda: {"tree": _tree(), "q": _tree().neutral(), "qd": np.ones(8),
                                                  "qdd": np.zeros(8), "f_ext": np.ones((4, 6))},
    _A + "derivatives.aba_derivatives": lambda: {"tree": _tree(), "q": _tree().neutral(), "qd": np.ones(8),
                                                 "tau": np.zeros(8), "f_ext": np.ones((4, 6))},
    _A + "derivatives.tangent_step": lambda: {"tree": _tree(), "q": _tree().neutral(), "dv": np.full(8, 0.1)},
})


def _chain_flight():
    """A short flight of a two-rod chain (chapter 10's articulated design, issue 31)."""
    from pbanim.design.articulated import simulate_chain, thrown_chain

    tree = thrown_chain(2)
    return simulate_chain(tree, np.array([0.0, 1.0, 0.3, 0.4]), np.array([1.0, 2.0, 1.0, 0.0]), 0.1, 0.05)


def _chain_flight_class():
    from pbanim.design.articulated import ChainFlight

    return ChainFlight


INSTANCES[_chain_flight_class()] = _chain_flight
