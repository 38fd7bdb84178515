"""The lean step of frictionless rigid-body time stepping (chapter 07, issue 28 point 3).

:meth:`pbanim.contact.friction.TimeStepping.step` is the readable step: a padded state dictionary
(:func:`pbanim.contact.assembly.rigid_state`), a validated contact set, :func:`velocity_lcp`, the checked
:func:`pbanim.lcp.solve.solve_lcp` and an update that computes the rotations again. For the scenes whose
narrow phase hands out raw arrays (:class:`pbanim.contact.scenes.SceneDetect`: ``detect.arrays(y, R)``,
geometry valid by construction) and no friction, :class:`LeanFrictionless` takes the same step with
everything that does not change from step to step paid once, when the stepper is built: the effects'
``apply``, the rotations and the solver bound unchecked, the static masks and body inertias gathered. Per step,
with the rotations R of y computed once:

    ũ = (W(P + hQ_v), I⁻¹(L + hQ_ω)),   I⁻¹ = R I_b⁻¹ Rᵀ,
    Jᵢ = [nᵢᵀ, (rᵢ × nᵢ)ᵀ] on a, −[nᵢᵀ, (r′ᵢ × nᵢ)ᵀ] on b,   A = J W Jᵀ,   b = J ũ + s⁺/h,
    0 ≤ p ⊥ A p + b ≥ 0 (the same solver, warm started from the last step, the same certificate),
    u⁺ = ũ + W Jᵀ p,   x⁺ = x + h v⁺,   q⁺ = exp(½hω⁺) ⊗ q,   P⁺ = m v⁺,   L⁺ = R I_b Rᵀ ω⁺.

The arithmetic is the readable step's, operation for operation (A by :func:`pbanim.lcp.delassus`, the
solve by the one solver routine), so the trajectories are equal to roundoff
(``tests/test_contact_lean.py``, ORACLES D14).

=========  ===============  ===========  ==================================================
symbol     code             shape        meaning
=========  ===============  ===========  ==================================================
ũ          ``u``            (N+1, 6)     free velocity (v, ω) per body (last row: the world)
p          ``f``            (m,)         normal impulses
s⁺         ``bias · h``     (m,)         separation s > 0, or erp · s for a penetration
=========  ===============  ===========  ==================================================

Limiting cases: no contact → ũ (a free fall); a box at rest on the ground → Σp = m g h.
"""

from __future__ import annotations

from math import cos, sin, sqrt

import numpy as np

from ..collision.shapes import Contacts
from ..contracts import Array, Obj, Real, contract, unchecked
from ..lcp.solve import delassus, lean_pgs, solve_lcp

__all__ = ["LeanFrictionless", "lean_applies"]


_STEPPER = Obj("pbanim.contact.friction:TimeStepping")


@contract(ts=_STEPPER)
def lean_applies(ts) -> bool:
    """Whether a :class:`~pbanim.contact.friction.TimeStepping` can take the lean step: rigid bodies, no
    friction, and a narrow phase with raw arrays for this very system."""
    det = ts.detect
    return (ts.rigid and not np.any(ts.mu > 0) and getattr(det, "arrays", None) is not None
            and getattr(det, "bodies", None) is ts.system)


#: up to this many bodies the lean step keeps J and W dense (a few small matrix products per step); above,
#: per-contact rows and :func:`pbanim.lcp.delassus` (cost linear in the contacts, not in N²)
DENSE_BODIES = 16


def _cross(a, b):
    out = np.empty(b.shape)
    out[:, 0] = a[:, 1] * b[:, 2] - a[:, 2] * b[:, 1]
    out[:, 1] = a[:, 2] * b[:, 0] - a[:, 0] * b[:, 2]
    out[:, 2] = a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0]
    return out


