"""Baumgarte's spectral radius over a grid from one batched step equals the point-by-point map (ORACLES B2)."""

import numpy as np
import pytest

import pbanim.constraints.stability as S
from pbanim.constraints import baumgarte_spectral_radius
from pbanim.errors import NonFiniteResult
from pbanim.ode import METHODS

EXPLICIT = sorted(k for k, m in METHODS.items() if not m.adaptive and not m.implicit)


@pytest.mark.parametrize("name", EXPLICIT)
def test_batched_radius_equals_the_per_point_map(name):
    # ORACLES B2: ρ of the one-step map of (C, Ċh); the grid's batch against _feedback_map per point
    WH, Z = np.meshgrid(np.linspace(0.0, 3.5, 40), np.linspace(0.0, 2.0, 21))
    got = baumgarte_spectral_radius(name, WH, Z)
    m = METHODS[name]
    maps = [S._feedback_map(m, float(w), float(z)) for w, z in zip(WH.ravel(), Z.ravel())]
    ref = np.array([S._radius(M) for M in maps])
    assert got.shape == WH.shape
    # roundoff, except near a double eigenvalue (τ²/4 ≈ δ), where ρ = τ/2 ± √(τ²/4 − δ) is determined to √ε only
    tau = np.array([M[0, 0] + M[1, 1] for M in maps])
    det = np.array([np.linalg.det(M) for M in maps])
    scale = np.maximum(np.maximum(0.25 * tau**2, np.abs(det)), 1.0)
    tol = 1e-12 * np.maximum(ref, 1.0) + np.sqrt(256 * np.finfo(float).eps * scale)
    near = np.abs(0.25 * tau**2 - det) <= 1e-6 * scale
    err = np.abs(got.ravel() - ref)
    assert np.all(err[~near] <= 1e-12 * np.maximum(ref[~near], 1.0))    # measured <= 1.2e-14
    assert np.all(err[near] <= tol[near])                               # measured <= 1.1e-7 (ρ ≈ 1)


def test_batched_radius_keeps_the_closed_forms_and_names_an_overflow():
    # symplectic Euler: det = 1 − h k_d = 1 − 2ζ ω h; undamped, ρ = 1 exactly inside the limit ωh < 2 (ORACLES B2)
    wh = np.linspace(0.1, 1.9, 7)
    assert np.allclose(baumgarte_spectral_radius("symplectic_euler", wh, 0.0), 1.0, rtol=0, atol=4e-16)
    # explicit Euler on the undamped error: |1 ± iωh| = √(1 + (ωh)²)
    assert np.allclose(baumgarte_spectral_radius("euler", wh, 0.0), np.sqrt(1 + wh**2), rtol=4e-16)
    with pytest.raises(NonFiniteResult, match="omega_h = 1e\\+200"):
        baumgarte_spectral_radius("rk4", np.array([1.0, 1e200]), np.array([1.0, 1.0]))
