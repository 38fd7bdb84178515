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
from ..contracts import Array, Func, Int, Obj, Real, contract
from ..errors import InvalidInput, NonFiniteResult
from ..derivatives import central_jacobian, directional_derivative

# x and v of any particle system (a user constraint need not be bound): the same (N, dim) for both
_X = Array(("N", "dim"))

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

    @contract(C=Func(), J=Func(), Jdot_qdot=Func(), m=Int(ge=1))
    def __init__(self, C: Callable, J: Callable, Jdot_qdot: Callable, m: int) -> None:
        self.C_fun, self.J_fun, self.Jd_fun = C, J, Jdot_qdot
        self.slots = np.zeros((int(m), 0), dtype=np.int64)

    def _rows(self, name: str, out, x) -> np.ndarray:
        """What the user's ``name`` returned, as m finite numbers, or a named error."""
        try:
            a = np.asarray(out, dtype=float).reshape(self.m)
        except (TypeError, ValueError):
            raise InvalidInput(f"UserConstraint: {name} must return {self.m} numbers (m = {self.m}), got "
                               f"shape {np.shape(out)}") from None
        if not np.isfinite(a).all():
            raise NonFiniteResult(f"the user constraint's {name}", f"at x with max |x| = {np.abs(x).max():g}")
        return a

    @contract(x=_X)
    def value(self, x):
        x = np.asarray(x, float)
        return self._rows("C", self.C_fun(x), x)

    @contract(x=_X)
    def jacobian(self, x):
        x = np.asarray(x, float)
        try:
            J = sp.csr_matrix(self.J_fun(x), dtype=float).reshape(self.m, x.size)
        except (TypeError, ValueError):
            raise InvalidInput(f"UserConstraint: J must return an (m, N·dim) = ({self.m}, {x.size}) matrix") from None
        if not np.isfinite(J.data).all():
            raise NonFiniteResult("the user constraint's J", f"at x with max |x| = {np.abs(x).max():g}")
        return J

    @contract(x=_X, v=_X)
    def jdot_qdot(self, x, v):
        x = np.asarray(x, float)
        return self._rows("Jdot_qdot", self.Jd_fun(x, np.asarray(v, float)), x)


@dataclass
class ConstraintCheck:
    """Outcome of :func:`check_constraint`: worst relative errors of J and J̇q̇ against finite differences."""

    J_error: float
    Jdot_error: float
    tol: float

    @property
    def ok(self) -> bool:
        return self.J_error <= self.tol and self.Jdot_error <= self.tol


@contract(c=Obj(Constraint), q=_X, qd=_X, eps=Real(gt=0), tol=Real(gt=0))
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
    elif (getattr(c, "N", x.shape[0]), c.dim) != x.shape:
        raise InvalidInput(f"check_constraint: q must have the shape (N, dim) = ({getattr(c, 'N', '?')}, {c.dim}) "
                           f"of the system c is bound to, got {x.shape}")
    with np.errstate(invalid="ignore", over="ignore", divide="ignore"):   # a non-finite error is named below
        J = c.jacobian(x).toarray()
        Jfd = central_jacobian(c.value, x, eps).reshape(J.shape)
        Jd = c.jdot_qdot(x, v)
        Jdfd = directional_derivative(lambda z: c.jacobian(z).toarray() @ v.ravel(), x, v, eps)
        eJ = float(np.max(np.abs(J - Jfd), initial=0.0) / max(1.0, np.max(np.abs(J), initial=0.0)))
        eD = float(np.max(np.abs(Jd - Jdfd), initial=0.0) / max(1.0, np.max(np.abs(Jd), initial=0.0)))
    if not (np.isfinite(eJ) and np.isfinite(eD)):    # C or J overflowed at q ± εe_j: no verdict
        raise NonFiniteResult("check_constraint's finite differences", f"eps = {eps:g}, max |q| = "
                              f"{np.abs(x).max():g}; use a smaller eps or a smaller q")
    return ConstraintCheck(eJ, eD, tol)
