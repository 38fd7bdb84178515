"""Checks of ch08_pd_control (PD servos: explicit, stable and implicit) — chapter 08, part 2.

In a copy of :mod:`pbanim.control.pd` the student writes the lecture's servo and its two implicit
variants (the module's docstring has the equations; ORACLES F1):

    explicit PD      τ = k_p (θ̄ − θ) − k_v θ̇,   clipped to |τ| ≤ τ_max            (PDServo.explicit)
    stable PD        τ = k_p (θ̄ − θ − h θ̇) − k_v θ̇⁺,  θ̇⁺ = θ̇ + h θ̈   (Tan, Liu & Turk 2011)
                     with M θ̈ + C = τ:  θ̈ = (M + h K_v)⁻¹ (−C − K_p (θ + h θ̇ − θ̄) − K_v θ̇)
                                                                       (stable_pd_acceleration)
    the split        τ = τ₀ − k θ̇⁺: stable τ₀ = k_p(θ̄ − θ − hθ̇), k = k_v; implicit τ₀ = k_p(θ̄ − θ),
                     k = k_v + h k_p; τ₀ clipped                        (PDServo.stable)
    one step         of m θ̈ = τ (target 0) by semi-implicit Euler, θ⁺ = θ + h θ̇⁺     (pd_step)

=====================  =====================================================================  ======
check                  oracle                                                                 id
=====================  =====================================================================  ======
explicit_torque        τ = k_p(θ̄ − θ) − k_v θ̇ on the servoed joints, 0 on the others           F1
torque_limits          |τ| ≤ τ_max: a saturated servo gives exactly ±τ_max (explicit, split)    F1
stable_split           (τ₀, k) of stable and implicit PD, joint and world-frame servos          F1
stable_pd_equations    q̈, τ of stable PD satisfy M q̈ + C = τ, τ = −K_p(q+hq̇−q̄) − K_v(q̇+hq̈)    F1
stability_regions      the measured largest stable step of each servo = the closed form         F1
=====================  =====================================================================  ======

The closed forms of the stability check, on m θ̈ = τ with c = k_v/m, ω² = k_p/m (the roots of the
binding conditions of F1): explicit h = min(2/c, (−2c + √(4c² + 16ω²))/(2ω²)); stable
h = min(((2/3)c + √((4/9)c² + (16/3)ω²))/(2ω²), (c + √(c² + 8ω²))/(2ω²)); implicit: every h.

Limiting cases: k_v = 0 (no damping) — stable PD's step limit is √(4/3)/ω, *shorter* than explicit PD's
2/ω; h → 0 — stable and implicit PD become the explicit servo.
"""

from __future__ import annotations

import numpy as np

from .registry import CheckFailed, Mutant, array, attr, check, close

CHECKS: list = []


def _servo(mod, **kw):
    return attr(mod, "PDServo")({"hip": 1, "knee": 3}, nv=5, **kw)


_Q = np.array([0.3, 0.1, -0.4, -0.2, 0.7])
_QD = np.array([-1.0, 1.0, 0.5, 2.0, 3.0])


@check(CHECKS, "explicit_torque", 20, "the explicit servo τ = k_p(θ̄ − θ) − k_v θ̇ (damping opposes θ̇)", "F1",
       regions=("PDServo.explicit",))
def explicit_torque(mod):
    kp, kv = np.array([100.0, 50.0]), np.array([10.0, 5.0])
    servo = _servo(mod, kp=kp, kv=kv)
    for targets in ({"hip": 0.5, "knee": 0.0}, {"knee": -1.0}):
        th = np.array([targets.get("hip", 0.0), targets.get("knee", 0.0)])
        want = np.zeros(5)
        want[[1, 3]] = kp * (th - _Q[[1, 3]]) - kv * _QD[[1, 3]]
        close(f"PDServo.explicit(q, q̇, {targets})", servo.explicit(_Q, _QD, targets), want, rtol=1e-14, unit="N·m",
              why="τ = k_p(θ̄ − θ) − k_v θ̇ on the servoed joints, 0 elsewhere")
    return "τ exact on servoed joints, 0 on the others"


@check(CHECKS, "torque_limits", 15, "torque limits: a saturated servo gives exactly ±τ_max", "F1",
       regions=("PDServo.explicit", "PDServo.stable"))
