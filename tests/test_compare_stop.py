"""run_compare's ``stop_below``: a sweep capped at the accuracy a plot shows (ORACLES K1)."""

from pbanim.compare import run_compare


def test_an_engine_at_the_error_stop_skips_the_finer_steps_of_its_sweep():
    # ORACLES K1: RK4 is exact on free fall (error ≈ 1e-14 m at every step of the quick sweep): with a stop
    # above that error only the coarsest step runs; with a stop below it (or none) every step runs, ok
    full = run_compare(["free_fall"], ["pbanim"], quick=True, own_steps=False)
    hs = [r.h for r in full.rows]
    assert len(hs) >= 2 and hs[0] == max(hs) and all(r.status == "ok" and r.error < 1e-12 for r in full.rows)
    capped = run_compare(["free_fall"], ["pbanim"], quick=True, own_steps=False, stop_below=1e-12)
    assert [r.h for r in capped.rows] == [hs[0]] and capped.rows[0].error == full.rows[0].error
    low = run_compare(["free_fall"], ["pbanim"], quick=True, own_steps=False, stop_below=1e-30)
    assert [r.h for r in low.rows] == hs
