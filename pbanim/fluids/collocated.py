"""Stam's collocated grid (chapter 09): every velocity component at the cell centres, and why its
projection is not one.

In Stable Fluids and in Stam's game code, u, v (and p) all sit at the cell centres. The divergence and the
gradient are then centred differences,

    (D_c u)_c = Σᵢ (uᵢ(c + eᵢ) − uᵢ(c − eᵢ)) / (2Δx),      (G_c p)_c = (p(c + eᵢ) − p(c − eᵢ)) / (2Δx),

and Stam's ``project`` solves the compact Laplacian L p = D_c u (the 5-point stencil, 20 Gauss–Seidel
sweeps) before u ← u − G_c p. But D_c G_c is not L: it is the *wide* Laplacian, Σᵢ (p(c + 2eᵢ) − 2p(c) +
p(c − 2eᵢ)) / (4Δx²), which couples only cells of equal parity. So even an exact solve of L leaves

    D_c u¹ = D_c u⁰ − D_c G_c p = (L − D_c G_c) p = O(Δx²) p⁗,

a divergence that only shrinks with the grid. Solving the wide operator instead (exact by FFT on a
periodic box, symbol −Σᵢ sin²θᵢ / Δx², θᵢ = 2πkᵢ/nᵢ) removes D_c u to roundoff but leaves the checkerboard
modes (θᵢ = π) undetermined: the odd–even decoupling that the staggered MAC grid of :mod:`.grid` avoids —
there D G = L exactly and the projection is exact (ORACLES E2, E13).

Walls follow Stam's ``set_bnd``: the normal component is mirrored with a sign change (u·n = 0 at the wall),
the tangential one and the pressure are mirrored (no flux).

==========  ====================================================================
symbol      meaning
==========  ====================================================================
D_c, G_c    centred divergence and gradient on the collocated grid
L           compact (5-point) Laplacian with Neumann walls (:meth:`.grid.Grid.laplacian`)
θᵢ          Fourier angle 2πkᵢ/nᵢ of a mode on a periodic axis
==========  ====================================================================

Limiting cases: for a smooth field the divergence left by the compact solve falls as Δx² (ORACLES E13);
for a single Fourier mode both operators agree up to sin²θ vs 4 sin²(θ/2), i.e. to O(θ⁴).

References: J. Stam, Stable Fluids (1999) and Real-Time Fluid Dynamics for Games (2003) (``project``,
``set_bnd``); R. Bridson, Fluid Simulation for Computer Graphics (2015), §2.4 (why staggered).
"""

from __future__ import annotations

import numpy as np

from ..contracts import Choice, Int, Obj, Opt, Real, contract
from ..errors import InvalidInput
from .poisson import POISSON_METHODS, _solve, check_method_fits
from .specs import MAX_ITER, MAX_SWEEPS, Cells, Velocity, finite_fields, quiet

__all__ = ["COLLOCATED_STENCILS", "collocated_divergence", "collocated_gradient", "project_collocated"]

COLLOCATED_STENCILS = ("compact", "wide")

_GRID = Obj("pbanim.fluids.grid:Grid")
_U = Velocity(at="cells")


def _shifted(grid, q, axis, sign_normal):
    """(q(c + e), q(c − e)) along ``axis`` with Stam's wall mirrors (``sign_normal`` = −1 for the normal
    component, +1 for tangential components and scalars)."""
    if grid.periodic[axis]:
        return np.roll(q, -1, axis=axis), np.roll(q, 1, axis=axis)
    pad = [(0, 0)] * grid.dim
    pad[axis] = (1, 1)
    e = np.pad(q, pad, mode="edge")
    v = np.moveaxis(e, axis, 0)
    v[0] *= sign_normal
    v[-1] *= sign_normal
    hi = [slice(None)] * grid.dim
    hi[axis] = slice(2, None)
    lo = [slice(None)] * grid.dim
    lo[axis] = slice(None, -2)
    return e[tuple(hi)], e[tuple(lo)]


@contract(grid=_GRID, u=_U, returns=finite_fields)
@quiet
def collocated_divergence(grid, u: list) -> np.ndarray:
    """D_c u: centred differences of the cell-centred components."""
    div = np.zeros(grid.shape)
    for i, c in enumerate(u):
        plus, minus = _shifted(grid, c, i, -1.0)
        div += plus - minus
    return div / (2.0 * grid.dx)


@contract(grid=_GRID, p=Cells(), returns=finite_fields)
@quiet
def collocated_gradient(grid, p: np.ndarray) -> list:
    """G_c p: centred differences of the cell pressure (mirrored at walls)."""
    out = []
    for i in range(grid.dim):
        plus, minus = _shifted(grid, p, i, 1.0)
        out.append((plus - minus) / (2.0 * grid.dx))
    return out


def _wide_spectral(grid, r):
    """Solve D_c G_c p = r exactly on a periodic box (modes where the symbol vanishes set to 0)."""
    from scipy import fft

    sym = np.zeros(())
    for a, n in enumerate(grid.shape):
        theta = 2.0 * np.pi * (np.fft.rfftfreq(n) if a == grid.dim - 1 else np.fft.fftfreq(n))
        shape = [1] * grid.dim
        shape[a] = theta.size
        sym = sym - (np.sin(theta) ** 2 / grid.dx ** 2).reshape(shape)
    small = np.abs(sym) < 1e-12 / grid.dx ** 2
    R = fft.rfftn(r)
    P = np.where(small, 0.0, R / np.where(small, 1.0, sym))
    return fft.irfftn(P, s=grid.shape)


@contract(grid=_GRID, u=_U, method=Choice(POISSON_METHODS), stencil=Choice(COLLOCATED_STENCILS),
          iterations=Int(ge=0, le=MAX_SWEEPS), omega=Real(gt=0, le=1), tol=Real(gt=0, le=1),
          max_iter=Opt(Int(ge=1, le=MAX_ITER)), returns=finite_fields)
@quiet
def project_collocated(grid, u, method: str = "spectral", stencil: str = "compact", *, iterations: int = 20,
                       omega: float = 1.0, tol: float = 1e-12, max_iter: int | None = None):
    """Stam's projection of cell-centred velocities: solve for p, return (u − G_c p, SolveInfo or None).

    ``stencil="compact"`` solves L p = D_c u with any method of :func:`~pbanim.fluids.poisson.solve_cells`
    and its options (Stam: ``gauss_seidel`` with 20 sweeps); ``"wide"`` solves D_c G_c p = D_c u exactly by
    FFT (periodic boxes only).
    """
    if grid.has_obstacles:
        raise InvalidInput("project_collocated: grid must be a plain box (the teaching comparison), got one with "
                           f"{int(grid.solid.sum())} obstacle cells")
    div = collocated_divergence(grid, u)
    if stencil == "wide":
        if not all(grid.periodic):
            raise InvalidInput(f"project_collocated: the wide stencil is solved by FFT on periodic boxes only; the "
                               f"grid has boundary {grid.boundary}")
        p, info = _wide_spectral(grid, div), None
    else:
        check_method_fits(grid, method, "project_collocated")
        p, info = _solve(grid, -div, np.zeros(grid.shape), 0.0, 1.0, method, iterations, omega, tol, max_iter)
    return [c - g for c, g in zip(u, collocated_gradient(grid, p))], info
