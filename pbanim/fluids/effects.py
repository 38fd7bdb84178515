"""The declared effects of a fluid step (chapter 09): sources, forces, buoyancy, vorticity confinement,
diffusion, advection, projection.

Stable Fluids splits one step of ∂u/∂t = −(u·∇)u − ∇p/ρ + ν∇²u + f into stages, each solved on its own
(operator splitting, first order in Δt):

    w₁ = w₀ + Δt f                  force       sources, forces, buoyancy, vorticity confinement
    w₂ = A(w₁; w₁)                  advect      −(u·∇)u and the scalars' transport (:mod:`.advection`)
    w₃ = (I − νΔt ∇²)⁻¹ w₂          diffuse     ν∇²u, κ∇²s (:mod:`.diffusion`)
    u¹ = w₃ − G p,  L p = D w₃      project     −∇p/ρ and ∇·u = 0 (:mod:`.poisson`); p absorbs Δt/ρ

A scene runs the stages it declares, in this phase order (declaration order within a phase); a stage that
is not declared is never run — ``Diffusion(viscosity=0)`` contributes no stage at all.

The force terms (Fedkiw, Stam, Jensen 2001), with ŷ the "up" axis:

    buoyancy                 f = (−α s + β (T − T_amb)) ŷ          (s smoke density, T temperature)
    vorticity confinement    ω = ∇ × u,  N = ∇|ω| / |∇|ω||,  f = ε Δx (N × ω)

==========  ====================================================================
symbol      meaning
==========  ====================================================================
w           the velocity between stages
α, β        weight of the smoke (sinks), lift of the heat (rises)
ε           vorticity confinement strength (dimensionless; multiplied by Δx)
ν, κ        viscosity, scalar diffusivity
==========  ====================================================================

Limiting cases: ε = 0 and α = β = 0 add nothing; ε Δx → 0 as the grid is refined, so confinement vanishes
with the numerical dissipation it puts back.

References: J. Stam, Stable Fluids (1999) §2–3; R. Fedkiw, J. Stam, H. W. Jensen, Visual Simulation of
Smoke, SIGGRAPH 2001 (buoyancy, vorticity confinement).
"""

from __future__ import annotations

import numpy as np

from ..contracts import Array, Choice, Flag, Int, Obj, Opt, Real, Seq, Text, contract
from ..errors import InvalidInput, check_result
from .advection import ADVECTION, BACKTRACES, _advect_scalars, advect_scalar, advect_velocity
from .diffusion import DIFFUSION_METHODS, diffuse_scalar, diffuse_velocity
from .poisson import POISSON_METHODS, _solve, check_method_fits
from .specs import MAX_ITER, MAX_SWEEPS, Named, StateOn, Velocity, finite_fields, quiet

__all__ = [
    "PHASES",
    "Advection",
    "Buoyancy",
    "Diffusion",
    "FluidEffect",
    "Force",
    "Projection",
    "Source",
    "VorticityConfinement",
    "confinement_force",
]

PHASES = ("force", "advect", "diffuse", "project")

_GRID = Obj("pbanim.fluids.grid:Grid")
_STATE = StateOn()
_H = Real(gt=0)
_NAME = Text(nonempty=True)
_SWEEPS = Int(ge=0, le=MAX_SWEEPS)
_TOL = Real(gt=0, le=1)


class FluidEffect:
    """A stage of the fluid step: ``bind(grid, state)`` validates once, ``apply(grid, state, h)`` updates
    ``state`` (``state.u`` face arrays, ``state.scalars``); ``info`` holds what the last call measured."""

    name = "effect"
    phase = "force"

    def __init__(self) -> None:
        self.info: dict = {}

    @contract(grid=_GRID, state=_STATE)
    def bind(self, grid, state) -> None:
        """Validate against the grid and the state; called once by the scene."""

    def stages(self) -> list:
        return [self]

    def apply(self, grid, state, h: float) -> None:  # pragma: no cover - interface
        raise NotImplementedError

    def _need_scalar(self, state, name: str, who: str) -> None:
        if name not in state.scalars:
            raise InvalidInput(f"{who} needs the scalar {name!r}; the scene has {sorted(state.scalars)}")

    def _bound(self, grid, attr: str):
        """What ``bind`` prepared (``attr``), or InvalidInput when the effect was not bound, or bound to a grid of
        another shape (``apply`` called by hand)."""
        value = getattr(self, attr, None)
        if value is None or getattr(self, "_shape", grid.shape) != grid.shape:
            raise InvalidInput(f"{self.name}.apply: bind(grid, state) must come first, with a grid of this shape "
                               f"{grid.shape} (FluidScene binds every effect)")
        return value


