"""Joints between rigid bodies in maximal coordinates (chapter 08; ORACLES G1, B2, I3)."""

import numpy as np
import pytest

from pbanim.articulated import ArticulatedSystem, ArticulatedTree, RigidJoints
from pbanim.errors import InvalidInput
from pbanim.rigid import RigidBodies, RigidGravity, RigidScene
from pbanim.rigid.quat import quat_from_axis_angle, quat_to_matrix

L, M, G = 1.0, 2.0, 9.81
IC = np.diag([M * L * L / 12, 0.01, M * L * L / 12])          # a rod along its y axis


def _rods(thetas, omegas):
    """Two rods hanging in a chain from the origin, rotated by absolute angles about z."""
    x, q, v, w = [], [], [], []
    top, vtop = np.zeros(3), np.zeros(3)
    for th, om in zip(thetas, omegas):
        R = quat_to_matrix(quat_from_axis_angle([0, 0, 1], th))
        c = top + R @ [0, -L / 2, 0]
        vc = vtop + np.cross([0, 0, om], c - top)
        x.append(c), q.append(quat_from_axis_angle([0, 0, 1], th)), v.append(vc), w.append([0, 0, om])
        top, vtop = top + R @ [0, -L, 0], vtop + np.cross([0, 0, om], R @ [0, -L, 0])
    return RigidBodies(M, IC, positions=x, orientations=q, velocities=v, angular_velocities=w)


def _angle(y, i):
    R = quat_to_matrix(y[3 * 2 + 4 * i: 3 * 2 + 4 * i + 4])
    return np.arctan2(R[1, 0], R[0, 0])


def test_hinged_double_pendulum_equals_the_reduced_tree():
    # ORACLES G1: two rods joined by hinges (maximal coordinates, multipliers) and the same chain as an
    # articulated tree (reduced coordinates, ABA) follow the same motion (measured 2e-12 after 1 s)
    th, om = np.array([0.7, -0.4]), np.array([0.3, -1.0])
    rb = _rods(th, om)
    joints = RigidJoints([dict(kind="hinge", a=0, b=-1, anchor_a=[0, L / 2, 0], anchor_b=[0, 0, 0], axis_a=[0, 0, 1]),
                          dict(kind="hinge", a=1, b=0, anchor_a=[0, L / 2, 0], anchor_b=[0, -L / 2, 0], axis_a=[0, 0, 1])])
    res = RigidScene(rb, [RigidGravity([0, -G, 0]), joints]).simulate(1.0, 1e-3, "rk4")
    tree = ArticulatedTree(gravity=(0, -G, 0))
    tree.add("rod0", -1, "revolute", axis=[0, 0, 1], mass=M, com=[0, -L / 2, 0], inertia=IC)
    tree.add("rod1", 0, "revolute", axis=[0, 0, 1], p=[0, -L, 0], mass=M, com=[0, -L / 2, 0], inertia=IC)
    red = ArticulatedSystem(tree, [th[0], th[1] - th[0]], [om[0], om[1] - om[0]]).simulate(1.0, 1e-3, "rk4")
    y = res.y[:, -1]
    np.testing.assert_allclose([_angle(y, 0), _angle(y, 1) - _angle(y, 0)], red.y[:2, -1], atol=1e-9)
    assert res.diagnostics["joint_error"].max() < 1e-8          # drift without feedback: measured 3.6e-10


def test_ball_joint_pendulum_conserves_energy_and_the_joint():
    # a rod on a ball joint swinging in 3-D: RK4's energy error falls as h⁴ (ORACLES I3, measured ratio
    # ≈ 16 per halving) and the joint holds to roundoff-level drift
    w0 = np.array([1.6, 0.3, -1.0])
    v0 = -np.cross(w0, [0, L / 2, 0])                       # the anchor at rest: a consistent start
    joints = RigidJoints([dict(kind="ball", a=0, b=-1, anchor_a=[0, L / 2, 0])])
    err = []
    for h in (8e-3, 4e-3):
        rb = RigidBodies(M, IC, positions=[[0, -L / 2, 0]], velocities=[v0], angular_velocities=[w0])
        res = RigidScene(rb, [RigidGravity([0, -G, 0]), joints]).simulate(1.0, h, "rk4")
        E = res.diagnostics["energy"]
        err.append(np.max(np.abs(E - E[0])))
        assert res.diagnostics["joint_error"].max() < 1e-8
    assert err[0] / err[1] > 10, err


