"""Pivoting LCP solvers for contact forces and collision impulses (chapters 06–07): Lemke, Dantzig, enumeration.

Both solve w = A f + b ≥ 0, f ≥ 0, fᵀw = 0 exactly in finitely many pivots (see :mod:`pbanim.lcp.solve`
for the notation and :func:`~pbanim.lcp.solve.solve_lcp` for the common signature):

* ``lemke``: complementary pivoting with the covering vector 1 and a lexicographic ratio test (no
  cycling on degenerate problems, Cottle–Pang–Stone §4.4); terminates on a secondary ray when the LCP
  has no solution (for a copositive-plus A, e.g. PSD), which is reported as infeasible.
* ``dantzig``: Baraff's (1994) principal pivoting, driving one wᵢ < 0 to zero at a time while keeping
  the others complementary; Bland's rule breaks ties.
* ``enumerate_active_sets``: every active set S in order of size, f_S = −A_SS⁺ b_S (least squares),
  the first one that is complementary — the readable O(2ᵐ) check for m ≤ 12 (collision impulses).

The collision impulses of chapter 06 (:func:`pbanim.collision.solve_lcp_small`) call these same solvers.

Each answer is refined on its active set by :func:`_polish` (minimum-norm least-squares correction,
kept only if it lowers the natural-map residual) and judged by :func:`residual_threshold`.

References: Cottle, Pang & Stone, *The Linear Complementarity Problem* (1992), ch. 4; D. Baraff, "Fast
contact force computation for nonpenetrating rigid bodies", SIGGRAPH 1994.
"""

from __future__ import annotations

from itertools import combinations
from typing import Any

import numpy as np

from .specs import LCP_ENTRIES, LIMIT as _LIMIT
from ..contracts import Array, Int, Opt, Real, contract
from ..errors import InvalidInput, as_floats
from ..results import natural_map_residual

__all__ = ["lemke", "dantzig", "enumerate_active_sets", "residual_threshold"]


#: the LCP data as contracts declare them: A (m, m) and b (m,), finite, |entries| ≤ 10¹⁰⁰, m = 0 allowed
_MATRIX = Array(("m", "m"), empty=True, **LCP_ENTRIES)
_VECTOR = Array(("m",), empty=True, **LCP_ENTRIES)


def _check(A, b) -> tuple[np.ndarray, np.ndarray]:
    """A and b as float arrays of matching shapes, finite and below 10¹⁰⁰: the check of the solvers'
    bodies, for the values internal callers (effects, joints, collisions) hand over unchecked."""
    A = as_floats("A", A)
    b = as_floats("b", b)
    A = A.reshape(1, 1) if A.ndim == 0 else A
    b = b.reshape(1) if b.ndim == 0 else b
    if b.ndim != 1:
        raise InvalidInput(f"b must be a vector, got shape {b.shape}")
    m = b.size
    if A.shape != (m, m):
        raise InvalidInput(f"A must have shape ({m}, {m}) to match b, got {A.shape}")
    big = max(float(np.abs(A).max(initial=0.0)), float(np.abs(b).max(initial=0.0)))    # NaN or inf if any is
    if not np.isfinite(big):
        raise InvalidInput("A and b must be finite (got NaN or Inf); check the contact assembly")
    if big > _LIMIT:     # products A f and the residual threshold would overflow: no certificate possible
        raise InvalidInput(f"A and b must have entries below {_LIMIT:.0e} in magnitude (rescale the units), "
                           f"got max |entry| = {big:.3e}")
    return A, b


_EPS1000 = 1000 * float(np.finfo(float).eps)


def _scale(b: np.ndarray) -> float:
    return max(1.0, float(np.abs(b).max())) if b.size else 1.0


@contract(A=_MATRIX, b=_VECTOR, f=Array(("m",), empty=True), tol=Real(gt=0, lt=1))
def residual_threshold(A: np.ndarray, b: np.ndarray, f: np.ndarray, tol: float) -> float:
    """tol·max(1, ‖b‖∞) + 1000 ε ‖|A||f|‖∞: the residual a solution must reach to be accepted.

    The second term is the roundoff floor of w = A f + b (1000 ulps of the terms that cancel): a stack
    of 1000 kg boxes cannot have w exact to better than that, whatever the solver.
    """
    if b.size == 0:
        return tol
    return tol * _scale(b) + _EPS1000 * float((np.abs(A) @ np.abs(f)).max())


