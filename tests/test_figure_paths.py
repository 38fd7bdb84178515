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


def test_red_black_sweeps_on_the_cached_masks_are_the_hand_written_sweeps():
    # ORACLES E2's smoother: red–black Gauss–Seidel x_c ← x_c + (r − A x)_c / a_c, the cells with Σ indices
    # even first; the masks are made once per shape (read-only) and the sweeps equal a loop written here
    # with masks made anew, bit for bit (the same operations on the same numbers)
    from pbanim.fluids import Grid
    from pbanim.fluids.poisson import CellOperator, relax

    rng = np.random.default_rng(3)
    X, Y = Grid((12, 10), 0.1).positions()
    grid = Grid((12, 10), 0.1, "walls", solid=(X - 0.6) ** 2 + (Y - 0.5) ** 2 < 0.2 ** 2)
    A = CellOperator(grid, 0.0, 1.0)
    r, x0 = rng.normal(size=grid.shape), rng.normal(size=grid.shape)
    red = np.add.outer(np.arange(12), np.arange(10)) % 2 == 0
    for reverse in (False, True):
        x = x0.copy()
        for _ in range(3):
            for c in ((~red, red) if reverse else (red, ~red)):
                x = np.where(c, x + (r - A(x)) / A.diag, x)
        got, sweeps = relax(A, r, x0.copy(), "gauss_seidel", 3, reverse=reverse)
        assert sweeps == 3 and np.array_equal(got, x)
    from pbanim.fluids.multigrid import _colours

    masks = _colours((12, 10))
    assert np.array_equal(masks[0], red) and np.array_equal(masks[1], ~red)
    with pytest.raises(ValueError):
        masks[0][0, 0] = False


def test_run_figures_hands_back_each_figures_cpu_seconds(tmp_path):
    # the cost= hints schedule the run (longest first) and are set from these numbers: one entry per figure,
    # the number its progress line prints
    from pbanim.cli import load_chapters
    from pbanim.plotting import run_figures

    specs = {k: s for k, s in load_chapters(["ch01"]).items() if k == "ch01_projectile_drag"}
    cpu, lines = {}, []
    files, seconds, _ = run_figures(specs, tmp_path, quick=True, jobs=1, progress=lines.append, cpu=cpu)
    assert list(cpu) == list(seconds) == list(specs) and all(np.isfinite(v) and v >= 0 for v in cpu.values())
    assert lines == [f"[1/1] ch01_projectile_drag: {files['ch01_projectile_drag'][0].name} "
                     f"({seconds['ch01_projectile_drag']:.1f}s; cpu {cpu['ch01_projectile_drag']:.1f}s)"]
