"""Valid calls for pbanim.cloth (chapter 12): 3 × 3 sheets, so that each entry's fuzz stays short."""

import numpy as np
import scipy.sparse as sp

from pbanim.cloth import Cloth, Ground, PCGResult, Sheet, Sphere


def _sheet():
    return Sheet(3, size=1.0, mass=0.2)


def _cloth():
    return Cloth(Sheet(3), model="bw", stretch=100.0, shear=10.0, bend=0.01, damping=0.01,
                 colliders=[Sphere([0.0, 0.0, -0.5], 0.3), Ground(-1.0)])


def _state(cloth):
    """A slightly moved state (so that every force and Jacobian term is non-zero)."""
    y = cloth.state()
    rng = np.random.default_rng(0)
    y[:cloth.n] += 0.01 * rng.standard_normal(cloth.n)
    y[cloth.n:] = 0.1 * rng.standard_normal(cloth.n)
    return y


def _step_call():
    c = _cloth()
    return {"cloth": c, "y": _state(c), "h": 0.01}


INSTANCES = {
    Sheet: _sheet,
    Cloth: _cloth,
    Sphere: lambda: Sphere([0.0, 0.0, 0.0], 0.5),
    Ground: lambda: Ground(0.0),
    PCGResult: lambda: PCGResult(np.zeros(3), 0, 0.0, True, 1e-6),
}

CALLS = {
    "pbanim.cloth.large_steps.modified_pcg": lambda: {"A": sp.diags([2.0, 3.0, 4.0]).tocsr(),
                                                      "b": np.array([1.0, 2.0, 3.0]), "S": np.eye(3)[None],
                                                      "z": np.zeros(3)},
    "pbanim.cloth.large_steps.large_step": _step_call,
    "pbanim.cloth.large_steps.newton_step": _step_call,
    "pbanim.cloth.xpbd.xpbd_step": _step_call,
    "pbanim.cloth.model.Cloth.free_state": lambda self: {"y": _state(self)},
    "pbanim.cloth.model.Cloth.full_state": lambda self: {"yf": self.free_state(_state(self))},
    "pbanim.cloth.model.Cloth.forces": lambda self: {"y": _state(self)},
    "pbanim.cloth.model.Cloth.jacobians": lambda self: {"y": _state(self)},
    "pbanim.cloth.model.Cloth.energy": lambda self: {"y": _state(self)},
    "pbanim.cloth.model.Cloth.momentum": lambda self: {"y": _state(self)},
    "pbanim.cloth.model.Cloth.rhs": lambda self: {"t": 0.0, "yf": self.free_state(_state(self))},
    "pbanim.cloth.model.Cloth.jac": lambda self: {"t": 0.0, "yf": self.free_state(_state(self))},
}

SKIP_EDGES = {
    "pbanim.cloth.large_steps.newton_step": "edge values of h (10 s) and of the iteration caps ask Newton for "
                                            "a step whose cost is set by the value",
    "pbanim.cloth.xpbd.xpbd_step": "edge values of substeps and iterations (10⁴ each) ask for 10⁸ sweeps",
    "pbanim.cloth.large_steps.large_step": "the edge max_iter = 10⁵ with an edge tol asks for 10⁵ CG iterations",
}

EXEMPT = {
    "pbanim.cloth.large_steps.PCGResult.__init__": "a result record (filled by modified_pcg, read by the user)",
}
