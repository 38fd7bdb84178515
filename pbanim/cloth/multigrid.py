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
* **pins**: the couplings of pinned particles are dropped from the A the cycle is built from (the filter S
  removes those rows and columns from the CG anyway); kept, they give B A eigenvalues up to ~8 on the free
  coordinates (a 16 × 16 sheet: cond(B A) 114 → 12 with the line smoother below);
* **the smoother** of the finest level: *line Gauss–Seidel*. A spring holds its two particles along its own
  direction, so the x coordinates of a grid row are coupled ~10× more strongly along the row than across it
  (the shear springs, 0.1 k, couple across), the y coordinates along the columns: the anisotropy that
  point smoothers (Jacobi, ℓ1-Jacobi) leave to CG. The block of a grid line is all 3 coordinates of its
  particles (banded: a row couples to the next two particles of its line, bandwidth 8), solved exactly by a
  banded Cholesky factor. The lines of an axis are coloured by index mod (reach + 1) (reach = 2, the bend
  springs), so the lines of one colour never couple and each colour is one block solve of its rows'
  residual: a *block Gauss–Seidel* sweep over the colours, rows then columns. Block Gauss–Seidel with exact
  blocks contracts in the A-norm for every SPD A, and the sweep after the coarse correction is the adjoint
  of the one before (colours and axes in reverse), so the cycle B is symmetric with the spectrum of B A in
  (0, 1] (measured 0.23 … 1 on 16 × 16): CG stays valid. A line block that is not positive definite (A not
  SPD) fails its Cholesky: ``setup`` raises ``numpy.linalg.LinAlgError``. Coarser levels, where the cost is
  the calls and not the flops, smooth by ℓ1-Jacobi, d_i = Σ_j |a_ij| (it contracts in the A-norm for every
  SPD A, Baker, Falgout, Kolev & Yang 2011; plain damped Jacobi, ω = ⅔ on a_ii, diverges on the cloth);
  the coarsest level (≤ ``coarsest`` particles) is solved by its inverse from a dense Cholesky.

``smoother="l1-jacobi"`` is the cycle with ℓ1-Jacobi on every level and, by default, additive on the
finest (B = D₁⁻¹ + P B₁ Pᵀ, spectrum of B A in (0, 2]), kept as the baseline the benchmark measures against.
CG iterations to ε = 10⁻² on the benchmark's sheet at h = 1/60 s, six steps into the fall (to 10⁻⁶ in
brackets):

=======  ==============  ======================  =====================
N        Jacobi          ℓ1-Jacobi, additive     line Gauss–Seidel
=======  ==============  ======================  =====================
16       46  (166)       22  (130)               2  (8)
32       89  (276)       37  (187)               3  (12)
64                       47  (236)               4  (16)
=======  ==============  ======================  =====================

A line V-cycle costs ~4 products with the fine A (each sweep one, in row blocks) and 12 banded solves,
against none for the additive ℓ1 cycle: at N = 64 it costs 5.3 ms against 0.4 ms for a product with A,
so the step does not get cheaper there (60 steps at h = 1/60 s, CG to 10⁻²: 4.45 CPU s against 4.41,
spreads 4.29–4.77 and 3.68–4.96, alternating rounds); at N = 128 it does (a step at 10⁻³: 0.92 s against
1.06 s, Jacobi 3.45 s). The count still grows with N, slower in absolute terms (to 10⁻³: 4, 5, 7, 11 at
N = 16 … 128, against 46, 67, 88, 104): the piecewise-constant aggregates are the remaining weakness
(line smoothing on the second level too: 11 → 9 at N = 128, no faster in time).

It is applied inside B&W's modified PCG (:func:`pbanim.cloth.large_steps.modified_pcg` with
``precond="multigrid"``): the filter S stays outside (c = S P⁻¹ r), so the iterates stay in the constraint
subspace as with Jacobi, and the stopping test is the residual in the P⁻¹-norm (with a good P, close to the
A-norm of the error). Limiting cases: a grid of at most ``coarsest`` particles has one level (a direct solve);
A SPD (M > 0, −K PSD on the CG path) keeps every Galerkin A_ℓ and every line block SPD, so no Cholesky fails.

