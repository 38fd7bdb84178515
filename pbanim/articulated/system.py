"""Simulating an articulated tree in reduced coordinates (chapter 08).

The state is y = [q, q̇] (nq + nv); its derivative is ẏ = (q̇ ↦ dq/dt, ABA(q, q̇, τ(t, q, q̇))). For
revolute, prismatic and fixed joints dq/dt = q̇. A floating joint's q = (quaternion w, x, y, z, origin p)
and q̇ = (ω, v) in the link's own axes, so

    d(quat)/dt = ½ quat ⊗ (0, ω),     dp/dt = R(quat) v,

and the quaternion is renormalized after every step (as :class:`pbanim.rigid.RigidScene` does). Runs go
through the one fixed-step driver (:mod:`pbanim.ode.driver`) with any method of :data:`pbanim.METHODS`.
A tree without floating joints steps on a lean path: ẏ on Python floats straight through the ABA sweep of
:mod:`.fastkernel` (the plan, the revolute joints and the torque bound once per run), the same arithmetic as
:meth:`ArticulatedSystem.rhs` bit for bit (tested); a state it cannot take (a q̈ that is not finite) goes to
:meth:`~ArticulatedSystem.rhs`, which raises its named error.
Joint position limits are not held here (a smooth right-hand side cannot stop a joint; the contact stepper
:class:`~pbanim.articulated.contact.ArticulatedContact` holds them as stops): a run reports how far past them
it went. Energy E = ½ q̇ᵀH q̇ + V(q) is conserved without damping or torques: the tests measure its drift as a
slope in h (ORACLES I3). The energy series is computed when it is read, from the recorded states at once
(:func:`~pbanim.articulated.batched.energy_batch`; ``diagnostics="lazy"``, the default), at the recorded
times during the run (``diagnostics=True``), or not at all (``False``).
"""

from __future__ import annotations

import time
from math import cos, isfinite, sin
from typing import Callable

import numpy as np

from ..contracts import Array, Choice, Either, Flag, Func, Int, Opt, Real, contract, finite_result, unchecked
from ..errors import InvalidInput
from ..ode import METHODS, get_method
from ..ode.driver import MAX_STEPS, check_finite, drive, step_grid
from ..results import LazyDiagnostics, SimResult
from .batched import aba_batch, energy_batch
from .fast import _pivot_float, aba_fast
from .fastkernel import sweep
from .fastplan import REVOLUTE, plan_for
from .dynamics import kinetic_energy, potential_energy
from .specs import JointPositions, Tree
from .tree import ArticulatedTree

_Y = JointPositions("self.tree", state=True)

__all__ = ["ArticulatedSystem"]


