"""Centred finite differences: the one reference every analytic derivative in pbanim is checked against.

Used by the Jacobian checks of the lectures (constraints, ch03: J and J̇q̇ of a constraint; reduced
coordinates, ch04: J and J̇u̇ of a chart) and by :func:`pbanim.testing.check_grad` (force Jacobians, ch01).
The implicit integrators use a one-sided, batched difference of their own (``pbanim.ode.implicit``):
it costs n evaluations instead of 2n and only feeds a Newton matrix, never a verdict.

For a smooth f the centred difference (f(x + εe_j) − f(x − εe_j)) / 2ε has truncation error
ε²/6·f‴ and roundoff ≈ ε_mach·|f|/ε, smallest near ε ≈ ε_mach^(1/3) ≈ 6e-6 (relative to the scale of x).

>>> central_jacobian(lambda x: np.array([x[0] * x[1], np.sin(x[0])]), np.array([1.0, 2.0]))
array([[2.        , 1.        ],
       [0.54030231, 0.        ]])
"""

from __future__ import annotations

from typing import Callable

import numpy as np

from .contracts import Array, Flag, Func, Real, contract, finite_result

__all__ = ["central_jacobian", "directional_derivative"]


@contract(f=Func(), x=Array(None), eps=Real(gt=0), relative=Flag(), returns=finite_result)
def central_jacobian(f: Callable[[np.ndarray], np.ndarray], x, eps: float = 1e-6,
                     relative: bool = False) -> np.ndarray:
    """∂f/∂x at x by centred differences, shape (f.size, x.size); f's output is flattened.

    ``relative``: step ε·max(1, |xⱼ|) per column instead of ε.
    """
    x = np.asarray(x, dtype=float)
    flat = x.ravel()
    cols = []
    for j in range(flat.size):
        step = eps * max(1.0, abs(flat[j])) if relative else eps
        dx = np.zeros_like(flat)
        dx[j] = step
        fp = np.ravel(f((flat + dx).reshape(x.shape)))
        fm = np.ravel(f((flat - dx).reshape(x.shape)))
        cols.append((np.asarray(fp, dtype=float) - np.asarray(fm, dtype=float)) / (2.0 * step))
    return np.column_stack(cols) if cols else np.zeros((0, 0))


@contract(g=Func(), x=Array(None), direction=Array(None), eps=Real(gt=0), returns=finite_result)
def directional_derivative(g: Callable[[np.ndarray], np.ndarray], x, direction, eps: float = 1e-6) -> np.ndarray:
    """d/ds g(x + s·direction) at s = 0 by a centred difference (e.g. J̇q̇ = d/ds [J(q + s q̇) q̇])."""
    x = np.asarray(x, dtype=float)
    if np.size(direction) != x.size:
        from .errors import InvalidInput
        raise InvalidInput(f"directional_derivative: direction must have the size of x ({x.size}), got "
                           f"shape {np.shape(direction)}")
    d = np.asarray(direction, dtype=float).reshape(x.shape)
    return (np.asarray(g(x + eps * d), dtype=float) - np.asarray(g(x - eps * d), dtype=float)) / (2.0 * eps)
