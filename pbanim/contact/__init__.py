"""Resting contact (chapter 07): contact forces by QP and LCP, friction, stacks.

The lecture's three conditions on the contact forces fᵢ (Baraff 1994), for contacts i = 1…m with
separation dᵢ = nᵢ·(p_a − p_b):

1. no inter-penetration   d̈ᵢ = Aᵢ f + bᵢ ≥ 0,
   d̈ᵢ = nᵢ·(p̈_a − p̈_b) + 2 ṅᵢ·(ṗ_a − ṗ_b)      (at the contact instant, dᵢ = 0)
2. no glue                fᵢ ≥ 0
3. no force on a breaking contact   fᵢ d̈ᵢ = 0

— a linear complementarity problem (LCP). With A = J W Jᵀ symmetric PSD it is the optimality
condition of the QP  min ½ fᵀAf + bᵀf  s.t. f ≥ 0  ("solved with a QP solver", as on the slide).
The contact force enters the equations of motion as Q_C = Jᵀ f:  q̈ = W (Q + Q_C).

==================  =====================  ============  =========================================
symbol              code                   shape         meaning
==================  =====================  ============  =========================================
f                   ``ContactSolution.f``  (m,)          contact force magnitudes
A, b                ``A, b``               (m,m), (m,)   d̈ = A f + b
J                   ``ContactProblem.J``   (m, n)        contact Jacobian (n generalized velocities)
W = M⁻¹             ``ContactProblem.W``   (n, n)        inverse mass (1/m, I⁻¹ per body)
Q, Q_C              ``Q``                  (N, 6)/(N,d)  applied and contact generalized forces
k_s, k_d            ``stiffness, damping`` scalars       Baumgarte stabilization gains
μ, k                ``friction, facets``                 Coulomb coefficient, friction-cone facets
==================  =====================  ============  =========================================

Parts
-----
* :mod:`pbanim.lcp.solve` — ``solve_lcp(A, b, solver="qp"|"lemke"|"dantzig"|"pgs"|"bpp")`` with a
  certificate (natural-map residual) every time; failures (a QP backend's own exception included) raise
  ``InfeasibleContact``, or return ``success=False`` with the status when asked.
* :mod:`pbanim.contact.assembly` — A and b for rigid bodies and particles (vectorized; the readable
  per-contact loops, tested equal, in :mod:`pbanim.contact.readable`).
* :mod:`pbanim.contact.specs` — what the arguments must be: systems, their states and forces, contacts
  among their bodies (also checked on what a user's ``detect(y)`` returns inside a step).
* :mod:`pbanim.contact.effect` — ``RestingContact``: the scene effect (phase "constraint").
* :mod:`pbanim.contact.friction` — polyhedral friction cones and the velocity-level
  (Stewart–Trinkle / Anitescu–Potra) time-stepping scheme; Painlevé detection at the acceleration level.

Limiting cases: all bᵢ ≥ 0 (every contact separating by itself) → f = 0; one body on the ground with
its weight as the only load → Σf = m g; μ = 0 → the velocity-level scheme is a frictionless LCP.

References: D. Baraff, "Fast contact force computation for nonpenetrating rigid bodies", SIGGRAPH 1994;
D. Baraff, A. Witkin, "Physically based modeling", SIGGRAPH 2001 course notes (rigid body simulation II);
D. E. Stewart, J. C. Trinkle, IJNME 1996; M. Anitescu, F. A. Potra, Nonlinear Dynamics 1997;
R. W. Cottle, J.-S. Pang, R. E. Stone, *The Linear Complementarity Problem*, 1992.
"""

from .assembly import *  # noqa: F401,F403
from .assembly import __all__ as _all_assembly
from .effect import *  # noqa: F401,F403
from .effect import __all__ as _all_effect
from .friction import *  # noqa: F401,F403
from .friction import __all__ as _all_friction
from ..lcp.solve import *  # noqa: F401,F403
from ..lcp.solve import __all__ as _all_lcp

__all__ = [*_all_lcp, *_all_assembly, *_all_effect, *_all_friction]
