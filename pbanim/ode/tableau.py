"""Butcher tableaux as data, and the one stepper that turns a tableau into a step function (chapter 02).

An explicit s-stage Runge–Kutta method is its tableau (A, b, c):

    kᵢ = f(t + cᵢh, y + h Σⱼ<ᵢ aᵢⱼ kⱼ),   i = 1 … s,        y₁ = y + h Σᵢ bᵢ kᵢ.

An *embedded pair* adds a second weight vector b̂ of lower order p̂; the difference
y₁ − ŷ₁ = h Σᵢ (bᵢ − b̂ᵢ) kᵢ = h Σᵢ eᵢ kᵢ is the local error estimate that drives step-size control
(:mod:`pbanim.ode.control`). A *continuous extension* (dense output) replaces the constants bᵢ by
polynomials bᵢ(θ), so y(t + θh) ≈ y + h Σᵢ bᵢ(θ) kᵢ for θ ∈ [0, 1] at no (or a few) extra evaluations.

Notation
--------
======  ============  ==============================================
symbol  code          meaning
======  ============  ==============================================
A       ``A``         (s, s) stage coefficients, strictly lower
b       ``B``         (s,) weights of the propagated solution
c       ``C``         (s,) nodes, cᵢ = Σⱼ aᵢⱼ (checked)
e       ``E``         b − b̂, weights of the error estimate
p, p̂    ``order``,    order of b, of the embedded b̂
        ``embedded_order``
======  ============  ==============================================

Limiting cases: s = 1, b = (1) is explicit Euler; a tableau of order p integrates y' = p t^(p−1)
exactly (its quadrature conditions Σ bᵢcᵢ^(k−1) = 1/k hold for k ≤ p). The order conditions are
the rooted-tree conditions Σ bᵢ Φᵢ(τ) = 1/γ(τ) (Butcher), checked for every registered tableau in
``tests/test_ode.py`` up to its order (ORACLES A9).

References: Butcher, *Numerical Methods for Ordinary Differential Equations* (2016), §23–32;
Hairer, Nørsett & Wanner, *Solving ODEs I*, §II.1–II.2 (order conditions, rooted trees).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Callable

import numpy as np

from ..contracts import Array, Int, Opt, Text, contract
from ..errors import InvalidInput

__all__ = ["Tableau", "make_rk_step"]

_EPS = np.finfo(float).eps


@contract(name=Text(nonempty=True), A=Array(("s", "s")), B=Array(("s",)), C=Array(("s",)), order=Int(ge=1),
          E=Opt(Array(("s",))), embedded_order=Opt(Int(ge=1)))
@dataclass(frozen=True)
class Tableau:
    """An explicit Runge–Kutta method  kᵢ = f(t + cᵢh, y + h Σⱼ aᵢⱼ kⱼ),  y₁ = y + h Σᵢ bᵢ kᵢ.

    ``E`` (optional) holds b − b̂ of an embedded formula of order ``embedded_order``, so the local
    error estimate is h Σᵢ eᵢ kᵢ. Building a tableau checks ΣB = 1, Σⱼ aᵢⱼ = cᵢ (to 16ε times the
    size of the coefficients: the published decimals of high-order pairs are rounded) and that A is
    strictly lower triangular.
    """

    name: str
    A: np.ndarray
    B: np.ndarray
    C: np.ndarray
    order: int
    E: np.ndarray | None = None
    embedded_order: int | None = None
    rows: tuple = field(init=False, repr=False)

    def __post_init__(self):
        A, B, C = (np.asarray(x, dtype=float) for x in (self.A, self.B, self.C))
        s = len(B)
        if A.shape != (s, s) or C.shape != (s,):
            raise InvalidInput(f"tableau {self.name}: A must be ({s}, {s}) and C ({s},), got {A.shape}, {C.shape}")
        if abs(B.sum() - 1.0) > max(1e-14, 16 * _EPS * np.abs(B).sum()):
            raise InvalidInput(f"tableau {self.name}: weights B must sum to 1, got {B.sum()!r}")
        slack = np.maximum(1e-14, 16 * _EPS * np.abs(A).sum(axis=1))
        if np.any(np.abs(A.sum(axis=1) - C) > slack):
            raise InvalidInput(f"tableau {self.name}: rows of A must sum to C")
        if np.any(np.triu(A) != 0):
            raise InvalidInput(f"tableau {self.name}: A must be strictly lower triangular (explicit method)")
        if self.E is not None:
            E = np.asarray(self.E, dtype=float)
            if E.shape != (s,):
                raise InvalidInput(f"tableau {self.name}: E must have shape ({s},), got {E.shape}")
            object.__setattr__(self, "E", E)
        object.__setattr__(self, "A", A)
        object.__setattr__(self, "B", B)
        object.__setattr__(self, "C", C)
        # nonzero coefficients per stage, precomputed so the stepper skips the zeros
        rows = tuple(tuple((j, A[i, j]) for j in range(i) if A[i, j] != 0) for i in range(s))
        object.__setattr__(self, "rows", rows)

    @property
    def stages(self) -> int:
        return len(self.B)


def _grouped(pairs) -> tuple:
    """Σ aⱼ kⱼ as ((a, j₀, (j₁, …)), …): the stages that share a coefficient a are summed, then multiplied."""
    groups: dict = {}
    for j, a in pairs:
        groups.setdefault(float(a), []).append(j)
    return tuple((a, js[0], tuple(js[1:])) for a, js in groups.items())


def _increment(k: list, h: float, groups: tuple):
    """h Σ aⱼ kⱼ over the grouped nonzero coefficients: (k₀ + k₃)·(h a) + (k₁ + k₂)·(h b) + …"""
    (a, j0, more), *rest = groups
    s = k[j0]
    for j in more:
        s = s + k[j]
    inc = s * (h * a)
    for a, j0, more in rest:
        s = k[j0]
        for j in more:
            s = s + k[j]
        inc = inc + s * (h * a)
    return inc


def make_rk_step(tab: Tableau) -> Callable:
    """Turn a tableau into a step function ``step(fun, t, y, h, split=None, jac=None)``.

    The coefficients are read once, here. A tableau whose every stage uses only the one before it
    (Euler, midpoint, RK4) gets a closure that keeps only the last stage; a tableau with a dozen stages
    or more (DOP853, Verner) stacks its stages in one preallocated array and forms every stage sum
    Σⱼ aᵢⱼkⱼ as one matrix–vector product; any other (Dormand–Prince 5) sums its nonzero coefficients
    grouped by value. All three compute the same formula as the readable loop
    :func:`pbanim.ode.explicit_rk_step` (the tests check that they agree).
    """
    s = tab.stages
    weights = _grouped((i, b) for i, b in enumerate(tab.B) if b != 0)
    if all(len(tab.rows[i]) == 1 and tab.rows[i][0][0] == i - 1 for i in range(1, s)):
        chain = tuple((float(tab.C[i]), float(tab.rows[i][0][1])) for i in range(1, s))

        def step(fun, t, y, h, split=None, jac=None):
            last = fun(t, y)
            k = [last]
            for c, a in chain:
                last = fun(t + c * h, y + last * (h * a))
                k.append(last)
            return y + _increment(k, h, weights)
    elif s >= 9:
        used = int(np.flatnonzero(tab.B)[-1]) + 1     # stages after the last weight feed only b̂
        rows = [tab.A[i, :i].copy() for i in range(used)]
        C, B = tab.C, tab.B[:used].copy()

        def step(fun, t, y, h, split=None, jac=None):
            y = np.asarray(y)
            K = np.empty((used,) + y.shape, dtype=np.result_type(y, float))
            K[0] = fun(t, y)
            for i in range(1, used):
                K[i] = fun(t + C[i] * h, y + np.tensordot(h * rows[i], K[:i], axes=1))
            return y + np.tensordot(h * B, K, axes=1)
    else:
        stages = tuple((float(tab.C[i]), _grouped(tab.rows[i])) for i in range(1, s))

        def step(fun, t, y, h, split=None, jac=None):
            k = [fun(t, y)]
            for c, groups in stages:
                k.append(fun(t + c * h, y + _increment(k, h, groups)) if groups else fun(t + c * h, y))
            return y + _increment(k, h, weights)

    step.__name__ = step.__qualname__ = f"{tab.name}_step"
    step.tableau = tab
    step.nfev = int(np.flatnonzero(tab.B)[-1]) + 1 if s >= 9 else s  # right-hand-side evaluations per step
    return step
