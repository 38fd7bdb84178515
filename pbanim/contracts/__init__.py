"""Argument contracts: what each public argument must be, declared once, read by the boundary check and
by the fuzzer (issue 27, "Nothing silent, by construction").

>>> from pbanim.contracts import contract, Real, Array
>>> @contract(k=Real(ge=0), x=Array(("n", 2)))
... def spring_force(k, x):
...     return -k * x
>>> spring_force(2.0, [[1.0, 0.0]])
array([[-2., -0.]])
>>> spring_force(-1.0, [[1.0, 0.0]])
Traceback (most recent call last):
...
pbanim.errors.InvalidInput: spring_force: k must be a finite number >= 0, got -1.0

See :mod:`pbanim.contracts.specs` for the vocabulary and :mod:`pbanim.contracts.declare` for the
decorator and where checks run.
"""

from .declare import (Contract, boundary_checks, call_checked, contract, contract_of, finite_result,
                      lenient_signatures, package_code, package_code_cached, unchecked)
from .specs import (Anything, Array, Choice, Either, Env, Flag, Func, Has, Index, Indices, Int, Obj, Opt, PathLike,
                    Real, Seq, Spec, Text)

__all__ = ["contract", "contract_of", "unchecked", "finite_result", "call_checked", "package_code", "package_code_cached", "lenient_signatures", "Contract", "boundary_checks", "Spec", "Real", "Int", "Index", "Array",
           "Indices", "Choice", "Flag", "Text", "PathLike", "Func", "Obj", "Has", "Seq", "Opt", "Either", "Anything",
           "Env"]
