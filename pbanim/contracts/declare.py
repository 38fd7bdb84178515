"""``@contract``: declare what each argument of a public callable must be, checked at the call boundary.

::

    @contract(y=Array(("n",)), ks=Real(ge=0), solver=Choice(SOLVERS))
    def solve_multipliers(constraints, system, y, Q=None, *, solver="auto", ks=0.0, ...): ...

The decorator reads the signature once, at import. At each call from *outside* the package it binds the
arguments given, checks each against its spec (in parameter order, references last) and calls the
function with the converted values (floats, ints, float arrays); an argument left at its default is
not checked. A call from inside the package (a module under ``pbanim/``) skips the checks: the boundary
has been checked once, by the public function the user called, and nothing inside a step loop pays for it
again. The unchecked function is ``fn.__wrapped__``; the contract, for the fuzzer and the surface test,
is ``fn.__contract__``.

On a class, the decorator checks ``__init__`` (and the class carries ``__contract__``); on a method, the
first argument (``self`` / ``cls``) is not checked and references may start with it (``"self.N"``).
"""

from __future__ import annotations

import functools
import inspect
import math
import os
import sys

import numpy as np

from .specs import Env, Spec, _is_ref

__all__ = ["contract", "Contract", "contract_of", "boundary_checks", "unchecked", "finite_result", "call_checked", "package_code_cached",
           "lenient_signatures"]

_PKG = os.path.dirname(os.path.dirname(os.path.abspath(__file__))) + os.sep
_STATE = {"always": False, "lenient": False}


class lenient_signatures:
    """Context manager: a contract naming a parameter the function lacks drops that spec instead of raising
    at import. For the grader loading a student's copy of a reference module: a changed signature must be
    reported as a wrong signature when the function is called, not as a decorator's complaint at import."""

    def __enter__(self):
        self._old, _STATE["lenient"] = _STATE["lenient"], True
        return self

    def __exit__(self, *exc):
        _STATE["lenient"] = self._old
        return False


class boundary_checks:
    """Context manager: check contracts on every call, from inside the package too (for tests that
    want to see which inner call refuses a value; a whole run under it pays the checks everywhere)."""

    def __enter__(self):
        self._old, _STATE["always"] = _STATE["always"], True
        return self

    def __exit__(self, *exc):
        _STATE["always"] = self._old
        return False


def _refs(spec) -> bool:
    """Whether a spec reads other arguments (sizes, shapes named after arguments, callables of the env)."""
    for attr in ("size", "shape"):
        v = getattr(spec, attr, None)
        if attr == "size" and (callable(v) or isinstance(v, str)):
            return True
        if isinstance(v, tuple) and any(_is_ref(d) for d in v):
            return True
    inner = [getattr(spec, "spec", None), getattr(spec, "item", None), *getattr(spec, "specs", ())]
    return any(s is not None and _refs(s) for s in inner)


