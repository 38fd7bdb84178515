"""How a scene steps: a plan chosen and bound once per run (issue 28; chapters 01–03).

A step of the pipeline is the same arithmetic however it is called; what differs is the interpreter's
work around it. :meth:`pbanim.scene.Scene._advance` picks, once per run (once per method for
:meth:`~pbanim.scene.Scene.step`), the leanest plan the scene admits, with the effects, buffers, the
method's step and the system's functions bound there. Each plan computes the readable step (the method of
:mod:`pbanim.ode` on :meth:`~pbanim.scene.Scene.rhs`) to roundoff (``tests/test_scene.py``, ORACLES A13);
``scene.lean_path = False`` runs the readable step instead.

==============  ===========================================================  ===============================
plan            when                                                         one step
==============  ===========================================================  ===============================
linear map      every force effect linear (``linear = True``), no constraint  y₁ = S y + s (S, s once per h)
                or post-step stage, an explicit Runge–Kutta method (not
                symplectic Euler or Verlet), n ≤ LINEAR_MAX, the package's
                own effects and system
floats          symplectic Euler, a small particle scene of the package's     the readable kick and drift on
                own gravity, drag, anchor and damped springs, and at most     Python floats, bit for bit (and
                the package's collision effect after the step                 the sphere response on them)
                (:mod:`pbanim.particles.lean`)
kick–drift      symplectic Euler, a system with ``kick_drift`` (particles),   one force evaluation into
                no constraint effect                                          buffers; affine forces folded
frozen Newton   implicit Euler or midpoint on a linear scene (as for the linear  Newton with I − θhJ factored
                map, any n ≤ LINEAR_MAX): J constant                          once per h, bit for bit
bound f         any other                                                    the method's step on f, bound
==============  ===========================================================  ===============================

The linear map
--------------
An effect that declares ``linear = True`` promises Q(t, x, v) = c + K_x x + K_v v with constant c, K_x, K_v
(gravity, drag, anchor springs) and a ``jacobian`` giving K_x, K_v. When every force effect is linear the
scene is ẏ = A y + b with A = ∂f/∂y (:meth:`~pbanim.scene.Scene.jac`) and b = f(0), and the step of an
explicit Runge–Kutta method is affine in y:

    y₁ = Φ_h(y) = S y + s,     S = R(hA) (RK4: I + hA + (hA)²/2 + (hA)³/6 + (hA)⁴/24),     s = Φ_h(0).

S is the method's stability function at hA — the matrix whose eigenvalues are the amplification factors of
ORACLES A1–A2 — obtained by stepping ẏ = A y from the n columns of the identity (one batched step of the
method itself), and s by one step of the scene's own f from y = 0. A step then costs one n × n product and
one sum, whatever the method: RK4 costs what Euler costs. Small states only (n ≤ :data:`LINEAR_MAX`: the
product is O(n²)); the per-particle kick–drift below keeps large linear scenes O(n).

Two limits. Symplectic Euler and Verlet are affine too, but keep their own kick and drift: what they are taught
for (ORACLES A1: H̃ = E − ½ h k x·v kept to roundoff at every step) holds for their own arithmetic, and a
fixed S carries its roundoff into every step. And the map is built from the effects' Jacobians, not from
their ``apply``: only the package's own effects and system are trusted to agree
(:func:`pbanim.contracts.package_code`); a user's subclass, or a course assignment's copy of a module, runs the
``apply`` it wrote (the same holds for the affine fold and for gravity summed once below).

The floats
----------
A system may offer ``_float_plan(scene)`` (:func:`float_plan` reads it once, when the scene is built): the
particle system's (:mod:`pbanim.particles.lean`) runs symplectic Euler on a small scene as the readable step
computes it — the same roundings in the same order, on Python floats bound once per run — where every numpy
call would cost a microsecond for a few nanoseconds of arithmetic. A scene whose class overrides ``rhs``,
``forces`` or ``applied_forces`` keeps its own (as for the kick–drift).

The kick–drift
--------------
A system with ``kick_drift(y, Q, h, out, lo, hi)`` (particles) runs symplectic Euler with one force
evaluation into preallocated buffers. If every force effect is *affine and per particle* — ``affine() ->
(c, d)`` meaning Qᵢ = cᵢ + dᵢ vᵢ with constant c (broadcastable to (N, dim)) and d (scalar or (N,)), like
gravity and drag — the forces are folded once per step size into v₁ = α v₀ + β (α = 1 + h W d, β = h W c)
and the particles are swept in cache-sized blocks, so a step costs about one read and one write of the
state (``scene.fold_affine = False``: the force phase effect by effect).

The bound f
-----------
:func:`bound_rhs` is :meth:`~pbanim.scene.Scene.rhs` as one closure over the effects' ``apply`` and
``constrain`` and the system's ``derivative`` (taken unchecked once), so an evaluation pays no chain of
method calls; the constant forces (``affine() -> (c, None)``: gravity) are summed once into the Q that every
evaluation starts from (Q = c + Σ the others: the readable sum in another order, equal to roundoff). A
subclass that overrides ``rhs``, ``forces`` or ``applied_forces`` keeps its own.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp

from ..contracts import package_code, unchecked
from ..ode.implicit_run import THETA, NewtonSteps

__all__ = ["LINEAR_MAX", "LinearMap", "KickDrift", "advance", "bound_rhs", "float_plan", "linear_scene"]

#: At most this many state components take the linear-map plan (an n × n product per step).
LINEAR_MAX = 64


def linear_scene(scene) -> bool:
    """Whether a scene's forces are all declared linear, with nothing but forces (see the module docstring)."""
    return (not scene._constraint and not scene._post and scene.n_state <= LINEAR_MAX and scene.has_jacobian
            and all(getattr(e, "linear", False) and package_code(e, "apply", "jacobian", "affine") for e in scene._force)
            and package_code(scene.system, "derivative"))


