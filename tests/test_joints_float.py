"""The joint rows on floats equal the array rows and the readable ones (ORACLES I13)."""

import numpy as np
import pytest

from pbanim.articulated import RigidJoints
from pbanim.articulated.joints_float import FLOAT_MAX_JOINTS
from pbanim.models.articulated import rod_chain
from pbanim.rigid import RigidBodies, RigidGravity, RigidScene, quat_from_axis_angle

EPS = np.finfo(float).eps


def _joints(scene):
    return [e for e in scene.effects if isinstance(e, RigidJoints)][0]


def _random_tree(seed, n=None, ks=50.0, kd=5.0):
    """n bodies of random masses and principal inertias, each joined to an earlier one (or the world) by a random
    ball or hinge joint at random anchors and axes (a tree: independent rows), with Baumgarte gains."""
    rng = np.random.default_rng(seed)
    n = int(rng.integers(1, 7)) if n is None else n
    qs = [quat_from_axis_angle(rng.normal(size=3), rng.uniform(0, 3)) for _ in range(n)]
    rb = RigidBodies(rng.uniform(0.5, 2.0, n), [np.diag(rng.uniform(0.3, 0.5, 3)) for _ in range(n)],
                     positions=rng.normal(size=(n, 3)), orientations=qs, velocities=rng.normal(size=(n, 3)),
                     angular_velocities=rng.normal(size=(n, 3)))
    js = []
    for i in range(n):
        axis = rng.normal(size=3)
        if i == 0:
            axis = np.array([1.0, 0.05, 0.0])            # |â_a,x| ≥ 0.9 at the start: the tangent from ŷ
        js.append(dict(kind=("ball", "hinge")[int(rng.integers(2))] if i else "hinge", a=i,
                       b=int(rng.integers(-1, i)), anchor_a=rng.normal(size=3), anchor_b=rng.normal(size=3),
                       axis_a=axis / np.linalg.norm(axis)))
    return RigidScene(rb, [RigidGravity([0, 0, -9.81]), RigidJoints(js, ks=ks, kd=kd)]), rb


def _three_ways(scene, y):
    """(ẏ, λ) with the float rows, the array rows and the readable path at y, and κ(J W Jᵀ)."""
    jt = _joints(scene)
    out = []
    for lean, floats in ((True, True), (True, False), (False, True)):
        jt.lean_path, jt._lean.floats = lean, floats
        out.append((scene.rhs(0.0, y), jt.last_lambda.copy()))
    jt.lean_path, jt._lean.floats = True, True
    C, J, _, _ = jt.rows(y)
    Wb = scene.system.inverse_mass_blocks(y)
    WJt = np.einsum("nij,knj->kni", Wb, J.reshape(len(C), scene.system.N, 6)).reshape(len(C), -1)
    return out, np.linalg.cond(J @ WJt.T)


@pytest.mark.parametrize("seed", range(6))
def test_float_rows_equal_array_and_readable_rows(seed):
    # ORACLES I13: ẏ and λ to 64 ε κ(J W Jᵀ) of their scale, at random states of random ball/hinge trees
    scene, rb = _random_tree(seed, ks=50.0 * (seed % 2), kd=5.0 * (seed % 3 == 0))
    assert _joints(scene)._lean._float is not None
    y0 = rb.state()
    rng = np.random.default_rng(200 + seed)
    for _ in range(3):
        y = y0 + rng.normal(scale=0.3, size=y0.size)
        ((f2, l2), (f1, l1), (f0, l0)), kappa = _three_ways(scene, y)
        for f, lam in ((f2, l2), (f1, l1)):
            assert np.abs(lam - l0).max() <= 64 * EPS * kappa * np.abs(l0).max()
            assert np.abs(f - f0).max() <= 64 * EPS * kappa * np.abs(f0).max()


def test_float_errors_equal_readable_rows():
    # ORACLES I13: the drift C and its rate Ċ = J u on floats against the readable rows, 64 ε of their scale
    for seed in range(4):
        scene, rb = _random_tree(seed)
        jt = _joints(scene)
        y = rb.state() + np.random.default_rng(seed).normal(scale=0.3, size=rb.state().size)
        C, J, _, Cdot = jt.rows(y)
        C1, Cdot1 = jt._lean.errors(y)
        assert np.abs(C1 - C).max() <= 64 * EPS * (1 + np.abs(C).max())
        scale = np.abs(J).max() * np.abs(rb.generalized_velocity(y)).max()
        assert np.abs(Cdot1 - Cdot).max() <= 64 * EPS * scale


@pytest.mark.parametrize("ks, kd", [(0.0, 0.0), (400.0, 40.0)])
def test_float_chain_run_equals_array_run(ks, kd):
    # ORACLES I13: the chain figure's 5-hinge chain, 200 RK4 steps with float rows and with array rows: the
    # states agree to 8 ε per step of their scale
    runs = []
    for floats in (True, False):
        scene, rb, _ = rod_chain(5, 0.5, 1.0, 0.9, 9.81, ks=ks, kd=kd)
        _joints(scene)._lean.floats = floats
        runs.append(scene.simulate(0.2, 1e-3, "rk4").y)
    assert np.abs(runs[0] - runs[1]).max() <= 8 * EPS * 200 * np.abs(runs[1]).max()


def test_float_rows_only_where_they_qualify():
    # ORACLES I13: a static body, a body off its principal axes, or more than FLOAT_MAX_JOINTS joints keep the
    # array rows (which still equal the readable path)
    scene, rb = _random_tree(3, n=FLOAT_MAX_JOINTS + 1)
    assert _joints(scene)._lean is not None and _joints(scene)._lean._float is None
    c, s = np.cos(0.4), np.sin(0.4)
    R = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
    tilted = RigidBodies(1.0, [R @ np.diag([0.1, 0.15, 0.2]) @ R.T], positions=[[0.5, 0.0, 0.0]])
    two = RigidBodies([1.0, 1.0], [[0.1, 0.2, 0.3]] * 2, positions=[[0.5, 0.0, 0.0], [1.0, 0.0, 0.0]],
                      static=[True, False])
    for bodies, js in ((tilted, [dict(kind="ball", a=0, b=-1, anchor_a=[-0.5, 0, 0])]),
                       (two, [dict(kind="hinge", a=1, b=0, anchor_a=[-0.25, 0, 0], anchor_b=[0.25, 0, 0],
                                   axis_a=[0, 0, 1])])):
        jt = RigidJoints(js)
        scene = RigidScene(bodies, [RigidGravity([0, -9.81, 0]), jt])
        assert jt._lean is not None and jt._lean._float is None
        y = bodies.state()
        f1 = scene.rhs(0.0, y)
        jt.lean_path = False
        assert np.abs(f1 - scene.rhs(0.0, y)).max() <= 64 * EPS * (1 + np.abs(f1).max())
