"""The base of every constraint kind, and the argument specs the kinds share (chapter 03).

A kind holds m rows of one type; row r touches particles ``slots[r, 0..k-1]`` (−1 = a fixed point of the
world, W = 0) and :meth:`Constraint.evaluate` returns, for positions x and velocities q̇ = v of shape
(N, dim), the values C (m,), the Jacobian blocks G (k, m, dim) with G[s, r] = ∂C_r/∂x_{slots[r, s]}, and
J̇q̇ (m,). ``bind(N, dim, x0)`` validates the indices against the particle system (and fills defaults
from the initial positions x0); the per-row views :meth:`Constraint.value`, :meth:`Constraint.jacobian`
and :meth:`Constraint.jdot_qdot` are for reading and for :func:`pbanim.constraints.check_constraint`.

Arguments arrive checked by the contracts at the public boundary (one state of the bound system: x and v of
shape (N, dim)); what pbanim itself passes (``ConstraintSet`` binding its kinds, the models building them)
is converted by :func:`_as_index` and :func:`_per_row` below, which keep their own checks for that path.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp

from ..contracts import Array, Int, Opt, contract
from ..errors import InvalidInput

__all__ = ["Constraint"]

# one state of the bound system, and the arguments of bind
X = Array(("self.N", "self.dim"))
N_PARTICLES = Int(ge=1)
DIM = Int(ge=2, le=3)
X0 = Opt(Array(("$N", "$dim")))


def _as_index(a, name: str, k: int | None = None) -> np.ndarray:
    raw = np.array(a, ndmin=1 if k is None else 2)
    if raw.size and raw.dtype.kind not in "iu":
        f = raw.astype(float) if raw.dtype.kind in "fb" else None
        if f is None or not np.all(np.isfinite(f)) or not np.all(f == np.round(f)):
            raise InvalidInput(f"{name} must be integer particle indices, got {np.asarray(a).ravel()[:5].tolist()}")
    arr = raw.astype(np.int64)
    if not arr.size and k is not None:
        arr = arr.reshape(0, k)
    if (k is None and arr.ndim != 1) or (k is not None and (arr.ndim != 2 or arr.shape[1] != k)):
        raise InvalidInput(f"{name} must have shape {'(m,)' if k is None else f'(m, {k})'}, got {np.shape(a)}")
    return arr


def _per_row(value, shape: tuple, name: str, finite: bool = True) -> np.ndarray:
    """A float parameter broadcast to ``shape`` (one per row, or per row and axis), checked finite."""
    a = np.asarray(value, dtype=float)
    try:
        out = np.broadcast_to(a, shape).copy()
    except ValueError:
        raise InvalidInput(f"{name} must be a scalar or broadcast to shape {shape}, got shape {a.shape}") from None
    if finite and not np.all(np.isfinite(out)):
        raise InvalidInput(f"{name} must be finite, got {out[~np.isfinite(out)][0]}")
    return out


def _square_finite(a: np.ndarray, name: str, what: str) -> np.ndarray:
    """a² (lengths, radii), or :class:`InvalidInput` when it overflows (C = ½(|d|² − a²) would be NaN)."""
    with np.errstate(over="ignore"):
        sq = a * a
    if not np.isfinite(sq).all():
        raise InvalidInput(f"{name} must be below 1e154 (its square enters C), got {a[~np.isfinite(sq)][0]:g} "
                           f"({what})")
    return sq


class Constraint:
    """Base class of a vectorized constraint kind (``m`` rows; see the module docstring).

    Subclasses set ``slots`` (m, k) and implement :meth:`evaluate`. ``bind(N, dim)`` validates indices
    against the particle system.
    """

    kind = "constraint"
    slots: np.ndarray
    opposite = False  # two slots with equal and opposite blocks, G[1] = −G[0] (a rod): |G[0]|² serves both

    @property
    def m(self) -> int:
        return int(self.slots.shape[0])

    @contract(N=N_PARTICLES, dim=DIM, x0=X0)
    def bind(self, N: int, dim: int, x0: np.ndarray | None = None) -> None:
        bad = self.slots[(self.slots >= N) | (self.slots < -1)]
        if bad.size:
            raise InvalidInput(f"particle index {int(bad[0])} out of range for a system of {N} particles "
                             f"({self.kind}); use indices in [0, {N - 1}] (or -1 for a fixed point)")
        self.N, self.dim = int(N), int(dim)

    @contract(x=X, v=X)
    def evaluate(self, x: np.ndarray, v: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(C (m,), G (k, m, dim), J̇q̇ (m,)) at positions x and velocities v of shape (N, dim)."""
        raise NotImplementedError

    # -- per-constraint views for students (not used in the hot path) ---------------------------------
    @contract(x=X)
    def value(self, x: np.ndarray) -> np.ndarray:
        """C(x), shape (m,)."""
        x = np.asarray(x, float)
        return self.evaluate(x, np.zeros_like(x))[0]

    @contract(x=X)
    def jacobian(self, x: np.ndarray) -> sp.csr_matrix:
        """J(x) = ∂C/∂q as a sparse (m, N·dim) matrix, q = x.ravel()."""
        x = np.asarray(x, float)
        N, dim = x.shape
        _, G, _ = self.evaluate(x, np.zeros_like(x))
        k = self.slots.shape[1]
        rows = np.tile(np.repeat(np.arange(self.m), dim), k)
        cols = (self.slots.T[:, :, None] * dim + np.arange(dim)).ravel()
        keep = np.repeat(self.slots.T.ravel() >= 0, dim)
        return sp.csr_matrix((G.ravel()[keep], (rows[keep], cols[keep])), shape=(self.m, N * dim))

    @contract(x=X, v=X)
    def jdot_qdot(self, x: np.ndarray, v: np.ndarray) -> np.ndarray:
        """J̇q̇, shape (m,)."""
        return self.evaluate(np.asarray(x, float), np.asarray(v, float))[2]