def _cell_mask(grid, region, who: str) -> np.ndarray:
    """The region's weights on the fluid cells: its shape is the grid's (known at bind, not at construction)."""
    if region.shape != grid.shape:
        raise InvalidInput(f"{who}: region must be an array of the cell shape {grid.shape}, got shape {region.shape}")
    return region * grid.fluid


class Source(FluidEffect):
    """s ← s + Δt · rate · region for the scalar ``field`` (region: a 0/1 or weight array over the cells)."""

    phase = "force"

    @contract(field=_NAME, rate=Real(), region=Array(None))
    def __init__(self, field: str, rate: float, region) -> None:
        super().__init__()
        self.field, self.rate, self.region = field, float(rate), np.array(region, dtype=float)
        self.name = f"source[{field}]"

    @contract(grid=_GRID, state=_STATE)
    def bind(self, grid, state) -> None:
        self._need_scalar(state, self.field, self.name)
        self.weights, self._shape = _cell_mask(grid, self.region, self.name), grid.shape

    @contract(grid=_GRID, state=_STATE, h=_H)
    def apply(self, grid, state, h):
        weights = self._bound(grid, "weights")
        self._need_scalar(state, self.field, self.name)
        state.scalars[self.field] += (h * self.rate) * weights


class Force(FluidEffect):
    """u ← u + Δt f: ``f`` a constant vector (d numbers), optionally only inside ``region`` (cells)."""

    phase = "force"
    name = "force"

    @contract(f=Array((None,)), region=Opt(Array(None)))
    def __init__(self, f, region=None) -> None:
        super().__init__()
        self.f = np.array(f, dtype=float)
        self.region = None if region is None else np.array(region, dtype=float)

    @contract(grid=_GRID, state=_STATE)
    def bind(self, grid, state) -> None:
        if self.f.shape != (grid.dim,):
            raise InvalidInput(f"Force: f must be {grid.dim} numbers (one per axis of the grid), got {self.f}")
        w = np.ones(grid.shape) if self.region is None else _cell_mask(grid, self.region, self.name)
        self.weights = [grid.cells_to_faces(w, i) * grid.open[i] for i in range(grid.dim)]
        self._shape = grid.shape

    @contract(grid=_GRID, state=_STATE, h=_H)
    def apply(self, grid, state, h):
        weights = self._bound(grid, "weights")
        for i in range(grid.dim):
            if self.f[i] != 0:
                state.u[i] += (h * self.f[i]) * weights[i]


class Buoyancy(FluidEffect):
    """f = (−α s + β (T − T_amb)) along ``axis`` (default 1, y up); T is optional."""

    phase = "force"
    name = "buoyancy"

    @contract(alpha=Real(ge=0), beta=Real(ge=0), ambient=Real(), density=_NAME, temperature=Opt(_NAME),
              axis=Int(ge=0, le=2))
    def __init__(self, alpha: float = 0.0, beta: float = 1.0, ambient: float = 0.0, density: str = "density",
                 temperature: str | None = "temperature", axis: int = 1) -> None:
        super().__init__()
        self.alpha, self.beta, self.ambient = float(alpha), float(beta), float(ambient)
        self.density, self.temperature = density, temperature
        self.axis = int(axis)

    @contract(grid=_GRID, state=_STATE)
    def bind(self, grid, state) -> None:
        if self.axis >= grid.dim:
            raise InvalidInput(f"Buoyancy: axis must be below the grid dimension {grid.dim}, got {self.axis}")
        self._need_scalar(state, self.density, self.name)
        if self.temperature is not None:
            self._need_scalar(state, self.temperature, self.name)

    @contract(grid=_GRID, state=_STATE, h=_H)
    def apply(self, grid, state, h):
        self.bind(grid, state)                 # three look-ups: what bind checks holds for this state too
        f = -self.alpha * state.scalars[self.density]
        if self.temperature is not None:
            f = f + self.beta * (state.scalars[self.temperature] - self.ambient)
        a = self.axis
        state.u[a] += h * grid.cells_to_faces(f, a) * grid.open[a]


