"""Canonical ODE models with exact solutions and invariants (chapter 02; ORACLES A1–A8).

Each constructor returns an :class:`OdeModel`: the right-hand side ``rhs(t, y)`` (works on y of shape
(n,) and on batches (K, n)), the initial state ``y0``, ``split`` (number of position components), the
exact solution ``exact(t) -> (n, len(t))`` where one exists, an analytic ``jac`` where useful, and the
invariants as callables on states of shape (n, ...) (a trajectory ``r.y`` works as is).

========================  =====================================================  ============================
model                     equations                                               exact / invariants
========================  =====================================================  ============================
harmonic_oscillator       ẍ = −ω²x                                                x = x₀cos ωt + v₀/ω sin ωt; E
damped_oscillator         ẍ = −ω²x − cẋ   (stiff spring: ω² = k/m = 10⁶)         closed form, all 3 regimes
free_fall                 ẍ = −g                                                  x = x₀ + v₀t − ½gt²
kepler                    r̈ = −GM r/|r|³, start at periapsis                     Kepler's equation; E, L, A
pendulum                  θ̈ = −(g/L) sin θ                                        T = 4√(L/g) K(sin²(θ₀/2)); E
========================  =====================================================  ============================

References: Goldstein, *Classical Mechanics* §3.7–3.9 (Kepler problem, Laplace–Runge–Lenz vector);
Landau & Lifshitz, *Mechanics* §11 (pendulum period as a complete elliptic integral); Hairer, Lubich &
Wanner, *Geometric Numerical Integration* §I.2 (Kepler as a test problem).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Callable

import numpy as np
from scipy.special import ellipk
from ..errors import InvalidInput, check_number

__all__ = ["OdeModel", "harmonic_oscillator", "damped_oscillator", "free_fall", "kepler", "pendulum",
           "kepler_position"]


@dataclass
class OdeModel:
    """A system ẏ = rhs(t, y) with its start state, exact solution and invariants."""

    name: str
    rhs: Callable
    y0: np.ndarray
    split: int
    exact: Callable | None = None
    jac: Callable | None = None
    invariants: dict = field(default_factory=dict)
    params: dict = field(default_factory=dict)
    period: float | None = None


_BIG = 1e100   # model parameters beyond this overflow the closed forms (products, squares, exponentials)


def _positive(name, value):
    return check_number(name, value, low=0.0, low_open=True, high=_BIG)


def _finite(name, value):
    return check_number(name, value, low=-_BIG, high=_BIG)


def harmonic_oscillator(omega: float = 1.0, x0: float = 1.0, v0: float = 0.0) -> OdeModel:
    """ẍ = −ω²x, y = [x, v], E = ½(v² + ω²x²) (ORACLES A1).

    >>> m = harmonic_oscillator(2.0)
    >>> bool(np.allclose(m.exact([np.pi])[:, 0], [1.0, 0.0]))
    True
    """
    x0, v0 = _finite("x0", x0), _finite("v0", v0)
    w = _positive("omega", omega)
    w2 = w * w
    A = np.array([[0.0, 1.0], [-w2, 0.0]])

    def rhs(t, y):
        return np.stack([y[..., 1], -w2 * y[..., 0]], axis=-1)

    def exact(t):
        t = np.atleast_1d(np.asarray(t, dtype=float))
        c, s = np.cos(w * t), np.sin(w * t)
        return np.array([x0 * c + v0 / w * s, -x0 * w * s + v0 * c])

    energy = lambda y: 0.5 * (np.asarray(y)[1] ** 2 + w2 * np.asarray(y)[0] ** 2)  # noqa: E731
    return OdeModel("harmonic_oscillator", rhs, np.array([x0, v0], dtype=float), 1, exact,
                    lambda t, y: A, {"energy": energy}, {"omega": w}, 2 * np.pi / w)


def damped_oscillator(omega: float = 1.0, c: float = 0.1, x0: float = 1.0, v0: float = 0.0) -> OdeModel:
    """ẍ = −ω²x − cẋ (a damped spring: ω² = k/m, c = k_d/m), exact in every regime.

    Underdamped c < 2ω: x = e^(−ct/2)(x₀ cos ω_d t + (v₀ + cx₀/2)/ω_d sin ω_d t), ω_d = √(ω² − c²/4);
    overdamped: x = αe^(r₁t) + βe^(r₂t), r₁r₂ = ω², r₁ + r₂ = −c; critical: (x₀ + (v₀ + ωx₀)t)e^(−ωt).

    >>> m = damped_oscillator(1e3, 2e5)   # a stiff overdamped spring: rates −5 and −2·10⁵ 1/s
    >>> bool(abs(m.exact([1.0])[0, 0] - np.exp(-5.0)) < 1e-3)
    True
    """
    x0, v0 = _finite("x0", x0), _finite("v0", v0)
    w = _positive("omega", omega)
    c = float(c)
    if not (np.isfinite(c) and c >= 0):
        raise InvalidInput(f"c (damping per unit mass) must be non-negative, got {c}")
    w2 = w * w
    A = np.array([[0.0, 1.0], [-w2, -c]])

    def rhs(t, y):
        return np.stack([y[..., 1], -w2 * y[..., 0] - c * y[..., 1]], axis=-1)

    rhs.autonomous = True       # f does not depend on t (exponential Euler skips ∂f/∂t)
    disc = 0.25 * c * c - w2

    def exact(t):
        t = np.atleast_1d(np.asarray(t, dtype=float))
        if abs(disc) <= 1e-14 * w2:  # critical
            e = np.exp(-w * t)
            b = v0 + w * x0
            return np.array([(x0 + b * t) * e, (b - w * (x0 + b * t)) * e])
        if disc < 0:
            wd = np.sqrt(-disc)
            e, co, si = np.exp(-0.5 * c * t), np.cos(wd * t), np.sin(wd * t)
            B = (v0 + 0.5 * c * x0) / wd
            x = e * (x0 * co + B * si)
            return np.array([x, -0.5 * c * x + e * (-x0 * wd * si + B * wd * co)])
        s = np.sqrt(disc)
        r2 = -0.5 * c - s
        r1 = w2 / r2  # = −c/2 + s without cancellation
        al = (v0 - r2 * x0) / (r1 - r2)
        be = x0 - al
        e1, e2 = np.exp(r1 * t), np.exp(r2 * t)
        return np.array([al * e1 + be * e2, al * r1 * e1 + be * r2 * e2])

    energy = lambda y: 0.5 * (np.asarray(y)[1] ** 2 + w2 * np.asarray(y)[0] ** 2)  # noqa: E731
    return OdeModel("damped_oscillator", rhs, np.array([x0, v0], dtype=float), 1, exact,
                    lambda t, y: A, {"energy": energy}, {"omega": w, "c": c})


def free_fall(g: float = 9.81, x0: float = 10.0, v0: float = 0.0) -> OdeModel:
    """ẍ = −g: x = x₀ + v₀t − ½gt² (ORACLES A8); hits x = 0 at t = (v₀ + √(v₀² + 2gx₀))/g.

    >>> free_fall(9.81, 10.0).params["t_ground"]  # doctest: +ELLIPSIS
    1.42784312...
    """
    x0, v0 = _finite("x0", x0), _finite("v0", v0)
    g = float(g)

    def rhs(t, y):
        return np.stack([y[..., 1], np.full_like(y[..., 1], -g)], axis=-1)

    def exact(t):
        t = np.atleast_1d(np.asarray(t, dtype=float))
        return np.array([x0 + v0 * t - 0.5 * g * t * t, v0 - g * t])

    t_ground = (v0 + np.sqrt(v0 * v0 + 2 * g * x0)) / g if g > 0 and x0 >= 0 else np.nan
    return OdeModel("free_fall", rhs, np.array([x0, v0], dtype=float), 1, exact, None, {},
                    {"g": g, "t_ground": float(t_ground)})


def kepler_position(t, e: float, GM: float = 1.0, a: float = 1.0) -> np.ndarray:
    """Exact state [x, y, vx, vy] at times t of the orbit that starts at periapsis at t = 0.

    Solves Kepler's equation M = E − e sin E (mean anomaly M = nt, n = √(GM/a³)) by Newton's method.
    """
    t = np.atleast_1d(np.asarray(t, dtype=float))
    n = np.sqrt(GM / a ** 3)
    M = n * t
    E = M + e * np.sin(M)
    for _ in range(50):
        dE = (E - e * np.sin(E) - M) / (1 - e * np.cos(E))
        E -= dE
        if np.max(np.abs(dE)) < 1e-15 * max(1.0, float(np.max(np.abs(M)))):
            break
    b = a * np.sqrt(1 - e * e)
    Ed = n / (1 - e * np.cos(E))
    return np.array([a * (np.cos(E) - e), b * np.sin(E), -a * np.sin(E) * Ed, b * np.cos(E) * Ed])


def kepler(e: float = 0.6, GM: float = 1.0, a: float = 1.0) -> OdeModel:
    """Kepler orbit r̈ = −GM r/|r|³ from periapsis (ORACLES A4).

    Invariants: E = ½|v|² − GM/|r| = −GM/2a, L = x v_y − y v_x = √(GM a(1 − e²)), Laplace–Runge–Lenz
    A = v × L − GM r̂ = (GM e, 0). Period T = 2π√(a³/GM).

    >>> m = kepler(0.6)
    >>> bool(np.isclose(m.invariants["energy"](m.y0), -0.5)), bool(np.allclose(m.invariants["lrl"](m.y0), [0.6, 0]))
    (True, True)
    """
    if not (0 <= e < 1):
        raise InvalidInput(f"e (eccentricity) must be in [0, 1) for a bound orbit, got {e}")
    GM, a = _positive("GM", GM), _positive("a", a)
    y0 = np.array([a * (1 - e), 0.0, 0.0, np.sqrt(GM * (1 + e) / (a * (1 - e)))])

    def rhs(t, y):
        q = y[..., :2]
        r2 = q[..., 0] ** 2 + q[..., 1] ** 2
        s = (-GM / (r2 * np.sqrt(r2)))[..., None]
        return np.concatenate([y[..., 2:], s * q], axis=-1)

    def energy(y):
        y = np.asarray(y)
        return 0.5 * (y[2] ** 2 + y[3] ** 2) - GM / np.hypot(y[0], y[1])

    def angular_momentum(y):
        y = np.asarray(y)
        return y[0] * y[3] - y[1] * y[2]

    def lrl(y):
        y = np.asarray(y)
        L = angular_momentum(y)
        r = np.hypot(y[0], y[1])
        return np.array([y[3] * L - GM * y[0] / r, -y[2] * L - GM * y[1] / r])

    return OdeModel("kepler", rhs, y0, 2, lambda t: kepler_position(t, e, GM, a), None,
                    {"energy": energy, "angular_momentum": angular_momentum, "lrl": lrl},
                    {"e": e, "GM": GM, "a": a, "E": -GM / (2 * a), "L": np.sqrt(GM * a * (1 - e * e))},
                    2 * np.pi * np.sqrt(a ** 3 / GM))


def pendulum(theta0=np.pi / 2, length: float = 1.0, g: float = 9.81, omega0=0.0) -> OdeModel:
    """θ̈ = −(g/L) sin θ from rest at θ₀ (array θ₀ → a batch y0 of shape (K, 2)) (ORACLES A5).

    Period T = 4√(L/g) K(m) with the *parameter* m = sin²(θ₀/2) (``scipy.special.ellipk`` takes m, not
    the modulus k = sin(θ₀/2)); small amplitudes give 2π√(L/g).

    >>> p = pendulum(1e-4)
    >>> bool(np.isclose(p.period, 2 * np.pi * np.sqrt(1 / 9.81)))
    True
    """
    L, g = _positive("length", length), _positive("g", g)
    th = np.asarray(theta0, dtype=float)
    if np.any(~np.isfinite(th)) or np.any(np.abs(th) >= np.pi):
        raise InvalidInput(f"theta0 must be finite with |theta0| < pi (radians), got {theta0}")
    k = g / L
    y0 = np.stack([th, np.broadcast_to(np.asarray(omega0, dtype=float), th.shape)], axis=-1)

    def rhs(t, y):
        return np.stack([y[..., 1], -k * np.sin(y[..., 0])], axis=-1)

    def jac(t, y):
        return np.array([[0.0, 1.0], [-k * np.cos(y[0]), 0.0]])

    energy = lambda y: 0.5 * np.asarray(y)[1] ** 2 + k * (1 - np.cos(np.asarray(y)[0]))  # noqa: E731
    period = 4 * np.sqrt(L / g) * ellipk(np.sin(th / 2) ** 2)
    return OdeModel("pendulum", rhs, y0, 1, None, jac, {"energy": energy},
                    {"length": L, "g": g, "theta0": th}, period if th.ndim else float(period))
