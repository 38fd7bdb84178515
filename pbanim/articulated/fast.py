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
naming the argument; a joint whose subtree has no inertia about its axis raises
:class:`~pbanim.errors.SingularChartError`, as the readable version does.

Cost (``pbanim bench articulated``, 10-link chain): see the benchmark's table; the single-state goal is
≤ 30× and the batched one ≤ 1× Pinocchio's C++ ABA called once per state from Python.
"""

from __future__ import annotations

from math import cos, isfinite, sin

import numpy as np

from ..errors import InvalidInput, SingularChartError
from .dynamics import external_forces
from .fastbatch import sweep_batch
from .fastkernel import sweep
from .fastplan import FLOATING, REVOLUTE, plan_for
from .tree import ArticulatedTree

__all__ = ["aba_fast"]


def _pivot_float(D, i, floor):
    if not abs(D) > floor:
        raise SingularChartError(np.inf, None, f"joint {i} has (nearly) zero articulated inertia about its axis "
                                 f"(pivot {D!r} ≤ {floor:.3g})")
    return 1.0 / D


def _pivot_array(D, i, floor):
    bad = ~(np.abs(D) > floor)
    if np.any(bad):
        k = int(np.argmax(bad))
        raise SingularChartError(np.inf, None, f"joint {i} has (nearly) zero articulated inertia about its axis in "
                                 f"state {k} of the batch")
    return 1.0 / D


def _vector(x, n: int, name: str) -> list:
    a = np.asarray(x, dtype=float)
    if a.shape != (n,):
        raise InvalidInput(f"{name} must have shape ({n},) for one state (or (K, {n}) for K states), got shape "
                           f"{a.shape}")
    out = a.tolist()
    if not all(map(isfinite, out)):
        raise InvalidInput(f"{name} must be finite, got {out}")
    return out


def _check_quaternions(P, q) -> None:
    for i, lp in enumerate(P.links):
        if lp.kind == FLOATING:
            k = lp.qi
            norm2 = q[k] * q[k] + q[k + 1] * q[k + 1] + q[k + 2] * q[k + 2] + q[k + 3] * q[k + 3]
            if not np.all(norm2 > 1e-300):
                raise InvalidInput(f"q: the quaternion q[{k}:{k + 4}] of floating joint {i} must be non-zero")


def _joint_frame_forces(P, f: np.ndarray) -> np.ndarray:
    """f̂ᵉˣᵗ (..., n, 6) in link coordinates → joint-frame coordinates (Q_iᵀ on both halves)."""
    return np.einsum("nab,...nkb->...nka", P.Qt, f.reshape(f.shape[:-1] + (2, 3))).reshape(f.shape)


def _one(tree: ArticulatedTree, q, qd, tau, f_ext) -> np.ndarray:
    P = plan_for(tree)
    q, qd, tau = _vector(q, P.nq, "q"), _vector(qd, P.nv, "qd"), _vector(tau, P.nv, "tau")
    _check_quaternions(P, q)
    if P.damping.any():
        tau = [t - b * v for t, b, v in zip(tau, P.damping.tolist(), qd)]
    trig = [(cos(q[lp.qi]), sin(q[lp.qi])) if lp.kind == REVOLUTE else None for lp in P.links]
    fx = [None] * P.n if f_ext is None else _joint_frame_forces(P, external_forces(tree, f_ext)).tolist()
    qdd = sweep(P, q, qd, tau, trig, fx, _pivot_float)
    if not all(map(isfinite, qdd)):
        raise SingularChartError(np.inf, q, "ABA's accelerations are not finite (overflowing inputs)")
    return np.array(qdd)


def _many(tree: ArticulatedTree, q, qd, tau, f_ext) -> np.ndarray:
    P = plan_for(tree)
    q, qd = tree.check_state(q, qd)
    _, tau = tree.check_state(q, tau, name_qd="tau")
    F = None
    if f_ext is not None:
        F = np.ascontiguousarray(_joint_frame_forces(P, external_forces(tree, f_ext, q.shape[0])).transpose(2, 1, 0))
    with np.errstate(over="ignore", invalid="ignore"):
        out = sweep_batch(P, q, qd, tau, F, _pivot_array, _check_quaternions)
    if not np.all(np.isfinite(out)):
        raise SingularChartError(np.inf, None, "ABA's accelerations are not finite (overflowing inputs)")
    return out.T.copy()                     # out is the plan's buffer, reused by the next call


def aba_fast(tree: ArticulatedTree, q, qd, tau, f_ext=None) -> np.ndarray:
    """q̈ by the world-frame ABA: q (nq,) → (nv,) on Python floats, or q (K, nq) → (K, nv) on arrays.

    >>> from pbanim.models.articulated import pendulum_chain
    >>> tree = pendulum_chain(2)
    >>> q = np.array([0.3, -0.2]); qd = np.array([1.0, 0.5]); tau = np.zeros(2)
    >>> from pbanim.articulated import aba
    >>> bool(np.allclose(aba_fast(tree, q, qd, tau), aba(tree, q, qd, tau), rtol=0, atol=1e-13))
    True
    """
    if not isinstance(tree, ArticulatedTree):
        raise InvalidInput(f"tree must be an ArticulatedTree, got {type(tree).__name__}")
    if np.ndim(q) == 1:
        return _one(tree, q, qd, tau, f_ext)
    return _many(tree, q, qd, tau, f_ext)
