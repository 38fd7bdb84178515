"""The cloth: a particle system, its conditions, gravity, pins and colliders, with f, K = ∂f/∂x and D = ∂f/∂v.

A :class:`Cloth` is the chapter-01 :class:`~pbanim.particles.ParticleSystem` of a :class:`Sheet` (masses
lumped by area; flat state y = [x, v], 3N coordinates each) with one of two force models, both built from
conditions C(x) with energy ½ k CᵀC (:mod:`pbanim.cloth.conditions`):

==========  ==========================================================================================
model       conditions (stiffness arguments, in their units)
==========  ==========================================================================================
"springs"   structural, shear and bend springs C = |x_a − x_b| − r  (``stretch``, ``shear``, ``bend``: N/m)
"bw"        Baraff–Witkin stretch and shear per triangle, C = a(|w_u| − 1, |w_v| − 1, w_u·w_v), with the
            per-triangle k = stretch/a, shear/a so the energy is ½ k_s a (|w| − 1)² (``stretch``, ``shear``:
            N/m, an areal stiffness: a uniaxial strain ε stores ½ k_s ε² per m², as the structural springs
            do); bend per hinge C = θ − θ₀ (``bend``: N·m per rad²)
==========  ==========================================================================================

Damping is stiffness-proportional (Rayleigh): k_d = β k for every condition (``damping`` = β, in s), so a
condition's mode of frequency ω is damped at the rate ½ β ω² and XPBD's damping is the same β
(:mod:`pbanim.cloth.xpbd`). Gravity adds f = M g, with energy −Σ mᵢ g·xᵢ.

Pinned particles never move: the equations of motion are those of the free particles F,

    ẋ_F = v_F,    M_F v̇_F = f_F(x, v),        y_F = [x_F, v_F]    (:meth:`Cloth.rhs`, :meth:`Cloth.jac`),

which is what pbanim's and scipy's ODE solvers integrate (the Jacobian [[0, I], [W K_FF, W D_FF]] sparse,
filled on the fixed pattern of :mod:`pbanim.cloth.assembly`); the large-step and XPBD solvers work on the full
state and hold the pins by their filter and zero inverse mass. Without pins, :meth:`Cloth.scene` is the same
cloth as a chapter-01 :class:`~pbanim.scene.Scene` (conditions as force effects, :class:`Gravity`).

Limiting cases (ORACLES J2): without gravity and pins every force is internal (Σ f = 0, linear and
angular momentum kept); undamped, E = T + V is a first integral, kept to O(h²) without drift by Verlet.

References: D. Baraff, A. Witkin, "Large steps in cloth simulation", SIGGRAPH 1998; X. Provot, Graphics
Interface 1995 (spring cloth); A. Witkin, D. Baraff, *Physically Based Modeling* (2001), particle systems.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp

from .assembly import FreeJacobian, Pattern
from .bend import BendCondition
from .lean_terms import bend_data, triangle_terms
from .collide import Ground, Sphere
from .conditions import SpringCondition, TriangleCondition
from .sheet import Sheet
from ..contracts import Array, Choice, Either, Obj, Real, Seq, contract, finite_result
from ..errors import InvalidInput, NonFiniteResult
from ..particles import ForceJacobian, Gravity, ParticleSystem
from ..scene import Effect, Scene

__all__ = ["Cloth", "MODELS"]

MODELS = ("springs", "bw")
_STIFF = Real(ge=0, le=1e9)
_Y = Array(("self.n_state",))
_YF = Array(("self.n_free_state",))


def _finite_matrices(value, where, arguments=None):
    """``returns`` certificate of :meth:`Cloth.jacobians`: both sparse matrices have finite entries."""
    for m in value:
        if not np.isfinite(m.data).all():
            raise NonFiniteResult(f"the result of {where}", "a degenerate element (zero length or area) or an "
                                                           "overflowing state")
    return value


def _finite_matrix(value, where, arguments=None):
    """``returns`` certificate of :meth:`Cloth.jac`: one sparse matrix with finite entries."""
    _finite_matrices((value,), where)
    return value


class ClothForces(Effect):
    """One condition kind of a cloth as a chapter-01 force effect (for :meth:`Cloth.scene`)."""

    phase = "force"

    def __init__(self, conditions, name: str) -> None:
        self.conditions, self.name = conditions, name

    def bind(self, system) -> None:
        self.system = system

    def apply(self, t, y, Q) -> None:
        x, v = self.system.unpack(y)
        Q += self.conditions.forces(x, v).reshape(Q.shape)

    def potential_energy(self, y) -> float:
        return self.conditions.energy(self.system.unpack(y)[0])

    def jacobian(self, t, y) -> ForceJacobian:
        x, v = self.system.unpack(y)
        _, Ke, De = self.conditions.terms(x, v)
        n, d = x.size, self.conditions.dofs
        rows, cols = np.broadcast_arrays(d[:, :, None], d[:, None, :])
        mat = lambda b: sp.csr_matrix((b.ravel(), (rows.ravel(), cols.ravel())), shape=(n, n))  # noqa: E731
        return ForceJacobian(mat(Ke), None if De is None else mat(De))


@contract(sheet=Obj(Sheet), model=Choice(MODELS), stretch=_STIFF, shear=_STIFF, bend=_STIFF,
          damping=Real(ge=0, le=10.0), gravity=Array((3,), ge=-1e3, le=1e3),
          colliders=Seq(Obj(Sphere, Ground), max_len=8), thickness=Real(ge=0, le=1.0))
class Cloth:
    """A sheet with forces: f(x, v), K, D, energies, and the free-particle ODE (see the module).

    Parameters
    ----------
    sheet : Sheet
    model : {"springs", "bw"}
    stretch, shear, bend : float
        Stiffnesses (units per model, module docstring); 0 switches a kind off.
    damping : float
        Rayleigh factor β (s): k_d = β k.
    gravity : (3,) array (m/s²)
    colliders : sequence of Sphere / Ground
        Used by the large-step and XPBD solvers (the ODE solvers run collision-free cloth).
    thickness : float
        Contact distance (m).

    Examples
    --------
    >>> cloth = Cloth(Sheet(4), stretch=1e3)
    >>> y = cloth.state(); f = cloth.forces(y)
    >>> bool(np.allclose(f.sum(axis=0), cloth.sheet.masses.sum() * cloth.gravity))   # at rest: gravity only
    True
    """

    def __init__(self, sheet: Sheet, model: str = "springs", stretch: float = 1e3, shear: float = 1e2,
                 bend: float = 1.0, damping: float = 0.0, gravity=(0.0, 0.0, -9.81), colliders=(),
                 thickness: float = 0.005) -> None:
        self.sheet, self.model, self.beta = sheet, model, float(damping)
        self.stretch, self.shear, self.bend = float(stretch), float(shear), float(bend)
        self.gravity = np.asarray(gravity, dtype=float).copy()
        self.colliders, self.thickness = list(colliders), float(thickness)
        self.system = ParticleSystem(sheet.x0, masses=sheet.masses)
        self.conditions = self._conditions()
        N = sheet.n_particles
        self.n = 3 * N
        self.mass3 = np.repeat(sheet.masses, 3)
        self.winv = 1.0 / self.mass3
        self.fext = (sheet.masses[:, None] * self.gravity).ravel()
        self.pattern = Pattern(self.n, [c.dofs for c in self.conditions],
                               [c.elements if hasattr(c, "pair_terms") else None for c in self.conditions])
        self.pinned = sheet.pinned
        self.lean_path = True            # False: the large steps' CG takes the readable _pcg (ORACLES J13) and
                                         # their bend terms the readable assembly (ORACLES J14)
        self.lean_terms = True           # False: the readable bend and triangle terms alone (J13 compares the CGs
                                         # on them)
        free = np.ones(N, bool)
        free[self.pinned] = False
        self.free_particles = np.flatnonzero(free)
        self.free = np.repeat(free, 3)
        self.nf = int(self.free.sum())
        self._jac_free = FreeJacobian(self.pattern, self.free, self.winv)

    def _conditions(self):
        s, b = self.sheet, self.beta
        out = []
        if self.model == "springs":
            d = s.spacing
            for kind, k, rest in (("structural", self.stretch, d), ("shear", self.shear, d * np.sqrt(2.0)),
                                  ("bend", self.bend, 2.0 * d)):
                if k > 0 and len(s.springs[kind]):
                    c = SpringCondition(s.springs[kind], rest, k, b * k)
                    c.kind = kind
                    out.append(c)
            return out
        tri = TriangleCondition(s.triangles, s.uv, 0.0, 0.0)
        k = np.stack([self.stretch / tri.area, self.stretch / tri.area, self.shear / tri.area], axis=1)
        tri.k, tri.kd = k, b * k
        if self.stretch > 0 or self.shear > 0:
            out.append(tri)
        if self.bend > 0 and len(s.hinges):
            out.append(BendCondition(s.hinges, s.x0, self.bend, b * self.bend))
        return out

    # -- sizes and states ---------------------------------------------------------------------------
    @property
    def n_state(self) -> int:
        """6N: the full state [x, v]."""
        return 2 * self.n

    @property
    def n_free_state(self) -> int:
        """2 n_F: the state [x_F, v_F] of the free particles."""
        return 2 * self.nf

    def state(self) -> np.ndarray:
        """The rest state [x₀, 0] (full)."""
        return self.system.state()

    @contract(y=_Y)
    def free_state(self, y) -> np.ndarray:
        """[x_F, v_F] of a full state."""
        return np.concatenate([y[:self.n][self.free], y[self.n:][self.free]])

    @contract(yf=_YF)
    def full_state(self, yf) -> np.ndarray:
        """The full state of a free one (pinned particles at rest at their rest positions)."""
        y = self.state()
        y[self.n:] = 0.0
        y[:self.n][self.free], y[self.n:][self.free] = yf[:self.nf], yf[self.nf:]
        return y

    # -- forces and Jacobians -----------------------------------------------------------------------
    def _forces(self, x, v):
        """f (n,) at x, v (N, 3): conditions + gravity."""
        f = self.fext.copy()
        for c in self.conditions:
            fe = c.terms(x, v, jacobians=False)[0]
            f += np.bincount(c.dofs.ravel(), fe.ravel(), minlength=self.n)
        return f

    def _all(self, x, v, exact=True):
        """f (n,), K.data and D.data on the pattern (D.data None when undamped; ``exact=False``: K without
        its unsymmetric damping term, for the CG solves: then, unless ``lean_path`` or ``lean_terms`` is False,
        the bend hinges' data and the triangles' blocks by :mod:`pbanim.cloth.lean_terms`, equal to roundoff,
        ORACLES J14)."""
        f = self.fext.copy()
        Kb, Db = [], []
        use_lean = not exact and self.lean_path and self.lean_terms and not self.pattern.pair_kinds
        lean = [i for i, c in enumerate(self.conditions) if use_lean and isinstance(c, BendCondition)]
        for i, (c, reduced) in enumerate(zip(self.conditions, self.pattern.reduced)):
            if i in lean:                          # its data below, by the lean twin (ORACLES J14)
                fe, Ke, De = bend_data(c, x, v, self.pattern.maps[i], self.pattern.nnz)
            elif use_lean and isinstance(c, TriangleCondition):
                fe, Ke, De = triangle_terms(c, x, v)
            else:
                fe, Ke, De = c.pair_terms(x, v, exact) if reduced else c.terms(x, v, True, exact)
            f += np.bincount(c.dofs.ravel(), fe.ravel(), minlength=self.n)
            Kb.append(Ke)
            Db.append(De)
        damped = any(d is not None for d in Db)
        return f, self.pattern.data(Kb), (self.pattern.data(Db) if damped else None)

    @contract(y=_Y, returns=finite_result)
    def forces(self, y) -> np.ndarray:
        """f = Σ conditions + M g, shape (N, 3) (N)."""
        x, v = self.system.unpack(y)
        with np.errstate(all="ignore"):
            return self._forces(x, v).reshape(-1, 3)

    @contract(y=_Y, returns=_finite_matrices)
    def jacobians(self, y) -> tuple[sp.csr_matrix, sp.csr_matrix]:
        """(K, D) = (∂f/∂x, ∂f/∂v), sparse 3N × 3N on the fixed pattern (D all zero when undamped)."""
        x, v = self.system.unpack(y)
        with np.errstate(all="ignore"):
            _, kd, dd = self._all(x, v)
        return self.pattern.matrix(kd), self.pattern.matrix(np.zeros_like(kd) if dd is None else dd)

    @contract(y=_Y, returns=finite_result)
    def energy(self, y) -> float:
        """E = ½ vᵀMv + Σ ½ k CᵀC − Σ mᵢ g·xᵢ (J)."""
        x, v = self.system.unpack(y)
        with np.errstate(all="ignore"):
            V = sum(c.energy(x) for c in self.conditions)
            return float(0.5 * np.dot(self.mass3, v.ravel() ** 2) + V - np.dot(self.fext, x.ravel()))

    @contract(y=_Y, returns=finite_result)
    def momentum(self, y) -> np.ndarray:
        """Σ mᵢ vᵢ (kg m/s)."""
        return self.system.linear_momentum(y)

    # -- the ODE of the free particles ---------------------------------------------------------------
    def _split(self, yf):
        y = self._full_buffer()
        y[:self.n][self.free], y[self.n:][self.free] = yf[:self.nf], yf[self.nf:]
        return y[:self.n].reshape(-1, 3), y[self.n:].reshape(-1, 3)

    def _full_buffer(self):
        y = np.empty(2 * self.n)
        y[:self.n] = self.sheet.x0.ravel()
        y[self.n:] = 0.0
        return y

    @contract(t=Real(), yf=_YF, returns=finite_result)
    def rhs(self, t: float, yf) -> np.ndarray:
        """ẏ_F = [v_F, W_F f_F(x, v)] (autonomous: ``rhs.autonomous`` is True for pbanim's Rosenbrock)."""
        x, v = self._split(yf)
        out = np.empty_like(yf)
        out[:self.nf] = yf[self.nf:]
        out[self.nf:] = self._forces(x, v)[self.free] * self.winv[self.free]
        return out

    @contract(t=Real(), yf=_YF, returns=_finite_matrix)
    def jac(self, t: float, yf) -> sp.csr_matrix:
        """∂ẏ_F/∂y_F = [[0, I], [W K_FF, W D_FF]], sparse CSR (2 n_F)²."""
        x, v = self._split(yf)
        _, kd, dd = self._all(x, v)
        return self._jac_free.matrix(kd, dd)

    def scene(self) -> Scene:
        """The free cloth as a chapter-01 Scene: the ParticleSystem, one force effect per condition kind and
        Gravity (InvalidInput for a pinned cloth: pins are not chapter-01 effects)."""
        if len(self.pinned):
            raise InvalidInput(f"Cloth.scene: the cloth has {len(self.pinned)} pinned particles; a Scene holds "
                               "free cloth only (use Sheet(..., pins='none'), or Cloth.rhs / Cloth.jac)")
        return Scene(self.system, [ClothForces(c, c.kind) for c in self.conditions] + [Gravity(self.gravity)])

    def __repr__(self) -> str:
        kinds = ", ".join(f"{c.kind} {len(c)}" for c in self.conditions)
        return f"Cloth({self.sheet!r}, model={self.model!r}: {kinds}; β = {self.beta:g} s)"


Cloth.rhs.autonomous = True      # f does not depend on t: pbanim's RODAS4 skips its ∂f/∂t difference
