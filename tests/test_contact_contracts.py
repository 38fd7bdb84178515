"""Chapter 07 and the LCP core, nothing silent (issue 27): QP backends that raise, answers that certify
themselves, values a user's callback hands back, and the edge values the contract fuzz found.

Tests that need an optional QP backend are parametrized over every backend qpsolvers knows and skip by
name (reported as skips) when it is not installed; the rest run with the required packages alone.
"""

import time

import numpy as np
import pytest

from pbanim.contact import ContactRows, RestingContact, TimeStepping, make_contacts
from pbanim.contact.friction import friction_directions
from pbanim.errors import InfeasibleContact, InvalidInput, NonFiniteResult
from pbanim.lcp import delassus, enumerate_active_sets, lemke, pgs_bounded, solve_lcp, solve_planar_contact
from pbanim.lcp.pivoting import _certified, residual_threshold
from pbanim.lcp.qp import BACKEND_ITERATIONS, BACKEND_TOLERANCES, backend_settings
from pbanim.models.contact import random_contact_lcp
from pbanim.particles import Gravity, ParticleSystem
from pbanim.results import natural_map_residual
from pbanim.scene import Scene

qpsolvers = pytest.importorskip("qpsolvers")

#: every backend qpsolvers can call that installs from PyPI (the extra "qp-backends", and proxqp)
BACKENDS = ("proxqp", "osqp", "quadprog", "clarabel", "daqp", "scs", "piqp", "highs", "ecos", "cvxopt", "qpalm")
#: backends that need a positive *definite* A: redundant contacts (a singular A) make them raise
DEFINITE_ONLY = {"quadprog", "ecos"}


def _installed(name: str) -> None:
    if name not in qpsolvers.available_solvers:
        pytest.skip(f"QP backend {name} is not installed (optional extra qp-backends)")


@pytest.mark.parametrize("backend", BACKENDS)
def test_every_backend_certifies_full_rank_contact_at_its_own_tolerance(backend):
    # ORACLES D8: every installed backend, asked for eps in its own settings (BACKEND_TOLERANCES), then
    # polished, passes the natural-map certificate; at default settings OSQP stopped at 2.7e-3 (m = 60)
    _installed(backend)
    assert backend in BACKEND_TOLERANCES
    case = random_contact_lcp(20, False, seed=3)
    sol = solve_lcp(case.A, case.b, "qp", backend=backend, native_box=False)
    assert sol.success and sol.residual <= sol.extra["threshold"] <= 2e-10 * max(1.0, np.abs(case.b).max())


@pytest.mark.parametrize("backend", BACKENDS)
def test_singular_contact_matrix_is_a_status_or_a_named_error(backend):
    # redundant contacts make A singular: quadprog and ECOS raise ProblemError("matrix P is not positive
    # definite"), which escaped solve_lcp even with raise_on_failure=False; now it is the status, the
    # certificate fails (residual of f = 0), and by default InfeasibleContact names the backend's message
    _installed(backend)
    case = random_contact_lcp(20, True, seed=3)
    sol = solve_lcp(case.A, case.b, "qp", backend=backend, native_box=False, raise_on_failure=False)
    if backend not in DEFINITE_ONLY:
        assert sol.success, (backend, sol.status, sol.residual)
        return
    assert not sol.success and "not positive definite" in sol.status and sol.status.startswith("backend error")
    assert sol.residual == pytest.approx(natural_map_residual(np.zeros(20), case.b)) and sol.residual > 0.1
    with pytest.raises(InfeasibleContact, match=f"contact solver 'qp' failed: status backend error .*not positive"):
        solve_lcp(case.A, case.b, "qp", backend=backend, native_box=False)
    sol = solve_lcp(case.A, case.b, "qp", backend=backend, native_box=False, fallback="lemke")
    assert sol.success and sol.extra["fallback_from"]["status"].startswith("backend error")


@pytest.mark.parametrize("backend", BACKENDS)
def test_max_iter_reaches_every_backend_under_its_own_name(backend):
    # max_iter was passed to ProxQP only: OSQP, SCS, ... ran to their own caps whatever the caller asked
    _installed(backend)
    case = random_contact_lcp(30, False, seed=3)
    if backend not in BACKEND_ITERATIONS:           # quadprog, HiGHS: no iteration cap pbanim knows
        with pytest.raises(InvalidInput, match=f"max_iter is not an option of the QP backend '{backend}'"):
            solve_lcp(case.A, case.b, "qp", backend=backend, native_box=False, max_iter=2)
        return
    sol = solve_lcp(case.A, case.b, "qp", backend=backend, native_box=False, max_iter=2, polish=False,
                    raise_on_failure=False)
    assert not sol.success and sol.iterations <= 2


