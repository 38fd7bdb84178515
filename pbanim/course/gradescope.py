"""Grading on Gradescope: its ``results.json``, and the autograder zip it takes.

Gradescope runs an autograder in a container laid out as

    /autograder/source/          the zip's contents; ``setup.sh`` ran there once, when the image was built
    /autograder/submission/      the student's upload (files, or a folder of them)
    /autograder/results/results.json     what the run must leave: the score and one entry per test

``results.json`` (Gradescope's "Autograder specifications"):
``{"score": Σ earned, "output": text, "tests": [{"name", "score", "max_score", "output", "visibility"}]}``
with ``visibility`` "visible" for a public check and "after_due_date" for a hidden one (the student sees
its line once the due date has passed), and ``stdout_visibility`` "hidden".

``pbanim course autograder NAME OUT.zip`` writes the zip: ``setup.sh`` (pip-installs the wheel beside
it), ``run_autograder`` (grades the upload and writes ``results.json``) and the grading edition of
pbanim (:func:`pbanim.course.edition.build_edition` with ``keep_hidden=True``): the assignment's
solution regions are removed — a submission that imports pbanim's own solution gets a
NotImplementedError — while its checks, hidden ones included, are there. (Inside the container the
hidden checks are files a submission could read, as with any Gradescope autograder.)

``python -m pbanim.course.gradescope NAME`` is what ``run_autograder`` runs. The root is ``/autograder``,
or the environment variable ``PBANIM_AUTOGRADER_ROOT`` (a test lays the platform out in a scratch
folder). The submission's module is found by name anywhere under ``submission/`` (one file of that
name); none or several is a results.json with score 0 and the reason, never a crash.

Other platforms: nbgrader's source notebook is written by :mod:`pbanim.course.nbgrader_export`
(``pbanim course export NAME OUT/``; it says why nbgrader was chosen over otter-grader).
"""

from __future__ import annotations

import json
import os
import stat
import sys
import tempfile
import zipfile
from pathlib import Path

from ..contracts import Flag, Obj, PathLike, contract
from ..errors import InvalidInput
from .grader import GradeReport, grade
from .registry import ASSIGNMENT, get_assignment

__all__ = ["gradescope_results", "write_autograder", "run_autograder", "ROOT_VARIABLE"]

ROOT_VARIABLE = "PBANIM_AUTOGRADER_ROOT"

_SETUP = """#!/usr/bin/env bash
# Gradescope runs this once when it builds the autograder image (in /autograder/source).
set -euo pipefail
cd "$(dirname "$0")"
PY="${PBANIM_PYTHON:-python3}"
if ! "$PY" -m pip --version >/dev/null 2>&1; then
    apt-get update && apt-get install -y python3 python3-pip
fi
# an image whose system Python is "externally managed" (PEP 668) takes the wheel with the override
"$PY" -m pip install ${PBANIM_PIP_ARGS:-} ./WHEEL || "$PY" -m pip install --break-system-packages ${PBANIM_PIP_ARGS:-} ./WHEEL
"""

_RUN = """#!/usr/bin/env bash
# Gradescope runs this for each submission; it writes $ROOT/results/results.json.
set -uo pipefail
ROOT="${PBANIM_AUTOGRADER_ROOT:-/autograder}"
cd "$ROOT/source"
exec "${PBANIM_PYTHON:-python3}" -m pbanim.course.gradescope NAME
"""


@contract(report=Obj(GradeReport))
def gradescope_results(report: GradeReport) -> dict:
    """Gradescope's results.json (a dict) of a grade report: one test per check, hidden ones shown after the
    due date; the score is the report's (Σ earned points)."""
    a = get_assignment(report.assignment)
    public = {c.id: c.public for c in a.checks}
    tests = [{"name": f"{r.id}: {r.physics}", "score": r.earned, "max_score": r.points,
              "output": f"{r.status}: {r.message} (ORACLES {r.oracle})",
              "visibility": "visible" if public.get(r.id, True) else "after_due_date"} for r in report.results]
    output = "\n".join([f"pbanim grade {report.assignment}: {report.title} — {report.file}"] + list(report.notes))
    return {"score": report.score, "output": output, "stdout_visibility": "hidden", "tests": tests}


def _failure(message: str) -> dict:
    return {"score": 0, "output": message, "stdout_visibility": "hidden", "tests": []}


@contract(name=ASSIGNMENT)
def run_autograder(name: str) -> dict:
    """Grade ``$ROOT/submission`` for assignment ``name`` and write ``$ROOT/results/results.json``
    (root: ``/autograder`` or ``$PBANIM_AUTOGRADER_ROOT``); returns the results."""
    a = get_assignment(name)
    root = Path(os.environ.get(ROOT_VARIABLE) or "/autograder")
    found = sorted(p for p in (root / "submission").rglob(a.filename) if p.is_file())
    if len(found) == 1:
        results = gradescope_results(grade(name, found[0]))
    elif not found:
        results = _failure(f"no file {a.filename} in the submission: upload the module you wrote "
                           f"(pbanim assignment make {name} DIR wrote it)")
    else:
        results = _failure(f"{len(found)} files named {a.filename} in the submission: upload one")
    out = root / "results" / "results.json"
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text(json.dumps(results, indent=1, ensure_ascii=False) + "\n", encoding="utf-8")
    return results


@contract(name=ASSIGNMENT, out_zip=PathLike(), overwrite=Flag())
def write_autograder(name: str, out_zip, *, overwrite: bool = False) -> Path:
    """Write Gradescope's autograder zip of assignment ``name``: setup.sh, run_autograder and the grading
    edition's wheel (solutions removed, checks kept); return its path."""
    from .edition import build_edition

    a = get_assignment(name)
    out = Path(out_zip)
    if out.suffix != ".zip":
        raise InvalidInput(f"out_zip must end in .zip, got {str(out_zip)!r}")
    if out.exists() and not overwrite:
        raise InvalidInput(f"{str(out_zip)!r} exists; choose another name or pass --force")
    with tempfile.TemporaryDirectory() as tmp:
        wheel = build_edition(tmp, [a.name], keep_hidden=True, tag="autograder")
        scripts = {"setup.sh": _SETUP.replace("WHEEL", wheel.name), "run_autograder": _RUN.replace("NAME", a.name)}
        out.parent.mkdir(parents=True, exist_ok=True)
        with zipfile.ZipFile(out, "w", zipfile.ZIP_DEFLATED) as z:
            for fname, text in scripts.items():
                zi = zipfile.ZipInfo(fname, (2020, 1, 1, 0, 0, 0))
                zi.external_attr = (0o755 | stat.S_IFREG) << 16
                z.writestr(zi, text)
            z.write(wheel, wheel.name)
    return out


if __name__ == "__main__":     # what run_autograder runs
    if len(sys.argv) != 2:
        sys.exit("usage: python -m pbanim.course.gradescope ASSIGNMENT")
    run_autograder(sys.argv[1])
