"""Scenes: bodies + declared effects → a step pipeline (every chapter).

A :class:`Scene` is built from one *mechanical system* (particles, rigid bodies, ...) and a list of
declared *effects* (gravity, drag, springs, constraints, collisions, resting contact, controllers...).
Building it assembles ``scene.pipeline``, the ordered names of the stages that will run:

    force effects (declaration order)  →  constraint effects  →  integrate[method]  →  post-step effects

A stage that is not declared is never called, allocates nothing and imports nothing: a scene without
springs never touches spring code, a scene without resting contact never imports qpsolvers.

The system protocol (implemented by :class:`pbanim.particles.ParticleSystem`, :class:`pbanim.rigid.RigidBodies`)
------------------------------------------------------------------------------------------------------------
``split``                         number of position components at the front of the flat state y = [q, v]
``state()``                       the current (initial) state, a fresh flat float64 array
``zero_forces()``                 a zeroed generalized-force array Q (e.g. shape (N, dim); (N, 6) for rigid bodies)
``derivative(y, Q)``              dy/dt given the total generalized force Q
``kinetic_energy(y)``             T
``linear_momentum(y)``            P, shape (dim,)
``angular_momentum(y)``           L about the origin

The effect protocol (subclass :class:`Effect`)
----------------------------------------------
``name``                          the stage name shown in ``scene.pipeline``
``phase``                         "force" | "constraint" | "post_step"
``bind(system)``                  validate against the system (indices in range, shapes), precompute
``apply(t, y, Q)``                force phase: add generalized forces into Q in place
``constrain(t, y, Q) -> Q``       constraint phase: return Q + Q_C (the constraint force Jᵀλ)
``post_step(t, y, h) -> y``       post-step phase: impulses, projections (may return y unchanged)
``potential_energy(y)``           optional: V of a conservative force (summed into the scene energy)
``diagnostics(t, y) -> dict``     optional: per-step scalars/arrays recorded in ``SimResult.diagnostics``
``stages() -> list``              optional: the stage effects it contributes (default: itself), e.g. a
                                  constraint effect plus its post-step projection
``jacobian(t, y)``                optional: ∂Q/∂x, ∂Q/∂v as a ``ForceJacobian`` (sparse, ``None`` = zero);
                                  when every force effect has one, :meth:`Scene.jac` assembles the state
                                  Jacobian and implicit methods use it instead of finite differences

Plans: the same step, less interpreter (issue 28)
------------------------------------------------
What a step computes is fixed by the pipeline; how much Python surrounds it is chosen once per run, when
the run starts (:mod:`pbanim.scene.plans`): a scene whose forces are all linear (``linear = True``:
gravity, drag, anchor springs) and whose state is small steps by y₁ = S y + s with S the method's
stability matrix; symplectic Euler on particles without constraints kicks and drifts into preallocated
buffers with affine forces folded (``scene.fold_affine``); any other scene runs the method's step on f bound
as one closure. Every plan equals the readable step to roundoff; ``scene.lean_path = False`` runs the
readable one. Optional effect attributes they read: ``linear`` (Q = c + K_x x + K_v v with constant c, K_x,
K_v, which ``jacobian`` returns), ``affine() -> (c, d)`` (Qᵢ = cᵢ + dᵢ vᵢ per particle).

Symplectic Euler's drift q₁ = q₀ + h q̇(q₀, v₁) takes q̇ from ``system.derivative(y₁, zero_forces())``
(position rates never depend on Q): one force/constraint evaluation per step, bit for bit the generic
two-evaluation step for stateless effects (a warm start comes from the kick's solve); an effect that
must see the discarded second evaluation sets ``drift_free = False`` (the generic step then runs).

Diagnostics (issue 28, point 2): a run records states; energies, momenta and the effects' series are
computed from them when ``result.diagnostics`` is first read (``diagnostics="lazy"``, the default), or at the
recorded times during the run when asked (``diagnostics=True``); what each costs: ``pbanim bench particles``.
"""

