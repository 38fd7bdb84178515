"""The one signature of every step function, as a contract: ``step(fun, t, y, h, split=None, jac=None)``.

Every integrator of :mod:`pbanim.ode` advances ẏ = f(t, y) by one step h with this signature (see
:mod:`pbanim.ode.methods`). ``STEP`` is its contract, declared once and shared by every public step
function: ``fun`` a callable ``fun(t, y)``, ``t`` a finite time, ``y`` one state of n numbers or a batch
(K, n), ``h`` a finite non-zero step (signed: a negative h integrates backwards), ``split`` the
number of positions q at the front of y (0 … n), ``jac`` the Jacobian ∂f/∂y as a callable, a dense (n, n)
matrix or a scipy.sparse one.

A step called from outside the package certifies its result (:func:`finite_step`). The registry
(:data:`pbanim.ode.METHODS`) holds the unchecked functions: a run checks its arguments
once, in :func:`pbanim.solve` or the scene, and the step loop pays nothing.
"""

from __future__ import annotations

import numpy as np

from ..contracts import Array, Either, Func, Int, Obj, Opt, Real
from ..errors import SimulationDiverged

__all__ = ["STEP", "JAC", "finite_step"]

JAC = Either(Func(), Array(("n", "n")), Obj("scipy.sparse:sparray", "scipy.sparse:spmatrix",
                                              what="a scipy.sparse matrix"),
             Obj("pbanim.ode.second_order:SecondOrderJacobian"))

STEP = dict(fun=Func(), t=Real(), y=Array(("n",), batch="first"), h=Either(Real(gt=0), Real(lt=0)),
            split=Opt(Int(ge=0)), jac=Opt(JAC))


def finite_step(y1, where: str, arguments: dict):
    """The certificate of one step called by a user: the new state is finite, else
    :class:`~pbanim.errors.SimulationDiverged` at the step's time (the step h is too large for the
    problem, or f returned NaN)."""
    if not np.isfinite(y1).all():
        raise SimulationDiverged(arguments.get("t", 0.0), 0, "the state after one step",
                                 f"{where} with h = {arguments.get('h')!r}")
    return y1
