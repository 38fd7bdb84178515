"""Checks of the chapter-05 assignments: the rigid-body state (ch05_rigid_body) and step (ch05_rigid_step).

ch05_rigid_body — in a copy of :mod:`pbanim.rigid.bodies` the student writes, for all bodies at once,

    I⁻¹_world = R I⁻¹_body Rᵀ,   v = P/m,   ω = I⁻¹_world L,   ẏ = [v, ½(0, ω)⊗q, F, τ].

ch05_rigid_step — in a copy of :mod:`pbanim.rigid.effects` the student writes the force and torque of a
force f at the body point p = x + R r (F += f, τ += (p − x) × f) and the post-step q ← q/|q|.

========================  ================================================================  ======
check                     oracle                                                            id
========================  ================================================================  ======
inertia_world             I⁻¹_world = R I⁻¹_body Rᵀ for a rotated body                        C1
angular_velocity          v = P/m, ω = I⁻¹_world L                                            C1
torque_free               body ω(t) of an asymmetric body = Jacobi elliptic closed form;      C1
                          |L| and E constant (RK4, h = 2 ms, 2 s)
free_flight               x(t) = x₀ + v₀t + ½gt² and ω constant for a sphere under gravity     A8
point_force_torque        F = Σf, τ = Σ (R r) × f for forces at rotated body points            C1
renormalize               q ← q/|q|: unit norm to a few ε, direction unchanged                 C3
quaternion_norm           explicit Euler with the post-step: ||q| − 1| ≤ 1e-14 after 400       C3
                          steps (without it the norm grows like (1 + h²|ω|²/4)^(n/2))
========================  ================================================================  ======

Limiting cases: R = E (identity orientation) hides a missing rotation of the inertia, so every check
uses a rotated body; a sphere (I ∝ E) hides it too, so torque_free uses moments (1, 2, 3).
"""

from __future__ import annotations

import numpy as np

from .registry import CheckFailed, Mutant, array, at_most, attr, check, close

BODY_CHECKS: list = []
STEP_CHECKS: list = []
Q_TILT = np.array([0.9, 0.3, -0.2, 0.25]) / np.linalg.norm([0.9, 0.3, -0.2, 0.25])
MOMENTS = np.array([1.0, 2.0, 3.0])


def _R(q):
    from ..rigid.quat import quat_to_matrix

    return quat_to_matrix(np.asarray(q, float))


def _bodies(mod, w_world=(1.0, -0.5, 2.0), v=(0.3, 0.0, -1.0)):
    return attr(mod, "RigidBodies")([2.0, 0.5], [MOMENTS, [0.5, 0.5, 0.8]], positions=[[0, 0, 1.0], [1.0, 2.0, 0]],
                                    orientations=[Q_TILT, [1.0, 0, 0, 0]], velocities=[v, [0, 1.0, 0]],
                                    angular_velocities=[w_world, [0.0, 0.0, 3.0]])


@check(BODY_CHECKS, "inertia_world", 20, "the world-frame inverse inertia is R I⁻¹_body Rᵀ", "C1",
       regions=("RigidBodies.inv_inertia_world",))
def inertia_world(mod):
    rb = _bodies(mod)
    Iw = array("RigidBodies.inv_inertia_world(y)", rb.inv_inertia_world(rb.state()), (2, 3, 3))
    R = _R(Q_TILT)
    close("I⁻¹_world of the tilted body", Iw[0], R @ np.diag(1 / MOMENTS) @ R.T, rtol=1e-14,
          why="rotate the body-frame tensor: R I⁻¹_body Rᵀ")
    close("I⁻¹_world of the unrotated body", Iw[1], np.diag(1 / np.array([0.5, 0.5, 0.8])), rtol=1e-14)
    return "R I⁻¹_body Rᵀ for both bodies (rtol 1e-14)"


@check(BODY_CHECKS, "angular_velocity", 20, "linear and angular velocity from momenta: v = P/m, ω = I⁻¹_world L",
       "C1", regions=("RigidBodies.velocities",))
def angular_velocity(mod):
    w0 = np.array([1.0, -0.5, 2.0])
    rb = _bodies(mod, w0)
    out = rb.velocities(rb.state())
    if not isinstance(out, tuple) or len(out) != 2:
        raise CheckFailed(f"RigidBodies.velocities must return a pair (v, ω), got {type(out).__name__}")
    v, w = array("v", out[0], (2, 3)), array("ω", out[1], (2, 3))
    close("v = P/m", v, [[0.3, 0.0, -1.0], [0, 1.0, 0]], rtol=1e-14, unit="m/s")
    close("ω = I⁻¹_world L (L stored from the initial ω)", w, [w0, [0.0, 0.0, 3.0]], rtol=1e-13, unit="rad/s",
          why="L = I_world ω at construction, so I⁻¹_world L must give ω back")
    return "v = P/m, ω = I⁻¹_world L (rtol 1e-13)"


