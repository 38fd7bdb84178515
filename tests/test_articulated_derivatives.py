"""Derivatives of RNEA and ABA (chapter 08; issue 31; ORACLES L1, I5): the analytical derivatives equal
centred finite differences of the recursions themselves (no peer needed) on random trees of every joint kind
and on real URDFs, Pinocchio's ``computeRNEADerivatives`` / ``computeABADerivatives`` where it is installed,
and the batched version equals the readable one."""

import math
import os

import numpy as np
import pytest

from pbanim.articulated import (ArticulatedTree, aba, aba_batch, aba_derivatives, aba_derivatives_batch, crba, load_urdf,
                                rnea, rnea_derivatives, rnea_derivatives_batch, tangent_step)
from pbanim.errors import InvalidInput
from pbanim.models.articulated import pendulum_chain, urdf_path
from test_articulated import _to_pinocchio, random_tree, random_state

H_FD = np.finfo(float).eps ** (1 / 3)            # the centred difference's best step, ≈ 6.1e-6

# (n, seed, floating, kinds): chains, branching trees, every joint kind (continuous and fixed included)
TREES = [(1, 1, False, ("revolute",)), (6, 2, False, ("revolute",)), (9, 3, False, ("revolute", "prismatic", "fixed")),
         (12, 4, True, ("revolute", "continuous", "prismatic", "fixed")), (5, 5, True, ("prismatic",))]


def _chain_or_tree(n, seed, floating, kinds):
    tree = random_tree(n, seed, floating, kinds)
    if seed == 2:                                  # a chain: every link hangs from the one before
        tree.parent = [i - 1 for i in range(tree.n)]
    return tree


def _fd(fn, tree, q, qd, x):
    """Centred differences of fn(q, q̇, x) along the tangent coordinates of q, along q̇ and along x."""
    h, E = H_FD, np.eye(tree.nv)
    dq = np.array([fn(tangent_step(tree, q, h * e), qd, x) - fn(tangent_step(tree, q, -h * e), qd, x) for e in E]).T
    dqd = np.array([fn(q, qd + h * e, x) - fn(q, qd - h * e, x) for e in E]).T
    dx = np.array([fn(q, qd, x + h * e) - fn(q, qd, x - h * e) for e in E]).T
    return dq / (2 * h), dqd / (2 * h), dx / (2 * h)


def _state(tree, seed):
    q, qd, x = random_state(tree, seed)
    rng = np.random.default_rng(seed + 100)
    return q, qd, x, rng.normal(size=(tree.n, 6))


@pytest.mark.parametrize("n, seed, floating, kinds", TREES)
def test_rnea_and_aba_derivatives_equal_centred_differences(n, seed, floating, kinds):
    # ORACLES L1: analytic = centred FD with h = ε^(1/3); the FD's own error is O(h²) relative to the scale of
    # the derivative: asserted 200 h² (7.3e-9) × scale; measured ≤ 5 h² × scale (damping, f_ext included)
    tree = _chain_or_tree(n, seed, floating, kinds)
    tree.damping = list(np.random.default_rng(seed).uniform(0, 0.5, tree.n))
    tree._cache = None
    q, qd, x, fx = _state(tree, seed)
    rnea_fx = lambda q_, qd_, qdd_: rnea(tree, q_, qd_, qdd_, fx)            # noqa: E731
    aba_fx = lambda q_, qd_, tau_: aba(tree, q_, qd_, tau_, fx)              # noqa: E731
    for analytic, fd in ((rnea_derivatives(tree, q, qd, x, fx), _fd(rnea_fx, tree, q, qd, x)),
                         (aba_derivatives(tree, q, qd, x, fx), _fd(aba_fx, tree, q, qd, x))):
        for a, b in zip(analytic, fd):
            scale = 1.0 + np.abs(b).max()
            assert np.abs(a - b).max() <= 200 * H_FD ** 2 * scale, (np.abs(a - b).max(), scale)


