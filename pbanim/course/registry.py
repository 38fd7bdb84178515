"""Assignments as data: a reference module, its marked regions, checks with points, and known student bugs.

An :class:`Assignment` names a reference module of pbanim whose solution regions are marked (see
:mod:`pbanim.course.markers`), the :class:`Check` objects that grade a student's version of that module,
and the :class:`Mutant` bugs that the checks must catch. Nothing here runs a check: the grader
(:mod:`pbanim.course.grader`) does, each in its own process.

A check is a function ``check(mod) -> str`` of the student's module: it builds a small scene *with the
student's classes and functions* and compares what comes out with an analytic oracle from ORACLES.md, at
that oracle's tolerance. It returns one line saying what it measured, or raises :class:`CheckFailed` with
one line saying what was expected and what came in (shape, value, tolerance).

===============  ==============================================================================
field            meaning
===============  ==============================================================================
points           what the check is worth; an assignment's points add up to 100
physics          one line: the physical statement the check tests (printed in the grade table)
oracle           the ORACLES.md id of the closed form or invariant used
public           True: the check ships with the starter as a public test (the student can run it);
                 False: hidden, run only by ``pbanim grade``
regions          the marked regions the check exercises (a NotImplementedError names them)
===============  ==============================================================================

A :class:`Mutant` is a typical bug written as text edits of the reference module (old → new); the
course tests grade each mutant and require exactly its ``catches`` checks to fail.

What a check uses to look at a student's module (:func:`attr`, :func:`array`, :func:`close`,
:func:`at_most`) turns a missing name, a wrong shape, a NaN or a number off its oracle into one
CheckFailed line, e.g. "Drag.apply with k_d = 0.3: max error 2.4e+00 N > tolerance 1.2e-15 N".
Assignments of
chapters still being written are registered with ``status="pending"`` and no checks: ``pbanim
assignment list`` shows them, ``make`` and ``grade`` refuse them with the reason.
"""

from __future__ import annotations

import difflib
import importlib.util
from dataclasses import dataclass, field
from typing import Callable

import numpy as np

from ..contracts import Choice, Flag, Func, Int, Obj, Seq, Text, contract
from ..errors import InvalidInput

__all__ = ["Check", "Mutant", "Assignment", "CheckFailed", "ASSIGNMENTS", "register", "get_assignment",
           "assignment_names", "ASSIGNMENT",
           "check", "closest", "attr", "array", "close", "at_most"]


class CheckFailed(AssertionError):
    """A check's oracle is not met: the message says what was expected and what came in."""


_NAMES = Seq(Text(nonempty=True))


@contract(id=Text(nonempty=True), points=Int(ge=0, le=100), physics=Text(), oracle=Text(), func=Func(), public=Flag(),
          regions=_NAMES)
@dataclass(frozen=True)
class Check:
    id: str
    points: int
    physics: str
    oracle: str
    func: Callable = field(repr=False, compare=False)
    public: bool = True
    regions: tuple[str, ...] = ()

    def __post_init__(self) -> None:
        object.__setattr__(self, "regions", tuple(self.regions))     # the contract hands in a list


@contract(name=Text(nonempty=True), description=Text(), edits=Seq(Seq(Text(), min_len=2, max_len=2), min_len=1),
          catches=_NAMES)
@dataclass(frozen=True)
class Mutant:
    """A typical student bug: text edits of the reference module and the checks that must catch it."""

    name: str
    description: str
    edits: tuple[tuple[str, str], ...]
    catches: tuple[str, ...]

    def __post_init__(self) -> None:
        object.__setattr__(self, "edits", tuple(tuple(e) for e in self.edits))
        object.__setattr__(self, "catches", tuple(self.catches))
        if any(not old for old, _ in self.edits):
            raise InvalidInput(f"mutant {self.name!r}: edits must replace non-empty text, got an empty 'old'")

    @contract(source=Text())
    def apply(self, source: str) -> str:
        """``source`` with every edit applied (each ``old`` must occur: a stale mutant is an error)."""
        for old, new in self.edits:
            if old not in source:
                raise InvalidInput(f"mutant {self.name!r}: text {old[:60]!r} not found in the module")
            source = source.replace(old, new)
        return source


