"""The specs of the contract vocabulary that are not numbers or arrays: names from a registry, flags, text,
paths, callables, objects and protocols, and the combinators (:class:`Seq`, :class:`Opt`, :class:`Either`,
:class:`Anything`). See :mod:`pbanim.contracts.specs` for the vocabulary and its table; every name here is
also importable from there."""

from __future__ import annotations

import difflib
import importlib
import os

import numpy as np

from ..errors import InvalidInput
from .specs import Env, Spec

__all__ = ["Choice", "Flag", "Text", "PathLike", "Func", "Obj", "Has", "Seq", "Opt", "Either", "Anything"]


# -- names, flags, objects -------------------------------------------------------------------------------
class Choice(Spec):
    """A name from a registry (a collection, or a callable returning one, read at each check)."""

    def __init__(self, options) -> None:
        self.options = options

    def _opts(self):
        opts = self.options() if callable(self.options) else self.options
        return list(opts)

    def describe(self) -> str:
        opts = self._opts()
        shown = ", ".join(repr(o) for o in opts[:12]) + (", ..." if len(opts) > 12 else "")
        return f"one of {shown}"

    def check(self, name, value, env):
        opts = self._opts()
        try:
            ok = value in opts and not isinstance(value, bool)
        except TypeError:
            ok = False
        if not ok:
            near = difflib.get_close_matches(value, [o for o in opts if isinstance(o, str)], n=3) \
                if isinstance(value, str) else []
            raise env.fail(name, self.describe(), value, f"did you mean {', '.join(map(repr, near))}?"
                           if near else "")
        return value

    def example(self, env):
        return self._opts()[0]

    def bad(self, env):
        return [("an unknown name", "no-such-name"), ("None", None), ("a number", 3.0)]


class Flag(Spec):
    """True or False (numpy bools too; 0, 1 and strings refused)."""

    def describe(self) -> str:
        return "True or False"

    def check(self, name, value, env):
        if not isinstance(value, (bool, np.bool_)):
            raise env.fail(name, self.describe(), value)
        return bool(value)

    def example(self, env):
        return False

    def bad(self, env):
        return [("None", None), ("a string", "yes"), ("a number", 2.0)]

    def edges(self, env):
        return [("True", True)]


class Text(Spec):
    """A string (``nonempty=True``: with at least one character)."""

    def __init__(self, *, nonempty: bool = False) -> None:
        self.nonempty = nonempty

    def describe(self) -> str:
        return "a non-empty string" if self.nonempty else "a string"

    def check(self, name, value, env):
        if not isinstance(value, str) or self.nonempty and not value:
            raise env.fail(name, self.describe(), value)
        return value

    def example(self, env):
        return "x"

    def bad(self, env):
        return [("None", None), ("a number", 1.0)] + ([("empty", "")] if self.nonempty else [])


class PathLike(Spec):
    """A file or folder path: a string or an ``os.PathLike``."""

    def describe(self) -> str:
        return "a path (a string or os.PathLike)"

    def check(self, name, value, env):
        if not isinstance(value, (str, os.PathLike)) or value == "":
            raise env.fail(name, self.describe(), value)
        return value

    def bad(self, env):
        return [("None", None), ("a number", 1.0), ("empty", "")]


class Func(Spec):
    """A callable (a function, a lambda, an object with ``__call__``)."""

    def describe(self) -> str:
        return "a callable"

    def check(self, name, value, env):
        if not callable(value) or isinstance(value, type) and False:
            raise env.fail(name, self.describe(), value)
        return value

    def bad(self, env):
        return [("None", None), ("a string", "f"), ("a number", 1.0)]


