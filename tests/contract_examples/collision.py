"""Valid calls for pbanim.collision (chapter 06)."""

import numpy as np

from pbanim.collision import Box, Capsule, Collisions, Contacts, ImpulseBodies, Plane, Sphere
from pbanim.particles import Gravity, ParticleSystem
from pbanim.scene import Scene


def _bodies():
    """Two spinning spheres (radius 0.5) touching along x, the first also resting on the ground z = 0."""
    return ImpulseBodies.make(x=[[0.0, 0.0, 0.5], [1.0, 0.0, 0.5]], v=[[1.0, 0.2, -1.0], [-0.5, 0.0, 0.0]],
                              inv_mass=[1.0, 0.5], omega=[[0.0, 2.0, 0.0], [1.0, 0.0, 0.0]],
                              inv_I=np.stack([np.eye(3) / 0.1, np.eye(3) / 0.05]))


def _contacts():
    """The two contacts of :func:`_bodies`: sphere 1 on sphere 0, sphere 0 on the ground."""
    return Contacts(a=[1, 0], b=[0, -1], point=[[0.5, 0.0, 0.5], [0.0, 0.0, 0.0]],
                    normal=[[1.0, 0.0, 0.0], [0.0, 0.0, 1.0]], depth=[0.0, 0.0], radius=[0.5, 0.5],
                    radius_b=[0.5, 0.0])


def _collisions():
    """A bound effect: two 2-D particles of radius 0.1 over the ground y = 0."""
    col = Collisions(obstacles=[Plane([0.0, 1.0])], radius=0.1, restitution=0.5, friction=0.2)
    Scene(ParticleSystem([[0.0, 0.05], [0.15, 0.1]], [[0.3, -1.0], [-0.2, 0.0]], masses=[1.0, 2.0]),
          [Gravity(), col])
    return col


def _ball_scene():
    ps = ParticleSystem([[0.0, 0.2]], [[0.5, 0.0]])
    return Scene(ps, [Gravity(), Collisions(obstacles=[Plane([0.0, 1.0])], restitution=0.5)])


def _lean_ball():
    scene = _ball_scene()
    from pbanim.ode import get_method

    return {"scene": scene, "col": scene.effects[-1], "method": get_method("rk4"), "gap_tol": 1e-12,
            "max_events": 100}


INSTANCES = {
    Plane: lambda: Plane([0.0, 0.0, 1.0]),
    Sphere: lambda: Sphere(0.5),
    Box: lambda: Box([0.3, 0.2, 0.1]),
    Capsule: lambda: Capsule(0.1, 0.3),
    Contacts: _contacts,
    ImpulseBodies: _bodies,
    Collisions: _collisions,
}

_I = "pbanim.collision.impulse."
CALLS = {
    _I + "ImpulseBodies.__init__": lambda: {k: getattr(_bodies(), k) for k in ("x", "v", "omega", "inv_mass",
                                                                               "inv_I")},
    _I + "contact_velocity": lambda: {"c": _contacts()},
    _I + "collision_matrix": lambda: {"c": _contacts()},
    _I + "apply_impulses": lambda: {"c": _contacts(), "J": [[0.1, 0.0, 0.0], [0.0, 0.0, 0.5]]},
    _I + "resolve_collisions": lambda: {"contacts": _contacts(), "restitution": 0.5, "friction": 0.3},
    _I + "contact_impulse": lambda: {"K": np.diag([3.5, 3.5, 1.0]), "u": np.array([0.3, 0.0, -2.0]),
                                     "n": np.array([0.0, 0.0, 1.0]), "restitution": 0.5, "friction": 0.3},
    "pbanim.collision.narrow.collide": lambda: {"shape_a": Sphere(0.5), "xa": [0.0, 0.0, 0.4], "Ra": None,
                                                "shape_b": Plane(), "xb": None, "Rb": None, "a": 0, "b": -1},
    "pbanim.collision.toi.simulate_collisions": lambda: {"scene": _ball_scene(), "t_end": 0.3, "h": 0.05},
    "pbanim.collision.lean.lean_ball": _lean_ball,
    "pbanim.collision.scene.Collisions.bind": lambda: {"system": ParticleSystem([[0.0, 0.05], [0.5, 0.1]])},
}

EXEMPT = {
    "pbanim.collision.impulse.ImpulseResult.__init__": "a result record resolve_collisions builds from "
                                                        "checked inputs; users read it, never build it",
    "pbanim.collision.broad.BroadPhase.__init__": "a result record the broad phase builds; users read its "
                                                  "pairs and cost, never build it",
}
