"""The lean step of a small rigid scene: Baraff's equations on plain floats (chapter 05, part of :mod:`pbanim.rigid`).

For one body, or a few, the vectorized step of :class:`pbanim.rigid.RigidBodies` pays some forty numpy
calls per right-hand side on arrays of one row: about a microsecond each of interpreter and dispatch, for
a few nanoseconds of arithmetic. This module writes the same step on Python floats, body by body, with
everything that does not change during a run (which effects, their constants, the inertias, the tableau)
bound once when the scene is built, as the locals of one function per body:

    s = 2/|q|²,  R = R(q) (the formula of :func:`pbanim.rigid.quat_to_matrix`),  v = W P,
    ω = R (I⁻¹_body (Rᵀ L)),  ẋ = v,  q̇ = ½ (0, ω) ⊗ q,  Ṗ = F = m g − c_v v,  L̇ = τ = −c_ω ω,

then the method's stages — an explicit Runge–Kutta method whose every stage uses the one before
(Euler, midpoint, RK4: k_{i+1} = f(y + h a_{i+1} k_i), y₁ = y + Σ_groups (Σ k_j)(h b), the grouping of
:func:`pbanim.ode.tableau.make_rk_step`), or symplectic Euler as the scene runs it (kick P, L with the forces
at y₀, drift x, q with the rates at (x₀, q₀, P₁, L₁)) — and the post-step stage q ← q/|q| of
:class:`pbanim.rigid.QuaternionRenormalize` (a |q|² that would overflow or underflow scaled first, as
:func:`pbanim.rigid.domain.tame` does).

==========================  ================================  ===============================
symbol                      code                              shape
==========================  ================================  ===============================
y = [x, q, P, L]            ``y``                             list of 13N floats (the flat layout)
W, I⁻¹_body                 ``W``, ``a00`` … ``a22``          per body
m g, c_v, c_ω               ``f0 … f2``, ``cv``, ``cw``       per body, folded from the effects
==========================  ================================  ===============================

When: :class:`pbanim.rigid.RigidScene` takes this path for a scene of at most :data:`LEAN_MAX_BODIES` bodies
whose force effects are :class:`~pbanim.rigid.RigidGravity`, :class:`~pbanim.rigid.LinearDrag` and
:class:`~pbanim.rigid.AngularDrag` only, with no constraint effect and no post-step stage but the
renormalization (``quaternions="renormalize"`` or ``"none"``), stepped by one of :data:`LEAN_METHODS`
(implicit Euler and implicit midpoint, :data:`FLOAT_RATE_METHODS`, run their own Newton step on these
float rates; one body's ``"verlet"`` is the splitting of :mod:`pbanim.rigid.splitting` on floats;
``quaternions="exponential"`` runs the float exponential map of :mod:`pbanim.rigid.lean_expmap`);
any other scene, or ``scene.lean_path = False``, runs the readable vectorized path. A step that divides
by zero (a quaternion collapsed to 0 in a diverging run) is handed to the readable path, which names
the divergence. The two paths agree to roundoff (``tests/test_rigid_lean.py``, ORACLES C1, C3).

Limiting cases: a static body (W = 0, I⁻¹ = 0) has all rates 0 and is skipped; without drag, F = m g
exactly (c_v = 0 adds an exact zero).
"""

from __future__ import annotations

from math import cos, sin, sqrt

import numpy as np

from ..contracts import Obj, contract
from .domain import _SAFE
from .effects import AngularDrag, LinearDrag, QuaternionRenormalize, RigidGravity
from .splitting import _SEQUENCE

__all__ = ["LEAN_MAX_BODIES", "LEAN_METHODS", "FLOAT_RATE_METHODS", "lean_plan"]

#: Up to this many bodies a scene steps on floats: the float step grows as N (a few µs per body and
#: right-hand side), the vectorized one barely; they cross near N = 25 (one RK4 step with gravity).
LEAN_MAX_BODIES = 16
#: The methods of the lean path (explicit chains of stages, and symplectic Euler).
LEAN_METHODS = ("euler", "midpoint", "rk4", "symplectic_euler")
#: The implicit methods whose Newton iterations (forward-difference Jacobian: n + 1 evaluations per matrix)
#: call the float rates through an array wrapper; the method's own step, unchanged.
FLOAT_RATE_METHODS = ("implicit_euler", "implicit_midpoint")


