"""The constant Laplacian preconditioner of the large step (chapter 12): P = (M + L_α) ⊗ I₃ bounds A from
above, and the step preconditioned by it is the filtered system's solution to a few CG tolerances.

Each test cites its oracle from ORACLES.md section J (J6, J13). Tolerances: measured first, asserted a fixed
factor above; both numbers are in the comment next to the assert.
"""

import numpy as np
import pytest

from pbanim.cloth import Cloth, Ground, Sheet, Sphere, large_step
from pbanim.cloth.laplacian import LaplacianPreconditioner

from test_cloth_multigrid import H, _direct_filtered_step, _falling, _matrices


def _readable_P(cloth, h):
    """M + L_α on the free particles, spring by spring (α = h²k + hk_d), the pinned ones removed."""
    N = cloth.n // 3
    P = np.diag(np.asarray(cloth.sheet.masses, dtype=float))
    for c in cloth.conditions:
        for (a, b), k, kd in zip(c.elements, c.k[:, 0], c.kd[:, 0]):
            alpha = h * h * k + h * kd
            P[a, a] += alpha
            P[b, b] += alpha
            P[a, b] -= alpha
            P[b, a] -= alpha
    free = np.setdiff1d(np.arange(N), cloth.pinned)
    return P[np.ix_(free, free)], free


def test_laplacian_preconditioner_is_the_inverse_of_m_plus_the_alpha_laplacian():
    # ORACLES J13: P⁻¹ applied to each unit vector of the free coordinates is the inverse of M + L_α built
    # spring by spring (a dense matrix per coordinate, the pinned particles removed: the Dirichlet Laplacian)
    cloth = Cloth(Sheet(7, pins="corners"), stretch=1e3, shear=1e2, bend=0.1, damping=1e-3)
    P, free = _readable_P(cloth, H)
    pc = LaplacianPreconditioner(cloth, H)
    n = cloth.n
    eye = np.eye(n)
    B = np.stack([pc(eye[:, 3 * p + c]).reshape(-1, 3)[free, c] for p in free for c in range(1)], axis=1)
    assert np.abs(P @ B - np.eye(len(free))).max() <= 1e3 * np.finfo(float).eps * np.linalg.cond(P)   # measured 2e-15
    # the three coordinates share one factor: y and z columns are the same solve
    r = np.random.default_rng(1).standard_normal(n)
    out = pc(r).reshape(-1, 3)
    for c in range(3):
        exact = np.linalg.solve(P, r.reshape(-1, 3)[free, c])
        assert np.abs(out[free, c] - exact).max() <= 1e3 * np.finfo(float).eps * np.abs(exact).max()


def test_laplacian_preconditioner_bounds_a_from_above_on_the_free_space():
    # ORACLES J13: every spring's block α 𝟙 dominates B_A = αŵŵᵀ + γ(𝟙 − ŵŵᵀ) (γ = h²s⁺/|d| ≤ h²k ≤ α), so
    # on the free coordinates M ⪯ A ⪯ P: the eigenvalues of P⁻¹A lie in (0, 1] for a bent, moving sheet
    cloth, y = _falling(8, 6)
    _, _, A = _matrices(cloth, y)
    P, free = _readable_P(cloth, H)
    dofs = (3 * free[:, None] + np.arange(3)).ravel()
    Af = A.toarray()[np.ix_(dofs, dofs)]
    Pf = np.kron(P, np.eye(3))
    ev = np.linalg.eigvals(np.linalg.solve(Pf, Af)).real
    assert ev.min() > 0.0 and ev.max() <= 1.0 + 1e-9, (ev.min(), ev.max())      # measured 0.0016 … 1 − 2e-6
    assert ev.min() < 0.1                         # the transverse modes: P is a bound, not A (measured 0.0016)


@pytest.mark.parametrize("colliders", [(), (Sphere([0.0, 0.0, 0.0], 0.3), Ground(-0.5))], ids=["pins", "contacts"])
def test_laplacian_step_equals_the_direct_filtered_solve(colliders):
    # ORACLES J6, J13: the preconditioner changes the CG's path, not its answer: the large step with the
    # constant Laplacian at CG tolerance ε equals a sparse direct solve of the filtered system to a few ε
    cloth, y = _falling(12, 3, colliders, height=0.3 if colliders else 0.0)
    dv, n_contacts = _direct_filtered_step(cloth, y)
    assert (n_contacts > 0) == bool(colliders)
    for tol in (1e-6, 1e-9):
        y1, sol = large_step(cloth, y, H, tol=tol, max_iter=2000, precond="laplacian")
        assert sol.converged
        err = np.abs(y1[cloth.n:] - y[cloth.n:] - dv).max() / np.abs(dv).max()
        # the stopping test is the residual in P⁻¹'s norm and κ(P⁻¹A) ~ 600 here (the transverse modes, λ_min
        # ~ 0.0016): the error in Δv is ~√κ ε, not the V-cycle's ~ε
        assert err <= 100 * tol, (tol, err)                   # measured 23 ε, 22 ε (pins and contacts at 1e-6)


def test_laplacian_step_of_a_baraff_witkin_cloth_equals_the_direct_filtered_solve():
    # ORACLES J6, J13: other condition kinds get the construction over every pair of an element's particles;
    # still SPD, so the step is the filtered system's solution
    cloth = Cloth(Sheet(8, pins="corners"), model="bw", stretch=1e3, shear=1e2, bend=1e-3, damping=1e-3)
    y = cloth.state()
    for _ in range(3):
        y = large_step(cloth, y, H, tol=1e-8)[0]
    dv, _ = _direct_filtered_step(cloth, y)
    y1, sol = large_step(cloth, y, H, tol=1e-8, max_iter=2000, precond="laplacian")
    assert sol.converged
    err = np.abs(y1[cloth.n:] - y[cloth.n:] - dv).max() / np.abs(dv).max()
    assert err <= 100 * 1e-8, err                               # measured 15 ε