def _ddx(grid, c: np.ndarray, axis: int) -> np.ndarray:
    """Centred ∂c/∂x_axis at the cells (one-sided at walls)."""
    if grid.periodic[axis]:
        return (np.roll(c, -1, axis=axis) - np.roll(c, 1, axis=axis)) / (2.0 * grid.dx)
    return np.gradient(c, grid.dx, axis=axis)


@contract(grid=_GRID, u=Velocity(), returns=finite_fields)
@quiet
def vorticity(grid, u: list):
    """ω = ∇ × u at the cells: a scalar field in 2-D, a list of 3 fields in 3-D."""
    c = grid.faces_to_cells(u)
    if grid.dim == 2:
        return _ddx(grid, c[1], 0) - _ddx(grid, c[0], 1)
    return [_ddx(grid, c[2], 1) - _ddx(grid, c[1], 2), _ddx(grid, c[0], 2) - _ddx(grid, c[2], 0),
            _ddx(grid, c[1], 0) - _ddx(grid, c[0], 1)]


class VorticityConfinement(FluidEffect):
    """f = ε Δx (N × ω), N = ∇|ω| / |∇|ω||: puts back the small swirls the advection smears away."""

    phase = "force"
    name = "vorticity_confinement"

    @contract(epsilon=Real(ge=0))
    def __init__(self, epsilon: float) -> None:
        super().__init__()
        self.epsilon = float(epsilon)

    @contract(grid=_GRID, state=_STATE, h=_H)
    def apply(self, grid, state, h):
        f, _ = confinement_force(grid, state.u, self.epsilon)
        for i in range(grid.dim):
            state.u[i] += h * grid.cells_to_faces(f[i] * grid.fluid, i) * grid.open[i]


@contract(grid=_GRID, u=Velocity(), epsilon=Real(ge=0))
def confinement_force(grid, u: list, epsilon: float):
    """(f, N) at the cells: f = ε Δx (N × ω), N = ∇|ω| / |∇|ω|| (0 where |ω| is flat).

    The lengths |ω| and |∇|ω|| are taken without squaring (no overflow on the way); a force that overflows
    all the same is :class:`~pbanim.errors.NonFiniteResult`."""
    with np.errstate(over="ignore", invalid="ignore"):
        w = vorticity(grid, u)
        mag = np.abs(w) if grid.dim == 2 else _length(w)
        eta = [_ddx(grid, mag, a) for a in range(grid.dim)]
        check_result("∇|ω| (the vorticity confinement)", eta)
        norm = _length(eta) + 1e-12 * (float(mag.max()) + 1e-300) / grid.dx
        N = [e / norm for e in eta]
        s = epsilon * grid.dx
        if grid.dim == 2:
            f = [s * N[1] * w, -s * N[0] * w]
        else:
            f = [s * (N[1] * w[2] - N[2] * w[1]), s * (N[2] * w[0] - N[0] * w[2]), s * (N[0] * w[1] - N[1] * w[0])]
    check_result("the vorticity confinement force ε Δx (N × ω)", f, f"ε = {epsilon:g}, Δx = {grid.dx:g}")
    return f, N


def _length(v: list) -> np.ndarray:
    """|v| of a field of 2 or 3 components, by hypot (no overflow of the squares)."""
    out = np.hypot(v[0], v[1])
    return out if len(v) == 2 else np.hypot(out, v[2])


class Diffusion(FluidEffect):
    """Implicit viscosity ν (and diffusivities κ per scalar); no stage at all when every coefficient is 0."""

    phase = "diffuse"

    @contract(viscosity=Real(ge=0), method=Choice(DIFFUSION_METHODS), diffusivity=Opt(Named(Real(ge=0))),
              iterations=_SWEEPS, tol=_TOL)
    def __init__(self, viscosity: float = 0.0, method: str = "cg", *, diffusivity: dict | None = None,
                 iterations: int = 20, tol: float = 1e-12) -> None:
        super().__init__()
        self.viscosity = float(viscosity)
        self.diffusivity = {k: float(v) for k, v in (diffusivity or {}).items()}
        self.method, self.iterations, self.tol = method, int(iterations), float(tol)
        self.name = f"diffuse[{method}]"

    def stages(self) -> list:
        return [self] if self.viscosity > 0 or any(v > 0 for v in self.diffusivity.values()) else []

    @contract(grid=_GRID, state=_STATE)
    def bind(self, grid, state) -> None:
        for k in self.diffusivity:
            self._need_scalar(state, k, self.name)
        # refuse fft on a box it cannot solve now, not at the first step
        if self.viscosity > 0 and self.method == "fft" and (grid.has_obstacles or not all(grid.periodic)):
            raise InvalidInput(f"{self.name}: method 'fft' needs a periodic box without obstacles (use 'cg')")

    @contract(grid=_GRID, state=_STATE, h=_H)
    def apply(self, grid, state, h):
        self.bind(grid, state)                 # the scalars named and the method's box, checked again
        kw = dict(iterations=self.iterations, tol=self.tol)
        if self.viscosity > 0:
            state.u, infos = diffuse_velocity(grid, state.u, self.viscosity, h, self.method, **kw)
            self.info = {"diffusion_residual": max(i.residual for i in infos)}
        method = "spectral" if self.method == "fft" else self.method
        for k, kappa in self.diffusivity.items():
            if kappa > 0:
                state.scalars[k], _ = diffuse_scalar(grid, state.scalars[k], kappa, h, method, **kw)


