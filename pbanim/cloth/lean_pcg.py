"""The lean twin of Baraff & Witkin's modified PCG (:func:`pbanim.cloth.large_steps._pcg`): the same iteration,

    q = S(A c);  α = δ/(cᵀq);  Δv += α c;  r −= α q;  s = P⁻¹ r;  δ' = δ;  δ = rᵀs;  c = S(s + (δ/δ') c),

with the same floating-point operations in the same order, so the same iterates bit for bit (ORACLES J13),
but with less work around them per iteration:

* A c by scipy's own CSR kernel into a buffer zeroed first — what ``A @ c`` computes (scipy's product is that
  kernel into a zeroed result) without its type dispatch and checks (~15 µs a call: a fifth of the product of
  the 24 × 24 drape's A);
* the filter S by flat coordinate indices computed once per step (pins zeroed, contact rows projected off
  their normal by the same ``einsum`` on the same (C, 3) rows);
* α c, α q, β c and the Jacobi P⁻¹ r = r / diag A into preallocated buffers (a product or a sum into ``out``
  gives the same number as into a fresh array; x·y = y·x in IEEE arithmetic).

``cloth.lean_path = False`` makes :func:`pbanim.cloth.large_steps.large_step` and ``newton_step`` take the
readable ``_pcg``; ``modified_pcg`` with a general S (3 × 3 blocks) always does.

Limits: A must be CSR with sorted or unsorted indices alike (the kernel reads them as stored); the product is
:func:`pbanim.sparse_kernel.csr_product` (``A @ c`` where scipy's kernel is not importable: the same numbers).

References: Baraff & Witkin, "Large steps in cloth simulation", SIGGRAPH 1998, §5.3 (Fig. 2).
"""

from __future__ import annotations

import numpy as np

from ..sparse_kernel import csr_product


class _LeanFilter:
    """S of a :class:`pbanim.cloth.large_steps._Filter` (pins and contacts) on flat coordinate indices."""

    def __init__(self, filt) -> None:
        three = np.arange(3)
        self.cf = (3 * filt.contact[:, None] + three).ravel()
        self.pf = (3 * filt.pinned[:, None] + three).ravel()
        self.normals = filt.normals
        self.has_contacts = len(filt.contact) > 0

    def __call__(self, r):
        """S r in place (r flat and contiguous); returns r."""
        if self.has_contacts:
            rc = r.take(self.cf).reshape(-1, 3)
            rc -= np.einsum("ij,ij->i", rc, self.normals)[:, None] * self.normals
            r[self.cf] = rc.ravel()
        r[self.pf] = 0.0
        return r


def lean_pcg(A, b, filt, z, tol, max_iter, prec, dot):
    """(Δv, iterations, residual, converged) of B&W's modified PCG, bit for bit those of the readable ``_pcg``
    (``filt`` a pins-and-contacts ``_Filter``; ``prec`` r ↦ P⁻¹r or None for Jacobi; ``dot`` its aᵀb)."""
    S, mv = _LeanFilter(filt), csr_product(A)
    if prec is None:
        dinv = 1.0 / A.diagonal()

        def pinv(r, out):
            return np.multiply(dinv, r, out=out)
    else:
        def pinv(r, out):
            return prec(r)
    n = len(b)
    q, tmp, sbuf = np.empty(n), np.empty(n), np.empty(n)
    x = np.zeros_like(b) if z is None else z.copy()
    fb = S(b.copy())
    if z is None or not z.any():
        r = fb.copy()
        c = S(pinv(r, np.empty(n)).copy() if prec is not None else pinv(r, np.empty(n)))
        delta0 = delta = dot(r, c)
    else:
        delta0 = dot(fb, pinv(fb, np.empty(n)))
        r = S(b - mv(x, q))
        c = S(pinv(r, np.empty(n)).copy() if prec is not None else pinv(r, np.empty(n)))
        delta = dot(r, c)
    if delta0 == 0.0 or delta <= tol * tol * delta0:
        res = 0.0 if delta0 == 0.0 else float(np.sqrt(max(delta, 0.0) / delta0))
        return x, 0, res, True
    it = 0
    for it in range(1, max_iter + 1):
        S(mv(c, q))
        cq = dot(c, q)
        if not cq > 0.0:
            delta = np.inf
            break
        alpha = delta / cq
        x += np.multiply(alpha, c, out=tmp)
        r -= np.multiply(alpha, q, out=tmp)
        s = pinv(r, sbuf)
        delta_old, delta = delta, dot(r, s)
        if not np.isfinite(delta) or delta < 0.0:
            delta = np.inf
            break
        if delta <= tol * tol * delta0:
            break
        np.multiply(delta / delta_old, c, out=tmp)
        S(np.add(s, tmp, out=c))
    res = float(np.sqrt(max(delta, 0.0) / delta0)) if np.isfinite(delta) else np.inf
    return x, it, res, res <= tol
