"""The 3-D biped's lean contact step equals its readable step to roundoff (ORACLES F20).

``WorldStep(lean=True)`` (:mod:`pbanim.control.biped3d_lean`) against ``WorldStep(lean=False)`` (the methods as
the lecture writes them) and the library's pieces: kinematics, mass matrix, point Jacobians, the bias forces
against the ABA, one contact step (the same PGS sweeps), and a short walk through the runner, step by step.
"""

import functools

import numpy as np
import pytest

import pbanim.control.simbicon3d_walk as walk3d
from pbanim.articulated.dynamics import aba, crba, rnea
from pbanim.control import biped3d_lean as lean
from pbanim.control.biped3d import biped3d, biped3d_contact_points, standing_state3d
from pbanim.control.biped3d_step import WorldStep
from pbanim.errors import SimulationDiverged
from test_biped3d import _random_state          # a random pose and velocity of the biped (any orientation)

TREE = biped3d()
PTS = biped3d_contact_points(TREE)
EPS = np.finfo(float).eps


def _steps():
    return WorldStep(TREE, PTS, tol=1e-5), WorldStep(TREE, PTS, tol=1e-5, lean=False)


def test_lean_kinematics_mass_matrix_and_jacobians_equal_the_readable_ones():
    # ORACLES F20: the same formulas regrouped; measured 0 on R, o, c, S, 1.4e-14 on H (max|H| ~ 40)
    fast, slow = _steps()
    rng = np.random.default_rng(7)
    for _ in range(4):
        q, _ = _random_state(rng)
        kf, ks = fast.kinematics(q), slow.kinematics(q)
        for key in "RocS":
            assert np.allclose(kf[key], ks[key], rtol=0, atol=8 * EPS * (1 + np.abs(ks[key]).max())), key
        H = fast.mass_matrix(kf)
        assert np.abs(H - slow.mass_matrix(ks)).max() <= 50 * EPS * np.abs(H).max()
        assert np.abs(H - crba(TREE, q)).max() <= 50 * EPS * np.abs(H).max()
        for links, pts in ((fast.links, fast.points), (np.arange(TREE.n), fast.com)):
            (Pf, Jf), (Ps, Js) = fast.point_jacobians(kf, links, pts), slow.point_jacobians(ks, links, pts)
            assert np.abs(Pf - Ps).max() <= 1e-14 and np.abs(Jf - Js).max() <= 1e-14
    # the kept kinematics is the last state's only: another q gives its own frames
    q1, _ = _random_state(rng)
    assert not np.allclose(fast.kinematics(q1)["o"], fast.kinematics(q)["o"])
    ko = slow.kinematics(q)["o"]
    assert np.abs(fast.kinematics(q)["o"] - ko).max() <= 8 * EPS * (1 + np.abs(ko).max())


def test_a_quaternion_whose_squares_overflow_gives_the_frames_of_its_direction():
    # ORACLES F20: R(q) depends on the direction of q only; at |q| ~ 1e300 the squares overflow, the lean
    # kinematics scales by the largest entry first (a bare ZeroDivisionError before), the readable R(q/|q|)
    fast, _ = _steps()
    q, _ = _random_state(np.random.default_rng(11))
    unit = fast.kinematics(q.copy())["R"]
    big = q.copy()
    big[:4] *= 1e300 / np.abs(q[:4]).max()
    R = fast.kinematics(big)["R"]
    assert np.isfinite(R).all() and np.abs(R - unit).max() <= 16 * EPS


def test_lean_bias_forces_give_the_aba_accelerations():
    # ORACLES F20: H⁻¹ (τ − C) with C from the world-frame Newton–Euler sums equals the readable ABA;
    # measured 1.2e-14 relative
    fast, slow = _steps()
    rng = np.random.default_rng(3)
    for _ in range(4):
        q, qd = _random_state(rng)
        tau = 10 * rng.normal(size=18)
        kin = fast.kinematics(q)
        acc = np.linalg.solve(fast.mass_matrix(kin), tau - lean.bias(fast, kin, qd))
        ref = aba(TREE, q, qd, tau)
        assert np.abs(acc - ref).max() <= 1e-11 * (1 + np.abs(ref).max())
        # C itself against RNEA at q̈ = 0 plus the joint damping; measured 6e-16 relative; also from the readable
        # step's arrays (no float frames in its dict)
        C = rnea(TREE, q, qd, np.zeros(18)) + np.asarray(TREE.arrays()["damping"]) * qd
        for k in (kin, slow.kinematics(q)):
            assert np.abs(lean.bias(fast, k, qd) - C).max() <= 1e-13 * (1 + np.abs(C).max())


