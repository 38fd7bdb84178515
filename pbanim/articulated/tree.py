"""Articulated trees in reduced coordinates: links, joints, placements (chapter 08).

A tree of n links, numbered so that every parent comes before its children (λ(i) < i, λ(i) = −1 for the
world). Link i hangs from its parent by joint i: the joint frame sits in the parent's link frame at the
placement X_T(i) (rotation R, origin p), the joint moves the child's frame relative to it by X_J(q_i),
so ⁱX_λ(i) = X_J(q_i) X_T(i). The joint's motion subspace S_i (6 × d_i) maps joint velocities to spatial
velocity: v̂_i = ⁱX_λ v̂_λ + S_i q̇_i.

=========== ===== ===== =================================================== =====================================
joint       q     q̇     X_J(q)                                              S
=========== ===== ===== =================================================== =====================================
revolute    1     1     rotation by q about the unit axis a                 (a, 0)
continuous  1     1     the same, with no position limits (q unwrapped:     (a, 0)
                        it runs past ±π)
prismatic   1     1     translation by q a                                  (0, a)
fixed       0     0     identity                                            (6 × 0)
floating    7     6     q = (quaternion w, x, y, z, position p): the link's  1₆ (q̇ = body-frame (ω, v))
                        orientation and origin in the parent's frame
=========== ===== ===== =================================================== =====================================

A revolute or prismatic joint may carry position limits lower ≤ q ≤ upper (enforced by the contact
stepper :class:`~pbanim.articulated.contact.ArticulatedContact`, which holds joint stops as unilateral
rows), and every joint an effort limit |τ| ≤ effort and a velocity limit |q̇| ≤ velocity, kept on the model
for controllers (URDF's ``<limit>``; ±inf: none).

The link inertia is given by mass m ≥ 0, centre of mass c and rotational inertia I_c about c, in the link
frame. I_c may be singular (a point mass: I_c = 0) but must be symmetric positive semi-definite and
satisfy the triangle inequality of principal moments. A massless link is allowed: what must not vanish is
the articulated inertia D = Sᵀ I^A S of each movable joint (the mass it moves), which forward dynamics
checks (:class:`~pbanim.errors.SingularChartError` naming the joint) and
:func:`~pbanim.articulated.dynamics.check_articulated_inertia`
checks at load.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..contracts import Array, Choice, Index, Opt, Real, Text, contract
from ..errors import InvalidInput
from .spatial import plucker, rotation, spatial_inertia
from ..rigid.admissible import Inertia
from ..rigid.domain import Rotation
from .specs import JointPositions, Parent, UnitAxis

__all__ = ["Joint", "Link", "ArticulatedTree", "JOINT_TYPES", "ROTATING", "ONE_DOF"]

JOINT_TYPES = {"revolute": (1, 1), "continuous": (1, 1), "prismatic": (1, 1), "fixed": (0, 0), "floating": (7, 6)}
ROTATING = ("revolute", "continuous")           # S = (a, 0)
ONE_DOF = ("revolute", "continuous", "prismatic")
_LIMITED = ("revolute", "prismatic")            # the kinds that may have position limits
_KIND = Choice(tuple(JOINT_TYPES))
_BOUND = Real(finite=False)                     # a position limit (±inf: none)
_RATE = Real(ge=0, finite=False)                # an effort or velocity limit (inf: none)
_V3 = Array((3,))


@contract(kind=_KIND, axis=UnitAxis(), R=Opt(Rotation()), p=_V3, lower=_BOUND, upper=_BOUND, effort=_RATE,
          velocity=_RATE)
@dataclass(frozen=True)
class Joint:
    """A joint: its type, unit axis (revolute, continuous, prismatic), placement (R, p) in the parent link
    frame, and its limits: position lower ≤ q ≤ upper (revolute and prismatic only), |τ| ≤ effort,
    |q̇| ≤ velocity (see the module docstring)."""

    kind: str
    axis: np.ndarray = (0.0, 0.0, 1.0)
    R: np.ndarray | None = None          # None: the identity
    p: np.ndarray = (0.0, 0.0, 0.0)
    lower: float = -math.inf
    upper: float = math.inf
    effort: float = math.inf
    velocity: float = math.inf

    def __post_init__(self) -> None:     # arrays, and the cross-argument conditions, for every caller
        for name, value in (("axis", self.axis), ("R", np.eye(3) if self.R is None else self.R), ("p", self.p)):
            object.__setattr__(self, name, np.array(value, dtype=float))
        if not self.lower <= self.upper:
            raise InvalidInput(f"Joint: lower must be <= upper, got lower = {self.lower}, upper = {self.upper}")
        if self.has_limits and self.kind not in _LIMITED:
            why = "a continuous joint turns freely" if self.kind == "continuous" else "it has no one coordinate"
            raise InvalidInput(f"Joint: lower and upper (position limits) apply to revolute and prismatic joints, "
                               f"got a {self.kind} joint with [{self.lower}, {self.upper}] ({why})")

    @property
    def has_limits(self) -> bool:
        """Whether a position limit is finite."""
        return self.lower > -math.inf or self.upper < math.inf


@contract(name=Text(), mass=Real(ge=0), com=_V3, inertia=Inertia(definite=False))
@dataclass(frozen=True)
class Link:
    """A rigid link: mass m ≥ 0, centre of mass and rotational inertia about it, in the link frame."""

    name: str
    mass: float
    com: np.ndarray
    inertia: np.ndarray


class ArticulatedTree:
    """A tree of links and joints (see the module docstring); built by :meth:`add`.

    ``joint_names[i]`` names the joint above link i; ``frames`` maps the name of a link merged into a body
    (welded to it by a fixed joint, as :func:`~pbanim.articulated.load_urdf` does) to (body index, R, p): its
    frame in the body's frame.

    >>> tree = ArticulatedTree()
    >>> tree.add("upper", -1, "revolute", axis=[0, 0, 1], mass=1.0, com=[0, -1, 0], inertia=np.zeros((3, 3)))
    0
    >>> tree.nq, tree.nv
    (1, 1)
    """

    @contract(gravity=_V3)
    def __init__(self, gravity=(0.0, 0.0, -9.81)) -> None:
        self.gravity = np.array(gravity, dtype=float)
        self.links: list[Link] = []
        self.joints: list[Joint] = []
        self.parent: list[int] = []
        self.damping: list[float] = []
        self.joint_names: list[str] = []
        self.frames: dict = {}
        self._q_index: list[slice] = []
        self._v_index: list[slice] = []
        self.nq = self.nv = 0
        self._cache = None

    @property
    def n(self) -> int:
        return len(self.links)

    @contract(name=Text(), parent=Parent("self.n"), kind=_KIND, axis=UnitAxis(), R=Opt(Rotation()), p=_V3,
              mass=Real(ge=0), com=_V3, inertia=Opt(Inertia(moments=True, definite=False)), damping=Real(ge=0),
              lower=_BOUND, upper=_BOUND, effort=_RATE, velocity=_RATE, joint=Opt(Text()))
    def add(self, name: str, parent: int, kind: str, *, axis=(0.0, 0.0, 1.0), R=None, p=(0.0, 0.0, 0.0),
            mass: float, com=(0.0, 0.0, 0.0), inertia=None, damping: float = 0.0, lower: float = -math.inf,
            upper: float = math.inf, effort: float = math.inf, velocity: float = math.inf,
            joint: str | None = None) -> int:
        """Append link ``name`` hanging from link ``parent`` (−1: the world) by a joint of type ``kind`` with
        limits ``lower``, ``upper``, ``effort``, ``velocity`` (module docstring); returns its index.
        ``joint`` names the joint (default: "<name>_joint")."""
        if kind == "floating" and parent != -1:
            raise InvalidInput(f"ArticulatedTree.add: a floating joint connects a link to the world (parent −1), "
                               f"got parent = {parent} for link {name!r}")
        a = np.asarray(axis, dtype=float)
        a = a / np.linalg.norm(a)                       # unit already from outside; from inside: made so
        Ic = np.zeros((3, 3)) if inertia is None else np.asarray(inertia, dtype=float)
        if Ic.shape == (3,):
            Ic = np.diag(Ic)
        jt = Joint(kind, a, np.eye(3) if R is None else np.asarray(R, dtype=float), np.asarray(p, dtype=float),
                   float(lower), float(upper), float(effort), float(velocity))
        nq, nv = JOINT_TYPES[kind]
        self.links.append(Link(str(name), float(mass), np.asarray(com, dtype=float), Ic))
        self.joints.append(jt)
        self.parent.append(int(parent))
        self.damping.append(float(damping))
        self.joint_names.append(f"{name}_joint" if joint is None else str(joint))
        self._q_index.append(slice(self.nq, self.nq + nq))
        self._v_index.append(slice(self.nv, self.nv + nv))
        self.nq += nq
        self.nv += nv
        self._cache = None
        return self.n - 1

    # -- derived, cached arrays ---------------------------------------------------------------
    def arrays(self) -> dict:
        """Per-link constants: X_T (n, 6, 6), spatial inertias (n, 6, 6), S blocks, index slices."""
        if self._cache is None:
            if self.n == 0:
                raise InvalidInput("the tree has no links: add at least one with ArticulatedTree.add")
            XT = np.stack([plucker(j.R.T, j.p) for j in self.joints])
            I = np.stack([spatial_inertia(lk.mass, lk.com, lk.inertia) for lk in self.links])
            S = []
            for j in self.joints:
                if j.kind in ROTATING:
                    S.append(np.concatenate([j.axis, np.zeros(3)])[:, None])
                elif j.kind == "prismatic":
                    S.append(np.concatenate([np.zeros(3), j.axis])[:, None])
                elif j.kind == "fixed":
                    S.append(np.zeros((6, 0)))
                else:
                    S.append(np.eye(6))
            self._cache = {"XT": XT, "I": I, "S": S, "qi": self._q_index, "vi": self._v_index,
                           "a0": np.concatenate([np.zeros(3), -self.gravity]),
                           "damping": np.repeat(self.damping, [v.stop - v.start for v in self._v_index])}
            path = np.zeros((self.n, self.nv), dtype=bool)        # path[i]: the velocity coordinates root → i
            for i in range(self.n):
                path[i, self._v_index[i]] = True
                if self.parent[i] >= 0:
                    path[i] |= path[self.parent[i]]
            self._cache["path"] = path
        return self._cache

    @contract(i=Index("self.n"), qi=JointPositions("self", joint="i", batch="first"))
    def joint_transform(self, i: int, qi: np.ndarray) -> np.ndarray:
        """X_J(q_i) (..., 6, 6) of joint i for its coordinates q_i (..., nq_i)."""
        j = self.joints[i]
        if j.kind in ROTATING:
            return plucker(np.swapaxes(rotation(j.axis, qi[..., 0]), -1, -2), np.zeros(3))
        if j.kind == "prismatic":
            return plucker(np.eye(3), qi[..., :1] * j.axis)
        if j.kind == "fixed":
            return np.broadcast_to(np.eye(6), qi.shape[:-1] + (6, 6)).copy()
        from ..rigid.quat import quat_to_matrix

        quat = qi[..., :4] / np.linalg.norm(qi[..., :4], axis=-1, keepdims=True)
        return plucker(np.swapaxes(quat_to_matrix(quat), -1, -2), qi[..., 4:7])

    def neutral(self) -> np.ndarray:
        """The zero configuration (unit quaternions for floating joints)."""
        q = np.zeros(self.nq)
        for j, s in zip(self.joints, self._q_index):
            if j.kind == "floating":
                q[s.start] = 1.0
        return q

    def limited(self) -> list[tuple[int, int, float, float]]:
        """(q index, q̇ index, lower, upper) of every joint with a finite position limit."""
        return [(s.start, v.start, j.lower, j.upper) for j, s, v in zip(self.joints, self._q_index, self._v_index)
                if j.has_limits]
