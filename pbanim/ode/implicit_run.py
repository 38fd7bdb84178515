"""Implicit Euler and the implicit midpoint rule over a whole fixed-step run: the Newton matrix kept across steps.

:func:`pbanim.ode.implicit.newton_solve` solves z = y₀ + θh f(t + θh, z) (θ = 1: implicit Euler, y₁ = z;
θ = ½: the implicit midpoint rule, y₁ = 2z − y₀) by simplified Newton with M = I − θhJ evaluated and factored
at the step start. Over a run of many small steps J changes by O(h) per step, so the M of an earlier step
contracts about as well: :class:`NewtonSteps` keeps it while the same contraction test that makes
``newton_solve`` refresh J within a step is passed (a correction at most a tenth of the previous one;
Hairer & Wanner, *Solving ODEs II*, §IV.8, "the Jacobian is kept over several steps"). When the test fails, J is
re-evaluated at the current iterate and refactored, as in ``newton_solve``. Each step still stops on
``newton_solve``'s criterion ‖Δz‖∞ ≤ tol·(1 + ‖z‖∞), so the states equal those of the per-step
``newton_solve`` to the Newton tolerance (the fixed point is the same; only the iterates that reach it
differ). What it saves per step: the Jacobian (n evaluations of f by forward differences, or one ``jac``
call) and one LU, for about one more Newton iteration. Two more savings, the same stopping test: Newton
starts from z⁰ = y₀ + (z − y₀) of the previous step at the same h (off by O(h²) instead of O(h): about half
an iteration fewer), and a small dense M (n ≤ :data:`~pbanim.ode.implicit.SMALL`) is applied through its
explicit inverse, as :func:`~pbanim.ode.implicit.factor` does (one product instead of a LAPACK call).

With a constant ``jac`` (a matrix: a linear scene) M is factored once per θh and never refreshed: the steps
then equal the per-step ``newton_solve`` bit for bit (the same matrix, the same factorization, the same
iterations). A step whose iteration does not converge with the kept matrix is retried once from y₀ with J
evaluated there (the per-step ``newton_solve``), so no run fails that the per-step solve carries through.
"""

from __future__ import annotations

from typing import Callable

import numpy as np
import scipy.sparse as sp

from .implicit import SMALL, _iterate, _jacobian, _newton_matrix
from .signature import JAC
from ..contracts import Choice, Func, Int, Opt, Real, contract
from ..errors import ConvergenceError

__all__ = ["NewtonSteps", "THETA"]

#: θ of the two one-stage implicit methods: z = y₀ + θh f(t + θh, z)
THETA = {"implicit_euler": 1.0, "implicit_midpoint": 0.5}


class NewtonSteps:
    """The steps y₁ = Φ_h(y₀) of ``method`` (implicit Euler or midpoint) on ``fun`` for one run, M kept across
    steps (module docstring). ``jac``: ``jac(t, y)``, a constant matrix, or None (forward differences).

    >>> steps = NewtonSteps(lambda t, y: np.array([y[1], -y[0]]), "implicit_midpoint")
    >>> y = np.array([1.0, 0.0])
    >>> for k in range(100):
    ...     y = steps.step(0.01 * k, y, 0.01)
    >>> bool(abs(y @ y - 1.0) < 1e-12)    # a quadratic invariant, kept to the Newton tolerance
    True
    """

    @contract(fun=Func(), method=Choice(tuple(THETA)), jac=Opt(JAC), tol=Real(gt=0), max_iter=Int(ge=1, le=10_000))
    def __init__(self, fun: Callable, method: str = "implicit_midpoint", jac=None, tol: float = 1e-12,
                 max_iter: int = 20) -> None:
        self.fun, self.theta, self.jac, self.tol, self.max_iter = fun, THETA[method], jac, tol, max_iter
        self.constant = jac is not None and not callable(jac)
        self.refactored = 0          # Newton matrices built (per θh for a constant jac), for tests and benchmarks
        self._th: float | None = None
        self._solve = None
        self._d: np.ndarray | None = None     # z − y₀ of the last step

    def _matrix(self, t, z, f, th):
        self.refactored += 1
        if self.constant:
            return _newton_matrix(self.fun, t, z, f, th, self.jac, False)
        J = _jacobian(self.fun, t, z, f, self.jac)
        n = z.shape[-1]
        if sp.issparse(J) or n > SMALL:
            return _newton_matrix(self.fun, t, z, f, th, lambda t, y: J, False)
        # a small dense M: its explicit inverse, one product per iteration (as :func:`pbanim.ode.implicit.factor`)
        M = np.eye(n) - th * np.asarray(J, dtype=float)
        return np.linalg.inv(M).dot

    def step(self, t: float, y: np.ndarray, h: float) -> np.ndarray:
        """y₁ from y at t (a new array): Newton with the kept matrix (built here at the first step and when h
        changes) from z⁰ = y₀ + (z − y₀) of the last step at the same h, else from y₀."""
        fun, th = self.fun, self.theta * h
        tm = t + th
        d = self._d
        # the start: z⁰ = y₀ + (z − y₀) of the last step at the same step (a predictor off by O(h²)), else y₀
        z = np.array(y, dtype=float, copy=True)
        if d is not None and th == self._th and not self.constant:
            z += d
        f = fun(tm, z)
        if self._solve is None or th != self._th:
            self._solve, self._th = self._matrix(tm, z, f, th), th
        refresh = None if self.constant else (lambda t, z, f: self._matrix(t, z, f, th))
        try:
            z, self._solve = _iterate(fun, tm, y, z, f, th, self._solve, refresh, self.tol, self.max_iter)
        except ConvergenceError:
            if self.constant:
                raise
            # the per-step solve: J at y₀ (the kept matrix did not carry this step)
            z = np.array(y, dtype=float, copy=True)
            f = fun(tm, z)
            self._solve = self._matrix(tm, z, f, th)
            z, self._solve = _iterate(fun, tm, y, z, f, th, self._solve, refresh, self.tol, self.max_iter)
        self._d = z - y
        if self.theta == 1.0:
            return z
        return 2.0 * z - y
