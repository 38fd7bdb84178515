"""The lean twin of S(t, u) for the sketching interface's ball (chapter 10, issue 30 point 5; part of
:mod:`pbanim.design`).

One sphere under gravity bouncing off fixed planes flies parabolas between its impacts, and the impact
times are roots of quadratics (:mod:`pbanim.design.exact`). For the editor's parameters u = (x₀, v₀) the
whole S(t, u) and ∂x(t*)/∂u follow by the chain rule through each impact, as Popović's deck does, on a few
floats per bounce — no grid, no driver, no general state. Carried along from the anchor a (the start or the
last impact) are x_a, v_a, t_a and their derivatives Dx_a, Dv_a (3 × p) and Dt_a (p):

    x(t) = x_a + v_a s + ½ g s²,       s = t − t_a,
    Dx(t) = Dx_a + s Dv_a − (v_a + g s) Dt_a;

the next impact with plane (n, o), gap γ(τ) = n·(x_a + v_a τ + ½ g τ² − o) − r = 0, first falling root,
moves with u as

    Dτ = −n·(Dx_a + τ Dv_a) / (n·v⁻),   v⁻ = v_a + g τ,
    Dx_e = Dx_a + τ Dv_a + v⁻ Dτ,  Dv⁻ = Dv_a + g Dτ,  Dt_e = Dt_a + Dτ,
    v⁺ = v⁻ − (1 + ε)(n·v⁻) n,     Dv⁺ = (𝟙 − (1 + ε) n nᵀ) Dv⁻

(a frictionless impulse through the centre: no spin, no change of L). This is the same derivative as the
saltation Φ⁺ = G(Φ⁻ + f⁻δτ) − f⁺δτ of :func:`pbanim.design.simulate`, written at the moving anchor.

Where the readable run does more than this — a touch at the start, an impact slower than ``SLOW`` (a graze,
a rest, Zeno: :mod:`pbanim.design.rest`), a tangent touch of a gap (its vertex within ``SLOW``·s of zero),
two planes hit within ``SLOW`` s, more than ``MAX_IMPACTS`` impacts — :func:`_ball_run` returns None and the
caller runs the readable S. Tested equal to it (ORACLES L5).

==========  ==============  =======  ==========================================
symbol      code            shape    meaning
==========  ==============  =======  ==========================================
x_a, v_a    ``x, v``        (3,)     the anchor's position and velocity
Dx_a, Dv_a  ``Dx, Dv``      (3, p)   their derivatives with respect to u
Dt_a        ``Dt``          (p,)     the anchor time's derivative
ε           ``eps``         scalar   restitution
==========  ==============  =======  ==========================================

Limiting cases: no impact gives Dx(t) = Dx₀ + t Dv₀ (ORACLES H3); ε = 1 keeps |v| at each bounce.

References: Popović et al. SIGGRAPH 2000 §4–5 (S, ∂S/∂u through impacts; the interactive loop); Hiskens &
Pai 2000 (saltation); W. H. Press et al., *Numerical Recipes* §5.6 (the quadratic's roots).
"""

from __future__ import annotations

import math

import numpy as np

from ..collision import Sphere

__all__: list = []

SLOW = 1e-2          # m/s, s: below this margin the readable run decides (grazes, rests, touches, near ties)
MAX_IMPACTS = 100    # the readable run's default cap


def ball_applies(scene, names) -> bool:
    """One sphere with isotropic inertia, free parameters among x₀, v₀ of body 0."""
    b = scene.bodies[0] if scene.N == 1 else None
    return (b is not None and isinstance(b.shape, Sphere) and np.ptp(b.inertia) <= 1e-12 * b.inertia[0]
            and set(names) <= {"x0", "v0"})


