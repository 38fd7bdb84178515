"""pbanim — the reference suite for constrained dynamics in physics-based animation courses.

``import pbanim`` loads numpy and scipy only; sympy, qpsolvers, proxsuite and matplotlib are imported
the first time a function or scene needs them.

The top level holds what a course needs (``pbanim.__all__``, a few dozen names): :func:`solve` and
:data:`METHODS`, :class:`Scene`, the systems and effects, the result types and the errors. Everything
else lives in its lecture's subpackage:

ch01 particles ``pbanim.particles`` · ch02 ODE solvers ``pbanim.ode`` · ch03 constraints
``pbanim.constraints`` · ch04 reduced coordinates ``pbanim.reduced`` (Lagrangian mechanics
``pbanim.reduced.lagrangian``) · ch05 rigid bodies ``pbanim.rigid`` · ch06 collisions ``pbanim.collision``
· ch07 resting contact ``pbanim.contact`` · the LCP / QP core ``pbanim.lcp`` · the body protocol
``pbanim.bodies``. See ``ARCHITECTURE.md`` for the layers.

Names that earlier versions exported at the top level (``pbanim.quat_multiply``, ``pbanim.solve_lambda``,
…) still resolve, lazily, from their subpackage (PEP 562 ``__getattr__`` below); new code imports them from
the subpackage.
"""

from __future__ import annotations

import importlib as _importlib

from .ode import solve, METHODS, get_method, Method
from .scene import Scene, Effect
from .bodies import Bodies
from .particles import ParticleSystem, Gravity, Drag, DampedSprings, AnchorSprings, UserForce
from .constraints import Constraints, Distance, FixedPoint, OnCircle, OnLine, OnPlane
from .reduced import ReducedSystem
from .rigid import RigidBodies, RigidScene, RigidGravity, RigidSprings
from .collision import Collisions, Plane, Sphere, Box, Capsule, simulate_collisions
from .contact import RestingContact, TimeStepping, make_contacts
from .lcp import solve_lcp
from .results import SimResult, ContactSolution
from .errors import (PbanimError, SimulationDiverged, StepLimitExceeded, BodyProtocolError, SingularConstraintError,
                     ConvergenceError, SingularChartError, InfeasibleContact, InconsistentContact)

__version__ = "0.1.0"

__all__ = ["solve", "METHODS", "get_method", "Method", "Scene", "Effect", "Bodies",
           "ParticleSystem", "Gravity", "Drag", "DampedSprings", "AnchorSprings", "UserForce",
           "Constraints", "Distance", "FixedPoint", "OnCircle", "OnLine", "OnPlane",
           "ReducedSystem", "RigidBodies", "RigidScene", "RigidGravity", "RigidSprings",
           "Collisions", "Plane", "Sphere", "Box", "Capsule", "simulate_collisions",
           "RestingContact", "TimeStepping", "make_contacts", "solve_lcp", "SimResult",
           "ContactSolution", "PbanimError", "SimulationDiverged", "StepLimitExceeded",
           "BodyProtocolError", "SingularConstraintError", "ConvergenceError", "SingularChartError",
           "InfeasibleContact", "InconsistentContact"]

