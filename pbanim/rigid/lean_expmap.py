"""The lean exponential-map step of a small rigid scene: Runge–Kutta–Munthe-Kaas on plain floats (chapter 05,
part of :mod:`pbanim.rigid`).

The readable step (:func:`pbanim.rigid.scene.exp_map_step`) writes q(t) = exp(½θ(t)) ⊗ q_n over one step and
steps the local state z = [x, θ, P, L] (θ(t_n) = 0) with the chosen method, where

    θ̇ = dexp⁻¹_θ(ω) = ω − ½ θ × ω + c(|θ|) θ × (θ × ω),   c(a) = (1 − (a/2) cot(a/2)) / a²  (→ 1/12 + a²/720),

then q_{n+1} = exp(½θ_{n+1}) ⊗ q_n. For one body, or a few, each evaluation of ż there is some sixty numpy
calls on rows of three or four numbers (quat_exp, quat_multiply, the rates, dexp⁻¹). This module computes the
same ż body by body on Python floats, with the body's constants bound once (the rates of
:mod:`pbanim.rigid.lean`, which give ω in place of q̇):

    exp(½θ) = (cos(a/2), sinc θ)/|·|,  a = |θ|,  sinc = sin(a/2)/a (½ − a²/48 + a⁴/3840 below a = 10⁻⁴),
    q = exp(½θ) ⊗ q_n,  (ẋ, ω, Ṗ, L̇) = rates(x, q, P, L),  θ̇ = dexp⁻¹_θ(ω)   (c by its series below a = 10⁻³).

The step itself is the method's: a chain tableau (Euler, midpoint, RK4) on lists of floats
(:func:`pbanim.rigid.lean.chain_stepper`), any other method its own ``step`` on ż behind an array wrapper; the
post-step stages of the scene (a renormalization added by hand) run after it, as on the readable path. Equal
to the readable step to roundoff (``tests/test_rigid_lean_expmap.py``, ORACLES C1, C3).

==========================  ================================  ===============================
symbol                      code                              shape
==========================  ================================  ===============================
z = [x, θ, P, L]            ``z``                             list of 12N floats
q_n                         ``q0``                            one 4-tuple per body, set per step
==========================  ================================  ===============================
"""

from __future__ import annotations

from math import cos, sin, sqrt, tan

import numpy as np

from .domain import _SAFE

__all__: list[str] = []          # used by pbanim.rigid.lean.lean_plan only


def _exp_times(t0: float, t1: float, t2: float, q0: tuple) -> tuple:
    """exp(½θ) ⊗ q₀ on floats (θ = (t0, t1, t2)): the formula of :func:`pbanim.rigid.quat_exp` (its |θ| scaled
    when |θ|² would underflow), then the Hamilton product of :func:`pbanim.rigid.quat_multiply`."""
    n2 = t0 * t0 + t1 * t1 + t2 * t2
    if n2 > _SAFE[0]:
        a = sqrt(n2)
    else:
        m = max(abs(t0), abs(t1), abs(t2))
        a = m * sqrt((t0 / m) ** 2 + (t1 / m) ** 2 + (t2 / m) ** 2) if m > 0 else 0.0
    if a < 1e-4:
        s = 0.5 - a * a / 48.0 + a ** 4 / 3840.0
    else:
        s = sin(0.5 * a) / a
    e0, e1, e2, e3 = cos(0.5 * a), s * t0, s * t1, s * t2
    n = sqrt(e0 * e0 + e1 * e1 + e2 * e2 + e3 * e3)
    e0, e1, e2, e3 = e0 / n, e1 / n, e2 / n, e3 / n
    b0, b1, b2, b3 = q0
    return (e0 * b0 - e1 * b1 - e2 * b2 - e3 * b3,
            e0 * b1 + e1 * b0 + e2 * b3 - e3 * b2,
            e0 * b2 - e1 * b3 + e2 * b0 + e3 * b1,
            e0 * b3 + e1 * b2 - e2 * b1 + e3 * b0)


def _dexpinv(t0: float, t1: float, t2: float, w0: float, w1: float, w2: float) -> tuple:
    """dexp⁻¹_θ(ω) on floats: the formula of :func:`pbanim.rigid.dexpinv`."""
    a2 = t0 * t0 + t1 * t1 + t2 * t2
    a = sqrt(a2)
    c = 1.0 / 12.0 + a2 / 720.0 if a < 1e-3 else (1.0 - 0.5 * a / tan(0.5 * a)) / a2
    u0, u1, u2 = t1 * w2 - t2 * w1, t2 * w0 - t0 * w2, t0 * w1 - t1 * w0          # θ × ω
    return (w0 - 0.5 * u0 + c * (t1 * u2 - t2 * u1), w1 - 0.5 * u1 + c * (t2 * u0 - t0 * u2),
            w2 - 0.5 * u2 + c * (t0 * u1 - t1 * u0))