def _raising_backend(monkeypatch, message="matrix P is not positive definite"):
    real = qpsolvers.solve_problem

    def solve_problem(problem, solver, **kw):
        if solver == "proxqp":
            raise qpsolvers.ProblemError(message)
        return real(problem, solver=solver, **kw)

    monkeypatch.setattr(qpsolvers, "solve_problem", solve_problem)


def test_backend_exception_is_a_status_with_any_backend_set(monkeypatch):
    # the same path without the optional backends: proxqp (a required package) made to raise
    _raising_backend(monkeypatch)
    case = random_contact_lcp(10, True, seed=1)
    sol = solve_lcp(case.A, case.b, "qp", native_box=False, raise_on_failure=False)
    assert not sol.success and sol.status == "backend error ProblemError: matrix P is not positive definite"
    assert np.isfinite(sol.residual) and sol.residual > 0
    with pytest.raises(InfeasibleContact, match="status backend error ProblemError: matrix P is not positive"):
        solve_lcp(case.A, case.b, "qp", native_box=False)


def test_bench_qp_table_names_a_raising_backend_instead_of_dying(monkeypatch):
    # `pbanim bench contact` died on quadprog's exception; the backend runs now hold it as a failure
    from pbanim.bench.contact import _backend_runs

    _raising_backend(monkeypatch, "boom")
    monkeypatch.setattr(qpsolvers, "available_solvers", ["proxqp"])
    case = random_contact_lcp(10, False, seed=1)
    runs, failed = _backend_runs(case.A, case.b)
    assert runs == {} and failed == {"proxqp": "backend error ProblemError: boom"}


def test_backend_settings_ask_each_backend_for_the_accuracy():
    assert backend_settings("osqp", 1e-9) == {"eps_abs": 1e-9, "eps_rel": 0.0, "max_iter": 20000}
    assert backend_settings("clarabel", 1e-9) == {"tol_gap_abs": 1e-9, "tol_gap_rel": 1e-9, "tol_feas": 1e-9}
    assert backend_settings("no-such-backend", 1e-9) == {}


def test_enumeration_accepts_only_a_complementary_active_set():
    # ORACLES D8: for this A (a zero on the diagonal, A_SS singular for S = {1}) the least-squares answer on S
    # = {1} has f ≥ 0 and w ≥ 0 but f₁w₁ = 3: the old acceptance (f ≥ 0, w ≥ 0) returned it as "solved"
    A = np.array([[0.0, 1.0, 2.0], [0.0, 0.0, 2.0], [1.0, 2.0, -1.0]])
    b = np.array([-1.0, 3.0, -2.0])
    f, status, _ = enumerate_active_sets(A, b)
    assert status == "solved"
    assert natural_map_residual(f, A @ f + b) <= 1e-12 and not np.allclose(f, [0.0, 1.0, 0.0])


def test_pivoting_answers_certify_their_status():
    A, b = np.array([[2.0, 1.0], [1.0, 2.0]]), np.array([-1.0, 1.0])
    assert lemke(A, b)[1] == "solved"
    # a "solved" that fails the natural-map certificate is reported, not passed on
    f, status, n = _certified(A, b, np.array([0.4, 0.0]), "solved", 2)
    assert status.startswith("inaccurate (residual 2.000e-01 >") and n == 2
    assert _certified(A, b, np.array([np.nan, 0.0]), "solved", 2)[1] == "inaccurate (not finite)"
    assert residual_threshold(A, b, np.array([0.5, 0.0]), 1e-10) == pytest.approx(1e-10 + 1000 * 2.2e-16 * 1.0,
                                                                                  rel=1e-3)


def test_warm_start_worse_than_zero_is_dropped():
    # 1e300 forces as a warm start kept ProxQP at its iteration cap (137 s measured on a loaded machine)
    A, b = np.array([[2.0, 1.0], [1.0, 2.0]]), np.array([-1.0, 1.0])
    start = time.perf_counter()
    sol = solve_lcp(A, b, "qp", warm_start=np.full(2, 1e300))
    assert sol.success and sol.extra["warm_start_dropped"] and time.perf_counter() - start < 5.0
    assert "warm_start_dropped" not in solve_lcp(A, b, "pgs", warm_start=[0.5, 0.0]).extra


