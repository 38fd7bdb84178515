"""The large step's system of a spring cloth in one pass: A = M − hD − h²K and b = h (f + K u) without K or D.

Baraff & Witkin's step (:mod:`pbanim.cloth.large_steps`) needs, per step, the CSR data of

    A = M − h D − h² K      and the right-hand side      b = h (f₀ + K u),   u = h v₀ + y,

(K here the symmetric K of the CG solves: a compressed spring's transverse term clamped, the unsymmetric
damping term left out). The readable path builds K.data and D.data on the pattern (two gathers of every
stored entry), then A.data from them (three more passes) and K u by a sparse product. For a cloth of springs
every element is a pair (a, b) with d = x_a − x_b, ŵ = d/|d|, and its blocks are K_e = c cᵀ ⊗ B_K,
D_e = c cᵀ ⊗ B_D (c = (1, −1)), B_K = −(k ŵŵᵀ + s⁺ P), B_D = −k_d ŵŵᵀ, P = (𝟙 − ŵŵᵀ)/|d|, s = k C + k_d Ċ,
s⁺ = max(s, 0). So A's part from one spring is c cᵀ ⊗ B_A with

    B_A = −h B_D − h² B_K = α ŵŵᵀ + γ (𝟙 − ŵŵᵀ) = (α − γ) ŵŵᵀ + γ 𝟙,    α = h² k + h k_d,   γ = h² s⁺/|d|,

and the spring's share of f + K u at its first particle (minus it at the second) is a vector,

    g_a = −s ŵ − k (ŵ·Δu) ŵ − s⁺ (Δu − (ŵ·Δu) ŵ)/|d|,      Δu = u_a − u_b.

One pass over all springs of the sheet (every kind at once: structural, shear, bend) computes B_A (E, 3, 3)
and g (E, 3) from two gathers of the stacked per-particle [x, v, u]; A.data is then the pattern's single
gather (:meth:`pbanim.cloth.assembly.Pattern.data`'s layout: −B_A on the two off-diagonal blocks, Σ B_A + m
on the diagonal) and Σ g a signed incidence product. No K.data, no D.data, no sparse product.

It equals the readable assembly to roundoff (ORACLES J10: A.data and b within a few ulps of the largest
entry). The Newton iterations of :func:`pbanim.cloth.large_steps.newton_step` use it too (u = 0: b = h f).

Notation: E springs, N particles, T the particles some spring touches; ``src`` the gather's source
[−B_A (9E), Σ B_A + m (9T), 0].

Limiting cases: a particle no spring reaches keeps A's diagonal m (added after the gather); a cloth with
another condition kind (Baraff–Witkin triangles, hinges) or a spring pair shared by two elements has no
one-pass system (:func:`spring_system` returns None and the step takes the readable path).
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp

from .conditions import SpringCondition

__all__ = ["SpringStepSystem", "spring_system"]


_SYM = np.array([0, 1, 2, 1, 3, 4, 2, 4, 5])            # entry (i, j) of a symmetric 3 × 3 → its 6 components
_PAIRS = ((0, 0), (0, 1), (0, 2), (1, 1), (1, 2), (2, 2))


class SpringStepSystem:
    """All springs of a cloth stacked once; :meth:`terms` gives A.data and f + K u of one step.

    Arrays are component-major (a row per coordinate, a column per spring) and a block's 6 distinct entries
    are stored once: the gather of the pattern is re-indexed once to that layout."""

    def __init__(self, cloth) -> None:
        pat = cloth.pattern
        conds = cloth.conditions
        el = np.concatenate([c.elements for c in conds])
        self.a, self.b = el[:, 0].copy(), el[:, 1].copy()
        self.k = np.concatenate([c.k[:, 0] for c in conds])
        self.kd = np.concatenate([c.kd[:, 0] for c in conds])
        self.rest = np.concatenate([c.rest for c in conds])
        self.damped = bool(np.any(self.kd))
        E, N = len(el), cloth.n // 3
        self.E = E
        touched = np.unique(el.ravel())                       # the rows of the pattern's incidence (sorted)
        T = self.T = len(touched)
        self.incidence = pat.incidence                        # touched particles × springs, |c|
        # the pattern's gather reads [−B (E, 9), Σ B (T, 9), 0]; here [−B (6, E), Σ B + m (6, T), 0]
        g = pat.gather.copy()
        n_old = 9 * E + 9 * T
        off, dg = g < 9 * E, (g >= 9 * E) & (g < n_old)
        g[off] = _SYM[g[off] % 9] * E + g[off] // 9
        t, q = np.divmod(g[dg] - 9 * E, 9)
        g[dg] = 6 * E + _SYM[q] * T + t
        g[g >= n_old] = 6 * E + 6 * T
        self.gather = g
        self.n_src = 6 * E + 6 * T + 1
        m = cloth.sheet.masses[touched]
        self.mass_diag = np.stack([m if i == j else np.zeros(T) for i, j in _PAIRS])
        lone = np.ones(N, bool)
        lone[touched] = False
        lone3 = np.repeat(lone, 3)
        self.lone_diag, self.lone_mass = pat.diag[lone3], cloth.mass3[lone3]
        sign = np.concatenate([np.ones(E), -np.ones(E)])
        self.signed = sp.csr_matrix((sign, (np.concatenate([self.a, self.b]), np.tile(np.arange(E), 2))),
                                    shape=(N, E))
        self.fext = cloth.fext.reshape(-1, 3)

    def terms(self, x, v, u, h):
        """(A.data on the cloth's pattern, f + K u (n,)) at positions x, velocities v (N, 3) and u (n,)."""
        X = np.concatenate([x.T, v.T, np.reshape(u, (-1, 3)).T])             # (9, N)
        dX = np.take(X, self.a, axis=1) - np.take(X, self.b, axis=1)         # (9, E): d, Δv, Δu
        d, du = dX[:3], dX[6:]
        length = np.sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2])
        inv = 1.0 / length
        w = d * inv
        s = self.k * (length - self.rest)
        if self.damped:
            s += self.kd * (w[0] * dX[3] + w[1] * dX[4] + w[2] * dX[5])
        spl = np.maximum(s, 0.0) * inv                                       # s⁺/|d|
        wdu = w[0] * du[0] + w[1] * du[1] + w[2] * du[2]
        g = ((spl - self.k) * wdu - s) * w - spl * du                       # (3, E): f + K u at the first end
        gamma = (h * h) * spl
        c = h * h * self.k + h * self.kd - gamma
        E = self.E
        src = np.empty(self.n_src)
        BA = src[:6 * E].reshape(6, E)
        for r, (i, j) in enumerate(_PAIRS):
            np.multiply(w[i], w[j], out=BA[r])
        BA *= c
        BA[0] += gamma
        BA[3] += gamma
        BA[5] += gamma
        diag = src[6 * E:-1].reshape(6, -1)
        for r in range(6):                                                   # Σ over a particle's springs
            diag[r] = self.incidence @ BA[r]
        diag += self.mass_diag
        np.negative(BA, out=BA)
        src[-1] = 0.0
        data = np.take(src, self.gather)
        if len(self.lone_diag):
            data[self.lone_diag] += self.lone_mass
        rhs = (self.signed @ g.T) + self.fext
        return data, rhs.ravel()


def spring_system(cloth):
    """The cloth's :class:`SpringStepSystem` (built once, kept on the cloth), or None when the cloth has a
    condition kind other than springs or a spring block shared with another element (module docstring)."""
    cached = cloth.__dict__.get("_spring_system", False)
    if cached is not False:
        return cached
    pat = cloth.pattern
    ok = (len(cloth.conditions) > 0 and all(isinstance(c, SpringCondition) for c in cloth.conditions)
          and pat.pair_kinds == list(range(len(cloth.conditions))))
    out = SpringStepSystem(cloth) if ok else None
    cloth.__dict__["_spring_system"] = out
    return out
