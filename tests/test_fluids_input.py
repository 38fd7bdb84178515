"""Bad input to pbanim.fluids gives named errors that say which argument and why; property tests of the
public entry points (hypothesis, small example counts).
"""

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from pbanim.errors import (
    ConvergenceError,
    InvalidInput,
    SimulationDiverged,
    StepLimitExceeded,
)
from pbanim.fluids import (
    BACKTRACES,
    Advection,
    Buoyancy,
    Diffusion,
    FluidScene,
    Force,
    Grid,
    Projection,
    Source,
    VorticityConfinement,
    advect_scalar,
    advect_velocity,
    diffuse_scalar,
    diffuse_velocity,
    lid_driven_cavity,
    sample,
    solve_cells,
    stream_velocity,
)


# -- ORACLES G3: invalid input gives a named error -------------------------------------------------
@pytest.mark.parametrize("kwargs,words", [
    (dict(shape=(2, 8)), "shape[0]"), (dict(shape=(8,)), "2 or 3"), (dict(shape=(8, 8, 8, 8)), "2 or 3"),
    (dict(shape=8), "shape must be 2 or 3 cell counts"),
    (dict(shape=(8, 2.5)), "shape[1]"), (dict(shape=(8, 8), dx=0.0), "dx"),
    (dict(shape=(8, 8), dx=-1.0), "dx"), (dict(shape=(8, 8), dx=math.nan), "dx"),
    (dict(shape=(8, 8), boundary="open"), "boundary"), (dict(shape=(8, 8), boundary=("walls",)), "boundary"),
    (dict(shape=(8, 8), solid=np.zeros((8, 7), bool)), "solid"),
    (dict(shape=(8, 8), solid=np.ones((8, 8), bool)), "no fluid"),
    (dict(shape=(8, 8), solid=np.full((8, 8), 0.5)), "boolean"),
    (dict(shape=(8, 8), lids={"top": (1, 0)}), "lids"), (dict(shape=(8, 8), lids={"y+": (1, 1)}), "tangential"),
    (dict(shape=(8, 8), lids={"y+": (1, math.inf)}), "finite"), (dict(shape=(8, 8), lids={"z+": (1, 0)}), "lids"),
    (dict(shape=(8, 8), boundary="periodic", lids={"y+": (1, 0)}), "periodic"),
])
def test_grid_refuses_bad_input(kwargs, words):
    with pytest.raises(InvalidInput, match=None) as err:
        Grid(**kwargs)
    assert words in str(err.value)


