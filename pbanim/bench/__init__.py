"""Benchmarks: ``pbanim bench NAME [--quick] [--json FILE]``.

Each family is a module ``pbanim/bench/NAME.py`` with ``run(quick: bool) -> Report``. A report holds
tables (medians of repeats, baselines measured *in the same run*) and goals, printed last, one line each:

    goal <id>: <measured> (target <target>) met|missed
    goal <id>: not measured (<reason>) (target <target>)       (an optional peer baseline is missing)

Benchmarks never run inside the test suite except as a tiny smoke run (``quick=True``) that checks they
execute and print their goal lines.
"""

from __future__ import annotations

import importlib
import json
import pkgutil
import time
from dataclasses import dataclass, field
from typing import Any, Callable

import numpy as np

from ..contracts import Choice, Env, Flag, Func, Int, Obj, PathLike, Real, contract

__all__ = ["Goal", "Table", "Report", "median_time", "available", "run_bench", "format_report", "write_json",
           "HELPERS"]


@dataclass
class Goal:
    """A measured figure against a target. ``met`` is computed, not declared."""

    id: str
    measured: float
    target: float
    sense: str = "<="          # "<=" (lower is better) or ">="
    unit: str = "x"
    note: str = ""
    skipped: str = ""          # why it was not measured (e.g. an optional peer is not installed); never met

    @property
    def met(self) -> bool:
        if self.skipped or not np.isfinite(self.measured):
            return False
        return self.measured <= self.target if self.sense == "<=" else self.measured >= self.target

    def line(self) -> str:
        fmt = lambda v: f"{v:.3g}{self.unit}"  # noqa: E731
        note = f" — {self.note}" if self.note else ""
        if self.skipped:
            return f"goal {self.id}: not measured ({self.skipped}) (target {self.sense} {fmt(self.target)}){note}"
        return (f"goal {self.id}: {fmt(self.measured)} (target {self.sense} {fmt(self.target)}) "
                f"{'met' if self.met else 'missed'}{note}")


@dataclass
class Table:
    """A titled table of rows, printed with aligned columns (floats in 4 significant digits)."""

    title: str
    header: list[str]
    rows: list[list[Any]] = field(default_factory=list)

    def format(self) -> str:
        def cell(v):
            if isinstance(v, float):
                return f"{v:.3e}" if (v != 0 and (abs(v) < 1e-2 or abs(v) >= 1e4)) else f"{v:.4g}"
            return str(v)

        cells = [[cell(v) for v in r] for r in self.rows]
        widths = [max(len(h), *(len(r[i]) for r in cells)) if cells else len(h) for i, h in enumerate(self.header)]
        out = [f"## {self.title}", "  ".join(h.ljust(w) for h, w in zip(self.header, widths)),
               "  ".join("-" * w for w in widths)]
        out += ["  ".join(c.ljust(w) for c, w in zip(r, widths)) for r in cells]
        return "\n".join(out)


@dataclass
class Report:
    """What a family's ``run`` returns: tables, goals (printed last) and notes."""

    name: str
    tables: list[Table] = field(default_factory=list)
    goals: list[Goal] = field(default_factory=list)
    notes: list[str] = field(default_factory=list)

    def to_json(self) -> dict:
        return {"name": self.name,
                "tables": [{"title": t.title, "header": t.header, "rows": t.rows} for t in self.tables],
                "goals": [{"id": g.id, "measured": g.measured, "target": g.target, "sense": g.sense,
                           "unit": g.unit, "met": g.met, "skipped": g.skipped, "line": g.line()} for g in self.goals],
                "notes": self.notes}


@contract(fn=Func(), repeats=Int(ge=1, le=1000), min_time=Real(ge=0, le=0.5))
def median_time(fn: Callable[[], Any], repeats: int = 5, min_time: float = 0.0) -> float:
    """Median wall time of ``fn()`` over ``repeats`` runs (each run looped until ``min_time`` s).

    At most 1000 repeats looped for at most 0.5 s each: the cost of a measurement is bounded before it
    starts (a single run of fn longer than that is measured once per repeat)."""
    times = []
    for _ in range(max(1, repeats)):
        n, start = 0, time.perf_counter()
        while True:
            fn()
            n += 1
            el = time.perf_counter() - start
            if el >= min_time:
                break
        times.append(el / n)
    return float(np.median(times))


