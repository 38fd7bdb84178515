"""Canonical collision systems with their exact answers (chapter 06, ORACLES D1–D3).

=====================  ===========================================================================
model                  exact answer
=====================  ===========================================================================
``bouncing_ball``      apex heights h_k = ε^(2k) h₀, impact speeds εᵏ√(2gh₀) (k ≥ 1: after k−1
                       bounces the k-th impact is at speed ε^(k−1)√(2gh₀)), Zeno time
                       t∞ = √(2h₀/g)(1+ε)/(1−ε)
``newtons_cradle``     sequential (0, …, 0, v₀); simultaneous, three balls, (−v₀/3, 2v₀/3, 2v₀/3)
``oblique_spheres``    (v₂′ − v₁′)·n = −ε(v₂ − v₁)·n, tangential parts unchanged, momentum conserved,
                       ΔE = −½ μ_red (1 − ε²) ((v₂ − v₁)·n)²,  μ_red = m₁m₂/(m₁+m₂)
``falling_rod``        j = −(1+ε) v_rel·n / (1/m + (r×n)²/I) for a rod hitting the ground at one end
``spinning_ball``      stick iff (2/7)|u_t| ≤ μ(1+ε)|v_n| (solid sphere); post-impact v and ω
=====================  ===========================================================================
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..collision.shapes import Plane, check_friction, check_restitution
from ..errors import InvalidInput, check_count

__all__ = ["BouncingBall", "bouncing_ball", "NewtonsCradle", "newtons_cradle", "ObliqueSpheres",
           "oblique_spheres", "FallingRod", "falling_rod", "SpinningBall", "spinning_ball"]


@dataclass
class BouncingBall:
    """A point mass dropped from rest at height h0 onto the plane y = 0 (2-D), restitution ε (ORACLES D1)."""

    h0: float
    restitution: float
    g: float

    def apex_heights(self, k) -> np.ndarray:
        """h_k = ε^(2k) h₀ after the k-th bounce."""
        return self.restitution ** (2 * np.asarray(k, float)) * self.h0

    def impact_speeds(self, k) -> np.ndarray:
        """Speed just before impact number k = 1, 2, …: ε^(k−1) √(2 g h₀)."""
        return self.restitution ** (np.asarray(k, float) - 1) * np.sqrt(2 * self.g * self.h0)

    def impact_times(self, k) -> np.ndarray:
        """t_k = t₁ (1 + 2ε(1 − ε^(k−1))/(1 − ε)), t₁ = √(2h₀/g)."""
        e, k = self.restitution, np.asarray(k, float)
        t1 = np.sqrt(2 * self.h0 / self.g)
        return t1 * (1 + 2 * e * (1 - e ** (k - 1)) / (1 - e))

    @property
    def zeno_time(self) -> float:
        """t∞ = √(2h₀/g)(1+ε)/(1−ε) (infinite for ε = 1)."""
        e = self.restitution
        return float(np.sqrt(2 * self.h0 / self.g) * (1 + e) / (1 - e)) if e < 1 else np.inf

    def energy(self) -> float:
        """Initial energy per unit mass, g h₀."""
        return self.g * self.h0

    def measured_apex_heights(self, res, drop: float = 1e-9) -> np.ndarray:
        """Apex heights of a simulated run, from the energy plateaus E/(m g) between impacts.

        In free flight E is constant (RK4 is exact on the parabola), so each impact that loses more than
        ``drop``·E₀ starts a new plateau; the apex of flight k is its energy over m g (mass 1 here).
        """
        E = np.asarray(res.diagnostics["energy"])
        jumps = np.flatnonzero(np.diff(E) < -drop * E[0])
        return E[jumps + 1] / self.g

    def scene(self, rest_velocity: float | None = None, mode: str = "sequential"):
        """A particle scene: ParticleSystem, Gravity and Collisions with the ground plane."""
        from ..collision.scene import Collisions
        from ..particles.system import Gravity, ParticleSystem
        from ..scene import Scene

        ps = ParticleSystem([[0.0, self.h0]], [[0.0, 0.0]], masses=1.0)
        col = Collisions(obstacles=[Plane([0.0, 1.0])], restitution=self.restitution, gravity=self.g,
                         rest_velocity=rest_velocity, mode=mode)
        return Scene(ps, [Gravity([0.0, -self.g]), col])


def bouncing_ball(h0: float = 1.0, restitution: float = 0.8, g: float = 9.81) -> BouncingBall:
    """The bouncing ball of ORACLES D1.

    >>> bb = bouncing_ball(1.0, 0.5, 9.81)
    >>> float(bb.apex_heights(1)), round(float(bb.zeno_time / np.sqrt(2 / 9.81)), 12)
    (0.25, 3.0)
    """
    if not (np.isfinite(h0) and h0 > 0):
        raise InvalidInput(f"h0 must be a positive height, got {h0}")
    return BouncingBall(float(h0), check_restitution(restitution), float(g))


@dataclass
class NewtonsCradle:
    """n equal touching balls on the x axis, the first moving at v₀ towards the others (ORACLES D2)."""

    n: int
    v0: float
    radius: float
    mass: float

    def positions(self) -> np.ndarray:
        return np.array([[2.0 * self.radius * i, 0.0, 0.0] for i in range(self.n)])

    def velocities(self) -> np.ndarray:
        v = np.zeros((self.n, 3))
        v[0, 0] = self.v0
        return v

    def expected(self, mode: str) -> np.ndarray:
        """x-velocities after the impact: sequential (0, …, 0, v₀); simultaneous for n = 3 (−1, 2, 2)v₀/3."""
        if mode == "sequential":
            out = np.zeros(self.n)
            out[-1] = self.v0
            return out
        if mode == "simultaneous" and self.n == 3:
            return np.array([-1.0, 2.0, 2.0]) * self.v0 / 3
        raise InvalidInput(f"closed form known for mode 'sequential' (any n) or 'simultaneous' (n = 3), "
                         f"got mode {mode!r}, n = {self.n}")


def newtons_cradle(n: int = 3, v0: float = 1.0, radius: float = 0.5, mass: float = 1.0) -> NewtonsCradle:
    """Newton's cradle of ORACLES D2 (ε = 1, equal masses, touching).

    >>> newtons_cradle(3, 1.5).expected("simultaneous")
    array([-0.5,  1. ,  1. ])
    """
    n = check_count("n", n, 2)
    return NewtonsCradle(int(n), float(v0), float(radius), float(mass))


@dataclass
class ObliqueSpheres:
    """Two smooth spheres colliding obliquely (ORACLES D3); n is the unit line of centres from 1 to 2."""

    m1: float
    m2: float
    v1: np.ndarray
    v2: np.ndarray
    n: np.ndarray
    restitution: float

    def after(self) -> tuple[np.ndarray, np.ndarray]:
        """Exact post-impact velocities: only the normal components change."""
        e, n = self.restitution, self.n
        u = (self.v2 - self.v1) @ n
        j = -(1 + e) * u / (1 / self.m1 + 1 / self.m2)      # impulse on sphere 2 along n
        return self.v1 - j / self.m1 * n, self.v2 + j / self.m2 * n

    def energy_change(self) -> float:
        """ΔE = −½ μ_red (1 − ε²) ((v₂ − v₁)·n)²."""
        mu = self.m1 * self.m2 / (self.m1 + self.m2)
        return -0.5 * mu * (1 - self.restitution**2) * float((self.v2 - self.v1) @ self.n) ** 2


def oblique_spheres(m1=1.0, m2=2.0, v1=(1.0, 0.5, 0.0), v2=(-0.5, 0.2, 0.1), n=(1.0, 0.3, 0.2),
                    restitution: float = 0.6) -> ObliqueSpheres:
    """Oblique collision of smooth spheres; ``n`` (from sphere 1 to 2) is normalized here.

    >>> s = oblique_spheres(1.0, 1.0, (1, 0, 0), (0, 0, 0), (1, 0, 0), 1.0); s.after()[1]
    array([1., 0., 0.])
    """
    n = np.asarray(n, float)
    return ObliqueSpheres(float(m1), float(m2), np.asarray(v1, float), np.asarray(v2, float),
                          n / np.linalg.norm(n), check_restitution(restitution))


@dataclass
class FallingRod:
    """A thin rod (mass m, length ℓ, inertia I = mℓ²/12) hitting the ground z = 0 with one end.

    ``angle`` is the rod's inclination from the horizontal; its lower end touches the ground.
    """

    mass: float
    length: float
    angle: float
    v: np.ndarray
    omega: np.ndarray
    restitution: float

    @property
    def inertia(self) -> np.ndarray:
        """Body inertia of a thin rod along body x: diag(≈0, mℓ²/12, mℓ²/12) (tiny axial moment)."""
        I = self.mass * self.length**2 / 12
        return np.diag([1e-3 * I, I, I])

    def rotation(self) -> np.ndarray:
        """R: body x axis tilted down by ``angle`` about world y (so the end −ℓ/2 is the lowest)."""
        c, s = np.cos(self.angle), np.sin(self.angle)
        return np.array([[c, 0.0, -s], [0.0, 1.0, 0.0], [s, 0.0, c]])

    def centre(self) -> np.ndarray:
        return np.array([0.0, 0.0, 0.5 * self.length * np.sin(self.angle)])

    def contact_point(self) -> np.ndarray:
        return self.centre() - 0.5 * self.length * self.rotation()[:, 0]

    def impulse(self) -> float:
        """j = −(1+ε) v_rel·n / (1/m + (r×n)·I⁻¹(r×n)) with n = ẑ (ORACLES D3)."""
        n = np.array([0.0, 0.0, 1.0])
        r = self.contact_point() - self.centre()
        u = self.v + np.cross(self.omega, r)
        R = self.rotation()
        Iinv = R @ np.linalg.inv(self.inertia) @ R.T
        rn = np.cross(r, n)
        return float(-(1 + self.restitution) * (u @ n) / (1 / self.mass + rn @ Iinv @ rn))


def falling_rod(mass=2.0, length=1.0, angle=0.5, v=(0.3, 0.0, -2.0), omega=(0.0, 0.7, 0.0),
                restitution: float = 0.5) -> FallingRod:
    """The rod of ORACLES D3, hitting the ground at one end.

    >>> rod = falling_rod(1.0, 1.0, 0.0, (0, 0, -1.0), (0, 0, 0), 0.0)   # flat rod, end impact: j = m/4
    >>> round(rod.impulse(), 12)
    0.25
    """
    return FallingRod(float(mass), float(length), float(angle), np.asarray(v, float),
                      np.asarray(omega, float), check_restitution(restitution))


@dataclass
class SpinningBall:
    """A solid ball (I = 2/5 mR²) hitting the ground z = 0 with velocity (vx, 0, −vz) and spin ω_y."""

    mass: float
    radius: float
    v: np.ndarray
    omega: np.ndarray
    restitution: float
    friction: float

    def slip_velocity(self) -> float:
        """u_t = v_x − R ω_y, the contact point's velocity along x."""
        return float(self.v[0] - self.radius * self.omega[1])

    def sticks(self) -> bool:
        """Stick iff the impulse −(2/7) m u_t lies in the cone: (2/7)|u_t| ≤ μ(1+ε)|v_z|."""
        return bool(2 / 7 * abs(self.slip_velocity()) <= self.friction * (1 + self.restitution) * abs(self.v[2]))

    def after(self) -> tuple[np.ndarray, np.ndarray]:
        """Exact post-impact (v, ω) from the stick/slip analysis."""
        m, R, e, mu = self.mass, self.radius, self.restitution, self.friction
        jn = (1 + e) * m * (-self.v[2])
        ut = self.slip_velocity()
        jx = -2 / 7 * m * ut if self.sticks() else -mu * jn * np.sign(ut)
        I = 0.4 * m * R * R
        v = np.array([self.v[0] + jx / m, self.v[1], self.v[2] + jn / m])
        w = np.array(self.omega, float).copy()
        w[1] += -R * jx / I          # Δω = I⁻¹ (r × J), r = (0, 0, −R)
        return v, w


def spinning_ball(mass=1.0, radius=0.1, v=(2.0, 0.0, -3.0), omega=(0.0, -10.0, 0.0), restitution=0.5,
                  friction=0.3) -> SpinningBall:
    """The spinning ball hitting the ground (friction impulse, stick vs slip).

    >>> spinning_ball(v=(1.0, 0, -1.0), omega=(0, 10.0, 0), friction=0.5).sticks()    # rolling: u_t = 0
    True
    """
    return SpinningBall(float(mass), float(radius), np.asarray(v, float), np.asarray(omega, float),
                        check_restitution(restitution), check_friction(friction))
