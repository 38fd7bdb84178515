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

so at critical damping stable PD allows a step 2.4× longer than explicit PD (h√(k_p/m) = 2 against 0.83),
and any step once the damping gain is large enough (Tan et al. recommend k_v ≥ k_p h); without damping it
is *less* stable than explicit PD (√(4/3) against 2). Implicit PD never limits the step but damps more. The price of both: every step needs the system's mass matrix, and the servo's force is
that of a state h ahead, so tracking lags by about one step.

Notation: θ, θ̇ the servoed coordinates; θ̄ targets; k_p, k_v gains per joint (K_p, K_v diagonal); h the step;
τ_max torque limits (|τ| ≤ τ_max, applied after the servo).
"""

from __future__ import annotations

import numpy as np

from ..errors import InvalidInput, as_floats, check_positive

__all__ = ["PDServo", "stable_pd_acceleration", "explicit_pd_stable", "stable_pd_stable", "largest_stable_step", "pd_step", "SERVOS", "servo_track", "InvalidGains",
           "UnknownJoint"]


class InvalidGains(InvalidInput):
    """A servo gain or torque limit that is negative, not finite or of the wrong length."""


class UnknownJoint(InvalidInput):
    """A target or gain for a joint the servo (or the model) does not have."""


def _gains(name: str, value, n: int, allow_inf: bool = False) -> np.ndarray:
    try:
        v = np.broadcast_to(np.asarray(value, dtype=float), (n,)).copy()
    except (ValueError, TypeError) as exc:
        raise InvalidGains(f"{name} must be a number or {n} numbers (one per servoed joint), got {value!r}") from exc
    bad = np.isnan(v) | (v < 0) | (~np.isfinite(v) if not allow_inf else np.zeros(n, bool))
    if np.any(bad):
        raise InvalidGains(f"{name} must be finite and >= 0 for every joint, got {v.tolist()}")
    return v


class PDServo:
    """Servos on the generalized coordinates ``joints`` (names → index in q) of a system with ``nv`` DOFs.

    ``kp``, ``kv``: one value or one per joint (≥ 0, finite); ``limits``: |τ| ≤ limit (may be inf).
    ``world``: names of joints whose targets are angles in the world frame, with ``angles`` the matrix
    whose row gives that angle as a linear function of q (for a planar tree, the row of
    :attr:`pbanim.articulated.PlanarKernel.Phi` of the joint's link: φ = Σ of the hinge angles above it).
    A world-frame servo measures θ = row · q and θ̇ = row · q̇ and applies its torque at its own joint (stable
    PD then treats only the joint's own velocity implicitly).
    """

    def __init__(self, joints: dict, nv: int, kp, kv, limits=np.inf, world=None, angles=None) -> None:
        if not isinstance(joints, dict) or not joints:
            raise InvalidInput(f"joints must be a non-empty dict name -> coordinate index, got {joints!r}")
        idx = np.array(list(joints.values()))
        if idx.dtype.kind not in "iu" or np.any(idx < 0) or np.any(idx >= nv) or len(set(idx.tolist())) != idx.size:
            raise InvalidInput(f"joint indices must be distinct integers in 0..{nv - 1}, got {list(joints.values())}")
        self.names = list(joints)
        self.index = idx
        self.nv = int(nv)
        n = idx.size
        self.kp = _gains("kp", kp, n)
        self.kv = _gains("kv", kv, n)
        self.limits = _gains("limits", limits, n, allow_inf=True)
        self.A = np.zeros((n, self.nv))                                  # θ = A q for every servo
        self.A[np.arange(n), idx] = 1.0
        for name in (world or ()):
            if name not in joints:
                raise UnknownJoint(f"world names joint {name!r} that the servo does not have; it has {self.names}")
            row = None if angles is None else np.asarray(angles.get(name) if isinstance(angles, dict) else None)
            if row is None or row.shape != (self.nv,) or not np.all(np.isfinite(row.astype(float))):
                raise InvalidInput(f"angles[{name!r}] must be a finite row of {self.nv} numbers (the world angle "
                                   f"as a function of q), got {None if row is None else row.shape}")
            self.A[self.names.index(name)] = row

    def angles(self, q) -> np.ndarray:
        """The servoed angles θ = A q (joint angles, or world angles for world-frame servos)."""
        return self.A @ np.asarray(q, dtype=float)

    def target_vector(self, targets) -> np.ndarray:
        """θ̄ per servoed joint from a dict name → angle (missing joints: 0) or an array."""
        if isinstance(targets, dict):
            unknown = sorted(set(targets) - set(self.names))
            if unknown:
                raise UnknownJoint(f"targets name joints {unknown} that the servo does not have; it has {self.names}")
            return np.array([float(targets.get(nm, 0.0)) for nm in self.names])
        t = as_floats("targets", targets, ndmin=1)
        if t.shape != (self.index.size,):
            raise InvalidInput(f"targets must have {self.index.size} entries, got shape {t.shape}")
        return t

    def explicit(self, q, qd, targets) -> np.ndarray:
        """τ (nv,) = k_p (θ̄ − θ) − k_v θ̇ on the servoed joints, clipped to the limits; zero elsewhere."""
        # BEGIN SOLUTION PDServo.explicit
        th = self.target_vector(targets)
        tau = np.zeros(self.nv)
        tau[self.index] = np.clip(self.kp * (th - self.A @ q) - self.kv * (self.A @ qd), -self.limits, self.limits)
        return tau
        # END SOLUTION

    def stable(self, q, qd, targets, h: float, implicit: bool = False) -> tuple[np.ndarray, np.ndarray]:
        """The servo split for a step of length h: (τ₀, k) with τ = τ₀ − k θ̇⁺.

        Stable PD: τ₀ = k_p (θ̄ − θ − h θ̇), k = k_v; implicit PD (``implicit``): τ₀ = k_p (θ̄ − θ),
        k = k_v + h k_p. τ₀ goes to the right-hand side, k to the left (M + h diag(k)); a solver that takes
        implicit damping (:class:`pbanim.articulated.planar_step.PlanarContactStep`) does the rest. Torque
        limits clip τ₀ (the implicit part is bounded by k |θ̇⁺|).
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


def stable_pd_acceleration(M, C, q, qd, target, kp, kv, h: float) -> tuple[np.ndarray, np.ndarray]:
    """(q̈, τ) of stable PD on every coordinate: q̈ = (M + h K_v)⁻¹(−C − K_p(q + h q̇ − q̄) − K_v q̇)."""
    M = np.asarray(M, dtype=float)
    n = M.shape[0]
    kp, kv = _gains("kp", kp, n), _gains("kv", kv, n)
    # BEGIN SOLUTION stable_pd_acceleration
    tau_p = -kp * (q + h * qd - target) - kv * qd
    qdd = np.linalg.solve(M + h * np.diag(kv), tau_p - C)
    return qdd, tau_p - h * kv * qdd
    # END SOLUTION


def explicit_pd_stable(h: float, kp: float, kv: float, m: float = 1.0) -> bool:
    """The closed-form stability of semi-implicit Euler with an explicit servo on m θ̈ = τ (ORACLES F1)."""
    w2, c = kp / m, kv / m
    return bool(h * c < 2.0 and h * h * w2 + 2.0 * h * c < 4.0)


SERVOS = ("explicit", "stable", "implicit")


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


def servo_track(servo: str, target, kp: float, kv: float, h: float, t_end: float, m: float = 1.0,
                x0: float = 0.0, v0: float = 0.0) -> tuple[np.ndarray, np.ndarray]:
    """(t, θ) of the mass m θ̈ = τ following ``target(t)`` with one servo, fixed step h (semi-implicit
    Euler; explicit PD reads the target now, stable and implicit PD at the next step). Stops early with
    θ = ±inf once |θ| > 1e6 (an unstable servo), so the caller sees the divergence."""
    if servo not in SERVOS:
        raise InvalidInput(f"servo must be one of {SERVOS}, got {servo!r}")
    n = int(np.ceil(check_positive("t_end", t_end) / check_positive("h", h) - 1e-9))
    t = h * np.arange(n + 1)
    xs = np.full(n + 1, np.inf)
    x, v = float(x0), float(v0)
    xs[0] = x
    for k in range(n):
        if servo == "explicit":
            v += h * (kp * (target(t[k]) - x) - kv * v) / m
        elif servo == "stable":
            v = (v + h * kp * (target(t[k + 1]) - x - h * v) / m) / (1.0 + h * kv / m)
        else:
            v = (v + h * kp * (target(t[k + 1]) - x) / m) / (1.0 + h * (kv + h * kp) / m)
        x += h * v
        if not abs(x) < 1e6:
            break
        xs[k + 1] = x
    return t, xs


def stable_pd_stable(h: float, kp: float, kv: float, m: float = 1.0) -> bool:
    """The closed-form stability of the stable-PD servo on m θ̈ = τ (ORACLES F1)."""
    a, hc = h * h * kp / m, h * kv / m
    return bool(a < 4.0 / 3.0 + 2.0 / 3.0 * hc and a < 2.0 + hc)


def largest_stable_step(kp: float, kv: float, *, m: float = 1.0, servo: str = "explicit", h_max: float = 10.0,
                        bisections: int = 50) -> float:
    """The largest step h ≤ h_max at which the servoed mass is stable, measured: the step map of
    :func:`pd_step` is linear, so two steps from the unit states give its matrix, and h is stable when its
    spectral radius is ≤ 1 (+1e-12); bisection with a cap known before it starts (``bisections``)."""

    def stable(h: float) -> bool:
        cols = [pd_step(1.0, 0.0, h, kp, kv, m, servo), pd_step(0.0, 1.0, h, kp, kv, m, servo)]
        return float(np.max(np.abs(np.linalg.eigvals(np.array(cols).T)))) <= 1.0 + 1e-12

    if stable(h_max):
        return h_max
    lo, hi = 0.0, h_max
    for _ in range(bisections):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if stable(mid) else (lo, mid)
    return lo
