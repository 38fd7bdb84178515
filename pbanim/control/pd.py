"""Proportional–derivative servos, explicit and stable (chapter 08, part 2).

A servo pulls joint coordinate θ toward a target θ̄ like a damped spring:

    explicit PD      τ = k_p (θ̄ − θ) − k_v θ̇                            (the lecture's servo)
    stable PD        τ = k_p (θ̄ − θ − h θ̇) − k_v θ̇⁺,  θ̇⁺ = θ̇ + h θ̈      (Tan, Liu & Turk 2011)

Stable PD evaluates the spring at the position predicted with the current velocity and the damper at the
next velocity, so with the equations of motion M θ̈ + C = τ it needs one solve with M + h K_v:

    θ̈ = (M + h K_v)⁻¹ (−C − K_p (θ + h θ̇ − θ̄) − K_v θ̇).

A third form, *implicit PD*, takes the spring at the next position too, τ = k_p(θ̄ − θ − h θ̇⁺) − k_v θ̇⁺: it
is backward Euler on the servo, M + h(K_v + h K_p) on the left.

Stability on one degree of freedom (m θ̈ = τ, ω² = k_p/m, c = k_v/m, a = h²ω²), with θ⁺ = θ + h θ̇⁺
(ORACLES F1; the step map is 2 × 2, its trace and determinant give the conditions):

    explicit PD      h c < 2  and  a + 2 h c < 4                  (critical damping k_v = 2 √(k_p m))
    stable PD        a < 4/3 + (2/3) h c  and  a < 2 + h c         (every h when k_v ≥ 1.5 h k_p)
    implicit PD      every h, every gain

(for k_p, k_v > 0; "stable" means the iterates stay bounded, so on the boundary, where an eigenvalue is ±1,
the helpers below answer exactly: a simple eigenvalue of modulus 1 is stable, a Jordan block is not; with
k_p = k_v = 0 no servo acts and θ drifts by h θ̇ each step, which no servo calls stable. Gains are ≥ 0:
a negative k_p pushes away from the target at every step), so at critical damping stable PD allows a step 2.4× longer than explicit PD (h√(k_p/m) = 2 against 0.83),
and any step once the damping gain is large enough (Tan et al. recommend k_v ≥ k_p h); without damping it
is *less* stable than explicit PD (√(4/3) against 2). Implicit PD never limits the step but damps more.
The price of both: every step needs the system's mass matrix, and the servo's force is that of a state h
ahead, so tracking lags by about one step.

Notation: θ, θ̇ the servoed coordinates; θ̄ targets; k_p, k_v gains per joint (K_p, K_v diagonal); h the step;
τ_max torque limits (|τ| ≤ τ_max, applied after the servo).
"""

from __future__ import annotations

from fractions import Fraction

import numpy as np

from ..contracts import Array, Choice, Either, Flag, Func, Index, Int, Opt, Real, Text, contract, finite_result
from ..errors import InvalidInput, NonFiniteResult
from ..ode.driver import step_grid
from .specs import Count, Mapping, Names, named

__all__ = ["PDServo", "stable_pd_acceleration", "explicit_pd_stable", "stable_pd_stable", "largest_stable_step",
           "pd_step", "SERVOS", "servo_track", "InvalidGains", "UnknownJoint"]

SERVOS = ("explicit", "stable", "implicit")


class InvalidGains(InvalidInput):
    """A servo gain or torque limit that is negative, not finite or of the wrong length."""


class UnknownJoint(InvalidInput):
    """A target or gain for a joint the servo (or the model) does not have."""


_GAIN = Real(ge=0)                      # k_p [N m/rad], k_v [N m s/rad]: a negative gain pushes away
_MASS = Real(gt=0)
_STEP = Real(gt=0)
_PER_JOINT = Count("joints")
_GAINS = named(InvalidGains, Array((_PER_JOINT,), ge=0, scalar=True))
_LIMITS = named(InvalidGains, Array((_PER_JOINT,), ge=0, finite=False, scalar=True))
_STATE = Array(("self.nv",))
_TARGETS = Either(Mapping(Text(), Real()), Array(("self.n_servos",)))