from __future__ import annotations

import time
from typing import Any, Sequence

import numpy as np

import scipy.sparse as sp

from ..contracts import (Array, Choice, Either, Flag, Has, Int, Opt, Real, Seq, contract, finite_result, package_code,
                         unchecked)
from ..errors import InvalidInput, SimulationDiverged
from ..ode import METHODS, get_method
from ..ode.driver import MAX_STEPS, check_finite, drive, drive_lean, fixed_steps, step_grid
from ..results import LazyDiagnostics, SimResult
from .plans import KickDrift, advance, float_plan, linear_scene

__all__ = ["Effect", "Scene", "check_finite", "fixed_steps"]

_PHASES = ("force", "constraint", "post_step")
_DIAGNOSTICS = Either(Flag(), Choice(("lazy",)))


def _series(diags: list) -> dict:
    """Per-recorded-time dicts → one array per key."""
    return {key: np.array([d[key] for d in diags]) for key in (diags[0] if diags else {})}


def _history(effects):
    """The diagnostics of the effects that describe the step just taken (read during the run), or None."""
    stateful = [unchecked(e.diagnostics) for e in effects
                if getattr(e, "history_diagnostics", False) and callable(getattr(e, "diagnostics", None))]
    if not stateful:
        return None

    def during(t, y):
        d: dict = {}
        for f in stateful:
            d.update(f(t, y))
        return d
    return during
_SYSTEM = Has("split", "state", "zero_forces", "derivative",
              what="a mechanical system (split, state(), zero_forces(), derivative(y, Q))")
_EFFECT = Has("phase", "bind", what="an effect (a pbanim.scene.Effect: phase, bind(system), ...)")
_T = Real()
_Y = Array(("self.n_state",))
_METHOD = Choice(lambda: METHODS)


class Effect:
    """Base class of a declared effect; override the hooks of your phase."""

    name: str = "effect"
    phase: str = "force"
    # False: symplectic Euler must also evaluate it at (q₀, v₁) (see the module docstring)
    drift_free: bool = True
    # constraint phase: set by Scene to applied_forces(t, y) -> Q of the scene's force effects
    applied = None

    def bind(self, system: Any) -> None:
        """Validate against ``system`` and precompute; called once by :class:`Scene`."""

    def apply(self, t: float, y: np.ndarray, Q: np.ndarray) -> None:  # pragma: no cover - interface
        raise NotImplementedError(f"{type(self).__name__} declares phase 'force' but has no apply()")

    def constrain(self, t: float, y: np.ndarray, Q: np.ndarray) -> np.ndarray:  # pragma: no cover
        raise NotImplementedError(f"{type(self).__name__} declares phase 'constraint' but has no constrain()")

    def post_step(self, t: float, y: np.ndarray, h: float) -> np.ndarray:  # pragma: no cover
        raise NotImplementedError(f"{type(self).__name__} declares phase 'post_step' but has no post_step()")


