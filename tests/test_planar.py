"""Planar trees in closed form, and their contact step (chapter 08, part 2).

ORACLES I6: the planar closed forms equal the 3-D recursions (CRBA, RNEA bias, point Jacobians).
ORACLES F3: a box sliding on the ground decelerates at μ g and stops at v₀²/(2 μ g); a resting box stays.
"""

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

from pbanim.articulated import (ArticulatedTree, NotPlanarError, PlanarContactStep, PlanarGround, PlanarKernel,
                                bias_forces, crba, solve_planar_contact)
from pbanim.articulated.contact import point_jacobians
from pbanim.articulated.planar_step import SEPARATE, SLIDE_NEG, SLIDE_POS, STICK
from pbanim.errors import InvalidInput
from pbanim.models.articulated import pendulum_chain
from pbanim.models.biped import biped_contact_points, planar_biped


def _random_planar_tree(rng, n):
    """A planar tree: a sliding root (x, y) and a random tree of z-hinges with random placements."""
    t = ArticulatedTree(gravity=(0.0, -9.81, 0.0))
    bx = t.add("bx", -1, "prismatic", axis=[1, 0, 0], mass=0.5, inertia=np.full(3, 0.01))
    by = t.add("by", bx, "prismatic", axis=[0, 1, 0], mass=0.5, inertia=np.full(3, 0.01))
    links = [by]
    for k in range(n):
        parent = int(rng.choice(links))
        sign = rng.choice([-1.0, 1.0])
        t.add(f"l{k}", parent, "revolute", axis=[0, 0, sign], p=[*rng.normal(size=2), 0.0], mass=rng.uniform(0.5, 2),
              com=[*rng.normal(size=2) * 0.3, 0.0], inertia=rng.uniform(0.1, 0.15, size=3), damping=0.1)
        links.append(t.n - 1)
    return t


@pytest.mark.parametrize("seed", range(4))
def test_planar_kernel_equals_the_recursions(seed):
    # ORACLES I6: H, C and point Jacobians equal crba, bias_forces and point_jacobians to roundoff
    rng = np.random.default_rng(seed)
    for tree in (_random_planar_tree(rng, 6), planar_biped(), pendulum_chain(4, [1.0, 0.5, 0.7, 0.3], 1.0)):
        k = PlanarKernel(tree)
        q, qd = rng.normal(size=tree.nv), rng.normal(size=tree.nv)
        H, C, kin = k.dynamics(q, qd)
        scale = 1 + np.abs(crba(tree, q)).max()
        np.testing.assert_allclose(H, crba(tree, q), atol=1e-12 * scale)       # measured ~1e-14
        np.testing.assert_allclose(C, bias_forces(tree, q, qd), atol=1e-11 * scale)
        links = rng.integers(0, tree.n, size=3)
        local = np.column_stack([rng.normal(size=(3, 2)), np.zeros(3)])
        P, J = point_jacobians(tree, q, links, local)
        p = k.point_positions(kin, links, local)
        np.testing.assert_allclose(p, P[:, :2], atol=1e-12)
        np.testing.assert_allclose(k.jacobians(kin, links, p), J[:, :2], atol=1e-11)


def test_bias_acceleration_is_the_time_derivative_of_the_jacobian():
    # ORACLES I6: J̇ q̇ by central differences of J along q̇ (error O(ε²) ≈ 1e-10)
    tree = planar_biped()
    k = PlanarKernel(tree)
    rng = np.random.default_rng(3)
    q, qd = rng.normal(size=9), rng.normal(size=9)
    links, local = np.array([5, 8]), np.array([[0.1, -0.05, 0], [0.0, 0.0, 0]])
    eps = 1e-5

    def J_at(x):
        kin = k.kinematics(x)
        return k.jacobians(kin, links, k.point_positions(kin, links, local))

    Jdot = (J_at(q + eps * qd) - J_at(q - eps * qd)) / (2 * eps)
    kin = k.kinematics(q)
    got = k.bias_acceleration(kin, links, k.point_positions(kin, links, local), qd)
    np.testing.assert_allclose(got, Jdot @ qd, atol=1e-7)


