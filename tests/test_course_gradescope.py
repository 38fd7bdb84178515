"""Grading on Gradescope (pbanim.course.gradescope): results.json, and the autograder zip run in the
platform's layout (source/, submission/, results/ under a root given by PBANIM_AUTOGRADER_ROOT).

``setup.sh`` is run as the platform runs it, with pip told to install the wheel without dependencies into
a folder (no network); ``run_autograder`` then runs with that folder first on the path. The reference scores
100 with every check listed, hidden ones visible after the due date; a submission that calls pbanim's own
solution scores nothing on the checks of that solution (ORACLES B1, B2, B5: the checks of ch03; G2: the
report holds no paths).
"""

from __future__ import annotations

import json
import os
import stat
import subprocess
import sys
import zipfile
from pathlib import Path

import pytest

from pbanim.cli import main
from pbanim.course import get_assignment, grade, make_assignment
from pbanim.course.gradescope import gradescope_results, write_autograder
from pbanim.course.markers import solution_source
from pbanim.errors import InvalidInput

NAME = "ch03_constraints"


def _reference(a) -> str:
    return solution_source(Path(a.reference_path()).read_text(encoding="utf-8"), a.package)


def test_results_json_has_the_platforms_fields(tmp_path):
    a = get_assignment("ch01_particles")
    make_assignment(a.name, tmp_path)
    res = gradescope_results(grade(a.name, tmp_path))
    assert res["score"] == 0 and res["stdout_visibility"] == "hidden" and str(tmp_path) not in json.dumps(res)
    assert [t["max_score"] for t in res["tests"]] == [c.points for c in a.checks]
    assert sum(t["max_score"] for t in res["tests"]) == 100
    for t, c in zip(res["tests"], a.checks):
        assert set(t) == {"name", "score", "max_score", "output", "visibility"}
        assert t["name"].startswith(c.id) and t["score"] == 0 and t["output"].startswith("not_implemented")
        assert t["visibility"] == ("visible" if c.public else "after_due_date")
    assert {t["visibility"] for t in res["tests"]} == {"visible", "after_due_date"}


def test_cli_grade_format_gradescope(tmp_path, capsys):
    a = get_assignment(NAME)
    (tmp_path / a.filename).write_text(_reference(a), encoding="utf-8")
    out = tmp_path / "results.json"
    assert main(["grade", NAME, str(tmp_path), "--format", "gradescope", "--json", str(out)]) == 0
    res = json.loads(out.read_text())
    assert res["score"] == 100 == sum(t["score"] for t in res["tests"])
    assert "score: 100/100" in capsys.readouterr().out
    assert not (tmp_path / "report.md").exists()
    with pytest.raises(SystemExit) as exc:
        main(["grade", NAME, str(tmp_path), "--format", "canvas"])
    assert exc.value.code == 2 and "invalid choice: 'canvas'" in capsys.readouterr().err


def _platform(tmp_path: Path, zip_path: Path) -> tuple[Path, dict]:
    """Lay the platform out under tmp_path/autograder, unpack the zip into source/ and run setup.sh."""
    root = tmp_path / "autograder"
    (root / "source").mkdir(parents=True)
    (root / "submission").mkdir()
    with zipfile.ZipFile(zip_path) as z:
        z.extractall(root / "source")
        for info in z.infolist():                      # zipfile drops the mode bits; the platform keeps them
            mode = info.external_attr >> 16
            if mode:
                os.chmod(root / "source" / info.filename, mode & 0o777)
    site = tmp_path / "site"
    env = {**os.environ, "PBANIM_PYTHON": sys.executable, "PIP_DISABLE_PIP_VERSION_CHECK": "1",
           "PBANIM_PIP_ARGS": f"--no-deps --no-index -q --target {site}", "PBANIM_AUTOGRADER_ROOT": str(root)}
    subprocess.run(["bash", str(root / "source" / "setup.sh")], check=True, env=env, timeout=120)
    return root, {**env, "PYTHONPATH": str(site)}


def _run(root: Path, env: dict) -> dict:
    subprocess.run([str(root / "source" / "run_autograder")], check=True, env=env, cwd=root, timeout=300)
    return json.loads((root / "results" / "results.json").read_text())


