"""The stiff ODE solvers on the cloth with the Jacobian in blocks: stage systems solved at half size (ORACLES J7).

J = [[0, I], [Jx, Jv]] of a second-order system: (σI − J)⁻¹ through the n × n Schur complement
S = σ²I − σJv − Jx equals the 2n × 2n sparse LU to roundoff, RODAS4 and Radau IIA run the same steps with
either, and the methods keep their orders (fitted slopes).
"""

import numpy as np
import pytest
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from pbanim.cloth import Cloth, Sheet
from pbanim.cloth.assembly import free_ode, second_order_jac
from pbanim.errors import InvalidInput
from pbanim.ode import solve
from pbanim.ode.radau import radau5_step
from pbanim.ode.rosenbrock import rodas4_step
from pbanim.ode.second_order import SecondOrderJacobian
from pbanim.testing import order_fit

EPS = np.finfo(float).eps


def _cloth(n=5):
    return Cloth(Sheet(n, pins="corners"), stretch=1e3, shear=1e2, bend=0.1, damping=1e-3)


def _bent_state(cloth, seed=0):
    rng = np.random.default_rng(seed)
    yf = cloth.free_state(cloth.state())
    yf += 0.02 * rng.standard_normal(yf.size)                  # positions off the plane, random velocities
    return yf


def test_block_jacobian_is_the_cloth_jacobian():
    # ORACLES J1, J7: the gather of W K_FF, W D_FF gives Cloth.jac's [[0, I], [W K, W D]] entry for entry
    cloth = _cloth()
    yf = _bent_state(cloth)
    J = second_order_jac(cloth)(0.0, yf)
    full = cloth.jac(0.0, yf)
    assert J.shape == full.shape
    x, v = cloth._split(yf)
    _, kd, dd = cloth._all(x, v)
    exact = SecondOrderJacobian(*cloth._jac_free.blocks(kd, dd))      # the readable gather: entry for entry
    assert abs(exact.tocsr() - full).max() == 0.0
    # the one-pass springs (ORACLES J11): the same entries to roundoff
    assert abs(J.tocsr() - full).max() <= 8 * EPS * abs(full).max()
    r = np.random.default_rng(1).standard_normal(full.shape[0])
    assert np.abs(J @ r - full @ r).max() <= 8 * EPS * np.abs(full).max() * np.abs(r).max()


@pytest.mark.parametrize("sigma", [240.0, 4.0, complex(2.68, -3.05) * 60.0])
def test_schur_solve_equals_full_solve_to_roundoff(sigma):
    # ORACLES J7: block elimination is exact; the two LUs differ by roundoff, κ(σI − J)·ε relative
    cloth = _cloth()
    J = second_order_jac(cloth)(0.0, _bent_state(cloth))
    n2 = J.shape[0]
    full = (sigma * sp.identity(n2, format="csc", dtype=complex if np.iscomplexobj(sigma) else float)
            - J.tocsr()).tocsc()
    r = np.random.default_rng(2).standard_normal(n2)
    x_full = spla.splu(full).solve(r.astype(full.dtype))
    x = J.factor(sigma)(r.astype(full.dtype))
    kappa = np.linalg.cond(full.toarray())
    rel = np.abs(x - x_full).max() / np.abs(x_full).max()
    assert rel <= 16 * kappa * EPS, (rel, kappa)                    # measured ≤ 0.003 κ ε
    assert np.abs(full @ x - r).max() <= 64 * EPS * (abs(full).max() * np.abs(x).max() * 30 + np.abs(r).max())


