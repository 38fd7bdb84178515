"""The student edition (pbanim.course.edition): a wheel of pbanim without the assignments' solutions.

Installed with ``pip install --no-deps --target DIR`` (no network, seconds) and run in a child process with
DIR first on ``PYTHONPATH`` (numpy, scipy … come from this environment): no solution line is in any installed
file, the hidden checks and the mutants are gone, what needs a removed region raises a NotImplementedError
naming its assignment, the rest works, and the starter's public checks run there — the starter scores 0,
the reference solution passes every public check but those that need another assignment's removed solution
(ORACLES G2: the grader's reports; the checks' own oracles are those of tests/test_course_grader.py).
"""

from __future__ import annotations

import ast
import json
import os
import subprocess
import sys
import zipfile
from pathlib import Path

import numpy as np
import pytest

from pbanim.cli import main
from pbanim.course import assignments, get_assignment, grade, make_assignment
from pbanim.course.edition import build_edition, edition_info, edition_source, strip_checks
from pbanim.course.markers import find_regions, solution_source
from pbanim.errors import InvalidInput

READY = assignments(ready_only=True)
PACKAGE = Path(__import__("pbanim").__file__).resolve().parent


def _solution_lines(a) -> set[str]:
    """The lines of the assignment's solution regions (stripped, ≥ 20 characters, not comments) that occur
    nowhere else in pbanim outside pbanim/course and the regions themselves: the solution's own text."""
    src = Path(a.reference_path()).read_text(encoding="utf-8")
    lines = src.splitlines()
    inside = set()
    for r in find_regions(src, a.filename):
        inside |= {ln.strip() for ln in lines[r.begin:r.end - 1]}
    inside = {ln for ln in inside if len(ln) >= 20 and not ln.startswith("#")}
    outside = set()
    for p in PACKAGE.rglob("*.py"):
        if "course" in p.relative_to(PACKAGE).parts:
            continue
        text = p.read_text(encoding="utf-8").splitlines()
        if p.resolve() == Path(a.reference_path()).resolve():
            keep = set(range(len(text))) - {k for r in find_regions(src) for k in range(r.begin - 1, r.end)}
            text = [text[k] for k in sorted(keep)]
        outside |= {ln.strip() for ln in text}
    return inside - outside


@pytest.fixture(scope="module")
def edition(tmp_path_factory):
    """The edition of every assignment, installed into a folder; starters and reference solutions beside."""
    root = tmp_path_factory.mktemp("edition")
    wheel = build_edition(root / "dist")
    site = root / "site"
    subprocess.run([sys.executable, "-m", "pip", "install", "-q", "--no-deps", "--no-index", "--target", str(site),
                    str(wheel)], check=True, env={**os.environ, "PIP_DISABLE_PIP_VERSION_CHECK": "1"})
    for name, a in READY.items():
        make_assignment(name, root / "starter" / name)
        ref = solution_source(Path(a.reference_path()).read_text(encoding="utf-8"), a.package)
        (root / "solution" / name).mkdir(parents=True)
        (root / "solution" / name / a.filename).write_text(ref, encoding="utf-8")
    return {"root": root, "wheel": wheel, "site": site}


def _run(edition, code: str) -> dict:
    """Run ``code`` (which prints one JSON line last) with the edition first on the path, from a scratch folder."""
    env = {**os.environ, "PYTHONPATH": str(edition["site"])}
    out = subprocess.run([sys.executable, "-c", code], cwd=edition["root"], env=env, capture_output=True,
                         text=True, timeout=120)
    assert out.returncode == 0, out.stderr[-2000:]
    return json.loads(out.stdout.strip().splitlines()[-1])


def test_the_wheel_holds_no_solution_line_and_no_hidden_check(edition):
    with zipfile.ZipFile(edition["wheel"]) as z:
        names = z.namelist()
        texts = {n: z.read(n).decode("utf-8", "replace") for n in names if n.endswith((".py", ".txt", ".md"))}
    installed = {str(p.relative_to(edition["site"])): p.read_text(encoding="utf-8", errors="replace")
                 for p in edition["site"].rglob("*") if p.is_file() and p.suffix in (".py", ".txt", ".md")}
    assert "pbanim/course/_edition.py" in names and "chapters/ch03_constraints.py" in names
    assert set(texts) <= set(installed)
    everything = "\n".join(ln.strip() for t in installed.values() for ln in t.splitlines())
    everything_lines = set(everything.splitlines())
    for name, a in READY.items():
        own = _solution_lines(a)
        assert own, name                                      # the test can fail: each solution has own lines
        assert not own & everything_lines, (name, sorted(own & everything_lines)[:3])
        for c in a.checks:
            module = installed[c.func.__module__.replace(".", "/") + ".py"]
            assert (f"def {c.func.__name__}(" in module) == c.public, (name, c.id)
    assert "Mutant(" not in installed["pbanim/course/checks_constraints.py"].split("import", 1)[1]


