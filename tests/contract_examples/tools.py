"""Valid calls for the tool layers: pbanim.bench (its package functions), pbanim.compare, pbanim.course and
pbanim.plotting. Every path handed out is a fresh folder under one temporary folder of this process (removed
at exit): the fuzz writes nowhere else."""

import atexit
import shutil
import tempfile
from pathlib import Path

import numpy as np
from matplotlib.figure import Figure

from pbanim.bench import Goal, Report, Table
from pbanim.compare import SCENES, Body, Comparison, Joint, SceneSpec, Trace, run_compare
from pbanim.course import Assignment, CheckResult, GradeReport, Mutant, get_assignment
from pbanim.course.markers import solution_source
from pbanim.plotting import FigureContext, FigureSpec

_ROOT: list = []


def _folder() -> Path:
    """A new empty folder under this process's temporary folder."""
    if not _ROOT:
        _ROOT.append(tempfile.mkdtemp(prefix="pbanim-fuzz-"))
        atexit.register(shutil.rmtree, _ROOT[0], True)
    return Path(tempfile.mkdtemp(dir=_ROOT[0]))


# -- bench -----------------------------------------------------------------------------------------------
def _report():
    return Report("fuzz", tables=[Table("t", ["a", "b"], [[1, 2.5]])], goals=[Goal("g", 1.0, 2.0)], notes=["n"])


# -- compare ---------------------------------------------------------------------------------------------
def _body():
    return Body("ball", "sphere", (0.1,), 1.0, (4e-3,) * 3, (0.0, 0.0, 1.0))


def _spec():
    return SceneSpec("s", "a ball", (_body(),), (0.0, 0.0, -9.81), 1.0, (0.1,), (0.1,))


def _trace():
    t = np.linspace(0.0, 0.2, 3)
    x = np.zeros((3, 1, 3))
    x[:, 0, 2] = 1.0 - 4.905 * t ** 2
    v = np.zeros((3, 1, 3))
    v[:, 0, 2] = -9.81 * t
    q = np.zeros((3, 1, 4))
    q[..., 0] = 1.0
    return Trace(t, x, q, v, np.zeros((3, 1, 3)), 1e-3, 2)


_CMP: list = []


def _comparison():
    """One small run (free fall in pbanim, two steps), made once: the methods the fuzz calls only read it."""
    if not _CMP:
        _CMP.append(run_compare(["free_fall"], ["pbanim"], quick=True, steps=[0.05, 0.025]))
    return _CMP[0]


# -- course ----------------------------------------------------------------------------------------------
_STUDENT: list = []


def _student_file() -> Path:
    """The reference solution of ch01_particles as a student's file (imports absolute), written once."""
    if not _STUDENT:
        a = get_assignment("ch01_particles")
        path = _folder() / a.filename
        path.write_text(solution_source(Path(a.reference_path()).read_text(encoding="utf-8"), a.package),
                        encoding="utf-8")
        _STUDENT.append(path)
    return _STUDENT[0]


def _grade_report():
    return GradeReport("ch01_particles", "t", "system.py",
                       [CheckResult("gravity_force", 15, 15, "passed", "m g", "A8", "ok")])


# -- plotting --------------------------------------------------------------------------------------------
def _tiny(ctx):
    fig = Figure(figsize=(0.5, 0.5))
    ax = fig.add_subplot()
    ax.plot([0.0, 1.0], [0.0, 1.0])
    ax.set_xlabel("t (s)")
    ax.set_ylabel("x (m)")
    ctx.save(fig)
    return {"n": 1.0}


def _figure_spec():
    return FigureSpec("zz", "fuzz", "A tiny figure", _tiny)


INSTANCES = {
    Report: _report,
    Body: _body,
    Joint: lambda: Joint("hinge", 0, -1, (0.0, 0.5, 0.0), (0.0, 0.0, 0.0)),
    SceneSpec: _spec,
    Trace: _trace,
    Comparison: _comparison,
    GradeReport: _grade_report,
    Assignment: lambda: get_assignment("ch01_particles"),
    Mutant: lambda: Mutant("m", "a typical bug", (("x", "y"),), ("gravity_force",)),
    FigureSpec: _figure_spec,
    FigureContext: lambda: FigureContext(_figure_spec(), _folder()),
    Figure: lambda: Figure(figsize=(1.0, 1.0)),
}