def _falling_root(a: float, b: float, c: float):
    """The first τ > 0 where a τ² + b τ + c falls through zero from above (c > 0), as
    :func:`pbanim.design.exact._first_down_root` on one gap; None when there is none; "near" when the gap's
    vertex comes within SLOW of zero without crossing (a touch: the readable run decides)."""
    D = b * b - 4.0 * a * c
    if D < 0.0:
        if a > 0.0 and b < 0.0 and c - b * b / (4.0 * a) <= SLOW:
            return "near"
        return None
    sq = math.sqrt(D)
    qq = -0.5 * (b + (sq if b >= 0 else -sq))
    best = None
    for r in ((qq / a) if a != 0 else math.inf, (c / qq) if qq != 0 else math.inf):
        if math.isfinite(r) and r > 0 and 2.0 * a * r + b < 0 and (best is None or r < best):
            best = r
    if best is None and a > 0.0 and b < 0.0 and -b / (2.0 * a) > 0 and c - b * b / (4.0 * a) <= SLOW:
        return "near"
    return best


def _ball_run(scene, names, u, t_end: float, t_draw: np.ndarray, t_star):
    """(X at t_draw (K, 3), x(t*), ∂x(t*)/∂u (3, p), impacts [(t, plane, speed)]) or None (module docstring)."""
    d = scene.values(names, u)
    sl = scene.slices(names)
    p = sum(s.stop - s.start for s in sl.values())
    x, v = np.array(d["x0"], dtype=float), np.array(d["v0"], dtype=float)
    g, eps, r = scene.gravity, float(d["restitution"][0]), float(scene.radius[0])
    Dx, Dv, Dt = np.zeros((3, p)), np.zeros((3, p)), np.zeros(p)
    if "x0" in sl:
        Dx[:, sl["x0"]] = np.eye(3)
    if "v0" in sl:
        Dv[:, sl["v0"]] = np.eye(3)
    planes = [(pl.normal, float(a @ pl.normal)) for pl, a in zip(scene.planes, scene.anchors)]
    a_n = [0.5 * float(n @ g) for n, _ in planes]
    tol = 1e-9 * max(1.0, float(np.abs(x).max()))
    if any(float(n @ x) - o - r <= max(tol, SLOW * 1e-3) for n, o in planes):
        return None                                    # touching at the start: the readable settle decides
    X = np.empty((len(t_draw), 3))
    ta, x_star, A, impacts = 0.0, None, None, []
    for _ in range(MAX_IMPACTS + 1):
        best, k_best = math.inf, -1
        for k, (n, o) in enumerate(planes):
            tau = _falling_root(a_n[k], float(n @ v), float(n @ x) - o - r)
            if tau == "near":
                if ta + (-float(n @ v) / (2.0 * a_n[k])) < t_end + SLOW:
                    return None
                continue
            if tau is not None and abs(tau - best) <= SLOW and ta + min(tau, best) <= t_end + SLOW:
                return None                            # two planes at (nearly) once
            if tau is not None and tau < best:
                best, k_best = tau, k
        te = ta + best
        last = te > t_end
        sel = (t_draw >= ta) & ((t_draw <= t_end) if last else (t_draw < te))
        s = t_draw[sel] - ta
        X[sel] = x + s[:, None] * v + 0.5 * (s * s)[:, None] * g
        if t_star is not None and x_star is None and (last or t_star < te):
            s = t_star - ta
            x_star = x + v * s + 0.5 * g * s * s
            A = Dx + s * Dv - np.outer(v + g * s, Dt)
        if last:
            return X, x_star, A, impacts
        n = planes[k_best][0]
        vm = v + g * best
        vn = float(n @ vm)
        if -vn < SLOW or -vn * eps < SLOW:
            return None                                # a graze, or a bounce dying into a rest
        Dtau = -(n @ (Dx + best * Dv)) / vn
        Dx = Dx + best * Dv + np.outer(vm, Dtau)
        Dvm = Dv + np.outer(g, Dtau)
        Dv = Dvm - (1.0 + eps) * np.outer(n, n @ Dvm)
        Dt = Dt + Dtau
        x = x + v * best + 0.5 * g * best * best
        v = vm - (1.0 + eps) * vn * n
        ta = te
        impacts.append((te, k_best, -vn))
    return None
