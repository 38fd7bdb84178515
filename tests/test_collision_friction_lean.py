"""The lean staggered friction pass of the simultaneous impulse rounds is the readable pass (ORACLES D22)."""

import numpy as np
import pytest

from pbanim.collision import Box, Collisions, Contacts, ImpulseBodies, Plane, resolve_collisions
from pbanim.collision import simultaneous
from pbanim.rigid.quat import quat_from_axis_angle


def _cluster(rng, B: int):
    """B bodies in a row touching their neighbours and the ground (a world contact each), random masses,
    inertias, velocities and spins; contacts pushed together so the rounds give friction impulses."""
    x = np.column_stack([np.arange(B) * 0.5, rng.normal(0, 0.02, B), 0.2 + rng.uniform(0, 0.01, B)])
    v = rng.normal(0, 1, (B, 3)) + [0.0, 0.0, -1.0]
    om = rng.normal(0, 3, (B, 3))
    Q = rng.normal(size=(B, 3, 3))
    inv_I = np.einsum("kij,kj,klj->kil", np.linalg.qr(Q)[0], rng.uniform(0.5, 5, (B, 3)), np.linalg.qr(Q)[0])
    inv_I = 0.5 * (inv_I + inv_I.transpose(0, 2, 1))
    bodies = ImpulseBodies.make(x, v, rng.uniform(0.2, 3.0, B), omega=om, inv_I=inv_I)
    a, b, point, normal = [], [], [], []
    for i in range(B):                              # the ground under each body: n = +z, from the world (b = −1)
        for dx in (-0.1, 0.1):
            a.append(i), b.append(-1), point.append(x[i] + [dx, 0.05 * dx, -0.2]), normal.append([0, 0, 1.0])
    for i in range(B - 1):                          # neighbours: n from i + 1 towards i, slightly tilted
        n = np.array([-1.0, rng.normal(0, 0.1), rng.normal(0, 0.1)])
        a.append(i), b.append(i + 1), point.append(0.5 * (x[i] + x[i + 1])), normal.append(n / np.linalg.norm(n))
    return bodies, Contacts(a, b, point, normal, np.zeros(len(a)))


@pytest.mark.parametrize("seed", range(12))
@pytest.mark.parametrize("mode", ["simultaneous", "sequential"])
def test_lean_friction_pass_is_the_readable_pass_bit_for_bit(seed, mode):
    # D22: the same impulses, velocities, sticking flags and rounds, bit for bit (the same operations in the
    # same order), on clusters with world contacts and body–body contacts, ε and μ random
    rng = np.random.default_rng(seed)
    bodies, c = _cluster(rng, int(rng.integers(2, 6)))
    eps, mu = float(rng.uniform(0, 1)), float(rng.uniform(0.1, 1.0))
    out = {}
    for lean in (False, True):
        b = ImpulseBodies(bodies.x.copy(), bodies.v.copy(), bodies.omega.copy(), bodies.inv_mass.copy(),
                          bodies.inv_I.copy())
        out[lean] = resolve_collisions(b, c, eps, mu, mode, 0.05, lean=lean)
    fast, slow = out[True], out[False]
    assert np.any(slow.impulse - slow.normal_impulse[:, None] * c.normal)     # friction acted
    for name in ("v", "omega", "impulse", "normal_impulse", "sticking"):
        assert np.array_equal(getattr(fast, name), getattr(slow, name)), name
    assert fast.extra == slow.extra and fast.energy_after == slow.energy_after


def test_lean_pass_runs_and_a_wrong_one_is_seen(monkeypatch):
    # the lean path is the one taken by default, and a pass that differs by one rounding is caught above
    rng = np.random.default_rng(3)
    bodies, c = _cluster(rng, 3)
    calls = []
    real = simultaneous._staggered_lean
    monkeypatch.setattr(simultaneous, "_staggered_lean", lambda *a: calls.append(1) or real(*a))
    resolve_collisions(bodies, c, 0.3, 0.5, "simultaneous", 0.05)
    assert calls


def test_tumbling_boxes_lean_run_is_the_readable_run():
    # D22 on the chapter 06 scene (three boxes tumbling onto the ground, ε = 0.3, μ = 0.5): the whole run with
    # the lean pass equals the run with lean_path = False bit for bit, landings and friction included
    from pbanim.rigid import RigidBodies, RigidGravity, RigidScene
    rng = np.random.default_rng(11)
    n = 3
    shapes = [Box(rng.uniform(0.15, 0.3, 3)) for _ in range(n)]
    q = np.array([quat_from_axis_angle(rng.normal(size=3), rng.uniform(0, np.pi)) for _ in range(n)])
    x = np.array([[-0.9 + 0.9 * i, 0.0, 0.5 + 0.3 * i] for i in range(n)])
    masses = np.array([8 * np.prod(s.half_extents) * 500 for s in shapes])
    runs = []
    for lean in (True, False):
        rb = RigidBodies(masses, np.array([s.inertia(m) for s, m in zip(shapes, masses)]), positions=x,
                         orientations=q, velocities=[[0.5, 0, 0], [0, 0, 0], [-0.5, 0, 0]],
                         angular_velocities=np.random.default_rng(5).normal(size=(n, 3)))
        col = Collisions(shapes, obstacles=[Plane()], restitution=0.3, friction=0.5, mode="simultaneous")
        col.lean_path = lean
        runs.append(RigidScene(rb, [RigidGravity(), col]).simulate(0.8, 0.004))
    assert runs[0].diagnostics["contacts"].max() > 0
    assert np.array_equal(runs[0].y, runs[1].y)
