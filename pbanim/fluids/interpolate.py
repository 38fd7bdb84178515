"""Sampling a grid field anywhere (chapter 09): linear and monotone cubic interpolation with ghost cells.

Semi-Lagrangian advection asks "what value sat at the departure point x − Δt u?", a point between
samples. A field q stored at the points (j + o) Δx (o = ½ for cells, 0 along its own axis for a velocity
component) is read at x through the sample coordinate s = x/Δx − o, split as s = j + t with t ∈ [0, 1):

    linear (Stam):   q(x) = Σ over the 2^d corners  Πₐ wₐ · q_corner,   wₐ ∈ {1 − tₐ, tₐ}
    monotone cubic:  along each axis, the Hermite cubic through q₀, q₁ with slopes
                     m₀ = (q₁ − q₋₁)/2, m₁ = (q₂ − q₀)/2, set to 0 where their sign differs from
                     Δ = q₁ − q₀ and clipped to |m| ≤ 3|Δ| (Fritsch–Carlson): it never overshoots [q₀, q₁]

Linear interpolation is a convex combination: it never creates a new extremum, and it smears (its error
per step is O(Δx²), so O(Δx) after the T/Δt = O(1/Δx) steps of a fixed CFL number). The cubic is O(Δx⁴)
per step where it is smooth and bounded by the same corners as the linear one.

Points outside the box: periodic axes wrap; at walls the point is clipped to the wall and ghost samples
carry the boundary condition — even reflection for scalars (no flux), odd reflection about the wall face
for the normal velocity component (u·n = 0), and 2w − q for a tangential component whose wall slides at
w (no slip; w = 0 on a still wall).

==========  ================================================================
symbol      meaning
==========  ================================================================
s, j, t     sample coordinate, its integer part, its fraction (per axis)
o           offset of the samples inside a cell (``Grid.offset``)
w           tangential velocity of a wall (``Grid.lids``; 0 otherwise)
==========  ================================================================

References: J. Stam, Stable Fluids (1999); R. Fedkiw, J. Stam, H. W. Jensen, Visual Simulation of Smoke,
SIGGRAPH 2001 (the monotone cubic); F. N. Fritsch, R. E. Carlson, SIAM J. Numer. Anal. 17 (1980).
"""

from __future__ import annotations

import itertools
import math

import numpy as np

from ..contracts import Choice, Flag, Int, Obj, Opt, contract
from ..errors import InvalidInput, NonFiniteResult
from .specs import Cells, Points, finite_fields, quiet

__all__ = ["ORDERS", "component_at_faces", "monotone_cubic_1d", "pad_field", "sample"]

ORDERS = ("linear", "cubic")
GHOSTS = 2


def _pad(q: np.ndarray, pad, mode: str) -> np.ndarray:
    """``np.pad(q, pad, mode)`` for one axis padded by g on both sides in mode "wrap", "reflect" or "symmetric":
    the same copies by slices, without np.pad's general machinery (np.pad itself when the axis has ≤ g + 1
    entries, where its reflections repeat)."""
    a = next(i for i, p in enumerate(pad) if p != (0, 0))
    g, n = pad[a][0], q.shape[a]
    if n <= g + 1:
        return np.pad(q, pad, mode=mode)
    shape = list(q.shape)
    shape[a] += 2 * g
    out = np.empty(shape)

    def at(x, lo, hi, step=1):
        return x[(slice(None),) * a + (slice(lo, hi, step),)]

    at(out, g, g + n)[...] = q
    if mode == "wrap":
        at(out, 0, g)[...], at(out, g + n, None)[...] = at(q, n - g, None), at(q, 0, g)
    elif mode == "reflect":                          # the edge entry not repeated: q[g], …, q[1] | q | q[n−2], …
        at(out, 0, g)[...], at(out, g + n, None)[...] = at(q, g, 0, -1), at(q, n - 2, n - g - 2, -1)
    else:                                            # symmetric: q[g−1], …, q[0] | q | q[n−1], …, q[n−g]
        at(out, 0, g)[...], at(out, g + n, None)[...] = at(q, g - 1, None, -1), at(q, n - 1, n - g - 1, -1)
    return out


