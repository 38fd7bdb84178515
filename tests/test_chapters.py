"""Every chapter's figures run in quick mode, write their files, return finite data, and are checked.

The physics of each figure's data is checked in the module's own test file through the ``figure_data``
fixture (one run per session, shared); here we check what holds for every figure, and that no figure
goes unchecked.
"""

import dataclasses
from pathlib import Path

import numpy as np
import pytest

from pbanim.cli import load_chapters
from pbanim.plotting import FIGURES

SPECS = load_chapters()
TESTS = Path(__file__).parent


def _numbers(value):
    """Every numeric leaf of a figure's data (dicts, lists, tuples, arrays)."""
    if isinstance(value, dict):
        for v in value.values():
            yield from _numbers(v)
    elif dataclasses.is_dataclass(value) and not isinstance(value, type):
        yield from _numbers(dataclasses.asdict(value))
    elif isinstance(value, (list, tuple)):
        for v in value:
            yield from _numbers(v)
    elif isinstance(value, np.ndarray) and value.dtype.kind in "fiub":
        yield value.astype(float)
    elif isinstance(value, (int, float, np.integer, np.floating)) and not isinstance(value, bool):
        yield np.array([float(value)])


def test_every_chapter_has_figures():
    chapters = {s.chapter for s in SPECS.values()}
    assert {"ch01", "ch02"} <= chapters, f"chapters with figures: {sorted(chapters)}"


@pytest.mark.parametrize("key", sorted(SPECS))
def test_figure_runs_and_returns_data(key, figure_data):
    data = figure_data(key)
    numbers = list(_numbers(data))
    assert numbers, f"figure {key} returned no numeric data: {sorted(data)}"
    # a figure may show a diverged run (that is often its point) but most of its numbers are finite
    finite = np.concatenate([n.ravel() for n in numbers])
    assert np.isfinite(finite).mean() > 0.5, f"figure {key}: most of its data is not finite"
    files = figure_data.files(key)
    assert files and all(Path(f).stat().st_size > 1000 for f in files), f"figure {key} wrote {files}"


@pytest.mark.parametrize("key", sorted(SPECS))
def test_figure_data_is_checked_by_a_physics_test(key):
    # each figure's returned data must be checked somewhere (figure_data("<key>") in a test file)
    uses = [p.name for p in TESTS.glob("test_*.py") if p.name != "test_chapters.py" and f'"{key}"' in p.read_text()]
    assert uses, f"no test checks the data of figure {key}; add figure_data({key!r}) checks to its module's test"


def test_figures_are_deterministic(tmp_path):
    # same code, same bytes: Agg, fixed DPI, scrubbed metadata, seeded RNG
    from pbanim.plotting import run_figure

    spec = FIGURES[sorted(SPECS)[0]]
    _, a = run_figure(spec, tmp_path / "a", quick=True)
    _, b = run_figure(spec, tmp_path / "b", quick=True)
    assert [p.read_bytes() for p in a] == [p.read_bytes() for p in b]


# cheap figures without wall times in their data (a timing figure's numbers differ from run to run)
PARALLEL_KEYS = ["ch01_projectile_drag", "ch02_stiff_spring", "ch05_polhode", "ch06_newtons_cradle"]


def test_figures_on_two_processes_write_the_serial_files(tmp_path):
    # pbanim figures runs figures on a process pool: each in a fresh seeded context, so the same bytes as a
    # serial run in this process, one progress line per figure, and the files reported per key
    from pbanim.plotting import run_figures

    specs = {k: FIGURES[k] for k in PARALLEL_KEYS}
    serial, _, _ = run_figures(specs, tmp_path / "serial", quick=True, jobs=1)
    lines: list[str] = []
    parallel, seconds, _ = run_figures(specs, tmp_path / "parallel", quick=True, jobs=2, progress=lines.append)
    assert list(parallel) == list(serial) == PARALLEL_KEYS and set(seconds) == set(PARALLEL_KEYS)
    for key in PARALLEL_KEYS:
        assert [p.name for p in parallel[key]] == [p.name for p in serial[key]] and serial[key], key
        assert [p.read_bytes() for p in parallel[key]] == [p.read_bytes() for p in serial[key]], key
    assert len(lines) == len(PARALLEL_KEYS) and {line.split()[1].rstrip(":") for line in lines} == set(PARALLEL_KEYS)
    assert sorted(int(line[1:line.index("/")]) for line in lines) == list(range(1, len(PARALLEL_KEYS) + 1))


def test_figures_sharing_a_computation_share_a_group():
    # the figures that read one cached run are one group (one process runs them, the run is made once)
    assert FIGURES["ch11_trajectories"].group == FIGURES["ch11_error_vs_cost"].group != ""


def _broken_figure(ctx):
    raise RuntimeError("drawn wrong on purpose")


def test_a_figure_failing_in_a_worker_is_raised_and_named(tmp_path):
    from pbanim.plotting import FigureSpec, run_figures

    specs = {"ch01_projectile_drag": FIGURES["ch01_projectile_drag"],
             "zz_broken": FigureSpec("zz", "broken", "A broken figure", _broken_figure, cost=100.0)}
    with pytest.raises(RuntimeError, match="on purpose") as info:
        run_figures(specs, tmp_path, quick=True, jobs=2)
    assert "zz_broken" in " ".join(getattr(info.value, "__notes__", []))


def test_derivations_forked_after_the_imports_equal_a_fresh_interpreter():
    # ch04_derivation_time (full) forks one process per job from a server that has only imported: the same
    # derived equations as a new interpreter per job (ü of pbanim and Kane agree to roundoff, as in
    # in ORACLES A1's derivation check of tests/test_reduced.py), finite times, and a job past its cap is
    # reported capped (NaN), never waited for
    from chapters.ch04_reduced import derive_forked
    from pbanim.bench.reduced import derive_in_subprocess

    forked = derive_forked([("pbanim", 2, 1), ("kane", 2, 1)], 60.0)
    fresh = derive_in_subprocess("pbanim", 2, 1, 60.0)
    assert all(np.isfinite(r["total"]) and r["total"] > 0 and not r["capped"] for r in forked)
    np.testing.assert_array_equal(forked[0]["rhs_value"], fresh["rhs_value"])
    np.testing.assert_allclose(forked[0]["rhs_value"], forked[1]["rhs_value"], atol=1e-12)
    (capped,) = derive_forked([("kane", 20, 0)], 0.5)
    assert capped["capped"] and np.isnan(capped["total"])