def _exp_times(theta, q):
    """exp(½θ) ⊗ q for rows θ (N, 3), q (N, 4): :func:`pbanim.rigid.quat.quat_exp` then
    :func:`~pbanim.rigid.quat.quat_multiply`, the same formulas in fewer array calls (equal to roundoff)."""
    a = np.sqrt((theta * theta).sum(axis=1))
    small = a < 1e-4                                   # sin(a/2)/a by its series ½ − a²/48 + a⁴/3840 there
    a_safe = np.where(small, 1.0, a)
    a2 = a * a
    sinc = np.where(small, 0.5 - a2 / 48.0 + a2 * a2 / 3840.0, np.sin(0.5 * a_safe) / a_safe)
    e = np.empty((a.size, 4))
    e[:, 0] = np.cos(0.5 * a)
    e[:, 1:] = sinc[:, None] * theta
    e /= np.sqrt((e * e).sum(axis=1))[:, None]
    a0, a1, a2, a3 = e.T
    b0, b1, b2, b3 = q.T
    out = np.empty(q.shape)
    out[:, 0] = a0 * b0 - a1 * b1 - a2 * b2 - a3 * b3
    out[:, 1] = a0 * b1 + a1 * b0 + a2 * b3 - a3 * b2
    out[:, 2] = a0 * b2 - a1 * b3 + a2 * b0 + a3 * b1
    out[:, 3] = a0 * b3 + a1 * b2 - a2 * b1 + a3 * b0
    return out


#: up to this many bodies the rotations and the quaternion update run on floats, body by body (the same
#: formulas as :func:`pbanim.rigid.quat.quat_to_matrix` and :func:`_exp_times`, equal to roundoff)
FLOAT_BODIES = 4


def _rotations_floats(q) -> np.ndarray | None:
    """R (N, 3, 3) of the quaternions q (N, 4) by :func:`pbanim.rigid.quat.quat_to_matrix`'s formula (s = 2/|q|²)
    on floats; None when some |q|² is outside (10⁻²⁹⁰, 10²⁹⁰) (the readable call scales it, or names a zero q)."""
    out = []
    for w, x, y, z in q.tolist():
        n2 = w * w + x * x + y * y + z * z
        if not 1e-290 < n2 < 1e290:
            return None
        s = 2.0 / n2
        xx, yy, zz = s * x * x, s * y * y, s * z * z
        xy, xz, yz = s * x * y, s * x * z, s * y * z
        wx, wy, wz = s * w * x, s * w * y, s * w * z
        out.append(((1.0 - yy - zz, xy - wz, xz + wy), (xy + wz, 1.0 - xx - zz, yz - wx),
                    (xz - wy, yz + wx, 1.0 - xx - yy)))
    return np.array(out)


def _exp_times_floats(theta, q) -> np.ndarray:
    """:func:`_exp_times` body by body on floats (the same formulas, in the same order)."""
    out = []
    for (t0, t1, t2), (b0, b1, b2, b3) in zip(theta.tolist(), q.tolist()):
        a = sqrt(t0 * t0 + t1 * t1 + t2 * t2)
        if a < 1e-4:
            a2 = a * a
            sinc = 0.5 - a2 / 48.0 + a2 * a2 / 3840.0
        else:
            sinc = sin(0.5 * a) / a
        a0, a1, a2, a3 = cos(0.5 * a), sinc * t0, sinc * t1, sinc * t2
        r = sqrt(a0 * a0 + a1 * a1 + a2 * a2 + a3 * a3)
        a0, a1, a2, a3 = a0 / r, a1 / r, a2 / r, a3 / r
        out.append((a0 * b0 - a1 * b1 - a2 * b2 - a3 * b3, a0 * b1 + a1 * b0 + a2 * b3 - a3 * b2,
                    a0 * b2 - a1 * b3 + a2 * b0 + a3 * b1, a0 * b3 + a1 * b2 - a2 * b1 + a3 * b0))
    return np.array(out)