def test_fields_and_parameters_are_checked():
    g = Grid((8, 6), 0.1, "walls")
    u = g.zeros_velocity()
    bad = [c.copy() for c in u]
    bad[1][2, 3] = np.nan
    with pytest.raises(InvalidInput, match=r"u\[1\] must be a float array of shape \(8, 7\) \(finite.*NaN or inf"):
        FluidScene(g, [], u=bad)
    with pytest.raises(InvalidInput, match=r"u\[0\] must be a float array of shape \(9, 6\).*got an array of shape "
                                          r"\(8, 6\)"):
        FluidScene(g, [], u=[np.zeros((8, 6)), u[1]])
    with pytest.raises(InvalidInput, match=r"u must be a list of 2 finite float arrays of shapes \(9, 6\), \(8, 7\).*"
                                          r"shape \(2, 8, 6\)"):
        FluidScene(g, [], u=np.zeros((2, 8, 6)))
    with pytest.raises(InvalidInput, match=r"scalars\['s'\] must be a float array .*finite.*NaN or inf"):
        FluidScene(g, [], scalars={"s": np.full((8, 6), np.inf)})
    with pytest.raises(InvalidInput, match="viscosity must be a finite number >= 0, got -0.1"):
        Diffusion(-0.1)
    with pytest.raises(InvalidInput, match="nu must be a finite number >= 0, got -1.0"):
        diffuse_velocity(g, u, -1.0, 0.1)
    with pytest.raises(InvalidInput, match="h must be a finite number > 0, got 0.0"):
        advect_velocity(g, u, 0.0)
    with pytest.raises(InvalidInput, match="h must be a finite number > 0, got -0.1"):
        FluidScene(g, []).step(-0.1)
    with pytest.raises(InvalidInput, match="h must be a finite number > 0, got nan"):
        FluidScene(g, []).simulate(1.0, math.nan)
    with pytest.raises(StepLimitExceeded):
        FluidScene(g, []).simulate(1.0, 1e-3, max_steps=10)
    with pytest.raises(InvalidInput, match="method must be one of 'semi_lagrangian'.*got 'upwind'"):
        Advection("upwind")
    with pytest.raises(InvalidInput, match="backtrace must be one of 'euler', 'midpoint', got 'rk4'"):
        Advection(backtrace="rk4")
    with pytest.raises(InvalidInput, match="Projection.__init__: method must be one of .*got 'sor'"):
        Projection("sor")
    with pytest.raises(InvalidInput, match="needs a box with periodic"):
        FluidScene(g, [Projection("fft")])
    with pytest.raises(InvalidInput, match="'fft' needs a periodic box"):
        FluidScene(g, [Diffusion(0.1, "fft")])
    with pytest.raises(InvalidInput, match="needs the scalar 'density'"):
        FluidScene(g, [Buoyancy()])
    with pytest.raises(InvalidInput, match=r"region must be an array of the cell shape \(8, 6\), got shape \(3, 3\)"):
        FluidScene(g, [Source("s", 1.0, np.ones((3, 3)))], scalars={"s": np.zeros((8, 6))})
    with pytest.raises(InvalidInput, match=r"f must be 2 numbers .*got \[0. 1. 0.\]"):
        FluidScene(g, [Force([0, 1, 0])])
    with pytest.raises(InvalidInput, match="epsilon must be a finite number >= 0, got -1"):
        VorticityConfinement(-1)
    with pytest.raises(InvalidInput, match=r"r must be a float array of shape \(8, 6\).*got an array of shape "
                                          r"\(3, 3\)"):
        solve_cells(g, np.zeros((3, 3)))
    with pytest.raises(InvalidInput, match="method must be one of .*got 'sor'"):
        solve_cells(g, np.zeros((8, 6)), method="sor")
    with pytest.raises(InvalidInput, match="order must be one of 'linear', 'cubic', got 'quintic'"):
        sample(g, np.zeros((8, 6)), None, [np.zeros(3), np.zeros(3)], "quintic")
    with pytest.raises(InvalidInput, match="reynolds must be a finite number > 0, got 0"):
        lid_driven_cavity(8, reynolds=0)
    with pytest.raises(InvalidInput, match="psi must be a callable, got 3.0"):
        stream_velocity(g, 3.0)
    with pytest.raises(InvalidInput, match=r"keep must name scalars among \[\] or 'speed', got 'smoke'"):
        FluidScene(g, []).simulate(0.1, 0.1, keep=("smoke",))


def test_cg_cap_raises_convergence_error():
    g = Grid((32, 32), 1 / 32, "walls")
    b = np.random.default_rng(0).standard_normal((32, 32))
    with pytest.raises(ConvergenceError, match="cg did not converge"):
        solve_cells(g, b, 0.0, 1.0, "cg", tol=1e-12, max_iter=3)


def test_a_diverging_run_raises_instead_of_returning_nan():
    # ORACLES G3: a force that overflows the velocity raises SimulationDiverged naming the quantity
    g = Grid((8, 8), 0.1, "periodic")
    scene = FluidScene(g, [Force([1e308, 0.0])])
    with pytest.raises(SimulationDiverged, match="velocity component 0"):
        scene.simulate(10.0, 5.0)
    scene = FluidScene(g, [Force([1e200, 0.0])])
    with pytest.raises(SimulationDiverged, match="kinetic energy"):
        scene.simulate(1.0, 1.0)                                  # u² overflows: E = inf
    scene = FluidScene(g, [Force([1.0, 0.0])])
    with pytest.raises(SimulationDiverged, match="kinetic energy"):
        scene.simulate(1.0, 0.1, max_energy=1e-6)


# -- property tests of the public entry points ---------------------------------------------------------
sizes = st.integers(3, 9)
kinds = st.sampled_from(["periodic", "walls"])


