"""Canonical reduced-coordinate models with their exact answers (chapter 04; ORACLES A5, B6, B7, G1).

======================  ==================================  =============================================
model                   coordinates u                       exact answers / invariants (``info``)
======================  ==================================  =============================================
``simple_pendulum``     θ (from the downward vertical)      period 4√(L/g)K(m), m = sin²(θ₀/2); E
``double_pendulum``     θ₁, θ₂ (absolute angles)            E; M = [[(m₁+m₂)L₁², m₂L₁L₂cos(θ₁−θ₂)], ...]
``n_link_pendulum``     θ₁ … θₙ (absolute angles)           E; rod tensions = g·Σ(masses below) at rest
``spherical_pendulum``  θ (polar, from below), φ            E, L_z = mL² sin²θ φ̇; conical: φ̇² = g/(L cos θ)
``bead_on_rotating_hoop`` θ on a hoop spinning at Ω         Jacobi integral; cos θ* = g/(RΩ²) for RΩ² > g,
                                                            small oscillations ω² = Ω² − g²/(R²Ω²)
``cart_pendulum``       x (cart), θ                         E, horizontal momentum p_x; ω² = g(M + m)/(ML)
``bead_x_chart``        x on a circle, y = −√(R² − x²)      a chart singular at x = ±R (ORACLES B6)
======================  ==================================  =============================================

Every model is a :class:`ReducedModel`: numbers at import (numpy only); the sympy positions are built
the first time :meth:`ReducedModel.lagrangian` or :meth:`ReducedModel.reduced` is called, and both are
cached per process under the model's ``key``.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Callable

import numpy as np
from scipy.special import ellipk
from ..errors import InvalidInput

__all__ = ["ReducedModel", "pendulum_period", "simple_pendulum", "double_pendulum", "n_link_pendulum",
           "n_link_chart", "spherical_pendulum", "bead_on_rotating_hoop", "cart_pendulum", "bead_x_chart",
           "chain_rod_tensions", "MaximalChain", "maximal_chain"]

_REDUCED: dict = {}
_VIEWS: dict = {}   # (structure, route, u0) → this model's view of a cached Lagrangian system


def pendulum_period(theta0: Any, length: float = 1.0, g: float = 9.81) -> Any:
    """T = 4√(L/g) K(m) with the parameter m = sin²(θ₀/2) (ORACLES A5; ``ellipk`` takes m, not k).

    >>> round(float(pendulum_period(np.pi / 2) / (2 * np.pi / np.sqrt(9.81))), 5)   # 90°: 2K(½)/π, 18% longer
    1.18034
    """
    th = np.asarray(theta0, dtype=float)
    if np.any(~np.isfinite(th)) or np.any(np.abs(th) >= np.pi) or np.any(th == 0):
        raise InvalidInput(f"theta0 must satisfy 0 < |theta0| < pi (radians), got {theta0}")
    if not (length > 0 and g > 0):
        raise InvalidInput(f"length and g must be positive, got length = {length}, g = {g}")
    T = 4.0 * np.sqrt(length / g) * ellipk(np.sin(th / 2) ** 2)
    return float(T) if th.ndim == 0 else T


@dataclass
class ReducedModel:
    """A point-mass model in generalized coordinates (numbers now, sympy on demand).

    Attributes
    ----------
    name : str
    key : tuple
        Cache key (model name and all parameters).
    masses : ndarray (N,)
    dim : int
    g : ndarray (dim,)
    u0, udot0 : ndarray (n,)
    info : dict
        Exact answers and invariants (callables of the state y = [u, u̇] where it applies).
    build : callable → (coords, positions, t)
        Sympy coordinates, N position lists, and the time symbol (or None).
    """

    name: str
    key: tuple
    masses: np.ndarray
    dim: int
    g: np.ndarray
    u0: np.ndarray
    udot0: np.ndarray
    build: Callable = field(repr=False)
    info: dict = field(default_factory=dict, repr=False)

    @property
    def n(self) -> int:
        return self.u0.size

    def state(self) -> np.ndarray:
        """y0 = [u0, u̇0]."""
        return np.concatenate([self.u0, self.udot0])

    def lagrangian(self, route: str = "kinematic"):
        """The compiled Euler–Lagrange equations (:func:`pbanim.reduced.lagrangian.lagrangian_system`, cached)."""
        from ..reduced.lagrangian import lagrangian_system

        import dataclasses

        from ..reduced.chart import ChartGuard

        coords, pos, t = self.build()
        pts = list(zip(self.masses.tolist(), pos))
        sysl = lagrangian_system(list(coords), pts, gravity=self.g.tolist(), t=t, route=route,
                                 key=self.key + (route,))
        view_key = self.key + (route, tuple(self.u0.tolist()))
        if view_key not in _VIEWS:
            # this model's own view: the chart check's reference metric is M at this model's u0, so the
            # answer never depends on which model of the same structure was built first
            view = dataclasses.replace(sysl, guard=ChartGuard(sysl.guard.max_cond), nfev=0)
            view.guard.set_reference(view.mass_matrix(self.u0))
            _VIEWS[view_key] = view
        return _VIEWS[view_key]

    def reduced(self, max_cond: float = 1e8):
        """A :class:`pbanim.reduced.ReducedSystem` with gravity (J, J̇u̇ from sympy; cached)."""
        from ..particles.system import Gravity
        from ..reduced.system import ReducedSystem

        k = self.key + (max_cond,)
        if k not in _REDUCED:       # the compiled chart depends on the structure only
            coords, pos, t = self.build()
            _REDUCED[k] = ReducedSystem.from_sympy(pos, list(coords), self.masses, self.dim, [Gravity(self.g)],
                                                   self.u0, self.udot0, t=t, max_cond=max_cond, name=self.name)
        # the cache key covers every argument: the initial state picks this model's own system
        kv = k + (tuple(self.u0.tolist()), tuple(self.udot0.tolist()))
        if kv not in _REDUCED:
            _REDUCED[kv] = _REDUCED[k].with_initial(self.u0, self.udot0)
        return _REDUCED[kv]


def _arr(x, n, name):
    try:
        a = np.broadcast_to(np.asarray(x, dtype=float), (n,)).copy()
    except (TypeError, ValueError):
        raise InvalidInput(f"{name} must be a positive number or {n} of them, got {x!r}") from None
    if np.any(~np.isfinite(a)) or np.any(a <= 0) or np.any(a > 1e100):
        raise InvalidInput(f"{name} must be positive and finite (at most 1e100), got {x}")
    return a


def n_link_pendulum(n: int, lengths: Any = 1.0, masses: Any = 1.0, g: float = 9.81, theta0: Any = None,
                    omega0: Any = None) -> ReducedModel:
    """n point masses on massless rods from a pivot at the origin; θⱼ absolute, from the downward vertical.

    Default start: θⱼ = 0.5 + 0.1 j rad at rest. ``info["lengths"]``.

    >>> mod = n_link_pendulum(3); mod.n, mod.masses.tolist()
    (3, [1.0, 1.0, 1.0])
    """
    if not isinstance(n, (int, np.integer)) or n < 1:
        raise InvalidInput(f"n must be a positive integer number of links, got {n!r}")
    L, m = _arr(lengths, n, "lengths"), _arr(masses, n, "masses")
    th0 = 0.5 + 0.1 * np.arange(n) if theta0 is None else np.broadcast_to(np.asarray(theta0, float), (n,)).copy()
    om0 = np.zeros(n) if omega0 is None else np.broadcast_to(np.asarray(omega0, float), (n,)).copy()

    def build():
        import sympy

        th = sympy.symbols(f"theta1:{n + 1}")
        x, y, pos = sympy.S.Zero, sympy.S.Zero, []
        for j in range(n):
            x = x + float(L[j]) * sympy.sin(th[j])
            y = y - float(L[j]) * sympy.cos(th[j])
            pos.append([x, y])
        return th, pos, None

    key = ("n_link_pendulum", n, tuple(L), tuple(m), float(g))
    return ReducedModel(f"{n}-link pendulum", key, m, 2, np.array([0.0, -g]), th0, om0, build,
                        {"lengths": L})


def simple_pendulum(theta0: float = 0.5, length: float = 1.0, mass: float = 1.0, g: float = 9.81,
                    omega0: float = 0.0) -> ReducedModel:
    """One link; ``info["period"]`` from rest = 4√(L/g)K(sin²(θ₀/2)) (ORACLES A5)."""
    mod = n_link_pendulum(1, length, mass, g, [theta0], [omega0])
    mod.name = "simple pendulum"
    if omega0 == 0.0 and 0 < abs(theta0) < np.pi:
        mod.info["period"] = pendulum_period(theta0, length, g)
    return mod


def double_pendulum(theta0=(1.0, 1.5), lengths=(1.0, 1.0), masses=(1.0, 1.0), g: float = 9.81,
                    omega0=(0.0, 0.0)) -> ReducedModel:
    """Two links (the chaotic double pendulum at large angles)."""
    mod = n_link_pendulum(2, lengths, masses, g, theta0, omega0)
    mod.name = "double pendulum"
    return mod


def n_link_chart(lengths: Any) -> tuple[Callable, Callable, Callable]:
    """Hand-written numeric chart of the planar chain (the student path of :class:`ReducedSystem`).

    Returns ``q(u)``, ``J(u)``, ``Jdot_udot(u, ud)`` with particle i at (Σⱼ≤ᵢ Lⱼ sin θⱼ, −Σⱼ≤ᵢ Lⱼ cos θⱼ),
    vectorized (cumulative sums; J is lower block-triangular).

    >>> q, J, Jd = n_link_chart([1.0, 2.0]); q(np.zeros(2))
    array([ 0., -1.,  0., -3.])
    """
    L = np.atleast_1d(np.asarray(lengths, float))
    n = L.size
    low = np.tril(np.ones((n, n)))

    def q(u):
        out = np.empty(2 * n)
        out[0::2] = np.cumsum(L * np.sin(u))
        out[1::2] = -np.cumsum(L * np.cos(u))
        return out

    def J(u):
        out = np.empty((2 * n, n))
        out[0::2] = low * (L * np.cos(u))
        out[1::2] = low * (L * np.sin(u))
        return out

    def Jdot_udot(u, ud):
        w = L * ud * ud
        out = np.empty(2 * n)
        out[0::2] = -np.cumsum(w * np.sin(u))
        out[1::2] = np.cumsum(w * np.cos(u))
        return out

    return q, J, Jdot_udot


def chain_rod_tensions(red, y, t: float = 0.0) -> np.ndarray:
    """Tensions of the rods of a chain simulated in reduced coordinates (positive = pulling).

    From the chart's constraint force Q_C = M q̈ − Q: rod k pulls particle k with f_k = Σ_{j≥k} Q_C,j
    (walking from the tip), and its tension is −f_k·êₖ, êₖ the unit vector from particle k − 1 (or the
    pivot) to particle k. Compare with −λₖLₖ of chapter 03's rods C = ½(|x_b − x_a|² − L²).
    """
    QC = red.constraint_force(t, y)
    x = red.particle_state(y, t)[: red.N * red.dim].reshape(red.N, red.dim)
    f = np.cumsum(QC[::-1], axis=0)[::-1]
    d = np.diff(np.vstack([np.zeros(red.dim), x]), axis=0)
    e = d / np.linalg.norm(d, axis=1)[:, None]
    return -np.einsum("ij,ij->i", f, e)


def spherical_pendulum(theta0: float = 1.0, phi0: float = 0.0, thetadot0: float = 0.0, phidot0: float = 2.0,
                       length: float = 1.0, mass: float = 1.0, g: float = 9.81) -> ReducedModel:
    """A mass on a rod to a 3-D pivot; θ polar from below, φ azimuth. Singular chart at θ = 0, π.

    ``info["Lz"](y)`` = mL² sin²θ φ̇ (conserved); ``info["conical_phidot"](θ)`` = √(g/(L cos θ)).
    """
    L, m = float(_arr(length, 1, "length")[0]), float(_arr(mass, 1, "mass")[0])

    def build():
        import sympy

        th, ph = sympy.symbols("theta phi")
        return (th, ph), [[L * sympy.sin(th) * sympy.cos(ph), L * sympy.sin(th) * sympy.sin(ph),
                           -L * sympy.cos(th)]], None

    info = {"Lz": lambda y: m * L * L * np.sin(y[0]) ** 2 * y[3],
            "conical_phidot": lambda th: np.sqrt(g / (L * np.cos(th)))}
    return ReducedModel("spherical pendulum", ("spherical", L, m, float(g)), np.array([m]), 3,
                        np.array([0.0, 0.0, -g]), np.array([theta0, phi0]), np.array([thetadot0, phidot0]),
                        build, info)


def bead_on_rotating_hoop(theta0: float = 0.3, thetadot0: float = 0.0, radius: float = 1.0, omega: float = 5.0,
                          mass: float = 1.0, g: float = 9.81) -> ReducedModel:
    """A bead on a vertical hoop spinning about the vertical axis at Ω (a time-dependent chart q(θ, t)).

    For RΩ² > g the bottom is unstable and the bead settles around cos θ* = g/(RΩ²), oscillating at
    ω² = Ω² − g²/(R²Ω²) (``info["theta_star"]``, ``info["omega_small"]``). E is not conserved (the
    motor works); the Jacobi integral is.
    """
    R, m = float(_arr(radius, 1, "radius")[0]), float(_arr(mass, 1, "mass")[0])
    W = float(omega)

    def build():
        import sympy

        th, t = sympy.symbols("theta t")
        return (th,), [[R * sympy.sin(th) * sympy.cos(W * t), R * sympy.sin(th) * sympy.sin(W * t),
                        -R * sympy.cos(th)]], t

    info = {}
    if R * W * W > g:
        info = {"theta_star": float(np.arccos(g / (R * W * W))),
                "omega_small": float(np.sqrt(W * W - (g / (R * W)) ** 2))}
    return ReducedModel("bead on a rotating hoop", ("hoop", R, W, m, float(g)), np.array([m]), 3,
                        np.array([0.0, 0.0, -g]), np.array([theta0]), np.array([thetadot0]), build, info)


def cart_pendulum(x0: float = 0.0, theta0: float = 0.5, cart_mass: float = 2.0, mass: float = 1.0,
                  length: float = 1.0, g: float = 9.81, xdot0: float = 0.0, thetadot0: float = 0.0) -> ReducedModel:
    """A pendulum hanging from a cart sliding freely on a horizontal rail.

    ``info["momentum"](y)`` = (M + m)ẋ + mL cos θ θ̇ (conserved); ``info["omega_small"]`` = √(g(M+m)/(ML)).
    """
    Mc, m, L = (float(_arr(v, 1, nm)[0]) for v, nm in ((cart_mass, "cart_mass"), (mass, "mass"), (length, "length")))

    def build():
        import sympy

        x, th = sympy.symbols("x theta")
        return (x, th), [[x, sympy.S.Zero], [x + L * sympy.sin(th), -L * sympy.cos(th)]], None

    info = {"momentum": lambda y: (Mc + m) * y[2] + m * L * np.cos(y[1]) * y[3],
            "omega_small": float(np.sqrt(g * (Mc + m) / (Mc * L)))}
    return ReducedModel("cart pendulum", ("cart", Mc, m, L, float(g)), np.array([Mc, m]), 2, np.array([0.0, -g]),
                        np.array([x0, theta0]), np.array([xdot0, thetadot0]), build, info)


def bead_x_chart(x0: float = 0.0, xdot0: float = 5.0, radius: float = 1.0, mass: float = 1.0,
                 g: float = 9.81) -> ReducedModel:
    """A bead on the lower half of a vertical circle parametrized by x: q = (x, −√(R² − x²)).

    JᵀMJ = mR²/(R² − x²) → ∞ at x = ±R (ORACLES B6): with enough speed (v₀² > 2gR) the bead reaches
    the equator, where this chart must report :class:`pbanim.errors.SingularChartError`.
    """
    R, m = float(_arr(radius, 1, "radius")[0]), float(_arr(mass, 1, "mass")[0])
    if not abs(x0) < R:
        raise InvalidInput(f"x0 must satisfy |x0| < radius = {R}, got {x0}")

    def build():
        import sympy

        x = sympy.Symbol("x")
        return (x,), [[x, -sympy.sqrt(R * R - x * x)]], None

    return ReducedModel("bead, x chart", ("bead_x", R, m, float(g)), np.array([m]), 2, np.array([0.0, -g]),
                        np.array([x0]), np.array([xdot0]), build, {"radius": R})


@dataclass
class MaximalChain:
    """The same chain in maximal coordinates (chapter 03): particles, rods, and a scene with gravity."""

    system: Any
    constraints: Any
    scene: Any
    rods: Any

    def state(self) -> np.ndarray:
        return self.system.state()


def maximal_chain(model: ReducedModel, solver: str = "auto", stabilization: str = "none") -> MaximalChain:
    """Particles at q(u0) with velocities J u̇0, rods of the model's lengths to the pivot (ORACLES G1).

    Rod k joins particle k − 1 (the pivot at the origin for k = 0) to particle k, so the chapter-03
    multiplier λₖ of C = ½(|Δx|² − L²) gives the tension −λₖLₖ (compare :func:`chain_rod_tensions`).
    """
    from ..constraints import Constraints, Distance
    from ..particles.system import Gravity, ParticleSystem
    from ..scene import Scene

    if "lengths" not in model.info:
        raise InvalidInput(f"model must be an n-link pendulum, got {model.name!r}")
    L = model.info["lengths"]
    n = L.size
    q, J, _ = n_link_chart(L)
    ps = ParticleSystem(q(model.u0).reshape(n, 2), (J(model.u0) @ model.udot0).reshape(n, 2), model.masses)
    rods = Distance(np.stack([np.arange(-1, n - 1), np.arange(n)], axis=1), lengths=L, anchors=np.zeros(2))
    eff = Constraints([rods], solver=solver, stabilization=stabilization)
    return MaximalChain(ps, eff, Scene(ps, [Gravity(model.g), eff]), rods)
