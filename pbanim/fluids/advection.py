"""Advection (chapter 09): Stam's semi-Lagrangian step and its higher-order corrections.

The transport part of the lecture's equations, ∂q/∂t + (u·∇)q = 0 for a scalar or for each velocity
component, says q is constant along the path of a fluid particle. Stam's semi-Lagrangian step traces the
path backwards from every sample point x over one step Δt and reads the old field there:

    q¹(x) = A(q⁰; u)(x) = q⁰(x − Δt u(x))           (interpolated: linear, or monotone cubic)

It is unconditionally stable — a new value is an interpolation of old ones, so max |q| never grows, at any
CFL number C = Δt |u| / Δx — and it smears: each step costs O(Δx²) in amplitude, first order overall at a
fixed C. Two corrections estimate that error by going back and forth, with Aᴿ the step with −u:

    BFECC (Kim, Liu, Llamas, Rossignac 2005):  q̃ = q⁰ + ½ (q⁰ − Aᴿ(A(q⁰))),   q¹ = A(q̃)
    MacCormack (Selle et al. 2008):            q̂ = A(q⁰),   q¹ = q̂ + ½ (q⁰ − Aᴿ(q̂))

The backtrace itself is Stam's Euler step x − Δt u(x) or the midpoint rule x − Δt u(x − ½Δt u(x)). In a
solid rotation of rate ω the Euler step lands on the circle of radius r√(1 + (ωΔt)²): every step spreads
the field by that factor and multiplies its mass by 1/(1 + (ωΔt)²); the midpoint step's factor is
1/(1 + (ωΔt)⁴/4) (ORACLES E14).

Both corrections are second order where the field is smooth; neither is monotone, so the limited variants
clamp q¹ to the [min, max] of the 2^d old values around the departure point (MacCormack reverts to q̂ there).

==========  =====================================================================
symbol      meaning
==========  =====================================================================
q           an advected quantity: a scalar at cells or a velocity component on faces
A, Aᴿ       one semi-Lagrangian step with u, with −u
Δt, C       time step (``h``), CFL number Δt max|u| / Δx
==========  =====================================================================

Limiting cases: u = 0 gives q¹ = q⁰; a uniform u with Δt u a whole number of cells gives the shifted
field exactly, whatever the interpolation (ORACLES E4); a linear q is reproduced exactly by every scheme.

References: J. Stam, Stable Fluids, SIGGRAPH 1999; B. Kim et al., FlowFixer: Using BFECC for Fluid
Simulation, NPH 2005; A. Selle, R. Fedkiw, B. Kim, Y. Liu, J. Rossignac, An Unconditionally Stable
MacCormack Method, J. Sci. Comput. 35 (2008).
"""

from __future__ import annotations

import math

import numpy as np

from ..contracts import Choice, Int, Obj, Real, contract
from ..errors import InvalidInput, NonFiniteResult
from .interpolate import _sample as sample
from .interpolate import _where
from .interpolate import component_at_faces, pad_field
from .specs import Cells, Velocity, finite_fields, quiet

BACKTRACES = ("euler", "midpoint")

__all__ = ["ADVECTION", "BACKTRACES", "advect_scalar", "advect_scalar_steps", "advect_velocity",
           "semi_lagrangian_loop"]

# name → (interpolation order, correction, limited)
ADVECTION = {
    "semi_lagrangian": ("linear", None, False),
    "cubic": ("cubic", None, False),
    "bfecc": ("linear", "bfecc", False),
    "maccormack": ("linear", "maccormack", True),
    "maccormack_unlimited": ("linear", "maccormack", False),
}

_GRID = Obj("pbanim.fluids.grid:Grid")
_H = Real(gt=0)
_METHOD = Choice(ADVECTION)
_BACKTRACE = Choice(BACKTRACES)


def _positions(grid, component):
    cache = grid.__dict__.setdefault("_positions_cache", {})
    if component not in cache:
        cache[component] = grid.positions(component)
    return cache[component]


