"""Implicit Euler / midpoint over a run with the Newton matrix kept across steps (ORACLES A17)."""

import numpy as np
import pytest

from pbanim.ode import implicit_euler_step, implicit_midpoint_step
from pbanim.ode.implicit_run import THETA, NewtonSteps


def _pendulum(t, y):
    # a pendulum with a slow forcing: J changes along the orbit and with t (ORACLES A17)
    return np.array([y[1], -9.81 * np.sin(y[0]) + 0.3 * np.cos(2.0 * t)])


READABLE = {"implicit_euler": implicit_euler_step, "implicit_midpoint": implicit_midpoint_step}


@pytest.mark.parametrize("name", sorted(THETA))
def test_kept_matrix_solves_the_defining_equation_to_the_newton_tolerance(name):
    # ORACLES A17: every step solves z = y0 + θh f(t + θh, z) to tol; the run equals the per-step solve
    theta, h, n, tol = THETA[name], 0.01, 600, 1e-12
    steps = NewtonSteps(_pendulum, name, tol=tol)
    y_kept = y_step = np.array([2.0, 0.0])
    worst = 0.0
    for k in range(n):
        t = k * h
        y1 = steps.step(t, y_kept, h)
        z = y1 if theta == 1.0 else 0.5 * (y_kept + y1)
        r = z - y_kept - theta * h * _pendulum(t + theta * h, z)
        worst = max(worst, float(np.max(np.abs(r)) / (1.0 + np.max(np.abs(z)))))
        y_kept = y1
        y_step = READABLE[name](_pendulum, t, y_step, h)
    assert worst <= 10 * tol
    assert np.max(np.abs(y_kept - y_step)) < 1e-9          # measured <= 4.8e-14
    assert steps.refactored < 0.05 * n                     # the matrix is kept (measured: 1 build)


def test_kept_matrix_refreshes_when_the_newton_iteration_contracts_slowly():
    # a large step on a stiff nonlinear term: the first matrix goes stale and is rebuilt, the run carries on
    f = lambda t, y: np.array([y[1], -1e4 * y[0] ** 3 - y[1]])  # noqa: E731
    steps = NewtonSteps(f, "implicit_euler")
    y = np.array([1.0, 0.0])
    for k in range(40):
        y1 = steps.step(0.05 * k, y, 0.05)
        assert np.max(np.abs(y1 - y - 0.05 * f(0.05 * (k + 1), y1))) <= 10 * 1e-12 * (1 + np.max(np.abs(y1)))
        y = y1
    assert steps.refactored > 1


def test_constant_jacobian_equals_the_per_step_solve_bit_for_bit():
    # a linear f with its constant J: the same matrix, factorization and iterations as newton_solve
    A = np.array([[0.0, 1.0], [-4.0, -0.1]])
    f = lambda t, y: A @ y  # noqa: E731
    for name, readable in READABLE.items():
        steps = NewtonSteps(f, name, jac=A)
        a = b = np.array([1.0, 0.5])
        for k in range(200):
            a = steps.step(0.05 * k, a, 0.05)
            b = readable(f, 0.05 * k, b, 0.05, jac=A)
        assert np.array_equal(a, b)
        assert steps.refactored == 1


def test_linear_scene_implicit_plan_is_the_readable_step_bit_for_bit():
    # ORACLES A16/A17: a linear scene's implicit Euler / midpoint factor I − θhJ once per run
    from pbanim.particles import AnchorSprings, Drag, ParticleSystem
    from pbanim.scene import Scene

    for name in THETA:
        ps = ParticleSystem([[1.0, 0.0], [0.0, 0.5]], masses=[1.0, 2.0])
        scene = Scene(ps, [AnchorSprings([0, 1], [[0.0, 0.0], [0.1, 0.0]], stiffness=4.0), Drag(0.2)])
        lean = scene.simulate(2.0, 0.05, name)
        scene.lean_path = False
        readable = scene.simulate(2.0, 0.05, name)
        assert np.array_equal(lean.y, readable.y)
        assert lean.njev == 1 and readable.njev == 40
