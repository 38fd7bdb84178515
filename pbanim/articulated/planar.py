"""Planar trees in closed form: H(q), C(q, q̇) and point Jacobians in a few vectorized operations.

Characters of the lecture's planar examples (the SIMBICON biped, a planar arm) move in the xy-plane:
every revolute joint turns about the world z axis and the root slides in the plane. Then each link's
orientation is one absolute angle and every quantity of chapter 08 has a short closed form:

    φᵢ = Σ_{k ∈ path(i)} s_k q_k                          (absolute angle; s_k = ±1, the axis' sign along z)
    oᵢ = dᵢ(q) + Σ_{k ∈ path(i)} R(φ_λ(k)) e_k             (joint origins; e_k the placement at q = 0)
    ∂p/∂q_k = s_k ẑ × (p − o_k)   (revolute k on the path of p's link),   = a_k   (prismatic)
    J̇ q̇ p  = −Σ_{k ∈ path(i)} φ̇²_λ(k) R(φ_λ(k)) e_k − φ̇ᵢ² (p − oᵢ)      (centripetal terms only)
    H = Σᵢ mᵢ J_cᵢᵀ J_cᵢ + I_zz,ᵢ ∇φᵢᵀ ∇φᵢ,          C = Σᵢ mᵢ J_cᵢᵀ (J̇_cᵢ q̇ − g)

(Lagrange's equations with the composite Jacobians of chapter 04; a planar body has no gyroscopic
term.) With the path matrix Pᵢₖ = [k is on the path from the root to i] all sums are matrix products,
so one evaluation costs a few dozen numpy operations whatever the tree: the fast kernel that the
character chapter steps at thousands of steps per second. It is checked against the readable
recursions, :func:`~pbanim.articulated.crba`, :func:`~pbanim.articulated.bias_forces` and the point
Jacobians of :mod:`.contact`, to roundoff (ORACLES I6).

Notation: q, q̇ joint coordinates; φ absolute link angles; oᵢ, cᵢ joint origin and centre of mass of
link i (2-D); e_k = o_k(0) − o_λ(k)(0); R(φ) the plane rotation; λ(k) the parent; g gravity (in the plane).

Limits: prismatic joints only ahead of every revolute joint on their path (a sliding root), axes in
the plane; no floating joints (a planar root is two sliders and a hinge). Anything else is refused with
:class:`NotPlanarError` naming the joint.
"""

from __future__ import annotations

import numpy as np

from ..contracts import Array, Indices, Opt, Real, contract, finite_result
from ..errors import InvalidInput
from .dynamics import world_poses
from .specs import PlanarKinematics, Tree, Size
from .tree import ROTATING, ArticulatedTree

__all__ = ["PlanarKernel", "NotPlanarError"]


class NotPlanarError(InvalidInput):
    """The tree does not move in the xy-plane (a joint axis, the gravity or a joint kind says why)."""


def _count(env) -> int:
    try:
        return len(env.values.get("links"))
    except TypeError:
        return -1                               # not a collection: its own spec refuses it


_Q, _KIN = Array(("self.nv",)), PlanarKinematics("self")
_LINKS = Indices("self.n")
_LOCAL, _P = Array((Size(_count, "len(links)"), 3)), Array((Size(_count, "len(links)"), 2))


def _complex(v: np.ndarray) -> np.ndarray:
    """(m, 2) real → (m,) complex x + i y."""
    v = np.asarray(v, dtype=float)
    return v[..., 0] + 1j * v[..., 1]


def _pairs(z: np.ndarray) -> np.ndarray:
    """(m,) complex → (m, 2) real (a view when z is contiguous)."""
    return np.ascontiguousarray(z).view(np.float64).reshape(z.shape + (2,))