@pytest.mark.parametrize("n, seed, floating, kinds", TREES)
def test_aba_derivatives_are_the_rnea_ones_through_the_mass_matrix(n, seed, floating, kinds):
    # ORACLES L1: ∂q̈/∂τ · H = 1 and H ∂q̈/∂q = −∂τ/∂q at q̈ = ABA (the implicit-function theorem on τ = RNEA):
    # roundoff, asserted 1e-13 relative (measured ≤ 1.4e-15)
    tree = _chain_or_tree(n, seed, floating, kinds)
    q, qd, tau, fx = _state(tree, seed)
    dq, dqd, Minv = aba_derivatives(tree, q, qd, tau, fx)
    H = crba(tree, q)
    assert np.abs(Minv @ H - np.eye(tree.nv)).max() <= 1e-13 * np.linalg.cond(H)
    tq, tqd, H2 = rnea_derivatives(tree, q, qd, aba(tree, q, qd, tau, fx), fx)
    assert np.array_equal(H, H2)
    for a, b in ((H @ dq, -tq), (H @ dqd, -tqd)):
        assert np.abs(a - b).max() <= 1e-13 * (1 + np.abs(b).max())


def test_closed_forms_of_a_pendulum_and_a_free_body():
    # ORACLES L1, I7: a point mass m on a rod l about a horizontal axis, τ = m l² q̈ + m g l sin q: ∂τ/∂q =
    # m g l cos q, ∂τ/∂q̇ = 0; a free body's RNEA does not depend on where it is (∂τ/∂p = 0 along its own
    # translation) and ∂q̈/∂q̇ of a free body at rest about its centre of mass is 0 (no gyroscopic term at
    # ω = 0). Roundoff: 1e-13.
    tree = pendulum_chain(1, lengths=2.0, masses=3.0)
    g = float(np.linalg.norm(tree.gravity))
    for q in (-1.0, 0.3, 2.5):
        dq, dqd, H = rnea_derivatives(tree, np.array([q]), np.array([0.7]), np.array([0.2]))
        assert abs(dq[0, 0] - 3.0 * g * 2.0 * math.cos(q)) < 1e-13 * 60 and abs(dqd[0, 0]) < 1e-13
        assert abs(H[0, 0] - 3.0 * 4.0) < 1e-13
    free = ArticulatedTree()
    free.add("body", -1, "floating", mass=2.0, inertia=[0.2, 0.3, 0.4])
    q = free.neutral()
    q[:4] = [0.8, 0.2, -0.4, 0.4]
    q[:4] /= np.linalg.norm(q[:4])
    dq, dqd, _ = rnea_derivatives(free, q, np.zeros(6), np.ones(6))
    assert np.abs(dq[:, 3:]).max() < 1e-13                  # translation changes nothing
    assert np.abs(aba_derivatives(free, q, np.zeros(6), np.ones(6))[1]).max() < 1e-13


@pytest.mark.parametrize("name", ["pendulum3", "planar_biped", "ragdoll"])
def test_repo_urdfs_equal_centred_differences(name):
    # ORACLES L1 on the shipped URDFs (fixed joints merged, limits ignored here): as above, 200 h² × scale
    # (measured ≤ 30 h² × scale: the biped's sliding root and long legs give the largest third derivatives)
    tree = load_urdf(str(urdf_path(name)))
    q, qd, tau, fx = _state(tree, 7)
    fd = _fd(lambda a, b, c: aba(tree, a, b, c), tree, q, qd, tau)
    for a, b in zip(aba_derivatives(tree, q, qd, tau), fd):
        assert np.abs(a - b).max() <= 200 * H_FD ** 2 * (1.0 + np.abs(b).max())


@pytest.mark.parametrize("n, seed, floating, kinds", TREES)
def test_batched_equals_readable(n, seed, floating, kinds):
    # ORACLES I5/L1: the same derivatives over K states, organized in the world frame (derivatives_batch) instead
    # of link frames; roundoff, asserted 5e-14 relative (measured ≤ 6.3e-15)
    tree = _chain_or_tree(n, seed, floating, kinds)
    K = 4
    q, qd, x = random_state(tree, seed, K=K)
    fx = np.random.default_rng(seed).normal(size=(K, tree.n, 6))
    for batch, one in ((rnea_derivatives_batch, rnea_derivatives), (aba_derivatives_batch, aba_derivatives)):
        B = batch(tree, q, qd, x, fx)
        for k in range(K):
            for a, b in zip(B, one(tree, q[k], qd[k], x[k], fx[k])):
                assert a.shape == (K, tree.nv, tree.nv)
                assert np.abs(a[k] - b).max() <= 5e-14 * (1 + np.abs(b).max())
    single = aba_derivatives_batch(tree, q[0], qd[0], x[0])               # one state: squeezed
    assert all(np.abs(a - b).max() <= 5e-14 * (1 + np.abs(b).max())
               for a, b in zip(single, aba_derivatives(tree, q[0], qd[0], x[0])))


