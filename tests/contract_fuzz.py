"""The fuzz generated from the contracts (issue 27, point 2): the machinery the ``test_contracts_fuzz_*``
files run on their share of the public surface.

For each public callable with a contract, starting from a valid call (``tests/contract_examples``):

1. the valid call itself: a valid result (no NaN anywhere in it) or a :class:`PbanimError`;
2. each argument in turn replaced by each value its spec must refuse (NaN, ±inf, out of range, a string,
   None, empty, a wrong shape, a batch where one state is expected): a ``PbanimError`` whose message names
   that argument;
3. each argument in turn replaced by each value at the edges of its contract (zero, a bound, 10³⁰⁰, an
   empty or batched array where allowed): a valid result or a ``PbanimError``;
4. hypothesis draws several arguments at once from those values and from the contract's range: a
   ``PbanimError`` naming one of the refused ones if any was drawn, else a valid result or a
   ``PbanimError``.

Every call runs under a time bound (a hang fails). RuntimeWarnings on the way to a named error are not
failures; the named error, or the result's finiteness, is what is checked.
"""

from __future__ import annotations

import inspect
import math
import os
import signal
import time
import warnings

import numpy as np
import pytest
from hypothesis import HealthCheck, Phase, given, settings
from hypothesis import strategies as st

import surface
from contract_examples import CALLS, RAISES, SELF, SKIP_EDGES, instance_of
from pbanim.contracts import Anything, Either, Func, Has, Obj, Opt, PathLike, Real, Seq
from pbanim.bodies import BodySystem
from pbanim.contracts.specs import Env
from pbanim.particles import ParticleSystem
from pbanim.errors import PbanimError

FACTOR = max(1, int(os.environ.get("PBANIM_FUZZ_FACTOR", "1")))
TIME_BOUND = 10.0
HYPOTHESIS_EXAMPLES = 3


class CallTimedOut(BaseException):
    """Raised by the alarm (a BaseException: library code catching Exception cannot swallow it)."""


def _alarm(signum, frame):
    raise CallTimedOut()


class MissingExample(Exception):
    """The fuzz cannot make up a valid value for an argument: add one to tests/contract_examples."""


def entries_of(prefixes: tuple[str, ...]) -> list:
    """Public callables with a contract and at least one argument, defined under one of ``prefixes``."""
    return [e for e in surface.entries() if e.contract is not None and surface.parameters(e)
            and e.id.startswith(prefixes)]


# -- a valid call ----------------------------------------------------------------------------------------
def example_for(spec, env):
    if isinstance(spec, Obj):
        inst = instance_of(spec.classes())
        if inst is None:
            raise MissingExample(f"no INSTANCES factory for {spec.describe()}")
        return inst
    if isinstance(spec, BodySystem):        # the body protocol: the chapter 01 particles implement it
        inst = instance_of([ParticleSystem])
        if inst is None:
            raise MissingExample("no INSTANCES factory for ParticleSystem")
        return inst
    if isinstance(spec, Opt):
        return example_for(spec.spec, env)
    if isinstance(spec, Seq):
        return [example_for(spec.item, env) for _ in range(max(1, spec.min_len))]
    if isinstance(spec, Either):
        for s in spec.specs:
            try:
                return example_for(s, env)
            except (MissingExample, NotImplementedError):
                continue
        raise MissingExample(f"no example for any of {spec.describe()}")
    if isinstance(spec, (Func, Anything, PathLike, Has)):
        raise MissingExample(f"no example for {spec.describe()}")
    try:
        return spec.example(env)
    except NotImplementedError as exc:
        raise MissingExample(str(exc)) from None


