"""Row-wise array helpers of the vectorized constraint kinds and their assembly (chapter 03).

A kind evaluates all its rows at once from particle rows x[idx] of an (N, dim) array; these helpers do
the gathers (or, for a run of consecutive indices, the slices that replace them) and the row-wise dot
products G·G that fill J and JWJᵀ.
"""

from __future__ import annotations

import numpy as np

from ..particles.springs import row_dot


def _gather(x: np.ndarray, idx: np.ndarray, fixed: np.ndarray) -> np.ndarray:
    """x[idx] with rows where idx == -1 taken from ``fixed`` (world points); readable, not hot."""
    out = x[idx]
    neg = idx < 0
    if neg.any():
        out[neg] = fixed[neg]
    return out


_dot = row_dot      # the row-wise dot products live with the particle rows (pbanim.particles.springs)


def _span(idx: np.ndarray) -> slice | None:
    """slice(i₀, i₀ + len) when idx is the contiguous range i₀, i₀ + 1, …; else None (use a gather)."""
    if len(idx) and idx[0] >= 0 and np.array_equal(idx, np.arange(idx[0], idx[0] + len(idx))):
        return slice(int(idx[0]), int(idx[0]) + len(idx))
    return None


def _take(x: np.ndarray, idx: np.ndarray) -> np.ndarray:
    """Rows x[idx] (np.take is several times faster than fancy indexing for (N, dim) arrays)."""
    return np.take(x, idx, axis=0)