def pad_field(grid, q: np.ndarray, component: int | None) -> np.ndarray:
    """``q`` with two ghost layers on every side that carry the boundary condition (see the module)."""
    g = GHOSTS
    out = q
    for a in range(grid.dim):
        pad = [(0, 0)] * grid.dim
        pad[a] = (g, g)
        if grid.periodic[a]:
            out = _pad(out, pad, "wrap")
            continue
        if component == a:                            # normal component: odd about the wall face (u = 0 there)
            out = _pad(out, pad, "reflect")
            lo = [slice(None)] * grid.dim
            lo[a] = slice(0, g)
            hi = [slice(None)] * grid.dim
            hi[a] = slice(-g, None)
            out[tuple(lo)] *= -1.0
            out[tuple(hi)] *= -1.0
            continue
        out = _pad(out, pad, "symmetric")            # scalar: no flux; tangential: mirrored then 2w − q
        if component is None:
            continue
        for side, sl in ((0, slice(0, g)), (1, slice(-g, None))):
            idx = [slice(None)] * grid.dim
            idx[a] = sl
            w = grid.lids.get((a, side))
            wall = 0.0 if w is None else float(w[component])
            out[tuple(idx)] = 2.0 * wall - out[tuple(idx)]
    return out


def monotone_cubic_1d(qm, q0, q1, q2, t):
    """The Fritsch–Carlson-limited Hermite cubic through q₀ (t = 0) and q₁ (t = 1), elementwise."""
    delta = q1 - q0
    m0 = 0.5 * (q1 - qm)
    m1 = 0.5 * (q2 - q0)
    lim = 3.0 * np.abs(delta)
    m0 = np.where(m0 * delta > 0, np.clip(m0, -lim, lim), 0.0)
    m1 = np.where(m1 * delta > 0, np.clip(m1, -lim, lim), 0.0)
    a3 = m0 + m1 - 2.0 * delta
    a2 = 3.0 * delta - 2.0 * m0 - m1
    return ((a3 * t + a2) * t + m0) * t + q0


def _coordinates(grid, shape, component, points):
    """Integer part (padded index) and fraction of the sample coordinate of each point, per axis."""
    off = grid.offset(component)
    inv = 1.0 / grid.dx
    idx, frac = [], []
    for a in range(grid.dim):
        x = np.asarray(points[a], dtype=float).ravel()
        if grid.periodic[a]:
            s = np.multiply(x, inv)
            s -= off[a]
            np.mod(s, shape[a], out=s)
            s += GHOSTS
        else:
            s = np.clip(x, 0.0, grid.shape[a] * grid.dx)
            s *= inv
            s += GHOSTS - off[a]                      # ≥ 1.5 > 0: truncation is the floor
        if s.size and not math.isfinite(s.max()):     # x/Δx overflowed (mod(±inf) is NaN), or x is NaN
            raise NonFiniteResult(f"a sample coordinate x/Δx along axis {a}",
                                  f"a point at {_far(x)} with Δx = {grid.dx:g}")
        j = s.astype(np.intp)
        s -= j                                        # the fraction, in place
        if grid.periodic[a]:
            j[j >= shape[a] + GHOSTS] -= shape[a]     # s rounded up to n in floating point
        idx.append(j)
        frac.append(s)
    return idx, frac


def _far(x) -> str:
    """The farthest coordinate among ``x`` (for a message)."""
    with np.errstate(invalid="ignore"):
        return f"{x[np.argmax(np.abs(x))]:g}"


def _lerp(flat, base, strides, frac, offset, axis):
    """Multilinear interpolation over axes ≥ ``axis`` of the corner at flat offset ``offset``."""
    if axis == len(strides):
        return flat[offset:][base]
    a = _lerp(flat, base, strides, frac, offset, axis + 1)
    b = _lerp(flat, base, strides, frac, offset + strides[axis], axis + 1)
    b -= a
    b *= frac[axis]
    a += b
    return a


@contract(grid=Obj("pbanim.fluids.grid:Grid"), q=Cells(faces="component"), component=Opt(Int(ge=0, le=2)),
          points=Points(), order=Choice(ORDERS), padded=Opt(Cells(faces="component", pad=GHOSTS)), bounds=Flag(),
          returns=finite_fields)
