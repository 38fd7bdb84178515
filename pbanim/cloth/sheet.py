"""A rectangular sheet of n × n particles: positions, rest (material) coordinates, triangles, springs, hinges.

The cloth of Baraff & Witkin (1998) is a triangle mesh whose every vertex carries a material point (u, v) of
the flat, unstretched sheet. This module builds the square one every lecture starts from:

    particle p = i n + j  (row i, column j),   rest  (u, v) = (j Δ, i Δ),   Δ = L / (n − 1),
    x₀ = (u − L/2, v − L/2, height)  (horizontal, centred on the z axis)   or  (u − L/2, 0, height − v + L)
    (vertical, hanging from its top row),

split into 2 (n − 1)² triangles by one diagonal per quad, and the element lists every force model needs:

=================  =====================================  ==============================================
element            vertices                               used by
=================  =====================================  ==============================================
structural spring  (i, j)–(i, j+1), (i, j)–(i+1, j)        the spring model (stretch), rest Δ
shear spring       (i, j)–(i+1, j+1), (i, j+1)–(i+1, j)    the spring model (shear), rest Δ√2
bend spring        (i, j)–(i, j+2), (i, j)–(i+2, j)        the spring model (bend), rest 2Δ
triangle           (p₀, p₁, p₂) counter-clockwise in uv    Baraff–Witkin stretch and shear conditions
hinge              edge (p₀, p₁), opposite p₂ and p₃       Baraff–Witkin bend condition (dihedral angle)
=================  =====================================  ==============================================

Masses are lumped: each triangle gives a third of its mass ρ·area to each of its vertices (ρ = mass / L²),
so Σ mᵢ = mass exactly and an interior particle carries ρΔ². Pins: ``"corners"`` fixes the two corners of the
top row (i = n − 1), ``"edge"`` that whole row, ``"none"`` nothing.

Limiting cases: n = 2 is one quad (two triangles, one hinge, no bend springs); the sheet at rest has every
condition C(x₀) = 0 (a strain-free, flat sheet), so its only force is gravity.

Reference: D. Baraff, A. Witkin, "Large steps in cloth simulation", SIGGRAPH 1998, §4 (the mesh, the uv
parametrization); X. Provot, "Deformation constraints in a mass-spring model to describe rigid cloth
behavior", Graphics Interface 1995 (structural, shear and bend springs).
"""

from __future__ import annotations

import numpy as np

from ..contracts import Choice, Int, Real, contract

__all__ = ["Sheet", "PINS", "ORIENTATIONS"]

PINS = ("corners", "edge", "none")
ORIENTATIONS = ("horizontal", "vertical")


def _grid_pairs(n: int, di: int, dj: int) -> np.ndarray:
    """Index pairs ((i, j), (i + di, j + dj)) of every grid point whose partner is inside the sheet."""
    i, j = np.meshgrid(np.arange(n), np.arange(n), indexing="ij")
    ok = (i + di >= 0) & (i + di < n) & (j + dj >= 0) & (j + dj < n)
    a = (i * n + j)[ok]
    return np.stack([a, a + di * n + dj], axis=1).astype(np.intp)


def _triangles(n: int) -> np.ndarray:
    """Two counter-clockwise triangles per quad, split along the (i, j)–(i+1, j+1) diagonal."""
    i, j = np.meshgrid(np.arange(n - 1), np.arange(n - 1), indexing="ij")
    p00 = (i * n + j).ravel()
    p01, p10, p11 = p00 + 1, p00 + n, p00 + n + 1
    return np.concatenate([np.stack([p00, p01, p11], 1), np.stack([p00, p11, p10], 1)]).astype(np.intp)


def _hinges(tri: np.ndarray, n_points: int) -> np.ndarray:
    """(edge p₀, edge p₁, opposite p₂, opposite p₃) for every edge shared by two triangles (vectorized:
    the three edges of every triangle, keyed by their sorted ends, and the keys that occur twice)."""
    edges = np.concatenate([tri[:, [0, 1]], tri[:, [1, 2]], tri[:, [2, 0]]])
    opposite = np.concatenate([tri[:, 2], tri[:, 0], tri[:, 1]])
    lo, hi = edges.min(axis=1), edges.max(axis=1)
    key = lo.astype(np.int64) * n_points + hi
    order = np.argsort(key, kind="stable")
    k = key[order]
    twice = np.flatnonzero(k[1:] == k[:-1])
    first, second = order[twice], order[twice + 1]
    return np.stack([lo[first], hi[first], opposite[first], opposite[second]], axis=1).astype(np.intp)


