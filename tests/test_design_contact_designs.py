"""Chapter 10, issue 30, point 2: designs that need contact. Differential control on the stepped S(t, u)
(pbanim.design.stepped_design), run once by the chapter's figures (quick mode): a box pushed to slide and
stop on a spot, a ball rolled off a table edge into a cup, a die thrown to rest on a chosen face at a
chosen place. Each design's u is replayed here, in scenes built by this file, by chapter 07's own
FrictionStepping on the same grid (ORACLES L2), and its final state checked."""

import numpy as np

from pbanim.collision import Box, Plane, Sphere
from pbanim.design import DesignBody
from pbanim.design.stepped import ContactScene, StaticBox
from pbanim.design.stepped_design import FACES
from pbanim.design.stepped_run import replay_chapter7
from pbanim.rigid import quat_to_matrix

H = 0.01


def face_down(q):
    return int(np.argmax(FACES @ (quat_to_matrix(q).T @ np.array([0.0, 0.0, -1.0]))))


def test_box_pushed_to_slide_and_stop_on_a_spot(figure_data):
    # ORACLES L2, H5: v0 and μ chosen together (min-norm, a vertical push weighted 1e6) so that the box stops
    # on the spot; chapter 07's replay stops there too, at rest (measured 2e-9 m from the spot)
    d = figure_data("ch10_contact_box_slide")
    assert d["success"] and d["at_rest"] and d["residual"] <= 1e-6
    u = d["u"]
    assert u[3] >= 0 and abs(u[2]) < 1e-3 and d["names"] == ["v0", "friction"]
    scene = ContactScene(DesignBody(Box([0.2, 0.1, 0.05]), position=[0, 0, 0.05], velocity=[1.0, 0, 0]),
                         [Plane()], friction=0.3)
    Y = replay_chapter7(scene, d["T"], d["names"], u, h=H)
    assert np.linalg.norm(Y[-1, :3] - d["spot"]) < 1e-6 and np.abs(Y[-1, 7:]).max() < 1e-9


def test_ball_rolled_off_the_table_edge_into_the_cup(figure_data):
    # ORACLES L2, H5: the ball rolls (its contact sticks) to the table's edge, flies over the cup's centre at
    # t = 0.62 s (goal on x, y) and drops in: chapter 07's replay ends inside the cup's walls, on its bottom
    d = figure_data("ch10_contact_ball_cup")
    assert d["success"] and d["residual"] <= 1e-6
    cup, w, Hc, r, th = np.array([1.05, 0.1]), 0.07, 0.2, 0.05, 0.01
    walls = [StaticBox([th, w + 2 * th, Hc / 2], [cup[0] + s * (w + th), cup[1], Hc / 2]) for s in (1, -1)]
    walls += [StaticBox([w, th, Hc / 2], [cup[0], cup[1] + s * (w + th), Hc / 2]) for s in (1, -1)]
    scene = ContactScene(DesignBody(Sphere(r), position=[0.2, 0, 0.8 + r], velocity=[1.5, 0, 0]), [Plane()],
                         [StaticBox([0.5, 0.5, 0.4], [0, 0, 0.4])] + walls, friction=0.4)
    Y = replay_chapter7(scene, d["T"], d["names"], d["u"], h=H)
    x = Y[-1, :3]
    assert np.abs(x[:2] - cup).max() <= w - r + 1e-6 and abs(x[2] - r) < 1e-6
    assert np.abs(Y[-1, :3] - d["final"][:3]).max() < 1e-6


def test_die_thrown_to_rest_on_a_chosen_face_at_a_chosen_place(figure_data):
    # ORACLES L2, H5: a cube thrown spinning (corner impacts, rolling, sliding) comes to rest at the place
    # (Gauss–Newton on v0 with backtracking through the kinks of S) on the chosen face (the cube's symmetry
    # applied to θ₀ relabels the faces of the same motion). Chapter 07's replay rests on that face within
    # 1 mm of the place (the compliance κ's 1e-9 difference grows through the impacts: measured 6e-9 to
    # 3e-4 m over random starts). The figure designs the first random throw; how many of 10 throws succeed is
    # the full `pbanim bench design`'s row design-die-successes (≈ 45 s a throw: not in the suite)
    d = figure_data("ch10_contact_die")
    assert d["success"] and d["face"] == 4 and d["at_rest"] and d["residual"] <= 1e-6
    assert d["successes"] >= 0.8 * d["starts"]
    rng = np.random.default_rng(0)
    v0, w0 = np.array([rng.uniform(0.5, 1.5), rng.uniform(-0.5, 0.5), rng.uniform(0, 1)]), rng.uniform(-8, 8, 3)
    scene = ContactScene(DesignBody(Box([0.05, 0.05, 0.05]), position=[0, 0, 0.3], velocity=v0,
                                    angular_velocity=w0), [Plane()], friction=0.5)
    Y = replay_chapter7(scene, d["T"], d["names"], d["u"], h=H)
    assert face_down(Y[-1, 3:7]) == 4
    assert np.linalg.norm(Y[-1, :3] - [0.6, 0.2, 0.05]) < 1e-3 and np.abs(Y[-1, 7:]).max() < 1e-9