def test_baumgarte_decay_of_a_joint_error():
    # ORACLES B2: a free body pulled onto a ball joint with k_s = ω², k_d = 2ω (no gravity, no spin) has
    # C(t) = (C₀ + (Ċ₀ + ωC₀)t) e^(−ωt) exactly; RK4 at h = 1e-3 reproduces it to 1e-9
    om = 5.0
    rb = RigidBodies(M, IC, positions=[[0.1, -L / 2, 0]])
    joints = RigidJoints([dict(kind="ball", a=0, b=-1, anchor_a=[0, L / 2, 0])], ks=om * om, kd=2 * om)
    res = RigidScene(rb, [joints]).simulate(1.0, 1e-3, "rk4")
    anchor_x = [(y[:3] + quat_to_matrix(y[3:7]) @ [0, L / 2, 0])[0] for y in res.y.T]
    exact = 0.1 * (1 + om * res.t) * np.exp(-om * res.t)
    np.testing.assert_allclose(anchor_x, exact, atol=1e-9)


@pytest.mark.parametrize("kind", ["weld", "slider"])
def test_weld_and_slider_hold(kind):
    # a weld keeps the two bodies one rigid body; a slider lets b slide along its axis only
    rb = RigidBodies([1.0, 1.0], [[1.0, 2.0, 3.0], [2.0, 2.0, 1.0]], positions=[[0, 0, 0], [1.0, 0, 0]],
                     velocities=[[0, 0, 0], [0.5, 0, 0]] if kind == "slider" else None)
    joints = RigidJoints([dict(kind="ball" if kind == "weld" else "weld", a=0, b=-1, anchor_a=[0, 0, 0]),
                          dict(kind=kind, a=1, b=0, anchor_a=[0, 0, 0], anchor_b=[1.0, 0, 0], axis_a=[1, 0, 0])],
                         ks=100.0, kd=20.0)
    res = RigidScene(rb, [RigidGravity([0, -G, 0]), joints]).simulate(0.5, 1e-3, "rk4")
    assert res.diagnostics["joint_error"].max() < 1e-6
    if kind == "slider":
        assert res.y[3, -1] == pytest.approx(1.0 + 0.5 * 0.5, abs=1e-6)   # slides freely along x


def test_bad_joints_are_named():
    rb = RigidBodies(1.0, [1.0, 1.0, 1.0])
    with pytest.raises(InvalidInput, match="joints\\[0\\]: RigidJoint: kind must be one of .* got 'universal'"):
        RigidJoints([dict(kind="universal")])
    with pytest.raises(InvalidInput, match="joints\\[0\\]: RigidJoint: axis_a must be a non-zero .* it is zero"):
        RigidJoints([dict(kind="hinge", axis_a=[0, 0, 0])])
    with pytest.raises(InvalidInput, match="joints\\[0\\] body b must be -1 \\(world\\) or 0..0 .* got 3"):
        RigidScene(rb, [RigidJoints([dict(kind="ball", a=0, b=3)])])


def test_figure_chain_maximal_vs_reduced(figure_data):
    # ORACLES G1: the tip of the hinged chain and of the articulated tree coincide (measured 3e-8 m at
    # h = 2 ms over 1 s); both conserve energy to RK4's truncation (measured 5e-8 J, 4e-9 J)
    d = figure_data("ch08_chain_maximal_vs_reduced")
    assert d["tip_difference"] < 1e-6
    for key in ("energy_maximal", "energy_reduced"):
        E = np.asarray(d[key])
        assert np.abs(E - E[0]).max() < 1e-6
    assert np.max(d["joint_error"]) < 1e-7 and np.max(d["joint_error_baumgarte"]) < 1e-7


def test_figure_cost_vs_links(figure_data):
    d = figure_data("ch08_cost_vs_links")
    for key in ("aba", "crba_solve", "aba_batched", "maximal", "maximal_linear"):
        assert np.all(np.isfinite(d[key])) and np.all(d[key] > 0)
    # the timings themselves are the benchmarks' business (pbanim bench articulated), not a unit test's: a
    # loaded machine reorders them; here every method is timed at every chain length the figure draws
    assert all(d[key].shape == d["n"].shape for key in ("aba", "crba_solve", "aba_batched", "maximal", "maximal_linear"))