def torque_limits(mod):
    limits = np.array([30.0, 20.0])
    servo = _servo(mod, kp=[100.0, 50.0], kv=[10.0, 5.0], limits=limits)
    q, qd = np.array([0, -1.0, 0, 2.0, 0]), np.zeros(5)          # at rest: only the springs act
    tau = array("PDServo.explicit(...)", servo.explicit(q, qd, {"hip": 0.5, "knee": 0.0}), (5,))
    close("saturated explicit torque", tau[[1, 3]], [30.0, -20.0], rtol=1e-14, unit="N·m",
          why="k_p(θ̄ − θ) = (150, −100) N·m is beyond the limits (30, 20): clip it")
    tau_free = servo.explicit(q, qd, {"hip": -0.9, "knee": 2.1})
    close("unsaturated explicit torque", array("PDServo.explicit(...)", tau_free, (5,))[[1, 3]], [10.0, 5.0],
          rtol=1e-13, unit="N·m", why="inside the limits the servo is not clipped")
    out = servo.stable(q, np.array([0, 1.0, 0, -1.0, 0]), {"hip": 0.5, "knee": 0.0}, 0.01)
    if not isinstance(out, tuple) or len(out) != 2:
        raise CheckFailed(f"PDServo.stable must return (tau0, k), got {type(out).__name__}")
    tau0 = array("PDServo.stable(...)[0]", out[0], (5,))
    close("saturated stable τ₀", tau0[[1, 3]], [30.0, -20.0], rtol=1e-14, unit="N·m",
          why="τ₀ = k_p(θ̄ − θ − hθ̇) is clipped to the limits")
    return "saturated servos give ±τ_max, unsaturated ones are not clipped"


@check(CHECKS, "stable_split", 15, "stable and implicit PD split τ = τ₀ − k θ̇⁺ (joint and world-frame servos)",
       "F1", public=False, regions=("PDServo.stable",))
def stable_split(mod):
    kp, kv, h = np.array([100.0, 50.0]), np.array([10.0, 5.0]), 0.02
    row = np.array([0.0, 1.0, 1.0, 1.0, 0.0])                   # the knee servo holds a world angle θ = q₁+q₂+q₃
    servo = _servo(mod, kp=kp, kv=kv, world=["knee"], angles={"knee": row})
    targets = {"hip": 0.5, "knee": -0.3}
    th = np.array([0.5, -0.3])
    A = np.zeros((2, 5))
    A[0, 1], A[1] = 1.0, row
    theta, thd = A @ _Q, A @ _QD
    other = thd - _QD[[1, 3]]                                    # the world angle's rate off its own joint
    for implicit in (False, True):
        out = servo.stable(_Q, _QD, targets, h, implicit=implicit)
        if not isinstance(out, tuple) or len(out) != 2:
            raise CheckFailed(f"PDServo.stable must return (tau0, k), got {type(out).__name__}")
        tau0, k = array("τ₀", out[0], (5,)), array("k", out[1], (5,))
        if implicit:
            want0 = kp * (th - theta - h * other) - kv * other
            wantk = kv + h * kp
        else:
            want0 = kp * (th - theta - h * thd) - kv * other
            wantk = kv
        name = "implicit" if implicit else "stable"
        close(f"{name} PD τ₀ on (hip, knee)", tau0[[1, 3]], want0, rtol=1e-13, unit="N·m",
              why="stable: spring at θ + hθ̇ (explicit part of a world servo's rate); implicit: spring at θ")
        close(f"{name} PD k on (hip, knee)", k[[1, 3]], wantk, rtol=1e-14, unit="N·m·s",
              why="stable: k = k_v; implicit: k = k_v + h k_p")
        close(f"{name} PD τ₀, k on unservoed joints", np.concatenate([tau0[[0, 2, 4]], k[[0, 2, 4]]]), np.zeros(6),
              atol=0.0)
    return "(τ₀, k) exact for stable and implicit PD, with a world-frame servo"


@check(CHECKS, "stable_pd_equations", 25, "stable PD on a coupled system: M q̈ + C = τ, spring at q + h q̇", "F1",
       regions=("stable_pd_acceleration",))
def stable_pd_equations(mod):
    rng = np.random.default_rng(8)
    worst = 0.0
    for n, h in ((3, 0.01), (4, 0.05)):
        G = rng.normal(size=(n, n))
        M, C = G @ G.T + n * np.eye(n), rng.normal(size=n)
        q, qd, target = rng.normal(size=n), rng.normal(size=n), rng.normal(size=n)
        kp, kv = rng.uniform(10.0, 200.0, n), rng.uniform(1.0, 20.0, n)
        out = attr(mod, "stable_pd_acceleration")(M, C, q, qd, target, kp, kv, h)
        if not isinstance(out, tuple) or len(out) != 2:
            raise CheckFailed(f"stable_pd_acceleration must return (qdd, tau), got {type(out).__name__}")
        qdd, tau = array("q̈", out[0], (n,)), array("τ", out[1], (n,))
        scale = float(np.abs(tau).max() + np.abs(C).max())
        # F1's tolerance 1e-12 (relative to the torques); the reference: measured 1.3e-16
        worst = max(worst, close(f"M q̈ + C − τ (n = {n})", M @ qdd + C, tau, atol=1e-12 * scale, unit="N·m",
                                 why="the torque is the one the equations of motion receive"))
        close(f"τ − (−K_p(q + hq̇ − q̄) − K_v(q̇ + hq̈)) (n = {n})", tau,
              -kp * (q + h * qd - target) - kv * (qd + h * qdd), atol=1e-12 * scale, unit="N·m",
              why="stable PD: spring at the predicted position q + hq̇, damper at the next velocity q̇ + hq̈")
    return f"equations of motion and Tan et al.'s torque hold (worst {worst:.1e} N·m)"


