"""Course tooling: solution markers and starters, the assignment registry, chapters as notebooks, figure
formats and the slides style, and the listings of the command line."""

from __future__ import annotations

import ast
import json
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from pbanim.cli import bench_lines, main
from pbanim.course import assignments, get_assignment, make_assignment
from pbanim.course.markers import MarkerError, absolute_imports, find_regions, starter_source
from pbanim.course.notebook import Cell, is_percent_script, notebook_json, percent_cells, write_notebook
from pbanim.course.registry import Assignment, Check, Mutant, register
from pbanim.errors import InvalidInput

REPO = Path(__file__).resolve().parent.parent
READY = assignments(ready_only=True)
NOTEBOOK_CHAPTERS = ["ch01_particles", "ch03_constraints", "ch04_reduced", "ch05_rigid", "ch06_collisions",
                     "ch07_contact", "ch08_articulated", "ch08_characters", "ch08_qp_control", "ch09_fluids",
                     "ch11_engines"]


def _functions(tree) -> dict:
    out = {}

    def walk(node, prefix=""):
        for ch in ast.iter_child_nodes(node):
            if isinstance(ch, (ast.FunctionDef, ast.ClassDef)):
                if isinstance(ch, ast.FunctionDef):
                    out[prefix + ch.name] = ch
                walk(ch, prefix + ch.name + ".")
    walk(tree)
    return out


# -- markers and starters -----------------------------------------------------------------------------
@pytest.mark.parametrize("name", sorted(READY))
def test_starter_replaces_every_region_and_keeps_docstrings_and_signatures(name):
    a = get_assignment(name)
    ref = Path(a.reference_path()).read_text(encoding="utf-8")
    regions = find_regions(ref, a.filename)
    starter = starter_source(ref, a.package, a.filename)
    assert starter.count("raise NotImplementedError(") == len(regions) >= 1
    assert "# BEGIN SOLUTION" not in starter and "from ." not in starter
    fr, fs = _functions(ast.parse(ref)), _functions(ast.parse(starter))
    assert set(fr) == set(fs)
    for q, node in fr.items():
        assert ast.get_docstring(node) == ast.get_docstring(fs[q]), q
        assert ast.dump(node.args) == ast.dump(fs[q].args), q
    # every region a check exercises exists, and every region is exercised by some check
    exercised = {r for c in a.checks for r in c.regions}
    assert exercised == {r.name for r in regions}


@pytest.mark.parametrize("source, message", [
    ("def f():\n    # BEGIN SOLUTION f\n    # BEGIN SOLUTION g\n    pass\n    # END SOLUTION\n", "do not nest"),
    ("def f():\n    pass\n    # END SOLUTION\n", "without a BEGIN"),
    ("def f():\n    # BEGIN SOLUTION f\n    pass\n", "has no END"),
    ("def f():\n    # BEGIN SOLUTION\n    pass\n    # END SOLUTION\n", "needs a name"),
    ("def f():\n    # BEGIN SOLUTION f\n    pass\n# END SOLUTION\n", "indented"),
    ("def f():\n    # BEGIN SOLUTION f\n    pass\n    # END SOLUTION\n"
     "def g():\n    # BEGIN SOLUTION f\n    pass\n    # END SOLUTION\n", "unique"),
])
def test_malformed_markers_are_named_errors(source, message):
    # ORACLES G3: a named error that says what is wrong, and where
    with pytest.raises(MarkerError, match=message):
        starter_source(source, "pkg")


def test_a_file_without_markers_cannot_become_an_assignment():
    with pytest.raises(MarkerError, match="no '# BEGIN SOLUTION name' markers"):
        starter_source("def f():\n    return 1\n", "pkg")


def test_relative_imports_become_absolute():
    src = "from ..errors import E\nfrom . import kinds\ndef f():\n    from .springs import (a,\n        b)\n"
    assert absolute_imports(src, "pbanim.particles") == (
        "from pbanim.errors import E\nfrom pbanim.particles import kinds\ndef f():\n"
        "    from pbanim.particles.springs import (a,\n        b)\n")


