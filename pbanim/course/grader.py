"""The autograder: ``pbanim grade NAME PATH`` scores a student's module against the chapter's oracles.

For each check of the assignment (in its declared order) the grader runs the check in its own process
(:mod:`pbanim.course.sandbox`), collects its status and one-line message, and awards all or none of its
points. The score is

    score = Σ points of the passed checks,   out of 100 (the points of an assignment add up to 100).

Before the checks, the file is imported once (in a child as well): a file that does not import gives one
line for the whole report ("does not import: SyntaxError at line 12: …") and every check is reported as
not run; a region whose signature differs from the reference's is named ("wrong signature").

The report is a :class:`GradeReport`: printed as a table (check, points, status, the physics it tests,
the message), written as JSON and as markdown. It holds no timings, no absolute paths and no dates, so
grading the same file twice gives byte-identical reports (ORACLES G2).

Limiting cases: the reference scores 100; the unmodified starter scores 0 with "not implemented yet:
<region>" on every check; a mutant (a typical bug) loses exactly the points of the checks that catch it
(``tests/test_course_grader.py`` proves it for each mutant of each assignment).
"""

from __future__ import annotations

import inspect
import json
from dataclasses import asdict, dataclass, field
from pathlib import Path

from ..contracts import Choice, Opt, PathLike, Real, Seq, Text, contract
from ..errors import InvalidInput
from .markers import region_owners
from .registry import ASSIGNMENT, Assignment, get_assignment
from .sandbox import StudentImportError, load_student, run_forked, run_inline, run_isolated

__all__ = ["CheckResult", "GradeReport", "grade", "run_check", "signature_problems"]


@dataclass
class CheckResult:
    id: str
    points: int
    earned: int
    status: str
    physics: str
    oracle: str
    message: str

    @property
    def passed(self) -> bool:
        return self.status == "passed"


@dataclass
class GradeReport:
    assignment: str
    title: str
    file: str
    results: list[CheckResult] = field(default_factory=list)
    notes: list[str] = field(default_factory=list)

    @property
    def score(self) -> int:
        return sum(r.earned for r in self.results)

    @property
    def total(self) -> int:
        return sum(r.points for r in self.results)

    def to_json(self) -> dict:
        return {"assignment": self.assignment, "title": self.title, "file": self.file, "score": self.score,
                "total": self.total, "notes": list(self.notes), "checks": [asdict(r) for r in self.results]}

    def table(self) -> str:
        """Plain-text table, one line per check, then the score."""
        head = ("check", "points", "status", "tests (ORACLES id)")
        rows = [(r.id, f"{r.earned}/{r.points}", r.status, f"{r.physics} ({r.oracle})") for r in self.results]
        w = [max(len(h), *(len(row[i]) for row in rows)) if rows else len(h) for i, h in enumerate(head)]
        out = [f"# pbanim grade {self.assignment}: {self.title} — {self.file}"]
        out += [f"note: {n}" for n in self.notes]
        out += ["  ".join(h.ljust(wi) for h, wi in zip(head, w)), "  ".join("-" * wi for wi in w)]
        for r, row in zip(self.results, rows):
            out.append("  ".join(c.ljust(wi) for c, wi in zip(row, w)).rstrip())
            out.append(f"    {r.message}")
        out.append(f"score: {self.score}/{self.total}")
        return "\n".join(out)

    def markdown(self) -> str:
        esc = lambda s: str(s).replace("|", "\\|")  # noqa: E731
        out = [f"# {self.assignment}: {self.title}", "", f"File: `{self.file}` — **score {self.score}/{self.total}**", ""]
        out += [f"> {esc(n)}" for n in self.notes] + ([""] if self.notes else [])
        out += ["| check | points | status | physics tested | oracle | message |",
                "| --- | --- | --- | --- | --- | --- |"]
        out += [f"| {r.id} | {r.earned}/{r.points} | {r.status} | {esc(r.physics)} | {r.oracle} | {esc(r.message)} |"
                for r in self.results]
        return "\n".join(out) + "\n"

    @contract(json_path=Opt(PathLike()), markdown_path=Opt(PathLike()))
    def write(self, json_path: str | Path | None = None, markdown_path: str | Path | None = None) -> None:
        if json_path:
            Path(json_path).write_text(json.dumps(self.to_json(), indent=1, sort_keys=True, ensure_ascii=False) + "\n")
        if markdown_path:
            Path(markdown_path).write_text(self.markdown())


def _student_file(a: Assignment, path) -> Path:
    """The student's module: ``path`` itself, or ``path/<module file>`` for the starter folder."""
    p = Path(path)
    if p.is_dir():
        p = p / a.filename
    if not p.is_file():
        raise InvalidInput(f"path must be the student's module file or its folder: {str(path)!r} not found (give "
                           f"the module file, e.g. "
                           f"DIR/{a.filename}, or the folder that `pbanim assignment make` wrote)")
    return p