class ArticulatedSystem:
    """A tree with initial state (q0, q̇0) and joint forces ``torque(t, q, q̇) -> τ`` (default zero).

    >>> from pbanim.articulated import ArticulatedTree
    >>> tree = ArticulatedTree(gravity=(0.0, -9.81, 0.0))
    >>> _ = tree.add("link", -1, "revolute", axis=[0, 0, 1], mass=1.0, com=[0, -1, 0])
    >>> sysm = ArticulatedSystem(tree, q0=[0.5])
    >>> res = sysm.simulate(1.0, 1e-3, "rk4")
    >>> bool(abs(res.diagnostics["energy"][-1] - res.diagnostics["energy"][0]) < 1e-9)
    True
    """

    @contract(tree=Tree(), q0=Opt(JointPositions("tree")), qd0=Opt(Array(("tree.nv",), empty=True)), torque=Opt(Func()))
    def __init__(self, tree: ArticulatedTree, q0=None, qd0=None, torque: Callable | None = None) -> None:
        self.tree = tree
        self.q0 = tree.neutral() if q0 is None else np.array(q0, dtype=float)
        self.qd0 = np.zeros(tree.nv) if qd0 is None else np.array(qd0, dtype=float)
        self.torque = torque
        self.nq, self.nv, self.split = tree.nq, tree.nv, tree.nq
        self._floating = [(s.start, v.start) for j, s, v in zip(tree.joints, tree._q_index, tree._v_index)
                          if j.kind == "floating"]
        # the q̇ entries of the other joints, in q order (for them nq = nv and dq/dt = q̇)
        self._plain_v = [c for j, v in zip(tree.joints, tree._v_index) if j.kind != "floating"
                         for c in range(v.start, v.stop)]
        self.nfev = 0

    @property
    def n_state(self) -> int:
        """The length of the flat state y = [q, q̇]: nq + nv."""
        return self.nq + self.nv

    def state(self) -> np.ndarray:
        return np.concatenate([self.q0, self.qd0])

    def _tau(self, t, q, qd):
        """τ(t, q, q̇) from the user's callable: a value from outside arriving inside, checked here."""
        if self.torque is None:
            return np.zeros(qd.shape)
        tau = np.asarray(self.torque(t, q, qd), dtype=float)
        if tau.shape != qd.shape:
            raise InvalidInput(f"torque(t, q, qd) must return shape {qd.shape}, got {tau.shape}")
        if not np.isfinite(tau).all():
            raise InvalidInput(f"torque(t, q, qd) must return finite joint forces, got {tau} at t = {t}")
        return tau

    @contract(q=JointPositions("self.tree", batch="first"), qd=Array(("self.nv",), batch="first", empty=True),
              returns=finite_result)
    def qdot(self, q: np.ndarray, qd: np.ndarray) -> np.ndarray:
        """dq/dt from q̇ (differs from q̇ only on floating joints), batched over leading axes."""
        if q.shape[:-1] != qd.shape[:-1]:
            raise InvalidInput(f"qd must hold the states of q, got shapes {qd.shape} and {q.shape}")
        if not self._floating:
            return qd
        from ..rigid.quat import quat_multiply, quat_to_matrix

        out = np.zeros(q.shape)
        pos = np.ones(q.shape[-1], bool)
        for qs, vs in self._floating:
            pos[qs:qs + 7] = False
        out[..., pos] = qd[..., self._plain_v]
        for qs, vs in self._floating:
            quat, w, v = q[..., qs:qs + 4], qd[..., vs:vs + 3], qd[..., vs + 3:vs + 6]
            out[..., qs:qs + 4] = 0.5 * quat_multiply(quat, np.concatenate([np.zeros(w.shape[:-1] + (1,)), w], -1))
            n = quat / np.linalg.norm(quat, axis=-1, keepdims=True)
            out[..., qs + 4:qs + 7] = np.einsum("...ij,...j->...i", quat_to_matrix(n), v)
        return out

    @contract(t=Real(), y=JointPositions("self.tree", state=True, batch="first"), returns=finite_result)
    def rhs(self, t: float, y: np.ndarray) -> np.ndarray:
        """ẏ = (dq/dt, q̈) for y of shape (nq + nv,) or (K, nq + nv) (batched ABA)."""
        self.nfev += 1
        q, qd = y[..., :self.nq], y[..., self.nq:]
        tau = self._tau(t, q, qd)
        qdd = aba_fast(self.tree, q, qd, tau) if y.ndim == 1 else aba_batch(self.tree, q, qd, tau)
        return np.concatenate([self.qdot(q, qd), qdd], axis=-1)

    @contract(y=_Y, returns=finite_result)
    def energy(self, y: np.ndarray) -> float:
        q, qd = y[:self.nq], y[self.nq:]
        return kinetic_energy(self.tree, q, qd) + potential_energy(self.tree, q)

    def _renormalize(self, y):
        for qs, _ in self._floating:
            y[qs:qs + 4] /= np.linalg.norm(y[qs:qs + 4])
        return y

    def _lean_rhs(self) -> Callable | None:
        """ẏ(t, y) on Python floats for a tree without floating joints, bound once (None for a tree with one):
        :func:`~pbanim.articulated.fast.aba_fast`'s one-state path and :meth:`rhs`'s assembly, operation for
        operation, without the calls between them. A q̈ that is not finite goes to :meth:`rhs`, which raises."""
        if self._floating:
            return None
        P, nq, nv = plan_for(self.tree), self.nq, self.nv
        damping = P.damping.tolist() if P.damping.any() else None
        revolute = [lp.qi if lp.kind == REVOLUTE else -1 for lp in P.links]
        fx, zero = [None] * P.n, [0.0] * nv
        torque, readable = (self._tau if self.torque is not None else None), unchecked(self.rhs)

        def rhs(t, y):
            self.nfev += 1
            yl = y.tolist()
            q, qd = yl[:nq], yl[nq:]
            tau = zero if torque is None else torque(t, y[:nq], y[nq:]).tolist()
            if damping is not None:
                tau = [x - b * v for x, b, v in zip(tau, damping, qd)]
            trig = [(cos(q[k]), sin(q[k])) if k >= 0 else None for k in revolute]
            qdd = sweep(P, q, qd, tau, trig, fx, _pivot_float)
            if not all(map(isfinite, qdd)):
                self.nfev -= 1
                return readable(t, y)
            return np.array(qd + qdd)

        return rhs

    @contract(t_end=Real(gt=0), h=Real(gt=0), method=Choice(lambda: METHODS), record_every=Int(ge=1),
              max_steps=Int(ge=1), diagnostics=Either(Flag(), Choice(("lazy",))))
    def simulate(self, t_end: float, h: float, method: str = "rk4", *, record_every: int = 1,
                 max_steps: int = MAX_STEPS, diagnostics: bool | str = "lazy") -> SimResult:
        """Fixed steps through the one driver. ``diagnostics["energy"]`` at every recorded state, and when
        a joint has position limits ``diagnostics["limit_excursion"]``: how far (rad or m) the recorded state
        is past them, 0 inside. This smooth integration does not hold the limits (the contact stepper
        :class:`~pbanim.articulated.contact.ArticulatedContact` does): the diagnostic says when that matters.

        ``diagnostics``: "lazy" (default) computes both from the recorded states the first time
        ``result.diagnostics`` is read (a run nobody asks about pays nothing); True computes the energy at
        the recorded times during the run (what the readable loop did); False records none."""
        grid = step_grid(0.0, t_end, h, max_steps=max_steps, record_every=record_every)
        m = get_method(method)
        y = self.state()
        check_finite(y, 0.0, 0, "initial state")
        during = diagnostics is True
        energy = unchecked(self.energy)
        ts, ys, es = [0.0], [y.copy()], ([energy(y)] if during else None)
        lean = self._lean_rhs()
        if lean is not None:
            step = m.step

            def advance(t, yy, hk):
                return step(lean, t, yy, hk, split=self.nq)
        else:
            def advance(t, yy, hk):
                return self._renormalize(m.step(self.rhs, t, yy, hk, split=self.nq))

        def record(t1, y1):
            ts.append(t1)
            ys.append(y1.copy())
            if during:
                es.append(energy(y1))

        start = time.perf_counter()
        drive(advance, grid, y, record=record, record_every=record_every)
        wall = time.perf_counter() - start
        Y = np.array(ys).T
        if diagnostics is False:
            diag = {}
        elif during:
            diag = self._diagnostics(Y, np.array(es))
        else:
            diag = LazyDiagnostics(lambda: self._diagnostics(Y))
        return SimResult(t=np.array(ts), y=Y, nfev=self.nfev, wall_time=wall, method=method, nsteps=grid.n_steps,
                         diagnostics=diag)

    def _diagnostics(self, Y: np.ndarray, energies: np.ndarray | None = None) -> dict:
        """The energy (from the recorded states Y (nq + nv, R) at once unless given) and the limit excursion."""
        if energies is None:
            with np.errstate(over="ignore", invalid="ignore"):
                energies = unchecked(energy_batch)(self.tree, Y[:self.nq].T, Y[self.nq:].T)
        diag = {"energy": np.asarray(energies, dtype=float)}
        lim = self.tree.limited()
        if lim:
            qi, lo, hi = (np.array([r[k] for r in lim]) for k in (0, 2, 3))
            q = Y[qi.astype(int)]
            diag["limit_excursion"] = np.maximum(np.maximum(lo[:, None] - q, q - hi[:, None]), 0.0).max(axis=0)
        return diag
