"""Linear solves on the cells (chapter 09): (α I − β L) x = r by relaxation, CG, spectral or direct methods.

Two steps of Stable Fluids are this one solve with the cell operator L = D open G of :mod:`.grid`:

    pressure       α = 0, β = 1, r = −D u*        (−L p = −D u*; then u = u* − G p)
    diffusion      α = 1, β = κΔt, r = s⁰          ((I − κΔt L) s¹ = s⁰, implicit Euler for a scalar)

A = α I − β L is symmetric positive (semi-)definite, with diagonal a = α + β nb/Δx² (nb = open faces of
the cell). The methods, one signature (``solve_cells``), from cheap to exact:

==============  ====================================================================================
method          what it does
==============  ====================================================================================
gauss_seidel    Stam's ``lin_solve``: a fixed number of sweeps (20), x_c ← x_c + (r − A x)_c / a_c,
                here in red–black order (all cells of one parity at once: vectorizable, same rate)
jacobi          x ← x + ω (r − A x) / a, all cells at once; on a periodic box each Fourier mode of the
                error is multiplied by 1 − ω(1 − Σᵢ cos θᵢ / d) per sweep (ORACLES E2)
cg              conjugate gradients, diagonal (Jacobi) preconditioner, to a relative tolerance
pcg             conjugate gradients preconditioned by the exact spectral inverse of the obstacle-free box
multigrid       V-cycles (:mod:`.multigrid`) to a relative tolerance (at most max_iter/10 cycles)
mgpcg           conjugate gradients preconditioned by one V-cycle (any obstacles)
fft / dct       exact: the FFT (periodic axes) and DCT-II (wall axes) diagonalize A when there is no
                obstacle: x̂_k = r̂_k / (α − β λ_k), λ_k = Σᵢ (2 cos θᵢ − 2)/Δx²; θᵢ = 2πkᵢ/nᵢ (periodic)
                or πkᵢ/nᵢ (walls); the constant mode is set to 0 when α = 0 (``spectral``: either, or
                both on a box with mixed axes)
direct          sparse LU of A (any obstacles; one cell pinned per connected fluid region when α = 0)
==============  ====================================================================================

Solid cells are not unknowns: their rows are the identity and their value 0. Every iterative method has its
cap before it starts (``iterations`` sweeps, or ``max_iter`` for the CGs and max_iter/10 V-cycles for
multigrid, which raise :class:`~pbanim.errors.ConvergenceError` when the tolerance is not met).

Limiting cases: β → 0 gives x = r/α; one Jacobi sweep from x = 0 is r/a; with no obstacle, pcg
converges in one iteration.

References: J. Stam, Real-Time Fluid Dynamics for Games (2003), ``lin_solve``; Y. Saad, Iterative Methods
for Sparse Linear Systems, 2nd ed. (2003), ch. 4 and 9; W. L. Briggs, V. E. Henson, S. McCormick, A
Multigrid Tutorial (2000), ch. 2 (the Jacobi error modes); R. Bridson, Fluid Simulation for Computer
Graphics (2015), ch. 5.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..contracts import Choice, Flag, Int, Obj, Opt, Real, contract
from ..errors import ConvergenceError, InvalidInput, check_result
from .specs import MAX_ITER, MAX_SWEEPS, Cells, finite_fields, quiet

__all__ = ["POISSON_METHODS", "CellOperator", "SolveInfo", "relax", "solve_cells", "spectral_eigenvalues", "unit_scale"]

_INF = float("inf")
POISSON_METHODS = ("gauss_seidel", "jacobi", "cg", "pcg", "multigrid", "mgpcg", "fft", "dct", "spectral", "direct")


@dataclass
class SolveInfo:
    """What a solve did: the method, iterations (sweeps; 0 for exact methods), the max-norm residual
    ‖r − A x‖∞ over the fluid cells."""

    method: str
    iterations: int
    residual: float


class CellOperator:
    """A = α I − β L on the fluid cells (identity on solid cells), matrix-free.

    Without periodic axes the call is the lean twin of ``α x − β grid.laplacian(x)``: per axis i the face
    flux (x(c + eᵢ) − x(c))·open/Δx² on the inner faces, added to one cell and taken from the other (no
    checks, no face arrays with their zero walls: equal to the readable D open G to roundoff, tested).
    """

    def __init__(self, grid, alpha: float, beta: float) -> None:
        self.grid, self.alpha, self.beta = grid, float(alpha), float(beta)
        with np.errstate(over="ignore"):
            d = alpha + beta * grid.neighbours() / grid.dx ** 2
        check_result("the diagonal α + β·nb/Δx² of αI − βL", d, f"α = {alpha:g}, β = {beta:g}, Δx = {grid.dx:g}")
        d[grid.solid | (d == 0)] = 1.0
        self.diag = d
        self._lean = None
        if not any(grid.periodic):
            inner = lambda i, lo, hi: tuple(slice(lo, hi) if a == i else slice(None) for a in range(grid.dim))  # noqa: E731
            self._lean = [(inner(i, 1, -1), inner(i, None, -1), inner(i, 1, None),
                           grid.open[i][inner(i, 1, -1)] / grid.dx ** 2) for i in range(grid.dim)]

    def laplacian(self, x: np.ndarray) -> np.ndarray:
        """L x (the lean twin of ``grid.laplacian``; the readable one when an axis is periodic)."""
        if self._lean is None:
            return self.grid.laplacian(x)
        lap = np.zeros(x.shape)
        for _, lo, hi, w in self._lean:
            flux = np.subtract(x[hi], x[lo])
            flux *= w                                      # in place: the same numbers, one array less
            lap[lo] += flux
            lap[hi] -= flux
        return lap

    def __call__(self, x: np.ndarray) -> np.ndarray:
        y = self.alpha * x - self.beta * self.laplacian(x)
        if self.grid.has_obstacles:
            y[self.grid.solid] = x[self.grid.solid]
        return y


def spectral_eigenvalues(grid) -> np.ndarray:
    """λ_k of L for the obstacle-free box, in the layout of the transforms used by :func:`_spectral`."""
    periodic = [a for a in range(grid.dim) if grid.periodic[a]]
    lam = np.zeros(())
    for a, n in enumerate(grid.shape):
        if grid.periodic[a]:
            k = np.fft.rfftfreq(n) * n if a == periodic[-1] else np.fft.fftfreq(n) * n
            theta = 2.0 * np.pi * k / n
        else:
            theta = np.pi * np.arange(n) / n
        shape = [1] * grid.dim
        shape[a] = theta.size
        lam = lam + ((2.0 * np.cos(theta) - 2.0) / grid.dx ** 2).reshape(shape)
    return lam


def _spectral(grid, r: np.ndarray, alpha: float, beta: float) -> np.ndarray:
    from scipy import fft

    cache = grid.__dict__.setdefault("_spectral_cache", {})
    key = (alpha, beta)
    if key not in cache:
        denom = alpha - beta * spectral_eigenvalues(grid)
        with np.errstate(divide="ignore"):
            inv = np.where(denom == 0, 0.0, 1.0 / np.where(denom == 0, 1.0, denom))
        cache[key] = inv
    inv = cache[key]
    walls = [a for a in range(grid.dim) if not grid.periodic[a]]
    periodic = [a for a in range(grid.dim) if grid.periodic[a]]
    x = fft.dctn(r, type=2, axes=walls, norm="ortho") if walls else r
    if periodic:
        x = fft.irfftn(fft.rfftn(x, axes=periodic) * inv, s=[grid.shape[a] for a in periodic], axes=periodic)
    else:
        x = x * inv
    return fft.idctn(x, type=2, axes=walls, norm="ortho") if walls else x


def _matrix(grid, alpha: float, beta: float):
    """A as a sparse CSC matrix (solid rows identity; with α = 0, one pinned cell per fluid region)."""
    import scipy.sparse as sp
    from scipy.sparse.csgraph import connected_components

    A, W = operator_matrix(grid, alpha, beta)
    fixed = grid.solid.ravel().copy()
    if alpha == 0:
        _, labels = connected_components(W, directed=False)
        labels = np.where(fixed, -1, labels)
        for lab in np.unique(labels[labels >= 0]):
            fixed[np.flatnonzero(labels == lab)[0]] = True
    # symmetric elimination of the pinned columns keeps A SPD; their values are 0 so nothing moves to r
    keep = sp.diags((~fixed).astype(float))
    A = (keep @ A @ keep + sp.diags(fixed.astype(float))).tocsc()
    return A, fixed


def operator_matrix(grid, alpha: float, beta: float):
    """(A, W): A = αI − βL as a sparse CSR matrix of the raveled cells (not pinned, solid rows not yet the
    identity: their entries are 0 besides α), W the open-face adjacency weights."""
    import scipy.sparse as sp

    n = grid.solid.size
    idx = np.arange(n).reshape(grid.shape)
    rows, cols, vals = [], [], []
    for i, w in enumerate(grid.open):
        if grid.periodic[i]:
            lo, hi, ww = np.roll(idx, 1, axis=i), idx, w
        else:
            cut = lambda lo_, hi_: tuple(slice(lo_, hi_) if a == i else slice(None) for a in range(grid.dim))  # noqa: E731,B023
            lo, hi, ww = idx[cut(None, -1)], idx[cut(1, None)], w[cut(1, -1)]
        keep = ww.ravel() > 0
        rows += [lo.ravel()[keep], hi.ravel()[keep]]
        cols += [hi.ravel()[keep], lo.ravel()[keep]]
        vals += [ww.ravel()[keep]] * 2
    W = sp.csr_matrix((np.concatenate(vals), (np.concatenate(rows), np.concatenate(cols))), shape=(n, n))
    deg = np.asarray(W.sum(axis=1)).ravel()
    return ((beta / grid.dx ** 2) * (sp.diags(deg) - W) + alpha * sp.identity(n)).tocsr(), W


def _direct(grid, r, alpha, beta):
    from scipy.sparse.linalg import factorized

    cache = grid.__dict__.setdefault("_direct_cache", {})
    key = (alpha, beta)
    if key not in cache:
        A, fixed = _matrix(grid, alpha, beta)
        cache[key] = (factorized(A), fixed)
    solve, fixed = cache[key]
    rhs = r.ravel().copy()
    rhs[fixed] = 0.0
    return solve(rhs).reshape(grid.shape)


def relax(A, r, x, method: str, iterations: int, omega: float = 1.0, reverse: bool = False):
    """``iterations`` sweeps of Jacobi (weight ω) or red–black Gauss–Seidel on A x = r from x (black–red when
    ``reverse``); A has ``__call__`` and ``diag``. Returns (x, sweeps)."""
    if method == "jacobi":
        for _ in range(iterations):
            x = x + omega * (r - A(x)) / A.diag
        return x, iterations
    from .multigrid import _colours

    order = _colours(x.shape)[::-1] if reverse else _colours(x.shape)
    for _ in range(iterations):
        for c in order:
            x = np.where(c, x + (r - A(x)) / A.diag, x)
    return x, iterations


def _dot(a, b) -> float:
    """Σ a b by numpy's pairwise sum (not BLAS: its threads stall when the cores are shared)."""
    return float(np.add.reduce(np.multiply(a, b), axis=None))     # what ndarray.sum calls, without its wrapper


