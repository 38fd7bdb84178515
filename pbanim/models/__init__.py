"""Canonical systems with their exact solutions and invariants — one list for tests, chapters, assignments.

One submodule per chapter, all re-exported here (numpy/scipy only at import):

=================  ==================================================================================
submodule          systems
=================  ==================================================================================
``models.particles`` projectile with linear drag, two-body spring, hanging net (ch01)
``models.ode``     harmonic and damped oscillators, projectile with linear drag, Kepler orbit,
                   two-body spring, pendulum with its elliptic-integral period (ch01, ch02)
``models.constrained`` bead on a circle, hanging chains, redundant constraints (ch03)
``models.reduced`` n-link pendulums, spherical pendulum, bead on a rotating hoop, cart-pendulum (ch04)
``models.rigid``   torque-free asymmetric body (Jacobi elliptic solution), T-handle (ch05)
``models.collision`` bouncing ball, Newton's cradle, oblique spheres, falling rod (ch06)
``models.contact`` box on plane, box stacks, incline, Painlevé rod, degenerate LCPs (ch07)
=================  ==================================================================================
"""

from .ode import *  # noqa: F401,F403
from .particles import *  # noqa: F401,F403
from .constrained import *  # noqa: F401,F403
from .reduced import *  # noqa: F401,F403
from .rigid import *  # noqa: F401,F403
from .collision import *  # noqa: F401,F403
from .contact import *  # noqa: F401,F403