@pytest.mark.parametrize("n, seed, kinds", [(6, 2, ("revolute",)), (9, 3, ("revolute", "prismatic", "fixed")),
                                             (12, 4, ("revolute", "continuous", "prismatic", "fixed"))])
def test_lean_path_equals_general_path_call_after_call(n, seed, kinds):
    # ORACLES I5/L1: trees without a floating joint take the lean path (batch axis last, buffers kept per tree
    # and K); it equals the general world-frame path and the readable one state by state, also on a second
    # call with other states, forces and the same K (a stale buffer would show there). Roundoff: 5e-14 relative
    # to the readable one, 1e-12 × cond(H) between the two batched paths (Cholesky vs inverse; measured ≤ 3e-13
    # on a 10-link chain, ≤ 7e-15 here)
    from pbanim.articulated.derivatives_batch import _aba_derivatives_general, _aba_derivatives_lean

    tree = _chain_or_tree(n, seed, False, kinds)
    tree.damping = list(np.random.default_rng(seed).uniform(0, 0.5, tree.n))
    tree._cache = None
    K = 3
    for call in range(2):
        q, qd, x = random_state(tree, seed + 10 * call, K=K)
        fx = None if call == 0 else np.random.default_rng(seed).normal(size=(K, tree.n, 6))
        lean, general = _aba_derivatives_lean(tree, q, qd, x, fx), _aba_derivatives_general(tree, q, qd, x, fx)
        for k in range(K):
            one = aba_derivatives(tree, q[k], qd[k], x[k], None if fx is None else fx[k])
            cond = np.linalg.cond(crba(tree, q[k]))
            for a, g, b in zip(lean, general, one):
                assert np.abs(a[k] - b).max() <= 5e-14 * (1 + np.abs(b).max())
                assert np.abs(a[k] - g[k]).max() <= 1e-12 * cond * (1 + np.abs(g[k]).max())


def test_a_joint_moving_no_inertia_raises_the_abas_named_error():
    # the lean path runs no ABA sweep; its Cholesky pivot of H is checked as the ABA's pivot is, and names the joint
    from pbanim.errors import SingularChartError

    tree = pendulum_chain(3, lengths=1.0, masses=[1.0, 1.0, 0.0])
    q = np.zeros((2, 3))
    for fn in (aba_batch, aba_derivatives_batch):
        with pytest.raises(SingularChartError, match="joint 2"):
            fn(tree, q, q, q)


def test_bad_input_is_named():
    tree = pendulum_chain(2)
    with pytest.raises(InvalidInput, match="qd"):
        aba_derivatives(tree, np.zeros(2), np.zeros(3), np.zeros(2))
    with pytest.raises(InvalidInput, match="f_ext"):
        rnea_derivatives(tree, np.zeros(2), np.zeros(2), np.zeros(2), np.zeros((3, 6)))
    with pytest.raises(InvalidInput, match="tau"):
        aba_derivatives_batch(tree, np.zeros((3, 2)), np.zeros((3, 2)), np.zeros((2, 2)))


# --- against Pinocchio (optional) -------------------------------------------------------------------------
@pytest.mark.parametrize("n, seed, floating", [(1, 31, False), (7, 32, False), (15, 33, True), (30, 34, False),
                                               (30, 35, True)])