def test_lean_contact_step_equals_the_readable_step():
    # ORACLES F20: soles 1 mm into the ground, stable PD damping on the joints; measured 1e-18 in q, 6e-16 in q̇
    fast, slow = _steps()
    rng = np.random.default_rng(5)
    q, qd = standing_state3d(height=-1e-3)
    qd = qd + 0.3 * rng.normal(size=18)
    tau = 20 * rng.normal(size=18)
    k = np.r_[np.zeros(6), 30 * rng.uniform(size=12)]
    for kk in (k, None):
        (qf, uf), (qs, us) = fast.step(q, qd, 2e-3, tau, kk), slow.step(q, qd, 2e-3, tau, kk)
        assert fast.last["sweeps"] == slow.last["sweeps"] and np.array_equal(fast.last["contacts"], slow.last["contacts"])
        assert np.abs(qf - qs).max() <= 16 * EPS and np.abs(uf - us).max() <= 64 * EPS * (1 + np.abs(us).max())


def test_lean_walk_follows_the_readable_walk_step_by_step(monkeypatch):
    # ORACLES F20: 0.3 s of the 3-D walk (150 steps at h = 2 ms) through the runner, both paths; the states
    # agree to a few ulps per step (bound 8 ε × steps; measured 1.3e-14 after 150 steps)
    fast = walk3d.simulate_walk3d(t_end=0.3, h=2e-3, record_every=1)
    monkeypatch.setattr(walk3d, "WorldStep", functools.partial(WorldStep, lean=False))
    slow = walk3d.simulate_walk3d(t_end=0.3, h=2e-3, record_every=1)
    assert fast.trace == slow.trace and fast.q.shape == slow.q.shape == (151, 19)
    steps = np.arange(151)[:, None]
    assert np.all(np.abs(fast.q - slow.q) <= 8 * EPS * np.maximum(steps, 1) * (1 + np.abs(slow.q)))
    assert np.abs(fast.q[-1] - fast.q[0]).max() > 0.05          # it moved: the comparison is not of two rests


def test_a_mass_matrix_that_is_not_positive_definite_is_named():
    with pytest.raises(SimulationDiverged, match="not positive definite"):
        lean._cholesky(-np.eye(18))


def test_lean_kinematics_of_a_tree_whose_levels_are_not_one_slice():
    # ORACLES F20: a neck and head on the torso put a torso child among the hips' children (parents 2, 3, 1:
    # the float kinematics reads each parent's frame by index); frames equal the readable ones to a few ulps
    # (measured ≤ 4 ε), H equals CRBA
    tree = biped3d()
    torso = [lk.name for lk in tree.links].index("torso")
    neck = tree.add("neck", torso, "revolute", axis=[0, 1, 0], p=[0, 0, 0.7], mass=1.0, com=[0, 0, 0.1],
                    inertia=[0.01, 0.01, 0.01])
    tree.add("head", neck, "revolute", axis=[1, 0, 0], mass=4.0, com=[0, 0, 0.1], inertia=[0.02, 0.02, 0.02])
    pts = biped3d_contact_points(tree)
    fast, slow = WorldStep(tree, pts), WorldStep(tree, pts, lean=False)
    assert [tree.parent[i] for i in range(tree.n)] != sorted(tree.parent)       # parents out of order: 2, 3, 1
    rng = np.random.default_rng(2)
    q = np.zeros(tree.nq)
    q[:4] = rng.normal(size=4)
    q[:4] /= np.linalg.norm(q[:4])
    q[4:7], q[7:] = rng.normal(size=3), rng.uniform(-1, 1, tree.nq - 7)
    kf, ks = fast.kinematics(q), slow.kinematics(q)
    for key in "RocS":
        assert np.allclose(kf[key], ks[key], rtol=0, atol=8 * EPS * (1 + np.abs(ks[key]).max())), key
    H = fast.mass_matrix(kf)
    assert np.abs(H - crba(tree, q)).max() <= 50 * EPS * np.abs(H).max()