def _velocity_at(grid, u, pads, component):
    """The velocity at the sample points of ``component`` (None: the cells): its own component exactly,
    the others interpolated linearly (at cells: the mean of the two faces)."""
    if component is None:
        return grid.faces_to_cells(u)
    return [u[i] if i == component else component_at_faces(grid, pads[i], i, component) for i in range(grid.dim)]


def _trace(grid, X, vel, h, pads, backtrace):
    """Departure points of X over a step h (h < 0: the reverse step): Euler X − h u(X), or the midpoint
    rule X − h u(X − ½h u(X))."""
    if backtrace == "euler":
        return [x - h * v for x, v in zip(X, vel)]
    mid = [x - 0.5 * h * v for x, v in zip(X, vel)]
    vm = [sample(grid, None, i, mid, "linear", padded=pads[i]) for i in range(grid.dim)]
    return [x - h * v for x, v in zip(X, vm)]


def _departures(grid, component, X, vel, h, pads, backtrace, both):
    """The sample coordinates (:func:`~.interpolate._where`) of the departure points of X over h, and over −h
    when ``both`` (the corrections' reverse step; else None)."""
    def where(step):
        return _where(grid, component, _trace(grid, X, vel, step, pads, backtrace))
    return where(h), (where(-h) if both else None)


def _one(grid, q, component, X, vel, h, method, pads, padded=None, backtrace="euler", at=None):
    """One quantity advected by ``method`` given its sample points X and the velocity there (``at``: their
    :func:`_departures`, computed before; then X and vel are not read)."""
    order, correction, limited = ADVECTION[method]
    fwd, bwd = _departures(grid, component, X, vel, h, pads, backtrace, correction is not None) if at is None else at
    if correction is None:
        return sample(grid, q, component, None, order, padded=padded, at=fwd)
    q1, lo, hi = sample(grid, q, component, None, order, bounds=True, at=fwd)
    back = sample(grid, q1, component, None, order, at=bwd)
    if correction == "bfecc":
        corrected = q + 0.5 * (q - back)
        out = sample(grid, corrected, component, None, order, at=fwd)
        return np.clip(out, lo, hi) if limited else out
    out = q1 + 0.5 * (q - back)
    if limited:
        out = np.where((out < lo) | (out > hi), q1, out)
    return out


@contract(grid=_GRID, u=Velocity(), h=_H, method=_METHOD, backtrace=_BACKTRACE, returns=finite_fields)
@quiet
def advect_velocity(grid, u: list, h: float, method: str = "semi_lagrangian", backtrace: str = "euler") -> list:
    """Every velocity component carried by u itself over one step ``h``: a new list of face arrays.

    A departure point whose coordinate overflows (Δt |u| near 10³⁰⁸ on a periodic axis) is
    :class:`~pbanim.errors.NonFiniteResult`."""
    pads = [pad_field(grid, c, i) for i, c in enumerate(u)]
    out = []
    for i in range(grid.dim):
        X = _positions(grid, i)
        out.append(_one(grid, u[i], i, X, _velocity_at(grid, u, pads, i), h, method, pads, pads[i], backtrace))
    return grid.close(out)


@contract(grid=_GRID, s=Cells(), u=Velocity(), h=_H, method=_METHOD, backtrace=_BACKTRACE, returns=finite_fields)
@quiet
def advect_scalar(grid, s: np.ndarray, u: list, h: float, method: str = "semi_lagrangian",
                  backtrace: str = "euler") -> np.ndarray:
    """A cell-centred scalar carried by u over one step ``h`` (0 inside obstacles)."""
    return _carried(grid, s, h, method, backtrace, *_scalar_departures(grid, u, h, method, backtrace))


def _scalar_departures(grid, u: list, h: float, method: str, backtrace: str) -> tuple:
    """(the velocity's padded components or None, :func:`_departures` of the cell centres over h): what
    carrying any cell-centred scalar by u over h reads of u, computed once for as many scalars as share it."""
    X = _positions(grid, None)
    pads = [pad_field(grid, c, i) for i, c in enumerate(u)] if backtrace != "euler" else None
    return pads, _departures(grid, None, X, grid.faces_to_cells(u), h, pads, backtrace,
                             ADVECTION[method][1] is not None)