@quiet
def sample(grid, q: np.ndarray, component: int | None, points, order: str = "linear",
           padded: np.ndarray | None = None, bounds: bool = False):
    """Values of the field ``q`` (cells when ``component`` is None, else velocity component i) at ``points``.

    ``points`` is a list of d coordinate arrays of one shape; the result has that shape. ``bounds=True``
    also returns the min and max of the 2^d linear-stencil corners of each point (MacCormack's clamp).
    ``padded`` may pass ``pad_field(grid, q, component)`` computed once for several calls (its inner part
    must be ``q``). A departure point so far away that its sample coordinate overflows on a periodic axis is
    :class:`~pbanim.errors.NonFiniteResult`.
    """
    if padded is not None and not np.array_equal(padded[(slice(GHOSTS, -GHOSTS),) * grid.dim], q):
        raise InvalidInput("sample: padded must be pad_field(grid, q, component) (its inner part is q), got "
                           "another field")
    return _sample(grid, q, component, points, order, padded, bounds)


def _where(grid, component, points):
    """(shape of the points, padded indices, fractions) of ``points`` for :func:`_sample`'s ``at``: what it
    computes from them, once for several fields sampled at the same points."""
    return (np.shape(points[0]),
            *_coordinates(grid, grid.shape if component is None else grid.face_shape(component), component, points))


def _sample(grid, q, component, points, order="linear", padded=None, bounds=False, at=None):
    """:func:`sample` without the checks (the advection's inner loop); ``at``: ``_where(grid, component,
    points)`` computed before (then ``points`` is not read)."""
    out_shape, idx, frac = _where(grid, component, points) if at is None else at
    P = pad_field(grid, q, component) if padded is None else padded
    flat = P.ravel()
    strides = [int(np.prod(P.shape[a + 1:])) for a in range(grid.dim)]
    base = sum(j * st for j, st in zip(idx, strides))
    if order == "linear" and not bounds:               # in place, corner pair by corner pair: least memory
        val = _lerp(flat, base, strides, frac, 0, 0)
        return val.reshape(out_shape)
    shifts = (0, 1) if order == "linear" else (-1, 0, 1, 2)
    vals = np.empty((len(shifts),) * grid.dim + base.shape)
    if shifts[0]:
        base += shifts[0] * sum(strides)              # the lowest corner (≥ 0 thanks to the ghosts)
    for corner in itertools.product(range(len(shifts)), repeat=grid.dim):
        vals[corner] = flat[sum(c * st for c, st in zip(corner, strides)):][base]   # shifted views, no index sums
    lo = hi = None
    if bounds:                                        # the 2^d corners of the linear stencil
        inner = vals if order == "linear" else vals[(slice(1, 3),) * grid.dim]
        flat_corners = inner.reshape(-1, base.size)
        lo, hi = flat_corners.min(axis=0), flat_corners.max(axis=0)
    for a in range(grid.dim):                         # reduce axis by axis (a tensor product of 1-D rules)
        if order == "linear":
            vals = vals[0] + frac[a] * (vals[1] - vals[0])
        else:
            vals = monotone_cubic_1d(vals[0], vals[1], vals[2], vals[3], frac[a])
    val = vals.reshape(out_shape)
    if bounds:
        return val, lo.reshape(out_shape), hi.reshape(out_shape)
    return val


def component_at_faces(grid, padded_j: np.ndarray, j: int, i: int) -> np.ndarray:
    """Velocity component j at the faces of component i ≠ j: the mean of its 2 × 2 nearest samples (what
    linear interpolation gives there), read from ``padded_j = pad_field(grid, u[j], j)``."""
    g = GHOSTS
    shape_i = grid.face_shape(i)
    total = 0.0
    for di, dj in itertools.product((0, 1), repeat=2):
        idx = []
        for a in range(grid.dim):
            m = shape_i[a]
            if a == i:        # i-face m sits between j-samples m − 1 and m
                start = g - 1 + di
            elif a == j:      # cell k sits between j-faces k and k + 1
                start = g + dj
            else:
                start = g
            idx.append(slice(start, start + m))
        total = total + padded_j[tuple(idx)]
    return 0.25 * total
