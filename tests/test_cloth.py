"""Cloth (chapter 12): Jacobians, invariants, large steps, XPBD and the static drape against their oracles.

Each test cites its oracle from ORACLES.md section J. Tolerances: measured first, asserted a fixed factor
above; both numbers are in the comment next to the assert.
"""

import numpy as np
import pytest
import scipy.optimize

from pbanim.cloth import Cloth, Ground, Sheet, Sphere, large_step, modified_pcg, newton_step, xpbd_step
from pbanim.cloth.readable import bend_gradient, condition_forces_loop
from pbanim.cloth.bend import _angle_terms
from pbanim.derivatives import central_jacobian
from pbanim.errors import InvalidInput
from pbanim.ode import solve

KINDS = [(model, kind) for model in ("springs", "bw") for kind in ("stretch", "shear", "bend")]


def _one_kind(model, kind, n=4, damping=0.05, pins="none"):
    kw = dict(stretch=0.0, shear=0.0, bend=0.0)
    kw[kind] = 50.0
    return Cloth(Sheet(n, pins=pins), model=model, damping=damping, gravity=(0.0, 0.0, 0.0), **kw)


def _random_state(cloth, seed, dx=0.05, dv=1.0):
    rng = np.random.default_rng(seed)
    y, n = cloth.state(), cloth.n
    y[:n] += dx * rng.standard_normal(n)
    y[n:] = dv * rng.standard_normal(n)
    return y


@pytest.mark.parametrize("model,kind", KINDS)
@pytest.mark.parametrize("seed", [0, 1])
def test_jacobians_equal_finite_differences(model, kind, seed):
    # ORACLES J1: K = ∂f/∂x and D = ∂f/∂v of every force equal centred differences on a random state
    cloth = _one_kind(model, kind)
    y, n = _random_state(cloth, seed), cloth.n
    K, D = cloth.jacobians(y)
    Kfd = central_jacobian(lambda x: cloth.forces(np.concatenate([x, y[n:]])).ravel(), y[:n])
    Dfd = central_jacobian(lambda v: cloth.forces(np.concatenate([y[:n], v])).ravel(), y[n:])
    eK = np.abs(K.toarray() - Kfd).max() / np.abs(Kfd).max()
    eD = np.abs(D.toarray() - Dfd).max() / np.abs(Dfd).max()
    assert eK < 1e-8 and eD < 1e-8, (eK, eD)          # measured ≤ 9e-11 (K), ≤ 7e-10 (D)


