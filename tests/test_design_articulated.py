"""Design of an articulated motion (chapter 10, issue 31; ORACLES H9, L1): S(t, u) of a chain in flight and its
sensitivity from the analytical derivatives of ABA, checked against centred differences of S and against the
closed-form flight of the centre of mass; a shooting design that reaches its target."""

import numpy as np
import pytest

from pbanim.articulated import ArticulatedTree, PlanarKernel
from pbanim.derivatives import central_jacobian
from pbanim.design import aim_chain, simulate_chain, thrown_chain
from pbanim.errors import InvalidInput

Q0 = np.array([0.0, 1.0, 0.3, 0.4])
QD0 = np.array([2.0, 3.0, 2.0, -1.0])
K = np.array([0.0, 0.0, 0.0, 5.0])


def _tree():
    return thrown_chain(2, 0.3)


def _final(tree, u, free, h, T=0.5):
    qd = QD0.copy()
    qd[free] = u
    return simulate_chain(tree, Q0, qd, T, h, free=free, stiffness=K, sensitivities=False).y[-1]


@pytest.mark.parametrize("free", [[0, 1, 2], [1, 3]])
def test_sensitivity_is_the_derivative_of_the_discrete_flight(free):
    # ORACLES H9: RK4 on (y, Φ) is the derivative of the RK4 map, so the centred difference of S converges to it
    # as δ²: fitted slope 2 ± 0.2 over δ = 4e-2 .. 1e-2 (measured 2.00), and at δ = 1e-3 within
    # 0.1 δ² × (1 + max|∂S/∂u|) (measured 0.017 δ² × scale)
    tree, h = _tree(), 0.05
    fl = simulate_chain(tree, Q0, QD0, 0.5, h, free=free, stiffness=K)
    A = fl.dy_du[-1]
    u0 = QD0[free]
    deltas = np.array([4e-2, 2e-2, 1e-2])
    errs = [np.abs(central_jacobian(lambda u: _final(tree, u, free, h), u0, eps=d) - A).max() for d in deltas]
    slope = np.polyfit(np.log(deltas), np.log(errs), 1)[0]
    assert 1.8 <= slope <= 2.2, (slope, errs)
    err = np.abs(central_jacobian(lambda u: _final(tree, u, free, h), u0, eps=1e-3) - A).max()
    assert err <= 0.1 * 1e-6 * (1 + np.abs(A).max()), err
    assert fl.dy_du.shape == (len(fl.t), 2 * tree.nv, len(free))
    assert np.array_equal(fl.dy_du[0][tree.nq + np.array(free), np.arange(len(free))], np.ones(len(free)))


def test_centre_of_mass_flies_on_a_parabola():
    # ORACLES H9 (limiting case): joint springs are internal, so the centre of mass obeys c̈ = g and
    # ∂c(T)/∂u = T ∂ċ₀/∂u exactly; the discrete flight meets it to RK4's error: falls as h⁴ (fitted slope
    # 4 ± 0.5 over h = 0.025 .. 0.00625, measured 4.2; at h = 0.1 the springy tip rod is past RK4's stability),
    # below 3e-6 at h = 0.00625 (measured 7.5e-7)
    tree, T = _tree(), 0.5
    kernel = PlanarKernel(tree)
    free = [0, 1, 2]

    def com_jac(q):
        kin = kernel.kinematics(q)
        Jz = kernel.mass @ kernel.com_jacobians(kin) / kernel.mass.sum()
        return np.stack([Jz.real, Jz.imag])                     # (2, nv)

    exact = T * com_jac(Q0)[:, free]
    hs, errs = np.array([0.025, 0.0125, 0.00625]), []
    for h in hs:
        fl = simulate_chain(tree, Q0, QD0, T, h, free=free, stiffness=K)
        errs.append(np.abs(com_jac(fl.y[-1, :tree.nq]) @ fl.dy_du[-1, :tree.nq] - exact).max())
    slope = np.polyfit(np.log(hs), np.log(errs), 1)[0]
    assert 3.5 <= slope <= 4.5, (slope, errs)
    assert errs[-1] < 3e-6


def test_aim_reaches_the_target_by_newton_steps():
    # ORACLES H5/H9: with as many launch parameters as needed (vx, vy, ω for a 2-D goal) the min-norm update
    # converges quadratically: residuals 0.14 → 3e-4 → 2e-9 (measured); the final tip, recomputed from the
    # flight's last state, within tol
    tree = thrown_chain(3, 0.3)
    q0, qd0 = np.array([0.0, 1.0, 0.3, 0.4, -0.3]), np.array([2.0, 3.0, 2.0, 0.0, 0.0])
    k = np.array([0.0, 0.0, 0.0, 5.0, 5.0])
    target = np.array([1.5, 1.5])
    res = aim_chain(tree, q0, qd0, 0.8, 0.05, 4, [0.3, 0.0, 0.0], target, tol=1e-8, stiffness=k)
    assert res.success and res.residuals[-1] <= 1e-8 and len(res.residuals) <= 5
    r = res.residuals
    assert all(r[i + 1] <= 10 * r[i] ** 2 / r[0] + 1e-12 for i in range(len(r) - 1)), r      # quadratic
    tip = PlanarKernel(tree).points(res.flight.y[-1, :tree.nq], [4], np.array([[0.3, 0.0, 0.0]]))[0]
    assert np.abs(tip - target).max() <= 1e-8
    assert np.array_equal(res.u, res.history[-1]) and np.array_equal(res.flight.y[0, tree.nq:tree.nq + 3], res.u)


def test_bad_input_is_named():
    tree = _tree()
    with pytest.raises(InvalidInput, match="free"):
        simulate_chain(tree, Q0, QD0, 0.5, 0.05, free=[0, 0])
    with pytest.raises(InvalidInput, match="steps"):
        simulate_chain(tree, Q0, QD0, 100.0, 1e-4)
    free_body = ArticulatedTree()
    free_body.add("b", -1, "floating", mass=1.0, inertia=[0.1, 0.1, 0.1])
    with pytest.raises(InvalidInput, match="floating"):
        simulate_chain(free_body, free_body.neutral(), np.zeros(6), 0.5, 0.05)
    with pytest.raises(InvalidInput, match="h"):
        simulate_chain(tree, Q0, QD0, 0.5, -0.05)


def test_thrown_chain_figure(figure_data):
    # ORACLES H9/L1 on the chapter's figure: ∂S/∂u equals a centred difference (δ = 1e-3) to 1e-5 × scale
    # (measured 1.4e-7), and the design reaches the bar: residual ≤ 1e-8 (measured 2e-9)
    d = figure_data("ch10_thrown_chain")
    assert d["success"] and d["residuals"][-1] <= 1e-8
    assert np.abs(d["tip"] - d["target"]).max() <= 1e-8
    assert d["fd_error"] <= 1e-5 * (1 + d["dS_du_scale"])