@settings(max_examples=40, deadline=None)
@given(st.lists(st.sampled_from(["begin", "end", "code"]), min_size=1, max_size=12))
def test_marker_structures_either_parse_balanced_or_raise(kinds):
    lines, n = ["def f(x):", "    '''doc'''"], 0
    for k in kinds:
        if k == "begin":
            n += 1
            lines.append(f"    # BEGIN SOLUTION r{n}")
        elif k == "end":
            lines.append("    # END SOLUTION")
        else:
            lines.append("    x = x + 1")
    lines.append("    return x")
    src = "\n".join(lines) + "\n"
    try:
        regions = find_regions(src)
    except MarkerError:
        return
    assert all(r.begin < r.end for r in regions)
    assert all(a.end < b.begin for a, b in zip(regions, regions[1:]))
    if regions:
        out = starter_source(src, "pkg")
        ast.parse(out)
        assert out.count("raise NotImplementedError(") == len(regions)


def test_make_writes_module_tests_readme_and_refuses_to_overwrite(tmp_path):
    files = make_assignment("ch03_constraints", tmp_path)
    assert sorted(p.name for p in files) == ["README.md", "effect.py", "test_ch03_constraints.py"]
    readme = (tmp_path / "README.md").read_text()
    a = get_assignment("ch03_constraints")
    assert all(f"| {c.id} | {c.points} |" in readme for c in a.checks)
    assert "`solve_multipliers`" in readme and "`Constraints._solve`" in readme
    tests = (tmp_path / "test_ch03_constraints.py").read_text()
    public = [c.id for c in a.checks if c.public]
    assert f"PUBLIC_CHECKS = {public!r}" in tests and "bead_energy" not in tests
    ast.parse(tests)
    with pytest.raises(InvalidInput, match="already has"):
        make_assignment("ch03_constraints", tmp_path)
    make_assignment("ch03_constraints", tmp_path, overwrite=True)


def test_every_chapter_has_a_ready_assignment():
    # the issue: at least one assignment per chapter, 01 to 10
    chapters = {a.chapter for a in READY.values()}
    assert chapters >= {f"ch{k:02d}" for k in range(1, 11)}, sorted(chapters)
    assert all(a.status == "ready" for a in assignments().values())


def test_pending_assignments_are_listed_and_refused_with_their_reason(capsys, monkeypatch):
    from pbanim.course.registry import ASSIGNMENTS

    monkeypatch.setitem(ASSIGNMENTS, "ch99_future", Assignment(
        "ch99_future", "ch99", "A chapter not written yet", "pbanim.errors", "", status="pending",
        pending_reason="chapter 99 is being written"))
    with pytest.raises(InvalidInput, match="pending: chapter 99 is being written"):
        get_assignment("ch99_future")
    with pytest.raises(InvalidInput, match="pending"):
        make_assignment("ch99_future", "unused")
    assert main(["assignment", "list"]) == 0
    out = capsys.readouterr().out.splitlines()
    assert len(out) == len(assignments()) and [line for line in out if "pending:" in line] == [
        "ch99_future            A chapter not written yet — pending: chapter 99 is being written"]


def test_register_refuses_inconsistent_assignments():
    chk = Check("a", 60, "x", "A1", lambda m: "")
    with pytest.raises(InvalidInput, match="add up to 100"):
        register(Assignment("bad", "ch99", "t", "pbanim.errors", "", (chk,)))
    with pytest.raises(InvalidInput, match="must catch known checks"):
        register(Assignment("bad", "ch99", "t", "pbanim.errors", "", (Check("a", 100, "x", "A1", chk.func),),
                            (Mutant("m", "d", (("x", "y"),), ("zzz",)),)))
    with pytest.raises(InvalidInput, match="not found in the module"):
        Mutant("m", "d", (("not there", "y"),), ("a",)).apply("source")