class Advection(FluidEffect):
    """Carries the velocity (``velocity=True``) and the scalars (``fields``: names; None = all) along u,
    tracing back by Stam's Euler step or the ``"midpoint"`` rule."""

    phase = "advect"

    @contract(method=Choice(ADVECTION), fields=Opt(Seq(_NAME)), velocity=Flag(), backtrace=Choice(BACKTRACES))
    def __init__(self, method: str = "semi_lagrangian", fields=None, velocity: bool = True,
                 backtrace: str = "euler") -> None:
        super().__init__()
        self.method, self.velocity, self.backtrace = method, bool(velocity), backtrace
        self.lean_path = True            # False: each scalar by advect_scalar, its departures traced again (E28)
        self.fields = None if fields is None else list(fields)
        self.name = f"advect[{method}]" if backtrace == "euler" else f"advect[{method}, {backtrace}]"

    @contract(grid=_GRID, state=_STATE)
    def bind(self, grid, state) -> None:
        self.names = list(state.scalars) if self.fields is None else list(self.fields)
        for k in self.names:
            self._need_scalar(state, k, self.name)

    @contract(grid=_GRID, state=_STATE, h=_H)
    def apply(self, grid, state, h):
        u = state.u
        for k in self._bound(grid, "names"):
            self._need_scalar(state, k, self.name)
        if self.lean_path and len(set(self.names)) == len(self.names):   # departures traced once for all names
            fields = _advect_scalars(grid, [state.scalars[k] for k in self.names], u, h, self.method, self.backtrace)
            state.scalars.update(zip(self.names, fields))
        else:
            for k in self.names:
                state.scalars[k] = advect_scalar(grid, state.scalars[k], u, h, self.method, self.backtrace)
        if self.velocity:
            state.u = advect_velocity(grid, u, h, self.method, self.backtrace)


class Projection(FluidEffect):
    """u ← u − G p with (−L) p = −D u: the divergence left is the solve's residual (``info``)."""

    phase = "project"

    @contract(method=Choice(POISSON_METHODS), iterations=_SWEEPS, omega=Real(gt=0, le=1), tol=_TOL,
              max_iter=Opt(Int(ge=1, le=MAX_ITER)), measure=Flag())
    def __init__(self, method: str = "dct", *, iterations: int = 20, omega: float = 1.0, tol: float = 1e-12,
                 max_iter: int | None = None, measure: bool = True) -> None:
        super().__init__()
        self.method = method
        self.kw = dict(iterations=int(iterations), omega=float(omega), tol=float(tol),
                       max_iter=None if max_iter is None else int(max_iter))
        self.measure = bool(measure)   # False: skip ‖r − A p‖∞ (one operator application; the bench's step)
        self.name = f"project[{method}]"
        self.pressure = None

    @contract(grid=_GRID, state=_STATE)
    def bind(self, grid, state) -> None:
        check_method_fits(grid, self.method, self.name)  # fail at build time, not at the first step

    @contract(grid=_GRID, state=_STATE, h=_H)
    def apply(self, grid, state, h):
        check_method_fits(grid, self.method, self.name)
        r = grid.divergence(state.u)
        r *= -1.0
        p, info = _solve(grid, r, np.zeros(grid.shape), 0.0, 1.0, self.method, residual=self.measure, **self.kw)
        for c, g in zip(state.u, grid.gradient(p)):
            c -= g
        self.pressure = p
        self.info = {"projection_iterations": info.iterations, "projection_residual": info.residual}
