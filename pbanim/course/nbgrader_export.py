"""``pbanim course export NAME OUT/``: an assignment as an nbgrader source notebook.

Which platform, and why nbgrader. nbgrader (Jupyter's course tool) grades a notebook whose cells carry
metadata ``nbgrader: {solution, grade, grade_id, points, locked, schema_version}``: ``nbgrader
generate_assignment`` replaces every ``### BEGIN SOLUTION`` … ``### END SOLUTION`` region of a solution
cell by ``raise NotImplementedError()`` at the marker's indentation and deletes every ``### BEGIN HIDDEN
TESTS`` … ``### END HIDDEN TESTS`` region of a test cell; ``nbgrader autograde`` restores the test cells,
runs the notebook and gives a test cell all its points when it runs without an error. That is pbanim's
own model, nearly line for line: solution regions inside function bodies replaced by a raise (the
convention :mod:`pbanim.course.markers` took from nbgrader), checks worth all their points or none,
hidden checks — so the export is a rewriting of markers and one test cell per check, no new grading
logic. otter-grader would have needed more: its solution markers replace a region by ``...`` (a function
returning None, not one raising), its tests are cells whose *printed output* is compared with the
solution's recorded output (or OK-format files written by ``otter assign``, which runs the solution
notebook to record them), and its questions, points and hidden flags live in YAML blocks of raw cells —
a second grading model beside pbanim's, where nbgrader's is the same one.

The notebook (written to ``OUT/source/NAME/NAME.ipynb``, the place nbgrader's course folder keeps an
assignment's source, so ``nbgrader generate_assignment NAME`` run in ``OUT`` finds it):

==============================  ==================================================================
cell                            nbgrader metadata and contents
==============================  ==================================================================
the task (markdown)             locked: title, summary, the regions to write, the checks' points
the module (code)               solution cell (autograded answer): ``%%writefile <module>.py`` and the
                                reference module, each marked region as ``# BEGIN STUDENT CODE
                                <name>`` / ``### BEGIN SOLUTION`` / the reference body / ``### END
                                SOLUTION`` / ``# END STUDENT CODE``, imports made absolute
one cell per check (code)       grade cell with the check's points (Σ = 100, ``pbanim grade``'s
                                weights): ``run_check(NAME, id, "<module>.py")`` and an assert on
                                its outcome; a hidden check's lines inside the hidden-test markers
==============================  ==================================================================

The module cell writes the student's module as a file and each test cell grades that file with the
grader's own check (:func:`pbanim.course.grader.run_check`, in a child process with its time and memory
limits), so a test cell passes exactly when ``pbanim grade`` gives that check its points. After
``generate_assignment`` the module cell is the starter (a region reads ``# YOUR CODE HERE`` / ``raise
NotImplementedError()``) and the hidden checks' cells are empty; the student's environment needs only
the student edition (:mod:`pbanim.course.edition`, which lacks the hidden checks: the instructor's
``autograde`` runs with the full reference).

Limiting cases: a region of one line gives a one-line solution region; a hidden check's cell is, in the
released notebook, a grade cell with no code (it passes there, and counts only at ``autograde``).
"""

from __future__ import annotations

import json
from pathlib import Path

from ..contracts import Choice, Flag, PathLike, contract
from ..errors import InvalidInput
from .markers import STUDENT_BEGIN, STUDENT_END, absolute_imports, find_regions
from .notebook import Cell, notebook_json
from .registry import ASSIGNMENT, Assignment, get_assignment

__all__ = ["nbgrader_notebook", "export_assignment", "FORMATS", "SOLUTION_BEGIN", "SOLUTION_END",
           "HIDDEN_BEGIN", "HIDDEN_END"]

FORMATS = ("nbgrader",)
SOLUTION_BEGIN, SOLUTION_END = "### BEGIN SOLUTION", "### END SOLUTION"
HIDDEN_BEGIN, HIDDEN_END = "### BEGIN HIDDEN TESTS", "### END HIDDEN TESTS"
SCHEMA_VERSION = 3


def _solution_cell_source(a: Assignment) -> str:
    """``%%writefile`` and the reference module with nbgrader's markers around each region's body."""
    src = Path(a.reference_path()).read_text(encoding="utf-8")
    regions = find_regions(src, a.filename)
    lines = absolute_imports(src, a.package).splitlines()
    clash = [k + 1 for k, ln in enumerate(lines) if ln.strip() in (SOLUTION_BEGIN, SOLUTION_END)]
    if clash or not regions:
        raise InvalidInput(f"assignment {a.name!r}: {a.filename} cannot be exported to nbgrader "
                           f"({'no marked regions' if not regions else f'nbgrader markers already at lines {clash}'})")
    for r in reversed(regions):            # 1-based BEGIN and END lines of our markers
        ind = r.indent
        lines[r.begin - 1: r.end] = ([f"{ind}{STUDENT_BEGIN} {r.name}", f"{ind}{SOLUTION_BEGIN}"]
                                     + lines[r.begin: r.end - 1] + [f"{ind}{SOLUTION_END}", f"{ind}{STUDENT_END}"])
    return "\n".join([f"%%writefile {a.filename}"] + lines) + "\n"


