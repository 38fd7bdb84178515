"""pbanim.scene with particle systems: the pipeline, undeclared stages, the lean step, the Jacobian path.

Each test names what it checks (and its oracle in ORACLES.md where there is one).
"""

import numpy as np
import pytest

from pbanim.ode import get_method
from pbanim.particles import AnchorSprings, DampedSprings, Drag, Gravity, ParticleSystem, UserForce
from pbanim.particles.springs import DampedSprings as _Springs
from pbanim.results import SimResult
from pbanim.scene import Scene
from pbanim.testing import check_grad


def cloud(N=50, dim=3, seed=0):
    rng = np.random.default_rng(seed)
    return ParticleSystem(rng.normal(size=(N, dim)), rng.normal(size=(N, dim)), rng.uniform(0.5, 2.0, N))


def chain_springs(N):
    return DampedSprings(np.stack([np.arange(N - 1), np.arange(1, N)], 1), stiffness=50.0, damping=0.2)


def test_pipeline_order_follows_declaration():
    # force effects in declaration order, then integrate
    ps = cloud(5)
    assert Scene(ps, [Drag(0.1), chain_springs(5), Gravity()]).pipeline == ("drag", "springs", "gravity", "integrate")
    assert Scene(ps, []).pipeline == ("integrate",)


@pytest.mark.parametrize("method", ["symplectic_euler", "rk4", "euler"])
def test_undeclared_springs_are_never_called(monkeypatch, method):
    # DESIGN 2: a stage not declared is never called; a scene without springs never touches spring code
    def boom(*args, **kwargs):
        raise AssertionError("spring code called in a scene that declares no springs")

    for attr in ("apply", "spring_forces", "jacobian", "potential_energy", "diagnostics", "_geometry", "bind"):
        monkeypatch.setattr(_Springs, attr, boom)
    ps = cloud(10)
    scene = Scene(ps, [Gravity(), Drag(0.2)])
    res = scene.simulate(0.05, 0.01, method)
    assert res.success and "V_springs" not in res.diagnostics
    scene.step(0.0, ps.state(), 0.01)
    scene.jac(0.0, ps.state())
    # and the monkeypatch is live: declaring springs does reach the patched code
    with pytest.raises(AssertionError, match="spring code called"):
        Scene(ps, [chain_springs(10)])


def test_simulate_returns_simresult_with_per_step_diagnostics():
    # SimResult fields aligned with t: energies of each conservative force, momenta; energy = T + sum V
    ps = cloud(8)
    scene = Scene(ps, [Gravity(), chain_springs(8), Drag(0.05)])
    res = scene.simulate(0.2, 0.01, "rk4", record_every=5)
    assert isinstance(res, SimResult) and res.success and res.method == "rk4" and res.nsteps == 20
    assert res.t.shape == (5,) and res.y.shape == (2 * ps.split, 5)
    for key in ("kinetic", "potential", "energy", "momentum", "angular_momentum", "V_gravity", "V_springs"):
        assert len(res.diagnostics[key]) == 5, key
    d = res.diagnostics
    assert np.allclose(d["energy"], d["kinetic"] + d["V_gravity"] + d["V_springs"], rtol=1e-14, atol=1e-14)
    assert res.nfev == 4 * 20  # rk4: four force evaluations per step
    # drag only dissipates: with drag the total energy decreases (RK4 error is far below the loss)
    assert np.all(np.diff(d["energy"]) < 0)


