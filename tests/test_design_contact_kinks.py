"""Chapter 10, issue 30, point 2: the kink-crossing step of design_contact (ORACLES L9). S(t, u) is piecewise
smooth in u; where a step's contact changes its mode between u and the Gauss–Newton trial u_t, ∂S/∂u jumps
and the trial can raise the residual although S is continuous. The crossing step takes Gauss–Newton from u_t
with u_t's own derivative (the far piece's). Checked on a piecewise-linear S with one kink (its far piece's
solution in closed form), and on a random throw of the die whose design stalled 3.5e-6 m from the place
(slow, linear progress over 40 updates: the trial points lie past a kink 7 % of the step away); the
crossing design ends on face 4 at the place, at rest, and chapter 07's stepper replays it there."""

import numpy as np

from pbanim.bench.design import DIE_FACE, DIE_PLACE, die_scene
from pbanim.design.control import min_norm_update, position_goal
from pbanim.design.stepped_design import FACES, _cross, design_contact
from pbanim.design.stepped_run import replay_chapter7
from pbanim.rigid import quat_to_matrix

C, D1 = 0.3, 10.0           # the kink at u0 = C; past it x1 gains D1 (u0 − C)


class _PiecewiseLinear:
    """x(u) = (u0 + u2, u1 + D1·max(0, u0 − C), 0): continuous, a kink along u0 = C (a trajectory's stand-in:
    position and d_position at any time)."""

    def __init__(self, u):
        self.u = np.asarray(u, dtype=float)

    def position(self, t):
        u = self.u
        return np.array([u[0] + u[2], u[1] + D1 * max(0.0, u[0] - C), 0.0])

    def d_position(self, t):
        far = self.u[0] > C
        return np.array([[1.0, 0, 1], [D1 if far else 0.0, 1, 0], [0, 0, 0]])


def test_the_crossing_step_lands_on_the_far_pieces_solution():
    # ORACLES L9: from u = 0 (near piece, J = [[1, 0, 1], [0, 1, 0]]) the min-norm Gauss–Newton step to
    # x = (1, 0) is (0.5, 0, 0.5): past the kink, where x1 = 10 · 0.2 = 2 > 1 = the residual at u = 0 (the plain
    # step fails at α = 1). Gauss–Newton from there with the far piece's J lands on its solution u0 + u2 = 1,
    # u1 = −10 (u0 − 0.3), u0 > 0.3: the residual 0 to roundoff (8 eps)
    goals, comp = [position_goal(0, 1.0, [1.0, 0.0, 0.0])], [0, 1]
    u = np.zeros(3)
    r = goals[0].target[comp] - _PiecewiseLinear(u).position(1.0)[comp]
    du = min_norm_update(_PiecewiseLinear(u).d_position(1.0)[comp], r).du
    assert np.allclose(du, [0.5, 0, 0.5], rtol=0, atol=1e-15)
    trial = _PiecewiseLinear(u + du)
    rt = goals[0].target[comp] - trial.position(1.0)[comp]
    assert np.linalg.norm(rt) > np.linalg.norm(r)                       # the plain step fails
    got = _cross(_PiecewiseLinear, goals, comp, min_norm_update, None, u + du, trial, rt, np.linalg.norm(r), 3)
    assert got is not None
    u2, tr2, r2 = got
    assert u2[0] > C and np.abs(r2).max() <= 8 * np.finfo(float).eps
    assert abs(u2[0] + u2[2] - 1.0) <= 8 * np.finfo(float).eps and abs(u2[1] + D1 * (u2[0] - C)) <= 1e-14
    # not accepted when it does not lower the residual below the one given
    assert _cross(_PiecewiseLinear, goals, comp, min_norm_update, None, u + du, trial, rt, 0.0, 3) is None


# throw 3 of default_rng(0) (pbanim bench design's die rows): the answer its design stalled at without the
# crossing step, 3.5e-6 m from the place on face 3 after 40 updates (repr of the floats: exact)
U_STALLED = [1.6952394763449883, 0.8644802685075955, 0.17210016714746998]


def _throw(k):
    rng = np.random.default_rng(0)
    for _ in range(k + 1):
        scene = die_scene(rng)
    return scene


def _design(scene, **kw):
    return design_contact(scene, 1.5, ["v0"], [position_goal(0, 1.5, DIE_PLACE)], rest=True, face=DIE_FACE,
                          h=0.01, components=(0, 1), u=U_STALLED, **kw)


def test_a_stalled_die_throw_reaches_the_place_on_face_4_by_crossing_the_kink():
    # ORACLES L9, L2: from the stalled answer, the readable Gauss–Newton without the crossing step makes no
    # progress below tol in 4 updates; with it the design reaches the place (≤ 1e-6), relabels the face to 4 and
    # is at rest; chapter 07's FrictionStepping replays the answer on face 4 within 1 mm of the place, at rest
    scene = _throw(3)
    plain = _design(scene, max_iter=4, cross=False)
    assert plain.residual > 1e-6 and not plain.success
    d = _design(scene, max_iter=8)
    assert d.success and d.face == DIE_FACE and d.at_rest and d.residual <= 1e-6
    Y = replay_chapter7(scene, 1.5, d.names, d.u, h=0.01)
    down = int(np.argmax(FACES @ (quat_to_matrix(Y[-1, 3:7]).T @ np.array([0.0, 0.0, -1.0]))))
    assert down == DIE_FACE
    assert np.linalg.norm(Y[-1, :3] - DIE_PLACE) < 1e-3 and np.abs(Y[-1, 7:]).max() < 1e-9
