"""A scene in PyBullet (Bullet 3 through its Python package): every parameter and the knob it becomes.

PyBullet is the optional extra ``[peers]``; it is imported inside :func:`run_bullet` only. The mapping
below is the part students get wrong, so it is written next to the code that does it:

====================  ============================================================================
scene parameter       PyBullet knob (DIRECT mode, one client per run)
====================  ============================================================================
step h                ``setTimeStep(h)``; ``numSubSteps`` 0 (one solver pass per step); the default
                      step is 1/240 s, so forgetting this runs a different scene
gravity g             ``setGravity(*g)`` (the default is 0: bodies float)
sphere r / box a      ``createCollisionShape(GEOM_SPHERE, radius=r)`` / ``GEOM_BOX, halfExtents=a``;
                      ``shape="none"``: no collision shape (index −1)
mass, inertia         ``createMultiBody(mass, …)``, then ``changeDynamics(localInertiaDiagonal=I)``
                      (Bullet would take the inertia of the shape's box or sphere; a rod with no
                      shape would get none); centre of mass at the base frame
x, q                  ``basePosition=x``, ``baseOrientation`` is (x, y, z, w) — pbanim stores
                      (w, x, y, z), MuJoCo (w, x, y, z): the reorder is the classic bug
v, ω                  ``resetBaseVelocity(v, ω)``, both world frame
(no air drag)         ``linearDamping=0, angularDamping=0`` — Bullet's default is 0.04 on both, a
                      drag that bends every free-flight answer
(no speed limit)      ``maxJointVelocity=1e4`` — a multibody clamps every velocity to 100 (rad/s or
                      m/s) by default: the top spinning at 150 rad/s would be braked to 100 and fall
restitution ε         Bullet combines ε_pair = ε_a · ε_b: the ground gets ε = 1 and the body ε, so
                      the pair is ε; impacts slower than Bullet's restitution velocity threshold
                      (0.2 m/s) are treated as plastic; ``contactProcessingThreshold=0`` on the body
                      and the ground when ε > 0: Bullet's speculative contacts otherwise catch the
                      ball before it touches, and whether it bounces at all depends on where the step
                      falls (no bounce at h = 0.5 ms, ε_eff 0.54 at 2 ms, 0.86 at 4 ms)
friction μ            Bullet combines μ_pair = μ_a · μ_b (clamped to 10): the ground gets μ = 1;
                      ``rollingFriction=spinningFriction=0``; friction is two 1-D constraints in the
                      contact plane (a square "pyramid"), exact for sliding along one of them
hinge chain           one ``createMultiBody`` with a fixed base (mass 0) and revolute links: each link
                      frame sits on its joint, the inertial frame at −anchor; the default velocity
                      motor of every joint is switched off (``VELOCITY_CONTROL, force=0``), or the
                      chain would hang stiff; ``jointDamping=0``
ball joint to world   ``createConstraint(JOINT_POINT2POINT)`` between the body's anchor and the world
                      point: a solver constraint (ERP-stabilized), not a reduced coordinate
====================  ============================================================================

Read back at every step (not timed): base or link centre-of-mass position, orientation (reordered to
(w, x, y, z)), linear and angular velocity (world), and the deepest contact (``getContactPoints``
distance, negative = penetration). Only ``stepSimulation`` is inside the wall time.

Limiting cases: with no contact and no joint, one step is semi-implicit Euler: v ← v + h g, x ← x + h v,
so free fall is off by exactly g h t / 2 (ORACLES K1).

References: E. Coumans, Y. Bai, *PyBullet quickstart guide* (2016–2021); E. Catto, "Iterative dynamics
with temporal coherence", GDC 2005 (the sequential-impulse solver Bullet uses).
"""

from __future__ import annotations

import time

import numpy as np

from .spec import SceneSpec, Trace, Unsupported

__all__ = ["run_bullet", "xyzw", "wxyz"]

MAX_FRICTION = 10.0           # Bullet clamps the combined friction coefficient to this
MAX_SPEED = 1e4               # rad/s or m/s: raises btMultiBody's clamp of every velocity (default 100)


def xyzw(q) -> list:
    """(w, x, y, z) → PyBullet's (x, y, z, w)."""
    return [float(q[1]), float(q[2]), float(q[3]), float(q[0])]


