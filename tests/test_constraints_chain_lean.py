"""The linear-time solver's lean twin on a chain (``pbanim.constraints.chain_lean``) and Jᵀ read as CSC on J's
own arrays (``ConstraintSet.assemble``): the readable solver's numbers, bit for bit.

Oracles: ORACLES B11 (the lean chain solve is the readable one), B3/B5 (what the readable one is checked against).
"""

import numpy as np
import pytest
import scipy.sparse as sp

from pbanim.constraints import ConstraintSet, Distance, solve_lambda
from pbanim.constraints import chain_lean
from pbanim.errors import NonFiniteResult
from pbanim.models.constrained import hanging_chain, random_chain
from pbanim.particles import ParticleSystem


def _setup(n, mass_ratio=1.0, seed=0, link_length=None):
    mod = hanging_chain(n, link_length=link_length or 1.0 / n, mass_ratio=mass_ratio, angle=0.3)
    ps = mod.system
    cs = ConstraintSet(mod.constraints, ps.N, ps.dim, ps.W, ps.x0)
    rng = np.random.default_rng(seed)
    x, v = ps.unpack(ps.state())
    x = x + 1e-3 / n * rng.normal(size=x.shape)           # off the rest lengths: C ≠ 0
    v = rng.normal(size=v.shape)
    Q = (ps.m[:, None] * mod.g).ravel() + rng.normal(size=ps.N * ps.dim)
    return cs, x, v, Q


def _same(a, b):
    return a.shape == b.shape and np.array_equal(a, b) and np.array_equal(np.signbit(a), np.signbit(b))


@pytest.mark.parametrize("n, mass_ratio", [(2, 1.0), (3, 1000.0), (64, 1.0), (1000, 1000.0), (10_000, 1.0)])
def test_lean_chain_solve_is_the_readable_one_bit_for_bit(n, mass_ratio):
    # ORACLES B11: λ, Q_C, q̈ and the stored right-hand side equal the readable solver's (lean=False), 0 ulp,
    # with Baumgarte terms in c and masses 1 : 1000 (κ(JWJᵀ) ≈ 1e9, where the refinement step matters)
    cs, x, v, Q = _setup(n, mass_ratio, seed=n)
    asm = cs.assemble(x, v)
    assert chain_lean.applies(cs, asm)
    c = -asm.Jdv - 100.0 * asm.C - 20.0 * asm.Cdot
    for _ in range(2):                                     # the second call reuses the scratch vectors
        lean = solve_lambda(asm.J, cs.Wq, Q, c, "linear", cset=cs, asm=asm)
        ref = solve_lambda(asm.J, cs.Wq, Q, c, "linear", cset=cs, asm=asm, lean=False)
        for a, b in ((lean.lam, ref.lam), (lean.Q_C, ref.Q_C), (lean.qdd, ref.qdd), (lean._problem[2], ref._problem[2])):
            assert _same(a, b)
        assert lean.residual == ref.residual and lean.solver == "linear" and not lean.rank_deficient
    # and the readable one is right (ORACLES B5): the dense solve's λ to its roundoff when small enough
    if n <= 1000:
        dense = solve_lambda(asm.J, cs.Wq, Q, c, "witkin-dense", cset=cs, asm=asm)
        assert np.abs(lean.lam - dense.lam).max() <= 1e-10 * np.abs(dense.lam).max()


def test_lean_chain_solve_would_catch_a_skipped_refinement():
    # the bit-for-bit comparison can fail: λ₀ alone (no refinement) differs from the readable λ at κ ≈ 1e9
    import scipy.linalg as sla
    cs, x, v, Q = _setup(1000, 1000.0, seed=5)
    asm = cs.assemble(x, v)
    c = -asm.Jdv
    ref = solve_lambda(asm.J, cs.Wq, Q, c, "linear", cset=cs, asm=asm, lean=False)
    d, e = cs.tridiagonal(asm)
    D, E, _ = sla.lapack.dpttrf(d, e)
    lam0 = sla.lapack.dpttrs(D, E, c - asm.J @ (cs.Wq * Q))[0]
    assert not np.array_equal(lam0, ref.lam)