class Call:
    """A valid call of one entry: the target, its arguments by name, and the env they were built in."""

    def __init__(self, entry) -> None:
        self.entry, self.contract = entry, entry.contract
        self.inst = None
        if entry.method == "__init__":
            self.target = entry.exported
        elif entry.method is not None:
            raw = entry.exported.__dict__.get(entry.method) if entry.method in vars(entry.exported) else None
            if isinstance(raw, (staticmethod, classmethod)) or isinstance(
                    inspect.getattr_static(entry.exported, entry.method), (staticmethod, classmethod)):
                self.target = getattr(entry.exported, entry.method)
            else:
                make = SELF.get(entry.id)
                self.inst = make() if make else instance_of([entry.exported])
                if self.inst is None:
                    raise MissingExample(f"no INSTANCES factory for {entry.exported.__qualname__}")
                self.target = getattr(self.inst, entry.method)
        else:
            self.target = entry.func
        fixed = CALLS.get(entry.id)
        fixed = {} if fixed is None else (fixed(self.inst) if _arity(fixed) else fixed())
        sig = self.contract.signature
        values = {p.name: p.default for p in sig.parameters.values() if p.default is not inspect.Parameter.empty}
        if self.inst is not None:
            values["self"] = self.inst
        values.update(fixed)
        self.env = Env("fuzz", values)
        self.names = []
        for name in surface.parameters(entry):
            if name in fixed:
                self.names.append(name)
        for name in self.contract.order:
            if name in fixed or name not in surface.parameters(entry):
                continue
            if name in values and not _required(sig, name):
                # an argument with a default: fuzzed, but its valid value is the default unless the spec can
                # say more (a None default stands for "not given": an example is made up when it can be)
                if values[name] is not None:
                    self.names.append(name)
                    continue
                try:
                    values[name] = example_for(self.contract.specs[name], self.env)
                except MissingExample:
                    pass
                self.names.append(name)
                continue
            values[name] = example_for(self.contract.specs[name], self.env)
            self.names.append(name)
        missing = [n for n in surface.parameters(entry) if _required(sig, n) and n not in values]
        if missing:
            raise MissingExample(f"{entry.id}: no value for {missing}")
        self.values = values
        self.params = sig.parameters

    def args(self, **override):
        vals = {**self.values, **override}
        pos, kw = [], {}
        for p in self.params.values():
            if p.name == "self" or p.name == "cls" and self.entry.method:
                continue
            if p.name not in vals:
                continue
            if p.kind is inspect.Parameter.POSITIONAL_ONLY:
                pos.append(vals[p.name])
            elif p.kind in (inspect.Parameter.VAR_POSITIONAL, inspect.Parameter.VAR_KEYWORD):
                continue
            elif p.name in self.names or not _is_default(p, vals[p.name]):
                kw[p.name] = vals[p.name]
        return pos, kw


def _arity(f) -> int:
    return len(inspect.signature(f).parameters)


def _required(sig, name) -> bool:
    return sig.parameters[name].default is inspect.Parameter.empty


def _is_default(p, v) -> bool:
    return p.default is not inspect.Parameter.empty and p.default is v


# -- running one call ------------------------------------------------------------------------------------
def no_nan(obj, where="result", depth=0) -> None:
    """A valid result: no NaN in any float (arrays, tuples, lists, dicts, result objects' arrays)."""
    if depth > 3:
        return
    if isinstance(obj, np.ndarray):
        if obj.dtype.kind in "fc" and obj.size:
            assert not np.isnan(obj).any(), f"{where} has NaN: {obj!r}"[:400]
    elif isinstance(obj, float):
        assert not math.isnan(obj), f"{where} is NaN"
    elif isinstance(obj, (tuple, list)) and len(obj) < 200:
        for i, o in enumerate(obj):
            no_nan(o, f"{where}[{i}]", depth + 1)
    elif isinstance(obj, dict) and len(obj) < 200:
        for k, o in obj.items():
            no_nan(o, f"{where}[{k!r}]", depth + 1)
    elif hasattr(obj, "__dict__") and type(obj).__module__.startswith("pbanim") and depth < 2:
        for k, o in vars(obj).items():
            if isinstance(o, (np.ndarray, float)):
                no_nan(o, f"{where}.{k}", depth + 1)


def run(what: str, fn, allowed: tuple = ()):
    """fn() under the time bound: ('ok', result) or ('error', the PbanimError, or one of ``allowed``);
    anything else fails."""
    old = signal.signal(signal.SIGALRM, _alarm)
    signal.setitimer(signal.ITIMER_REAL, TIME_BOUND)
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            return "ok", fn()
    except (PbanimError, *allowed) as exc:
        return "error", exc
    except CallTimedOut:
        pytest.fail(f"{what}: no answer within {TIME_BOUND} s (a hang)")
    except Exception as exc:  # noqa: BLE001 - the property under test
        pytest.fail(f"{what}: raised a bare {type(exc).__name__}: {str(exc)[:300]}")
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0)
        signal.signal(signal.SIGALRM, old)


