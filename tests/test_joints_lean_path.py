"""The lean joint step (ball and hinge rows on preallocated arrays) equals the readable one (ORACLES I11)."""

import numpy as np
import pytest

from pbanim.articulated import RigidJoints
from pbanim.models.articulated import rod_chain
from pbanim.rigid import RigidBodies, RigidGravity, RigidScene, quat_from_axis_angle

EPS = np.finfo(float).eps


def _joints(scene):
    return [e for e in scene.effects if isinstance(e, RigidJoints)][0]


def _random_tree(seed):
    """Bodies 0..n−1 of random masses and inertias, each joined to an earlier one (or the world) by a random
    ball or hinge joint at random anchors and axes (a tree: independent rows)."""
    rng = np.random.default_rng(seed)
    n = int(rng.integers(1, 6))
    Ib = [np.diag(rng.uniform(0.3, 0.5, 3)) for _ in range(n)]          # moments within a factor 5/3: admissible
    qs = [quat_from_axis_angle(rng.normal(size=3), rng.uniform(0, 3)) for _ in range(n)]
    rb = RigidBodies(rng.uniform(0.5, 2.0, n), Ib, positions=rng.normal(size=(n, 3)), orientations=qs,
                     velocities=rng.normal(size=(n, 3)), angular_velocities=rng.normal(size=(n, 3)))
    js = []
    for i in range(n):
        axis = rng.normal(size=3)
        js.append(dict(kind=("ball", "hinge")[int(rng.integers(2))], a=i, b=int(rng.integers(-1, i)),
                       anchor_a=rng.normal(size=3), anchor_b=rng.normal(size=3), axis_a=axis / np.linalg.norm(axis)))
    ks, kd = (0.0, 0.0) if seed % 2 else (50.0, 5.0)
    return RigidScene(rb, [RigidGravity([0, 0, -9.81]), RigidJoints(js, ks=ks, kd=kd)]), rb


def _both(scene, y):
    """(ẏ, λ) of the lean path and of the readable one at y, and κ(J W Jᵀ)."""
    jt = _joints(scene)
    out = []
    for lean in (True, False):
        jt.lean_path = lean
        out.append((scene.rhs(0.0, y), jt.last_lambda.copy()))
    jt.lean_path = True
    C, J, _, _ = jt.rows(y)
    N = scene.system.N
    Wb = scene.system.inverse_mass_blocks(y)
    WJt = np.einsum("nij,knj->kni", Wb, J.reshape(len(C), N, 6)).reshape(len(C), -1)
    return out, np.linalg.cond(J @ WJt.T)


@pytest.mark.parametrize("seed", range(8))
def test_lean_rhs_equals_readable_on_random_trees(seed):
    # ORACLES I11: ẏ and λ to 64 ε κ(J W Jᵀ) of their scale at random states of random ball/hinge trees
    scene, rb = _random_tree(seed)
    assert _joints(scene)._lean is not None
    y0 = rb.state()
    rng = np.random.default_rng(100 + seed)
    for _ in range(3):
        y = y0 + rng.normal(scale=0.3, size=y0.size)
        ((f1, l1), (f0, l0)), kappa = _both(scene, y)
        assert np.abs(l1 - l0).max() <= 64 * EPS * kappa * np.abs(l0).max()
        assert np.abs(f1 - f0).max() <= 64 * EPS * kappa * np.abs(f0).max()


@pytest.mark.parametrize("ks, kd", [(0.0, 0.0), (400.0, 40.0)])
def test_lean_chain_run_equals_readable_run(ks, kd):
    # ORACLES I11: the chain figure's scene (5 hinges, with and without Baumgarte) stepped 200 RK4 steps both
    # ways: the states agree to 8 ε per step of their scale (measured ≤ 1.6e-15 after 500 steps)
    runs = []
    for lean in (True, False):
        scene, rb, _ = rod_chain(5, 0.5, 1.0, 0.9, 9.81, ks=ks, kd=kd)
        _joints(scene).lean_path = lean
        runs.append(scene.simulate(0.2, 1e-3, "rk4").y)
    assert np.abs(runs[0] - runs[1]).max() <= 8 * EPS * 200 * np.abs(runs[1]).max()


def test_lean_top_run_equals_readable_run():
    # ORACLES I11: one body on a ball joint at the world (chapter 11's top, 3 rows): 200 steps both ways
    runs = []
    for lean in (True, False):
        q = quat_from_axis_angle([1.0, 0.0, 0.0], 0.3)
        rb = RigidBodies(1.0, np.diag([0.2, 0.2, 0.1]), positions=[[0.0, -0.15, 0.48]], orientations=[q],
                         angular_velocities=[[0.0, 0.0, 60.0]])
        jt = RigidJoints([dict(kind="ball", a=0, b=-1, anchor_a=[0, 0, -0.5], anchor_b=[0, 0, 0])])
        scene = RigidScene(rb, [RigidGravity([0, 0, -9.81]), jt])
        jt.lean_path = lean
        runs.append(scene.simulate(0.2, 1e-3, "rk4").y)
    assert np.abs(runs[0] - runs[1]).max() <= 8 * EPS * 200 * np.abs(runs[1]).max()


def test_lean_path_only_for_ball_and_hinge_equalities():
    # ORACLES I11: a slider, a limit or a motor keeps the readable path; so does a dependent pair of rows,
    # which the lean factor hands back (the least squares then solves it)
    rb = RigidBodies(1.0, np.diag([0.1, 0.1, 0.1]), positions=[[0.5, 0.0, 0.0]])
    for extra in (dict(kind="slider", axis_a=[1, 0, 0]), dict(kind="hinge", limits=(-1.0, 1.0)),
                  dict(kind="hinge", motor=0.5)):
        jt = RigidJoints([dict(a=0, b=-1, anchor_a=[-0.5, 0, 0], **extra)])
        RigidScene(rb, [RigidGravity([0, -9.81, 0]), jt])
        assert jt._lean is None
    j = dict(kind="ball", a=0, b=-1, anchor_a=[-0.5, 0, 0], anchor_b=[0, 0, 0])
    jt = RigidJoints([j, j])
    scene = RigidScene(rb, [RigidGravity([0, -9.81, 0]), jt])
    assert jt._lean is not None and jt._lean.constrain(rb.state(), np.zeros((1, 6))) is None
    x = scene.simulate(0.05, 1e-3, "rk4").y[:3, -1]
    assert np.linalg.norm(x) == pytest.approx(0.5, abs=1e-6)


def test_lean_diagnostics_equal_readable():
    # ORACLES I11: the drift max|C| and its rate max|J u| of random trees, lean against the readable rows
    for seed in range(4):
        scene, rb = _random_tree(seed)
        jt = _joints(scene)
        y = rb.state() + np.random.default_rng(seed).normal(scale=0.3, size=rb.state().size)
        C, J, _, Cdot = jt.rows(y)
        d = jt.diagnostics(0.0, y)
        assert d["joint_error"] == pytest.approx(np.abs(C).max(), rel=0, abs=64 * EPS * (1 + np.abs(C).max()))
        scale = np.abs(J).max() * np.abs(rb.generalized_velocity(y)).max()
        assert d["joint_velocity_error"] == pytest.approx(np.abs(Cdot).max(), rel=0, abs=64 * EPS * scale)