def test_the_edition_runs_removes_what_it_says_and_keeps_the_rest(edition):
    got = _run(edition, """
import json, numpy as np, pbanim
from pbanim.course import assignments
from pbanim.course.edition import edition_info
from pbanim.constraints.effect import solve_multipliers
from pbanim.constraints.kinds import OnCircle
from pbanim.particles import ParticleSystem
from pbanim.lcp import solve_lcp
from pbanim.ode import solve
from pbanim.models.ode import kepler
out = {"file": pbanim.__file__, "info": edition_info()}
ps = ParticleSystem([[1.0, 0.0]], [[0.0, 1.0]], masses=1.0)
try:
    solve_multipliers([OnCircle([0], [0.0, 0.0], 1.0)], ps, ps.state(), [[0.0, -9.81]])
except NotImplementedError as e:
    out["removed"] = str(e)
kp = kepler(0.3)
r = solve(kp.rhs, (0, kp.period), kp.y0, method="dopri5", rtol=1e-10, atol=1e-12)
out["kepler"] = float(np.max(np.abs(r.y[:, -1] - kp.y0)))
f = solve_lcp(np.array([[2.0]]), np.array([-1.0]), "lemke").f
out["lcp"] = float(f[0])
from pbanim.cloth import Cloth, Sheet
from pbanim.articulated import rnea, rnea_derivatives
from pbanim.models.articulated import pendulum_chain
for key, call in (("cloth", lambda: Cloth(Sheet(3), stretch=10.0).jacobians(Cloth(Sheet(3)).state())),
                  ("rnea_d", lambda: rnea_derivatives(pendulum_chain(2), np.zeros(2), np.ones(2), np.zeros(2)))):
    try:
        call()
    except NotImplementedError as e:
        out[key] = str(e)
bw = Cloth(Sheet(3), model="bw", stretch=10.0, bend=0.0)
out["bw"] = float(np.abs(bw.forces(bw.state()).sum(axis=0) - bw.sheet.masses.sum() * bw.gravity).max())
out["rnea"] = float(rnea(pendulum_chain(1), np.array([0.3]), np.zeros(1), np.zeros(1))[0])
out["checks"] = {n: [c.public for c in a.checks] for n, a in assignments(ready_only=True).items()}
out["mutants"] = sum(len(a.mutants) for a in assignments(ready_only=True).values())
print(json.dumps(out))
""")
    assert got["file"].startswith(str(edition["site"]))
    assert got["info"]["assignments"] == sorted(READY) and got["info"]["hidden_checks"] is False
    assert "solve_multipliers is not in the student edition" in got["removed"]
    assert "assignment ch03_constraints" in got["removed"]
    assert got["kepler"] < 1e-7                               # ORACLES A4: a closed orbit returns after T
    assert got["lcp"] == pytest.approx(0.5, abs=1e-12)       # ORACLES D8: f = max(0, −b/a)
    # the new chapter parts: a spring cloth's Jacobians and RNEA's derivatives name their assignments; the
    # Baraff–Witkin cloth (at rest: gravity alone, ORACLES J2) and RNEA itself (m g l sin q, L1) still run
    assert "SpringCondition.pair_terms is not in the student edition" in got["cloth"]
    assert "assignment ch12_cloth_spring" in got["cloth"] and "assignment ch08_rnea_derivatives" in got["rnea_d"]
    assert got["bw"] < 1e-12 and got["rnea"] == pytest.approx(9.81 * np.sin(0.3), rel=1e-12)
    assert all(all(flags) and flags for flags in got["checks"].values()) and got["mutants"] == 0
    assert set(got["checks"]) == set(READY)


