"""LCP / QP contact solvers: degenerate LCPs, certificates, loud failures (ORACLES D8, D9)."""

import subprocess
import sys

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from pbanim.contact import LCP_SOLVERS, residual_threshold, solve_lcp
from pbanim.errors import InfeasibleContact
from pbanim.models.contact import (infeasible_lcp, murty_lcp, psd_nonunique_lcp, random_contact_lcp,
                                   trivial_lcp)
from pbanim.testing import assert_complementarity

SYMMETRIC = LCP_SOLVERS                       # qp needs a symmetric PSD matrix
GENERAL = ("lemke", "dantzig", "pgs")


@pytest.mark.parametrize("solver", SYMMETRIC)
def test_psd_nonunique(solver):
    # ORACLES D8: A = [[1,1],[1,1]], b = (−1,−1) has the solution set f ≥ 0, f1 + f2 = 1; judge by the
    # natural-map residual, never by f itself.  measured ≤ 1.1e-16 for all solvers, bound 1e-12
    case = psd_nonunique_lcp()
    sol = solve_lcp(case.A, case.b, solver)
    assert sol.success
    assert_complementarity(sol.f, sol.w, tol=1e-12)
    assert abs(sol.f.sum() - 1.0) < 1e-12


@pytest.mark.parametrize("solver", GENERAL)
def test_murty_p_matrix_unique_solution(solver):
    # ORACLES D8: Murty's upper-triangular P-matrix with b = −1 has the unique solution e_n
    # (w_n = f_n − 1 = 0, every other w_i = 2 f_n − 1 = 1 > 0).  measured residual 0.0, bound 1e-12
    case = murty_lcp(8)
    sol = solve_lcp(case.A, case.b, solver, max_iter=5000)
    assert sol.residual <= 1e-12
    np.testing.assert_allclose(sol.f, case.solution, atol=1e-12)


def test_qp_rejects_non_symmetric_and_indefinite():
    # the QP form is the LCP only for symmetric PSD A: anything else is refused with the fix named
    with pytest.raises(ValueError, match="A must be symmetric for solver='qp'.*lemke"):
        solve_lcp(murty_lcp(3).A, -np.ones(3), "qp")
    with pytest.raises(ValueError, match="positive semidefinite"):
        solve_lcp(infeasible_lcp().A, infeasible_lcp().b, "qp")


@pytest.mark.parametrize("solver", GENERAL)
def test_infeasible_is_loud(solver):
    # ORACLES D8: A = [−1], b = [−1]: w = −f − 1 < 0 for all f ≥ 0 → InfeasibleContact with status/residual,
    # or success False when asked
    case = infeasible_lcp()
    with pytest.raises(InfeasibleContact, match=f"contact solver '{solver}' failed: status") as exc:
        solve_lcp(case.A, case.b, solver)
    assert exc.value.residual >= 1.0 - 1e-12 and exc.value.status
    sol = solve_lcp(case.A, case.b, solver, raise_on_failure=False)
    assert not sol.success and sol.residual >= 1.0 - 1e-12


@pytest.mark.parametrize("solver", SYMMETRIC)
def test_psd_infeasible_is_loud(solver):
    # a PSD but infeasible LCP: w1 + w2 = −2 whatever f (A = [[1,−1],[−1,1]], b = (−1,−1)); the QP is
    # unbounded below.  Every solver must fail loudly, none may return a "solution"
    A, b = np.array([[1.0, -1.0], [-1.0, 1.0]]), np.array([-1.0, -1.0])
    sol = solve_lcp(A, b, solver, raise_on_failure=False, max_iter=200)
    assert not sol.success and sol.residual >= 1.0 - 1e-9
    with pytest.raises(InfeasibleContact):
        solve_lcp(A, b, solver, max_iter=200)


@pytest.mark.parametrize("solver", SYMMETRIC)
def test_trivial(solver):
    # b ≥ 0: every contact separates by itself, f = 0 exactly (ORACLES D8 trivial case)
    case = trivial_lcp(4)
    sol = solve_lcp(case.A, case.b, solver)
    assert sol.success and np.all(sol.f == 0.0) and sol.residual == 0.0


def test_fallback_is_explicit_and_recorded():
    # PGS cannot handle a zero diagonal; with fallback='lemke' the answer is Lemke's, and it says so
    A, b = np.array([[0.0, 1.0], [1.0, 1.0]]), np.array([1.0, -1.0])
    with pytest.raises(InfeasibleContact, match="zero_diagonal"):
        solve_lcp(A, b, "pgs")
    sol = solve_lcp(A, b, "pgs", fallback="lemke")
    assert sol.solver == "lemke" and sol.extra["fallback_from"]["solver"] == "pgs"
    assert sol.residual <= 1e-14   # measured 0.0


def test_pgs_never_claims_unreached_convergence():
    # a 1:1000 stack-like ill-conditioned problem: PGS after 5 sweeps must say "max_iter", success False
    case = random_contact_lcp(40, redundant=True, seed=3)
    A = case.A.copy()
    A[:20, :20] *= 1e3
    sol = solve_lcp(A, case.b, "pgs", max_iter=5, raise_on_failure=False)
    assert sol.status == "max_iter" and not sol.success and sol.iterations == 5
    assert sol.residual > residual_threshold(A, case.b, sol.f, 1e-10)


def test_pgs_warm_start_from_solution_is_immediate():
    # warm starting PGS at the exact answer costs 0 sweeps (what a resting stack gains every step)
    case = random_contact_lcp(30, seed=1)
    ref = solve_lcp(case.A, case.b, "lemke")
    sol = solve_lcp(case.A, case.b, "pgs", warm_start=ref.f)
    assert sol.success and sol.iterations == 0