def _norm(v) -> float:
    """‖v‖₂, without overflow of the squares (scaled by max |v| when Σ v² is not finite). Its callers run
    under ``np.errstate(over="ignore")`` (:func:`~pbanim.fluids.specs.quiet`, or a step's)."""
    n = _dot(v, v) ** 0.5
    if n < _INF:
        return n
    m = float(np.abs(v).max())
    return m * _dot(v / m, v / m) ** 0.5 if 0 < m < _INF else m


def unit_scale(*arrays) -> float:
    """A power of two s with s·max|a| near 1 when max|a| is beyond 2^±200 (else 1): the Krylov solves work on
    s·r and s·x, exactly, so that their inner products of 10³⁰⁰-sized fields do not overflow (a linear
    operator: A(s x) = s A(x))."""
    m = max((float(np.abs(a).max()) for a in arrays if a.size), default=0.0)
    if m == 0 or 2.0 ** -200 < m < 2.0 ** 200 or not np.isfinite(m):
        return 1.0
    return 2.0 ** -np.frexp(m)[1]


def warm_start(A, r, x):
    """(x, r − A x, ‖r‖₂) from the start x, or from 0 when x leaves a larger residual than 0 does (the field
    itself as the start of an implicit solve with a huge νΔt: A x is νΔt/Δx² times larger than r)."""
    res = r - A(x)
    r_norm = max(_norm(r), np.finfo(float).tiny)
    if not _norm(res) <= r_norm:
        return np.zeros_like(r), r.copy(), r_norm
    return x, res, r_norm