def test_rotation_vector_on_floats_is_the_quaternion_route():
    # ORACLES F20: rotation_vector_floats (the controller's servos) against quat_log(matrix_to_quat(R)), equal
    # to 2 ulps (np.linalg.norm's |v| is a BLAS dot: one rounding apart from sqrt(x² + y² + z²) in 8 of 400),
    # on random rotations and on ones near 0 and near π (each of Shepperd's four branches taken)
    from pbanim.design.simulate import quat_log
    from pbanim.rigid.quat import matrix_to_quat, quat_to_matrix

    rng = np.random.default_rng(11)
    branches, exact = set(), 0
    for i in range(400):
        q = rng.normal(size=4)
        if i % 4 == 1:
            q[1:] *= 10.0 ** rng.uniform(-14, -3)            # near the identity
        elif i % 4 == 2:
            q[0] *= 10.0 ** rng.uniform(-14, -3)             # near a half turn
        R = quat_to_matrix(q / np.linalg.norm(q))
        r = lean.rotation_vector_floats(R)
        ref = quat_log(matrix_to_quat(R))
        assert np.abs(r - ref).max() <= 2 * EPS * np.abs(ref).max()      # |v| by sqrt(x² + y² + z²), norm's dot
        exact += bool(np.array_equal(r, ref))
        branches.add(int(np.argmax([np.trace(R), *(2 * np.diag(R) - np.trace(R))])))
        assert abs(np.linalg.norm(r) - 2 * np.arctan2(np.linalg.norm(q[1:]), abs(q[0]))) <= 1e-12
    assert branches == {0, 1, 2, 3} and exact >= 360                 # measured 392 of 400 bit for bit


def test_the_contact_sweep_skips_and_stops_exactly_as_the_readable_sweep():
    # ORACLES D20, F20: the float sweep visits one contact at a time, skips a zero tangent under a zero bound
    # and stops the residual at the first value above the exit threshold; against the readable array sweep,
    # bit for bit: contacts that separate (f = 0), μ = 0 on some contacts, warm starts, and runs stopped at a
    # cap of 1, 3 and 40 sweeps (the residual then reported whole, as the readable sweep reports it)
    from pbanim.lcp.box import _box_residual, _box_sweeps
    from pbanim.lcp.box_lean import box_residual_floats, box_sweeps_floats, project_impulses

    rng = np.random.default_rng(21)
    zeros_seen = skipped_mu = 0
    for m in range(1, 9):
        J = rng.normal(size=(3 * m, 2 * m + 3))
        A = J @ J.T + 1e-6 * np.eye(3 * m)
        b = rng.normal(size=3 * m)
        b[0::3] += rng.choice([0.0, 3.0], size=m)                  # some contacts pulled apart: f = 0
        mu = np.where(rng.uniform(size=m) < 0.3, 0.0, rng.uniform(0.2, 1.0, m))
        skipped_mu += int(np.sum(mu == 0))
        for warm in (None, 2 * rng.normal(size=3 * m)):
            for cap, tol in ((1, 1e-300), (3, 1e-300), (40, 1e-300), (500, 1e-7)):
                z0 = project_impulses(np.zeros(3 * m) if warm is None else warm.copy(), mu)
                za, ra, ka = _box_sweeps(A, b, mu, np.diag(A).copy(), z0.copy(), cap, tol)
                zb, rb, kb = box_sweeps_floats(A, b, mu, np.diag(A).copy(), z0.copy(), cap,
                                               tol * max(1.0, float(np.abs(b).max())))
                assert ka == kb and ra == rb and np.array_equal(za, zb)
                zeros_seen += int(np.sum(zb[0::3] == 0))
        # the residual with a stop: the whole value when it is at most the stop, else a value above the stop
        z, w = rng.normal(size=3 * m), rng.normal(size=3 * m)
        z[0::3] = np.abs(z[0::3])
        full = _box_residual(z, w, mu)
        for stop in (0.0, 0.5 * full, full, 2 * full):
            r = box_residual_floats(z.tolist(), w.tolist(), mu.tolist(), stop)
            assert (r == full) if full <= stop else (stop < r <= full)
    assert zeros_seen > 0 and skipped_mu > 0                      # the skipped rows were there


