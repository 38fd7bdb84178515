"""Point Jacobians of articulated trees: all points at once equal the walk up each point's path (ORACLES I8)."""

import numpy as np
import pytest

from pbanim.articulated.contact import point_jacobians
from pbanim.articulated.dynamics import world_poses
from pbanim.articulated.spatial import plucker_inverse
from pbanim.models.articulated import pendulum_chain, ragdoll, ragdoll_contact_points


def _path_walk(tree, q, links, points):
    """The readable form: for each point p on link i, for each joint j from i to the root, the columns
    ω_j × p + v_j of ⁰X_j S_j."""
    A = tree.arrays()
    _, X0, origins = world_poses(tree, q)
    P, J = np.zeros((len(links), 3)), np.zeros((len(links), 3, tree.nv))
    for k, (i, r) in enumerate(zip(links, points)):
        p = origins[i] + X0[i][:3, :3].T @ r
        P[k] = p
        j = i
        while j >= 0:
            s = plucker_inverse(X0[j]) @ A["S"][j]
            J[k][:, A["vi"][j]] = (np.cross(s[:3].T, p) + s[3:].T).T
            j = tree.parent[j]
    return P, J


@pytest.mark.parametrize("seed", range(3))
def test_all_points_at_once_equal_the_path_walk(seed):
    # I8: the ragdoll (a floating root, 11 links, 22 points), random configurations: equal to a few ulps
    rng = np.random.default_rng(seed)
    tree = ragdoll(damping=3.0)
    pts = ragdoll_contact_points(tree)
    links, local = [lk for lk, _ in pts], [p for _, p in pts]
    q = tree.neutral()
    q[:4] = rng.normal(size=4)
    q[:4] /= np.linalg.norm(q[:4])
    q[4:] += rng.normal(size=tree.nq - 4)
    P, J = point_jacobians(tree, q, links, local)
    P0, J0 = _path_walk(tree, q, links, local)
    eps = np.finfo(float).eps
    np.testing.assert_allclose(P, P0, rtol=0, atol=4 * eps * (1 + np.abs(P0).max()))
    np.testing.assert_allclose(J, J0, rtol=0, atol=4 * eps * (1 + np.abs(J0).max()))
    off_path = J0 == 0.0
    assert off_path.any() and np.all(J[off_path] == 0.0)          # columns off the point's path stay zero


def test_point_jacobians_are_the_derivative_of_the_positions():
    # I8: on a hinge chain, J q̇ equals the central difference of the positions along q̇ (to O(ε²))
    rng = np.random.default_rng(7)
    tree = pendulum_chain(4, [1.0, 0.5, 0.7, 0.3], 1.0)
    q, qd = rng.normal(size=tree.nq), rng.normal(size=tree.nv)
    links, local = [0, 2, 3], rng.normal(size=(3, 3))
    _, J = point_jacobians(tree, q, links, local)
    e = 1e-6
    pos = lambda x: point_jacobians(tree, x, links, local)[0]   # noqa: E731
    fd = (pos(q + e * qd) - pos(q - e * qd)) / (2 * e)
    np.testing.assert_allclose(J @ qd, fd, atol=1e-8)