# modules of this package that help a family but are not one (no ``run``)
HELPERS = frozenset({"contact_peers"})


def _alternating(fns: dict, rounds: int, min_cpu: float, max_calls: int = 5000) -> dict:
    """name → [(wall s, CPU s) per call, one pair per round]: in every round each fn in turn (alternating rounds:
    every competitor sees the same load), looped until ``min_cpu`` seconds of this process's CPU time or
    ``max_calls`` calls, whichever comes first (the cost of a measurement is bounded before it starts)."""
    out: dict = {name: [] for name in fns}
    for _ in range(rounds):
        for name, fn in fns.items():
            n, w0, c0 = 0, time.perf_counter(), time.process_time()
            while True:
                fn()
                n += 1
                cpu = time.process_time() - c0
                if cpu >= min_cpu or n >= max_calls:
                    break
            out[name].append(((time.perf_counter() - w0) / n, cpu / n))
    return out


def available() -> list[str]:
    """The benchmark families, sorted (modules of this package with a ``run``; helpers excluded)."""
    import pbanim.bench as pkg

    return sorted(m.name for m in pkgutil.iter_modules(pkg.__path__)
                  if not m.name.startswith("_") and m.name not in HELPERS)


def one_blas_thread():
    """A context in which every BLAS library loaded in the process uses one thread (threadpoolctl).

    pbanim's solves call BLAS/LAPACK on small matrices many times; on a loaded or shared machine a
    multi-threaded OpenBLAS can spin-wait for a busy core and take 100× longer per call (measured here:
    a 500 × 500 Cholesky 1.2 ms on one thread, 240 ms on two with the other core busy). Timings are taken
    with one thread, for both sides of every comparison alike.
    """
    from threadpoolctl import threadpool_limits

    return threadpool_limits(limits=1, user_api="blas")


FAMILY = Choice(available)


def run_bench(name: str, quick: bool = False) -> Report:
    """Run the family ``name`` with one BLAS thread (:func:`one_blas_thread`) and return its report
    (``InvalidInput`` naming the argument for an unknown name or a quick that is not a bool).

    No ``@contract``: a valid call is a whole benchmark run, which the generated fuzz cannot afford; the
    body applies the specs a contract would (``name``: one of :func:`available`, ``quick``: a flag), for
    every caller, the command line included."""
    env = Env("run_bench", {})
    name, quick = FAMILY.check("name", name, env), Flag().check("quick", quick, env)
    mod = importlib.import_module(f"pbanim.bench.{name}")
    with one_blas_thread():
        rep = mod.run(quick=quick)
    rep.notes.append("BLAS/LAPACK ran on one thread for the whole run, for pbanim and its baselines alike "
                     "(a multi-threaded BLAS on a busy machine costs small solves up to 100×)")
    return rep


@contract(rep=Obj(Report))
def format_report(rep: Report) -> str:
    """The report as text: tables, notes, then one line per goal."""
    parts = [f"# pbanim bench {rep.name}"]
    parts += [t.format() for t in rep.tables]
    parts += [f"note: {n}" for n in rep.notes]
    parts += [g.line() for g in rep.goals]
    return "\n\n".join(parts[:-len(rep.goals)] if rep.goals else parts) + (
        "\n\n" + "\n".join(g.line() for g in rep.goals) if rep.goals else "")


@contract(rep=Obj(Report), path=PathLike())
def write_json(rep: Report, path: str) -> None:
    """Write the report (tables, goals with their lines, notes) as JSON to ``path``."""
    with open(path, "w") as fh:
        json.dump(rep.to_json(), fh, indent=1, default=float)