def _cg(A, r, x, tol, max_iter, precondition, name):
    """Preconditioned conjugate gradients from x (from 0 when x is a worse start); stops when ‖r − A x‖₂ ≤
    tol ‖r‖₂ (capped; the error reports the relative residual). r and x are scaled by :func:`unit_scale`."""
    s = unit_scale(r, x)
    if s != 1.0:
        x, k = _cg(A, r * s, x * s, tol, max_iter, precondition, name)
        return x / s, k
    x, res, r_norm = warm_start(A, r, x)
    target = tol * r_norm
    z = precondition(res)
    p = z.copy()
    rz = _dot(res, z)
    for k in range(max_iter + 1):
        norm = _norm(res)
        if norm <= target:
            return x, k
        if k == max_iter:
            break
        Ap = A(p)
        pAp = _dot(p, Ap)
        if not pAp > 0:                 # breakdown, or an operator too large for its inner products
            break
        step = rz / pAp
        x = x + step * p
        res = res - step * Ap
        z = precondition(res)
        rz, rz_old = _dot(res, z), rz
        if rz_old == 0:                 # breakdown (cannot happen with an SPD preconditioner)
            break
        p = z + (rz / rz_old) * p
    raise ConvergenceError(name, k, _norm(r - A(x)) / r_norm, tol, "relative 2-norm residual ‖r − Ax‖/‖r‖ of "
                           "(αI − βL)x = r")