def test_energy_of_the_planar_kernel_matches_the_tree():
    tree = planar_biped()
    k = PlanarKernel(tree)
    q, qd = np.full(9, 0.1), np.full(9, 0.2)
    from pbanim.articulated import kinetic_energy, potential_energy
    assert k.energy(q, qd) == pytest.approx(kinetic_energy(tree, q, qd) + potential_energy(tree, q), abs=1e-9)


def test_trees_that_are_not_planar_are_refused_by_name():
    t = ArticulatedTree(gravity=(0, -9.81, 0))
    t.add("tilted", -1, "revolute", axis=[1, 0, 0], mass=1.0)
    with pytest.raises(NotPlanarError, match="tilted"):
        PlanarKernel(t)
    t = ArticulatedTree(gravity=(0, 0, -9.81))
    t.add("a", -1, "revolute", axis=[0, 0, 1], mass=1.0)
    with pytest.raises(NotPlanarError, match="gravity"):
        PlanarKernel(t)
    t = ArticulatedTree(gravity=(0, -9.81, 0))
    a = t.add("a", -1, "revolute", axis=[0, 0, 1], mass=1.0)
    t.add("slider", a, "prismatic", axis=[1, 0, 0], mass=1.0)
    with pytest.raises(NotPlanarError, match="slider"):
        PlanarKernel(t)
    with pytest.raises(InvalidInput, match="ArticulatedTree"):
        PlanarKernel("tree")


def _box(mass=2.0, half=0.2):
    t = ArticulatedTree(gravity=(0.0, -9.81, 0.0))
    bx = t.add("bx", -1, "prismatic", axis=[1, 0, 0], p=[0, half, 0], mass=1e-6, inertia=np.full(3, 1e-9))
    by = t.add("by", bx, "prismatic", axis=[0, 1, 0], mass=1e-6, inertia=np.full(3, 1e-9))
    t.add("box", by, "revolute", axis=[0, 0, 1], mass=mass, inertia=np.full(3, mass * (2 * half) ** 2 / 6))
    pts = [(2, np.array([-half, -half, 0.0])), (2, np.array([half, -half, 0.0]))]
    return t, pts


@pytest.mark.parametrize("mu, v0", [(0.5, 2.0), (0.3, 1.0)])
def test_sliding_box_decelerates_at_mu_g(mu, v0):
    # ORACLES F3: v(t) = v₀ − μ g t until v₀/(μ g), distance v₀²/(2 μ g); the box never tips or sinks
    tree, pts = _box()
    step = PlanarContactStep(PlanarKernel(tree), pts, PlanarGround(0.0, mu))
    q, qd, h = np.zeros(3), np.array([v0, 0.0, 0.0]), 1e-3
    t_stop = v0 / (mu * 9.81)
    vs = []
    for k in range(int(1.5 * t_stop / h)):
        q, qd = step.step(q, qd, h, np.zeros(3))
        vs.append(qd[0])
    t = h * np.arange(1, len(vs) + 1)
    sliding = t < t_stop - 2 * h
    # the speed follows v₀ − μ g t; the only error is the constraint-force mixing (cfm = 1e-6 of the
    # Delassus diagonal) softening the normal impulse: measured 1e-6 m/s, asserted 1e-5
    np.testing.assert_allclose(np.array(vs)[sliding], v0 - mu * 9.81 * t[sliding], atol=1e-5)
    assert abs(vs[-1]) < 1e-9                                     # stopped, and stays
    # distance: v₀²/(2μg) within one step's travel (h v₀)
    assert q[0] == pytest.approx(v0 ** 2 / (2 * mu * 9.81), abs=h * v0)
    assert abs(q[1]) < 1e-6 and abs(q[2]) < 1e-6


