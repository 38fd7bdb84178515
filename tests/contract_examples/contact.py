"""Valid calls for pbanim.contact and pbanim.lcp (chapter 07): a particle on the ground, two boxes on it,
small LCPs with a known answer."""

import numpy as np

from pbanim.contact import (ContactProblem, ContactRows, RestingContact, TimeStepping, assemble_particles,
                            make_contacts, rigid_state)
from pbanim.particles import Gravity, ParticleSystem
from pbanim.rigid import RigidBodies
from pbanim.scene import Scene


def _particle(dim: int = 2) -> ParticleSystem:
    return ParticleSystem([[0.0] * dim], [[0.3] + [0.0] * (dim - 1)], masses=2.0)


def _ground(dim: int):
    """detect(y): particle 0 on the plane x_d = 0 (the world, −1), normal up."""
    up = np.eye(dim)[-1]

    def detect(y):
        return make_contacts([0], [-1], [y[:dim]], [up], [max(0.0, -y[dim - 1])])
    return detect


def _boxes() -> RigidBodies:
    return RigidBodies([1.0, 2.0], [[0.2, 0.2, 0.2], [0.5, 0.5, 0.8]], positions=[[0.0, 0.0, 0.5], [0.0, 0.0, 1.5]],
                       orientations=[[1.0, 0.0, 0.0, 0.0], [0.9, 0.3, -0.2, 0.25]],
                       velocities=[[0.3, 0.0, 0.0], [0.0, 0.1, 0.0]])


def _box_contacts():
    """Box 0 on the ground, box 1 on box 0 (3-D)."""
    return make_contacts([0, 1], [-1, 0], [[0.0, 0.0, 0.0], [0.0, 0.0, 1.0]], [[0.0, 0.0, 1.0]] * 2, [0.0, 0.0])


def _resting() -> RestingContact:
    eff = RestingContact(_ground(2), "lemke")
    Scene(_particle(2), [Gravity(), eff])          # binds it
    return eff


def _stepper() -> TimeStepping:
    return TimeStepping(_particle(3), _ground(3), [Gravity()], friction=0.5)


def _rows() -> ContactRows:
    """Two 3-D particles (n_pad = 3 with the world): one on the ground, one on the other."""
    return ContactRows(np.array([0, 1]), np.array([2, 0]), np.array([[0.0, 0.0, 1.0]] * 2),
                       np.array([[0.0, 0.0, 1.0]] * 2), 3)


def _problem() -> ContactProblem:
    ps = _particle(3)
    c = make_contacts([0], [-1], [[0.0, 0.0, 0.0]], [[0.0, 0.0, 1.0]], [0.0])
    return assemble_particles(ps, ps.state(), c, np.array([[0.0, 0.0, -19.62]]))


_A2 = np.array([[2.0, 1.0], [1.0, 2.0]])
_B2 = np.array([-1.0, 1.0])
_LCP = {"A": _A2, "b": _B2}


def _box_lcp():
    """One contact with box friction: rows (normal, two tangents), A symmetric positive definite."""
    G = np.array([[1.0, 0.2, 0.0], [0.2, 1.0, 0.1], [0.0, 0.1, 1.0]])
    return {"A": G @ G.T + 0.1 * np.eye(3), "b": np.array([-1.0, 0.3, -0.2])}


def _delassus_args():
    W = np.stack([0.5 * np.eye(3), np.eye(3), np.zeros((3, 3))])
    G = np.array([[0.0, 0.0, 1.0], [0.0, 0.6, 0.8]])
    return {"a": np.array([0, 1]), "b": np.array([2, 0]), "Ga": G, "Gb": G, "Wb": W}


def _velocity_lcp_args():
    from pbanim.contact.friction import friction_directions

    rows_n = ContactRows(np.array([0]), np.array([1]), np.array([[0.0, 0.0, 1.0]]), np.array([[0.0, 0.0, 1.0]]), 2)
    d = friction_directions([[0.0, 0.0, 1.0]], 4).reshape(-1, 3)
    rows_d = ContactRows(np.zeros(4, np.intp), np.ones(4, np.intp), d, d, 2)
    return {"rows_n": rows_n, "rows_d": rows_d, "Wb": np.stack([np.eye(3), np.zeros((3, 3))]), "facets": 4}


INSTANCES = {
    RestingContact: _resting,
    TimeStepping: _stepper,
    ContactRows: _rows,
    ContactProblem: _problem,
}

CALLS = {
    # the LCP core: small problems with a known answer (f = (0.5, 0))
    "pbanim.lcp.solve.solve_lcp": lambda: dict(_LCP),
    "pbanim.lcp.pivoting.lemke": lambda: dict(_LCP),
    "pbanim.lcp.pivoting.dantzig": lambda: dict(_LCP),
    "pbanim.lcp.pivoting.enumerate_active_sets": lambda: dict(_LCP),
    "pbanim.lcp.pivoting.residual_threshold": lambda: {**_LCP, "f": np.array([0.5, 0.0])},
    "pbanim.lcp.box.pgs_box_friction": _box_lcp,
    "pbanim.lcp.box.pgs_bounded": lambda: {**_LCP, "lo": np.array([0.0, -1.0]), "hi": np.array([np.inf, 1.0])},
    "pbanim.lcp.planar.solve_planar_contact": lambda: {"A": 2 * np.eye(2) + 0.1, "b": np.array([-1.0, 0.4])},
    "pbanim.lcp.solve.delassus": _delassus_args,
    "pbanim.contact.readable.delassus_by_bodies": _delassus_args,
    # assembly: systems with their contacts (the contacts, states and forces come from the contracts)
    "pbanim.contact.assembly.rigid_state": lambda: {"bodies": _boxes()},
    "pbanim.contact.assembly.rigid_rows": lambda: {"S": rigid_state(_boxes(), _boxes().state()),
                                                   "a": np.array([0, 1]), "b": np.array([2, 0]),
                                                   "p": np.array([[0.0, 0.0, 0.0], [0.0, 0.0, 1.0]]),
                                                   "d": np.array([[0.0, 0.0, 1.0]] * 2)},
    "pbanim.contact.assembly.assemble_rigid": lambda: {"bodies": _boxes(), "contacts": _box_contacts()},
    "pbanim.contact.readable.assemble_rigid_loop": lambda: {"bodies": _boxes(), "contacts": _box_contacts()},
    "pbanim.contact.friction.acceleration_lcp_check": lambda: {"bodies": _boxes(), "contacts": _box_contacts()},
    "pbanim.contact.assembly.assemble_particles": lambda: {"system": _particle(3)},
    "pbanim.contact.readable.assemble_particles_loop": lambda: {"system": _particle(3)},
    "pbanim.contact.assembly.particle_blocks": lambda: {"system": _particle(3)},
    "pbanim.contact.friction.velocity_lcp": _velocity_lcp_args,
    # effects and the time stepper
    "pbanim.contact.effect.RestingContact.__init__": lambda: {"detect": _ground(2)},
    "pbanim.contact.friction.TimeStepping.__init__": lambda: {"system": _particle(3), "detect": _ground(3),
                                                              "forces": [Gravity()]},
    # a run's length is t_end / h steps: capped small, so that no draw asks for millions of LCP solves
    "pbanim.contact.friction.TimeStepping.simulate": lambda ts: {"max_steps": 50},
}

EXEMPT = {
    "pbanim.contact.assembly.ContactProblem.__init__":
        "a record the assembly functions build (A, b, rows, inverse-mass blocks of one configuration); "
        "users read its fields and call generalized_force, which is declared",
}