class Obj(Spec):
    """An instance of one of ``types`` (classes, or ``"module:Class"`` strings resolved on first use, so
    that a low layer can name a high layer's class without importing it)."""

    def __init__(self, *types, what: str | None = None) -> None:
        self.types, self.what, self._resolved = types, what, None

    def classes(self) -> tuple:
        if self._resolved is None:
            out = []
            for t in self.types:
                if isinstance(t, str):
                    mod, _, cls = t.partition(":")
                    t = getattr(importlib.import_module(mod), cls)
                out.append(t)
            self._resolved = tuple(out)
        return self._resolved

    def describe(self) -> str:
        if self.what:
            return self.what
        names = [t.rpartition(":")[2] if isinstance(t, str) else t.__name__ for t in self.types]
        return "an instance of " + " or ".join(names)

    def check(self, name, value, env):
        if not isinstance(value, self.classes()):
            raise env.fail(name, self.describe(), value, f"a {type(value).__name__}")
        return value

    def bad(self, env):
        return [("None", None), ("a string", "x"), ("a number", 1.0)]


class Has(Spec):
    """An object with the named members (a protocol checked by duck typing, e.g. a mechanical system)."""

    def __init__(self, *members: str, what: str | None = None) -> None:
        self.members, self.what = members, what

    def describe(self) -> str:
        return self.what or f"an object with {', '.join(self.members)}"

    def check(self, name, value, env):
        missing = [m for m in self.members if not hasattr(value, m)]
        if missing:
            raise env.fail(name, self.describe(), value, f"a {type(value).__name__} lacks {', '.join(missing)}")
        return value

    def bad(self, env):
        return [("None", None), ("a string", "x"), ("a number", 1.0)]


# -- combinators -----------------------------------------------------------------------------------------
class Seq(Spec):
    """A list or tuple (not a string) whose every item meets ``item``; returned as a list."""

    def __init__(self, item: Spec, *, min_len: int = 0, max_len: int | None = None) -> None:
        self.item, self.min_len, self.max_len = item, min_len, max_len

    def describe(self) -> str:
        n = f" of at least {self.min_len}" if self.min_len else ""
        return f"a list{n} of ({self.item.describe()})"

    def check(self, name, value, env):
        if not isinstance(value, (list, tuple)) or len(value) < self.min_len or \
                self.max_len is not None and len(value) > self.max_len:
            raise env.fail(name, self.describe(), value)
        return [self.item.check(f"{name}[{i}]", v, env) for i, v in enumerate(value)]

    def example(self, env):
        return [self.item.example(env) for _ in range(max(1, self.min_len))]

    def bad(self, env):
        out = [("None", None), ("a string", "x")]
        if self.min_len:
            out.append(("empty", []))
        out += [(f"an item {label}", [v]) for label, v in self.item.bad(env)[:3]]
        return out


class Opt(Spec):
    """None, or what ``spec`` accepts."""

    def __init__(self, spec: Spec) -> None:
        self.spec = spec

    def describe(self) -> str:
        return f"None or {self.spec.describe()}"

    def check(self, name, value, env):
        return None if value is None else self.spec.check(name, value, env)

    def example(self, env):
        return self.spec.example(env)

    def bad(self, env):
        return [(k, v) for k, v in self.spec.bad(env) if v is not None]

    def edges(self, env):
        return [("None", None)] + self.spec.edges(env)


class Either(Spec):
    """What the first of ``specs`` that accepts the value makes of it."""

    def __init__(self, *specs: Spec) -> None:
        self.specs = specs

    def describe(self) -> str:
        return ", or ".join(s.describe() for s in self.specs)

    def check(self, name, value, env):
        for s in self.specs:
            saved = dict(env.symbols)
            try:
                return s.check(name, value, env)
            except InvalidInput:
                env.symbols.clear()
                env.symbols.update(saved)
        raise env.fail(name, self.describe(), value)

    def example(self, env):
        return self.specs[0].example(env)

    def bad(self, env):
        out = []
        for label, v in self.specs[0].bad(env):
            try:
                self.check("x", v, Env("fuzz", env.values))
            except InvalidInput:
                out.append((label, v))
        return out

    def edges(self, env):
        return [e for s in self.specs for e in s.edges(env)]


class Anything(Spec):
    """No check: an explicit exemption, with its reason (printed by the surface test)."""

    def __init__(self, reason: str) -> None:
        if not reason:
            raise TypeError("Anything needs a reason")
        self.reason = reason

    def describe(self) -> str:
        return f"anything ({self.reason})"

    def check(self, name, value, env):
        return value

    def bad(self, env):
        return []
