"""pbanim's side of every scene: each scene translated to the pbanim parts that the lectures built.

pbanim has no single "world" object: each lecture's system answers its own scene, and this module says
which one runs which scene, with what (every number comes from the :class:`~pbanim.compare.spec.SceneSpec`):

=============  =========================================================================  =============
scene          pbanim translation                                                         step map
=============  =========================================================================  =============
free_fall,     ``RigidBodies`` + ``RigidGravity`` in a ``RigidScene``                        RK4 (exact on
projectile                                                                                a parabola)
bounce         :func:`pbanim.models.collision.bouncing_ball` (a point on the plane; the   RK4, impacts
               sphere's centre is r higher), :func:`pbanim.collision.simulate_collisions`  located (event)
incline_*      :func:`pbanim.models.contact.box_on_plane` with gravity tilted by θ,          velocity-level
               ``TimeStepping`` (Stewart–Trinkle LCP, Lemke, 4-facet pyramid along x)       Euler
rolling        one sphere, one contact below its centre, the same ``TimeStepping``          velocity-level
chain          :func:`pbanim.models.articulated.rod_chain` (maximal coordinates, hinge      RK4, no
               ``RigidJoints``)                                                           stabilization
cradle         spheres as particles of radius r, ``Collisions`` (ε = 1, sequential),       RK4, impacts
               ``simulate_collisions``                                                    located (event)
stack          :func:`pbanim.models.contact.box_stack` (vertex–face manifolds),            velocity-level
               ``TimeStepping`` with μ                                                    Euler
top            ``RigidBodies`` + a ``ball`` ``RigidJoint`` at the tip (multipliers)        RK4
=============  =========================================================================  =============

``method`` picks another integrator of :data:`pbanim.ode.METHODS` for the smooth scenes (free flight,
chain, top): ``symplectic_euler`` is the step map of PyBullet and MuJoCo (ORACLES K1). Restitution
and friction need no combining rule here: a scene gives each contact pair one ε and one μ.

Limiting cases: with ``method="rk4"`` free flight is exact to roundoff; a scene with contact is first
order in h (velocity-level stepping), one with impacts exact up to the event location (1e-12).

References: Baraff 1997 (rigid bodies); Stewart & Trinkle 1996 (velocity-level contact); Mirtich,
*Impulse-based dynamic simulation of rigid body systems*, 1996 (impacts).
"""

from __future__ import annotations

import time
from typing import Callable

import numpy as np

from .spec import SceneSpec, Trace, Unsupported

__all__ = ["run_native", "NATIVE"]

MARGIN = 1e-6          # contact look-ahead of the velocity-level scenes (m)


def _rigid(spec: SceneSpec):
    from ..rigid import RigidBodies

    b = spec.bodies
    return RigidBodies([x.mass for x in b], [x.inertia for x in b], positions=[x.x for x in b],
                       orientations=[x.quat for x in b], velocities=[x.v for x in b],
                       angular_velocities=[x.w for x in b])


def _rigid_trace(rb, res, wall: float, steps: int, settings: str, extra=None) -> Trace:
    """The recorded states as a trace: x, q, and (v, ω) = (P/m, R (I⁻¹_body (Rᵀ L))) as
    :meth:`pbanim.rigid.RigidBodies.velocities` computes them, for all samples at once (the same products)."""
    from ..rigid import quat_to_matrix

    Y = np.asarray(res.y).T
    K, N = Y.shape[0], rb.N
    x, q = Y[:, :3 * N].reshape(K, N, 3), Y[:, 3 * N:7 * N].reshape(K, N, 4)
    P, L = Y[:, 7 * N:10 * N].reshape(K, N, 3), Y[:, 10 * N:].reshape(K, N, 3)
    R = quat_to_matrix(q)
    RtL = np.matmul(L[..., None, :], R)[..., 0, :]
    w = np.matmul(R, np.matmul(rb.inv_I_body, RtL[..., None]))[..., 0]
    extra = {} if extra is None else extra          # (not ``extra or {}``: a lazy extra's truth would compute it)
    return Trace(res.t, x.copy(), q.copy(), rb.inv_mass[:, None] * P, w, wall, steps, extra, settings)


def _timed(fn):
    start = time.perf_counter()
    out = fn()
    return out, time.perf_counter() - start


def _smooth(spec: SceneSpec, h: float, T: float, method: str) -> Trace:
    from ..rigid import RigidGravity, RigidScene

    effects = [RigidGravity(spec.gravity)]
    if spec.name == "chain":
        from ..models.articulated import rod_chain

        p = spec.params
        scene, rb, _ = rod_chain(p["n"], p["length"], spec.bodies[0].mass, p["theta0"], -spec.gravity[1])
    else:
        rb = _rigid(spec)
        if spec.joints:
            from ..articulated.joints import RigidJoints

            effects.append(RigidJoints([dict(kind=j.kind, a=j.a, b=j.b, anchor_a=j.anchor_a, anchor_b=j.anchor_b,
                                             axis_a=j.axis) for j in spec.joints]))
        scene = RigidScene(rb, effects)
    res, wall = _timed(lambda: scene.simulate(T, h, method))
    kinds = sorted({j.kind for j in spec.joints})
    what = f"rigid bodies, {' and '.join(kinds)} joints (multipliers, no stabilization)" if kinds else "rigid bodies"
    return _rigid_trace(rb, res, wall, int(np.ceil(T / h - 1e-9)), f"{what}, {method}")


