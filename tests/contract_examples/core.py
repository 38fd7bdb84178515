"""Valid calls and exemptions for the core layers: the scene, the body protocol, results, errors, geometry,
derivatives, accuracy sweeps and test assertions."""

import numpy as np

from pbanim.accuracy import Row
from pbanim.particles import Gravity, ParticleSystem, AnchorSprings
from pbanim.scene import Scene
from pbanim.testing import OrderFit

from .ode import oscillator


def _scene():
    ps = ParticleSystem([[1.0, 0.0], [0.0, 1.0]], [[0.0, 0.5], [0.2, 0.0]], masses=[1.0, 2.0])
    return Scene(ps, [Gravity(), AnchorSprings([0, 1], [[0.0, 0.0], [0.0, 0.0]], 10.0, 0.5)])


_ROW = lambda: Row("rk4", 0.1, 1e-4, 1e-3, 40)  # noqa: E731

INSTANCES = {
    __import__("pbanim.results", fromlist=["x"]).LazyDiagnostics:
        lambda: __import__("pbanim.results", fromlist=["x"]).LazyDiagnostics(lambda: {"energy": np.ones(3)}),
    Scene: _scene,
    Row: _ROW,
    OrderFit: lambda: OrderFit(2.0, np.array([0.1, 0.05]), np.array([1e-2, 2.5e-3]), np.array([True, True]), ()),
}

_ABSTRACT = ("an abstract hook of the protocol: the base raises (or does nothing); every effect or system that "
             "implements it declares its own contract")
_RECORD = ("a result record: pbanim builds it from a run or a solve and a user reads its fields; the run that "
           "built it checked every number")

EXEMPT = {
    "pbanim.scene.Effect.bind": _ABSTRACT,
    "pbanim.scene.Effect.apply": _ABSTRACT,
    "pbanim.scene.Effect.constrain": _ABSTRACT,
    "pbanim.scene.Effect.post_step": _ABSTRACT,
    "pbanim.bodies.Bodies.generalized_velocity": _ABSTRACT,
    "pbanim.bodies.Bodies.inverse_mass_blocks": _ABSTRACT,
    "pbanim.bodies.Bodies.apply_inverse_mass": _ABSTRACT,
    "pbanim.bodies.Bodies.point_velocity": _ABSTRACT,
    "pbanim.bodies.Bodies.apply_impulses": _ABSTRACT,
    "pbanim.results.SimResult.__init__": _RECORD,
    "pbanim.results.ContactSolution.__init__": _RECORD,
}

_Y = lambda: {"y": np.array([1.0, 0.0, 0.0, 1.0, 0.0, 0.5, 0.2, 0.0])}  # noqa: E731

