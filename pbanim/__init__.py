"""pbanim — the reference suite for constrained dynamics in physics-based animation courses.

``import pbanim`` loads numpy and scipy only; sympy, qpsolvers, proxsuite and matplotlib are imported
the first time a function or scene needs them.

Chapters and modules
--------------------
ch01 particles ``pbanim.particles`` · ch02 ODE solvers ``pbanim.ode`` · ch03 constraints
``pbanim.constraints`` · ch04 reduced coordinates ``pbanim.reduced``, ``pbanim.reduced.lagrangian`` · ch05 rigid
bodies ``pbanim.rigid`` · ch06 collisions ``pbanim.collision`` · ch07 resting contact ``pbanim.contact``.
"""

from . import errors, results, ode, scene, particles, accuracy, testing  # noqa: F401
from . import constraints, reduced, rigid, collision, contact  # noqa: F401
from .errors import *  # noqa: F401,F403
from .results import *  # noqa: F401,F403
from .ode import *  # noqa: F401,F403
from .scene import *  # noqa: F401,F403
from .particles.system import *  # noqa: F401,F403
from .constraints import *  # noqa: F401,F403
from .reduced.system import *  # noqa: F401,F403
from .rigid import *  # noqa: F401,F403
from .collision import *  # noqa: F401,F403
from .contact import *  # noqa: F401,F403

__version__ = "0.1.0"