def _polish(A: np.ndarray, b: np.ndarray, f: np.ndarray, tol: float, rounds: int = 4) -> np.ndarray:
    """Refine f on the active set C = {fᵢ > wᵢ}: set f = 0 off C and correct f_C by the minimum-norm
    least-squares step Δ with A_CC Δ = −(A_CC f_C + b_C) (redundant contacts make A_CC singular but
    consistent; the minimum-norm *correction* stays next to f, where an absolute least-squares solve
    could jump along the null space to negative forces). Indices that come out negative are dropped;
    a few rounds, keeping the best answer by natural-map residual (never a worse one)."""
    best, best_r = f, natural_map_residual(f, A @ f + b)
    g = f
    for _ in range(rounds):
        w = A @ g + b
        C = np.flatnonzero(g > w)  # the natural active-set guess (includes violated wᵢ < 0 at fᵢ = 0)
        if C.size == 0:            # no active contact: the candidate is f = 0 (every contact separating)
            g = np.zeros_like(f)
            r = natural_map_residual(g, b)
            if r < best_r:
                best, best_r = g, r
            break
        for drop in range(4):
            ACC = A[np.ix_(C, C)]
            gC = g[C] + np.linalg.lstsq(ACC, -(ACC @ g[C] + b[C]), rcond=None)[0]
            if np.all(gC >= 0) or not np.any(gC > 0) or drop == 3:
                break
            C = C[gC > 0]
        g = np.zeros_like(f)
        g[C] = np.maximum(gC, 0.0)
        r = natural_map_residual(g, A @ g + b)
        if r < best_r:
            best, best_r = g, r
        elif r >= best_r:
            break
    return best


# ---------------------------------------------------------------------------------------------
# Lemke's complementary pivoting (Cottle–Pang–Stone §4.4), lexicographic anti-cycling
# ---------------------------------------------------------------------------------------------
def _lemke(A: np.ndarray, b: np.ndarray, *, max_iter: int | None = None, pivot_tol: float = 1e-9,
           **_: Any) -> tuple[np.ndarray, str, int]:
    """Lemke's method on w − A f − d z₀ = b with covering vector d = 1 (the route of ``solve_lcp``, which
    certifies; the public :func:`lemke` certifies its own answer)."""
    m = b.size
    if np.all(b >= 0):
        return np.zeros(m), "solved", 0
    max_iter = 50 * (m + 1) + 1000 if max_iter is None else int(max_iter)
    # tableau columns: w (0..m-1), f (m..2m-1), z0 (2m); last column the basic values
    T = np.hstack([np.eye(m), -A, -np.ones((m, 1)), b[:, None]])
    basis = np.arange(m)

    def lexmin(rows: np.ndarray, col: np.ndarray, clamp: bool = True) -> int:
        # lexicographic minimum of [x_B, B⁻¹] rows divided by the pivot column entries
        cand = rows
        for k in [2 * m + 1] + list(range(m)):
            vals = np.maximum(T[cand, k], 0.0) if (clamp and k == 2 * m + 1) else T[cand, k]  # roundoff: x_B ≥ 0
            ratios = vals / col[cand]
            best = ratios.min()
            cand = cand[ratios <= best + pivot_tol * max(1.0, abs(best))]
            if cand.size == 1:
                break
        return int(cand[0])

    def pivot(r: int, e: int) -> None:
        T[r] /= T[r, e]
        col = T[:, e].copy()
        col[r] = 0.0
        T[:] -= np.outer(col, T[r])
        basis[r] = e

    # first pivot: z0 enters, the most negative b leaves (lexicographic among ties)
    rows = np.arange(m)
    neg = rows[T[:, 2 * m + 1] < 0]
    # with d = 1 the ratio is b_i / 1; the minimum (most negative) leaves
    r = lexmin(neg, np.ones(m), clamp=False) if neg.size else 0
    leaving = int(basis[r])
    pivot(r, 2 * m)
    pivots = 1
    while pivots < max_iter:
        e = leaving + m if leaving < m else leaving - m  # the complement of what just left
        col = T[:, e]
        # relative pivot threshold: redundant contacts leave roundoff-level entries that must not pivot
        pos = np.flatnonzero(col > pivot_tol * max(1.0, float(np.max(np.abs(col)))))
        if pos.size == 0:
            return np.zeros(m), "ray", pivots
        # if z0 can leave at the minimum ratio, let it (terminates with a solution)
        r = lexmin(pos, col)
        z0_row = np.flatnonzero(basis == 2 * m)
        if z0_row.size and z0_row[0] in pos:
            rz = int(z0_row[0])
            if max(T[rz, 2 * m + 1], 0.0) / col[rz] <= max(T[r, 2 * m + 1], 0.0) / col[r] + 1e-12 * _scale(b):
                r = rz
        leaving = int(basis[r])
        pivot(r, e)
        pivots += 1
        if leaving == 2 * m:
            f = np.zeros(m)
            zb = basis >= m
            f[basis[zb] - m] = T[zb, 2 * m + 1]
            return np.maximum(f, 0.0), "solved", pivots
    return np.zeros(m), "max_iter", pivots


