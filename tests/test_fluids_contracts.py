"""Chapter 09 under its contracts (issue 27): one test per defect the contract fuzz and its edge values found in
pbanim.fluids (each failed before its fix), and the behaviour the contracts changed.
"""

import warnings

import numpy as np
import pytest

from pbanim.errors import ConvergenceError, InvalidInput, NonFiniteResult, SimulationDiverged
from pbanim.fluids import (Advection, Buoyancy, Diffusion, FluidScene, Grid, Projection, Source, StamSolver,
                           VorticityConfinement, advect_scalar, centreline_u, collocated_divergence,
                           confinement_force, diffuse_scalar, diffuse_velocity, lid_driven_cavity, sample,
                           semi_lagrangian_loop, solve_cells, stream_velocity, taylor_green_energy)
from pbanim.fluids.interpolate import pad_field
from pbanim.fluids.specs import MAX_CELLS

RNG = np.random.default_rng(27)


def _walls(lid=False):
    return Grid((8, 8), 1 / 8, "walls", lids={"y+": (1.0, 0.0)} if lid else None)


def _velocity(g, scale=1.0):
    return g.close([scale * RNG.standard_normal(g.face_shape(i)) for i in range(g.dim)])


# -- Krylov solves of huge fields ------------------------------------------------------------------------
@pytest.mark.parametrize("method", ["cg", "pcg", "mgpcg", "multigrid"])
def test_krylov_solves_of_fields_near_1e300_meet_their_tolerance(method):
    # ORACLES E2: CG meets ‖r‖₂ ≤ tol ‖b‖₂ whatever the scale of b; its inner products of 1e300 entries used
    # to overflow to inf ≤ inf, and it returned the start x = 0 (relative residual 1)
    g = _walls()
    b = 1e300 * RNG.standard_normal(g.shape)
    x, info = solve_cells(g, b, 0.0, 1.0, method, tol=1e-12)
    r = b - b.mean()                                    # the solvable part (α = 0 drops the mean)
    assert np.abs(r + g.laplacian(x)).max() <= 1e-11 * np.abs(r).max()
    assert info.iterations > 0 and np.isfinite(info.residual)


def test_a_cg_projection_of_a_huge_field_is_the_projection_scaled():
    # ORACLES E2 (Π linear, D Π u = roundoff): projecting 1e300 u by CG gives 1e300 times the projection of u
    # (it left u unprojected: ‖D u‖∞ stayed 4e301)
    g = _walls()
    u = _velocity(g)
    small = FluidScene(g, [Projection("dct")], u=u)
    small.step(0.1)
    big = FluidScene(g, [Projection("cg")], u=[1e300 * c for c in u])
    big.step(0.1)
    for a, b in zip(small.state.u, big.state.u):
        np.testing.assert_allclose(b, 1e300 * a, rtol=0, atol=1e-10 * 1e300)
    assert np.abs(g.divergence(big.state.u)).max() <= 1e-10 * 1e300


def test_convergence_error_reports_the_relative_residual_it_names():
    # the message says "relative 2-norm residual"; the number was ‖r − Ax‖₂ itself (2.3 for b, 2.3e6 for 1e6 b)
    g = Grid((32, 32), 1 / 32, "walls")
    b = RNG.standard_normal(g.shape)
    res = []
    for scale in (1.0, 1e6):
        with pytest.raises(ConvergenceError, match="relative 2-norm residual") as err:
            solve_cells(g, scale * b, 0.0, 1.0, "cg", max_iter=3)
        res.append(err.value.residual)
    assert 0 < res[0] < 1 and res[1] == pytest.approx(res[0], rel=1e-12)


def test_a_huge_viscosity_reaches_the_steady_lid_profile():
    # ORACLES E10 (the lid's steady solution of the heat equation): with νΔt = 1e300, CG started from the field
    # (A u⁰ is 1e302 times larger than u⁰) and ended in ConvergenceError with residual inf; it now starts
    # from 0 when that is the better start, and agrees with a merely large νΔt
    g = _walls(lid=True)
    u = _velocity(g)
    huge, _ = diffuse_velocity(g, u, 1e300, 1.0, "cg", tol=1e-8)
    large, _ = diffuse_velocity(g, u, 1e6, 1.0, "cg", tol=1e-12)
    for a, b in zip(huge, large):
        np.testing.assert_allclose(a, b, atol=1e-5)
    assert huge[0].max() > 0.5                     # the lid drags the top row: not the zero of a lost solve