# --- contact for articulated trees (pbanim.articulated.contact) -------------------------------------------
def test_floating_box_rests_on_its_corners_with_its_weight():
    # ORACLES D4: a box (floating base) dropped onto the ground comes to rest on its four bottom corners; at
    # rest the normal impulses per step sum to m g h and nothing sinks (measured gap 0, speed 0)
    from pbanim.articulated.contact import ArticulatedContact

    m, h = 2.0, 1e-3
    tree = ArticulatedTree(gravity=(0, 0, -G))
    tree.add("box", -1, "floating", mass=m, inertia=[0.2, 0.3, 0.4])
    q0 = tree.neutral()
    q0[6] = 0.3
    corners = [(0, [sx * 0.3, sy * 0.2, -0.1]) for sx in (-1, 1) for sy in (-1, 1)]
    ac = ArticulatedContact(ArticulatedSystem(tree, q0), corners, friction=0.5)
    res = ac.simulate(1.0, h)
    assert res.y[6, -1] == pytest.approx(0.1, abs=1e-6)
    assert np.abs(res.y[7:, -1]).max() < 1e-9
    assert res.diagnostics["min_gap"].min() > -1e-3
    assert ac.last["impulses"][0::3].sum() == pytest.approx(m * G * h, rel=1e-6)


def test_ragdoll_falls_and_lands_without_gaining_energy():
    # the ragdoll (11 links, floating pelvis, damped hinges) dropped from 1.2 m: energy never grows (contact
    # and damping only dissipate), it does not sink more than a few mm, and it has landed by the end
    from pbanim.articulated.contact import ArticulatedContact
    from pbanim.models.articulated import ragdoll, ragdoll_contact_points

    tree = ragdoll(damping=3.0)
    q0 = tree.neutral()
    q0[:4] = quat_from_axis_angle([1, 0.3, 0], 0.6)
    q0[4:7] = [0, 0, 1.2]
    q0[7:] = np.random.default_rng(0).uniform(-0.5, 0.5, tree.nq - 7)
    ac = ArticulatedContact(ArticulatedSystem(tree, q0), ragdoll_contact_points(tree), friction=0.8)
    res = ac.simulate(1.2, 5e-3, record_every=4)
    E = res.diagnostics["energy"]
    assert np.all(np.diff(E) <= 1e-6 * E[0])
    assert res.diagnostics["min_gap"].min() > -5e-3
    assert E[-1] < 0.2 * E[0] and res.y[6, -1] < 0.5


def test_figure_ragdoll_fall(figure_data):
    d = figure_data("ch08_ragdoll_fall")
    E = np.asarray(d["energy"])
    assert np.all(np.diff(E) <= 1e-6 * E[0]) and E[-1] < 0.5 * E[0]
    assert np.min(d["min_gap"]) > -5e-3 and d["frames"] >= 6


def _hinge_angle(y):
    R = quat_to_matrix(y[3:7])
    return np.arctan2(R[1, 0], R[0, 0])


def test_hinge_motor_spins_up_at_torque_over_inertia():
    # a constant motor torque τ on a rod hinged at its end, no gravity: θ(t) = ½ (τ / I_O) t² with
    # I_O = I_zz + m (L/2)² about the hinge (measured 0.5250000000 vs 0.525 after 1 s)
    tau = 0.7
    rb = _rods([0.0], [0.0])
    joints = RigidJoints([dict(kind="hinge", a=0, b=-1, anchor_a=[0, L / 2, 0], axis_a=[0, 0, 1], motor=tau)])
    res = RigidScene(rb, [joints]).simulate(1.0, 1e-3, "rk4")
    assert _hinge_angle(res.y[:, -1]) == pytest.approx(0.5 * tau / (IC[2, 2] + M * (L / 2) ** 2), rel=1e-9)


