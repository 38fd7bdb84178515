"""Your own constraints, and the finite-difference check of any constraint's J and J̇q̇ (chapter 03).

A student writing a new constraint supplies C(x), J(x) and J̇q̇(x, v) as callables
(:class:`UserConstraint`) and checks them with :func:`check_constraint`, which compares J with centred
differences of C and J̇q̇ with centred differences of J along q̇ — the two derivations students most
often get wrong (a forgotten factor 2, a sign in J̇).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

import numpy as np
import scipy.sparse as sp

from .kinds import Constraint, Distance  # noqa: F401  (Distance: doctest)
from ..errors import InvalidInput
from ..derivatives import central_jacobian, directional_derivative

__all__ = ["UserConstraint", "ConstraintCheck", "check_constraint"]


class UserConstraint(Constraint):
    """Constraints from your own callables, for students writing their own C, J and J̇q̇.

    Parameters
    ----------
    C : callable x -> (m,)
    J : callable x -> (m, N·dim) dense or sparse
    Jdot_qdot : callable (x, v) -> (m,)
    m : int
        Number of rows.

    x and v are (N, dim) arrays. Check your J and J̇q̇ with :func:`check_constraint` first. Scenes with
    user constraints use the generic sparse assembly (no linear-time solver).
    """

    kind = "user"

    def __init__(self, C: Callable, J: Callable, Jdot_qdot: Callable, m: int) -> None:
        if int(m) < 1:
            raise InvalidInput(f"m must be a positive number of rows, got {m}")
        self.C_fun, self.J_fun, self.Jd_fun = C, J, Jdot_qdot
        self.slots = np.zeros((int(m), 0), dtype=np.int64)

    def value(self, x):
        return np.asarray(self.C_fun(np.asarray(x, float)), float).reshape(self.m)

    def jacobian(self, x):
        J = self.J_fun(np.asarray(x, float))
        return sp.csr_matrix(J).reshape(self.m, np.size(x))

    def jdot_qdot(self, x, v):
        return np.asarray(self.Jd_fun(np.asarray(x, float), np.asarray(v, float)), float).reshape(self.m)


@dataclass
class ConstraintCheck:
    """Outcome of :func:`check_constraint`: worst relative errors of J and J̇q̇ against finite differences."""

    J_error: float
    Jdot_error: float
    tol: float

    @property
    def ok(self) -> bool:
        return self.J_error <= self.tol and self.Jdot_error <= self.tol


def check_constraint(c: Constraint, q, qd, eps: float = 1e-6, tol: float = 1e-6) -> ConstraintCheck:
    """Compare a constraint's J and J̇q̇ with centred finite differences at (q, q̇).

    J is checked column by column against (C(q + εe_j) − C(q − εe_j))/2ε; J̇q̇ against
    (J(q + εq̇) − J(q − εq̇))q̇/2ε (the derivative of J along the motion). Errors are relative to the
    largest entry (or 1).

    Examples
    --------
    >>> import numpy as np
    >>> c = Distance([[0, 1]], lengths=1.0); c.bind(2, 2)
    >>> rng = np.random.default_rng(0)
    >>> check_constraint(c, rng.normal(size=(2, 2)), rng.normal(size=(2, 2))).ok
    True
    """
    x = np.array(q, float)
    v = np.array(qd, float).reshape(x.shape)
    if not hasattr(c, "dim"):
        c.bind(x.shape[0], x.shape[1], x0=x)
    J = c.jacobian(x).toarray()
    Jfd = central_jacobian(c.value, x, eps).reshape(J.shape)
    Jd = c.jdot_qdot(x, v)
    Jdfd = directional_derivative(lambda z: c.jacobian(z).toarray() @ v.ravel(), x, v, eps)
    eJ = float(np.max(np.abs(J - Jfd), initial=0.0) / max(1.0, np.max(np.abs(J), initial=0.0)))
    eD = float(np.max(np.abs(Jd - Jdfd), initial=0.0) / max(1.0, np.max(np.abs(Jd), initial=0.0)))
    return ConstraintCheck(eJ, eD, tol)
