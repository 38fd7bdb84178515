"""The LCP / QP core (chapters 06–07, and joint limits and controllers to come).

One linear complementarity problem serves collision impulses, resting contact and friction:

    w = A f + b ≥ 0,   f ≥ 0,   fᵀ w = 0.

Parts: :mod:`pbanim.lcp.solve` (``solve_lcp``: one signature for every solver, QP through qpsolvers and
proxsuite, projected Gauss–Seidel, the certificate) and :mod:`pbanim.lcp.pivoting` (Lemke's
complementary pivoting and Dantzig-style principal pivoting). Every answer is judged by the natural-map
residual ‖f − max(0, f − w)‖∞ computed from A and b (ORACLES D8), never by the solver's own claim.
"""

from __future__ import annotations

from .pivoting import dantzig, lemke, residual_threshold
from .solve import LCP_SOLVERS, solve_lcp

__all__ = ["solve_lcp", "LCP_SOLVERS", "lemke", "dantzig", "residual_threshold"]
