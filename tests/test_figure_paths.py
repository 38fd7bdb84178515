"""The shorter paths the chapters' figures take (issue 28, ``pbanim figures`` in three minutes) compute what
the readable paths compute.

Each test compares the short path with the readable one on the same input: bit for bit where the same
floating-point operations run in the same order, else to a few ε.
"""

import numpy as np
import pytest

from pbanim.errors import InvalidInput
from pbanim.rigid import quat_to_matrix

EPS = np.finfo(float).eps


@pytest.mark.parametrize("shape", [(4,), (1, 4)])
def test_one_quaternion_takes_the_float_path_and_gives_the_batch_rotation(shape):
    # ORACLES C3: R is built from q/|q| whatever |q|; one quaternion on Python floats, the same products in
    # the same order as the batch formula (here the row of a batch of three), so the same matrix to 2 ε
    rng = np.random.default_rng(7)
    for scale in (1e-120, 1e-3, 1.0, 7.5, 1e120):
        qs = rng.normal(size=(3, 4)) * scale
        batch = quat_to_matrix(qs)
        for q, R_batch in zip(qs, batch):
            R = quat_to_matrix(q.reshape(shape))
            assert R.shape == shape[:-1] + (3, 3)
            R = R.reshape(3, 3)
            assert np.abs(R - R_batch).max() <= 2 * EPS
            assert np.abs(R @ R.T - np.eye(3)).max() < 1e-14 and abs(np.linalg.det(R) - 1.0) < 1e-14


def test_one_quaternion_out_of_range_or_zero_takes_the_guarded_path():
    # |q|² beyond 1e290 (or below 1e-290) is scaled first: the same rotation as the unit quaternion
    q = np.array([1.0, 2.0, -2.0, 4.0])
    R = quat_to_matrix(q / 5.0)
    for s in (1e-160, 1e160):
        assert np.abs(quat_to_matrix(q * s) - R).max() < 4 * EPS
    with pytest.raises(InvalidInput, match="quat"):
        quat_to_matrix(np.zeros(4))
