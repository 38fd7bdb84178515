"""Broad phase: which pairs of spheres (or bounding spheres) can touch (chapter 06).

All-pairs tests N(N−1)/2 pairs. A uniform grid with cells as wide as the largest diameter puts each
sphere in one cell; two spheres can only touch if their cells are neighbours, so each sphere is tested
against the spheres of its own cell and of the 13 "forward" neighbour cells (half of the 26, so each
pair is generated once). At bounded density this is O(N) pairs (Ericson, *Real-Time Collision
Detection* §7.1; Teschner et al. 2003, spatial hashing). The grid is built with one sort of integer cell
keys and ``searchsorted`` — no Python loop per sphere.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .shapes import _as3
from ..contracts import Array, Choice, Either, Int, Opt, Real, contract
from ..errors import InvalidInput

__all__ = ["BroadPhase", "broad_phase", "all_pairs", "grid_pairs"]

_CENTRES = Either(Array(("N", 3)), Array(("N", 2)))
_RADII = Array(("N",), ge=0, scalar=True)
_MARGIN = Real(ge=0)
_MAX_CELLS = 2 ** 20          # cells per axis: (2²⁰ + 2)³ cell keys fit an int64
METHODS = ("grid", "all_pairs")

_FORWARD = np.array([(dx, dy, dz) for dx in (-1, 0, 1) for dy in (-1, 0, 1) for dz in (-1, 0, 1)
                     if (dx, dy, dz) > (0, 0, 0)])     # the 13 lexicographically positive offsets


@dataclass
class BroadPhase:
    """Overlapping pairs and the cost of finding them.

    Attributes
    ----------
    pairs : ndarray of int, shape (k, 2)
        Index pairs (i < j) whose spheres overlap (distance ≤ r_i + r_j + margin), sorted.
    tested : int
        Candidate pairs on which the exact sphere test ran (the broad phase's cost).
    method : str
    """

    pairs: np.ndarray
    tested: int
    method: str


def _overlap(c, r, i, j, margin):
    d = c[i] - c[j]
    return np.einsum("ij,ij->i", d, d) <= (r[i] + r[j] + margin) ** 2


def _finish(i, j, tested, method):
    lo, hi = np.minimum(i, j), np.maximum(i, j)
    pairs = np.stack([lo, hi], axis=1) if lo.size else np.zeros((0, 2), np.intp)
    if len(pairs):
        pairs = pairs[np.lexsort((pairs[:, 1], pairs[:, 0]))]
    return BroadPhase(pairs.astype(np.intp), int(tested), method)


@contract(centers=_CENTRES, radii=_RADII, margin=_MARGIN, block=Int(ge=1))
def all_pairs(centers, radii, margin: float = 0.0, block: int = 512) -> BroadPhase:
    """Every pair tested (the O(N²) baseline), in row blocks to bound memory.

    >>> all_pairs([[0, 0, 0], [1.5, 0, 0], [5, 0, 0]], 1.0).pairs
    array([[0, 1]])
    """
    c = _as3(centers)
    N = len(c)
    r = np.broadcast_to(np.asarray(radii, dtype=float), (N,))
    out_i, out_j = [], []
    block = int(block)
    for s in range(0, N, block):
        rows = np.arange(s, min(N, s + block))
        d2 = ((c[rows, None, :] - c[None, :, :]) ** 2).sum(-1)
        hit = (d2 <= (r[rows, None] + r[None, :] + margin) ** 2) & (np.arange(N)[None, :] > rows[:, None])
        ii, jj = np.nonzero(hit)
        out_i.append(rows[ii])
        out_j.append(jj)
    i = np.concatenate(out_i) if out_i else np.zeros(0, np.intp)
    j = np.concatenate(out_j) if out_j else np.zeros(0, np.intp)
    return _finish(i, j, N * (N - 1) // 2, "all_pairs")


def _ranges_to_pairs(order, left, right):
    """For each sorted position p, pair order[p] with order[left[p]:right[p]] (vectorized)."""
    counts = np.maximum(right - left, 0)
    total = int(counts.sum())
    src = np.repeat(np.arange(len(left)), counts)
    first = np.repeat(left, counts)
    offs = np.arange(total) - np.repeat(np.cumsum(counts) - counts, counts)
    return order[src], order[first + offs]


@contract(centers=_CENTRES, radii=_RADII, margin=_MARGIN, cell=Opt(Real(gt=0)))
def grid_pairs(centers, radii, margin: float = 0.0, cell: float | None = None) -> BroadPhase:
    """Overlapping pairs by a uniform grid (cell ≥ largest diameter + margin; default: exactly that).

    A cell smaller than the largest diameter + margin would miss pairs, so it is refused. Any larger cell
    is correct (more candidates), so a cell wider than the whole cloud, or a zero one (points, no margin),
    is replaced by one that spans the cloud in at most 2²⁰ cells per axis (the int64 cell keys).

    >>> grid_pairs([[0, 0, 0], [1.5, 0, 0], [5, 0, 0]], 1.0).pairs
    array([[0, 1]])
    """
    c = _as3(centers)
    N = len(c)
    r = np.broadcast_to(np.asarray(radii, dtype=float), (N,))
    if N < 2:
        return BroadPhase(np.zeros((0, 2), np.intp), 0, "grid")
    need = 2.0 * float(r.max()) + margin
    if cell is not None and float(cell) < need:
        raise InvalidInput(f"grid_pairs: cell must be >= the largest diameter + margin = {need:g} (a smaller "
                           f"cell misses pairs), got {cell}")
    size = need if cell is None else float(cell)
    lo = c.min(axis=0)
    with np.errstate(over="ignore", invalid="ignore"):
        extent = float((c.max(axis=0) - lo).max())
    if not np.isfinite(extent):
        raise InvalidInput(f"grid_pairs: centers spread over more than double precision can subtract (max - "
                           f"min overflows); rescale the scene")
    # a larger cell is always correct: span the cloud with at most _MAX_CELLS cells per axis
    size = max(min(size, extent) if extent > 0 else 1.0, extent / _MAX_CELLS)
    if size <= 0:           # points at one place with no margin: any cell will do
        size = 1.0
    ijk = np.floor((c - lo) / size).astype(np.int64) + 1       # ≥ 1, so offsets −1 stay ≥ 0
    dims = ijk.max(axis=0) + 2
    key = (ijk[:, 0] * dims[1] + ijk[:, 1]) * dims[2] + ijk[:, 2]
    order = np.argsort(key, kind="stable")
    skey = key[order]
    pos = np.arange(N)
    # own cell: each sorted position with the later positions of the same key
    right = np.searchsorted(skey, skey, side="right")
    ii, jj = [], []
    a, b = _ranges_to_pairs(order, pos + 1, right)
    ii.append(a)
    jj.append(b)
    for off in _FORWARD:
        nkey = skey + (off[0] * dims[1] + off[1]) * dims[2] + off[2]
        a, b = _ranges_to_pairs(order, np.searchsorted(skey, nkey, "left"), np.searchsorted(skey, nkey, "right"))
        ii.append(a)
        jj.append(b)
    i, j = np.concatenate(ii), np.concatenate(jj)
    hit = _overlap(c, r, i, j, margin)
    return _finish(i[hit], j[hit], i.size, "grid")


def _grid_pairs_small(centers, radii, margin: float = 0.0) -> np.ndarray:
    """``grid_pairs(centers, radii, margin).pairs`` for a few spheres, by one all-pairs product: the pairs within
    a slightly wider margin (a superset of the grid's), then the grid's own overlap test on each (the same
    d·d and (rᵢ + rⱼ + margin)², bit for bit), in the same sorted order. For N ≥ 2 centres and radii > 0
    somewhere (the callers' test); several times cheaper than the grid below a few dozen spheres."""
    c = _as3(centers)
    r = np.broadcast_to(np.asarray(radii, dtype=float), (len(c),))
    p = all_pairs(c, r, margin + 1e-9 * (1.0 + float(r.max()) + margin)).pairs
    return p[_overlap(c, r, p[:, 0], p[:, 1], margin)]


@contract(centers=_CENTRES, radii=_RADII, method=Choice(METHODS), margin=_MARGIN)
def broad_phase(centers, radii, method: str = "grid", margin: float = 0.0) -> BroadPhase:
    """Overlapping sphere pairs by ``method`` = "grid" (near-linear) or "all_pairs" (quadratic).

    >>> rng = np.random.default_rng(0); c = rng.uniform(0, 5, (300, 3))
    >>> g, a = broad_phase(c, 0.2), broad_phase(c, 0.2, method="all_pairs")
    >>> bool(np.array_equal(g.pairs, a.pairs)), g.tested < a.tested
    (True, True)
    """
    return grid_pairs(centers, radii, margin) if method == "grid" else all_pairs(centers, radii, margin)