@pytest.mark.parametrize("effects, fold", [("affine", True), ("affine", False), ("springs", True)])
def test_lean_step_equals_generic_symplectic_euler(effects, fold):
    # Scene.step's lean path (one force evaluation, preallocated buffers; gravity + drag folded into
    # v1 = alpha v0 + beta and swept in blocks) computes the same state as pbanim.ode's symplectic Euler
    # on scene.rhs, to roundoff (measured <= 0.52 ulp of the largest component, bound 4 ulp)
    N = 1000
    ps = cloud(N)
    eff = [Gravity(), Drag(np.linspace(0.1, 1.0, N))] + ([chain_springs(N)] if effects == "springs" else [])
    scene = Scene(ps, eff)
    scene.fold_affine = fold
    scene._BLOCK = 128  # several blocks (and a ragged last one)
    y = ps.state()
    h = 1e-3
    lean = scene.step(0.0, y, h)
    generic = get_method("symplectic_euler").step(scene.rhs, 0.0, y, h, split=ps.split)
    assert scene._affine == (effects == "affine")
    assert np.abs(lean - generic).max() <= 4 * np.finfo(float).eps * np.abs(generic).max()
    assert np.array_equal(y, ps.state())  # the input state is not modified
    # many steps through simulate (lean) and through the generic step agree too
    res = scene.simulate(0.05, h)
    yg = y.copy()
    for k in range(50):
        yg = get_method("symplectic_euler").step(scene.rhs, k * h, yg, h, split=ps.split)
    assert np.abs(res.y[:, -1] - yg).max() < 1e-12 * np.abs(yg).max()
    # a new step size refolds alpha, beta
    assert np.abs(scene.step(0.0, y, 2 * h)
                  - get_method("symplectic_euler").step(scene.rhs, 0.0, y, 2 * h, split=ps.split)).max() \
        <= 4 * np.finfo(float).eps * np.abs(generic).max()


def test_scene_jac_assembles_state_jacobian():
    # [[0, I], [W dQ/dx, W dQ/dv]] equals centred finite differences of scene.rhs (gravity, drag, springs)
    ps = cloud(7, dim=2)
    scene = Scene(ps, [Gravity(), Drag(0.3), chain_springs(7)])
    y = ps.state()
    J = scene.jac(0.0, y)
    n = ps.split
    assert (J[:n, :n].nnz == 0) and np.array_equal(J[:n, n:].toarray(), np.eye(n))
    check_grad(lambda yy: scene.rhs(0.0, yy), y, J, rtol=1e-6, atol=1e-7)  # measured max abs diff 1.3e-8


def test_scene_jac_rejects_effect_without_jacobian():
    # a user force without a Jacobian: no analytic Jacobian, named in the error (implicit methods use FD)
    ps = cloud(3)
    scene = Scene(ps, [Gravity(), UserForce(lambda t, x, v: -x, name="pull")])
    assert not scene.has_jacobian
    with pytest.raises(ValueError, match=r"scene has no analytic Jacobian: effects \['pull'\] provide none"):
        scene.jac(0.0, ps.state())


def test_implicit_method_receives_the_analytic_jacobian():
    # simulate() hands Scene.jac to implicit methods (njev counts its calls); without it they use FD
    ps = cloud(6)
    with_jac = Scene(ps, [Gravity(), chain_springs(6)]).simulate(0.05, 0.01, "implicit_euler")
    no_jac = Scene(ps, [Gravity(), chain_springs(6), UserForce(lambda t, x, v: 0.0 * x)]).simulate(
        0.05, 0.01, "implicit_euler")
    assert with_jac.njev >= 5 and no_jac.njev == 0
    # both solve the same equations: same answer to the Newton tolerance (measured 2.2e-16, bound 1e-12)
    assert np.abs(with_jac.y[:, -1] - no_jac.y[:, -1]).max() < 1e-12


def test_potential_energy_skips_effects_without_potential():
    # drag has no potential; a user force without one is not counted; with one it is
    ps = ParticleSystem([[0.0, 2.0]], masses=1.0)
    s1 = Scene(ps, [Gravity([0.0, -10.0]), Drag(0.1), UserForce(lambda t, x, v: 0 * x)])
    assert s1.potential_energy(ps.state()) == pytest.approx(20.0)  # V = -m g.x = 20 J
    s2 = Scene(ps, [UserForce(lambda t, x, v: 0 * x, potential=lambda x: 7.0)])
    assert s2.potential_energy(ps.state()) == 7.0


