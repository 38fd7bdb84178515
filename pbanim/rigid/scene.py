"""Rigid scenes: quaternion handling and rigid diagnostics (chapter 05, part of :mod:`pbanim.rigid`).

Two ways to keep q a unit quaternion, chosen by name (``RigidScene(..., quaternions=...)``):

``"renormalize"`` (default)
    Any :mod:`pbanim.ode` method steps y = [x, q, P, L]; the post-step stage ``renormalize`` then sets
    q ← q/|q|. The step's error is untouched to first order (the projection is orthogonal to the sphere).
``"exponential"``
    Runge–Kutta–Munthe-Kaas: over one step write q(t) = exp(½θ(t)) ⊗ q_n with θ(t_n) = 0 and step the
    local state z = [x, θ, P, L] (split 6N) with the chosen method, where

        θ̇ = dexp⁻¹_θ(ω) = ω − ½ θ × ω + c(|θ|) θ × (θ × ω),   c(a) = (1 − (a/2) cot(a/2)) / a²  (→ 1/12),

    then q_{n+1} = exp(½θ_{n+1}) ⊗ q_n, a unit quaternion to roundoff. The method keeps its order
    (Munthe-Kaas 1999) and |q| never drifts; with explicit Euler this is Lie–Euler q ← exp(½hω) ⊗ q.
``"none"``
    Raw integration (for the drift figure and ORACLES C3); R is still built from q/|q|.

Diagnostics recorded per step (beside the scene's energy and momenta): ``kinetic_translational``,
``kinetic_rotational``, ``angular_momentum_com`` (about the system's centre of mass) and ``quat_norm_error``
(max ||q| − 1|).

References: H. Munthe-Kaas, Appl. Numer. Math. 29 (1999); Hairer, Lubich & Wanner, GNI §IV.8.
"""

from __future__ import annotations

from typing import Any, Sequence

import numpy as np

from ..contracts import Array, Choice, Either, Flag, Func, Int, Obj, Opt, Real, Seq, contract
from ..ode import get_method
from ..ode.driver import MAX_STEPS, check_finite
from ..results import SimResult
from .bodies import RigidBodies
from .domain import Counter, RigidState, Vectors, certifier
from ..geometry import cross as _cross
from .effects import QuaternionRenormalize
from .lean import lean_plan
from .quat import quat_exp, quat_multiply
from ..scene import Effect, Scene
from ..errors import InvalidInput, NonFiniteResult, SimulationDiverged

__all__ = ["RigidScene", "exp_map_step", "dexpinv"]

QUATERNION_MODES = ("renormalize", "exponential", "none")


def _methods():
    from ..ode import METHODS
    return list(METHODS)


_METHOD = Choice(_methods)
_T = Real()
_H = Real(gt=0)


@contract(theta=Vectors(3, batch="first", below=2 * np.pi), omega=Array((3,), batch="first"),
          returns=certifier("dexpinv: dexp⁻¹_θ(ω)"))
def dexpinv(theta: np.ndarray, omega: np.ndarray) -> np.ndarray:
    """θ̇ = dexp⁻¹_θ(ω) for R = exp([θ]×) R₀ and world angular velocity ω, rows (..., 3) (one each, or
    batches of one length); |θ| < 2π (dexp⁻¹ has poles at |θ| = 2π, 4π, ...).

    >>> dexpinv(np.zeros(3), np.array([1.0, 2.0, 3.0]))     # at θ = 0 it is the identity
    array([1., 2., 3.])
    """
    try:
        return _dexpinv(theta, omega)
    except ValueError:
        raise InvalidInput(f"dexpinv: theta and omega must be one each, or batches of one length, got theta "
                           f"{np.shape(theta)} and omega {np.shape(omega)}") from None


def _dexpinv(theta: np.ndarray, omega: np.ndarray) -> np.ndarray:
    th = np.asarray(theta, dtype=float)
    w = np.asarray(omega, dtype=float)
    a2 = np.sum(th * th, axis=-1, keepdims=True)
    a = np.sqrt(a2)
    small = a < 1e-3
    a_s = np.where(small, 1.0, a)
    c = np.where(small, 1.0 / 12.0 + a2 / 720.0, (1.0 - 0.5 * a_s / np.tan(0.5 * a_s)) / np.where(small, 1.0, a2))
    tw = _cross(th, w)
    return w - 0.5 * tw + c * _cross(th, tw)


@contract(system=Obj(RigidBodies), forces=Func(), t=_T, y=RigidState("system"), h=_H, method=_METHOD,
          counter=Opt(Counter()))
