"""Stam's collocated Stable Fluids (chapter 09): every field at the cell centres, his step, stage by stage.

Stam's game code keeps the velocity components and the scalars (density ρ_s, temperature T) in one
cell-centred array each, and splits a step of ∂u/∂t = −(u·∇)u − ∇p/ρ + ν∇²u + f into

    velocity   u ← u + Δt f                  add_source
               (I − νΔt ∇²) u¹ = u           diffuse   (implicit; Stam: 20 Gauss–Seidel sweeps)
               u¹(x) ← u¹(x − Δt u¹(x))      advect    (linear semi-Lagrangian on the cell centres)
               L p = D_c u,  u ← u − G_c p   project   (compact Laplacian, centred D_c, G_c)
    scalar     s ← s + Δt S,   (I − κΔt ∇²) s¹ = s,   s¹(x) ← s¹(x − Δt u(x))      (no projection)

with the boundary rule of Stam's ``set_bnd`` at walls: the ghost value of the normal component is its
mirror with the sign changed (u·n = 0 on the wall, half a cell out), the tangential components and the
scalars are mirrored (free slip, no flux). On a periodic axis the ghosts wrap. Stam's code also projects
once before advecting (``pre_project=True`` here), so that the field that carries is divergence-free.

Each stage reuses the package: the scalar diffusion is :func:`.diffusion.diffuse_scalar` (the cell
operator of :mod:`.poisson`), the normal component at walls uses that solve's relaxation and CG with the
mirrored diagonal, the advection reads fields through :mod:`.interpolate`'s ghost cells, and the
projection is :func:`.collocated.project_collocated` (so the divergence it leaves is O(Δx²), ORACLES E13).
A stage that is not declared does not run: ν = 0 means no diffusion solve, κ = 0 (or no entry) none for
that scalar, ``project=False`` no pressure.

==========  ====================================================================
symbol      meaning
==========  ====================================================================
u           velocity, d cell arrays (``state.u``)
s, S        cell scalar (``state.scalars``), its source rate (``sources``)
f           body force density, d cell arrays (``forces``)
ν, κ        viscosity, scalar diffusivity (≥ 0)
D_c, G_c    centred divergence and gradient (:mod:`.collocated`)
E           ½ρ Σ_cells |u|² Δx^d
==========  ====================================================================

Limiting cases: ν = κ = 0 and no projection is pure transport (a uniform flow over whole cells shifts
fields exactly); the Taylor–Green vortex sampled at the cell centres has D_c u = 0 exactly, so without
advection the pipeline only diffuses it, by 1/(1 − νΔtλ) per step with λ = 2(2 cos kΔx − 2)/Δx², the
same factor as on the MAC grid (ORACLES E18).

References: J. Stam, Stable Fluids, SIGGRAPH 1999; J. Stam, Real-Time Fluid Dynamics for Games, GDC 2003
(``add_source``, ``diffuse``, ``advect``, ``project``, ``set_bnd``, ``vel_step``, ``dens_step``).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..contracts import Choice, Flag, Int, Obj, Opt, Real, Seq, contract
from ..errors import InvalidInput, NonFiniteResult, SimulationDiverged
from ..ode.driver import MAX_STEPS, step_grid
from .collocated import _shifted, collocated_divergence, project_collocated
from .diffusion import diffuse_scalar, diffusion_coefficient
from .grid import Grid
from .interpolate import _sample, pad_field
from .poisson import POISSON_METHODS, SolveInfo, _cg, check_method_fits, relax
from .scene import check_fields
from .specs import MAX_ITER, MAX_SWEEPS, Cells, Named, Velocity, finite_fields, quiet

__all__ = ["STAM_DIFFUSION", "StamResult", "StamSolver", "advect_collocated"]

STAM_DIFFUSION = ("gauss_seidel", "jacobi", "cg", "fft")

_GRID = Obj(Grid)
_CELLS_U = Velocity(at="cells")
_H = Real(gt=0)


class _MirroredOperator:
    """A = I − a ∇² for a cell-centred normal component: at a wall its ghost is −u (Stam's ``set_bnd``)."""

    def __init__(self, grid, i: int, a: float) -> None:
        self.grid, self.i, self.a = grid, i, a
        walls = np.zeros(grid.shape)
        for ax in range(grid.dim):
            if not grid.periodic[ax]:
                v = np.moveaxis(walls, ax, 0)
                v[0] += 1.0 if ax == i else -1.0            # the ghost adds ∓u to the cell's own row
                v[-1] += 1.0 if ax == i else -1.0
        self.diag = 1.0 + a * (2 * grid.dim + walls) / grid.dx ** 2

    def __call__(self, x: np.ndarray) -> np.ndarray:
        lap = -2.0 * self.grid.dim * x
        for ax in range(self.grid.dim):
            plus, minus = _shifted(self.grid, x, ax, -1.0 if ax == self.i else 1.0)
            lap += plus + minus
        return x - self.a * lap / self.grid.dx ** 2


def _diffuse_component(grid, c, i, nu, h, method, iterations, tol, max_iter):
    """(I − νΔt ∇²) c¹ = c for velocity component i with Stam's mirrors; returns (c¹, SolveInfo)."""
    if grid.periodic[i]:                                     # same operator as a scalar's: reuse it
        return diffuse_scalar(grid, c, nu, h, method, iterations=iterations, tol=tol, max_iter=max_iter)
    A = _MirroredOperator(grid, i, diffusion_coefficient(grid, nu, h, "viscosity"))
    if method == "cg":
        x, its = _cg(A, c, c.copy(), tol, max_iter, lambda v: v / A.diag, "stam diffusion cg")
    else:
        x, its = relax(A, c, c.copy(), method, iterations)
    return x, SolveInfo(method, int(its), float(np.abs(c - A(x)).max()))


def _padded(grid, q, component):
    """Ghost cells for a cell-centred field: even mirrors, odd across the walls normal to ``component``."""
    P = pad_field(grid, q, None)
    if component is not None and not grid.periodic[component]:
        v = np.moveaxis(P, component, 0)
        v[:2] *= -1.0
        v[-2:] *= -1.0
    return P


@contract(grid=_GRID, fields=Seq(Cells()), components=Seq(Opt(Int(ge=0, le=2))), u=_CELLS_U, h=_H,
          returns=finite_fields)
@quiet
def advect_collocated(grid, fields: list, components: list, u: list, h: float) -> list:
    """Stam's ``advect``: each cell field q ← q(x − Δt u(x)), linear, u the cell-centred velocity.

    ``components[j]`` is the velocity axis of ``fields[j]`` (its normal ghosts are odd at walls) or None for
    a scalar. Departure points outside a wall box are clipped to the wall.
    """
    if len(fields) != len(components):
        raise InvalidInput(f"advect_collocated: components must have one entry per field ({len(fields)}), got "
                           f"{components!r}")
    for j, comp in enumerate(components):
        if comp is not None and comp >= grid.dim:
            raise InvalidInput(f"advect_collocated: components[{j}] must be None or an axis in 0 … {grid.dim - 1}, "
                               f"got {comp!r}")
    return _advect(grid, fields, components, u, h)


def _advect(grid, fields, components, u, h):
    """:func:`advect_collocated` without the checks (the step's inner call)."""
    X = grid.positions(None)
    back = [x - h * c for x, c in zip(X, u)]
    return [_sample(grid, q, None, back, "linear", padded=_padded(grid, q, comp)) for q, comp in zip(fields, components)]


@dataclass
class StamResult:
    """A run: times, diagnostics per recorded step (kinetic energy, max |D_c u|, totals), final fields."""

    t: np.ndarray
    diagnostics: dict
    u: list
    scalars: dict
    pipeline: tuple
    nsteps: int


class StamSolver:
    """Stam's collocated solver on a plain box (periodic axes or walls; no obstacles, no sliding lids).

    Parameters
    ----------
    grid : Grid
    u : d cell arrays, optional (zero when omitted)
    scalars : dict name → cell array, optional
    viscosity : ν ≥ 0 (0: no velocity diffusion stage)
    diffusivity : dict name → κ ≥ 0 (missing or 0: no diffusion stage for that scalar)
    sources : dict name → cell array S (rate per unit time); forces : d cell arrays f, optional
    diffusion : one of ``STAM_DIFFUSION`` (Stam: ``gauss_seidel``, ``iterations`` sweeps; ``cg`` to ``tol``)
    projection : a method of :func:`~pbanim.fluids.poisson.solve_cells`, or None for no projection
    pre_project : also project before advecting, as Stam's ``vel_step`` does
    self_advect : False drops the velocity's advection stage (Stokes flow; the scalars are still carried)
    """

    @contract(grid=_GRID, u=Opt(_CELLS_U), scalars=Opt(Named(Cells())), viscosity=Real(ge=0),
              diffusivity=Opt(Named(Real(ge=0))), sources=Opt(Named(Cells())), forces=Opt(_CELLS_U),
              diffusion=Choice(STAM_DIFFUSION), projection=Opt(Choice(POISSON_METHODS)),
              iterations=Int(ge=0, le=MAX_SWEEPS), tol=Real(gt=0, le=1), max_iter=Opt(Int(ge=1, le=MAX_ITER)),
              pre_project=Flag(), self_advect=Flag(), density=Real(gt=0))
    def __init__(self, grid, u=None, scalars=None, *, viscosity: float = 0.0, diffusivity=None, sources=None,
                 forces=None, diffusion: str = "gauss_seidel", projection: str | None = "gauss_seidel",
                 iterations: int = 20, tol: float = 1e-10, max_iter: int | None = None,
                 pre_project: bool = False, self_advect: bool = True, density: float = 1.0) -> None:
        where = "StamSolver"
        if grid.has_obstacles or grid.lids:
            raise InvalidInput(f"{where}: grid must be a plain box (no obstacles, no sliding lids), got {grid!r}")
        self.grid, self.density = grid, float(density)
        self.u = [np.array(c, dtype=float) for c in (u if u is not None else [np.zeros(grid.shape)] * grid.dim)]
        self.scalars = {k: np.array(v, dtype=float) for k, v in (scalars or {}).items()}
        self.nu = float(viscosity)
        for what, named in (("diffusivity", diffusivity), ("sources", sources)):
            unknown = sorted(set(named or {}) - set(self.scalars))
            if unknown:
                raise InvalidInput(f"{where}: {what} must name scalars among {sorted(self.scalars)}, got {unknown}")
        self.kappa = {k: float(v) for k, v in (diffusivity or {}).items()}
        self.sources = {k: np.array(v, dtype=float) for k, v in (sources or {}).items()}
        self.forces = None if forces is None else [np.array(c, dtype=float) for c in forces]
        if diffusion == "fft" and not all(grid.periodic):
            raise InvalidInput(f"{where}: diffusion 'fft' needs a periodic box, the grid has boundary {grid.boundary} "
                               "(use 'cg')")
        if projection is not None:
            check_method_fits(grid, projection, where, "projection")
        self.diffusion, self.projection = diffusion, projection
        self.iterations, self.tol = int(iterations), float(tol)
        self.max_iter = 20 * max(grid.shape) + 100 if max_iter is None else int(max_iter)
        self.pre_project, self.self_advect = bool(pre_project), bool(self_advect)
        self.t, self.nsteps, self.info = 0.0, 0, {}

    @property
    def pipeline(self) -> tuple:
        """The stages one step runs, in order (undeclared stages are absent)."""
        vel = (["add_force"] if self.forces is not None else []) + (["diffuse[u]"] if self.nu > 0 else [])
        vel += (["project"] if self.pre_project and self.projection else []) + (["advect[u]"] if self.self_advect else [])
        vel += ["project"] if self.projection else []
        sc = []
        for k in self.scalars:
            sc += ([f"add_source[{k}]"] if k in self.sources else []) + \
                  ([f"diffuse[{k}]"] if self.kappa.get(k, 0.0) > 0 else []) + [f"advect[{k}]"]
        return tuple(vel + sc)

    def _check_finite(self) -> None:
        check_fields(self.t, self.nsteps, self.u, {})

    def _project(self):
        self._check_finite()                  # the solvers refuse non-finite input: report it by name first
        opts = {"iterations": self.iterations, "tol": self.tol, "max_iter": self.max_iter}
        self.u, info = project_collocated(self.grid, self.u, self.projection, "compact", **opts)
        self.info["projection_residual"] = info.residual

    @contract(h=_H)
    def step(self, h: float) -> None:
        """One step of Stam's ``vel_step`` then ``dens_step`` (in place); a field that stops being finite, or
        an overflow on the way, is :class:`~pbanim.errors.SimulationDiverged`."""
        try:
            self._step(h)
        except NonFiniteResult as exc:                # the field that overflowed first, else what a stage met
            check_fields(self.t, self.nsteps, self.u, self.scalars, "before the step ended")
            raise SimulationDiverged(self.t, self.nsteps, exc.what) from exc
        check_fields(self.t, self.nsteps, self.u, self.scalars)
        self.t += h
        self.nsteps += 1

    def _step(self, h: float) -> None:
        g = self.grid
        with np.errstate(over="ignore", invalid="ignore"):      # an overflow is reported below, by name
            if self.forces is not None:
                self.u = [c + h * f for c, f in zip(self.u, self.forces)]
            if self.nu > 0:
                solved = [_diffuse_component(g, c, i, self.nu, h, self.diffusion, self.iterations, self.tol,
                                             self.max_iter) for i, c in enumerate(self.u)]
                self.u = [x for x, _ in solved]
                self.info["diffusion_residual"] = max(s.residual for _, s in solved)
            if self.pre_project and self.projection:
                self._project()
            if self.self_advect:
                self.u = _advect(g, self.u, list(range(g.dim)), self.u, h)
            if self.projection:
                self._project()
            for k, s in self.scalars.items():
                if k in self.sources:
                    s = s + h * self.sources[k]
                if self.kappa.get(k, 0.0) > 0:
                    s, _ = diffuse_scalar(g, s, self.kappa[k], h, self.diffusion, iterations=self.iterations,
                                          tol=self.tol, max_iter=self.max_iter)
                self.scalars[k] = _advect(g, [s], [None], self.u, h)[0]

    def measure(self) -> dict:
        """Kinetic energy ½ρ Σ|u|²Δx^d, max |D_c u|, and ∫ s dV of each scalar (inf when they overflow)."""
        g = self.grid
        with np.errstate(over="ignore", invalid="ignore"):
            out = {"kinetic_energy": 0.5 * self.density * g.dx ** g.dim * float(sum(np.sum(c * c) for c in self.u)),
                   "max_divergence": float(np.abs(collocated_divergence(g, self.u)).max())}
            out.update({f"total_{k}": g.total(v) for k, v in self.scalars.items()})
        return out

    @contract(t_end=Real(), h=_H, max_steps=Int(ge=1))
    def simulate(self, t_end: float, h: float, *, max_steps: int = MAX_STEPS) -> StamResult:
        """Step to ``t_end`` by the one step rule (:func:`pbanim.ode.driver.step_grid`), recording every step
        (at most ``max_steps`` steps: :class:`~pbanim.errors.StepLimitExceeded` before the first one)."""
        sg = step_grid(self.t, t_end, h, max_steps=max_steps)
        diag = {k: [v] for k, v in self.measure().items()}
        ts = [self.t]
        for k in range(sg.n_steps):
            self.step(sg.size(k))
            if k == sg.n_steps - 1:
                self.t = sg.t_end
            for name, v in self.measure().items():
                diag[name].append(v)
            ts.append(self.t)
        return StamResult(np.asarray(ts), {k: np.asarray(v) for k, v in diag.items()}, [c.copy() for c in self.u],
                          {k: v.copy() for k, v in self.scalars.items()}, self.pipeline, sg.n_steps)
