"""The fluid grid (chapter 09): cells, faces, and the discrete D, G and L = D G of the projection.

The lecture's incompressible Navier–Stokes equations,

    ∇·u = 0,        ∂u/∂t = −(u·∇)u − ∇p/ρ + ν∇²u + f,

are discretized on a box of n₀ × n₁ (× n₂) square cells of side Δx. Pressure p and the scalars (smoke
density ρ_s, temperature T) live at cell centres; the velocity lives on the staggered *MAC* grid: the
component uᵢ sits on the faces normal to axis i. With that layout the discrete divergence of a cell

    (D u)_c = Σᵢ (uᵢ(c + ½eᵢ) − uᵢ(c − ½eᵢ)) / Δx

and the gradient on a face, (G p)_f = (p(c + eᵢ) − p(c)) / Δx, are adjoint (D = −Gᵀ), and the pressure
operator L = D diag(open) G is the compact 5-point (7-point in 3-D) Laplacian with Neumann conditions at
walls and obstacles. Solving L p = D u* and setting u = u* − G p leaves D u = D u* − L p = 0: the
divergence left is exactly the residual of the Poisson solve (ORACLES E2). Stam's papers keep every
component at the cell centres (a collocated grid); there D and G are centred differences, D G is a wide
stencil that decouples odd and even cells, and a solve with the compact Laplacian leaves an O(Δx²)
divergence however exactly it is done — the MAC grid is the one on which the projection is a projection.

Boundaries, per axis: ``"periodic"`` (face 0 ≡ face n) or ``"walls"`` (solid walls: the n + 1 faces of
axis i include the two wall faces, held at u·n = 0). A wall may slide: ``lids={"y+": (1, 0)}`` gives the
top wall a tangential velocity (the moving lid of the cavity). Obstacles are a boolean mask of solid
cells; every face touching one is closed.

==========  =================================================================================
symbol      meaning
==========  =================================================================================
n, d        cells per axis (≥ 3 each), number of axes (2 or 3)
Δx          cell side (``dx``)
uᵢ          velocity component i on the faces normal to axis i; shape n with nᵢ + 1 along i at walls
open_f      1 on a face fluid can cross, 0 on wall faces and faces touching a solid cell
D, G, L     divergence (faces → cells), gradient (cells → faces), L = D open G (cells → cells)
==========  =================================================================================

Limiting cases: with no obstacle and all walls, L is diagonalized by the DCT-II (eigenvalues
Σᵢ (2 cos(π kᵢ/nᵢ) − 2)/Δx²); all periodic, by the FFT (Σᵢ (2 cos(2π kᵢ/nᵢ) − 2)/Δx²); constants are its
null space either way.

References: F. Harlow, J. Welch, Phys. Fluids 8 (1965) (the MAC grid); J. Stam, Stable Fluids, SIGGRAPH
1999; J. Stam, Real-Time Fluid Dynamics for Games, GDC 2003; R. Bridson, Fluid Simulation for Computer
Graphics, 2nd ed. (2015), ch. 2 and 5.
"""

from __future__ import annotations

import numpy as np

from ..errors import InvalidInput, as_floats, check_count, check_positive

__all__ = ["BOUNDARIES", "SIDES", "Grid", "check_field"]

BOUNDARIES = ("periodic", "walls")
SIDES = {f"{a}{s}": (i, k) for i, a in enumerate("xyz") for k, s in enumerate("-+")}


def check_field(name: str, value, shape: tuple) -> np.ndarray:
    """``value`` as a finite float array of ``shape`` (a copy), or :class:`InvalidInput` naming ``name``."""
    arr = as_floats(name, value)
    if arr.shape != tuple(shape):
        raise InvalidInput(f"{name} must have shape {tuple(shape)}, got {arr.shape}")
    if not np.all(np.isfinite(arr)):
        bad = np.argwhere(~np.isfinite(arr))[0]
        raise InvalidInput(f"{name} must be finite, got {arr[tuple(bad)]} at index {tuple(int(b) for b in bad)}")
    return arr


