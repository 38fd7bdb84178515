"""Diffusion (chapter 09): the viscous term ν∇²u, and κ∇²s for a scalar, by implicit Euler.

Stam diffuses implicitly so that no viscosity and no step can make it blow up:

    (I − νΔt ∇²) u¹ = u⁰        (each velocity component; κ in place of ν for a scalar)

An explicit step u¹ = u⁰ + νΔt ∇²u⁰ is stable only for νΔt/Δx² ≤ 1/(2d); the implicit one damps every
Fourier mode k by 1/(1 − νΔt λ_k) < 1 for any Δt (λ_k ≤ 0 the eigenvalues of the discrete ∇²), which is
also the decay it gives the Taylor–Green vortex, exp(−2νk²t) in the limit Δt, Δx → 0 (ORACLES E1).

On the MAC grid a component uᵢ lives on faces: along its own axis the wall faces are held at uᵢ = 0,
across the other axes the wall sits half a cell away and the ghost value 2w − uᵢ enforces no slip with
the wall's tangential velocity w (the moving lid); faces touching obstacles are held at 0. The lid makes
the system affine: A u = u⁰ + νΔt ∇²_w 0, the wall part moved to the right-hand side. Scalars have no
flux through walls and obstacles: their operator is the pressure operator L of :mod:`.grid` with α = 1,
β = κΔt (:func:`pbanim.fluids.poisson.solve_cells`).

Methods, one signature: ``gauss_seidel`` (Stam: fixed sweeps, red–black), ``jacobi``, ``cg``
(diagonal preconditioner, to a tolerance, capped), ``fft`` (exact, periodic boxes without obstacles;
for scalars also ``dct``/``spectral`` on wall boxes).

==========  ======================================================================
symbol      meaning
==========  ======================================================================
ν, κ        kinematic viscosity, scalar diffusivity (≥ 0; 0 means no solve at all)
Δt          step ``h``
w           tangential velocity of a sliding wall (``Grid.lids``)
λ_k         eigenvalues of the discrete Laplacian, Σᵢ (2 cos θᵢ − 2)/Δx²
==========  ======================================================================

Limiting cases: ν = 0 returns the field untouched (and the scene does not even declare the stage);
νΔt → ∞ on a periodic box leaves the mean (the k = 0 mode) only.

References: J. Stam, Stable Fluids (1999) §2.3 and Real-Time Fluid Dynamics for Games (2003) ``diffuse``.
"""

from __future__ import annotations

import numpy as np

from ..contracts import Choice, Flag, Int, Obj, Opt, Real, contract
from ..errors import InvalidInput, check_result
from .poisson import SolveInfo, _cg, _solve, _spectral, check_method_fits, relax
from .specs import MAX_ITER, MAX_SWEEPS, Cells, Velocity, finite_fields, quiet

__all__ = ["DIFFUSION_METHODS", "FaceOperator", "SparseFaceOperator", "diffuse_scalar", "diffuse_velocity", "diffusion_coefficient"]

DIFFUSION_METHODS = ("gauss_seidel", "jacobi", "cg", "fft")


class FaceOperator:
    """A = I − a ∇² for velocity component ``i`` (closed faces: identity), matrix-free, with the sliding
    walls' ghost values when ``walls`` is True (the affine part) and without them otherwise."""

    def __init__(self, grid, i: int, a: float) -> None:
        self.grid, self.i, self.a = grid, i, float(a)
        self.closed = grid.open[i] == 0
        ghosts = np.zeros(grid.face_shape(i))
        for ax in range(grid.dim):
            if grid.periodic[ax] or ax == i:
                continue
            for end in (0, -1):
                idx = [slice(None)] * grid.dim
                idx[ax] = end
                ghosts[tuple(idx)] += 1.0
        self.diag = np.where(self.closed, 1.0, 1.0 + a * (2 * grid.dim + ghosts) / grid.dx ** 2)
        cut = lambda ax, k: tuple(k if b == ax else slice(None) for b in range(grid.dim))  # noqa: E731
        # per axis: (upper, lower, first, last) index tuples — the views moveaxis would give, made once
        self._cuts = [(cut(ax, slice(1, None)), cut(ax, slice(None, -1)), cut(ax, 0), cut(ax, -1))
                      for ax in range(grid.dim)]

    def laplacian(self, x: np.ndarray, walls: bool) -> np.ndarray:
        g, i = self.grid, self.i
        lap = -2.0 * g.dim * x
        for ax in range(g.dim):
            if g.periodic[ax]:
                lap += np.roll(x, 1, axis=ax) + np.roll(x, -1, axis=ax)
                continue
            upper, lower, first, last = self._cuts[ax]     # lap += lower and upper neighbours along ax
            lap[upper] += x[lower]
            lap[lower] += x[upper]
            if ax == i:                                    # wall faces are held: any value will do
                lap[first] += x[first]
                lap[last] += x[last]
                continue
            for side, end in ((0, first), (1, last)):      # ghost 2w − x across a wall half a cell away
                w = g.lids.get((ax, side)) if walls else None
                lap[end] += (0.0 if w is None else 2.0 * float(w[i])) - x[end]
        return lap / g.dx ** 2

    def __call__(self, x: np.ndarray) -> np.ndarray:
        y = x - self.a * self.laplacian(x, walls=False)
        return np.where(self.closed, x, y)

    def wall_term(self) -> np.ndarray:
        """a ∇²_w 0: what the sliding walls add to the right-hand side."""
        z = np.zeros(self.grid.face_shape(self.i))
        return np.where(self.closed, 0.0, self.a * self.laplacian(z, walls=True))