class Scene:
    """A mechanical system and its declared effects.

    Parameters
    ----------
    system : mechanical system
        See the module docstring for the protocol.
    effects : sequence of Effect
        What the scene simulates; nothing else is computed.

    Examples
    --------
    >>> from pbanim.particles import ParticleSystem, Gravity
    >>> ps = ParticleSystem(positions=[[0.0, 10.0]], velocities=[[1.0, 0.0]], masses=[2.0])
    >>> scene = Scene(ps, [Gravity()])
    >>> scene.pipeline
    ('gravity', 'integrate')
    """

    @contract(system=_SYSTEM, effects=Seq(_EFFECT))
    def __init__(self, system: Any, effects: Sequence[Effect] = ()) -> None:
        self.system = system
        self.n_state = int(np.size(system.state()))   # length of the flat state y = [q, v]
        # an effect may contribute several stages (e.g. Constraints + its post-step projection)
        self.effects = [s for e in effects
                        for s in (e.stages() if callable(getattr(e, "stages", None)) else (e,))]
        for e in self.effects:
            if getattr(e, "phase", None) not in _PHASES:
                raise InvalidInput(f"effect {e!r} has phase {getattr(e, 'phase', None)!r}; "
                                 f"expected one of {_PHASES}")
            e.bind(system)
        self._force = [e for e in self.effects if e.phase == "force"]
        self._constraint = [e for e in self.effects if e.phase == "constraint"]
        self._post = [e for e in self.effects if e.phase == "post_step"]
        for e in self._constraint:
            e.applied = unchecked(self.applied_forces)
        # the step loop calls the stages' functions without their boundary checks (bound once, here)
        self._apply = [unchecked(e.apply) for e in self._force]
        self._constrain = [unchecked(e.constrain) for e in self._constraint]
        self._post_step = [unchecked(e.post_step) for e in self._post]
        self._derivative = unchecked(system.derivative)
        self._forces = unchecked(self.forces)
        self._applied = unchecked(self.applied_forces)
        self._rhs = unchecked(self.rhs)
        # the plans (pbanim.scene.plans): what each admits is read once, here; a run binds its plan
        self._lean = hasattr(system, "kick_drift") and hasattr(system, "dim") and not self._constraint
        # folding Q = c + d v replaces apply by affine(): only the package's own effects (a course assignment's
        # copy or a user's subclass runs the apply it wrote; pbanim.contracts.package_code)
        self._affine = self._lean and all(callable(getattr(e, "affine", None)) and package_code(e, "apply", "affine")
                                          for e in self._force)
        # symplectic Euler with one force evaluation per step (see the module docstring)
        self._drift_free = all(getattr(e, "drift_free", True) for e in self.effects)
        self._linear = linear_scene(self)
        self._kick = KickDrift(self) if self._lean else None
        self._floats = float_plan(self) if self._lean else None    # a small particle scene: floats
        self.fold_affine = True
        self.lean_path = True           # False: every run and step takes the readable path
        self._stepper_cache: dict = {}

    @property
    def pipeline(self) -> tuple[str, ...]:
        """Ordered names of the stages a step runs."""
        return tuple([e.name for e in self._force] + [e.name for e in self._constraint]
                     + ["integrate"] + [e.name for e in self._post])

    # -- continuous part -------------------------------------------------------------------------
    @contract(t=_T, y=_Y, returns=finite_result)
    def applied_forces(self, t: float, y: np.ndarray) -> np.ndarray:
        """Q of the force effects alone at (t, y) (what a constraint effect sees as applied)."""
        Q = self.system.zero_forces()
        for apply in self._apply:
            apply(t, y, Q)
        return Q

    @contract(t=_T, y=_Y, returns=finite_result)
    def forces(self, t: float, y: np.ndarray) -> np.ndarray:
        """Total generalized force Q (applied + constraint forces) at (t, y)."""
        Q = self._applied(t, y)
        for constrain in self._constrain:
            Q = constrain(t, y, Q)
        return Q

    @contract(t=_T, y=_Y, returns=finite_result)
    def rhs(self, t: float, y: np.ndarray) -> np.ndarray:
        """dy/dt of the scene's continuous dynamics (what every integrator steps)."""
        return self._derivative(y, self._forces(t, y))

    # -- diagnostics ----------------------------------------------------------------------------
    @contract(y=_Y, returns=finite_result)
    def potential_energy(self, y: np.ndarray) -> float:
        return float(sum(e.potential_energy(y) for e in self.effects
                         if callable(getattr(e, "potential_energy", None))))

    @contract(y=_Y, returns=finite_result)
    def energy(self, y: np.ndarray) -> float:
        """Total energy T + ΣV over the effects that have a potential."""
        return float(self.system.kinetic_energy(y)) + self.potential_energy(y)

    @contract(t=_T, y=_Y, returns=finite_result)
    def diagnostics(self, t: float, y: np.ndarray) -> dict[str, Any]:
        sysm = self.system
        T = float(sysm.kinetic_energy(y)) if hasattr(sysm, "kinetic_energy") else np.nan
        V = self.potential_energy(y)
        d: dict[str, Any] = {"kinetic": T, "potential": V, "energy": T + V}
        if hasattr(sysm, "linear_momentum"):
            d["momentum"] = np.asarray(sysm.linear_momentum(y), dtype=float)
        if hasattr(sysm, "angular_momentum"):
            d["angular_momentum"] = np.asarray(sysm.angular_momentum(y), dtype=float)
        for e in self.effects:
            if callable(getattr(e, "diagnostics", None)):
                d.update(e.diagnostics(t, y))
        return d

    # -- Jacobian -------------------------------------------------------------------------------
    @property
    def has_jacobian(self) -> bool:
        """True when every force effect provides ``jacobian`` (and no constraint effect is declared)."""
        return (hasattr(self.system, "W") and hasattr(self.system, "dim") and not self._constraint
                and all(callable(getattr(e, "jacobian", None)) for e in self._force))

    @contract(t=_T, y=_Y)
    def jac(self, t: float, y: np.ndarray) -> sp.csr_matrix:
        """Sparse state Jacobian ∂(dy/dt)/∂y = [[0, I], [W ∂Q/∂x, W ∂Q/∂v]] from the effects' Jacobians.

        Raises ValueError if some force effect has no ``jacobian`` (see :attr:`has_jacobian`).

        Examples
        --------
        >>> from pbanim.particles import ParticleSystem, Drag
        >>> ps = ParticleSystem([[0.0, 0.0]], masses=2.0)
        >>> Scene(ps, [Drag(4.0)]).jac(0.0, ps.state()).toarray()
        array([[ 0.,  0.,  1.,  0.],
               [ 0.,  0.,  0.,  1.],
               [ 0.,  0., -2.,  0.],
               [ 0.,  0.,  0., -2.]])
        """
        if not self.has_jacobian:
            missing = [e.name for e in self._force if not callable(getattr(e, "jacobian", None))]
            raise InvalidInput(f"scene has no analytic Jacobian: effects {missing or [e.name for e in self._constraint]} "
                             f"provide none; implicit methods then use finite differences")
        n = self.system.split
        Kx = sp.csr_matrix((n, n))
        Kv = sp.csr_matrix((n, n))
        for e in self._force:
            fj = e.jacobian(t, y)
            if fj.dQdx is not None:
                Kx = Kx + fj.dQdx
            if fj.dQdv is not None:
                Kv = Kv + fj.dQdv
        Wd = sp.diags(np.repeat(self.system.W, self.system.dim))
        return sp.bmat([[None, sp.eye(n)], [Wd @ Kx, Wd @ Kv]], format="csr")

    # -- stepping -------------------------------------------------------------------------------
    @contract(t=_T, y=_Y, h=Real(gt=0), method=_METHOD, returns=finite_result)
    def step(self, t: float, y: np.ndarray, h: float, method: str = "symplectic_euler") -> np.ndarray:
        """One step of the pipeline: integrate the continuous part, then the post-step stages.

        Returns a new state (``y`` is not modified). The step is the one :meth:`simulate` takes, its plan
        built at the first call with a method and kept (see :mod:`pbanim.scene.plans`: build a new scene, or
        run :meth:`simulate`, which binds its plan per run, after changing an effect's parameters); implicit
        methods get :meth:`jac` when :attr:`has_jacobian`.
        """
        key = (method, self.lean_path)
        advance = self._stepper_cache.get(key)
        if advance is None:
            advance = self._stepper_cache[key] = self._advance(get_method(method), [0, 0])
        return advance(t, y, h)

    _BLOCK = 8192  # particles per block of the folded affine path (a few 100 kB per array: stays in cache)

    @contract(t_end=_T, h=Real(gt=0), method=_METHOD, t0=_T, y0=Opt(_Y), record_every=Int(ge=1),
              diagnostics=_DIAGNOSTICS, check_every=Int(ge=1), max_steps=Int(ge=1))
    def simulate(self, t_end: float, h: float, method: str = "symplectic_euler", *, t0: float = 0.0,
                 y0: np.ndarray | None = None, record_every: int = 1, diagnostics: bool | str = "lazy",
                 check_every: int = 1, max_steps: int = MAX_STEPS) -> SimResult:
        """Fixed-step simulation from ``t0`` to ``t_end`` through the one driver (:mod:`pbanim.ode.driver`).

        Parameters
        ----------
        t_end, h : float
            End time and step (h > 0). N = ⌈(t_end − t0)/h⌉ steps (to within 10⁻⁹), the last one
            shortened so that the run ends exactly at ``t_end``.
        method : str
            A name in :data:`pbanim.ode.METHODS`.
        y0 : ndarray, optional
            Start state (default ``system.state()``).
        record_every : int
            Record the state every this many steps (and at the end).
        diagnostics : "lazy", True or False
            ``"lazy"`` (default): energies, momenta and the effects' series are computed from the recorded
            states the first time ``result.diagnostics`` is read (a run nobody asks about pays nothing);
            effects whose diagnostics describe the step just taken (``history_diagnostics = True``: contact
            counts, impacts) are read at the recorded times during the run. ``True``: all of them at the
            recorded times during the run. ``False``: none.
        check_every : int
            Check for non-finite states every this many steps (raises :class:`SimulationDiverged`).
        max_steps : int
            Cap on N, checked before the first step (:class:`~pbanim.errors.StepLimitExceeded`).
        """
        grid = step_grid(t0, t_end, h, max_steps=max_steps, record_every=record_every)
        m = get_method(method)
        y = np.array(self.system.state() if y0 is None else y0, dtype=float, copy=True)
        check_finite(y, t0, 0, "initial state")
        diagnose = unchecked(self.diagnostics)
        during = diagnose if diagnostics is True else _history(self.effects) if diagnostics == "lazy" else None
        counter = [0, 0]  # right-hand-side (force) evaluations, Jacobian evaluations
        advance = self._advance(m, counter)
        n, r = grid.n_steps, record_every
        ts = np.append(grid.t0 + grid.h * np.arange(0, n, r), grid.t_end)     # the times grid.times() gives
        start = time.perf_counter()
        if during is None:      # nothing to read during the run: the states go straight into one array
            # a plan that cannot raise on a non-finite state is checked once per block (the first bad step named)
            check = None if r == 1 and getattr(advance, "nan_safe", False) else check_every
            run = getattr(advance, "run", None)     # a fused float run (pbanim.particles.lean_run): the whole run
            Y = run(grid, y, r, check) if run is not None else drive_lean(advance, grid, y, "state", record_every=r,
                                                                           check_every=check)
            diags: list = []
        else:
            Y = np.empty((len(ts), len(y)))
            Y[0] = y
            diags = [during(t0, y)]
            row = [0]

            def record(t, yy):
                row[0] += 1
                Y[row[0]] = yy
                diags.append(during(t, yy))

            drive(advance, grid, y, record=record, record_every=r, check_every=check_every)
        wall = time.perf_counter() - start
        diag_arrays = _series(diags)
        if diagnostics == "lazy":
            recorded = diag_arrays
            diag_arrays = LazyDiagnostics(lambda: {**_series([diagnose(t, yy) for t, yy in zip(ts, Y)]), **recorded})
        return SimResult(t=ts, y=Y.T, nfev=counter[0], njev=counter[1], status=0, wall_time=wall,
                         method=method, nsteps=grid.n_steps, diagnostics=diag_arrays)

    def _advance(self, m, counter: list):
        """The step y₁ = Φ_h(t, y) of method ``m`` followed by the post-step effects, its plan chosen and bound
        here (:func:`pbanim.scene.plans.advance`); counts f in ``counter[0]``, the Jacobian in ``counter[1]``."""
        return advance(self, m, counter, Scene)
