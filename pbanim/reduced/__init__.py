"""Reduced coordinates and Lagrangian mechanics (chapter 04).

Particles moved by generalized coordinates u through a chart q = q(u): the constraint is built into the
state, and (JᵀMJ) ü = Jᵀ(Q − M J̇ u̇) needs no multiplier. Parts: :mod:`pbanim.reduced`
(``ReducedSystem`` from sympy maps or numeric callables), :mod:`pbanim.reduced.chart` (the singular-chart
guard, point kinematics, the fixed-step chart driver), :mod:`pbanim.reduced.inputs` (what the chapter's
arguments must be: real numbers or real sympy expressions, coordinates, point masses), and, imported on
demand because they load sympy, :mod:`pbanim.reduced.lagrangian` (L = T − V → Euler–Lagrange equations)
and :mod:`pbanim.reduced.codegen` (compiling them to a fast numeric right-hand side). ``import pbanim.reduced`` does not import sympy.
"""

from __future__ import annotations

from ..errors import SingularChartError  # noqa: F401  (importable here before the move)
from .chart import PointKinematics, validate_coords
from .system import ChartCheck, ChartGuard, ReducedSystem, check_chart, point_kinematics, simulate_fixed

__all__ = ["ReducedSystem", "ChartGuard", "ChartCheck", "check_chart", "point_kinematics", "PointKinematics",
           "simulate_fixed", "validate_coords"]