def _bounce(spec: SceneSpec, h: float, T: float, method: str) -> Trace:
    from ..collision import simulate_collisions
    from ..models.collision import bouncing_ball

    p, r = spec.params, spec.bodies[0].size[0]
    bb = bouncing_ball(p["h0"], p["restitution"], -spec.gravity[2])
    res, wall = _timed(lambda: simulate_collisions(bb.scene(), T, h, method="rk4", toi="event",
                                                   max_events_per_step=1000))
    k = res.t.size
    x = np.zeros((k, 1, 3))
    v = np.zeros((k, 1, 3))
    x[:, 0, 2], v[:, 0, 2] = res.y[1] + r, res.y[3]
    q = np.tile([1.0, 0, 0, 0], (k, 1, 1))
    return Trace(res.t, x, q, v, np.zeros((k, 1, 3)), wall, int(np.ceil(T / h - 1e-9)), {},
                 "point mass on a plane, RK4, impacts located by events, ε exact")


def _cradle(spec: SceneSpec, h: float, T: float, method: str) -> Trace:
    from ..collision import Collisions, simulate_collisions
    from ..particles import ParticleSystem
    from ..scene import Scene

    b = spec.bodies
    if len({x.size[0] for x in b}) != 1 or len({x.mass for x in b}) != 1:
        raise Unsupported("pbanim", "the cradle translation takes equal balls (one radius, one mass)")
    ps = ParticleSystem([x.x for x in b], [x.v for x in b], masses=b[0].mass)
    col = Collisions(radius=b[0].size[0], restitution=min(x.restitution for x in b), gravity=0.0)
    res, wall = _timed(lambda: simulate_collisions(Scene(ps, [col]), T, h, method="rk4", toi="event"))
    n, k = len(b), res.t.size
    x = res.y[: 3 * n].T.reshape(k, n, 3)
    v = res.y[3 * n:].T.reshape(k, n, 3)
    return Trace(res.t, x, np.tile([1.0, 0, 0, 0], (k, n, 1)), v, np.zeros((k, n, 3)), wall,
                 int(np.ceil(T / h - 1e-9)), {}, "spheres as particles, RK4, impacts located, sequential impulses")


def _contact(spec: SceneSpec, h: float, T: float, method: str) -> Trace:
    from ..contact import TimeStepping, make_contacts
    from ..rigid import RigidGravity

    mu = spec.bodies[0].friction
    if spec.name == "stack":
        from ..models.contact import box_stack

        sc = box_stack(len(spec.bodies), 1.0, half_extents=spec.bodies[0].size, g=-spec.gravity[2], margin=MARGIN)
        rb, detect = sc.system, sc.detect
    elif spec.name.startswith("incline"):
        from ..models.contact import box_on_plane

        sc = box_on_plane(spec.bodies[0].mass, spec.bodies[0].size, margin=MARGIN)
        rb, detect = sc.system, sc.detect
    else:                                                        # one sphere on the ground z = 0
        rb, r = _rigid(spec), spec.bodies[0].size[0]
        up = np.array([[0.0, 0.0, 1.0]])

        def detect(y):
            x = rb.unpack(y)[0][0]
            if x[2] - r > MARGIN:
                return None
            return make_contacts([0], [-1], [x - [0.0, 0.0, r]], up, [r - x[2]])

    from ..results import LazyDiagnostics

    ts = TimeStepping(rb, detect, [RigidGravity(spec.gravity)], friction=mu, facets=4)
    res, wall = _timed(lambda: ts.simulate(T, h))
    # the penetration series (a detection per recorded state) is computed when a score reads it (the stack's)
    return _rigid_trace(rb, res, wall, int(np.ceil(T / h - 1e-9)),
                        f"velocity-level LCP (Lemke), μ = {mu:g}, 4-facet pyramid, look-ahead {MARGIN:g} m",
                        LazyDiagnostics(lambda: {"penetration": res.diagnostics["max_penetration"]}))


SMOOTH = ("free_fall", "projectile", "chain", "top")
NATIVE: dict[str, Callable] = {"free_fall": _smooth, "projectile": _smooth, "chain": _smooth, "top": _smooth,
                               "bounce": _bounce, "cradle": _cradle, "incline_stick": _contact,
                               "incline_slide": _contact, "rolling": _contact, "stack": _contact}


def run_native(spec: SceneSpec, h: float, t_end: float, option: str | None = None) -> Trace:
    """Run ``spec`` in pbanim with step ``h`` until ``t_end``; ``option`` is the integrator of the smooth
    scenes (default ``rk4``). See the module docstring for the translation."""
    from ..ode import METHODS

    method = option or "rk4"
    if method != "rk4" and spec.name not in SMOOTH:
        raise Unsupported("pbanim", f"scene {spec.name!r} has its own step map (contact or impacts); the "
                                    f"integrator option {method!r} applies to {sorted(SMOOTH)}")

    if spec.name not in NATIVE:
        raise Unsupported("pbanim", f"no pbanim translation for scene {spec.name!r} (known: {sorted(NATIVE)})")
    if method not in METHODS:
        raise Unsupported("pbanim", f"integrator must be one of {list(METHODS)}, got {method!r}")
    return NATIVE[spec.name](spec, float(h), float(t_end), method)