# ---------------------------------------------------------------------------------------------
# Baraff 1994 / Dantzig principal pivoting: drive one contact at a time to complementarity
# ---------------------------------------------------------------------------------------------
def _dantzig(A: np.ndarray, b: np.ndarray, *, max_iter: int | None = None, pivot_tol: float = 1e-12,
             lean: bool = True, **_: Any) -> tuple[np.ndarray, str, int]:
    """Baraff's principal pivoting (the route of ``solve_lcp``; the public :func:`dantzig` certifies).

    ``lean`` (default): the direction Δf_C = −A_CC⁺ A_Cd is solved once per pair (C, d) and reused when
    the pivots come back to it — redundant contacts make the method cycle between a few clamped sets
    (m = 200 redundant contacts at the step cap: 4118 solves, 736 distinct), and the same least-squares
    call on the same entries gives the same bits. ``lean=False`` solves every time (ORACLES D25)."""
    m = b.size
    memo: dict | None = {} if lean else None
    f = np.zeros(m)
    w = b.copy()
    clamped = np.zeros(m, dtype=bool)
    unclamped = np.zeros(m, dtype=bool)
    max_iter = 20 * (m + 1) + 100 if max_iter is None else int(max_iter)
    it = 0
    tol = pivot_tol * _scale(b)
    while True:
        todo = np.flatnonzero((w < -tol) & ~clamped & ~unclamped)
        if todo.size == 0:
            return np.maximum(f, 0.0), "solved", it
        d = int(todo[0])  # Bland: smallest index first
        while True:
            it += 1
            if it > max_iter:
                return f, "max_iter", it
            C = np.flatnonzero(clamped)
            df = np.zeros(m)
            df[d] = 1.0
            if C.size:
                key = None if memo is None else (C.tobytes(), d)
                sol = None if key is None else memo.get(key)
                if sol is None:
                    sol = np.linalg.lstsq(A[np.ix_(C, C)], A[C, d], rcond=None)[0]
                    if key is not None:
                        memo[key] = sol
                df[C] = -sol
            dw = A @ df
            s, j = np.inf, -1
            if dw[d] > pivot_tol:
                s, j = -w[d] / dw[d], d
            for i in C:  # a clamped force reaching zero
                if df[i] < -pivot_tol:
                    si = -f[i] / df[i]
                    if si < s - pivot_tol or (si <= s + pivot_tol and i < j):
                        s, j = si, i
            for i in np.flatnonzero(unclamped):  # an unclamped acceleration reaching zero
                if dw[i] < -pivot_tol:
                    si = -w[i] / dw[i]
                    if si < s - pivot_tol or (si <= s + pivot_tol and i < j):
                        s, j = si, i
            if j < 0:
                return f, "infeasible", it
            s = max(s, 0.0)
            f += s * df
            w += s * dw
            if j == d:
                clamped[d] = True
                w[d] = 0.0
                break
            if clamped[j]:
                clamped[j], unclamped[j] = False, True
                f[j] = 0.0
            else:
                unclamped[j], clamped[j] = False, True
                w[j] = 0.0