class Contract:
    """The specs of one callable, with its signature: what the boundary check and the fuzzer read."""

    def __init__(self, fn, specs: dict, where: str) -> None:
        self.fn, self.where = fn, where
        self.signature = inspect.signature(fn)
        params = list(self.signature.parameters.values())
        names = [p.name for p in params]
        unknown = set(specs) - set(names)
        if unknown and _STATE["lenient"]:
            specs = {k: v for k, v in specs.items() if k in names}
            unknown = set()
        if unknown:
            raise TypeError(f"contract of {where} names {sorted(unknown)}, which are not among its "
                            f"parameters {names}")
        for k, s in specs.items():
            if not isinstance(s, Spec):
                raise TypeError(f"contract of {where}: {k} must be a Spec, got {s!r}")
        self.specs = {n: specs[n] for n in names if n in specs}
        kinds = (inspect.Parameter.POSITIONAL_ONLY, inspect.Parameter.POSITIONAL_OR_KEYWORD)
        self.positional = [p.name for p in params if p.kind in kinds]
        self.defaults = {p.name: p.default for p in params if p.default is not inspect.Parameter.empty}
        self.needs_all = any(_refs(s) for s in self.specs.values())
        # arguments whose spec reads others come last
        self.order = sorted(self.specs, key=lambda n: _refs(self.specs[n]))
        self.method = bool(params) and params[0].name in ("self", "cls")
        self.by_position = [(i, n, self.specs[n]) for i, n in enumerate(self.positional) if n in self.specs]

    def unchecked_arguments(self) -> list[str]:
        """Parameters with no spec (besides self / cls and *args / **kwargs)."""
        var = (inspect.Parameter.VAR_POSITIONAL, inspect.Parameter.VAR_KEYWORD)
        return [p.name for i, p in enumerate(self.signature.parameters.values())
                if p.name not in self.specs and p.kind not in var and not (i == 0 and self.method)]

    def bind(self, args: tuple, kwargs: dict) -> dict:
        """The given arguments by name (and the defaults of the others, when a spec reads them)."""
        values = dict(self.defaults) if self.needs_all else {}
        values.update(zip(self.positional, args))
        values.update(kwargs)
        return values

    def check(self, args: tuple, kwargs: dict):
        """The arguments with each given one checked and converted, as (args, kwargs)."""
        if not self.needs_all:      # the common case: no spec reads another argument
            env = Env(self.where, kwargs)
            if args:
                args = list(args)
                n = len(args)
                for i, name, spec in self.by_position:
                    if i >= n:
                        break
                    args[i] = spec.check(name, args[i], env)
            specs = self.specs
            for k in kwargs:
                spec = specs.get(k)
                if spec is not None:
                    kwargs[k] = spec.check(k, kwargs[k], env)
            return args, kwargs
        values = self.bind(args, kwargs)
        env = Env(self.where, values)
        if self.needs_all:
            given = set(self.positional[:len(args)])
            given.update(kwargs)
        else:
            given = values
        specs = self.specs
        for name in self.order:
            if name in given:
                values[name] = specs[name].check(name, values[name], env)
        n = min(len(args), len(self.positional))
        new_args = tuple(values[k] for k in self.positional[:n]) + tuple(args[n:])
        new_kwargs = {k: values[k] if k in self.specs else v for k, v in kwargs.items()}
        return new_args, new_kwargs

    def describe(self) -> str:
        return "\n".join(f"{n}: {s.describe()}" for n, s in self.specs.items())


def _wrap(fn, specs: dict, where: str, returns=None):
    c = Contract(fn, specs, where)
    c.returns = returns
    getframe = sys._getframe
    state = _STATE

    if returns is None:
        @functools.wraps(fn)
        def checked(*args, **kwargs):
            if getframe(1).f_code.co_filename.startswith(_PKG) and not state["always"]:
                return fn(*args, **kwargs)
            args, kwargs = c.check(args, kwargs)
            return fn(*args, **kwargs)
    else:
        @functools.wraps(fn)
        def checked(*args, **kwargs):
            if getframe(1).f_code.co_filename.startswith(_PKG) and not state["always"]:
                return fn(*args, **kwargs)
            args, kwargs = c.check(args, kwargs)
            with np.errstate(over="ignore", invalid="ignore", divide="ignore"):   # the certificate names it
                out = fn(*args, **kwargs)
            return returns(out, where, c.bind(args, kwargs))

    checked.__contract__ = c
    return checked


def contract(returns=None, **specs):
    """Declare the contract of a function, a method or a class (its ``__init__``); see the module.

    ``returns``, optional: ``returns(result, where, arguments) -> result`` certifies the result of a call
    from outside the package (``arguments``: the checked arguments by name) (e.g. :func:`finite_result`: no NaN or inf from finite arguments), raising a named error
    when the certificate fails.
    """

    def deco(obj):
        if isinstance(obj, type):
            init = obj.__dict__.get("__init__")
            if init is None:
                raise TypeError(f"contract on class {obj.__qualname__}: it defines no __init__ of its own")
            obj.__init__ = _wrap(init, specs, obj.__qualname__)
            obj.__contract__ = obj.__init__.__contract__
            return obj
        if isinstance(obj, (staticmethod, classmethod)):
            wrapped = type(obj)(_wrap(obj.__func__, specs, obj.__func__.__qualname__, returns))
            wrapped.__contract__ = wrapped.__func__.__contract__
            return wrapped
        return _wrap(obj, specs, obj.__qualname__, returns)

    return deco


