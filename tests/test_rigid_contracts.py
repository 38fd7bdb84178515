"""Chapter 05 under its contracts (issue 27): each defect the contract fuzz found in pbanim.rigid, as a test.

Each test states what happened before the fix. Oracles: C3 (R is built from q/|q|, |q| = 1 after the
post-step), G3 (invalid input gives a named error naming the argument; nothing returns NaN).
"""

import numpy as np
import pytest

from pbanim.errors import InvalidInput, NonFiniteResult, SimulationDiverged
from pbanim.rigid import (MassProperties, PointForce, QuaternionRenormalize, RigidBodies, RigidScene, box_mesh,
                          dexpinv, exp_map_step, matrix_to_quat, mesh_mass_properties, parallel_axis, principal_axes,
                          quat_exp, quat_from_axis_angle, quat_multiply, quat_normalize, quat_rotate, quat_to_matrix)

QZ = np.array([1.0, 0.0, 0.0, 1.0])             # 90° about z, |q| = √2
RZ = np.array([[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]])


def _body():
    return RigidBodies(1.0, [1.0, 2.0, 2.5], angular_velocities=[[0.1, 3.0, 0.1]])


# -- quaternions at the ends of the double range (ORACLES C3: R from q/|q|, whatever |q|) ---------------------
@pytest.mark.parametrize("scale", [1e300, 1e-300, 1.0])
def test_rotation_of_a_huge_or_tiny_quaternion_is_its_unit_quaternions(scale):
    # before: |q|² overflowed (1e300: s = 2/|q|² = 0, R = E, silently wrong) or underflowed (1e-300: NaN)
    np.testing.assert_allclose(quat_to_matrix(scale * QZ), RZ, atol=1e-15)
    np.testing.assert_allclose(quat_rotate(scale * QZ, [1.0, 0.0, 0.0]), [0.0, 1.0, 0.0], atol=1e-15)


@pytest.mark.parametrize("scale", [1e300, 1e-300])
def test_normalize_and_renormalize_huge_or_tiny_quaternions(scale):
    # before: quat_normalize refused them (norm inf or 0), the post-step "renormalize" set q to zero (q/inf)
    q = scale * np.array([3.0, 0.0, 4.0, 0.0])
    np.testing.assert_allclose(quat_normalize(q), [0.6, 0.0, 0.8, 0.0], rtol=1e-15)
    rb = _body()
    eff = QuaternionRenormalize()
    eff.bind(rb)
    y = rb.state()
    rb.unpack(y)[1][0] = q
    np.testing.assert_allclose(rb.unpack(eff.post_step(0.0, y, 0.01))[1][0], [0.6, 0.0, 0.8, 0.0], rtol=1e-15)


def test_renormalize_leaves_a_unit_quaternion_bit_for_bit():
    # a static body's quaternion must not drift by roundoff through the post-step (test_static_bodies_never_move)
    rb = _body()
    eff = QuaternionRenormalize()
    eff.bind(rb)
    y = rb.state()
    q = np.array([0.9, 0.3, -0.2, 0.25]) / np.linalg.norm([0.9, 0.3, -0.2, 0.25])
    q = q / np.sqrt(np.sum(q * q))
    rb.unpack(y)[1][0] = q
    once = eff.post_step(0.0, y.copy(), 0.01)
    np.testing.assert_array_equal(eff.post_step(0.0, once.copy(), 0.01), once)


def test_exponential_map_and_axis_angle_of_huge_vectors_are_unit_quaternions():
    # before: quat_exp([1e300, 1e300, 0]) was NaN; an axis of 1e300 gave (cos θ/2, 0, 0, 0), not a unit q
    q = quat_exp([1e300, 1e300, 0.0])
    assert np.all(np.isfinite(q)) and abs(np.linalg.norm(q) - 1) < 1e-15 and q[1] == q[2]
    np.testing.assert_allclose(quat_from_axis_angle([1e300, 0.0, 0.0], 0.5), quat_from_axis_angle([1.0, 0, 0], 0.5))


def test_axis_angle_takes_a_batch_of_axes_with_one_angle():
    # before: a bare ValueError from np.concatenate (cos of one angle has one axis, the axes two)
    q = quat_from_axis_angle([[1.0, 0, 0], [0, 2.0, 0]], 0.5)
    np.testing.assert_allclose(q, [quat_from_axis_angle([1.0, 0, 0], 0.5), quat_from_axis_angle([0, 1.0, 0], 0.5)])
    with pytest.raises(InvalidInput, match=r"axis and angle must be one each, or batches of one length, got axis "
                                           r"\(2, 3\) and angle \(3,\)"):
        quat_from_axis_angle([[1.0, 0, 0], [0, 1.0, 0]], [0.1, 0.2, 0.3])