@contract(scene=Obj("pbanim.rigid.scene:RigidScene"))
def lean_plan(scene) -> "LeanRigid | None":
    """The lean plan of a :class:`~pbanim.rigid.RigidScene`, or None when the scene does not qualify (see the
    module docstring); built once, when the scene is. A scene with ``quaternions="exponential"`` gets the
    float exponential map of :mod:`pbanim.rigid.lean_expmap`.

    >>> from pbanim.rigid import RigidBodies, RigidGravity, RigidScene, RigidSprings
    >>> rb = RigidBodies(1.0, [1.0, 2.0, 3.0])
    >>> lean_plan(RigidScene(rb, [RigidGravity()])) is not None
    True
    >>> type(lean_plan(RigidScene(rb, [RigidGravity()], quaternions="exponential"))).__name__
    'LeanExpMap'
    >>> lean_plan(RigidScene(RigidBodies(np.ones(LEAN_MAX_BODIES + 1), [1.0, 2.0, 3.0]))) is None
    True
    """
    rb = scene.system
    if rb.N > LEAN_MAX_BODIES or scene._constraint:
        return None
    if any(type(e) is not QuaternionRenormalize for e in scene._post):
        return None
    Q0 = np.zeros((rb.N, 6))
    cv, cw = np.zeros(rb.N), np.zeros(rb.N)
    for e in scene._force:
        if type(e) is RigidGravity:
            Q0 += e._mg
        elif type(e) is LinearDrag:
            cv += e.c
        elif type(e) is AngularDrag:
            cw += e.c
        else:
            return None
    if scene.quaternions == "exponential":
        from .lean_expmap import LeanExpMap

        return LeanExpMap(rb, Q0, cv, cw, renormalize=bool(scene._post))
    return LeanRigid(rb, Q0, cv, cw, renormalize=bool(scene._post))


def _body_rates(W: float, inv_I: tuple, F: tuple, cv: float, cw: float, omega: bool = False):
    """ẏ of one body as a function of its 13 floats (x, q, P, L), the constants bound here (see the module
    docstring). A drag coefficient of 0 adds no term (the readable path has no such effect); a diagonal
    I⁻¹_body skips its zero products (a·u + 0·v = a·u exactly for finite u, v). ``omega``: the 12 floats
    (ẋ, ω, Ṗ, L̇) instead, ω in place of q̇ (what the exponential map steps, :mod:`pbanim.rigid.lean_expmap`)."""
    a00, a01, a02, a10, a11, a12, a20, a21, a22 = inv_I
    f0, f1, f2, t0, t1, t2 = F
    linear, angular = cv != 0.0, cw != 0.0
    full = any((a01, a02, a10, a12, a20, a21))

    def rates(y) -> tuple:
        _, _, _, w, x, yq, z, p0, p1, p2, l0, l1, l2 = y
        s = 2.0 / (w * w + x * x + yq * yq + z * z)
        xx, yy, zz = x * x, yq * yq, z * z
        xy, xz, yz = x * yq, x * z, yq * z
        wx, wy, wz = w * x, w * yq, w * z
        r00, r01, r02 = 1.0 - s * (yy + zz), s * (xy - wz), s * (xz + wy)
        r10, r11, r12 = s * (xy + wz), 1.0 - s * (xx + zz), s * (yz - wx)
        r20, r21, r22 = s * (xz - wy), s * (yz + wx), 1.0 - s * (xx + yy)
        u0 = r00 * l0 + r10 * l1 + r20 * l2             # Rᵀ L
        u1 = r01 * l0 + r11 * l1 + r21 * l2
        u2 = r02 * l0 + r12 * l1 + r22 * l2
        if full:                                         # I⁻¹_body Rᵀ L
            u0, u1, u2 = a00 * u0 + a01 * u1 + a02 * u2, a10 * u0 + a11 * u1 + a12 * u2, a20 * u0 + a21 * u1 + a22 * u2
        else:
            u0, u1, u2 = a00 * u0, a11 * u1, a22 * u2
        o0 = r00 * u0 + r01 * u1 + r02 * u2              # ω
        o1 = r10 * u0 + r11 * u1 + r12 * u2
        o2 = r20 * u0 + r21 * u1 + r22 * u2
        v0, v1, v2 = p0 * W, p1 * W, p2 * W
        if linear:
            f0_, f1_, f2_ = f0 - cv * v0, f1 - cv * v1, f2 - cv * v2
        else:
            f0_, f1_, f2_ = f0, f1, f2
        if omega:
            if angular:
                return v0, v1, v2, o0, o1, o2, f0_, f1_, f2_, t0 - cw * o0, t1 - cw * o1, t2 - cw * o2
            return v0, v1, v2, o0, o1, o2, f0_, f1_, f2_, t0, t1, t2
        if angular:
            return (v0, v1, v2,
                    -0.5 * (o0 * x + o1 * yq + o2 * z), 0.5 * (o0 * w + o1 * z - o2 * yq),
                    0.5 * (o1 * w + o2 * x - o0 * z), 0.5 * (o2 * w + o0 * yq - o1 * x),
                    f0_, f1_, f2_, t0 - cw * o0, t1 - cw * o1, t2 - cw * o2)
        return (v0, v1, v2,
                -0.5 * (o0 * x + o1 * yq + o2 * z), 0.5 * (o0 * w + o1 * z - o2 * yq),
                0.5 * (o1 * w + o2 * x - o0 * z), 0.5 * (o2 * w + o0 * yq - o1 * x),
                f0_, f1_, f2_, t0, t1, t2)
    return rates


