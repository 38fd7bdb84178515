"""The chapters' GIFs drawn with the frame helpers of :mod:`pbanim.plotting_gif` against the same GIFs drawn
whole: the same bytes (ORACLES G5 for ``frozen_backdrop``, L7 for ``blit_canvas``). The helpers' own frame
tests are in tests/test_plotting_gif.py; the cloth's 3-D backdrop in tests/test_cloth_gif_backdrop.py.

Each case runs the quick figure twice, once as written and once with the helper replaced by a stand-in that
draws every artist in every frame, and compares the files' digests (checked on the full figures too when
each speed-up was written):

* ``frozen_backdrop`` — the boxes of ch06_boxes_tumbling and ch07_stack_settling and the discs of
  ch07_sphere_pile are patches over a grid drawn below them, so the figure, the axes' face and both axes are
  rendered once; the ragdoll's stairs' fill, axes and figure are frozen under the limbs; the 3-D walk's
  figure and side view's face under both views, which follow the walker (their x axes, the bones, the floor,
  the path, the title and spines drawn live);
* ``blit_canvas`` — the box of ch10_contact_box_slide rests on the floor line and passes the goal star, the
  thrown chain and its trail are the last artists drawn over a view that never moves: the axes, ticks,
  labels and targets restored as pixels under them.
"""

import hashlib
import importlib

import pytest

from pbanim.plotting import run_figure

_WHOLE = {"frozen_backdrop": lambda fig, still, moving: (lambda: None),   # nothing frozen: full draws
          "blit_canvas": lambda fig, moving: None}                         # no blitting: full draws

CASES = [("ch06_boxes_tumbling", "frozen_backdrop"), ("ch07_stack_settling", "frozen_backdrop"),
         ("ch07_sphere_pile", "frozen_backdrop"), ("ch08_ragdoll_fall", "frozen_backdrop"),
         ("ch08_biped3d_walk", "frozen_backdrop"), ("ch10_contact_box_slide", "blit_canvas"),
         ("ch10_thrown_chain", "blit_canvas")]


def _digests(files) -> dict:
    return {f.name: hashlib.md5(f.read_bytes()).hexdigest() for f in files}


@pytest.mark.parametrize("key,helper", CASES)
def test_gif_drawn_with_the_frame_helper_equals_full_draws(tmp_path, monkeypatch, key, helper):
    # ORACLES G5 / L7: exact equality of every file's bytes, the GIF among them
    from pbanim.cli import select_figures

    spec = select_figures([key])[key]
    chapter = importlib.import_module(spec.func.__module__)
    assert hasattr(chapter, helper), f"{key}'s chapter no longer draws with {helper}"
    fast = _digests(run_figure(spec, tmp_path / "helper", quick=True)[1])
    monkeypatch.setattr(chapter, helper, _WHOLE[helper])
    whole = _digests(run_figure(spec, tmp_path / "whole", quick=True)[1])
    assert fast == whole and any(name.endswith(".gif") for name in whole)