def exp_map_step(system: RigidBodies, forces, t: float, y: np.ndarray, h: float, method: str = "rk4",
                 counter: list | None = None) -> np.ndarray:
    """One Runge–Kutta–Munthe-Kaas step of ``method`` on the rotation group (see the module docstring).

    ``forces(t, y) -> Q (N, 6)`` is the scene's total generalized force.

    Examples
    --------
    >>> from pbanim.rigid import RigidBodies
    >>> rb = RigidBodies(1.0, [1.0, 2.0, 3.0], angular_velocities=[[1.0, 5.0, 0.1]])
    >>> y = rb.state()
    >>> for _ in range(100):
    ...     y = exp_map_step(rb, lambda t, y: rb.zero_forces(), 0.0, y, 0.05, "euler")
    >>> bool(abs(np.linalg.norm(rb.unpack(y)[1]) - 1) < 1e-13)        # roundoff only, even with Euler
    True
    """
    N = system.N

    def checked(tt, yy):            # the user's forces arrive inside the step: checked at each call
        Q = np.asarray(forces(tt, yy), dtype=float)
        if Q.shape != (N, 6):
            raise InvalidInput(f"exp_map_step: forces(t, y) must return an array of shape ({N}, 6), got shape "
                               f"{Q.shape}")
        if not np.isfinite(Q).all() and np.isfinite(yy).all():
            raise InvalidInput(f"exp_map_step: forces(t, y) must return finite forces, got {Q.tolist()} at t = {tt}")
        return Q

    y1 = _exp_map_step(system, checked, t, y, h, method, counter)
    check_finite(y1, t, 0)
    return y1


def _exp_map_step(system: RigidBodies, forces, t: float, y: np.ndarray, h: float, method: str,
                  counter: list | None = None) -> np.ndarray:
    N = system.N
    x0, q0, P0, L0 = system.unpack(y)
    q0 = q0.copy()

    def to_y(z):
        theta = z[3 * N:6 * N].reshape(N, 3)
        q = quat_multiply(quat_exp(theta), q0)
        return system.pack(z[:3 * N], q, z[6 * N:9 * N], z[9 * N:]), theta

    def fun(tt, z):
        if counter is not None:
            counter[0] += 1
        yy, theta = to_y(z)
        dy, w = system.derivative_and_omega(yy, forces(tt, yy))
        dz = np.empty_like(z)
        dz[:3 * N] = dy[:3 * N]
        dz[3 * N:6 * N] = _dexpinv(theta, w).ravel()
        dz[6 * N:] = dy[7 * N:]
        return dz

    z0 = np.concatenate([x0.ravel(), np.zeros(3 * N), P0.ravel(), L0.ravel()])
    z1 = get_method(method).step(fun, t, z0, h, split=6 * N)
    return to_y(z1)[0]