def float_plan(scene):
    """The system's float plan for symplectic Euler (``system._float_plan(scene)``: a small particle scene,
    :mod:`pbanim.particles.lean`), or None; read once, when the scene is built."""
    make = getattr(scene.system, "_float_plan", None)
    return make(scene) if callable(make) and package_code(scene.system, "_float_plan") else None


def _nan_safe(scene) -> bool:
    """Whether a step of the scene cannot raise on a non-finite state (forces only, each affine or declaring
    ``nan_safe``): the run then checks its stored states once per block and names the first bad step."""
    return not scene._constraint and not scene._post and all(
        getattr(e, "nan_safe", False) or callable(getattr(e, "affine", None)) for e in scene._force)


def _overrides(scene, base, names) -> bool:
    """Whether the scene's class replaces one of ``base``'s methods ``names`` (its own f, Q or Jacobian)."""
    cls = type(scene)
    return any(getattr(cls, name) is not getattr(base, name) for name in names)


def bound_rhs(scene, base):
    """f(t, y) of the scene as one closure (``base``: the class whose ``rhs`` it replaces; a subclass that
    overrides ``rhs``, ``forces`` or ``applied_forces`` gets its own ``rhs``, unchecked)."""
    if _overrides(scene, base, ("rhs", "forces", "applied_forces")):
        return unchecked(scene.rhs)
    derivative, constrains = scene._derivative, tuple(scene._constrain)
    # constant forces (``affine() -> (c, None)``: gravity) summed once into Q₀, the start of every evaluation
    Q0 = scene.system.zero_forces()
    applies = []
    for e, apply in zip(scene._force, scene._apply):
        own = callable(getattr(e, "affine", None)) and package_code(e, "apply", "affine")
        c, d = e.affine() if own else (None, 0)
        if d is None and c is not None and np.broadcast(Q0, c).shape == Q0.shape:
            Q0 += c
        else:
            applies.append(apply)
    applies = tuple(applies)
    if not constrains:
        def rhs(t, y):
            Q = Q0.copy()
            for apply in applies:
                apply(t, y, Q)
            return derivative(y, Q)
        return rhs

    def rhs(t, y):
        Q = Q0.copy()
        for apply in applies:
            apply(t, y, Q)
        for constrain in constrains:
            Q = constrain(t, y, Q)
        return derivative(y, Q)
    return rhs



