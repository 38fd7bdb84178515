"""The autograder (pbanim.course): the reference scores 100, the starter 0, each typical bug loses exactly
the points of the checks that catch it, and student faults (endless loops, exits, crashes, memory, broken
files, wrong signatures and shapes) each cost their check and become one report line.

The checks themselves compare the student's module with the analytic oracles of the chapters
(ORACLES A1, A3, A5, A7, A8, B1, B2, B5, B7, C1, C3, D1, D3, D4, D8, E2, E3, E6, F1, H1, J1, J8, L1, L2, L6): grading
the reference to 100 % is the test that those oracles hold for pbanim's own code at the checks' tolerances.
"""

from __future__ import annotations

import json
import os
from pathlib import Path

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from pbanim.cli import main
from pbanim.course import assignments, get_assignment, grade, make_assignment
from pbanim.course.markers import solution_source
from pbanim.errors import InvalidInput

READY = assignments(ready_only=True)
MUTANTS = [(n, m.name) for n, a in READY.items() for m in a.mutants]


def _reference(tmp_path: Path, name: str, edit=None) -> Path:
    a = get_assignment(name)
    src = solution_source(Path(a.reference_path()).read_text(encoding="utf-8"), a.package)
    if edit is not None:
        src = edit(src)
    path = tmp_path / a.filename
    path.write_text(src, encoding="utf-8")
    return path


def _swap(old: str, new: str):
    def edit(src: str) -> str:
        assert old in src, old
        return src.replace(old, new, 1)
    return edit


@pytest.mark.parametrize("name", sorted(READY))
def test_reference_scores_100(name, tmp_path):
    # ORACLES A1, A3, A5, A7, A8, B1, B2, B5, B7, C1, C3, D1, D3, D4, D8, E2, E3, E6, F1, H1, J1, J8, L1, L2, L6:
    # every check's oracle holds for pbanim
    rep = grade(name, _reference(tmp_path, name))
    bad = [(r.id, r.status, r.message) for r in rep.results if not r.passed]
    assert rep.score == rep.total == 100 and not bad, bad
    assert not rep.notes


@pytest.mark.parametrize("name", sorted(READY))
def test_starter_scores_zero_and_says_what_is_missing(name, tmp_path):
    make_assignment(name, tmp_path)
    rep = grade(name, tmp_path)
    assert rep.score == 0
    regions = {r for c in get_assignment(name).checks for r in c.regions}
    for r in rep.results:
        assert r.status == "not_implemented", (r.id, r.status, r.message)
        assert r.message.startswith("not implemented yet: ") and any(g in r.message for g in regions), r.message


@pytest.mark.parametrize("name, mutant", MUTANTS)
def test_typical_bug_loses_exactly_the_points_of_its_checks(name, mutant, tmp_path):
    a = get_assignment(name)
    m = next(mm for mm in a.mutants if mm.name == mutant)
    rep = grade(name, _reference(tmp_path, name, m.apply))
    failed = {r.id for r in rep.results if not r.passed}
    assert failed == set(m.catches), f"{mutant}: {[(r.id, r.status, r.message) for r in rep.results]}"
    # a bug fails its checks (CheckFailed), or makes pbanim raise a named error in them (e.g. a sequential
    # impulse loop that no longer converges): either way the check's points are lost
    assert all(r.status in ("failed", "error") for r in rep.results if r.id in failed)
    assert rep.score == 100 - sum(c.points for c in a.checks if c.id in m.catches)


def test_every_required_bug_of_the_issue_is_a_mutant():
    names = {(n, m) for n, m in MUTANTS}
    for required in [("ch03_constraints", "baumgarte_sign"), ("ch03_constraints", "missing_jdot"),
                     ("ch04_reduced", "missing_jdot"), ("ch06_impulses", "restitution_sign"),
                     ("ch01_particles", "explicit_euler"), ("ch02_integrators", "explicit_euler_as_symplectic"),
                     ("ch05_rigid_step", "never_renormalized"), ("ch05_rigid_body", "world_inertia_not_rotated"),
                     # chapters 08-10: the damping sign, stable PD's spring at θ, the missing h K_v, no torque
                     # limits; the gradient's sign, Δx missing, boundary cells; the event-time term dropped
                     ("ch08_pd_control", "damping_sign"), ("ch08_pd_control", "spring_at_theta"),
                     ("ch08_pd_control", "missing_h_kv"), ("ch08_pd_control", "no_torque_limits"),
                     ("ch09_pressure", "gradient_sign"), ("ch09_pressure", "divergence_without_dx"),
                     ("ch09_pressure", "walls_counted_open"), ("ch09_pressure", "obstacle_faces_open"),
                     ("ch10_impact_gradient", "no_event_time"),
                     # the chapter parts of issue 32 point 4: cloth, articulated derivatives, contact design
                     ("ch12_cloth_spring", "geometric_stiffness_sign"), ("ch12_cloth_spring", "missing_projector"),
                     ("ch12_cloth_spring", "transposed_damping_block"),
                     ("ch12_cloth_spring", "damping_on_absolute_velocity"),
                     ("ch08_rnea_derivatives", "motion_force_cross_swapped"),
                     ("ch08_rnea_derivatives", "missing_parent_velocity"), ("ch08_rnea_derivatives", "backward_sign"),
                     ("ch10_contact_sensitivity", "sliding_as_sticking"),
                     ("ch10_contact_sensitivity", "cone_direction_dropped")]:
        assert required in names


