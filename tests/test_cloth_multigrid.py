"""The line-smoothed multigrid preconditioner of the large step (chapter 12): SPD, the same step as a direct
solve, and CG iteration counts an order of magnitude below Jacobi's and the ℓ1-Jacobi cycle's.

Each test cites its oracle from ORACLES.md section J (J6, J9). Tolerances: measured first, asserted a fixed
factor above; both numbers are in the comment next to the assert.
"""

import numpy as np
import pytest
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from pbanim.cloth import Cloth, Ground, Sheet, Sphere, large_step
from pbanim.cloth.collide import contacts
from pbanim.cloth.large_steps import _system
from pbanim.cloth.multigrid import Multigrid

H = 1.0 / 60.0


def _falling(n, steps, colliders=(), height=0.0):
    cloth = Cloth(Sheet(n, pins="corners", height=height), stretch=1e3, shear=1e2, bend=0.1, damping=1e-3,
                  colliders=list(colliders))
    y = cloth.state()
    for _ in range(steps):
        y = large_step(cloth, y, H, tol=1e-6, precond="multigrid")[0]
    return cloth, y


def _matrices(cloth, y):
    n = cloth.n
    x, v = y[:n].reshape(-1, 3), y[n:].reshape(-1, 3)
    f, kd, dd = cloth._all(x, v, exact=False)
    return f, cloth.pattern.matrix(kd), _system(cloth, kd, dd, H)


@pytest.mark.parametrize("n", [10, 16])
def test_line_multigrid_is_spd_with_spectrum_in_0_1(n):
    # ORACLES J9: the V-cycle with symmetric line Gauss–Seidel (forward sweeps before the coarse correction,
    # their adjoint after) is symmetric, and on A with the pins' couplings dropped (what it is built from)
    # the eigenvalues of B A lie in (0, 1]: block Gauss–Seidel contracts in the A-norm for every SPD A
    cloth, y = _falling(n, 4)
    _, _, A = _matrices(cloth, y)
    mg = Multigrid(cloth.pattern, n, coarsest=16, pinned=cloth.pinned)
    mg.setup(A.data)
    assert len(mg.levels) >= 3 and len(mg.blocks) == 1
    B = np.stack([mg(e) for e in np.eye(cloth.n)], axis=1)
    assert np.abs(B - B.T).max() <= 1e3 * np.finfo(float).eps * np.abs(B).max()      # measured 6e-17 rel
    data = A.data.copy()
    data[mg.pin_mask] = 0.0
    ev = np.linalg.eigvals(B @ cloth.pattern.matrix(data).toarray()).real
    assert ev.min() > 0.05 and ev.max() <= 1.0 + 1e-9, (ev.min(), ev.max())          # measured 0.37, 0.23 … 1 + 2e-14


