"""Constrained dynamics (chapter 03): λ by Witkin's JWJᵀ, KKT and the linear-time solver; Baumgarte; projection.

Oracles: ORACLES B1 (bead tension), B2 (drift, Baumgarte, its own stability limit), B3 (hanging chains),
B4 (redundant / inconsistent constraints), B5 (KKT vs Witkin), G3 (bad inputs).
"""

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from pbanim.constraints import (SOLVERS, Constraints, ConstraintSet, Distance, FixedPoint, OnCircle, OnPlane,
                                baumgarte_feedback_map, baumgarte_spectral_radius, baumgarte_stability_limit, solve_multipliers)
from pbanim.errors import (ConvergenceError, InvalidInput, NonFiniteResult, SimulationDiverged,
                           SingularConstraintError)
from pbanim.models.constrained import (bead_on_circle, cloth_patch, hanging_chain, inconsistent_x, random_chain,
                                       random_tree, redundant_rod, redundant_xy)
from pbanim.particles import Gravity, ParticleSystem
from pbanim.scene import Scene

DIRECT = ["witkin-dense", "witkin-sparse", "kkt"]


def _gravity_Q(mod):
    return mod.system.m[:, None] * mod.g


# -- B1: bead on a circle ----------------------------------------------------------------------------
def test_bead_lambda_equals_tension_at_every_step():
    # ORACLES B1: with C = ½(|x|² − R²), −λ|x| = m(v²/R + g cos θ) at the simulated state, every step
    mod = bead_on_circle(radius=1.0, mass=1.0, theta0=np.pi / 2)
    res = Scene(mod.system, [Gravity(mod.g), Constraints(mod.constraints)]).simulate(1.0, 1e-3, "rk4")
    lam = res.diagnostics["lam"][:, 0]
    R = np.linalg.norm(res.y[:2].T, axis=1)
    T = np.array([mod.info["tension"](y) for y in res.y.T])
    rel = np.max(np.abs(-lam * R - T)) / np.max(np.abs(T))
    assert rel < 1e-10  # measured 3.6e-16, bound 1e-10 (the issue's)
    # and the solver choice does not matter: every solver gives the same λ at the final state
    for s in SOLVERS:
        sol = solve_multipliers(mod.constraints, mod.system, res.y[:, -1], _gravity_Q(mod), solver=s)
        assert abs(sol.lam[0] - lam[-1]) <= 1e-12 * abs(lam[-1])  # measured ~1e-16


def test_bead_released_from_horizontal_has_3mg_at_the_bottom():
    # ORACLES B1: energy gives v² = 2gR at the bottom, so the tension there is m(2g + g) = 3mg
    mod = bead_on_circle(radius=1.0, mass=2.0, g=9.81, theta0=np.pi / 2)
    res = Scene(mod.system, [Gravity(mod.g), Constraints(mod.constraints)]).simulate(1.0, 1e-3, "rk4")
    th = np.array([mod.info["theta"](y) for y in res.y.T])
    lam = res.diagnostics["lam"][:, 0]
    k = np.flatnonzero((th[:-1] > 0) & (th[1:] <= 0))[0]
    a = th[k] / (th[k] - th[k + 1])
    T_bottom = -((1 - a) * lam[k] + a * lam[k + 1])  # R = 1
    # linear interpolation across the bottom: error ≈ 3mg θ²/2 with θ ≈ ωh
    assert abs(T_bottom / (3 * 2.0 * 9.81) - 1) < 2e-6  # measured 3.7e-7, bound 2e-6


# -- B2: drift, Baumgarte, projection ----------------------------------------------------------------
def test_drift_without_feedback_follows_the_exact_explicit_euler_recursion():
    # ORACLES B2: with k_s = k_d = 0 and explicit Euler, x·v stays 0, so |x_{n+1}|² = |x_n|² + h²|v_n|²
    # exactly; the constraint force (along x) raises the speed: |v_{n+1}|² = |v_n|²(1 + h²|v_n|²/R_n²).
    mod = bead_on_circle(theta0=0.3, omega0=2.0)
    h = 1e-2
    res = Scene(mod.system, [Constraints(mod.constraints)]).simulate(1.0, h, "euler")
    x, v = res.y[:2].T, res.y[2:].T
    R2 = np.sum(x * x, axis=1)
    R2_exact, s = [R2[0]], float(v[0] @ v[0])
    for _ in range(len(R2) - 1):
        R2_exact.append(R2_exact[-1] + h * h * s)
        s *= 1 + h * h * s / R2_exact[-2]
    assert np.max(np.abs(R2 - np.array(R2_exact)) / R2) < 1e-13  # measured 1.7e-15, bound 1e-13
    # to first order this is R_n² = R₀² + n h² v₀² (the speed grows only at O(h²) per step)
    n = np.arange(len(R2))
    assert np.max(np.abs(R2 - (R2[0] + n * h * h * (v[0] @ v[0]))) / R2) < 5e-3  # measured 7.7e-4
    assert R2[-1] > R2[0] + 0.9 * (len(R2) - 1) * h * h * (v[0] @ v[0])  # it does drift outward