# -- student faults: each costs its own check, the grade completes ------------------------------------
def test_endless_loop_costs_only_its_check(tmp_path):
    path = _reference(tmp_path, "ch01_particles", _swap("        Q += self._mg\n", "        while True:\n            pass\n"))
    rep = grade("ch01_particles", path, checks=["gravity_force", "drag_force"], time_limit=1.0)
    res = {r.id: r for r in rep.results}
    assert res["gravity_force"].status == "timeout" and "time limit" in res["gravity_force"].message
    assert res["drag_force"].passed


def test_exit_calls_and_crashes_are_report_lines(tmp_path):
    path = _reference(tmp_path, "ch01_particles", lambda s: s.replace(
        "        dy = np.empty_like(y)\n", "        import sys\n        sys.exit(3)\n", 1).replace(
        "        Q += self._mg\n", "        import os\n        os._exit(7)\n", 1).replace(
        "        _, v = self.system.unpack(y)\n        if self._scalar:",
        "        _, v = self.system.unpack(y)\n        junk = bytearray(2**34)\n        if self._scalar:", 1))
    rep = grade("ch01_particles", path, checks=["derivative", "gravity_force", "drag_force", "symplectic_step"],
                memory_mb=256)
    res = {r.id: r for r in rep.results}
    assert res["derivative"].status == "error" and "sys.exit(3)" in res["derivative"].message
    assert res["gravity_force"].status == "crashed" and "exit code 7" in res["gravity_force"].message
    assert res["drag_force"].status == "crashed" and "memory" in res["drag_force"].message
    assert res["symplectic_step"].passed
    assert rep.score == 30


def test_a_file_that_does_not_import_is_one_line(tmp_path):
    bad = tmp_path / "system.py"
    bad.write_text("import numpy as np\n\ndef f(:\n    pass\n")
    rep = grade("ch01_particles", bad)
    assert rep.score == 0 and rep.notes == ["system.py does not import: SyntaxError at line 3: invalid syntax"]
    assert {r.status for r in rep.results} == {"import_error"}
    bad.write_text("import sys\nsys.exit(2)\n")
    assert grade("ch01_particles", bad).notes == ["system.py calls sys.exit(2) while being imported"]


def test_wrong_signature_and_wrong_shape_are_named(tmp_path):
    path = _reference(tmp_path, "ch01_particles", lambda s: s.replace(
        "    def apply(self, t: float, y: np.ndarray, Q: np.ndarray) -> None:\n        # BEGIN SOLUTION Gravity.apply",
        "    def apply(self, t: float, y: np.ndarray) -> None:\n        # BEGIN SOLUTION Gravity.apply", 1).replace(
        "        return dy\n", "        return dy[:2]\n", 1))
    rep = grade("ch01_particles", path, checks=["gravity_force", "derivative"])
    assert rep.notes == ["wrong signature: Gravity.apply(t, y), expected Gravity.apply(t, y, Q)"]
    res = {r.id: r for r in rep.results}
    assert res["gravity_force"].status == "error" and "(wrong signature?)" in res["gravity_force"].message
    assert res["derivative"].status in ("failed", "error") and "shape" in res["derivative"].message