# -- the closed forms the checks of chapters 08-10 grade against, across their parameters ------------------
@settings(max_examples=25, deadline=None)
@given(st.floats(4.0, 1e4), st.floats(0.0, 3.0), st.floats(0.2, 5.0))
def test_pd_step_limits_of_the_checks_match_the_measured_ones(kp, zeta, m):
    # ORACLES F1: the grader's closed-form step limits equal pbanim's measured ones over the gain space
    from pbanim.control.pd import largest_stable_step
    from pbanim.course.checks_control import _closed_form_step

    kv = 2 * zeta * np.sqrt(kp * m)
    for servo in ("explicit", "stable"):
        got = largest_stable_step(kp, kv, m=m, servo=servo, h_max=100.0)
        assert got == pytest.approx(_closed_form_step(servo, kp, kv, m), rel=1e-9), servo   # measured ≤ 2e-11


@settings(max_examples=25, deadline=None)
@given(st.integers(0, 7), st.integers(1, 7), st.floats(0.1, 1.0), st.integers(1, 12), st.floats(0.01, 2.0))
def test_jacobi_mode_factor_of_the_checks_matches_the_reference(kx, ky, omega, sweeps, dx):
    # ORACLES E2: x_k = (1 − f^k) r/λ for one Fourier mode, f = 1 − ω(1 − (cos θx + cos θy)/2)
    from pbanim.fluids import Grid
    from pbanim.fluids.poisson import solve_cells

    n = 16
    tx, ty = 2 * np.pi * kx / n, 2 * np.pi * ky / n
    i, j = np.indices((n, n))
    r = np.cos(tx * i + ty * j)
    lam = (4 - 2 * np.cos(tx) - 2 * np.cos(ty)) / dx ** 2
    f = 1 - omega * (1 - (np.cos(tx) + np.cos(ty)) / 2)
    x, _ = solve_cells(Grid((n, n), dx, "periodic"), r, 0.0, 1.0, "jacobi", iterations=sweeps, omega=omega)
    want = (1 - f ** sweeps) * r / lam
    assert np.abs(x - want).max() <= 1e-10 * np.abs(want).max()                     # E2 tol.; measured ≤ 1.4e-14


@settings(max_examples=25, deadline=None)
@given(st.floats(0.05, 1.0), st.floats(0.1, 10.0), st.floats(0.05, 5.0))
def test_saltation_of_the_checks_holds_for_the_reference_everywhere(eps, m, h0):
    # ORACLES H1: S = [[−ε, 0], [−(1+ε)g/v⁻, −ε]] on (z, P_z/m) at every restitution, mass and height
    import pbanim.design.impact as reference
    from pbanim.course.checks_design import G, _ball_jump

    Phi, t1 = _ball_jump(reference, eps, m, h0)
    S = Phi[np.ix_([2, 9], [2, 9])] * [[1.0, m], [1.0 / m, 1.0]]                   # (z, P) → (z, v)
    want = [[-eps, 0.0], [(1 + eps) / t1, -eps]]                                   # −(1+ε)g/v⁻ = (1+ε)/t₁
    assert np.abs(S - want).max() <= 1e-12 * max(1.0, (1 + eps) / t1)              # measured ≤ 4e-16
    assert Phi[9, 13] == pytest.approx(m * G * t1, rel=1e-13)                      # dP⁺/dε = −m v⁻


# -- notebooks --------------------------------------------------------------------------------------
def test_percent_cells_and_notebook_json():
    text = "import x\n\n# %% [markdown]\n# # Title\n#\n# text\n\n# %%\ny = 1\n# %%\n\n"
    cells = percent_cells(text)
    assert cells == [Cell("code", "import x"), Cell("markdown", "# Title\n\ntext"), Cell("code", "y = 1")]
    nb = notebook_json(cells)
    assert nb["nbformat"] == 4 and [c["id"] for c in nb["cells"]] == ["cell-0", "cell-1", "cell-2"]
    assert nb["cells"][1]["source"] == ["# Title\n", "\n", "text"] and nb["cells"][2]["outputs"] == []
    with pytest.raises(InvalidInput, match="markdown cell line"):
        percent_cells("# %% [markdown]\nnot a comment\n")


