"""Features of a planar character for the QP controller: centre of mass, angular momentum, points (chapter 08).

A *feature* (de Lasa, Mordatch & Hertzmann 2010) is a quantity y(q, q̇) of the whole character whose
acceleration is linear in the joint accelerations:

    ÿ = J_y q̈ + J̇_y q̇                                         (J̇_y q̇: the bias, no q̈ in it)

so a desired ÿ* makes a least-squares objective ‖J_y q̈ + J̇_y q̇ − ÿ*‖² of the QP. For a planar tree
(:class:`~pbanim.articulated.planar.PlanarKernel`: link i has mass mᵢ, centre cᵢ, inertia I_zz,i and
absolute angle φᵢ = Φᵢ q) the features of the lecture are:

    centre of mass      c = Σ mᵢ cᵢ / M,         J_c = Σ mᵢ J_cᵢ / M,     J̇_c q̇ = Σ mᵢ J̇_cᵢ q̇ / M
    angular momentum    L = Σ mᵢ (cᵢ − c) × ċᵢ + I_zz,ᵢ φ̇ᵢ = A_L q̇   about the centre of mass, with
                        A_L = Σ mᵢ (cᵢ − c) × J_cᵢ + I_zz,ᵢ Φᵢ           (a row: planar L is one number)
                        L̇ = A_L q̈ + Σ mᵢ (cᵢ − c) × J̇_cᵢ q̇
    a point on a link   p,  J_p = ∂p/∂q,  J̇_p q̇  (the kernel's point Jacobians)

(a × b = a_x b_y − a_y b_x). The rate of L needs no derivative of A_L: d/dt (cᵢ − c) × ċᵢ =
(ċᵢ − ċ) × ċᵢ + (cᵢ − c) × c̈ᵢ and Σ mᵢ (ċᵢ − ċ) × ċᵢ = −ċ × M ċ = 0. Newton and Euler for the whole
body then read M c̈ = Σ fⱼ + M g and L̇ = Σ (pⱼ − c) × fⱼ (ORACLES F10): gravity has no moment about
the centre of mass, so only the contact forces turn the body.

==============  ================  ===========  =================================================
symbol          code              shape        meaning
==============  ================  ===========  =================================================
q, q̇            ``q``, ``qd``     (nv,)        joint coordinates and velocities
cᵢ, J_cᵢ        ``kin["c"]``      (n, 2)       link centres and their Jacobians (n, 2, nv)
c, J_c          ``com``, ``J``    (2,), (2,nv) the centre of mass and its Jacobian
L, A_L          ``L``, ``A``      (), (nv,)    angular momentum about c, its "Jacobian" (L = A_L q̇)
J̇ q̇             ``bias``          like ÿ       the acceleration at q̈ = 0
==============  ================  ===========  =================================================

Limiting cases: one link (a rigid body) has L = I_zz φ̇ and A_L = Φ; a body at rest has zero biases;
a pure translation of the base changes neither L nor A_L.

:func:`angular_momentum_loop` is the readable per-link sum; :func:`centroidal` the vectorized form used
by the controller (a test checks that they agree, and A_L q̇ against the definition, and L̇ against
centred differences of L along the motion; ORACLES F11).

References: M. de Lasa, I. Mordatch, A. Hertzmann, "Feature-Based Locomotion Controllers", SIGGRAPH
2010; D. Orin, A. Goswami, S.-H. Lee, "Centroidal dynamics of a humanoid robot", Autonomous Robots 2013.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..articulated.planar import PlanarKernel

__all__ = ["Centroidal", "angular_momentum_loop", "centroidal", "point_feature"]


def _cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Planar cross product a × b = a_x b_y − a_y b_x along the last axis of (…, 2) arrays."""
    return a[..., 0] * b[..., 1] - a[..., 1] * b[..., 0]


@dataclass(frozen=True)
class Centroidal:
    """Centre of mass (position, velocity, Jacobian, bias) and angular momentum about it (L, A_L, bias)."""

    mass: float
    com: np.ndarray          # (2,)
    vcom: np.ndarray         # (2,)
    J: np.ndarray            # (2, nv)
    bias: np.ndarray         # (2,)   J̇ q̇
    L: float
    A: np.ndarray            # (nv,)  L = A q̇
    L_bias: float            # L̇ at q̈ = 0


def centroidal(kernel: PlanarKernel, q: np.ndarray, qd: np.ndarray, kin: dict | None = None) -> Centroidal:
    """The centroidal features at (q, q̇), vectorized over the links (``kin``: the kernel's kinematics of q).

    >>> from pbanim.control.biped import planar_biped
    >>> k = PlanarKernel(planar_biped())
    >>> cf = centroidal(k, np.zeros(9), np.zeros(9))
    >>> round(cf.mass, 3), round(float(cf.com[1]), 4), cf.L
    (90.0, 1.0031, 0.0)
    """
    kin = kernel.kinematics(q) if kin is None else kin
    kernel.com_jacobians(kin)
    Jc, c = kin["Jc"], kin["c"]                                     # (n, 2, nv), (n, 2)
    m = kernel.mass
    M = float(m.sum())
    links = np.arange(kernel.n)
    bias_i = kernel.bias_acceleration(kin, links, c, qd)            # (n, 2): J̇_cᵢ q̇
    com = m @ c / M
    J = np.einsum("i,icv->cv", m, Jc) / M
    r = c - com                                                     # (n, 2)
    A = m @ (r[:, 0, None] * Jc[:, 1, :] - r[:, 1, None] * Jc[:, 0, :]) + kernel.Izz @ kernel.Phi
    return Centroidal(mass=M, com=com, vcom=J @ qd, J=J, bias=m @ bias_i / M, L=float(A @ qd), A=A,
                      L_bias=float(m @ _cross(r, bias_i)))


def angular_momentum_loop(kernel: PlanarKernel, q: np.ndarray, qd: np.ndarray) -> tuple[float, np.ndarray]:
    """(L, A_L) by the definition, link by link: L = Σ mᵢ (cᵢ − c) × ċᵢ + I_zz,ᵢ φ̇ᵢ (the readable form)."""
    kin = kernel.kinematics(q)
    kernel.com_jacobians(kin)
    com = kernel.centre_of_mass(q, kin=kin)
    L, A = 0.0, np.zeros(kernel.nv)
    for i in range(kernel.n):                                       # one link at a time
        r = kin["c"][i] - com
        Ji = kin["Jc"][i]                                           # (2, nv): ċᵢ = Jᵢ q̇
        vi = Ji @ qd
        phid = kernel.Phi[i] @ qd
        L += kernel.mass[i] * (r[0] * vi[1] - r[1] * vi[0]) + kernel.Izz[i] * phid
        A += kernel.mass[i] * (r[0] * Ji[1] - r[1] * Ji[0]) + kernel.Izz[i] * kernel.Phi[i]
    return float(L), A


def point_feature(kernel: PlanarKernel, kin: dict, qd: np.ndarray, link: int, local) -> tuple:
    """(p (2,), ṗ (2,), J_p (2, nv), J̇_p q̇ (2,)) of the link-frame point ``local`` (3,) on ``link``."""
    links = np.array([int(link)])
    loc = np.asarray(local, dtype=float).reshape(1, 3)
    p = kernel.point_positions(kin, links, loc)
    J = kernel.jacobians(kin, links, p)[0]
    return p[0], J @ qd, J, kernel.bias_acceleration(kin, links, p, qd)[0]