@pytest.mark.parametrize("name, old, new, check, expected", [
    ("ch09_pressure", "        return div / self.dx\n", "        return list(div / self.dx)[:-1]\n", "divergence",
     "has shape (4, 4), expected (5, 4)"),
    ("ch09_pressure", "        return out\n        # END SOLUTION", "        return out[0]\n        # END SOLUTION",
     "gradient", "must be a list of 2 face arrays, got ndarray"),
    ("ch10_impact_gradient", "    return y1, T1, impact, dtau\n", "    return y1, T1, impact\n", "saltation_matrix",
     "apply_impact must return (y⁺, T⁺, Impact, δτ), got tuple"),
    ("ch10_impact_gradient", "    return T1 - dtau[:, None] * flight_rhs(model, y1)[None]\n", "    return None\n",
     "sphere_pair", "saltation_post(...) is None"),
    ("ch08_pd_control", "        return tau0, k\n", "        return tau0\n", "stable_split",
     "PDServo.stable must return (tau0, k), got ndarray"),
], ids=["ch09-divergence-shape", "ch09-gradient-not-a-list", "ch10-three-returns", "ch10-none", "ch08-one-return"])
def test_wrong_shapes_and_returns_in_later_chapters_are_one_line(name, old, new, check, expected, tmp_path):
    # ORACLES G3: a student's wrong return is a named line of the report, not a traceback
    rep = grade(name, _reference(tmp_path, name, _swap(old, new)), checks=[check], isolation="inline")
    (r,) = rep.results
    assert r.status == "failed" and expected in r.message, r.message


def test_reports_are_deterministic_and_hold_no_paths(tmp_path):
    # ORACLES G2: identical inputs, identical bytes
    path = _reference(tmp_path, "ch06_impulses", get_assignment("ch06_impulses").mutants[0].apply)
    a, b = grade("ch06_impulses", path), grade("ch06_impulses", path)
    a.write(tmp_path / "a.json", tmp_path / "a.md")
    b.write(tmp_path / "b.json", tmp_path / "b.md")
    assert (tmp_path / "a.json").read_bytes() == (tmp_path / "b.json").read_bytes()
    assert (tmp_path / "a.md").read_bytes() == (tmp_path / "b.md").read_bytes()
    text = (tmp_path / "a.json").read_text()
    assert str(tmp_path) not in text and json.loads(text)["score"] == a.score == 20
    assert "| particle_bounce | 0/20 | failed |" in (tmp_path / "a.md").read_text()


def test_inline_isolation_gives_the_same_report(tmp_path):
    path = _reference(tmp_path, "ch07_lcp", get_assignment("ch07_lcp").mutants[0].apply)
    assert grade("ch07_lcp", path, isolation="inline").to_json() == grade("ch07_lcp", path).to_json()


# -- the command line ---------------------------------------------------------------------------------
def test_cli_grade_prints_the_table_and_writes_both_reports(tmp_path, capsys):
    make_assignment("ch05_rigid_step", tmp_path)
    assert main(["grade", "ch05_rigid_step", str(tmp_path)]) == 0
    out = capsys.readouterr().out
    assert "point_force_torque  0/40    not_implemented" in out and "score: 0/100" in out
    assert json.loads((tmp_path / "report.json").read_text())["total"] == 100
    assert (tmp_path / "report.md").read_text().startswith("# ch05_rigid_step: Torques and the quaternion step")


@pytest.mark.parametrize("argv, expected", [
    (["grade", "ch01_particle", "."], "did you mean 'ch01_particles'"),
    (["grade", "ch01_particles", "no/such/file.py"], "not found"),
    (["grade", "ch09_presure", "."], "did you mean 'ch09_pressure'"),
    (["grade", "ch01_particles", ".", "--time-limit", "-1"], "grade: time_limit must be a finite number > 0 and "
                                                            "<= 86400, got -1.0"),
    (["assignment", "make", "ch02_integrator", "x"], "did you mean 'ch02_integrators'"),
])
def test_cli_bad_input_is_one_error_line(argv, expected, capsys):
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert expected in err and err.count("\n") == 1 and "Traceback" not in err


@settings(max_examples=30, deadline=None)
@given(st.text(min_size=0, max_size=30))
def test_unknown_assignment_names_are_refused_by_name(name):
    # ORACLES G3: a named error that says which names exist
    if name in READY:
        assert get_assignment(name).name == name
        return
    with pytest.raises(InvalidInput, match="assignment"):
        get_assignment(name)


@settings(max_examples=20, deadline=None)
@given(st.sampled_from(["fork", "inline", "spawn", "", "FORK"]), st.floats(allow_nan=True, allow_infinity=True))
def test_grade_validates_its_options(isolation, limit):
    ok = isolation in ("fork", "inline") and limit > 0 and limit < float("inf")
    if ok:
        return  # grading itself is covered above
    with pytest.raises(InvalidInput):
        grade("ch01_particles", os.devnull, isolation=isolation, time_limit=limit)
