"""Checks of assignment ch02_integrators: explicit Euler, symplectic Euler, Verlet and a tableau RK step.

The student writes, in a copy of :mod:`pbanim.ode.methods`, the step functions
``step(fun, t, y, h, split=None, jac=None) -> y₁`` on ẏ = f(t, y), y = [q, v] (``split`` = number of
position components, default n // 2):

    explicit Euler      y₁ = y₀ + h f(t₀, y₀)
    symplectic Euler    v₁ = v₀ + h a(q₀, v₀),  q₁ = q₀ + h v₁   (kick, then drift with the new v)
    velocity Verlet     v½ = v₀ + h/2 a(q₀),  q₁ = q₀ + h v½,  v₁ = v½ + h/2 a(q₁)
    Runge–Kutta         kᵢ = f(t + cᵢh, y + h Σⱼ aᵢⱼ kⱼ),  y₁ = y + h Σᵢ bᵢ kᵢ      (Butcher tableau A, b, c)

===================  ==========================================================================  ======
check                oracle (harmonic oscillator ẍ = −ω²x unless said)                          id
===================  ==========================================================================  ======
euler_energy         E₁/E₀ = 1 + h²ω² exactly, every step                                        A1
symplectic_energy    one step = the kick–drift map; H̃ = E − ½hω²xv conserved to roundoff        A1
verlet_energy        ½v² + ½ω²(1 − h²ω²/4)x² conserved to roundoff                              A1
orders               fitted slopes of the global error at t = 1: Euler 1, symplectic Euler 1,    A3
                     Verlet 2, RK4 (through explicit_rk_step) 4, each within ±0.15
free_fall_exact      constant force: Verlet and RK4 exact (error ≤ 1e-12 m) over 50 steps        A8
===================  ==========================================================================  ======

Limiting cases: h → 0 makes all methods agree (the order check measures how fast); ω = 0 is free
motion, integrated exactly by every method here.
"""

from __future__ import annotations

import numpy as np

from .registry import CheckFailed, Mutant, array, at_most, attr, check, close

CHECKS: list = []
W = 2.0  # ω of the oscillator (rad/s)


def _osc(t, y):
    y = np.asarray(y, float)
    return np.concatenate([y[..., 1:2], -W * W * y[..., 0:1]], axis=-1)


def _energy(y):
    return 0.5 * y[..., 1] ** 2 + 0.5 * W * W * y[..., 0] ** 2


def _run(step, h, n, y0=(1.0, 0.0)):
    y = np.array(y0, float)
    out = [y]
    for _ in range(n):
        y = array(f"{getattr(step, '__name__', 'step')}(…) result", step(_osc, 0.0, y, h), (2,))
        out.append(y)
    return np.array(out)


@check(CHECKS, "euler_energy", 10, "explicit Euler gains energy by exactly 1 + h²ω² per step", "A1",
       regions=("euler_step",))
def euler_energy(mod):
    h = 0.05
    ys = _run(attr(mod, "euler_step"), h, 20)
    ratio = _energy(ys[1:]) / _energy(ys[:-1])
    close("E₁/E₀ of explicit Euler per step", ratio, np.full(20, 1 + (h * W) ** 2), rtol=1e-13,
          why="y₁ = y₀ + h f(y₀) multiplies E by 1 + h²ω² on the oscillator")
    return f"E₁/E₀ = 1 + h²ω² = {1 + (h * W) ** 2:.4f} every step"


@check(CHECKS, "symplectic_energy", 20, "symplectic Euler (kick, then drift) keeps H̃ = E − ½hω²xv exactly",
       "A1", regions=("symplectic_euler_step",))
def symplectic_energy(mod):
    h = 0.1
    step = attr(mod, "symplectic_euler_step")
    y1 = array("symplectic_euler_step(…) result", step(_osc, 0.0, np.array([1.0, 0.5]), h), (2,))
    v1 = 0.5 - h * W * W
    close("one symplectic Euler step from (x, v) = (1, 0.5)", y1, [1.0 + h * v1, v1], rtol=1e-14,
          why="v₁ = v₀ − hω²x₀, then x₁ = x₀ + h v₁ (explicit Euler would use v₀)")
    ys = _run(step, h, 300)
    Ht = _energy(ys) - 0.5 * h * W * W * ys[:, 0] * ys[:, 1]
    drift = float(np.max(np.abs(Ht - Ht[0])) / Ht[0])
    # measured 1.1e-15 over 300 steps for the reference: bound 1e-12
    at_most("relative drift of H̃ over 300 steps", drift, 1e-12)
    return f"one step exact; H̃ drift {drift:.1e} over 300 steps"


