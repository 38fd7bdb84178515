"""``pbanim assignment make NAME DIR``: the student's starter folder, cut from the reference.

The folder holds three files:

===========================  ======================================================================
file                         contents
===========================  ======================================================================
``<module>.py``              the reference module with each marked region replaced by
                             ``raise NotImplementedError`` (docstrings kept, imports made absolute:
                             the file uses the installed pbanim for everything else)
``test_<assignment>.py``     the public checks, one pytest test each (``pytest DIR``); each runs the
                             grader's own check in a child process, so a student sees exactly what
                             ``pbanim grade`` will say about those checks
``README.md``                the task, the regions to write, the checks with their points and physics,
                             how to test and how to grade
===========================  ======================================================================

The hidden checks run only in ``pbanim grade``. Writing refuses to overwrite an existing file unless
``overwrite=True``; a pending assignment (its chapter still being written) is refused with its reason.
Limiting case: an assignment whose module has no markers cannot be made (``MarkerError``).
"""

from __future__ import annotations

from pathlib import Path

from ..errors import InvalidInput
from .markers import find_regions, starter_source
from .registry import Assignment, get_assignment

__all__ = ["write_starter", "public_tests_source", "readme_text"]


def public_tests_source(a: Assignment) -> str:
    """The public test file: one parametrized test over the public checks."""
    public = [c.id for c in a.checks if c.public]
    return f'''"""Public tests of the pbanim assignment {a.name} ({a.title}).

Run them with `pytest` in this folder. Each test runs one check of the grader on {a.filename},
in a separate process with a time limit: the message says what was expected and what came in.
`pbanim grade {a.name} .` runs these checks and the hidden ones, and writes the report.
"""

from pathlib import Path

import pytest

from pbanim.course import run_check

MODULE = Path(__file__).with_name("{a.filename}")
PUBLIC_CHECKS = {public!r}


@pytest.mark.parametrize("check", PUBLIC_CHECKS)
def test_public_check(check):
    result = run_check("{a.name}", check, MODULE)
    assert result.passed, f"{{check}}: {{result.status}}: {{result.message}} (tests: {{result.physics}})"
'''


def readme_text(a: Assignment, regions) -> str:
    """The student's README: task, regions, checks, commands."""
    lines = [f"# {a.title} ({a.name}, chapter {a.chapter[2:]})", "", a.summary, "",
             "## What to write", "",
             f"Open `{a.filename}` and replace each `raise NotImplementedError` between the lines "
             "`# BEGIN STUDENT CODE <name>` and `# END STUDENT CODE`. Keep every function's name and "
             "signature; read its docstring (and the module's) for the equations and the notation.", ""]
    lines += [f"- `{r.name}`" for r in regions]
    lines += ["", "## How you are graded", "",
              "| check | points | what it tests | public |", "| --- | --- | --- | --- |"]
    lines += [f"| {c.id} | {c.points} | {c.physics} (ORACLES {c.oracle}) | {'yes' if c.public else 'hidden'} |"
              for c in a.checks]
    lines += ["", "A check gives all its points or none. Each runs in its own process with a time limit "
              "(20 s) and a memory limit (1 GB): an endless loop or a crash costs that check only.", "",
              "## Commands", "", "```",
              "pytest .                          # the public checks",
              f"pbanim grade {a.name} .   # every check: table, report.json, report.md", "```", ""]
    return "\n".join(lines)


def write_starter(name: str, out_dir, *, overwrite: bool = False) -> list[Path]:
    """Write the starter folder of assignment ``name`` into ``out_dir``; return the files written."""
    a = get_assignment(name)
    src = Path(a.reference_path()).read_text(encoding="utf-8")
    regions = find_regions(src, a.filename)
    code = starter_source(src, a.package, a.filename)
    out = Path(out_dir)
    if out.exists() and not out.is_dir():
        raise InvalidInput(f"out_dir must be a folder, got the file {str(out_dir)!r}")
    files = {out / a.filename: code, out / f"test_{a.name}.py": public_tests_source(a),
             out / "README.md": readme_text(a, regions)}
    existing = [p.name for p in files if p.exists()]
    if existing and not overwrite:
        raise InvalidInput(f"{str(out_dir)!r} already has {existing}; choose an empty folder or pass --force")
    out.mkdir(parents=True, exist_ok=True)
    for p, text in files.items():
        p.write_text(text, encoding="utf-8")
    return list(files)