def test_hinge_limit_stops_the_swing_and_never_adds_energy():
    # released at 0.8 rad (joint angle 0 at bind) with limits (−0.3, 1.0): without the limit it swings to
    # −0.8 (absolute), with it the rod stops near 0.5 absolute (soft stop of k_s = 2500, k_d = 100: measured
    # overshoot 0.017 rad) and comes to rest against the stop; the stop dissipates (it is a spring-damper
    # whose spring energy the diagnostic does not count: measured +3.5e-3 J within one step, then lost)
    def run(limits):
        d = dict(kind="hinge", a=0, b=-1, anchor_a=[0, L / 2, 0], axis_a=[0, 0, 1])
        if limits:
            d["limits"] = limits
        res = RigidScene(_rods([0.8], [0.0]), [RigidGravity([0, -G, 0]), RigidJoints([d], ks=2500.0, kd=100.0)]) \
            .simulate(2.0, 1e-3, "rk4")
        return np.array([_hinge_angle(y) for y in res.y.T]), res.diagnostics["energy"]

    free, _ = run(None)
    stopped, E = run((-0.3, 1.0))
    assert free.min() == pytest.approx(-0.8, abs=1e-6)
    assert stopped.min() > 0.5 - 0.03 and stopped[-1] == pytest.approx(0.5, abs=1e-6)
    assert E.max() <= E[0] + 1e-3 * abs(E[0]) and E[-1] < E[0] - 1.0
    with pytest.raises(InvalidInput, match="limits apply to hinge and slider joints"):
        RigidJoints([dict(kind="ball", limits=(0, 1))])
    with pytest.raises(InvalidInput, match="lower < upper"):
        RigidJoints([dict(kind="hinge", limits=(1, 0))])


def test_four_bar_loop_holds_by_the_full_solve():
    # a closed chain (parallelogram four-bar, the ground as the fourth bar): four hinges give 20 rows for
    # 18 freedoms, redundant but consistent; the J W Jᵀ solve (least squares on the redundant rows) keeps the
    # loop closed and RK4 keeps the energy (measured joint error 1e-11, energy drift 1e-9 J over 1 s)
    from pbanim.rigid.quat import quat_from_axis_angle

    th = -1.0
    P = {"O1": np.zeros(3), "O2": np.array([2.0, 0, 0])}
    P["A"] = np.array([np.cos(th), np.sin(th), 0.0])
    P["B"] = P["A"] + [2.0, 0, 0]
    bars = [("O1", "A"), ("A", "B"), ("O2", "B")]
    x, q, inertia, lengths = [], [], [], []
    for p, r in bars:
        d = P[r] - P[p]
        length = np.linalg.norm(d)
        u = d / length
        x.append((P[p] + P[r]) / 2), q.append(quat_from_axis_angle([0, 0, 1], np.arctan2(u[0], -u[1])))
        inertia.append(np.diag([length ** 2 / 12, 1e-3, length ** 2 / 12])), lengths.append(length)
    rb = RigidBodies(1.0, np.array(inertia), positions=x, orientations=q)
    top = lambda i: [0, lengths[i] / 2, 0]  # noqa: E731
    bottom = lambda i: [0, -lengths[i] / 2, 0]  # noqa: E731
    joints = RigidJoints([
        dict(kind="hinge", a=0, b=-1, anchor_a=top(0), anchor_b=P["O1"], axis_a=[0, 0, 1]),
        dict(kind="hinge", a=1, b=0, anchor_a=top(1), anchor_b=bottom(0), axis_a=[0, 0, 1]),
        dict(kind="hinge", a=2, b=1, anchor_a=bottom(2), anchor_b=bottom(1), axis_a=[0, 0, 1]),
        dict(kind="hinge", a=2, b=-1, anchor_a=top(2), anchor_b=P["O2"], axis_a=[0, 0, 1])])
    res = RigidScene(rb, [RigidGravity([0, -G, 0]), joints]).simulate(1.0, 1e-3, "rk4")
    E = res.diagnostics["energy"]
    assert res.diagnostics["joint_error"].max() < 1e-8
    assert np.abs(E - E[0]).max() < 1e-6
    assert np.ptp(res.y[1]) > 0.05                              # it does swing (measured 0.079 m)


