"""Constrained particle dynamics: Lagrange multipliers, the KKT system, Baumgarte stabilization (ch03).

Governing equations (the lecture's slides, Witkin & Baraff notation)
-----------------------------------------------------------------------
Particles q (positions), q̇, with q̈ = W (Q + Q_C), W = M⁻¹. Constraints C(q) = 0 must hold along the
motion, so Ċ = J q̇ = 0 and C̈ = J q̈ + J̇ q̇ = 0 with J = ∂C/∂q. The constraint force does no work,
Q_Cᵀq̇ = 0 for every admissible q̇, hence Q_C = Jᵀλ and (Witkin's form, with Baumgarte feedback)

    J W Jᵀ λ = −J̇ q̇ − J W Q − k_s C − k_d Ċ

or, keeping q̈ as an unknown (the KKT / saddle-point form, sparse):

    [[M, −Jᵀ], [J, 0]] [q̈; λ] = [Q; b],   b = −J̇ q̇ − k_s C − k_d Ċ.

Notation
--------
=========  ==============================  =================================
symbol     code                            shape
=========  ==============================  =================================
q, q̇       ``x``, ``v`` (``unpack(y)``)     (N, dim) — flat (n,) = (N·dim,)
W = M⁻¹    ``ConstraintSet.Wq``             (n,) diagonal
Q          ``Q``                            (N, dim) / (n,)
C, Ċ       ``Assembly.C``, ``.Cdot``        (m,)
J          ``Assembly.J``                   (m, n) scipy.sparse CSR
J̇q̇         ``Assembly.Jdv``                 (m,)
λ          ``ConstraintSolution.lam``       (m,)
Q_C = Jᵀλ  ``ConstraintSolution.Q_C``       (n,)
k_s, k_d   ``ks``, ``kd``                   scalars, 1/s² and 1/s
=========  ==============================  =================================

Parts: :mod:`pbanim.constraints.base` (the base class of the kinds and their shared argument specs),
:mod:`pbanim.constraints.kinds` (C, J, J̇q̇ of each kind), :mod:`pbanim.constraints.check`
(``UserConstraint``, ``check_constraint``),
:mod:`pbanim.constraints.assembly` (J and JWJᵀ patterns, chain/tree structure),
:mod:`pbanim.constraints.rows` (row gathers, slices and dot products of the kinds and the assembly),
:mod:`pbanim.constraints.solvers` (witkin-dense, witkin-sparse, witkin-cg, kkt, linear; min-norm λ for
redundant rows; :mod:`pbanim.constraints.chain_lean` the linear solver's lean twin on a chain),
:mod:`pbanim.constraints.effect` (the scene effect, projection, gains),
:mod:`pbanim.constraints.stability` (the step limit of Baumgarte feedback).

Limiting cases
--------------
* No constraints: a scene without the effect never assembles J (the stage does not exist).
* k_s = k_d = 0: C̈ = 0 exactly, so C and Ċ drift only by the integrator's truncation error; with explicit
  Euler on a bead, R_{n+1}² = R_n² + h²|v_n|² every step (ORACLES B2).
* Redundant rows: Jᵀλ unique, λ minimum-norm; inconsistent rows raise ``SingularConstraintError``.
* A chain or tree of constraints: JWJᵀ has a perfect elimination order, λ costs O(n) (Baraff 1996).

Baumgarte gains and the knobs of other engines
----------------------------------------------
Error dynamics C̈ + k_d Ċ + k_s C = 0 is a unit-mass spring–damper with ω_b = √k_s, ζ = k_d/(2ω_b).

=====================  ==============================  ===========================================
engine knob            → (k_s, k_d)                    assumptions
=====================  ==============================  ===========================================
(ω_b, ζ)               (ω_b², 2ζω_b)                   definition
Box2D (hertz f, ζ)     ((2πf)², 4πζf)                  soft constraint = spring–damper at f Hz;
                                                       Box2D integrates it implicitly, the
                                                       continuous-time oscillator is the same
MuJoCo solref (τ, ζ)   (1/(τ²ζ²), 2/τ)                 reference acceleration −bĊ − kC with
                                                       b = 2/(d τ), k = d/(d² τ² ζ²), impedance
                                                       d → 1 (hard); for d < 1 multiply by d
Bullet/ODE (ERP, CFM)  (ERP/(h·CFM·m_eff),             spring k_p = ERP/(h·CFM), damper
                       (1 − ERP)/(CFM·m_eff))          c = (1 − ERP)/CFM (ODE's definitions), per
                                                       row effective mass m_eff = 1/(JWJᵀ)_rr
=====================  ==============================  ===========================================

Bullet's CFM = 0 (hard) sends k_s, k_d → ∞ with k_s/k_d = ERP/(h(1 − ERP)) fixed: the overdamped slow
mode Ċ = −(k_s/k_d)C stepped by implicit Euler gives C_{n+1} = (1 − ERP)C_n, Bullet's "fraction of the
error removed per step". Derived here from the cited definitions; see ``gains_from_*`` for code.

References
----------
A. Witkin, "Constrained dynamics", and D. Baraff & A. Witkin, "Physically based modeling", SIGGRAPH
course notes (2001). D. Baraff, "Linear-time dynamics using Lagrange multipliers", SIGGRAPH 1996.
J. Baumgarte, "Stabilization of constraints and integrals of motion", CMAME 1 (1972). E. Catto, "Soft
step", GDC 2011 (Box2D). E. Todorov, MuJoCo documentation, "solref". R. Smith, ODE user guide, §3.8
(ERP and CFM). E. Hairer, C. Lubich, G. Wanner, "Geometric numerical integration", §VII (projection).

Examples
--------
>>> import numpy as np
>>> from pbanim.particles import ParticleSystem, Gravity
>>> from pbanim.scene import Scene
>>> ps = ParticleSystem([[1.0, 0.0]], masses=1.0)             # pendulum released from horizontal
>>> scene = Scene(ps, [Gravity([0.0, -1.0]), Constraints([OnCircle([0], [0.0, 0.0], 1.0)])])
>>> res = scene.simulate(np.pi / 2 * 1.18034, 1e-3, "rk4")   # ≈ time to reach the bottom
>>> bool(abs(res.diagnostics["C_max"][-1]) < 1e-9)
True
"""