@contract(grid=Obj("pbanim.fluids.grid:Grid"), r=Cells(), alpha=Real(ge=0), beta=Real(gt=0),
          method=Choice(POISSON_METHODS), iterations=Int(ge=0, le=MAX_SWEEPS), omega=Real(gt=0, le=1),
          tol=Real(gt=0, le=1), max_iter=Opt(Int(ge=1, le=MAX_ITER)), x0=Opt(Cells()), lean=Flag(),
          returns=finite_fields)
@quiet
def solve_cells(grid, r, alpha: float = 0.0, beta: float = 1.0, method: str = "dct", *, iterations: int = 20,
                omega: float = 1.0, tol: float = 1e-12, max_iter: int | None = None, x0=None, lean: bool = True):
    """Solve (α I − β L) x = r on the cells of ``grid``; returns ``(x, SolveInfo)``.

    ``iterations`` is the number of sweeps of gauss_seidel / jacobi (Stam: 20); ``omega`` Jacobi's weight
    in (0, 1]; ``tol`` and ``max_iter`` (default 20·max(n) + 100) the stop and the cap of the CGs
    (multigrid: max_iter/10 cycles); ``lean=False`` runs the readable V-cycle, not its sparse twin
    (:class:`~pbanim.fluids.multigrid.LeanCycle`). With α = 0 the part of r that is constant over a fluid region is not
    solvable and is dropped. An operator whose entries β/Δx² overflow is
    :class:`~pbanim.errors.NonFiniteResult`.
    """
    check_method_fits(grid, method)
    x = np.zeros(grid.shape) if x0 is None else np.array(x0, dtype=float)
    return _solve(grid, np.array(r, dtype=float), x, alpha, beta, method, iterations, omega, tol, max_iter, lean=lean)


def check_method_fits(grid, method: str, where: str = "solve_cells", name: str = "method") -> None:
    """:class:`InvalidInput` when an exact spectral method is asked of a box it cannot diagonalize (the
    message names the callable ``where`` and the argument ``name``)."""
    if method in ("fft", "dct", "spectral"):
        want = {"fft": "periodic", "dct": "walls"}.get(method)
        if grid.has_obstacles or (want and any(k != want for k in grid.boundary)):
            raise InvalidInput(f"{where}: {name} {method!r} needs a box with {want or 'any boundary'} on every axis "
                               f"and no obstacle; this grid has boundary {grid.boundary} and "
                               f"{int(grid.solid.sum())} solid cells (use 'pcg' or 'direct')")