def _test_cell_source(a: Assignment, check) -> str:
    head = [f"# {check.id} ({check.points} points{'' if check.public else ', hidden'}): {check.physics} "
            f"(ORACLES {check.oracle})"]
    body = ["from pbanim.course import run_check",
            f'result = run_check("{a.name}", "{check.id}", "{a.filename}")',
            'assert result.passed, f"{result.status}: {result.message}"']
    if check.public:
        return "\n".join(head + body)
    return "\n".join(head + [HIDDEN_BEGIN] + body + [HIDDEN_END])


def _task_text(a: Assignment) -> str:
    regions = find_regions(Path(a.reference_path()).read_text(encoding="utf-8"), a.filename)
    out = [f"# {a.title} ({a.name}, chapter {a.chapter[2:]})", "", a.summary, "",
           f"The next cell writes `{a.filename}` when it runs. Replace each `raise NotImplementedError()` between "
           f"`# BEGIN STUDENT CODE <name>` and `# END STUDENT CODE`, keeping every function's name and signature; "
           "run that cell again, then the test cells. Regions:", ""]
    out += [f"- `{r.name}`" for r in regions]
    out += ["", "| check | points | what it tests | public |", "| --- | --- | --- | --- |"]
    out += [f"| {c.id} | {c.points} | {c.physics} (ORACLES {c.oracle}) | {'yes' if c.public else 'hidden'} |"
            for c in a.checks]
    return "\n".join(out)


def _meta(grade_id: str, *, solution: bool, grade: bool, locked: bool, points: int | None = None) -> dict:
    m = {"grade": grade, "grade_id": grade_id, "locked": locked, "schema_version": SCHEMA_VERSION,
         "solution": solution, "task": False}
    if grade:
        m["points"] = points
    return {"nbgrader": m}


@contract(name=ASSIGNMENT)
def nbgrader_notebook(name: str) -> dict:
    """The nbgrader source notebook (an nbformat-4.5 dict) of assignment ``name``: the task, the module as
    a solution cell, one grade cell per check with its points (hidden checks in the hidden-test markers)."""
    a = get_assignment(name)
    cells = [Cell("markdown", _task_text(a)), Cell("code", _solution_cell_source(a))]
    cells += [Cell("code", _test_cell_source(a, c)) for c in a.checks]
    nb = notebook_json(cells)
    metas = [("task", _meta(f"{a.name}-task", solution=False, grade=False, locked=True)),
             ("module", _meta(f"{a.name}-module", solution=True, grade=False, locked=False))]
    metas += [(f"check-{c.id}", _meta(f"{a.name}-{c.id}", solution=False, grade=True, locked=True, points=c.points))
              for c in a.checks]
    for cell, (cid, meta) in zip(nb["cells"], metas):
        cell["id"], cell["metadata"] = cid, meta
    nb["metadata"]["pbanim"] = {"assignment": a.name, "format": "nbgrader"}
    del nb["metadata"]["jupytext"]
    return nb


@contract(name=ASSIGNMENT, out_dir=PathLike(), fmt=Choice(FORMATS), overwrite=Flag())
def export_assignment(name: str, out_dir, fmt: str = "nbgrader", *, overwrite: bool = False) -> Path:
    """Write ``OUT/source/NAME/NAME.ipynb`` (nbgrader's course layout) for assignment ``name``; return it."""
    a = get_assignment(name)
    out = Path(out_dir)
    if out.exists() and not out.is_dir():
        raise InvalidInput(f"out_dir must be a folder, got the file {str(out_dir)!r}")
    path = out / "source" / a.name / f"{a.name}.ipynb"
    if path.exists() and not overwrite:
        raise InvalidInput(f"{str(path)!r} exists; choose another folder or pass --force")
    nb = nbgrader_notebook(a.name)
    try:
        import nbformat
    except ImportError:
        nbformat = None
    if nbformat is not None:
        nbformat.validate(nbformat.from_dict(nb))
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(json.dumps(nb, indent=1, ensure_ascii=False) + "\n", encoding="utf-8")
    return path