# ---------------------------------------------------------------------------------------------
# Enumeration of active sets: the readable O(2ᵐ) check
# ---------------------------------------------------------------------------------------------
@contract(A=_MATRIX, b=_VECTOR, tol=Real(gt=0, lt=1), max_size=Int(ge=0, le=16))
def enumerate_active_sets(A: np.ndarray, b: np.ndarray, *, tol: float = 1e-12,
                          max_size: int = 12) -> tuple[np.ndarray, str, int]:
    """Try every active set S (smallest first): f_S = −A_SS⁺ b_S by least squares, f = 0 elsewhere.

    Returns ``(f, status, size)`` for the first S whose answer passes the certificate — f ≥ −tol·s and a
    natural-map residual ‖min(f, w)‖∞ ≤ 1e-9·s with w = A f + b (s = max(1, ‖A‖∞, ‖b‖∞)) — status
    "solved"; "no active set" when none does. A singular, inconsistent A_SS leaves w_S ≠ 0, which the
    residual refuses (f ≥ 0 and w ≥ 0 alone would accept a force on a separating contact). Refuses
    m > ``max_size`` (2ᵐ least-squares solves; ``max_size`` ≤ 16, a cap known before the first).

    >>> enumerate_active_sets(np.array([[2.0, 1.0], [1.0, 2.0]]), np.array([-1.0, 1.0]))[:2]
    (array([0.5, 0. ]), 'solved')
    """
    A, b = _check(A, b)
    m = b.size
    if m > max_size:
        raise InvalidInput(f"enumerate_active_sets: A and b have m = {m} contacts, more than max_size = {max_size} "
                           "(2^m least-squares solves); use 'lemke'")
    if np.all(b >= 0):
        return np.zeros(m), "solved", 0
    scale = max(1.0, float(np.abs(A).max()), float(np.abs(b).max()))
    for k in range(1, m + 1):
        for S in combinations(range(m), k):
            S = list(S)
            f = np.zeros(m)
            f[S] = np.linalg.lstsq(A[np.ix_(S, S)], -b[S], rcond=None)[0]
            if f.min() < -tol * scale:
                continue
            f = np.maximum(f, 0.0)
            if natural_map_residual(f, A @ f + b) <= 1e-9 * scale:
                return f, "solved", k
    return np.zeros(m), "no active set", 2 ** m - 1


def _certified(A: np.ndarray, b: np.ndarray, f: np.ndarray, status: str, count: int, tol: float = 1e-10):
    """The project's one certificate on a pivoting answer: a "solved" whose natural-map residual exceeds
    :func:`residual_threshold` (or that is not finite) is reported as "inaccurate (residual r > t)"."""
    if status == "solved":
        if not np.isfinite(f).all():
            return np.zeros_like(f), "inaccurate (not finite)", count
        r, t = natural_map_residual(f, A @ f + b), residual_threshold(A, b, f, tol)
        if not r <= t:
            status = f"inaccurate (residual {r:.3e} > {t:.1e})"
    return f, status, count


@contract(A=_MATRIX, b=_VECTOR, max_iter=Opt(Int(ge=1)), pivot_tol=Real(gt=0, lt=1))
def lemke(A: np.ndarray, b: np.ndarray, *, max_iter: int | None = None,
          pivot_tol: float = 1e-9) -> tuple[np.ndarray, str, int]:
    """Lemke's method on w − A f − d z₀ = b with covering vector d = 1.

    Returns ``(f, status, pivots)``; status is "solved" (certified: natural-map residual within
    :func:`residual_threshold` at tol = 1e-10), "inaccurate (...)" (the pivots ended but the answer fails
    the certificate), "ray" (secondary ray: for a copositive-plus A the LCP is infeasible) or "max_iter"
    (at most ``max_iter`` pivots, default 50(m + 1) + 1000). Ties in the ratio test are broken
    lexicographically with the rows of B⁻¹, which prevents cycling on degenerate problems.

    >>> lemke(np.array([[2.0, 1.0], [1.0, 2.0]]), np.array([-1.0, 1.0]))
    (array([0.5, 0. ]), 'solved', 2)
    """
    A, b = _check(A, b)
    return _certified(A, b, *_lemke(A, b, max_iter=max_iter, pivot_tol=pivot_tol))


@contract(A=_MATRIX, b=_VECTOR, max_iter=Opt(Int(ge=1)), pivot_tol=Real(gt=0, lt=1))
def dantzig(A: np.ndarray, b: np.ndarray, *, max_iter: int | None = None,
            pivot_tol: float = 1e-12) -> tuple[np.ndarray, str, int]:
    """Baraff's (1994) force-computation algorithm (a Dantzig–Cottle principal pivoting method).

    Keeps a clamped set C (wᵢ = 0, fᵢ ≥ 0) and an unclamped set NC (fᵢ = 0, wᵢ ≥ 0); each
    contact d with w_d < 0 is driven to zero by moving along Δf (Δf_d = 1, A_CC Δf_C = −A_Cd) up to
    the first blocking index. Ties are broken by the smallest index (Bland). Redundant contacts make
    A_CC singular but consistent: solved by least squares. Status "solved" (certified as in
    :func:`lemke`), "inaccurate (...)", "infeasible" (no blocking index: Δw_d ≤ 0, which for a PSD A
    proves infeasibility) or "max_iter" (at most ``max_iter`` steps, default 20(m + 1) + 100).

    >>> dantzig(np.array([[2.0, 1.0], [1.0, 2.0]]), np.array([-1.0, 1.0]))[1]
    'solved'
    """
    A, b = _check(A, b)
    return _certified(A, b, *_dantzig(A, b, max_iter=max_iter, pivot_tol=pivot_tol))