# -- one state or a batch: the same named error for the same bad input ----------------------------------------
@pytest.mark.parametrize("batch", [False, True])
def test_zero_quaternion_is_refused_alone_or_in_a_batch(batch):
    # before: NaN rotation matrices (one state and batch alike); ORACLES G3
    q = np.array([[1.0, 0, 0, 0], [0.0, 0, 0, 0]]) if batch else np.zeros(4)
    for f, name in ((quat_to_matrix, "quat"), (quat_normalize, "q")):
        with pytest.raises(InvalidInput, match=rf"{f.__name__}: {name} must be quaternions .*non-zero, got .*"
                                               rf"{'row 1 is zero' if batch else 'it is zero'}"):
            f(q)


@pytest.mark.parametrize("batch", [False, True])
def test_quaternion_product_overflow_is_named_alone_or_in_a_batch(batch):
    # before: [inf, nan, 0, 0] for one product and for the batch alike
    a, b = np.array([1e200, 1e200, 0, 0]), np.array([1e200, -1e200, 0, 0])
    with pytest.raises(NonFiniteResult, match="quat_multiply"):
        quat_multiply(np.stack([a, a]) if batch else a, b)
    with pytest.raises(InvalidInput, match=r"a and b must be one each, or batches of one length"):
        quat_multiply(np.ones((2, 4)), np.ones((3, 4)))


@pytest.mark.parametrize("batch", [False, True])
def test_inertia_helpers_agree_alone_or_in_a_batch(batch):
    # the same named error for one tensor and for a stack holding it: an overflow, an impossible tensor
    I, bad = np.diag([1.0, 2.0, 2.5]), np.diag([1.0, 1.0, 3.0])
    stack = (lambda a: np.stack([I, a])) if batch else (lambda a: a)
    with pytest.raises(NonFiniteResult, match="parallel_axis"):
        parallel_axis(stack(I), 1.0, [1e300, 1e300, 0.0])
    for f in (principal_axes, lambda a: parallel_axis(a, 1.0, [1.0, 0, 0])):
        with pytest.raises(InvalidInput, match=rf"inertia must be .*{'tensor 1: ' if batch else ''}principal moments "
                                               r"\[1. 1. 3.\] violate the triangle inequality"):
            f(stack(bad))


@pytest.mark.parametrize("method", ["velocities", "kinetic_energy", "rotations", "derivative"])
def test_one_state_methods_refuse_a_batch_of_states_and_strings_by_name(method):
    # before: "cannot reshape array of size 26 into shape (1, 3)" (ValueError) or "'str' object has no
    # attribute 'reshape'" (AttributeError) from inside numpy
    rb = _body()
    args = (rb.zero_forces(),) if method == "derivative" else ()
    Y = np.stack([rb.state(), rb.state()])
    with pytest.raises(InvalidInput, match=rf"RigidBodies.{method}: y must be .*; a batch of states is not accepted"):
        getattr(rb, method)(Y, *args)
    with pytest.raises(InvalidInput, match=rf"RigidBodies.{method}: y must be .*got 'abc'"):
        getattr(rb, method)("abc", *args)
    assert rb.n_state == 13 * rb.N == 13


def test_a_state_with_a_zero_quaternion_is_refused_by_name():
    # before: NaN velocities and rotation matrices; ORACLES G3
    rb = _body()
    y = rb.state()
    rb.unpack(y)[1][0] = 0.0
    with pytest.raises(InvalidInput, match=r"RigidBodies.velocities: y must be .*the quaternion of body 0 is zero"):
        rb.velocities(y)


# -- physically impossible inertia tensors (ORACLES G3) -------------------------------------------------------
@pytest.mark.parametrize("call", [lambda I: principal_axes(I), lambda I: parallel_axis(I, 1.0, [1.0, 0, 0]),
                                  lambda I: MassProperties(1.0, np.zeros(3), I, 1.0)])
def test_impossible_inertia_tensors_are_refused_by_name(call):
    # before: principal_axes(diag(1, 1, 3)) returned its "moments", parallel_axis shifted a non-symmetric tensor
    for I, why in ((np.diag([1.0, 1.0, 3.0]), "violate the triangle inequality I1 \\+ I2 >= I3"),
                   (np.array([[1.0, 0.5, 0], [0, 1.0, 0], [0, 0, 1.0]]), "it is not symmetric"),
                   (np.diag([-1.0, 1.0, 1.0]), "are not all")):
        with pytest.raises(InvalidInput, match=rf"inertia must be an inertia tensor .*got .*; .*{why}"):
            call(I)
    call(np.diag([1.0, 1.0, 2.0]))         # a lamina (equality) is a body