def test_simulate_rejects_bad_arguments():
    # bad input -> ValueError naming the argument (DESIGN 2, errors)
    ps = cloud(3)
    scene = Scene(ps, [Gravity()])
    with pytest.raises(ValueError, match=r"y0 must be a float array of shape \(18,\) .* got an array of shape \(17,\)"):
        scene.simulate(0.1, 0.01, y0=np.zeros(17))
    with pytest.raises(ValueError, match="t_end must be a finite time after t0 = 0.0, got -1.0"):
        scene.simulate(-1.0, 0.01)
    with pytest.raises(ValueError, match="record_every must be a positive integer, got 0"):
        scene.simulate(0.1, 0.01, record_every=0)
    with pytest.raises(ValueError, match="method must be one of .* got 'leapfrog-ish'"):
        scene.simulate(0.1, 0.01, method="leapfrog-ish")


def test_symplectic_euler_evaluates_forces_once_and_matches_the_generic_step():
    # symplectic Euler's drift q₁ = q₀ + h q̇(q₀, v₁) needs no forces: a scene takes q̇ from the force-free
    # derivative, one force evaluation per step, and reproduces the generic two-evaluation step bit for bit
    # (rigid bodies: q̇ = (P/m, ½ω⊗q) depends on P, L and q only).  measured 0 difference
    from pbanim.rigid import RigidBodies, RigidGravity, RigidScene, RigidSprings

    rng = np.random.default_rng(3)
    rb = RigidBodies([1.0, 2.0], [[1.0, 2.0, 3.0], [2.0, 2.5, 1.0]], positions=rng.normal(size=(2, 3)),
                     orientations=rng.normal(size=(2, 4)), velocities=rng.normal(size=(2, 3)),
                     angular_velocities=rng.normal(size=(2, 3)))
    springs = RigidSprings([0], [[0.1, 0, 0]], [1], [[0, 0.2, 0]], 40.0, 0.5)
    scene = RigidScene(rb, [RigidGravity(), springs], quaternions="none")
    res = scene.simulate(0.2, 1e-2)
    assert res.nfev == res.nsteps == 20
    step = get_method("symplectic_euler").step
    y = rb.state()
    for k in range(20):
        y = step(scene.rhs, k * 1e-2, y, 1e-2, split=rb.split)
    np.testing.assert_array_equal(res.y[:, -1], y)
    springs.drift_free = False               # an effect that must see the drift evaluation: the generic step
    generic = RigidScene(rb, [RigidGravity(), springs], quaternions="none").simulate(0.2, 1e-2)
    assert generic.nfev == 2 * generic.nsteps
    np.testing.assert_array_equal(generic.y, res.y)


def test_diagnostics_are_computed_when_read_and_equal_those_of_the_run():
    # issue 28 point 2: by default a run computes no diagnostics at its steps; reading result.diagnostics
    # computes them from the recorded states, equal to those computed during a run that asked for them
    from pbanim.results import LazyDiagnostics

    ps = cloud(4)
    scene = Scene(ps, [Gravity(), DampedSprings([[0, 1], [1, 2], [2, 3]], 30.0, 0.2)])
    calls = [0]
    original = scene.diagnostics

    def counting(t, y):
        calls[0] += 1
        return original(t, y)

    scene.diagnostics = counting
    lazy = scene.simulate(0.2, 0.01, "rk4")
    assert isinstance(lazy.diagnostics, LazyDiagnostics) and not lazy.diagnostics.computed and calls[0] == 0
    eager = scene.simulate(0.2, 0.01, "rk4", diagnostics=True)
    assert calls[0] == 21                                   # the recorded times: 20 steps and the start
    assert set(lazy.diagnostics) == set(eager.diagnostics)  # reading computes them, once
    assert calls[0] == 42 and lazy.diagnostics.computed
    for k in eager.diagnostics:
        np.testing.assert_array_equal(lazy.diagnostics[k], eager.diagnostics[k])
    assert scene.simulate(0.2, 0.01, "rk4", diagnostics=False).diagnostics == {}


