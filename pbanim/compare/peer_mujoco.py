"""A scene in MuJoCo (an MJCF model written here): every parameter and the knob it becomes.

MuJoCo is the optional extra ``[peers]``; it is imported inside :func:`run_mujoco` only. MuJoCo's
contacts and joints are *soft* constraints: the solver asks each constraint row for the acceleration

    a₁ + d(r) (b v + k r) = (1 − d(r)) a₀,          r: violation (penetration < 0), v: its rate,

with impedance d ∈ (0, 1) from ``solimp`` and the reference spring–damper (k, b) from ``solref``. For
``solref = (τ, ζ)`` (time constant, damping ratio; default (0.02 s, 1)) it is b = 2/(d_max τ),
k = d(r)/(d_max² τ² ζ²); for ``solref = (−k, −b)`` (negative: stiffness and damping given directly)
b and k are used as they are. With d(r) = d_max the contact is the oscillator r̈ + b ṙ + k r ≈ 0.

====================  ============================================================================
scene parameter       MuJoCo knob (this module's MJCF)
====================  ============================================================================
step h, gravity g     ``<option timestep="h" gravity="g"/>``; integrator Euler (semi-implicit), the
                      default; solver Newton, pyramidal cone (defaults). Euler (and implicitfast)
                      take the gyroscopic torque ω × Iω explicitly: the 150 rad/s top of chapter 11
                      falls over at h = 1 ms; the engine option ``mujoco:RK4`` (or ``implicit``) keeps it
sphere r / box a      ``<geom type="sphere" size="r"/>`` / ``type="box" size="a"`` (half extents);
                      ``shape="none"``: no geom
mass, inertia         ``<inertial pos="c" mass="m" diaginertia="I"/>``: explicit, so MuJoCo does not
                      derive them from geoms (density 1000 kg/m³ otherwise)
x, q                  free body: ``<freejoint/>`` and ``qpos = (x, q)`` with q = (w, x, y, z), the same
                      order as pbanim
v, ω                  ``qvel = (v, Rᵀω)``: the free joint's linear velocity is in the world frame, its
                      angular velocity in the *body* frame; a ball joint's likewise
restitution ε         no coefficient: ε is the bounce of the contact oscillator. ε > 0 → direct
                      ``solref = (−k, −b)`` with ζ = −ln ε / √(π² + ln² ε) (the damped oscillator that
                      rebounds at ε), ω₀ = π / (T_c √(1 − ζ²)), k = ω₀², b = 2ζω₀, contact time
                      T_c = 10 h (resolved by the step), ``solimp = (0.99, 0.99, 0.001)`` (d ≈ 1 so
                      the spring acts as written); solrefs of two geoms are averaged (``solmix``), so
                      bodies with different ε cannot be written without ``<pair>``: refused. ε = 0 →
                      MuJoCo's default contact (critically damped, ζ = 1)
friction μ            ``friction="μ 0 0"`` on the body, 0 on the ground: MuJoCo takes the maximum of
                      the two geoms' coefficients; ``condim=3`` (no torsional or rolling friction)
hinge chain           nested bodies (the body frame is the centre of mass), ``<joint type="hinge"
                      pos="anchor" axis="a"/>``: reduced coordinates, a closed joint by construction
ball joint to world   a body whose frame sits on the world point, ``<joint type="ball"/>``, the
                      centre of mass at ``<inertial pos="−anchor"/>``; ``qpos`` = q, ``qvel`` = Rᵀω
====================  ============================================================================

Read back at every step (not timed): the centre-of-mass frame (``xipos``, ``xquat``) and its velocity
(``mj_objectVelocity``, world frame) for every body; the deepest contact (``data.contact.dist``). Only
``mj_step`` is inside the wall time. ``mj_step`` integrates *after* computing positions and velocities of
the frames, so those lag one step behind ``qpos``; an ``mj_forward`` (untimed) brings them up to date.

Limiting cases: no contact, no joint: Euler is semi-implicit (v first), free fall off by g h t / 2
(ORACLES K1); ε → 1 gives ζ → 0, an undamped contact spring; ε = 0 the default, sticky contact.

References: E. Todorov, "Convex and analytically-invertible dynamics with contacts and constraints",
ICRA 2014; MuJoCo documentation, *Computation* (soft constraints) and *XML reference* (solref, solimp).
"""

from __future__ import annotations

import math
import time

import numpy as np

from .spec import SceneSpec, Trace, Unsupported

