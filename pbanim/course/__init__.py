"""Course tools (layer 9): assignments cut from the reference, and the autograder.

    pbanim assignment list                      the assignments, one line each (pending ones marked)
    pbanim assignment make NAME DIR             the student's starter: module, public tests, README
    pbanim grade NAME PATH [--json F] [--markdown F]   per-check table with points; JSON and markdown reports

Parts: :mod:`~pbanim.course.markers` (solution markers, starter source), :mod:`~pbanim.course.registry`
(assignments as data: module, checks with points, mutants), :mod:`~pbanim.course.catalog` (the course's
assignments), the checks (``checks_*``), :mod:`~pbanim.course.sandbox` (one check per child process
with time and memory limits), :mod:`~pbanim.course.grader` (the report), :mod:`~pbanim.course.starter`
(writing the student's folder) and :mod:`~pbanim.course.notebook` (chapters as notebooks).
Nothing here is imported by ``import pbanim``.
"""

from __future__ import annotations

from ..contracts import Flag, PathLike, contract
from .grader import CheckResult, GradeReport, grade, run_check
from .registry import ASSIGNMENT, ASSIGNMENTS, Assignment, Check, CheckFailed, Mutant, get_assignment

__all__ = ["grade", "run_check", "GradeReport", "CheckResult", "Assignment", "Check", "Mutant", "CheckFailed",
           "ASSIGNMENTS", "get_assignment", "assignments", "make_assignment"]


@contract(ready_only=Flag())
def assignments(ready_only: bool = False) -> dict:
    """Every registered assignment (loads the catalog), sorted by name."""
    from . import catalog  # noqa: F401

    return {k: a for k, a in sorted(ASSIGNMENTS.items()) if a.status == "ready" or not ready_only}


@contract(name=ASSIGNMENT, out_dir=PathLike(), overwrite=Flag())
def make_assignment(name: str, out_dir, *, overwrite: bool = False):
    """Write the student's starter folder for assignment ``name`` (see :mod:`pbanim.course.starter`)."""
    from .starter import write_starter

    return write_starter(name, out_dir, overwrite=overwrite)
