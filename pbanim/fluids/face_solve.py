"""The exact inverse of a face operator on a box without obstacles, by fast diagonalization (chapter 09; the
lean CG's preconditioner of :func:`pbanim.fluids.diffusion.diffuse_velocity`).

On a box without obstacles the implicit viscous operator of velocity component i,

    A = I − a ∇²,   ∇² = (K₀ ⊗ 𝟙 ⊗ …) + (𝟙 ⊗ K₁ ⊗ …) + …   on the free faces,

is a Kronecker sum of one-dimensional second differences K_ax / Δx²: along a periodic axis the circulant
(1, −2, 1); along axis i itself (walls) the faces strictly between the two wall faces, which are held at 0
(Dirichlet: (1, −2, 1) with the wall values dropped); across a wall half a cell away the ghost −u doubles
into −3 on the end rows (the sliding wall's 2w is the affine part, on the right-hand side). Each K_ax is
symmetric: K_ax = V Λ Vᵀ (a dense eigendecomposition of an n × n matrix, once), and

    A⁻¹ v = V₀ ⊗ V₁ … [ (V₀ᵀ ⊗ V₁ᵀ … v) / (1 − a Σ_ax λ_ax / Δx²) ]

costs 2d products of an n × n matrix with the field, against the ~25 CG iterations the diagonal needs on the
lid cavity's 64². As CG's preconditioner it makes CG stop after one iteration, at the same test ‖r − A x‖₂ ≤
tol ‖r‖₂: the answer differs from the diagonal CG's by at most the tolerance (ORACLES E26). The closed faces
(A = I there) are passed through.

The inverse is checked on a random field when it is built (‖A(M⁻¹ x) − x‖∞ ≤ 1e-10 ‖x‖∞): a grid with
obstacles, or anything the Kronecker form does not describe, has no inverse here and the caller keeps the
diagonal.

==========  ==============  ==========================================
symbol      code            meaning
==========  ==============  ==========================================
a           ``a``           νΔt
K_ax        ``K``           1-D second difference along axis ax (Δx² units)
V, Λ        ``V, lam``      its eigenvectors and eigenvalues
==========  ==============  ==========================================

Limiting cases: a = 0 gives A = I and M⁻¹ = I; one free face along an axis gives K = (−3) or (−2).

References: R. E. Lynch, J. R. Rice, D. H. Thomas, Direct solution of partial difference equations by tensor
product methods, Numer. Math. 6 (1964) (fast diagonalization).
"""

from __future__ import annotations

import numpy as np

__all__: list = []

MAX_SIDE = 1024          # an axis longer than this is not diagonalized densely (n² memory, n³ once)


def _second_difference(m: int, periodic: bool, ghost_ends: bool) -> np.ndarray:
    """K (m × m): −2 on the diagonal, 1 beside it; periodic wraps; ``ghost_ends`` makes the end rows −3."""
    K = -2.0 * np.eye(m) + np.eye(m, k=1) + np.eye(m, k=-1)
    if periodic:
        K[0, -1] += 1.0
        K[-1, 0] += 1.0
    elif ghost_ends:
        K[0, 0] -= 1.0
        K[-1, -1] -= 1.0
    return K


class FaceInverse:
    """M⁻¹ = A⁻¹ for the :class:`~pbanim.fluids.diffusion.FaceOperator` ``A`` (module docstring); ``ok`` is
    False when the grid has obstacles or the check on a random field fails (then do not use it)."""

    def __init__(self, A) -> None:
        g, i = A.grid, A.i
        shape = A.diag.shape
        self.ok = False
        if g.has_obstacles or max(shape) > MAX_SIDE:
            return
        inner, bases, lam = [], [], 0.0
        for ax in range(g.dim):
            held = ax == i and not g.periodic[ax]
            inner.append(slice(1, -1) if held else slice(None))
            m = shape[ax] - 2 if held else shape[ax]
            if m < 1:
                return
            w, V = np.linalg.eigh(_second_difference(m, bool(g.periodic[ax]), not held))
            bases.append(V)
            lam = np.add.outer(lam, w) if ax else w
        self.inner, self.bases = tuple(inner), bases
        self.denom = 1.0 - A.a * lam / g.dx ** 2
        x = np.random.default_rng(0).standard_normal(shape)
        x[A.closed] = 0.0
        self.ok = bool(np.isfinite(self.denom).all() and np.all(self.denom > 0)
                       and np.abs(A(self(x)) - x).max() <= 1e-10 * np.abs(x).max())

    def _along(self, v: np.ndarray, transpose: bool) -> np.ndarray:
        if len(self.bases) == 2:                    # V₀ᵀ v V₁ and V₀ w V₁ᵀ: two products, no axis moves
            V0, V1 = self.bases
            return V0.T @ v @ V1 if transpose else V0 @ v @ V1.T
        for ax, V in enumerate(self.bases):
            v = np.moveaxis(np.tensordot(V.T if transpose else V, v, axes=([1], [ax])), 0, ax)
        return v

    def __call__(self, v: np.ndarray) -> np.ndarray:
        out = v.copy()                              # the closed faces: A = I there
        out[self.inner] = self._along(self._along(v[self.inner], True) / self.denom, False)
        return out
