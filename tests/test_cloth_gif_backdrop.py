"""The drape's GIF drawn over a frozen backdrop of its 3-D axes (chapters/ch12_cloth.py, _frozen_axes3d) against
the same GIF drawn whole: the same bytes (ORACLES G5)."""

import hashlib

import pytest

from pbanim.plotting import run_figure


@pytest.mark.parametrize("style", ["paper", "slides"])
def test_the_drape_gif_over_its_backdrop_equals_full_draws(tmp_path, monkeypatch, style):
    # ORACLES G5: the figure, the axes' face, panes, grid, ticks and labels frozen under the ball, the sheet and
    # the title (the 3-D axis then off): the quick figure's files have the bytes of drawing every artist
    import chapters.ch12_cloth as ch
    from pbanim.cli import select_figures

    spec = select_figures(["ch12_drape"])["ch12_drape"]
    digest = lambda files: {f.name: hashlib.md5(f.read_bytes()).hexdigest() for f in files}  # noqa: E731
    frozen = digest(run_figure(spec, tmp_path / "frozen", quick=True, style=style)[1])
    monkeypatch.setattr(ch, "_frozen_axes3d", lambda fig, ax, moving: None)
    whole = digest(run_figure(spec, tmp_path / "whole", quick=True, style=style)[1])
    assert frozen == whole and len(whole) == 2
