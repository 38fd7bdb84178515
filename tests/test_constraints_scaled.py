"""D A D for the scaled sparse LU of the constraint solvers, formed entry by entry (ORACLES B8)."""

import numpy as np
import scipy.sparse as sp

from pbanim.constraints.solvers import _scaled, _splu


def _spd(n, seed):
    rng = np.random.default_rng(seed)
    B = sp.random(n, n, density=0.05, random_state=seed, format="csr")
    A = (B @ B.T + sp.eye(n)).tocsr()
    return A, 0.5 + rng.random(n)


def test_scaled_equals_the_diagonal_products_bit_for_bit():
    # ORACLES B8: same pattern, same values as sp.diags(d) @ A @ sp.diags(d), for CSR and CSC input
    for seed in range(3):
        A, d = _spd(80, seed)
        for fmt in ("csr", "csc"):
            M = A.asformat(fmt, copy=True)
            M.data[[0, 7]] = 0.0          # stored zeros next to ordinary entries
            Ds = sp.diags(d)
            ref = (Ds @ sp.csc_matrix(M) @ Ds).tocsc()
            got = _scaled(sp.csc_matrix(M), d)
            ref.sort_indices()
            assert np.array_equal(ref.indptr, got.indptr) and np.array_equal(ref.indices, got.indices)
            assert np.array_equal(ref.data, got.data)


def test_scaled_solve_equals_the_unscaled_solve():
    A, d = _spd(60, 7)
    r = np.linspace(-1.0, 2.0, 60)
    x_scaled = _splu(A, scale=d)(r)
    x_plain = _splu(A)(r)
    kappa = np.linalg.cond(A.toarray())
    assert np.max(np.abs(x_scaled - x_plain)) <= 100 * kappa * np.finfo(float).eps * np.max(np.abs(x_plain))
