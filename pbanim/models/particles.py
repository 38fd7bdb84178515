"""Canonical particle systems with exact answers (chapter 01).

===============================  ==================================================================
model                            exact answer
===============================  ==================================================================
:func:`projectile_drag_model`    v(t) = v_T + (v₀ − v_T) e^(−k t/m),  v_T = m g / k
                                 x(t) = x₀ + v_T t + (v₀ − v_T)(m/k)(1 − e^(−k t/m));  k → 0: free fall
:func:`two_body_spring_model`    separation l(t) = r + A cos(ω t), ω = √(k (m₁ + m₂)/(m₁ m₂)),
                                 centre of mass at rest, energy ½ k A²
:func:`hanging_net`              a rectangular mass-spring net (structural + shear springs) hung from
                                 its top corners by anchor springs; stiff at large k_s (no closed form:
                                 used for stability, momentum and energy checks)
===============================  ==================================================================

Each returns a :class:`ParticleModel`: the system, its declared effects, a ready :class:`Scene`, and
``exact(t)`` where a closed form exists. References: Witkin & Baraff, *Physically Based Modeling*
(SIGGRAPH 2001), "Particle System Dynamics"; Baraff & Witkin, "Large Steps in Cloth Simulation" (1998).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Callable

import numpy as np

from ..particles.system import AnchorSprings, DampedSprings, Drag, Gravity, ParticleSystem
from ..scene import Scene
from ..errors import InvalidInput

__all__ = ["ParticleModel", "projectile_drag_model", "two_body_spring_model", "hanging_net"]


@dataclass
class ParticleModel:
    """A particle system, its effects and (where known) its exact solution.

    Attributes
    ----------
    name : str
    system : ParticleSystem
    effects : list of Effect
    exact : callable or None
        ``exact(t) -> dict`` of exact quantities at the times t (array).
    params : dict
        The physical parameters (and derived ones such as ``omega``, ``v_terminal``).
    """

    name: str
    system: ParticleSystem
    effects: list
    exact: Callable[[np.ndarray], dict] | None = None
    params: dict[str, Any] = field(default_factory=dict)

    def scene(self) -> Scene:
        """A fresh :class:`Scene` of this model."""
        return Scene(self.system, self.effects)


def projectile_drag_model(mass: float = 1.0, drag: float = 0.5, g: Any = (0.0, -9.81),
                          position: Any = (0.0, 0.0), velocity: Any = (10.0, 10.0)) -> ParticleModel:
    """One particle under gravity and viscous drag −k v, with its closed form.

    Examples
    --------
    >>> model = projectile_drag_model(mass=2.0, drag=1.0, velocity=(3.0, 0.0))
    >>> model.params["v_terminal"]
    array([  0.  , -19.62])
    >>> out = model.exact(np.array([0.0])); out["v"][0]
    array([3., 0.])
    """
    m, k = float(mass), float(drag)
    if not (np.isfinite(m) and m > 0):
        raise InvalidInput(f"mass must be positive, got {mass}")
    if not (np.isfinite(k) and k >= 0):
        raise InvalidInput(f"drag must be finite and >= 0, got {drag}")
    gv = np.asarray(g, float)
    x0 = np.asarray(position, float)
    v0 = np.asarray(velocity, float)
    ps = ParticleSystem(x0[None], v0[None], masses=m)
    effects = [Gravity(gv)] + ([Drag(k)] if k > 0 else [])
    vT = m * gv / k if k > 0 else np.full_like(gv, np.inf)

    def exact(t):
        t = np.asarray(t, float)[:, None]
        if k == 0:
            return {"x": x0 + v0 * t + 0.5 * gv * t * t, "v": v0 + gv * t}
        e = np.exp(-k * t / m)
        return {"x": x0 + vT * t + (v0 - vT) * (m / k) * (1.0 - e), "v": vT + (v0 - vT) * e}

    return ParticleModel("projectile_drag", ps, effects, exact,
                         {"mass": m, "drag": k, "g": gv, "v_terminal": vT, "tau": m / k if k > 0 else np.inf})


def two_body_spring_model(m1: float = 1.0, m2: float = 3.0, stiffness: float = 10.0, rest_length: float = 1.0,
                          amplitude: float = 0.2, dim: int = 2) -> ParticleModel:
    """Two masses on one undamped spring, released at rest with stretch ``amplitude``.

    ω = √(k (m₁ + m₂)/(m₁ m₂)); the separation is l(t) = r + A cos(ω t) and the centre of mass stays
    at the origin.

    Examples
    --------
    >>> model = two_body_spring_model(m1=1.0, m2=1.0, stiffness=2.0)
    >>> float(model.params["omega"])
    2.0
    """
    k, r, A = float(stiffness), float(rest_length), float(amplitude)
    if not (k > 0 and np.isfinite(k)):
        raise InvalidInput(f"stiffness must be positive, got {stiffness}")
    for nm, v in (("m1", m1), ("m2", m2)):
        if not (isinstance(v, (int, float, np.integer, np.floating)) and np.isfinite(v) and v > 0):
            raise InvalidInput(f"{nm} must be a positive finite mass, got {v}")
    for nm, v in (("rest_length", r), ("amplitude", A)):
        if not np.isfinite(v):
            raise InvalidInput(f"{nm} must be finite, got {v}")
    with np.errstate(over="ignore", divide="ignore", under="ignore"):
        w2 = np.float64(k) * (np.float64(m1) + m2) / (np.float64(m1) * m2)
    if not np.isfinite(w2):
        raise InvalidInput(f"masses m1 = {m1}, m2 = {m2} and stiffness {k} give no finite frequency ω; use moderate units")
    if not (r + A > 0):
        raise InvalidInput(f"rest_length + amplitude must be positive (a spring of positive length), got {r + A}")
    M = m1 + m2
    L0 = r + A
    x = np.zeros((2, dim))
    x[0, 0], x[1, 0] = -L0 * m2 / M, L0 * m1 / M   # centre of mass at the origin
    ps = ParticleSystem(x, masses=[m1, m2])
    omega = np.sqrt(k * M / (m1 * m2))

    def exact(t):
        t = np.asarray(t, float)
        return {"length": r + A * np.cos(omega * t), "energy": 0.5 * k * A * A + 0 * t}

    return ParticleModel("two_body_spring", ps,
                         [DampedSprings([[0, 1]], stiffness=k, damping=0.0, rest_length=r)], exact,
                         {"omega": omega, "period": 2 * np.pi / omega, "energy": 0.5 * k * A * A})


def hanging_net(nx: int = 10, ny: int = 10, spacing: float = 0.1, mass: float = 0.01,
                stiffness: float = 1e3, damping: float = 0.0, shear: bool = True,
                anchor_stiffness: float | None = None, gravity: bool = True, drag: float = 0.0) -> ParticleModel:
    """A rectangular mass-spring net in the x–y plane (3-D), hung from its two top corners.

    Particle (i, j) (column i, row j, row 0 at the top) is number ``j * nx + i``, at
    (i·spacing, −j·spacing, 0). Structural springs join grid neighbours, shear springs (optional) the
    diagonals; rest lengths are the initial lengths. The top corners are held by zero-length anchor
    springs (default stiffness 10·``stiffness``). ``params["omega_max_bound"]`` is the Gershgorin bound
    √(2·(springs per node)·k_s/m) on the stiffest frequency: explicit methods need h·ω < 2, implicit Euler
    with the sparse Jacobian does not.

    Examples
    --------
    >>> net = hanging_net(4, 3)
    >>> net.system.N, net.effects[0].S
    (12, 29)
    >>> net.scene().pipeline
    ('springs', 'anchors', 'gravity', 'integrate')
    """
    if not all(isinstance(k, (int, np.integer)) and not isinstance(k, bool) and k >= 2 for k in (nx, ny)):
        raise InvalidInput(f"nx and ny must be >= 2 (a net), whole numbers, got nx={nx}, ny={ny}")
    nx, ny = int(nx), int(ny)
    if nx * ny > 1_000_000:
        raise InvalidInput(f"nx·ny must be at most 1e6 particles, got nx={nx}, ny={ny}")
    if not (spacing > 0 and mass > 0 and stiffness > 0):
        raise InvalidInput(f"spacing, mass and stiffness must be positive, got {spacing}, {mass}, {stiffness}")
    i, j = np.meshgrid(np.arange(nx), np.arange(ny))
    i, j = i.ravel(), j.ravel()
    idx = j * nx + i
    x = np.stack([i * spacing, -j * spacing, np.zeros_like(i, dtype=float)], axis=1).astype(float)
    grid = idx.reshape(ny, nx)
    pairs = [np.stack([grid[:, :-1].ravel(), grid[:, 1:].ravel()], 1),
             np.stack([grid[:-1, :].ravel(), grid[1:, :].ravel()], 1)]
    if shear:
        pairs += [np.stack([grid[:-1, :-1].ravel(), grid[1:, 1:].ravel()], 1),
                  np.stack([grid[:-1, 1:].ravel(), grid[1:, :-1].ravel()], 1)]
    pairs = np.concatenate(pairs)
    ps = ParticleSystem(x, masses=mass)
    ka = 10.0 * stiffness if anchor_stiffness is None else float(anchor_stiffness)
    effects: list = [DampedSprings(pairs, stiffness=stiffness, damping=damping),
                     AnchorSprings([0, nx - 1], stiffness=ka, damping=damping)]
    if gravity:
        effects.append(Gravity([0.0, -9.81, 0.0]))
    if drag > 0:
        effects.append(Drag(drag))
    return ParticleModel("hanging_net", ps, effects, None,
                         {"nx": nx, "ny": ny, "spacing": spacing, "mass": mass, "stiffness": stiffness,
                          "damping": damping, "anchor_stiffness": ka,
                          "omega_max_bound": float(np.sqrt(2 * (4 + 4 * shear) * max(stiffness, ka / 2) / mass))})
