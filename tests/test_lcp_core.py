"""One LCP / QP core (issue #12, point 4): collisions and contact share Lemke, the Delassus matrix,
the tangent frame, the skew matrix and the certificate — each written once."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import pbanim.collision.impulse as impulse_mod
import pbanim.collision.lcp as collision_lcp
import pbanim.contact.assembly as assembly_mod
import pbanim.rigid.bodies as bodies_mod
from pbanim.collision import Contacts, ImpulseBodies, collision_matrix, resolve_collisions, solve_lcp_small
from pbanim.collision.lcp import _normal_lcp
from pbanim.contact import friction_directions
from pbanim.contact.assembly import ContactRows
from pbanim.geometry import cone_edges, cross, skew, tangent_basis
from pbanim.lcp import delassus, enumerate_active_sets, lemke, solve_lcp
from pbanim.results import natural_map_residual
from pbanim.rigid.quat import skew as quat_skew


def _p_matrix(rng, m):
    """S + K with S symmetric positive definite and K skew: positive definite, hence a P-matrix
    (the LCP has exactly one solution for every b)."""
    G = rng.normal(size=(m, m))
    K = rng.normal(size=(m, m))
    return G @ G.T + 0.1 * np.eye(m) + (K - K.T)


# ------------------------------------------------------------------------------------------------
# one Lemke: the collision path is a client of pbanim.lcp
# ------------------------------------------------------------------------------------------------
@settings(max_examples=15, deadline=None)
@given(m=st.integers(1, 7), seed=st.integers(0, 10**6))
def test_collision_lcp_equals_lcp_core_on_p_matrices(m, seed):
    rng = np.random.default_rng(seed)
    A, b = _p_matrix(rng, m), rng.normal(size=m)
    f_small, its = solve_lcp_small(A, b)
    sol = solve_lcp(A, b, "lemke")
    np.testing.assert_array_equal(f_small, sol.f)           # the same code path: identical to the bit
    assert its == sol.iterations
    # the unique solution, found by every solver of the core
    scale = 1 + np.abs(b).max()
    for f in (solve_lcp_small(A, b, "enumerate")[0], solve_lcp(A, b, "dantzig").f,
              enumerate_active_sets(A, b)[0]):
        np.testing.assert_allclose(f, f_small, atol=1e-9 * scale)
    assert natural_map_residual(f_small, A @ f_small + b) <= 1e-10 * scale


def test_collision_lcp_keeps_its_named_errors():
    with pytest.raises(ValueError, match="solve_lcp_small: method must be one of 'lemke', 'enumerate', got 'pgs'"):
        solve_lcp_small(np.eye(2), [-1.0, 1.0], method="pgs")
    # A = [−1], b = [−1] has no solution: Lemke ends on a secondary ray, enumeration finds no set
    from pbanim.errors import InfeasibleContact
    with pytest.raises(InfeasibleContact, match="'lemke' failed: status ray termination"):
        solve_lcp_small([[-1.0]], [-1.0])
    with pytest.raises(InfeasibleContact, match="'enumerate' failed: status no active set"):
        solve_lcp_small([[-1.0]], [-1.0], method="enumerate")
    assert lemke(np.array([[-1.0]]), np.array([-1.0]))[1] == "ray"
    f, its = solve_lcp_small(np.zeros((0, 0)), np.zeros(0))
    assert f.shape == (0,) and its == 0


def test_no_private_copies_left():
    for mod, names in ((collision_lcp, ("_tangents",)), (impulse_mod, ("_skew",)),
                       (assembly_mod, ("_cross", "_Contacts")), (bodies_mod, ("_cross",))):
        for name in names:
            assert not hasattr(mod, name), f"{mod.__name__}.{name} is a second copy"
    assert quat_skew is skew
    import pbanim.articulated.batched as batched_mod
    import pbanim.articulated.spatial as spatial_mod
    assert spatial_mod.skew is skew and batched_mod._cross is cross


# ------------------------------------------------------------------------------------------------
# one skew matrix / cross product
# ------------------------------------------------------------------------------------------------
@settings(max_examples=20, deadline=None)
@given(seed=st.integers(0, 10**6))
def test_skew_and_cross_equal_np_cross(seed):
    rng = np.random.default_rng(seed)
    a, b = rng.normal(size=(5, 3)), rng.normal(size=(5, 3))
    np.testing.assert_allclose(skew(a) @ b[..., None], np.cross(a, b)[..., None], rtol=0, atol=1e-14)
    np.testing.assert_allclose(cross(a, b), np.cross(a, b), rtol=0, atol=1e-14)
    np.testing.assert_allclose(cross(a[0], b), np.cross(a[0], b), rtol=0, atol=1e-14)   # broadcasting
    np.testing.assert_array_equal(skew(a[0]), -skew(a[0]).T)


def test_collision_matrix_uses_the_skew_matrix():
    # K = (1/m_a + 1/m_b) 𝟙 − [r_a]× I_a⁻¹ [r_a]× − [r_b]× I_b⁻¹ [r_b]×: Δu = K J, checked with np.cross
    rng = np.random.default_rng(5)
    G = rng.normal(size=(2, 3, 3))
    inv_I = np.linalg.inv(G @ G.transpose(0, 2, 1) + np.eye(3))
    bodies = ImpulseBodies.make(rng.normal(size=(2, 3)), np.zeros((2, 3)), [0.5, 2.0], None, inv_I)
    c = Contacts([0], [1], rng.normal(size=(1, 3)), [[0.0, 0.0, 1.0]], [0.0])
    J = rng.normal(size=3)
    ra, rb = c.point[0] - bodies.x[0], c.point[0] - bodies.x[1]
    du = ((0.5 + 2.0) * J + np.cross(inv_I[0] @ np.cross(ra, J), ra)
          + np.cross(inv_I[1] @ np.cross(rb, J), rb))
    np.testing.assert_allclose(collision_matrix(bodies, c)[0] @ J, du, rtol=0, atol=1e-13)


# ------------------------------------------------------------------------------------------------
# one tangent frame
# ------------------------------------------------------------------------------------------------
_AXES = [[1.0, 0, 0], [-1.0, 0, 0], [0, 1.0, 0], [0, -1.0, 0], [0, 0, 1.0], [0, 0, -1.0]]


@pytest.mark.parametrize("n", _AXES + [[0.6, 0.0, 0.8], [0.95, 0.3122498999, 0.0]])
def test_tangent_basis_is_orthonormal_and_right_handed(n):
    n = np.array([n]) / np.linalg.norm(n)
    t1, t2 = tangent_basis(n)
    F = np.stack([t1[0], t2[0], n[0]])                      # rows t₁, t₂, n
    np.testing.assert_allclose(F @ F.T, np.eye(3), rtol=0, atol=1e-15)
    assert abs(np.linalg.det(F) - 1.0) < 1e-15             # t₂ = n × t₁
    np.testing.assert_allclose(t2, np.cross(n, t1), rtol=0, atol=0)


def test_tangent_basis_conventions():
    t1, t2 = tangent_basis(np.array(_AXES))
    np.testing.assert_array_equal(t1[4:], [[1.0, 0, 0], [1.0, 0, 0]])          # n = ±z: t₁ = x
    np.testing.assert_array_equal(t2[4:], [[0, 1.0, 0], [0, -1.0, 0]])         # t₂ = ±y
    np.testing.assert_array_equal(t1[:2], [[0, 1.0, 0], [0, 1.0, 0]])          # n = ±x: t₁ = y
    with pytest.raises(ValueError, match="tangent must not be parallel"):
        tangent_basis([[0, 0, 1.0]], reference=[0, 0, -3.0])


@settings(max_examples=15, deadline=None)
@given(seed=st.integers(0, 10**6), k=st.integers(2, 9))
def test_contact_and_collision_cones_share_the_frame(seed, k):
    rng = np.random.default_rng(seed)
    n = rng.normal(size=(4, 3))
    n = np.vstack([n / np.linalg.norm(n, axis=1)[:, None], _AXES])
    d = friction_directions(n, k)
    np.testing.assert_array_equal(d, cone_edges(n, k))
    np.testing.assert_array_equal(d[:, 0], tangent_basis(n)[0])
    np.testing.assert_allclose(np.linalg.norm(d, axis=2), 1.0, atol=1e-15)
    np.testing.assert_allclose(np.einsum("mkj,mj->mk", d, n), 0.0, atol=1e-15)


# ------------------------------------------------------------------------------------------------
# one Delassus matrix
# ------------------------------------------------------------------------------------------------
def _random_impulse_scene(rng, B=4, m=7):
    G = rng.normal(size=(B, 3, 3))
    inv_I = np.linalg.inv(G @ G.transpose(0, 2, 1) + np.eye(3))
    w = rng.uniform(0.2, 2.0, B)
    bodies = ImpulseBodies.make(rng.normal(size=(B, 3)), rng.normal(size=(B, 3)), w, rng.normal(size=(B, 3)), inv_I)
    ia = rng.integers(0, B, m)
    ib = np.where(rng.random(m) < 0.3, -1, (ia + 1 + rng.integers(0, B - 1, m)) % B)
    nrm = rng.normal(size=(m, 3))
    c = Contacts(ia, ib, rng.normal(size=(m, 3)), nrm / np.linalg.norm(nrm, axis=1)[:, None], np.zeros(m))
    return bodies, c


def test_collision_and_contact_share_the_delassus_builder():
    rng = np.random.default_rng(17)
    bodies, c = _random_impulse_scene(rng)
    B = bodies.B
    Wb = np.zeros((B + 1, 6, 6))
    Wb[:, :3, :3] = bodies.inv_mass[:, None, None] * np.eye(3)
    Wb[:, 3:, 3:] = bodies.inv_I
    a, b = np.where(c.a < 0, B, c.a), np.where(c.b < 0, B, c.b)
    ra, rb = c.point - bodies.x[a], c.point - bodies.x[b]
    rows = ContactRows(a, b, np.hstack([c.normal, np.cross(ra, c.normal)]),
                       np.hstack([c.normal, np.cross(rb, c.normal)]), B + 1)
    A = delassus(rows.a, rows.b, rows.Ga, rows.Gb, Wb)
    np.testing.assert_array_equal(rows.gram(rows, Wb), A)
    np.testing.assert_allclose(_normal_lcp(bodies, c), A, rtol=0, atol=1e-14)
    J = rows.sparse().toarray()
    W = np.zeros((6 * (B + 1), 6 * (B + 1)))
    for i in range(B + 1):
        W[6 * i:6 * i + 6, 6 * i:6 * i + 6] = Wb[i]
    np.testing.assert_allclose(A, J @ W @ J.T, rtol=0, atol=1e-13)


# ------------------------------------------------------------------------------------------------
# one certificate
# ------------------------------------------------------------------------------------------------
@pytest.mark.parametrize("friction_model", ["staggered", "lcp"])
def test_impulse_residual_is_the_core_certificate(friction_model):
    rng = np.random.default_rng(2)
    bodies, c = _random_impulse_scene(rng, B=3, m=4)
    A = _normal_lcp(bodies, c)
    u0n = np.einsum("ij,ij->i", impulse_mod.contact_velocity(bodies, c), c.normal)
    res = resolve_collisions(bodies, c, restitution=0.0, friction=0.3, mode="simultaneous",
                             friction_model=friction_model)
    tol = 1e-10 * max(1.0, np.abs(u0n).max())
    assert res.residual <= tol
    if friction_model == "staggered" and res.extra["rounds"] == 1 and not res.extra["plastic_finish"]:
        # one round: the normal impulses certify the normal LCP (n·J up to roundoff)
        f = res.normal_impulse
        assert natural_map_residual(f, A @ f + u0n) <= tol
    # whatever the rounds (friction changes the normal velocities of the contacts sharing a body, so the law
    # runs again): afterwards no contact approaches (ORACLES D3: the impulse certificate)
    assert res.approach <= res.tolerance * max(1.0, np.abs(u0n).max())


def test_pgs_box_friction_meets_its_conditions():
    # normal impulses complementary to separation, tangential impulses inside [−μf, μf] with zero slip where
    # strictly inside, for random well-posed contact problems (A = J Jᵀ + δ1)
    from pbanim.lcp import pgs_box_friction

    rng = np.random.default_rng(5)
    for _ in range(20):
        m = int(rng.integers(1, 6))
        J = rng.normal(size=(3 * m, 3 * m + 2))
        A = J @ J.T + 1e-3 * np.eye(3 * m)
        b = rng.normal(size=3 * m)
        z, res, sweeps = pgs_box_friction(A, b, 0.7, max_iter=5000, tol=1e-10)
        w = A @ z + b
        f, t = z[0::3], np.stack([z[1::3], z[2::3]], axis=1)
        assert np.all(f >= 0) and np.all(np.abs(t) <= 0.7 * f[:, None] + 1e-12)
        assert res < 1e-6 and np.abs(np.minimum(f, w[0::3])).max() < 1e-6
    with pytest.raises(Exception, match="3 rows per contact"):
        pgs_box_friction(np.eye(2), np.ones(2), 0.5)


def test_pgs_bounded_meets_its_conditions():
    # box-constrained problems: w = 0 where lo < z < hi, w ≥ 0 at lo, w ≤ 0 at hi
    from pbanim.lcp import pgs_bounded

    rng = np.random.default_rng(6)
    for _ in range(20):
        n = int(rng.integers(1, 8))
        J = rng.normal(size=(n, n + 2))
        A, b = J @ J.T + 1e-3 * np.eye(n), rng.normal(size=n)
        lo, hi = -rng.uniform(0, 1, n), rng.uniform(0, 1, n)
        z, res, _ = pgs_bounded(A, b, lo, hi, max_iter=20000, tol=1e-12)
        w = A @ z + b
        assert np.all(z >= lo - 1e-15) and np.all(z <= hi + 1e-15) and res < 1e-8
        free = (z > lo + 1e-12) & (z < hi - 1e-12)
        assert np.all(np.abs(w[free]) < 1e-8) and np.all(w[z <= lo + 1e-12] > -1e-8) and np.all(w[z >= hi - 1e-12] < 1e-8)


# ------------------------------------------------------------------------------------------------
# ORACLES D17: the stepping loop's PGS (pbanim.lcp.solve.lean_pgs) runs the readable sweeps — the same
# warm-start test, the same iterates bit for bit, the same certificate — and hands back what it cannot certify
# ------------------------------------------------------------------------------------------------
@settings(max_examples=25, deadline=None)
@given(m=st.integers(1, 8), seed=st.integers(0, 10**6), warm=st.sampled_from(["none", "near", "far"]))
def test_lean_pgs_equals_solve_lcp(m, seed, warm):
    from pbanim.lcp.solve import lean_pgs

    rng = np.random.default_rng(seed)
    G = rng.normal(size=(m, m + 2))
    A = G @ G.T + 0.1 * np.eye(m)
    b = rng.normal(size=m)
    ws = {"none": None, "near": np.abs(rng.normal(size=m)) * 0.1, "far": np.full(m, 1e6)}[warm]
    ref = solve_lcp(A, b, "pgs", tol=1e-10, warm_start=ws, validate=False)
    got = lean_pgs(A, b, ws, 1e-10)
    assert got is not None and got.success and ref.success
    assert np.array_equal(got.f, ref.f) and got.iterations == ref.iterations
    assert got.extra["threshold"] == ref.extra["threshold"]
    assert got.extra.get("warm_start_dropped") == ref.extra.get("warm_start_dropped")
    assert got.residual <= got.extra["threshold"]


def test_lean_pgs_hands_back_what_it_cannot_certify():
    from pbanim.lcp.solve import lean_pgs

    A = np.array([[2.0, 1.0], [1.0, 2.0]])
    assert lean_pgs(np.array([[1.0, 0.0], [0.0, 0.0]]), np.array([-1.0, -1.0]), None, 1e-10) is None  # Aᵢᵢ = 0
    assert lean_pgs(A, np.array([-1.0, np.nan]), None, 1e-10) is None                                # not finite
    assert lean_pgs(A, np.array([-1.0, -1.0]), None, 1e-14, max_iter=1) is None                      # unconverged
    with pytest.raises(Exception, match="pgs"):                       # the readable call names the failure
        solve_lcp(A, np.array([-1.0, -1.0]), "pgs", tol=1e-14, max_iter=1)
    sol = lean_pgs(A, np.array([1.0, 2.0]), None, 1e-10)              # b ≥ 0: f = 0 with no sweep
    assert sol.iterations == 0 and np.array_equal(sol.f, np.zeros(2))
