"""The lean step of a small particle scene: symplectic Euler on plain floats (chapter 01, part of :mod:`pbanim.particles`).

For one particle on a spring, or a few particles on a few springs, every numpy call of the vectorized step
(:meth:`~pbanim.particles.ParticleSystem.kick_drift`, :meth:`~pbanim.particles.DampedSprings.apply`) works on
arrays of two to a dozen numbers: about a microsecond of interpreter and dispatch for a few nanoseconds of
arithmetic. This module writes the same step on Python floats, with everything that does not change during
a run (which effects, their constants, the inverse masses) bound once when the run starts, as the locals of
one function:

    Q = Σ_effects Qₑ(x₀, v₀)     (declaration order, each added into Q as its ``apply`` adds it)
    v₁ = v₀ + h (W Q),   x₁ = x₀ + h v₁

the kick then drift of :func:`pbanim.ode.symplectic_euler_step` as :class:`pbanim.scene.Scene` runs it on
its readable path (``scene.lean_path = False``: one force evaluation, the drift with the new velocity), with
the forces written operation for operation as the effects compute them:

=========================  ==============================================================================
effect                     Qᵢ on floats (component k of particle i)
=========================  ==============================================================================
:class:`Gravity`           Qₖ + mᵢ gₖ (leading gravity terms summed into the Q a step starts from)
:class:`Drag`              Qₖ − k_d,ᵢ vₖ
:class:`AnchorSprings`     Qₖ − (k_s (xₖ − pₖ) + k_d vₖ)
:class:`DampedSprings`     d = x_a − x_b, l = √(d·d), c = [k_s (l − r) + (k_d ḋ·d) / l] / l, f = d (−c);
                           Σ_s ±f per particle (springs in order), then added to Q
=========================  ==============================================================================

So a step is the readable step's arithmetic: the same roundings in the same order, bit for bit, except the
sum of several springs' forces on one particle, which the readable path forms as one product with the
incidence matrix (another order of the same terms: equal to roundoff). ORACLES A1 (H̃ kept to roundoff)
holds for it as for the readable step.

A post-step stage that offers a response on floats — the package's own
:class:`~pbanim.collision.Collisions` (its own code, :func:`pbanim.contracts.package_code`) with its float
response bound (:meth:`pbanim.collision.lean_spheres.LeanSpheres.floats`: a few spheres, no friction, the
sequential law) —
runs on the list the drift leaves, so a whole step (kick, drift, contact detection, impulses, projection)
makes no numpy call between the state's two conversions. A response it cannot answer on floats (resting
contact, a failed certificate) hands the state to the effect's readable response; a non-finite state is
returned as it is, for the driver to name the step.

When: a scene of the package's own :class:`ParticleSystem` of at most :data:`FLOAT_MAX` coordinates whose
force effects are the package's :class:`Gravity`, :class:`Drag`, :class:`AnchorSprings` and
:class:`DampedSprings` only (exactly these classes: a user's subclass or a course assignment's copy runs the
``apply`` it wrote, :func:`pbanim.contracts.package_code`), with no constraint stage and no post-step stage but
the collision effect above, stepped by symplectic Euler. The effects' parameters are read when a run starts (``scene.step``: at its first call).
A spring of length 0, or one whose |d|² overflows, hands the step to the readable path (which has the rule
for both); float arithmetic raises on no other non-finite value, so the driver checks the stored states
once per block. ``scene.lean_path = False`` runs the readable step (``tests/test_scene.py``, ORACLES A16;
with collisions ``tests/test_collision.py``, ORACLES D17).
"""

from __future__ import annotations

from math import inf, isfinite, sqrt

import numpy as np

from ..contracts import Obj, contract, package_code

__all__ = ["FLOAT_MAX", "float_plan"]

#: Up to this many position components N·dim (16 particles in 2-D, 10 in 3-D) a symplectic Euler step runs on
#: floats: the float step grows with the particles and springs, the vectorized one barely; measured under
#: gravity and a chain of springs (or anchors), the float step costs 0.13–0.6 of the vectorized one up to 32
#: components and 1.1–1.2 of it at 48.
FLOAT_MAX = 32


class _Handoff(Exception):
    """A spring of zero or overflowing length: the readable step takes this one."""


