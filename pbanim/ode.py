"""ODE solvers (chapter 02) — minimal seed; the full module (tableaux, implicit methods, adaptive
Dormand–Prince, events, batch mode, ``solve``) is being written on top of these contracts.

Contract used by every other module:

* ``fun(t, y) -> dy/dt`` on a flat float64 array (or shape (K, n) in batch mode).
* A mechanical state is ``y = [q, v]``; split methods take ``split`` = number of position components
  (default ``n // 2``).
* ``METHODS[name]`` is a :class:`Method` with ``order``, ``symplectic``, ``implicit``, ``adaptive`` and
  ``step(fun, t, y, h, split=None, jac=None) -> y_new``.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

import numpy as np

__all__ = ["Method", "METHODS", "get_method", "euler_step", "symplectic_euler_step", "rk4_step"]


@dataclass(frozen=True)
class Method:
    name: str
    order: int
    symplectic: bool
    implicit: bool
    adaptive: bool
    step: Callable
    description: str = ""


def _split(y: np.ndarray, split: int | None) -> int:
    n = y.shape[-1]
    return n // 2 if split is None else int(split)


def euler_step(fun, t, y, h, split=None, jac=None):
    """Explicit Euler: y₁ = y₀ + h f(t₀, y₀)."""
    return y + h * fun(t, y)


def symplectic_euler_step(fun, t, y, h, split=None, jac=None):
    """Symplectic Euler (kick then drift): v₁ = v₀ + h a(q₀, v₀); q₁ = q₀ + h q̇(q₀, v₁)."""
    s = _split(y, split)
    k = fun(t, y)
    y1 = np.array(y, dtype=float, copy=True)
    y1[..., s:] = y[..., s:] + h * k[..., s:]
    k2 = fun(t, y1)
    y1[..., :s] = y[..., :s] + h * k2[..., :s]
    return y1


def rk4_step(fun, t, y, h, split=None, jac=None):
    """Classical 4th-order Runge–Kutta."""
    k1 = fun(t, y)
    k2 = fun(t + h / 2, y + h / 2 * k1)
    k3 = fun(t + h / 2, y + h / 2 * k2)
    k4 = fun(t + h, y + h * k3)
    return y + h / 6 * (k1 + 2 * k2 + 2 * k3 + k4)


METHODS: dict[str, Method] = {
    "euler": Method("euler", 1, False, False, False, euler_step, "explicit Euler"),
    "symplectic_euler": Method("symplectic_euler", 1, True, False, False, symplectic_euler_step,
                               "symplectic Euler (kick-drift)"),
    "rk4": Method("rk4", 4, False, False, False, rk4_step, "classical Runge–Kutta 4"),
}


def get_method(name: str) -> Method:
    """Look up a method by name, with a clear error listing the known names."""
    try:
        return METHODS[name]
    except KeyError:
        raise ValueError(f"method must be one of {sorted(METHODS)}, got {name!r}") from None
