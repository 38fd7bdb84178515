"""Particles (chapter 01): point masses and Witkin's force objects.

``ParticleSystem`` holds N point masses in 2-D or 3-D with the flat state y = [x.ravel(), v.ravel()] and
ẋ = v, v̇ = W Q(t, x, v), W = M⁻¹; force objects (gravity, drag, damped springs, anchor springs, user
forces) are scene effects that add to Q. Parts: :mod:`pbanim.particles.system` (the system, gravity,
drag), :mod:`pbanim.particles.springs` (vectorized damped springs with sparse ∂Q/∂x, ∂Q/∂v, and the
readable per-spring loop they are tested against), :mod:`pbanim.particles.forces` (anchor springs, user
forces) and :mod:`pbanim.particles.specs` (the argument specs of chapters 01 and 03 beyond
:mod:`pbanim.contracts`).
"""

from __future__ import annotations

from ..scene import Effect  # noqa: F401  (importable here before the move)
from .system import (AnchorSprings, DampedSprings, Drag, ForceJacobian, Gravity, ParticleSystem, UserForce,
                     spring_forces_loop)

__all__ = ["ParticleSystem", "ForceJacobian", "Gravity", "Drag", "DampedSprings", "AnchorSprings", "UserForce",
           "spring_forces_loop"]