def test_an_overflowing_diffusion_coefficient_is_named():
    # ν h = 1e600: Gauss–Seidel returned NaN, CG a ConvergenceError with residual nan, the DCT an InvalidInput
    # about an internal 'beta'; Stam's step a ConvergenceError
    g = _walls()
    u = _velocity(g)
    with pytest.raises(NonFiniteResult, match=r"nu·h .*nu = 1e\+300, h = 1e\+300"):
        diffuse_velocity(g, u, 1e300, 1e300, "gauss_seidel")
    with pytest.raises(NonFiniteResult, match="kappa·h"):
        diffuse_scalar(g, RNG.random(g.shape), 1e300, 1e300, "dct")
    stam = StamSolver(g, [RNG.random(g.shape) for _ in range(2)], viscosity=1e300, diffusion="cg")
    with pytest.raises(SimulationDiverged, match="diffusion coefficient viscosity·h"):
        stam.step(1e300)
    with pytest.raises(NonFiniteResult, match=r"ν = lid / reynolds"):
        lid_driven_cavity(8, 1e-300, 1e300)          # was InvalidInput about a 'viscosity' never passed


# -- overflows met inside a step, and certified results -------------------------------------------------
@pytest.mark.parametrize("dim", [2, 3])
def test_the_confinement_force_is_linear_in_a_velocity_near_1e160(dim):
    # ORACLES E16 (f = εΔx N × ω, N unit: f linear in u): |∇|ω||² overflowed, N became 0 (2-D) or NaN (3-D)
    g = Grid((6,) * dim, 1 / 6, "walls")
    u = _velocity(g)
    f1, n1 = confinement_force(g, u, 1.0)
    f2, n2 = confinement_force(g, [1e160 * c for c in u], 1.0)
    for a, b in zip(f1, f2):
        np.testing.assert_allclose(b, 1e160 * a, rtol=1e-12, atol=1e-12 * 1e160 * max(np.abs(f1).max(), 1e-300))
    for a, b in zip(n1, n2):
        np.testing.assert_allclose(b, a, atol=1e-12)


def _smoke_scene():
    g = _walls(lid=True)
    x, y = g.positions()
    blob = np.exp(-20.0 * ((x - 0.5) ** 2 + (y - 0.3) ** 2))
    effects = [Source("density", 1.0, blob), Buoyancy(), VorticityConfinement(0.5), Advection(),
               Diffusion(0.01, diffusivity={"density": 0.01}), Projection("dct")]
    return FluidScene(g, effects, u=_velocity(g, 0.5), scalars={"density": blob, "temperature": 0.5 * blob})


def test_a_step_that_overflows_names_the_field():
    # h = 1e300: the buoyancy gives |u| ≈ 1e300 and the confinement force overflows u; the step returned a
    # finite state (the force was dropped) or, with the confinement fixed, a bare IndexError from a NaN
    # departure point; now SimulationDiverged names the velocity and the stage
    scene = _smoke_scene()
    with pytest.raises(SimulationDiverged, match="velocity component 0 is not finite; before stage advect"):
        scene.step(1e300)


def test_departure_points_that_overflow_are_named():
    # a periodic axis wraps x/Δx by mod: mod(±inf) is NaN, and NaN cast to an index read out of bounds
    # (IndexError in advect_scalar, OverflowError in the readable loop)
    g = Grid((8, 8), 1 / 8, "periodic")
    s = RNG.random(g.shape)
    u = [1e300 * np.ones(g.face_shape(i)) for i in range(2)]
    with pytest.raises(NonFiniteResult, match="sample coordinate x/Δx along axis 0"):
        advect_scalar(g, s, u, 1e300)
    with pytest.raises(NonFiniteResult, match=r"departure point of cell \(0, 0\)"):
        semi_lagrangian_loop(g, s, u, 1e300)


def test_results_that_overflow_are_named_without_warnings():
    # a linear sample and D_c of fields at ±1.7e308 returned NaN; the kinetic energy of 1e200 returned inf
    g = _walls()
    q = np.where(RNG.standard_normal(g.shape) > 0, 1.7e308, -1.7e308)
    q[3:5, 3:5] = [[1.7e308, -1.7e308], [-1.7e308, 1.7e308]]
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        with pytest.raises(NonFiniteResult, match="the result of sample"):
            sample(g, q, None, [np.array([0.5]), np.array([0.5])])
        with pytest.raises(NonFiniteResult, match="collocated_divergence"):
            collocated_divergence(g, [q, q])
        with pytest.raises(NonFiniteResult, match="Grid.kinetic_energy"):
            g.kinetic_energy(_velocity(g, 1e200))


def test_taylor_green_energy_at_its_limits():
    # ORACLES E1: E(t) = E(0) e^(−4νk²t); at t = 0 it is E(0) (was inf · 0 = NaN when 4νk² overflows), for
    # t > 0 its limit 0; growing back in time past 1e308 is named
    assert taylor_green_energy(2.0, 1e300, 1e300, 0.0) == 2.0
    assert taylor_green_energy(2.0, 1e300, 1e300, 1.0) == 0.0
    np.testing.assert_allclose(taylor_green_energy(2.0, 0.1, 2.0, [0.0, 1.0]), [2.0, 2.0 * np.exp(-1.6)])
    with pytest.raises(NonFiniteResult, match="taylor_green_energy"):
        taylor_green_energy(2.0, 1.0, 1.0, -1e300)