def test_public_checks_run_in_the_edition(edition):
    root = edition["root"]
    got = _run(edition, f"""
import json
from pbanim.course import assignments, grade
out = {{}}
for n in assignments(ready_only=True):
    s, r = grade(n, {str(root / 'starter')!r} + "/" + n), grade(n, {str(root / 'solution')!r} + "/" + n)
    out[n] = {{"starter": [x.status for x in s.results], "starter_score": s.score,
              "reference": [(x.id, x.status, x.message) for x in r.results], "total": r.total}}
print(json.dumps(out))
""")
    for name, g in got.items():
        a = get_assignment(name)
        assert g["total"] == sum(c.points for c in a.checks if c.public) < 100
        assert g["starter_score"] == 0 and set(g["starter"]) == {"not_implemented"}, name
        for cid, status, message in g["reference"]:
            if status != "passed":
                # only another assignment's removed solution may stop the reference, and the message names it
                assert status == "not_implemented" and "assignment ch" in message, (name, cid, message)
                assert f"assignment {name} " not in message, (name, cid, message)
    assert sum(s == "passed" for g in got.values() for _, s, _ in g["reference"]) >= 25


def test_the_full_reference_is_untouched_by_a_build(edition):
    # the instructor's grader keeps scoring the reference 100 and the starter 0 after a build: that is
    # tests/test_course_grader.py::test_reference_scores_100 and ::test_starter_scores_zero_and_says_what_is_missing,
    # which read these same files
    assert edition_info() == {} and not (PACKAGE / "course" / "_edition.py").exists()
    for a in READY.values():
        text = Path(a.reference_path()).read_text(encoding="utf-8")
        assert "is not in the student edition" not in text, a.name
        lines = text.splitlines()
        for r in find_regions(text, a.filename):       # every region still holds its solution, not the one raise
            body = [ln for ln in lines[r.begin:r.end - 1] if ln.strip() and not ln.strip().startswith("#")]
            assert body and not (len(body) == 1 and "raise NotImplementedError" in body[0]), (a.name, r.name)
        assert any(not c.public for c in a.checks) and a.total_points == 100


def test_edition_source_and_strip_checks_on_their_own():
    src = ("def f(x):\n    '''Doc.'''\n    y = 2 * x\n    # BEGIN SOLUTION f\n    y = y + 1\n    return y\n"
           "    # END SOLUTION\n")
    out = edition_source(src, "hw9")
    assert "y = y + 1" not in out and "y = 2 * x" in out and "assignment hw9" in out
    assert [r.name for r in find_regions(out)] == ["f"]
    ns: dict = {}
    exec(compile(out, "<edition>", "exec"), ns)
    with pytest.raises(NotImplementedError, match="hw9"):
        ns["f"](1)
    with pytest.raises(InvalidInput, match="no solution markers"):
        edition_source("x = 1\n", "hw9")
    checks = ("C = []\n\n\ndef _only_hidden():\n    return 1\n\n\ndef _shared():\n    return 2\n\n\n"
              "@check(C, 'a')\ndef public(m):\n    return _shared()\n\n\n@check(C, 'b', public=False)\n"
              "def hidden(m):\n    return _only_hidden() + _shared()\n\n\nMUTANTS = (\n    Mutant('x'),\n)\n")
    out = strip_checks(checks, ["hidden"], ("MUTANTS",))
    tree = ast.parse(out)
    assert {n.name for n in tree.body if isinstance(n, ast.FunctionDef)} == {"_shared", "public"}
    assert "MUTANTS = ()" in out and "Mutant(" not in out
    with pytest.raises(InvalidInput, match="no top-level functions"):
        strip_checks(checks, ["nope"])


def test_cli_student_edition_of_chosen_assignments(tmp_path, capsys):
    assert main(["course", "student-edition", str(tmp_path), "--assignments", "ch09_pressure"]) == 0
    wheel = next(tmp_path.glob("pbanim-*+student-py3-none-any.whl"))
    assert wheel.name in capsys.readouterr().out
    with zipfile.ZipFile(wheel) as z:
        changed = [n for n in z.namelist() if n.endswith(".py") and (PACKAGE.parent / n).is_file()
                   and z.read(n) != (PACKAGE.parent / n).read_bytes()]
        record = z.read(next(n for n in z.namelist() if n.endswith("RECORD"))).decode()
    assert sorted(changed) == ["pbanim/course/checks_fluids.py", "pbanim/fluids/grid.py"]
    assert record.count("sha256=") == len(record.splitlines()) - 1
    assert main(["course", "student-edition", str(tmp_path), "--assignments", "ch09_presure"]) == 2
    assert "did you mean 'ch09_pressure'" in capsys.readouterr().err
    assert main(["course", "student-edition"]) == 2