def _per_joint(value, n: int) -> np.ndarray:
    """One value per joint: ``value`` (a number or n numbers, already checked) broadcast to (n,)."""
    return np.broadcast_to(np.asarray(value, dtype=float), (n,)).copy()


class PDServo:
    """Servos on the generalized coordinates ``joints`` (names → index in q) of a system with ``nv`` DOFs.

    ``kp``, ``kv``: one value or one per joint (≥ 0, finite); ``limits``: |τ| ≤ limit (≥ 0, may be inf).
    ``world``: names of joints whose targets are angles in the world frame, with ``angles`` the dict
    whose row (nv,) gives that angle as a linear function of q (for a planar tree, the row of
    :attr:`pbanim.articulated.PlanarKernel.Phi` of the joint's link: φ = Σ of the hinge angles above it).
    A world-frame servo measures θ = row · q and θ̇ = row · q̇ and applies its torque at its own joint (stable
    PD then treats only the joint's own velocity implicitly).
    """

    @contract(joints=Mapping(Text(nonempty=True), Index("$nv"), min_len=1, distinct=True), nv=Int(ge=1),
              kp=_GAINS, kv=_GAINS, limits=_LIMITS, world=Opt(Names()),
              angles=Opt(Mapping(Text(), Array(("$nv",)))))
    def __init__(self, joints: dict, nv: int, kp, kv, limits=np.inf, world=None, angles=None) -> None:
        self.names = list(joints)
        self.index = np.array(list(joints.values()), dtype=int)
        self.nv = int(nv)
        n = self.index.size
        self.kp, self.kv, self.limits = (_per_joint(v, n) for v in (kp, kv, limits))
        self.A = np.zeros((n, self.nv))                                  # θ = A q for every servo
        self.A[np.arange(n), self.index] = 1.0
        world, angles = list(world or ()), dict(angles or {})
        unknown = [nm for nm in world if nm not in joints]
        if unknown:
            raise UnknownJoint(f"PDServo: world names joints {unknown} that the servo does not have; it has "
                               f"{self.names}")
        stray = sorted(set(angles) - set(world))
        if stray:
            raise InvalidInput(f"PDServo: angles gives rows for {stray}, which world does not list (their "
                               f"servos would measure joint angles and ignore the rows); world is {world}")
        for name in world:
            if name not in angles:
                raise InvalidInput(f"PDServo: angles[{name!r}] is missing: the world-frame servo {name!r} needs "
                                   f"its row of {self.nv} numbers (the world angle as a function of q)")
            self.A[self.names.index(name)] = angles[name]

    @property
    def n_servos(self) -> int:
        """The number of servoed joints."""
        return int(self.index.size)

    @contract(q=_STATE)
    def angles(self, q) -> np.ndarray:
        """The servoed angles θ = A q (joint angles, or world angles for world-frame servos)."""
        return self.A @ np.asarray(q, dtype=float)

    @contract(targets=_TARGETS)
    def target_vector(self, targets) -> np.ndarray:
        """θ̄ per servoed joint from a dict name → angle (missing joints: 0) or an array of one per joint."""
        if isinstance(targets, dict):
            unknown = sorted(set(targets) - set(self.names))
            if unknown:
                raise UnknownJoint(f"targets name joints {unknown} that the servo does not have; it has {self.names}")
            return np.array([float(targets.get(nm, 0.0)) for nm in self.names])
        return np.array(targets, dtype=float)

    @contract(q=_STATE, qd=_STATE, targets=_TARGETS)
    def explicit(self, q, qd, targets) -> np.ndarray:
        """τ (nv,) = k_p (θ̄ − θ) − k_v θ̇ on the servoed joints, clipped to the limits; zero elsewhere."""
        # BEGIN SOLUTION PDServo.explicit
        th = self.target_vector(targets)
        tau = np.zeros(self.nv)
        tau[self.index] = np.clip(self.kp * (th - self.A @ q) - self.kv * (self.A @ qd), -self.limits, self.limits)
        return tau
        # END SOLUTION

    @contract(q=_STATE, qd=_STATE, targets=_TARGETS, h=Real(ge=0), implicit=Flag())
    def stable(self, q, qd, targets, h: float, implicit: bool = False) -> tuple[np.ndarray, np.ndarray]:
        """The servo split for a step of length h: (τ₀, k) with τ = τ₀ − k θ̇⁺.

        Stable PD: τ₀ = k_p (θ̄ − θ − h θ̇), k = k_v; implicit PD (``implicit``): τ₀ = k_p (θ̄ − θ),
        k = k_v + h k_p. τ₀ goes to the right-hand side, k to the left (M + h diag(k)); a solver that takes
        implicit damping (:class:`pbanim.articulated.planar_step.PlanarContactStep`) does the rest. Torque
        limits clip τ₀ (the implicit part is bounded by k |θ̇⁺|). At h = 0 both are the explicit servo.
        """
        # BEGIN SOLUTION PDServo.stable
        th = self.target_vector(targets)
        tau0, k = np.zeros(self.nv), np.zeros(self.nv)
        i = self.index
        # the joint's own velocity is implicit; a world servo's other terms (row entries off the joint) explicit
        other = (self.A @ qd) - qd[i]
        if implicit:
            tau0[i], k[i] = self.kp * (th - self.A @ q - h * other) - self.kv * other, self.kv + h * self.kp
        else:
            tau0[i], k[i] = self.kp * (th - self.A @ q - h * (self.A @ qd)) - self.kv * other, self.kv
        tau0[i] = np.clip(tau0[i], -self.limits, self.limits)
        return tau0, k
        # END SOLUTION


