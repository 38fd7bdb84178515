"""The ``Constraints`` scene effect: λ each force evaluation, Baumgarte feedback or post-step projection.

Stages. ``Constraints(...)`` is an effect of phase "constraint": at every right-hand-side evaluation it
assembles C, J, J̇q̇ at (q, q̇), solves JWJᵀλ = −J̇q̇ − JWQ − k_s C − k_d Ċ with the chosen solver and
returns Q + Jᵀλ. With ``stabilization="projection"`` it also contributes a post-step stage
("constraint-projection") that moves the state back onto C = 0 (Gauss–Newton steps δq = −WJᵀ(JWJᵀ)⁻¹C,
the mass-weighted closest point) and then removes Ċ (q̇ ← q̇ − WJᵀ(JWJᵀ)⁻¹Jq̇).

Baumgarte feedback turns the constraint error into a damped oscillator C̈ + k_d Ċ + k_s C = 0: with
k_s = ω_b², k_d = 2ζω_b the error decays at rate ω_b (critically for ζ = 1). It is a stiff spring with
its own step limit: see :mod:`pbanim.constraints.stability`.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Sequence

import numpy as np

from .assembly import ConstraintSet
from .dense import DenseWitkin, dense_fits
from .kinds import Constraint
from .solvers import SOLVERS, ConstraintSolution, certified, solve_lambda
from ..contracts import Array, Choice, Either, Int, Obj, Opt, Real, Seq, contract, package_code, unchecked
from ..errors import InvalidInput, NonFiniteResult, SimulationDiverged, SingularConstraintError
from ..scene import Effect

__all__ = ["Constraints", "ConstraintProjection", "STABILIZATIONS", "solve_multipliers", "BaumgarteGains",
           "baumgarte_gains", "gains_from_box2d", "gains_from_mujoco", "gains_from_erp_cfm"]

STABILIZATIONS = ("none", "baumgarte", "projection")


_GAIN = Real(ge=0)
_STATE = Array(("self.system.n_state",))
_TIME = Real()


@contract(ks=_GAIN, kd=_GAIN)
@dataclass(frozen=True)
class BaumgarteGains:
    """Baumgarte gains (k_s in 1/s², k_d in 1/s) and the oscillator they make: ω_b = √k_s, ζ = k_d/2ω_b."""

    ks: float
    kd: float

    def __post_init__(self) -> None:    # gains computed inside pbanim from other parameters
        for name in ("ks", "kd"):
            v = getattr(self, name)
            if not (np.isfinite(v) and v >= 0):
                raise InvalidInput(f"Baumgarte gain {name} must be a finite number >= 0, got {v}; the "
                                   "parameters it came from are out of range (too large or too small)")

    @property
    def natural_frequency(self) -> float:
        return float(np.sqrt(self.ks))

    @property
    def damping_ratio(self) -> float:
        return float(self.kd / (2 * np.sqrt(self.ks))) if self.ks > 0 else float("inf")


@contract(natural_frequency=_GAIN, damping_ratio=_GAIN)
def baumgarte_gains(natural_frequency: float, damping_ratio: float = 1.0) -> BaumgarteGains:
    """k_s = ω², k_d = 2ζω.

    >>> baumgarte_gains(10.0, 1.0)
    BaumgarteGains(ks=100.0, kd=20.0)
    """
    w, z = float(natural_frequency), float(damping_ratio)
    return BaumgarteGains(w * w, 2 * z * w)


@contract(hertz=_GAIN, damping_ratio=_GAIN)
def gains_from_box2d(hertz: float, damping_ratio: float) -> BaumgarteGains:
    """Box2D soft constraints (hertz f, damping ratio ζ): ω = 2πf, so k_s = (2πf)², k_d = 2ζ(2πf).

    >>> g = gains_from_box2d(1.0, 0.5); round(g.ks, 6), round(g.kd, 6)
    (39.478418, 6.283185)
    """
    return baumgarte_gains(2 * np.pi * float(hertz), damping_ratio)


@contract(timeconst=Real(gt=0), dampratio=Real(gt=0))
def gains_from_mujoco(timeconst: float, dampratio: float) -> BaumgarteGains:
    """MuJoCo solref (timeconst τ, dampratio ζ), impedance d → 1: k_s = 1/(τ²ζ²), k_d = 2/τ.

    >>> gains_from_mujoco(0.02, 1.0)
    BaumgarteGains(ks=2500.0, kd=100.0)
    """
    tau, z = float(timeconst), float(dampratio)
    with np.errstate(over="ignore", divide="ignore"):   # an overflow is refused by BaumgarteGains
        return BaumgarteGains(float(1.0 / np.float64(tau * tau * z * z)), float(2.0 / np.float64(tau)))


@contract(erp=Real(gt=0, lt=1), cfm=Real(gt=0), h=Real(gt=0), effective_mass=Real(gt=0))
def gains_from_erp_cfm(erp: float, cfm: float, h: float, effective_mass: float = 1.0) -> BaumgarteGains:
    """Bullet/ODE (ERP, CFM) at step h: spring k_p = ERP/(h·CFM), damper c = (1 − ERP)/CFM, per unit of the
    row's effective mass m_eff = 1/(JWJᵀ): k_s = k_p/m_eff, k_d = c/m_eff (needs CFM > 0: CFM = 0 is the
    hard limit k_s, k_d → ∞).

    >>> g = gains_from_erp_cfm(0.2, 0.01, 0.01); round(g.ks, 9), round(g.kd, 9)
    (2000.0, 80.0)
    """
    with np.errstate(over="ignore", divide="ignore", invalid="ignore"):  # refused by BaumgarteGains
        hc, m = np.float64(h * cfm), np.float64(effective_mass)
        return BaumgarteGains(float(erp / hc / m), float((1 - erp) / np.float64(cfm) / m))


@contract(constraints=Either(Obj(ConstraintSet), Seq(Obj(Constraint), min_len=1)),
          system=Obj("pbanim.particles.system:ParticleSystem"), y=Array(("system.n_state",)),
          Q=Opt(Array(("system.N", "system.dim"))), solver=Choice(SOLVERS), ks=_GAIN, kd=_GAIN,
          tol=Real(gt=0), max_iter=Opt(Int(ge=1)), returns=certified)
def solve_multipliers(constraints: Sequence[Constraint] | ConstraintSet, system, y, Q=None, *,
                      solver: str = "auto", ks: float = 0.0, kd: float = 0.0, tol: float = 1e-12,
                      max_iter: int | None = None) -> ConstraintSolution:
    """λ, Q_C = Jᵀλ and q̈ for a particle system at state y under applied force Q (default zero).

    Examples
    --------
    >>> from pbanim.particles import ParticleSystem
    >>> from pbanim.constraints.kinds import OnCircle
    >>> ps = ParticleSystem([[0.0, -1.0]], [[2.0, 0.0]], masses=1.0)
    >>> sol = solve_multipliers([OnCircle([0], [0.0, 0.0], 1.0)], ps, ps.state(), [[0.0, -9.81]])
    >>> round(-float(sol.lam[0]), 10)   # bead tension m(v²/R + g cos θ) at the bottom = 4 + 9.81
    13.81
    """
    cset = constraints if isinstance(constraints, ConstraintSet) else ConstraintSet(
        constraints, system.N, system.dim, system.W, system.x0)
    if cset.n != system.N * system.dim:
        raise InvalidInput(f"solve_multipliers: constraints were assembled for {cset.n} coordinates, the "
                           f"system has {system.N * system.dim}")
    x, v = system.unpack(np.asarray(y, float))
    Qf = np.zeros(cset.n) if Q is None else np.asarray(Q, float).ravel()
    asm = cset.assemble(x, v, pairs=cset.blocks)
    # BEGIN SOLUTION solve_multipliers
    c = -asm.Jdv - ks * asm.C - kd * asm.Cdot
    return solve_lambda(asm.J, cset.Wq, Qf, c, solver, cset=cset, asm=asm, tol=tol, max_iter=max_iter)
    # END SOLUTION


class Constraints(Effect):
    """Constraint forces for a particle scene (phase "constraint"; a projection stage if asked).

    Parameters
    ----------
    constraints : sequence of Constraint
    solver : str
        One of "auto", "witkin-dense", "witkin-sparse", "witkin-cg", "kkt", "linear". "auto" picks
        "linear" for chains and trees, else dense below 64 rows, else sparse.
    stabilization : {"none", "baumgarte", "projection"}
    ks, kd : float, optional
        Baumgarte gains (1/s², 1/s). Or give ``natural_frequency`` (rad/s) and ``damping_ratio``.
    tol, max_iter : CG settings.
    projection_tol : float
        Stop the projection when max|C| ≤ this (units of C).
    max_violation : float, optional
        Raise :class:`SimulationDiverged` when max|C| exceeds it (a blown-up feedback loop).

    Examples
    --------
    >>> from pbanim.particles import ParticleSystem, Gravity
    >>> from pbanim.scene import Scene
    >>> from pbanim.constraints.kinds import Distance
    >>> ps = ParticleSystem([[1.0, 0.0]], masses=1.0)
    >>> eff = Constraints([Distance([[0, -1]], anchors=[0.0, 0.0])], stabilization="projection")
    >>> scene = Scene(ps, [Gravity(), eff])
    >>> scene.pipeline
    ('gravity', 'constraints', 'integrate', 'constraint-projection')
    >>> res = scene.simulate(0.5, 0.01, "symplectic_euler")
    >>> bool(res.diagnostics["C_max"].max() < 1e-12)
    True
    """

    name = "constraints"
    phase = "constraint"

    @contract(constraints=Seq(Obj(Constraint), min_len=1), solver=Choice(SOLVERS),
              stabilization=Choice(STABILIZATIONS), ks=Opt(_GAIN), kd=Opt(_GAIN), natural_frequency=Opt(_GAIN),
              damping_ratio=_GAIN, tol=Real(gt=0), max_iter=Opt(Int(ge=1)), projection_tol=Real(gt=0),
              projection_max_iter=Int(ge=1, le=10_000), max_violation=Opt(Real(gt=0)))
    def __init__(self, constraints: Sequence[Constraint], solver: str = "auto", stabilization: str = "none",
                 ks: float | None = None, kd: float | None = None, *, natural_frequency: float | None = None,
                 damping_ratio: float = 1.0, tol: float = 1e-12, max_iter: int | None = None,
                 projection_tol: float = 1e-13, projection_max_iter: int = 20,
                 max_violation: float | None = None) -> None:
        if stabilization == "baumgarte":
            if natural_frequency is not None:
                g = baumgarte_gains(natural_frequency, damping_ratio)
                ks, kd = g.ks, g.kd
            elif ks is None and kd is None:
                raise InvalidInput("stabilization='baumgarte' needs ks and kd, or natural_frequency "
                                 "(and damping_ratio)")
        elif (ks or kd or natural_frequency):
            raise InvalidInput(f"ks, kd and natural_frequency only apply to stabilization='baumgarte', "
                             f"got stabilization={stabilization!r}")
        self.constraints = list(constraints)
        self.solver, self.stabilization = solver, stabilization
        self.ks, self.kd = float(ks or 0.0), float(kd or 0.0)
        self.tol, self.max_iter = tol, max_iter
        self.projection_tol, self.projection_max_iter = float(projection_tol), int(projection_max_iter)
        self.max_violation = max_violation
        self._last: ConstraintSolution | None = None
        self.lean_path = True           # a small set solves on dense arrays (pbanim.constraints.dense)
        self._dense: DenseWitkin | None = None

    @property
    def last(self) -> ConstraintSolution | None:
        """The solve of the last evaluation (after a dense solve, built when read)."""
        if self._last is None and self._dense is not None and self._dense.last is not None:
            _, _, lam, QC, r = self._dense.last
            Q = self._dense_Q
            self._last = ConstraintSolution(lam, QC, (Q + QC) * self.cset.Wq, "witkin-dense", 0, False, None,
                                            (self._dense.J.copy(), self.cset.Wq, r))
        return self._last

    def stages(self) -> list[Effect]:
        """The stages this effect adds to a scene: itself, plus the projection when asked."""
        return [self, ConstraintProjection(self)] if self.stabilization == "projection" else [self]

    @contract(system=Obj("pbanim.particles.system:ParticleSystem"))
    def bind(self, system) -> None:
        self.system = system
        self.cset = ConstraintSet(self.constraints, system.N, system.dim, system.W, system.x0)
        self._unpack = unchecked(system.unpack)     # the step loop's own calls pay no argument check
        # the dense solve is this module's solve on dense arrays: a copy of the module (a course assignment cut
        # from it) or a subclass that replaces the solve runs its own (pbanim.contracts.package_code)
        own = package_code(self, "constrain", "_solve", "_solved")
        self._dense = DenseWitkin(self.cset) if own and dense_fits(self.cset, self.solver) else None

    def _solve(self, x, v, Qf, ks, kd, t=0.0) -> tuple[ConstraintSolution, object]:
        cset = self.cset
        asm = cset.assemble(x, v, pairs=cset.blocks and self.solver not in ("kkt", "witkin-cg"))
        if self.max_violation is not None:
            cmax = float(np.max(np.abs(asm.C), initial=0.0))
            if not cmax <= self.max_violation:
                raise SimulationDiverged(t, -1, "constraint violation C",
                                         f"max|C| = {cmax:.3e} > max_violation = {self.max_violation:.3e}")
        # BEGIN SOLUTION Constraints._solve
        c = -asm.Jdv - ks * asm.C - kd * asm.Cdot
        sol = solve_lambda(asm.J, cset.Wq, Qf, c, self.solver, cset=cset, asm=asm, tol=self.tol,
                           max_iter=self.max_iter)
        return sol, asm
        # END SOLUTION

    def _solved(self, x, v, Qf, t):
        """:meth:`_solve`, with a NaN or inf state or force met during a run named as a divergence."""
        try:
            return self._solve(x, v, Qf, self.ks, self.kd, t)
        except NonFiniteResult:
            _diverged(t, x, v, Qf)
            raise

    def _lam(self, asm, Qf, c, t) -> ConstraintSolution:
        """solve_lambda with this effect's settings (the projection's solves), a NaN state named as in _solved."""
        try:
            return solve_lambda(asm.J, self.cset.Wq, Qf, c, self.solver, cset=self.cset, asm=asm, tol=self.tol,
                                max_iter=self.max_iter)
        except NonFiniteResult:
            _diverged(t, asm.C, asm.v, Qf)
            raise

    @contract(t=_TIME, y=_STATE, Q=Array(("self.system.N", "self.system.dim")))
    def constrain(self, t, y, Q):
        x, v = self._unpack(y)
        if self._dense is not None and self.lean_path:
            Qf = Q.reshape(-1)
            out = self._dense.solve(x, v, Qf, self.ks, self.kd)
            if out is not None and (self.max_violation is None or np.abs(out[0]).max() <= self.max_violation):
                self._last, self._dense_Q = None, Qf.copy()     # last's q̈ = W (Q + Q_C), whatever Q becomes
                return Q + out[3].reshape(Q.shape)
        sol, _ = self._solved(x, v, np.array(Q, float).ravel(), t)
        self._last = sol
        return Q + sol.Q_C.reshape(Q.shape)

    @contract(t=_TIME, y=_STATE)
    def diagnostics(self, t, y) -> dict:
        """C_max, Cdot_max, and λ at (t, y) with the applied forces at (t, y) (from the scene that holds
        this effect; zero outside a scene). Nothing carries over from an earlier evaluation or run."""
        x, v = self.system.unpack(y)
        Qf = np.ravel(self.applied(t, y)) if self.applied is not None else np.zeros(self.cset.n)
        if self._dense is not None and self.lean_path:
            # a small set: the dense solve of the step (equal to the readable one to roundoff, ORACLES B5); the
            # last step's solve is kept first (``last`` reads the dense buffers this solve rewrites)
            self.last  # noqa: B018  (materialized: it copies the dense J)
            kept = self._dense.last
            out = self._dense.solve(x, v, Qf, self.ks, self.kd)
            self._dense.last = kept
            if out is not None and (self.max_violation is None or np.abs(out[0]).max() <= self.max_violation):
                C, Cdot, lam, _ = out
                return {"C_max": float(np.max(np.abs(C), initial=0.0)),
                        "Cdot_max": float(np.max(np.abs(Cdot), initial=0.0)), "lam": lam}
        sol, asm = self._solved(x, v, Qf, t)
        return {"C_max": float(np.max(np.abs(asm.C), initial=0.0)),
                "Cdot_max": float(np.max(np.abs(asm.Cdot), initial=0.0)), "lam": sol.lam}

    @contract(y=_STATE)
    def project(self, y: np.ndarray) -> np.ndarray:
        """Project y onto C = 0 (mass-weighted Gauss–Newton), then onto Ċ = 0; returns a new state."""
        return self._project(y, 0.0)

    def _project(self, y: np.ndarray, t: float) -> np.ndarray:
        y = np.array(y, float)
        x, v = self.system.unpack(y)
        zero = np.zeros(self.cset.n)
        cmax = np.inf
        for _ in range(self.projection_max_iter):
            asm = self.cset.assemble(x, v, pairs=self.cset.blocks and self.solver not in ("kkt", "witkin-cg"))
            cmax = float(np.max(np.abs(asm.C), initial=0.0))
            if cmax <= self.projection_tol:
                break
            # J δq = −C with the smallest mass-weighted δq: the Witkin/KKT system with Q = 0, c = −C
            x += self._lam(asm, zero, -asm.C, t).qdd.reshape(x.shape)
        else:
            asm = self.cset.assemble(x, v, pairs=False)
            cmax = float(np.max(np.abs(asm.C), initial=0.0))
            if cmax > self.projection_tol:
                bad = np.flatnonzero(np.abs(asm.C) > self.projection_tol)
                raise SingularConstraintError(bad[:20], cmax, f"position projection did not reach "
                                              f"|C| <= {self.projection_tol:g} in {self.projection_max_iter} steps")
        asm = self.cset.assemble(x, v, pairs=self.cset.blocks and self.solver not in ("kkt", "witkin-cg"))
        v += self._lam(asm, zero, -asm.Cdot, t).qdd.reshape(v.shape)
        return y


def _diverged(t, *arrays) -> None:
    """SimulationDiverged when one of the arrays (state, forces) is not finite: a run reached NaN or inf."""
    if not all(np.isfinite(a).all() for a in arrays):
        raise SimulationDiverged(t, -1, "state or applied force", "met by the constraint solve") from None


class ConstraintProjection(Effect):
    """Post-step stage of :class:`Constraints` with ``stabilization="projection"``."""

    name = "constraint-projection"
    phase = "post_step"

    @contract(owner=Obj(Constraints))
    def __init__(self, owner: Constraints) -> None:
        self.owner = owner

    @contract(t=_TIME, y=Array(("self.owner.system.n_state",)), h=Real(gt=0))
    def post_step(self, t, y, h):
        return self.owner._project(y, t)