def _closed_form_step(servo: str, kp: float, kv: float, m: float) -> float:
    w2, c = kp / m, kv / m
    if servo == "explicit":
        roots = [(-2 * c + np.sqrt(4 * c * c + 16 * w2)) / (2 * w2)] + ([2.0 / c] if c > 0 else [])
    else:
        roots = [((2 / 3) * c + np.sqrt((4 / 9) * c * c + (16 / 3) * w2)) / (2 * w2),
                 (c + np.sqrt(c * c + 8 * w2)) / (2 * w2)]
    return float(min(roots))


@check(CHECKS, "stability_regions", 25, "the largest stable step of each servo equals the closed form", "F1",
       public=False, regions=("pd_step",))
def stability_regions(mod):
    largest = attr(mod, "largest_stable_step")
    rows = []
    for kp, zeta, m in ((100.0, 1.0, 1.0), (1e4, 0.5, 2.0), (100.0, 0.0, 1.0), (9.0, 3.0, 0.5)):
        kv = 2.0 * zeta * np.sqrt(kp * m)
        for servo in ("explicit", "stable"):
            exact = _closed_form_step(servo, kp, kv, m)
            got = largest(kp, kv, m=m, servo=servo, h_max=10.0)
            # F1's tolerance 1e-9 relative (bisection to 2⁻⁵⁰ of the bracket); the reference: measured 7e-13
            close(f"largest stable step, {servo} PD, k_p = {kp:g}, ζ = {zeta:g}, m = {m:g}", got, exact, rtol=1e-9,
                  unit="s", why="spectral radius of the step map of pd_step ≤ 1 (ORACLES F1)")
            rows.append(got * np.sqrt(kp / m))
        got = largest(kp, kv, m=m, servo="implicit", h_max=100.0)
        close(f"largest stable step, implicit PD, k_p = {kp:g}, ζ = {zeta:g}", got, 100.0, rtol=0.0, unit="s",
              why="implicit PD is stable at every step")
    return f"h√(k_p/m) at critical damping: explicit {rows[0]:.3f}, stable {rows[1]:.3f}; implicit never limited"


MUTANTS = (
    Mutant("damping_sign", "the damper pushes along the velocity: τ = k_p(θ̄ − θ) + k_v θ̇",
           (("- self.kv * (self.A @ qd), -self.limits", "+ self.kv * (self.A @ qd), -self.limits"),
            ("v = v + h * (-kp * x - kv * v) / m", "v = v + h * (-kp * x + kv * v) / m")),
           ("explicit_torque", "stability_regions")),
    Mutant("spring_at_theta", "stable PD evaluates the spring at θ instead of the predicted θ + hθ̇",
           (("tau_p = -kp * (q + h * qd - target) - kv * qd", "tau_p = -kp * (q - target) - kv * qd"),
            ("v = (v - h * kp * (x + h * v) / m) / (1.0 + h * kv / m)", "v = (v - h * kp * x / m) / (1.0 + h * kv / m)"),
            ("self.kp * (th - self.A @ q - h * (self.A @ qd))", "self.kp * (th - self.A @ q)")),
           ("stable_split", "stable_pd_equations", "stability_regions")),
    Mutant("missing_h_kv", "the h K_v term forgotten on the left: M q̈ = … instead of (M + h K_v) q̈ = …",
           (("qdd = np.linalg.solve(M + h * np.diag(kv), tau_p - C)", "qdd = np.linalg.solve(M, tau_p - C)"),
            ("v = (v - h * kp * (x + h * v) / m) / (1.0 + h * kv / m)", "v = v - h * kp * (x + h * v) / m")),
           ("stable_pd_equations", "stability_regions")),
    Mutant("no_torque_limits", "the torque limits are never applied",
           (("tau[self.index] = np.clip(self.kp * (th - self.A @ q) - self.kv * (self.A @ qd), -self.limits, self.limits)",
             "tau[self.index] = self.kp * (th - self.A @ q) - self.kv * (self.A @ qd)"),
            ("tau0[i] = np.clip(tau0[i], -self.limits, self.limits)", "tau0[i] = tau0[i]")),
           ("torque_limits",)),
)