def _mass_matrix(M: np.ndarray) -> None:
    """M symmetric (to 1e-12 of its largest entry) and positive definite to working precision (Cholesky
    succeeds and (min Lᵢᵢ / max Lᵢᵢ)² > n ε, a lower bound of 1/cond(M) up to a factor), or
    :class:`InvalidInput` naming M: a solve with any other matrix answers, but not for a mechanical system."""
    asym = float(np.abs(M - M.T).max())
    if not asym <= 1e-12 * float(np.abs(M).max()):
        raise InvalidInput(f"stable_pd_acceleration: M must be a symmetric positive definite mass matrix, got one "
                           f"with |M − Mᵀ| up to {asym:.3g}")
    try:
        d = np.abs(np.diag(np.linalg.cholesky(M)))
    except np.linalg.LinAlgError:
        d = None
    if d is None or not (d.min() / d.max()) ** 2 > M.shape[0] * np.finfo(float).eps:
        raise InvalidInput("stable_pd_acceleration: M must be a symmetric positive definite mass matrix, got a "
                           "symmetric one that is not positive definite (or singular to working precision)")


@contract(returns=finite_result, M=Array(("n", "n")), C=Array(("n",)), q=Array(("n",)), qd=Array(("n",)),
          target=Array(("n",)), kp=Array(("n",), ge=0, scalar=True), kv=Array(("n",), ge=0, scalar=True),
          h=Real(ge=0))
def stable_pd_acceleration(M, C, q, qd, target, kp, kv, h: float) -> tuple[np.ndarray, np.ndarray]:
    """(q̈, τ) of stable PD on every coordinate: q̈ = (M + h K_v)⁻¹(−C − K_p(q + h q̇ − q̄) − K_v q̇)."""
    M = np.asarray(M, dtype=float)
    n = M.shape[0]
    kp, kv = _per_joint(kp, n), _per_joint(kv, n)
    _mass_matrix(M)
    # BEGIN SOLUTION stable_pd_acceleration
    tau_p = -kp * (q + h * qd - target) - kv * qd
    qdd = np.linalg.solve(M + h * np.diag(kv), tau_p - C)
    return qdd, tau_p - h * kv * qdd
    # END SOLUTION


