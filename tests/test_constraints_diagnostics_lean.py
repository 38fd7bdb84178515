"""A small constraint set's diagnostics (C_max, Ċ_max, λ at each recorded state) take the dense solve of its
step (pbanim.constraints.dense) and equal the readable solve's to roundoff (ORACLES B5); the solve of the last
step (``Constraints.last``) is not changed by reading them."""

import numpy as np
import pytest

from pbanim.constraints import Constraints
from pbanim.models.constrained import hanging_chain
from pbanim.particles import Gravity
from pbanim.scene import Scene

EPS = np.finfo(float).eps


@pytest.mark.parametrize("stabilization", ["none", "baumgarte", "projection"])
def test_dense_diagnostics_equal_the_readable_ones(stabilization):
    mod = hanging_chain(4, link_length=0.25, angle=np.pi / 2)
    kw = {"natural_frequency": 30.0} if stabilization == "baumgarte" else {}
    eff = Constraints(mod.constraints, stabilization=stabilization, **kw)
    scene = Scene(mod.system, [Gravity(mod.g), eff])
    assert eff._dense is not None
    res = scene.simulate(0.2, 5e-3, "rk4")
    lean = {k: np.asarray(res.diagnostics[k]) for k in ("C_max", "Cdot_max", "lam")}
    eff.lean_path = False
    readable = [eff.diagnostics(t, y) for t, y in zip(res.t, res.y.T)]
    eff.lean_path = True
    lam = np.array([d["lam"] for d in readable])
    assert np.abs(lean["lam"] - lam).max() <= 64 * EPS * np.abs(lam).max()
    for k in ("C_max", "Cdot_max"):
        ref = np.array([d[k] for d in readable])
        # C by the same kinds' formulas: to roundoff of the positions (the chain's links have unit scale)
        assert np.abs(lean[k] - ref).max() <= 64 * EPS * (1.0 + np.abs(res.y).max()), k
    assert lean["C_max"].max() > 0 and np.abs(lam).max() > 0


def test_reading_diagnostics_keeps_the_last_solve():
    mod = hanging_chain(3, link_length=1.0 / 3, angle=0.4)
    eff = Constraints(mod.constraints)
    scene = Scene(mod.system, [Gravity(mod.g), eff])
    y = scene.step(0.0, mod.system.state(), 1e-3, "rk4")
    scene.rhs(0.0, y)
    before = eff.last.lam.copy()
    d = eff.diagnostics(0.0, mod.system.state())          # another state: another λ
    assert np.abs(d["lam"] - before).max() > 1e-6
    np.testing.assert_array_equal(eff.last.lam, before)