def free_velocity(lean, t: float, y: np.ndarray, h: float):
    """The start of a lean rigid step: (x, q, R, Rᵀ, I⁻¹, ũ) with R of y once (on floats up to
    :data:`FLOAT_BODIES` bodies), the bound effects applied and ũ = (W(P + hQ_v), I⁻¹(L + hQ_ω)) padded to
    (N + 1, 6) (the world's row zero). ``lean``: a lean stepper's bound fields (N, floats, rotations, zero,
    applies, Ib_inv, inv_mass)."""
    N = lean.N
    x = y[:3 * N].reshape(N, 3)
    q = y[3 * N:7 * N].reshape(N, 4)
    P = y[7 * N:10 * N].reshape(N, 3)
    L = y[10 * N:].reshape(N, 3)
    R = _rotations_floats(q) if lean.floats else None
    if R is None:
        R = lean.rotations(y)
    Rt = np.swapaxes(R, 1, 2)
    Q = lean.zero.copy()
    for apply in lean.applies:
        apply(t, y, Q)
    Iinv = R @ lean.Ib_inv @ Rt
    u = np.zeros((N + 1, 6))
    u[:N, :3] = lean.inv_mass[:N, None] * (P + h * Q[:, :3])
    u[:N, 3:] = (Iinv @ (L + h * Q[:, 3:])[:, :, None])[:, :, 0]
    return x, q, R, Rt, Iinv, u


def advance(lean, x, q, R, Rt, u, h: float) -> np.ndarray:
    """The end of a lean rigid step: x⁺ = x + h v⁺, q⁺ = exp(½hω⁺) ⊗ q, P⁺ = m v⁺, L⁺ = R I_b Rᵀ ω⁺ (zero on
    static bodies), as the flat state. ``lean``: the bound fields (N, floats, Ib, m_live, live)."""
    N = lean.N
    v, w = u[:N, :3], u[:N, 3:]
    L_new = (R @ lean.Ib @ Rt @ w[:, :, None])[:, :, 0]
    L_new[~lean.live[:, 0]] = 0.0
    out = np.empty(13 * N)
    out[:3 * N] = (x + h * v).ravel()
    out[3 * N:7 * N] = (_exp_times_floats if lean.floats else _exp_times)(h * w, q).ravel()
    out[7 * N:10 * N] = (lean.m_live * v).ravel()
    out[10 * N:] = L_new.ravel()
    return out