def _ratios(h, kp, kv, m) -> tuple[Fraction, Fraction]:
    """(a, hc) = (h² k_p/m, h k_v/m) exactly, as fractions of the floats given: no overflow (h = 1e300 with
    k_p = 0 gives a = 0, not inf·0 = NaN) and no rounding at a boundary of the region."""
    h, m = Fraction(h), Fraction(m)
    return h * h * Fraction(kp) / m, h * Fraction(kv) / m


@contract(h=_STEP, kp=_GAIN, kv=_GAIN, m=_MASS)
def explicit_pd_stable(h: float, kp: float, kv: float, m: float = 1.0) -> bool:
    """Whether semi-implicit Euler with an explicit servo on m θ̈ = τ is stable at step h (ORACLES F1).

    Stable: every iterate of the step map stays bounded (trace 2 − a − hc, determinant 1 − hc): hc ≤ 2 and
    a + 2hc ≤ 4, except a Jordan block on the unit circle at hc = 0 with a = 0 or a = 4. Inside, the
    oracle's hc < 2 and a + 2hc < 4; on the boundary an eigenvalue ±1 that is simple keeps the iterates
    bounded. With k_p = k_v = 0 nothing pulls the mass back (θ drifts by h θ̇ each step): not stable.

    >>> explicit_pd_stable(0.05, 100.0, 20.0), explicit_pd_stable(0.1, 100.0, 20.0), explicit_pd_stable(1.0, 0.0, 0.0)
    (True, False, False)
    """
    a, hc = _ratios(h, kp, kv, m)
    return hc <= 2 and a + 2 * hc <= 4 and not (hc == 0 and a in (0, 4))


@contract(h=_STEP, kp=_GAIN, kv=_GAIN, m=_MASS)
def stable_pd_stable(h: float, kp: float, kv: float, m: float = 1.0) -> bool:
    """Whether the stable-PD servo on m θ̈ = τ is stable at step h (ORACLES F1; stable as in
    :func:`explicit_pd_stable`).

    Trace (2 + hc − 2a)/(1 + hc), determinant (1 − a)/(1 + hc): a ≤ 4/3 + (2/3) hc (which implies the
    oracle's a < 2 + hc), except a = hc = 0 (no servo: the mass drifts).

    >>> stable_pd_stable(0.1, 100.0, 20.0), stable_pd_stable(10.0, 100.0, 1500.0), stable_pd_stable(1e300, 0.0, 1.0)
    (True, True, True)
    """
    a, hc = _ratios(h, kp, kv, m)
    return a <= Fraction(4, 3) + Fraction(2, 3) * hc and not (a == 0 and hc == 0)


@contract(returns=finite_result, x=Real(), v=Real(), h=_STEP, kp=_GAIN, kv=_GAIN, m=_MASS, servo=Choice(SERVOS))
def pd_step(x: float, v: float, h: float, kp: float, kv: float, m: float = 1.0, servo: str = "explicit"):
    """One semi-implicit Euler step (θ⁺ = θ + h θ̇⁺) of the servoed mass m θ̈ = τ, target 0."""
    # BEGIN SOLUTION pd_step
    if servo == "stable":
        v = (v - h * kp * (x + h * v) / m) / (1.0 + h * kv / m)
    elif servo == "implicit":
        v = (v - h * kp * x / m) / (1.0 + h * (kv + h * kp) / m)
    elif servo == "explicit":
        v = v + h * (-kp * x - kv * v) / m
    else:
        raise InvalidInput(f"servo must be one of {SERVOS}, got {servo!r}")
    return x + h * v, v
    # END SOLUTION


@contract(servo=Choice(SERVOS), target=Func(), kp=_GAIN, kv=_GAIN, h=_STEP, t_end=Real(gt=0), m=_MASS, x0=Real(),
          v0=Real(), max_steps=Int(ge=1))
