"""Chapter 10, issue 30, point 2: designs that need contact. Differential control on the stepped S(t, u)
(pbanim.design.stepped_design): a box pushed to slide and stop on a spot, a ball rolled off a table edge
into a cup, a die thrown to rest on a chosen face at a chosen place. Each design's final state is checked
in an independent replay: chapter 07's own FrictionStepping on the same grid (ORACLES L2)."""

import numpy as np
import pytest

from pbanim.collision import Box, Plane, Sphere
from pbanim.design import DesignBody
from pbanim.design.control import position_goal
from pbanim.design.stepped import ContactScene, StaticBox
from pbanim.design.stepped_design import FACES, design_contact
from pbanim.design.stepped_run import replay_chapter7
from pbanim.rigid import quat_to_matrix


def face_down(q):
    return int(np.argmax(FACES @ (quat_to_matrix(q).T @ np.array([0.0, 0.0, -1.0]))))


def test_box_pushed_to_slide_and_stop_on_a_spot():
    # ORACLES L2, H5: the push v0 and μ chosen together (min-norm) so that the box stops at the spot; the
    # replay by chapter 07 stops there too, at rest (measured 2e-9 from the spot)
    scene = ContactScene(DesignBody(Box([0.2, 0.1, 0.05]), position=[0, 0, 0.05], velocity=[1.0, 0, 0]),
                         [Plane()], friction=0.3)
    spot, T = np.array([0.8, -0.3, 0.05]), 1.0
    M = np.diag([1.0, 1.0, 1e6, 1.0])                    # a vertical push costs: the box is pushed, not tossed
    d = design_contact(scene, T, ["v0", "friction"], [position_goal(0, T, spot)], rest=True, h=0.01, M=M)
    assert d.success and d.at_rest and d.residual <= 1e-6, d.notes
    assert d.u[3] >= 0 and abs(d.u[2]) < 1e-3
    Y = replay_chapter7(scene, T, d.names, d.u, h=0.01)
    assert np.linalg.norm(Y[-1, :3] - spot) < 1e-6 and np.abs(Y[-1, 7:]).max() < 1e-9


CUP, R_BALL, W_IN, H_CUP = np.array([1.05, 0.1]), 0.05, 0.07, 0.2


def table_and_cup():
    th = 0.01
    cx, cy = CUP
    walls = [StaticBox([th, W_IN + 2 * th, H_CUP / 2], [cx + s * (W_IN + th), cy, H_CUP / 2]) for s in (1, -1)]
    walls += [StaticBox([W_IN, th, H_CUP / 2], [cx, cy + s * (W_IN + th), H_CUP / 2]) for s in (1, -1)]
    table = StaticBox([0.5, 0.5, 0.4], [0, 0, 0.4])
    body = DesignBody(Sphere(R_BALL), position=[0.2, 0, 0.8 + R_BALL], velocity=[1.5, 0.0, 0])
    return ContactScene(body, [Plane()], [table] + walls, friction=0.4)


def test_ball_rolled_off_the_table_edge_into_the_cup():
    # ORACLES L2, H5: the ball rolls (sticking contact) to the table's edge, flies, and passes over the cup's
    # centre at t = 0.62 s (goal on x, y); the replay ends inside the cup, on its bottom
    scene, T = table_and_cup(), 1.0
    d = design_contact(scene, T, ["v0"], [position_goal(0, 0.62, [*CUP, 0.0])], components=(0, 1), h=0.01,
                       u=np.array([1.5, 0.0, 0.0]))
    assert d.success and d.residual <= 1e-6, d.notes
    Y = replay_chapter7(scene, T, d.names, d.u, h=0.01)
    x = Y[-1, :3]
    assert np.abs(x[:2] - CUP).max() <= W_IN - R_BALL + 1e-6 and abs(x[2] - R_BALL) < 1e-6


def test_die_thrown_to_rest_on_a_chosen_face_at_a_chosen_place():
    # ORACLES L2, H5: a cube thrown spinning (corner impacts, rolling, sliding) comes to rest at the place
    # (Gauss–Newton on v0 with backtracking through the kinks of S) on the chosen face (the cube's symmetry
    # applied to θ₀ relabels the faces of the same motion). The replay by chapter 07 rests on that face
    # within 1 mm of the place (the compliance κ's 1e-9 difference grows through the impacts: measured
    # 6e-5 to 3e-4 m); one seeded start here, 10 random starts measured in the chapter's figure run
    rng = np.random.default_rng(0)
    v0, w0 = np.array([rng.uniform(0.5, 1.5), rng.uniform(-0.5, 0.5), rng.uniform(0, 1)]), rng.uniform(-8, 8, 3)
    scene = ContactScene(DesignBody(Box([0.05, 0.05, 0.05]), position=[0, 0, 0.3], velocity=v0,
                                    angular_velocity=w0), [Plane()], friction=0.5)
    place, face, T = np.array([0.6, 0.2, 0.05]), 4, 1.5
    d = design_contact(scene, T, ["v0"], [position_goal(0, T, place)], rest=True, face=face, h=0.01)
    assert d.success and d.face == face and d.at_rest, d.notes
    Y = replay_chapter7(scene, T, d.names, d.u, h=0.01)
    assert face_down(Y[-1, 3:7]) == face
    assert np.linalg.norm(Y[-1, :3] - place) < 1e-3 and np.abs(Y[-1, 7:]).max() < 1e-9
