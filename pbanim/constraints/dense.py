"""Small constraint sets: Witkin's λ on dense arrays, bound once (chapter 03; the lean path of ``Constraints``).

For a pendulum, a short chain or a few rods the readable solve (:func:`pbanim.constraints.solve_lambda` on
the sparse assembly of :class:`~pbanim.constraints.ConstraintSet`) spends its time in the interpreter: sparse
matrix products, solver dispatch and result records cost some microseconds each, the arithmetic a few
nanoseconds. :class:`DenseWitkin` computes the same equations on preallocated dense arrays:

    J ← the kinds' blocks G written into a dense (m, n) array (positions computed once, from the set's
        compiled sparsity pattern),                 Ċ = J q̇,        c = −J̇q̇ − k_s C − k_d Ċ,
    A = (J W) Jᵀ = L Lᵀ (LAPACK dpotrf),            r = c − J W Q,
    λ = A⁻¹ r (dpotrs), plus one refinement step with the residual in factored form r − J(W(Jᵀλ)),
    Q_C = Jᵀ λ.

This is the readable ``witkin-dense`` solve (the same Cholesky and the same refinement step,
:func:`pbanim.constraints.solvers._refined`) with J dense instead of sparse: λ and Q_C agree with every
readable solver to roundoff (ORACLES B5; ``tests/test_constraints.py``). A pivot below 10⁻¹³ of its diagonal
entry (dependent rows, ORACLES B4) or a non-finite λ returns None, and the caller takes the readable path
(the minimum-norm λ, or the named error).

========  ======================  ========================================
symbol    code                    shape
========  ======================  ========================================
J         ``self.J``              (m, n) dense, rewritten every evaluation
W         ``self.Wq``             (n,) inverse masses per coordinate
A, L      ``A``, ``L``            (m, m): JWJᵀ and its Cholesky factor
========  ======================  ========================================

Used by :class:`~pbanim.constraints.Constraints` for sets of built-in kinds with m ≤ :data:`DENSE_ROWS` rows
and n ≤ :data:`DENSE_COORDS` coordinates and ``solver`` "auto" or "witkin-dense" (``effect.lean_path =
False``: the readable solve at every evaluation).
"""

from __future__ import annotations

import math

import numpy as np
from scipy.linalg.lapack import dpotrf, dpotrs

__all__ = ["DENSE_ROWS", "DENSE_COORDS", "DenseWitkin", "dense_fits"]

#: Most rows of a set solved on dense arrays (A is m × m: the solve is O(m³), the products O(m² n)).
DENSE_ROWS = 24
#: Most coordinates n = N·dim of a set solved on dense arrays.
DENSE_COORDS = 72
_PIVOT = 1e-13      # as the readable dense solve (pbanim.constraints.solvers)


def dense_fits(cset, solver: str) -> bool:
    """Whether a set takes the dense path: built-in kinds, small, and a solver that leaves the choice open."""
    return (solver in ("auto", "witkin-dense") and cset.blocks and 0 < cset.m <= DENSE_ROWS
            and cset.n <= DENSE_COORDS)


class DenseWitkin:
    """λ and Q_C of a small :class:`~pbanim.constraints.ConstraintSet` on dense arrays (see the module)."""

    def __init__(self, cset) -> None:
        m, n = cset.m, cset.n
        Jp = cset._J                                         # the compiled CSR pattern of J
        rows = np.repeat(np.arange(m), np.diff(Jp.indptr))
        self._pos = rows * n + Jp.indices                    # where each stored entry sits in the dense J
        self._perm = cset._Jperm                             # which block component of the stacked G it is
        self.J = np.zeros((m, n))
        self._flat = self.J.reshape(-1)
        self.Wq = cset.Wq
        self._evaluate = tuple(cset._evaluate)
        self.m, self.n, self.dim = m, n, cset.dim
        self.last: tuple | None = None                       # (C, Ċ, λ, Q_C, r) of the last solve

    def solve(self, x: np.ndarray, v: np.ndarray, Q: np.ndarray, ks: float, kd: float):
        """(C, Ċ, λ, Q_C) at positions x, velocities v (N, dim) under the applied force Q (n,), or None when a
        pivot vanishes or λ is not finite (the readable path then decides)."""
        if len(self._evaluate) == 1:
            C, G, Jdv = self._evaluate[0](x, v)
            gflat = G.reshape(-1)
        else:
            out = [f(x, v) for f in self._evaluate]
            C = np.concatenate([o[0] for o in out])
            Jdv = np.concatenate([o[2] for o in out])
            gflat = np.concatenate([o[1].reshape(-1) for o in out])
        J, Wq = self.J, self.Wq
        self._flat[self._pos] = gflat[self._perm]
        Cdot = J @ v.reshape(-1)
        c = ks * C
        c += Jdv
        c += kd * Cdot
        JW = J * Wq
        A = JW @ J.T
        r = JW @ Q
        r += c
        np.negative(r, out=r)                                # r = c − JWQ, c = −J̇q̇ − k_s C − k_d Ċ
        tiny = _PIVOT * A.diagonal()
        L, info = dpotrf(A.T, lower=1, clean=0, overwrite_a=1)   # A symmetric: its transpose is Fortran-ordered
        if info != 0 or (L.diagonal() ** 2 < tiny).any():
            return None
        lam = dpotrs(L, r, lower=1)[0]
        t = J.T @ lam                                        # one refinement step in factored form
        t *= Wq
        lam += dpotrs(L, r - J @ t, lower=1)[0]
        QC = J.T @ lam
        if not math.isfinite(QC @ QC):                       # a NaN state, an overflow: the readable path names it
            return None
        self.last = (C, Cdot, lam, QC, r)
        return C, Cdot, lam, QC
