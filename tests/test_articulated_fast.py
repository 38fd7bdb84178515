"""The world-frame ABA kernels (aba_fast on floats, aba_batch on arrays) against the readable ABA and closed
forms (chapter 08; ORACLES I5, I7, I2)."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from pbanim.articulated import ArticulatedTree, aba, aba_batch, aba_fast, rnea
from pbanim.errors import InvalidInput, SingularChartError
from pbanim.models.articulated import pendulum_chain


def _rotation(rng):
    R = np.linalg.qr(rng.normal(size=(3, 3)))[0]
    return R * np.sign(np.linalg.det(R))


def make_tree(n, seed, floating=False, damping=False):
    """A random tree: branching, revolute / prismatic / fixed joints on random axes and placements."""
    rng = np.random.default_rng(seed)
    tree = ArticulatedTree(gravity=rng.normal(size=3) * 5)
    kinds = ("revolute", "revolute", "prismatic", "fixed")
    for i in range(n):
        kind = "floating" if floating and i == 0 else (kinds[int(rng.integers(4))] if i else "revolute")
        placed = kind != "floating"
        Q = _rotation(rng)
        tree.add(f"l{i}", -1 if i == 0 else int(rng.integers(0, i)), kind, axis=rng.normal(size=3),
                 R=_rotation(rng) if placed else None, p=rng.normal(size=3) if placed else np.zeros(3),
                 mass=rng.uniform(0.5, 2.0), com=0.3 * rng.normal(size=3),
                 inertia=Q @ np.diag(rng.uniform(0.5, 1.0, 3)) @ Q.T,
                 damping=rng.uniform(0.0, 2.0) if damping and kind in ("revolute", "prismatic") else 0.0)
    return tree


def make_states(tree, seed, K=None):
    rng = np.random.default_rng(seed)
    shape = () if K is None else (K,)
    q = tree.neutral() + 0.5 * rng.normal(size=shape + (tree.nq,))
    return q, rng.normal(size=shape + (tree.nv,)), rng.normal(size=shape + (tree.nv,))


def _rel(a, b):
    return float(np.abs(a - b).max() / (1 + np.abs(b).max()))


# --- ORACLES I5: the fast kernels equal the readable ABA ----------------------------------------------
@pytest.mark.parametrize("n, seed, floating", [(1, 0, False), (6, 1, False), (12, 2, True), (30, 3, False),
                                               (30, 4, True)])
def test_fast_equals_readable_with_damping_and_external_forces(n, seed, floating):
    # ORACLES I5: same q̈ state by state, floats and arrays; measured ≤ 1.2e-14 relative (bound 1e-13)
    tree = make_tree(n, seed, floating, damping=True)
    K = 6
    q, qd, tau = make_states(tree, seed + 50, K)
    f = np.random.default_rng(seed).normal(size=(K, n, 6))
    batch = aba_batch(tree, q, qd, tau, f)
    for k in range(K):
        ref = aba(tree, q[k], qd[k], tau[k], f[k])
        assert _rel(aba_fast(tree, q[k], qd[k], tau[k], f[k]), ref) < 1e-13
        assert _rel(batch[k], ref) < 1e-13
    same_force = aba_batch(tree, q, qd, tau, f[0])                      # one (n, 6) force for every state
    assert _rel(same_force[1], aba(tree, q[1], qd[1], tau[1], f[0])) < 1e-13


@settings(max_examples=25, deadline=None)
@given(n=st.integers(1, 12), seed=st.integers(0, 10**6), floating=st.booleans(), K=st.integers(1, 4))
def test_fast_equals_readable_on_random_trees(n, seed, floating, K):
    # ORACLES I5 (property): any tree, any state; and RNEA inverts the fast q̈ (ORACLES I1)
    tree = make_tree(n, seed, floating, damping=seed % 2 == 0)
    q, qd, tau = make_states(tree, seed + 1, K)
    batch = aba_batch(tree, q, qd, tau)
    assert batch.shape == (K, tree.nv)
    for k in range(K):
        ref = aba(tree, q[k], qd[k], tau[k])
        one = aba_fast(tree, q[k], qd[k], tau[k])
        assert _rel(one, ref) < 2e-13 and _rel(batch[k], ref) < 2e-13          # measured ≤ 2.6e-14 (200 trees)
        if not any(tree.damping):
            assert _rel(rnea(tree, q[k], qd[k], one), tau[k]) < 1e-12          # measured ≤ 1.5e-13


# --- ORACLES I7: limiting cases in closed form ------------------------------------------------------------
def test_one_revolute_link_is_a_compound_pendulum():
    # ORACLES I7: q̈ = (τ − b q̇ + (h × m g)·z) / (Ī_zz + m |h⊥|²); gyroscopic terms have no moment about
    # the axis. Measured 2.0e-16 relative (bound 2e-15).
    m, com, Id, b, g = 1.7, np.array([0.4, -0.3, 0.25]), np.array([0.2, 0.3, 0.45]), 0.6, np.array([0.3, -9.81, 0.5])
    tree = ArticulatedTree(gravity=g)
    tree.add("rod", -1, "revolute", axis=[0, 0, 1], mass=m, com=com, inertia=Id, damping=b)
    for q, qd, tau in [(0.3, 1.5, 0.2), (-2.0, -4.0, 1.0), (1.0, 0.0, 0.0)]:
        c, s = np.cos(q), np.sin(q)
        h = np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]]) @ com
        expected = (tau - b * qd + np.cross(h, m * g)[2]) / (Id[2] + m * (h[0] ** 2 + h[1] ** 2))
        for got in (aba_fast(tree, [q], [qd], [tau])[0], aba_batch(tree, [[q]], [[qd]], [[tau]])[0, 0]):
            assert got == pytest.approx(expected, rel=2e-15)


def test_a_welded_link_merges_into_its_parent():
    # ORACLES I7: a fixed joint adds its link's inertia to the parent's; the composite body (mass sum,
    # weighted centre of mass, parallel-axis inertia) gives the same q̈. Measured 3.5e-15 (bound 3e-14).
    rng = np.random.default_rng(3)
    R, p = _rotation(rng), rng.normal(size=3)
    parts = [(1.2, rng.normal(size=3) * 0.3, np.diag([0.3, 0.4, 0.5])), (0.8, rng.normal(size=3) * 0.3, np.diag([0.2, 0.2, 0.3]))]
    welded, merged = ArticulatedTree(gravity=(0, -9.81, 0)), ArticulatedTree(gravity=(0, -9.81, 0))
    for tree in (welded, merged):
        tree.add("base", -1, "revolute", axis=[0, 0, 1], mass=1.0, com=[0.5, 0, 0], inertia=[0.1, 0.1, 0.1])
    welded.add("arm", 0, "revolute", axis=[1, 0, 1], p=[1, 0, 0], mass=parts[0][0], com=parts[0][1], inertia=parts[0][2])
    welded.add("tip", 1, "fixed", R=R, p=p, mass=parts[1][0], com=parts[1][1], inertia=parts[1][2])
    m = parts[0][0] + parts[1][0]
    c2 = p + R @ parts[1][1]                                   # the tip's centre of mass in the arm's frame
    c = (parts[0][0] * parts[0][1] + parts[1][0] * c2) / m
    shift = lambda mi, d: mi * (d @ d * np.eye(3) - np.outer(d, d))
    Ic = parts[0][2] + shift(parts[0][0], parts[0][1] - c) + R @ parts[1][2] @ R.T + shift(parts[1][0], c2 - c)
    merged.add("arm", 0, "revolute", axis=[1, 0, 1], p=[1, 0, 0], mass=m, com=c, inertia=Ic)
    q, qd, tau = rng.normal(size=(4, 2)), rng.normal(size=(4, 2)), rng.normal(size=(4, 2))
    assert _rel(aba_batch(welded, q, qd, tau), aba_batch(merged, q, qd, tau)) < 3e-14
    assert _rel(aba_fast(welded, q[0], qd[0], tau[0]), aba_fast(merged, q[0], qd[0], tau[0])) < 3e-14


def test_a_free_body_obeys_newton_euler():
    # ORACLES I7: one floating body with its centre of mass at the frame origin: Ī ω̇ + ω × Ī ω = n and
    # v̇ = f/m + Rᵀg − ω × v (body frame; q̈ is the spatial acceleration). Measured 2.1e-16 (bound 2e-15).
    m, Id, g = 2.5, np.array([0.4, 0.9, 1.2]), np.array([0.0, 0.0, -9.81])
    tree = ArticulatedTree(gravity=g)
    tree.add("body", -1, "floating", mass=m, inertia=Id)
    rng = np.random.default_rng(5)
    quat = rng.normal(size=4)
    q = np.concatenate([quat / np.linalg.norm(quat), rng.normal(size=3)])
    qd, tau, f = rng.normal(size=6), rng.normal(size=6), rng.normal(size=(1, 6))
    w, v = qd[:3], qd[3:]
    a, b, c, d = q[:4]
    R = np.array([[1 - 2 * (c * c + d * d), 2 * (b * c - a * d), 2 * (b * d + a * c)],
                  [2 * (b * c + a * d), 1 - 2 * (b * b + d * d), 2 * (c * d - a * b)],
                  [2 * (b * d - a * c), 2 * (c * d + a * b), 1 - 2 * (b * b + c * c)]])
    n_tot, f_tot = tau[:3] + f[0, :3], tau[3:] + f[0, 3:]
    expected = np.concatenate([(n_tot - np.cross(w, Id * w)) / Id, f_tot / m + R.T @ g - np.cross(w, v)])
    assert _rel(aba_fast(tree, q, qd, tau, f), expected) < 2e-15
    assert _rel(aba_batch(tree, q[None], qd[None], tau[None], f)[0], expected) < 2e-15


# --- ORACLES I2: Pinocchio, when installed ----------------------------------------------------------------
def test_fast_kernels_agree_with_pinocchio():
    # ORACLES I2: the benchmark's chain (10 links) on 64 random states; measured ≤ 3.6e-14 relative to |q̈|max
    # (bound 1e-10, the tolerance for Pinocchio)
    pytest.importorskip("pinocchio")
    from pbanim.bench.articulated import chain, pinocchio_aba

    tree = chain(10)
    pin_aba = pinocchio_aba(tree)
    rng = np.random.default_rng(11)
    q, qd, tau = (rng.normal(size=(64, 10)) for _ in range(3))
    ref = np.array([pin_aba(q[k], qd[k], tau[k]) for k in range(64)])
    assert np.abs(aba_batch(tree, q, qd, tau) - ref).max() < 1e-10 * (1 + np.abs(ref).max())
    assert max(np.abs(aba_fast(tree, q[k], qd[k], tau[k]) - ref[k]).max() for k in range(8)) < 1e-10 * (1 + np.abs(ref).max())


# --- plumbing: the per-tree plan and the reused buffers ---------------------------------------------------
def test_plan_follows_the_tree_and_results_are_not_buffers():
    # ORACLES I5: after add() the plan is rebuilt (measured 5e-16, bound 1e-13); a returned q̈ is never
    # overwritten by the next call
    tree = pendulum_chain(3)
    q, qd, tau = make_states(tree, 0, K=1)
    first = aba_batch(tree, q, qd, tau)
    keep = first.copy()
    aba_batch(tree, q + 1.0, qd, tau)
    np.testing.assert_array_equal(first, keep)
    tree.add("extra", 2, "prismatic", axis=[1, 0, 0], mass=0.5, com=[0, -0.5, 0], inertia=np.eye(3) * 0.01)
    q, qd, tau = make_states(tree, 1, K=3)
    assert _rel(aba_batch(tree, q, qd, tau)[2], aba(tree, q[2], qd[2], tau[2])) < 1e-13
    assert _rel(aba_fast(tree, q[0], qd[0], tau[0]), aba(tree, q[0], qd[0], tau[0])) < 1e-13


# --- bad input --------------------------------------------------------------------------------------------
def test_bad_input_is_named():
    # ORACLES G3: shapes, non-finite values, a zero quaternion, a non-tree, a singular joint
    tree = pendulum_chain(3)
    with pytest.raises(InvalidInput, match="aba_fast: q must be .* got array\\(\\[0., 0.\\]\\); shape \\(2,\\)"):
        aba_fast(tree, np.zeros(2), np.zeros(3), np.zeros(3))
    with pytest.raises(InvalidInput, match="aba_fast: qd must be .* got \\[0.0, nan, 0.0\\]; it has NaN"):
        aba_fast(tree, np.zeros(3), [0.0, np.nan, 0.0], np.zeros(3))
    with pytest.raises(InvalidInput, match="tau must hold the states of q \\(K = 4\\), got shape \\(5, 3\\)"):
        aba_batch(tree, np.zeros((4, 3)), np.zeros((4, 3)), np.zeros((5, 3)))
    with pytest.raises(InvalidInput, match="aba_fast: f_ext must be .* shape \\(2, 6\\)"):
        aba_fast(tree, np.zeros(3), np.zeros(3), np.zeros(3), np.zeros((2, 6)))
    with pytest.raises(InvalidInput, match="tree must be an ArticulatedTree with at least one link, got 'chain'"):
        aba_fast("chain", np.zeros(3), np.zeros(3), np.zeros(3))
    free = ArticulatedTree()
    free.add("body", -1, "floating", mass=1.0, inertia=[1.0, 1.0, 1.0])
    with pytest.raises(InvalidInput, match="quaternion"):
        aba_fast(free, np.zeros(7), np.zeros(6), np.zeros(6))
    with pytest.raises(InvalidInput, match="quaternion"):
        aba_batch(free, np.zeros((2, 7)), np.zeros((2, 6)), np.zeros((2, 6)))
    spin = ArticulatedTree()                                 # a point mass on its own axis: D = 0
    spin.add("bead", -1, "revolute", axis=[0, 0, 1], mass=1.0, com=[0, 0, 1.0])
    with pytest.raises(SingularChartError, match="joint 0"):
        aba_fast(spin, [0.1], [0.0], [0.0])
    with pytest.raises(SingularChartError, match="joint 0"):
        aba_batch(spin, [[0.1], [0.2]], [[0.0], [0.0]], [[0.0], [0.0]])


@settings(max_examples=30, deadline=None)
@given(shape_q=st.sampled_from([(3,), (2,), (4, 3), (4, 2), (0, 3)]), bad=st.sampled_from([None, np.nan, np.inf]))
def test_any_input_gives_a_result_or_a_named_error(shape_q, bad):
    # ORACLES G3 (property): a finite q̈ of the right shape, or InvalidInput — never NaN
    tree = pendulum_chain(3)
    q = np.full(shape_q, 0.3)
    qd, tau = np.full(shape_q[:-1] + (3,), 0.1), np.zeros(shape_q[:-1] + (3,))
    if bad is not None and q.size:
        q.flat[0] = bad
    ok = shape_q[-1] == 3 and (bad is None or q.size == 0)
    if not ok:
        with pytest.raises(InvalidInput):
            aba_fast(tree, q, qd, tau)
        return
    out = aba_fast(tree, q, qd, tau)
    assert out.shape == shape_q[:-1] + (3,) and np.all(np.isfinite(out))