class SparseFaceOperator:
    """The lean twin of a :class:`FaceOperator` (its linear part): the same matrix, read off the operator by
    2d + 1 probes and applied as one sparse product (a CG iteration's A p).

    Probe k is the indicator of the faces of colour k, colour = Σₐ (a + 1) idxₐ mod (2d + 1): the 2d + 1 faces of
    a stencil (itself and ±eₐ) have distinct colours, so row r of A(probe k) is the one entry of row r in the
    column of that colour. The matrix is checked against the operator on a random field before use (a
    periodic axis whose length is no multiple of 2d + 1 makes two stencil faces share a colour: then ``ok`` is
    False and the caller keeps the readable operator). Equal to it to roundoff (ORACLES E25).
    """

    def __init__(self, A: FaceOperator) -> None:
        import scipy.sparse as sp

        shape, d = A.diag.shape, A.diag.ndim
        m, idx = 2 * d + 1, np.indices(A.diag.shape)
        colour = sum((a + 1) * idx[a] for a in range(d)) % m
        flat = np.arange(colour.size).reshape(shape)
        rows, cols, vals = [], [], []
        for k in range(m):
            y = A((colour == k).astype(float))
            for a in range(d):
                for o in (0, 1, -1) if a == 0 else (1, -1):
                    nb = idx.copy()
                    nb[a] += o
                    nb[a] %= shape[a]                  # wrapped (a wall face's neighbour outside is never read)
                    inside = A.grid.periodic[a] | ((idx[a] + o >= 0) & (idx[a] + o < shape[a]))
                    hit = inside & (colour[tuple(nb)] == k)
                    rows.append(flat[hit]), cols.append(flat[tuple(nb)][hit]), vals.append(y[hit])
        M = sp.csr_matrix((np.concatenate(vals), (np.concatenate(rows), np.concatenate(cols))), shape=(flat.size,) * 2)
        M.sum_duplicates()
        self.matrix, self.diag, self.shape = M, A.diag, shape
        x = np.random.default_rng(0).standard_normal(shape)
        self.ok = bool(np.abs(self(x) - A(x)).max() <= 64 * np.finfo(float).eps * np.abs(A(x)).max())

    def __call__(self, x: np.ndarray) -> np.ndarray:
        from .multigrid import _mv

        return _mv(self.matrix, x.ravel()).reshape(self.shape)


_GRID = Obj("pbanim.fluids.grid:Grid")
_COEF = Real(ge=0)
_H = Real(gt=0)
_SWEEPS = Int(ge=0, le=MAX_SWEEPS)
_TOL = Real(gt=0, le=1)
_MAX_ITER = Opt(Int(ge=1, le=MAX_ITER))


def diffusion_coefficient(grid, coef: float, h: float, what: str) -> float:
    """a = νΔt (or κΔt), with its largest diagonal entry a·2d/Δx² finite, else NonFiniteResult naming it."""
    with np.errstate(over="ignore"):
        a = coef * h
        check_result(f"the diffusion coefficient {what}·h", a * (2 * grid.dim + 2) / grid.dx ** 2,
                     f"{what} = {coef:g}, h = {h:g}, Δx = {grid.dx:g}")
    return a