def test_mesh_mass_properties_certify_the_solid():
    # before: a box with an inverted box 10 m away passed the closedness and volume checks and returned the
    # "inertia" with moments (−109, −109, 5.2); now the result's own admissibility refuses the mesh by name
    v1, f1 = box_mesh([2.0, 2.0, 2.0])
    v2, f2 = box_mesh([1.0, 1.0, 1.0])
    with pytest.raises(InvalidInput, match=r"mesh_mass_properties: faces must bound a solid .*principal moments "
                                           r"\[-109.1"):
        mesh_mass_properties(np.vstack([v1, v2 + [10.0, 0, 0]]), np.vstack([f1, f2[:, ::-1] + 8]))
    hollow = mesh_mass_properties(np.vstack([v1, v2]), np.vstack([f1, f2[:, ::-1] + 8]))    # a cavity is a body
    assert hollow.volume == 7.0 and np.all(np.linalg.eigvalsh(hollow.inertia) > 0)


def test_matrix_to_quat_refuses_a_matrix_that_is_no_rotation():
    # before: matrix_to_quat(2 E) returned (1.32, 0, 0, 0), a quaternion of no rotation
    with pytest.raises(InvalidInput, match=r"matrix_to_quat: R must be .*a rotation .*got .*max \|R\^T R - E\| = 3"):
        matrix_to_quat(2 * np.eye(3))
    with pytest.raises(InvalidInput, match=r"det R = -1"):
        matrix_to_quat(np.diag([1.0, 1.0, -1.0]))
    np.testing.assert_allclose(matrix_to_quat(RZ), QZ / np.sqrt(2), atol=1e-15)


# -- numbers that cannot be answered, named instead of NaN --------------------------------------------------
def test_dexpinv_refuses_the_poles_of_its_domain():
    # before: dexpinv at |θ| = 2π gave -2.6e16 (the pole of (a/2) cot(a/2)), at |θ| = 1e300 NaN
    for theta in ([2 * np.pi, 0, 0], [1e300, 0, 0]):
        with pytest.raises(InvalidInput, match=r"dexpinv: theta must be .*of norm < 6.28319, got .*\|theta\| = "):
            dexpinv(theta, [0.0, 1.0, 0.0])
    np.testing.assert_allclose(dexpinv([1.0, 0, 0], [1.0, 0, 0]), [1.0, 0, 0])   # ω ∥ θ: dexp⁻¹ ω = ω


def test_center_of_mass_of_static_bodies_only():
    # before: 0/0 = NaN (the masses of static bodies are not counted); now the mean of their positions
    rb = RigidBodies([np.inf, np.inf], [1.0, 1.0, 1.0], positions=[[0.0, 0, 0], [2.0, 0, 0]])
    np.testing.assert_array_equal(rb.center_of_mass(rb.state()), [1.0, 0, 0])
    np.testing.assert_array_equal(rb.angular_momentum_com(rb.state()), [0.0, 0, 0])


def test_overflow_from_finite_input_is_a_named_error():
    # before: RigidBodies(1e300, ..., v = 1e300) stored P = inf; the derivative of a state of 1e300 had NaN
    with pytest.raises(NonFiniteResult, match=r"RigidBodies: the momenta P = m v and L = I ω"):
        RigidBodies(1e300, [1.0, 1.0, 1.0], velocities=[[1e300, 0, 0]])
    rb = _body()
    with pytest.raises(NonFiniteResult, match=r"RigidBodies.derivative"):
        rb.derivative(np.full(13, 1e300), rb.zero_forces())


def test_an_overflowing_force_during_a_run_is_simulation_diverged():
    # a force that overflows from a finite state inside RigidScene.simulate stops the run at that step (the
    # loop checks the state, not each force: the step pays no certificate)
    rb = _body()
    pf = PointForce([0], [[1e200, 0, 0]], lambda t, y: np.array([[0.0, 1e200, 1e200]]))
    with pytest.raises(SimulationDiverged, match=r"at t = 0 \(step 0\): state is not finite"):
        RigidScene(rb, [pf]).simulate(0.1, 0.05, "euler")


def test_user_force_callables_of_the_wrong_shape_are_named():
    # before: a bare ValueError ("array is not broadcastable", "cannot reshape array of size 6 into (2, 6)")
    rb = _body()
    pf = PointForce([0], [[0.1, 0, 0]], lambda t, y: np.ones((2, 3)))
    with pytest.raises(InvalidInput, match=r"PointForce: force\(t, y\) must return an array of shape \(1, 3\) or "
                                           r"\(3,\), got shape \(2, 3\)"):
        RigidScene(rb, [pf]).simulate(0.1, 0.05, "euler")
    rb2 = RigidBodies([1.0, 1.0], [1.0, 2.0, 2.5])
    with pytest.raises(InvalidInput, match=r"exp_map_step: forces\(t, y\) must return an array of shape \(2, 6\), "
                                           r"got shape \(6,\)"):
        exp_map_step(rb2, lambda t, y: np.zeros(6), 0.0, rb2.state(), 0.1)
    with pytest.raises(InvalidInput, match=r"exp_map_step: counter must be a list whose first item is an integer"):
        exp_map_step(rb2, lambda t, y: np.zeros((2, 6)), 0.0, rb2.state(), 0.1, counter=(0,))
