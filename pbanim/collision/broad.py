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
from ..errors import InvalidInput

__all__ = ["BroadPhase", "broad_phase", "all_pairs", "grid_pairs"]

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


def all_pairs(centers, radii, margin: float = 0.0, block: int = 512) -> BroadPhase:
    """Every pair tested (the O(N²) baseline), in row blocks to bound memory.

    >>> all_pairs([[0, 0, 0], [1.5, 0, 0], [5, 0, 0]], 1.0).pairs
    array([[0, 1]])
    """
    c = _as3(centers)
    N = len(c)
    r = np.broadcast_to(np.asarray(radii, dtype=float), (N,))
    out_i, out_j = [], []
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


def grid_pairs(centers, radii, margin: float = 0.0, cell: float | None = None) -> BroadPhase:
    """Overlapping pairs by a uniform grid (cell ≥ largest diameter + margin).

    >>> grid_pairs([[0, 0, 0], [1.5, 0, 0], [5, 0, 0]], 1.0).pairs
    array([[0, 1]])
    """
    c = _as3(centers)
    N = len(c)
    r = np.broadcast_to(np.asarray(radii, dtype=float), (N,))
    if N < 2:
        return BroadPhase(np.zeros((0, 2), np.intp), 0, "grid")
    size = 2.0 * float(r.max()) + margin if cell is None else float(cell)
    if not np.isfinite(size) or size <= 0:
        raise InvalidInput(f"grid cell size must be positive, got {size}; give spheres a radius > 0 or pass cell")
    ijk = np.floor((c - c.min(axis=0)) / size).astype(np.int64) + 1       # ≥ 1, so offsets −1 stay ≥ 0
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


def broad_phase(centers, radii, method: str = "grid", margin: float = 0.0) -> BroadPhase:
    """Overlapping sphere pairs by ``method`` = "grid" (near-linear) or "all_pairs" (quadratic).

    >>> rng = np.random.default_rng(0); c = rng.uniform(0, 5, (300, 3))
    >>> g, a = broad_phase(c, 0.2), broad_phase(c, 0.2, method="all_pairs")
    >>> bool(np.array_equal(g.pairs, a.pairs)), g.tested < a.tested
    (True, True)
    """
    if method == "grid":
        return grid_pairs(centers, radii, margin)
    if method == "all_pairs":
        return all_pairs(centers, radii, margin)
    raise InvalidInput(f"broad-phase method must be 'grid' or 'all_pairs', got {method!r}")
