"""Rigid-body dynamics with Baraff's state (chapter 05): many bodies, one set of arrays.

Governing equations (Newton–Euler in momentum form; Baraff 1997, Witkin & Baraff 2001 course notes)
----------------------------------------------------------------------------------------------------
Each body carries the state (x, q, P, L): centre of mass, unit quaternion, linear and angular momentum.
Everything else is derived from it:

    R = R(q/|q|),   v = P/m,   I⁻¹_world = R I⁻¹_body Rᵀ,   ω = I⁻¹_world L,

and the state obeys

    ẋ = v,   q̇ = ½ (0, ω) ⊗ q,   Ṗ = F,   L̇ = τ      (F, τ: total force and torque about x, world frame).

The generalized force Q of a body is the row [F, τ] (shape (N, 6)); a force f at a world point p adds
F += f and τ += (p − x) × f. With no torque, L̇ = 0 and *every* integrator keeps L exactly: that is why
Baraff integrates L rather than ω (integrating Euler's equations I ω̇ + ω × Iω = τ for ω lets L drift).
Kinetic energy T = ½ P·v + ½ L·ω; momenta Σ P and Σ (x × P + L) about the origin.

Quaternions. An integrator moves q off the unit sphere (explicit Euler: |q_{n+1}| = |q_n|·√(1 + h²|ω|²/4),
ORACLES C3). R is always built from q/|q|, and a scene either renormalizes q after every step (the
default post-step stage "renormalize") or steps q on the rotation group with the exponential map,
q ← exp(½θ) ⊗ q, where the Runge–Kutta–Munthe-Kaas local coordinate θ obeys θ̇ = dexp⁻¹_θ(ω); see
:class:`pbanim.rigid.RigidScene`.

Notation
--------
==================  =======================  ===========
symbol              code                     shape
==================  =======================  ===========
x                   ``x``                    (N, 3)
q                   ``quat``                 (N, 4)  scalar first (w, x, y, z)
P, L                ``P, L``                 (N, 3)
m, W = 1/m          ``mass, inv_mass``       (N,)    W = 0: static body
I_body, I⁻¹_body    ``I_body, inv_I_body``   (N, 3, 3)
R                   ``R``                    (N, 3, 3)
v, ω                ``v, omega``             (N, 3)
Q = [F, τ]          ``Q``                    (N, 6)
y = [x, q, P, L]    ``y``                    (13N,)  split = 7N
h                   ``h``                    step
==================  =======================  ===========

Body index −1 is the static world: per-body arrays are padded with one zero-inverse-mass row
(``inv_mass_padded``), so no formula special-cases it.

Limiting cases: I⁻¹_body = 0 and W = 0 give a static body; an isotropic body (sphere) has ω ∥ L and
constant |ω|; a body spinning about a principal axis keeps ω constant; a torque-free asymmetric body
follows Euler's closed form in Jacobi elliptic functions (:mod:`pbanim.models.rigid`, ORACLES C1).

References
----------
D. Baraff, "An introduction to physically based modeling: rigid body simulation I — unconstrained rigid
body dynamics", SIGGRAPH 1997 course notes; A. Witkin & D. Baraff, *Physically Based Modeling*, SIGGRAPH
2001 course; L. D. Landau & E. M. Lifshitz, *Mechanics*, §§32–37; H. Munthe-Kaas, "High order
Runge–Kutta methods on manifolds", Appl. Numer. Math. 1999; Hairer, Lubich & Wanner, *Geometric
Numerical Integration*, §IV.8, §VII.5.

Parts: :mod:`pbanim.rigid.bodies` (the system), :mod:`pbanim.rigid.protocol` (its body protocol: points,
impulses, inverse-mass blocks), :mod:`pbanim.rigid.quat` (quaternions), :mod:`pbanim.rigid.inertia` (mass
properties), :mod:`pbanim.rigid.admissible` (which inertia tensors a body can have),
:mod:`pbanim.rigid.effects` (forces, torques, renormalization), :mod:`pbanim.rigid.scene` (scene with
quaternion handling and rigid diagnostics), :mod:`pbanim.rigid.lean` (the same step on plain floats for a
scene of a few bodies under gravity and drag: what such a scene runs, equal to the readable step to
roundoff), :mod:`pbanim.rigid.domain` (what each argument must be: the specs of the argument contracts the
vocabulary of :mod:`pbanim.contracts` lacks).

Every public callable declares its arguments (:func:`pbanim.contracts.contract`): a call from outside
the package with a wrong shape, a NaN, a zero quaternion, a batch of states where one is expected or an
inertia tensor no body can have is refused by name; a result that overflows from finite input is a
:class:`~pbanim.errors.NonFiniteResult` (:class:`~pbanim.errors.SimulationDiverged` inside a run).

Example
-------
>>> import numpy as np
>>> rb = RigidBodies(mass=1.0, inertia=box_inertia(1.0, [1.0, 2.0, 3.0]),
...                  angular_velocities=[[0.1, 3.0, 0.1]])
>>> res = RigidScene(rb).simulate(1.0, 0.01, method="rk4")
>>> L = res.diagnostics["angular_momentum"]
>>> bool(np.all(L == L[0]))                     # torque-free: L exact with Baraff's state
True
"""

from __future__ import annotations

from .bodies import RigidBodies
from .effects import AngularDrag, LinearDrag, PointForce, QuaternionRenormalize, RigidGravity, \
    RigidSprings
from .inertia import MassProperties, box_inertia, box_mesh, capsule_inertia, cylinder_inertia, \
    icosphere_mesh, mesh_mass_properties, parallel_axis, principal_axes, sphere_inertia, validate_inertia
from .quat import matrix_to_quat, quat_conjugate, quat_exp, quat_from_axis_angle, quat_multiply, \
    quat_normalize, quat_rotate, quat_to_matrix, skew
from .scene import RigidScene, dexpinv, exp_map_step

__all__ = ["RigidBodies", "RigidScene", "exp_map_step", "dexpinv",
           "RigidGravity", "PointForce", "RigidSprings", "LinearDrag", "AngularDrag", "QuaternionRenormalize",
           "MassProperties", "box_inertia", "sphere_inertia", "cylinder_inertia", "capsule_inertia",
           "mesh_mass_properties", "parallel_axis", "principal_axes", "validate_inertia", "box_mesh",
           "icosphere_mesh",
           "quat_multiply", "quat_conjugate", "quat_normalize", "quat_to_matrix", "matrix_to_quat",
           "quat_from_axis_angle", "quat_exp", "quat_rotate", "skew"]