@contract(scene=Obj("pbanim.scene:Scene"))
def float_plan(scene) -> "FloatParticles | None":
    """The float plan of a particle scene, or None when the scene does not qualify (the module docstring);
    read once, when the scene is built.

    >>> from pbanim.particles import AnchorSprings, ParticleSystem
    >>> from pbanim.scene import Scene
    >>> ps = ParticleSystem([[1.0, 0.0]], masses=0.5)
    >>> float_plan(Scene(ps, [AnchorSprings([0], [[0.0, 0.0]], 20.0)])) is not None
    True
    >>> class Stiffer(AnchorSprings):
    ...     pass
    >>> float_plan(Scene(ps, [Stiffer([0], [[0.0, 0.0]], 20.0)])) is None
    True
    """
    from .forces import AnchorSprings
    from .springs import DampedSprings
    from .system import Drag, Gravity, ParticleSystem

    ps = scene.system
    if (not isinstance(ps, ParticleSystem) or ps.split > FLOAT_MAX or ps.dim not in (2, 3) or scene._constraint
            or not package_code(ps, "derivative", "kick_drift", "unpack", "zero_forces")):
        return None
    if not all(type(e) in (Gravity, Drag, AnchorSprings, DampedSprings) for e in scene._force):
        return None
    # post-step stages: each must offer a response on floats (the package's collision effect with its float
    # response bound, ``_lean``: pbanim.collision.lean_spheres); a user's effect, or a subclass with its own
    # post_step, runs the post_step it wrote, on arrays
    if not all(callable(getattr(getattr(e, "_lean", None), "floats", None)) and package_code(e, "post_step")
               for e in scene._post):
        return None
    return FloatParticles(scene)


class FloatParticles:
    """The float symplectic Euler step of one particle scene (see the module docstring)."""

    def __init__(self, scene) -> None:
        self.scene = scene

    def stepper(self):
        """``step(y, h) -> y₁`` on lists, the effects' parameters read now."""
        from .system import Gravity

        ps = self.scene.system
        n = ps.split
        W = ps._Wflat.tolist()
        Q0 = [0.0] * n
        kernels = []
        for e in self.scene._force:
            if type(e) is Gravity and not kernels:      # 0 + m g (+ m g' …): the same sums, once
                Q0 = [q + g for q, g in zip(Q0, e._mg.ravel().tolist())]
            else:
                kernels.append(_kernel(e, ps))
        kernels = tuple(kernels)
        if not kernels:
            # constant forces only (none, or gravity): the kick h (Qₖ Wₖ) is the same number every step, formed
            # once per step size with the readable rounding
            kick = [0.0, None]

            def kicks(h: float) -> list:
                """The kick h (Qₖ Wₖ) of every velocity component, with the readable rounding."""
                return [h * (q * w) for q, w in zip(Q0, W)]

            def step(y: list, h: float) -> list:
                if kick[1] != h:
                    kick[:] = [kicks(h), h]
                v1 = [v + dv for v, dv in zip(y[n:], kick[0])]
                y1 = [x + h * u for x, u in zip(y, v1)]
                y1 += v1
                return y1
            step.kicks = kicks          # constant forces: the fused run (pbanim.particles.lean_run) kicks in place
            return step

        def step(y: list, h: float) -> list:
            Q = Q0[:]
            for add in kernels:
                Q = add(y, Q)
            v1 = [v + h * (q * w) for v, q, w in zip(y[n:], Q, W)]
            y1 = [x + h * u for x, u in zip(y, v1)]          # zip stops at n: x₀ + h v₁
            y1 += v1
            return y1
        return step

    def responses(self) -> tuple:
        """Per post-step stage, its float response ``(t, y, h, margin, plastic) -> list | None``
        (:meth:`pbanim.collision.lean_spheres.LeanSpheres.floats`), or None where the effect's ``lean_path`` is
        off now (its readable response then answers every step)."""
        return tuple(e._lean.floats if e.lean_path and e._lean is not None else None for e in self.scene._post)

    def advance(self, counter: list, readable, post=()):
        """``advance(t, y, h)`` of the scene's driver on floats, counting one evaluation of f per step in
        ``counter[0]``; ``readable`` (the readable kick–drift) takes a step this one hands off, and ``post``
        (the post-step stages' ``post_step``, in order) the state a float response hands off (from that stage
        on), or the state after a handed-off kick–drift."""
        from .lean_run import fused_run

        step, array = self.stepper(), np.array
        if not post:
            def advance(t, y, h):
                try:
                    y1 = array(step(y.tolist(), h))
                except _Handoff:
                    return readable(t, y, h)
                counter[0] += 1
                return y1
            advance.run = fused_run(step, None, readable, None, counter)
        else:
            floats, post = self.responses(), tuple(post)
            # the response a float one hands its state to: the effect's readable one (not its post_step, which
            # would try the float response again)
            readables = tuple(post_step if f is None else e._lean.readable
                              for f, e, post_step in zip(floats, self.scene._post, post))

            def handoff(t1, y1, h, i):
                """The readable response of stage i, then the post-step stages after it; a non-finite state is
                returned as it is (no stage runs on it: the driver names the step, as it names a diverged one)."""
                y = array(y1)
                if not isfinite(sum([u * u for u in y1])):
                    return y
                y = readables[i](t1, y, h, 0.0, False) if floats[i] is not None else post[i](t1, y, h)
                for post_step in post[i + 1:]:
                    y = post_step(t1, y, h)
                return y

            def handed(t, y, h):
                """A kick–drift handed to the readable step, then the post-step stages."""
                y = readable(t, y, h)
                for post_step in post:
                    y = post_step(t + h, y, h)
                return y

            if len(floats) == 1 and floats[0] is not None:
                respond = floats[0]

                def advance(t, y, h):           # one response (the usual scene): no loop over the stages
                    try:
                        y1 = step(y.tolist(), h)
                    except _Handoff:
                        return handed(t, y, h)
                    counter[0] += 1
                    out = respond(t + h, y1, h, 0.0, False)
                    return handoff(t + h, y1, h, 0) if out is None else array(out)
                advance.run = fused_run(step, respond, handed,
                                        lambda t, y, h: handoff(t, y, h, 0), counter)
            else:
                def advance(t, y, h):
                    try:
                        y1 = step(y.tolist(), h)
                    except _Handoff:
                        return handed(t, y, h)
                    counter[0] += 1
                    t1 = t + h
                    for i, respond in enumerate(floats):
                        out = None if respond is None else respond(t1, y1, h, 0.0, False)
                        if out is None:
                            return handoff(t1, y1, h, i)
                        y1 = out
                    return array(y1)
        # float arithmetic raises on no non-finite value (a zero or infinite spring length goes to the readable
        # step, a non-finite state skips the readable response): the driver may check the stored states once
        # per block
        advance.nan_safe = True
        advance.plan = "floats"
        return advance