def servo_track(servo: str, target, kp: float, kv: float, h: float, t_end: float, m: float = 1.0,
                x0: float = 0.0, v0: float = 0.0, *, max_steps: int = 1_000_000) -> tuple[np.ndarray, np.ndarray]:
    """(t, θ) of the mass m θ̈ = τ following ``target(t)`` with one servo, fixed step h (semi-implicit
    Euler; explicit PD reads the target now, stable and implicit PD at the next step; the last time n h may
    pass t_end by less than h). Stops early with θ = inf from the first step where |θ| exceeds 10⁶ times
    the problem's scale (1, |θ₀|, h|θ̇₀| and the largest |θ̄| so far): an unstable servo, so the caller sees
    the divergence. ``target(t)`` must return a finite number (:class:`InvalidInput` naming it otherwise);
    a run longer than ``max_steps`` steps is refused before it starts."""
    n = step_grid(0.0, t_end, h, max_steps=max_steps).n_steps          # the step count and its cap
    t = h * np.arange(n + 1)
    xs = np.full(n + 1, np.inf)
    x, v = float(x0), float(v0)
    xs[0] = x
    scale = max(1.0, abs(x), abs(h * v))
    for k in range(n):
        r = _target_value(target, t[k] if servo == "explicit" else t[k + 1])
        scale = max(scale, abs(r))
        if servo == "explicit":
            v += h * (kp * (r - x) - kv * v) / m
        elif servo == "stable":
            v = (v + h * kp * (r - x - h * v) / m) / (1.0 + h * kv / m)
        else:
            v = (v + h * kp * (r - x) / m) / (1.0 + h * (kv + h * kp) / m)
        x += h * v
        if not abs(x) <= 1e6 * scale:                                  # also NaN from an overflow
            break
        xs[k + 1] = x
    return t, xs


def _target_value(target, t: float) -> float:
    """target(t) as a finite float, or :class:`InvalidInput` naming ``target`` (a NaN target would make a
    NaN servo force, read as a divergence)."""
    r = target(t)
    try:
        v = float(r)
    except (TypeError, ValueError):
        raise InvalidInput(f"servo_track: target must return one number, got {r!r:.60} at t = {t:g}") from None
    if not np.isfinite(v):
        raise InvalidInput(f"servo_track: target must return a finite number, got {v} at t = {t:g}")
    return v


def _bounded(A: np.ndarray) -> bool:
    """Whether every iterate Aⁿx of a 2 × 2 step map stays bounded: spectral radius ≤ 1 (+1e-12), and no
    Jordan block on the unit circle (a repeated eigenvalue of modulus 1 with A ≠ λI grows like n)."""
    lam = np.linalg.eigvals(A)
    rho = float(np.abs(lam).max())
    if rho > 1.0 + 1e-12:
        return False
    return not (lam[0] == lam[1] and rho >= 1.0 - 1e-12 and np.any(A != lam[0] * np.eye(2)))


@contract(kp=_GAIN, kv=_GAIN, m=_MASS, servo=Choice(SERVOS), h_max=_STEP, bisections=Int(ge=0, le=1100))
def largest_stable_step(kp: float, kv: float, *, m: float = 1.0, servo: str = "explicit", h_max: float = 10.0,
                        bisections: int = 50) -> float:
    """The largest step h ≤ h_max at which the servoed mass is stable, measured: the step map of
    :func:`pd_step` is linear, so two steps from the unit states give its matrix, and h is stable when its
    iterates stay bounded (spectral radius ≤ 1 + 1e-12, no Jordan block on the unit circle); bisection
    with a cap known before it starts (``bisections``; 1100 halve any bracket to the last bit). 0.0 when
    no step is stable (k_p = k_v = 0: the mass drifts). A step map that overflows double precision (h_max
    beyond ~1e150 s at unit gains) is :class:`NonFiniteResult`, not a guess."""

    def stable(h: float) -> bool:
        cols = [pd_step(1.0, 0.0, h, kp, kv, m, servo), pd_step(0.0, 1.0, h, kp, kv, m, servo)]
        A = np.array(cols, dtype=float).T
        if not np.isfinite(A).all():
            raise NonFiniteResult(f"largest_stable_step: the step map at h = {h:g} (h_max = {h_max:g})",
                                  "give a smaller h_max")
        return _bounded(A)

    if stable(h_max):
        return h_max
    lo, hi = 0.0, h_max
    for _ in range(bisections):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if stable(mid) else (lo, mid)
    return lo
