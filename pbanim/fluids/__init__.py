"""Fluids (chapter 09): Stam's Stable Fluids on a MAC grid, stage by declared stage.

The lecture's incompressible Navier–Stokes equations ∇·u = 0, ∂u/∂t = −(u·∇)u − ∇p/ρ + ν∇²u + f, solved
by operator splitting (forces → semi-Lagrangian advection → implicit diffusion → pressure projection),
each stage with its variants side by side behind one signature:

==================  ==========================================================================
module              what it holds
==================  ==========================================================================
``grid``            :class:`Grid` (periodic or wall axes, sliding lids, obstacle masks), D, G, L
``interpolate``     linear and monotone cubic sampling with the boundary conditions in ghost cells
``advection``       semi-Lagrangian (linear, cubic), BFECC, MacCormack; a readable loop version
``poisson``         (αI − βL)x = r: Gauss–Seidel, Jacobi, CG, PCG, multigrid, FFT/DCT, sparse LU
``multigrid``       V-cycles for those solves, alone or preconditioning CG (any obstacles)
``collocated``      Stam's cell-centred layout and its projection, for comparison with the MAC grid
``stam``            :class:`StamSolver`: Stam's collocated step (source → diffuse → advect → project)
``diffusion``       implicit viscosity for the face velocities and the scalars
``effects``         the declared stages: Source, Force, Buoyancy, VorticityConfinement, Diffusion,
                    Advection, Projection
``scene``           :class:`FluidScene`: the pipeline, ``step``, ``simulate`` with its diagnostics
``flows``           Taylor–Green, stream functions, the lid-driven cavity (Ghia's table), smoke
``specs``           what the arguments must be (grid shapes, fields of a grid, velocities, states) and the
                    certificate of the results (:func:`~pbanim.fluids.specs.finite_fields`)
==================  ==========================================================================

``import pbanim`` does not load this subpackage; scipy.fft and scipy.sparse load on first use.
"""

from __future__ import annotations

from .advection import ADVECTION, BACKTRACES, advect_scalar, advect_scalar_steps, advect_velocity, semi_lagrangian_loop
from .collocated import COLLOCATED_STENCILS, collocated_divergence, collocated_gradient, project_collocated
from .diffusion import DIFFUSION_METHODS, diffuse_scalar, diffuse_velocity
from .effects import (Advection, Buoyancy, Diffusion, FluidEffect, Force, Projection, Source, VorticityConfinement,
                      confinement_force, vorticity)
from .flows import (GHIA_RE100, centreline_u, lid_driven_cavity, smoke_plume, stream_velocity, taylor_green,
                    taylor_green_energy)
from .grid import BOUNDARIES, Grid
from .interpolate import sample
from .poisson import POISSON_METHODS, SolveInfo, solve_cells
from .scene import FluidResult, FluidScene, FluidState
from .stam import STAM_DIFFUSION, StamResult, StamSolver, advect_collocated

__all__ = ["Grid", "BOUNDARIES", "FluidScene", "FluidState", "FluidResult", "FluidEffect", "Source", "Force",
           "Buoyancy", "VorticityConfinement", "Diffusion", "Advection", "Projection", "vorticity",
           "confinement_force", "ADVECTION", "BACKTRACES", "advect_scalar", "advect_scalar_steps", "advect_velocity",
           "semi_lagrangian_loop", "DIFFUSION_METHODS", "diffuse_scalar", "diffuse_velocity", "POISSON_METHODS",
           "SolveInfo", "solve_cells", "sample", "COLLOCATED_STENCILS", "collocated_divergence",
           "collocated_gradient", "project_collocated", "GHIA_RE100", "centreline_u", "lid_driven_cavity",
           "smoke_plume", "stream_velocity", "taylor_green", "taylor_green_energy", "STAM_DIFFUSION", "StamResult",
           "StamSolver", "advect_collocated"]
