"""The contact figures' GIF frames drawn by blitting (pbanim.plotting_gif.blit_canvas) against full
draws: the same bytes (ORACLES L7)."""

import hashlib

from pbanim.plotting import run_figure


def test_blitted_gif_of_the_box_slide_equals_full_draws(tmp_path, monkeypatch):
    # ORACLES L7: the box's outline rests on the floor line and passes the goal star; blitted, its GIF has the
    # bytes of full draws (checked here on the quick figure; on the full figures of the box and the die too)
    import chapters.ch10_design_contact as ch
    from pbanim.cli import select_figures

    spec = select_figures(["ch10_contact_box_slide"])["ch10_contact_box_slide"]
    digest = lambda files: {f.name: hashlib.md5(f.read_bytes()).hexdigest() for f in files}  # noqa: E731
    blit = digest(run_figure(spec, tmp_path / "blit", quick=True)[1])
    monkeypatch.setattr(ch, "blit_canvas", lambda fig, moving: None)
    full = digest(run_figure(spec, tmp_path / "full", quick=True)[1])
    assert blit == full and len(full) == 2