@settings(max_examples=30, deadline=None)
@given(nx=sizes, ny=sizes, bx=kinds, by=kinds, seed=st.integers(0, 2 ** 31 - 1),
       method=st.sampled_from(["direct", "pcg", "spectral"]))
def test_projection_property(nx, ny, bx, by, seed, method):
    # ORACLES E2: on any small box the exact projections leave roundoff divergence and never add energy
    g = Grid((nx, ny), 0.3, (bx, by))
    rng = np.random.default_rng(seed)
    u = g.close([rng.standard_normal(g.face_shape(i)) for i in range(2)])
    p, _ = solve_cells(g, -g.divergence(u), 0.0, 1.0, method, tol=1e-13)
    w = [c - gp for c, gp in zip(u, g.gradient(p))]
    assert np.abs(g.divergence(w)).max() <= 1e-9 * (1 + np.abs(g.divergence(u)).max())
    assert g.kinetic_energy(w) <= g.kinetic_energy(u) * (1 + 1e-12)


@settings(max_examples=30, deadline=None)
@given(nx=sizes, ny=sizes, bx=kinds, by=kinds, seed=st.integers(0, 2 ** 31 - 1),
       h=st.floats(1e-3, 10.0), method=st.sampled_from(["semi_lagrangian", "cubic", "bfecc", "maccormack"]),
       backtrace=st.sampled_from(BACKTRACES))
def test_advection_property(nx, ny, bx, by, seed, h, method, backtrace):
    # ORACLES E9: any step size gives finite fields; the monotone schemes stay within the old extrema
    g = Grid((nx, ny), 0.2, (bx, by))
    rng = np.random.default_rng(seed)
    u = g.close([rng.standard_normal(g.face_shape(i)) for i in range(2)])
    s = rng.random(g.shape)
    out = advect_scalar(g, s, u, h, method, backtrace)
    v = advect_velocity(g, u, h, method, backtrace)
    assert np.all(np.isfinite(out)) and all(np.all(np.isfinite(c)) for c in v)
    if method != "bfecc":
        assert out.min() >= s.min() - 1e-12 and out.max() <= s.max() + 1e-12


@settings(max_examples=25, deadline=None)
@given(n=st.integers(3, 8), seed=st.integers(0, 2 ** 31 - 1), kappa=st.floats(0.0, 5.0),
       method=st.sampled_from(["gauss_seidel", "cg", "spectral"]))
def test_scalar_diffusion_property(n, seed, kappa, method):
    # ORACLES E10: implicit diffusion keeps ∫s (no flux through walls), never raises the max, never NaN
    g = Grid((n, n + 1), 0.5, "walls")
    s = np.random.default_rng(seed).random(g.shape)
    out, _ = diffuse_scalar(g, s, kappa, 0.1, method, iterations=50)
    assert out.max() <= s.max() + 1e-9 and out.min() >= s.min() - 1e-9
    if method != "gauss_seidel":
        assert abs(g.total(out) - g.total(s)) <= 1e-9 * g.total(s)


@settings(max_examples=20, deadline=None)
@given(n=st.integers(3, 6), seed=st.integers(0, 2 ** 31 - 1), cfl=st.floats(0.1, 10.0))
def test_scene_property_3d(n, seed, cfl):
    # ORACLES E6: a 3-D closed box, advection + exact projection: energy never grows, divergence at roundoff
    g = Grid((n, n, n + 1), 1.0 / n, "walls")
    rng = np.random.default_rng(seed)
    u = g.close([rng.standard_normal(g.face_shape(i)) for i in range(3)])
    first = FluidScene(g, [Projection("dct")], u=u)
    first.step(0.1)                                   # a divergence-free start
    scene = FluidScene(g, [Advection(), VorticityConfinement(0.0), Projection("dct")], u=first.state.u)
    e0 = g.kinetic_energy(scene.state.u)
    scene.step(cfl * g.dx / max(1e-12, max(np.abs(c).max() for c in scene.state.u)))
    assert g.kinetic_energy(scene.state.u) <= e0 * (1 + 1e-12)
    assert np.abs(g.divergence(scene.state.u)).max() <= 1e-9 * (1 + np.abs(g.divergence(u)).max())