def test_resting_box_on_a_slope_below_the_friction_angle_stays():
    # ORACLES F3 (D6 in the plane): tan α < μ → no sliding; above it slides at g(sin α − μ cos α)
    tree, pts = _box()
    for angle, mu, expect in ((0.2, 0.5, 0.0), (0.4, 0.2, 9.81 * (np.sin(0.4) - 0.2 * np.cos(0.4)))):
        gr = PlanarGround(angle, mu)
        step = PlanarContactStep(PlanarKernel(tree), pts, gr)
        # place the box on the slope: rotate it by the slope angle about its bottom-centre
        q = np.array([-0.2 * np.sin(angle), 0.2 * np.cos(angle) - 0.2, angle])
        qd = np.zeros(3)
        for _ in range(500):
            q, qd = step.step(q, qd, 1e-3, np.zeros(3))
        speed_along = qd[:2] @ gr.tangent
        assert -speed_along == pytest.approx(expect * 0.5, rel=2e-2, abs=1e-6)


def test_planar_contact_solver_meets_the_conditions():
    # ORACLES D8-like certificate on random contact problems: z ≥ 0 ⊥ w ≥ 0 and |zₜ| ≤ μ zₙ with modes
    rng = np.random.default_rng(0)
    for trial in range(30):
        m = int(rng.integers(1, 5))
        G = rng.normal(size=(2 * m, 2 * m + 2))
        A = G @ G.T + 1e-3 * np.eye(2 * m)
        b = rng.normal(size=2 * m)
        mu = float(rng.uniform(0.1, 1.0))
        z, modes, info = solve_planar_contact(A, b, mu)
        w = A @ z + b
        if info["path"] == "pgs":
            continue
        zn, zt, wn, wt = z[0::2], z[1::2], w[0::2], w[1::2]
        assert np.all(zn >= -1e-9) and np.all(wn >= -1e-9) and np.all(np.abs(zn * wn) < 1e-8)
        assert np.all(np.abs(zt) <= mu * zn + 1e-9)
        stick = modes == STICK
        assert np.all(np.abs(wt[stick]) < 1e-8)
        assert np.all(wt[modes == SLIDE_POS] >= -1e-9) and np.all(wt[modes == SLIDE_NEG] <= 1e-9)
        assert np.all(zn[modes == SEPARATE] == 0)


@settings(max_examples=25, deadline=None)
@given(st.lists(st.floats(-10, 10), min_size=9, max_size=9), st.lists(st.floats(-10, 10), min_size=9, max_size=9))
def test_biped_step_is_finite_for_any_state(q, qd):
    tree = planar_biped()
    step = PlanarContactStep(PlanarKernel(tree), biped_contact_points(tree))
    q1, u1 = step.step(np.array(q), np.array(qd), 1e-3, np.zeros(9))
    assert np.all(np.isfinite(q1)) and np.all(np.isfinite(u1))


def test_bad_contact_input_is_named():
    tree, pts = _box()
    k = PlanarKernel(tree)
    with pytest.raises(InvalidInput, match="points"):
        PlanarContactStep(k, [])
    with pytest.raises(InvalidInput, match="points\\[0\\] link must be a link index in 0..2, got 7"):
        PlanarContactStep(k, [(7, [0, 0, 0])])
    with pytest.raises(InvalidInput, match="friction"):
        PlanarGround(0.0, -1.0)
    with pytest.raises(InvalidInput, match="angle"):
        PlanarGround(2.0)


# --------------------------------------------------------------------------------------------------
# The lean contact step (pbanim.articulated.planar_lean) takes the readable step's arithmetic, bit for bit
# --------------------------------------------------------------------------------------------------
def _lean_pair(tree, pts, ground=None):
    from pbanim.articulated.planar_lean import LeanPlanarStep

    readable = PlanarContactStep(PlanarKernel(tree), pts, ground)
    twin = PlanarContactStep(PlanarKernel(tree), pts, ground)
    return readable, LeanPlanarStep(twin)


def _lean_step(lean, q, qd, h, tau, kd=None):
    kin = lean.kinematics(q)
    return lean.step(q, qd, h, tau, kd, kin, lean.com_jacobians(kin[2], kin[3]))


