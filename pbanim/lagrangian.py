"""Lagrangian mechanics with sympy (chapter 04): the stable import path ``pbanim.lagrangian``.

The code lives in :mod:`pbanim.reduced.lagrangian` (derivation) and :mod:`pbanim.reduced.codegen`
(compilation); this module re-exports their public names so that course material written against
``pbanim.lagrangian`` keeps working. Importing it imports sympy.
"""

from __future__ import annotations

from .reduced.lagrangian import (EulerLagrangeEquations, LagrangianSystem, cache_info, clear_cache,
                                 compile_equations, derive_equations, energy_rate, lagrangian_system, speeds_for)
from .reduced.chart import point_kinematics, validate_coords  # noqa: F401  (importable here before the move)

__all__ = ["EulerLagrangeEquations", "LagrangianSystem", "derive_equations", "compile_equations",
           "lagrangian_system", "clear_cache", "cache_info", "energy_rate", "speeds_for"]