def chain_stepper(tableau, rates, unit=None):
    """``step(y, h) -> y₁`` on lists of floats for a chain tableau (every stage uses the one before:
    k_{i+1} = rates(y + h a_{i+1} k_i)), or None for another tableau; ``unit(y₁)`` (in place), when given, is
    applied to the result. The weights are grouped as :func:`pbanim.ode.tableau.make_rk_step` groups them:
    y + Σ_groups (Σ k_j)(h b)."""
    s = tableau.stages
    if not all(len(tableau.rows[i]) == 1 and tableau.rows[i][0][0] == i - 1 for i in range(1, s)):
        return None
    chain = tuple(float(tableau.rows[i][0][1]) for i in range(1, s))
    groups: dict = {}
    for j, b in enumerate(tableau.B):
        if b != 0:
            groups.setdefault(float(b), []).append(j)
    groups = tuple((b, tuple(js)) for b, js in groups.items())
    if len(groups) == 2 and all(len(js) == 2 for _, js in groups):   # RK4: (k₀ + k₃)(h/6) + (k₁ + k₂)(h/3)
        (b, (i0, i1)), (c, (j0, j1)) = groups
        a1, a2, a3 = chain

        def step(y: list, h: float) -> list:
            k0 = rates(y)
            ha = h * a1
            k1 = rates([u + d * ha for u, d in zip(y, k0)])
            ha = h * a2
            k2 = rates([u + d * ha for u, d in zip(y, k1)])
            ha = h * a3
            k3 = rates([u + d * ha for u, d in zip(y, k2)])
            k = (k0, k1, k2, k3)
            hb, hc = h * b, h * c
            y1 = [u + ((p + q) * hb + (r + v) * hc) for u, p, q, r, v in zip(y, k[i0], k[i1], k[j0], k[j1])]
            return unit(y1) if unit else y1
        return step

    def step(y: list, h: float) -> list:
        last = rates(y)
        k = [last]
        for a in chain:
            ha = h * a
            last = rates([u + d * ha for u, d in zip(y, last)])
            k.append(last)
        inc = None
        for b, js in groups:
            part = k[js[0]]
            for j in js[1:]:
                part = [p + q for p, q in zip(part, k[j])]
            hb = h * b
            inc = [p * hb for p in part] if inc is None else [i + p * hb for i, p in zip(inc, part)]
        y1 = [u + i for u, i in zip(y, inc)]
        return unit(y1) if unit else y1
    return step


