"""ODE solvers (chapter 02): integrators as data, and ``solve`` in the shape of scipy's ``solve_ivp``.

Every simulation in pbanim is an initial value problem

    ẏ = f(t, y),   y(t₀) = y₀,     y = [q, v]  (positions first, velocities second),

and for a particle system f = [v, W Q(q, v)] with W = M⁻¹ (the deck's q̈ = W(Q + Q_C)). A one-step method
maps y_n to y_{n+1} = Φ_h(y_n); its *order* p means the global error is O(hᵖ).

Methods (``METHODS``; each a :class:`Method` with ``order``, ``symplectic``, ``implicit``, ``adaptive``)
--------------------------------------------------------------------------------------------------------
=====================  =====  ==========  ========================================================
name                   order  symplectic  one step
=====================  =====  ==========  ========================================================
``euler``              1      no          y₁ = y₀ + h f(y₀)
``midpoint``           2      no          y₁ = y₀ + h f(y₀ + h/2 f(y₀))
``rk4``                4      no          classical Runge–Kutta (Butcher tableau)
``symplectic_euler``   1      yes         v₁ = v₀ + h a(q₀, v₀);  q₁ = q₀ + h v₁   (kick, then drift)
``verlet``             2      yes         v½ = v₀ + h/2 a(q₀); q₁ = q₀ + h v½; v₁ = v½ + h/2 a(q₁)
``implicit_euler``     1      no          y₁ = y₀ + h f(y₁)   (Newton; L-stable)
``implicit_midpoint``  2      yes         y₁ = y₀ + h f((y₀ + y₁)/2)   (Newton; also non-separable H)
``exponential_euler``  2      no          y₁ = y₀ + h φ₁(hJ) f(y₀)   (exact for linear springs)
``dopri5``             5      no          Dormand–Prince 5(4), embedded error estimate, adaptive h
``dop853``             8      no          Dormand–Prince 8(5,3), PI control, dense output of order 7
``vern7``              7      no          Verner 7(6), PI control, Verner's dense output
``rodas4``             4      no          Rosenbrock: (1/(hγ) − J)Uᵢ = f(Yᵢ) + Σ cᵢⱼUⱼ/h; one LU/step
``radau5``             5      no          Radau IIA collocation, simplified Newton, J and LU reused
``dprkn6`` … ``12``    6-12   no          Nyström: Qᵢ = q + cᵢhv + h²Σaᵢⱼg(Qⱼ), only for q̈ = g(t, q)
=====================  =====  ==========  ========================================================

The explicit Runge–Kutta methods are Butcher tableaux (A, B, C) run by one stepper
(:mod:`pbanim.ode.methods`); each tableau checks ΣB = 1 and Σⱼ aᵢⱼ = cᵢ.

Notation
--------
=========  ==============  =================================
symbol     code            shape
=========  ==============  =================================
y = [q,v]  ``y``           (n,) or (K, n) in batch mode
f(t, y)    ``fun(t, y)``   same as y
h          ``h``           scalar (signed internally)
∂f/∂y      ``jac(t, y)``   (n, n) dense or scipy.sparse
split      ``split``       number of q components (default n // 2)
R(z)       stability fn    y₁ = R(hλ) y₀ on ẏ = λy
=========  ==============  =================================

Limiting cases and stability (ORACLES A1, A2)
---------------------------------------------
On the oscillator ẍ = −ω²x with E = ½(v² + ω²x²) and y = hω, one step multiplies E by 1 + y² (explicit
Euler: spirals out for every h), 1/(1 + y²) (implicit Euler: numerical damping), 1 + y⁴/4 (midpoint),
1 − y⁶/72 + y⁸/576 (RK4). Symplectic Euler conserves the modified energy E − ½hω²xv, Verlet
½v² + ½ω²(1 − y²/4)x²: bounded, never drifting, stable iff hω < 2. RK4 is stable iff hω ≤ 2√2. A stiff
spring (k = 10⁶, ω = 10³) therefore forces h < 2 ms on every explicit method; implicit Euler takes any h.
Baraff & Witkin's linearized implicit step (I − hJ)Δy = h f(y₀) is the first Newton iteration of implicit
Euler, exact for linear forces. The exponential integrator goes further: for a linear spring it *is* the
exact flow e^(hJ), at any step.

What accuracy costs (ORACLES A9–A12): an order-p method needs N ∝ ε^(−1/p) steps for an error ε, so
the tight tolerances belong to the high-order pairs (DOP853, Verner; for q̈ = g(t, q), such as Kepler
and the Pleiades, the Runge–Kutta–Nyström pairs ``dprkn8`` and ``dprkn12``, which need about half the
evaluations of f at equal error), and stiff problems (a k = 10⁶
spring, Van der Pol with μ = 1000, Robertson's kinetics) to the L-stable implicit ones (RODAS4, Radau
IIA), whose step is limited by accuracy only. ``pbanim bench ode`` measures both against scipy.

Code map: :mod:`pbanim.ode.methods` (the registry, split steps), :mod:`pbanim.ode.tableau` (Butcher
tableaux and their stepper), :mod:`pbanim.ode.high_order` (DOP853, Verner 7(6), dense output),
:mod:`pbanim.ode.implicit` (Newton, implicit and exponential steps, reusable factorizations),
:mod:`pbanim.ode.rosenbrock`, :mod:`pbanim.ode.radau` (stiff adaptive methods), :mod:`pbanim.ode.solve`
(``solve``: validation, fixed-step loops, scipy delegation), :mod:`pbanim.ode.adaptive` and
:mod:`pbanim.ode.control` (error control, PI controller), :mod:`pbanim.ode.events` (event location,
results), :mod:`pbanim.ode.problems` (the benchmark problems: Pleiades, Van der Pol, Robertson).

References
----------
Witkin & Baraff, *Physically Based Modeling*, SIGGRAPH course notes ("Differential equation basics",
"Implicit methods"); Baraff & Witkin, "Large steps in cloth simulation", SIGGRAPH 1998; Hairer, Nørsett &
Wanner, *Solving ODEs I*, §II.1–II.5 (Runge–Kutta, Dormand–Prince, step-size control); Hairer & Wanner,
*Solving ODEs II*, §IV.5–IV.8 (Radau IIA, Rosenbrock methods); Hairer, Lubich &
Wanner, *Geometric Numerical Integration*, §I.1, §VI (symplectic methods, modified energy); Hochbruck &
Ostermann, "Exponential integrators", Acta Numerica 2010; Michels, Sobottka & Weber, "Exponential
integrators for stiff elastodynamic problems", ACM TOG 2014.

Examples
--------
>>> import pbanim
>>> r = pbanim.solve(lambda t, y: np.array([y[1], -y[0]]), (0.0, np.pi), [1.0, 0.0], method="verlet", h=1e-3)
>>> bool(abs(r.y[0, -1] + 1.0) < 1e-6)
True
"""

from __future__ import annotations

import numpy as np  # noqa: F401  (doctest namespace)

from .methods import (METHODS, TABLEAUX, Method, Tableau, dop853_step, dopri5_step, euler_step,
                          explicit_rk_step, expm_small, exponential_euler_step, get_method, implicit_euler_step,
                          implicit_midpoint_step, midpoint_step, newton_solve, radau5_step, rk4_step,
                          rodas4_step, symplectic_euler_step, verlet_step, vern7_step)
from .second_order import SecondOrderJacobian
from .solve import SCIPY_METHODS, solve

__all__ = ["Method", "Tableau", "METHODS", "TABLEAUX", "SCIPY_METHODS", "get_method", "solve",
           "explicit_rk_step", "euler_step", "midpoint_step", "rk4_step", "symplectic_euler_step",
           "verlet_step", "implicit_euler_step", "implicit_midpoint_step", "exponential_euler_step", "dopri5_step",
           "dop853_step", "vern7_step", "rodas4_step", "radau5_step", "newton_solve", "expm_small",
           "SecondOrderJacobian"]
