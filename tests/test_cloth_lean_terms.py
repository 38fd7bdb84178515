"""The lean bend and triangle terms (pbanim/cloth/lean_terms.py) equal the readable ones to roundoff (ORACLES
J14): the element terms f_e, K_e, D_e of every hinge and triangle, and the f and the data of K and D a large
step assembles from them."""

import numpy as np
import pytest

from pbanim.cloth import Cloth, Ground, Sheet, Sphere, large_step
from pbanim.cloth.lean_terms import bend_terms, triangle_terms

EPS = np.finfo(float).eps
TOL = 64 * EPS                  # of the largest entry of each array (ORACLES J14)


def _cloth(n=8, damping=0.02):
    return Cloth(Sheet(n, pins="corners"), model="bw", stretch=500.0, shear=50.0, bend=1e-3, damping=damping,
                 colliders=[Sphere([0.0, 0.0, -0.2], 0.3), Ground(-0.5)])


def _crumpled(cloth, seed):
    """x, v (N, 3): the rest sheet moved by a third of a spacing at random (every hinge bent), random v."""
    rng = np.random.default_rng(seed)
    x0 = cloth.sheet.x0
    x = x0 + rng.uniform(-1.0, 1.0, x0.shape) * cloth.sheet.spacing / 3.0
    return x, rng.normal(size=x0.shape)


def _close(a, b):
    return np.abs(a - b).max() <= TOL * np.abs(b).max()


@pytest.mark.parametrize("damping", [0.02, 0.0])
@pytest.mark.parametrize("seed", [0, 1])
def test_lean_bend_terms_equal_the_readable_ones(damping, seed):
    cloth = _cloth(damping=damping)
    bend = cloth.conditions[1]
    x, v = _crumpled(cloth, seed)
    fe, Ke, De = bend.terms(x, v, True, False)
    lf, lK, lD = bend_terms(bend, x, v, exact=False)
    assert np.abs(Ke).max() > 0 and np.abs(fe).max() > 0
    assert _close(lf, fe) and _close(lK, Ke)
    assert (De is None and lD is None) if damping == 0 else _close(lD, De)


@pytest.mark.parametrize("damping", [0.02, 0.0])
@pytest.mark.parametrize("seed", [0, 1])
def test_lean_triangle_terms_equal_the_readable_ones(damping, seed):
    cloth = _cloth(damping=damping)
    tri = cloth.conditions[0]
    x, v = _crumpled(cloth, seed)
    fe, Ke, De = tri.terms(x, v, True, False)
    lf, lK, lD = triangle_terms(tri, x, v)
    s = tri.k * tri.evaluate(x, hessian=False)[0]
    assert (s[:, :2] < 0).any() and (s[:, :2] > 0).any()       # stretched and compressed: the clamp at 0 is seen
    assert _close(lf, fe) and _close(lK, Ke)
    assert (De is None and lD is None) if damping == 0 else _close(lD, De)


def test_lean_assembly_of_a_draping_sheet_equals_the_readable_one():
    cloth = _cloth()
    y = cloth.state()
    for _ in range(30):                        # folds over the sphere: bent hinges, contacts
        y, _ = large_step(cloth, y, 1.0 / 60.0)
    x, v = y[:cloth.n].reshape(-1, 3), y[cloth.n:].reshape(-1, 3)
    lean = cloth._all(x, v, exact=False)
    cloth.lean_terms = False
    readable = cloth._all(x, v, exact=False)
    for a, b in zip(lean, readable):
        assert _close(a, b)
    assert not all(np.array_equal(a, b) for a, b in zip(lean, readable))   # the lean twin was taken


def test_the_exact_jacobians_stay_the_readable_ones():
    cloth = _cloth()
    x, v = _crumpled(cloth, 2)
    lean = cloth._all(x, v, exact=True)
    cloth.lean_terms = False
    assert all(np.array_equal(a, b) for a, b in zip(lean, cloth._all(x, v, exact=True)))


@pytest.mark.parametrize("flag", ["lean_path", "lean_terms"])
def test_the_readable_bend_assembly_is_taken_when_asked(monkeypatch, flag):
    import pbanim.cloth.model as model
    monkeypatch.setattr(model, "bend_data", lambda *a: (_ for _ in ()).throw(AssertionError("lean taken")))
    cloth = _cloth(4)
    setattr(cloth, flag, False)
    large_step(cloth, cloth.state(), 1.0 / 60.0)