from __future__ import annotations

from .assembly import Assembly, ConstraintSet, Structure
from .effect import (STABILIZATIONS, BaumgarteGains, ConstraintProjection, Constraints, baumgarte_gains,
                     gains_from_box2d, gains_from_erp_cfm, gains_from_mujoco, solve_multipliers)
from .stability import baumgarte_feedback_map, baumgarte_spectral_radius, baumgarte_stability_limit
from .check import ConstraintCheck, UserConstraint, check_constraint
from .kinds import (Angle2D, Constraint, Distance, FixedPoint, LinearCombination, OnCircle, OnLine,
                                OnPlane)
from .solvers import (SOLVERS, ConstraintSolution, EliminationResult, eliminate_readable,
                                  min_norm_lambda, solve_lambda)

__all__ = ["Constraint", "Distance", "FixedPoint", "OnCircle", "OnLine", "OnPlane", "LinearCombination",
           "Angle2D", "UserConstraint", "check_constraint", "ConstraintCheck", "ConstraintSet", "Assembly",
           "Structure", "ConstraintSolution", "SOLVERS", "solve_lambda", "min_norm_lambda", "eliminate_readable",
           "EliminationResult",
           "solve_multipliers", "Constraints", "ConstraintProjection", "STABILIZATIONS", "BaumgarteGains",
           "baumgarte_gains", "gains_from_box2d", "gains_from_mujoco", "gains_from_erp_cfm",
           "baumgarte_feedback_map", "baumgarte_spectral_radius", "baumgarte_stability_limit"]