def test_velocity_motor_reaches_its_speed_within_its_force_limit():
    # a velocity motor drives θ̇ to ω* with θ̈ = (ω* − θ̇)/τ_m: ω(t) = ω*(1 − e^(−t/τ_m)) while the torque stays
    # below motor_max; with a small motor_max it saturates and θ̈ = motor_max / I_O (no gravity)
    I_O = IC[2, 2] + M * (L / 2) ** 2

    def omega_at(t_end, fmax):
        joints = RigidJoints([dict(kind="hinge", a=0, b=-1, anchor_a=[0, L / 2, 0], axis_a=[0, 0, 1],
                                   motor_speed=2.0, motor_max=fmax)], motor_time=0.05)
        y = RigidScene(_rods([0.0], [0.0]), [joints]).simulate(t_end, 1e-3, "rk4").y[:, -1]
        rb = _rods([0.0], [0.0])
        return rb.velocities(y)[1][0, 2]

    assert omega_at(0.1, 1e3) == pytest.approx(2.0 * (1 - np.exp(-0.1 / 0.05)), rel=1e-6)
    assert omega_at(0.1, 0.05) == pytest.approx(0.05 * 0.1 / I_O, rel=1e-6)


def test_linear_time_joint_solve_equals_the_dense_one():
    # Baraff 1996: a tree of joints eliminated leaves first has no fill; the sparse solve gives the same
    # constraint forces as the dense one (measured 1.8e-8 N on forces of ~1e2 N for 64 links) and refuses
    # what is not a tree
    import sys
    import pathlib

    sys.path.insert(0, str(pathlib.Path(__file__).resolve().parents[1]))
    from chapters.ch08_articulated import chain_models

    scene, rb, _ = chain_models(20, theta0=0.7)
    joints = [e for e in scene.effects if isinstance(e, RigidJoints)][0]
    y = rb.state()
    dense = scene.forces(0.0, y)
    joints.solver = "linear"
    linear = scene.forces(0.0, y)
    np.testing.assert_allclose(linear, dense, atol=1e-9 * np.abs(dense).max())
    with pytest.raises(InvalidInput, match="solver must be one of 'dense', 'linear', got 'ldl'"):
        RigidJoints([dict(kind="ball")], solver="ldl")
    with pytest.raises(InvalidInput, match="limits and velocity motors need solver='dense'"):
        RigidJoints([dict(kind="hinge", limits=(0, 1))], solver="linear")


def test_ragdoll_tumbles_down_steps_and_comes_to_rest():
    # issue 15 item 4: thrown forward over the top of a staircase (rise 0.15 m, run 0.35 m), the ragdoll
    # lands on a lower tread and comes to rest: kinetic energy below 1e-2 J after 2.5 s (measured 2e-3 J at
    # 2 s, 0 at 3 s); it never sinks into a tread by more than a few mm; energy only ever decreases after
    # the throw except for what gravity gives on the way down (E = T + V never grows)
    from pbanim.articulated import kinetic_energy
    from pbanim.models.articulated import ragdoll_down_stairs

    ac, stairs = ragdoll_down_stairs()
    tree = ac.tree
    res = ac.simulate(2.5, 5e-3, record_every=10)
    E = res.diagnostics["energy"]
    assert np.all(np.diff(E) <= 1e-6 * abs(E[0]) + 1e-9)
    assert res.diagnostics["min_gap"].min() > -5e-3
    y = res.y[:, -1]
    assert kinetic_energy(tree, y[:tree.nq], y[tree.nq:]) < 1e-2
    assert y[6] < stairs.height(y[4]) + 0.5 and stairs.height(y[4]) < -0.15     # lying on a lower tread


def test_bad_terrain_is_named():
    from pbanim.articulated.contact import ArticulatedContact, Plane, Staircase
    from pbanim.models.articulated import ragdoll, ragdoll_contact_points

    tree = ragdoll()
    with pytest.raises(InvalidInput, match="terrain"):
        ArticulatedContact(ArticulatedSystem(tree), ragdoll_contact_points(tree), terrain=object())
    with pytest.raises(InvalidInput, match="run"):
        Staircase(run=0.0)
    with pytest.raises(InvalidInput, match="normal"):
        Plane([0, 0, 0])


