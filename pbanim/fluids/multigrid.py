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
from ..sparse_kernel import add_csr_product
from .poisson import CellOperator, _direct, _norm, operator_matrix, relax, unit_scale, warm_start


__all__ = ["LeanCycle", "lean_cycle", "levels", "multigrid_solve", "preconditioner", "v_cycle"]

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


def _mv(M, x: np.ndarray) -> np.ndarray:
    """M x for a CSR matrix M: what ``M @ x`` computes, without its type dispatch, which on the coarse levels
    costs as long as the product (bit for bit the same numbers; :mod:`pbanim.sparse_kernel`)."""
    y = np.empty(M.shape[0])
    y.fill(0.0)                                                    # (np.zeros: a fresh zeroed page, slower)
    add_csr_product(M, x, y)
    return y


class LeanCycle:
    """The lean twin of :func:`v_cycle`: on each level the cells in red–black order (red first) and every
    half-sweep, residual, restriction R and prolongation P one sparse product, built once per hierarchy.

    A red half-sweep of the readable cycle, x_R ← x_R + (b − A x)_R / a_R, is here the same update rearranged,
    x_R ← b_R / a_R + N_R x with N = −diag(a)⁻¹ A°, A° = A − diag(a) (its red rows; black likewise): equal in
    exact arithmetic, to roundoff in floats (ORACLES E24). Every smoothing level has even lengths (:func:`_coarsen`),
    so no red cell neighbours a red one, even across a periodic side: N_R reads black cells only and the
    product adds into x_R in place. A solid cell's row is the identity, as in :class:`CellOperator`.
    Called on a field of the fine grid's shape, it returns what ``v_cycle(hierarchy, b, α, β)`` returns. A
    level's first red half-sweep starts from x = 0, so it is x_R = b_R / a_R, taken without the product (the
    same numbers: N_R·0 adds zeros).
    """

    def __init__(self, hierarchy) -> None:
        import scipy.sparse as sp

        self.levels, below = [], None
        for g, A in reversed(hierarchy):                     # coarse to fine: R and P need the coarse order
            red = _colours(g.shape)[0].ravel()
            perm = np.concatenate([np.flatnonzero(red), np.flatnonzero(~red)])
            fluid = g.fluid.ravel()[perm].astype(float)
            lv = {"grid": g, "A": A, "perm": perm, "n_red": int(red.sum()), "fluid": fluid}
            if below is not None:
                M = operator_matrix(g, A.alpha, A.beta)[0][perm][:, perm]
                M = (sp.diags(fluid) @ M + sp.diags(1.0 - fluid)).tocsr()     # solid rows: the identity
                d = A.diag.ravel()[perm]
                N = (-sp.diags(1.0 / d) @ (M - sp.diags(M.diagonal()))).tocsr()
                nr = lv["n_red"]
                red, black = (slice(None, nr), N[:nr]), (slice(nr, None), N[nr:])
                lv.update(M=M, d=d, sweeps=((red, black) * SMOOTH, (black, red) * SMOOTH))
                # fine cell (i, j, …) → coarse cell (i//2, j//2, …), both in their red–black order
                coarse = np.ravel_multi_index(tuple(c // 2 for c in np.unravel_index(perm, g.shape)),
                                              below["grid"].shape)
                where = np.empty_like(below["perm"])
                where[below["perm"]] = np.arange(below["perm"].size)
                cols = where[coarse]
                rows = np.arange(perm.size)
                lv["P"] = sp.csr_matrix((fluid, (rows, cols)), shape=(perm.size, below["perm"].size))
                lv["R"] = sp.csr_matrix((fluid / 2 ** g.dim, (cols, rows)), shape=(below["perm"].size, perm.size))
            self.levels.insert(0, lv)
            below = lv
        self.perm = self.levels[0]["perm"]
        self.back = np.empty_like(self.perm)                 # the inverse permutation: a gather, not a scatter
        self.back[self.perm] = np.arange(self.perm.size)

    def __call__(self, b: np.ndarray) -> np.ndarray:
        return self._cycle(0, b.ravel().take(self.perm)).take(self.back).reshape(b.shape)

    def _cycle(self, k: int, b: np.ndarray) -> np.ndarray:
        lv = self.levels[k]
        if k == len(self.levels) - 1:
            g, A = lv["grid"], lv["A"]
            full = np.empty(b.size)
            full[lv["perm"]] = b
            return _direct(g, full.reshape(g.shape), A.alpha, A.beta).ravel()[lv["perm"]] * lv["fluid"]
        bs = b / lv["d"]
        pre, post = lv["sweeps"]
        x = np.zeros(b.size)                   # the first (red) half-sweep from x = 0 is x_R = b_R/a_R: no product
        x[pre[0][0]] = bs[pre[0][0]]
        for order in (pre[1:], "coarse", post):
            if order == "coarse":
                x += _mv(lv["P"], self._cycle(k + 1, _mv(lv["R"], b - _mv(lv["M"], x))))
                continue
            for part, N in order:              # x_part = b/a + N x, added in place (N reads the other colour)
                y = x[part]
                y[...] = bs[part]
                add_csr_product(N, x, y)
        return x * lv["fluid"]


def lean_cycle(grid, alpha: float, beta: float) -> LeanCycle:
    """The :class:`LeanCycle` of ``levels(grid, α, β)`` (cached on the grid beside the hierarchy)."""
    cache = grid.__dict__.setdefault("_multigrid_lean", {})
    if (alpha, beta) not in cache:
        cache[alpha, beta] = LeanCycle(levels(grid, alpha, beta))
    return cache[alpha, beta]


def preconditioner(grid, alpha: float, beta: float, lean: bool = True):
    """b ↦ one V-cycle for (αI − βL) x = b on ``grid``: the :class:`LeanCycle` (``lean``) or the readable
    :func:`v_cycle`."""
    if lean:
        return lean_cycle(grid, alpha, beta)
    hierarchy = levels(grid, alpha, beta)
    return lambda b: v_cycle(hierarchy, b, alpha, beta)


def multigrid_solve(grid, A, r, x, alpha, beta, tol, max_iter, lean=True):
    """V-cycles on the residual until ‖r − A x‖₂ ≤ tol ‖r‖₂ (at most ``max_iter`` cycles); (x, cycles). r and x
    are scaled by :func:`~pbanim.fluids.poisson.unit_scale` first (the cycle is linear); ``lean``: see
    :func:`preconditioner`."""
    s = unit_scale(r, x)
    if s != 1.0:
        x, k = multigrid_solve(grid, A, r * s, x * s, alpha, beta, tol, max_iter, lean)
        return x / s, k
    cycle = preconditioner(grid, alpha, beta, lean)
    x, res, r_norm = warm_start(A, r, x)
    for k in range(max_iter + 1):
        norm = _norm(res)
        if norm <= tol * r_norm:
            return x, k
        if k == max_iter:
            break
        x = x + cycle(res)
        res = r - A(x)
    raise ConvergenceError("multigrid", max_iter, norm / r_norm, tol, "relative 2-norm residual ‖r − Ax‖/‖r‖ of "
                           "(αI − βL)x = r")