Reference: P. Vaněk, J. Mandel, M. Brezina, "Algebraic multigrid by smoothed aggregation", Computing 56
(1996) (aggregation, Galerkin coarse operators); A. H. Baker, R. D. Falgout, T. V. Kolev, U. M. Yang,
"Multigrid smoothers for ultraparallel computing", SIAM J. Sci. Comput. 33 (2011) (ℓ1-Jacobi);
W. L. Briggs, V. E. Henson, S. F. McCormick, *A Multigrid Tutorial* (2000), ch. 3–5 (the V-cycle, line
relaxation for anisotropic problems); U. Trottenberg, C. W. Oosterlee, A. Schüller, *Multigrid* (2001),
§5.1 (alternating line Gauss–Seidel).
"""

from __future__ import annotations

import numpy as np
import scipy.linalg as sla
import scipy.sparse as sp
from scipy.linalg.lapack import dpbtrf, dpbtrs

__all__ = ["Multigrid"]

class _Level:
    """One level: its CSR pattern (rows, indices, indptr), diagonal positions and the aggregation below it."""

    def __init__(self, n, rows, indices, indptr):
        self.n, self.rows, self.indices, self.indptr = n, rows, indices, indptr
        self.diag = np.flatnonzero(rows == indices)


class _LineColour:
    """The lines of one colour along one grid axis on one level: the rows they own (CSR gather) and the band
    of their block-diagonal part (upper form of ``cholesky_banded``), both positions into the level's data."""

    def __init__(self, lv, dofs):
        self.dofs = dofs
        loc = np.full(lv.n, -1, np.int64)
        loc[dofs] = np.arange(len(dofs))
        counts = lv.indptr[dofs + 1] - lv.indptr[dofs]
        self.sel = np.concatenate([np.arange(lv.indptr[d], lv.indptr[d + 1]) for d in dofs]) if len(dofs) else \
            np.zeros(0, np.int64)
        self.indices = lv.indices[self.sel].astype(np.int32)
        self.indptr = np.concatenate([[0], np.cumsum(counts)]).astype(np.int32)
        r, c = loc[lv.rows[self.sel]], loc[lv.indices[self.sel]]
        up = c >= r                                         # c = −1: outside these lines
        self.u = int((c[up] - r[up]).max())
        self.bsel, self.flat = self.sel[up], (self.u + r[up] - c[up]) * len(dofs) + c[up]
        self.shape = (len(dofs), lv.n)
        self.band = np.zeros((self.u + 1, len(dofs)))