@check(BODY_CHECKS, "torque_free", 35, "a torque-free asymmetric body follows Euler's closed-form ω(t)", "C1",
       regions=("RigidBodies.derivative_and_omega",))
def torque_free(mod):
    from ..models.rigid import torque_free_body
    from ..ode import solve

    model = torque_free_body(MOMENTS, [1.0, 0.1, 2.0])
    rb = attr(mod, "RigidBodies")(1.0, MOMENTS, orientations=[Q_TILT], angular_velocities=[_R(Q_TILT) @ model.omega0])
    zero = np.zeros((1, 6))
    res = solve(lambda t, y: array("RigidBodies.derivative(y, Q)", rb.derivative(y, zero), (13,)),
                (0.0, 2.0), rb.state(), method="rk4", h=0.002)
    q, L = res.y[3:7].T, res.y[10:13].T
    R = _R(q)
    w_body = np.einsum("kji,kj->ki", R, L) / MOMENTS          # I⁻¹_body Rᵀ L
    # measured 6.9e-11 rad/s for the reference (RK4, h = 2 ms, 2 s): bound 5e-10 rad/s
    err = close("body ω(t) vs the elliptic closed form", w_body, model.omega(res.t), atol=5e-10, unit="rad/s",
                why="ω = I⁻¹_world L with I⁻¹_world = R I⁻¹_body Rᵀ, q̇ = ½(0, ω)⊗q")
    at_most("change of world L (torque-free)", float(np.max(np.abs(L - L[0]))), 1e-12, unit="kg·m²/s")
    return f"body ω(t) matches the closed form within {err:.1e} rad/s over 2 s"


@check(BODY_CHECKS, "free_flight", 25, "a spinning sphere under gravity flies a parabola at constant ω", "A8",
       public=False, regions=("RigidBodies.derivative_and_omega",))
def free_flight(mod):
    from ..ode import solve

    g = np.array([0.0, 0.0, -9.81])
    rb = attr(mod, "RigidBodies")(2.0, [0.4, 0.4, 0.4], positions=[[0.0, 0.0, 1.0]], orientations=[Q_TILT],
                                  velocities=[[1.0, 0.5, 3.0]], angular_velocities=[[0.0, 4.0, 1.0]])
    Q = np.concatenate([2.0 * g, np.zeros(3)])[None]
    res = solve(lambda t, y: array("RigidBodies.derivative(y, Q)", rb.derivative(y, Q), (13,)),
                (0.0, 1.0), rb.state(), method="rk4", h=0.01)
    T = res.t[-1]
    close("x(1 s)", res.y[:3, -1], np.array([0.0, 0.0, 1.0]) + np.array([1.0, 0.5, 3.0]) * T + 0.5 * g * T * T,
          atol=1e-12, unit="m", why="ẋ = P/m, Ṗ = F = m g")
    w = rb.velocities(res.y[:, -1])[1]
    close("ω(1 s) of the sphere", w, [[0.0, 4.0, 1.0]], atol=1e-10, unit="rad/s", why="no torque: L and ω constant")
    return "parabola exact (1e-12 m), ω constant"


BODY_MUTANTS = (
    Mutant("world_inertia_not_rotated", "the body-frame inertia is used as if it were the world-frame one",
           (("        return R @ self.inv_I_body @ np.swapaxes(R, 1, 2)\n", "        return self.inv_I_body.copy()\n"),
            ("_matvec(R, _matvec(self.inv_I_body, _matTvec(R, L)))", "_matvec(self.inv_I_body, L)"),
            ('w = np.einsum("nij,nj->ni", R, np.einsum("nij,nj->ni", self.inv_I_body, np.einsum("nji,nj->ni", R, L)))',
             'w = np.einsum("nij,nj->ni", self.inv_I_body, L)')),
           ("inertia_world", "angular_velocity", "torque_free")),
    Mutant("quaternion_rate_halved", "q̇ = ¼(0, ω)⊗q: the factor ½ written twice",
           (("qd[:, 0] = -0.5 *", "qd[:, 0] = -0.25 *"), ("qd[:, 1] = 0.5 *", "qd[:, 1] = 0.25 *"),
            ("qd[:, 2] = 0.5 *", "qd[:, 2] = 0.25 *"), ("qd[:, 3] = 0.5 *", "qd[:, 3] = 0.25 *")),
           ("torque_free",)),
)


