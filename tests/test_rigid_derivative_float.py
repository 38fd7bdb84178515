"""The rigid bodies' right-hand side on floats (pbanim.rigid.derivative_float) equals the vectorized one (ORACLES C5).

``RigidBodies.derivative`` of a few bodies runs on Python floats; ``rb.lean_path = False`` runs the numpy arrays.
On this package's numpy the two give the same bits (the products in the same order, a zero's sign included);
the stated tolerance elsewhere is a few ulps of the largest product, which these tests would report as a
failure of the bit-for-bit claim — they check array_equal and the signs of zeros.
"""

import numpy as np
import pytest

from pbanim.articulated.joints import RigidJoints
from pbanim.rigid import RigidBodies, RigidGravity, RigidScene
from pbanim.rigid.derivative_float import FLOAT_MAX_BODIES, derivative_floats


def _random_bodies(rng, N, full, static):
    m = rng.uniform(1.0, 1.8, (N, 3))                       # principal moments: I1 + I2 >= I3 always
    if full:                                                # a rotated tensor: off-diagonal entries
        axes = np.linalg.qr(rng.normal(size=(N, 3, 3)))[0]
        m = axes @ (m[:, :, None] * axes.transpose(0, 2, 1))
        m = 0.5 * (m + m.transpose(0, 2, 1))
    else:
        m = m[:, :, None] * np.eye(3)                       # (N, 3, 3): not read as one tensor when N = 3
    return RigidBodies(rng.uniform(0.5, 2.0, N), m, static=static)


def _vectorized(rb, y, Q):
    return RigidBodies.derivative_and_omega.__wrapped__(rb, y, Q)


def _same_bits(a, b):
    return np.array_equal(a, b) and np.array_equal(np.signbit(a), np.signbit(b))


@pytest.mark.parametrize("N", [1, 2, 3, FLOAT_MAX_BODIES])
@pytest.mark.parametrize("full", [False, True])
def test_float_derivative_equals_vectorized_bit_for_bit(N, full):
    rng = np.random.default_rng(10 * N + full)
    for k in range(60):
        static = (rng.random(N) < 0.3) if (k % 3 == 0 and N > 1) else None
        rb = _random_bodies(rng, N, full, static)
        y = rng.normal(size=13 * N) * rng.choice([1e-3, 1.0, 1e3])
        if k % 4 == 0:
            y[10 * N:] = 0.0                        # L = 0: ω and q̇ exactly zero, with signs
        Q = rng.normal(size=(N, 6))
        dy, w = derivative_floats(rb, y, Q)
        dy_ref, w_ref = _vectorized(rb, y, Q)
        assert _same_bits(dy, dy_ref) and _same_bits(w, w_ref)
        rb.lean_path = True
        fast = RigidBodies.derivative.__wrapped__(rb, y, Q)
        rb.lean_path = False
        slow = RigidBodies.derivative.__wrapped__(rb, y, Q)
        assert _same_bits(fast, slow) and _same_bits(fast, dy_ref)


def test_float_derivative_differs_from_a_wrong_order():
    """The check above can fail: an ω summed in another order (or with the inverse inertia transposed) is seen."""
    rng = np.random.default_rng(3)
    rb = _random_bodies(rng, 3, True, None)
    y, Q = rng.normal(size=39), rng.normal(size=(3, 6))
    rb.inv_I_body = rb.inv_I_body + 1e-3 * rng.normal(size=(3, 3, 3))   # not symmetric: transposing shows
    dy, _ = derivative_floats(rb, y, Q)
    rb2 = _random_bodies(np.random.default_rng(3), 3, True, None)
    rb2.inv_I_body = np.swapaxes(rb.inv_I_body, 1, 2).copy()
    assert not np.array_equal(dy, _vectorized(rb2, y, Q)[0])
    assert _same_bits(dy, _vectorized(rb, y, Q)[0])


