"""The float exponential map (pbanim.rigid.lean_expmap), the implicit methods on float rates (pbanim.rigid.lean,
FLOAT_RATE_METHODS) and the float rigid-body Verlet (LeanRigid.verlet) compute the readable steps (chapter 05).

Each test runs one scene twice, ``scene.lean_path`` True and False, from the same start, and compares the
final states after n steps (roundoff: a few ε per step; the implicit methods' Newton iterations on
forward-difference Jacobians of the two rates, which agree to roundoff, converge to the same step) and the
counts of f (ORACLES C4); the physics checks (ORACLES C1, C3) run on the lean path.
"""

import numpy as np
import pytest

from pbanim.models.rigid import torque_free_body
from pbanim.rigid import AngularDrag, LinearDrag, QuaternionRenormalize, RigidBodies, RigidGravity, RigidScene

EPS = np.finfo(float).eps


def _bodies(N=1, static=None):
    rng = np.random.default_rng(N + 7)
    moving = np.ones((N, 1)) if static is None else ~np.array(static)[:, None]
    return RigidBodies(rng.uniform(0.5, 2.0, N), rng.uniform(1.5, 2.5, (N, 3)), positions=rng.normal(size=(N, 3)),
                       orientations=rng.normal(size=(N, 4)), velocities=rng.normal(size=(N, 3)) * moving,
                       angular_velocities=3 * rng.normal(size=(N, 3)) * moving, static=static)


def _both(scene, n, h, method):
    runs = []
    for lean in (True, False):
        scene.lean_path = lean
        runs.append(scene.simulate(n * h, h, method, diagnostics=False))
    scene.lean_path = True
    return runs


def _effects():
    return [RigidGravity([0.0, -9.81, 1.0]), LinearDrag(0.3), AngularDrag([0.2])]


@pytest.mark.parametrize("method", ["euler", "midpoint", "rk4", "symplectic_euler", "verlet", "implicit_midpoint"])
def test_float_exponential_map_equals_the_readable_one(method):
    # ORACLES C3: the exp map keeps |q| = 1 to roundoff on both paths; the states agree to a few ε per step
    n, h = 150, 4e-3
    scene = RigidScene(_bodies(), _effects(), quaternions="exponential")
    assert type(scene._lean_plan).__name__ == "LeanExpMap"
    a, b = _both(scene, n, h, method)
    assert np.abs(a.y - b.y).max() <= 8 * EPS * n * (1.0 + np.abs(b.y).max())
    assert a.nfev == b.nfev > 0
    assert np.abs(np.linalg.norm(a.y[3:7], axis=0) - 1).max() <= 8 * EPS * n


def test_float_exponential_map_several_bodies_a_static_one_and_a_renormalization():
    rb = _bodies(4, static=[False, True, False, False])
    scene = RigidScene(rb, [*_effects(), QuaternionRenormalize()], quaternions="exponential")
    a, b = _both(scene, 100, 5e-3, "rk4")
    assert np.abs(a.y - b.y).max() <= 8 * EPS * 100 * (1.0 + np.abs(b.y).max())
    np.testing.assert_allclose(a.y[16:20, -1], rb.state()[16:20], rtol=0, atol=4 * EPS)   # the static body's q


@pytest.mark.parametrize("quaternions", ["renormalize", "none"])
@pytest.mark.parametrize("method", ["implicit_euler", "implicit_midpoint"])
def test_implicit_methods_on_float_rates_equal_the_readable_step(method, quaternions):
    n, h = 100, 5e-3
    scene = RigidScene(_bodies(2), _effects(), quaternions=quaternions)
    a, b = _both(scene, n, h, method)
    assert np.abs(a.y - b.y).max() <= 8 * EPS * n * (1.0 + np.abs(b.y).max())
    assert a.nfev == b.nfev


def test_float_exponential_map_rk4_converges_at_order_4_to_the_closed_form():
    # ORACLES C1: ω(t) of the torque-free body against the Jacobi elliptic closed form, RKMK RK4 on floats;
    # the fitted slope of the error over h is the method's order
    body = torque_free_body((1.0, 2.0, 3.0), (1.0, 0.1, 2.0))
    rb = body.bodies(orientation=[0.3, 0.5, -0.2, 0.8])
    scene = RigidScene(rb, quaternions="exponential")
    hs = np.array([0.1, 0.05, 0.025])
    errs = [np.abs(rb.body_angular_velocity(scene.simulate(2.0, h, "rk4", diagnostics=False).y[:, -1])[0]
                   - body.omega(2.0)[0]).max() for h in hs]
    slope = np.polyfit(np.log(hs), np.log(errs), 1)[0]
    assert 3.7 < slope < 4.3, (slope, errs)


@pytest.mark.parametrize("quaternions", ["renormalize", "none"])
@pytest.mark.parametrize("effects", ["none", "gravity and drag"])
def test_float_rigid_verlet_equals_the_splitting_step(quaternions, effects):
    # ORACLES C1 (the splitting keeps |L| of a free body and |q| = 1 to roundoff) on both paths
    n, h = 200, 4e-3
    scene = RigidScene(_bodies(), _effects() if effects != "none" else [], quaternions=quaternions)
    a, b = _both(scene, n, h, "verlet")
    assert np.abs(a.y - b.y).max() <= 8 * EPS * n * (1.0 + np.abs(b.y).max())
    assert a.nfev == b.nfev == 2 * n
    assert np.abs(np.linalg.norm(a.y[3:7], axis=0) - 1).max() <= 8 * EPS * n
    if effects == "none":
        L = np.linalg.norm(a.y[10:13], axis=0)
        assert np.abs(L / L[0] - 1).max() <= 4 * EPS


def test_several_bodies_take_the_readable_splitting():
    scene = RigidScene(_bodies(2), _effects())
    from pbanim.ode import get_method

    assert scene._lean_plan.advance(get_method("verlet"), [0, 0], object()) is None