# --- issue 28: the plans compute the readable step (ORACLES A16) ------------------------------------------
def _linear_scene():
    # three particles under gravity, drag and two anchor springs: every force linear, 12 state components
    rng = np.random.default_rng(1)
    ps = ParticleSystem(rng.normal(size=(3, 2)), rng.normal(size=(3, 2)), masses=[1.0, 2.0, 0.5])
    return Scene(ps, [Gravity([0.0, -9.81]), Drag(0.3), AnchorSprings([0, 2], [[0.0, 0.0], [1.0, 1.0]], 20.0, 0.4)])


def _springs_scene():
    # four particles, five damped springs and gravity: not linear, the bound-f plan
    rng = np.random.default_rng(2)
    ps = ParticleSystem(rng.normal(size=(4, 2)), rng.normal(size=(4, 2)), masses=[1.0, 2.0, 0.5, 1.5])
    return Scene(ps, [Gravity([0.0, -9.81]), DampedSprings([[0, 1], [1, 2], [2, 3], [3, 0], [0, 2]], 50.0, 0.5)])


def _chain_scene():
    # three particles on three rods from the origin, Baumgarte feedback: the dense Witkin solve
    from pbanim.constraints import Constraints, Distance

    u = np.array([np.sin(1.0), -np.cos(1.0)])
    pairs = np.array([[0, -1], [1, 0], [2, 1]])
    eff = Constraints([Distance(pairs, anchors=[0.0, 0.0])], stabilization="baumgarte", ks=100.0, kd=20.0)
    ps = ParticleSystem(0.5 * np.arange(1, 4)[:, None] * u, np.zeros((3, 2)), [1.0, 1.5, 2.0])
    return Scene(ps, [Gravity([0.0, -9.81]), eff])


def _final(make, method, lean, n=1000, h=1e-3, **kw):
    scene = make()
    scene.lean_path = lean
    for e in scene.effects:
        if hasattr(e, "lean_path"):
            e.lean_path = lean
    res = scene.simulate(n * h, h, method, diagnostics=False, **kw)
    return res


@pytest.mark.parametrize("make, method, plan", [
    (_linear_scene, "euler", "linear"), (_linear_scene, "midpoint", "linear"), (_linear_scene, "rk4", "linear"),
    # the structure-preserving methods keep their own kick and drift on a linear scene (not S y + s)
    (_linear_scene, "symplectic_euler", "floats"), (_linear_scene, "verlet", "f"),
    (_linear_scene, "dopri5", "linear"),
    (_springs_scene, "rk4", "f"), (_springs_scene, "symplectic_euler", "floats"), (_springs_scene, "midpoint", "f"),
    (_chain_scene, "rk4", "f"), (_chain_scene, "symplectic_euler", "f")])
def test_every_plan_equals_the_readable_step_to_roundoff(make, method, plan):
    # ORACLES A16: 1000 steps of the plan a run picks (linear map y₁ = S y + s; f bound once; the dense
    # Witkin solve) end within 2 ulp × n of the largest component of the readable run's final state
    # (scene.lean_path = False, effect.lean_path = False). Measured: linear map ≤ 0.15 ulp × n (RK4), bound f
    # 0 (bit for bit), dense constraints ≤ 0.007 ulp × n. The plan is the one announced: the linear map
    # evaluates f only to build S and s (nfev = the method's stages, once), the others at every stage.
    n = 1000
    lean, readable = _final(make, method, True, n), _final(make, method, False, n)
    per = get_method(method).step.nfev
    assert readable.nfev in (n * per, n * (per - 1))    # symplectic Euler: one evaluation when drift-free
    assert lean.nfev == (per if plan == "linear" else readable.nfev)
    ref = readable.y[:, -1]
    assert np.abs(lean.y[:, -1] - ref).max() <= 2 * n * np.finfo(float).eps * np.abs(ref).max()
    assert np.abs(lean.y - readable.y).max() > 0 or plan != "linear"    # the linear map is another sum


@pytest.mark.parametrize("make", [_linear_scene, _springs_scene, _chain_scene])
def test_step_takes_the_plan_of_simulate(make):
    # Scene.step binds the same plan once per method: n calls of step give simulate's states, bit for bit
    scene = make()
    y, h = scene.system.state(), 1e-3
    res = scene.simulate(20 * h, h, "rk4", diagnostics=False)
    for k in range(20):
        y = scene.step(k * h, y, h, "rk4")
    np.testing.assert_array_equal(y, res.y[:, -1])


