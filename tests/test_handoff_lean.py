"""The hand-off's active set on floats is the library's hand-off bit for bit (ORACLES I14)."""

from collections import Counter

import numpy as np
import pytest

from pbanim.lcp.box import box_friction_handoff
from pbanim.lcp.handoff_lean import handoff_floats


def _same(a, r) -> bool:
    z, res, sweeps, state, ok = r
    return (np.array_equal(a[0], z) and a[1] == res and a[2] == sweeps and a[4] == ok
            and a[3] == [tuple(x) for x in np.asarray(state).tolist()])


def test_random_problems_and_guesses_give_the_library_answer():
    # ORACLES I14: random A = J Jᵀ + 1e-4 𝟙 (rank-deficient J: redundant rows) of 1–8 contacts, random b, μ in
    # {0, 0.3, 0.9} and random first guesses (on/off, sticking, sliding ±): z, residual, sweeps, states and
    # certificate exactly equal; the three routes (the guess certifies, exchanges, PGS chunks) all taken
    rng = np.random.default_rng(0)
    routes = Counter()
    for _ in range(300):
        m = int(rng.integers(1, 9))
        J = rng.normal(size=(3 * m, 2 * m + 3))
        A = J @ J.T + 1e-4 * np.eye(3 * m)
        b = rng.normal(size=3 * m)
        mu = float(rng.choice([0.0, 0.3, 0.9]))
        guess = [(1, int(rng.integers(-1, 2)), int(rng.integers(-1, 2))) if rng.uniform() < 0.6 else (0, 0, 0)
                 for _ in range(m)]
        a = handoff_floats(A.copy(), b, mu, guess, max_iter=300, tol=1e-6)
        r = box_friction_handoff(A.copy(), b, np.full(m, mu), state=np.array(guess), max_iter=300, tol=1e-6)
        assert _same(a, r)
        routes["pgs" if a[2] else "certified" if a[3] == guess else "exchanged"] += 1
    assert routes["pgs"] > 0 and routes["certified"] > 0 and routes["exchanged"] > 0, routes


def test_every_contact_problem_of_the_walk_gives_the_library_answer(monkeypatch):
    # ORACLES I14: 0.6 s of the 3-D walk (300 steps at 2 ms: the start, the first strikes, both soles flat):
    # each contact problem the lean step solves, solved by the library's hand-off too, exactly equal
    import pbanim.control.biped3d_step as step
    from pbanim.control.simbicon3d_walk import simulate_walk3d

    seen = Counter()

    def both(A, b, mu, state, **kw):
        a = handoff_floats(A.copy(), b, mu, state, **kw)
        r = box_friction_handoff(A, b, np.full(len(state), mu), state=np.array(state), **kw)
        assert _same(a, r)
        seen[len(state)] += 1
        return a

    monkeypatch.setattr(step, "_handoff_floats", both)
    r = simulate_walk3d(t_end=0.6, h=2e-3, record_every=100)
    assert not r.fell and sum(seen.values()) >= 250 and len(seen) >= 2, seen


@pytest.mark.parametrize("mu", (0.0, 0.9))
def test_a_guess_that_is_right_needs_no_sweep(mu):
    # ORACLES I14, I12: the states returned, given back as the guess, certify at once (no sweep) with the same z
    rng = np.random.default_rng(3)
    J = rng.normal(size=(12, 9))
    A, b = J @ J.T + 1e-3 * np.eye(12), rng.normal(size=12)
    z, _, _, s, ok = handoff_floats(A, b, mu, [(0, 0, 0)] * 4, max_iter=300, tol=1e-9)
    z2, _, sweeps, s2, ok2 = handoff_floats(A, b, mu, s, max_iter=300, tol=1e-9)
    assert ok and ok2 and sweeps == 0 and s2 == s and np.abs(z2 - z).max() <= 1e-9 * max(1.0, np.abs(b).max())
