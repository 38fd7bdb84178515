"""Issue 14, parts 3–5: warm-started active-set contact solves, the dropped stack and the sphere pile,
the vectorized narrow phase beside its readable loop, block principal pivoting for the contact QP."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from pbanim.contact.scenes import box_box_contacts, box_box_contacts_loop, dropped_stack, sphere_pile
from pbanim.contact.stepping import FrictionStepping
from pbanim.errors import InvalidInput
from pbanim.lcp import solve_lcp
from pbanim.lcp.active_set import box_friction_active_set, box_friction_residual, bpp
from pbanim.lcp.solve import pgs_box_friction
from pbanim.models.contact import random_contact_lcp
from pbanim.results import natural_map_residual


def _friction_problem(seed, m):
    """A = J W Jᵀ of m contacts on a few bodies with three rows each (full rank: 6 per body > 3m rows)."""
    rng = np.random.default_rng(seed)
    J = rng.normal(size=(3 * m, 6 * m))
    A = J @ J.T / (6 * m) + 1e-3 * np.eye(3 * m)
    b = rng.normal(size=3 * m)
    return A, b


# ORACLES D11: the active-set box-friction solve and the readable PGS agree
@settings(max_examples=25, deadline=None)
@given(seed=st.integers(0, 10**6), m=st.integers(1, 5), mu=st.sampled_from([0.0, 0.3, 0.5, 1.0]))
def test_active_set_agrees_with_readable_pgs(seed, m, mu):
    A, b = _friction_problem(seed, m)
    z, res, rounds, _ = box_friction_active_set(A, b, mu, max_iter=60)
    zp, rp, _ = pgs_box_friction(A, b, mu, max_iter=20000, tol=1e-12)
    if res > 1e-9 or rp > 1e-9:          # the pivoting guess may not settle on a hard draw: then it must say so
        assert max(res, box_friction_residual(z, A @ z + b, mu)) > 1e-9 or rp > 1e-9
        return
    # measured: max |z − z_pgs| ≤ 4e-10 over 200 draws; bound 1e-7 (PGS stops at residual 1e-12·scale)
    np.testing.assert_allclose(z, zp, atol=1e-7)
    assert box_friction_residual(z, A @ z + b, mu) == pytest.approx(res)


def test_active_set_from_the_right_state_needs_one_round():
    # ORACLES D11: started from the answer's state (a contact that persists), one solve confirms it
    A, b = _friction_problem(3, 4)
    z, res, rounds, state = box_friction_active_set(A, b, 0.5)
    assert res < 1e-10 and rounds > 1
    z2, res2, rounds2, _ = box_friction_active_set(A, b, 0.5, state=state)
    assert rounds2 == 1 and np.allclose(z2, z, atol=1e-12)


# ORACLES D12: block principal pivoting reaches the certificate on full-rank contact LCPs, equal to Lemke's
@settings(max_examples=20, deadline=None)
@given(m=st.integers(1, 60), seed=st.integers(0, 10**6))
def test_bpp_equals_lemke_on_full_rank(m, seed):
    case = random_contact_lcp(m, False, seed=seed)
    sol = solve_lcp(case.A, case.b, "bpp")
    ref = solve_lcp(case.A, case.b, "lemke")
    # measured ≤ 4e-15 residual, ≤ 2e-13 difference; bounds 1e-10 (the certificate) and 1e-9
    assert sol.success and sol.residual <= 1e-10
    np.testing.assert_allclose(sol.f, ref.f, atol=1e-9)


def test_bpp_warm_active_set_and_redundant_fallback():
    case = random_contact_lcp(200, False, seed=1)
    f, status, rounds = bpp(case.A, case.b)
    assert status == "solved" and rounds >= 1
    cache = {}
    f2, status2, rounds2 = bpp(case.A, case.b, active=f > 0, cache=cache)
    assert status2 == "solved" and rounds2 == 0 and cache["factorizations"] == 1    # D12: no exchange
    red = random_contact_lcp(100, True, seed=100)
    sol = solve_lcp(red.A, red.b, "bpp")            # degenerate stack: hands over to the dual active set, says so
    assert sol.success and natural_map_residual(sol.f, red.A @ sol.f + red.b) <= 1e-10
    assert sol.status == "bpp→dual"


# ORACLES D13: the vectorized narrow phase equals the readable per-corner loop
@settings(max_examples=25, deadline=None)
@given(seed=st.integers(0, 10**6))
def test_box_box_vectorized_equals_loop(seed):
    from pbanim.rigid.quat import quat_from_axis_angle, quat_to_matrix

    rng = np.random.default_rng(seed)
    n = 4
    half = np.array([0.5, 0.4, 0.25])
    x = np.zeros((n, 3))
    x[:, 2] = 0.5 * np.arange(n) + rng.uniform(-0.01, 0.01, n)
    x[:, :2] = rng.uniform(-0.3, 0.3, (n, 2))
    R = np.stack([quat_to_matrix(quat_from_axis_angle(rng.normal(size=3), rng.uniform(0, 0.2))) for _ in range(n)])
    pairs = np.array([[i, j] for i in range(n) for j in range(i)])
    v = box_box_contacts(x, R, half, pairs, 0.02, 0.01)
    ref = box_box_contacts_loop(x, R, half, pairs, 0.02, 0.01)
    order = lambda out: np.lexsort((out[5], out[1], out[0]))  # noqa: E731
    for a, b in zip(v, ref):
        assert a.shape == b.shape
    if v[0].size:
        for a, b in zip(v, ref):
            np.testing.assert_allclose(np.asarray(a)[order(v)], np.asarray(b)[order(ref)], atol=1e-14)


@pytest.fixture(scope="module")
def stack_run():
    sc = dropped_stack(10)
    ts = FrictionStepping(sc.system, sc.detect, sc.forces, friction=sc.friction)
    return sc, ts, ts.simulate(0.5, 1 / 60)


def test_dropped_stack_lands_and_stays(stack_run):
    # ORACLES D13: the stack falls its 1 mm gaps and rests: top at 9.5 m + h_z = 4.75 m, no drift, no penetration
    sc, ts, res = stack_run
    N = sc.system.N
    top = res.y[3 * (N - 1) + 2]
    assert top[0] == pytest.approx(4.75 + 10e-3)
    # measured: |top − 4.75| ≤ 2e-15, drift over the last half 0, penetration ≤ 1e-15; bounds 1e-9
    assert abs(top[-1] - 4.75) <= 1e-9
    half = res.t.size // 2
    assert np.abs(top[half:] - top[half]).max() <= 1e-9
    assert res.diagnostics["max_penetration"][half:].max() <= 1e-9
    assert np.all(res.diagnostics["contact_count"][half:] == 40)        # 4 corners per interface
    # persistence: every contact after the first step was found again, about one solve per step
    assert ts.stats["persisted"] >= ts.stats["contacts"] - 40
    assert ts.stats["rounds"] <= 2 * ts.stats["steps"]                   # measured 1.5 at h = 1/60
    assert ts.stats["fallbacks"] == ts.stats["skipped"] == 0             # the active set never failed here


def test_active_set_backs_off_where_it_fails_and_pgs_keeps_the_pile_in_the_box():
    # ORACLES D13, D16: in a dense pile sliding contacts make the friction problem non-monotone and the
    # active set fails on some steps; after k failures in a row the next 2^k steps (at most 64) go to the
    # colored PGS directly, every step is accounted for, and the pile stays in the box
    sc = sphere_pile(30)
    ts = FrictionStepping(sc.system, sc.detect, sc.forces, friction=sc.friction)
    res = ts.simulate(1.0, 1 / 60)
    st = ts.stats
    assert st["fallbacks"] >= 1 and st["skipped"] >= 2                   # measured 4 and 29
    assert st["skipped"] <= sum(min(2 ** k, 64) for k in range(1, st["fallbacks"] + 1))
    assert st["contact_steps"] == 60
    x = res.y[:90, -1].reshape(30, 3)
    r, L = sc.info["radius"], sc.info["box_half"]
    assert np.all(np.abs(x[:, :2]) <= L - r + 1e-3) and np.all(x[:, 2] >= r - 1e-3)
    # a step of 1/60 s lands spheres up to 7.2 mm deep (measured); never deeper than 0.2 r = 1 cm
    assert res.diagnostics["max_penetration"].max() <= 0.2 * r


def test_warm_start_saves_rounds():
    sc = dropped_stack(4)
    cold = FrictionStepping(sc.system, sc.detect, sc.forces, warm_start=False)
    cold.simulate(0.2, 1 / 60)
    warm = FrictionStepping(sc.system, sc.detect, sc.forces)
    warm.simulate(0.2, 1 / 60)
    assert warm.stats["rounds"] < cold.stats["rounds"]


def test_sphere_pile_stays_in_the_box():
    # ORACLES D13: spheres stay inside the box and their landing penetration is removed
    sc = sphere_pile(8)
    ts = FrictionStepping(sc.system, sc.detect, sc.forces, friction=sc.friction)
    res = ts.simulate(0.4, 1 / 60)
    x = res.y[:24, -1].reshape(8, 3)
    r, L = sc.info["radius"], sc.info["box_half"]
    assert np.all(np.abs(x[:, :2]) <= L - r + 1e-3) and np.all(x[:, 2] >= r - 1e-3)
    # a 2 cm step lands spheres up to 7 mm deep (beyond the r/10 look-ahead); erp = 0.2 removes it:
    # measured 3.2e-4 m over the last five steps, bound 0.02 r = 1e-3 m
    assert res.diagnostics["max_penetration"][-5:].max() <= 0.02 * r


def test_inputs_are_validated():
    sc = dropped_stack(2)
    with pytest.raises(InvalidInput, match="solver"):
        FrictionStepping(sc.system, sc.detect, sc.forces, solver="magic")
    with pytest.raises(InvalidInput, match="friction"):
        FrictionStepping(sc.system, sc.detect, sc.forces, friction=-1.0)
    with pytest.raises(InvalidInput, match="offset"):
        dropped_stack(3, offset=0.05)
    with pytest.raises(InvalidInput, match="3 rows"):
        box_friction_active_set(np.eye(4), np.ones(4), 0.5)
    with pytest.raises(InvalidInput, match="active"):
        bpp(np.eye(3), -np.ones(3), active=np.ones(2, bool))


# ---------------------------------------------------------------------------------------------
# Issue 14, part 4: the cheap step — Delassus by three evaluation orders, the narrow phase's raw arrays with
# the step's rotations, contact persistence by sorted keys
# ---------------------------------------------------------------------------------------------
def _random_rows(rng, n_bodies, m, block):
    """m contacts × ``block`` rows on random body pairs (the last body is the world: a zero W block)."""
    from pbanim.rigid.quat import quat_from_axis_angle, quat_to_matrix

    a = rng.integers(0, n_bodies, m)
    b = (a + 1 + rng.integers(0, n_bodies - 1, m)) % (n_bodies + 1)   # ≠ a; may be the world (index n_bodies)
    a, b = np.repeat(a, block), np.repeat(b, block)
    Ga, Gb = rng.normal(size=(m * block, 6)), rng.normal(size=(m * block, 6))
    Wb = np.zeros((n_bodies + 1, 6, 6))
    for i in range(n_bodies):
        R = quat_to_matrix(quat_from_axis_angle(rng.normal(size=3), rng.uniform(0, 3)))
        Wb[i, :3, :3] = np.eye(3) / rng.uniform(0.5, 2.0)
        Wb[i, 3:, 3:] = R @ np.diag(1 / rng.uniform(0.1, 1.0, 3)) @ R.T
    return a, b, Ga, Gb, Wb


# ORACLES D14: A = J W Kᵀ by every evaluation order of pbanim.lcp.delassus equals the readable body loop
@settings(max_examples=20, deadline=None)
@given(seed=st.integers(0, 10**6), size=st.sampled_from([(3, 5), (30, 12), (6, 60)]), other=st.booleans())
def test_delassus_orders_equal_readable_loop(seed, size, other):
    from pbanim.contact.assembly import delassus_by_bodies
    from pbanim.lcp.solve import delassus

    # (bodies, contacts): 3 bodies × 15 rows → dense scatter; 30 bodies × 36 rows → masked products;
    # 6 bodies × 180 rows → pairs of row groups sharing a body (m·k > 150²)
    rng = np.random.default_rng(seed)
    n_bodies, m = size
    a, b, Ga, Gb, Wb = _random_rows(rng, n_bodies, m, 3)
    K = None
    if other:
        ka, kb, Ha, Hb, _ = _random_rows(rng, n_bodies, m + 1, 3)
        K = (ka, kb, Ha, Hb)
    ref = delassus_by_bodies(a, b, Ga, Gb, Wb, K)
    scale = max(1.0, np.abs(ref).max())
    for block in (1, 3):
        A = delassus(a, b, Ga, Gb, Wb, K, block=block)
        # measured ≤ 4.3e-16 · scale over 200 draws × 3 sizes (summation order); bound 1e-12 · scale
        np.testing.assert_allclose(A, ref, rtol=0, atol=1e-12 * scale)
    if K is None:
        np.testing.assert_allclose(A, A.T, rtol=0, atol=1e-12 * scale)


def test_delassus_block_must_group_rows():
    from pbanim.lcp.solve import delassus

    rng = np.random.default_rng(0)
    a, b, Ga, Gb, Wb = _random_rows(rng, 4, 60, 3)
    a = a.copy()
    a[1] = (a[0] + 1) % 4                                  # a contact's rows on two different bodies
    with pytest.raises(InvalidInput, match="block = 3"):
        delassus(a, b, Ga, Gb, Wb, block=3)


# ORACLES D14: the step through the scene's raw arrays (rotations reused) equals the step through detect(y)
@pytest.mark.parametrize("scene", ["stack", "pile"])
def test_fast_narrow_phase_path_equals_public_detect(scene):
    sc = dropped_stack(4) if scene == "stack" else sphere_pile(8)
    fast = FrictionStepping(sc.system, sc.detect, sc.forces, friction=sc.friction)
    slow = FrictionStepping(sc.system, lambda y: sc.detect(y), sc.forces, friction=sc.friction)
    r1, r2 = fast.simulate(0.3, 1 / 60), slow.simulate(0.3, 1 / 60)
    # measured: identical (the same arithmetic, in the same order); bound 1e-12
    np.testing.assert_allclose(r1.y, r2.y, rtol=0, atol=1e-12)
    assert fast.stats == slow.stats
    c = fast.last_info["contacts"]
    ref, _ = sc.detect(r1.y[:, -2])                       # the last step's contacts, validated
    np.testing.assert_array_equal(c.a, ref.a)
    np.testing.assert_allclose(c.depth, ref.depth, rtol=0, atol=0)


# ORACLES D14: contact persistence by sorted keys finds what a dictionary keyed by contact finds
@settings(max_examples=30, deadline=None)
@given(seed=st.integers(0, 10**6), m0=st.integers(0, 30), m1=st.integers(1, 30))
def test_persistence_lookup_equals_dictionary(seed, m0, m1):
    rng = np.random.default_rng(seed)
    sc = dropped_stack(2)
    ts = FrictionStepping(sc.system, sc.detect, sc.forces)
    k0 = rng.integers(0, 40, m0)                           # duplicates allowed: the last one wins, as in a dict
    s0 = rng.integers(-1, 2, (m0, 3))
    z0 = rng.normal(size=3 * m0)
    ts._remember(k0, s0, z0)
    k1 = rng.integers(0, 40, m1)
    b = rng.normal(size=3 * m1)
    state, z = ts._warm(k1, b)
    ref = {int(k): (s0[i], z0[3 * i:3 * i + 3]) for i, k in enumerate(k0)}
    if not ref:
        assert state is None and not z.any()
        return
    for i, k in enumerate(k1.tolist()):
        if k in ref:
            np.testing.assert_array_equal(state[i], ref[k][0])
            np.testing.assert_array_equal(z[3 * i:3 * i + 3], ref[k][1])
        else:
            assert state[i].tolist() == [int(b[3 * i] < 0), 0, 0] and not z[3 * i:3 * i + 3].any()
    assert ts.stats["persisted"] == sum(k in ref for k in k1.tolist())


def test_scene_detect_validates_the_state():
    sc = dropped_stack(3)
    with pytest.raises(InvalidInput, match="state of shape"):
        sc.detect(np.zeros(5))
