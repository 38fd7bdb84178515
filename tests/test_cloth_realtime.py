"""The CG tolerance of the real-time large step (chapter 12's benchmark row): the solve's error of one step
against the step's own truncation error.

Each test cites its oracle from ORACLES.md section J (J12). Tolerances: measured first, asserted a fixed
factor above; both numbers are in the comment next to the assert.
"""

from pbanim.bench._cloth_realtime import cg_error_vs_truncation


def test_the_cg_error_of_a_loose_step_stays_below_its_truncation_error():
    # ORACLES J12: B&W stop the CG at a loose residual; on the benchmark's 16 × 16 sheet 6 steps into its fall
    # (h = 1/60 s, line multigrid) the state's distance from the step solved to 1e-10, over the step's
    # truncation error (step doubling), is below 1 at ε = 1e-1 and ~10× smaller at 1e-2: the measure follows ε
    tight = cg_error_vs_truncation(16, 1e-2, "multigrid")
    loose = cg_error_vs_truncation(16, 1e-1, "multigrid")
    assert max(loose) < 1.0, loose                     # measured 0.35 (x), 0.27 (v)
    assert max(tight) < 0.1, tight                     # measured 0.035, 0.025
    assert loose[0] > 3 * tight[0] and loose[1] > 3 * tight[1], (tight, loose)     # measured 10×, 11×
