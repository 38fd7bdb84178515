"""Valid calls for pbanim.constraints (chapter 03)."""

import numpy as np

from pbanim.constraints import (Angle2D, Constraints, Distance, FixedPoint, LinearCombination, OnCircle, OnLine,
                                OnPlane, UserConstraint)
from pbanim.constraints.assembly import ConstraintSet
from pbanim.constraints.effect import ConstraintProjection
from pbanim.constraints.kinds import Constraint
from pbanim.particles import ParticleSystem
from pbanim.scene import Scene


def _pendulum():
    """Two particles: a rod from the origin to the first, a rod between them (a double pendulum)."""
    return ParticleSystem([[1.0, 0.0], [2.0, 0.5]], [[0.0, 0.3], [0.1, 0.0]], masses=[1.0, 2.0])


def _rods():
    return [Distance([[0, -1], [0, 1]], anchors=[0.0, 0.0])]


def _effect():
    eff = Constraints(_rods(), stabilization="baumgarte", ks=4.0, kd=4.0)
    Scene(_pendulum(), [eff])     # binds it
    return eff


def _cset():
    ps = _pendulum()
    return ConstraintSet(_rods(), ps.N, ps.dim, ps.W, ps.x0)


def _star_x0(n=21):
    return np.c_[np.cos(np.arange(n)), np.sin(np.arange(n))] * np.arange(n)[:, None]


def _star():
    """A tree: 20 rods from particle 0 (nailed) to particles 1…20 (leaves-first order, bandwidth > 16)."""
    n = 21
    rods = Distance(np.c_[np.zeros(n - 1, int), np.arange(1, n)])
    return ConstraintSet([rods, FixedPoint([0])], n, 2, np.ones(n), _star_x0())


def _angle():
    """A bending angle at particle 1 of three (its own system: N = 3)."""
    c = Angle2D([[0, 1, 2]], 0.3)
    c.bind(3, 2, np.array([[1.0, 0.0], [0.0, 0.0], [0.0, 1.0]]))
    return c


def _bound(c):
    """A kind bound to the pendulum's two particles (N = 2, dim = 2)."""
    ps = _pendulum()
    c.bind(ps.N, ps.dim, ps.x0)
    return c


def _user():
    # the bead on the unit circle, written by hand: C = ½(|x₀|² − 1)
    return UserConstraint(lambda x: [0.5 * (x[0] @ x[0] - 1.0)],
                          lambda x: np.r_[x[0], np.zeros(x.size - 2)][None, :],
                          lambda x, v: [v[0] @ v[0]], m=1)


def _asm(cs):
    x = np.array([[1.0, 0.0], [2.0, 0.5]])
    return {"asm": cs.assemble(x, np.zeros_like(x))}


def _solve_args():
    # m = n = 2 (a bead on a circle and on a line through its centre: two independent rows on one particle in
    # 2-D), the sizes the contract's own examples use for the symbols m and n when it varies another argument
    bead = ParticleSystem([[0.6, -0.8]], [[0.8, 0.6]])
    cs = ConstraintSet([OnCircle([0], [0.0, 0.0], 1.0), OnLine([0], [0.0, 0.0], [0.6, -0.8])], 1, 2, bead.W, bead.x0)
    asm = cs.assemble(bead.x0, bead.v0)
    return {"J": asm.J, "W": cs.Wq, "Q": np.array([0.0, -9.81]), "c": -asm.Jdv, "cset": cs, "asm": asm}


INSTANCES = {
    ParticleSystem: _pendulum,
    Constraint: lambda: _bound(_rods()[0]),
    Distance: lambda: _bound(_rods()[0]),
    FixedPoint: lambda: _bound(FixedPoint([1])),
    OnCircle: lambda: _bound(OnCircle([0], [0.0, 0.0], 1.0)),
    OnLine: lambda: _bound(OnLine([1], [0.0, 0.5], [1.0, 0.0])),
    OnPlane: lambda: _bound(OnPlane([0, 1], [0.0, 0.0], [0.0, 1.0])),
    LinearCombination: lambda: _bound(LinearCombination([[0, 1]], [[0, 1]], [[1.0, -2.0]], [0.0])),
    Angle2D: _angle,
    UserConstraint: _user,
    Constraints: _effect,
    ConstraintSet: _cset,
}

CALLS = {
    "pbanim.constraints.effect.solve_multipliers": lambda: {"system": _pendulum(), "constraints": _rods()},
    "pbanim.constraints.effect.Constraints.__init__": lambda: {"constraints": _rods()},
    "pbanim.constraints.check.UserConstraint.__init__": lambda: {"C": _user().C_fun, "J": _user().J_fun,
                                                                 "Jdot_qdot": _user().Jd_fun},
    "pbanim.constraints.check.check_constraint": lambda: {"c": _rods()[0], "q": _pendulum().x0,
                                                          "qd": _pendulum().v0},
    "pbanim.constraints.assembly.ConstraintSet.__init__": lambda: {"constraints": _rods(), "N": 2, "dim": 2},
    "pbanim.constraints.assembly.ConstraintSet.matrix": _asm,
    "pbanim.constraints.assembly.ConstraintSet.bands": _asm,
    "pbanim.constraints.assembly.ConstraintSet.tridiagonal": _asm,
    "pbanim.constraints.solvers.solve_lambda": _solve_args,
    # a two-rod chain's JWJᵀ, eliminated leaves first (m = 2, the contract's own size for the symbol m)
    "pbanim.constraints.solvers.eliminate_readable": lambda: {
        "A": np.array([[2.0, -1.0], [-1.0, 2.0]]), "r": np.array([1.0, 0.5]), "order": np.array([1, 0])},
    "pbanim.constraints.solvers.min_norm_lambda": lambda: {"A": np.array([[1.0, 1.0], [1.0, 1.0]]),
                                                           "r": np.array([2.0, 2.0])},
}

# the contract's own example of dim = Int(ge=2, le=2) is 3 (lower bound + 1): give the valid call
CALLS["pbanim.constraints.kinds.Angle2D.bind"] = lambda c: {"N": 3, "dim": 2}

SELF = {
    "pbanim.constraints.assembly.ConstraintSet.permuted_matrix": _star,
}

CALLS["pbanim.constraints.assembly.ConstraintSet.permuted_matrix"] = lambda cs: {
    "asm": cs.assemble(_star_x0(), np.zeros((21, 2)))}

INSTANCES[ConstraintProjection] = lambda: _effect_with_projection()


def _effect_with_projection():
    eff = Constraints(_rods(), stabilization="projection")
    scene = Scene(_pendulum(), [eff])
    return scene.effects[-1]


_RECORD = "a result record that pbanim builds and the user only reads"
EXEMPT = {
    "pbanim.constraints.assembly.Assembly.__init__": _RECORD + " (ConstraintSet.assemble makes it)",
    "pbanim.constraints.assembly.Structure.__init__": _RECORD + " (ConstraintSet finds it at construction)",
    "pbanim.constraints.solvers.ConstraintSolution.__init__": _RECORD + " (every solver of λ returns one)",
    "pbanim.constraints.solvers.EliminationResult.__init__": _RECORD + " (eliminate_readable returns it)",
    "pbanim.constraints.check.ConstraintCheck.__init__": _RECORD + " (check_constraint returns it)",
}