@contract(name=Text(nonempty=True), chapter=Text(nonempty=True), title=Text(), module=Text(nonempty=True),
          summary=Text(), checks=Seq(Obj(Check)), mutants=Seq(Obj(Mutant)), status=Choice(("ready", "pending")),
          pending_reason=Text())
@dataclass(frozen=True)
class Assignment:
    name: str
    chapter: str
    title: str
    module: str                       # dotted name of the reference module, e.g. "pbanim.particles.system"
    summary: str                      # the student's task, a few sentences (README)
    checks: tuple[Check, ...] = ()
    mutants: tuple[Mutant, ...] = ()
    status: str = "ready"             # "ready" or "pending" (chapter still being written)
    pending_reason: str = ""

    def __post_init__(self) -> None:
        object.__setattr__(self, "checks", tuple(self.checks))       # the contract hands in lists
        object.__setattr__(self, "mutants", tuple(self.mutants))

    @property
    def package(self) -> str:
        return self.module.rpartition(".")[0]

    @property
    def filename(self) -> str:
        return self.module.rpartition(".")[2] + ".py"

    @property
    def total_points(self) -> int:
        return sum(c.points for c in self.checks)

    def reference_path(self) -> str:
        """The reference module's file (found, not imported)."""
        spec = importlib.util.find_spec(self.module)
        if spec is None or spec.origin is None:
            raise InvalidInput(f"assignment {self.name!r}: module {self.module} is not installed")
        return spec.origin

    @contract(check_id=Text())
    def get_check(self, check_id: str) -> Check:
        """The check ``check_id`` (the one check of check ids: the grader's internal calls use it too)."""
        for c in self.checks:
            if c.id == check_id:
                return c
        raise InvalidInput(f"assignment {self.name!r}: check_id must be one of {[c.id for c in self.checks]}, got "
                           f"{check_id!r}{closest(check_id, [c.id for c in self.checks])}")


ASSIGNMENTS: dict[str, Assignment] = {}


def register(a: Assignment) -> Assignment:
    """Add an assignment (a ready one needs checks worth 100 points with unique ids, mutants naming them)."""
    if a.status not in ("ready", "pending"):
        raise InvalidInput(f"assignment status must be 'ready' or 'pending', got {a.status!r}")
    if a.status == "ready":
        ids = [c.id for c in a.checks]
        # a student edition (pbanim.course.edition) ships an assignment's public checks only: < 100 points
        stripped = a.name in _stripped_assignments() and all(c.public for c in a.checks)
        if len(set(ids)) != len(ids) or not (a.total_points == 100 or stripped and a.total_points <= 100):
            raise InvalidInput(f"assignment {a.name!r}: check ids must be unique and points add up to 100, "
                               f"got ids {ids}, {a.total_points} points")
        for m in a.mutants:
            unknown = set(m.catches) - set(ids)
            if unknown or not m.catches:
                raise InvalidInput(f"assignment {a.name!r}: mutant {m.name!r} must catch known checks, got {m.catches}")
    ASSIGNMENTS[a.name] = a
    return a


def _stripped_assignments() -> tuple:
    """The assignments whose hidden checks this installation lacks (a student edition), else ()."""
    from .edition import edition_info

    info = edition_info()
    return () if not info or info.get("hidden_checks") else tuple(info.get("assignments", ()))


def closest(name: str, names) -> str:
    """" (did you mean 'x'?)" for the closest names, or ""."""
    near = difflib.get_close_matches(str(name), list(names), n=3, cutoff=0.5)
    return f" (did you mean {', '.join(repr(n) for n in near)}?)" if near else ""


