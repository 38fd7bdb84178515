"""The joint rows' written-out cross products compute pbanim.geometry.cross (ORACLES I9)."""

import numpy as np

from pbanim.articulated.joint_rows import _cx, _cx_axes, _rows_one_by_one
from pbanim.contracts import unchecked
from pbanim.geometry import cross as _cross

cross = unchecked(_cross)


def test_cx_is_geometry_cross_bit_for_bit():
    """I9: equal shapes and the broadcasts the rows use ((m, 1, 3) × (m, 2, 3) and back)."""
    rng = np.random.default_rng(11)
    for sa, sb in (((7, 3), (7, 3)), ((4, 1, 3), (4, 2, 3)), ((4, 2, 3), (4, 1, 3)), ((3,), (3,))):
        a, b = rng.normal(size=sa) * 10.0 ** rng.integers(-8, 8), rng.normal(size=sb)
        assert np.array_equal(_cx(a, b), cross(a, b))


def test_cx_axes_is_r_cross_each_axis():
    """I9: row k of _cx_axes(r) is r × e_k (equal values: the dropped products were by 0 and 1)."""
    r = np.random.default_rng(12).normal(size=(9, 3))
    assert np.array_equal(_cx_axes(r), cross(r[:, None, :], np.eye(3)))


def test_array_rows_still_equal_the_row_by_row_table():
    """I9 (and the rows' own test): C, J, J̇u of a hinge chain with a ball joint and a slider at random
    states equal the readable one-joint-at-a-time form to 64 ulps of their scale."""
    from pbanim.articulated.joints import RigidJoints
    from pbanim.rigid import RigidBodies, RigidGravity, RigidScene

    rng = np.random.default_rng(13)
    rb = RigidBodies([1.0, 2.0, 1.5], [np.diag([0.2, 0.25, 0.3])] * 3, positions=[[0, 0, 0], [1, 0, 0], [2, 0, 0]])
    joints = RigidJoints([dict(kind="hinge", a=0, b=-1, anchor_a=[0, 0, 0.5], anchor_b=[0, 0, 0.5], axis_a=[0, 1, 0]),
                          dict(kind="ball", a=1, b=0, anchor_a=[-0.5, 0, 0], anchor_b=[0.5, 0, 0]),
                          dict(kind="slider", a=2, b=1, anchor_a=[0, 0, 0], anchor_b=[1, 0, 0], axis_a=[1, 0, 0])])
    RigidScene(rb, [RigidGravity([0, 0, -9.81]), joints])
    y0 = rb.state()
    for _ in range(20):
        y = y0 + rng.normal(scale=0.2, size=y0.size)
        for u, v in zip(joints.rows(y)[:3], _rows_one_by_one(joints, y)[:3]):
            u = u.toarray() if hasattr(u, "toarray") else u
            v = v.toarray() if hasattr(v, "toarray") else np.asarray(v)
            assert np.allclose(u, v, rtol=0, atol=64 * np.finfo(float).eps * max(1.0, np.abs(v).max()))
