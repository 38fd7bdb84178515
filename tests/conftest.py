"""Shared test set-up: hypothesis profile for CI, Agg backend, and a cache of quick figure runs."""

import os

import matplotlib
import pytest
from hypothesis import HealthCheck, settings

matplotlib.use("Agg", force=True)

settings.register_profile("ci", max_examples=25, deadline=None, derandomize=True,
                          suppress_health_check=[HealthCheck.too_slow])
settings.register_profile("dev", max_examples=50, deadline=None)
settings.load_profile(os.environ.get("HYPOTHESIS_PROFILE", "ci"))

_FIGURE_CACHE: dict = {}


@pytest.fixture(scope="session")
def figure_data(tmp_path_factory):
    """``figure_data("ch03_bead_tension")`` → the data dict of that figure run in quick mode (cached)."""
    from pbanim.plotting import load_chapters, run_figure

    out = tmp_path_factory.mktemp("figures")

    def get(key: str) -> dict:
        if key not in _FIGURE_CACHE:
            specs = load_chapters([key[:4]])
            if key not in specs:
                raise KeyError(f"no figure {key!r}; chapter {key[:4]} has {sorted(specs)}")
            _FIGURE_CACHE[key] = run_figure(specs[key], out, quick=True)
        return _FIGURE_CACHE[key][0]

    return get