@pytest.mark.parametrize("model,kind", KINDS)
def test_stiffness_is_symmetric_and_kills_translations(model, kind):
    # ORACLES J1: ∂f/∂x of a conservative force is symmetric (−Hessian of the energy); K·(translation) = 0
    cloth = _one_kind(model, kind, damping=0.0)
    y = _random_state(cloth, 3)
    K, D = cloth.jacobians(y)
    scale = np.abs(K).max()
    assert abs(K - K.T).max() <= 1e-14 * scale                # measured ≤ 1.2e-16 relative
    assert np.abs(D.data).max() == 0.0
    for axis in range(3):
        t = np.zeros((cloth.n // 3, 3))
        t[:, axis] = 1.0
        assert np.abs(K @ t.ravel()).max() <= 1e-12 * scale   # measured ~1e-15


@pytest.mark.parametrize("model", ["springs", "bw"])
def test_forces_are_minus_the_energy_gradient(model):
    # ORACLES J1: f = −∂V/∂x (undamped; V includes gravity)
    cloth = Cloth(Sheet(4, pins="none"), model=model, stretch=30.0, shear=5.0, bend=0.2)
    y, n = _random_state(cloth, 4), cloth.n
    y[n:] = 0.0
    g = central_jacobian(lambda x: np.array([cloth.energy(np.concatenate([x, y[n:]]))]), y[:n])[0]
    f = cloth.forces(y).ravel()
    assert np.abs(f + g).max() <= 1e-7 * np.abs(f).max()       # measured ~1e-10


@pytest.mark.parametrize("model", ["springs", "bw"])
def test_readable_loop_equals_vectorized(model):
    # the readable element loop and the vectorized kinds give one force to roundoff (ORACLES J1)
    cloth = Cloth(Sheet(5, pins="corners"), model=model, stretch=40.0, shear=4.0, bend=0.3, damping=0.02)
    y = _random_state(cloth, 5)
    f, floop = cloth.forces(y), condition_forces_loop(cloth, y)
    assert np.abs(f - floop).max() <= 64 * np.finfo(float).eps * np.abs(f).max()   # measured ≤ 4.3e-16 rel


@pytest.mark.parametrize("exact", [True, False])
def test_pair_assembly_equals_full_element_blocks(exact):
    # the springs' reduced 3 × 3 blocks (K_e = c cᵀ ⊗ B), gathered with the incidence sums, give the K, D
    # and f of the full 6 × 6 element blocks summed by bincount, to roundoff (ORACLES J1, J6); a pattern whose
    # pair blocks are shared (the same kind twice) takes the general path and agrees too
    from pbanim.cloth.assembly import Pattern
    cloth = Cloth(Sheet(6, pins="corners"), stretch=1e3, shear=1e2, bend=1.0, damping=1e-2)
    y = _random_state(cloth, 3, dx=0.02)
    x, v = y[:cloth.n].reshape(-1, 3), y[cloth.n:].reshape(-1, 3)
    assert all(p is not None for p in cloth.pattern.pairs)
    f, kd, dd = cloth._all(x, v, exact)
    full = [c.terms(x, v, True, exact) for c in cloth.conditions]
    general = Pattern(cloth.n, [c.dofs for c in cloth.conditions])
    fg = cloth.fext + sum(np.bincount(c.dofs.ravel(), t[0].ravel(), minlength=cloth.n)
                          for c, t in zip(cloth.conditions, full))
    tol = 16 * np.finfo(float).eps
    assert np.abs(general.data([t[1] for t in full]) - kd).max() <= tol * np.abs(kd).max()   # measured 1.7e-16
    assert np.abs(general.data([t[2] for t in full]) - dd).max() <= tol * np.abs(dd).max()   # measured 3.1e-16
    assert np.abs(f - fg).max() <= tol * np.abs(fg).max()
    c = cloth.conditions[0]
    twice = Pattern(cloth.n, [c.dofs, c.dofs], [c.elements, c.elements])
    assert twice.pairs == [None, None] and twice.reduced == [True, True]
    _, BK, _ = c.pair_terms(x, v, exact)
    once = Pattern(cloth.n, [c.dofs]).data([c.terms(x, v, True, exact)[1]])      # the same keys as ``twice``
    assert np.abs(twice.data([BK, BK]) - 2 * once).max() <= 2 * tol * np.abs(once).max()


def test_bend_gradient_closed_forms_agree():
    # ORACLES J1: Bridson et al.'s closed-form ∂θ/∂x equals the inner-product form of pbanim.cloth.bend
    rng = np.random.default_rng(6)
    X = np.array([[0.0, 0, 0], [1, 0, 0], [0.4, 1, 0], [0.6, -1, 0]]) + 0.2 * rng.standard_normal((4, 3))
    theta, g = bend_gradient(X)
    th2, g2, _ = _angle_terms(X[None])
    L = np.kron(np.array([[-1.0, 1, 0, 0], [-1, 0, 1, 0], [-1, 0, 0, 1]]), np.eye(3))
    assert abs(theta - th2[0]) < 1e-15
    assert np.abs(g.ravel() - g2[0] @ L).max() < 1e-13          # measured 1e-16


# --------------------------------------------------------------------------------------------------
# J2: invariants
# --------------------------------------------------------------------------------------------------
@pytest.mark.parametrize("method", ["verlet", "symplectic_euler"])
def test_free_sheet_keeps_momentum_and_angular_momentum(method):
    # ORACLES J2: no pins, no gravity: Σ m v and Σ m x × v kept to roundoff by a force-pair-symmetric method
    cloth = Cloth(Sheet(4, pins="none"), model="bw", stretch=50.0, shear=5.0, bend=0.01, damping=0.01,
                  gravity=(0.0, 0.0, 0.0))
    y0, n = _random_state(cloth, 7, dx=0.02, dv=0.3), cloth.n
    r = solve(cloth.rhs, (0.0, 0.3), cloth.free_state(y0), method=method, h=1e-3)
    m = cloth.sheet.masses[:, None]
    X, V = r.y[:n].T.reshape(-1, n // 3, 3), r.y[n:].T.reshape(-1, n // 3, 3)
    P, L = (m * V).sum(axis=1), (m * np.cross(X, V)).sum(axis=1)
    assert np.abs(P - P[0]).max() <= 1e-14                       # measured 2e-16 (|P| = 0.03)
    assert np.abs(L - L[0]).max() <= 1e-14                       # measured 1e-16 (|L| = 0.007)


def test_undamped_energy_bounded_under_verlet():
    # ORACLES J2: undamped, Verlet's energy error oscillates without drift (second half no larger than first)
    cloth = Cloth(Sheet(4, pins="none"), model="bw", stretch=50.0, shear=5.0, bend=0.01, gravity=(0.0, 0.0, 0.0))
    y0 = _random_state(cloth, 1, dx=0.02, dv=0.3)
    r = solve(cloth.rhs, (0.0, 1.5), cloth.free_state(y0), method="verlet", h=1e-3)
    E = np.array([cloth.energy(r.y[:, k]) for k in range(0, r.y.shape[1], 10)])
    first, second = np.ptp(E[:len(E) // 2]), np.ptp(E[len(E) // 2:])
    assert np.ptp(E) / E[0] < 5e-3                                # measured 1.1e-3 over 10⁴ steps, ≤ 1e-3 over 1500
    assert second < 2.0 * first                                   # measured 0.8× (no drift)


def test_large_step_keeps_momentum_of_a_free_sheet_to_the_cg_residual():
    # ORACLES J2: 1ᵀK = 1ᵀD = 0, so Σ m Δv = −1ᵀ r: at a tight CG tolerance the momentum is kept
    cloth = Cloth(Sheet(5, pins="none"), model="springs", stretch=1e3, shear=1e2, bend=1.0, damping=0.01,
                  gravity=(0.0, 0.0, 0.0))
    y, n = _random_state(cloth, 8, dx=0.0, dv=0.3), cloth.n      # from rest shape: A = M − hD − h²K is SPD
    P0 = cloth.momentum(y)
    for _ in range(5):
        y, sol = large_step(cloth, y, 0.01, tol=1e-12)
        assert sol.converged
    assert np.abs(cloth.momentum(y) - P0).max() < 1e-12          # measured 3.5e-14 (|P| = 0.02)


# --------------------------------------------------------------------------------------------------
# J3: implicit Euler limits
# --------------------------------------------------------------------------------------------------
def _linear_spring_cloth(k=300.0, n=4):
    """A spring cloth whose springs have zero rest length: f = −k (x_a − x_b), linear in x."""
    cloth = Cloth(Sheet(n, pins="corners"), model="springs", stretch=k, shear=0.1 * k, bend=0.01 * k)
    for c in cloth.conditions:
        c.rest[:] = 0.0
    return cloth


@pytest.mark.parametrize("precond", ["jacobi", "multigrid"])
def test_large_step_on_linear_springs_is_implicit_euler(precond):
    # ORACLES J3: for linear forces the one Newton step is implicit Euler; compare a dense solve of
    # M Δv = h f(x₀ + h(v₀ + Δv)) on the free coordinates (only Cloth.forces used); either preconditioner
    cloth = _linear_spring_cloth()
    y0, n, h = _random_state(cloth, 9, dx=0.02, dv=0.5), cloth.n, 0.05
    y0[:n].reshape(-1, 3)[cloth.pinned] = cloth.sheet.x0[cloth.pinned]
    y0[n:].reshape(-1, 3)[cloth.pinned] = 0.0
    F = cloth.free
    f0 = cloth.forces(y0).ravel()
    A = np.zeros((cloth.nf, cloth.nf))
    for j, col in enumerate(np.flatnonzero(F)):                # f is affine: columns of ∂f/∂x by unit moves
        y = y0.copy()
        y[col] += 1.0
        A[:, j] = (cloth.forces(y).ravel() - f0)[F]
    M = np.diag(cloth.mass3[F])
    rhs = h * (f0[F] + h * A @ y0[n:][F])
    dv = np.linalg.solve(M - h * h * A, rhs)
    y1, sol = large_step(cloth, y0, h, tol=1e-13, precond=precond)
    assert sol.converged
    assert np.abs(y1[n:][F] - (y0[n:][F] + dv)).max() < 1e-10 * np.abs(dv).max()     # measured 6e-16 rel
    yN, iters = newton_step(cloth, y0, h)
    assert iters == 1 and np.abs(yN - y1).max() < 1e-11                             # already converged


def _falling_sheet_system(n, steps=4):
    """The benchmark's kind of sheet a few large steps into its fall, and A = M − hD − h²K there (h = 1/60)."""
    from pbanim.cloth.large_steps import _system
    cloth = Cloth(Sheet(n, pins="corners"), stretch=1e3, shear=1e2, bend=0.1, damping=1e-3)
    y = cloth.state()
    for _ in range(steps):
        y = large_step(cloth, y, 1.0 / 60.0, tol=1e-6)[0]
    x, v = y[:cloth.n].reshape(-1, 3), y[cloth.n:].reshape(-1, 3)
    _, kd, dd = cloth._all(x, v, exact=False)
    return cloth, y, _system(cloth, kd, dd, 1.0 / 60.0)


@pytest.mark.parametrize("n", [10, 20])
@pytest.mark.parametrize("additive_top", [False, True])
def test_multigrid_preconditioner_is_spd_with_bounded_spectrum(n, additive_top):
    # ORACLES J6: the V-cycle (ℓ1-Jacobi smoothing, Galerkin coarse matrices) is a symmetric operator B with
    # the eigenvalues of B A in (0, 1]; the default, additive on the finest level (D₁⁻¹ + P B₁ Pᵀ, two
    # contractions summed), in (0, 2] — what CG needs; and damped Jacobi (ω = ⅔ on a_ii) would not be
    from pbanim.cloth.multigrid import Multigrid
    cloth, _, A = _falling_sheet_system(n)
    mg = Multigrid(cloth.pattern, n, coarsest=16, additive_top=additive_top, smoother="l1-jacobi")
    mg.setup(A.data)
    assert len(mg.levels) >= 2
    B = np.stack([mg(e) for e in np.eye(cloth.n)], axis=1)
    assert np.abs(B - B.T).max() <= 1e3 * np.finfo(float).eps * np.abs(B).max()      # measured 1e-17 rel
    ev = np.linalg.eigvals(B @ A.toarray()).real
    top = 2.0 if additive_top else 1.0
    assert ev.min() > 1e-3 and ev.max() <= top + 1e-9, (ev.min(), ev.max())          # measured 0.010 … 1
    dinv = 1.0 / A.diagonal()
    assert np.linalg.eigvals((2.0 / 3.0) * dinv[:, None] * A.toarray()).real.max() > 2.0   # ω D⁻¹A past 2


def test_large_step_preconditioners_agree_with_pins_and_contacts():
    # ORACLES J3, J6: the filtered PCG converges to one solution whatever SPD preconditioner: Jacobi and
    # multigrid at tolerance 1e-11 on a sheet with pins, a sphere and the ground
    cloth = Cloth(Sheet(12, pins="corners", height=0.3), stretch=1e3, shear=1e2, bend=0.1, damping=1e-3,
                  colliders=[Sphere([0.0, 0.0, 0.0], 0.3), Ground(-0.5)])
    y = cloth.state()
    for _ in range(3):
        y = large_step(cloth, y, 1.0 / 60.0, tol=1e-8)[0]
    a, sa = large_step(cloth, y, 1.0 / 60.0, tol=1e-11, max_iter=5000)
    b, sb = large_step(cloth, y, 1.0 / 60.0, tol=1e-11, max_iter=5000, precond="multigrid")
    assert sa.converged and sb.converged and sb.iterations < sa.iterations
    dv = np.abs(a[cloth.n:] - y[cloth.n:]).max()
    assert np.abs(a - b).max() <= 1e-8 * dv, (np.abs(a - b).max(), dv)


def test_large_steps_never_gain_energy_at_h_01_k_1e6():
    # ORACLES J3: on linear springs (zero rest length, k = 10⁶) the large step is implicit Euler, which
    # never gains energy (convex V): 30 steps of h = 0.1 s. (On the nonlinear flat sheet one linearized
    # step is not enough at this h: the module docstring of pbanim.cloth.large_steps says why.)
    cloth = _linear_spring_cloth(k=1e6)
    y = cloth.state()
    E = [cloth.energy(y)]
    for _ in range(30):
        y, sol = large_step(cloth, y, 0.1, tol=1e-10, max_iter=5000)
        assert sol.converged
        E.append(cloth.energy(y))
    assert np.all(np.diff(E) <= 1e-14 * E[0]), np.diff(E).max() / E[0]    # measured ≤ 4e-17 E₀ (roundoff)
    assert E[-1] < 0.5 * E[0]                                              # measured 1.57e6 → 3.5e5 J


def test_filter_leaves_pinned_particles_exactly():
    # ORACLES J3: the filter zeroes every pinned row: the pins do not move, bit for bit
    cloth = Cloth(Sheet(6, pins="edge"), model="bw", stretch=1e3, shear=1e2, bend=0.01, damping=0.01,
                  colliders=[Sphere([0.0, 0.0, -0.3], 0.25), Ground(-0.6)])
    y = cloth.state()
    n, pins = cloth.n, cloth.pinned
    for _ in range(20):
        y, _ = large_step(cloth, y, 1.0 / 60.0)
    assert np.array_equal(y[:n].reshape(-1, 3)[pins], cloth.sheet.x0[pins])
    assert np.array_equal(y[n:].reshape(-1, 3)[pins], np.zeros((len(pins), 3)))


def test_collisions_keep_the_cloth_out_of_the_sphere_and_ground():
    # ORACLES J3: contact particles are filtered along n and put back on the surface (large step and XPBD)
    sphere = Sphere([0.0, 0.0, -0.3], 0.2)
    cloth = Cloth(Sheet(8, pins="none"), model="springs", stretch=500.0, shear=50.0, bend=0.1, damping=0.02,
                  colliders=[sphere, Ground(-0.6)])
    for step in (lambda y: large_step(cloth, y, 1.0 / 60.0)[0], lambda y: xpbd_step(cloth, y, 1.0 / 60.0, 4, 2)):
        y = cloth.state()
        for _ in range(40):
            y = step(y)
        x = y[:cloth.n].reshape(-1, 3)
        assert sphere.signed_distance(x)[0].min() > -0.02         # measured ≥ −0.006 (one step of approach)
        assert x[:, 2].min() > -0.62


def test_modified_pcg_prescribed_and_filtered():
    # ORACLES J3: a filtered row keeps its prescribed value z; free rows solve A x = b
    import scipy.sparse as sp
    rng = np.random.default_rng(2)
    B = rng.standard_normal((6, 6))
    A = sp.csr_matrix(B @ B.T + 6 * np.eye(6))
    b = rng.standard_normal(6)
    S = np.stack([np.eye(3), np.zeros((3, 3))])
    z = np.array([0, 0, 0, 1.0, 2.0, 3.0])
    r = modified_pcg(A, b, S=S, z=z, tol=1e-14)
    assert np.array_equal(r.x[3:], z[3:])
    assert np.abs((A @ r.x - b)[:3]).max() < 1e-12
    with pytest.raises(InvalidInput):
        modified_pcg(A, b[:5])


# --------------------------------------------------------------------------------------------------
# J4: XPBD and compliance
# --------------------------------------------------------------------------------------------------
@pytest.mark.parametrize("model", ["springs", "bw"])
def test_xpbd_converges_to_compliant_implicit_euler(model):
    # ORACLES J4: α = 1/k; n substeps of one sweep vs n implicit Euler steps of h/n (Newton): the gap
    # shrinks at a fitted rate ≥ 1 in n; at fixed h, more sweeps approach the implicit Euler step itself
    cloth = Cloth(Sheet(5, pins="corners"), model=model, stretch=200.0, shear=20.0, bend=0.05, damping=0.01)
    y0, n, h = cloth.state(), cloth.n, 0.02
    ns, gaps = [2, 4, 8, 16], []
    for s in ns:
        y = y0.copy()
        for _ in range(s):
            y = newton_step(cloth, y, h / s)[0]
        gaps.append(np.abs(xpbd_step(cloth, y0, h, s, 1)[:n] - y[:n]).max())
    rate = -np.polyfit(np.log(ns), np.log(gaps), 1)[0]
    assert rate > 0.9, (rate, gaps)                                 # measured 1.14 (springs), 1.55 (bw)
    ie = newton_step(cloth, y0, h)[0]
    e10, e100 = (np.abs(xpbd_step(cloth, y0, h, 1, it)[:n] - ie[:n]).max() for it in (10, 100))
    assert e100 < 0.1 * e10 and e100 < 1e-6, (e10, e100)            # measured 1e-5 → 2e-8 (springs), 3e-6 → 2e-7


def test_xpbd_alpha_zero_limit_is_hard_constraint():
    # ORACLES J4: k → ∞ (α → 0) is PBD: the springs end at their rest length after enough sweeps
    cloth = Cloth(Sheet(3, pins="edge"), model="springs", stretch=1e9, shear=0.0, bend=0.0)
    y = cloth.state()
    for _ in range(5):
        y = xpbd_step(cloth, y, 1.0 / 60.0, 1, 200)
    c = cloth.conditions[0]
    C = c.evaluate(y[:cloth.n].reshape(-1, 3), hessian=False)[0]
    assert np.abs(C).max() < 1e-8                                   # measured 1.2e-10 (of Δ = 0.5 m)


# --------------------------------------------------------------------------------------------------
# J5: the static drape
# --------------------------------------------------------------------------------------------------
def test_static_drape_is_the_energy_minimum():
    # ORACLES J5: damped large steps settle where scipy's L-BFGS finds the minimum of the same energy
    cloth = Cloth(Sheet(5, pins="corners", orientation="vertical"), model="springs", stretch=200.0, shear=20.0,
                  bend=0.05, damping=0.05)
    y, n = cloth.state(), cloth.n
    for _ in range(400):
        y, _ = large_step(cloth, y, 0.02, tol=1e-10)
    F = cloth.free

    def energy(xf):
        z = cloth.state()
        z[:n][F] = xf
        return cloth.energy(z), -cloth.forces(z).ravel()[F]

    res = scipy.optimize.minimize(energy, cloth.state()[:n][F], jac=True, method="L-BFGS-B",
                                  options=dict(gtol=1e-12, ftol=1e-15, maxiter=20000))
    gap = np.abs(y[:n][F] - res.x).max()
    assert gap < 1e-6, gap                                          # measured 4.3e-9 m (sheet of 1 m)
    assert np.abs(y[n:]).max() < 1e-6


# --------------------------------------------------------------------------------------------------
# the ODE of the free particles and the input checks
# --------------------------------------------------------------------------------------------------
def test_free_jacobian_is_the_rhs_derivative():
    # ORACLES J1: jac = ∂rhs/∂y_F = [[0, I], [W K_FF, W D_FF]] equals centred differences of rhs
    cloth = Cloth(Sheet(4, pins="corners"), model="bw", stretch=30.0, shear=3.0, bend=0.1, damping=0.02)
    yf = cloth.free_state(_random_state(cloth, 11, dx=0.02, dv=0.5))
    J = cloth.jac(0.0, yf).toarray()
    Jfd = central_jacobian(lambda z: cloth.rhs(0.0, z), yf)
    assert np.abs(J - Jfd).max() < 1e-7 * np.abs(Jfd).max()        # measured ~1e-10 rel


def test_scene_of_a_free_cloth_matches_rhs_and_refuses_pins():
    cloth = Cloth(Sheet(3, pins="none"), model="springs")
    y = _random_state(cloth, 12, dx=0.02, dv=0.5)
    assert np.abs(cloth.scene().rhs(0.0, y) - cloth.rhs(0.0, cloth.free_state(y))).max() < 1e-12
    with pytest.raises(InvalidInput):
        Cloth(Sheet(3)).scene()
    with pytest.raises(InvalidInput):
        Sheet(1)
    with pytest.raises(InvalidInput):
        Cloth(Sheet(3), model="fem")
