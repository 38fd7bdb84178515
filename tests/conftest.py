"""Shared test set-up: hypothesis profile for CI, Agg backend, and a cache of quick figure runs."""

import os
import pickle
from pathlib import Path

import matplotlib
import pytest
from hypothesis import HealthCheck, settings
from threadpoolctl import threadpool_limits

matplotlib.use("Agg", force=True)

# one BLAS thread per test process: CI runs two xdist workers on two cores, and a multi-threaded
# OpenBLAS spin-waiting for the other worker's core makes small solves up to 100x slower
_BLAS = threadpool_limits(limits=1, user_api="blas")

settings.register_profile("ci", max_examples=25, deadline=None, derandomize=True,
                          suppress_health_check=[HealthCheck.too_slow])
settings.register_profile("dev", max_examples=50, deadline=None)
settings.load_profile(os.environ.get("HYPOTHESIS_PROFILE", "ci"))

_FIGURE_CACHE: dict = {}

# -- fuzzing (tests/test_fuzz.py): --fuzz multiplies the example counts; the counts are reported ----------
_FUZZ_COUNTS: dict = {}


def pytest_addoption(parser):
    parser.addoption("--fuzz", action="store", nargs="?", type=int, const=10, default=1, metavar="N",
                     help="multiply the example counts of tests/test_fuzz.py by N (default 10 when given "
                          "without a value; 1 otherwise), for release checks")


def pytest_configure(config):
    factor = config.getoption("--fuzz")
    if factor is None or factor < 1:
        raise pytest.UsageError(f"--fuzz must be a positive integer, got {factor}")
    os.environ["PBANIM_FUZZ_FACTOR"] = str(factor)   # read by tests/test_fuzz.py when it is collected


_SURFACE: dict = {}


@pytest.fixture(scope="session")
def surface_report():
    """Counts of the public surface (filled by tests/test_contracts_surface.py, printed at the end)."""
    return _SURFACE


@pytest.fixture(scope="session")
def fuzz_counts():
    """Examples run per fuzzed entry point in this process (filled by tests/test_fuzz.py)."""
    return _FUZZ_COUNTS


def pytest_sessionfinish(session):
    workeroutput = getattr(session.config, "workeroutput", None)
    if workeroutput is not None:            # an xdist worker: hand the counts to the controller
        workeroutput["fuzz_counts"] = dict(_FUZZ_COUNTS)
        workeroutput["surface"] = dict(_SURFACE)


@pytest.hookimpl(optionalhook=True)
def pytest_testnodedown(node, error):
    for k, v in getattr(node, "workeroutput", {}).get("fuzz_counts", {}).items():
        _FUZZ_COUNTS[k] = _FUZZ_COUNTS.get(k, 0) + v
    _SURFACE.update(getattr(node, "workeroutput", {}).get("surface", {}))


def pytest_terminal_summary(terminalreporter, exitstatus, config):
    if _SURFACE:
        tr = terminalreporter
        tr.section("public surface (tests/test_contracts_surface.py)")
        tr.write_line(f"{_SURFACE['covered']} callables with a contract on every argument, {_SURFACE['bare']} "
                      f"without arguments, {len(_SURFACE['exempted'])} exempted, {_SURFACE['missing']} missing")
        for k, why in sorted(_SURFACE["exempted"].items()):
            tr.write_line(f"  exempt {k}: {why}")
    if not _FUZZ_COUNTS:
        return
    tr = terminalreporter
    tr.section(f"fuzz cases per entry point (--fuzz factor {config.getoption('--fuzz')})")
    width = max(len(k) for k in _FUZZ_COUNTS)
    for k in sorted(_FUZZ_COUNTS):
        tr.write_line(f"{k:<{width}}  {_FUZZ_COUNTS[k]}")
    tr.write_line(f"{'total':<{width}}  {sum(_FUZZ_COUNTS.values())}")


def _shared_dir(tmp_path_factory) -> Path:
    """A folder shared by all xdist workers of this run (the parent of the per-worker base temp)."""
    base = tmp_path_factory.getbasetemp()
    root = base.parent if os.environ.get("PYTEST_XDIST_WORKER") else base
    path = root / "figure-cache"
    path.mkdir(exist_ok=True)
    return path


@pytest.fixture(scope="session")
def figure_data(tmp_path_factory):
    """``figure_data("ch03_bead_tension")`` → the data dict of that figure run in quick mode.

    Each figure runs once per test session: the result (data and written files) is pickled into a folder
    shared by the xdist workers, so tests/test_chapters.py and the per-module tests reuse one run.
    """
    from pbanim.cli import load_chapters
    from pbanim.plotting import run_figure

    shared = _shared_dir(tmp_path_factory)

    def run(key: str):
        if key in _FIGURE_CACHE:
            return _FIGURE_CACHE[key]
        pkl = shared / f"{key}.pkl"
        if pkl.exists():
            with open(pkl, "rb") as fh:
                _FIGURE_CACHE[key] = pickle.load(fh)
            return _FIGURE_CACHE[key]
        specs = load_chapters([key[:4]])
        if key not in specs:
            raise KeyError(f"no figure {key!r}; chapter {key[:4]} has {sorted(specs)}")
        data, files = run_figure(specs[key], shared / "png", quick=True)
        _FIGURE_CACHE[key] = (data, files)
        tmp = pkl.with_suffix(f".{os.getpid()}.tmp")
        with open(tmp, "wb") as fh:
            pickle.dump((data, files), fh)
        os.replace(tmp, pkl)  # atomic: another worker sees all or nothing
        return _FIGURE_CACHE[key]

    def get(key: str) -> dict:
        return run(key)[0]

    get.files = lambda key: run(key)[1]  # type: ignore[attr-defined]
    return get
