"""A multigrid preconditioner for the large-step system A = M − hD − h²K of a sheet (aggregation on the grid).

Jacobi-preconditioned CG needs ∝ N iterations on an N × N sheet (the stretch stiffness acts like a grid
Laplacian: cond(A) ≈ 1 + h²k/m · O(N²)·…), so a large step cannot cost ∝ N². A V-cycle of aggregation
multigrid is a preconditioner whose CG iteration count hardly grows with N:

* **aggregates**: the particles of 2 × 2 cells of the grid, level after level (an m × m grid of particles
  becomes ⌈m/2⌉ × ⌈m/2⌉); the prolongation P copies an aggregate's 3 coordinates to each of its particles
  (piecewise constant, P: n_ℓ → n_{ℓ−1}), the restriction is Pᵀ;
* **Galerkin coarse matrices** A_{ℓ+1} = Pᵀ A_ℓ P: entry (I r, J s) is the sum of the fine entries (i r, j s)
  over i ∈ I, j ∈ J, so the coarse CSR data is one fixed 0/1 sparse matrix times the fine data (computed once
  per pattern; each step costs one sparse product per level, no sparse-matrix product);
* **the cycle** (symmetric, so CG may use it): pre-smooth x = D₁⁻¹ r, the residual r − A x restricted, the
  coarse correction (recursively; the coarsest level, ≤ ``coarsest`` particles, by its inverse from a
  dense Cholesky),
  prolonged and scaled by ``boost``, post-smooth x += D₁⁻¹ (r − A x). D₁ is the ℓ1-Jacobi diagonal
  d_i = Σ_j |a_ij|: plain damped Jacobi (ω = ⅔ on a_ii) diverges on the cloth (the shear and bend springs
  make D⁻¹A reach past 3: measured eigenvalues of P⁻¹A down to −0.5 on a 12 × 12 sheet), while ℓ1-Jacobi
  contracts in the A-norm for every SPD A (Baker, Falgout, Kolev & Yang 2011), so P⁻¹A has its spectrum in
  (0, 1] (measured 0.018 … 1 on 12 × 12, 0.010 … 1 on 20 × 20). A boost above 1 (over-correction) widens
  it (1.8: up to 5.8 on 20 × 20) and is left at 1.

A V-cycle costs two products with the fine A besides the CG's own. The default (``additive_top``) drops
them: on the finest level the two corrections are added instead of applied in turn, B = D₁⁻¹ + P B₁ Pᵀ
with B₁ the V-cycle of level 1 — a sum of two SPD operators, each at most A⁻¹ in the A-norm, so the
spectrum of B A lies in (0, 2] (measured 0.005 … 1.97 on 20 × 20). Measured on the benchmark's sheet at
h = 1/60 s, six steps into the fall, CG to 10⁻³ (iterations; time per step, one BLAS thread, loaded machine):

=======  ================  ================  ==================
N        Jacobi            V-cycle           additive top
=======  ================  ================  ==================
16       70;  5 ms         29;  8 ms         47;  9 ms
64       290; 204 ms       58;  143 ms       84;  123 ms
128      554; 2.08 s       71;  1.08 s       99;  0.62 s
=======  ================  ================  ==================

It is applied inside B&W's modified PCG (:func:`pbanim.cloth.large_steps.modified_pcg` with
``precond="multigrid"``): the filter S stays outside (c = S P⁻¹ r), so the iterates stay in the constraint
subspace as with Jacobi, and the stopping test is the residual in the P⁻¹-norm (with a good P, close to the
A-norm of the error). Limiting cases: a grid of at most ``coarsest`` particles has one level (a direct solve);
A SPD (M > 0, −K PSD on the CG path) keeps every Galerkin A_ℓ SPD, so the Cholesky never fails.

Reference: P. Vaněk, J. Mandel, M. Brezina, "Algebraic multigrid by smoothed aggregation", Computing 56
(1996) (aggregation, Galerkin coarse operators); A. H. Baker, R. D. Falgout, T. V. Kolev, U. M. Yang,
"Multigrid smoothers for ultraparallel computing", SIAM J. Sci. Comput. 33 (2011) (ℓ1-Jacobi);
W. L. Briggs, V. E. Henson, S. F. McCormick, *A Multigrid Tutorial* (2000), ch. 3–5 (the V-cycle).
"""