def advance(scene, m, counter: list, base):
    """advance(t, y, h) -> y₁ of ``scene`` for method ``m``: the plan chosen and bound once (the table above),
    then the post-step stages; f counted in ``counter[0]``, the Jacobian in ``counter[1]``. ``scene.lean_path =
    False``: the readable step (the method's step on the scene's unchecked ``rhs``)."""
    lean = scene.lean_path
    # the structure-preserving methods (symplectic Euler, Verlet) run their own kick and drift: their invariants
    # (ORACLES A1: H̃ kept to roundoff) hold step by step only for the method's own arithmetic, not for S y + s
    if (lean and scene._linear and not m.implicit and not m.nystrom and m.name not in ("symplectic_euler", "verlet")
            and not _overrides(scene, base, ("rhs", "forces", "applied_forces", "jac"))):
        return LinearMap(scene, m, bound_rhs(scene, base), counter).advance()
    post, split = scene._post_step, scene.system.split
    rhs = bound_rhs(scene, base) if lean else scene._rhs
    per = None if m.implicit else getattr(m.step, "nfev", None)   # evaluations per step, when fixed

    def fun(t, yy):
        counter[0] += 1
        return rhs(t, yy)

    jac_fn, jac = None, unchecked(scene.jac)
    if m.implicit and scene.has_jacobian:
        def jac_fn(t, yy):
            counter[1] += 1
            return jac(t, yy)
    if (m.name == "symplectic_euler" and lean and scene._floats is not None
            and not _overrides(scene, base, ("rhs", "forces", "applied_forces"))):
        # a small particle scene: the readable kick and drift on floats (pbanim.particles.lean); a spring of zero
        # or overflowing length hands its step to the readable one
        return scene._floats.advance(counter, _kick_then_drift(scene, scene._rhs, counter), post)
    if m.name == "symplectic_euler" and scene._lean and lean and not _overrides(scene, base, ("rhs", "forces",
                                                                                             "applied_forces")):
        kick = scene._kick.step

        def step(t, y, h):
            counter[0] += 1
            return kick(t, y, h)
        step.nan_safe = _nan_safe(scene)
    elif m.name == "symplectic_euler" and scene._drift_free:
        step = _kick_then_drift(scene, rhs, counter)
    elif (m.name in THETA and lean and scene._linear and scene.has_jacobian
          and not _overrides(scene, base, ("rhs", "forces", "applied_forces", "jac"))):
        # a linear scene: J constant, I − θhJ factored once per h (the readable step bit for bit)
        counter[1] += 1
        newton = NewtonSteps(fun, m.name, jac(0.0, np.zeros(scene.n_state)))
        step = newton.step
    elif per is not None:
        method_step = m.step

        def step(t, y, h):
            counter[0] += per
            return method_step(rhs, t, y, h, split)
        step.nan_safe = _nan_safe(scene)
    else:
        def step(t, y, h):
            return m.step(fun, t, y, h, split=split, jac=jac_fn)
    if not post:
        return step

    def stepped(t, y, h):
        y = step(t, y, h)
        for post_step in post:
            y = post_step(t + h, y, h)
        return y
    return stepped

def _kick_then_drift(scene, rhs, counter: list):
    """Symplectic Euler with one evaluation of f: kick with f(t, y), drift with the force-free rates q̇(q₀, v₁)
    (module docstring of :mod:`pbanim.scene`); counts it in ``counter[0]``."""
    derivative, zero, split = scene._derivative, scene.system.zero_forces, scene.system.split

    def step(t, y, h):
        counter[0] += 1
        y1 = np.array(y, dtype=float, copy=True)
        y1[split:] += h * rhs(t, y)[split:]
        y1[:split] = y[:split] + h * derivative(y1, zero())[:split]
        return y1
    return step