def test_the_contact_frames_follow_the_terrain_normals():
    # ORACLES F20: the lean step keeps the contact frames (n, t₁, t₂) per set of normals; a step on a tilted
    # plane after one on the flat, then the flat again, equals the readable step each time (a stale frame would
    # put the impulses along the wrong normal: errors of order the impulse, not ulps)
    from pbanim.articulated.contact import Plane

    fast, slow = _steps()
    rng = np.random.default_rng(8)
    q, qd = standing_state3d(height=-1e-3)
    qd = qd + 0.2 * rng.normal(size=18)
    tau = 10 * rng.normal(size=18)
    tilt = np.array([np.sin(0.1), 0.0, np.cos(0.1)])
    for terrain in (Plane((0.0, 0.0, 1.0), 0.0), Plane(tilt, 0.0), Plane((0.0, 0.0, 1.0), 0.0)):
        fast.terrain = slow.terrain = terrain
        (qf, uf), (qs, us) = fast.step(q, qd, 2e-3, tau), slow.step(q, qd, 2e-3, tau)
        assert fast.last is not None and np.array_equal(fast.last["contacts"], slow.last["contacts"])
        # roundoff of the two solves (Cholesky, LU) through the sweeps: measured 4e-14 in q̇ on the tilted plane
        assert np.abs(qf - qs).max() <= 64 * EPS and np.abs(uf - us).max() <= 1e-12 * (1 + np.abs(us).max())
    assert len(fast._plan.basis) == 2                            # two sets of normals seen, two frames kept


def test_the_controller_follows_a_heading_change_and_a_new_phase():
    # ORACLES F20: Simbicon3D keeps R_z(ψ̄) and the torso target, and its servo table per (stance, phase); after
    # the heading moves, or the machine changes state, its torques equal a fresh controller's in the same state
    from pbanim.control.simbicon3d import Simbicon3D

    ws, _ = _steps()
    rng = np.random.default_rng(9)
    q, qd = standing_state3d(speed=0.5)
    q[7:] += 0.1 * rng.normal(size=12)
    qd = qd + 0.2 * rng.normal(size=18)
    kin = ws.kinematics(q)
    used = Simbicon3D(ws)
    used.torques(0.0, q, qd, (), kin, 2e-3)
    for heading, start, t in ((0.3, "R0", 0.01), (0.3, "R1", 0.35)):
        used.heading = heading
        fresh = Simbicon3D(ws, heading=heading, start=start)
        fresh.fsm.entered = used.fsm.entered if start == "R0" else t
        tau, k = used.torques(t, q, qd, (), kin, 2e-3)
        assert used.fsm.state == start
        tau0, k0 = fresh.torques(t, q, qd, (), kin, 2e-3)
        assert np.array_equal(tau, tau0) and np.array_equal(k, k0)
    # the heading moved the swing hip's torques (the cache did not hide it)
    assert not np.array_equal(used.torques(0.36, q, qd, (), kin, 2e-3)[0],
                              Simbicon3D(ws, start="R1").torques(0.36, q, qd, (), kin, 2e-3)[0])


def test_the_controller_on_float_frames_equals_it_on_the_readable_arrays():
    # ORACLES F20: Simbicon3D reads the lean kinematics' floats (R row-major, the joint columns) and, given the
    # readable step's dict, the same numbers from its arrays; the torques agree to roundoff (the frames differ
    # by a few ulps: BLAS's fused products against Python's), and the stable-PD gains k exactly
    from pbanim.control.simbicon3d import Simbicon3D

    fast, slow = _steps()
    rng = np.random.default_rng(12)
    for start in ("R0", "L1"):
        q, qd = standing_state3d(speed=0.5)
        q[7:] += 0.2 * rng.normal(size=12)
        qd = qd + 0.3 * rng.normal(size=18)
        kf, ks = fast.kinematics(q), slow.kinematics(q)
        assert "Rf" in kf and "Rf" not in ks
        tf, kkf = Simbicon3D(fast, heading=0.2, start=start).torques(0.01, q, qd, (), kf, 2e-3)
        ts, kks = Simbicon3D(slow, heading=0.2, start=start).torques(0.01, q, qd, (), ks, 2e-3)
        assert np.array_equal(kkf, kks)
        assert np.abs(tf - ts).max() <= 1e-12 * (1 + np.abs(ts).max())
        assert np.count_nonzero(tf) >= 12                             # the servos and both hips act


def test_the_walk_names_a_state_that_is_not_finite(monkeypatch):
    # the runner's finiteness test on floats (|y|² finite) hands a NaN, an Inf and a finite state whose |y|²
    # overflows to the driver's check, which names them as before
    for bad in (np.nan, np.inf, 1e200):
        real = WorldStep.step

        def step(self, q, qd, h, tau0, k=None, kin=None, _real=real, _bad=bad):
            q1, u1 = _real(self, q, qd, h, tau0, k, kin)
            u1 = u1.copy()
            u1[7] = _bad
            return q1, u1

        monkeypatch.setattr(WorldStep, "step", step)
        with pytest.raises(SimulationDiverged):
            walk3d.simulate_walk3d(t_end=0.02, h=2e-3)
        monkeypatch.undo()