def _carried(grid, s: np.ndarray, h: float, method: str, backtrace: str, pads, at) -> np.ndarray:
    """The scalar s advected from its departure points ``at`` (:func:`_scalar_departures`), 0 inside obstacles."""
    out = _one(grid, s, None, None, None, h, method, pads, backtrace=backtrace, at=at)
    if grid.has_obstacles:
        out[grid.solid] = 0.0
    return out


def _advect_scalars(grid, fields: list, u: list, h: float, method: str, backtrace: str) -> list:
    """``[advect_scalar(grid, s, u, h, method, backtrace) for s in fields]`` (the same numbers) with the departure
    points and their sample coordinates traced once for all the fields (the scene's density and temperature)."""
    pads, at = _scalar_departures(grid, u, h, method, backtrace)
    return [_carried(grid, s, h, method, backtrace, pads, at) for s in fields]


@contract(grid=_GRID, s=Cells(), u=Velocity(), h=_H, steps=Int(ge=0, le=10_000), method=_METHOD,
          returns=finite_fields)
@quiet
def advect_scalar_steps(grid, s: np.ndarray, u: list, h: float, steps: int,
                        method: str = "semi_lagrangian") -> np.ndarray:
    """``steps`` steps of ``advect_scalar(grid, s, u, h, method)`` in a row under the same velocity u: its
    departure points (Euler backtrace) and their sample coordinates computed once, not every step; the same
    numbers as the steps one by one (ORACLES E27)."""
    pads, at = _scalar_departures(grid, u, h, method, "euler")
    for _ in range(steps):
        s = _carried(grid, s, h, method, "euler", pads, at)
    return s


@contract(grid=_GRID, s=Cells(), u=Velocity(), h=_H, returns=finite_fields)
@quiet
def semi_lagrangian_loop(grid, s: np.ndarray, u: list, h: float) -> np.ndarray:
    """The readable version of Stam's step for a 2-D cell scalar: one cell at a time, bilinear by hand.

    Equal to ``advect_scalar(grid, s, u, h)`` to roundoff (tests/test_fluids_advection.py). Slow: for
    teaching and for that test only.
    """
    if grid.dim != 2:
        raise InvalidInput(f"semi_lagrangian_loop: grid must be 2-D (the teaching version), got {grid.dim} axes")
    (nx, ny), dx = grid.shape, grid.dx
    uc, vc = grid.faces_to_cells(u)
    out = np.zeros_like(s)

    def value(i, j):                     # the field at cell (i, j), with the walls' even reflection
        if grid.periodic[0]:
            i %= nx
        else:
            i = -1 - i if i < 0 else (2 * nx - 1 - i if i >= nx else i)
        if grid.periodic[1]:
            j %= ny
        else:
            j = -1 - j if j < 0 else (2 * ny - 1 - j if j >= ny else j)
        return s[i, j]

    for i in range(nx):
        for j in range(ny):
            x = (i + 0.5) * dx - h * uc[i, j]          # the departure point
            y = (j + 0.5) * dx - h * vc[i, j]
            if not grid.periodic[0]:
                x = min(max(x, 0.0), nx * dx)
            if not grid.periodic[1]:
                y = min(max(y, 0.0), ny * dx)
            sx, sy = x / dx - 0.5, y / dx - 0.5         # sample coordinates
            if not (math.isfinite(sx) and math.isfinite(sy)):
                raise NonFiniteResult(f"the departure point of cell ({i}, {j})", f"x/Δx = {sx:g}, y/Δx = {sy:g}")
            i0, j0 = math.floor(sx), math.floor(sy)
            tx, ty = sx - i0, sy - j0
            out[i, j] = ((1 - tx) * (1 - ty) * value(i0, j0) + tx * (1 - ty) * value(i0 + 1, j0)
                         + (1 - tx) * ty * value(i0, j0 + 1) + tx * ty * value(i0 + 1, j0 + 1))
    if grid.has_obstacles:
        out[grid.solid] = 0.0
    return out