class LeanFrictionless:
    """The frictionless rigid step of a :class:`~pbanim.contact.friction.TimeStepping`, bound once (see the
    module docstring); ``step(t, y, h)`` sets the stepper's ``last`` and ``last_info`` as its readable step.
    Up to :data:`DENSE_BODIES` bodies J (m × 6N) and W (6N × 6N) are dense: A = J W Jᵀ, b = J ũ + s⁺/h and
    u⁺ = ũ + W Jᵀ p are three products; above, per-contact rows and :func:`pbanim.lcp.delassus`."""

    @contract(ts=_STEPPER)
    def __init__(self, ts) -> None:
        s = ts.system
        self.ts, self.N = ts, s.N
        self.applies = [unchecked(e.apply) for e in ts.forces]
        self.arrays = ts.detect.arrays
        self.opts = dict(ts.solver_options)
        self.solve = unchecked(solve_lcp)
        # PGS: the sweeps called directly, certified by their own stop test (pbanim.lcp.solve.lean_pgs); any
        # other option, or a step it does not certify, goes to the readable solve_lcp
        self.pgs = ts.solver == "pgs" and set(self.opts) <= {"max_iter", "omega"}
        self.rotations = unchecked(s.rotations)
        N = s.N
        self.dense = N <= DENSE_BODIES
        self.floats = N <= FLOAT_BODIES
        self.inv_mass = np.append(s.inv_mass, 0.0)                       # padded: the world's row is zero
        self.Ib_inv, self.Ib = s.inv_I_body, s.I_body
        self.m_live = np.where(s.static, 0.0, s.mass)[:, None]
        self.live = ~s.static[:, None]
        self.Wb = np.zeros((N + 1, 6, 6))
        self.Wb[:, :3, :3] = self.inv_mass[:, None, None] * np.eye(3)
        self.xp = np.zeros((N + 1, 3))                                   # padded centres (the world at 0)
        self.zero = np.zeros((N, 6))
        self.W = np.zeros((6 * N, 6 * N))                                # dense W (live bodies), diagonal 1/m set once
        idx = np.arange(N)
        for k in range(3):
            self.W[6 * idx + k, 6 * idx + k] = s.inv_mass
        self.ang = (6 * idx[:, None, None] + 3 + np.arange(3)[:, None], 6 * idx[:, None, None] + 3 + np.arange(3))

    @contract(t=Real(), y=Array((lambda env: 13 * env.values["self"].N,)), h=Real(gt=0))
    def step(self, t: float, y: np.ndarray, h: float) -> np.ndarray:
        ts, N = self.ts, self.N
        x, q, R, Rt, Iinv, u = free_velocity(self, t, y, h)
        ca, cb, point, normal, sep, keys = self.arrays(y, R)
        m = ca.size
        ts.last_info = {"m": m, "penetration": float(np.max(-sep, initial=0.0))}
        if m:
            a = np.where(ca < 0, N, ca)
            b = np.where(cb < 0, N, cb)
            xp = self.xp
            xp[:N] = x
            Ga, Gb = np.empty((m, 6)), np.empty((m, 6))
            Ga[:, :3] = Gb[:, :3] = normal
            Ga[:, 3:] = _cross(point - xp[a], normal)
            Gb[:, 3:] = _cross(point - xp[b], normal)
            bias = np.where(sep > 0, sep, ts.erp * sep) / h
            if self.dense:
                W = self.W
                W[self.ang] = Iinv
                J = np.zeros((m, 6 * N + 6))                             # the world's six columns, dropped below
                rows = np.arange(m)[:, None]
                J[rows, 6 * a[:, None] + np.arange(6)] = Ga
                J[rows, 6 * b[:, None] + np.arange(6)] -= Gb
                J = J[:, :6 * N]
                JW = J @ W
                A = JW @ J.T
                A = 0.5 * (A + A.T)
                bb = J @ u[:N].ravel() + bias
            else:
                Wb = self.Wb
                Wb[:N, 3:, 3:] = Iinv
                A = delassus(a, b, Ga, Gb, Wb)
                A = 0.5 * (A + A.T)
                bb = np.einsum("ij,ij->i", Ga, u[a]) - np.einsum("ij,ij->i", Gb, u[b]) + bias
            last = ts.last
            ws = last.f if (last is not None and last.f.size == m) else None
            sol = lean_pgs(A, bb, ws, ts.tol, **self.opts) if self.pgs else None
            if sol is None:
                sol = self.solve(A, bb, ts.solver, tol=ts.tol, raise_on_failure=not ts.accept_unconverged,
                                 warm_start=ws, validate=False, **self.opts)
            ts.last = sol
            f = sol.f
            if self.dense:
                du = (f @ JW).reshape(N, 6)                              # W Jᵀ p (W symmetric)
                imp = (f @ J).reshape(N, 6)
            else:
                full = np.zeros((N + 1, 6))
                np.add.at(full, a, Ga * f[:, None])
                np.add.at(full, b, -Gb * f[:, None])
                imp = full[:N]
                du = np.einsum("nij,nj->ni", Wb[:N], imp)
            u[:N] += du
            contacts = object.__new__(Contacts)          # the step's record, fields as Contacts stores them
            contacts.a, contacts.b, contacts.point, contacts.normal, contacts.depth = ca, cb, point, normal, -sep
            contacts.radius = contacts.radius_b = np.zeros(m)
            ts.last_info.update(normal_impulse=f, impulse=imp, friction_impulse=None, contacts=contacts)
        else:
            ts.last = None
            ts.last_info["contacts"] = None
        return advance(self, x, q, R, Rt, u, h)
