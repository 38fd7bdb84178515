"""Valid calls for pbanim.fluids (chapter 09): 8 × 8 grids, so that each entry's fuzz stays short."""

import numpy as np

from pbanim.fluids import (Advection, Buoyancy, Diffusion, FluidEffect, FluidScene, FluidState, Force, Grid,
                           Projection, Source, StamSolver, VorticityConfinement)

N = 8


def _walls():
    """The cavity: a closed 8 × 8 box whose top wall slides (the grid of most calls)."""
    return Grid((N, N), 1.0 / N, "walls", lids={"y+": (1.0, 0.0)})


def _periodic():
    return Grid((N, N), 1.0 / N, "periodic")


def _velocity(grid, seed=0):
    rng = np.random.default_rng(seed)
    return grid.close([0.5 * rng.standard_normal(grid.face_shape(i)) for i in range(grid.dim)])


def _blob(grid):
    x, y = grid.positions()
    return np.exp(-20.0 * ((x - 0.5) ** 2 + (y - 0.3) ** 2))


def _state():
    g = _walls()
    return FluidState(_velocity(g), {"density": _blob(g), "temperature": 0.5 * _blob(g), "s": np.ones(g.shape)})


def _bound(effect):
    """An effect bound to the default grid and state (as FluidScene binds it)."""
    effect.bind(_walls(), _state())
    return effect


def _scene():
    g = _walls()
    s = _state()
    effects = [Source("density", 1.0, _blob(g)), Buoyancy(), VorticityConfinement(0.5), Advection(),
               Diffusion(0.01, diffusivity={"density": 0.01}), Projection("dct")]
    return FluidScene(g, effects, u=s.u, scalars=s.scalars)


def _stam():
    g = _periodic()
    rng = np.random.default_rng(1)
    return StamSolver(g, [0.3 * rng.standard_normal(g.shape) for _ in range(2)], {"s": _blob(g)}, viscosity=0.01,
                      diffusivity={"s": 0.01}, sources={"s": _blob(g)},
                      forces=[np.zeros(g.shape), -np.ones(g.shape)])


INSTANCES = {
    Grid: _walls,
    FluidState: _state,
    FluidScene: _scene,
    StamSolver: _stam,
    FluidEffect: lambda: VorticityConfinement(0.5),
    Source: lambda: _bound(Source("density", 1.0, np.ones((N, N)))),
    Force: lambda: _bound(Force([0.0, -1.0])),
    Buoyancy: lambda: _bound(Buoyancy(alpha=0.1, beta=1.0)),
    VorticityConfinement: lambda: VorticityConfinement(0.5),
    Diffusion: lambda: Diffusion(0.01, diffusivity={"density": 0.01}),
    Advection: lambda: _bound(Advection("maccormack")),
    Projection: lambda: Projection("dct"),
}

_F = "pbanim.fluids."
CALLS = {
    # the shape, spacing and lid of the cavity (the contract's own lid example is not tangential to its wall)
    _F + "grid.Grid.__init__": lambda: {"shape": (N, N), "dx": 1.0 / N, "boundary": "walls",
                                        "lids": {"y+": [1.0, 0.0]}},
    _F + "grid.Grid.check_velocity": lambda g: {"u": _velocity(g)},
    # padded left out: one made up by its spec is not pad_field of q (refused, and tested as such)
    _F + "interpolate.sample": lambda: {"padded": None},
    _F + "flows.taylor_green": lambda: {"grid": _periodic()},
    _F + "flows.stream_velocity": lambda: {"psi": lambda x, y: np.sin(2 * np.pi * x) * np.sin(2 * np.pi * y)},
    _F + "stam.StamSolver.__init__": lambda: {"grid": _periodic()},
    _F + "scene.FluidScene.__init__": lambda: {"effects": [Advection(), Projection("dct")]},
    _F + "scene.FluidScene.simulate": lambda sc: {"t_end": 0.05, "h": 0.01, "max_steps": 50, "keep": ["density"],
                                                  "frame_every": 2},
    _F + "stam.StamSolver.simulate": lambda st: {"t_end": 0.05, "h": 0.01, "max_steps": 50},
}
for _cls in ("FluidEffect", "Source", "Force", "Buoyancy", "Diffusion", "Advection", "Projection"):
    CALLS[f"{_F}effects.{_cls}.bind"] = lambda e: {"state": _state()}
for _cls in ("Source", "Force", "Buoyancy", "VorticityConfinement", "Diffusion", "Advection", "Projection"):
    CALLS[f"{_F}effects.{_cls}.apply"] = lambda e: {"state": _state(), "h": 0.01}

_RECORD = "a result record that pbanim builds and the user only reads"
EXEMPT = {
    _F + "scene.FluidResult.__init__": _RECORD + " (FluidScene.simulate returns it)",
    _F + "stam.StamResult.__init__": _RECORD + " (StamSolver.simulate returns it)",
    _F + "poisson.SolveInfo.__init__": _RECORD + " (every solve of chapter 09 returns one)",
    _F + "effects.FluidEffect.apply": "an abstract hook of the stage protocol: the base raises NotImplementedError; "
                                      "every stage that implements it declares its own contract",
}
