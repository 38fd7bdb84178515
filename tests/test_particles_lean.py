"""The fused float run of a small particle scene (pbanim.particles.lean_run; ORACLES D17, D2, A16)."""

from __future__ import annotations

import numpy as np
import pytest

from pbanim.collision import Collisions, Plane

EPS = np.finfo(float).eps


def _scene(kind: str, seed: int = 0):
    """The cradle of D2, or a few balls of random masses, radii and velocities thrown about a box (2-D) or
    dropped on a floor (3-D) under gravity: impacts between balls and with the walls in the first steps."""
    from pbanim.particles import Gravity, ParticleSystem
    from pbanim.scene import Scene

    rng = np.random.default_rng(seed)
    if kind == "cradle":
        ps = ParticleSystem([[0.0, 0.0], [1.05, 0.0], [2.05, 0.0]], [[1.0, 0.0], [0.0, 0.0], [0.0, 0.0]])
        return Scene(ps, [Collisions(radius=0.5, restitution=1.0, gravity=0.0)])
    n = int(rng.integers(2, 6))
    if kind == "2-D":
        x = np.column_stack([0.6 + 1.1 * np.arange(n), 0.6 + rng.uniform(0, 1, n)])
        walls = [Plane([0, 1]), Plane([1, 0]), Plane([-1, 0], offset=-1.1 * n - 0.6)]
    else:
        x = np.column_stack([0.3 * rng.normal(size=(n, 2)), 0.6 + 1.1 * np.arange(n)])
        walls = [Plane([0, 0, 1.0])]
    ps = ParticleSystem(x, rng.normal(size=x.shape) * 3, masses=rng.uniform(0.5, 2.0, n))
    return Scene(ps, [Gravity(), Collisions(obstacles=walls, radius=rng.uniform(0.2, 0.5, n),
                                            restitution=float(rng.uniform(0.3, 1.0)))])


def _three(kind: str, seed: int, T: float, **kw):
    """(fused, stepped, readable) runs of one scene: the fused float run (diagnostics=False), the float plan
    called step by step through the driver (the same plan, diagnostics read during the run) and the readable
    step on arrays (the scene's and the effect's lean paths off)."""
    out = []
    for mode in ("fused", "stepped", "readable"):
        s = _scene(kind, seed)
        if mode == "readable":
            s.lean_path = s.effects[-1].lean_path = False
        res = s.simulate(T, 1e-3, "symplectic_euler", diagnostics=mode != "fused", **kw)
        out.append((s, res))
    return out


@pytest.mark.parametrize("kind, seed, T", [("cradle", 0, 0.3), ("2-D", 1, 0.3), ("2-D", 2, 0.3), ("3-D", 3, 0.3),
                                           ("3-D", 4, 0.3)])
def test_the_fused_run_is_the_stepped_float_run_and_the_readable_one(kind, seed, T):
    # ORACLES D17: the fused run (kick, drift, contacts, impulses, projection in one loop) is the float plan's
    # arithmetic, call for call: its states equal the stepped float run's (bit for bit up to the sign of a zero)
    # and the readable run's to 4 ulps per step of the state's scale; the same impacts logged, the same last
    # response, one evaluation of f per step
    from pbanim.ode import get_method

    (sf, f), (ss, st), (sr, rd) = _three(kind, seed, T)
    assert callable(getattr(sf._advance(get_method("symplectic_euler"), [0, 0]), "run", None))
    np.testing.assert_array_equal(f.y, st.y)
    scale = max(1.0, float(np.abs(rd.y).max()))
    assert np.abs(f.y - rd.y).max() <= 4 * EPS * f.nsteps * scale
    assert f.nfev == st.nfev == rd.nfev == f.nsteps
    cf, cs, cr = sf.effects[-1], ss.effects[-1], sr.effects[-1]
    assert len(cf.log) == len(cs.log) == len(cr.log) > 0
    assert [d["t"] for d in cf.log] == [d["t"] for d in cr.log]
    assert [d["regime"] for d in cf.log] == [d["regime"] for d in cr.log]
    assert (cf.last is None) == (cr.last is None)
    if cf.last is not None:                 # the run's last response, as the readable step left it
        np.testing.assert_array_equal(cf.last.regime, cr.last.regime)
        np.testing.assert_allclose(cf.last.normal_impulse, cr.last.normal_impulse, rtol=0, atol=1e-15 * scale)
    if kind == "cradle":                    # ORACLES D2: the sequential law leaves (0, 0, v0)
        np.testing.assert_allclose(f.y[6:12:2, -1], [0.0, 0.0, 1.0], atol=1e-15)


def test_the_fused_run_records_the_sample_times_only():
    # ORACLES D17: with record_every = 7 the fused run keeps the states the driver keeps (every 7th step and the
    # last), equal to the stepped run's recorded at every step, at those steps
    (_, f), (_, st), _ = _three("2-D", 5, 0.1, record_every=7)
    s = _scene("2-D", 5)
    every = s.simulate(0.1, 1e-3, "symplectic_euler", diagnostics=True)
    idx = list(range(0, every.nsteps + 1, 7)) + ([every.nsteps] if every.nsteps % 7 else [])
    np.testing.assert_array_equal(f.t, st.t)
    np.testing.assert_array_equal(f.y, every.y[:, idx])


def test_the_fused_run_of_springs_is_the_stepped_float_run():
    # ORACLES A16, D17: a scene with no post-step stage (gravity, drag, anchors and a chain of springs) takes
    # the fused run of the float plan's step: the stepped run's states, bit for bit
    from pbanim.particles import AnchorSprings, DampedSprings, Drag, Gravity, ParticleSystem
    from pbanim.scene import Scene

    def scene():
        ps = ParticleSystem([[0.0, 0.0], [1.0, 0.1], [2.1, -0.2], [3.0, 0.0]], masses=[1.0, 0.5, 2.0, 1.0])
        return Scene(ps, [Gravity(), Drag(0.1), AnchorSprings([0], [[0.0, 0.0]], 50.0, 0.5),
                          DampedSprings([(0, 1), (1, 2), (2, 3)], 80.0, 0.3)])

    a = scene().simulate(0.5, 1e-3, "symplectic_euler", diagnostics=False)
    b = scene().simulate(0.5, 1e-3, "symplectic_euler", diagnostics=True)
    r = scene()
    r.lean_path = False
    c = r.simulate(0.5, 1e-3, "symplectic_euler", diagnostics=False)
    np.testing.assert_array_equal(a.y, b.y)
    assert np.abs(a.y - c.y).max() <= 4 * EPS * a.nsteps * max(1.0, float(np.abs(c.y).max()))
    assert a.nfev == c.nfev == a.nsteps


def test_a_diverging_fused_run_names_the_step_the_readable_run_names():
    # a ball launched at 3e152 m/s, recorded every 5th step and checked every 3rd: the fused run names the step
    # and time the readable run names (the check's own step), and never returns NaN
    from pbanim.errors import SimulationDiverged

    messages = []
    for lean in (True, False):
        s = _scene("cradle")
        s.lean_path = s.effects[-1].lean_path = lean
        y0 = s.system.state()
        y0[6] = 3e152
        with pytest.raises(SimulationDiverged) as info:
            s.simulate(100.0, 1.0, "symplectic_euler", diagnostics=False, record_every=5, check_every=3, y0=y0)
        messages.append(str(info.value))
    assert messages[0] == messages[1] and "step" in messages[0]
