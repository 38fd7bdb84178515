"""Sparse products by scipy's own kernel, bound once (shared by the lean twins of chapters 07, 09 and 12).

``A @ x`` for a CSR (or CSC) matrix A is, inside scipy, a zeroed result into which the compiled kernel
``csr_matvec`` (``csc_matvec``) adds A x. A Krylov or a sweep loop calls that product hundreds of times a step on
the same A, and on small or medium matrices the operator's type dispatch and checks cost as long as the
product. Here the kernel is reached once and bound to A's arrays:

    product(x, out):  out ← 0;  out += A x         (what A @ x computes, bit for bit)
    add_product(x, y):          y  += A x          (in place: y a contiguous array or a contiguous view)

Limits: the kernel is a private module of scipy; where it is not importable (another scipy layout) both fall
back to the public ``A @ x`` (the same numbers). Float64 data and scipy's own index arrays are expected (the
matrices the package builds). References: scipy.sparse, ``_compressed._matmul_vector``.
"""

from __future__ import annotations

try:
    from scipy.sparse import _sparsetools
except ImportError:                                            # pragma: no cover - another scipy layout
    _sparsetools = None

__all__: list[str] = []      # internal: the lean twins' products (lcp.rows, fluids.multigrid, cloth.lean_pcg)


def _kernel(fmt: str):
    return getattr(_sparsetools, f"{fmt}_matvec", None) if _sparsetools is not None else None


_CSR = _kernel("csr")


def product_of(fmt: str, arrays: tuple, shape: tuple):
    """``(x, out) -> out = A x`` of the ``fmt`` ("csr" or "csc") matrix A = (data, indices, indptr) of
    ``shape``: the kernel into ``out`` zeroed first, or ``A @ x`` where the kernel is not found."""
    kernel = _kernel(fmt)
    if kernel is None:                                         # pragma: no cover
        from scipy import sparse

        A = (sparse.csr_matrix if fmt == "csr" else sparse.csc_matrix)(arrays, shape=shape)

        def product(x, out):
            out[:] = A @ x
            return out
        return product
    M, N = shape
    data, idx, ptr = arrays

    def product(x, out):
        out.fill(0.0)
        kernel(M, N, ptr, idx, data, x, out)
        return out
    return product


def csr_product(A):
    """:func:`product_of` of a scipy CSR matrix A."""
    return product_of("csr", (A.data, A.indices, A.indptr), A.shape)


def add_csr_product(A, x, y) -> None:
    """y += A x in place for a scipy CSR matrix A (y contiguous), by the kernel when reachable."""
    if _CSR is None:                                           # pragma: no cover
        y += A @ x
    else:
        _CSR(A.shape[0], A.shape[1], A.indptr, A.indices, A.data, x, y)