def test_critical_baumgarte_error_follows_the_closed_form_and_never_grows_after_the_transient():
    # ORACLES B2: C̈ + 2ωĊ + ω²C = 0 ⇒ C(t) = (C₀ + (Ċ₀ + ωC₀)t)e^(−ωt); |C| non-increasing after its peak
    ps = ParticleSystem([[0.0, -1.05]], [[1.0, -1.0]], masses=1.0)
    w = 10.0
    eff = Constraints([OnCircle([0], [0.0, 0.0], 1.0)], stabilization="baumgarte", natural_frequency=w,
                      damping_ratio=1.0)
    res = Scene(ps, [Gravity(), eff]).simulate(2.0, 2e-3, "rk4")
    x, v = res.y[:2].T, res.y[2:].T
    C = 0.5 * (np.sum(x * x, axis=1) - 1)
    Cd = np.sum(x * v, axis=1)
    t = res.t
    C_exact = (C[0] + (Cd[0] + w * C[0]) * t) * np.exp(-w * t)
    assert np.max(np.abs(C - C_exact)) < 3e-9  # RK4 at ωh = 0.02 (error ∝ h⁴); measured 4.2e-10, bound 3e-9
    t_peak = 1 / w - C[0] / (Cd[0] + w * C[0])
    assert t_peak > 0.01  # a real transient: |C| first grows
    after = np.abs(C[t >= t_peak + 1e-3])
    assert np.all(np.diff(after) <= 1e-14)  # non-increasing (to roundoff)
    assert after[-1] < 1e-6 * after[0]  # e^(−ω t) at t = 2 s: ~8e-8 of the peak


def test_projection_keeps_the_constraint_error_below_1e12():
    # ORACLES B2: post-step projection onto C = 0, Ċ = 0 (swinging chain, symplectic Euler)
    mod = hanging_chain(10, link_length=0.1, angle=1.2)
    eff = Constraints(mod.constraints, stabilization="projection")
    scene = Scene(mod.system, [Gravity(mod.g), eff])
    assert scene.pipeline == ("gravity", "constraints", "integrate", "constraint-projection")
    res = scene.simulate(1.0, 5e-3, "symplectic_euler")
    assert res.diagnostics["C_max"].max() < 1e-12  # measured ~1e-16 after the first step
    assert res.diagnostics["Cdot_max"][1:].max() < 1e-12
    free = Scene(mod.system, [Gravity(mod.g), Constraints(mod.constraints)]).simulate(1.0, 5e-3, "symplectic_euler")
    assert free.diagnostics["C_max"].max() > 1e-6  # without it the same run drifts


def _plane_scene(omega_h, zeta, h, method, C0=1e-3):
    # a linear constraint (y = 0): the error obeys exactly the discrete feedback map of the integrator
    ps = ParticleSystem([[0.0, C0]], [[0.3, 0.0]], masses=1.0)
    eff = Constraints([OnPlane([0], [0.0, 0.0], [0.0, 1.0])], stabilization="baumgarte",
                      natural_frequency=omega_h / h, damping_ratio=zeta, max_violation=1.0)
    return Scene(ps, [Gravity(), eff])


@pytest.mark.parametrize("method", ["symplectic_euler", "rk4"])
def test_baumgarte_feedback_has_its_own_step_limit(method):
    # ORACLES B2: the feedback is a stiff spring; its limit in ω_b h from the eigenvalues of the map
    lim = baumgarte_stability_limit(method, 1.0)
    if method == "symplectic_euler":
        # kick-drift on C̈ = −ω²C − 2ζωĊ is stable iff hk_d < 2 and h²k_s + 2hk_d < 4: (ωh)² + 4ωh = 4
        assert abs(lim - (2 * np.sqrt(2) - 2)) < 1e-9
    rho = baumgarte_spectral_radius(method, [0.98 * lim, 1.02 * lim], 1.0)
    assert rho[0] < 1 < rho[1]
    h, C0 = 0.01, 1e-3
    res = _plane_scene(0.98 * lim, 1.0, h, method, C0).simulate(1500 * h, h, method)
    # bounded just below the limit, by the transient growth of the (non-normal) map: max_k ‖M^k e₁‖ C₀
    M = baumgarte_feedback_map(method, 0.98 * lim, 1.0)
    growth = max(np.linalg.norm(np.linalg.matrix_power(M, k)[:, 0]) for k in range(200))
    assert res.diagnostics["C_max"].max() <= 1.0001 * growth * C0  # measured 17.7 C₀ for RK4 (growth 17.7+)
    assert res.diagnostics["C_max"][-1] < 1e-6 * C0
    with pytest.raises(SimulationDiverged, match="constraint violation"):
        _plane_scene(1.02 * lim, 1.0, h, method, C0).simulate(1500 * h, h, method)


