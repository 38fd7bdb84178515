"""The scenes of the comparison and their exact answers (chapter 11, ORACLES K1–K8).

Each scene is a :class:`~pbanim.compare.spec.SceneSpec` (described once) with a *score* — the error of
any engine's :class:`~pbanim.compare.spec.Trace` against the closed form — and an *observable* (one
number per sample, plotted over its exact curve in chapter 11). Gravity is g = 9.81 m/s² along −z
(−y for the chain, as in :func:`pbanim.models.articulated.rod_chain`); the ground, when present, is z = 0.

=============  ==============================================================  ======================
scene          exact answer                                                    headline error
=============  ==============================================================  ======================
free_fall      x(t) = x₀ + v₀t + ½gt²                                          max |x − x_exact| (m)
projectile     the same parabola, v₀ = (3, 0, 4) m/s, until it is back at z = 0  max |x − x_exact| (m)
bounce         apex k at ε^(2k) h₀, rest at t∞ = √(2h₀/g)(1+ε)/(1−ε)              max rel. error, apexes 1–3
incline_stick  tan θ < μ: s(t) = 0                                              max |s − s_exact| (m)
incline_slide  tan θ > μ: s(t) = ½ g (sin θ − μ cos θ) t²                        max |s − s_exact| (m)
rolling        v = v₀ − μgt until t* = 2v₀/(7μg), then 5v₀/7 (solid sphere)      max |v − v_exact| (m/s)
chain          E(t) = E₀ and every joint closed (C = 0)                         max |E − E₀| / (M g ℓ)
cradle         small gaps d: ball i starts at i d/v₀, final (0, …, 0, v₀)         max |v_i(T) − v_i| / v₀
stack          boxes at rest forever: drift 0, penetration 0, settling time 0   max |z_top − z_top(0)| (m)
top            steady precession Ω: I₁′Ω² cos θ − I₃ω₃Ω + mgr = 0 (→ mgr/(I₃ω₃))  |Ω_measured − Ω| / Ω
=============  ==============================================================  ======================

Notation: h₀ drop height (of the ball's lowest point), ε restitution, μ friction, θ incline angle (the
incline is the ground with gravity tilted by θ about y: downhill is +x), s the downhill displacement,
v₀ the launch speed, M g ℓ the total weight times the chain length, ω₃ the spin about the top's axis,
I₁′ = I₁ + m r² the top's transverse moment about its tip, r the tip-to-centre distance.

Limiting cases: ε → 1 gives t∞ → ∞ (the ball bounces forever); θ = arctan μ is the boundary between
sticking and sliding (a = 0 on both sides); ω₃ → ∞ gives the fast-top rate mgr/(I₃ω₃).

References: A. Boeing, T. Bräunl, GRAPHITE 2007 (the test scenes: integrator, restitution, friction,
constraint stability, stacking); H. Goldstein, *Classical Mechanics*, §5.7 (the heavy symmetric top);
the rolling transition is Routh's, *Dynamics of a System of Rigid Bodies* (1905), §§ on sliding spheres.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

import numpy as np

from .spec import Body, Joint, SceneSpec, Trace, energy, joint_drift
from ..contracts import Choice, Func, Obj, Real, Text, contract
from ..errors import InvalidInput, check_result
from ..models.collision import bouncing_ball
from ..models.contact import incline_expected
from ..rigid.quat import quat_from_axis_angle, quat_to_matrix

__all__ = ["Scene", "SCENES", "scene"]

G = 9.81
STEPS = (4e-3, 2e-3, 1e-3, 5e-4)
QUICK = (4e-3, 2e-3)


@contract(spec=Obj(SceneSpec), error_name=Text(), score=Func(), observable=Func(), exact=Func(), ylabel=Text())
@dataclass(frozen=True)
class Scene:
    """A scene, its score and its observable. ``score(trace)`` returns {"error": headline, …};
    ``observable(trace)`` and ``exact(t)`` are the curves chapter 11 draws."""

    spec: SceneSpec
    error_name: str
    score: Callable[[Trace], dict]
    observable: Callable[[Trace], np.ndarray]
    exact: Callable[[np.ndarray], np.ndarray]
    ylabel: str


def _sphere(name, r, m, x, **kw) -> Body:
    return Body(name, "sphere", (r,), m, (0.4 * m * r * r,) * 3, x, **kw)


def _box(name, half, m, x, **kw) -> Body:
    a, b, c = (2 * np.asarray(half)) ** 2
    return Body(name, "box", half, m, (m * (b + c) / 12, m * (a + c) / 12, m * (a + b) / 12), x, **kw)


# -- free flight (ORACLES K1) ----------------------------------------------------------------------------
def _flight(name, title, x0, v0, duration, quick_duration) -> Scene:
    spec = SceneSpec(name, title, (_sphere("ball", 0.1, 1.0, x0, v=v0),), (0, 0, -G), duration,
                     (1e-2, 5e-3, 2e-3, 1e-3), (1e-2, 5e-3), quick_duration=quick_duration,
                     params={"x0": x0, "v0": v0}, notes="x(t) = x₀ + v₀t + ½gt²; no contact")
    x0, v0, g = np.asarray(x0), np.asarray(v0), np.asarray(spec.gravity)

    def exact_x(t):
        t = np.asarray(t, float)[:, None]
        return x0 + v0 * t + 0.5 * g * t * t

    def score(tr):
        return {"error": float(np.max(np.linalg.norm(tr.x[:, 0] - exact_x(tr.t), axis=1)))}

    return Scene(spec, "max |x − x_exact| (m)", score, lambda tr: tr.x[:, 0, 2], lambda t: exact_x(t)[:, 2],
                 "z (m)")


def free_fall() -> Scene:
    return _flight("free_fall", "Free fall from 10 m", (0.0, 0.0, 10.0), (0.0, 0.0, 0.0), 1.0, 0.5)


def projectile() -> Scene:
    return _flight("projectile", "Projectile, v₀ = (3, 0, 4) m/s", (0.0, 0.0, 0.0), (3.0, 0.0, 4.0),
                   round(8.0 / G, 6), round(8.0 / G, 6))


# -- restitution (ORACLES K2) ----------------------------------------------------------------------------
def bounce(h0: float = 1.0, restitution: float = 0.8, radius: float = 0.1) -> Scene:
    bb = bouncing_ball(h0, restitution, G)
    spec = SceneSpec("bounce", f"Ball bounced with ε = {restitution:g} from h₀ = {h0:g} m",
                     (_sphere("ball", radius, 1.0, (0.0, 0.0, radius + h0), restitution=restitution),),
                     (0, 0, -G), round(1.2 * bb.zeno_time, 6), STEPS, QUICK, ground=True,
                     quick_duration=round(float(bb.impact_times(4)) + 0.05, 6),
                     params={"h0": h0, "restitution": restitution, "zeno_time": bb.zeno_time},
                     notes="apex k at ε^(2k) h₀; at rest from the Zeno time t∞ on")

    def apexes(tr):
        z, vz = tr.x[:, 0, 2] - radius, tr.v[:, 0, 2]
        k = np.flatnonzero((vz[:-1] > 0) & (vz[1:] <= 0))
        top = z[k] + vz[k] ** 2 / (2 * G)
        return top[top > 1e-3 * h0]

    def score(tr):
        want = bb.apex_heights(np.arange(1, 4))
        got = apexes(tr)[:3]
        got = np.concatenate([got, np.zeros(3 - got.size)])          # a missing bounce is a 100 % error
        out = {"error": float(np.max(np.abs(got - want) / want)), "apex_1": float(got[0])}
        if tr.t[-1] > bb.zeno_time:
            z, v = tr.x[:, 0, 2] - radius, np.linalg.norm(tr.v[:, 0], axis=1)
            moving = np.flatnonzero((z > 1e-3) | (v > 0.05))
            rest = tr.t[min(moving[-1] + 1, tr.t.size - 1)] if moving.size else 0.0
            out["rest_time_error"] = float(rest - bb.zeno_time)
        return out

    def exact(t):
        t = np.asarray(t, float)
        tk = np.concatenate([[0.0], bb.impact_times(np.arange(1, 200))])
        k = np.clip(np.searchsorted(tk, t, side="right") - 1, 0, tk.size - 1)
        v_up = np.where(k == 0, 0.0, restitution ** k * np.sqrt(2 * G * h0))
        s = t - tk[k]
        z = np.where(k == 0, h0 - 0.5 * G * t * t, v_up * s - 0.5 * G * s * s)
        return np.where(t >= bb.zeno_time, 0.0, np.maximum(z, 0.0))

    return Scene(spec, "max rel. error of apexes 1–3 (1)", score, lambda tr: tr.x[:, 0, 2] - radius, exact,
                 "height of the lowest point (m)")


# -- friction on an incline (ORACLES K3) -----------------------------------------------------------------
def incline(slide: bool, friction: float = 0.5, offset: float = 0.05) -> Scene:
    theta = float(np.arctan(friction) + (offset if slide else -offset))
    half = (0.2, 0.2, 0.1)
    ex = incline_expected(theta, friction, G)
    name = "incline_slide" if slide else "incline_stick"
    spec = SceneSpec(name, f"Box on an incline, θ = arctan μ {'+' if slide else '−'} {offset:g} rad, μ = {friction:g}",
                     (_box("box", half, 1.0, (0.0, 0.0, half[2]), friction=friction),),
                     (G * np.sin(theta), 0.0, -G * np.cos(theta)), 1.0, STEPS, QUICK, ground=True,
                     quick_duration=0.3, params={"angle": theta, "friction": friction, **ex},
                     notes="static iff tan θ ≤ μ, else a = g(sin θ − μ cos θ) (incline_expected)")
    a = ex["acceleration"]

    def score(tr):
        s = tr.x[:, 0, 0] - tr.x[0, 0, 0]
        err = np.abs(s - 0.5 * a * tr.t ** 2)
        late = tr.t >= 0.5 * tr.t[-1]
        fit = np.polyfit(tr.t[late], s[late], 2)[0] * 2 if late.sum() >= 3 else np.nan
        return {"error": float(err.max()), "acceleration_error": float(abs(fit - a))}

    return Scene(spec, "max |s − s_exact| (m)", score, lambda tr: tr.x[:, 0, 0] - tr.x[0, 0, 0],
                 lambda t: 0.5 * a * np.asarray(t, float) ** 2, "downhill displacement s (m)")


# -- sliding to rolling (ORACLES K4) ---------------------------------------------------------------------
def rolling(v0: float = 2.0, friction: float = 0.3, radius: float = 0.1) -> Scene:
    t_star = 2 * v0 / (7 * friction * G)
    spec = SceneSpec("rolling", f"Sphere thrown sliding at {v0:g} m/s, μ = {friction:g}",
                     (_sphere("ball", radius, 1.0, (0.0, 0.0, radius), v=(v0, 0.0, 0.0), friction=friction),),
                     (0, 0, -G), round(2 * t_star, 6), STEPS, QUICK, ground=True,
                     quick_duration=round(1.5 * t_star, 6),
                     params={"v0": v0, "friction": friction, "t_roll": t_star, "v_roll": 5 * v0 / 7},
                     notes="v = v₀ − μgt until t* = 2v₀/(7μg), then rolls at 5v₀/7")

    def exact(t):
        t = np.asarray(t, float)
        return np.where(t < t_star, v0 - friction * G * t, 5 * v0 / 7)

    def score(tr):
        v, slip = tr.v[:, 0, 0], tr.v[:, 0, 0] - radius * tr.w[:, 0, 1]
        rolled = np.flatnonzero(slip <= 1e-3 * v0)
        t_roll = float(tr.t[rolled[0]]) if rolled.size else np.inf
        return {"error": float(np.max(np.abs(v - exact(tr.t)))), "t_roll_error": abs(t_roll - t_star),
                "v_final_error": float(abs(v[-1] - 5 * v0 / 7))}

    return Scene(spec, "max |v − v_exact| (m/s)", score, lambda tr: tr.v[:, 0, 0], exact, "speed v (m/s)")


# -- a pendulum chain (ORACLES K5) -----------------------------------------------------------------------
def chain(n: int = 3, length: float = 0.5, mass: float = 1.0, theta0: float = 0.9) -> Scene:
    L = length
    q0 = tuple(quat_from_axis_angle([0.0, 0.0, 1.0], theta0))
    R = quat_to_matrix(np.asarray(q0))
    inertia = (mass * L * L / 12, 1e-3 * mass * L * L, mass * L * L / 12)     # as pbanim.models.articulated.rod_chain
    bodies = tuple(Body(f"rod{k}", "none", (0.02, L / 2, 0.02), mass, inertia, tuple(R @ [0.0, -L * (k + 0.5), 0.0]),
                        quat=q0) for k in range(n))
    joints = (Joint("hinge", 0, -1, (0, L / 2, 0), (0, 0, 0)),) + tuple(
        Joint("hinge", k, k - 1, (0, L / 2, 0), (0, -L / 2, 0)) for k in range(1, n))
    spec = SceneSpec("chain", f"Chain of {n} rods released at {theta0:g} rad", bodies, (0, -G, 0), 2.0, STEPS, QUICK,
                     joints=joints, quick_duration=0.15, params={"n": n, "length": L, "theta0": theta0},
                     notes="energy constant, every joint closed")
    scale = n * mass * G * n * L

    def score(tr):
        E = energy(spec, tr)
        return {"error": float(np.max(np.abs(E - E[0])) / scale), "joint_drift": float(joint_drift(spec, tr).max())}

    return Scene(spec, "max |E − E₀| / (M g ℓ) (1)", score, lambda tr: energy(spec, tr) - energy(spec, tr)[0],
                 lambda t: np.zeros(np.shape(t)), "E − E₀ (J)")


# -- Newton's cradle (ORACLES K6) ------------------------------------------------------------------------
def cradle(n: int = 3, gap: float = 0.0503, v0: float = 1.0, radius: float = 0.1) -> Scene:
    # gap / v₀ is no multiple of the sweep's steps: no impact falls exactly on a step boundary, where
    # pbanim's event location takes a pair touching at the step's start for a resting one (ε = 0)
    bodies = tuple(_sphere(f"ball{i}", radius, 1.0, (i * (2 * radius + gap), 0.0, 0.0), v=(v0 if i == 0 else 0.0, 0, 0),
                           restitution=1.0) for i in range(n))
    t_last = (n - 1) * gap / v0
    spec = SceneSpec("cradle", f"Newton's cradle, {n} balls {gap:g} m apart", bodies, (0, 0, 0), round(t_last + 0.1, 6),
                     (2e-3, 1e-3, 5e-4, 2.5e-4), (2e-3, 1e-3), params={"n": n, "gap": gap, "v0": v0},
                     notes="elastic, equal masses: the velocity passes along; final (0, …, 0, v₀)")
    want = np.zeros(n)
    want[-1] = v0

    def score(tr):
        v = tr.v[-1, :, 0]
        E = 0.5 * (tr.v[-1] ** 2).sum()
        return {"error": float(np.max(np.abs(v - want)) / v0), "energy_loss": float(1 - E / (0.5 * v0 * v0))}

    return Scene(spec, "max |v_i(T) − v_i| / v₀ (1)", score, lambda tr: tr.v[:, -1, 0],
                 lambda t: np.where(np.asarray(t, float) >= t_last, v0, 0.0), "last ball's speed (m/s)")


# -- a stack of boxes (ORACLES K7) -----------------------------------------------------------------------
def stack(n: int = 3, friction: float = 0.5) -> Scene:
    half = (0.5, 0.5, 0.25)                    # as pbanim.models.contact.box_stack and pbanim bench contact
    bodies = tuple(_box(f"box{k}", half, 1.0, (0.0, 0.0, half[2] * (2 * k + 1)), friction=friction) for k in range(n))
    spec = SceneSpec("stack", f"Stack of {n} boxes at rest", bodies, (0, 0, -G), 1.0, (1e-2, 5e-3, 2e-3), (1e-2, 5e-3),
                     ground=True, quick_duration=0.3, params={"n": n, "friction": friction},
                     notes="at rest forever: drift, penetration and settling time all 0")

    def score(tr):
        z = tr.x[:, -1, 2]
        speed = np.linalg.norm(tr.v, axis=2).max(axis=1)
        moving = np.flatnonzero(speed > 1e-3)
        pen = tr.extra.get("penetration")
        return {"error": float(np.max(np.abs(z - z[0]))),
                "penetration": float(np.max(pen)) if pen is not None and np.size(pen) else np.nan,
                "settling_time": float(tr.t[moving[-1]]) if moving.size else 0.0,
                "lateral_drift": float(np.max(np.linalg.norm(tr.x[:, :, :2] - tr.x[0, :, :2], axis=2)))}

    return Scene(spec, "max |z_top − z_top(0)| (m)", score, lambda tr: tr.x[:, -1, 2] - tr.x[0, -1, 2],
                 lambda t: np.zeros(np.shape(t)), "top box height change (m)")


# -- a spinning top (ORACLES K8) -------------------------------------------------------------------------
@contract(mass=Real(gt=0), r=Real(ge=0), I1=Real(gt=0), I3=Real(gt=0), spin=Real(gt=0), theta=Real(ge=0, le=np.pi))
def top_precession(mass, r, I1, I3, spin, theta) -> float:
    """The slow steady precession rate Ω of a heavy symmetric top at tilt θ (0 … π from the upward vertical)
    with axial spin ω₃ = ``spin`` > 0: the smaller positive root of I₁′ cos θ Ω² − I₃ω₃ Ω + m g r = 0,
    I₁′ = I₁ + m r² (→ mgr/(I₃ω₃) as ω₃ → ∞; NonFiniteResult when the numbers overflow)."""
    with np.errstate(over="ignore", invalid="ignore"):
        a, b, c = (I1 + mass * r * r) * np.cos(theta), I3 * spin, mass * G * r
        disc = b * b - 4 * a * c
        if not disc > 0 and np.isfinite(disc):
            raise InvalidInput(f"spin must exceed {2 * np.sqrt(a * c) / I3:.4g} rad/s (I₃ω₃ > 2√(I₁′ cos θ m g r)) "
                               f"for a steady precession, got spin = {spin!r}")
        return float(check_result("top_precession: Ω", 2 * c / (b + np.sqrt(disc))))


def top(spin: float = 150.0, theta: float = 0.3, mass: float = 1.0, r: float = 0.1, I1: float = 9e-4,
        I3: float = 1.8e-3) -> Scene:
    Om = top_precession(mass, r, I1, I3, spin, theta)
    e3 = np.array([np.sin(theta), 0.0, np.cos(theta)])
    w = Om * np.array([0.0, 0.0, 1.0]) + (spin - Om * np.cos(theta)) * e3       # ω·e₃ = ω₃, φ̇ = Ω, θ̇ = 0
    body = Body("top", "none", (0.06, 0.06, r), mass, (I1, I1, I3), tuple(r * e3),
                quat=tuple(quat_from_axis_angle([0.0, 1.0, 0.0], theta)), v=tuple(np.cross(w, r * e3)), w=tuple(w))
    spec = SceneSpec("top", f"Top spinning at {spin:g} rad/s, tilted {theta:g} rad", (body,), (0, 0, -G), 1.0,
                     (2e-3, 1e-3, 5e-4, 2.5e-4), (2e-3, 1e-3), joints=(Joint("ball", 0, -1, (0, 0, -r), (0, 0, 0)),),
                     quick_duration=0.15, params={"precession": Om, "fast_top": mass * G * r / (I3 * spin),
                                                 "theta": theta, "spin": spin},
                     notes="uniform precession at Ω (fast top: mgr/(I₃ω₃)); no nutation")

    def azimuth(tr):
        axis = np.einsum("kij,j->ki", quat_to_matrix(tr.q[:, 0] / np.linalg.norm(tr.q[:, 0], axis=1)[:, None]),
                         [0.0, 0.0, 1.0])
        return np.unwrap(np.arctan2(axis[:, 1], axis[:, 0])), np.arccos(np.clip(axis[:, 2], -1, 1))

    def score(tr):
        phi, tilt = azimuth(tr)
        rate = np.polyfit(tr.t, phi, 1)[0] if tr.t.size > 2 else np.nan
        return {"error": float(abs(rate - Om) / Om), "nutation": float(np.max(np.abs(tilt - theta))),
                "joint_drift": float(joint_drift(spec, tr).max())}

    return Scene(spec, "|Ω − Ω_exact| / Ω (1)", score, lambda tr: azimuth(tr)[0], lambda t: Om * np.asarray(t, float),
                 "precession angle φ (rad)")


SCENES: dict[str, Callable[[], Scene]] = {
    "free_fall": free_fall, "projectile": projectile, "bounce": bounce,
    "incline_stick": lambda: incline(False), "incline_slide": lambda: incline(True), "rolling": rolling,
    "chain": chain, "cradle": cradle, "stack": stack, "top": top,
}


@contract(name=Choice(SCENES))
def scene(name: str) -> Scene:
    """The scene called ``name`` (:data:`SCENES`), or :class:`~pbanim.errors.InvalidInput` naming the closest."""
    return SCENES[name]()
