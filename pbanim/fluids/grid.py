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
n, d        cells per axis (≥ 3 each, at most 2²² cells in all), number of axes (2 or 3)
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

from ..contracts import Anything, Array, Choice, Either, Env, Index, Opt, Real, Seq, Text, contract, finite_result
from ..errors import InvalidInput
from .specs import Cells, GridShape, Mask, Named, Slots, Velocity, finite_fields, quiet

__all__ = ["BOUNDARIES", "SIDES", "Grid"]

BOUNDARIES = ("periodic", "walls")
SIDES = {f"{a}{s}": (i, k) for i, a in enumerate("xyz") for k, s in enumerate("-+")}
DX_RANGE = (1e-100, 1e100)      # Δx^d, 1/Δx² and the operators' entries stay finite

_AXIS = Opt(Index("self.dim"))
_U = Velocity("self")
_P = Cells("self")


@contract(shape=GridShape(), dx=Real(ge=DX_RANGE[0], le=DX_RANGE[1]),
          boundary=Either(Choice(BOUNDARIES), Seq(Choice(BOUNDARIES), min_len=2, max_len=3)),
          solid=Opt(Mask("$shape")), lids=Opt(Named(Array((None,)), keys=tuple(SIDES))))
class Grid:
    """A box of square cells with periodic or wall boundaries, optional sliding walls and obstacles.

    Parameters
    ----------
    shape : sequence of 2 or 3 ints, each ≥ 3, at most ``MAX_CELLS`` = 2²² cells in all
        Cells per axis (axis 0 is x, axis 1 is y, axis 2 is z; arrays are indexed [x, y(, z)]).
    dx : float in [1e-100, 1e100]
        Cell side Δx (the range keeps Δx^d and 1/Δx² finite).
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
        self.shape = tuple(int(n) for n in shape)
        self.dim = len(self.shape)
        self.dx = float(dx)
        kinds = (boundary,) * self.dim if isinstance(boundary, str) else tuple(boundary)
        if len(kinds) != self.dim:
            raise InvalidInput(f"Grid: boundary must be one of {BOUNDARIES} or one per axis ({self.dim} entries), "
                               f"got {boundary!r}")
        self.boundary = kinds
        self.periodic = tuple(k == "periodic" for k in kinds)
        self.solid = np.zeros(self.shape, dtype=bool) if solid is None else np.asarray(solid, dtype=bool)
        self.has_obstacles = bool(self.solid.any())
        self.fluid = ~self.solid
        self.lids = self._check_lids(lids)
        self.open = tuple(self._open_faces(i) for i in range(self.dim))

    # -- construction helpers ----------------------------------------------------------------------
    def _check_lids(self, lids) -> dict:
        """The sliding walls by (axis, side); what the contract cannot say: a side of this grid's axes, a wall
        (not a periodic axis), a tangential velocity of d components."""
        out = {}
        for key, vel in dict(lids or {}).items():
            if SIDES[key][0] >= self.dim:
                raise InvalidInput(f"Grid: lids keys must be sides {[s for s, (a, _) in SIDES.items() if a < self.dim]}"
                                   f", got {key!r}")
            axis, side = SIDES[key]
            if self.periodic[axis]:
                raise InvalidInput(f"Grid: lids[{key!r}]: axis {'xyz'[axis]} is periodic, it has no wall to slide")
            v = np.array(vel, dtype=float)
            if v.shape != (self.dim,):
                raise InvalidInput(f"Grid: lids[{key!r}] must be {self.dim} finite numbers, got {vel!r}")
            if v[axis] != 0:
                raise InvalidInput(f"Grid: lids[{key!r}] must be tangential to the wall (component {axis} = 0), "
                                   f"got {v}")
            out[(axis, side)] = v
        return out

    @contract(i=Index("self.dim"))
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

    @contract(component=_AXIS)
    def offset(self, component: int | None) -> np.ndarray:
        """Where samples sit inside a cell, in cells: ½ on every axis for cells, 0 along i for uᵢ."""
        o = np.full(self.dim, 0.5)
        if component is not None:
            o[component] = 0.0
        return o

    @contract(component=_AXIS)
    def positions(self, component: int | None = None) -> list:
        """Coordinates of the samples of uᵢ (``component = i``) or of the cells (None), one array per axis."""
        shape = self.shape if component is None else self.face_shape(component)
        o = self.offset(component)
        axes = [(np.arange(m) + o[a]) * self.dx for a, m in enumerate(shape)]
        return list(np.meshgrid(*axes, indexing="ij"))

    @property
    def extent(self) -> tuple:
        return tuple(n * self.dx for n in self.shape)

    @contract(u=Anything("the value under check: answered by the face arrays it holds or by InvalidInput naming "
                         "it"), name=Text(nonempty=True))
    def check_velocity(self, u, name: str = "u") -> list:
        """``u`` as a list of finite float face arrays of the right shapes (copies), or :class:`InvalidInput`
        naming ``name`` (the contract's own check of a velocity, :class:`~pbanim.fluids.specs.Velocity`)."""
        return [np.array(c) for c in _U.check(name, u, Env("Grid.check_velocity", {"self": self}))]

    @contract(u=_U)
    def close(self, u: list) -> list:
        """Set the velocity on closed faces (walls, obstacles) to zero, in place; returns ``u``."""
        for c, o in zip(u, self.open):
            c *= o
        return u

    # -- the discrete operators ---------------------------------------------------------------------
    @contract(u=_U, returns=finite_result)
    @quiet
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

    @contract(p=_P, out=Opt(Slots("self")), returns=finite_fields)
    @quiet
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

    @contract(p=_P, returns=finite_result)
    @quiet
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

    @contract(c=_P, i=Index("self.dim"), returns=finite_result)
    @quiet
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

    @contract(u=_U, returns=finite_result)
    @quiet
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

    @contract(u=_U, density=Real(gt=0), returns=finite_result)
    def kinetic_energy(self, u: list, density: float = 1.0) -> float:
        """E = ½ ρ Σ_faces u² Δx^d (each face once: the MAC inner product in which the projection is
        orthogonal). Called by a user, an overflow is :class:`~pbanim.errors.NonFiniteResult`; inside a run
        it reads inf, which the run reports as divergence."""
        with np.errstate(over="ignore", invalid="ignore"):
            return 0.5 * density * self.dx ** self.dim * float(sum(np.sum(c * c) for c in u))

    @contract(s=_P, returns=finite_result)
    @quiet
    def total(self, s: np.ndarray) -> float:
        """∫ s dV over the fluid cells (the mass of a scalar)."""
        return float(np.sum(s[self.fluid])) * self.dx ** self.dim

    def __repr__(self) -> str:
        kinds = self.boundary[0] if len(set(self.boundary)) == 1 else self.boundary
        return (f"Grid(shape={self.shape}, dx={self.dx:g}, boundary={kinds!r}, obstacles={int(self.solid.sum())} "
                f"cells, lids={sorted('xyz'[a] + '-+'[s] for a, s in self.lids)})")