@settings(max_examples=30, deadline=None)
@given(st.lists(st.tuples(st.sampled_from(["code", "markdown"]),
                          st.lists(st.text("abc xyz=1+", min_size=1, max_size=12).map(str.strip).filter(bool),
                                   min_size=1, max_size=4)), min_size=1, max_size=5))
def test_percent_format_round_trip(cells):
    text = ""
    for kind, lines in cells:
        text += "# %% [markdown]\n" + "".join(f"# {ln}\n" for ln in lines) if kind == "markdown" else \
            "# %%\n" + "".join(f"{ln}\n" for ln in lines)
    assert percent_cells(text) == [Cell(k, "\n".join(lines)) for k, lines in cells]


@pytest.mark.parametrize("chapter", NOTEBOOK_CHAPTERS)
def test_chapter_is_a_percent_script_and_becomes_a_valid_notebook(chapter, tmp_path):
    src = REPO / "chapters" / f"{chapter}.py"
    text = src.read_text(encoding="utf-8")
    assert is_percent_script(text)
    n_figures = text.count("\n@figure(")
    cells = percent_cells(text)
    assert sum(c.kind == "markdown" for c in cells) >= n_figures + 1
    path = write_notebook(src, tmp_path)
    nb = json.loads(path.read_text())
    from pbanim.course.widgets import DEMOS, get_demo

    get_demo("ch02_step_size")                                  # loads the demos
    n_live = sum(d.chapter == chapter for d in DEMOS.values())
    assert nb["nbformat"] == 4 and len(nb["cells"]) == len(cells) + 2 * n_live
    nbformat = pytest.importorskip("nbformat")
    nbformat.validate(nbformat.read(str(path), as_version=4))


def test_cli_notebook_and_its_errors(tmp_path, capsys):
    assert main(["notebook", "ch04", str(tmp_path)]) == 0
    assert (tmp_path / "ch04_reduced.ipynb").is_file()
    assert main(["notebook", "ch4", str(tmp_path)]) == 2
    assert "did you mean 'ch04'" in capsys.readouterr().err


# -- figures: formats, slides style, captions ----------------------------------------------------------
def _tiny_spec(record: dict):
    from pbanim.plotting import FigureSpec

    def tiny(ctx):
        fig, ax = ctx.subplots()
        ax.plot([0, 1, 2], [1.0, 0.5, 0.25], label="decay")
        ax.set(xlabel="t (s)", ylabel="x")
        ax.legend()
        record.update(font=float(__import__("matplotlib").rcParams["font.size"]),
                      lw=float(__import__("matplotlib").rcParams["lines.linewidth"]))
        ctx.save(fig)
        fig2, ax2 = ctx.subplots()
        (line,) = ax2.plot([], [])
        ctx.save_gif(fig2, lambda i: line.set_data([0, i], [0, i]), frames=2)
        return {"n": 1.0}

    return FigureSpec("zz", "tiny", "A tiny figure", tiny)


@pytest.mark.parametrize("fmt, magic", [("png", b"\x89PNG"), ("svg", b"<?xml"), ("pdf", b"%PDF")])
def test_formats_styles_and_gif_size(fmt, magic, tmp_path):
    from pbanim.plotting import run_figure

    rec: dict = {}
    issues: list = []
    _, files = run_figure(_tiny_spec(rec), tmp_path / "paper", quick=True, fmt=fmt, issues=issues)
    assert files[0].suffix == f".{fmt}" and files[0].read_bytes().startswith(magic)
    paper = dict(rec)
    _, slides = run_figure(_tiny_spec(rec), tmp_path / "slides", quick=True, fmt=fmt, style="slides")
    assert rec["font"] >= 1.6 * paper["font"] and rec["lw"] >= 1.6 * paper["lw"]
    from PIL import Image
    small, big = Image.open(files[1]).size, Image.open(slides[1]).size
    assert big[0] > 1.5 * small[0], (small, big)          # slide GIFs: larger canvas at 100 dpi
    assert issues == ["zz_tiny: axes 0 y: 'x' has no unit"]
    _, again = run_figure(_tiny_spec(rec), tmp_path / "again", quick=True, fmt=fmt)
    assert again[0].read_bytes() == files[0].read_bytes()  # ORACLES G2: same code, same bytes


