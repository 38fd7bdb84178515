"""Articulated bodies (chapter 08, part 1): trees of links and joints in reduced coordinates.

Limbs can be simulated two ways. In *maximal* coordinates each link is a rigid body and joints are
constraints between them (Newton–Euler plus Lagrange multipliers). In *reduced* coordinates the joint
angles are the state: no constraint can drift, but the equations of motion

    H(q) q̈ + C(q, q̇) = τ,        H = Σᵢ Jᵢᵀ Iᵢ Jᵢ  (the joint-space mass matrix)

couple every link. Featherstone's spatial algebra (6-D motion and force vectors, Plücker transforms)
turns the three questions of dynamics into recursions over the tree:

=====================  ==========================================  =======  =================================
question               algorithm                                   cost     code
=====================  ==========================================  =======  =================================
τ for a given q̈        RNEA, recursive Newton–Euler                O(n)     :func:`rnea`
H(q)                   CRBA, composite rigid bodies                O(n d)   :func:`crba` (d = tree depth)
q̈ for a given τ        ABA, articulated bodies                     O(n)     :func:`aba`
∂τ/∂(q, q̇), ∂q̈/∂(q,   derivatives of RNEA and ABA (Carpentier &    O(n nv)  :func:`rnea_derivatives`,
q̇, τ)                  Mansard 2018)                                         :func:`aba_derivatives`
=====================  ==========================================  =======  =================================

In maximal coordinates, :class:`RigidJoints` (ball, hinge, slider, weld) holds rigid bodies of a
:class:`~pbanim.rigid.RigidScene` together with multipliers, as chapter 03 does for particles; the tests
check that both ways give the same motion (ORACLES G1).

Readable one-state versions (:mod:`.dynamics`) stand beside versions vectorized over K states
(:mod:`.batched`, arrays of shape (K, nq)); tests check that the two agree and that RNEA inverts ABA,
ABA equals the CRBA solve, H is symmetric positive definite and energy is conserved (ORACLES I1–I5).

Notation: q, q̇, q̈ joint positions, velocities, accelerations; τ joint forces; v̂, â, f̂ spatial motion
and force vectors (angular part first); ⁱX_λ(i) the transform from the parent λ(i) to link i; S_i the
joint's motion subspace; I_i the link's spatial inertia; g gravity.

References: R. Featherstone, *Rigid Body Dynamics Algorithms*, Springer 2008 (chapters 2, 5–7);
Featherstone & Orin, "Dynamics", Springer Handbook of Robotics, 2016; Mirtich, *Impulse-based dynamic
simulation of rigid body systems*, PhD thesis 1996 (ch. 4, the articulated-body method).
"""

from __future__ import annotations

from .batched import aba_batch, crba_batch, energy_batch, rnea_batch
from .fast import aba_fast
from .derivatives import aba_derivatives, rnea_derivatives, tangent_step
from .derivatives_batch import aba_derivatives_batch, rnea_derivatives_batch
from .dynamics import (SingularJointInertia, aba, bias_forces, check_articulated_inertia, crba, kinetic_energy,
                       link_transforms, potential_energy, rnea)
from .joints import JOINTS, RigidJoint, RigidJoints
from .planar import NotPlanarError, PlanarKernel
from .planar_step import PlanarContactStep, PlanarGround, solve_planar_contact
from .system import ArticulatedSystem
from .urdf import load_urdf, rpy_matrix
from .spatial import crf, crm, plucker, plucker_inverse, rotation, spatial_inertia
from .tree import JOINT_TYPES, ONE_DOF, ROTATING, ArticulatedTree, Joint, Link

__all__ = ["PlanarKernel", "NotPlanarError", "PlanarContactStep", "PlanarGround", "solve_planar_contact",
           "ArticulatedTree", "ArticulatedSystem", "RigidJoints", "RigidJoint", "JOINTS", "load_urdf", "rpy_matrix",
           "Joint", "Link", "JOINT_TYPES", "ROTATING", "ONE_DOF", "rnea", "crba", "aba", "bias_forces",
           "kinetic_energy", "potential_energy", "link_transforms", "check_articulated_inertia",
           "SingularJointInertia", "rnea_batch", "crba_batch", "aba_batch", "aba_fast", "energy_batch",
           "plucker", "plucker_inverse", "crm", "crf", "spatial_inertia", "rotation", "rnea_derivatives",
           "aba_derivatives", "rnea_derivatives_batch", "aba_derivatives_batch", "tangent_step"]
