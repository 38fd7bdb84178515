"""Work-precision sweeps: what accuracy costs in time, for any algorithm choice.

A sweep runs ``variants × params`` (methods × steps, solvers × tolerances, gains × steps ...) on one
problem with a reference answer and returns one :class:`Row` per pair: the error, the median wall time
of ``repeats`` runs, and the number of function evaluations. Plot ``error`` against ``wall_time`` and
read off, at each error level, which variant is cheapest.

The runner is any callable ``run(variant, param) -> (value, nfev)``; the error is
``error(value) -> float`` against the reference. Pass a ``concurrent.futures.Executor`` (a process pool,
or ``dask.distributed.Client.get_executor()``) to spread a large sweep; the callables must then be
picklable (module-level functions, ``functools.partial``).

Example
-------
>>> import numpy as np
>>> run = lambda variant, h: (np.exp(-1.0) * (1 + h) ** (0 if variant == "exact" else 1), 1)
>>> rows = sweep(run, ["exact", "off"], [0.1, 0.01], lambda v: abs(v - np.exp(-1.0)), repeats=1)
>>> [(r.variant, r.param) for r in rows]
[('exact', 0.1), ('exact', 0.01), ('off', 0.1), ('off', 0.01)]
"""

from __future__ import annotations

import time
from concurrent.futures import Executor
from dataclasses import dataclass
from typing import Any, Callable, Iterable, Sequence

import numpy as np

from .contracts import Anything, Func, Has, Int, Obj, Opt, Real, Seq, contract

__all__ = ["Row", "sweep", "best_at_error", "rows_by_variant"]


@contract(variant=Anything("a label: any hashable value"), param=Anything("the swept parameter: any value"),
          error=Real(ge=0, finite=False), wall_time=Real(ge=0), nfev=Int(ge=0))
@dataclass(frozen=True)
class Row:
    variant: Any
    param: Any
    error: float
    wall_time: float
    nfev: int

    def as_list(self) -> list:
        return [self.variant, self.param, self.error, self.wall_time, self.nfev]


def _one(run: Callable, error: Callable, variant, param, repeats: int) -> Row:
    times, value, nfev = [], None, 0
    for _ in range(max(1, repeats)):
        start = time.perf_counter()
        value, nfev = run(variant, param)
        times.append(time.perf_counter() - start)
    return Row(variant, param, float(error(value)), float(np.median(times)), int(nfev))


@contract(run=Func(), variants=Anything("an iterable of labels, each handed to run"),
          params=Anything("a sequence of parameters for all variants, or a dict variant -> sequence"),
          error=Func(), repeats=Int(ge=1, le=1000), executor=Opt(Has("submit", what="a concurrent.futures.Executor")))
def sweep(run: Callable[[Any, Any], tuple[Any, int]], variants: Iterable, params: Sequence | dict,
          error: Callable[[Any], float], repeats: int = 3, executor: Executor | None = None) -> list[Row]:
    """Run every (variant, param) pair; ``params`` may be one list for all or a dict variant → list."""
    variants = list(variants)
    pairs = [(v, p) for v in variants for p in (params[v] if isinstance(params, dict) else params)]
    if executor is None:
        return [_one(run, error, v, p, repeats) for v, p in pairs]
    futures = [executor.submit(_one, run, error, v, p, repeats) for v, p in pairs]
    return [f.result() for f in futures]


@contract(rows=Seq(Obj(Row)))
def rows_by_variant(rows: Iterable[Row]) -> dict[Any, list[Row]]:
    out: dict[Any, list[Row]] = {}
    for r in rows:
        out.setdefault(r.variant, []).append(r)
    return out


@contract(rows=Seq(Obj(Row)), level=Real(gt=0))
def best_at_error(rows: Iterable[Row], level: float) -> Row | None:
    """The cheapest row whose error is ≤ ``level`` (None if no variant reaches it)."""
    ok = [r for r in rows if np.isfinite(r.error) and r.error <= level]
    return min(ok, key=lambda r: r.wall_time) if ok else None
