"""Valid calls for pbanim.reduced and pbanim.lagrangian (chapter 04): a simple pendulum, numeric and symbolic."""

import numpy as np
import sympy as sp

from pbanim.particles import Gravity
from pbanim.reduced import ChartGuard, ReducedSystem
from pbanim.reduced.lagrangian import EulerLagrangeEquations, LagrangianSystem, derive_equations, lagrangian_system

TH = sp.Symbol("th")
POSITION = [sp.sin(TH), -sp.cos(TH)]
A, B = sp.symbols("a b")
POLAR = [[A * sp.cos(B), A * sp.sin(B)]]      # one particle in polar coordinates (a, b) = (r, φ): two coordinates


def _chart():
    """q(u), J(u), J̇u̇ of a unit pendulum (θ from the downward vertical)."""
    return {"q": lambda u: np.array([np.sin(u[0]), -np.cos(u[0])]),
            "J": lambda u: np.array([[np.cos(u[0])], [np.sin(u[0])]]),
            "Jdot_udot": lambda u, ud: ud[0] ** 2 * np.array([-np.sin(u[0]), np.cos(u[0])])}


def _double():
    """q(u), J(u), J̇u̇ of a unit double pendulum, u = (a, b) the two angles from the downward vertical (two
    coordinates: the fuzz's arrays of unbound size have two entries, so its edge values fit the chart)."""
    def q(u):
        a, b = u
        return np.array([np.sin(a), -np.cos(a), np.sin(a) + np.sin(b), -np.cos(a) - np.cos(b)])

    def J(u):
        a, b = u
        ca, sa, cb, sb = np.cos(a), np.sin(a), np.cos(b), np.sin(b)
        return np.array([[ca, 0.0], [sa, 0.0], [ca, cb], [sa, sb]])

    def Jdot_udot(u, ud):
        (a, b), (da, db) = u, ud
        pa = da * da * np.array([-np.sin(a), np.cos(a)])
        pb = db * db * np.array([-np.sin(b), np.cos(b)])
        return np.concatenate([pa, pa + pb])

    return {"q": q, "J": J, "Jdot_udot": Jdot_udot}


def _pendulum():
    return ReducedSystem(**_chart(), masses=1.0, dim=2, forces=[Gravity()], u0=[0.3], udot0=[0.1])


def _guard():
    g = ChartGuard(1e6)
    g.set_reference(np.diag([2.0, 8.0]))
    return g


def _points():
    return [(1.0, list(POSITION))]


INSTANCES = {
    ReducedSystem: _pendulum,
    ChartGuard: _guard,
    sp.Symbol: lambda: TH,
    EulerLagrangeEquations: lambda: derive_equations([TH], _points(), gravity=[0.0, -9.81]),
    LagrangianSystem: lambda: lagrangian_system([TH], _points(), gravity=[0.0, -9.81]),
}

_R = "pbanim.reduced."
CALLS = {
    _R + "system.ReducedSystem.__init__": lambda: {**_double(), "forces": [Gravity()], "u0": [0.3, 0.5],
                                                   "udot0": [0.1, 0.0]},
    _R + "system.ReducedSystem.from_sympy": lambda: {"positions": [list(r) for r in POLAR], "coords": [A, B],
                                                     "forces": [Gravity()], "u0": [1.3, 0.5], "udot0": [0.1, 0.0]},
    _R + "system.ReducedSystem.simulate": lambda: {"max_steps": 1000},
    _R + "chart.simulate_fixed": lambda: {"rhs": lambda t, y: np.array([y[1], -y[0]]), "y0": [1.0, 0.0],
                                          "energy": lambda y, t: 0.5 * float(y @ y), "max_steps": 1000},
    _R + "chart.check_chart": lambda: {**_double(), "u": [0.3, 0.5], "udot": [1.0, -0.5]},
    _R + "chart.point_kinematics": lambda: {"positions": list(POSITION), "coords": [TH], "t": None},
    _R + "chart.ChartGuard.solve": lambda: {"A": np.diag([2.0, 8.0]), "r": [2.0, 8.0], "u": [0.0, 0.0]},
    _R + "lagrangian.derive_equations": lambda: {"coords": [TH], "points": _points(), "gravity": [0.0, -9.81],
                                                 "T": None, "forces": None, "t": None},
    _R + "lagrangian.lagrangian_system": lambda: {"coords": [TH], "points": _points(), "key": ("fuzz pendulum",)},
}

EXEMPT = {
    _R + "codegen.LagrangianSystem.__init__": "the compiled model compile_equations builds from equations pbanim "
                                              "derived; its private fields (_factors, _terms, _energy) are generated "
                                              "code, never user input",
    _R + "lagrangian.EulerLagrangeEquations.__init__": "the derived equations derive_equations builds and users read "
                                                       "(and hand back to compile_equations and energy_rate, whose "
                                                       "contracts check the object)",
    _R + "chart.PointKinematics.__init__": "the derivatives point_kinematics builds and users only read",
    _R + "chart.ChartCheck.__init__": "the result record check_chart builds and users only read (errors and ok)",
}
