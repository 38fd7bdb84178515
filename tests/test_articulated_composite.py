"""The batched ABA's sweeps by composites and rank-one terms (pbanim/articulated/fastcomposite.py) against the
kernel's 6 × 6 sweeps and the readable ABA (chapter 08; ORACLES I16, I5)."""

import numpy as np
import pytest
from test_articulated_fast import make_states, make_tree

from pbanim.articulated import aba, aba_batch, crba
from pbanim.articulated.fast import _check_quaternions, _pivot_array
from pbanim.articulated.fastbatch import sweep_batch
from pbanim.articulated.fastcomposite import lean_fits
from pbanim.articulated.fastplan import plan_for
from pbanim.errors import SingularChartError
from pbanim.models.articulated import pendulum_chain

EPS = np.finfo(float).eps


def _both(tree, q, qd, tau, F=None):
    P = plan_for(tree)
    with np.errstate(over="ignore", invalid="ignore"):
        lean = sweep_batch(P, q, qd, tau, F, _pivot_array, _check_quaternions, lean=True).T.copy()
        full = sweep_batch(P, q, qd, tau, F, _pivot_array, _check_quaternions, lean=False).T.copy()
    return lean, full


def _within_eps_cond(tree, q, got, ref):
    """|Δq̈| ≤ 32 n ε κ(H) (1 + max|q̈|) state by state: the forward error of a solve of H q̈ = b backward-stable
    to n ε (measured factor ≤ 11.6 over 200 random trees of 1–12 links, the kernel's own sweeps ≤ 9.8)."""
    for k in range(len(q)):
        unit = tree.n * EPS * np.linalg.cond(crba(tree, q[k])) * (1 + np.abs(ref[k]).max())
        assert np.abs(got[k] - ref[k]).max() <= 32 * unit, (k, np.abs(got[k] - ref[k]).max(), unit)


@pytest.mark.parametrize("n", [1, 2, 5, 10, 20])
def test_composite_sweeps_equal_the_kernel_on_the_benchmark_chain(n):
    # ORACLES I16: the benchmark's chain (K states of N(0, 1)), against the readable ABA and the kernel's sweeps
    tree = pendulum_chain(n, lengths=1.0, masses=1.0)
    assert lean_fits(plan_for(tree))
    rng = np.random.default_rng(n)
    q, qd, tau = (rng.normal(size=(64, n)) for _ in range(3))
    lean, full = _both(tree, q, qd, tau)
    ref = np.array([aba(tree, q[k], qd[k], tau[k]) for k in range(len(q))])
    _within_eps_cond(tree, q, lean, ref)
    _within_eps_cond(tree, q, lean, full)


@pytest.mark.parametrize("n, seed", [(3, 0), (6, 1), (9, 2), (12, 3), (12, 4), (8, 5)])
def test_composite_sweeps_on_random_trees_with_damping_and_external_forces(n, seed):
    # ORACLES I16: branching trees numbered in any order (descendants not contiguous), revolute, prismatic and
    # fixed joints on random axes, joint damping and external forces
    tree = make_tree(n, seed, damping=True)
    P = plan_for(tree)
    K = 8
    q, qd, tau = make_states(tree, seed + 7, K)
    f = np.random.default_rng(seed).normal(size=(K, n, 6))
    got = aba_batch(tree, q, qd, tau, f)
    assert lean_fits(P)
    ref = np.array([aba(tree, q[k], qd[k], tau[k], f[k]) for k in range(K)])
    _within_eps_cond(tree, q, got, ref)
    F = np.ascontiguousarray(np.einsum("nab,xnyb->xnya", P.Qt, f.reshape(K, n, 2, 3)).reshape(K, n, 6)
                             .transpose(2, 1, 0))
    lean, full = _both(tree, q, qd, tau, F)
    _within_eps_cond(tree, q, lean, full)


def test_deep_chains_and_floating_roots_keep_the_kernel_sweeps():
    # the O(n · depth) sums do not pay for deep chains (module docstring): Σ depth ≤ 12 n
    assert lean_fits(plan_for(pendulum_chain(25)))
    assert not lean_fits(plan_for(pendulum_chain(26)))
    assert not lean_fits(plan_for(make_tree(5, 0, floating=True)))


def test_a_joint_moving_no_inertia_is_named_as_by_the_kernel():
    # ORACLES I16: a point mass on its own axis (D = 0) below a good joint: the same named error, same joint
    from pbanim.articulated import ArticulatedTree

    tree = ArticulatedTree()
    tree.add("arm", -1, "revolute", axis=[0, 0, 1], mass=1.0, com=[1.0, 0, 0])
    tree.add("bead", 0, "revolute", axis=[0, 0, 1], p=[1.0, 0, 0], mass=1.0, com=[0, 0, 1.0])
    q = np.zeros((3, 2))
    for lean in (True, False):
        with pytest.raises(SingularChartError, match="joint 1 .* in state 0"):
            with np.errstate(over="ignore", invalid="ignore"):
                sweep_batch(plan_for(tree), q, q, q, None, _pivot_array, _check_quaternions, lean=lean)