def _regions(grid):
    """Connected fluid regions: labels 1..count per cell (0 in solids), cached on the grid."""
    cache = grid.__dict__.setdefault("_regions_cache", {})
    if "labels" not in cache:
        import scipy.ndimage as ndi

        structure = ndi.generate_binary_structure(grid.dim, 1)
        labels, count = ndi.label(grid.fluid, structure=structure)
        for _ in range(count + 1):         # regions that meet across a periodic boundary are one region
            merged = False
            for a in range(grid.dim):
                if not grid.periodic[a]:
                    continue
                lo, hi = np.take(labels, 0, axis=a).ravel(), np.take(labels, -1, axis=a).ravel()
                pair = (lo > 0) & (hi > 0) & (lo != hi)
                if pair.any():
                    x, y = lo[pair][0], hi[pair][0]
                    labels[labels == max(x, y)] = min(x, y)
                    merged = True
            if not merged:
                break
        uniq = np.unique(labels[labels > 0])
        remap = np.zeros(labels.max() + 1, dtype=int)
        remap[uniq] = np.arange(1, uniq.size + 1)
        cache["labels"] = (remap[labels], int(uniq.size))
    return cache["labels"]


def _operator(grid, alpha, beta) -> CellOperator:
    cache = grid.__dict__.setdefault("_operator_cache", {})
    if (alpha, beta) not in cache:
        cache[alpha, beta] = CellOperator(grid, alpha, beta)
    return cache[alpha, beta]


def _solve(grid, r, x, alpha, beta, method, iterations=20, omega=1.0, tol=1e-12, max_iter=None, residual=True,
           lean=True):
    """The solve behind :func:`solve_cells`, arguments already checked (r may be modified in place)."""
    max_iter = 20 * max(grid.shape) + 100 if max_iter is None else max_iter
    if grid.has_obstacles:
        r[grid.solid] = 0.0
        x[grid.solid] = 0.0
    if alpha == 0:                     # only the part of r with zero mean over each fluid region is solvable
        if not grid.has_obstacles:
            r -= r.mean()
        else:
            labels, count = _regions(grid)
            sums = np.bincount(labels.ravel(), weights=r.ravel(), minlength=count + 1)
            sizes = np.bincount(labels.ravel(), minlength=count + 1)
            r -= np.where(labels > 0, (sums / np.maximum(sizes, 1))[labels], 0.0)
    A = _operator(grid, alpha, beta)
    its = 0
    if method in ("fft", "dct", "spectral"):
        x = _spectral(grid, r, alpha, beta)
    elif method == "direct":
        x = _direct(grid, r, alpha, beta)
    elif method in ("jacobi", "gauss_seidel"):
        x, its = relax(A, r, x, method, iterations, omega)
    elif method == "multigrid":
        from .multigrid import multigrid_solve

        x, its = multigrid_solve(grid, A, r, x, alpha, beta, tol, max(1, max_iter // 10), lean)
    else:
        if method == "cg":
            pre = lambda v: v / A.diag
        elif method == "mgpcg":
            from .multigrid import preconditioner

            pre = preconditioner(grid, alpha, beta, lean)
        else:
            free = grid.__dict__.setdefault("_free_box", {})
            if grid.shape not in free:
                from .grid import Grid

                free[grid.shape] = Grid(grid.shape, grid.dx, grid.boundary)
            box = free[grid.shape]
            if alpha == 0:      # the box inverse drops the constant mode; give it weight Δx² (keeps M SPD)
                pre = lambda v: _spectral(box, v, alpha, beta) + v.mean() * grid.dx ** 2 / beta
            else:
                pre = lambda v: _spectral(box, v, alpha, beta)
        x, its = _cg(A, r, x, tol, max_iter, pre, method)
    res = float(np.abs((r - A(x))[grid.fluid]).max()) if residual else float("nan")
    return x, SolveInfo(method, int(its), res)