def unit_quats(y: list, quats) -> list:
    """q ← q/|q| for the quaternions of y starting at the indices ``quats``, in place (a |q|² outside the safe
    range: q scaled by max |qᵢ| first)."""
    lo, hi = _SAFE
    for i in quats:
        w, x, yq, z = y[i], y[i + 1], y[i + 2], y[i + 3]
        n2 = w * w + x * x + yq * yq + z * z
        if not lo < n2 < hi:
            m = max(abs(w), abs(x), abs(yq), abs(z))
            if m > 0:                            # (0 and NaN are left to the divergence check)
                w, x, yq, z = w / m, x / m, yq / m, z / m
                n2 = w * w + x * x + yq * yq + z * z
        n = sqrt(n2)
        y[i], y[i + 1], y[i + 2], y[i + 3] = w / n, x / n, yq / n, z / n
    return y


class LeanRigid:
    """The bound per-body rates of one scene and its float steps (see the module docstring)."""

    def __init__(self, rb, Q0: np.ndarray, cv: np.ndarray, cw: np.ndarray, renormalize: bool) -> None:
        N = rb.N
        self.n, self.split, self.renormalize = 13 * N, 7 * N, renormalize
        self.quats = tuple(range(3 * N, 7 * N, 4))
        bodies = tuple((3 * i, 3 * N + 4 * i, 7 * N + 3 * i, 10 * N + 3 * i,
                        _body_rates(float(rb.inv_mass[i]), tuple(float(a) for a in rb.inv_I_body[i].ravel()),
                                    tuple(float(f) for f in Q0[i]), float(cv[i]), float(cw[i])))
                       for i in range(N) if not rb.static[i])          # every rate of a static body is 0
        if N == 1 and bodies:
            self.rates = bodies[0][4]        # one body: the flat layout is the body's own (x, q, P, L)
        else:
            self.rates = self._gathered(bodies)
        # the rigid-body Verlet (pbanim.rigid.splitting) on floats: per body W, principal moments and axes
        self._verlet = None
        if N == 1 and bodies:
            from .splitting import _principal

            lam, axes = _principal(rb)
            self._verlet = (float(rb.inv_mass[0]), tuple(float(v) for v in lam[0]),
                            tuple(tuple(float(v) for v in row) for row in axes[0]))

    def _gathered(self, bodies):
        """ẏ at y (13N floats) for several bodies: each body's 13 floats gathered, its rates scattered."""
        n = self.n

        def rates(y) -> list:
            out = [0.0] * n
            for ix, iq, iP, iL, f in bodies:
                r = f(y[ix:ix + 3] + y[iq:iq + 4] + y[iP:iP + 3] + y[iL:iL + 3])
                out[ix:ix + 3], out[iq:iq + 4], out[iP:iP + 3], out[iL:iL + 3] = r[:3], r[3:7], r[7:10], r[10:]
            return out
        return rates

    def unit(self, y: list) -> list:
        """q ← q/|q| for every body, in place (:func:`unit_quats`)."""
        return unit_quats(y, self.quats)

    def stepper(self, tableau):
        """``step(y, h) -> y₁`` on lists for a chain tableau (see the module docstring), or None."""
        return chain_stepper(tableau, self.rates, self.unit if self.renormalize else None)

    def kick_drift(self, y: list, h: float) -> list:
        """Symplectic Euler as :class:`pbanim.scene.Scene` runs it: P₁, L₁ = P, L + h (F, τ)(y₀), then
        x₁, q₁ = x, q + h (ẋ, q̇)(x₀, q₀, P₁, L₁); renormalized."""
        s = self.split
        d = self.rates(y)
        y1 = y[:s] + [u + h * di for u, di in zip(y[s:], d[s:])]
        d1 = self.rates(y1)
        y1[:s] = [u + h * di for u, di in zip(y[:s], d1[:s])]
        return self.unit(y1) if self.renormalize else y1

    def verlet(self, y: list, h: float) -> list:
        """Kick, free translation, the free rotation R₁(½h) R₂(½h) R₃(h) R₂(½h) R₁(½h), kick: the step of
        :func:`pbanim.rigid.splitting.rigid_verlet_step` for one body on floats (F, τ read from the rates)."""
        W, lam, A = self._verlet
        rates, hh = self.rates, 0.5 * h
        d = rates(y)
        x0, x1, x2, w, qx, qy, qz = y[:7]
        P = [u + hh * f for u, f in zip(y[7:10], d[7:10])]
        L = [u + hh * f for u, f in zip(y[10:13], d[10:13])]
        hW = h * W
        x0, x1, x2 = x0 + hW * P[0], x1 + hW * P[1], x2 + hW * P[2]
        s = 2.0 / (w * w + qx * qx + qy * qy + qz * qz)          # Rᵀ L (the formula of quat_to_matrix)
        l0, l1, l2 = L
        u0 = (1.0 - s * (qy * qy + qz * qz)) * l0 + s * (qx * qy + w * qz) * l1 + s * (qx * qz - w * qy) * l2
        u1 = s * (qx * qy - w * qz) * l0 + (1.0 - s * (qx * qx + qz * qz)) * l1 + s * (qy * qz + w * qx) * l2
        u2 = s * (qx * qz + w * qy) * l0 + s * (qy * qz - w * qx) * l1 + (1.0 - s * (qx * qx + qy * qy)) * l2
        Pi = [A[0][i] * u0 + A[1][i] * u1 + A[2][i] * u2 for i in range(3)]      # Aᵀ Rᵀ L
        for i, frac in _SEQUENCE:
            theta = frac * h * Pi[i] / lam[i]
            c, sn = cos(0.5 * theta), sin(0.5 * theta)
            b1, b2, b3 = sn * A[0][i], sn * A[1][i], sn * A[2][i]
            w, qx, qy, qz = (w * c - qx * b1 - qy * b2 - qz * b3, w * b1 + qx * c + qy * b3 - qz * b2,
                             w * b2 - qx * b3 + qy * c + qz * b1, w * b3 + qx * b2 - qy * b1 + qz * c)
            j, k = (i + 1) % 3, (i + 2) % 3
            cj, ck = cos(theta), sin(theta)
            Pi[j], Pi[k] = cj * Pi[j] + ck * Pi[k], -ck * Pi[j] + cj * Pi[k]
        y1 = [x0, x1, x2, w, qx, qy, qz, *P, *L]
        d = rates(y1)
        y1[7:] = [u + hh * f for u, f in zip(y1[7:], d[7:])]
        return self.unit(y1) if self.renormalize else y1

    def advance(self, method, counter: list, readable):
        """``advance(t, y, h)`` of the scene's driver on the lean path for ``method`` (a registered
        :class:`pbanim.ode.Method`), counting right-hand sides in ``counter[0]`` as the readable path does;
        None for a method it does not run. ``readable`` is the readable advance, taken for a step that
        divides by zero."""
        from ..ode.methods import TABLEAUX

        if method.name in FLOAT_RATE_METHODS:
            return self._float_rates_advance(method, counter, readable)
        if method.name == "symplectic_euler":
            step, nfev = self.kick_drift, 1
        elif method.name == "verlet":
            if self._verlet is None:
                return None
            step, nfev = self.verlet, 2
        elif method.name in LEAN_METHODS and method.name in TABLEAUX:
            step, nfev = self.stepper(TABLEAUX[method.name]), TABLEAUX[method.name].stages
            if step is None:
                return None
        else:
            return None
        array = np.array

        def advance(t, y, h):
            try:
                y1 = array(step(y.tolist(), h))
            except ZeroDivisionError:                 # |q| = 0: the readable step names the divergence
                return readable(t, y, h)
            counter[0] += nfev
            return y1
        # float arithmetic raises on no non-finite state (an overflow is inf, 0/0 goes to the readable step):
        # the driver may check the stored states once per block (the first bad step named as at each step)
        advance.nan_safe = True
        return advance

    def _float_rates_advance(self, method, counter: list, readable):
        """``advance`` of an implicit method (:data:`FLOAT_RATE_METHODS`): the method's own step and Newton
        solve, f(t, y) the float rates behind an array (13N floats in, an array out), then q ← q/|q|."""
        rates, unit, array, method_step, split = self.rates, self.unit, np.array, method.step, self.split

        def fun(t, y):
            counter[0] += 1
            return array(rates(y.tolist()))

        def advance(t, y, h):
            try:
                y1 = method_step(fun, t, y, h, split=split)
            except ZeroDivisionError:                 # |q| = 0: the readable step names the divergence
                return readable(t, y, h)
            return array(unit(y1.tolist())) if self.renormalize else y1
        return advance
