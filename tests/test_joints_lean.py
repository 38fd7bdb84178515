"""The joints' multipliers by Cholesky beside the least squares (chapter 08, ORACLES I10)."""

import numpy as np
import pytest

from pbanim.articulated import RigidJoints
from pbanim.articulated.joints import _spd_solve
from pbanim.models.articulated import rod_chain

EPS = np.finfo(float).eps
G = 9.81


def _joint_system(n, seed):
    """(A, rhs) of the hinge chain's multiplier solve at a random state."""
    scene, rb, _ = rod_chain(n, 0.5, 1.0, 0.9, G)
    joints = [e for e in scene.effects if isinstance(e, RigidJoints)][0]
    y = rb.state()
    rng = np.random.default_rng(seed)
    N = rb.N
    y[7 * N:] += rng.normal(size=6 * N)                   # momenta: a moving chain
    vel = rb.velocities(y)
    C, J, jdot, Cdot = joints._plan.evaluate(rb, y, velocities=vel)
    Wb, WQ = joints._free_acceleration(y, np.zeros((N, 6)), vel[1])
    WJt = np.einsum("nij,knj->kni", Wb, J.reshape(len(C), N, 6)).reshape(len(C), -1)
    return J @ WJt.T, -jdot - J @ WQ


@pytest.mark.parametrize("n, seed", [(1, 0), (3, 1), (5, 2), (8, 3)])
def test_cholesky_multipliers_equal_least_squares(n, seed):
    # ORACLES I10: the SPD solve and the SVD least squares give one λ, to 100 ε κ(A) |λ|
    A, rhs = _joint_system(n, seed)
    lam = _spd_solve(A, rhs)
    ref = np.linalg.lstsq(A, rhs, rcond=1e-12)[0]
    assert lam is not None
    assert np.abs(lam - ref).max() <= 100 * EPS * np.linalg.cond(A) * np.abs(ref).max()


def test_cholesky_refuses_a_singular_system():
    # ORACLES I10: dependent rows (a row repeated, as a closed loop makes) are left to the least squares
    A, rhs = _joint_system(3, 4)
    J = np.linalg.cholesky(A).T
    Jd = np.vstack([J, J[:1]])
    assert _spd_solve(Jd @ Jd.T, np.ones(Jd.shape[0])) is None


def test_singular_joint_loop_still_solves_by_least_squares():
    # ORACLES I10: a pendulum held twice at the same anchor (dependent rows, consistent): λ from the least
    # squares, the body stays on its anchor (the Cholesky path would fail or refuse)
    from pbanim.rigid import RigidBodies, RigidGravity, RigidScene

    rb = RigidBodies(1.0, np.diag([0.1, 0.1, 0.1]), positions=[[0.5, 0.0, 0.0]])
    j = dict(kind="ball", a=0, b=-1, anchor_a=[-0.5, 0, 0], anchor_b=[0, 0, 0])
    scene = RigidScene(rb, [RigidGravity([0, -G, 0]), RigidJoints([j, j])])
    res = scene.simulate(0.05, 1e-3, "rk4")
    x = res.y[:3, -1]
    assert np.linalg.norm(x) == pytest.approx(0.5, abs=1e-6)
