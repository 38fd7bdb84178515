"""The public surface enumerated (issue 27, point 2): every callable in every ``__all__``, every public
method of every exported class, and each numeric or array argument of each carries a contract.

The rule is stricter than "numeric or array": every argument but ``self`` / ``cls`` and ``*args`` /
``**kwargs`` has a spec (objects have ``Obj``, callables ``Func``, names ``Choice``); an argument that truly
takes anything says so with ``Anything(reason)``. Callables with no such argument need no contract. The
exemptions below are whole callables, each with its reason; the terminal summary prints the counts and the
exemptions (``public surface`` section).
"""

from __future__ import annotations

import inspect

import surface
from pbanim.contracts import Spec
from contract_examples import EXEMPT

# classes exempted by kind
# (EXEMPT, whole callables with their reasons, is merged from tests/contract_examples/*.py)
EXEMPT_KINDS = {
    BaseException: "named errors: pbanim constructs them when it refuses an input or a run fails; a user "
                   "catches them, never calls them with numbers",
    Spec: "a contract spec of a chapter (pbanim.contracts.Spec): its check is what answers any value, its "
          "other methods serve the fuzz; the vocabulary is tested in tests/test_contracts.py",
}


# whole units exempted, with the reason
EXEMPT_UNITS = {
    "pbanim.contracts.": "the contract vocabulary itself: a spec's check is what answers any value (its arguments "
                         "are the values under check); the specs are tested in tests/test_contracts.py",
}


def _exempt_reason(entry):
    if entry.id in EXEMPT:
        return EXEMPT[entry.id]
    for prefix, reason in EXEMPT_UNITS.items():
        if entry.id.startswith(prefix):
            return reason
    if inspect.isclass(entry.exported):
        for kind, reason in EXEMPT_KINDS.items():
            if issubclass(entry.exported, kind):
                return reason
    return None


def classify():
    """(covered, no_arguments, exempted, missing): ids, and for missing the arguments without a spec."""
    covered, bare, exempted, missing = [], [], {}, {}
    for e in surface.entries():
        reason = _exempt_reason(e)
        params = surface.parameters(e)
        if reason is not None:
            exempted[e.id] = reason
        elif not params:
            bare.append(e.id)
        elif e.contract is None:
            missing[e.id] = params
        else:
            unchecked = [p for p in params if p not in e.contract.specs]
            if unchecked:
                missing[e.id] = unchecked
            else:
                covered.append(e.id)
    return covered, bare, exempted, missing


def test_every_public_argument_carries_a_contract(surface_report):
    covered, bare, exempted, missing = classify()
    surface_report.update(covered=len(covered), bare=len(bare), exempted=exempted, missing=len(missing))
    lines = [f"  {k}: {', '.join(v)}" for k, v in sorted(missing.items())]
    assert not missing, (f"{len(missing)} public callables have arguments without a contract "
                         f"(declare them with pbanim.contracts.contract):\n" + "\n".join(lines))


def test_the_surface_is_the_whole_package():
    # the enumeration reaches every subpackage's __all__ (a subpackage without one is not public surface)
    ids = {e.id for e in surface.entries()}
    for unit in ("pbanim.ode", "pbanim.particles", "pbanim.constraints", "pbanim.reduced", "pbanim.rigid",
                 "pbanim.collision", "pbanim.contact", "pbanim.lcp", "pbanim.articulated", "pbanim.control",
                 "pbanim.fluids", "pbanim.design", "pbanim.compare", "pbanim.course"):
        assert any(i.startswith(unit + ".") for i in ids), unit
    assert len(ids) > 700
    # methods count: a class's public methods are on the surface, its private ones are not
    assert "pbanim.scene.Scene.simulate" in ids
    assert not any(i.rsplit(".", 1)[-1].startswith("_") and not i.endswith("__init__") for i in ids)


def test_exemptions_have_reasons():
    for k, v in EXEMPT.items():
        assert len(v) > 20, k


def test_the_fuzz_files_share_the_whole_surface():
    # every callable with a contract is fuzzed by exactly one of the tests/test_contracts_fuzz_*.py files
    import importlib

    shares = [importlib.import_module(f"test_contracts_fuzz_{n}").ENTRIES for n in ("core", "bodies", "characters",
                                                                                  "tools", "cloth")]
    fuzzed = [e.id for share in shares for e in share]
    assert len(fuzzed) == len(set(fuzzed))
    declared = {e.id for e in surface.entries() if e.contract is not None and surface.parameters(e)}
    assert declared == set(fuzzed), sorted(declared ^ set(fuzzed))[:10]
