"""The assignments of the course, one or more per chapter (registered on import of this module).

========================  =======  =================================  ============================================
assignment                chapter  reference module                   the student writes
========================  =======  =================================  ============================================
ch01_particles            01       pbanim/particles/system.py         ẏ = [v, WQ], gravity, drag, symplectic Euler
ch02_integrators          02       pbanim/ode/methods.py              Euler, symplectic Euler, Verlet, RK tableau
ch03_constraints          03       pbanim/constraints/effect.py       the multiplier solve with Baumgarte
ch04_reduced              04       pbanim/reduced/system.py           (JᵀMJ)ü = Jᵀ(Q − M J̇u̇) and Q_C
ch05_rigid_body           05       pbanim/rigid/bodies.py             I⁻¹_world, ω, Baraff's ẏ
ch05_rigid_step           05       pbanim/rigid/effects.py            torque of a point force, renormalization
ch06_impulses             06       pbanim/collision/impulse.py        u, K, Newton's impulse law
ch07_lcp                  07       pbanim/lcp/solve.py                projected Gauss–Seidel for the contact LCP
ch08_pd_control           08       pbanim/control/pd.py               explicit, stable, implicit PD; torque limits
ch08_rnea_derivatives     08       pbanim/articulated/derivatives.py  ∂τ/∂q, ∂τ/∂q̇ of RNEA; ABA's by H⁻¹
ch09_pressure             09       pbanim/fluids/grid.py              MAC divergence, gradient, open-face counts
ch10_impact_gradient      10       pbanim/design/impact.py            event time, δj, the saltation's flow term
ch10_contact_sensitivity  10       pbanim/design/stepped_sim.py       δz of a contact step on its active set
ch12_cloth_spring         12       pbanim/cloth/conditions.py         a spring's force, ∂f/∂x and ∂f/∂v blocks
========================  =======  =================================  ============================================

Every chapter's assignment is ready. A new one is registered here once its reference module carries
solution markers and a checks module exists: an :class:`~pbanim.course.registry.Assignment` with
``checks`` (100 points), ``mutants`` (typical bugs and the checks that catch them) and ``status="ready"``;
until then it may be registered with ``status="pending"`` and the reason (``make`` and ``grade`` refuse it).
"""

from __future__ import annotations

from . import (checks_cloth, checks_constraints, checks_contact, checks_control, checks_derivatives, checks_design,
               checks_design_contact, checks_fluids, checks_ode, checks_particles, checks_rigid)
from .registry import ASSIGNMENTS, Assignment, register

__all__ = ["ASSIGNMENTS"]


def _ready(name, chapter, title, module, summary, checks_module, prefix=""):
    checks = getattr(checks_module, f"{prefix}CHECKS")
    mutants = getattr(checks_module, f"{prefix}MUTANTS")
    return register(Assignment(name, chapter, title, module, summary, tuple(checks), tuple(mutants)))


_ready("ch01_particles", "ch01", "Force objects and a particle step", "pbanim.particles.system",
       "Write Newton's law as a first-order system (ParticleSystem.derivative), the gravity and drag force "
       "objects (Gravity.apply, Gravity.potential_energy, Drag.apply) and the in-place symplectic Euler step "
       "ParticleSystem.kick_drift (kick the velocity with the force, then drift the position with the new "
       "velocity).", checks_particles)
_ready("ch02_integrators", "ch02", "Integrators", "pbanim.ode.methods",
       "Write explicit Euler, symplectic Euler (kick then drift), velocity Verlet and the generic explicit "
       "Runge–Kutta step from a Butcher tableau (explicit_rk_step).", checks_ode)
_ready("ch03_constraints", "ch03", "Constraint multipliers with Baumgarte stabilization",
       "pbanim.constraints.effect",
       "Write the right-hand side c = −J̇q̇ − k_s C − k_d Ċ of the multiplier system J W Jᵀ λ = c − J W Q and "
       "solve it (solve_multipliers and Constraints._solve; the linear solve solve_lambda is given).",
       checks_constraints, "CH03_")
_ready("ch04_reduced", "ch04", "A pendulum in reduced coordinates", "pbanim.reduced.system",
       "Write the reduced equations of motion (JᵀMJ) ü = Jᵀ(Q − M J̇u̇) in ReducedSystem._solve and the "
       "constraint force Q_C = M q̈ − Q in ReducedSystem.constraint_force.", checks_constraints, "CH04_")
_ready("ch05_rigid_body", "ch05", "The rigid-body state and its derivative", "pbanim.rigid.bodies",
       "Write the world-frame inverse inertia R I⁻¹_body Rᵀ, the velocities v = P/m and ω = I⁻¹_world L, and "
       "Baraff's derivative ẏ = [v, ½(0, ω)⊗q, F, τ] for all bodies (RigidBodies.derivative_and_omega).",
       checks_rigid, "BODY_")
_ready("ch05_rigid_step", "ch05", "Torques and the quaternion step", "pbanim.rigid.effects",
       "Write the force and torque of a force applied at a body point (PointForce.apply: F += f, τ += r × f "
       "with r = R r_body) and the post-step quaternion renormalization q ← q/|q| "
       "(QuaternionRenormalize.post_step).", checks_rigid, "STEP_")
