"""Flows with known answers, and the chapter's scenes (chapter 09).

Taylor–Green vortex (periodic box of side L, k = 2π/L), an exact solution of the Navier–Stokes equations:

    u = U cos(kx) sin(ky) e^(−2νk²t),   v = −U sin(kx) cos(ky) e^(−2νk²t),   E(t) = E(0) e^(−4νk²t)

Its advection term is a gradient, (u·∇)u = −∇(U²/4 (cos 2kx + cos 2ky)), so the projection takes it all
away and only viscosity decays it (ORACLES E1). On the MAC grid the sampled field is divergence-free to
roundoff: the x and y differences both bring the factor 2 sin(kΔx/2)/Δx. The implicit Euler step decays
it by 1/(1 − νΔt λ) per step, λ = 2 (2 cos kΔx − 2)/Δx² → −2k²: the measured rate tends to 2νk².

A stream function ψ at the cell corners gives u = ∂ψ/∂y, v = −∂ψ/∂x by differences on the faces; then
D u = 0 exactly (the two mixed differences cancel), whatever ψ: a field the projection must leave alone.

Lid-driven cavity: the unit box with the top wall sliding at U, Re = U·1/ν. At Re = 100 it settles to one
steady vortex; U. Ghia, K. N. Ghia, C. T. Shin (J. Comput. Phys. 48, 1982, Table I) tabulate u on the
vertical centre line (``GHIA_RE100``), the reference every solver is compared with.

==========  ====================================================================
symbol      meaning
==========  ====================================================================
U, k        amplitude, wavenumber of the Taylor–Green vortex (k = 2π m / L)
ψ           stream function at the cell corners (2-D)
Re          Reynolds number U L / ν of the cavity
==========  ====================================================================

Limiting cases: ν = 0 keeps the Taylor–Green vortex steady; ψ constant gives u = 0.

References: G. I. Taylor, A. E. Green, Proc. R. Soc. A 158 (1937); U. Ghia et al. (1982); J. Stam (1999).
"""

from __future__ import annotations

import numpy as np

from ..contracts import Array, Choice, Flag, Func, Int, Obj, Opt, Real, contract, finite_result
from ..errors import InvalidInput, check_result
from .advection import ADVECTION
from .diffusion import DIFFUSION_METHODS
from .effects import (
    Advection,
    Buoyancy,
    Diffusion,
    Projection,
    Source,
    VorticityConfinement,
)
from .grid import Grid
from .poisson import POISSON_METHODS
from .scene import FluidScene
from .specs import MAX_CELLS, GridShape, finite_fields, quiet

__all__ = [
    "GHIA_RE100",
    "centreline_u",
    "lid_driven_cavity",
    "smoke_plume",
    "stream_velocity",
    "taylor_green",
    "taylor_green_energy",
]

# U. Ghia, K. N. Ghia, C. T. Shin (1982), Table I, Re = 100: (y, u) on the vertical line x = 0.5
GHIA_RE100 = np.array([
    (0.0000, 0.00000), (0.0547, -0.03717), (0.0625, -0.04192), (0.0703, -0.04775), (0.1016, -0.06434),
    (0.1719, -0.10150), (0.2813, -0.15662), (0.4531, -0.21090), (0.5000, -0.20581), (0.6172, -0.13641),
    (0.7344, 0.00332), (0.8516, 0.23151), (0.9531, 0.68717), (0.9609, 0.73722), (0.9688, 0.78871),
    (0.9766, 0.84123), (1.0000, 1.00000)])


_GRID = Obj(Grid)
MAX_SIDE = int(MAX_CELLS ** 0.5)      # the largest square grid: 2048 × 2048


@contract(grid=_GRID, amplitude=Real(), mode=Int(ge=1), returns=finite_fields)
def taylor_green(grid: Grid, amplitude: float = 1.0, mode: int = 1) -> list:
    """The Taylor–Green velocity on the faces of a periodic square grid (k = 2π·mode / L, mode < n/2)."""
    if grid.dim != 2 or not all(grid.periodic) or grid.shape[0] != grid.shape[1]:
        raise InvalidInput(f"taylor_green: grid must be a periodic square 2-D grid, got {grid!r}")
    if mode > grid.shape[0] // 2 - 1:
        raise InvalidInput(f"taylor_green: mode must be at most n/2 − 1 = {grid.shape[0] // 2 - 1} on this grid "
                           f"(a finer mode is not resolved), got {mode}")
    k = 2.0 * np.pi * mode / grid.extent[0]
    x, y = grid.positions(0)
    u = amplitude * np.cos(k * x) * np.sin(k * y)
    x, y = grid.positions(1)
    v = -amplitude * np.sin(k * x) * np.cos(k * y)
    return [u, v]


@contract(e0=Real(ge=0), nu=Real(ge=0), k=Real(), t=Array(None, scalar=True, empty=True),
          returns=finite_result)
def taylor_green_energy(e0: float, nu: float, k: float, t) -> np.ndarray:
    """E(t) = E(0) e^(−4νk²t), the exact kinetic energy of the decaying vortex: E(0) itself at t = 0 and 0 for
    t > 0 when 4νk² overflows (its limit); an energy that overflows backwards in time (t < 0) is
    :class:`~pbanim.errors.NonFiniteResult`."""
    t = np.asarray(t, dtype=float)
    with np.errstate(over="ignore", invalid="ignore"):
        exponent = np.where(t == 0, 0.0, -(4.0 * nu * k * k) * t)     # no ∞ · 0 at t = 0
        out = np.zeros(t.shape) if e0 == 0 else e0 * np.exp(exponent)
    return out if out.ndim else float(out)


