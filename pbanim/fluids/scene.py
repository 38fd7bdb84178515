"""A fluid scene (chapter 09): a grid, a state and the declared stages of Stable Fluids.

:class:`FluidScene` is the fluid counterpart of :class:`pbanim.Scene`: built from a :class:`~.grid.Grid`,
the initial fields and a list of declared effects (:mod:`.effects`), it assembles ``scene.pipeline``,

    force effects (declaration order) → advect → diffuse → project

and one step runs those stages and nothing else: a scene without ``Diffusion`` (or with ν = 0) never
builds a diffusion operator, one without ``Projection`` is not incompressible. The state is the MAC
velocity (one face array per component) and named cell scalars (smoke ``density``, ``temperature``, ...).

``simulate(t_end, h)`` uses the one step rule of :func:`pbanim.ode.driver.step_grid` (N = ⌈t_end/h⌉,
the last step shortened, the ``max_steps`` cap checked before the first step) and after every step checks
that the state is finite, raising :class:`~pbanim.errors.SimulationDiverged` otherwise. It records per
step the kinetic energy E = ½ρ Σ u² Δx^d, the largest divergence ‖D u‖∞, the total of each scalar
∫ s dV, what each stage measured (e.g. the projection's residual) and the wall time of the step.

==========  ===========================================================
symbol      meaning
==========  ===========================================================
u           velocity on the faces (``state.u``)
s           cell scalars (``state.scalars``)
E           kinetic energy; never grows without forces (ORACLES E6)
‖D u‖∞      divergence left by the projection (ORACLES E2)
==========  ===========================================================

Limiting cases: an empty effect list leaves the state unchanged (E constant); a scene with only
``Projection`` makes u divergence-free in one step and then leaves it alone (Π² = Π).

References: J. Stam, Stable Fluids (1999) and Real-Time Fluid Dynamics for Games (2003) (``vel_step``,
``dens_step``); R. Bridson, Fluid Simulation for Computer Graphics (2015) ch. 2.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field

import numpy as np

from ..contracts import Array, Int, Obj, Opt, Real, Seq, Text, contract
from ..errors import InvalidInput, NonFiniteResult, SimulationDiverged
from ..ode.driver import MAX_STEPS, step_grid
from .effects import PHASES, FluidEffect
from .grid import Grid
from .specs import Cells, Named, Velocity

__all__ = ["FluidResult", "FluidScene", "FluidState", "check_fields"]


def check_fields(t: float, step: int, u: list, scalars: dict, detail: str = "") -> None:
    """:class:`~pbanim.errors.SimulationDiverged` naming the first velocity component or scalar that is not
    finite (nothing when all are)."""
    for i, c in enumerate(u):
        if not np.isfinite(c).all():
            raise SimulationDiverged(t, step, f"velocity component {i}", detail)
    for k, v in scalars.items():
        if not np.isfinite(v).all():
            raise SimulationDiverged(t, step, f"scalar {k!r}", detail)


@contract(u=Seq(Array(None), min_len=2, max_len=3), scalars=Named(Array(None)), t=Real())
@dataclass
class FluidState:
    """The velocity on the faces, the cell scalars, and the time."""

    u: list
    scalars: dict = field(default_factory=dict)
    t: float = 0.0

    def copy(self) -> FluidState:
        return FluidState([c.copy() for c in self.u], {k: v.copy() for k, v in self.scalars.items()}, self.t)


@dataclass
class FluidResult:
    """A run: recorded times and diagnostics, the kept frames of the scalars, the final state."""

    t: np.ndarray
    diagnostics: dict
    frames: dict
    frame_times: np.ndarray
    state: FluidState
    pipeline: tuple
    wall_time: float
    nsteps: int


class FluidScene:
    """A grid, its fields, and the declared effects of each step.

    Parameters
    ----------
    grid : Grid
    effects : sequence of FluidEffect
    u : list of face arrays, optional
        Initial velocity (zero when omitted); closed faces are set to 0.
    scalars : dict name → cell array, optional
        Initial scalars (0 inside obstacles).
    density : float > 0
        Fluid density ρ (only scales the kinetic energy; the pressure absorbs Δt/ρ).

    Examples
    --------
    >>> from pbanim.fluids import Grid, Advection, Diffusion, Projection
    >>> g = Grid((8, 8), 1 / 8, "periodic")
    >>> FluidScene(g, [Advection(), Diffusion(0.0), Projection("fft")]).pipeline
    ('advect[semi_lagrangian]', 'project[fft]')
    """

    @contract(grid=Obj(Grid), effects=Seq(Obj(FluidEffect)), u=Opt(Velocity()), scalars=Opt(Named(Cells())),
              density=Real(gt=0))
    def __init__(self, grid: Grid, effects=(), u=None, scalars=None, density: float = 1.0) -> None:
        self.grid = grid
        self.density = float(density)
        vel = grid.zeros_velocity() if u is None else [np.array(c, dtype=float) for c in u]
        sc = {k: np.array(v, dtype=float) * grid.fluid for k, v in (scalars or {}).items()}
        self.state = FluidState(grid.close(vel), sc, 0.0)
        stages = []
        for e in effects:
            stages += e.stages()
        for e in stages:
            if e.phase not in PHASES:      # a user's own FluidEffect subclass
                raise InvalidInput(f"FluidScene: effect {e.name!r} has phase {e.phase!r}; expected one of {PHASES}")
            e.bind(grid, self.state)
        self.stages = [e for ph in PHASES for e in stages if e.phase == ph]
        self.nsteps = 0

    @property
    def pipeline(self) -> tuple:
        """Ordered names of the stages one step runs."""
        return tuple(e.name for e in self.stages)

    @contract(h=Real(gt=0))
    def step(self, h: float) -> FluidState:
        """One step of size ``h`` through the pipeline (in place); returns the state. A field that stops being
        finite, or an overflow inside a stage, is :class:`~pbanim.errors.SimulationDiverged`."""
        s = self.state
        with np.errstate(over="ignore", invalid="ignore"):      # an overflow is reported just below, by name
            for e in self.stages:
                try:
                    e.apply(self.grid, s, h)
                except NonFiniteResult as exc:        # the field that overflowed first, else what the stage met
                    check_fields(s.t, self.nsteps, s.u, s.scalars, f"before stage {e.name} ended")
                    raise SimulationDiverged(s.t, self.nsteps, exc.what, f"in stage {e.name}") from exc
        check_fields(s.t, self.nsteps, s.u, s.scalars)
        s.t += h
        self.nsteps += 1
        return s

    def measure(self) -> dict:
        """Kinetic energy, largest divergence, the scalars' totals (inf when they overflow), and the stages'
        last measurements."""
        g, s = self.grid, self.state
        with np.errstate(over="ignore", invalid="ignore"):
            div = g.divergence(s.u)
            out = {"kinetic_energy": g.kinetic_energy(s.u, self.density),
                   "max_divergence": float(np.abs(div[g.fluid]).max())}
            out.update({f"total_{k}": g.total(v) for k, v in s.scalars.items()})
        for e in self.stages:
            out.update(e.info)
        return out

    @contract(t_end=Real(), h=Real(gt=0), record_every=Int(ge=1), frame_every=Opt(Int(ge=1)),
              keep=Seq(Text(nonempty=True)), max_steps=Int(ge=1), max_energy=Real(ge=0, finite=False))
    def simulate(self, t_end: float, h: float, *, record_every: int = 1, frame_every: int | None = None,
                 keep=(), max_steps: int = MAX_STEPS, max_energy: float = np.inf) -> FluidResult:
        """Step from the current time to ``t_end`` with step ``h`` (the one step rule; at most ``max_steps``
        steps, :class:`~pbanim.errors.StepLimitExceeded` before the first one otherwise).

        ``keep`` names the fields stored every ``frame_every`` steps (scalars by name, ``"speed"`` for |u| at
        the cells); ``max_energy`` makes a run whose kinetic energy exceeds it raise ``SimulationDiverged``.
        """
        sg = step_grid(self.state.t, t_end, h, max_steps=max_steps, record_every=record_every)
        for k in keep:
            if k != "speed" and k not in self.state.scalars:
                raise InvalidInput(f"FluidScene.simulate: keep must name scalars among {sorted(self.state.scalars)} "
                                   f"or 'speed', got {k!r}")
        diag = {k: [v] for k, v in self.measure().items()}
        diag["step_time"] = [0.0]
        ts, frames, ftimes = [self.state.t], {k: [] for k in keep}, []

        def snap():
            for k in keep:
                frames[k].append(self._field(k))
            ftimes.append(self.state.t)

        if frame_every:
            snap()
        start = time.perf_counter()
        for k in range(sg.n_steps):
            t0 = time.perf_counter()
            self.step(sg.size(k))
            dt = time.perf_counter() - t0
            if k == sg.n_steps - 1:
                self.state.t = sg.t_end
            if (k + 1) % record_every == 0 or k == sg.n_steps - 1:
                m = self.measure()
                if not (m["kinetic_energy"] <= max_energy and np.isfinite(m["kinetic_energy"])):
                    finite = bool(np.isfinite(m["kinetic_energy"]))
                    raise SimulationDiverged(self.state.t, k, "kinetic energy",
                                             f"{m['kinetic_energy']:.3e} > max_energy {max_energy:.3e}",
                                             what="exceeds its bound" if finite else "is not finite")
                for name, v in m.items():
                    diag.setdefault(name, [np.nan] * len(ts)).append(v)   # a stage's first measurement
                diag["step_time"].append(dt)
                ts.append(self.state.t)
            if frame_every and ((k + 1) % frame_every == 0):
                snap()
        wall = time.perf_counter() - start
        out = {k: np.asarray(v, dtype=float) for k, v in diag.items()}
        return FluidResult(np.asarray(ts), out, {k: np.asarray(v) for k, v in frames.items()}, np.asarray(ftimes),
                           self.state, self.pipeline, wall, sg.n_steps)

    def _field(self, name: str) -> np.ndarray:
        if name == "speed":
            c = self.grid.faces_to_cells(self.state.u)
            return np.sqrt(sum(x * x for x in c))
        return self.state.scalars[name].copy()