@settings(max_examples=40, deadline=None)
@given(st.integers(0, 10 ** 6), st.sampled_from([0.0, 0.05, -0.2]), st.sampled_from([1e-3, 4e-3]),
       st.booleans())
def test_lean_contact_step_equals_the_readable_step(seed, slope, h, servo_gains):
    # ORACLES I6 (the kernel's closed forms) and F3 (the contact step): the lean step is the readable one's
    # arithmetic, operation for operation: equal states, contact sets and modes, bit for bit, over 40 steps
    # of a biped dropped near the ground (contacts touching, sliding, separating; modes switched)
    rng = np.random.default_rng(seed)
    tree = planar_biped()
    readable, lean = _lean_pair(tree, biped_contact_points(tree), PlanarGround(slope, 0.6))
    q = rng.normal(scale=0.15, size=9)
    q[1] = rng.uniform(-0.03, 0.05) + np.tan(slope) * q[0]
    qd = rng.normal(scale=0.5, size=9)
    q2, qd2 = q.copy(), qd.copy()
    kd = rng.uniform(0, 30, size=9) * (np.arange(9) >= 3) if servo_gains else None
    for _ in range(40):
        tau = rng.normal(scale=20.0, size=9) * (np.arange(9) >= 3)
        q, qd = readable.step(q, qd, h, tau, kd)
        q2, qd2, near, z = _lean_step(lean, q2, qd2, h, tau, kd)
        assert np.array_equal(q, q2) and np.array_equal(qd, qd2)
        assert np.array_equal(near, readable.last["near"]) and np.array_equal(readable.modes, lean.modes)
        if near.size:
            assert np.array_equal(z, readable.last["impulses"])


def test_lean_contact_step_hands_what_it_cannot_take_to_the_readable_step():
    # a state that overflows the step: the readable step's named error, not a NaN state
    from pbanim.errors import NonFiniteResult

    tree = planar_biped()
    readable, lean = _lean_pair(tree, biped_contact_points(tree))
    q, qd = np.zeros(9), np.zeros(9)
    qd[3] = 1e200
    with np.errstate(over="ignore", invalid="ignore"):      # the readable step's overflow, named
        with pytest.raises(NonFiniteResult, match="planar step"):
            readable.step(q, qd, 1e-3, np.zeros(9))
        with pytest.raises(NonFiniteResult, match="planar step"):
            _lean_step(lean, q, qd, 1e-3, np.zeros(9))


@settings(max_examples=60, deadline=None)
@given(st.integers(0, 10 ** 6), st.integers(1, 4), st.sampled_from([0.0, 0.3, 0.9]))
def test_lean_mode_switching_equals_the_readable_solve(seed, m, mu):
    # ORACLES F24 (and F3: the contact step's LCP core): the lean step's rounds of solve_planar_contact (the
    # modes imposed, checked and switched on Python floats) give the readable solve's impulses and modes bit
    # for bit whenever they answer; they answer for most problems, switching modes in many of them
    from pbanim.articulated.planar_lean import LeanPlanarStep
    from pbanim.lcp.planar import solve_planar_contact

    rng = np.random.default_rng(seed)
    tree = planar_biped()
    lean = LeanPlanarStep(PlanarContactStep(PlanarKernel(tree), biped_contact_points(tree), PlanarGround(0.0, mu)))
    answered = switched = 0
    for _ in range(20):
        G = rng.normal(size=(2 * m, 3))
        A = G @ G.T + rng.uniform(1e-3, 1.0) * np.eye(2 * m)
        b = rng.normal(size=2 * m)
        guess = tuple(int(x) for x in rng.integers(0, 4, size=m))
        z, modes = lean._modes_solve(A, b, b.tolist(), guess)
        if z is None:
            continue
        zr, mr, info = solve_planar_contact(A, b, mu, np.array(guess))
        assert info["path"] in ("guess", "modes")
        assert np.array_equal(z, zr) and tuple(modes) == tuple(mr.tolist())
        answered += 1
        switched += info["path"] == "modes"
    assert answered >= 10
    assert switched >= 1 or mu == 0.0 and m == 1
