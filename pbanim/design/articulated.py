"""Design of an articulated motion: a chain thrown through flight, S(t, u) and ∂S/∂u (chapter 10, issue 31).

Chapter 10's design loop needs S(t, u) and its derivative; for an articulated body the state is
y = (q, q̇) and its motion ẏ = F(y) = (q̇, q̈(q, q̇, τ(q, q̇))) with q̈ from ABA. The sensitivity Φ = ∂y/∂u
obeys the variational equation

    Φ̇ = ∂F/∂y Φ,      ∂F/∂y = [[0, 1], [∂q̈/∂q + H⁻¹ ∂τ/∂q,  ∂q̈/∂q̇ + H⁻¹ ∂τ/∂q̇]],      Φ(0) = ∂y₀/∂u,

whose blocks are the analytical derivatives of ABA (:func:`~pbanim.articulated.aba_derivatives`, with
∂q̈/∂τ = H⁻¹ carrying the joint springs τ = −k (q − q_rest) through). Integrating (y, Φ) together by RK4
gives exactly the derivative of the RK4 step map (the stages of Φ are the derivatives of the stages of y),
so ∂S/∂u equals finite differences of the discrete S to the differences' own O(δ²) error (ORACLES H9).

The thrown chain (:func:`thrown_chain`) is planar: a free base made of two sliders and a hinge (x, y, θ)
carrying n rods hinged end to end, gravity −y. A planar free base instead of the 3-D floating joint keeps
the state a vector space (q ⊕ δ = q + δ), so the variational equation is the plain one above; the
derivatives themselves handle floating joints too (in the tangent space). The parameters u are a
selection of the initial joint velocities q̇₀ (default: the base's launch velocity vx, vy and spin ω),
and the design goal is that a chosen point of a chosen link (the tip of the last rod) is at a target at
time T: C(u) = p(T, u) − p* = 0, solved by chapter 10's min-norm update
(:func:`~pbanim.design.control.min_norm_update`), with ∂p/∂u = J_p(q(T)) ∂q(T)/∂u from the planar point
Jacobian (:class:`~pbanim.articulated.PlanarKernel`).

Reference: J. Popović, S. M. Seitz, M. Erdmann, Z. Popović, A. Witkin, "Interactive manipulation of rigid
body simulations", SIGGRAPH 2000 (S, ∂S/∂u, min-norm edits); J. Carpentier, N. Mansard, RSS 2018.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..articulated import ArticulatedTree, PlanarKernel, aba_derivatives, aba_fast
from ..articulated.specs import JointPositions, Tree
from ..contracts import Array, Flag, Index, Int, Obj, Opt, Real, Seq, contract
from ..errors import InvalidInput, SimulationDiverged
from .control import min_norm_update

__all__ = ["thrown_chain", "ChainFlight", "ChainAim", "simulate_chain", "aim_chain"]

MAX_STEPS = 100_000


@contract(links=Int(ge=1, le=20), length=Real(gt=0, le=100), mass=Real(gt=0, le=1e6), gravity=Real(ge=0, le=1e3))
def thrown_chain(links: int = 4, length: float = 0.3, mass: float = 1.0, gravity: float = 9.81) -> ArticulatedTree:
    """A planar chain of ``links`` uniform rods (length, mass) hinged end to end about z, on a free base
    (slider x, slider y, hinge θ: q = (x, y, θ, q₁ … q_{n−1})), gravity −y."""
    tree = ArticulatedTree(gravity=(0.0, -gravity, 0.0))
    tree.add("base_x", -1, "prismatic", axis=[1, 0, 0], mass=0.0)
    tree.add("base_y", 0, "prismatic", axis=[0, 1, 0], mass=0.0)
    rod = dict(mass=mass, com=[length / 2, 0.0, 0.0], inertia=np.diag([1e-6, 1.0, 1.0]) * mass * length ** 2 / 12)
    parent = tree.add("rod0", 1, "revolute", axis=[0, 0, 1], **rod)
    for i in range(1, links):
        parent = tree.add(f"rod{i}", parent, "revolute", axis=[0, 0, 1], p=[length, 0.0, 0.0], **rod)
    return tree


@contract(t=Array((None,)), y=Array((None, None)), dy_du=Array((None, None, None), empty=True),
          free=Array((None,), empty=True), tree=Tree())
@dataclass
class ChainFlight:
    """S(t, u) of a tree: times t (N,), states y (N, nq + nv), sensitivities dy_du (N, nq + nv, p), the
    indices of q̇₀ that u selects, and the tree."""

    t: np.ndarray
    y: np.ndarray
    dy_du: np.ndarray
    free: np.ndarray
    tree: ArticulatedTree

    @contract(link=Index("self.tree.n"), local=Array((3,)))
    def point(self, link: int, local) -> tuple[np.ndarray, np.ndarray]:
        """(positions (N, 2), ∂p/∂u (N, 2, p)) of the point ``local`` (link frame) of ``link`` over the run."""
        kernel, nq = PlanarKernel(self.tree), self.tree.nq
        links, loc = np.array([link]), np.asarray(local, dtype=float)[None]
        P, D = np.zeros((len(self.t), 2)), np.zeros((len(self.t), 2, self.dy_du.shape[2]))
        for k, y in enumerate(self.y):
            kin = kernel.kinematics(y[:nq])
            P[k] = kernel.point_positions(kin, links, loc)[0]
            D[k] = kernel.jacobians(kin, links, P[k][None])[0] @ self.dy_du[k, :nq]
        return P, D


def _rhs(tree, y, stiffness, rest, sens):
    """ẏ and, when ``sens`` is given, Φ̇ = ∂F/∂y Φ (module docstring)."""
    nq = tree.nq
    q, qd = y[:nq], y[nq:]
    tau = -stiffness * (q - rest)
    qdd = aba_fast(tree, q, qd, tau)
    if sens is None:
        return np.concatenate([qd, qdd]), None
    dq, dqd, Minv = aba_derivatives(tree, q, qd, tau)
    Jq = dq - Minv * stiffness                        # + H⁻¹ ∂τ/∂q, ∂τ/∂q = −diag(k)
    return np.concatenate([qd, qdd]), np.concatenate([sens[nq:], Jq @ sens[:nq] + dqd @ sens[nq:]])


@contract(tree=Tree(), q0=JointPositions("tree"), qd0=Array(("tree.nv",)), T=Real(gt=0, le=100), h=Real(gt=0, le=1),
          free=Opt(Array((None,))), stiffness=Opt(Array(("tree.nv",))), rest=Opt(Array(("tree.nv",))),
          sensitivities=Flag())
def simulate_chain(tree, q0, qd0, T: float, h: float, free=None, stiffness=None, rest=None,
                   sensitivities: bool = True) -> ChainFlight:
    """S(t, u) of a tree without floating joints from (q0, q̇0) to T by RK4 with step ≈ h, with ∂y/∂u for
    u = q̇0[free] (default: the first three, a planar free base's launch) and joint springs
    τ = −stiffness (q − rest). Raises :class:`~pbanim.errors.SimulationDiverged` on a state that is not finite."""
    if tree.nq != tree.nv:
        raise InvalidInput("simulate_chain: the tree must have no floating joint (q ⊕ δ = q + δ): use a planar "
                           "free base (two sliders and a hinge)")
    free = np.arange(min(3, tree.nv)) if free is None else np.asarray(free, dtype=int)
    if free.size and (free.min() < 0 or free.max() >= tree.nv or len(set(free.tolist())) != free.size):
        raise InvalidInput(f"simulate_chain: free must be distinct indices of q̇ (0..{tree.nv - 1}), got {free}")
    k = np.zeros(tree.nv) if stiffness is None else np.asarray(stiffness, dtype=float)
    rest = np.zeros(tree.nv) if rest is None else np.asarray(rest, dtype=float)
    steps = int(np.ceil(T / h - 1e-9))
    if steps > MAX_STEPS:
        raise InvalidInput(f"simulate_chain: T/h = {steps} steps exceeds {MAX_STEPS}")
    dt, nq = T / steps, tree.nq
    y = np.concatenate([np.asarray(q0, dtype=float), np.asarray(qd0, dtype=float)])
    Phi = np.zeros((2 * nq, free.size))
    Phi[nq + free, np.arange(free.size)] = 1.0
    ys, Ps = [y], [Phi]
    S = Phi if sensitivities else None
    for n in range(steps):                              # RK4 on (y, Φ): the derivative of the RK4 map
        k1, l1 = _rhs(tree, y, k, rest, S)
        k2, l2 = _rhs(tree, y + 0.5 * dt * k1, k, rest, None if S is None else S + 0.5 * dt * l1)
        k3, l3 = _rhs(tree, y + 0.5 * dt * k2, k, rest, None if S is None else S + 0.5 * dt * l2)
        k4, l4 = _rhs(tree, y + dt * k3, k, rest, None if S is None else S + dt * l3)
        y = y + dt / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
        if S is not None:
            S = S + dt / 6 * (l1 + 2 * l2 + 2 * l3 + l4)
        if not (np.all(np.isfinite(y)) and (S is None or np.all(np.isfinite(S)))):
            raise SimulationDiverged(f"simulate_chain: the state is not finite at step {n + 1} (t = {(n + 1) * dt:.4g})")
        ys.append(y)
        Ps.append(Phi if S is None else S)
    return ChainFlight(np.linspace(0.0, T, steps + 1), np.array(ys), np.array(Ps), free, tree)


@contract(u=Array((None,), empty=True), flight=Obj(ChainFlight), residuals=Seq(Real(ge=0)), success=Flag(),
          history=Seq(Array((None,), empty=True)), flights=Seq(Obj(ChainFlight)))
@dataclass
class ChainAim:
    """A shooting design: the launch u found, the flight, the residual |p(T) − p*| and u per iterate, success."""

    u: np.ndarray
    flight: ChainFlight
    residuals: list
    success: bool
    history: list
    flights: list = field(default_factory=list)     # the flight of every iterate (the last is ``flight``)


@contract(tree=Tree(), q0=JointPositions("tree"), qd0=Array(("tree.nv",)), T=Real(gt=0, le=100), h=Real(gt=0, le=1),
          link=Index("tree.n"), local=Array((3,)), target=Array((2,)), tol=Real(gt=0), max_iter=Int(ge=1, le=100),
          stiffness=Opt(Array(("tree.nv",))), rest=Opt(Array(("tree.nv",))), free=Opt(Array((None,))))
def aim_chain(tree, q0, qd0, T: float, h: float, link: int, local, target, tol: float = 1e-8, max_iter: int = 20,
              stiffness=None, rest=None, free=None) -> ChainAim:
    """Single shooting: change u = q̇0[free] by min-norm updates δu = argmin |δu| s.t. (∂p/∂u) δu = p* − p(T)
    until the point ``local`` of ``link`` is at ``target`` at T (|residual| ≤ tol); at most ``max_iter``
    simulations. Certified: the returned flight's residual is recomputed from its own final state."""
    qd = np.array(qd0, dtype=float)
    target = np.asarray(target, dtype=float)
    residuals, history, flights = [], [], []
    for _ in range(max_iter):
        fl = simulate_chain(tree, q0, qd, T, h, free, stiffness, rest)
        history.append(qd[fl.free].copy())
        flights.append(fl)
        P, D = fl.point(link, local)
        r = target - P[-1]
        residuals.append(float(np.linalg.norm(r)))
        if residuals[-1] <= tol:
            break
        qd[fl.free] += min_norm_update(D[-1], r).du
    final = PlanarKernel(tree).points(fl.y[-1, :tree.nq], [link], np.asarray(local, dtype=float)[None])[0]
    success = float(np.linalg.norm(target - final)) <= tol
    return ChainAim(history[-1], fl, residuals, success, history, flights)
