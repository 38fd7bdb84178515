"""The contact and collision GIFs drawn over a frozen backdrop (pbanim.plotting_gif.frozen_backdrop) against
full draws: the same bytes (ORACLES G5).

The boxes of ch06_boxes_tumbling and ch07_stack_settling and the discs of ch07_sphere_pile are patches over a
grid drawn below them (``set_axisbelow(True)``), so the figure, the axes' face and both axes are drawn before
every moving artist and rendered once; a frame draws the bodies, the ground or walls, the spines and the title.
"""

import hashlib

import pytest

from pbanim.plotting import run_figure


@pytest.mark.parametrize("key", ["ch06_boxes_tumbling", "ch07_stack_settling", "ch07_sphere_pile"])
def test_gif_over_a_frozen_backdrop_equals_full_draws(tmp_path, monkeypatch, key):
    # ORACLES G5: each frame has the pixels of drawing every artist (checked here on the quick figures; on the
    # full ones too when this was written)
    import importlib

    from pbanim.cli import select_figures

    spec = select_figures([key])[key]
    ch = importlib.import_module(spec.func.__module__)
    digest = lambda files: {f.name: hashlib.md5(f.read_bytes()).hexdigest() for f in files}  # noqa: E731
    frozen = digest(run_figure(spec, tmp_path / "frozen", quick=True)[1])
    monkeypatch.setattr(ch, "frozen_backdrop", lambda fig, still, moving: (lambda: None))
    full = digest(run_figure(spec, tmp_path / "full", quick=True)[1])
    assert frozen == full and any(name.endswith(".gif") for name in full)
