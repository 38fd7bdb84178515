"""The lean step of small rigid scenes (pbanim.rigid.lean) computes the readable vectorized step (chapter 05).

Each test runs one scene twice, ``scene.lean_path`` True and False, from the same start, and compares the
final states after n steps (roundoff: a few ε per step) and the counts; the physics checks (ORACLES C1,
C3) run on the lean path, which is what a default scene of one body now takes.
"""

import numpy as np
import pytest

from pbanim.errors import SimulationDiverged
from pbanim.ode import get_method
from pbanim.rigid import (AngularDrag, LinearDrag, PointForce, QuaternionRenormalize, RigidBodies, RigidGravity,
                          RigidScene, RigidSprings)
from pbanim.rigid.lean import LEAN_MAX_BODIES, LEAN_METHODS

EPS = np.finfo(float).eps


def _bodies(N=1, static=None):
    rng = np.random.default_rng(N)
    moving = np.ones((N, 1)) if static is None else ~np.array(static)[:, None]
    return RigidBodies(rng.uniform(0.5, 2.0, N), rng.uniform(1.0, 3.0, (N, 3)), positions=rng.normal(size=(N, 3)),
                       orientations=rng.normal(size=(N, 4)), velocities=rng.normal(size=(N, 3)) * moving,
                       angular_velocities=3 * rng.normal(size=(N, 3)) * moving, static=static)


def _both(scene, t_end, h, method):
    scene.lean_path = True
    a = scene.simulate(t_end, h, method, diagnostics=False)
    scene.lean_path = False
    b = scene.simulate(t_end, h, method, diagnostics=False)
    scene.lean_path = True
    return a, b


EFFECTS = {"none": lambda: [], "gravity": lambda: [RigidGravity()],
           "gravity and drag": lambda: [RigidGravity([0.0, -9.81, 1.0]), LinearDrag(0.3), AngularDrag([0.2])]}


@pytest.mark.parametrize("method", LEAN_METHODS)
@pytest.mark.parametrize("quaternions", ["renormalize", "none"])
@pytest.mark.parametrize("effects", list(EFFECTS))
def test_lean_run_equals_the_readable_run_to_roundoff(method, quaternions, effects):
    # ORACLES C3 on both paths: the same q drift (none) or the same renormalized q; states to a few ε per step
    n, h = 300, 2e-3
    scene = RigidScene(_bodies(), EFFECTS[effects](), quaternions=quaternions)
    assert scene._lean_plan is not None
    a, b = _both(scene, n * h, h, method)
    scale = 1.0 + np.abs(b.y).max(axis=1, keepdims=True)
    assert np.abs(a.y - b.y).max() <= 8 * EPS * n * scale.max()
    assert a.nfev == b.nfev == n * (get_method(method).step.nfev if method != "symplectic_euler" else 1)
    np.testing.assert_array_equal(a.t, b.t)


def test_several_bodies_and_a_static_one_take_the_lean_path_too():
    rb = _bodies(5, static=[False, True, False, False, False])
    scene = RigidScene(rb, [RigidGravity(), LinearDrag([0.1, 0.2, 0.3, 0.4, 0.5])])
    a, b = _both(scene, 0.5, 1e-3, "rk4")
    assert np.abs(a.y - b.y).max() <= 8 * EPS * 500 * (1 + np.abs(b.y).max())
    x, q, P, L = rb.unpack(a.y[:, -1])
    x0, q0, _, _ = rb.unpack(a.y[:, 0])
    assert np.array_equal(x[1], x0[1]) and np.abs(q[1] - q0[1]).max() <= 2 * EPS   # the static body stays
    assert not P[1].any() and not L[1].any()


@pytest.mark.parametrize("method", ["rk4", "symplectic_euler"])
def test_a_full_inertia_tensor_takes_the_full_product(method):
    # I_body not diagonal: the lean rates take the 3 × 3 product (a diagonal one skips its zero terms)
    rng = np.random.default_rng(7)
    A = rng.normal(size=(3, 3))
    I = A @ A.T + 2 * np.eye(3)
    rb = RigidBodies(1.5, I, orientations=[[0.9, 0.1, -0.3, 0.2]], angular_velocities=[[1.0, -2.0, 0.5]])
    scene = RigidScene(rb, [RigidGravity(), AngularDrag(0.1)])
    assert scene._lean_plan is not None
    a, b = _both(scene, 0.6, 2e-3, method)
    assert np.abs(a.y - b.y).max() <= 8 * EPS * 300 * (1 + np.abs(b.y).max())


