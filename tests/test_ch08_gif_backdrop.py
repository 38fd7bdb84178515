"""The chapter 08 GIFs drawn over a frozen backdrop (pbanim.plotting_gif.frozen_backdrop) against the same
GIFs drawn whole: the same bytes (ORACLES G5). The helper's own frame tests are in tests/test_plotting_gif.py."""

import hashlib

from pbanim.plotting import run_figure


def test_the_ragdoll_gif_over_its_backdrop_equals_full_draws(tmp_path, monkeypatch):
    # ORACLES G5: the stairs' fill, the axes and the figure frozen under the limbs, the stairs' edge, the
    # spines and the title: the quick figure's files have the bytes of drawing every artist in every frame
    import chapters.ch08_articulated as ch
    from pbanim.cli import select_figures

    spec = select_figures(["ch08_ragdoll_fall"])["ch08_ragdoll_fall"]
    digest = lambda files: {f.name: hashlib.md5(f.read_bytes()).hexdigest() for f in files}  # noqa: E731
    frozen = digest(run_figure(spec, tmp_path / "frozen", quick=True)[1])
    monkeypatch.setattr(ch, "frozen_backdrop", lambda fig, still, moving: lambda: None)
    whole = digest(run_figure(spec, tmp_path / "whole", quick=True)[1])
    assert frozen == whole and len(whole) == 2


def test_the_3d_walk_gif_over_its_backdrop_equals_full_draws(tmp_path, monkeypatch):
    # ORACLES G5: the figure and the side view's face frozen under both views (which follow the walker: their
    # x axes, the top view's y axis, the bones, the floor, the path, the title and spines drawn live): the
    # quick figure's files have the bytes of drawing every artist in every frame (the full figure's too)
    import chapters.ch08_biped3d as ch
    from pbanim.cli import select_figures

    spec = select_figures(["ch08_biped3d_walk"])["ch08_biped3d_walk"]
    digest = lambda files: {f.name: hashlib.md5(f.read_bytes()).hexdigest() for f in files}  # noqa: E731
    frozen = digest(run_figure(spec, tmp_path / "frozen", quick=True)[1])
    monkeypatch.setattr(ch, "frozen_backdrop", lambda fig, still, moving: lambda: None)
    whole = digest(run_figure(spec, tmp_path / "whole", quick=True)[1])
    assert frozen == whole and len(whole) == 2