def assignment_names() -> list[str]:
    """Every registered assignment's name (loads the catalog)."""
    from . import catalog  # noqa: F401  (registers every assignment)

    return sorted(ASSIGNMENTS)


ASSIGNMENT = Choice(assignment_names)


@contract(name=ASSIGNMENT, ready=Flag())
def get_assignment(name: str, ready: bool = True) -> Assignment:
    """The assignment ``name`` (its checks loaded), or :class:`InvalidInput` suggesting the closest names.

    The one check of assignment names: its contract at the boundary, this body for the grader, the starter
    and the command line inside pbanim (and a pending assignment's reason)."""
    from . import catalog  # noqa: F401  (registers every assignment)

    if not isinstance(name, str) or name not in ASSIGNMENTS:
        raise InvalidInput(f"unknown assignment {name!r}{closest(name, ASSIGNMENTS)}; "
                           f"available: {sorted(ASSIGNMENTS)}")
    a = ASSIGNMENTS[name]
    if ready and a.status != "ready":
        raise InvalidInput(f"assignment {name!r} is pending: {a.pending_reason}")
    return a


def check(checks: list, id: str, points: int, physics: str, oracle: str, public: bool = True,
          regions: tuple[str, ...] = ()) -> Callable:
    """Decorator: append a :class:`Check` built from the function to the list ``checks``."""

    def deco(func: Callable) -> Callable:
        checks.append(Check(id, points, physics, oracle, func, public, tuple(regions)))
        return func

    return deco


# -- what checks use to look at a student's module --------------------------------------------------
def attr(mod, dotted: str):
    """``mod.A.b`` for ``dotted = "A.b"``, or CheckFailed naming what is missing."""
    obj = mod
    for part in dotted.split("."):
        if not hasattr(obj, part):
            raise CheckFailed(f"the module has no {dotted!r} (missing {part!r}); keep the names of the starter")
        obj = getattr(obj, part)
    return obj


def array(what: str, value, shape: tuple | None = None) -> np.ndarray:
    """``value`` as a finite float array of ``shape``, or CheckFailed saying what came in."""
    if value is None:
        raise CheckFailed(f"{what} is None; expected an array{'' if shape is None else f' of shape {shape}'} "
                          "(did you forget a return?)")
    try:
        a = np.array(value, dtype=float)
    except (TypeError, ValueError):
        raise CheckFailed(f"{what} is not numbers: {type(value).__name__} {str(value)[:60]}") from None
    if shape is not None and a.shape != tuple(shape):
        raise CheckFailed(f"{what} has shape {a.shape}, expected {tuple(shape)}")
    if not np.all(np.isfinite(a)):
        raise CheckFailed(f"{what} contains NaN or inf")
    return a


def close(what: str, got, want, *, rtol: float = 0.0, atol: float = 0.0, unit: str = "", why: str = "") -> float:
    """max |got − want| ≤ atol + rtol·max|want|, or CheckFailed with the error and the tolerance."""
    want = np.asarray(want, dtype=float)
    got = array(what, got, want.shape)
    err = float(np.max(np.abs(got - want), initial=0.0))
    tol = atol + rtol * float(np.max(np.abs(want), initial=0.0))
    if not err <= tol:
        u = f" {unit}" if unit else ""
        sample = ""
        if want.size <= 6:
            sample = f" (got {np.round(got, 6).tolist()}, expected {np.round(want, 6).tolist()})"
        raise CheckFailed(f"{what}: max error {err:.2e}{u} > tolerance {tol:.1e}{u}{sample}{'; ' + why if why else ''}")
    return err


def at_most(what: str, value: float, bound: float, unit: str = "", why: str = "") -> float:
    """``value`` ≤ ``bound`` (and finite), or CheckFailed."""
    value = float(value)
    if not (np.isfinite(value) and value <= bound):
        u = f" {unit}" if unit else ""
        raise CheckFailed(f"{what} = {value:.3e}{u}, expected at most {bound:.1e}{u}{'; ' + why if why else ''}")
    return value
