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
prismatic   1     1     translation by q a                                  (0, a)
fixed       0     0     identity                                            (6 × 0)
floating    7     6     q = (quaternion w, x, y, z, position p): the link's  1₆ (q̇ = body-frame (ω, v))
                        orientation and origin in the parent's frame
=========== ===== ===== =================================================== =====================================

The link inertia is given by mass m, centre of mass c and rotational inertia I_c about c, in the link
frame. I_c may be singular (a point mass: I_c = 0) but must be symmetric positive semi-definite and
satisfy the triangle inequality of principal moments; m > 0.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..errors import InvalidInput
from .spatial import plucker, rotation, spatial_inertia

__all__ = ["Joint", "Link", "ArticulatedTree", "JOINT_TYPES"]

JOINT_TYPES = {"revolute": (1, 1), "prismatic": (1, 1), "fixed": (0, 0), "floating": (7, 6)}


@dataclass(frozen=True)
class Joint:
    """A joint: its type, unit axis (revolute, prismatic) and placement (R, p) in the parent link frame."""

    kind: str
    axis: np.ndarray = field(default_factory=lambda: np.array([0.0, 0.0, 1.0]))
    R: np.ndarray = field(default_factory=lambda: np.eye(3))
    p: np.ndarray = field(default_factory=lambda: np.zeros(3))


@dataclass(frozen=True)
class Link:
    """A rigid link: mass, centre of mass and rotational inertia about it, in the link frame."""

    name: str
    mass: float
    com: np.ndarray
    inertia: np.ndarray


def _vector(value, name: str, who: str) -> np.ndarray:
    a = np.asarray(value, dtype=float)
    if a.shape != (3,) or not np.all(np.isfinite(a)):
        raise InvalidInput(f"{who}: {name} must be a finite 3-vector, got {value!r}")
    return a


class ArticulatedTree:
    """A tree of links and joints (see the module docstring); built by :meth:`add`.

    >>> tree = ArticulatedTree()
    >>> tree.add("upper", -1, "revolute", axis=[0, 0, 1], mass=1.0, com=[0, -1, 0], inertia=np.zeros((3, 3)))
    0
    >>> tree.nq, tree.nv
    (1, 1)
    """

    def __init__(self, gravity=(0.0, 0.0, -9.81)) -> None:
        self.gravity = _vector(gravity, "gravity", "ArticulatedTree")
        self.links: list[Link] = []
        self.joints: list[Joint] = []
        self.parent: list[int] = []
        self.damping: list[float] = []
        self._q_index: list[slice] = []
        self._v_index: list[slice] = []
        self.nq = self.nv = 0
        self._cache = None

    @property
    def n(self) -> int:
        return len(self.links)

    def add(self, name: str, parent: int, kind: str, *, axis=(0.0, 0.0, 1.0), R=None, p=(0.0, 0.0, 0.0),
            mass: float, com=(0.0, 0.0, 0.0), inertia=None, damping: float = 0.0) -> int:
        """Append link ``name`` hanging from link ``parent`` (−1: the world) by a joint; returns its index."""
        who = f"link {name!r}"
        if kind not in JOINT_TYPES:
            raise InvalidInput(f"{who}: joint type must be one of {list(JOINT_TYPES)}, got {kind!r}")
        ok = not isinstance(parent, bool) and isinstance(parent, (int, float, np.integer, np.floating)) \
            and np.isfinite(parent) and int(parent) == parent
        if not ok or not -1 <= parent < self.n:
            raise InvalidInput(f"{who}: parent must be −1 (the world) or an existing link 0..{self.n - 1} "
                               f"(parents come before children, so the tree has no cycle), got {parent!r}")
        if kind == "floating" and parent != -1:
            raise InvalidInput(f"{who}: a floating joint connects a link to the world (parent −1), got {parent}")
        a = _vector(axis, "axis", who)
        if kind in ("revolute", "prismatic"):
            norm = float(np.linalg.norm(a))
            if not norm > 1e-12:
                raise InvalidInput(f"{who}: the {kind} joint axis must be non-zero, got {axis!r}")
            a = a / norm
        Rm = np.eye(3) if R is None else np.asarray(R, dtype=float)
        if Rm.shape != (3, 3) or not np.all(np.isfinite(Rm)) or not np.allclose(Rm @ Rm.T, np.eye(3), atol=1e-9) \
                or np.linalg.det(Rm) < 0:
            raise InvalidInput(f"{who}: the joint placement R must be a rotation matrix, got {R!r}")
        m = float(mass)
        if not (np.isfinite(m) and m > 0):
            raise InvalidInput(f"{who}: mass must be a positive finite number, got {mass}")
        c = _vector(com, "com", who)
        Ic = np.zeros((3, 3)) if inertia is None else np.asarray(inertia, dtype=float)
        if Ic.shape == (3,):
            Ic = np.diag(Ic)
        _check_inertia(Ic, who)
        d = float(damping)
        if not (np.isfinite(d) and d >= 0):
            raise InvalidInput(f"{who}: joint damping must be a finite number >= 0, got {damping}")
        nq, nv = JOINT_TYPES[kind]
        self.links.append(Link(str(name), m, c, Ic))
        self.joints.append(Joint(kind, a, Rm, _vector(p, "p", who)))
        self.parent.append(int(parent))
        self.damping.append(d)
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
                if j.kind == "revolute":
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
        return self._cache

    def joint_transform(self, i: int, qi: np.ndarray) -> np.ndarray:
        """X_J(q_i) (..., 6, 6) of joint i for its coordinates q_i (..., nq_i)."""
        j = self.joints[i]
        if j.kind == "revolute":
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

    def check_state(self, q, qd=None, name_q: str = "q", name_qd: str = "qd"):
        """(q, q̇) as float arrays of shape (nq,) / (K, nq) and (nv,) / (K, nv), finite; InvalidInput otherwise."""
        q = np.asarray(q, dtype=float)
        if q.ndim not in (1, 2) or q.shape[-1] != self.nq or not np.all(np.isfinite(q)):
            raise InvalidInput(f"{name_q} must be finite with shape ({self.nq},) or (K, {self.nq}), got "
                               f"shape {q.shape}" + ("" if np.all(np.isfinite(q)) else " with non-finite values"))
        if qd is None:
            return q, None
        qd = np.asarray(qd, dtype=float)
        if qd.shape != q.shape[:-1] + (self.nv,) or not np.all(np.isfinite(qd)):
            raise InvalidInput(f"{name_qd} must be finite with shape {q.shape[:-1] + (self.nv,)}, got shape "
                               f"{qd.shape}" + ("" if np.all(np.isfinite(qd)) else " with non-finite values"))
        return q, qd


def _check_inertia(Ic: np.ndarray, who: str) -> None:
    if Ic.shape != (3, 3) or not np.all(np.isfinite(Ic)) or not np.allclose(Ic, Ic.T, atol=1e-12 * (1 + np.abs(Ic).max())):
        raise InvalidInput(f"{who}: inertia must be a finite symmetric 3×3 matrix (or 3 principal moments), "
                           f"got {Ic!r}")
    lam = np.linalg.eigvalsh(Ic)
    tol = 1e-12 * max(1.0, float(np.abs(lam).max()))
    if lam[0] < -tol or lam[0] + lam[1] < lam[2] - tol:
        raise InvalidInput(f"{who}: inertia must be positive semi-definite with principal moments satisfying "
                           f"I1 + I2 >= I3, got principal moments {lam}")
