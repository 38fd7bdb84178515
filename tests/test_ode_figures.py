"""Chapter 02 figures: the data they return is checked against the physics (not the pixels)."""

import numpy as np
import pytest

from pbanim.ode import METHODS


def test_convergence_figure_slopes(figure_data):
    # ORACLES A3 in the figure: every method's fitted slope matches its declared order
    d = figure_data("ch02_convergence")
    assert set(d["slope"]) == set(METHODS)
    for name, slope in d["slope"].items():
        assert abs(slope - METHODS[name].order) < 0.2, (name, slope)  # measured within 0.1 (dopri5 5.097)


def test_stability_figure_regions(figure_data):
    # the spectral radius of one step on the oscillator with eigenvalues z, z̄ equals |R(z)| for RK methods;
    # explicit Euler's region is the disk |1 + z| ≤ 1
    d = figure_data("ch02_stability")
    for name, R in d["R_direct"].items():
        # atol: at a double eigenvalue (z on the real axis) the 2×2 route takes a square root of a roundoff-size
        # discriminant, √ε·|R| ≈ 1e-11 (measured 8e-13 for the 12-stage DOP853)
        np.testing.assert_allclose(d["rho"][name], R, rtol=1e-10, atol=1e-11)
    Z = d["x"][None, :] + 1j * d["y"][:, None]
    np.testing.assert_allclose(d["rho"]["euler"], np.abs(1 + Z), rtol=1e-12)
    left = Z.real < -1e-9
    assert np.all(d["rho"]["implicit_euler"][left] < 1)  # A-stable
    assert np.all(d["rho"]["implicit_midpoint"][left] <= 1 + 1e-12)
    np.testing.assert_allclose(d["rho"]["exponential_euler"], np.abs(np.exp(Z)), rtol=1e-10)  # R(z) = eᶻ


def test_stability_limits_on_the_imaginary_axis():
    # ORACLES A2 from the stability functions: RK4 stable on iy iff |y| ≤ 2√2, symplectic Euler and Verlet
    # iff |y| < 2 (undamped oscillator: z = ±ihω)
    from chapters.ch02_ode import stability_radius

    eps = 1e-3
    assert stability_radius("rk4", [2j * np.sqrt(2) * (1 - eps)])[0] <= 1
    assert stability_radius("rk4", [2j * np.sqrt(2) * (1 + eps)])[0] > 1
    for name in ("symplectic_euler", "verlet"):
        assert stability_radius(name, [2j * (1 - eps)])[0] == pytest.approx(1.0, abs=1e-12)
        assert stability_radius(name, [2j * (1 + eps)])[0] > 1 + 1e-3


def test_kepler_figure_invariants(figure_data):
    # ORACLES A4 in the figure: symplectic methods keep L to roundoff; explicit Euler gains energy
    d = figure_data("ch02_kepler")
    for name in ("symplectic_euler", "verlet", "implicit_midpoint"):
        assert np.max(np.abs(d["L_error"][name])) < 5e-14  # measured 1.0e-15 – 9.7e-15
    assert d["energy_error"]["euler"][-1] > 0.05  # measured 0.235
    assert np.max(np.abs(d["energy_error"]["rk4"])) < 5e-7  # measured 7.1e-8


def test_work_precision_figure(figure_data):
    # ORACLES A6 in the figure: for every variant of both libraries, tightening the tolerance buys a smaller
    # error; the same method in both libraries (Dormand–Prince 8, Radau IIA 5) lands at a comparable error
    d = figure_data("ch02_work_precision")
    assert {"pbanim:dop853", "scipy:DOP853", "odeint"} <= set(d["sweeps"]["Kepler e = 0.5, 10 periods"])
    for title, sweeps in d["sweeps"].items():
        for v, pts in sweeps.items():
            errs = [p[1] for p in pts]
            assert np.all(np.isfinite([p[2] for p in pts])), (title, v)
            if len(pts) > 1:
                assert errs[-1] < errs[0], (title, v)
    for title, ours, theirs in (("Kepler e = 0.5, 10 periods", "pbanim:dop853", "scipy:DOP853"),
                                ("Robertson, t in [0, 40]", "pbanim:radau5", "scipy:Radau")):
        a, b = d["sweeps"][title][ours], d["sweeps"][title][theirs]
        for (ra, ea, _, _), (rb, eb, _, _) in zip(a, b):
            assert ra == rb and 0.01 < ea / eb < 50, (title, ra, ea, eb)  # measured 0.095 – 5.6 (same formulas)


def test_stiff_spring_figure(figure_data):
    # ORACLES A2 in the figure: at hω = 2.5 explicit and symplectic Euler diverge, RK4 and implicit Euler decay
    d = figure_data("ch02_stiff_spring")
    assert set(d["diverged_at"]) == {"euler", "symplectic_euler"}
    for name in ("rodas4", "radau5"):   # ORACLES A11: L-stable and accurate: they follow the physical decay e^(−ct/2)
        x = d["x"][name]
        assert np.max(np.abs(x)) <= 1.0 + 1e-12 and np.max(np.abs(x[len(x) // 2:])) < 0.1  # measured 0.060
    for name in ("rk4", "implicit_euler"):
        x = d["x"][name]
        assert np.max(np.abs(x[len(x) // 2:])) < 1e-6
    assert np.max(np.abs(d["x"]["implicit_midpoint"])) <= 1.0 + 1e-12  # A-stable, no growth
    t, x = d["t"]["exponential_euler"], d["x"]["exponential_euler"]
    from pbanim.models.ode import damped_oscillator
    assert np.max(np.abs(x - damped_oscillator(1e3, 20.0).exact(t)[0])) < 1e-12  # exact flow; measured 1e-16
