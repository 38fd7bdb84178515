"""Canonical constrained particle systems with their exact answers (chapter 03; ORACLES B1–B5).

=====================  =====================================================================
model                  exact answer
=====================  =====================================================================
``bead_on_circle``     tension m(v²/R + g cos θ) (θ from the bottom); 3mg at the bottom after
                       release from horizontal (energy: v² = 2gR)
``hanging_chain``      at rest, tension in link k = g·Σ(masses below k); swinging variant
``cloth_patch``        grid of rods pinned at two corners (no closed form: solvers cross-checked)
``random_chain`` /     random masses, lengths and directions for cross-solver agreement tests
``random_tree``
``redundant_*``        the same rod twice; x = 0, y = 0, x + y = 0; x = 0 and x = 1 (inconsistent)
=====================  =====================================================================
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..constraints import Distance, FixedPoint, LinearCombination, OnCircle
from ..particles.system import ParticleSystem
from ..errors import InvalidInput, check_count, check_number

__all__ = ["ConstrainedModel", "bead_on_circle", "hanging_chain", "cloth_patch", "random_chain", "random_tree",
           "redundant_rod", "redundant_xy", "inconsistent_x"]


@dataclass
class ConstrainedModel:
    """A particle system, its constraints, gravity g, and model-specific exact answers in ``info``."""

    system: ParticleSystem
    constraints: list
    g: np.ndarray
    info: dict = field(default_factory=dict)


def bead_on_circle(radius: float = 1.0, mass: float = 1.0, g: float = 9.81, theta0: float = np.pi / 2,
                   omega0: float = 0.0, center=(0.0, 0.0)) -> ConstrainedModel:
    """A bead on a vertical circle (a Cartesian pendulum); θ from the bottom, θ̇ = omega0 at start.

    ``info["tension"](y)`` = m(v²/R + g cos θ) evaluated at state y; ``info["theta"](y)``.

    >>> mod = bead_on_circle(theta0=0.0, omega0=2.0)
    >>> float(mod.info["tension"](mod.system.state()))   # 1·(4/1 + 9.81)
    13.81
    """
    if not radius > 0 or not mass > 0:
        raise InvalidInput(f"radius and mass must be positive, got {radius}, {mass}")
    c = np.asarray(center, float)
    x0 = c + radius * np.array([np.sin(theta0), -np.cos(theta0)])
    v0 = radius * omega0 * np.array([np.cos(theta0), np.sin(theta0)])
    ps = ParticleSystem([x0], [v0], masses=mass)

    def theta(y):
        r = y[:2] - c
        return np.arctan2(r[0], -r[1])

    def tension(y):
        r, v = y[:2] - c, y[2:4]
        R = np.linalg.norm(r)
        return mass * (v @ v / R + g * (-r[1] / R))

    return ConstrainedModel(ps, [OnCircle([0], c, radius)], np.array([0.0, -g]),
                            {"radius": radius, "mass": mass, "tension": tension, "theta": theta})


def hanging_chain(n: int, link_length: float = 1.0, masses=1.0, mass_ratio: float | None = None,
                  g: float = 9.81, angle: float = 0.0, dim: int = 2) -> ConstrainedModel:
    """n particles hung from the origin by n rods; link k joins particle k − 1 (the anchor for k = 0) to k.

    ``angle`` tilts the straight chain from the downward vertical (0: hanging at rest; π/2: horizontal,
    released to swing). ``mass_ratio`` r gives alternating masses 1, r, 1, r, ... (the hard case).
    ``info["tension_at_rest"]`` = g·Σ_{j ≥ k} m_j, the tension of link k hanging at rest (ORACLES B3).

    >>> mod = hanging_chain(3, masses=[1.0, 2.0, 3.0], g=10.0)
    >>> mod.info["tension_at_rest"]
    array([60., 50., 30.])
    """
    n = check_count("n", n, 1, 1_000_000)
    m = np.array([1.0 if i % 2 == 0 else mass_ratio for i in range(n)]) if mass_ratio is not None else \
        np.broadcast_to(np.asarray(masses, float), (n,)).copy()
    down = np.zeros(dim)
    down[1] = -1.0
    direction = np.cos(angle) * down
    direction[0] += np.sin(angle)
    x = np.outer(np.arange(1, n + 1) * link_length, direction)
    ps = ParticleSystem(x, masses=m)
    pairs = np.stack([np.arange(n), np.arange(-1, n - 1)], axis=1)
    rods = Distance(pairs, lengths=link_length, anchors=np.zeros(dim))
    gv = g * down
    return ConstrainedModel(ps, [rods], gv, {"tension_at_rest": g * np.cumsum(m[::-1])[::-1],
                                             "link_length": link_length, "rods": rods})


def cloth_patch(nx: int = 6, ny: int = 6, spacing: float = 0.1, mass: float = 0.01, shear: bool = False,
                jitter: float = 0.0, sag: float = 0.1, seed: int = 0) -> ConstrainedModel:
    """A 3-D cloth of nx × ny particles near the horizontal plane z = 0, rods on the grid edges (and
    diagonals if ``shear``) at their initial lengths, nailed at the two corners of the edge y = 0; gravity −z.

    The patch starts sagging along x, z = −sag·width·sin(πi/(nx − 1)): a *taut* straight row of rods between
    two nails would be redundant (the nails fix the sum of its lengths), so the row between the pins is
    given slack. ``jitter`` adds random offsets (in units of the spacing).

    >>> mod = cloth_patch(3, 3); mod.constraints[0].m, mod.info["pins"]
    (12, [0, 6])
    """
    nx, ny = check_count("nx", nx, 2, 1000), check_count("ny", ny, 2, 1000)
    rng = np.random.default_rng(seed)
    I, Jg = np.meshgrid(np.arange(nx), np.arange(ny), indexing="ij")
    idx = I * ny + Jg
    x = np.stack([I.ravel() * spacing, Jg.ravel() * spacing, np.zeros(nx * ny)], axis=1)
    x[:, 2] = -sag * spacing * (nx - 1) * np.sin(np.pi * I.ravel() / (nx - 1))
    x += jitter * spacing * rng.normal(size=x.shape)
    pairs = [np.stack([idx[:-1, :].ravel(), idx[1:, :].ravel()], 1), np.stack([idx[:, :-1].ravel(), idx[:, 1:].ravel()], 1)]
    if shear:
        pairs += [np.stack([idx[:-1, :-1].ravel(), idx[1:, 1:].ravel()], 1)]
    ps = ParticleSystem(x, masses=mass)
    pins = [int(idx[0, 0]), int(idx[-1, 0])]
    return ConstrainedModel(ps, [Distance(np.concatenate(pairs)), FixedPoint(pins)], np.array([0.0, 0.0, -9.81]),
                            {"pins": pins, "shape": (nx, ny)})


def _random_masses(rng, n, spread):
    n = check_count("n", n, 1, 1_000_000)
    spread = check_number("spread", spread, low=0.0, high=100.0) + 0.0   # 10^±spread finite; −0.0 → 0.0
    return 10.0 ** rng.uniform(-spread, spread, n)


def random_chain(n: int, rng: np.random.Generator, dim: int = 2, spread: float = 1.0) -> ConstrainedModel:
    """A chain hung from the origin with random masses (10^±spread), link lengths, directions, velocities."""
    masses = _random_masses(rng, n, spread)
    n = int(n)
    if dim not in (2, 3):
        raise InvalidInput(f"dim must be 2 or 3, got {dim}")
    steps = rng.normal(size=(n, dim))
    steps *= rng.uniform(0.5, 2.0, n)[:, None] / np.linalg.norm(steps, axis=1)[:, None]
    x = np.cumsum(steps, axis=0)
    ps = ParticleSystem(x, rng.normal(size=(n, dim)), masses=masses)
    pairs = np.stack([np.arange(n), np.arange(-1, n - 1)], axis=1)
    return ConstrainedModel(ps, [Distance(pairs, anchors=np.zeros(dim))], -9.81 * np.eye(dim)[1], {})


def random_tree(n: int, rng: np.random.Generator, dim: int = 2, spread: float = 1.0) -> ConstrainedModel:
    """A random tree: particle i > 0 hangs by a rod from a random earlier particle; particle 0 is nailed."""
    masses = _random_masses(rng, n, spread)
    n = int(n)
    if dim not in (2, 3):
        raise InvalidInput(f"dim must be 2 or 3, got {dim}")
    parent = np.array([-1] + [int(rng.integers(0, i)) for i in range(1, n)])
    x = np.zeros((n, dim))
    for i in range(1, n):
        d = rng.normal(size=dim)
        x[i] = x[parent[i]] + rng.uniform(0.5, 2.0) * d / np.linalg.norm(d)
    ps = ParticleSystem(x, rng.normal(size=(n, dim)), masses=masses)
    cons = [FixedPoint([0])]
    if n > 1:
        cons.insert(0, Distance(np.stack([np.arange(1, n), parent[1:]], axis=1)))
    return ConstrainedModel(ps, cons, -9.81 * np.eye(dim)[1], {"parent": parent})


def redundant_rod() -> ConstrainedModel:
    """A pendulum whose rod is declared twice (ORACLES B4); ``info["reference"]`` has it once."""
    ps = ParticleSystem([[0.6, -0.8]], [[0.8, 0.6]], masses=2.0)
    rod = lambda: Distance([[0, -1]], lengths=1.0, anchors=[0.0, 0.0])  # noqa: E731
    return ConstrainedModel(ps, [rod(), rod()], np.array([0.0, -9.81]), {"reference": [rod()]})


def redundant_xy() -> ConstrainedModel:
    """x = 0, y = 0 and x + y = 0 on one particle (ORACLES B4); ``info["reference"]`` is x = 0, y = 0."""
    ps = ParticleSystem([[0.0, 0.0]], [[0.0, 0.0]], masses=1.5)
    three = LinearCombination([[0, 0], [0, 0], [0, 0]], [[0, 0], [1, 1], [0, 1]],
                              [[1.0, 0.0], [1.0, 0.0], [1.0, 1.0]])
    ref = LinearCombination([[0], [0]], [[0], [1]], [[1.0], [1.0]])
    return ConstrainedModel(ps, [three], np.array([0.0, -9.81]), {"reference": [ref]})


def inconsistent_x() -> ConstrainedModel:
    """x = 0 and x = 1 on one particle: no configuration satisfies both (ORACLES B4)."""
    ps = ParticleSystem([[0.5, 0.0]], masses=1.0)
    return ConstrainedModel(ps, [LinearCombination([[0], [0]], [[0], [0]], [[1.0], [1.0]], [0.0, 1.0])],
                            np.array([0.0, -9.81]), {})