_PATH = {"path": lambda: _folder() / "report.json"}
CALLS = {
    "pbanim.bench.median_time": lambda: {"fn": lambda: None, "repeats": 1},
    "pbanim.bench.write_json": lambda: {"path": _folder() / "report.json"},
    "pbanim.compare.harness.Engine.__init__": lambda: {"run": lambda *a, **k: None},
    "pbanim.compare.harness.run_compare": lambda: {"scenes": ["free_fall"], "engines": ["pbanim"], "quick": True,
                                                   "steps": [0.05], "progress": lambda line: None},
    "pbanim.compare.harness.check_names": lambda: {"kind": "scene", "names": ["free_fall"], "known": SCENES},
    "pbanim.compare.scenes.Scene.__init__": lambda: {"score": lambda tr: {"error": 0.0},
                                                     "observable": lambda tr: tr.x[:, 0, 2],
                                                     "exact": lambda t: np.zeros_like(t)},
    "pbanim.compare.spec.Body.__init__": lambda: {"size": [0.1], "inertia": [4e-3] * 3, "x": [0.0, 0.0, 1.0]},
    "pbanim.compare.spec.Joint.__init__": lambda: {"kind": "hinge", "a": 0, "b": -1, "anchor_a": [0.0, 0.5, 0.0],
                                                   "anchor_b": [0.0, 0.0, 0.0]},
    "pbanim.compare.spec.SceneSpec.__init__": lambda: {"bodies": [_body()], "gravity": [0.0, 0.0, -9.81],
                                                       "duration": 1.0, "steps": [0.1], "quick_steps": [0.1],
                                                       "params": {}},     # the signature's default is a factory
    "pbanim.compare.report.write": lambda: {"markdown_path": _folder() / "c.md", "json_path": _folder() / "c.json"},
    "pbanim.course.grader.grade": lambda: {"name": "ch01_particles", "path": _student_file(), "isolation": "inline",
                                           "checks": ["gravity_force"]},
    "pbanim.course.grader.run_check": lambda: {"name": "ch01_particles", "check_id": "gravity_force",
                                               "path": _student_file(), "isolation": "inline"},
    "pbanim.course.grader.GradeReport.write": lambda: {"json_path": _folder() / "r.json",
                                                       "markdown_path": _folder() / "r.md"},
    "pbanim.course.registry.Assignment.get_check": lambda: {"check_id": "gravity_force"},
    "pbanim.course.registry.Check.__init__": lambda: {"func": lambda mod: "ok"},
    "pbanim.course.make_assignment": lambda: {"name": "ch01_particles", "out_dir": _folder()},
    "pbanim.plotting.FigureSpec.__init__": lambda: {"func": _tiny},
    "pbanim.plotting.FigureContext.save": lambda: {"fig": Figure(figsize=(1.0, 1.0))},
    "pbanim.plotting.FigureContext.save_gif": lambda: {"fig": Figure(figsize=(1.0, 1.0)), "update": lambda i: None,
                                                       "frames": 2},
    "pbanim.plotting.run_figure": lambda: {"spec": _figure_spec(), "out_dir": _folder(), "quick": True, "dpi": 50.0,
                                           "issues": []},
    # one tiny figure in this process (jobs=1; one group never starts a worker), into a temporary folder
    "pbanim.plotting.run_figures": lambda: {"specs": {"zz_fuzz": _figure_spec()}, "out_dir": _folder(), "quick": True,
                                            "dpi": 50.0, "jobs": 1},
    "pbanim.plotting.write_index": lambda: {"specs": {"zz_fuzz": _figure_spec()}, "out_dir": _folder(), "files": {},
                                            "checked_by": None},
}

SKIP_EDGES = {
    "pbanim.compare.harness.run_compare": "scenes = None and engines = None (their edge) mean every scene in every "
                                          "engine: the whole comparison, minutes",
}

_RECORD = "a record pbanim builds and a user only reads"
EXEMPT = {
    "pbanim.bench.Goal.__init__": f"{_RECORD}: a benchmark family states its measured figure and target",
    "pbanim.bench.Table.__init__": f"{_RECORD}: a benchmark family's table of measured rows",
    "pbanim.bench.Report.__init__": f"{_RECORD}: what a benchmark family's run returns",
    "pbanim.bench.run_bench": "a valid call is a whole benchmark run (seconds to minutes even with quick=True), "
                              "beyond the generated fuzz's time bound; its body applies the specs a contract would "
                              "(name: Choice(available), quick: Flag) for every caller, the command line included "
                              "(tests/test_course.py::test_run_bench_refuses_by_name)",
    "pbanim.compare.harness.Row.__init__": f"{_RECORD}: one (scene, engine, h) row of run_compare",
    "pbanim.compare.harness.Comparison.__init__": f"{_RECORD}: what run_compare returns",
    "pbanim.compare.spec.Trace.__init__": f"{_RECORD}: the states an engine translation recorded; it holds NaN "
                                          "states by design when an engine diverges (first_nonfinite reports them)",
    "pbanim.course.grader.GradeReport.__init__": f"{_RECORD}: what grade returns",
    "pbanim.course.grader.CheckResult.__init__": f"{_RECORD}: one check's outcome in a GradeReport",
    "pbanim.plotting.FigureContext.__init__": "built by run_figure (whose contract checks the options) and handed to "
                                              "the figure function; its methods carry contracts",
}