def _ball_on_post(x0):
    from pbanim.articulated.contact import ArticulatedContact, Plane

    t = ArticulatedTree(gravity=(0, 0, -9.81))
    post = t.add("post", -1, "fixed", p=[0, 0, 0.5], mass=5.0, inertia=np.full(3, 0.1))
    ball = t.add("ball", -1, "floating", mass=2.0, inertia=np.full(3, 0.4 * 2 * 0.04))
    q0 = t.neutral()
    q0[-3:] = [x0, 0, 1.05]
    return t, ArticulatedContact(ArticulatedSystem(t, q0), [(ball, [0, 0, -0.2])], terrain=Plane([0, 0, 1], -10),
                                 spheres=[(post, [0, 0, 0], 0.3), (ball, [0, 0, 0], 0.2)], friction=0.5)


def test_links_touch_each_other_a_ball_rests_on_a_sphere():
    # ORACLES D4 between links: a 2 kg ball (r = 0.2) dropped on a fixed sphere (r = 0.3, centre 0.5) rests at
    # centre height 0.5 + 0.3 + 0.2 = 1.0 with a normal impulse m g h per step (measured exact to 1e-15)
    t, ac = _ball_on_post(0.0)
    res = ac.simulate(1.0, 1e-3, record_every=100)
    assert res.y[6, -1] == pytest.approx(1.0, abs=1e-6)
    assert ac.last["sphere_contacts"] == 1
    assert ac.last["impulses"][0::3].sum() == pytest.approx(2.0 * 9.81 * 1e-3, rel=1e-9)
    # placed 5 cm off the top, it rolls off and falls past the sphere's equator
    _, ac = _ball_on_post(0.05)
    res = ac.simulate(1.5, 1e-3, record_every=100)
    assert res.y[4, -1] > 0.5 and res.y[6, -1] < 0.5


def test_bad_spheres_are_named():
    from pbanim.articulated.contact import ArticulatedContact

    t = ArticulatedTree(gravity=(0, 0, -9.81))
    t.add("a", -1, "floating", mass=1.0, inertia=np.full(3, 0.1))
    for bad, match in ((["x"], "spheres\\[0\\]"), ([(0, [0, 0], 0.1)], "centre"), ([(0, [0, 0, 0], -1.0)], "radius"),
                       ([(5, [0, 0, 0], 1.0)], "link")):
        with pytest.raises(InvalidInput, match=match):
            ArticulatedContact(ArticulatedSystem(t), [(0, [0, 0, 0])], spheres=bad)


def test_post_step_projection_keeps_hinges_on_their_constraint():
    # ORACLES B2 for rigid joints: without feedback a 4-rod chain drifts (measured max |C| 4e-8 m over 1 s, rk4,
    # h = 4 ms); with post-step projection |C| ≤ 1e-11 (measured 4e-13) and the energy error shrinks
    # (measured 1.4e-6 → 1.7e-7 J); the velocity step never adds kinetic energy
    from pbanim.models.articulated import rod_chain

    scene, rb, _ = rod_chain(4)
    joints = [e for e in scene.effects if isinstance(e, RigidJoints)][0]
    free = scene.simulate(1.0, 4e-3, "rk4")
    proj_scene = RigidScene(rb, [scene.effects[0], RigidJoints(joints.joints, projection=True)])
    assert "joint-projection" in proj_scene.pipeline
    proj = proj_scene.simulate(1.0, 4e-3, "rk4")
    assert free.diagnostics["joint_error"].max() > 1e-9
    assert proj.diagnostics["joint_error"].max() < 1e-11
    E0, E1 = free.diagnostics["energy"], proj.diagnostics["energy"]
    assert np.abs(E1 - E1[0]).max() < 0.3 * np.abs(E0 - E0[0]).max()          # measured ratio 0.12
    stage = proj_scene.effects[-1] if proj_scene.effects[-1].name == "joint-projection" else \
        [e for e in proj_scene.effects if e.name == "joint-projection"][0]
    y = proj.y[:, -1].copy()
    x, q, P, L = rb.unpack(y)
    P += 0.3                                                  # a velocity that violates J u = 0
    ke = lambda z: 0.5 * np.sum(np.hstack(rb.velocities(z)) * np.hstack(rb.unpack(z)[2:]))  # noqa: E731
    y1 = stage.post_step(0.0, y, 2e-3)
    assert ke(y1) <= ke(y) + 1e-12
    _, J, _, _ = stage.joints.rows(y1)
    assert np.abs(J @ np.ravel(rb.generalized_velocity(y1))).max() < 1e-10