@pytest.mark.parametrize("kw, message", [({"fmt": "jpg"}, "fmt must be one of 'png', 'svg', 'pdf', got 'jpg'"),
                                         ({"style": "poster"}, "style must be one of 'paper', 'slides', got 'poster'"),
                                         ({"dpi": -5}, "dpi must be a finite number >= 10 and <= 1200, got -5"),
                                         ({"dpi": float("nan")}, "dpi must be a finite number >= 10 and <= 1200, got nan")])
def test_bad_figure_options_are_named_errors(kw, message, tmp_path):
    from pbanim.plotting import run_figure

    with pytest.raises(InvalidInput, match=message):
        run_figure(_tiny_spec({}), tmp_path, quick=True, **kw)


def test_cli_single_figure_in_svg_and_unknown_names(tmp_path, capsys):
    assert main(["figures", "ch01_spring_energy", "--quick", "--format", "svg", "--out", str(tmp_path)]) == 0
    assert [p.name for p in tmp_path.iterdir()] == ["ch01_spring_energy.svg"]
    capsys.readouterr()
    assert main(["figures", "ch03_drif", "--quick", "--out", str(tmp_path)]) == 2
    assert "did you mean 'ch03_drift'" in capsys.readouterr().err


def test_index_captions_say_what_and_which_test(tmp_path):
    from pbanim.cli import checked_by, load_chapters
    from pbanim.plotting import write_index

    specs = {k: s for k, s in load_chapters(["ch01"]).items()}
    path = write_index(specs, tmp_path, {}, checked_by(list(specs)))
    text = path.read_text()
    row = next(line for line in text.splitlines() if "Mass on a spring" in line)
    assert "relative energy error per integrator" in row and "tests/test_particles.py::" in row


# -- listings -----------------------------------------------------------------------------------------
def test_bench_help_and_list_show_every_benchmark_and_figure(capsys):
    from pbanim.bench import available
    from pbanim.cli import load_chapters

    with pytest.raises(SystemExit):
        main(["bench", "--help"])
    help_text = capsys.readouterr().out
    lines = bench_lines()
    assert len(lines) == len(available())
    for name, line in zip(available(), lines):
        assert line.startswith(name) and len(line.split(None, 1)[1]) > 10 and line in help_text
    assert main(["list"]) == 0
    out = capsys.readouterr().out.splitlines()
    for key in load_chapters():
        assert sum(line.split()[:2] == ["figure", key] for line in out) == 1
    assert sum(line.startswith("bench ") for line in out) == len(available())
    assert np.all([len(line) < 200 for line in out])


# -- issue 27: nothing silent ------------------------------------------------------------------------------
def test_a_mutant_with_an_empty_edit_is_refused():
    # "" occurs in every text: str.replace("", new) used to insert new between all characters, silently
    with pytest.raises(InvalidInput, match="mutant 'm': edits must replace non-empty text"):
        Mutant("m", "d", (("", "X"),), ("a",))


def test_figure_folders_may_be_strings(tmp_path):
    # a str out_dir used to fail deep inside with "'str' object has no attribute 'mkdir'" (and "str / str")
    from pbanim.plotting import run_figure, write_index

    _, files = run_figure(_tiny_spec({}), str(tmp_path / "figs"), quick=True)
    assert files and files[0].parent == tmp_path / "figs"
    assert write_index({}, str(tmp_path), {}).read_text().startswith("# Figures")


def test_run_bench_refuses_by_name():
    from pbanim.bench import median_time, run_bench

    with pytest.raises(InvalidInput, match="run_bench: name must be one of .*got 'nope'"):
        run_bench("nope")
    with pytest.raises(InvalidInput, match="run_bench: quick must be True or False, got 'yes'"):
        run_bench("contracts", quick="yes")
    # a measurement whose loop time is 1e300 s used to hang; the bound is known before it starts
    with pytest.raises(InvalidInput, match="median_time: min_time must be a finite number >= 0 and <= 0.5, got 1e"):
        median_time(lambda: None, 1, 1e300)