class LinearMap:
    """y₁ = S y + s: the step of method ``m`` on a linear scene (see the module docstring), S and s built once
    per step size; ``counter[0]`` counts the evaluations of f that building them takes (none per step)."""

    def __init__(self, scene, m, rhs, counter: list) -> None:
        n = scene.n_state
        A = unchecked(scene.jac)(0.0, np.zeros(n))
        self._AT = np.ascontiguousarray((A.toarray() if sp.issparse(A) else np.asarray(A)).T)
        self.m, self.rhs, self.counter, self.split, self.n = m, rhs, counter, scene.system.split, n
        self.per = getattr(m.step, "nfev", None) or 1
        self.maps: dict = {}

    def map(self, h: float) -> tuple[np.ndarray, np.ndarray]:
        """(S, s) for step h: S = Φ_h of ẏ = A y on the identity's columns (one batched step), s = Φ_h(0)."""
        got = self.maps.get(h)
        if got is None:
            AT, step = self._AT, self.m.step
            S = np.ascontiguousarray(step(lambda t, Y: Y @ AT, 0.0, np.eye(self.n), h, split=self.split).T)
            s = step(self.rhs, 0.0, np.zeros(self.n), h, split=self.split)
            self.counter[0] += self.per
            if len(self.maps) > 4:          # a run uses h and its shortened last step
                self.maps.clear()
            self.maps[h] = got = (S, s)
        return got

    def advance(self):
        """The step function advance(t, y, h) -> y₁ (a new array; ``y`` is not written)."""
        get = self.map
        h0, S, s = None, None, None

        def advance(t, y, h):
            nonlocal h0, S, s
            if h != h0:
                S, s = get(h)
                h0 = h
            out = S @ y
            out += s
            return out
        advance.nan_safe = True       # a product and a sum: a NaN passes through, nothing raises
        return advance


class KickDrift:
    """Symplectic Euler with one force evaluation into preallocated buffers (see the module docstring)."""

    def __init__(self, scene) -> None:
        self.scene, self.system = scene, scene.system
        self._kick_drift = unchecked(scene.system.kick_drift)    # the step's own call pays no wrapper
        self._Q: np.ndarray | None = None
        self._fold: tuple | None = None

    def step(self, t: float, y: np.ndarray, h: float) -> np.ndarray:
        scene = self.scene
        out = np.empty_like(y)
        if scene._affine and scene.fold_affine:
            fold = self._fold
            if fold is None or fold[0] != h:
                fold = self._fold = self.fold(h)
            for sx, sv, alpha, beta, tmp in fold[1]:
                v1 = out[sv]
                np.multiply(y[sv], alpha, out=v1)
                np.add(v1, beta, out=v1)
                np.multiply(v1, h, out=tmp)
                np.add(y[sx], tmp, out=out[sx])
            return out
        Q = self._Q
        if Q is None:
            Q = self._Q = self.system.zero_forces()
        Q.fill(0.0)
        for apply in scene._apply:
            apply(t, y, Q)
        return self._kick_drift(y, Q, h, out, 0, len(Q))

    def fold(self, h: float) -> tuple:
        """Fold affine per-particle forces Q = c + d v into v₁ = α v₀ + β (α = 1 + h W d, β = h W c).

        Returns (h, blocks) with, per block of particles, the slices of x and v in y and the α, β and
        scratch operands, all flat and contiguous (a broadcast (n, 1) or (1, dim) operand makes numpy
        loop over rows of length dim, several times slower). Folded once per step size: rebuild the
        scene after changing an effect's parameters.
        """
        scene, sysm = self.scene, self.system
        N, dim, s = sysm.N, sysm.dim, sysm.split
        c = np.zeros((1, dim))
        d = np.zeros(1)
        for e in scene._force:
            ce, de = e.affine()
            if ce is not None:
                c = c + np.asarray(ce, float)
            if de is not None:
                d = d + np.asarray(de, float)
        W = sysm.W
        alpha = 1.0 + h * W * d                                   # (N,) (or (1,) with no drag)
        beta = h * (W[:, None] * c)                               # (N, dim) (or (1, dim))
        B = min(N, scene._BLOCK)
        # a uniform α is a scalar; a uniform β (gravity alone: W m g = g up to an ulp) is tiled over one block
        alpha = float(alpha[0]) if np.all(alpha == alpha[0]) else np.repeat(alpha, dim)
        uniform = bool(np.allclose(beta, beta[0], rtol=1e-15, atol=0.0))
        beta = np.tile(beta[0], B) if uniform else np.ascontiguousarray(np.broadcast_to(beta, (N, dim))).ravel()
        tmp = np.empty(B * dim)
        blocks = []
        for lo in range(0, N, B):
            i, j = lo * dim, min(N, lo + B) * dim
            blocks.append((slice(i, j), slice(s + i, s + j), alpha if isinstance(alpha, float) else alpha[i:j],
                           beta[: j - i] if uniform else beta[i:j], tmp[: j - i]))
        return h, blocks