@pytest.mark.parametrize("diagnostics", [False, "lazy", True])
def test_simulate_honours_record_every_into_one_array(diagnostics):
    # the recorded times are t0 + k h for k = 0, r, 2r, … and t_end; the states are those of a run recording
    # every step, at those times, bit for bit (the same steps); diagnostics only at the recorded times
    scene = _springs_scene()
    every = scene.simulate(0.1, 3e-3, "rk4", diagnostics=False)                 # 34 steps, the last shortened
    sparse = scene.simulate(0.1, 3e-3, "rk4", record_every=5, diagnostics=diagnostics)
    assert every.nsteps == sparse.nsteps == 34
    keep = list(range(0, 34, 5)) + [34]
    np.testing.assert_array_equal(sparse.t, every.t[keep])
    np.testing.assert_array_equal(sparse.y, every.y[:, keep])
    assert sparse.y.flags.c_contiguous or sparse.y.T.flags.c_contiguous
    if diagnostics:
        assert len(sparse.diagnostics["energy"]) == len(keep)


def test_floor_rows_of_chapters_01_to_03_are_equal_work():
    # pbanim bench floors: each row's hand-written loop computes what pbanim's run computes (the same
    # method on the same equations from the same start): final states within the row's tolerance
    from pbanim.bench import _floor_constraints, _floor_particles

    for make in _floor_particles.FLOORS + _floor_constraints.FLOORS:
        fl = make()
        a, b = np.asarray(fl.pbanim(), float), np.asarray(fl.hand(), float)
        assert a.shape == b.shape
        assert np.abs(a - b).max() / max(1.0, np.abs(b).max()) <= fl.tol, fl.scene


def test_a_scene_that_overrides_its_rhs_keeps_it():
    # a subclass with its own rhs (or forces, applied_forces, jac) is stepped on that rhs, never on the linear
    # map built from the effects' Jacobians: here rhs is doubled, and the run follows the doubled f
    class Doubled(Scene):
        def rhs(self, t, y):
            return 2.0 * super().rhs(t, y)

    scene = Doubled(_linear_scene().system, _linear_scene().effects)
    res = scene.simulate(0.05, 1e-3, "rk4", diagnostics=False)
    assert res.nfev == 4 * 50
    y = scene.system.state()
    for k in range(50):
        y = get_method("rk4").step(scene.rhs, k * 1e-3, y, 1e-3)
    np.testing.assert_array_equal(res.y[:, -1], y)


@pytest.mark.parametrize("method", ["rk4", "symplectic_euler"])
def test_a_diverging_plan_names_the_step_the_readable_run_names(method):
    # springs far too stiff for h blow up: the plan that checks its stored states once per block (its forces
    # cannot raise on a non-finite state) names the same first bad step as the readable run checking each step
    from pbanim.errors import SimulationDiverged

    def run(lean):
        scene = _springs_scene()
        scene.effects[1].ks = scene.effects[1].ks * 1e7
        scene.lean_path = lean
        with pytest.raises(SimulationDiverged) as exc:
            scene.simulate(5.0, 1e-2, method, diagnostics=False)
        return exc.value.step, exc.value.t

    assert run(True) == run(False)