def test_a_single_step_takes_the_path_of_a_run():
    rb = _bodies(2)
    scene = RigidScene(rb, [RigidGravity()])
    y = rb.state()
    fast = scene.step(0.0, y, 1e-2, "rk4")
    scene.lean_path = False
    slow = scene.step(0.0, y, 1e-2, "rk4")
    assert np.abs(fast - slow).max() <= 16 * EPS and fast is not y and np.array_equal(y, rb.state())


def test_torque_free_body_matches_the_elliptic_solution_on_the_lean_path():
    # ORACLES C1: body ω(t) against the Jacobi closed form, L exact (Baraff's state), on the lean path
    from pbanim.models.rigid import torque_free_body

    body = torque_free_body((1.0, 2.0, 3.0), (1.0, 0.1, 2.0))
    rb = body.bodies(orientation=[0.3, 0.5, -0.2, 0.8])
    scene = RigidScene(rb)
    assert scene._lean_plan is not None
    res = scene.simulate(2.0, 1e-3, "rk4")
    w = rb.body_angular_velocity(res.y[:, -1])[0]
    assert np.abs(w - body.omega(2.0)[0]).max() < 1e-8
    L = res.diagnostics["angular_momentum"]
    assert np.abs(L - L[0]).max() == 0.0


def test_renormalized_quaternions_stay_unit_on_the_lean_path():
    # ORACLES C3: with the post-step stage ||q| − 1| < 10ε at every step; without it, Euler's drift law
    rb = RigidBodies(1.0, [2.0, 2.0, 2.0], angular_velocities=[[0.0, 0.0, 4.0]])
    res = RigidScene(rb).simulate(1.0, 0.01, "euler")
    q = res.y[3:7]
    assert np.abs(np.linalg.norm(q, axis=0) - 1).max() < 10 * EPS
    raw = RigidScene(rb, quaternions="none").simulate(1.0, 0.01, "euler")
    norms = np.linalg.norm(raw.y[3:7], axis=0)
    law = (1 + 0.01 ** 2 * 16 / 4) ** (np.arange(norms.size) / 2)
    assert np.abs(norms / law - 1).max() < 1e-12


@pytest.mark.parametrize("make", [
    lambda rb: RigidScene(rb, [RigidGravity(), RigidSprings([0], [[0.0, 0, 0]], [-1], [[0.0, 0, 1]], 10.0)]),
    lambda rb: RigidScene(rb, [PointForce([0], [[0.0, 0.0, 1.0]], [1.0, 0.0, 0.0])]),
    lambda rb: RigidScene(rb, [RigidGravity(), type("MyRenormalize", (QuaternionRenormalize,), {})()]),
], ids=["springs", "point force", "a subclass of a stage"])
def test_scenes_the_lean_path_does_not_cover_run_the_readable_one(make):
    assert make(_bodies())._lean_plan is None


def test_many_bodies_and_other_methods_run_the_readable_path():
    assert RigidScene(_bodies(LEAN_MAX_BODIES + 1), [RigidGravity()])._lean_plan is None
    scene = RigidScene(_bodies(), [RigidGravity()])
    readable = object()
    for name in ("dopri5",):      # (the exp map, the implicit methods and Verlet: tests/test_rigid_lean_expmap.py)
        assert scene._lean_plan.advance(get_method(name), [0, 0], readable) is None


def test_a_zero_quaternion_is_handed_to_the_readable_step():
    scene = RigidScene(_bodies(), [RigidGravity()])
    y = scene.system.state()
    y[3:7] = 0.0
    calls = []
    advance = scene._lean_plan.advance(get_method("rk4"), [0, 0], lambda t, yy, h: calls.append(h) or yy)
    assert advance(0.0, y, 0.1) is y and calls == [0.1]


def test_a_diverging_lean_run_is_named_at_the_step_the_readable_run_names():
    rb = RigidBodies(1.0, [1.0, 2.0, 3.0], angular_velocities=[[1e140, 2e140, 0.5e140]])
    errors = []
    for lean in (True, False):
        scene = RigidScene(rb, quaternions="none")
        scene.lean_path = lean
        with pytest.raises(SimulationDiverged) as info:
            scene.simulate(1.0, 0.1, "euler", diagnostics=False)
        errors.append((info.value.t, info.value.step))
    assert errors[0] == errors[1]


def test_floor_row_of_chapter_05_is_equal_work():
    # pbanim bench floors: the hand loop (RK4 on floats, q renormalized) computes what the scene's run computes
    from pbanim.bench import _floor_rigid

    for make in _floor_rigid.FLOORS:
        fl = make()
        a, b = np.asarray(fl.pbanim(), float), np.asarray(fl.hand(), float)
        assert a.shape == b.shape and np.abs(a - b).max() / max(1.0, np.abs(b).max()) <= fl.tol, fl.scene