# -- stages applied by hand, cross-argument conditions ---------------------------------------------------
def test_stages_applied_by_hand_are_checked_against_their_grid_and_state():
    g = _walls()
    state = FluidScene(g, [], scalars={"density": np.zeros(g.shape)}).state
    with pytest.raises(InvalidInput, match=r"source\[density\].apply: bind\(grid, state\) must come first"):
        Source("density", 1.0, np.ones(g.shape)).apply(g, state, 0.1)       # was AttributeError
    advection = Advection()
    advection.bind(g, FluidScene(g, [], scalars={"s": np.zeros(g.shape)}).state)
    with pytest.raises(InvalidInput, match="needs the scalar 's'"):
        advection.apply(g, state, 0.1)                                       # was KeyError
    # ORACLES E2 (a projection leaves roundoff): the DCT solve asked of a box with obstacles, never bound,
    # returned a field whose divergence was 8 (the box's inverse is not the obstacles')
    solid = np.zeros(g.shape, bool)
    solid[3:5, 3:5] = True
    go = Grid(g.shape, g.dx, "walls", solid=solid)
    st = FluidScene(go, [], u=_velocity(go)).state
    with pytest.raises(InvalidInput, match=r"project\[dct\]: method 'dct' needs a box .* 4 solid cells"):
        Projection("dct").apply(go, st, 0.1)


def test_sample_refuses_a_padded_field_of_another_q():
    # padded must be pad_field(grid, q, component): another field's was read silently
    g = _walls()
    q, other = RNG.random(g.shape), RNG.random(g.shape)
    pts = [np.array([0.3]), np.array([0.4])]
    with pytest.raises(InvalidInput, match="padded must be pad_field"):
        sample(g, q, None, pts, padded=pad_field(g, other, None))
    assert sample(g, q, None, pts, padded=pad_field(g, q, None)) == sample(g, q, None, pts)
    with pytest.raises(InvalidInput, match="component must be an integer >= 0 and <= 2, got True"):
        sample(g, RNG.random(g.face_shape(1)), True, pts)                   # True was axis 1


def test_centreline_and_stream_function_name_what_they_cannot_use():
    with pytest.raises(InvalidInput, match="centreline_u: scene must be on a 2-D grid with walls along y"):
        centreline_u(FluidScene(Grid((8, 8), 1 / 8, "periodic"), []))       # returned wall values 0 there
    with pytest.raises(InvalidInput, match="centreline_u: scene"):
        centreline_u(FluidScene(Grid((4, 4, 4), 1 / 4, "walls"), []))      # was a bare ValueError
    with pytest.raises(InvalidInput, match="psi must return numbers"):
        stream_velocity(_walls(), lambda x, y: np.full(x.shape, "a"))       # was a bare ValueError


# -- behaviour the contracts changed ---------------------------------------------------------------------
def test_grid_caps_are_stated_before_anything_runs():
    with pytest.raises(InvalidInput, match=f"at most {MAX_CELLS} cells in all, got \\(4096, 4096\\); 16777216 cells"):
        Grid((4096, 4096))
    # Δx = 1e-300 was accepted and its first step divided by Δx² = 0
    with pytest.raises(InvalidInput, match=r"dx must be a finite number >= 1e-100 and <= 1e\+100, got 1e-300"):
        Grid((8, 8), 1e-300)
    with pytest.raises(InvalidInput, match="iterations must be an integer >= 0 and <= 10000, got 100000"):
        Projection("jacobi", iterations=100_000)


def test_stam_refuses_a_projection_its_box_cannot_solve_when_built():
    with pytest.raises(InvalidInput, match="StamSolver: projection 'dct' needs a box with walls"):
        StamSolver(Grid((8, 8), 1 / 8, "periodic"), projection="dct")       # refused at the first step only


def test_fields_are_accepted_as_lists_and_tuples_and_copied():
    g = _walls()
    u = _velocity(g)
    scene = FluidScene(g, [Projection()], u=tuple(c.tolist() for c in u))
    for a, b in zip(scene.state.u, u):
        np.testing.assert_array_equal(a, b)
    scene.step(0.1)
    assert not np.array_equal(scene.state.u[0], u[0])                       # projected its own copy
    copies = g.check_velocity(u, "w")
    assert all(c is not d for c, d in zip(copies, u))
    with pytest.raises(InvalidInput, match=r"Grid.check_velocity: w\[0\] must be a float array of shape \(9, 8\)"):
        g.check_velocity([np.zeros((8, 8)), u[1]], "w")