from __future__ import annotations

import numpy as np
import scipy.linalg as sla
import scipy.sparse as sp

__all__ = ["Multigrid"]

class _Level:
    """One level: its CSR pattern (rows, indices, indptr), diagonal positions and the aggregation below it."""

    def __init__(self, n, rows, indices, indptr):
        self.n, self.rows, self.indices, self.indptr = n, rows, indices, indptr
        self.diag = np.flatnonzero(rows == indices)


class Multigrid:
    """The aggregation hierarchy of an m × m particle grid with the CSR pattern of ``pattern`` (module docstring).

    ``setup(data)`` takes the CSR data of A on the finest pattern; then ``__call__(r)`` applies one V-cycle."""

    def __init__(self, pattern, m: int, coarsest: int = 64, boost: float = 1.0, additive_top: bool = True) -> None:
        self.boost, self.additive_top = boost, additive_top
        lv = _Level(pattern.n, pattern.rows.astype(np.int64), pattern.indices.astype(np.int64), pattern.indptr)
        self.levels, self.P, self.R = [lv], [], []
        for _ in range(32):                                     # m halves each level: ≤ log₂ m + 1 levels
            if m * m <= coarsest:
                break
            mc = (m + 1) // 2
            i, j = np.divmod(np.arange(m * m), m)
            agg = (i // 2) * mc + j // 2
            dof = (3 * agg[:, None] + np.arange(3)).ravel()     # coarse coordinate of each fine one
            nc = 3 * mc * mc
            self.P.append(sp.csr_matrix((np.ones(lv.n), (np.arange(lv.n), dof)), shape=(lv.n, nc)))
            key = dof[lv.rows] * nc + dof[lv.indices]
            uniq, pos = np.unique(key, return_inverse=True)
            rows = uniq // nc
            self.R.append(sp.csr_matrix((np.ones(len(key)), (pos, np.arange(len(key)))), shape=(len(uniq), len(key))))
            indptr = np.concatenate([[0], np.cumsum(np.bincount(rows, minlength=nc))])
            lv = _Level(nc, rows, uniq - rows * nc, indptr)
            self.levels.append(lv)
            m = mc
        self.Pt = [P.T.tocsr() for P in self.P]

    def setup(self, data) -> None:
        """The matrices of every level from the finest CSR data (one sparse product per level) and the
        coarsest level's Cholesky factor."""
        self.A, self.dinv = [], []
        for k, lv in enumerate(self.levels):
            if k:
                data = self.R[k - 1] @ data
            self.A.append(sp.csr_matrix((data, lv.indices, lv.indptr), shape=(lv.n, lv.n)))
            self.dinv.append(1.0 / np.bincount(lv.rows, np.abs(data), minlength=lv.n))
        c, low = sla.cho_factor(self.A[-1].toarray(), check_finite=False)
        self.coarse_inv = sla.cho_solve((c, low), np.eye(len(c)), check_finite=False)   # ≤ 192², applied by a product

    def __call__(self, r) -> np.ndarray:
        if self.additive_top and len(self.levels) > 1:         # B = D₁⁻¹ + P B₁ Pᵀ: no product with the fine A
            return self.dinv[0] * r + self.P[0] @ self._cycle(1, self.Pt[0] @ r)
        return self._cycle(0, r)

    def _cycle(self, k, r):
        if k == len(self.levels) - 1:
            return self.coarse_inv @ r
        A, dinv = self.A[k], self.dinv[k]
        x = dinv * r
        xc = self._cycle(k + 1, self.Pt[k] @ (r - A @ x))
        x += self.boost * (self.P[k] @ xc)
        x += dinv * (r - A @ x)
        return x
