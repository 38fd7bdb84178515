"""Fast forward dynamics q̈ = FD(q, q̇, τ): the world-frame ABA on floats or on batches (chapter 08).

:func:`aba_fast` runs the one kernel of :mod:`.fastkernel` (equations in :mod:`.fastplan`) two ways:

* one state, q of shape (nq,): every component is a Python float. For a small tree the cost of a numpy
  call (~1 µs) dwarfs its arithmetic, so plain floats — about 400 operations of ~10 ns per link — beat
  numpy by an order of magnitude; the plan (joint frames, placements, inertias) is built once per tree.
* K states, q of shape (K, nq): every component is an array of K values, so each of the ~400 operations
  per link is one numpy call over the whole batch (the batch axis last and contiguous: q is transposed
  once). ``aba_batch`` of :mod:`.batched` is this path.

Both return the same q̈ as the readable :func:`~pbanim.articulated.dynamics.aba` up to roundoff
(ORACLES I5; the readable version is the one to study), joint damping −b q̇ and external forces f̂ᵉˣᵗ
(link coordinates, (n, 6) or (K, n, 6)) included. Invalid input raises :class:`~pbanim.errors.InvalidInput`
naming the argument (the contract, checked once at the call; the loops check nothing), a joint whose subtree
has no inertia about its axis :class:`~pbanim.errors.SingularChartError` and an overflow
:class:`~pbanim.errors.NonFiniteResult`, as the readable version does, one state or a batch alike.

Cost (``pbanim bench articulated``, 10-link chain): see the benchmark's table; the single-state goal is
≤ 30× and the batched one ≤ 1× Pinocchio's C++ ABA called once per state from Python.
"""

from __future__ import annotations

from math import cos, isfinite, sin

import numpy as np

from ..contracts import Array, Opt, contract
from ..errors import InvalidInput, NonFiniteResult
from .dynamics import external_forces, pivot_error
from .fastbatch import sweep_batch
from .fastkernel import sweep
from .fastplan import REVOLUTE, plan_for
from .specs import JointPositions, Tree
from .tree import ArticulatedTree

__all__ = ["aba_fast", "batch_of"]

_HUGE = "of a tree and state with huge entries"


def _pivot_float(D, i, floor):
    if not abs(D) > floor:                      # NaN lands here too
        raise pivot_error(D, f"joint {i}", None, f" (pivot {D!r} ≤ {floor:.3g})")
    return 1.0 / D


def _pivot_array(D, i, floor):
    bad = ~(np.abs(D) > floor)
    if np.any(bad):
        k = int(np.argmax(bad))
        raise pivot_error(D[k], f"joint {i}", None, f" in state {k} of the batch")
    return 1.0 / D


def _check_quaternions(P, q) -> None:
    """A zero quaternion (reachable from inside, e.g. a diverging run) is named, not divided by."""
    for i, k in P.floating_q:
        norm2 = q[k] * q[k] + q[k + 1] * q[k + 1] + q[k + 2] * q[k + 2] + q[k + 3] * q[k + 3]
        if not np.all(norm2 > 1e-300):
            raise InvalidInput(f"q: the quaternion q[{k}:{k + 4}] of floating joint {i} must be non-zero")


def batch_of(q, **others):
    """(single, q (K, nq), [each of ``others`` as (K, ·)]): one state, or K states for every argument alike
    (a cross-argument condition no single spec says: InvalidInput naming the argument)."""
    q = np.asarray(q, dtype=float)
    out = []
    for name, a in others.items():
        a = np.asarray(a, dtype=float)
        if a.shape[:-1] != q.shape[:-1]:
            held = "one state" if q.ndim == 1 else f"K = {q.shape[0]}"
            raise InvalidInput(f"{name} must hold the states of q ({held}), got shape {a.shape} for q of shape {q.shape}")
        out.append(a if a.ndim == 2 else a[None])
    return q.ndim == 1, (q if q.ndim == 2 else q[None]), out


def _joint_frame_forces(P, f: np.ndarray) -> np.ndarray:
    """f̂ᵉˣᵗ (..., n, 6) in link coordinates → joint-frame coordinates (Q_iᵀ on both halves)."""
    return np.einsum("nab,...nkb->...nka", P.Qt, f.reshape(f.shape[:-1] + (2, 3))).reshape(f.shape)


def _list(x) -> list:
    return x.tolist() if type(x) is np.ndarray else np.asarray(x, dtype=float).tolist()


def _one(tree: ArticulatedTree, q, qd, tau, f_ext) -> np.ndarray:
    P = plan_for(tree)
    q, qd, tau = _list(q), _list(qd), _list(tau)
    if P.floating_q:
        _check_quaternions(P, q)
    if P.damping.any():
        tau = [t - b * v for t, b, v in zip(tau, P.damping.tolist(), qd)]
    trig = [(cos(q[lp.qi]), sin(q[lp.qi])) if lp.kind == REVOLUTE else None for lp in P.links]
    fx = [None] * P.n if f_ext is None else _joint_frame_forces(P, external_forces(tree, f_ext)).tolist()
    qdd = sweep(P, q, qd, tau, trig, fx, _pivot_float)
    if not all(map(isfinite, qdd)):
        raise NonFiniteResult("aba_fast", _HUGE)
    return np.array(qdd)


def _many(tree: ArticulatedTree, q, qd, tau, f_ext) -> np.ndarray:
    P = plan_for(tree)
    _, q, (qd, tau) = batch_of(q, qd=qd, tau=tau)
    F = None
    if f_ext is not None:
        F = np.ascontiguousarray(_joint_frame_forces(P, external_forces(tree, f_ext, q.shape[0])).transpose(2, 1, 0))
    with np.errstate(over="ignore", invalid="ignore"):
        out = sweep_batch(P, q, qd, tau, F, _pivot_array, _check_quaternions)
    if not np.all(np.isfinite(out)):
        raise NonFiniteResult("aba_batch", _HUGE)
    return out.T.copy()                     # out is the plan's buffer, reused by the next call


_QB = JointPositions("tree", batch="first")
_VB = Array(("tree.nv",), batch="first", empty=True)


@contract(tree=Tree(), q=_QB, qd=_VB, tau=_VB, f_ext=Opt(Array(("tree.n", 6), batch="first")))
def aba_fast(tree: ArticulatedTree, q, qd, tau, f_ext=None) -> np.ndarray:
    """q̈ by the world-frame ABA: q (nq,) → (nv,) on Python floats, or q (K, nq) → (K, nv) on arrays.

    >>> from pbanim.models.articulated import pendulum_chain
    >>> tree = pendulum_chain(2)
    >>> q = np.array([0.3, -0.2]); qd = np.array([1.0, 0.5]); tau = np.zeros(2)
    >>> from pbanim.articulated import aba
    >>> bool(np.allclose(aba_fast(tree, q, qd, tau), aba(tree, q, qd, tau), rtol=0, atol=1e-13))
    True
    """
    if np.ndim(q) == 1:
        if np.ndim(qd) != 1 or np.ndim(tau) != 1:
            batch_of(q, qd=qd, tau=tau)             # raises, naming the argument that holds a batch
        return _one(tree, q, qd, tau, f_ext)
    return _many(tree, q, qd, tau, f_ext)
