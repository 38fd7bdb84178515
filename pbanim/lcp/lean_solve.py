"""The stepping loops' routes to the LCP solvers (chapter 07): the readable :func:`pbanim.lcp.solve.solve_lcp`
for PGS and for Lemke's method, without the checks of values a loop made itself (issue 28 points 3, 5).

Each takes the A and b a time step assembled (finite by construction, checked once against the entries'
limit), runs the very routine of the readable call — the same warm-start test, the same sweeps or pivots,
the same polish — and the same certificate (ORACLES D8): a ``ContactSolution`` that ``solve_lcp`` would
return, or None when the readable call must answer (a failure it names, or an answer it returns uncertified).
Tested bit for bit against ``solve_lcp`` (``tests/test_lcp_core.py``, ``tests/test_contact_lean_friction.py``).

Lemke's route polishes with :func:`_polish_lean`, the arithmetic of :func:`pbanim.lcp.pivoting._polish` (the
minimum-norm correction on the active set, LAPACK's gelsd with rcond = |C| ε as ``np.linalg.lstsq`` calls it,
through the same gufunc) without the per-call wrappers; tested bit for bit against it
(``tests/test_lcp_lean_polish.py``, ORACLES D23).
"""

from __future__ import annotations

import time
from typing import Any

import numpy as np

from .pivoting import _EPS1000, _lemke, _scale, residual_threshold
from .specs import LIMIT as _LIMIT
from . import solve as _solve     # its sweeps_for (the readable row loop lives beside pgs)
from ..contracts import unchecked
from ..results import ContactSolution, natural_map_residual

__all__ = ["lean_pgs", "lean_lemke"]

try:                    # the gufunc np.linalg.lstsq calls (LAPACK gelsd), without its wrapper's per-call work
    from numpy.linalg._umath_linalg import lstsq as _gelsd
    from numpy.linalg._linalg import _raise_linalgerror_lstsq as _svd_failed
except ImportError:     # pragma: no cover - another numpy: the public function, the same arithmetic
    _gelsd = None

_EPS = float(np.finfo(float).eps)


def _lstsq(M: np.ndarray, r: np.ndarray) -> np.ndarray:
    """``np.linalg.lstsq(M, r, rcond=None)[0]`` for a square float M (n, n), n ≥ 1, and r (n,): the same gufunc
    with the same rcond = n ε and the same error state (a failed SVD raises LinAlgError)."""
    if _gelsd is None:  # pragma: no cover
        return np.linalg.lstsq(M, r, rcond=None)[0]
    with np.errstate(call=_svd_failed, invalid="call", over="ignore", divide="ignore", under="ignore"):
        x = _gelsd(M, r[:, None], _EPS * r.size, signature="ddd->ddid")[0]
    return x[:, 0]


_nmr = unchecked(natural_map_residual)     # ‖f − max(0, f − w)‖∞ without the contract wrapper


def _polish_lean(A: np.ndarray, b: np.ndarray, f: np.ndarray, rounds: int = 4) -> np.ndarray:
    """:func:`pbanim.lcp.pivoting._polish` (A, b, f) with the same operations in the same order: f = 0 off the
    active set C = {fᵢ > wᵢ}, f_C corrected by the minimum-norm least-squares step of A_CC Δ = −(A_CC f_C + b_C),
    negative indices dropped (up to three times), a few rounds, the best answer by natural-map residual kept.
    For the non-empty A (m, m), b, f (m,) of a stepping loop."""
    best, best_r = f, _nmr(f, A @ f + b)
    g = f
    for _ in range(rounds):
        w = A @ g + b
        C = np.flatnonzero(g > w)
        if C.size == 0:
            g = np.zeros_like(f)
            r = _nmr(g, b)
            if r < best_r:
                best, best_r = g, r
            break
        for drop in range(4):
            ACC = A[np.ix_(C, C)]
            gC = g[C] + _lstsq(ACC, -(ACC @ g[C] + b[C]))
            if np.all(gC >= 0) or not np.any(gC > 0) or drop == 3:
                break
            C = C[gC > 0]
        g = np.zeros_like(f)
        g[C] = np.maximum(gC, 0.0)
        r = _nmr(g, A @ g + b)
        if r < best_r:
            best, best_r = g, r
        elif r >= best_r:
            break
    return best


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
            worse = not _nmr(ws, A @ ws + b) <= _nmr(np.zeros(m), b)
        if worse:
            extra["warm_start_dropped"] = True
        elif np.any(ws > 0):
            g = _polish_lean(A, b, np.where(ws > 0, 1.0, 0.0) * np.maximum(ws, 0))
            if _nmr(g, A @ g + b) <= residual_threshold(A, b, g, tol):
                f, status, extra["warm_start_hit"] = g, "solved", True
    if f is None:
        try:
            f, status, iters = _lemke(A, b, **opts)
        except (ArithmeticError, RuntimeError, ValueError, np.linalg.LinAlgError):
            return None
        if polish and status == "solved":
            g = _polish_lean(A, b, f)
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
