"""An assignment as an nbgrader source notebook (pbanim.course.nbgrader_export, ``pbanim course export``).

What the platform does is written here from nbgrader's documentation, not from the exporter: the cell
metadata of schema version 3 ("JSON Metadata Format" and its JSON schema: ``schema_version``, ``grade``,
``solution``, ``locked`` required on every nbgrader cell, no keys beyond those and ``task``, ``grade_id``,
``points``, ``checksum``, ``cell_type``; ``grade_id`` of letters, digits, _ and - when any flag is true and
unique, ``points`` ≥ 0 on a grade cell, a markdown cell graded only as a solution), ``generate_assignment`` replacing a line ``### BEGIN SOLUTION`` … ``### END SOLUTION``
by ``# YOUR CODE HERE`` / ``raise NotImplementedError()`` at the BEGIN line's indentation and deleting
``### BEGIN HIDDEN TESTS`` … ``### END HIDDEN TESTS``, and ``autograde`` giving a grade cell its points
when it runs without an error. The notebook of the reference then scores 100 and the cleared one 0, as
``pbanim grade`` scores the reference and the starter (ORACLES D4, D8: the checks of ch07 that its test
cells run); a format or an overwrite it refuses is a named error (ORACLES G3).
"""

from __future__ import annotations

import json
import re
from pathlib import Path

import pytest

from pbanim.cli import main
from pbanim.course import assignments, get_assignment
from pbanim.course.markers import find_regions, starter_source
from pbanim.course.nbgrader_export import export_assignment, nbgrader_notebook
from pbanim.errors import InvalidInput

READY = sorted(assignments(ready_only=True))
END_TO_END = "ch07_lcp"                  # three checks, one hidden: the shortest grading run (about 1 s)
# nbgrader's documented markers and stub (ClearSolutions, ClearHiddenTests)
NB_BEGIN, NB_END = "### BEGIN SOLUTION", "### END SOLUTION"
NB_HIDDEN_BEGIN, NB_HIDDEN_END = "### BEGIN HIDDEN TESTS", "### END HIDDEN TESTS"
NB_STUB = ("# YOUR CODE HERE", "raise NotImplementedError()")


def _src(cell) -> str:
    s = cell["source"]
    return s if isinstance(s, str) else "".join(s)


def clear_solutions(text: str) -> str:
    """nbgrader's generate_assignment on a solution cell, as its documentation describes it."""
    out, inside = [], False
    for line in text.split("\n"):
        if line.strip() == NB_BEGIN:
            assert not inside, "nested solution regions"
            inside = True
            indent = line[:line.index(NB_BEGIN)]
            out += [indent + s for s in NB_STUB]
        elif line.strip() == NB_END:
            assert inside, "END SOLUTION without BEGIN"
            inside = False
        elif not inside:
            out.append(line)
    assert not inside, "no END SOLUTION"
    return "\n".join(out)


def clear_hidden_tests(text: str) -> str:
    out, inside = [], False
    for line in text.split("\n"):
        if line.strip() == NB_HIDDEN_BEGIN:
            inside = True
        elif line.strip() == NB_HIDDEN_END:
            inside = False
        elif not inside:
            out.append(line)
    return "\n".join(out)


NB_REQUIRED = {"schema_version", "grade", "locked", "solution"}
NB_ALLOWED = NB_REQUIRED | {"task", "grade_id", "points", "checksum", "cell_type"}


def _nbgrader_meta_problems(nb) -> list[str]:
    problems, ids = [], set()
    for cell in nb["cells"]:
        meta = cell["metadata"].get("nbgrader")
        if meta is None:
            continue
        missing, extra = NB_REQUIRED - set(meta), set(meta) - NB_ALLOWED
        if missing or extra:
            problems.append(f"{cell['id']}: missing {sorted(missing)}, not in the schema {sorted(extra)}")
            continue
        if not all(isinstance(meta.get(k, False), bool) for k in ("grade", "locked", "solution", "task")):
            problems.append(f"{cell['id']}: a flag that is not a boolean")
        if not re.fullmatch(r"[a-zA-Z0-9_\-]*", meta.get("grade_id", "")):
            problems.append(f"{cell['id']}: grade_id {meta['grade_id']!r} has characters the schema refuses")
        if meta["schema_version"] != 3:
            problems.append(f"{cell['id']}: schema_version {meta['schema_version']}")
        if meta["grade"] or meta["solution"] or meta["locked"]:
            if not meta.get("grade_id"):
                problems.append(f"{cell['id']}: no grade_id")
            elif meta["grade_id"] in ids:
                problems.append(f"duplicate grade_id {meta['grade_id']}")
            ids.add(meta.get("grade_id"))
        if meta["grade"] and not (isinstance(meta.get("points"), (int, float)) and meta["points"] >= 0):
            problems.append(f"{cell['id']}: grade cell without points")
        if cell["cell_type"] == "markdown" and meta["grade"] != meta["solution"] and not meta.get("task"):
            problems.append(f"{cell['id']}: a markdown cell graded without being a solution (or the reverse)")
    return problems


def _without_stubs(text: str) -> list[str]:
    drop = ("raise NotImplementedError", NB_STUB[0])
    return [ln for ln in text.split("\n") if not ln.strip().startswith(drop)]