__all__ = ["run_mujoco", "bounce_solref", "mjcf"]

CONTACT_STEPS = 10            # a bouncing contact lasts this many steps


def mjcf_numbers(*values) -> str:
    """MJCF number list: shortest round-trip decimal of each value."""
    return " ".join(repr(float(v)) for v in values)


def bounce_solref(restitution: float, h: float) -> tuple[float, float]:
    """(−k, −b) of a contact spring that lasts ``CONTACT_STEPS`` steps and rebounds at ``restitution``.

    >>> k, b = bounce_solref(1.0, 1e-3); round(-k), b
    (98696, -0.0)
    """
    lg = math.log(restitution)
    zeta = -lg / math.sqrt(math.pi ** 2 + lg * lg)
    w0 = math.pi / (CONTACT_STEPS * h * math.sqrt(1 - zeta * zeta))
    return -w0 * w0, -2 * zeta * w0


def _contact_attrs(spec: SceneSpec, h: float) -> str:
    eps = {b.restitution for b in spec.bodies if b.shape != "none"}
    if len(eps) > 1:
        raise Unsupported("mujoco", f"bodies have different restitutions {sorted(eps)}; MuJoCo averages the two "
                                    "geoms' solref, so each pair would need its own <pair> element")
    e = eps.pop() if eps else 0.0
    if e == 0.0:
        return ""
    return f' solref="{mjcf_numbers(*bounce_solref(e, h))}" solimp="0.99 0.99 0.001"'


def _inertial(b, com=(0.0, 0.0, 0.0)) -> str:
    return f'<inertial pos="{mjcf_numbers(*com)}" mass="{mjcf_numbers(b.mass)}" diaginertia="{mjcf_numbers(*b.inertia)}"/>'


def _geom(b, contact: str) -> str:
    if b.shape == "none":
        return ""
    kind = "sphere" if b.shape == "sphere" else "box"
    return f'<geom type="{kind}" size="{mjcf_numbers(*b.size)}" friction="{mjcf_numbers(b.friction, 0, 0)}" condim="3"{contact}/>'


INTEGRATORS = ("Euler", "RK4", "implicit", "implicitfast")


def mjcf(spec: SceneSpec, h: float, integrator: str = "Euler") -> str:
    """The MJCF text of ``spec`` at step ``h`` (see the module docstring for each attribute)."""
    from ..rigid.quat import quat_conjugate, quat_multiply, quat_to_matrix

    contact = _contact_attrs(spec, h)
    lines = [f'<mujoco model="pbanim-{spec.name}">',
             f'  <option timestep="{mjcf_numbers(h)}" gravity="{mjcf_numbers(*spec.gravity)}" integrator="{integrator}"/>', "  <worldbody>"]
    if spec.ground:
        lines.append(f'    <geom name="ground" type="plane" size="50 50 0.1" friction="0 0 0"{contact}/>')
    hinges = [j for j in spec.joints if j.kind == "hinge"]
    if hinges:
        if any(j.a != k or j.b != k - 1 for k, j in enumerate(hinges)) or len(hinges) != len(spec.bodies):
            raise Unsupported("mujoco", "hinges are translated as one chain hung from the world (joint k "
                                        "between body k and body k − 1)")
        prev_x, prev_q, close = np.zeros(3), np.array([1.0, 0, 0, 0]), []
        for k, (b, j) in enumerate(zip(spec.bodies, hinges)):
            pos = quat_to_matrix(prev_q).T @ (np.asarray(b.x) - prev_x)
            rel = quat_multiply(quat_conjugate(prev_q), np.asarray(b.quat))
            pad = "    " + "  " * k
            lines += [f'{pad}<body name="b{k}" pos="{mjcf_numbers(*pos)}" quat="{mjcf_numbers(*rel)}">',
                      f'{pad}  <joint type="hinge" pos="{mjcf_numbers(*j.anchor_a)}" axis="{mjcf_numbers(*j.axis)}"/>',
                      f"{pad}  {_inertial(b)}"]
            close.append(f"{pad}</body>")
            prev_x, prev_q = np.asarray(b.x), np.asarray(b.quat)
        lines += close[::-1]
    else:
        balls = {j.a: j for j in spec.joints}
        for k, b in enumerate(spec.bodies):
            if k in balls:
                j = balls[k]
                if j.b != -1:
                    raise Unsupported("mujoco", "ball joints are translated to the world only")
                lines += [f'    <body name="b{k}" pos="{mjcf_numbers(*j.anchor_b)}">', '      <joint type="ball"/>',
                          f"      {_inertial(b, -np.asarray(j.anchor_a))} {_geom(b, contact)}", "    </body>"]
            else:
                lines += [f'    <body name="b{k}" pos="{mjcf_numbers(*b.x)}">', "      <freejoint/>",
                          f"      {_inertial(b)} {_geom(b, contact)}", "    </body>"]
    lines += ["  </worldbody>", "</mujoco>", ""]
    return "\n".join(lines)