def _line_colours(lv, m):
    """The line smoother's blocks of an m × m level: all three coordinates of a grid line (row, then column) in
    one block, the lines of an axis coloured by index mod (reach + 1), reach = the farthest line a row couples
    to, so that lines of one colour never couple: each colour is one exact (banded) block solve."""
    dof = np.arange(lv.n)
    i, j = np.divmod(dof // 3, m)
    out = []
    for line, along in ((i, j), (j, i)):
        reach = int(np.abs(line[lv.rows] - line[lv.indices]).max())
        order = np.lexsort((dof % 3, along, line))           # by line, position along it, coordinate
        out.append([_LineColour(lv, order[line[order] % (reach + 1) == c]) for c in range(reach + 1)])
    return out


class Multigrid:
    """The aggregation hierarchy of an m × m particle grid with the CSR pattern of ``pattern`` (module docstring).

    ``setup(data)`` takes the CSR data of A on the finest pattern; then ``__call__(r)`` applies one V-cycle.
    ``smoother``: "line" (symmetric line Gauss–Seidel over coloured grid lines, both axes) or "l1-jacobi";
    ``pinned``: particles whose couplings are dropped from the preconditioner's A (the filter removes them)."""

    def __init__(self, pattern, m: int, coarsest: int = 64, boost: float = 1.0, additive_top: bool | None = None,
                 smoother: str = "line", pinned=(), line_levels: int = 1) -> None:
        self.boost, self.smoother = boost, smoother
        self.additive_top = (smoother != "line") if additive_top is None else additive_top
        lv = _Level(pattern.n, pattern.rows.astype(np.int64), pattern.indices.astype(np.int64), pattern.indptr)
        pin = np.zeros(pattern.n, bool)
        pin.reshape(-1, 3)[np.asarray(pinned, dtype=np.intp)] = True
        self.pin_mask = np.flatnonzero((pin[lv.rows] | pin[lv.indices]) & (lv.rows != lv.indices))
        self.levels, self.P, self.R, self.lines = [lv], [], [], []
        for _ in range(32):                                     # m halves each level: ≤ log₂ m + 1 levels
            if m * m <= coarsest:
                break
            if smoother == "line" and len(self.levels) <= line_levels:
                self.lines.append(_line_colours(lv, m))
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
        """The matrices of every level from the finest CSR data (one sparse product per level), the line
        blocks' banded Cholesky factors and the coarsest level's inverse. Raises ``numpy.linalg.LinAlgError``
        when a block is not positive definite (A not SPD)."""
        if len(self.pin_mask):
            data = data.copy()
            data[self.pin_mask] = 0.0
        self.A, self.dinv, self.blocks = [], [], []
        for k, lv in enumerate(self.levels):
            if k:
                data = self.R[k - 1] @ data
            self.A.append(sp.csr_matrix((data, lv.indices, lv.indptr), shape=(lv.n, lv.n)))
            if k < len(self.lines):
                self.blocks.append([[self._factor(data, lc) for lc in axis] for axis in self.lines[k]])
                self.dinv.append(None)
            else:
                self.dinv.append(1.0 / np.bincount(lv.rows, np.abs(data), minlength=lv.n))
        self.coarse = sla.cho_factor(self.A[-1].toarray(), check_finite=False)    # ≤ 192²: two triangular
        # solves per cycle (forming the inverse, cho_solve against 𝟙, cost ~3 ms a setup at N = 64)

    @staticmethod
    def _factor(data, lc):
        ab = lc.band                                        # zero outside the band's entries, kept
        ab.ravel()[lc.flat] = data[lc.bsel]
        cb, info = dpbtrf(ab, lower=0)
        if info:
            raise np.linalg.LinAlgError(f"a line block is not positive definite (LAPACK info {info})")
        return lc.dofs, sp.csr_matrix((data[lc.sel], lc.indices, lc.indptr), shape=lc.shape), cb

    def __call__(self, r) -> np.ndarray:
        if self.additive_top and len(self.levels) > 1 and self.smoother != "line":
            return self.dinv[0] * r + self.P[0] @ self._cycle(1, self.Pt[0] @ r)   # D₁⁻¹ + P B₁ Pᵀ
        return self._cycle(0, r)

    def _smooth(self, k, r, x, backward):
        """Line Gauss–Seidel: each colour's lines solved exactly against the current residual of their rows;
        forward: rows then columns, colours in order; backward: the reverse (its adjoint)."""
        seq = [b for axis in self.blocks[k] for b in axis]
        if backward:
            seq = seq[::-1]
        elif x is None:                                     # from x = 0: the first colour's residual is r
            x = np.zeros_like(r)
            dofs, _, cb = seq[0]
            x[dofs] = dpbtrs(cb, r[dofs], lower=0, overwrite_b=1)[0]
            seq = seq[1:]
        for dofs, Ar, cb in seq:
            x[dofs] += dpbtrs(cb, r[dofs] - Ar @ x, lower=0, overwrite_b=1)[0]
        return x

    def _cycle(self, k, r):
        if k == len(self.levels) - 1:
            return sla.cho_solve(self.coarse, r, check_finite=False)
        A, line = self.A[k], k < len(self.blocks)
        x = self._smooth(k, r, None, False) if line else self.dinv[k] * r
        xc = self._cycle(k + 1, self.Pt[k] @ (r - A @ x))
        x += self.boost * (self.P[k] @ xc)
        if line:
            return self._smooth(k, r, x, True)
        x += self.dinv[k] * (r - A @ x)
        return x
