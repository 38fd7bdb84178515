"""The body protocol: what impulses, constraints and contacts ask of a system (chapters 05–07).

Collision impulses (ch06), resting contact and friction (ch07) and, later, the articulated bodies act on
a system through one small interface, the same for point masses, rigid bodies and body trees. With M the
generalized mass and W = M⁻¹, a body i has generalized velocity uᵢ (particles: vᵢ ∈ ℝᵈ; rigid bodies:
(vᵢ, ωᵢ) ∈ ℝ⁶), and an impulse j applied at a world point p on body i changes it by

    Δuᵢ = Wᵢ Gᵢ(p)ᵀ j,     particles Gᵢ = I,   rigid bodies Gᵢ(p)ᵀ j = (j, (p − xᵢ) × j),

so a contact Jacobian row is n·Gᵢ(p), the Delassus matrix is J W Jᵀ, and the point moves with
ṗ = Gᵢ(p) uᵢ. Body index −1 is the static world (W = 0, ṗ = 0) everywhere.

=============================================  =========================================================
member                                         meaning
=============================================  =========================================================
``kind``                                       "particles" | "rigid" | "articulated": which Jacobian
                                               rows the contact assembly builds
``N``, ``dof``                                 number of bodies; components of each uᵢ (d or 6)
``generalized_velocity(y)``                    u, shape (N, dof)
``inverse_mass_blocks(y)``                     Wᵢ per body, shape (N, dof, dof) (world frame)
``apply_inverse_mass(y, G)``                   W G for generalized impulses G (N, dof) → (N, dof)
``point_velocity(y, body_idx, points)``        ṗ of world points (m, 3) moving with the bodies
``apply_impulses(y, body_idx, points, j)``     a new state with impulses j (m, 3) applied at the points
=============================================  =========================================================

A system takes part by subclassing :class:`Bodies` (or ``Bodies.register(cls)`` for a class that
already has the members). :func:`require_bodies` is the one check at a boundary: a system that is not a
``Bodies`` fails with :class:`~pbanim.errors.BodyProtocolError` naming the members it lacks, instead of
an ``AttributeError`` deep inside a solver.
"""

from __future__ import annotations

import abc

import numpy as np

from .contracts import Anything, Spec, Text, contract
from .errors import BodyProtocolError

__all__ = ["Bodies", "BODY_MEMBERS", "require_bodies", "BodySystem"]

#: The members of the body protocol (the names :class:`~pbanim.errors.BodyProtocolError` reports).
BODY_MEMBERS = ("kind", "N", "dof", "generalized_velocity", "inverse_mass_blocks", "apply_inverse_mass",
                "point_velocity", "apply_impulses")


class Bodies(abc.ABC):
    """Base class of every system impulses, constraints and contacts act on (see the module docstring)."""

    kind: str = ""
    N: int
    dof: int

    @abc.abstractmethod
    def generalized_velocity(self, y: np.ndarray) -> np.ndarray:
        """u, shape (N, dof)."""

    @abc.abstractmethod
    def inverse_mass_blocks(self, y: np.ndarray) -> np.ndarray:
        """The inverse-mass block Wᵢ of each body in world axes, shape (N, dof, dof)."""

    def apply_inverse_mass(self, y: np.ndarray, G: np.ndarray) -> np.ndarray:
        """W G for generalized impulses G of shape (N, dof) (default: the blocks times G)."""
        return np.einsum("nij,nj->ni", self.inverse_mass_blocks(y), np.asarray(G, dtype=float))

    @abc.abstractmethod
    def point_velocity(self, y: np.ndarray, body_idx, points_world) -> np.ndarray:
        """ṗ of world points (m, 3) moving with bodies ``body_idx`` (m,); zero rows for −1 (the world)."""

    @abc.abstractmethod
    def apply_impulses(self, y: np.ndarray, body_idx, points_world, impulses) -> np.ndarray:
        """A new state with impulses (m, 3) applied at world points (m, 3) of bodies ``body_idx`` (m,).

        Repeated indices accumulate; impulses on the world (−1) change nothing.
        """


@contract(system=Anything("the object under test: any object is answered (itself, or BodyProtocolError)"),
          who=Text(nonempty=True))
def require_bodies(system, who: str) -> Bodies:
    """Return ``system`` if it implements the body protocol, else raise :class:`BodyProtocolError`.

    ``who`` names the caller in the message (e.g. ``"Collisions"``), which lists the missing members.

    >>> require_bodies(object(), "Collisions")
    Traceback (most recent call last):
    ...
    pbanim.errors.BodyProtocolError: Collisions needs a system implementing the body protocol (pbanim.bodies.Bodies); object lacks kind, N, dof, generalized_velocity, inverse_mass_blocks, apply_inverse_mass, point_velocity, apply_impulses
    """
    if isinstance(system, Bodies):
        return system
    have = set(dir(type(system))) | set(getattr(system, "__dict__", {}))
    missing = [m for m in BODY_MEMBERS if m not in have]
    raise BodyProtocolError(who, type(system).__name__, missing)


class BodySystem(Spec):
    """Contract spec: a system implementing the body protocol, checked by :func:`require_bodies` (so a refusal
    is the :class:`~pbanim.errors.BodyProtocolError` that lists the missing members)."""

    def describe(self) -> str:
        return "a system implementing the body protocol (pbanim.bodies.Bodies)"

    def check(self, name, value, env):
        return require_bodies(value, env.where.split(".")[0])

    def bad(self, env):
        return [("None", None), ("a string", "x"), ("a number", 1.0)]