# Earlier top-level names → the public module that holds them now (resolved on first access).
_LEGACY_HOMES = {
    "pbanim.results": ("natural_map_residual").split(),
    "pbanim.ode": ("SCIPY_METHODS TABLEAUX Tableau dopri5_step euler_step explicit_rk_step expm_small "
            "exponential_euler_step implicit_euler_step implicit_midpoint_step midpoint_step newton_solve "
            "rk4_step symplectic_euler_step verlet_step").split(),
    "pbanim.ode.driver": ("check_finite").split(),
    "pbanim.scene": ("fixed_steps").split(),
    "pbanim.particles": ("ForceJacobian spring_forces_loop").split(),
    "pbanim.constraints": ("Angle2D Assembly BaumgarteGains Constraint ConstraintCheck ConstraintProjection ConstraintSet "
            "ConstraintSolution EliminationResult LinearCombination SOLVERS STABILIZATIONS Structure "
            "UserConstraint baumgarte_feedback_map baumgarte_gains baumgarte_spectral_radius "
            "baumgarte_stability_limit check_constraint eliminate_readable gains_from_box2d "
            "gains_from_erp_cfm gains_from_mujoco min_norm_lambda solve_lambda solve_multipliers").split(),
    "pbanim.reduced": ("ChartCheck ChartGuard check_chart point_kinematics simulate_fixed").split(),
    "pbanim.rigid": ("AngularDrag LinearDrag MassProperties PointForce QuaternionRenormalize box_inertia box_mesh "
            "capsule_inertia cylinder_inertia dexpinv exp_map_step icosphere_mesh matrix_to_quat "
            "mesh_mass_properties parallel_axis principal_axes quat_conjugate quat_exp quat_from_axis_angle "
            "quat_multiply quat_normalize quat_rotate quat_to_matrix skew sphere_inertia validate_inertia").split(),
    "pbanim.collision": ("BroadPhase Contacts ImpulseBodies ImpulseResult all_pairs apply_impulses box_box box_plane "
            "broad_phase capsule_plane capsule_sphere check_friction check_restitution collide "
            "collision_matrix contact_impulse contact_velocity grid_pairs resolve_collisions solve_lcp_small "
            "sphere_box sphere_plane sphere_sphere").split(),
    "pbanim.contact": ("ContactProblem ContactRows LCP_SOLVERS acceleration_lcp_check assemble_particles "
            "assemble_particles_loop assemble_rigid assemble_rigid_loop friction_directions particle_blocks "
            "particle_rows residual_threshold rigid_rows rigid_state velocity_lcp").split(),
}
_LEGACY = {name: home for home, names in _LEGACY_HOMES.items() for name in names}
# Modules of the flat layout before the subpackages (``from pbanim import rigid_quat`` keeps working).
_LEGACY_MODULES = {
    "collision_broad": "pbanim.collision.broad",
    "collision_impulse": "pbanim.collision.impulse",
    "collision_lcp": "pbanim.collision.lcp",
    "collision_narrow": "pbanim.collision.narrow",
    "collision_scene": "pbanim.collision.scene",
    "collision_shapes": "pbanim.collision.shapes",
    "collision_toi": "pbanim.collision.toi",
    "constraints_assembly": "pbanim.constraints.assembly",
    "constraints_check": "pbanim.constraints.check",
    "constraints_effect": "pbanim.constraints.effect",
    "constraints_kinds": "pbanim.constraints.kinds",
    "constraints_rows": "pbanim.constraints.rows",
    "constraints_solvers": "pbanim.constraints.solvers",
    "contact_assembly": "pbanim.contact.assembly",
    "contact_effect": "pbanim.contact.effect",
    "contact_friction": "pbanim.contact.friction",
    "contact_lcp": "pbanim.lcp.solve",
    "contact_pivoting": "pbanim.lcp.pivoting",
    "lagrangian_codegen": "pbanim.reduced.codegen",
    "ode_adaptive": "pbanim.ode.adaptive",
    "ode_events": "pbanim.ode.events",
    "ode_implicit": "pbanim.ode.implicit",
    "ode_methods": "pbanim.ode.methods",
    "ode_solve": "pbanim.ode.solve",
    "particles_springs": "pbanim.particles.springs",
    "reduced_chart": "pbanim.reduced.chart",
    "rigid_bodies": "pbanim.rigid.bodies",
    "rigid_effects": "pbanim.rigid.effects",
    "rigid_inertia": "pbanim.rigid.inertia",
    "rigid_quat": "pbanim.rigid.quat",
    "rigid_scene": "pbanim.rigid.scene",
}


def __getattr__(name: str):
    home = _LEGACY.get(name)
    if home is not None:
        value = getattr(_importlib.import_module(home), name)
    elif name in _LEGACY_MODULES:
        value = _importlib.import_module(_LEGACY_MODULES[name])
    else:
        raise AttributeError(f"module 'pbanim' has no attribute {name!r}")
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(_LEGACY) | set(_LEGACY_MODULES))
