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

from ..errors import InvalidInput, as_floats, check_count, check_number
from .advection import _check_backtrace, advect_scalar, advect_velocity, check_method
from .diffusion import DIFFUSION_METHODS, diffuse_scalar, diffuse_velocity
from .poisson import POISSON_METHODS, _solve, check_method_fits

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


class FluidEffect:
    """A stage of the fluid step: ``bind(grid, state)`` validates once, ``apply(grid, state, h)`` updates
    ``state`` (``state.u`` face arrays, ``state.scalars``); ``info`` holds what the last call measured."""

    name = "effect"
    phase = "force"

    def __init__(self) -> None:
        self.info: dict = {}

    def bind(self, grid, state) -> None:
        """Validate against the grid and the state; called once by the scene."""

    def stages(self) -> list:
        return [self]

    def apply(self, grid, state, h: float) -> None:  # pragma: no cover - interface
        raise NotImplementedError

    def _need_scalar(self, state, name: str, who: str) -> None:
        if name not in state.scalars:
            raise InvalidInput(f"{who} needs the scalar {name!r}; the scene has {sorted(state.scalars)}")


def _cell_mask(grid, region, name: str) -> np.ndarray:
    arr = as_floats(name, region)
    if arr.shape != grid.shape or not np.all(np.isfinite(arr)):
        raise InvalidInput(f"{name} must be a finite array of the cell shape {grid.shape}, got shape {arr.shape}")
    return arr * grid.fluid


class Source(FluidEffect):
    """s ← s + Δt · rate · region for the scalar ``field`` (region: a 0/1 or weight array over the cells)."""

    phase = "force"

    def __init__(self, field: str, rate: float, region) -> None:
        super().__init__()
        self.field, self.rate, self.region = field, check_number("rate", rate), region
        self.name = f"source[{field}]"

    def bind(self, grid, state) -> None:
        self._need_scalar(state, self.field, self.name)
        self.weights = _cell_mask(grid, self.region, "region")

    def apply(self, grid, state, h):
        state.scalars[self.field] += (h * self.rate) * self.weights


class Force(FluidEffect):
    """u ← u + Δt f: ``f`` a constant vector (d numbers), optionally only inside ``region`` (cells)."""

    phase = "force"
    name = "force"

    def __init__(self, f, region=None) -> None:
        super().__init__()
        self.f, self.region = as_floats("f", f, ndmin=1), region

    def bind(self, grid, state) -> None:
        if self.f.shape != (grid.dim,) or not np.all(np.isfinite(self.f)):
            raise InvalidInput(f"f must be {grid.dim} finite numbers, got {self.f}")
        w = np.ones(grid.shape) if self.region is None else _cell_mask(grid, self.region, "region")
        self.weights = [grid.cells_to_faces(w, i) * grid.open[i] for i in range(grid.dim)]

    def apply(self, grid, state, h):
        for i in range(grid.dim):
            if self.f[i] != 0:
                state.u[i] += (h * self.f[i]) * self.weights[i]


class Buoyancy(FluidEffect):
    """f = (−α s + β (T − T_amb)) along ``axis`` (default 1, y up); T is optional."""

    phase = "force"
    name = "buoyancy"

    def __init__(self, alpha: float = 0.0, beta: float = 1.0, ambient: float = 0.0, density: str = "density",
                 temperature: str | None = "temperature", axis: int = 1) -> None:
        super().__init__()
        self.alpha = check_number("alpha", alpha, low=0.0)
        self.beta = check_number("beta", beta, low=0.0)
        self.ambient = check_number("ambient", ambient)
        self.density, self.temperature = density, temperature
        self.axis = check_count("axis", axis, minimum=0, maximum=2)

    def bind(self, grid, state) -> None:
        if self.axis >= grid.dim:
            raise InvalidInput(f"axis must be below the grid dimension {grid.dim}, got {self.axis}")
        self._need_scalar(state, self.density, self.name)
        if self.temperature is not None:
            self._need_scalar(state, self.temperature, self.name)

    def apply(self, grid, state, h):
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

    def __init__(self, epsilon: float) -> None:
        super().__init__()
        self.epsilon = check_number("epsilon", epsilon, low=0.0)

    def apply(self, grid, state, h):
        f, _ = confinement_force(grid, state.u, self.epsilon)
        for i in range(grid.dim):
            state.u[i] += h * grid.cells_to_faces(f[i] * grid.fluid, i) * grid.open[i]