def test_a_user_subclass_of_a_linear_force_runs_the_apply_it_wrote():
    """The plans that replace apply by a precomputed form (the linear map, the affine fold, gravity summed once)
    trust only the package's own code: a subclass written outside pbanim (as a course assignment's copy is)
    runs its own apply. Free fall under the doubled force, exact for RK4 and symplectic Euler's closed form
    (ORACLES A8)."""
    from pbanim.contracts import package_code, package_code_cached
    from pbanim.particles import Gravity, ParticleSystem

    class Doubled(Gravity):
        def apply(self, t, y, Q):
            super().apply(t, y, Q)
            super().apply(t, y, Q)

    assert package_code(Gravity([0.0, -10.0]), "apply", "affine") and not package_code(Doubled([0.0, -10.0]), "apply")
    for _ in range(2):      # the per-class cache answers what package_code answers, first call and later
        assert package_code_cached(Gravity([0.0, -10.0]), "apply", "affine")
        assert not package_code_cached(Doubled([0.0, -10.0]), "apply")
    ps = ParticleSystem([[0.0, 0.0]], [[1.0, 0.0]], masses=2.0)
    for method in ("rk4", "symplectic_euler"):
        res = Scene(ps, [Doubled([0.0, -10.0])]).simulate(1.0, 0.01, method)
        n, h = 100, 0.01
        # RK4: x = ½ a t²; symplectic Euler: x_n = ½ a h² n (n + 1)
        expected = -10.0 if method == "rk4" else -0.5 * 20.0 * h * h * n * (n + 1)
        assert abs(res.y[1, -1] - expected) <= 1e-12 * abs(expected), (method, res.y[1, -1], expected)


# --- issue 28: the float plan of a small particle scene (pbanim.particles.lean; ORACLES A16, A1) -------------
def _one_spring():
    # the floor row: one particle on an anchor spring (2-D), a 0.5 kg mass, k = 20 N/m
    return Scene(ParticleSystem([[1.0, 0.0]], [[0.0, 0.5]], masses=0.5), [AnchorSprings([0], [[0.0, 0.0]], 20.0)])


def _damped_pair():
    # the floor row: two particles on one damped spring (2-D)
    ps = ParticleSystem([[0.0, 0.0], [1.2, 0.0]], [[0.0, 0.3], [0.0, -0.6]], [1.0, 0.5])
    return Scene(ps, [DampedSprings([[0, 1]], 50.0, 0.5, rest_length=1.0)])


def _net_3d():
    # six particles in 3-D: drag, a damped net (particles on up to three springs), gravity last, one anchor
    rng = np.random.default_rng(3)
    ps = ParticleSystem(rng.normal(size=(6, 3)), rng.normal(size=(6, 3)), rng.uniform(0.5, 2.0, 6))
    pairs = [[0, 1], [1, 2], [2, 3], [3, 4], [4, 5], [5, 0], [0, 3], [1, 4]]
    return Scene(ps, [Drag(np.linspace(0.1, 0.6, 6)), DampedSprings(pairs, 40.0, 0.3),
                      AnchorSprings([2], None, 15.0, 0.2), Gravity()])


@pytest.mark.parametrize("make, exact", [(_one_spring, True), (_damped_pair, True), (_linear_scene, True),
                                         (_springs_scene, False), (_net_3d, False)])
def test_the_float_plan_computes_the_readable_symplectic_euler_step(make, exact):
    # ORACLES A16: a small particle scene under symplectic Euler steps on floats (plan "floats"), the readable
    # kick and drift operation for operation: 1000 steps end within 2 ulp × n of the largest component of the
    # readable run (scene.lean_path = False), and bit for bit where no particle has two springs (the same
    # roundings in the same order). Where one has, its spring forces are summed in the order of the springs,
    # the readable path's by the incidence product (another order of the same terms, whatever the BLAS does):
    # measured 0 here too. One evaluation of f per step on both paths.
    scene = make()
    plan = scene._advance(get_method("symplectic_euler"), [0, 0])
    assert getattr(plan, "plan", None) == "floats"
    n = 1000
    lean, readable = _final(make, "symplectic_euler", True, n), _final(make, "symplectic_euler", False, n)
    assert lean.nfev == readable.nfev == n
    ref = readable.y[:, -1]
    assert np.abs(lean.y[:, -1] - ref).max() <= 2 * n * np.finfo(float).eps * np.abs(ref).max()
    if exact:
        np.testing.assert_array_equal(lean.y, readable.y)
    # Scene.step takes the same plan: n calls give simulate's states, bit for bit
    s, y = make(), make().system.state()
    for k in range(20):
        y = s.step(k * 1e-3, y, 1e-3)
    np.testing.assert_array_equal(y, _final(make, "symplectic_euler", True, 20).y[:, -1])