def _initial_state(spec: SceneSpec, model, data) -> None:
    """qpos, qvel of free and ball joints from the scene (hinge chains start at q = 0, at rest)."""
    import mujoco

    from ..rigid.quat import quat_to_matrix

    for k, b in enumerate(spec.bodies):
        jid = model.body_jntadr[k + 1]
        kind = model.jnt_type[jid]
        qa, va = model.jnt_qposadr[jid], model.jnt_dofadr[jid]
        Rt = quat_to_matrix(np.asarray(b.quat)).T
        if kind == mujoco.mjtJoint.mjJNT_FREE:
            data.qpos[qa:qa + 7] = [*b.x, *b.quat]
            data.qvel[va:va + 6] = [*b.v, *(Rt @ np.asarray(b.w))]
        elif kind == mujoco.mjtJoint.mjJNT_BALL:
            data.qpos[qa:qa + 4] = b.quat
            data.qvel[va:va + 3] = Rt @ np.asarray(b.w)
        elif any(np.asarray(b.v) != 0) or any(np.asarray(b.w) != 0):
            raise Unsupported("mujoco", "hinge chains are translated starting at rest")


def run_mujoco(spec: SceneSpec, h: float, t_end: float, option: str | None = None) -> Trace:
    """Run ``spec`` in MuJoCo with step ``h`` until ``t_end``; ``option`` names another integrator of
    :data:`INTEGRATORS` (default Euler). See the module docstring for the mapping."""
    import mujoco

    integrator = option or "Euler"
    if integrator not in INTEGRATORS:
        raise Unsupported("mujoco", f"integrator must be one of {list(INTEGRATORS)}, got {integrator!r}")
    text = mjcf(spec, h, integrator)
    model = mujoco.MjModel.from_xml_string(text)
    data = mujoco.MjData(model)
    _initial_state(spec, model, data)
    mujoco.mj_forward(model, data)
    steps = max(1, int(np.ceil(t_end / h - 1e-9)))
    n = len(spec.bodies)
    rec = np.zeros((steps + 1, n, 13))
    pen = np.zeros(steps + 1)
    vel = np.zeros(6)

    body, xipos, xquat = mujoco.mjtObj.mjOBJ_BODY, data.xipos, data.xquat

    def read(k):
        # slices copied into the record (the same numbers as a list of the unpacked entries, without it)
        rk = rec[k]
        rk[:, :3] = xipos[1:n + 1]
        rk[:, 3:7] = xquat[1:n + 1]
        for i in range(n):
            mujoco.mj_objectVelocity(model, data, body, i + 1, vel, 0)
            rk[i, 7:10] = vel[3:]
            rk[i, 10:] = vel[:3]
        if data.ncon:
            pen[k] = max(0.0, -float(np.min(data.contact.dist)))

    read(0)
    wall = 0.0
    for k in range(1, steps + 1):
        start = time.perf_counter()
        mujoco.mj_step(model, data)
        wall += time.perf_counter() - start
        mujoco.mj_forward(model, data)          # mj_step leaves xipos, xquat, cvel at the step's start
        read(k)
        if not np.all(np.isfinite(rec[k])):
            rec, pen = rec[: k + 1], pen[: k + 1]
            break
    names = [mujoco.mjtSolver(model.opt.solver).name, mujoco.mjtCone(model.opt.cone).name,
             mujoco.mjtIntegrator(model.opt.integrator).name]
    solref = "default solref (0.02, 1)" if "solref" not in text else f"solref (−k, −b) for ε, T_c = {CONTACT_STEPS} h"
    t = h * np.arange(rec.shape[0])
    return Trace(t, rec[..., :3], rec[..., 3:7], rec[..., 7:10], rec[..., 10:], wall, steps,
                 {"penetration": pen} if spec.ground or n > 1 else {},
                 ", ".join(s.split("_", 1)[1].lower() for s in names) + f", {solref}")
