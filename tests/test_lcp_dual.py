"""The Goldfarb–Idnani dual active set and the block-principal-pivoting route that hands over to it
(issue 14, part 5: QP contact solves of m = 10…1000 contacts, full-rank and redundant)."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import pbanim.lcp.active_set as active_set
from pbanim.lcp import solve_lcp
from pbanim.lcp.active_set import bpp, dual_active_set
from pbanim.models.contact import random_contact_lcp
from pbanim.results import natural_map_residual


def _certified(A, b, f, tol=1e-10):
    return natural_map_residual(f, A @ f + b) <= tol * max(1.0, float(np.max(np.abs(b))))


# ORACLES D15: on redundant stacks w equals a certified QP's w, and the certificate holds
@settings(max_examples=25, deadline=None)
@given(m=st.integers(2, 60), seed=st.integers(0, 10**6))
def test_dual_active_set_on_redundant_contact(m, seed):
    case = random_contact_lcp(m, True, seed=seed)
    A, b = case.A, case.b
    f, status, rounds = dual_active_set(A, b)
    assert status == "solved" and rounds <= 3 * m + 10 and np.all(f >= 0)
    assert _certified(A, b, f)
    ref = solve_lcp(A, b, "qp")
    # measured ≤ 3e-11 difference in w (unique for a convex QP); bound 1e-8
    np.testing.assert_allclose(A @ f + b, ref.w, atol=1e-8)


# ORACLES D15: on full rank the solution is unique: the same f as Lemke's, with or without a start guess
@settings(max_examples=25, deadline=None)
@given(m=st.integers(1, 60), seed=st.integers(0, 10**6), guess=st.booleans())
def test_dual_active_set_equals_lemke_on_full_rank(m, seed, guess):
    case = random_contact_lcp(m, False, seed=seed)
    A, b = case.A, case.b
    f, status, _ = dual_active_set(A, b, start=(b < 0) if guess else None)
    ref = solve_lcp(A, b, "lemke")
    assert status == "solved" and _certified(A, b, f)
    np.testing.assert_allclose(f, ref.f, atol=1e-9)          # measured ≤ 1e-13


def test_dual_active_set_says_infeasible_and_max_iter():
    # ORACLES D15: w₁ + w₂ = −2 for every f: no solution, and the method says so
    A = np.array([[1.0, -1.0], [-1.0, 1.0]])
    f, status, _ = dual_active_set(A, np.array([-1.0, -1.0]))
    assert status == "infeasible"
    f, status, _ = dual_active_set(np.zeros((1, 1)), np.array([-1.0]))
    assert status == "infeasible"
    case = random_contact_lcp(30, True, seed=3)
    f, status, rounds = dual_active_set(case.A, case.b, max_iter=2)
    assert status == "max_iter" and rounds == 2
    f, status, rounds = dual_active_set(np.zeros((0, 0)), np.zeros(0))
    assert status == "solved" and f.size == 0


def test_start_guess_saves_rounds_and_a_bad_guess_is_harmless():
    # ORACLES D15: a guess (the contacts with bᵢ < 0) is reduced to a valid start; measured 11 → 1 rounds
    case = random_contact_lcp(30, False, seed=30)
    A, b = case.A, case.b
    _, _, cold = dual_active_set(A, b)
    f, status, warm = dual_active_set(A, b, start=b < 0)
    assert status == "solved" and warm < cold and _certified(A, b, f)
    red = random_contact_lcp(30, True, seed=30)               # every contact held: A_SS singular → cold start
    f, status, _ = dual_active_set(red.A, red.b, start=np.ones(30, bool))
    assert status == "solved" and _certified(red.A, red.b, f)


def test_bpp_hands_over_on_degenerate_stacks():
    # ORACLES D12, D15: block principal pivoting stops early ("degenerate") on a redundant stack instead of
    # cycling, keeps solving full-rank problems itself, and the route certifies either way; up to
    # DUAL_FIRST contacts the route starts with the dual active set
    from pbanim.lcp.solve import DUAL_FIRST
    for m in (30, 100, 300):
        red = random_contact_lcp(m, True, seed=m)
        f, status, rounds = bpp(red.A, red.b, max_iter=4, handoff=True)
        assert status == "degenerate" and rounds <= 2
        sol = solve_lcp(red.A, red.b, "bpp")
        assert sol.success and sol.status == ("solved" if m <= DUAL_FIRST else "bpp→dual")
        full = random_contact_lcp(m, False, seed=m)
        sol = solve_lcp(full.A, full.b, "bpp")
        assert sol.success and sol.status == "solved"
    # the route's guess: a warm start's support (the previous step's answer) is the dual's start
    case = random_contact_lcp(40, False, seed=4)
    ref = solve_lcp(case.A, case.b, "bpp")
    again = solve_lcp(case.A, case.b, "bpp", warm_start=ref.f)
    assert again.success and again.iterations <= 1 < ref.iterations


@pytest.mark.parametrize("m, route", [(40, "dual→qp"), (120, "bpp→qp")])
def test_route_falls_back_to_the_qp_when_the_dual_does_not_certify(monkeypatch, m, route):
    # ORACLES D12: the last resort is still there, and the status says it was used
    red = random_contact_lcp(m, True, seed=7)
    monkeypatch.setattr(active_set, "dual_active_set", lambda A, b, **k: (np.zeros(b.size), "max_iter", 1))
    sol = solve_lcp(red.A, red.b, "bpp")
    assert sol.success and sol.status.startswith(route)


@pytest.mark.parametrize("m", [1, 5])
def test_lapack_factor_solves_match_numpy(m):
    # the direct LAPACK Cholesky / LU solves equal numpy's solve (symmetric and non-symmetric)
    rng = np.random.default_rng(m)
    G = rng.normal(size=(m, m))
    K = G @ G.T + np.eye(m)
    r = rng.normal(size=m)
    for M, sym in ((K, True), (K + 0.3 * (G - G.T), False)):
        x, fac = active_set._prox_solve(M, r, 0.0, 0, sym=sym)
        np.testing.assert_allclose(x, np.linalg.solve(M, r), rtol=1e-12, atol=1e-12)
        assert fac[0] == ("cho" if sym else "lu")


def test_a_degenerate_held_set_stalls_and_the_route_still_certifies():
    # ORACLES D15: on this redundant stack (m = 200, rank 101) the held set becomes nearly dependent and
    # the dual stops with w_p = −1.1e-7 that nothing can raise: "stalled", not "infeasible", never "solved";
    # the route's last resort (the QP, polished) certifies (measured residual 1.4e-13)
    case = random_contact_lcp(200, True, seed=7)
    f, status, _ = dual_active_set(case.A, case.b, start=case.b < 0)
    assert status == "stalled"
    sol = solve_lcp(case.A, case.b, "bpp")
    assert sol.success and sol.status.startswith("bpp→qp") and sol.residual <= 1e-10