def test_derivatives_equal_pinocchio_on_random_trees(n, seed, floating):
    # ORACLES L1: equal to computeRNEADerivatives / computeABADerivatives to 1e-9 relative, the bound
    # (measured ≤ 3.9e-15 on trees of 1–30 links, floating roots included)
    tree = random_tree(n, seed, floating)
    pin, model, qmap, vmap = _to_pinocchio(tree, floating)
    data = model.createData()
    q, qd, x = random_state(tree, seed)
    qp, vp, xp = np.zeros(model.nq), np.zeros(model.nv), np.zeros(model.nv)
    qp[qmap], vp[vmap], xp[vmap] = q, qd, x
    ix = np.ix_(vmap, vmap)
    pin.computeRNEADerivatives(model, data, qp, vp, xp)
    M = np.triu(data.M) + np.triu(data.M, 1).T
    ours = rnea_derivatives(tree, q, qd, x)
    for a, b in zip(ours, (data.dtau_dq[ix], data.dtau_dv[ix], M[ix])):
        assert np.abs(a - b).max() <= 1e-9 * (1 + np.abs(b).max())
    pin.computeABADerivatives(model, data, qp, vp, xp)
    Minv = np.triu(data.Minv) + np.triu(data.Minv, 1).T
    ours = aba_derivatives(tree, q, qd, x)
    for a, b in zip(ours, (data.ddq_dq[ix], data.ddq_dv[ix], Minv[ix])):
        assert np.abs(a - b).max() <= 1e-9 * (1 + np.abs(b).max())


@pytest.mark.parametrize("rel", ["kuka_iiwa/model.urdf", "franka_panda/panda.urdf", "r2d2.urdf",
                                 "laikago/laikago_toes.urdf", "a1/a1.urdf", "quadruped/minitaur.urdf"])
def test_derivatives_equal_pinocchio_on_robot_urdfs(rel):
    # ORACLES L1 on real robots (joints matched by name; Pinocchio's continuous joint is (cos θ, sin θ) in q
    # and has no joint damping, so −b q̇ goes into its τ and −H⁻¹B into its ∂q̈/∂q̇): 1e-9 relative (measured
    # ≤ 9e-14 over the six robots)
    pin = pytest.importorskip("pinocchio")
    pybullet_data = pytest.importorskip("pybullet_data")
    path = os.path.join(pybullet_data.getDataPath(), rel)
    model, tree = pin.buildModelFromUrdf(path), load_urdf(path)
    rng = np.random.default_rng(len(rel))
    q, qd, tau = rng.uniform(-1, 1, tree.nq), rng.normal(size=tree.nv), rng.normal(size=tree.nv)
    qp, vmap = pin.neutral(model), np.zeros(tree.nv, dtype=int)
    for i, name in enumerate(tree.joint_names):
        if tree.joints[i].kind != "fixed":
            jm = model.joints[model.getJointId(name)]
            k = tree._q_index[i].start
            vmap[tree._v_index[i].start] = jm.idx_v
            qp[jm.idx_q:jm.idx_q + jm.nq] = (math.cos(q[k]), math.sin(q[k])) if jm.nq == 2 else q[k]
    b = tree.arrays()["damping"]
    vp, tp, bp = np.zeros(model.nv), np.zeros(model.nv), np.zeros(model.nv)
    vp[vmap], tp[vmap], bp[vmap] = qd, tau, b
    data = model.createData()
    pin.computeABADerivatives(model, data, qp, vp, tp - bp * vp)
    ix = np.ix_(vmap, vmap)
    Minv = (np.triu(data.Minv) + np.triu(data.Minv, 1).T)[ix]
    ref = (data.ddq_dq[ix], data.ddq_dv[ix] - Minv * b, Minv)
    for a, r in zip(aba_derivatives(tree, q, qd, tau), ref):
        assert np.abs(a - r).max() <= 1e-9 * (1 + np.abs(r).max())


def test_bench_derivative_table_smoke():
    # pbanim bench articulated, the derivatives table: it runs and checks its own agreement with Pinocchio
    # (ORACLES L1, 1e-9) when Pinocchio is installed; never timed here
    from pbanim.bench.articulated import derivative_table

    table, ratios = derivative_table([3], 8, 1)
    assert [r[0] for r in table.rows] == [3] and all(r[1] > 0 and r[2] > 0 for r in table.rows)
    agree = [r[8] for r in table.rows if np.isfinite(r[8])]
    assert all(a < 1e-9 for a in agree)
    assert set(ratios) <= {3}
