"""Geometric multigrid for the cell solves (chapter 09): V-cycles, alone or as the CG preconditioner.

Gauss–Seidel kills the rough part of the error in a few sweeps and the smooth part hardly at all: the
slowest mode of an n × n box falls by ((1 + cos π/n)/2)² ≈ 1 − π²/(2n²) per sweep (ORACLES E2), so the
sweeps needed grow like n². On a grid twice as coarse that smooth error is rough again. A V-cycle for
A x = b (A = αI − βL of :mod:`.poisson`) is

    x ← ν₁ red–black sweeps from 0                                  (pre-smoothing)
    r_c = R (b − A x)                                               (restrict the residual)
    e_c = V-cycle(A_c, r_c)   — exact (sparse LU) on the coarsest grid
    x ← x + P e_c                                                   (prolong the correction)
    x ← ν₂ black–red sweeps                                         (post-smoothing, reverse order)

with R the average over the 2^d children of a coarse cell, P the copy of a coarse value to its children
(R = 2^(−d) Pᵀ), and A_c the same operator rediscretized on cells of side 2Δx (a coarse cell is solid when
all its children are). Sweeping back in reverse order makes the cycle a symmetric positive operator, so it
can precondition conjugate gradients (``mgpcg``, after McAdams, Sifakis, Teran 2010); alone
(``multigrid``) it repeats cycles until the residual meets the tolerance, capped.

==========  ================================================================
symbol      meaning
==========  ================================================================
ν₁, ν₂      pre- and post-smoothing sweeps (2 each)
R, P        restriction (average of children), prolongation (copy)
A_c         the operator on the grid twice as coarse
==========  ================================================================

Limiting cases: a grid that cannot be halved (an odd axis, or fewer than 6 cells) is the coarsest level and
is solved exactly, so on small grids one cycle is a direct solve.

References: W. L. Briggs, V. E. Henson, S. McCormick, A Multigrid Tutorial, 2nd ed. (2000); A. McAdams,
E. Sifakis, J. Teran, A Parallel Multigrid Poisson Solver for Fluids Simulation on Large Grids, SCA 2010.
"""

from __future__ import annotations

import numpy as np

from ..errors import ConvergenceError
from .poisson import CellOperator, _direct, _norm, relax, unit_scale, warm_start

__all__ = ["levels", "multigrid_solve", "v_cycle"]

SMOOTH = 2


def _coarsen(grid):
    """The grid twice as coarse, or None when an axis is odd or below 6 cells."""
    from .grid import Grid

    if any(n % 2 or n < 6 for n in grid.shape):
        return None
    shape = tuple(n // 2 for n in grid.shape)
    solid = grid.solid.reshape([v for n in shape for v in (n, 2)]).all(axis=tuple(range(1, 2 * grid.dim, 2)))
    if solid.all():
        return None
    lids = {f"{'xyz'[a]}{'-+'[s]}": v for (a, s), v in grid.lids.items()}
    return Grid(shape, 2 * grid.dx, grid.boundary, solid=solid if solid.any() else None, lids=lids)


def levels(grid, alpha: float, beta: float) -> list:
    """[(grid, operator), ...] from fine to coarse (cached on the fine grid)."""
    cache = grid.__dict__.setdefault("_multigrid_cache", {})
    if (alpha, beta) not in cache:
        out, g = [], grid
        while g is not None:
            out.append((g, CellOperator(g, alpha, beta)))
            g = _coarsen(g)
        cache[alpha, beta] = out
    return cache[alpha, beta]


_COLOURS: dict = {}


def _colours(shape) -> tuple:
    """(red, black) cell masks of a grid shape (red: Σ indices even) for red–black Gauss–Seidel, read-only,
    made once per shape (a V-cycle relaxes on every level several times per CG iteration)."""
    if shape not in _COLOURS:
        red = np.indices(shape).sum(axis=0) % 2 == 0
        _COLOURS[shape] = (red, ~red)
        red.flags.writeable = _COLOURS[shape][1].flags.writeable = False
    return _COLOURS[shape]


def _restrict(r: np.ndarray, coarse_shape) -> np.ndarray:
    d = len(coarse_shape)
    return r.reshape([v for n in coarse_shape for v in (n, 2)]).mean(axis=tuple(range(1, 2 * d, 2)))


def _prolong(e: np.ndarray) -> np.ndarray:
    for a in range(e.ndim):
        e = np.repeat(e, 2, axis=a)
    return e


def v_cycle(hierarchy, b: np.ndarray, alpha: float, beta: float, level: int = 0) -> np.ndarray:
    """One V-cycle from x = 0 for A x = b on ``hierarchy[level]`` (a symmetric positive operator of b)."""
    g, A = hierarchy[level]
    if level == len(hierarchy) - 1:
        return _direct(g, b.copy(), alpha, beta) * g.fluid
    x, _ = relax(A, b, np.zeros_like(b), "gauss_seidel", SMOOTH)
    r = (b - A(x)) * g.fluid
    coarse = hierarchy[level + 1][0]
    x = x + _prolong(v_cycle(hierarchy, _restrict(r, coarse.shape), alpha, beta, level + 1)) * g.fluid
    x, _ = relax(A, b, x, "gauss_seidel", SMOOTH, reverse=True)
    return x * g.fluid


def multigrid_solve(grid, A, r, x, alpha, beta, tol, max_iter):
    """V-cycles on the residual until ‖r − A x‖₂ ≤ tol ‖r‖₂ (at most ``max_iter`` cycles); (x, cycles). r and x
    are scaled by :func:`~pbanim.fluids.poisson.unit_scale` first (the cycle is linear)."""
    s = unit_scale(r, x)
    if s != 1.0:
        x, k = multigrid_solve(grid, A, r * s, x * s, alpha, beta, tol, max_iter)
        return x / s, k
    hierarchy = levels(grid, alpha, beta)
    x, res, r_norm = warm_start(A, r, x)
    for k in range(max_iter + 1):
        norm = _norm(res)
        if norm <= tol * r_norm:
            return x, k
        if k == max_iter:
            break
        x = x + v_cycle(hierarchy, res, alpha, beta)
        res = r - A(x)
    raise ConvergenceError("multigrid", max_iter, norm / r_norm, tol, "relative 2-norm residual ‖r − Ax‖/‖r‖ of "
                           "(αI − βL)x = r")