# --------------------------------------------------------------------------------------------------
# ch05_rigid_step: torques and the quaternion post-step (student effects on the reference bodies)
# --------------------------------------------------------------------------------------------------
@check(STEP_CHECKS, "point_force_torque", 40, "a force at a body point adds F = f and τ = (R r) × f", "C1",
       regions=("PointForce.apply",))
def point_force_torque(mod):
    from ..rigid import RigidBodies
    from ..scene import Scene

    rb = RigidBodies([1.0, 2.0], MOMENTS, positions=[[0, 0, 0], [1.0, 0, 0]], orientations=[Q_TILT, [1.0, 0, 0, 0]])
    r = np.array([[0.5, 0.0, 0.0], [0.0, 1.0, 0.2], [0.0, 0.0, -1.0]])
    f = np.array([[0.0, 1.0, 0.0], [2.0, 0.0, 1.0], [1.0, 1.0, 1.0]])
    Q = Scene(rb, [attr(mod, "PointForce")([0, 0, 1], r, f)]).applied_forces(0.0, rb.state())
    R0 = _R(Q_TILT)
    arm = np.array([R0 @ r[0], R0 @ r[1], r[2]])
    want = np.zeros((2, 6))
    for b, a, ff in zip([0, 0, 1], arm, f):
        want[b, :3] += ff
        want[b, 3:] += np.cross(a, ff)
    close("Q = [F, τ] of three point forces", Q, want, rtol=1e-14, unit="N, N·m",
          why="τ = (p − x) × f with p − x = R r (body point in world axes); two forces on one body add")
    return "F and τ of three point forces on two bodies (rtol 1e-14)"


@check(STEP_CHECKS, "renormalize", 30, "the post-step puts the quaternion back on the unit sphere", "C3",
       regions=("QuaternionRenormalize.post_step",))
def renormalize(mod):
    from ..rigid import RigidBodies

    rb = RigidBodies([1.0, 1.0], MOMENTS, orientations=[Q_TILT, [1.0, 0, 0, 0]])
    y = rb.state()
    y[6:14] *= np.repeat([1.3, 0.7], 4)
    eff = attr(mod, "QuaternionRenormalize")()
    eff.bind(rb)
    y1 = array("QuaternionRenormalize.post_step(t, y, h)", eff.post_step(0.0, y.copy(), 0.01), (26,))
    q = y1[6:14].reshape(2, 4)
    close("|q| after the post-step", np.linalg.norm(q, axis=1), [1.0, 1.0], atol=4e-16,
          why="q ← q/|q| (ORACLES C3: a few ε)")
    close("direction of q", q, np.array([Q_TILT, [1.0, 0, 0, 0]]), atol=1e-15, why="only the length changes")
    return "|q| = 1 to a few ε, direction kept"


@check(STEP_CHECKS, "quaternion_norm", 30, "explicit Euler keeps unit quaternions only with the post-step", "C3",
       public=False, regions=("QuaternionRenormalize.post_step",))
def quaternion_norm(mod):
    from ..rigid import RigidBodies, RigidScene

    rb = RigidBodies(1.0, MOMENTS, orientations=[Q_TILT], angular_velocities=[[3.0, 1.0, -2.0]])
    res = RigidScene(rb, [attr(mod, "QuaternionRenormalize")()], quaternions="none").simulate(2.0, 0.005, "euler")
    err = float(np.max(np.abs(np.linalg.norm(res.y[3:7], axis=0) - 1.0)))
    # measured 2.2e-16 for the reference over 400 steps: bound 1e-14 (without it: 0.3)
    at_most("max ||q| − 1| over 400 explicit Euler steps", err, 1e-14,
            why="each step scales |q| by √(1 + h²|ω|²/4); the post-step must undo it")
    return f"max ||q| − 1| = {err:.1e} over 400 steps"


STEP_MUTANTS = (
    Mutant("never_renormalized", "the quaternion is never renormalized (post_step returns y unchanged)",
           (("        q /= np.sqrt(np.sum(q * q, axis=1, keepdims=True))\n", ""),), ("renormalize", "quaternion_norm")),
    Mutant("torque_sign", "τ = f × r instead of r × f", (("_cross(r, f)", "_cross(f, r)"),), ("point_force_torque",)),
)
