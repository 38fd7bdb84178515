"""Valid calls for the contract fuzz (``tests/test_contracts_fuzz.py``), one module per subpackage.

The fuzz builds a valid call of each public callable from its contract: each argument's ``spec.example``
(a number inside its range, an array of its shape), the defaults of the others. What a contract cannot
make up lives here:

* ``INSTANCES[cls] = factory``: a valid instance of a class (for ``Obj`` arguments and for the ``self``
  of methods); looked up along the class's MRO, so a factory for a base serves its subclasses unless they
  have their own;
* ``CALLS[id] = factory``: keyword arguments for one callable (``id`` is ``module.qualname`` where it is
  defined, as ``tests/surface.py`` lists it); the factory may take the instance (for methods) and returns
  a dict of the arguments it fixes; the others still come from the contract;
* ``SELF[id] = factory``: the instance a method is called on, when it is not the class's usual one;
* ``SKIP_EDGES[id] = reason``: edge values are not run for this callable (say why: e.g. an edge value
  asks for a run whose cost is set by the value, such as a count of 10⁹ steps);
* ``RAISES[id] = (ExceptionType, ...)``: exceptions that are the callable's documented answer besides
  PbanimError (the assertions of ``pbanim.testing`` raise AssertionError);
* ``EXEMPT[id] = reason``: a whole callable exempted from contracts (``tests/test_contracts_surface.py``
  prints each with its reason);

Each module of this package defines any of these; they are merged here.
"""

from __future__ import annotations

import importlib
import pkgutil

INSTANCES: dict = {}
CALLS: dict = {}
SELF: dict = {}
SKIP_EDGES: dict = {}
EXEMPT: dict = {}
RAISES: dict = {}

for _info in pkgutil.iter_modules(__path__):
    _mod = importlib.import_module(f"{__name__}.{_info.name}")
    for _name in ("INSTANCES", "CALLS", "SELF", "SKIP_EDGES", "EXEMPT", "RAISES"):
        _part = getattr(_mod, _name, {})
        _clash = set(_part) & set(globals()[_name])
        if _clash:
            raise RuntimeError(f"{_info.name}.{_name} repeats {sorted(map(str, _clash))}")
        globals()[_name].update(_part)


def instance_of(classes):
    """A valid instance of the first of ``classes`` with a factory (along each class's MRO), or None."""
    for cls in classes:
        for k in cls.__mro__:
            if k in INSTANCES:
                return INSTANCES[k]()
    return None