CALLS = {
    "pbanim.scene.Scene.__init__": lambda: {"system": ParticleSystem([[1.0, 0.0]]), "effects": [Gravity()]},
    "pbanim.accuracy.Row.__init__": lambda: {"variant": "rk4", "param": 0.1},
    "pbanim.testing.OrderFit.__init__": lambda: {"hs": np.array([0.1, 0.05]), "errors": np.array([1e-2, 2.5e-3]),
                                                 "used": np.array([True, True]), "dropped": ()},
    "pbanim.accuracy.sweep": lambda: {"run": lambda v, p: (p * 2.0, 1), "variants": ["a"], "params": [0.1, 0.2],
                                      "error": lambda value: abs(value)},
    "pbanim.accuracy.rows_by_variant": lambda: {"rows": [_ROW(), _ROW()]},
    "pbanim.accuracy.best_at_error": lambda: {"rows": [_ROW()]},
    "pbanim.derivatives.central_jacobian": lambda: {"f": lambda x: np.sin(x), "x": np.array([0.1, 0.2])},
    "pbanim.derivatives.directional_derivative": lambda: {"g": lambda x: x ** 2, "x": np.array([0.1, 0.2]),
                                                          "direction": np.array([1.0, 0.0])},
    "pbanim.geometry.tangent_basis": lambda: {"normal": np.array([[0.0, 0.0, 1.0], [1.0, 0.0, 0.0]])},
    "pbanim.geometry.cone_edges": lambda: {"normal": np.array([[0.0, 0.6, 0.8]]), "k": 4},
    "pbanim.testing.order_fit": lambda: {"hs": [0.1, 0.05, 0.025], "errors": [1e-3, 2.5e-4, 6.25e-5]},
    "pbanim.testing.fitted_order": lambda: {"hs": [0.1, 0.05, 0.025], "errors": [1e-3, 2.5e-4, 6.25e-5]},
    "pbanim.testing.assert_order": lambda: {"hs": [0.1, 0.05, 0.025], "errors": [1e-3, 2.5e-4, 6.25e-5],
                                            "order": 2.0},
    "pbanim.testing.drift_ratio": lambda: {"series": np.cos(np.linspace(0, 10, 50))},
    "pbanim.testing.assert_conserved": lambda: {"series": np.ones(10), "rtol": 1e-12},
    "pbanim.testing.check_grad": lambda: {"f": lambda x: x ** 2, "x": np.array([1.0, 2.0]),
                                          "J": np.diag([2.0, 4.0])},
    "pbanim.testing.assert_complementarity": lambda: {"f": np.array([0.0, 1.0]), "w": np.array([2.0, 0.0])},
    "pbanim.ode.tableau.Tableau.__init__": lambda: {"name": "heun", "A": np.array([[0.0, 0.0], [1.0, 0.0]]),
                                                    "B": np.array([0.5, 0.5]), "C": np.array([0.0, 1.0]),
                                                    "order": 2},
    "pbanim.results.natural_map_residual": lambda: {"f": np.array([0.0, 1.0]), "w": np.array([2.0, 0.0])},
    "pbanim.bodies.require_bodies": lambda: {"system": ParticleSystem([[1.0, 0.0]]), "who": "test"},
    "pbanim.errors.check_count": lambda: {"name": "n", "value": 3},
    "pbanim.errors.check_number": lambda: {"name": "x", "value": 0.5},
    "pbanim.errors.check_positive": lambda: {"name": "x", "value": 0.5},
    "pbanim.errors.as_float": lambda: {"name": "x", "value": 0.5},
    "pbanim.errors.as_floats": lambda: {"name": "x", "value": [0.5, 1.0]},
    "pbanim.errors.check_result": lambda: {"what": "x", "value": np.array([1.0])},
    "pbanim.ode.driver.check_finite": lambda: {"y": np.array([1.0, 2.0]), "t": 0.0, "step": 0},
    "pbanim.ode.driver.fixed_steps": lambda: {"t0": 0.0, "t_end": 1.0, "h": 0.1},
}
for _m in ("applied_forces", "forces", "rhs", "potential_energy", "energy", "diagnostics", "jac", "step"):
    CALLS[f"pbanim.scene.Scene.{_m}"] = _Y
CALLS["pbanim.results.LazyDiagnostics.__init__"] = lambda: {"compute": lambda: {"energy": np.ones(3)}}
CALLS["pbanim.results.LazyDiagnostics.get"] = lambda: {"key": "energy"}
CALLS["pbanim.scene.Scene.simulate"] = lambda: {"t_end": 0.05, "h": 0.01}

# the assertions of pbanim.testing raise AssertionError when the property fails: that is their answer
RAISES = {f"pbanim.testing.{n}": (AssertionError,) for n in ("assert_order", "assert_conserved", "check_grad",
                                                             "assert_complementarity")}

SKIP_EDGES = {
    "pbanim.scene.Scene.simulate": "t_end = 1e300 with h at its lower bound asks for a run capped only by max_steps "
                                   "(refused up front; the cap's own test is in tests/test_driver.py)",
}