class Grid:
    """A box of square cells with periodic or wall boundaries, optional sliding walls and obstacles.

    Parameters
    ----------
    shape : sequence of 2 or 3 ints, each ≥ 3
        Cells per axis (axis 0 is x, axis 1 is y, axis 2 is z; arrays are indexed [x, y(, z)]).
    dx : float > 0
        Cell side Δx.
    boundary : "periodic" | "walls", or one of them per axis
    solid : bool array of ``shape``, optional
        Obstacle cells (stationary).
    lids : dict, optional
        ``{"y+": (U, 0)}``: the wall on that side slides with that (tangential) velocity.

    Examples
    --------
    >>> g = Grid((4, 3), dx=0.5, boundary="walls")
    >>> [f.shape for f in g.zeros_velocity()]
    [(5, 3), (4, 4)]
    >>> g.divergence(g.gradient(np.zeros((4, 3)))).shape
    (4, 3)
    """

    def __init__(self, shape, dx: float = 1.0, boundary="walls", solid=None, lids=None) -> None:
        if isinstance(shape, (int, np.integer)) or not hasattr(shape, "__len__"):
            raise InvalidInput(f"shape must be a sequence of 2 or 3 cell counts, got {shape!r}")
        if len(shape) not in (2, 3):
            raise InvalidInput(f"shape must have 2 or 3 entries (a 2-D or 3-D grid), got {len(shape)}: {tuple(shape)}")
        self.shape = tuple(check_count(f"shape[{i}]", n, minimum=3) for i, n in enumerate(shape))
        self.dim = len(self.shape)
        self.dx = check_positive("dx", dx)
        kinds = (boundary,) * self.dim if isinstance(boundary, str) else tuple(boundary)
        if len(kinds) != self.dim or any(k not in BOUNDARIES for k in kinds):
            raise InvalidInput(f"boundary must be one of {BOUNDARIES} or one per axis ({self.dim} entries), "
                               f"got {boundary!r}")
        self.boundary = kinds
        self.periodic = tuple(k == "periodic" for k in kinds)
        if solid is None:
            self.solid = np.zeros(self.shape, dtype=bool)
        else:
            s = np.asarray(solid)
            if s.shape != self.shape:
                raise InvalidInput(f"solid must be a mask of shape {self.shape} (one entry per cell), got {s.shape}")
            if s.dtype != bool and not np.all(np.isin(s, (0, 1))):
                raise InvalidInput("solid must be a boolean mask (True = obstacle cell), got values other than 0/1")
            self.solid = s.astype(bool)
            if self.solid.all():
                raise InvalidInput("solid covers every cell: no fluid is left")
        self.has_obstacles = bool(self.solid.any())
        self.fluid = ~self.solid
        self.lids = self._check_lids(lids)
        self.open = tuple(self._open_faces(i) for i in range(self.dim))

    # -- construction helpers ----------------------------------------------------------------------
    def _check_lids(self, lids) -> dict:
        out = {}
        for key, vel in dict(lids or {}).items():
            if key not in SIDES or SIDES[key][0] >= self.dim:
                raise InvalidInput(f"lids keys must be sides {[s for s, (a, _) in SIDES.items() if a < self.dim]}, "
                                   f"got {key!r}")
            axis, side = SIDES[key]
            if self.periodic[axis]:
                raise InvalidInput(f"lids[{key!r}]: axis {'xyz'[axis]} is periodic, it has no wall to slide")
            v = as_floats(f"lids[{key!r}]", vel)
            if v.shape != (self.dim,) or not np.all(np.isfinite(v)):
                raise InvalidInput(f"lids[{key!r}] must be {self.dim} finite numbers, got {vel!r}")
            if v[axis] != 0:
                raise InvalidInput(f"lids[{key!r}] must be tangential to the wall (component {axis} = 0), got {v}")
            out[(axis, side)] = v
        return out

    def face_shape(self, i: int) -> tuple:
        """Shape of the array of velocity component i (one more face along i at walls)."""
        return tuple(n + (0 if self.periodic[a] or a != i else 1) for a, n in enumerate(self.shape))

    def _open_faces(self, i: int) -> np.ndarray:
        f = self.fluid
        if self.periodic[i]:
            return (f & np.roll(f, 1, axis=i)).astype(float)
        out = np.zeros(self.face_shape(i))
        inner = [slice(None)] * self.dim
        inner[i] = slice(1, -1)
        lo = [slice(None)] * self.dim
        lo[i] = slice(None, -1)
        hi = [slice(None)] * self.dim
        hi[i] = slice(1, None)
        out[tuple(inner)] = f[tuple(lo)] & f[tuple(hi)]
        return out

    # -- fields ------------------------------------------------------------------------------------
    def zeros_velocity(self) -> list:
        return [np.zeros(self.face_shape(i)) for i in range(self.dim)]

    def zeros_cells(self) -> np.ndarray:
        return np.zeros(self.shape)

    def offset(self, component: int | None) -> np.ndarray:
        """Where samples sit inside a cell, in cells: ½ on every axis for cells, 0 along i for uᵢ."""
        o = np.full(self.dim, 0.5)
        if component is not None:
            o[component] = 0.0
        return o

    def positions(self, component: int | None = None) -> list:
        """Coordinates of the samples of uᵢ (``component = i``) or of the cells (None), one array per axis."""
        shape = self.shape if component is None else self.face_shape(component)
        o = self.offset(component)
        axes = [(np.arange(m) + o[a]) * self.dx for a, m in enumerate(shape)]
        return list(np.meshgrid(*axes, indexing="ij"))

    @property
    def extent(self) -> tuple:
        return tuple(n * self.dx for n in self.shape)

    def check_velocity(self, u, name: str = "u") -> list:
        """``u`` as a list of finite face arrays of the right shapes, or :class:`InvalidInput`."""
        if not isinstance(u, (list, tuple)) or len(u) != self.dim:
            raise InvalidInput(f"{name} must be a list of {self.dim} face arrays (one per component), "
                               f"got {type(u).__name__}{'' if not hasattr(u, '__len__') else f' of length {len(u)}'}")
        return [check_field(f"{name}[{i}]", c, self.face_shape(i)) for i, c in enumerate(u)]

    def close(self, u: list) -> list:
        """Set the velocity on closed faces (walls, obstacles) to zero, in place; returns ``u``."""
        for c, o in zip(u, self.open):
            c *= o
        return u

    # -- the discrete operators ---------------------------------------------------------------------
    def divergence(self, u: list) -> np.ndarray:
        """(D u)_c = Σᵢ (uᵢ(c + ½eᵢ) − uᵢ(c − ½eᵢ)) / Δx, one value per cell."""
        # BEGIN SOLUTION Grid.divergence
        div = np.zeros(self.shape)
        for i, c in enumerate(u):
            if self.periodic[i]:
                div += np.roll(c, -1, axis=i) - c
            else:
                div += np.diff(c, axis=i)
        return div / self.dx
        # END SOLUTION

    def gradient(self, p: np.ndarray, out: list | None = None) -> list:
        """(G p)_f = open_f (p(c + eᵢ) − p(c)) / Δx on the faces of each axis (0 on closed faces)."""
        # BEGIN SOLUTION Grid.gradient
        out = out if out is not None else [None] * self.dim
        for i in range(self.dim):
            if self.periodic[i]:
                g = p - np.roll(p, 1, axis=i)
            else:
                g = np.zeros(self.face_shape(i))
                inner = [slice(None)] * self.dim
                inner[i] = slice(1, -1)
                g[tuple(inner)] = np.diff(p, axis=i)
            out[i] = g * (self.open[i] / self.dx)
        return out
        # END SOLUTION

    def laplacian(self, p: np.ndarray) -> np.ndarray:
        """L p = D open G p: the pressure operator (Neumann at walls and obstacles)."""
        return self.divergence(self.gradient(p))

    def neighbours(self) -> np.ndarray:
        """Σ open over the faces of each cell: the diagonal of −Δx² L."""
        # BEGIN SOLUTION Grid.neighbours
        s = np.zeros(self.shape)
        for i, o in enumerate(self.open):
            if self.periodic[i]:
                s += o + np.roll(o, -1, axis=i)
            else:
                lo = [slice(None)] * self.dim
                lo[i] = slice(None, -1)
                hi = [slice(None)] * self.dim
                hi[i] = slice(1, None)
                s += o[tuple(lo)] + o[tuple(hi)]
        return s
        # END SOLUTION

    def cells_to_faces(self, c: np.ndarray, i: int) -> np.ndarray:
        """Average of the two cells beside each face of axis i (the wall faces take their one cell)."""
        if self.periodic[i]:
            return 0.5 * (c + np.roll(c, 1, axis=i))
        pad = [(0, 0)] * self.dim
        pad[i] = (1, 1)
        e = np.pad(c, pad, mode="edge")
        lo = [slice(None)] * self.dim
        lo[i] = slice(None, -1)
        hi = [slice(None)] * self.dim
        hi[i] = slice(1, None)
        return 0.5 * (e[tuple(lo)] + e[tuple(hi)])

    def faces_to_cells(self, u: list) -> list:
        """The velocity at the cell centres: the mean of the two faces of each component."""
        out = []
        for i, c in enumerate(u):
            if self.periodic[i]:
                out.append(0.5 * (c + np.roll(c, -1, axis=i)))
            else:
                lo = [slice(None)] * self.dim
                lo[i] = slice(None, -1)
                hi = [slice(None)] * self.dim
                hi[i] = slice(1, None)
                out.append(0.5 * (c[tuple(lo)] + c[tuple(hi)]))
        return out

    def kinetic_energy(self, u: list, density: float = 1.0) -> float:
        """E = ½ ρ Σ_faces u² Δx^d (each face once: the MAC inner product in which the projection is
        orthogonal)."""
        with np.errstate(over="ignore", invalid="ignore"):     # an overflowing field reports inf energy
            return 0.5 * density * self.dx ** self.dim * float(sum(np.sum(c * c) for c in u))

    def total(self, s: np.ndarray) -> float:
        """∫ s dV over the fluid cells (the mass of a scalar)."""
        return float(np.sum(s[self.fluid])) * self.dx ** self.dim

    def __repr__(self) -> str:
        kinds = self.boundary[0] if len(set(self.boundary)) == 1 else self.boundary
        return (f"Grid(shape={self.shape}, dx={self.dx:g}, boundary={kinds!r}, obstacles={int(self.solid.sum())} "
                f"cells, lids={sorted('xyz'[a] + '-+'[s] for a, s in self.lids)})")
