"""The lean modified PCG (pbanim/cloth/lean_pcg.py) gives the readable PCG's steps bit for bit (ORACLES J13):
large steps with pins and contacts (Jacobi, the drape's setting), with the line multigrid, and Newton steps."""

import numpy as np
import pytest

from pbanim.cloth import Cloth, Ground, Sheet, Sphere, large_step, newton_step
from pbanim.cloth.collide import contacts


def _drape(n=8):
    return Cloth(Sheet(n, pins="corners"), model="bw", stretch=500.0, shear=50.0, bend=1e-3, damping=0.02,
                 colliders=[Sphere([0.0, 0.0, -0.2], 0.3), Ground(-0.5)])


def _run(cloth, lean, steps, **kw):
    cloth.lean_path, cloth.lean_terms = lean, False     # the same (readable) bend, triangle terms: the CGs compared
    y, out = cloth.state(), []
    for _ in range(steps):
        y, sol = large_step(cloth, y, 1.0 / 60.0, **kw)
        out.append((y.copy(), sol.iterations, sol.residual, sol.converged))
    return out


@pytest.mark.parametrize("kw", [{}, {"tol": 1e-2, "precond": "multigrid"}, {"tol": 1e-2, "precond": "multigrid-l1"}])
def test_lean_large_steps_equal_the_readable_ones_bit_for_bit(kw):
    cloth = _drape()
    lean, readable = _run(cloth, True, 40, **kw), _run(cloth, False, 40, **kw)
    touched = 0
    for (ya, ia, ra, ca), (yb, ib, rb, cb) in zip(lean, readable):
        assert np.array_equal(ya, yb) and (ia, ra, ca) == (ib, rb, cb)
        x, v = ya[:cloth.n].reshape(-1, 3), ya[cloth.n:].reshape(-1, 3)
        touched += len(contacts(cloth.colliders, x, v, cloth.thickness)[0])
    assert touched > 0                         # particles touched the sphere: contact rows were filtered


def test_lean_newton_step_equals_the_readable_one():
    cloth = _drape()
    cloth.lean_terms = False
    y = cloth.state()
    for _ in range(5):
        y, _ = large_step(cloth, y, 1.0 / 60.0)
    cloth.lean_path = True
    a = newton_step(cloth, y, 1.0 / 60.0, tol=1e-8, cg_tol=1e-8)
    cloth.lean_path = False
    b = newton_step(cloth, y, 1.0 / 60.0, tol=1e-8, cg_tol=1e-8)
    assert np.array_equal(a[0], b[0]) and a[1] == b[1]


def test_the_readable_path_is_taken_when_asked(monkeypatch):
    import pbanim.cloth.large_steps as ls
    calls = []
    monkeypatch.setattr(ls, "lean_pcg", lambda *a: calls.append(1) or (_ for _ in ()).throw(AssertionError))
    cloth = _drape(4)
    cloth.lean_path = False
    large_step(cloth, cloth.state(), 1.0 / 60.0)
    assert not calls