def confinement_force(grid, u: list, epsilon: float):
    """(f, N) at the cells: f = ε Δx (N × ω), N = ∇|ω| / |∇|ω|| (0 where |ω| is flat)."""
    w = vorticity(grid, u)
    mag = np.abs(w) if grid.dim == 2 else np.sqrt(sum(c * c for c in w))
    eta = [_ddx(grid, mag, a) for a in range(grid.dim)]
    norm = np.sqrt(sum(e * e for e in eta)) + 1e-12 * (float(mag.max()) + 1e-300) / grid.dx
    N = [e / norm for e in eta]
    s = epsilon * grid.dx
    if grid.dim == 2:
        return [s * N[1] * w, -s * N[0] * w], N
    return [s * (N[1] * w[2] - N[2] * w[1]), s * (N[2] * w[0] - N[0] * w[2]),
            s * (N[0] * w[1] - N[1] * w[0])], N


class Diffusion(FluidEffect):
    """Implicit viscosity ν (and diffusivities κ per scalar); no stage at all when every coefficient is 0."""

    phase = "diffuse"

    def __init__(self, viscosity: float = 0.0, method: str = "cg", *, diffusivity: dict | None = None,
                 iterations: int = 20, tol: float = 1e-12) -> None:
        super().__init__()
        self.viscosity = check_number("viscosity", viscosity, low=0.0)
        self.diffusivity = {k: check_number(f"diffusivity[{k!r}]", v, low=0.0) for k, v in (diffusivity or {}).items()}
        if method not in DIFFUSION_METHODS:
            raise InvalidInput(f"diffusion method must be one of {DIFFUSION_METHODS}, got {method!r}")
        self.method, self.iterations = method, check_count("iterations", iterations, minimum=0)
        self.tol = check_number("tol", tol, low=0.0, high=1.0, low_open=True)
        self.name = f"diffuse[{method}]"

    def stages(self) -> list:
        return [self] if self.viscosity > 0 or any(v > 0 for v in self.diffusivity.values()) else []

    def bind(self, grid, state) -> None:
        for k in self.diffusivity:
            self._need_scalar(state, k, self.name)
        # refuse fft on a box it cannot solve now, not at the first step
        if self.viscosity > 0 and self.method == "fft" and (grid.has_obstacles or not all(grid.periodic)):
            raise InvalidInput("diffusion method 'fft' needs a periodic box without obstacles (use 'cg')")

    def apply(self, grid, state, h):
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

    def __init__(self, method: str = "semi_lagrangian", fields=None, velocity: bool = True,
                 backtrace: str = "euler") -> None:
        super().__init__()
        check_method(method)
        _check_backtrace(backtrace)
        self.method, self.fields, self.velocity, self.backtrace = method, fields, bool(velocity), backtrace
        self.name = f"advect[{method}]" if backtrace == "euler" else f"advect[{method}, {backtrace}]"

    def bind(self, grid, state) -> None:
        self.names = list(state.scalars) if self.fields is None else list(self.fields)
        for k in self.names:
            self._need_scalar(state, k, self.name)

    def apply(self, grid, state, h):
        u = state.u
        for k in self.names:
            state.scalars[k] = advect_scalar(grid, state.scalars[k], u, h, self.method, self.backtrace)
        if self.velocity:
            state.u = advect_velocity(grid, u, h, self.method, self.backtrace)


class Projection(FluidEffect):
    """u ← u − G p with (−L) p = −D u: the divergence left is the solve's residual (``info``)."""

    phase = "project"

    def __init__(self, method: str = "dct", *, iterations: int = 20, omega: float = 1.0, tol: float = 1e-12,
                 max_iter: int | None = None, measure: bool = True) -> None:
        super().__init__()
        if method not in POISSON_METHODS:
            raise InvalidInput(f"projection method must be one of {POISSON_METHODS}, got {method!r}")
        self.method = method
        self.kw = dict(iterations=check_count("iterations", iterations, minimum=0),
                       omega=check_number("omega", omega, low=0.0, high=1.0, low_open=True),
                       tol=check_number("tol", tol, low=0.0, high=1.0, low_open=True),
                       max_iter=None if max_iter is None else check_count("max_iter", max_iter))
        self.measure = bool(measure)   # False: skip ‖r − A p‖∞ (one operator application; the bench's step)
        self.name = f"project[{method}]"
        self.pressure = None

    def bind(self, grid, state) -> None:
        check_method_fits(grid, self.method)             # fail at build time, not at the first step

    def apply(self, grid, state, h):
        r = grid.divergence(state.u)
        r *= -1.0
        p, info = _solve(grid, r, np.zeros(grid.shape), 0.0, 1.0, self.method, residual=self.measure, **self.kw)
        for c, g in zip(state.u, grid.gradient(p)):
            c -= g
        self.pressure = p
        self.info = {"projection_iterations": info.iterations, "projection_residual": info.residual}
