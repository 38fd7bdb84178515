"""The point kinematics derived once per structure (ORACLES B9): the cached derivation shared by
ReducedSystem.from_sympy and derive_equations equals a fresh point_kinematics, in fresh lists, and the
systems built after a cache hit compute bit for bit what those built with an empty cache compute."""

import numpy as np
import pytest
import sympy as sp

from pbanim.errors import InvalidInput
from pbanim.particles import Gravity
from pbanim.reduced import ReducedSystem, point_kinematics
from pbanim.reduced import chart
from pbanim.reduced.lagrangian import compile_equations, derive_equations


def _chain(n, moving=False):
    u = sp.symbols(f"a0:{n}")
    t = sp.Symbol("t") if moving else None
    x, y, pos = (sp.sin(t) / 3 if moving else 0), 0, []
    for k in range(n):
        x, y = x + sp.sin(u[k]), y - sp.cos(u[k])
        pos.append([x, y])
    return list(u), pos, t


def _same(a, b):
    assert a.coords == b.coords and a.speeds == b.speeds
    assert a.J == b.J and a.qdot == b.qdot and a.b == b.b
    assert a.J_terms == b.J_terms and a.b_terms == b.b_terms


@pytest.mark.parametrize("moving", [False, True])
def test_cached_equals_fresh_and_lists_are_fresh(moving):
    # ORACLES B9: term by term equal to the readable derivation, for a fixed and a moving (t) chart
    u, pos, t = _chain(3, moving)
    flat = [e for r in pos for e in r]
    chart._KINEMATICS.clear()
    first = chart._point_kinematics_cached(flat, u, t)
    second = chart._point_kinematics_cached(flat, u, t)
    _same(first, point_kinematics(flat, u, t))
    _same(second, point_kinematics(flat, u, t))
    assert len(chart._KINEMATICS) == 1
    second.J[0][0] = sp.Integer(7)          # an edit by one caller ...
    second.b_terms[0].append(sp.Integer(1))
    _same(chart._point_kinematics_cached(flat, u, t), point_kinematics(flat, u, t))   # ... is not seen by the next
    slow = chart._point_kinematics_cached(flat, u, t, lean=False)
    _same(slow, first)


def test_keys_tell_structures_apart():
    # ORACLES B9: other coords, another t or other positions are other entries
    u, pos, t = _chain(2)
    flat = [e for r in pos for e in r]
    chart._KINEMATICS.clear()
    a = chart._point_kinematics_cached(flat, u)
    tt = sp.Symbol("t")
    b = chart._point_kinematics_cached(flat, u, tt)
    v = sp.symbols("b0:2")
    c = chart._point_kinematics_cached([e.subs(dict(zip(u, v))) for e in flat], v)
    d = chart._point_kinematics_cached([2 * e for e in flat], u)
    assert len(chart._KINEMATICS) == 4
    assert a.speeds != c.speeds and c.J == point_kinematics([e.subs(dict(zip(u, v))) for e in flat], v).J
    assert d.J[0][0] == 2 * a.J[0][0]
    _same(b, point_kinematics(flat, u, tt))
    with pytest.raises(InvalidInput):       # a string is never cached: the readable path's check sees it
        chart._point_kinematics_cached(["sin(a0)", "x"], u)


def _systems(n):
    u, pos, _ = _chain(n)
    red = ReducedSystem.from_sympy(pos, u, [1.0] * n, forces=[Gravity()], u0=np.linspace(0.3, 0.7, n))
    eqs = derive_equations(u, [(1.0, p) for p in pos], gravity=[0.0, -9.81])
    return red, compile_equations(eqs)


def test_systems_after_a_hit_equal_those_from_an_empty_cache():
    # ORACLES B9: bit for bit (0 ulp) rhs and mass matrix, the Lagrangian built second (a cache hit)
    rng = np.random.default_rng(3)
    ys = rng.uniform(-2, 2, (5, 8))
    chart._KINEMATICS.clear()
    red_a, lag_a = _systems(4)
    hits = len(chart._KINEMATICS)
    chart._KINEMATICS.clear()
    u, pos, _ = _chain(4)
    lag_b = compile_equations(derive_equations(u, [(1.0, p) for p in pos], gravity=[0.0, -9.81]))
    chart._KINEMATICS.clear()
    red_b = ReducedSystem.from_sympy(pos, u, [1.0] * 4, forces=[Gravity()], u0=np.linspace(0.3, 0.7, 4))
    assert hits == 1
    for y in ys:
        assert np.array_equal(red_a.rhs(0.0, y), red_b.rhs(0.0, y))
        assert np.array_equal(lag_a.rhs(0.0, y), lag_b.rhs(0.0, y))
        assert np.array_equal(lag_a.mass_matrix(y[:4]), lag_b.mass_matrix(y[:4]))


@pytest.mark.parametrize("moving", [False, True])
def test_term_by_term_derivatives_equal_whole_expression_derivatives(moving):
    # ORACLES B9: J = ∂q/∂u, q̇ = Ju̇ + ∂q/∂t and b = Σ ∂²q/∂u_j∂u_k u̇_j u̇_k + 2 ∂²q/∂u_j∂t u̇_j + ∂²q/∂t²
    # taken by sympy on each whole position (the derivative memo shares terms repeated along the chain)
    u, pos, t = _chain(4, moving)
    flat = [e for r in pos for e in r]
    k = point_kinematics(flat, u, t)
    ud = k.speeds
    for i, q in enumerate(flat):
        for j, c in enumerate(u):
            assert sp.expand(k.J[i][j] - sp.diff(q, c)) == 0
        qt = sp.diff(q, t) if t is not None else 0
        assert sp.expand(k.qdot[i] - sum(sp.diff(q, c) * s for c, s in zip(u, ud)) - qt) == 0
        b = sum(sp.diff(q, a, c) * sa * sc for a, sa in zip(u, ud) for c, sc in zip(u, ud))
        if t is not None:
            b += 2 * sum(sp.diff(q, a, t) * sa for a, sa in zip(u, ud)) + sp.diff(q, t, 2)
        assert sp.expand(k.b[i] - b) == 0
