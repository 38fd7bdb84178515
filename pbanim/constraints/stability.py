"""The stability of Baumgarte feedback itself: its discrete one-step map, spectral radius and step limit (ch03).

Baumgarte feedback makes the constraint error a damped oscillator C̈ + k_d Ċ + k_s C = 0, a stiff spring with
its own step limit. With k_s = ω_b², k_d = 2ζω_b and time measured in steps, an integrator's one-step map of
(C, Ċ·h) depends on ω_b h and ζ only; the feedback is stable with that integrator and step when the map's
spectral radius ρ ≤ 1 (ORACLES B2).
"""

from __future__ import annotations

import numpy as np

from ..contracts import Array, Choice, Real, contract
from ..errors import InvalidInput, NonFiniteResult, check_result

__all__ = ["baumgarte_feedback_map", "baumgarte_spectral_radius", "baumgarte_stability_limit"]

_GAIN = Real(ge=0)


# -- the discrete feedback map (stability of Baumgarte itself) ---------------------------------------
def _fixed_step_methods():
    from ..ode import METHODS
    return [k for k, m in METHODS.items() if not m.adaptive]


_METHOD = Choice(_fixed_step_methods)


@contract(method=_METHOD, omega_h=_GAIN, zeta=_GAIN)
def baumgarte_feedback_map(method: str, omega_h: float, zeta: float) -> np.ndarray:
    """The 2×2 one-step map of (C, Ċ·h) for C̈ = −k_s C − k_d Ċ integrated by ``method`` with step h,
    as a function of ω_b h and ζ only (time measured in steps). Exact for constraints linear in q
    (J constant), and the linearization of the error dynamics otherwise.

    >>> M = baumgarte_feedback_map("symplectic_euler", 0.5, 1.0)
    >>> round(float(np.linalg.det(M)), 12)   # symplectic Euler: det = 1 − h k_d
    0.0
    """
    from ..ode import get_method

    wh, z = float(omega_h), float(zeta)
    with np.errstate(all="ignore"):     # an overflow is named below
        M = _feedback_map(get_method(method), wh, z)
    return check_result("baumgarte_feedback_map", M, f"omega_h = {wh:g}, zeta = {z:g}")


def _feedback_map(meth, wh: float, z: float) -> np.ndarray:
    """The map of :func:`baumgarte_feedback_map` for a method object, unchecked (NaN or inf on overflow)."""
    A = np.array([[0.0, 1.0], [-wh * wh, -2 * z * wh]])
    fun = lambda t, y: y @ A.T  # noqa: E731  (works on (2,) and batches)
    jac = lambda t, y: A  # noqa: E731
    return np.array([np.asarray(meth.step(fun, 0.0, e, 1.0, split=1, jac=jac), float) for e in np.eye(2)]).T


def _radius(M: np.ndarray) -> float:
    """ρ of a finite 2×2 matrix from its trace τ and determinant δ, λ = τ/2 ± √(τ²/4 − δ) (eigvals when τ²
    overflows)."""
    tau, det = M[0, 0] + M[1, 1], M[0, 0] * M[1, 1] - M[0, 1] * M[1, 0]
    disc = 0.25 * tau * tau - det
    if not np.isfinite(disc):
        return float(np.max(np.abs(np.linalg.eigvals(M))))
    if disc < 0:                                  # a complex pair: |λ|² = δ
        return float(np.sqrt(det))
    return float(0.5 * abs(tau) + np.sqrt(disc))