@pytest.mark.parametrize("name", READY)
def test_every_assignment_exports_an_nbgrader_notebook(name):
    nbformat = pytest.importorskip("nbformat")
    a = get_assignment(name)
    nb = nbgrader_notebook(name)
    nbformat.validate(nbformat.from_dict(nb))
    assert nb["nbformat"] == 4 and _nbgrader_meta_problems(nb) == []
    solution = [c for c in nb["cells"] if c["metadata"]["nbgrader"]["solution"]]
    graded = [c for c in nb["cells"] if c["metadata"]["nbgrader"]["grade"]]
    assert len(solution) == 1 and solution[0]["cell_type"] == "code"
    # the points of pbanim grade, in its order, one grade cell per check
    assert [c["metadata"]["nbgrader"]["points"] for c in graded] == [k.points for k in a.checks]
    assert sum(c["metadata"]["nbgrader"]["points"] for c in graded) == 100
    # the platform's clearing leaves the starter: the same lines outside the regions, no reference body
    ref = Path(a.reference_path()).read_text(encoding="utf-8")
    head, _, module = _src(solution[0]).partition("\n")
    assert head == f"%%writefile {a.filename}" and module.count(NB_BEGIN) == len(find_regions(ref))
    released = clear_solutions(module)
    assert _without_stubs(released) == _without_stubs(starter_source(ref, a.package, a.filename))
    assert [r.name for r in find_regions(released)] == [r.name for r in find_regions(ref)]
    # hidden checks vanish from the students' version, public ones stay whole
    for cell, chk in zip(graded, a.checks):
        text = _src(cell)
        call = f'run_check("{name}", "{chk.id}", "{a.filename}")'
        assert call in text and (call in clear_hidden_tests(text)) == chk.public, chk.id


def _grade_cells(nb) -> list[tuple[int, bool, str]]:
    """(points, ran without an error, the error's text) of each grade cell: nbgrader autograde's verdict."""
    out = []
    for c in nb.cells:
        meta = c.metadata.get("nbgrader", {})
        if meta.get("grade"):
            errors = [o for o in c.outputs if o.get("output_type") == "error"]
            out.append((meta["points"], not errors, " ".join(e.get("evalue", "") for e in errors)))
    return out


def test_the_notebook_scores_the_reference_100_and_the_cleared_one_0(tmp_path):
    nbclient = pytest.importorskip("nbclient")
    pytest.importorskip("ipykernel")
    nbformat = pytest.importorskip("nbformat")
    path = export_assignment(END_TO_END, tmp_path)
    source = nbformat.read(str(path), as_version=4)
    cleared = nbformat.read(str(path), as_version=4)       # an untouched release, at autograde: hidden tests back
    for c in cleared.cells:
        if c.metadata["nbgrader"]["solution"]:
            c.source = clear_solutions(c.source)
    for nb, where in ((source, tmp_path / "reference"), (cleared, tmp_path / "starter")):
        where.mkdir()
        nbclient.NotebookClient(nb, timeout=120, kernel_name="python3", allow_errors=True,
                                resources={"metadata": {"path": str(where)}}).execute()
    ref, start = _grade_cells(source), _grade_cells(cleared)
    assert sum(p for p, ok, _ in ref if ok) == 100, ref
    assert len(start) == len(get_assignment(END_TO_END).checks) and not any(ok for _, ok, _ in start), start
    assert all("not_implemented" in msg for _, _, msg in start), start


def test_nbgraders_own_preprocessors_agree():
    # with nbgrader installed, its own validator and clearing on the notebook (skipped without it; the
    # documented behaviour is tested above without the package)
    pytest.importorskip("nbgrader")
    nbformat = pytest.importorskip("nbformat")
    from nbgrader.nbgraderformat import MetadataValidator
    from nbgrader.preprocessors import ClearHiddenTests, ClearSolutions

    nb = nbformat.from_dict(nbgrader_notebook(END_TO_END))
    MetadataValidator().validate_nb(nb)
    want = [clear_hidden_tests(clear_solutions(c.source)) for c in nb.cells]
    nb, _ = ClearSolutions().preprocess(nb, {})
    nb, _ = ClearHiddenTests().preprocess(nb, {})
    assert [c.source.rstrip("\n") for c in nb.cells] == [w.rstrip("\n") for w in want]


def test_cli_export_writes_nbgraders_layout_and_refuses_to_overwrite(tmp_path, capsys):
    assert main(["course", "export", END_TO_END, str(tmp_path)]) == 0
    path = tmp_path / "source" / END_TO_END / f"{END_TO_END}.ipynb"
    assert json.loads(path.read_text(encoding="utf-8"))["metadata"]["pbanim"]["format"] == "nbgrader"
    assert main(["course", "export", END_TO_END, str(tmp_path)]) == 2
    assert "exists" in capsys.readouterr().err
    assert main(["course", "export", END_TO_END, str(tmp_path), "--force"]) == 0
    with pytest.raises(SystemExit):
        main(["course", "export", END_TO_END, str(tmp_path), "--format", "otter"])
    with pytest.raises(InvalidInput, match="fmt"):
        export_assignment(END_TO_END, tmp_path, "otter", overwrite=True)