@check(CHECKS, "verlet_energy", 20, "velocity Verlet keeps ½v² + ½ω²(1 − h²ω²/4)x² exactly", "A1",
       regions=("verlet_step",))
def verlet_energy(mod):
    h = 0.1
    ys = _run(attr(mod, "verlet_step"), h, 300)
    Ht = 0.5 * ys[:, 1] ** 2 + 0.5 * W * W * (1 - (h * W) ** 2 / 4) * ys[:, 0] ** 2
    drift = float(np.max(np.abs(Ht - Ht[0])) / Ht[0])
    # measured 1.1e-15 over 300 steps for the reference: bound 1e-12
    at_most("relative drift of Verlet's modified energy over 300 steps", drift, 1e-12,
            why="half kick with a(q₀), drift with v½, half kick with a(q₁)")
    return f"modified energy drift {drift:.1e} over 300 steps"


@check(CHECKS, "orders", 30, "global error shrinks as hᵖ: p = 1, 1, 2, 4 for Euler, symplectic Euler, "
       "Verlet, RK4", "A3", regions=("euler_step", "symplectic_euler_step", "verlet_step", "explicit_rk_step"))
def orders(mod):
    from ..testing import order_fit

    exact = np.array([np.cos(W), -W * np.sin(W)])
    rk = attr(mod, "explicit_rk_step")
    steps = {"euler_step": (attr(mod, "euler_step"), 1), "symplectic_euler_step": (attr(mod, "symplectic_euler_step"), 1),
             "verlet_step": (attr(mod, "verlet_step"), 2),
             "explicit_rk_step('rk4')": (lambda f, t, y, h: rk("rk4", f, t, y, h), 4)}
    found = []
    for name, (step, p) in steps.items():
        hs = np.array([1 / 40, 1 / 80, 1 / 160, 1 / 320]) if p < 4 else np.array([1 / 10, 1 / 20, 1 / 40, 1 / 80])
        errs = [float(np.max(np.abs(_run(step, h, int(round(1 / h)))[-1] - exact))) for h in hs]
        if not np.all(np.isfinite(errs)):
            raise CheckFailed(f"{name}: the error at t = 1 is not finite ({errs})")
        slope = order_fit(hs, errs, window=(1e-13, 10.0)).order
        if abs(slope - p) > 0.15:
            raise CheckFailed(f"{name}: fitted order {slope:.2f}, expected {p} ± 0.15 (errors {np.round(errs, 10).tolist()})")
        found.append(f"{name} {slope:.2f}")
    return "fitted orders: " + ", ".join(found)


@check(CHECKS, "free_fall_exact", 20, "a constant force is integrated exactly by Verlet and RK4", "A8",
       public=False, regions=("verlet_step", "explicit_rk_step"))
def free_fall_exact(mod):
    g, h, n = -9.81, 0.02, 50

    def fall(t, y):
        return np.array([y[1], g])

    rk = attr(mod, "explicit_rk_step")
    for name, step in (("verlet_step", attr(mod, "verlet_step")),
                       ("explicit_rk_step('rk4')", lambda f, t, y, hh: rk("rk4", f, t, y, hh))):
        y = np.array([10.0, 1.0])
        for k in range(n):
            y = array(f"{name} result", step(fall, k * h, y, h), (2,))
        T = n * h
        close(f"{name}: free fall after {n} steps", y, [10.0 + T + 0.5 * g * T * T, 1.0 + g * T], atol=1e-12,
              unit="m", why="second-order methods are exact on x = x₀ + v₀t + ½gt²")
    return "Verlet and RK4 exact on free fall (error ≤ 1e-12 m)"


MUTANTS = (
    Mutant("explicit_euler_as_symplectic", "explicit Euler where symplectic Euler was asked (drift with v₀)",
           (("    k2 = fun(t, y1)\n", "    k2 = fun(t, y)\n"),), ("symplectic_energy",)),
    Mutant("verlet_stale_force", "Verlet's second half kick reuses the old acceleration a(q₀)",
           (("    y1[..., s:] += half * fun(t + h, y1)[..., s:]\n", "    y1[..., s:] += half * fun(t, y)[..., s:]\n"),),
           ("verlet_energy", "orders")),
)