def _radius_batch(meth, wh: np.ndarray, z: np.ndarray) -> np.ndarray:
    """ρ over a grid for an explicit method: the maps of all points from one batched step (the columns e₁, e₂ of
    every point's map as 2K states, each point's A applied by its own row), then :func:`_radius`'s formulas
    elementwise; the same sums per point as :func:`_feedback_map`, equal to roundoff (√ε relative where the
    eigenvalues nearly coincide, τ²/4 ≈ δ, as for any evaluation of a double root; ORACLES B2)."""
    w, zz = wh.ravel(), z.ravel()
    K = w.size
    Y0 = np.zeros((2 * K, 2))
    Y0[:K, 0] = Y0[K:, 1] = 1.0
    with np.errstate(all="ignore"):     # an overflow is named below
        A = np.zeros((K, 2, 2))
        A[:, 0, 1], A[:, 1, 0], A[:, 1, 1] = 1.0, -w * w, -2 * zz * w
        AA = np.concatenate([A, A])                      # row k and K + k: point k's e₁ and e₂
        fun = lambda t, Y: np.einsum("kij,kj->ki", AA, Y)  # noqa: E731
        Y1 = np.asarray(meth.step(fun, 0.0, Y0, 1.0, split=1), float)
        M = np.stack([Y1[:K], Y1[K:]], axis=-1)        # (K, 2, 2): columns are the images of e₁, e₂
        bad = ~np.isfinite(M).all(axis=(1, 2))
        if bad.any():
            k = int(np.flatnonzero(bad)[0])
            raise NonFiniteResult("baumgarte_spectral_radius's feedback map", f"omega_h = {w[k]:g}, zeta = {zz[k]:g}")
        tau, det = M[:, 0, 0] + M[:, 1, 1], M[:, 0, 0] * M[:, 1, 1] - M[:, 0, 1] * M[:, 1, 0]
        disc = 0.25 * tau * tau - det
        rho = np.where(disc < 0, np.sqrt(np.abs(det)), 0.5 * np.abs(tau) + np.sqrt(np.abs(disc)))
        for k in np.flatnonzero(~np.isfinite(disc)):   # τ² overflowed: the eigenvalues themselves
            rho[k] = float(np.max(np.abs(np.linalg.eigvals(M[k]))))
    return rho.reshape(wh.shape)


@contract(method=_METHOD, omega_h=Array(None, ge=0, scalar=True), zeta=Array(None, ge=0, scalar=True))
def baumgarte_spectral_radius(method: str, omega_h, zeta) -> np.ndarray:
    """ρ(map) over arrays of ω_b h and ζ (≤ 1: the feedback is stable with this integrator and step)."""
    from ..ode import get_method

    try:
        wh, z = np.broadcast_arrays(np.asarray(omega_h, float), np.asarray(zeta, float))
    except ValueError:
        raise InvalidInput(f"baumgarte_spectral_radius: omega_h and zeta must broadcast together, got shapes "
                           f"{np.shape(omega_h)} and {np.shape(zeta)}") from None
    meth = get_method(method)
    if not meth.implicit and wh.size > 1:
        return _radius_batch(meth, wh, z)
    out = np.empty(wh.shape)
    with np.errstate(all="ignore"):     # an overflow is named below
        for idx in np.ndindex(wh.shape):
            M = _feedback_map(meth, float(wh[idx]), float(z[idx]))
            if not np.isfinite(M).all():
                raise NonFiniteResult("baumgarte_spectral_radius's feedback map",
                                      f"omega_h = {wh[idx]:g}, zeta = {z[idx]:g}")
            out[idx] = _radius(M)
    return out


@contract(method=_METHOD, zeta=_GAIN, upper=Real(gt=1e-3, le=1e6))
def baumgarte_stability_limit(method: str, zeta: float, upper: float = 20.0) -> float:
    """The largest ω_b h below which ρ ≤ 1 for all smaller ω_b h (bisection to 1e-10), for damping ratio ζ.

    >>> round(baumgarte_stability_limit("symplectic_euler", 1.0), 6)   # (ωh)² + 4ωh = 4: 2√2 − 2
    0.828427
    """
    grid = np.linspace(1e-3, upper, 2000)
    rho = baumgarte_spectral_radius(method, grid, zeta)
    bad = np.flatnonzero(rho > 1 + 1e-12)
    if not bad.size:
        return float("inf")
    lo, hi = (grid[bad[0] - 1] if bad[0] else 0.0), grid[bad[0]]
    for _ in range(200):   # bisection: width/2²⁰⁰ is far below the tolerance, so the cap is never the stop
        if hi - lo <= 1e-10:
            break
        mid = 0.5 * (lo + hi)
        if baumgarte_spectral_radius(method, mid, zeta) > 1 + 1e-12:
            hi = mid
        else:
            lo = mid
    return float(0.5 * (lo + hi))