def test_large_scenes_and_subclasses_take_the_arrays(monkeypatch):
    calls = []
    import pbanim.rigid.bodies as bodies

    monkeypatch.setattr(bodies, "derivative_floats", lambda *a: calls.append(1) or derivative_floats(*a))
    rng = np.random.default_rng(0)
    big = _random_bodies(rng, FLOAT_MAX_BODIES + 1, False, None)
    RigidBodies.derivative.__wrapped__(big, rng.normal(size=13 * big.N), np.zeros((big.N, 6)))
    assert calls == []

    class Mine(RigidBodies):
        def derivative_and_omega(self, y, Q):               # a user's own ẏ: runs what it wrote
            return RigidBodies.derivative_and_omega.__wrapped__(self, y, Q)

    mine = Mine(1.0, [1.0, 2.0, 2.5])
    RigidBodies.derivative.__wrapped__(mine, mine.state(), np.zeros((1, 6)))
    assert calls == []
    small = RigidBodies(1.0, [1.0, 2.0, 2.5])
    RigidBodies.derivative.__wrapped__(small, small.state(), np.zeros((1, 6)))
    assert calls == [1]


def test_zero_quaternion_is_handed_to_the_arrays():
    """A quaternion collapsed to 0: the float twin raises, derivative() returns what the arrays give."""
    rb = RigidBodies([1.0, 1.0], [1.0, 1.5, 1.8])
    y = rb.state()
    y[6:10] = 0.0                                            # body 1's quaternion
    with pytest.raises(ZeroDivisionError):
        derivative_floats(rb, y, np.zeros((2, 6)))
    with np.errstate(all="ignore"):
        got = RigidBodies.derivative.__wrapped__(rb, y, np.zeros((2, 6)))
        ref = _vectorized(rb, y, np.zeros((2, 6)))[0]
    assert np.array_equal(got, ref, equal_nan=True) and np.isnan(got[6:10]).all()       # body 1's q̇


def test_a_jointed_chain_runs_the_same_states():
    """The compare harness's chain (three rods, ball joints, RK4): the same trajectory bit for bit."""
    from pbanim.models.articulated import rod_chain

    _, rb, _ = rod_chain(3, 0.5, 1.0, 0.9, 9.81)
    runs = []
    for lean in (True, False):
        rb.lean_path = lean
        joints = RigidJoints([dict(kind="ball", a=-1, b=0, anchor_a=[0.0, 0.0, 0.0], anchor_b=[0.0, 0.25, 0.0])])
        res = RigidScene(rb, [RigidGravity([0.0, -9.81, 0.0]), joints]).simulate(0.2, 1e-2, "rk4")
        runs.append(np.asarray(res.y))
    rb.lean_path = True
    assert _same_bits(runs[0], runs[1])


def test_float_renormalization_equals_the_arrays():
    """QuaternionRenormalize.post_step of a few bodies on floats: the same bits as the arrays' q/|q|, also where
    the arrays rescale a |q|² that would overflow or underflow (the float twin hands those to them) and for NaN."""
    from pbanim.contracts import unchecked
    from pbanim.rigid import QuaternionRenormalize

    rng = np.random.default_rng(5)
    for k in range(400):
        N = int(rng.integers(1, FLOAT_MAX_BODIES + 1))
        rb = RigidBodies(np.ones(N), [1.0, 1.5, 1.8])
        stage = QuaternionRenormalize()
        stage.bind(rb)
        y = rng.normal(size=13 * N) * rng.choice([1e-3, 1.0, 1e3])
        if k % 5 == 0:
            y[3 * N:3 * N + 4] *= rng.choice([1e160, 1e-160])     # |q|² beyond the direct range
        if k % 37 == 0:
            y[3 * N] = np.nan
        fast, slow = y.copy(), y.copy()
        rb.lean_path = True
        with np.errstate(all="ignore"):
            unchecked(stage.post_step)(0.0, fast, 0.01)
            rb.lean_path = False
            unchecked(stage.post_step)(0.0, slow, 0.01)
        assert np.array_equal(fast, slow, equal_nan=True)
        assert np.array_equal(np.signbit(fast), np.signbit(slow))
        if k % 5 and k % 37:                                     # and it is q/|q| to roundoff
            q = y[3 * N:7 * N].reshape(N, 4)
            assert np.allclose(fast[3 * N:7 * N].reshape(N, 4), q / np.linalg.norm(q, axis=1, keepdims=True),
                               rtol=4e-16, atol=0)