class LeanExpMap:
    """The bound per-body rates of one scene and its float exponential-map steps (see the module docstring)."""

    def __init__(self, rb, Q0: np.ndarray, cv: np.ndarray, cw: np.ndarray, renormalize: bool) -> None:
        from .lean import _body_rates, unit_quats

        N = rb.N
        self.N, self.renormalize = N, renormalize
        quats = tuple(range(3 * N, 7 * N, 4))
        self._unit = lambda y: unit_quats(y, quats)                       # q ← q/|q| (a renormalization added)
        self._q0: list = [None] * N                                        # q_n of each body, set per step
        bodies = tuple((i, _body_rates(float(rb.inv_mass[i]), tuple(float(a) for a in rb.inv_I_body[i].ravel()),
                                       tuple(float(f) for f in Q0[i]), float(cv[i]), float(cw[i]), omega=True))
                       for i in range(N) if not rb.static[i])          # every rate of a static body is 0
        q0s = self._q0
        n = 12 * N

        def rates(z) -> list:
            """ż at z (12N floats) for the q_n of this step."""
            out = [0.0] * n
            for i, f in bodies:
                ix, it, iP, iL = 3 * i, 3 * (N + i), 3 * (2 * N + i), 3 * (3 * N + i)
                t0, t1, t2 = z[it], z[it + 1], z[it + 2]
                v0, v1, v2, w0, w1, w2, F0, F1, F2, T0, T1, T2 = f(
                    (z[ix], z[ix + 1], z[ix + 2], *_exp_times(t0, t1, t2, q0s[i]), z[iP], z[iP + 1], z[iP + 2],
                     z[iL], z[iL + 1], z[iL + 2]))
                out[ix], out[ix + 1], out[ix + 2] = v0, v1, v2
                out[it], out[it + 1], out[it + 2] = _dexpinv(t0, t1, t2, w0, w1, w2)
                out[iP], out[iP + 1], out[iP + 2], out[iL], out[iL + 1], out[iL + 2] = F0, F1, F2, T0, T1, T2
            return out
        self.rates = rates

    def _local(self, y: list) -> list:
        """z₀ = [x, 0, P, L] from y = [x, q, P, L]; q_n of each body kept for this step."""
        N = self.N
        for i in range(N):
            j = 3 * N + 4 * i
            self._q0[i] = (y[j], y[j + 1], y[j + 2], y[j + 3])
        return y[:3 * N] + [0.0] * (3 * N) + y[7 * N:]

    def _global(self, z: list) -> list:
        """y₁ = [x, exp(½θ) ⊗ q_n, P, L] from z₁ (then q ← q/|q| if the scene renormalizes)."""
        N = self.N
        q: list = []
        for i in range(N):
            it = 3 * (N + i)
            q.extend(_exp_times(z[it], z[it + 1], z[it + 2], self._q0[i]))
        y1 = z[:3 * N] + q + z[6 * N:]
        return self._unit(y1) if self.renormalize else y1

    def advance(self, method, counter: list, readable):
        """``advance(t, y, h)`` of the scene's driver for ``method`` (a registered :class:`pbanim.ode.Method`):
        a chain tableau on floats, any other method's own step on ż behind an array; right-hand sides counted
        in ``counter[0]`` as the readable path counts them. ``readable`` takes a step that divides by zero."""
        from ..ode.methods import TABLEAUX
        from .lean import chain_stepper

        array, rates, local, glob = np.array, self.rates, self._local, self._global
        tableau = TABLEAUX.get(method.name)
        chain = chain_stepper(tableau, rates) if tableau is not None and not method.implicit else None
        if chain is not None:
            stages = tableau.stages

            def advance(t, y, h):
                try:
                    y1 = array(glob(chain(local(y.tolist()), h)))
                except ZeroDivisionError:                 # |q| = 0: the readable step names the divergence
                    return readable(t, y, h)
                counter[0] += stages
                return y1
            return advance
        method_step, split = method.step, 6 * self.N

        def fun(t, z):
            counter[0] += 1
            return array(rates(z.tolist()))

        def advance(t, y, h):
            try:
                z1 = method_step(fun, t, array(local(y.tolist())), h, split=split)
                return array(glob(z1.tolist()))
            except ZeroDivisionError:
                return readable(t, y, h)
        return advance