def _face_operator(grid, i: int, a: float) -> tuple:
    """(FaceOperator, its wall term, its :class:`SparseFaceOperator` or the operator itself when the probe
    failed, the lean CG's preconditioner) for component i and a = νΔt, made once per (i, a) and cached on the
    grid (at most 16 kept). The preconditioner is the exact inverse on a box without obstacles
    (:class:`~pbanim.fluids.face_solve.FaceInverse`, ORACLES E26), else the diagonal."""
    from .face_solve import FaceInverse

    cache = grid.__dict__.setdefault("_face_cache", {})
    if (i, a) not in cache:
        if len(cache) >= 16:
            cache.clear()
        A = FaceOperator(grid, i, a)
        lean, inv = SparseFaceOperator(A), FaceInverse(A)
        cache[i, a] = (A, A.wall_term(), lean if lean.ok else A, inv if inv.ok else (lambda v, A=A: v / A.diag))
    return cache[i, a]


@contract(grid=_GRID, u=Velocity(), nu=_COEF, h=_H, method=Choice(DIFFUSION_METHODS), iterations=_SWEEPS, tol=_TOL,
          max_iter=_MAX_ITER, lean=Flag(), returns=finite_fields)
@quiet
def diffuse_velocity(grid, u: list, nu: float, h: float, method: str = "cg", *, iterations: int = 20,
                     tol: float = 1e-12, max_iter: int | None = None, lean: bool = True) -> tuple[list, list]:
    """Solve (I − νΔt ∇²) u¹ = u⁰ component by component; returns (u¹, [SolveInfo per component]).

    ``iterations``: sweeps of gauss_seidel / jacobi; ``tol``, ``max_iter`` (default 20·max(n) + 100): the
    stop and the cap of cg (:class:`~pbanim.errors.ConvergenceError` past it); ``lean=False``: cg applies the
    readable :class:`FaceOperator`, not its :class:`SparseFaceOperator`, preconditioned by the diagonal, not
    by the exact inverse of a box without obstacles (:mod:`~pbanim.fluids.face_solve`: one iteration to the
    same stopping test, so the same answer to ``tol``, ORACLES E26)."""
    if nu == 0:
        return [c.copy() for c in u], [SolveInfo(method, 0, 0.0) for _ in u]
    if method == "fft" and (grid.has_obstacles or not all(grid.periodic)):
        raise InvalidInput(f"diffuse_velocity: method 'fft' needs a periodic box without obstacles; this grid has "
                           f"boundary {grid.boundary} and {int(grid.solid.sum())} solid cells (use 'cg')")
    max_iter = 20 * max(grid.shape) + 100 if max_iter is None else max_iter
    a = diffusion_coefficient(grid, nu, h, "nu")
    out, infos = [], []
    for i, c in enumerate(u):
        A, wall, sparse, pre = _face_operator(grid, i, a)
        r = np.where(A.closed, 0.0, c) + wall
        its = 0
        if method == "fft":
            x = _spectral(grid, r, 1.0, a)
        elif method == "cg":
            x, its = _cg(sparse if lean else A, r, c * grid.open[i], tol, max_iter,
                         pre if lean else (lambda v, A=A: v / A.diag), "diffusion cg")
        else:
            x, its = relax(A, r, c * grid.open[i], method, iterations)
        res = r - A(x)
        out.append(x * grid.open[i])
        infos.append(SolveInfo(method, int(its), float(np.abs(res).max())))
    return out, infos


@contract(grid=_GRID, s=Cells(), kappa=_COEF, h=_H, method=Choice(DIFFUSION_METHODS + ("dct", "spectral")),
          iterations=_SWEEPS, tol=_TOL, max_iter=_MAX_ITER, returns=finite_fields)
@quiet
def diffuse_scalar(grid, s: np.ndarray, kappa: float, h: float, method: str = "cg", *, iterations: int = 20,
                   tol: float = 1e-12, max_iter: int | None = None) -> tuple[np.ndarray, SolveInfo]:
    """Solve (I − κΔt L) s¹ = s⁰ (no flux through walls and obstacles); returns (s¹, SolveInfo)."""
    if kappa == 0:
        return s.copy(), SolveInfo(method, 0, 0.0)
    check_method_fits(grid, method, "diffuse_scalar")
    a = diffusion_coefficient(grid, kappa, h, "kappa")
    return _solve(grid, s.copy(), s.copy(), 1.0, a, method, iterations, 1.0, tol, max_iter)