def wxyz(q) -> list:
    """PyBullet's (x, y, z, w) → (w, x, y, z)."""
    return [float(q[3]), float(q[0]), float(q[1]), float(q[2])]


def _shape(pb, body, kw) -> int:
    if body.shape == "sphere":
        return pb.createCollisionShape(pb.GEOM_SPHERE, radius=body.size[0], **kw)
    if body.shape == "box":
        return pb.createCollisionShape(pb.GEOM_BOX, halfExtents=list(body.size), **kw)
    return -1


def _material(pb, uid: int, link: int, body, kw) -> None:
    """Inertia, ε, μ, no damping, no speed clamp — one ``changeDynamics`` call per group: a call that mixes
    a multibody-wide knob (damping, speed clamp) with a link's inertia silently drops the inertia. Read
    back and compared, so a knob PyBullet ignores is a failed row, not a wrong answer."""
    pb.changeDynamics(uid, link, localInertiaDiagonal=list(body.inertia), **kw)
    pb.changeDynamics(uid, link, restitution=body.restitution, lateralFriction=body.friction, rollingFriction=0.0,
                      spinningFriction=0.0, **kw)
    pb.changeDynamics(uid, -1, linearDamping=0.0, angularDamping=0.0, **kw)
    pb.changeDynamics(uid, link, jointDamping=0.0, **kw)
    pb.changeDynamics(uid, link, maxJointVelocity=MAX_SPEED, **kw)
    if body.restitution > 0:
        pb.changeDynamics(uid, link, contactProcessingThreshold=0.0, **kw)
    info = pb.getDynamicsInfo(uid, link, **kw)
    got = np.array([info[0], info[1], *info[2], info[5]])
    want = np.array([body.mass, body.friction, *body.inertia, body.restitution])
    if not np.allclose(got, want, rtol=1e-12, atol=0.0):
        raise RuntimeError(f"PyBullet kept (m, μ, I, ε) = {got.tolist()} for body {body.name!r}, asked {want.tolist()}")


def _check(spec: SceneSpec) -> None:
    for b in spec.bodies:
        if b.friction > MAX_FRICTION:
            raise Unsupported("pybullet", f"body {b.name!r} has μ = {b.friction:g}; Bullet clamps the combined "
                                          f"friction coefficient to {MAX_FRICTION:g}")
    hinges = [j for j in spec.joints if j.kind == "hinge"]
    if hinges and (len(hinges) != len(spec.bodies) or any(j.b != k - 1 or j.a != k for k, j in enumerate(hinges))):
        raise Unsupported("pybullet", "hinges are translated as one chain hung from the world (joint k between "
                                      "body k and body k − 1)")


def _chain(pb, spec: SceneSpec, kw) -> int:
    """The hinge chain as one multibody with a fixed base at the origin; returns its id."""
    from ..rigid.quat import quat_conjugate, quat_multiply, quat_to_matrix

    pos, orn = [], []
    prev_p, prev_q = np.zeros(3), np.array([1.0, 0, 0, 0])
    for k, (b, j) in enumerate(zip(spec.bodies, spec.joints)):
        q = np.asarray(b.quat)
        p = np.asarray(b.x) + quat_to_matrix(q) @ np.asarray(j.anchor_a)          # joint k in the world
        pos.append((quat_to_matrix(prev_q).T @ (p - prev_p)).tolist())
        orn.append(xyzw(quat_multiply(quat_conjugate(prev_q), q)))
        prev_p, prev_q = p, q
    n = len(spec.bodies)
    uid = pb.createMultiBody(0.0, -1, basePosition=list(spec.joints[0].anchor_b), linkMasses=[b.mass for b in spec.bodies],
                             linkCollisionShapeIndices=[-1] * n, linkVisualShapeIndices=[-1] * n, linkPositions=pos,
                             linkOrientations=orn, linkInertialFramePositions=[(-np.asarray(j.anchor_a)).tolist()
                                                                               for j in spec.joints],
                             linkInertialFrameOrientations=[[0, 0, 0, 1]] * n, linkParentIndices=list(range(n)),
                             linkJointTypes=[pb.JOINT_REVOLUTE] * n, linkJointAxis=[list(j.axis) for j in spec.joints],
                             **kw)
    for k, b in enumerate(spec.bodies):
        _material(pb, uid, k, b, kw)
    pb.setJointMotorControlArray(uid, list(range(n)), pb.VELOCITY_CONTROL, forces=[0.0] * n, **kw)
    return uid


