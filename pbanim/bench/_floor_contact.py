"""Floor row of chapter 07: a box dropped on the ground, velocity-level contact (``pbanim bench floors``).

pbanim's side is :meth:`pbanim.contact.friction.TimeStepping.simulate` (``diagnostics=False``: the states
alone) on :func:`pbanim.contact.scenes.dropped_stack` with one box (half extents (0.5, 0.5, 0.25) m, 1 kg,
1 mm above the ground z = 0), frictionless, projected Gauss–Seidel warm started from the last step's
impulses. The hand loop below is the same step written out in numpy, as a student would write it from the
lecture (Stewart–Trinkle / Anitescu–Potra without friction), with the same contacts (the corners within
2 mm of the ground) and the same solver (PGS from the last step's impulses, stopping at the same
certificate):

    ũ = (v + h g, I⁻¹L),   I⁻¹ = R I_b⁻¹ Rᵀ,   Jᵢ = [nᵀ, (rᵢ × n)ᵀ],   A = J W Jᵀ,   b = J ũ + s⁺/h,
    pᵢ ← max(0, pᵢ − (Aᵢ·p + bᵢ)/Aᵢᵢ) until ‖p − max(0, p − (Ap + b))‖∞ ≤ tol·max(1, ‖b‖∞) + 1000ε‖|A||p|‖∞,
    u⁺ = ũ + W Jᵀ p,   x⁺ = x + h v⁺,   q⁺ = exp(½hω⁺) ⊗ q,   P⁺ = m v⁺,   L⁺ = R I_b Rᵀ ω⁺,

with s⁺ = s for a gap and erp·s for a penetration (erp = 0.2). Both return the final state y = [x, q, P, L]
and the bench checks that they agree to roundoff (equal work).

pbanim's step is the lean one (:class:`pbanim.contact.lean.LeanFrictionless`): PGS's sweeps called directly
(:func:`pbanim.lcp.solve.lean_pgs`: the same warm-start test and iterates, the stopping test being the
certificate of ``solve_lcp``, which answers only what the sweeps do not certify), the rotations and the
quaternion update on floats for a few bodies (before: ``solve_lcp`` checking, copying and certifying its
inputs again at every step, and those on arrays: 2.87x).
"""

from __future__ import annotations

import numpy as np

from .floors import Floor

__all__ = ["FLOORS", "box_on_ground"]

H, N_STEPS, TOL, ERP, MARGIN, G = 1e-3, 1000, 1e-10, 0.2, 2e-3, 9.81
HALF = np.array([0.5, 0.5, 0.25])
CORNERS = np.array([[sx, sy, sz] for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)], dtype=float) * HALF
EPS1000 = 1000 * float(np.finfo(float).eps)


def _rotation(q):
    w, x, y, z = q
    return np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
                     [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
                     [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)]])


def _exp_times(theta, q):
    """exp(½θ) ⊗ q, with the series of sin(a/2)/a for a tiny rotation a = |θ|."""
    a = float(np.sqrt(theta @ theta))
    s = 0.5 - a * a / 48.0 + a ** 4 / 3840.0 if a < 1e-4 else np.sin(0.5 * a) / a
    e = np.array([np.cos(0.5 * a), *(s * theta)])
    e /= np.sqrt(e @ e)
    a0, a1, a2, a3 = e
    b0, b1, b2, b3 = q
    return np.array([a0 * b0 - a1 * b1 - a2 * b2 - a3 * b3, a0 * b1 + a1 * b0 + a2 * b3 - a3 * b2,
                     a0 * b2 - a1 * b3 + a2 * b0 + a3 * b1, a0 * b3 + a1 * b2 - a2 * b1 + a3 * b0])


def _pgs(A, b, p):
    """Projected Gauss–Seidel from p, stopping at the certificate (a warm start worse than p = 0 is dropped)."""
    m = b.size
    res = lambda f: float(np.max(np.abs(f - np.maximum(0.0, f - (A @ f + b)))))  # noqa: E731
    if p is None or not res(p) <= res(np.zeros(m)):
        p = np.zeros(m)
    p = np.maximum(p, 0.0)
    absA, scale = np.abs(A), max(1.0, float(np.max(np.abs(b))))
    if res(p) <= TOL * scale + EPS1000 * float(np.max(absA @ p)):
        return p
    diag = np.diag(A)
    for _ in range(1000):
        for i in range(m):
            fi = p[i] - (A[i] @ p + b[i]) / diag[i]
            p[i] = fi if fi > 0.0 else 0.0
        if res(p) <= TOL * scale + EPS1000 * float(np.max(absA @ p)):
            break
    return p


def box_on_ground() -> Floor:
    """One 1 kg box dropped from 1 mm onto the ground, frictionless velocity-level PGS, h = 1 ms, 1000 steps."""
    from ..contact.friction import TimeStepping
    from ..contact.scenes import dropped_stack
    from ..rigid.inertia import box_inertia

    sc = dropped_stack(1, gap=1e-3, offset=0.0)
    ts = TimeStepping(sc.system, sc.detect, sc.forces, friction=0.0, solver="pgs", tol=TOL, erp=ERP)

    def pbanim():
        ts.last = None                     # each run from the scene's start, nothing warm from the last run
        return ts.simulate(fl.steps * H, H, diagnostics=False).y[:, -1]

    Ib = box_inertia(1.0, 2 * HALF)
    Ib_inv = np.linalg.inv(Ib)
    up = np.array([0.0, 0.0, 1.0])

    def hand():
        x, q = np.array([0.0, 0.0, HALF[2] + 1e-3]), np.array([1.0, 0.0, 0.0, 0.0])
        P, L = np.zeros(3), np.zeros(3)
        p_last = None
        for _ in range(fl.steps):
            R = _rotation(q)
            Iinv = R @ Ib_inv @ R.T
            v, w = P + H * np.array([0.0, 0.0, -G]), Iinv @ L           # m = 1
            pts = x + CORNERS @ R.T
            sep = pts[:, 2]
            touch = sep <= MARGIN
            if touch.any():
                r, s = pts[touch] - x, sep[touch]
                rxn = np.cross(r, up)
                A = 1.0 + rxn @ Iinv @ rxn.T                                 # n·n / m + (r×n)ᵀ I⁻¹ (r×n)
                b = v[2] + rxn @ w + np.where(s > 0, s, ERP * s) / H
                p = _pgs(A, b, p_last if p_last is not None and p_last.size == b.size else None)
                p_last = p
                v, w = v + p.sum() * up, w + Iinv @ (rxn.T @ p)
            else:
                p_last = None
            x, q = x + H * v, _exp_times(H * w, q)
            P, L = v, R @ Ib @ R.T @ w
        return np.concatenate([x, q, P, L])

    fl = Floor("contact", "a box dropped 1 mm onto the ground (4 corner contacts)", "velocity-level PGS",
               N_STEPS, pbanim, hand, tol=1e-9)     # the runs read fl.steps (the quick run sets fewer)
    return fl


FLOORS = [box_on_ground]