def test_transpose_read_as_csc_is_the_csr_transpose_bit_for_bit():
    # ORACLES B11: Jᵀy by J's arrays read as CSC adds each column of J in row order, the sums of a CSR copy of
    # Jᵀ; checked on a chain, a random chain (other numbering) and a set of two kinds sharing particles
    rng = np.random.default_rng(2)
    for n in (5, 300):
        cs, x, v, _ = _setup(n, seed=n)
        rc = random_chain(n, rng)
        cs2 = ConstraintSet(rc.constraints, rc.system.N, rc.system.dim, rc.system.W, rc.system.x0)
        for s, (xx, vv) in ((cs, (x, v)), (cs2, rc.system.unpack(rc.system.state()))):
            asm = s.assemble(xx, vv)
            assert asm.JT.format == "csc" and asm.JT.shape == (s.n, s.m)
            JTcsr = sp.csr_matrix(asm.J.toarray().T)
            for _ in range(3):
                y = rng.normal(size=s.m)
                assert _same(asm.JT @ y, JTcsr @ y)
            assert np.array_equal(asm.JT.toarray(), asm.J.toarray().T)
    # the values follow J each step (a new assembly at another state)
    x2 = x + 0.1
    asm2 = cs.assemble(x2, v)
    assert asm2.JT.data is asm2.J.data and np.array_equal(asm2.JT.toarray(), asm2.J.toarray().T)


def test_other_structures_take_the_readable_path():
    # a chain numbered from its free end (not natural) and a pivot that vanishes are the readable solver's
    mod = hanging_chain(50, link_length=0.02, angle=0.3)
    N = mod.system.N
    pairs = np.stack([np.arange(N), np.arange(-1, N - 1)], axis=1)
    flipped = np.where(pairs >= 0, N - 1 - pairs, -1)[np.r_[N - 1, np.arange(N - 1)]]
    x0, m = mod.system.x0, mod.system.m
    ps = ParticleSystem(x0[::-1], 0 * x0, m[::-1])
    cs = ConstraintSet([Distance(flipped, lengths=0.02, anchors=np.zeros(2))], N, 2, ps.W, ps.x0)
    asm = cs.assemble(*ps.unpack(ps.state()))
    assert cs.structure.kind == "chain" and not cs.structure.natural and not chain_lean.applies(cs, asm)
    # a vanishing pivot: chain_lambda hands back None (the readable solver falls back to the min-norm λ)
    cs1, x, v, Q = _setup(4, seed=1)
    asm1 = cs1.assemble(x, v)
    d, e = asm1.vals
    asm1.vals = (d, e.copy())
    asm1.vals[1][:] = np.sqrt(d[:-1] * d[1:])                 # a singular tridiagonal A (first minor 0)
    assert chain_lean.chain_lambda(cs1, asm1, asm1.J, cs1.Wq, Q, -asm1.Jdv) is None


def test_non_finite_right_hand_side_is_named_on_both_paths():
    cs, x, v, Q = _setup(10, seed=3)
    asm = cs.assemble(x, v)
    Q[:] = 1e308                                            # finite, but W Q overflows (W = 4 here)
    for lean in (True, False):
        with pytest.raises(NonFiniteResult, match="the right-hand side r = c − JWQ"):
            solve_lambda(asm.J, 4 * cs.Wq, Q, -asm.Jdv, "linear", cset=cs, asm=asm, lean=lean)


def test_the_goal_rounds_time_both_solves_at_equal_work():
    # ORACLES B5: the benchmark's two steps solve the same JWJᵀλ = r from the same assembly, both refined once:
    # their λ agree to roundoff (bound 1e-10, B5's; measured 3.3e-15 at n = 10⁴); the floor's calls run
    from pbanim.bench.constraints import _goal_rounds

    g = _goal_rounds(n=1000, rounds=2, min_cpu=0.001)
    assert g["lam_diff"] < 1e-10
    assert all(len(g[k]) == 2 and min(g[k]) > 0 for k in ("linear", "witkin-sparse", "floor"))


@pytest.mark.parametrize("dim", [2, 3])
def test_lean_chain_solve_on_random_chains_in_2d_and_3d(dim):
    # ORACLES B11 on chains of random masses (10^±1), lengths and directions, in the plane and in space
    rc = random_chain(500, np.random.default_rng(dim), dim=dim)
    ps = rc.system
    cs = ConstraintSet(rc.constraints, ps.N, ps.dim, ps.W, ps.x0)
    asm = cs.assemble(*ps.unpack(ps.state()))
    assert chain_lean.applies(cs, asm)
    Q = np.random.default_rng(0).normal(size=cs.n)
    a = solve_lambda(asm.J, cs.Wq, Q, -asm.Jdv, "linear", cset=cs, asm=asm)
    b = solve_lambda(asm.J, cs.Wq, Q, -asm.Jdv, "linear", cset=cs, asm=asm, lean=False)
    assert _same(a.lam, b.lam) and _same(a.Q_C, b.Q_C) and _same(a.qdd, b.qdd)