@contract(grid=_GRID, psi=Func(), returns=finite_fields)
@quiet
def stream_velocity(grid: Grid, psi) -> list:
    """u = ∂ψ/∂y, v = −∂ψ/∂x on the faces, ψ a function of the corner coordinates (x, y) (2-D)."""
    if grid.dim != 2:
        raise InvalidInput(f"stream_velocity: grid must be 2-D, got {grid.dim} axes")
    nodes = [np.arange(n + (0 if p else 1)) * grid.dx for n, p in zip(grid.shape, grid.periodic)]
    X, Y = np.meshgrid(*nodes, indexing="ij")
    try:
        P = np.asarray(psi(X, Y), dtype=float)
    except (TypeError, ValueError) as exc:
        raise InvalidInput(f"stream_velocity: psi must return numbers, its return could not be read ({exc})") from None
    if P.shape != X.shape or not np.all(np.isfinite(P)):
        raise InvalidInput(f"stream_velocity: psi must return finite values of the corner shape {X.shape}, got "
                           f"shape {P.shape}" + ("" if P.shape != X.shape else " with NaN or inf entries"))
    dy = (np.roll(P, -1, axis=1) - P) if grid.periodic[1] else np.diff(P, axis=1)
    dx = (np.roll(P, -1, axis=0) - P) if grid.periodic[0] else np.diff(P, axis=0)
    return [dy / grid.dx, -dx / grid.dx]


@contract(n=Int(ge=3, le=MAX_SIDE), reynolds=Real(gt=0), lid=Real(), advection=Choice(ADVECTION),
          projection=Choice(POISSON_METHODS), diffusion=Choice(DIFFUSION_METHODS))
def lid_driven_cavity(n: int, reynolds: float = 100.0, lid: float = 1.0, *, advection: str = "semi_lagrangian",
                      projection: str = "dct", diffusion: str = "cg") -> FluidScene:
    """The unit square with the top wall sliding at ``lid``: ν = lid / Re, at rest at t = 0 (ν overflowing
    is :class:`~pbanim.errors.NonFiniteResult`)."""
    grid = Grid((n, n), 1.0 / n, "walls", lids={"y+": (lid, 0.0)})
    with np.errstate(over="ignore"):
        nu = check_result("the viscosity ν = lid / reynolds", abs(lid) / reynolds, f"lid = {lid:g}, reynolds = "
                          f"{reynolds:g}")
    return FluidScene(grid, [Advection(advection), Diffusion(nu, diffusion), Projection(projection)])


@contract(scene=Obj(FluidScene))
def centreline_u(scene: FluidScene) -> tuple[np.ndarray, np.ndarray]:
    """(y, u) on the vertical centre line of a 2-D wall box (u averaged over the two middle columns of
    faces when n is odd), with the wall values (0 at the bottom, the lid at the top) appended."""
    g, u = scene.grid, scene.state.u[0]
    if g.dim != 2 or g.periodic[1]:
        raise InvalidInput(f"centreline_u: scene must be on a 2-D grid with walls along y, got {g!r}")
    nx = g.shape[0]
    col = u[nx // 2] if nx % 2 == 0 else 0.5 * (u[nx // 2] + u[nx // 2 + 1])
    y = (np.arange(g.shape[1]) + 0.5) * g.dx
    top = g.lids.get((1, 1))
    return (np.concatenate([[0.0], y, [g.extent[1]]]),
            np.concatenate([[0.0], col, [0.0 if top is None else top[0]]]))


@contract(shape=GridShape(dims=(2,), minimum=8), obstacle=Flag(), projection=Opt(Choice(POISSON_METHODS)),
          advection=Choice(ADVECTION), confinement=Real(ge=0), buoyancy=Real(ge=0))
def smoke_plume(shape=(64, 96), *, obstacle: bool = True, projection: str | None = None,
                advection: str = "maccormack", confinement: float = 2.0, buoyancy: float = 4.0) -> FluidScene:
    """Hot smoke released at the bottom of a closed box, rising around a disc (obstacle).

    Sources of density and temperature near the floor, buoyancy β T (smoke weight α = 0.1 per unit
    density), vorticity confinement ε, advection of velocity and scalars, projection (``mgpcg`` with the
    obstacle, ``dct`` without, unless given).
    """
    grid_shape = tuple(int(n) for n in shape)
    nx, ny = grid_shape
    dx = 1.0 / nx
    X, Y = Grid(grid_shape, dx).positions()
    solid = None
    if obstacle:
        solid = (X - 0.5) ** 2 + (Y - 0.45 * ny * dx) ** 2 < (0.12) ** 2
    grid = Grid(grid_shape, dx, "walls", solid=solid)
    source = ((np.abs(X - 0.5) < 0.08) & (Y < 0.1 * ny * dx) & (Y > 2 * dx)).astype(float)
    method = projection or ("mgpcg" if obstacle else "dct")
    effects = [Source("density", 4.0, source), Source("temperature", 6.0, source),
               Buoyancy(alpha=0.1, beta=buoyancy),
               VorticityConfinement(confinement), Advection(advection), Projection(method)]
    zeros = np.zeros(grid_shape)
    return FluidScene(grid, effects, scalars={"density": zeros, "temperature": zeros})