def _kernel(e, ps):
    """Q ↦ Q + Qₑ(y) of one effect on floats (a new list, or Q written in place), its constants bound here."""
    from .forces import AnchorSprings
    from .system import Drag, Gravity

    n, dim = ps.split, ps.dim
    if type(e) is Gravity:
        mg = e._mg.ravel().tolist()
        return lambda y, Q: [q + g for q, g in zip(Q, mg)]
    if type(e) is Drag:
        kd = e._kdflat.tolist()
        return lambda y, Q: [q - k * v for q, k, v in zip(Q, kd, y[n:])]
    if type(e) is AnchorSprings:
        ks, kd = e.ks, e.kd
        pins = tuple((int(i) * dim + k, float(e.points[j, k])) for j, i in enumerate(e.idx) for k in range(dim))

        def anchors(y, Q):
            for k, p in pins:
                Q[k] -= ks * (y[k] - p) + kd * y[n + k]
            return Q
        return anchors
    return _springs(e, n, dim)


def _springs(e, n: int, dim: int):
    """Damped springs on floats: c = [k_s (l − r) + (k_d ḋ·d)/l]/l, f = d(−c), as :meth:`DampedSprings._forces`
    rounds them (|d|² and ḋ·d summed component by component, left to right)."""
    table = tuple((tuple(range(int(a) * dim, int(a) * dim + dim)), tuple(range(int(b) * dim, int(b) * dim + dim)),
                   float(ks), float(kd), float(r)) for a, b, ks, kd, r in zip(e.a, e.b, e.ks, e.kd, e.rest))
    damped, three = e._damped, dim == 3
    zero = [0.0] * n

    def springs(y, Q):
        acc = zero[:]
        for ia, ib, ks, kd, r in table:
            d = [y[i] - y[j] for i, j in zip(ia, ib)]
            dd = d[0] * d[0] + d[1] * d[1]
            if three:
                dd += d[2] * d[2]
            if not 0.0 < dd < inf:
                raise _Handoff
            length = sqrt(dd)
            inv = 1.0 / length
            c = ks * (length - r)
            if damped:
                w = [y[n + i] - y[n + j] for i, j in zip(ia, ib)]
                vd = w[0] * d[0] + w[1] * d[1]
                if three:
                    vd += w[2] * d[2]
                c += kd * vd * inv
            c = -(c * inv)
            for i, j, u in zip(ia, ib, d):
                f = u * c
                acc[i] += f
                acc[j] -= f
        return [q + u for q, u in zip(Q, acc)]
    return springs