def test_the_autograder_zip_runs_in_the_platforms_layout(tmp_path):
    a = get_assignment(NAME)
    zip_path = write_autograder(NAME, tmp_path / "ch03.zip")
    with zipfile.ZipFile(zip_path) as z:
        names = z.namelist()
        assert z.getinfo("run_autograder").external_attr >> 16 & stat.S_IXUSR
    assert {"setup.sh", "run_autograder"} <= set(names) and any(n.endswith("+autograder-py3-none-any.whl") for n in names)
    root, env = _platform(tmp_path, zip_path)

    # the reference, uploaded inside a folder: 100, hidden checks shown after the due date
    (root / "submission" / "hw3").mkdir()
    (root / "submission" / "hw3" / a.filename).write_text(_reference(a), encoding="utf-8")
    res = _run(root, env)
    bad = [(t["name"], t["output"]) for t in res["tests"] if t["score"] != t["max_score"]]
    assert res["score"] == 100 and not bad, bad
    assert [t["visibility"] == "visible" for t in res["tests"]] == [c.public for c in a.checks]
    assert str(root) not in json.dumps(res)

    # a submission that hands the work to pbanim's own solver finds it removed in the grading edition
    cheat = _reference(a).replace("def solve_multipliers(", "def _own_solve_multipliers(", 1)
    cheat += "\nfrom pbanim.constraints.effect import solve_multipliers  # noqa: E402\n"
    (root / "submission" / "hw3" / a.filename).write_text(cheat, encoding="utf-8")
    res = _run(root, env)
    lost = {t["name"].split(":")[0] for t in res["tests"] if t["score"] == 0}
    assert {"bead_tension", "constraint_acceleration"} <= lost and res["score"] < 100
    assert all("not in the student edition" in t["output"] for t in res["tests"] if t["name"].startswith("bead_tension"))


@pytest.mark.parametrize("files, reason", [((), "no file effect.py"), (("a/effect.py", "b/effect.py"), "2 files named")])
def test_a_submission_without_its_module_gets_a_zero_and_the_reason(files, reason, tmp_path, monkeypatch):
    from pbanim.course.gradescope import ROOT_VARIABLE, run_autograder

    for f in files:
        (tmp_path / "submission" / f).parent.mkdir(parents=True, exist_ok=True)
        (tmp_path / "submission" / f).write_text("x = 1\n")
    (tmp_path / "submission").mkdir(exist_ok=True)
    monkeypatch.setenv(ROOT_VARIABLE, str(tmp_path))
    res = run_autograder(NAME)
    assert res == json.loads((tmp_path / "results" / "results.json").read_text())
    assert res["score"] == 0 and res["tests"] == [] and reason in res["output"]


def test_autograder_refuses_bad_arguments(tmp_path, capsys):
    with pytest.raises(InvalidInput, match="must end in .zip"):
        write_autograder(NAME, tmp_path / "ch03.tar")
    (tmp_path / "x.zip").write_text("")
    with pytest.raises(InvalidInput, match="exists"):
        write_autograder(NAME, tmp_path / "x.zip")
    assert main(["course", "autograder", "ch03_constraint", str(tmp_path / "y.zip")]) == 2
    assert "did you mean 'ch03_constraints'" in capsys.readouterr().err
    assert main(["course", "autograder", NAME]) == 2


NEW = ["ch08_rnea_derivatives", "ch10_contact_sensitivity", "ch12_cloth_spring"]


@pytest.mark.parametrize("name", NEW)
def test_the_new_assignments_grade_in_the_platforms_layout(name, tmp_path, monkeypatch):
    # ORACLES J1, J8 (ch12), L1 (ch08), L2, L6 (ch10): the checks' oracles hold for the reference, whose
    # results.json scores 100 with hidden checks shown after the due date; the starter scores 0
    from pbanim.course.gradescope import ROOT_VARIABLE, run_autograder

    a = get_assignment(name)
    monkeypatch.setenv(ROOT_VARIABLE, str(tmp_path))
    make_assignment(name, tmp_path / "submission" / "starter")
    starter = run_autograder(name)
    assert starter["score"] == 0 and len(starter["tests"]) == len(a.checks)
    assert all(t["output"].startswith("not_implemented") for t in starter["tests"])
    (tmp_path / "submission" / "starter" / a.filename).write_text(_reference(a), encoding="utf-8")
    res = run_autograder(name)
    bad = [(t["name"], t["output"]) for t in res["tests"] if t["score"] != t["max_score"]]
    assert res["score"] == 100 and not bad, bad
    assert [t["visibility"] == "visible" for t in res["tests"]] == [c.public for c in a.checks]
    assert {t["visibility"] for t in res["tests"]} == {"visible", "after_due_date"}


def test_the_cloth_autograder_zip_runs_in_the_platforms_layout(tmp_path):
    # the zip of a new assignment: setup.sh installs its grading edition, run_autograder grades there
    name = "ch12_cloth_spring"
    a = get_assignment(name)
    root, env = _platform(tmp_path, write_autograder(name, tmp_path / "ch12.zip"))
    make_assignment(name, root / "submission")
    res = _run(root, env)
    assert res["score"] == 0 and {t["output"].split(":")[0] for t in res["tests"]} == {"not_implemented"}
    (root / "submission" / a.filename).write_text(_reference(a), encoding="utf-8")
    res = _run(root, env)
    assert res["score"] == 100 and [t["max_score"] for t in res["tests"]] == [c.points for c in a.checks]
