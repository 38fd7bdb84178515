"""The public surface of pbanim, enumerated: every callable in the ``__all__`` of the package and of each
of its subpackages, every public method of every exported class (issue 27, point 2).

Shared by ``tests/test_contracts_surface.py`` (every numeric or array argument carries a contract) and
``tests/test_contracts_fuzz.py`` (the fuzz generated from the contracts). An entry is one function object
(a method inherited by several exported classes is one entry, listed under the first class that has it).
"""

from __future__ import annotations

import importlib
import inspect
import pkgutil
from dataclasses import dataclass

import pbanim
from pbanim.contracts import contract_of


@dataclass(frozen=True)
class Entry:
    """One public callable: its id (``module.qualname`` where it is defined), the exported object (a
    function or a class), the method name when it is one (``"__init__"`` for a constructor), and what
    to call."""

    id: str
    exported: object        # the function, or the class that exports the method
    method: str | None      # None for a function; "__init__" for a constructor; else a method name
    func: object            # the function object itself (the checked wrapper when it has a contract)

    @property
    def contract(self):
        if self.method == "__init__":
            return contract_of(self.exported)
        return contract_of(self.func)            # a staticmethod / classmethod object is read through


def public_modules() -> list:
    """pbanim and every subpackage or module directly under it that declares ``__all__``."""
    mods = [pbanim]
    for info in pkgutil.iter_modules(pbanim.__path__):
        if info.name in ("cli", "__main__"):
            continue
        mod = importlib.import_module(f"pbanim.{info.name}")
        if hasattr(mod, "__all__"):
            mods.append(mod)
    return mods


def _own(cls):
    """Classes of cls's MRO defined in pbanim (their methods are pbanim's surface)."""
    return [k for k in cls.__mro__ if k.__module__.startswith("pbanim")]


def _raw(f):
    return f.__func__ if isinstance(f, (staticmethod, classmethod)) else f


def entries() -> list[Entry]:
    """Every public callable once, in a stable order."""
    seen, out = set(), []

    def add(entry: Entry, key) -> None:
        if key not in seen:
            seen.add(key)
            out.append(entry)

    for mod in public_modules():
        for name in mod.__all__:
            obj = getattr(mod, name)
            if not callable(obj):
                continue
            if inspect.isclass(obj):
                if not obj.__module__.startswith("pbanim"):
                    continue
                if issubclass(obj, BaseException):
                    add(Entry(f"{obj.__module__}.{obj.__qualname__}", obj, "__init__", obj), ("exc", obj))
                    continue
                init = next((k.__dict__["__init__"] for k in _own(obj) if "__init__" in k.__dict__), None)
                if init is not None:
                    add(Entry(f"{obj.__module__}.{obj.__qualname__}.__init__", obj, "__init__", init),
                        _raw(init))
                for klass in _own(obj):
                    for mname, member in vars(klass).items():
                        if mname.startswith("_") or not (inspect.isfunction(member) or
                                                         isinstance(member, (staticmethod, classmethod))):
                            continue
                        f = _raw(member)
                        add(Entry(f"{f.__module__}.{f.__qualname__}", obj, mname, member), f)
            elif inspect.isfunction(obj) or hasattr(obj, "__wrapped__"):
                add(Entry(f"{obj.__module__}.{obj.__qualname__}", obj, None, obj), obj)
            else:           # a callable instance (a registry object with __call__)
                add(Entry(f"{mod.__name__}.{name}", obj, None, obj), id(obj))
    return out


def parameters(entry: Entry) -> list[str]:
    """The checkable parameters: all but self / cls and *args / **kwargs."""
    f = entry.func
    if entry.method == "__init__" and inspect.isclass(f):
        f = f.__init__
    f = _raw(f)
    try:
        sig = inspect.signature(f)
    except (TypeError, ValueError):
        return []
    params = list(sig.parameters.values())
    var = (inspect.Parameter.VAR_POSITIONAL, inspect.Parameter.VAR_KEYWORD)
    is_method = entry.method is not None and not isinstance(entry.func, staticmethod)
    return [p.name for i, p in enumerate(params) if p.kind not in var and not (i == 0 and is_method
                                                                                and p.name in ("self", "cls"))]