class RigidScene(Scene):
    """A :class:`pbanim.scene.Scene` of :class:`RigidBodies` with a quaternion policy and rigid diagnostics.

    Parameters
    ----------
    system : RigidBodies
    effects : sequence of Effect
    quaternions : {"renormalize", "exponential", "none"}
        See the module docstring. "renormalize" appends the post-step stage ``renormalize``.

    A scene of at most :data:`pbanim.rigid.lean.LEAN_MAX_BODIES` bodies under gravity and drag steps on
    plain floats (:mod:`pbanim.rigid.lean`: the same equations, equal to roundoff, some 20× faster for one
    body; with ``quaternions="exponential"``, :mod:`pbanim.rigid.lean_expmap`); set ``scene.lean_path =
    False`` to run the readable vectorized step instead.

    Examples
    --------
    >>> from pbanim.rigid import RigidBodies, RigidGravity
    >>> rb = RigidBodies(1.0, [1.0, 2.0, 3.0])
    >>> RigidScene(rb, [RigidGravity()]).pipeline
    ('gravity', 'integrate', 'renormalize')
    >>> RigidScene(rb, [RigidGravity()], quaternions="exponential").pipeline
    ('gravity', 'integrate[exp_map]')
    """

    @contract(system=Obj(RigidBodies), effects=Seq(Obj(Effect)), quaternions=Choice(QUATERNION_MODES))
    def __init__(self, system: RigidBodies, effects: Sequence[Effect] = (), quaternions: str = "renormalize") -> None:
        effects = list(effects)
        if quaternions == "renormalize" and not any(isinstance(e, QuaternionRenormalize) for e in effects):
            effects.append(QuaternionRenormalize())
        self.quaternions = quaternions
        super().__init__(system, effects)
        # a small scene of gravity and drag steps on floats (pbanim.rigid.lean); False: the readable path
        self.lean_path = True
        self._lean_plan = lean_plan(self)
        self._steppers: dict = {}

    @property
    def pipeline(self) -> tuple[str, ...]:
        stages = super().pipeline
        if self.quaternions == "exponential":
            stages = tuple("integrate[exp_map]" if s == "integrate" else s for s in stages)
        return stages

    @contract(t=_T, y=RigidState("self.system"))
    def diagnostics(self, t: float, y: np.ndarray) -> dict[str, Any]:
        d = super().diagnostics(t, y)
        rb = self.system
        d["kinetic_translational"] = rb.translational_kinetic_energy(y)
        d["kinetic_rotational"] = rb.rotational_kinetic_energy(y)
        d["angular_momentum_com"] = rb.angular_momentum_com(y)
        d["quat_norm_error"] = rb.quaternion_norm_error(y)
        return d

    @contract(t=_T, y=RigidState("self.system"), h=_H, method=_METHOD)
    def step(self, t: float, y: np.ndarray, h: float, method: str = "symplectic_euler") -> np.ndarray:
        """One step of the pipeline (see :meth:`pbanim.scene.Scene.step`); a state that stops being finite
        is a :class:`~pbanim.errors.SimulationDiverged` at ``t``. The step is the one a run takes (built
        once per method and path: dispatch is paid at the first call, not at each)."""
        key = (method, self.lean_path)
        step = self._steppers.get(key)
        if step is None:
            step = self._steppers[key] = self._advance_step(get_method(method), [0, 0])
        y1 = step(t, y, h)
        check_finite(y1, t, 0)
        return y1

    @contract(t_end=_T, h=_H, method=_METHOD, t0=_T, y0=Opt(RigidState("self.system")), record_every=Int(ge=1),
              diagnostics=Either(Flag(), Choice(("lazy",))), check_every=Int(ge=1), max_steps=Int(ge=1))
    def simulate(self, t_end: float, h: float, method: str = "symplectic_euler", *, t0: float = 0.0,
                 y0: np.ndarray | None = None, record_every: int = 1, diagnostics: bool | str = "lazy",
                 check_every: int = 1, max_steps: int = MAX_STEPS) -> SimResult:
        """Fixed-step simulation (see :meth:`pbanim.scene.Scene.simulate`; same driver, same step rule,
        same arguments).

        With ``quaternions="exponential"`` each step is :func:`exp_map_step` and the result's ``method``
        reads ``"<method>+exp_map"``. A force or rate that overflows from a finite state during the run
        is a :class:`~pbanim.errors.SimulationDiverged` naming it and the step.
        """
        res = super().simulate(t_end, h, method, t0=t0, y0=y0, record_every=record_every, diagnostics=diagnostics,
                               check_every=check_every, max_steps=max_steps)
        if self.quaternions == "exponential":
            res.method = f"{method}+exp_map"
        return res

    def _advance(self, m, counter: list):
        step = self._advance_step(m, counter)
        taken = [0]

        def advance(t, y, h):
            try:
                y1 = step(t, y, h)
            except NonFiniteResult as exc:
                raise SimulationDiverged(t, taken[0], exc.what, "it overflowed from a finite state") from None
            taken[0] += 1
            return y1
        advance.nan_safe = getattr(step, "nan_safe", False)
        return advance

    def _advance_step(self, m, counter: list):
        if m.name == "verlet" and self.quaternions != "exponential":
            readable = self._splitting_advance(counter)
            lean = self._lean_plan.advance(m, counter, readable) if self._lean_plan and self.lean_path else None
            return lean or readable
        if self.quaternions != "exponential":
            readable = super()._advance(m, counter)
            lean = self._lean_plan.advance(m, counter, readable) if self._lean_plan and self.lean_path else None
            return lean or readable
        system, forces, post, name = self.system, self.forces, self._post, m.name

        def advance(t, y, h):
            y = _exp_map_step(system, forces, t, y, h, name, counter)
            for e in post:
                y = e.post_step(t + h, y, h)
            return y
        if self._lean_plan and self.lean_path:        # a small scene: the same exponential map on floats
            return self._lean_plan.advance(m, counter, advance)
        return advance

    def _splitting_advance(self, counter: list):
        """Velocity Verlet as kick, exact-axis free rotation, kick (:mod:`pbanim.rigid.splitting`)."""
        from .splitting import rigid_verlet_step

        system, forces, post = self.system, self.forces, self._post

        def advance(t, y, h):
            y = rigid_verlet_step(system, forces, t, y, h, counter)
            for e in post:
                y = e.post_step(t + h, y, h)
            return y
        return advance