def test_the_float_plan_keeps_the_modified_energy_of_symplectic_euler():
    # ORACLES A1: on one particle on an anchor spring symplectic Euler keeps H̃ = ½m|v|² + ½k|x|² − ½hk x·v
    # exactly; the float plan's states keep it to roundoff over 2000 steps (measured 2.4e-15 relative, bound
    # 5e-15, as the course's check)
    m, k, h = 0.5, 20.0, 1e-2
    scene = _one_spring()
    res = scene.simulate(2000 * h, h, "symplectic_euler", diagnostics=False)
    x, v = res.y[:2], res.y[2:]
    Ht = 0.5 * m * (v * v).sum(0) + 0.5 * k * (x * x).sum(0) - 0.5 * h * k * (x * v).sum(0)
    assert np.abs(Ht / Ht[0] - 1).max() < 5e-15


def test_a_user_subclass_or_a_large_scene_does_not_take_the_float_plan():
    # the float plan writes the package's own forces out on floats: a subclass of AnchorSprings (its own apply:
    # the stiffness doubled) runs the apply it wrote, and its run keeps H̃ of the doubled spring (ORACLES A1),
    # which the float arithmetic of the package's spring would not; a scene past FLOAT_MAX, a Scene subclass
    # with its own rhs and a constrained scene take other plans
    from pbanim.particles.lean import FLOAT_MAX, float_plan

    class Doubled(AnchorSprings):
        def apply(self, t, y, Q):
            super().apply(t, y, Q)
            super().apply(t, y, Q)

    m, k, h = 0.5, 20.0, 1e-2
    ps = ParticleSystem([[1.0, 0.0]], [[0.0, 0.5]], masses=m)
    scene = Scene(ps, [Doubled([0], [[0.0, 0.0]], k)])
    assert scene._floats is None and float_plan(_one_spring()) is not None
    res = scene.simulate(200 * h, h, "symplectic_euler", diagnostics=False)
    x, v = res.y[:2], res.y[2:]
    Ht = 0.5 * m * (v * v).sum(0) + k * (x * x).sum(0) - h * k * (x * v).sum(0)
    assert np.abs(Ht / Ht[0] - 1).max() < 5e-15
    big = ParticleSystem(np.zeros((FLOAT_MAX // 2 + 1, 2)))
    assert Scene(big, [Gravity()])._floats is None and Scene(ParticleSystem(np.zeros((FLOAT_MAX // 2, 2))),
                                                              [Gravity()])._floats is not None

    class Doubled2(Scene):
        def rhs(self, t, y):
            return 2.0 * super().rhs(t, y)

    s2 = Doubled2(_one_spring().system, _one_spring().effects)
    assert getattr(s2._advance(get_method("symplectic_euler"), [0, 0]), "plan", None) is None
    assert _chain_scene()._floats is None


def test_a_spring_of_zero_or_overflowing_length_hands_its_step_to_the_readable_one():
    # coincident ends (no direction) and ends 1.6e154 apart (|d|² overflows, |y|² not): the float step hands it to
    # the readable one, which has the rule for both (no force; the scaled length): the states equal the
    # readable run's bit for bit, finite, one evaluation per step (ORACLES A16)
    def make(x):
        ps = ParticleSystem(x, [[1.0, 0.0], [0.0, 0.0]])
        return Scene(ps, [DampedSprings([[0, 1]], 3.0, 1.0, rest_length=0.5)])

    for x in ([[0.5, 0.5], [0.5, 0.5]], [[8e153, 0.0], [-8e153, 0.0]]):
        lean, readable = make(x), make(x)
        readable.lean_path = False
        a = lean.simulate(0.01, 1e-3, "symplectic_euler", diagnostics=False)
        b = readable.simulate(0.01, 1e-3, "symplectic_euler", diagnostics=False)
        assert lean._floats is not None and a.nfev == b.nfev == 10
        assert np.isfinite(a.y).all()
        np.testing.assert_array_equal(a.y, b.y)