_ready("ch06_impulses", "ch06", "Collision impulses", "pbanim.collision.impulse",
       "Write the relative contact velocity u = ṗ_a − ṗ_b, the collision matrix K, the application of impulses "
       "to velocities, and Newton's impulse law with Coulomb friction (contact_impulse).",
       checks_contact, "CH06_")
_ready("ch07_lcp", "ch07", "The contact LCP by projected Gauss–Seidel", "pbanim.lcp.solve",
       "Write projected Gauss–Seidel for w = A f + b ≥ 0, f ≥ 0, fᵀw = 0 (pgs): sweep the contacts, set "
       "fᵢ ← max(0, fᵢ − ω wᵢ/Aᵢᵢ), stop when the natural-map residual is below the threshold.",
       checks_contact, "CH07_")
_ready("ch08_pd_control", "ch08", "PD servos: explicit, stable and implicit", "pbanim.control.pd",
       "Write the lecture's servo τ = k_p(θ̄ − θ) − k_v θ̇ with torque limits (PDServo.explicit), the split "
       "τ = τ₀ − k θ̇⁺ of stable and implicit PD (PDServo.stable), stable PD on a coupled system "
       "(M + h K_v) q̈ = −C − K_p(q + h q̇ − q̄) − K_v q̇ (stable_pd_acceleration) and one semi-implicit Euler step "
       "of a servoed mass for each servo (pd_step), whose stability regions the grader measures.", checks_control)
_ready("ch09_pressure", "ch09", "The pressure projection on the MAC grid", "pbanim.fluids.grid",
       "Write the MAC grid's divergence (D u)_c = Σᵢ (uᵢ(c + ½eᵢ) − uᵢ(c − ½eᵢ))/Δx (Grid.divergence), its gradient "
       "(G p)_f = open_f (p(c + eᵢ) − p(c))/Δx, zero on wall and obstacle faces (Grid.gradient), and the number of "
       "open faces of each cell, the diagonal of −Δx² L (Grid.neighbours). pbanim's projection u ← u − G p with "
       "−L p = −D u then runs on your grid, and the grader measures what it leaves.", checks_fluids)
_ready("ch10_impact_gradient", "ch10", "∂S/∂u through an impact: the saltation jump", "pbanim.design.impact",
       "Write how the sensitivities Φ = ∂y/∂u jump at an impact: the moving event time δτ = −δg/ġ and "
       "T_s = T + δτ f⁻ (apply_impact.event_time: define `gdot`, `dtau` and `Ts`, which the given code after it "
       "uses), the impulse's tangent δj = −(δε v_rel + (1 + ε) δv_rel + "
       "j δk)/k applied to the momenta (apply_impact.impulse_derivative), and the flow term T⁺ = T₁ − δτ f⁺ "
       "after the jump (saltation_post). The impulse itself (chapter 6) and the contact quantities' tangents "
       "are given.", checks_design)
_ready("ch12_cloth_spring", "ch12", "A cloth spring and its Jacobians for large steps", "pbanim.cloth.conditions",
       "Write the force of the springs of a cloth and the 3 × 3 blocks of its Jacobians "
       "(SpringCondition.pair_terms): f_a = −(k(|d| − r) + k_d ŵ·u) ŵ = −f_b, B_K = −(k ŵŵᵀ + s P + k_d ŵ (P u)ᵀ) "
       "with P = (𝟙 − ŵŵᵀ)/|d|, B_D = −k_d ŵŵᵀ, and the symmetric B_K that the large step's conjugate gradients "
       "need (exact=False: s clamped at 0, the last term left out). pbanim assembles K = ∂f/∂x and D = ∂f/∂v "
       "from your blocks.", checks_cloth)
_ready("ch08_rnea_derivatives", "ch08", "Analytical derivatives of RNEA and ABA", "pbanim.articulated.derivatives",
       "Differentiate the recursive Newton–Euler algorithm along q and q̇ (Carpentier & Mansard 2018): the forward "
       "pass's ∂v̂_i, ∂â_i, ∂f̂_i with the moved transform's terms (ⁱX_λ v̂_λ)× S_i and (ⁱX_λ â_λ)× S_i "
       "(_rnea_derivatives.forward), the backward pass ∂τ_i = S_iᵀ ∂f̂_i, ∂f̂_λ += ⁱX_λᵀ ∂f̂_i + ⁱX_λᵀ f̂_i‾ S_i "
       "(_rnea_derivatives.backward), and ABA's derivatives ∂q̈/∂q = −H⁻¹ ∂τ/∂q, ∂q̈/∂q̇ = −H⁻¹(∂τ/∂q̇ + B), "
       "∂q̈/∂τ = H⁻¹ (aba_derivatives.implicit). RNEA, CRBA and ABA themselves are given.", checks_derivatives)
_ready("ch10_contact_sensitivity", "ch10", "∂S/∂u through a contact step: the active set's linear system",
       "pbanim.design.stepped_sim",
       "Differentiate one velocity-level contact step (chapter 07's box friction) on its active set "
       "(contact_step.active_set): build K δz = r with identity rows for a separating contact, the rows of A and "
       "r = −δw|_z for a sticking one, and for a sliding tangent the normal row of A and δτⱼ − σⱼ μ δλ = σⱼ λ δμ; "
       "solve it in least squares (redundant contacts). The contact solve, δw|_z and the map from δz to the "
       "state's tangent are given.", checks_design_contact)