def _direct_filtered_step(cloth, y):
    """Δv of B&W's step by a sparse direct solve on the constraint subspace: Δv = z + T u with T the basis of
    each particle's filter (I free, the two tangents of a contact, nothing pinned), Tᵀ A T u = Tᵀ (b − A z)."""
    n = cloth.n
    x, v = y[:n].reshape(-1, 3), y[n:].reshape(-1, 3)
    f, K, A = _matrices(cloth, y)
    idx, nrm, depth = contacts(cloth.colliders, x, v, cloth.thickness)
    ycorr, z = np.zeros(n), np.zeros(n)
    ycorr.reshape(-1, 3)[idx] = depth[:, None] * nrm
    z.reshape(-1, 3)[idx] = -np.einsum("ij,ij->i", v[idx], nrm)[:, None] * nrm
    z.reshape(-1, 3)[cloth.pinned] = -v[cloth.pinned]
    b = H * (f.ravel() + K @ (H * y[n:] + ycorr))
    cols, rows, vals = [], [], []
    k = 0
    contact_normal = dict(zip(idx.tolist(), nrm))
    for p in range(n // 3):
        if p in set(cloth.pinned.tolist()):
            continue
        if p in contact_normal:
            t1 = np.cross(contact_normal[p], [1.0, 0.0, 0.0] if abs(contact_normal[p][0]) < 0.9 else [0.0, 1.0, 0.0])
            t1 /= np.linalg.norm(t1)
            basis = [t1, np.cross(contact_normal[p], t1)]
        else:
            basis = list(np.eye(3))
        for t in basis:
            rows += [3 * p, 3 * p + 1, 3 * p + 2]
            cols += [k] * 3
            vals += list(t)
            k += 1
    T = sp.csr_matrix((vals, (rows, cols)), shape=(n, k))
    u = spla.spsolve((T.T @ A @ T).tocsc(), T.T @ (b - A @ z))
    return z + T @ u, len(idx)


@pytest.mark.parametrize("colliders", [(), (Sphere([0.0, 0.0, 0.0], 0.3), Ground(-0.5))], ids=["pins", "contacts"])
def test_line_multigrid_step_equals_the_direct_filtered_solve(colliders):
    # ORACLES J6, J9: the preconditioner changes the CG's path, not its answer: the large step with the line
    # multigrid at CG tolerance ε equals a sparse direct solve of the filtered system to a few ε
    cloth, y = _falling(12, 3, colliders, height=0.3 if colliders else 0.0)
    dv, n_contacts = _direct_filtered_step(cloth, y)
    assert (n_contacts > 0) == bool(colliders)
    for tol in (1e-6, 1e-10):
        y1, sol = large_step(cloth, y, H, tol=tol, max_iter=500, precond="multigrid")
        assert sol.converged
        err = np.abs(y1[cloth.n:] - y[cloth.n:] - dv).max() / np.abs(dv).max()
        assert err <= 10 * tol, (tol, err)                    # measured 0.6 ε, 0.9 ε (pins); 3.2 ε, 2.5 ε (contacts)


def test_line_multigrid_iteration_counts_are_bounded_at_n16_and_n32():
    # ORACLES J9: on the benchmark's sheet 6 steps into its fall, CG to 1e-6: the line multigrid needs at most
    # 12 iterations at N = 16 and 16 at N = 32 (measured 8, 12); ℓ1-Jacobi smoothing and Jacobi need > 100
    # (measured 130 / 166 at N = 16): the counts the cost-per-step slope of the benchmark rests on
    from pbanim.bench.cloth import sheet
    from pbanim.bench._cloth_realtime import WARM
    counts = {}
    for n in (16, 32):
        cloth = sheet(n)
        y = cloth.state()
        for _ in range(WARM):
            y = large_step(cloth, y, H, tol=1e-3, precond="multigrid")[0]
        for pc in ("multigrid", "multigrid-l1") if n == 16 else ("multigrid",):
            counts[n, pc] = large_step(cloth, y, H, tol=1e-6, max_iter=5000, precond=pc)[1].iterations
    assert counts[16, "multigrid"] <= 12 and counts[32, "multigrid"] <= 16, counts
    assert counts[16, "multigrid-l1"] > 100 and counts[16, "multigrid-l1"] > 5 * counts[16, "multigrid"], counts


def test_a_line_block_that_is_not_positive_definite_is_reported():
    # ORACLES J9: the banded Cholesky of a line block certifies it: an indefinite A raises LinAlgError at
    # setup (the large step then falls back to Jacobi), it never yields a V-cycle that is not SPD
    cloth, y = _falling(10, 1)
    _, _, A = _matrices(cloth, y)
    mg = Multigrid(cloth.pattern, 10, coarsest=16, pinned=cloth.pinned)
    with pytest.raises(np.linalg.LinAlgError):
        mg.setup(-A.data)


@pytest.mark.parametrize("damping", [0.0, 1e-3])
def test_one_pass_spring_system_equals_the_readable_assembly(damping):
    # ORACLES J10: A.data and f + K u of the large step from one pass over all springs (B_A = (α − γ)ŵŵᵀ + γ𝟙)
    # equal the readable path (K.data, D.data on the pattern, A = M − hD − h²K, K u by a sparse product) to
    # a few ulps of the largest entry; the state is perturbed so that some springs are compressed (s⁺ = 0)
    from pbanim.cloth.step_system import spring_system
    cloth = Cloth(Sheet(9, pins="corners"), stretch=1e3, shear=1e2, bend=0.1, damping=damping)
    rng = np.random.default_rng(7)
    n = cloth.n
    x = cloth.sheet.x0 + 0.02 * rng.standard_normal((n // 3, 3))
    v = rng.standard_normal((n // 3, 3))
    u = 1e-2 * rng.standard_normal(n)
    f, kd, dd = cloth._all(x, v, exact=False)
    A0 = _system(cloth, kd, dd, H).data
    b0 = f + cloth.pattern.matrix(kd) @ u
    lengths = np.linalg.norm(x[cloth.conditions[0].elements[:, 0]] - x[cloth.conditions[0].elements[:, 1]], axis=1)
    assert (lengths < cloth.sheet.spacing).any() and (lengths > cloth.sheet.spacing).any()
    A1, b1 = spring_system(cloth).terms(x, v, u, H)
    eps = np.finfo(float).eps
    assert np.abs(A1 - A0).max() <= 16 * eps * np.abs(A0).max()          # measured 1.9 ε
    assert np.abs(b1 - b0).max() <= 16 * eps * np.abs(b0).max()          # measured 1.9 ε


def test_a_cloth_with_other_conditions_takes_the_readable_path():
    # ORACLES J10: the one-pass system is for springs only; Baraff–Witkin triangles and hinges keep the
    # readable assembly, and the step of either model is finite and keeps the pins
    from pbanim.cloth.step_system import spring_system
    bw = Cloth(Sheet(6, pins="corners"), model="bw", stretch=1e3, shear=1e2, bend=1e-3)
    assert spring_system(bw) is None
    springs = Cloth(Sheet(6, pins="corners"), stretch=1e3, shear=1e2, bend=0.1)
    assert spring_system(springs) is not None
    for cloth in (bw, springs):
        y1 = large_step(cloth, cloth.state(), H, tol=1e-8)[0]
        assert np.isfinite(y1).all()
        assert np.array_equal(y1[:cloth.n].reshape(-1, 3)[cloth.pinned], cloth.sheet.x0[cloth.pinned])