@pytest.mark.parametrize("redundant", [False, True])
@pytest.mark.parametrize("m", [10, 60])
def test_qp_and_pivoting_agree_in_Jtf(m, redundant):
    # ORACLES D9: frictionless A = J W Jᵀ: QP, Lemke and Dantzig agree in the contact impulse W Jᵀ f
    # (unique even when f is not, for redundant contacts) to 1e-8; PGS agrees when it reports convergence.
    # measured max relative difference 9.3e-10 (PGS converged to tol 1e-10; the direct solvers agree to
    # ~1e-12), bound 1e-8
    rng = np.random.default_rng(m + 7 * redundant)
    n = m // 2 + 1 if redundant else 2 * m
    J = rng.normal(size=(m, n)) / np.sqrt(n)
    A, b = J @ J.T, J @ rng.normal(size=n)
    ref = solve_lcp(A, b, "qp")
    for solver in ("lemke", "dantzig", "pgs"):
        sol = solve_lcp(A, b, solver, raise_on_failure=False, max_iter=3000 if solver == "pgs" else None)
        if solver != "pgs":
            assert sol.success, (solver, sol.status, sol.residual)
        if sol.success:
            np.testing.assert_allclose(J.T @ sol.f, J.T @ ref.f, atol=1e-8 * max(1.0, np.abs(J.T @ ref.f).max()))


@given(m=st.integers(1, 12), seed=st.integers(0, 10_000), redundant=st.booleans())
def test_random_contact_lcps_certified(m, seed, redundant):
    # every solver's answer to a feasible frictionless contact LCP passes the complementarity certificate
    case = random_contact_lcp(m, redundant, seed)
    for solver in ("qp", "lemke", "dantzig"):
        sol = solve_lcp(case.A, case.b, solver)
        assert sol.success
        tol = sol.extra["threshold"]
        assert_complementarity(sol.f, sol.w, tol=tol)


def test_bad_inputs_named():
    # G3: every rejected input names the argument and the fix
    with pytest.raises(ValueError, match="solver must be one of 'qp', 'lemke', .*got 'simplex'"):
        solve_lcp(np.eye(2), np.ones(2), "simplex")
    with pytest.raises(ValueError, match=r"b must be a float array of shape \(m,\) \(m = 3\).*; shape \(2,\)"):
        solve_lcp(np.eye(3), np.ones(2))
    with pytest.raises(ValueError, match=r"b must be a float array .*got \[nan\]; it has NaN or inf entries"):
        solve_lcp(np.eye(1), [np.nan])
    # a name no qpsolvers release has: the test holds whatever backends are installed (osqp included)
    with pytest.raises(ValueError, match="backend must be one of .*'proxqp'.*got 'no-such-qp'"):
        solve_lcp(np.eye(2), -np.ones(2), "qp", backend="no-such-qp")
    with pytest.raises(ValueError, match="fallback must be one of 'qp', .*got 'magic'"):
        solve_lcp(np.eye(2), -np.ones(2), "pgs", fallback="magic")
    with pytest.raises(ValueError, match="tol must be a finite number > 0 and < 1, got 0.0"):
        solve_lcp(np.eye(2), -np.ones(2), tol=0.0)
    with pytest.raises(ValueError, match=r"warm_start must be .*\(m = 2\).*; shape \(3,\)"):
        solve_lcp(np.eye(2), -np.ones(2), "pgs", warm_start=np.ones(3))
    # solver options are checked by name too (they were passed on silently: a typo ran the defaults)
    with pytest.raises(ValueError, match="solve_lcp: solver 'pgs' takes no option 'max_iters'"):
        solve_lcp(np.eye(2), -np.ones(2), "pgs", max_iters=10)
    with pytest.raises(ValueError, match="omega must be a finite number > 0 and < 2, got 2.5"):
        solve_lcp(np.eye(2), -np.ones(2), "pgs", omega=2.5)


def test_qp_through_qpsolvers_matches_native_box():
    # the same QP through qpsolvers.solve_problem (lb = 0) and through proxsuite's own box constraints
    case = random_contact_lcp(20, seed=5)
    a = solve_lcp(case.A, case.b, "qp", native_box=True)
    b = solve_lcp(case.A, case.b, "qp", native_box=False)
    assert a.success and b.success
    np.testing.assert_allclose(a.w, b.w, atol=1e-9)


def test_no_qpsolvers_without_qp():
    # pivoting and PGS never import qpsolvers or proxsuite (lazy heavy imports)
    code = ("import sys, numpy as np; from pbanim.contact import solve_lcp; "
            "solve_lcp(np.eye(2), -np.ones(2), 'lemke'); solve_lcp(np.eye(2), -np.ones(2), 'pgs'); "
            "print(any(m in sys.modules for m in ('qpsolvers', 'proxsuite')))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "False"


def test_qp_polish_on_degenerate_redundant_problem():
    # regression: m = 200 redundant contacts (rank 101). ProxQP at eps_abs 1e-9 stops at residual 5.8e-9; the
    # polish (minimum-norm correction on the active set {f > w}) certifies it.  measured 1.3e-13, bound 1e-10
    case = random_contact_lcp(200, redundant=True, seed=7)
    raw = solve_lcp(case.A, case.b, "qp", polish=False, raise_on_failure=False)
    sol = solve_lcp(case.A, case.b, "qp")
    assert sol.success and sol.residual < 1e-10 < raw.residual
