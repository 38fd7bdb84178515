"""The stepping loops' routes to the LCP solvers (chapter 07): the readable :func:`pbanim.lcp.solve.solve_lcp`
for PGS and for Lemke's method, without the checks of values a loop made itself (issue 28 points 3, 5).

Each takes the A and b a time step assembled (finite by construction, checked once against the entries'
limit), runs the very routine of the readable call — the same warm-start test, the same sweeps or pivots,
the same polish — and the same certificate (ORACLES D8): a ``ContactSolution`` that ``solve_lcp`` would
return, or None when the readable call must answer (a failure it names, or an answer it returns uncertified).
Tested bit for bit against ``solve_lcp`` (``tests/test_lcp_core.py``, ``tests/test_contact_lean_friction.py``).
"""

from __future__ import annotations

import time
from typing import Any

import numpy as np

from .pivoting import _EPS1000, _lemke, _polish, _scale, residual_threshold
from .specs import LIMIT as _LIMIT
from . import solve as _solve     # its sweeps_for (the readable row loop lives beside pgs)
from ..results import ContactSolution, natural_map_residual

__all__ = ["lean_pgs", "lean_lemke"]


def lean_pgs(A: np.ndarray, b: np.ndarray, warm_start, tol: float, max_iter: int = 1000,
             omega: float = 1.0) -> ContactSolution | None:
    """``solve_lcp(A, b, "pgs", tol=tol, warm_start=warm_start, validate=False)`` for a stepping loop that built
    A and b itself: the same warm-start test, the same iterates (:func:`pbanim.lcp.solve.sweeps_for`) and the
    same certificate,
    without the checks of values the loop made (shapes, options) or the certificate computed a second time.
    None when the readable call must answer: A or b not finite or beyond the entries' limit, a diagonal entry
    ≤ 0, or no convergence in ``max_iter`` sweeps (the readable call then names the failure or returns it)."""
    m = b.size
    absA = np.abs(A)
    if not (m and max(float(absA.max()), float(np.abs(b).max())) <= _LIMIT):      # NaN fails too
        return None
    diag = np.diag(A).copy()
    if not diag.min() > 0:
        return None
    start = time.perf_counter()
    extra: dict = {}
    f = None
    if warm_start is not None:
        ws = np.asarray(warm_start, dtype=float)
        with np.errstate(over="ignore", invalid="ignore"):
            worse = not natural_map_residual(ws, A @ ws + b) <= natural_map_residual(np.zeros(m), b)
        if worse:
            extra["warm_start_dropped"] = True
        else:
            f = np.maximum(np.array(ws, dtype=float), 0.0)
    if f is None:
        f = np.zeros(m)
    tol_b = tol * _scale(b)
    thresh = tol_b + _EPS1000 * float(np.max(absA @ f))
    if natural_map_residual(f, A @ f + b) <= thresh:
        sweeps = 0
    else:
        f, status, sweeps, _, thresh = _solve.sweeps_for(m)(A, b, f, diag, absA, tol_b, int(max_iter), omega)
        if status != "converged":
            return None
    extra["threshold"] = thresh
    return ContactSolution(f=f, solver="pgs", status="converged", success=True, iterations=sweeps,
                           time=time.perf_counter() - start, A=A, b=b, extra=extra)


def lean_lemke(A: np.ndarray, b: np.ndarray, warm_start, tol: float, *, polish: bool = True,
               **opts: Any) -> ContactSolution | None:
    """``solve_lcp(A, b, "lemke", tol=tol, warm_start=warm_start, polish=polish, **opts)`` for a stepping loop that
    built A and b itself (the lean friction step, :mod:`pbanim.contact.lean_friction`): the same warm-start test
    and polish of its support, the same pivots (:func:`~pbanim.lcp.pivoting._lemke`), the same polish and the
    same certificate, without the checks of values the loop made. None when the readable call must answer:
    A or b not finite or beyond the entries' limit, a numerical failure, or an answer that does not certify
    (the readable call then names the failure, or returns it)."""
    m = b.size
    if not (m and max(float(np.abs(A).max()), float(np.abs(b).max())) <= _LIMIT):      # NaN fails too
        return None
    start = time.perf_counter()
    extra: dict = {}
    f, status, iters = None, "", 0
    if warm_start is not None:
        ws = warm_start
        with np.errstate(over="ignore", invalid="ignore"):
            worse = not natural_map_residual(ws, A @ ws + b) <= natural_map_residual(np.zeros(m), b)
        if worse:
            extra["warm_start_dropped"] = True
        elif np.any(ws > 0):
            g = _polish(A, b, np.where(ws > 0, 1.0, 0.0) * np.maximum(ws, 0), tol)
            if natural_map_residual(g, A @ g + b) <= residual_threshold(A, b, g, tol):
                f, status, extra["warm_start_hit"] = g, "solved", True
    if f is None:
        try:
            f, status, iters = _lemke(A, b, **opts)
        except (ArithmeticError, RuntimeError, ValueError, np.linalg.LinAlgError):
            return None
        if polish and status == "solved":
            g = _polish(A, b, f, tol)
            extra["polished"] = g is not f
            f = g
    if not np.isfinite(f).all():
        return None
    sol = ContactSolution(f=np.asarray(f, dtype=float), solver="lemke", status=status, success=False,
                          iterations=iters, time=time.perf_counter() - start, A=A, b=b, extra=extra)
    thresh = residual_threshold(A, b, sol.f, tol)
    extra["threshold"] = thresh
    sol.success = bool(sol.residual <= thresh)
    return sol if sol.success else None