@contract(n=Int(ge=2, le=512), size=Real(ge=1e-4, le=1e3), mass=Real(gt=0, le=1e6), height=Real(ge=-1e3, le=1e3),
          orientation=Choice(ORIENTATIONS), pins=Choice(PINS))
class Sheet:
    """The n × n sheet: geometry and topology, no forces (see :class:`pbanim.cloth.Cloth` for those).

    Parameters
    ----------
    n : int
        Particles per side (n² in all, 3n² unknowns x, 3n² unknowns v), 2 ≤ n ≤ 512.
    size : float
        Side L (m), 10⁻⁴ ≤ L ≤ 10³.
    mass : float
        Total mass (kg), lumped to the vertices by triangle area.
    height : float
        z of the sheet (horizontal) or of its top row (vertical) (m).
    orientation : {"horizontal", "vertical"}
    pins : {"corners", "edge", "none"}
        Particles held fixed: the two corners of the top row, the whole top row, or none.

    Attributes
    ----------
    x0 : (n², 3) rest positions;  uv : (n², 2) material coordinates (m);  masses : (n²,)
    triangles : (2(n−1)², 3);  hinges : (H, 4);  springs : dict kind → (S, 2) for "structural", "shear", "bend"
    pinned : sorted particle indices held fixed;  spacing : Δ = L/(n − 1)

    Examples
    --------
    >>> s = Sheet(3, size=2.0, mass=4.0)
    >>> s.x0.shape, s.triangles.shape, s.hinges.shape, s.springs["structural"].shape
    ((9, 3), (8, 3), (8, 4), (12, 2))
    >>> float(s.masses.sum()), s.pinned.tolist()
    (4.0, [6, 8])
    """

    def __init__(self, n: int, size: float = 1.0, mass: float = 0.2, height: float = 0.0,
                 orientation: str = "horizontal", pins: str = "corners") -> None:
        self.n, self.size, self.mass, self.orientation, self.pin_mode = int(n), float(size), float(mass), \
            orientation, pins
        n = self.n
        self.spacing = self.size / (n - 1)
        i, j = np.meshgrid(np.arange(n), np.arange(n), indexing="ij")
        u, v = (j * self.spacing).ravel(), (i * self.spacing).ravel()
        self.uv = np.stack([u, v], axis=1)
        half = 0.5 * self.size
        if orientation == "horizontal":
            self.x0 = np.stack([u - half, v - half, np.full_like(u, height)], axis=1)
        else:
            self.x0 = np.stack([u - half, np.zeros_like(u), height - self.size + v], axis=1)
        self.triangles = _triangles(n)
        self.hinges = _hinges(self.triangles, n * n)
        self.springs = {"structural": np.concatenate([_grid_pairs(n, 0, 1), _grid_pairs(n, 1, 0)]),
                        "shear": np.concatenate([_grid_pairs(n, 1, 1), _grid_pairs(n, 1, -1)]),
                        "bend": np.concatenate([_grid_pairs(n, 0, 2), _grid_pairs(n, 2, 0)])}
        area = 0.5 * self.spacing ** 2                       # every triangle of the square grid
        rho = self.mass / self.size ** 2
        self.masses = np.bincount(self.triangles.ravel(), minlength=n * n) * (rho * area / 3.0)
        top = np.arange((n - 1) * n, n * n)
        self.pinned = {"corners": top[[0, -1]], "edge": top, "none": np.zeros(0, np.intp)}[pins].astype(np.intp)

    @property
    def n_particles(self) -> int:
        """n²."""
        return self.n * self.n

    def __repr__(self) -> str:
        return (f"Sheet(n={self.n}, size={self.size:g} m, mass={self.mass:g} kg, {self.orientation}, "
                f"pins={self.pin_mode!r}: {len(self.pinned)} pinned)")
