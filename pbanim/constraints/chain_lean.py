"""The linear-time solve of λ for a chain on reused buffers: the lean twin of ``solve_lambda(..., "linear")``
for a chain numbered along itself (chapter 03; ORACLES B11).

For a chain whose leaves-first order is its own numbering, A = JWJᵀ is tridiagonal (diagonal d, sub-diagonal
e, the assembly's block values W_p G_{r,p}·G_{s,p}) and the readable solver (``solvers._linear`` with
``solvers._refined``) computes, with c = −J̇q̇ − k_s C − k_d Ċ,

    r = c − J(WQ),   A = L D Lᵀ (LAPACK dpttrf),   λ₀ = A⁻¹r,   λ = λ₀ + A⁻¹(r − J(W(Jᵀλ₀))),
    Q_C = Jᵀλ,   q̈ = W(Q + Q_C)

(Baraff 1996, "Linear-time dynamics using Lagrange multipliers"; one step of fixed-precision refinement in
factored form, Skeel 1980). This module does the same operations in the same order, so every λ, Q_C and q̈
is the readable one bit for bit; what it leaves out is the per-call packaging around them: the sparse
products go to scipy's kernel through ``pbanim.sparse_kernel`` (Jᵀ read as CSC on J's own arrays) into two
scratch vectors kept on the constraint set, the refinement's right-hand side is solved in place, and the
vanishing-pivot test D_i < 1e-13·d_i is done by two reductions (min D against 1e-13·max d, which rounds to the
largest threshold) and entry by entry only when those do not clear it.

Limits: chains in their natural order (``Structure.natural``) with a tridiagonal A (bandwidth 1) and
block-valued assemblies; anything else, and a vanishing pivot (redundant rows: the minimum-norm fallback),
is handed back to the readable solver (:func:`chain_lambda` returns None).
"""

from __future__ import annotations

import numpy as np
import scipy.linalg as sla

from ..sparse_kernel import product_of
from .solvers import _PIVOT, _checked_rhs

__all__: list[str] = []   # internal: solve_lambda's lean path

_dpttrf, _dpttrs = sla.lapack.dpttrf, sla.lapack.dpttrs


def applies(cset, asm) -> bool:
    """The lean path covers this set and assembly (natural-order tridiagonal chain, block values, CSC Jᵀ)."""
    st = cset.structure
    return (st.kind == "chain" and st.bandwidth == 1 and st.natural and asm.vals is not None
            and asm.JT is not None and asm.JT.format == "csc")


def _scratch(cset):
    bufs = cset.__dict__.get("_chain_lean_bufs")
    if bufs is None:
        bufs = cset._chain_lean_bufs = (np.empty(cset.n), np.empty(cset.m))
    return bufs


def chain_lambda(cset, asm, J, W: np.ndarray, Q: np.ndarray, c: np.ndarray):
    """(λ, Q_C, q̈, r) as the readable linear solver computes them, or None where it would fall back (a
    vanishing pivot). Raises NonFiniteResult on a non-finite r, as the readable path does."""
    t_n, t_m = _scratch(cset)
    JT = asm.JT
    Jx = product_of("csr", (J.data, J.indices, J.indptr), J.shape)
    JTx = product_of("csc", (JT.data, JT.indices, JT.indptr), JT.shape)
    np.multiply(W, Q, out=t_n)
    r = _checked_rhs(np.subtract(c, Jx(t_n, t_m)), c, Q)   # r = c − J(WQ), a fresh array (the solution keeps it)
    d, e = cset.tridiagonal(asm)
    D, E, info = _dpttrf(d, e)                    # copies d and e (the assembly's arrays)
    if info != 0 or (D.min() < _PIVOT * d.max() and np.any(D < _PIVOT * d)):
        return None
    lam = _dpttrs(D, E, r)[0]                     # λ₀, a fresh array
    JTx(lam, t_n)
    t_n *= W                                      # W Jᵀλ₀
    np.subtract(r, Jx(t_n, t_m), out=t_m)         # r − J(W(Jᵀλ₀))
    lam += _dpttrs(D, E, t_m, overwrite_b=1)[0]
    Q_C = JTx(lam, np.empty(cset.n))
    qdd = Q + Q_C
    qdd *= W
    return lam, Q_C, qdd, r
