"""Floor rows of chapter 05: one torque-free rigid body under gravity, RK4 (``pbanim bench floors``).

The hand loop is what a student writes for one body once the numpy version is too slow: Baraff's state
(x, q, P, L) as thirteen Python floats,

    R = R(q) with s = 2/|q|²,   ω = R I⁻¹_body Rᵀ L,   ẋ = P/m,   q̇ = ½ (0, ω) ⊗ q,   Ṗ = m g,   L̇ = 0,

the four RK4 stages written out, q renormalized after each step as pbanim's default post-step stage does.
pbanim runs ``RigidScene(RigidBodies(...), [RigidGravity(g)]).simulate(T, h, "rk4")`` with its defaults
(states recorded every step, diagnostics computed only if read), which for one body is the lean path of
:mod:`pbanim.rigid.lean`. Goal: ≤ 2× the hand loop and ≤ 50 µs a step.

CPython bounds this row: a step is four evaluations of the right-hand side, about 80 float operations
each, and each operation costs the interpreter some 20–40 ns whatever the arithmetic. The row's note prints
that floor as measured in the run: the hand loop's four right-hand sides alone, without the stage sums,
the renormalization or the recording.
"""

from __future__ import annotations

import time
from math import sqrt

import numpy as np

from .floors import Floor

__all__ = ["FLOORS", "one_rigid_body"]

MASS, MOMENTS, H, N_STEPS = 2.0, (1.0, 2.0, 3.0), 1e-3, 1000
X0, Q0 = (0.0, 0.0, 1.0), (0.3, 0.5, -0.2, 0.8)
V0, W0 = (1.0, 0.0, 2.0), (1.0, 0.1, 2.0)
G = (0.0, 0.0, -9.81)


def _rates(s):
    """ẏ of the hand loop at s = (x, q, P, L): 13 floats in, 13 out."""
    x0, x1, x2, w, a, b, c, p0, p1, p2, l0, l1, l2 = s
    k = 2.0 / (w * w + a * a + b * b + c * c)
    r00, r01, r02 = 1.0 - k * (b * b + c * c), k * (a * b - w * c), k * (a * c + w * b)
    r10, r11, r12 = k * (a * b + w * c), 1.0 - k * (a * a + c * c), k * (b * c - w * a)
    r20, r21, r22 = k * (a * c - w * b), k * (b * c + w * a), 1.0 - k * (a * a + b * b)
    u0 = (r00 * l0 + r10 * l1 + r20 * l2) / MOMENTS[0]          # I⁻¹_body Rᵀ L (a diagonal inertia)
    u1 = (r01 * l0 + r11 * l1 + r21 * l2) / MOMENTS[1]
    u2 = (r02 * l0 + r12 * l1 + r22 * l2) / MOMENTS[2]
    o0 = r00 * u0 + r01 * u1 + r02 * u2                            # ω = R I⁻¹_body Rᵀ L
    o1 = r10 * u0 + r11 * u1 + r12 * u2
    o2 = r20 * u0 + r21 * u1 + r22 * u2
    return (p0 / MASS, p1 / MASS, p2 / MASS,
            -0.5 * (o0 * a + o1 * b + o2 * c), 0.5 * (o0 * w + o1 * c - o2 * b),
            0.5 * (o1 * w + o2 * a - o0 * c), 0.5 * (o2 * w + o0 * b - o1 * a),
            MASS * G[0], MASS * G[1], MASS * G[2], 0.0, 0.0, 0.0)


def _hand_rk4(y0, steps: int) -> np.ndarray:
    """RK4 on (x, q, P, L) with q ← q/|q| after each step, from y0, for ``steps`` steps of H."""
    f, h, h2, h6 = _rates, H, H / 2, H / 6
    y = list(y0)
    for _ in range(steps):
        k1 = f(y)
        k2 = f([u + h2 * d for u, d in zip(y, k1)])
        k3 = f([u + h2 * d for u, d in zip(y, k2)])
        k4 = f([u + h * d for u, d in zip(y, k3)])
        y = [u + h6 * (d1 + 2 * d2 + 2 * d3 + d4) for u, d1, d2, d3, d4 in zip(y, k1, k2, k3, k4)]
        n = sqrt(y[3] * y[3] + y[4] * y[4] + y[5] * y[5] + y[6] * y[6])
        y[3], y[4], y[5], y[6] = y[3] / n, y[4] / n, y[5] / n, y[6] / n
    return np.array(y)


def _rates_floor_us(y0, calls: int = 4000) -> float:
    """µs per step of the four right-hand sides alone (the CPython floor of the row), median of 5."""
    f, y = _rates, list(y0)
    times = []
    for _ in range(5):
        start = time.perf_counter()
        for _ in range(calls):
            f(y)
        times.append((time.perf_counter() - start) / calls * 4e6)
    return float(np.median(times))


def one_rigid_body() -> Floor:
    """A 1 × 2 × 3 kg m² body of 2 kg thrown spinning under gravity (no torque: L stays constant)."""
    from ..rigid import RigidBodies, RigidGravity, RigidScene

    rb = RigidBodies(MASS, MOMENTS, positions=[X0], orientations=[Q0], velocities=[V0], angular_velocities=[W0])
    scene = RigidScene(rb, [RigidGravity(G)])
    y0 = tuple(rb.state().tolist())             # the same start: q normalized, P = m v, L = I_world ω

    def pbanim():
        return scene.simulate(fl.steps * H, H, "rk4").y[:, -1]

    def hand():
        return _hand_rk4(y0, fl.steps)

    fl = Floor("rigid bodies", "one torque-free body under gravity (3-D)", "rk4", N_STEPS, pbanim, hand,
               limit_us=50.0)
    fl.notes.append(f"rigid bodies: CPython floor of the RK4 step, its four right-hand sides on floats alone: "
                    f"{_rates_floor_us(y0):.1f} µs (the ≤ 50 µs goal is judged against it)")
    return fl


FLOORS = [one_rigid_body]