@pytest.mark.parametrize("sigma", [240.0, complex(2.68, -3.05) * 60.0])
def test_banded_lu_equals_superlu(sigma):
    # ORACLES J7: the cloth's S factored by LAPACK's banded LU (its half-bandwidth from the grid order) solves
    # as SuperLU's sparse LU does, to κ ε, from the blocks' shared pattern and from S itself (Jv on another
    # pattern); an entry outside the declared band is refused, not dropped
    cloth = _cloth(6)
    J = second_order_jac(cloth)(0.0, _bent_state(cloth))
    assert J.band is not None and 0 < J.band < J.n
    sparse_lu = SecondOrderJacobian(J.jx, J.jv)
    assert sparse_lu.band is None
    other = SecondOrderJacobian(J.jx, sp.csc_matrix(J.jv.toarray() + 1e-3 * np.eye(J.n)), band=J.band)
    r = np.random.default_rng(4).standard_normal(2 * J.n)
    ref = sparse_lu.factor(sigma)(r)
    S = J.schur(sigma).toarray()
    kappa = np.linalg.cond(S)
    assert np.abs(J.factor(sigma)(r) - ref).max() <= 16 * kappa * EPS * np.abs(ref).max()    # measured 0.03, 0.33 κ ε
    ref2 = SecondOrderJacobian(other.jx, other.jv).factor(sigma)(r)
    assert np.abs(other.factor(sigma)(r) - ref2).max() <= 16 * kappa * EPS * np.abs(ref2).max()
    with pytest.raises(InvalidInput):
        SecondOrderJacobian(J.jx, J.jv, band=J.band // 2).factor(sigma)


def test_dense_blocks_and_limiting_case():
    # ORACLES J7: Jx = Jv = 0 leaves u = r₂/σ, p = (r₁ + u)/σ; a dense pair equals the dense inverse
    z = np.zeros((2, 2))
    x = SecondOrderJacobian(z, z).factor(2.0)(np.array([1.0, 2.0, 4.0, 6.0]))
    assert x.tolist() == [1.5, 2.5, 2.0, 3.0]
    rng = np.random.default_rng(3)
    jx, jv = rng.standard_normal((4, 4)), rng.standard_normal((4, 4))
    J = np.block([[np.zeros((4, 4)), np.eye(4)], [jx, jv]])
    r = rng.standard_normal(8)
    x = SecondOrderJacobian(jx, jv).factor(3.0)(r)
    ref = np.linalg.solve(3.0 * np.eye(8) - J, r)
    assert np.abs(x - ref).max() <= 1e3 * EPS * np.linalg.cond(3.0 * np.eye(8) - J) * np.abs(ref).max()
    with pytest.raises(InvalidInput):
        SecondOrderJacobian(np.zeros((3, 3)), np.zeros((2, 2)))


@pytest.mark.parametrize("method", ["rodas4", "radau5"])
def test_adaptive_runs_equal_with_either_jacobian(method):
    # ORACLES J7: the same accepted steps and the same final state to roundoff (measured ≤ 7e-15 m at N = 16)
    cloth = _cloth(6)
    y0 = cloth.free_state(cloth.state())
    a = solve(cloth.rhs, (0.0, 0.03), y0, method=method, rtol=1e-5, atol=1e-7, jac=cloth.jac)
    b = solve(cloth.rhs, (0.0, 0.03), y0, method=method, rtol=1e-5, atol=1e-7, jac=second_order_jac(cloth))
    assert a.nfev == b.nfev and len(a.t) == len(b.t)
    assert np.abs(a.y[:, -1] - b.y[:, -1]).max() <= 1e-11 * (1.0 + np.abs(a.y[:, -1]).max())


def _duffing(t, y):
    """ẍ = −x − x³ − 0.1 ẋ + (coupling), 3 oscillators: a nonlinear second-order test system."""
    x, v = y[:3], y[3:]
    a = -x - x ** 3 - 0.1 * v + 0.5 * (np.roll(x, 1) - x)
    return np.concatenate([v, a])


def _duffing_jac(t, y):
    x = y[:3]
    jx = np.diag(-1.0 - 3.0 * x ** 2 - 0.5) + 0.5 * np.roll(np.eye(3), -1, axis=1)
    return SecondOrderJacobian(jx, -0.1 * np.eye(3))


@pytest.mark.parametrize("step, order", [(rodas4_step, 4), (radau5_step, 5)])
def test_order_unchanged_with_block_jacobian(step, order):
    # ORACLES A3, J7: fixed steps with the half-size stage solves keep the methods' orders (fitted slope)
    y0 = np.array([1.0, 0.5, -0.3, 0.0, 0.2, 0.1])
    T = 2.0

    def run(k):
        y = y0.copy()
        for i in range(k):
            y = step(_duffing, i * T / k, y, T / k, jac=_duffing_jac)
        return y
    ref = run(1024)
    ks = [8, 16, 32, 64]
    errs = [np.abs(run(k) - ref).max() for k in ks]
    fit = order_fit([T / k for k in ks], errs)
    assert order - 0.3 <= fit.order <= order + 0.6, (fit.order, errs)


@pytest.mark.parametrize("damping, squeeze", [(1e-3, 1.0), (0.0, 1.0), (1e-3, 0.9)])
def test_one_pass_rhs_and_jacobian_equal_the_cloth(damping, squeeze):
    # ORACLES J11: f and the exact J of a spring cloth from one pass over all springs equal Cloth.rhs and
    # Cloth.jac (readable: per condition kind, element blocks on the pattern) to roundoff, damped or not,
    # with springs compressed (squeeze < 1: s < 0 in front of P, the unsymmetric damping term kept)
    cloth = Cloth(Sheet(6, pins="corners"), stretch=1e3, shear=1e2, bend=0.1, damping=damping)
    yf = _bent_state(cloth, seed=3)
    yf[:cloth.nf] *= squeeze
    rhs, jac = free_ode(cloth)
    f, full = cloth.rhs(0.0, yf), cloth.jac(0.0, yf)
    assert np.abs(rhs(0.0, yf) - f).max() <= 16 * EPS * np.abs(f).max()
    assert abs(jac(0.0, yf) - full).max() <= 16 * EPS * abs(full).max()
    assert abs(second_order_jac(cloth)(0.0, yf).tocsr() - full).max() <= 16 * EPS * abs(full).max()
    # a wrong sign of the damping term would show: the unsymmetric part is there and matched
    if damping:
        K = full[cloth.nf:, :cloth.nf]
        assert abs(K - K.T).max() > 1e3 * EPS * abs(K).max()


def test_one_pass_falls_back_for_other_conditions():
    # a Baraff–Witkin cloth (triangles, hinges) has no one-pass form: free_ode hands over Cloth.rhs, Cloth.jac
    cloth = Cloth(Sheet(4, pins="corners"), model="bw", stretch=1e2, shear=10.0, bend=1e-3, damping=1e-3)
    yf = _bent_state(cloth)
    rhs, jac = free_ode(cloth)
    assert np.array_equal(rhs(0.0, yf), cloth.rhs(0.0, yf))
    assert abs(jac(0.0, yf) - cloth.jac(0.0, yf)).max() == 0.0
    assert abs(second_order_jac(cloth)(0.0, yf).tocsr() - cloth.jac(0.0, yf)).max() == 0.0


def test_one_pass_force_sum_is_the_operator_product_bit_for_bit():
    # ORACLES J11: the springs' forces summed into the particles by scipy's CSR kernel, one column at a time,
    # are the operator's product signed @ fe.T (the same sums in the same order), bit for bit
    from pbanim.cloth.assembly import _spring_pass
    cloth = Cloth(Sheet(6, pins="corners"), stretch=1e3, shear=1e2, bend=0.1, damping=1e-3)
    yf = _bent_state(cloth, seed=5)
    lean = _spring_pass(cloth)
    f = lean.pass_(yf, False)[0]
    X = lean._state(yf)
    dX = np.take(X, lean.a, axis=1) - np.take(X, lean.b, axis=1)
    d, dv = dX[:3], dX[3:]
    length = np.sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2])
    w = d * (1.0 / length)
    s = lean.k * (length - lean.rest) + lean.kd * (w[0] * dv[0] + w[1] * dv[1] + w[2] * dv[2])
    assert np.array_equal(f, (lean.signed @ (w * -s).T + lean.fext).ravel())
