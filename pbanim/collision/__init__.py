"""Collisions: detection (points, normals, depths) and impulses with restitution ε and friction μ (ch06).

The lecture: between two steps, bodies may interpenetrate. *Detection* finds contacts — a point p, a unit
normal n from body b to body a, a depth — first cheaply (broad phase: which pairs can touch), then exactly
(narrow phase: sphere–plane, sphere–sphere, box–plane, box–box by separating axes, capsule–plane,
capsule–sphere). *Response* changes velocities instantly by impulses J so that, along n,

    v⁺_rel = −ε v⁻_rel,          v_rel = n·(ṗ_a − ṗ_b),  ṗ = v + ω × (p − x),

which for one frictionless contact gives Baraff's impulse

    j = −(1+ε) v⁻_rel / (1/m_a + 1/m_b + n·(I_a⁻¹(r_a×n))×r_a + n·(I_b⁻¹(r_b×n))×r_b),

and with Coulomb friction a tangential part bounded by μ j (stick vs slip decided exactly, see
:mod:`pbanim.collision.impulse`). The *time of impact* is either found by event location — the ODE
solver's bracketing root finder on the signed distance splits the step at the collision, the impulse is
applied and the solver restarted — or ignored: fixed-step detection after the step (penetration, then
impulse). A contact approaching slower than the *restitution threshold* ``rest_velocity`` is resting:
it gets ε = 0. Under gravity a body gains g·h of approach speed per step, so the threshold must exceed
g·h or a resting ball jitters (ORACLES D10); the default is 3·g·h.

=================  ==================  ============  ====================================================
symbol             code                shape         meaning
=================  ==================  ============  ====================================================
p, n, depth        ``Contacts``        (m, 3) ...    contact points, normals (b → a), penetration depths
a, b               ``Contacts.a/b``    (m,) int      body indices; −1 is the static world
ε                  ``restitution``     scalar        coefficient of restitution, in [0, 1]
μ                  ``friction``        scalar        Coulomb coefficient, ≥ 0
K                  ``collision_matrix``(m, 3, 3)     Δu = K J at one contact
W = M⁻¹            ``inv_mass, inv_I`` (B+1,) ...    inverse masses/inertias with the world row (zero)
v_rest             ``rest_velocity``   scalar        restitution threshold (m/s)
=================  ==================  ============  ====================================================

Limiting cases: ε = 1 conserves energy in a single frictionless impact, ε = 0 is plastic (v⁺_rel = 0);
an infinite mass (the world, a static body) receives the impulse and does not move; μ = 0 leaves the
tangential velocities unchanged; μ → ∞ makes every impact stick.

Parts: :mod:`pbanim.collision.shapes` (shapes, ``Contacts``), :mod:`pbanim.collision.narrow`,
:mod:`pbanim.collision.broad`, :mod:`pbanim.collision.lcp` (small LCPs: Lemke, enumeration),
:mod:`pbanim.collision.impulse` (with :mod:`pbanim.collision.simultaneous`: the simultaneous law in
rounds, and the certificate every impulse answer passes: no contact left approaching, no energy gained),
:mod:`pbanim.collision.scene` (the ``Collisions`` post-step effect), :mod:`pbanim.collision.toi` (the driver
``simulate_collisions``, event location vs fixed-step detection), :mod:`pbanim.collision.lean` (its step
on floats for one particle among planes, equal to the readable one to the root finder's roundoff),
:mod:`pbanim.collision.specs` (what the
arguments must be: body indices, unit normals, rotations, PSD matrices — the contracts' extra vocabulary).

References: Witkin & Baraff, *Physically Based Modeling* SIGGRAPH course notes (Baraff: Rigid body
simulation, §8 collisions); Baraff 1989 (analytical methods for dynamic non-penetrating rigid bodies);
Mirtich 1996; Ericson, *Real-Time Collision Detection* (2005); Gottschalk, Lin & Manocha 1996 (SAT).
"""

from __future__ import annotations

from .shapes import *  # noqa: F401,F403
from .shapes import __all__ as _shapes
from .narrow import *  # noqa: F401,F403
from .narrow import __all__ as _narrow
from .broad import *  # noqa: F401,F403
from .broad import __all__ as _broad
from .lcp import *  # noqa: F401,F403
from .lcp import __all__ as _lcp
from .impulse import *  # noqa: F401,F403
from .impulse import __all__ as _impulse
from .scene import *  # noqa: F401,F403
from .scene import __all__ as _scene
from .toi import *  # noqa: F401,F403
from .toi import __all__ as _toi

__all__ = list(_shapes) + list(_narrow) + list(_broad) + list(_lcp) + list(_impulse) + list(_scene) + list(_toi)
