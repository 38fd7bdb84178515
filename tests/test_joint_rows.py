"""The joint rows evaluated all at once equal the readable row-by-row evaluation (ORACLES I5)."""

import numpy as np
import pytest

from pbanim.articulated import RigidJoints
from pbanim.articulated.joint_rows import _rows_one_by_one
from pbanim.rigid import RigidBodies

EPS = np.finfo(float).eps

JOINTS = [dict(kind="hinge", a=0, b=-1, anchor_a=[0, .3, 0], axis_a=[0, 0, 1]),
          dict(kind="ball", a=1, b=0, anchor_a=[.1, .2, .3], anchor_b=[0, -.2, 0]),
          dict(kind="slider", a=2, b=1, anchor_a=[.1, 0, 0], anchor_b=[0, .1, .2], axis_a=[1, 1, 0]),
          dict(kind="weld", a=3, b=2, anchor_a=[0, .1, 0], anchor_b=[.2, 0, 0]),
          dict(kind="hinge", a=4, b=3, anchor_a=[0, .3, 0], anchor_b=[.1, .1, .1], axis_a=[0, 1, 1],
               axis_b=[1, 0, 1]),
          dict(kind="slider", a=4, b=-1, axis_a=[0, 0, 1]),
          dict(kind="ball", a=-1, b=2, anchor_a=[1.0, 0, 0], anchor_b=[0, 0, .2])]


def _unit(rng, n):
    v = rng.normal(size=(n, 4))
    return v / np.linalg.norm(v, axis=1, keepdims=True)


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_joint_rows_at_once_equal_the_rows_one_by_one(seed):
    rng = np.random.default_rng(seed)
    N = 5
    rb = RigidBodies(rng.uniform(0.5, 2.0, N), np.array([np.diag(rng.uniform(0.5, 0.8, 3)) for _ in range(N)]),
                     rng.normal(size=(N, 3)), _unit(rng, N), rng.normal(size=(N, 3)), rng.normal(size=(N, 3)))
    joints = RigidJoints(JOINTS)
    joints.bind(rb)
    for _ in range(4):                   # states off the constraints: every row and every bias term nonzero
        y = rb.state().copy()
        y[:3 * N] += 0.1 * rng.normal(size=3 * N)
        y[3 * N:7 * N] = _unit(rng, N).ravel()
        y[7 * N:] += rng.normal(size=6 * N)
        for sparse in (False, True):
            got, ref = joints.rows(y, sparse=sparse), _rows_one_by_one(joints, y, sparse=sparse)
            assert len(ref[0]) == 3 + 3 + 5 + 5 + 6 + 5 + 5 == len(got[0])
            for g, r in zip(got, ref):
                g, r = (m.toarray() if hasattr(m, "toarray") else np.asarray(m) for m in (g, r))
                assert g.shape == r.shape
                scale = max(1.0, float(np.abs(r).max()))
                assert np.abs(g - r).max() <= 64 * EPS * scale
            if sparse:                   # the same sparsity structure (explicit zeros included)
                assert got[1].nnz == ref[1].nnz

