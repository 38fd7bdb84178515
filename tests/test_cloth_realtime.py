"""The CG tolerance of the real-time large step (chapter 12's benchmark row): the solve's error of one step
against the step's own truncation error.

Each test cites its oracle from ORACLES.md section J (J12, J16). Tolerances: measured first, asserted a fixed
factor above; both numbers are in the comment next to the assert.
"""

import numpy as np
import pytest

from pbanim.bench._cloth_realtime import _free_symplectic, _sheet, _stable, cg_error_vs_truncation, largest_stable_step
from pbanim.cloth.assembly import free_ode


def test_the_cg_error_of_a_loose_step_stays_below_its_truncation_error():
    # ORACLES J12: B&W stop the CG at a loose residual; on the benchmark's 16 × 16 sheet 6 steps into its fall
    # (h = 1/60 s, line multigrid) the state's distance from the step solved to 1e-10, over the step's
    # truncation error (step doubling), is below 1 at ε = 1e-1 and ~10× smaller at 1e-2: the measure follows ε
    tight = cg_error_vs_truncation(16, 1e-2, "multigrid")
    loose = cg_error_vs_truncation(16, 1e-1, "multigrid")
    assert max(loose) < 1.0, loose                     # measured 0.35 (x), 0.27 (v)
    assert max(tight) < 0.1, tight                     # measured 0.035, 0.025
    assert loose[0] > 3 * tight[0] and loose[1] > 3 * tight[1], (tight, loose)     # measured 10×, 11×


@pytest.mark.parametrize("stretch,h", [(1e3, 8e-4), (1e3, 1.6e-3), (1e4, 2e-4)])
def test_symplectic_euler_on_the_free_state_is_the_full_state_step(stretch, h):
    # ORACLES J16: the stability search's symplectic Euler run in place on [x_F, v_F] takes the states of the
    # step through the full state (free_state / full_state each step) bit for bit, and gives the same verdict
    # (h on both sides of the threshold: stable at 8e-4, unstable at 1.6e-3 for k = 1e3 on the 6 × 6 sheet;
    # unstable at 2e-4 for k = 1e4)
    cloth = _sheet(6, stretch)
    f, nf = free_ode(cloth)[0], cloth.nf
    y, yf = cloth.state(), cloth.free_state(cloth.state())
    free_step = _free_symplectic(f, nf)
    for _ in range(40):
        zf = cloth.free_state(y)
        zf[nf:] += h * f(0.0, zf)[nf:]
        zf[:nf] += h * zf[nf:]
        y = cloth.full_state(zf)
        yf = free_step(yf, h)
        assert np.array_equal(yf, cloth.free_state(y)) or not np.isfinite(yf).all()

    def full_step(y, h):
        zf = cloth.free_state(y)
        zf[nf:] += h * f(0.0, zf)[nf:]
        zf[:nf] += h * zf[nf:]
        return cloth.full_state(zf)

    assert (_stable(free_step, cloth.free_state(cloth.state()), nf, h)
            == _stable(full_step, cloth.state(), cloth.n, h))


def test_largest_stable_step_lean_and_readable_agree():
    # ORACLES J16: the search's answer, lean and readable, at stiffnesses whose thresholds differ
    got = [(largest_stable_step("symplectic Euler", k, 6), largest_stable_step("symplectic Euler", k, 6, lean=False))
           for k in (1e2, 1e3)]
    assert all(a == b for a, b in got) and got[0][0] > got[1][0], got
