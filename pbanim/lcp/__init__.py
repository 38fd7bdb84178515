"""The LCP / QP core (chapters 06–07, and joint limits and controllers to come).

One linear complementarity problem serves collision impulses, resting contact and friction:

    w = A f + b ≥ 0,   f ≥ 0,   fᵀ w = 0.

Parts: :mod:`pbanim.lcp.solve` (``solve_lcp``: one signature for every solver, projected Gauss–Seidel, the
certificate; ``delassus``: the matrix A = J W Kᵀ from per-contact Jacobian rows), :mod:`pbanim.lcp.qp` (the
QP through proxsuite or any qpsolvers backend, each asked for the accuracy in its own settings, a backend's
exception returned as a status), :mod:`pbanim.lcp.specs` (what the arguments must be: the solvers' options
by name, the rows of a second Jacobian), :mod:`pbanim.lcp.pivoting` (Lemke's complementary pivoting, Dantzig-style principal
pivoting, enumeration of active sets), :mod:`pbanim.lcp.active_set` (block principal pivoting, the
Goldfarb–Idnani dual active set, the box-friction active set), :mod:`pbanim.lcp.box` (projected
Gauss–Seidel with box friction and bounds) and :mod:`pbanim.lcp.colored` (its colored, vectorized sweep). Collision impulses (chapter 06) and resting contact (chapter 07)
both build A with ``delassus`` and solve with these solvers: each algorithm exists once. Every answer
is judged by the natural-map residual ‖f − max(0, f − w)‖∞ (:func:`pbanim.results.natural_map_residual`)
computed from A and b (ORACLES D8), never by the solver's own claim.
"""

from __future__ import annotations

from .pivoting import dantzig, enumerate_active_sets, lemke, residual_threshold
from .planar import solve_planar_contact
from .solve import LCP_SOLVERS, delassus, pgs_bounded, pgs_box_friction, solve_lcp

__all__ = ["solve_planar_contact", "solve_lcp", "LCP_SOLVERS", "lemke", "dantzig", "enumerate_active_sets", "residual_threshold",
           "delassus", "pgs_box_friction", "pgs_bounded"]