def test_planar_contact_flags_a_pgs_answer_short_of_its_tolerance():
    # a non-symmetric problem whose mode switching cycles: with 3 PGS sweeps the answer misses the
    # tolerance and says so (info["success"] False, was only a residual key); with 100 it is polished
    A = np.array([[1.438, -0.385, -0.533, 0.46], [-0.128, 0.828, 0.663, -0.504],
                  [0.148, 0.896, 0.828, 0.009], [0.737, 0.447, 0.862, 0.837]])
    b = np.array([-1.482, -0.11, -0.446, 0.775])
    _, _, info = solve_planar_contact(A, b, 0.5, max_iter=3)
    assert info["path"] == "pgs" and info["success"] is False and info["residual"] > 1e-3
    _, _, info = solve_planar_contact(A, b, 0.5, max_iter=100)
    assert info["path"] == "pgs+polish" and info["success"] is True
    with pytest.raises(InvalidInput, match="guess must hold one mode per contact \\(m = 2\\), got 3"):
        solve_planar_contact(A, b, 0.5, guess=[1, 1, 1])          # was ignored silently
    with pytest.raises(InvalidInput, match="A and b must have 2 rows per contact .*got 3 rows"):
        solve_planar_contact(np.eye(3), -np.ones(3), 0.5)         # was a bare ValueError from matmul


def _one_particle_scene(detect):
    return Scene(ParticleSystem([[0.0, 0.0]], masses=2.0), [Gravity(), RestingContact(detect, "lemke")])


@pytest.mark.parametrize("detect, what", [
    (lambda y: make_contacts([5], [-1], [y[:2]], [[0.0, 1.0]], [0.0]), "names body 5 of N = 1"),   # IndexError
    (lambda y: make_contacts([0], [0], [y[:2]], [[0.0, 1.0]], [0.0]), "joins body 0 to itself"),  # NaN in A
    (lambda y: (1, 2), "a tuple, not a Contacts"),                                                 # AttributeError
])
def test_what_detect_returns_is_checked(detect, what):
    with pytest.raises(InvalidInput, match=f"RestingContact: detect\\(y\\) must be a Contacts .*{what}"):
        _one_particle_scene(detect).simulate(0.02, 0.01)


def test_time_stepping_refuses_contacts_of_the_wrong_dimension():
    # 2-D contacts for 3-D particles: a bare broadcasting ValueError before
    ps = ParticleSystem([[0.0, 0.0, 0.0]], [[1.0, 0.0, 0.0]], masses=1.0)
    flat = lambda y: make_contacts([0], [-1], [y[:2]], [[0.0, 1.0]], [0.0])  # noqa: E731
    with pytest.raises(InvalidInput, match="TimeStepping: detect\\(y\\) must be .*2-D points for a 3-D system"):
        TimeStepping(ps, flat, [Gravity()]).simulate(0.02, 0.01)


def test_friction_directions_tangent_scale_and_facet_cap():
    # a tangent of 1e300 gave all-zero directions (its square overflowed); only its direction counts now
    n = [[0.0, 0.0, 1.0]]
    np.testing.assert_allclose(friction_directions(n, 4, tangent=[1e300, 1e300, 0.0]),
                               friction_directions(n, 4, tangent=[1.0, 1.0, 0.0]), rtol=0, atol=1e-15)
    with pytest.raises(InvalidInput, match="facets must be an integer >= 2 and <= 64, got 1000000000"):
        friction_directions(n, 10**9)                              # allocated (m, 10⁹, 3) before
    with pytest.raises(InvalidInput, match="normal must hold unit vectors"):
        friction_directions([[0.0, 0.0, 2.0]], 4)


def test_overflow_and_bad_bounds_are_named():
    W = np.stack([np.eye(3), np.zeros((3, 3))])
    G = np.array([[1e200, 0.0, 0.0]])
    with pytest.raises(NonFiniteResult, match="the result of delassus is not finite"):
        delassus(np.array([0]), np.array([1]), G, G, W)            # returned [[nan]]
    with pytest.raises(InvalidInput, match="pgs_bounded: lo and hi must satisfy .*lo < inf"):
        pgs_bounded(np.eye(2), -np.ones(2), np.inf, np.inf)        # returned z = [nan, nan]
    rows = ContactRows(np.array([0]), np.array([1]), np.ones((1, 3)), np.ones((1, 3)), 2)
    other = ContactRows(np.array([0]), np.array([2]), np.ones((1, 3)), np.ones((1, 3)), 3)
    with pytest.raises(InvalidInput, match="gram: other must be rows on the same bodies \\(n_pad = 2"):
        rows.gram(other, W)                                        # a bare IndexError