class PlanarKernel:
    """Closed-form dynamics of a planar :class:`ArticulatedTree` (see the module docstring)."""

    @contract(tree=Tree(), tol=Real(gt=0, lt=1))
    def __init__(self, tree: ArticulatedTree, tol: float = 1e-9) -> None:
        A = tree.arrays()
        if tree.nq != tree.nv:
            raise NotPlanarError("planar kernel: floating joints are not planar; use two sliders and a hinge")
        if abs(tree.gravity[2]) > tol * (1 + np.linalg.norm(tree.gravity)):
            raise NotPlanarError(f"planar kernel: gravity must lie in the xy-plane, got {tree.gravity}")
        n, nv = tree.n, tree.nv
        _, X0, origins = world_poses(tree, tree.neutral())
        self.tree, self.n, self.nv = tree, n, nv
        self.parent = np.array(tree.parent)
        P = np.zeros((n, n))
        for i in range(n):
            k = i
            while k >= 0:                                       # the path to the root: at most n links
                P[i, k] = 1.0
                k = tree.parent[k]
        self.P = P
        self.E0 = [X[:3, :3] for X in X0]                      # world → link at q = 0
        Phi = np.zeros((n, nv))                                 # φ = Phi q
        Apr = np.zeros((n, 2, nv))                              # prismatic axis columns of link k
        revolute = np.zeros(n, dtype=bool)
        vidx = np.full(n, -1)
        for k, j in enumerate(tree.joints):
            sl = A["vi"][k]
            if j.kind == "fixed":
                continue
            vidx[k] = sl.start
            a = self.E0[k].T @ j.axis                           # the joint axis in world coordinates
            if j.kind in ROTATING:
                if abs(abs(a[2]) - 1.0) > tol:
                    raise NotPlanarError(f"planar kernel: revolute joint of link {tree.links[k].name!r} turns "
                                         f"about world axis {a}, not ±z")
                revolute[k] = True
                Phi[P[:, k] > 0, sl.start] = np.sign(a[2])
            else:
                if abs(a[2]) > tol:
                    raise NotPlanarError(f"planar kernel: prismatic joint of link {tree.links[k].name!r} slides "
                                         f"along {a}, out of the plane")
                if np.any(revolute[P[k] > 0]):
                    raise NotPlanarError(f"planar kernel: prismatic joint of link {tree.links[k].name!r} is "
                                         "below a revolute joint (only a sliding root is supported)")
                Apr[k, :, sl.start] = a[:2]
        self.Phi, self.revolute = Phi, revolute
        self.sign = np.array([Phi[k, vidx[k]] if revolute[k] else 0.0 for k in range(n)])
        self.vidx = vidx
        # prismatic displacement d_i = (Σ_k P_ik a_k q_k): columns per link
        self.Dpr = np.einsum("ik,kcv->icv", P, Apr)             # (n, 2, nv)
        par0 = np.array([origins[p, :2] if p >= 0 else np.zeros(2) for p in tree.parent])
        self.e = origins[:, :2] - par0                          # e_k at q = 0 (prismatic q removed: q = 0)
        self.mass = np.array([lk.mass for lk in tree.links])
        com0 = np.array([self.E0[i].T @ lk.com for i, lk in enumerate(tree.links)])
        self.rc = com0[:, :2]                                   # c_i − o_i at q = 0, world axes
        self.Izz = np.array([(self.E0[i].T @ lk.inertia @ self.E0[i])[2, 2] for i, lk in enumerate(tree.links)])
        self.g = tree.gravity[:2].copy()
        self.damping = A["damping"]
        # revolute columns: Rv[k, v] = s_k where v is k's velocity index
        self.Rv = np.zeros((n, nv))
        for k in np.flatnonzero(revolute):
            self.Rv[k, vidx[k]] = self.sign[k]
        self.Pr = P * revolute[None, :]                         # path entries that are revolute joints
        # complex forms of the constant vectors (x + i y)
        self._ez, self._rcz = _complex(self.e), _complex(self.rc)
        self._Dz = self.Dpr[:, 0, :] + 1j * self.Dpr[:, 1, :]
        self._gz = complex(self.g[0], self.g[1])
        self._Hrot = (self.Phi.T * self.Izz) @ self.Phi
        self._E0 = np.stack(self.E0)
        self._all = np.arange(n)

    # -- kinematics (2-D vectors as complex numbers: R(φ) v = e^{iφ} v, ẑ × v = i v) -----------------
    @contract(q=_Q)
    def kinematics(self, q: np.ndarray) -> dict:
        """Absolute angles φ (n,), joint origins o (n, 2), centres of mass c (n, 2) (and their complex forms)."""
        q = np.asarray(q, dtype=float)
        phi = self.Phi @ q
        rot = np.exp(1j * phi)
        prot = np.where(self.parent >= 0, rot[self.parent], 1.0)
        w = prot * self._ez
        zo = self.P @ w + self._Dz @ q
        zc = zo + rot * self._rcz
        return {"phi": phi, "rot": rot, "w": w, "zo": zo, "zc": zc, "o": _pairs(zo), "c": _pairs(zc)}

    @contract(q=_Q, links=_LINKS, local=_LOCAL, returns=finite_result)
    def points(self, q: np.ndarray, links, local) -> np.ndarray:
        """World positions (m, 2) of link-frame points ``local`` (m, 3) on ``links`` (m,)."""
        return self.point_positions(self.kinematics(q), np.asarray(links), np.asarray(local, dtype=float))

    @contract(links=Indices("self.n", empty=True), local=Array((Size(_count, "len(links)"), 3), empty=True))
    def point_offsets(self, links, local) -> np.ndarray:
        """The offsets (m,) complex, from each link's origin at q = 0, of link-frame points ``local`` (m, 3)."""
        links = np.asarray(links, dtype=int)
        if not len(links):
            return np.zeros(0, complex)
        r0 = np.einsum("mji,mj->mi", self._E0[links], np.asarray(local, dtype=float))
        return r0[:, 0] + 1j * r0[:, 1]

    @contract(kin=_KIN, links=_LINKS, local=_LOCAL, returns=finite_result)
    def point_positions(self, kin, links, local) -> np.ndarray:
        """World positions (m, 2) of link-frame points ``local`` (m, 3) on ``links`` from :meth:`kinematics`."""
        links = np.asarray(links, dtype=int)
        return _pairs(kin["zo"][links] + kin["rot"][links] * self.point_offsets(links, local))

    @contract(kin=_KIN, links=_LINKS, p=_P, returns=finite_result)
    def jacobians(self, kin, links, p: np.ndarray) -> np.ndarray:
        """Jacobians (m, 2, nv) of world points p (m, 2) fixed on ``links`` (m,)."""
        Jz = self._jacobians_z(kin, np.asarray(links, dtype=int), _complex(p))
        return np.stack([Jz.real, Jz.imag], axis=1)

    def _jacobians_z(self, kin, links, pz) -> np.ndarray:
        """(m, nv) complex: column k is s_k i (p − o_k) on the path of each point (+ prismatic axes)."""
        cols = 1j * (pz[:, None] - kin["zo"][None, :]) * self.Pr[links]
        return cols @ self.Rv + self._Dz[links]

    @contract(kin=_KIN, links=_LINKS, p=_P, qd=_Q, returns=finite_result)
    def bias_acceleration(self, kin, links, p: np.ndarray, qd: np.ndarray) -> np.ndarray:
        """J̇ q̇ (m, 2) of world points p fixed on ``links``: the centripetal terms."""
        links = np.asarray(links, dtype=int)
        return _pairs(self._bias_z(kin, links, _complex(p), qd))

    def _bias_z(self, kin, links, pz, qd):
        phid = self.Phi @ qd
        pd2 = np.where(self.parent >= 0, phid[self.parent], 0.0) ** 2
        along = (self.P[links] * pd2[None, :]) @ kin["w"]       # Σ_k φ̇²_λ(k) R e_k over each path
        return -along - phid[links] ** 2 * (pz - kin["zo"][links])

    # -- dynamics ------------------------------------------------------------------------------
    @contract(kin=_KIN, returns=finite_result)
    def com_jacobians(self, kin) -> np.ndarray:
        """Complex Jacobians (n, nv) of every link's centre of mass, cached in ``kin`` (and their (n, 2, nv)
        real form as kin["Jc"])."""
        if "Jz" not in kin:
            Jz = self._jacobians_z(kin, self._all, kin["zc"])
            kin["Jz"], kin["Jc"] = Jz, np.stack([Jz.real, Jz.imag], axis=1)
        return kin["Jz"]

    @contract(q=_Q, kin=Opt(_KIN), returns=finite_result)
    def mass_matrix(self, q: np.ndarray, kin=None) -> np.ndarray:
        """H(q) (nv, nv), equal to :func:`~pbanim.articulated.crba`."""
        kin = self.kinematics(q) if kin is None else kin
        Jz = self.com_jacobians(kin)
        return ((Jz.conj().T * self.mass) @ Jz).real + self._Hrot

    @contract(q=_Q, qd=_Q, kin=Opt(_KIN), returns=finite_result)
    def dynamics(self, q: np.ndarray, qd: np.ndarray, kin=None) -> tuple[np.ndarray, np.ndarray, dict]:
        """(H, C, kinematics) with H q̈ + C = τ (C: Coriolis, centripetal and gravity; no joint damping);
        ``kin``: :meth:`kinematics` of the same q when the caller has it."""
        kin = self.kinematics(q) if kin is None else kin
        Jz = self.com_jacobians(kin)
        JmT = Jz.conj().T * self.mass
        H = (JmT @ Jz).real + self._Hrot
        C = (JmT @ (self._bias_z(kin, self._all, kin["zc"], qd) - self._gz)).real
        return H, C, kin

    @contract(q=_Q, qd=_Q, returns=finite_result)
    def energy(self, q: np.ndarray, qd: np.ndarray) -> float:
        """½ q̇ᵀ H q̇ + Σ mᵢ (−g · cᵢ)."""
        kin = self.kinematics(q)
        H = self.mass_matrix(q, kin)
        return float(0.5 * qd @ H @ qd - self.mass @ (kin["c"] @ self.g))

    @contract(q=_Q, qd=Opt(_Q), kin=Opt(_KIN), returns=finite_result)
    def centre_of_mass(self, q: np.ndarray, qd: np.ndarray | None = None, kin=None):
        """Centre of mass (2,), and its velocity when q̇ is given."""
        kin = self.kinematics(q) if kin is None else kin
        M = self.mass.sum()
        com = self.mass @ kin["c"] / M
        if qd is None:
            return com
        vz = self.mass @ (self.com_jacobians(kin) @ qd) / M
        return com, np.array([vz.real, vz.imag])