def finite_result(value, where: str, arguments=None):
    """A ``returns`` certificate: every float in the result (an array, a number, a tuple or list of them)
    is finite, else :class:`~pbanim.errors.NonFiniteResult` naming the function."""
    from ..errors import NonFiniteResult

    items = value if isinstance(value, (tuple, list)) else tuple(value.values()) if isinstance(value, dict) \
        else (value,)
    for v in items:
        if isinstance(v, float) and not math.isfinite(v) or isinstance(v, np.ndarray) and v.dtype.kind in "fc" \
                and not np.isfinite(v).all():
            raise NonFiniteResult(f"the result of {where}")
    return value


def unchecked(f):
    """The function under a contract's check (for a bound method: the unchecked function bound to the same
    object); ``f`` itself when it has none. For hot loops that hold a public callable: they pay nothing."""
    raw = getattr(f, "__wrapped__", None)
    if raw is None or getattr(f, "__contract__", None) is None:
        return f
    owner = getattr(f, "__self__", None)
    return raw if owner is None else raw.__get__(owner)


def package_code(obj, *names: str) -> bool:
    """Whether the methods ``names`` of ``obj``'s class are the package's own code (written in a module under
    ``pbanim/``, the same line the boundary check draws). A lean step that replaces a method by an equivalent
    form precomputed from another (a force's ``apply`` by its ``affine()`` or ``jacobian``, a multiplier solve
    by its dense twin) trusts only the package's: a course assignment's copy of a module or a user's subclass
    runs the code it wrote."""
    cls = type(obj)
    for name in names:
        f = getattr(cls, name, None)
        if f is None:                   # nothing to trust or distrust
            continue
        code = getattr(inspect.unwrap(f), "__code__", None)
        if code is None or not code.co_filename.startswith(_PKG):
            return False
    return True


_CLASS_CODE: dict = {}


def package_code_cached(obj, *names: str) -> bool:
    """:func:`package_code`, kept per (class, names): for a lean path that asks at every step (what it answers
    depends on the class only, whose methods a run does not replace)."""
    key = (type(obj), names)
    got = _CLASS_CODE.get(key)
    if got is None:
        got = _CLASS_CODE[key] = package_code(obj, *names)
    return got


def call_checked(fn, *args, **kwargs):
    """``fn(*args, **kwargs)`` checked as a call from user code, wherever it is made (the command line is a
    module of the package, yet what it passes comes from the user); ``fn`` without a contract is just
    called."""
    c = contract_of(fn)
    if isinstance(fn, type):
        if c is not None:                           # the class's __init__ (self is not checked)
            a2, kwargs = c.check((None,) + args, kwargs)
            args = tuple(a2[1:])
        return fn(*args, **kwargs)
    if c is None:
        return fn(*args, **kwargs)
    bound_self = getattr(fn, "__self__", None)
    raw = fn.__wrapped__ if bound_self is None else fn.__wrapped__.__get__(bound_self)
    if c.method and bound_self is not None:
        a2, kwargs = c.check((bound_self,) + args, kwargs)
        args = tuple(a2[1:])
    else:
        args, kwargs = c.check(args, kwargs)
    out = raw(*args, **kwargs)
    return c.returns(out, c.where, c.bind(args, kwargs)) if c.returns is not None else out


def contract_of(obj):
    """The :class:`Contract` of a callable or class, or None."""
    if isinstance(obj, type):
        return obj.__dict__.get("__contract__") or getattr(obj.__dict__.get("__init__"), "__contract__", None)
    if isinstance(obj, (staticmethod, classmethod)):      # either order of the two decorators
        return getattr(obj, "__contract__", None) or getattr(obj.__func__, "__contract__", None)
    return getattr(obj, "__contract__", None)
