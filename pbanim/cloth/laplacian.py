"""A constant preconditioner for the large step: the isotropic bound of every spring, factored once.

The large step's A = M − hD − h²K (:mod:`pbanim.cloth.large_steps`) gets from a spring (a, b) the blocks
c cᵀ ⊗ B_A, c = (1, −1), with (ORACLES J10)

    B_A = α ŵŵᵀ + γ (𝟙 − ŵŵᵀ),     α = h² k + h k_d,     γ = h² s⁺/|d| = h² k (1 − L₀/|d|)⁺ (undamped),

which rotates with the sheet (ŵ the spring's direction). Replacing every B_A by its isotropic bound α 𝟙
gives

    P = (M + L_α) ⊗ I₃,      L_α = Σ_springs α_e (e_a − e_b)(e_a − e_b)ᵀ   (the α-weighted graph Laplacian),

constant in time: three identical scalar systems of N² unknowns, factored once per (cloth, h) and applied as
one solve with 3 right-hand sides (the per-particle rows of r are the x, y, z columns). This is the matrix
of projective dynamics (Bouaziz et al. 2014; Liu et al. 2013's "fast mass-springs") used here as a CG
preconditioner, not as the solver. Since γ ≤ h² k ≤ α (the clamp keeps s⁺ ≥ 0, and k_d ≥ 0), every
spring's P-block minus its A-block is PSD, so P ⪰ A ⪰ M on the filtered subspace: the eigenvalues of P⁻¹A
lie in (0, 1]; the small ones are the sheet's transverse modes (a flat sheet has γ ≈ 0 across).

Pins: P's rows and columns of a pinned particle are decoupled (its diagonal m, its springs' α kept on the
free ends' diagonals), so P = P_FF ⊕ M_pinned and S P⁻¹ S = P_FF⁻¹ on the free particles (S the filter):
the Dirichlet Laplacian, SPD. Contacts project rows (S = 𝟙 − nnᵀ): S P⁻¹ S stays positive definite on the
range of S. The factor: P_FF in the grid's natural order is banded (half-bandwidth the reach of the
longest spring in particle indices, 2N for the bend springs of an N × N sheet), factored by LAPACK's band
Cholesky once (N = 64: ~60 ms) and solved with 3 right-hand sides per CG iteration (~1.5 ms, against ~2.4 ms
for a sparse LU with a minimum-degree order).

Measured at N = 64 on the benchmark's sheet (60 steps of h = 1/60 s from rest, CG to ε = 10⁻²): 15.7 mean
CG iterations against the line multigrid's 4.55, but no per-step setup (the multigrid's Galerkin products
and line factors, 14–21 ms) and a cheaper P⁻¹ (1.5 ms against 6–8 ms): the step costs ~3× less
(:mod:`pbanim.bench._cloth_realtime` prints both).

Other condition kinds (Baraff–Witkin triangles, hinges) get the same construction with every pair of an
element's particles weighted by h² max(k) + h max(k_d) of that element: a bound in spirit only (their
stiffness is not a spring's), kept so that every cloth has the option.

Reference: S. Bouaziz, S. Martin, T. Liu, L. Kavan, M. Pauly, "Projective dynamics", SIGGRAPH 2014, §4;
T. Liu, A. W. Bargteil, J. F. O'Brien, L. Kavan, "Fast simulation of mass-spring systems", SIGGRAPH Asia
2013, §4 (the constant system matrix M + h² L); Baraff & Witkin 1998, §5.3 (the filter).
"""

from __future__ import annotations

import numpy as np
from scipy.linalg.lapack import dpbtrf, dpbtrs

from ..errors import InvalidInput

__all__ = ["LaplacianPreconditioner"]


def _edges(cloth, h):
    """(a, b, weight) of every coupled particle pair: springs' α = h²k + hk_d, other elements' pairs."""
    a, b, w = [], [], []
    for c in cloth.conditions:
        el = c.elements
        alpha = h * h * c.k.max(axis=1) + h * c.kd.max(axis=1)
        for i in range(el.shape[1]):
            for j in range(i + 1, el.shape[1]):
                a.append(el[:, i])
                b.append(el[:, j])
                w.append(alpha)
    if not a:
        return np.zeros(0, np.intp), np.zeros(0, np.intp), np.zeros(0)
    return np.concatenate(a), np.concatenate(b), np.concatenate(w)


class LaplacianPreconditioner:
    """r ↦ P⁻¹r with P = (M + L_α) ⊗ I₃ of the cloth at step h (module docstring), pinned rows decoupled."""

    def __init__(self, cloth, h: float) -> None:
        if not h > 0:
            raise InvalidInput(f"LaplacianPreconditioner: h must be > 0, got {h}")
        N = cloth.n // 3
        a, b, w = _edges(cloth, h)
        if np.any(w < 0) or not np.isfinite(w).all():
            raise InvalidInput("LaplacianPreconditioner: stiffness and damping must be finite and ≥ 0")
        pinned = np.zeros(N, bool)
        pinned[cloth.pinned] = True
        diag = np.asarray(cloth.sheet.masses, dtype=float).copy()
        np.add.at(diag, a[~pinned[a]], w[~pinned[a]])          # a spring's α on each free end's diagonal
        np.add.at(diag, b[~pinned[b]], w[~pinned[b]])
        both = ~pinned[a] & ~pinned[b]                           # couplings between free particles only
        lo, hi, wf = np.minimum(a, b)[both], np.maximum(a, b)[both], w[both]
        bw = int((hi - lo).max()) if len(lo) else 0
        ab = np.zeros((bw + 1, N))                               # LAPACK's upper band: ab[bw + i − j, j] = P_ij
        ab[bw] = diag
        np.add.at(ab, (bw - (hi - lo), hi), -wf)
        factor, info = dpbtrf(ab, lower=0)
        if info != 0:
            raise np.linalg.LinAlgError(f"LaplacianPreconditioner: P is not positive definite (info {info})")
        self.h, self.bandwidth, self.factor = float(h), bw, factor

    def __call__(self, r) -> np.ndarray:
        """P⁻¹ r for r of 3N entries (particle-major: x, y, z of particle 0, then 1, …)."""
        x, info = dpbtrs(self.factor, np.asfortranarray(np.reshape(r, (-1, 3))), lower=0)
        return x.ravel()