def run_bullet(spec: SceneSpec, h: float, t_end: float, option: str | None = None) -> Trace:
    """Run ``spec`` in PyBullet with step ``h`` until ``t_end`` (see the module docstring for the mapping);
    PyBullet has one integrator, so ``option`` must be None."""
    import pybullet as pb

    if option:
        raise Unsupported("pybullet", f"no engine option {option!r}: PyBullet steps with semi-implicit Euler only")
    _check(spec)
    steps = max(1, int(np.ceil(t_end / h - 1e-9)))
    cid = pb.connect(pb.DIRECT)
    kw = {"physicsClientId": cid}
    try:
        pb.setGravity(*spec.gravity, **kw)
        pb.setTimeStep(h, **kw)
        pb.setPhysicsEngineParameter(numSubSteps=0, **kw)
        if spec.ground:
            ground = pb.createMultiBody(0.0, pb.createCollisionShape(pb.GEOM_PLANE, **kw), **kw)
            pb.changeDynamics(ground, -1, restitution=1.0, lateralFriction=1.0, rollingFriction=0.0,
                              spinningFriction=0.0, **kw)
            if any(b.restitution > 0 for b in spec.bodies):
                pb.changeDynamics(ground, -1, contactProcessingThreshold=0.0, **kw)
        chain = any(j.kind == "hinge" for j in spec.joints)
        if chain:
            uid = _chain(pb, spec, kw)
            links = list(range(len(spec.bodies)))
        else:
            ids = []
            for b in spec.bodies:
                uid = pb.createMultiBody(b.mass, _shape(pb, b, kw), basePosition=list(b.x), baseOrientation=xyzw(b.quat), **kw)
                _material(pb, uid, -1, b, kw)
                pb.resetBaseVelocity(uid, list(b.v), list(b.w), **kw)
                ids.append(uid)
            for j in spec.joints:                                         # ball joints to the world
                c = pb.createConstraint(ids[j.a], -1, -1, -1, pb.JOINT_POINT2POINT, [0, 0, 0], list(j.anchor_a),
                                        list(j.anchor_b), **kw)
                pb.changeConstraint(c, maxForce=1e9, **kw)
        n = len(spec.bodies)
        rec = np.zeros((steps + 1, n, 13))
        pen = np.zeros(steps + 1)

        def read(k):
            if chain:
                for i, s in enumerate(pb.getLinkStates(uid, links, computeLinkVelocity=1, **kw)):
                    rec[k, i] = [*s[0], *wxyz(s[1]), *s[6], *s[7]]
            else:
                for i, u in enumerate(ids):
                    x, q = pb.getBasePositionAndOrientation(u, **kw)
                    v, w = pb.getBaseVelocity(u, **kw)
                    rec[k, i] = [*x, *wxyz(q), *v, *w]
            if spec.ground or n > 1:
                pen[k] = max(0.0, -min((c[8] for c in pb.getContactPoints(**kw)), default=0.0))

        read(0)
        wall = 0.0
        for k in range(1, steps + 1):
            start = time.perf_counter()
            pb.stepSimulation(**kw)
            wall += time.perf_counter() - start
            read(k)
            if not np.all(np.isfinite(rec[k])):
                rec, pen = rec[: k + 1], pen[: k + 1]
                break
        iters = int(pb.getPhysicsEngineParameters(**kw)["numSolverIterations"])
    finally:
        pb.disconnect(cid)
    t = h * np.arange(rec.shape[0])
    extra = {"penetration": pen} if spec.ground or n > 1 else {}
    return Trace(t, rec[..., :3], rec[..., 3:7], rec[..., 7:10], rec[..., 10:], wall, steps, extra,
                 f"semi-implicit Euler, sequential impulses ({iters} it.), ε and μ combined as products"
                 + (", reduced-coordinate hinges" if chain else ""))