# -- B5: every solver agrees ---------------------------------------------------------------------------
def _model(kind, n, seed):
    rng = np.random.default_rng(seed)
    if kind == "chain":
        return random_chain(n, rng, dim=int(rng.integers(2, 4)))
    if kind == "tree":
        return random_tree(n, rng, dim=int(rng.integers(2, 4)))
    return cloth_patch(3 + n % 4, 2 + (n // 4) % 4, jitter=0.2, seed=seed)  # nx = 2: the rod between the pins is redundant


@given(kind=st.sampled_from(["chain", "tree", "cloth"]), n=st.integers(1, 40), seed=st.integers(0, 2**31),
       ks=st.floats(0, 100), kd=st.floats(0, 20))
def test_all_solvers_agree_and_satisfy_the_acceleration_constraint(kind, n, seed, ks, kd):
    # ORACLES B5: Witkin (dense, sparse, CG), KKT and the linear-time solver give one q̈ and λ, and
    # J q̈ + J̇q̇ + k_s C + k_d Ċ = 0
    mod = _model(kind, n, seed)
    ps = mod.system
    rng = np.random.default_rng(seed + 1)
    y = ps.state()
    y[: ps.split] += 0.05 * rng.normal(size=ps.split)  # off the constraint manifold: C ≠ 0
    cs = ConstraintSet(mod.constraints, ps.N, ps.dim, ps.W, ps.x0)
    assert cs.structure.linear == (kind != "cloth")
    Q = _gravity_Q(mod) + rng.normal(size=(ps.N, ps.dim))
    solvers = DIRECT + ["witkin-cg"] + (["linear"] if cs.structure.linear else [])
    sols = {s: solve_multipliers(cs, ps, y, Q, solver=s, ks=ks, kd=kd) for s in solvers}
    ref = sols["witkin-dense"]
    lam_scale = max(np.abs(ref.lam).max(), 1e-300)
    qdd_scale = max(np.abs(ref.qdd).max(), np.abs(np.repeat(ps.W, ps.dim) * Q.ravel()).max())
    for s, sol in sols.items():
        assert np.abs(sol.lam - ref.lam).max() <= 1e-10 * lam_scale, s  # measured ≤ 8.8e-13 (CG), 2e-14 others
        assert np.abs(sol.qdd - ref.qdd).max() <= 1e-10 * qdd_scale, s
    x, v = ps.unpack(y)
    asm = cs.assemble(x, v)
    acc = asm.J @ ref.qdd + asm.Jdv + ks * asm.C + kd * asm.Cdot
    WQ = np.repeat(ps.W, ps.dim) * Q.ravel()
    scale = np.abs(asm.J @ WQ).max() + np.abs(asm.Jdv).max() + ks * np.abs(asm.C).max() + kd * np.abs(asm.Cdot).max()
    assert np.abs(acc).max() <= 1e-10 * scale  # measured ~1e-15
    assert ConstraintSet(mod.constraints, ps.N, ps.dim, ps.W, ps.x0).structure.kind == cs.structure.kind


def test_auto_picks_the_linear_solver_for_chains_and_trees_only():
    mod = hanging_chain(50)
    ps = mod.system
    assert solve_multipliers(mod.constraints, ps, ps.state(), _gravity_Q(mod)).solver == "linear"
    cloth = cloth_patch(8, 8)
    sol = solve_multipliers(cloth.constraints, cloth.system, cloth.system.state(), _gravity_Q(cloth))
    assert sol.solver == "witkin-sparse"
    with pytest.raises(ValueError, match="solver 'linear' needs chain- or tree-structured"):
        solve_multipliers(cloth.constraints, cloth.system, cloth.system.state(), solver="linear")
    big = random_tree(300, np.random.default_rng(3))  # wide tree: zero-fill sparse LDLᵀ path
    cs = ConstraintSet(big.constraints, big.system.N, 2, big.system.W, big.system.x0)
    assert cs.structure.kind == "tree"
    a = solve_multipliers(cs, big.system, big.system.state(), _gravity_Q(big), solver="linear")
    b = solve_multipliers(cs, big.system, big.system.state(), _gravity_Q(big), solver="witkin-dense")
    assert np.abs(a.lam - b.lam).max() <= 1e-10 * np.abs(b.lam).max()


# -- B3: hanging chain at rest ---------------------------------------------------------------------------
@pytest.mark.parametrize("link_length", [0.01, 2.0 ** -7])
@pytest.mark.parametrize("solver", ["kkt", "linear", "witkin-dense", "witkin-sparse"])
def test_hanging_chain_tension_is_the_weight_below(solver, link_length):
    # ORACLES B3: at rest, tension in link k = g·Σ(masses below k); n = 1000, masses alternating 1 : 1000
    mod = hanging_chain(1000, link_length=link_length, mass_ratio=1000.0)
    ps = mod.system
    sol = solve_multipliers(mod.constraints, ps, ps.state(), _gravity_Q(mod), solver=solver)
    T = mod.info["rods"].tension(ps.x0, sol.lam)
    exact = mod.info["tension_at_rest"]
    rel = np.max(np.abs(T - exact) / exact)
    # the tolerance 1e-8 for every solver. Witkin's normal form JWJᵀ has κ ≈ 1e9 here, so a plain
    # solve gives ~κε (measured 7e-9…5.5e-8 before refinement); one refinement step with the residual in
    # factored form r − J(W(Jᵀλ)) brings it to measured 2e-15 (linear, sparse, dense); KKT 1.7e-11
    assert rel < 1e-8
    # and nothing moves: q̈ = W(Q + Q_C) cancels forces up to T_max = 4.9e6 N on a 1 kg particle, so its
    # roundoff unit is ε·T_max/m_min ≈ 1e-9 m/s²; measured 9.4e-8 (sparse), bound 1e-6
    assert np.abs(sol.qdd).max() < 1e-6


def test_linear_solver_on_a_chain_in_either_numbering_matches_the_dense_one():
    # a chain numbered from its root is eliminated in its own row order 0…m−1 (a path has a leaf at each
    # end; no gathers); numbered from its free end (row 0 there, the rest shuffled), in the leaves-first
    # order (gathers). Both give witkin-dense's λ and q̈ at masses 1 : 1000, where κ(JWJᵀ) ≈ 1e9
    mod = hanging_chain(1000, link_length=0.01, mass_ratio=1000.0, angle=0.3)
    N = mod.system.N
    pairs = np.stack([np.arange(N), np.arange(-1, N - 1)], axis=1)
    rest = np.random.default_rng(7).permutation(N - 1)
    flipped = np.where(pairs >= 0, N - 1 - pairs, -1)[np.r_[N - 1, rest]]  # row 0 = rod (0, 1)
    x0, m = mod.system.x0, mod.system.m
    for rows, ps, natural in ((pairs, mod.system, True), (flipped, ParticleSystem(x0[::-1], 0 * x0, m[::-1]), False)):
        cs = ConstraintSet([Distance(rows, lengths=0.01, anchors=np.zeros(2))], N, 2, ps.W, ps.x0)
        assert cs.structure.kind == "chain" and cs.structure.natural == natural
        Q = ps.m[:, None] * mod.g
        lin = solve_multipliers(cs, ps, ps.state(), Q, solver="linear")
        ref = solve_multipliers(cs, ps, ps.state(), Q, solver="witkin-dense")
        assert np.abs(lin.lam - ref.lam).max() <= 1e-10 * np.abs(ref.lam).max()  # measured 6e-15
        # Q_C = Jᵀλ sums rod forces of ~5e6 N that cancel to the weight: q̈'s roundoff unit is ε·W|J|ᵀ|λ|
        J = cs.assemble(*ps.unpack(ps.state())).J
        assert np.abs(lin.qdd - ref.qdd).max() <= 1e-10 * np.max(cs.Wq * (abs(J).T @ np.abs(ref.lam)))


def test_banded_and_sparse_solves_equal_the_dense_one_in_relative_residual():
    # ORACLES B3: every solver's λ has a relative residual < 1e-10 in the dense system, measured as the
    # normwise backward error ‖Aλ − r‖/(‖A‖‖λ‖ + ‖r‖): r is tiny here (only the top row is loaded through
    # J W Q), so ‖Aλ − r‖/‖r‖ is ~1e-9 for every solver, dense included.
    mod = hanging_chain(1000, link_length=0.01, mass_ratio=1000.0)
    ps = mod.system
    cs = ConstraintSet(mod.constraints, ps.N, ps.dim, ps.W, ps.x0)
    x, v = ps.unpack(ps.state())
    asm = cs.assemble(x, v)
    A = cs.matrix(asm).toarray()
    Q = _gravity_Q(mod).ravel()
    r = -asm.Jdv - asm.J @ (cs.Wq * Q)
    for solver in ("linear", "witkin-dense", "witkin-sparse", "kkt"):
        lam = solve_multipliers(cs, ps, ps.state(), _gravity_Q(mod), solver=solver).lam
        eta = np.linalg.norm(A @ lam - r) / (np.linalg.norm(A, 2) * np.linalg.norm(lam) + np.linalg.norm(r))
        assert eta < 1e-10, solver  # measured ≤ 8.7e-17 (all four)


def test_cg_reports_non_convergence_instead_of_a_bad_lambda():
    # ORACLES B3: iterative solvers report non-convergence (ConvergenceError with iterations and residual)
    mod = hanging_chain(1000, link_length=0.01, mass_ratio=1000.0)
    with pytest.raises(ConvergenceError, match=r"witkin-cg did not converge: residual .* after 50 iterations") as e:
        solve_multipliers(mod.constraints, mod.system, mod.system.state(), _gravity_Q(mod), solver="witkin-cg",
                          max_iter=50)
    assert e.value.iterations == 50 and e.value.residual > e.value.tol


# -- B4: redundant and inconsistent constraints --------------------------------------------------------
@pytest.mark.parametrize("build", [redundant_rod, redundant_xy])
@pytest.mark.parametrize("solver", ["witkin-dense", "witkin-sparse", "witkin-cg", "kkt", "linear", "auto"])
def test_redundant_constraints_give_the_unique_constraint_force(build, solver):
    # ORACLES B4: λ is not unique but Jᵀλ is; the min-norm answer matches the non-redundant model
    mod = build()
    ps = mod.system
    Q = _gravity_Q(mod) + np.array([[0.7, -0.2]])
    sol = solve_multipliers(mod.constraints, ps, ps.state(), Q, solver=solver, ks=4.0, kd=1.0)
    ref = solve_multipliers(mod.info["reference"], ps, ps.state(), Q, solver="witkin-dense", ks=4.0, kd=1.0)
    assert np.abs(sol.Q_C - ref.Q_C).max() <= 1e-10 * max(1.0, np.abs(ref.Q_C).max())  # measured ≤ 7.1e-15
    assert np.abs(sol.qdd - ref.qdd).max() <= 1e-10 * max(1.0, np.abs(ref.qdd).max())
    if build is redundant_rod:  # the min-norm split of one force over two identical rows is half-half
        assert abs(sol.lam[0] - sol.lam[1]) <= 1e-10 * abs(ref.lam[0])
        assert abs(sol.lam[0] - ref.lam[0] / 2) <= 1e-10 * abs(ref.lam[0])
    if solver != "witkin-cg":
        assert sol.rank_deficient


def test_inconsistent_constraints_raise_naming_the_rows_and_the_residual():
    # ORACLES B4: x = 0 and x = 1 cannot both hold; with feedback the rows ask for different C̈
    mod = inconsistent_x()
    ps = mod.system
    for solver in DIRECT + ["linear"]:
        with pytest.raises(SingularConstraintError, match=r"rows \[0, 1\] are dependent and conflict") as e:
            solve_multipliers(mod.constraints, ps, ps.state(), solver=solver, ks=10.0)
        assert e.value.rows == [0, 1] and e.value.residual > 1.0  # |k_s(C₀ − C₁)|/√2 = 10/√2
    scene = Scene(ps, [Constraints(mod.constraints, stabilization="projection")])
    with pytest.raises(SingularConstraintError, match="rows"):
        scene.simulate(0.1, 0.01)


# -- G3: bad inputs ------------------------------------------------------------------------------------
def test_bad_inputs_raise_value_errors_naming_the_argument():
    with pytest.raises(ValueError, match=r"Distance.__init__: lengths must be .*entries > 0.*got -1.0"):
        Distance([[0, 1]], lengths=-1.0)
    mod = hanging_chain(3)
    with pytest.raises(ValueError, match=r"ks must be a finite number >= 0, got -1"):
        Constraints(mod.constraints, stabilization="baumgarte", ks=-1.0, kd=1.0)
    with pytest.raises(ValueError, match=r"kd must be a finite number >= 0, got -2"):
        Constraints(mod.constraints, stabilization="baumgarte", ks=1.0, kd=-2.0)
    with pytest.raises(ValueError, match=r"solver must be one of .* got 'lu'"):
        Constraints(mod.constraints, solver="lu")
    with pytest.raises(ValueError, match=r"stabilization must be one of .* got 'magic'"):
        Constraints(mod.constraints, stabilization="magic")
    with pytest.raises(ValueError, match=r"needs ks and kd, or natural_frequency"):
        Constraints(mod.constraints, stabilization="baumgarte")
    with pytest.raises(ValueError, match=r"only apply to stabilization='baumgarte'"):
        Constraints(mod.constraints, ks=3.0)
    with pytest.raises(ValueError, match=r"particle index 7 out of range for a system of 3 particles"):
        Scene(mod.system, [Constraints([Distance([[0, 7]], lengths=1.0)])])
    with pytest.raises(ValueError, match=r"FixedPoint.__init__: particles must be .* >= 0.*got \[-5\]"):
        FixedPoint([-5])
    with pytest.raises(ValueError, match=r"OnCircle.__init__: radius must be .*entries > 0.*got 0.0"):
        OnCircle([0], [0.0, 0.0], 0.0)
    with pytest.raises(ValueError, match=r"solver must be one of .* got 'qr'"):
        solve_multipliers(mod.constraints, mod.system, mod.system.state(), solver="qr")


def test_a_scene_without_constraints_never_assembles_J(monkeypatch):
    # "only what is declared runs": no constraint effect, no ConstraintSet, no assembly
    calls = []
    monkeypatch.setattr(ConstraintSet, "assemble", lambda *a, **k: calls.append(1))
    mod = hanging_chain(3)
    scene = Scene(mod.system, [Gravity(mod.g)])
    scene.simulate(0.1, 0.01, "rk4")
    assert calls == [] and scene.pipeline == ("gravity", "integrate")


# -- constraint kinds: J and J̇q̇ against finite differences ----------------------------------------------
def test_every_kind_passes_check_constraint_and_a_wrong_jdot_fails():
    from pbanim.constraints import Angle2D, LinearCombination, OnLine, UserConstraint, check_constraint

    rng = np.random.default_rng(7)
    x2, v2 = rng.normal(size=(4, 2)), rng.normal(size=(4, 2))
    x3, v3 = rng.normal(size=(4, 3)), rng.normal(size=(4, 3))
    kinds2 = [Distance([[0, 1], [2, -1]], lengths=1.0, anchors=[0.3, 0.1]), FixedPoint([1, 3], points=[0.0, 1.0]),
              OnCircle([0, 2], [0.5, 0.0], 2.0), OnLine([1], [0.0, 1.0], [1.0, 1.0]),
              OnPlane([3], [0.0, 0.0], [1.0, 2.0]),
              LinearCombination([[0, 1]], [[0, 1]], [[2.0, -1.0]], [0.5]), Angle2D([[0, 1, 2], [1, 2, 3]], 0.4)]
    for c in kinds2:
        chk = check_constraint(c, x2, v2)
        assert chk.ok, (c.kind, chk)  # FD agreement ~1e-9 (centred differences, ε = 1e-6)
    for c in [Distance([[0, 1], [1, 2]], lengths=0.5), OnLine([2], [0.0, 0.0, 1.0], [0.0, 1.0, 1.0]),
              OnCircle([3], [0.0, 0.0, 0.0], 1.0)]:
        assert check_constraint(c, x3, v3).ok, c.kind
    # a student's constraint with the wrong J̇q̇ (sign error) is caught
    good = UserConstraint(lambda x: [0.5 * (x[0] @ x[0] - 1)], lambda x: np.r_[x[0], np.zeros(x.size - 2)][None, :],
                          lambda x, v: [v[0] @ v[0]], m=1)
    bad = UserConstraint(good.C_fun, good.J_fun, lambda x, v: [-(v[0] @ v[0])], m=1)
    assert check_constraint(good, x2, v2).ok
    chk = check_constraint(bad, x2, v2)
    assert not chk.ok and chk.Jdot_error > 0.5 and chk.J_error < 1e-8


def test_user_constraint_in_a_scene_matches_the_built_in_kind():
    # the same circle written by hand (generic sparse assembly) and as OnCircle: same λ every step (B1)
    from pbanim.constraints import UserConstraint

    mod = bead_on_circle(theta0=1.0, omega0=1.0)
    user = UserConstraint(lambda x: [0.5 * (x[0] @ x[0] - 1)], lambda x: x[0][None, :], lambda x, v: [v[0] @ v[0]], m=1)
    a = Scene(mod.system, [Gravity(mod.g), Constraints([user])]).simulate(0.5, 1e-2, "rk4")
    b = Scene(mod.system, [Gravity(mod.g), Constraints(mod.constraints)]).simulate(0.5, 1e-2, "rk4")
    assert np.abs(a.y - b.y).max() < 1e-13 and np.abs(a.diagnostics["lam"] - b.diagnostics["lam"]).max() < 1e-12


def test_vectorized_jacobian_matches_per_constraint_assembly():
    # the set's J (patterns compiled once, values refilled per step) equals the stack of each kind's own J
    import scipy.sparse as sp

    mod = cloth_patch(5, 4, jitter=0.1)
    ps = mod.system
    cs = ConstraintSet(mod.constraints, ps.N, ps.dim, ps.W, ps.x0)
    x, v = ps.unpack(ps.state())
    asm = cs.assemble(x, v)
    J_ref = sp.vstack([c.jacobian(x) for c in mod.constraints]).toarray()
    assert np.array_equal(asm.J.toarray(), J_ref)
    A_ref = J_ref @ np.diag(cs.Wq) @ J_ref.T
    assert np.abs(cs.matrix(asm).toarray() - A_ref).max() <= 1e-14 * np.abs(A_ref).max()


# -- gains and engine conversions ------------------------------------------------------------------------
def test_box2d_hertz_is_the_oscillation_frequency_of_the_error():
    # Box2D (f = 2 Hz, ζ = 0): the error of a linear constraint oscillates with period 1/f = 0.5 s
    from pbanim.constraints import gains_from_box2d

    g = gains_from_box2d(2.0, 0.0)
    ps = ParticleSystem([[0.0, 0.01]], masses=1.0)
    eff = Constraints([OnPlane([0], [0.0, 0.0], [0.0, 1.0])], stabilization="baumgarte", ks=g.ks, kd=g.kd)
    res = Scene(ps, [eff]).simulate(1.2, 2e-3, "rk4")
    C = res.y[1]
    up = np.flatnonzero((C[:-1] < 0) & (C[1:] >= 0))
    t_cross = res.t[up] - C[up] * (res.t[up + 1] - res.t[up]) / (C[up + 1] - C[up])
    assert abs(np.mean(np.diff(t_cross)) - 0.5) < 1e-6  # measured ~1e-9


def test_mujoco_and_erp_conversions_follow_their_definitions():
    from pbanim.constraints import baumgarte_gains, gains_from_erp_cfm, gains_from_mujoco

    g = gains_from_mujoco(0.02, 0.5)  # ω = 1/(τζ) = 100 rad/s, k_d = 2ζω = 2/τ
    assert g.natural_frequency == pytest.approx(100.0) and g.damping_ratio == pytest.approx(0.5)
    # ERP/CFM: the slow mode Ċ = −(k_s/k_d)C stepped by implicit Euler removes the fraction ERP per step
    h, erp = 0.01, 0.2
    e = gains_from_erp_cfm(erp, 1e-9, h)
    assert 1 / (1 + h * e.ks / e.kd) == pytest.approx(1 - erp, rel=1e-6)
    assert baumgarte_gains(3.0, 0.5).kd == pytest.approx(3.0)
    with pytest.raises(ValueError, match=r"erp must be a finite number > 0 and < 1, got 1.5"):
        gains_from_erp_cfm(1.5, 0.1, h)
    with pytest.raises(ValueError, match=r"natural_frequency must be a finite number >= 0, got -3"):
        baumgarte_gains(-3.0)


# -- chapter 03 figures (their returned data) ----------------------------------------------------------
def test_figure_bead_tension(figure_data):
    d = figure_data("ch03_bead_tension")  # ORACLES B1
    assert d["rel_err_formula"] < 1e-10  # measured 3.6e-16
    assert d["rel_err_energy"] < 5e-8  # RK4 h = 2e-3 against 3mg cos θ; measured 4.9e-9, bound 5e-8
    assert abs(d["T_max"] / (3 * d["mg"]) - 1) < 1e-3  # sampled maximum ≈ 3mg


def test_figure_drift(figure_data):
    d = figure_data("ch03_drift")  # ORACLES B2
    assert d["max_projection"] < 1e-12
    assert d["final_baumgarte"] < d["final_none"]
    assert d["max_none"] > 1e3 * d["max_projection"]


def test_figure_baumgarte_stability(figure_data):
    d = figure_data("ch03_baumgarte_stability")  # ORACLES B2: eigenvalues predict the simulations
    for method in ("symplectic_euler", "rk4"):
        assert d[method]["agreement"] == 1.0
        assert np.all(d[method]["rho"][:, 0] < 1.0 + 1e-12)  # tiny ω_b h is stable for every ζ
    assert abs(d["symplectic_euler"]["limit_zeta1"] - (2 * np.sqrt(2) - 2)) < 1e-9


def test_figure_chain_tension(figure_data):
    d = figure_data("ch03_chain_tension")  # ORACLES B3
    for s in ("linear", "witkin-sparse", "kkt"):
        assert d[f"rel_err_{s}"] < 1e-8  # n = 200: measured 2.8e-10 (linear), 1.0e-9 (sparse), 8.9e-12 (kkt)


def test_figure_swinging_chain(figure_data):
    d = figure_data("ch03_swinging_chain")
    assert d["C_max"] < 1e-12 and d["solver"] == "linear"
    assert np.allclose(d["lengths_final"], d["link_length"], rtol=1e-10)
    assert d["energy_change"] < 1e-3  # projection never adds energy beyond RK4's error; measured < 0


def test_figure_cloth(figure_data):
    d = figure_data("ch03_cloth")
    assert d["C_max"] < 1e-12 and d["pin_shift"] < 1e-12
    assert d["z_min"] < -0.3  # it fell
    assert d["energy_change"] < 1e-3


def test_figure_solver_cost(figure_data):
    d = figure_data("ch03_solver_cost")
    costs = d["costs"]
    assert all(np.all(np.isfinite(costs[s])) for s in ("linear", "witkin-sparse", "kkt"))
    assert costs["linear"][-1] < costs["witkin-sparse"][-1]  # the O(n) solve beats the generic LU


def test_figure_work_precision(figure_data):
    rows = figure_data("ch03_work_precision")["rows"]
    assert all(r["drift"] < 1e-12 for r in rows if r["stabilization"] == "projection")
    none = sorted((r["h"], r["drift"]) for r in rows if r["method"] == "rk4" and r["stabilization"] == "none")
    assert none[0][1] < none[-1][1]  # smaller h, smaller drift


@pytest.mark.parametrize("method", ["rk4", "symplectic_euler"])
@pytest.mark.parametrize("stab,kw,lean", [("none", {}, True), ("baumgarte", {"natural_frequency": 30.0}, True),
                                          ("projection", {}, True), ("baumgarte", {"natural_frequency": 30.0}, False)])
def test_work_precision_drift_energy_are_the_diagnostics(method, stab, kw, lean):
    """ORACLES B10: the sweep's E series and max |C| equal the scene's diagnostics, bit for bit."""
    from pbanim.bench.constraints import _energy_and_drift
    from pbanim.constraints import Constraints
    from pbanim.models.constrained import hanging_chain
    from pbanim.particles.system import Gravity
    from pbanim.scene import Scene

    mod = hanging_chain(5, link_length=0.2, angle=np.pi / 2)
    eff = Constraints(mod.constraints, stabilization=stab, max_violation=1.0, **kw)
    eff.lean_path = lean
    scene = Scene(mod.system, [Gravity(mod.g), eff])
    res = scene.simulate(0.2, 0.01, method)
    E, drift = _energy_and_drift(scene, eff, res.y.T)
    assert drift > 0.0 if stab != "projection" else drift < 1e-12
    np.testing.assert_array_equal(E, res.diagnostics["energy"])
    assert drift == float(res.diagnostics["C_max"].max())


def test_bench_smoke():
    from pbanim.bench.constraints import run

    rep = run(quick=True)
    assert {g.id for g in rep.goals} >= {"constraints-linear-1e4", "constraints-linear-slope",
                                         "constraints-linear-vs-sparse-lu"}
    assert all(np.isfinite(g.measured) for g in rep.goals)


def test_readable_elimination_matches_the_linear_solver_with_zero_fill_on_trees():
    # Baraff 1996: leaves-first elimination of a tree's JWJᵀ creates no fill; a cloth (loops) does
    from pbanim.constraints import eliminate_readable

    for mod in (random_tree(60, np.random.default_rng(5)), hanging_chain(40, mass_ratio=10.0, angle=0.4)):
        ps = mod.system
        cs = ConstraintSet(mod.constraints, ps.N, ps.dim, ps.W, ps.x0)
        x, v = ps.unpack(ps.state())
        asm = cs.assemble(x, v)
        r = np.random.default_rng(0).normal(size=cs.m)
        ref = solve_multipliers(cs, ps, ps.state(), solver="linear")
        res = eliminate_readable(cs.matrix(asm), -asm.Jdv, cs.structure.order)
        assert res.fill == 0
        assert np.abs(res.lam - ref.lam).max() <= 1e-12 * np.abs(ref.lam).max()
        A = cs.matrix(asm).toarray()
        assert np.abs(A @ eliminate_readable(A, r, cs.structure.order).lam - r).max() < 1e-10 * np.abs(r).max() * np.abs(A).max()
    cloth = cloth_patch(4, 4)
    cs = ConstraintSet(cloth.constraints, cloth.system.N, 3, cloth.system.W, cloth.system.x0)
    x, v = cloth.system.unpack(cloth.system.state())
    assert eliminate_readable(cs.matrix(cs.assemble(x, v)), np.ones(cs.m), range(cs.m)).fill > 0


# -- issue 27: nothing silent (each input below was a silent wrong answer or a bare error) -----------------
def test_a_rod_from_a_particle_to_itself_is_refused():
    # was accepted: J = 0, and λ = 0 for a constraint C = −L²/2 that no motion can satisfy
    ps = ParticleSystem([[1.0, 0.0], [2.0, 0.5]])
    with pytest.raises(InvalidInput, match=r"Distance.__init__: pairs must be .*no index twice in a row.*row 0 is "
                                           r"\[0, 0\]"):
        solve_multipliers([Distance([[0, 0]], lengths=1.0)], ps, ps.state())
    with pytest.raises(InvalidInput, match=r"pairs .*row 1 is \[-1, -1\]"):
        Distance([[0, -1], [-1, -1]], anchors=[0.0, 0.0])


@pytest.mark.parametrize("solver", DIRECT + ["witkin-cg", "linear"])
@pytest.mark.parametrize("where", ["Q", "c", "W"])
def test_solve_lambda_refuses_nan_inputs_by_name(solver, where):
    # witkin-dense and kkt returned λ = 0 for a NaN force, the others λ = NaN; now the argument is named
    from pbanim.constraints import solve_lambda

    ps = ParticleSystem([[1.0, 0.0], [2.0, 0.5]], [[0.0, 0.3], [0.1, 0.0]], masses=[1.0, 2.0])
    cs = ConstraintSet([Distance([[0, -1], [0, 1]], anchors=[0.0, 0.0])], 2, 2, ps.W, ps.x0)
    asm = cs.assemble(*ps.unpack(ps.state()))
    args = {"Q": np.zeros(4), "c": -asm.Jdv, "W": cs.Wq.copy()}
    args[where] = args[where].copy()
    args[where][0] = np.nan
    with pytest.raises(InvalidInput, match=rf"solve_lambda: {where} must be .*it has NaN or inf entries"):
        solve_lambda(asm.J, args["W"], args["Q"], args["c"], solver, cset=cs, asm=asm)


@pytest.mark.parametrize("solver", SOLVERS)
def test_a_nan_force_inside_a_run_is_a_divergence_at_the_constraint_solve(solver):
    # a force that turns NaN after t = 0 reaches the multiplier solve unchecked (inside pbanim); witkin-sparse
    # and kkt answered λ = 0 there, the others NaN or a ConvergenceError: now SimulationDiverged with its time
    from pbanim.particles import UserForce

    ps = ParticleSystem([[1.0, 0.0], [2.0, 0.5]], masses=[1.0, 2.0])
    bad = UserForce(lambda t, x, v: np.full(x.shape, np.nan if t > 0.005 else 0.0))
    scene = Scene(ps, [bad, Constraints([Distance([[0, -1], [0, 1]], anchors=[0.0, 0.0])], solver=solver)])
    with pytest.raises(SimulationDiverged, match=r"t = 0.01.*state or applied force.*constraint solve"):
        scene.simulate(0.1, 0.01, "rk4")


def test_min_norm_and_readable_elimination_name_bad_matrices():
    from pbanim.constraints import eliminate_readable, min_norm_lambda

    with pytest.raises(InvalidInput, match=r"min_norm_lambda: A must be .*finite.*NaN or inf entries"):
        min_norm_lambda(np.full((2, 2), np.nan), np.ones(2))      # was λ = 0
    with pytest.raises(InvalidInput, match=r"eliminate_readable: A must be non-singular .*zero pivot at row 0"):
        eliminate_readable(np.zeros((1, 1)), np.ones(1), [0])      # was a bare KeyError
    with pytest.raises(InvalidInput, match=r"eliminate_readable: A must be .*NaN or inf entries"):
        eliminate_readable(np.array([[np.nan]]), np.ones(1), [0])  # was λ = NaN
    with pytest.raises(InvalidInput, match=r"order must be .*an index repeats"):
        eliminate_readable(np.eye(2), np.ones(2), [0, 0])


def test_kinds_refuse_a_nan_state_and_name_an_undefined_angle():
    from pbanim.constraints import Angle2D, check_constraint

    rod = Distance([[0, 1]], lengths=1.0)
    rod.bind(2, 2)
    x = np.array([[0.0, 0.0], [1.0, 0.0]])
    with pytest.raises(InvalidInput, match=r"Distance.evaluate: x must be .*NaN or inf entries"):
        rod.evaluate(x * np.nan, x)                                 # was C = NaN
    with pytest.raises(InvalidInput, match=r"x must be a float array of shape \(2, 2\).*a batch of states is not accepted"):
        rod.value(np.stack([x, x]))
    bend = Angle2D([[0, 1, 2]], 0.5)
    bend.bind(3, 2)
    with pytest.raises(InvalidInput, match=r"Angle2D.evaluate: x puts two particles of the angle \[0, 1, 2\]"):
        bend.evaluate(np.zeros((3, 2)), np.zeros((3, 2)))          # was J = NaN
    with pytest.raises(NonFiniteResult, match="check_constraint's finite differences"):
        check_constraint(rod, x, x, eps=1e300)                      # was J_error = NaN, "not ok"


def test_constraint_set_methods_refuse_an_assembly_of_another_set():
    mod = hanging_chain(3)
    ps = mod.system
    cs = ConstraintSet(mod.constraints, ps.N, ps.dim, ps.W, ps.x0)
    other = ConstraintSet([Distance([[0, 1]])], ps.N, ps.dim, ps.W, ps.x0)
    asm = other.assemble(*ps.unpack(ps.state()))
    with pytest.raises(InvalidInput, match=r"ConstraintSet.bands: asm must be an Assembly of this ConstraintSet.*"
                                           r"it has 1 rows and 6 columns, the set 3 and 6"):
        cs.bands(asm)                                               # was a bare IndexError
    with pytest.raises(InvalidInput, match=r"permuted_matrix: asm must be .*this set's structure is 'chain'"):
        cs.permuted_matrix(cs.assemble(*ps.unpack(ps.state())))    # was a bare AttributeError


# -- issue 28: the dense Witkin solve of a small set (the lean path of Constraints) -------------------------
@pytest.mark.parametrize("build, n, dim", [(random_chain, 1, 2), (random_chain, 4, 2), (random_chain, 5, 3),
                                           (random_tree, 6, 2), (random_tree, 4, 3), (bead_on_circle, None, 2)])
@pytest.mark.parametrize("seed", [0, 1, 2])
def test_dense_solve_equals_the_readable_solve(build, n, dim, seed):
    # ORACLES B5, A16: on a small set the effect solves Witkin's system on dense arrays bound once
    # (pbanim.constraints.dense); its Q_C and λ equal the readable solve's (sparse assembly, solve_lambda)
    # to 64 ε relative (measured ≤ 4 ε); several kinds at once (random trees: a fixed point and rods)
    rng = np.random.default_rng(seed)
    mod = bead_on_circle(radius=1.3, mass=2.0, theta0=0.4 + seed) if n is None else build(n, rng, dim=dim)
    ps = mod.system
    y = ps.state()
    Q = _gravity_Q(mod) + rng.normal(size=(ps.N, ps.dim))
    lean, readable = (Constraints(mod.constraints, stabilization="baumgarte", ks=9.0, kd=6.0) for _ in range(2))
    for e in (lean, readable):
        e.bind(ps)
    readable.lean_path = False
    assert lean._dense is not None
    QC_lean, QC_readable = lean.constrain(0.0, y, Q), readable.constrain(0.0, y, Q)
    scale = np.abs(QC_readable).max()
    assert np.abs(QC_lean - QC_readable).max() <= 64 * np.finfo(float).eps * scale
    a, b = lean.last, readable.last                    # the dense solve's record is built when read
    assert a.solver == "witkin-dense" and not a.rank_deficient
    assert np.abs(a.lam - b.lam).max() <= 64 * np.finfo(float).eps * np.abs(b.lam).max()
    assert np.abs(a.qdd - b.qdd).max() <= 64 * np.finfo(float).eps * np.abs(b.qdd).max()
    assert a.residual <= 1e-12


@pytest.mark.parametrize("build", [redundant_rod, redundant_xy])
def test_dense_solve_leaves_dependent_rows_to_the_readable_path(build):
    # ORACLES B4: a vanishing pivot (dependent rows) returns None from the dense solve; the effect then
    # gives the readable minimum-norm answer, flagged rank deficient
    from pbanim.constraints.dense import DenseWitkin

    mod = build()
    ps = mod.system
    eff = Constraints(mod.constraints)
    eff.bind(ps)
    x, v = ps.unpack(ps.state())
    Q = _gravity_Q(mod)
    assert DenseWitkin(eff.cset).solve(x, v, Q.reshape(-1), 0.0, 0.0) is None
    eff.constrain(0.0, ps.state(), Q)
    assert eff.last.rank_deficient