def fresh(entry):
    """A new valid call (arguments and instance made anew: a call may mutate them)."""
    return Call(entry)


def invoke(c: Call, /, **override):
    pos, kw = c.args(**override)
    return c.target(*pos, **kw)


def check_entry(entry, counts: dict) -> None:
    """Points 1–3 of the module docstring, for one entry."""
    started = time.perf_counter()
    c = fresh(entry)
    allowed = RAISES.get(entry.id, ())
    kind, out = run(f"{entry.id} (valid call)", lambda: invoke(c), allowed)
    if kind == "ok":
        no_nan(out, f"{entry.id}(valid call)")
    counts["calls"] = 1
    for name in c.names:
        spec = c.contract.specs.get(name)
        if spec is None:
            continue
        for label, value in spec.bad(c.env):
            c2 = fresh(entry)
            kind, out = run(f"{entry.id}({name}={label})", lambda: invoke(c2, **{name: value}))
            counts["calls"] += 1
            assert kind == "error", f"{entry.id}: {name} = {label} ({value!r:.80}) was accepted, returned {out!r:.200}"
            assert name in str(out), f"{entry.id}: {name} = {label}: the error does not name {name}: {out}"
        if entry.id in SKIP_EDGES:
            continue
        for label, value in spec.edges(c.env):
            c2 = fresh(entry)
            kind, out = run(f"{entry.id}({name}={label})", lambda: invoke(c2, **{name: value}), allowed)
            counts["calls"] += 1
            if kind == "ok":
                no_nan(out, f"{entry.id}({name}={label})")
    counts["seconds"] = time.perf_counter() - started


def hypothesis_test(entry):
    """Point 4: several arguments drawn at once."""
    phases = [p for p in Phase if p != Phase.shrink] if os.environ.get("PBANIM_FUZZ_NO_SHRINK") else list(Phase)

    @settings(max_examples=HYPOTHESIS_EXAMPLES * FACTOR, deadline=None, derandomize=True, database=None,
              phases=phases, suppress_health_check=list(HealthCheck))
    @given(data=st.data())
    def prop(data):
        c = fresh(entry)
        override, refused = {}, []
        for name in c.names:
            spec = c.contract.specs.get(name)
            if spec is None:
                continue
            pick = data.draw(st.sampled_from(["keep", "keep", "bad", "edge", "range"]), label=f"{name}: kind")
            if pick == "bad" and spec.bad(c.env):
                label, value = data.draw(st.sampled_from(spec.bad(c.env)), label=name)
                override[name] = value
                refused.append(name)
            elif pick == "edge" and spec.edges(c.env) and entry.id not in SKIP_EDGES:
                override[name] = data.draw(st.sampled_from(spec.edges(c.env)), label=name)[1]
            elif pick == "range" and isinstance(spec, Real):
                b = spec.bounds
                override[name] = data.draw(st.floats(
                    min_value=b.lo if b.lo is not None else -1e6, max_value=b.hi if b.hi is not None else 1e6,
                    exclude_min=b.lo_open, exclude_max=b.hi_open, allow_nan=False, allow_infinity=False), label=name)
        kind, out = run(f"{entry.id}({sorted(override)})", lambda: invoke(c, **override), RAISES.get(entry.id, ()))
        if refused:
            assert kind == "error", f"{entry.id}: refused values for {refused} accepted"
            assert any(n in str(out) for n in refused), f"{entry.id}: error names none of {refused}: {out}"
        elif kind == "ok":
            no_nan(out, entry.id)

    return prop


if __name__ == "__main__":      # python tests/contract_fuzz.py pbanim.constraints [more prefixes]: a quick run
    import sys
    import traceback

    failed = 0
    for e in entries_of(tuple(sys.argv[1:]) or ("pbanim",)):
        t0 = time.perf_counter()
        try:
            counts = {}
            check_entry(e, counts)
            hypothesis_test(e)()
            print(f"ok   {e.id}  {counts.get('calls')} calls  {time.perf_counter() - t0:.2f} s")
        except BaseException as exc:  # noqa: BLE001 - report and go on
            failed += 1
            if isinstance(exc, KeyboardInterrupt):
                raise
            print(f"FAIL {e.id}: {type(exc).__name__}: {str(exc)[:800]}")
            if "-v" in sys.argv:
                traceback.print_exc()
    print(f"{failed} failed")