def signature_problems(a: Assignment, mod) -> list[str]:
    """One line per marked function of the reference whose signature the student changed or removed."""
    owners = region_owners(Path(a.reference_path()).read_text(encoding="utf-8"), a.filename)
    problems = []
    for q in sorted(owners):
        obj = mod
        for part in q.split("."):
            obj = getattr(obj, part, None)
        if obj is None:
            problems.append(f"{q} is missing from the file")
            continue
        args = owners[q].args
        names = [p.arg for p in args.posonlyargs + args.args] + ([args.vararg.arg] if args.vararg else []) + \
            [p.arg for p in args.kwonlyargs] + ([args.kwarg.arg] if args.kwarg else [])
        try:
            got = list(inspect.signature(obj).parameters)
        except (TypeError, ValueError):
            continue
        if names and names[0] == "self":
            names = names[1:]
            got = got[1:] if got[:1] == ["self"] else got
        if got != names:
            problems.append(f"wrong signature: {q}({', '.join(got)}), expected {q}({', '.join(names)})")
    return problems


def _import_probe(a: Assignment, path: Path) -> dict:
    """Import the file (in the calling process) and list its signature problems."""
    try:
        mod = load_student(path, f"probe_{a.name}")
    except StudentImportError as exc:
        return {"status": "import_error", "message": str(exc)}
    return {"status": "passed", "message": "; ".join(signature_problems(a, mod))}


# what the limits of a check's process may be: a CPU-time limit and an address-space budget the kernel can
# set (setrlimit takes whole seconds and bytes; a day and a terabyte are far beyond any check)
ISOLATION = Choice(("fork", "inline"))
TIME_LIMIT = Real(gt=0, le=86_400)
MEMORY_MB = Real(gt=0, le=2**20)
_LIMITS = dict(name=ASSIGNMENT, path=PathLike(), isolation=ISOLATION, time_limit=TIME_LIMIT, memory_mb=MEMORY_MB)


@contract(check_id=Text(), **_LIMITS)
def run_check(name: str, check_id: str, path, *, isolation: str = "fork", time_limit: float = 20.0,
              memory_mb: float = 1024.0) -> CheckResult:
    """Run one check of assignment ``name`` on the student file ``path`` (the public tests use this)."""
    a = get_assignment(name)
    chk = a.get_check(check_id)
    p = _student_file(a, path)
    out = (run_isolated(a, check_id, p, time_limit=time_limit, memory_mb=memory_mb) if isolation == "fork"
           else run_inline(a, check_id, p))
    return CheckResult(chk.id, chk.points, chk.points if out["status"] == "passed" else 0, out["status"],
                       chk.physics, chk.oracle, out["message"])


@contract(checks=Opt(Seq(Text(), min_len=1)), **_LIMITS)
def grade(name: str, path, *, isolation: str = "fork", time_limit: float = 20.0, memory_mb: float = 1024.0,
          checks: list[str] | None = None) -> GradeReport:
    """Grade the student file (or starter folder) ``path`` against assignment ``name``.

    ``isolation``: "fork" (default: each check in a child with limits) or "inline" (same process, no
    limits; for debugging). ``checks``: only these check ids (default all).
    """
    a = get_assignment(name)
    p = _student_file(a, path)
    unknown = [c for c in checks or () if c not in {k.id for k in a.checks}]
    if unknown:
        raise InvalidInput(f"grade: checks must be ids of {a.name}'s checks {[k.id for k in a.checks]}, got "
                           f"{unknown}")
    selected = list(a.checks) if checks is None else [a.get_check(c) for c in checks]
    rep = GradeReport(a.name, a.title, p.name)
    if isolation == "fork":
        probe = run_forked(_import_probe, (a, p), time_limit=time_limit, memory_mb=memory_mb)
    else:
        probe = _import_probe(a, p)
    if probe["status"] != "passed":
        rep.notes.append(probe["message"])
        rep.results = [CheckResult(c.id, c.points, 0, "import_error", c.physics, c.oracle,
                                   "not run: the module does not import") for c in selected]
        return rep
    if probe["message"]:
        rep.notes.append(probe["message"])
    for c in selected:
        out = (run_isolated(a, c.id, p, time_limit=time_limit, memory_mb=memory_mb) if isolation == "fork"
               else run_inline(a, c.id, p))
        rep.results.append(CheckResult(c.id, c.points, c.points if out["status"] == "passed" else 0,
                                       out["status"], c.physics, c.oracle, out["message"]))
    return rep
