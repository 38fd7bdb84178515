"""Peer engines for ``pbanim bench contact`` (issue 7): the same contact scenes in PyBullet and MuJoCo.

A helper of the ``contact`` family, not a family itself. Both peers are the optional extra ``[peers]``:
each function imports its engine inside the function, so importing this module needs neither, and
:func:`have` is the one import check the benchmark (and its tests) go through.

Scenes (read from :mod:`pbanim.models.contact`, not re-typed, so both sides simulate the same thing):

* :func:`pybullet_stack`, :func:`mujoco_stack` — ``box_stack(n, 1.0)``: n boxes of half extents
  (0.5, 0.5, 0.25) m, all of mass 1 kg (the "alternating" pattern with ratio 1), placed exactly touching
  (box k centred at z = 0.25 (2k + 1)) on a static ground plane z = 0, gravity 9.81 m/s², fixed step h.
  Each engine runs with its default solver: PyBullet's sequential-impulse solver (50 iterations per
  step, its default; default ERP/contact ERP and collision margins; default lateral friction 0.5),
  MuJoCo's Newton solver with pyramidal cones, Euler integrator and default soft-contact parameters
  (solref 0.02, solimp 0.9–0.95; default friction 1).
* :func:`mujoco_pour` — ``sphere_pour(n)``: n spheres of radius 0.05 m and mass 1 kg, at the model's
  initial positions (jittered lattice, seed 0), dropped into the open box |x|, |y| ≤ 0.3 m, z ≥ 0 made
  of five planes (floor and four walls), at the step h of the pbanim run. Contacts are exactly
  frictionless (``condim="1"``: normal force only), like pbanim's frictionless velocity-level run.

Measured (every function returns a small dict):

* ``per_step`` — wall time of the stepping call alone (``stepSimulation`` / ``mj_step``), summed over
  the run and divided by the number of steps; reading the state for the figures below is not timed.
* ``drift`` — max over the run of |z_top(t) − z_top(0)| (top-box centre height).
* ``penetration`` — the deepest contact the engine reports over the run, from its own signed contact
  distances (PyBullet ``getContactPoints(...)[8]``, MuJoCo ``data.contact.dist``; negative =
  penetration): max(0, −min distance). For the stack this is the overlap at an interface, not the
  accumulated sag (which ``drift`` shows).
* ``jitter`` — max body speed |v| over the run and all bodies (translation only).
"""

from __future__ import annotations

import time

import numpy as np

from ..compare.harness import have
from ..compare.peer_mujoco import mjcf_numbers
from ..errors import InvalidInput

__all__ = ["have", "pybullet_stack", "mujoco_stack", "mujoco_pour", "settle_run", "settle_scene", "scene_numbers",
           "MJ_SOLVERS"]

G = 9.81


def _stack_scene(n: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(half extents (3,), masses (n,), initial centres (n, 3)) of ``box_stack(n, 1.0)``."""
    from ..models.contact import box_stack

    sc = box_stack(n, 1.0)
    x0 = sc.system.unpack(sc.system.state())[0]
    return np.asarray(sc.half_extents, float), np.asarray(sc.system.mass, float), np.array(x0, float)


def _steps(t_end: float, h: float) -> int:
    if not (np.isfinite(h) and h > 0 and np.isfinite(t_end) and t_end > 0):
        raise InvalidInput(f"t_end and h must be positive and finite, got t_end = {t_end}, h = {h}")
    return max(1, int(round(t_end / h)))


def pybullet_stack(n: int = 10, t_end: float = 2.0, h: float = 1e-3) -> dict:
    """The n-box stack at rest in PyBullet (DIRECT mode, default solver settings), see the module docstring."""
    import pybullet as pb

    half, masses, x0 = _stack_scene(n)
    steps = _steps(t_end, h)
    cid = pb.connect(pb.DIRECT)
    try:
        kw = {"physicsClientId": cid}
        pb.setGravity(0.0, 0.0, -G, **kw)
        pb.setTimeStep(h, **kw)
        plane = pb.createCollisionShape(pb.GEOM_PLANE, **kw)
        pb.createMultiBody(0.0, plane, **kw)
        box = pb.createCollisionShape(pb.GEOM_BOX, halfExtents=half.tolist(), **kw)
        ids = [pb.createMultiBody(float(m), box, basePosition=x.tolist(), **kw) for m, x in zip(masses, x0)]
        iters = int(pb.getPhysicsEngineParameters(**kw)["numSolverIterations"])
        friction = float(pb.getDynamicsInfo(ids[-1], -1, **kw)[1])
        z_top0 = pb.getBasePositionAndOrientation(ids[-1], **kw)[0][2]
        elapsed = drift = pen = jitter = 0.0
        for _ in range(steps):
            start = time.perf_counter()
            pb.stepSimulation(**kw)
            elapsed += time.perf_counter() - start
            drift = max(drift, abs(pb.getBasePositionAndOrientation(ids[-1], **kw)[0][2] - z_top0))
            dist = [c[8] for c in pb.getContactPoints(**kw)]
            pen = max(pen, -min(dist, default=0.0))
            jitter = max(jitter, max(float(np.linalg.norm(pb.getBaseVelocity(i, **kw)[0])) for i in ids))
    finally:
        pb.disconnect(cid)
    return {"per_step": elapsed / steps, "steps": steps, "drift": drift, "penetration": pen, "jitter": jitter,
            "solver": f"default (SI, {iters} it.)",
            "settings": f"sequential impulse, {iters} iterations, default ERP and margins, friction {friction:g}"}


def _mjcf_stack(half, masses, x0, h: float) -> str:
    size = mjcf_numbers(*half)
    bodies = "\n".join(
        f'    <body name="box{k}" pos="{mjcf_numbers(*x)}"><freejoint/><geom type="box" size="{size}" mass="{mjcf_numbers(m)}"/></body>'
        for k, (m, x) in enumerate(zip(masses, x0)))
    return (f'<mujoco model="pbanim-box-stack">\n  <option timestep="{mjcf_numbers(h)}" gravity="{mjcf_numbers(0, 0, -G)}"/>\n'
            f'  <worldbody>\n    <geom name="ground" type="plane" size="10 10 0.1"/>\n{bodies}\n'
            "  </worldbody>\n</mujoco>\n")


def _mj_solver(model) -> str:
    import mujoco

    names = (mujoco.mjtSolver(model.opt.solver).name, mujoco.mjtCone(model.opt.cone).name,
             mujoco.mjtIntegrator(model.opt.integrator).name)
    return ", ".join(s.split("_", 1)[1].lower() for s in names)


def mujoco_stack(n: int = 10, t_end: float = 2.0, h: float = 1e-3) -> dict:
    """The n-box stack at rest in MuJoCo (MJCF built here, default solver), see the module docstring."""
    import mujoco

    half, masses, x0 = _stack_scene(n)
    steps = _steps(t_end, h)
    model = mujoco.MjModel.from_xml_string(_mjcf_stack(half, masses, x0, h))
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    top = model.body(f"box{n - 1}").id
    z_top0 = float(data.xpos[top, 2])
    qv = data.qvel.reshape(n, 6)            # free joints: (linear velocity (world), angular velocity (local))
    elapsed = drift = pen = jitter = 0.0
    for _ in range(steps):
        start = time.perf_counter()
        mujoco.mj_step(model, data)
        elapsed += time.perf_counter() - start
        drift = max(drift, abs(float(data.xpos[top, 2]) - z_top0))
        if data.ncon:
            pen = max(pen, -float(np.min(data.contact.dist)))
        jitter = max(jitter, float(np.max(np.linalg.norm(qv[:, :3], axis=1))))
    return {"per_step": elapsed / steps, "steps": steps, "drift": drift, "penetration": pen, "jitter": jitter,
            "solver": f"default ({_mj_solver(model).split(',')[0]})", "settings": _mj_solver(model)}


def _mjcf_pour(x0: np.ndarray, radius: float, box_half: float, mass: float, h: float) -> str:
    L = box_half
    walls = [("floor", (0.0, 0.0, 0.0), (0.0, 0.0, 1.0)), ("wall-x", (-L, 0.0, 0.0), (1.0, 0.0, 0.0)),
             ("wall+x", (L, 0.0, 0.0), (-1.0, 0.0, 0.0)), ("wall-y", (0.0, -L, 0.0), (0.0, 1.0, 0.0)),
             ("wall+y", (0.0, L, 0.0), (0.0, -1.0, 0.0))]
    geoms = "\n".join(f'    <geom name="{nm}" type="plane" size="{mjcf_numbers(L, L, 0.1)}" pos="{mjcf_numbers(*p)}" zaxis="{mjcf_numbers(*z)}"/>'
                      for nm, p, z in walls)
    bodies = "\n".join(f'    <body name="s{k}" pos="{mjcf_numbers(*x)}"><freejoint/>'
                       f'<geom type="sphere" size="{mjcf_numbers(radius)}" mass="{mjcf_numbers(mass)}"/></body>' for k, x in enumerate(x0))
    return (f'<mujoco model="pbanim-sphere-pour">\n  <option timestep="{mjcf_numbers(h)}" gravity="{mjcf_numbers(0, 0, -G)}"/>\n'
            '  <default><geom condim="1"/></default>\n'
            f"  <worldbody>\n{geoms}\n{bodies}\n  </worldbody>\n</mujoco>\n")


def mujoco_pour(n: int = 100, t_end: float = 1.2, h: float = 4e-3) -> dict:
    """``sphere_pour(n)`` in MuJoCo, frictionless (condim 1), step h; see the module docstring."""
    import mujoco

    from ..models.contact import sphere_pour

    sc = sphere_pour(n)
    r, L = float(sc.exact["radius"]), float(sc.exact["box_half"])
    x0 = sc.system.state()[: 3 * n].reshape(n, 3)
    mass = float(1.0 / sc.system.W[0])
    steps = _steps(t_end, h)
    model = mujoco.MjModel.from_xml_string(_mjcf_pour(x0, r, L, mass, h))
    data = mujoco.MjData(model)
    elapsed = pen = 0.0
    contacts = 0
    for _ in range(steps):
        start = time.perf_counter()
        mujoco.mj_step(model, data)
        elapsed += time.perf_counter() - start
        contacts += int(data.ncon)
        if data.ncon:
            pen = max(pen, -float(np.min(data.contact.dist)))
    xs = data.qpos.reshape(n, 7)[:, :3]
    inside = bool(np.all(np.abs(xs[:, :2]) <= L + r) and np.all(xs[:, 2] >= -r))
    return {"per_step": elapsed / steps, "steps": steps, "penetration": pen, "mean_contacts": contacts / steps,
            "inside": inside, "radius": r, "settings": f"{_mj_solver(model)}, condim 1 (frictionless)"}


# ---------------------------------------------------------------------------------------------
# Issue 14: the dropped stack and the sphere pile (pbanim.contact.scenes), drift and penetration after settling
# ---------------------------------------------------------------------------------------------
def _new_scene(scene: str, quick: bool) -> dict:
    """Geometry, start and duration of ``dropped_stack(10)`` / ``sphere_pile(20 | 50)``, as pbanim runs them."""
    from ..contact.scenes import dropped_stack, sphere_pile

    if scene not in ("stack", "pile"):
        raise InvalidInput(f"scene must be 'stack' or 'pile', got {scene!r}")
    sc = dropped_stack(10) if scene == "stack" else sphere_pile(20 if quick else 50)
    N = sc.system.N
    t_end = (0.3 if scene == "stack" else 0.6) if quick else (1.5 if scene == "stack" else 3.0)
    return {"x0": np.array(sc.system.unpack(sc.system.state())[0], float), "N": N, "t_end": t_end, "mu": sc.friction,
            "half": sc.info.get("half_extents"), "radius": sc.info.get("radius"), "L": sc.info.get("box_half")}


def _mjcf_new(scene: str, S: dict, h: float, iterations: int, options: dict | None = None) -> str:
    mu = S["mu"]
    o = options or {}
    soft = "".join(f' {k}="{mjcf_numbers(*o[k])}"' for k in ("solref", "solimp") if k in o)
    if scene == "stack":
        geom = f'type="box" size="{mjcf_numbers(*S["half"])}"'
        walls = '    <geom name="ground" type="plane" size="10 10 0.1"/>'
    else:
        geom = f'type="sphere" size="{mjcf_numbers(S["radius"])}"'
        L = S["L"]
        walls = "\n".join(f'    <geom type="plane" size="{mjcf_numbers(L, L, 0.1)}" pos="{mjcf_numbers(*p)}" zaxis="{mjcf_numbers(*z)}"/>' for p, z in
                          (((0, 0, 0), (0, 0, 1)), ((-L, 0, 0), (1, 0, 0)), ((L, 0, 0), (-1, 0, 0)),
                           ((0, -L, 0), (0, 1, 0)), ((0, L, 0), (0, -1, 0))))
    bodies = "\n".join(f'    <body name="b{k}" pos="{mjcf_numbers(*x)}"><freejoint/><geom {geom} mass="1"/></body>'
                       for k, x in enumerate(S["x0"]))
    return (f'<mujoco model="pbanim-{scene}">\n  <option timestep="{mjcf_numbers(h)}" gravity="{mjcf_numbers(0, 0, -G)}" '
            f'iterations="{int(iterations)}"/>\n  <default><geom friction="{mjcf_numbers(mu)} 0.005 0.0001"{soft}/></default>\n'
            f"  <worldbody>\n{walls}\n{bodies}\n  </worldbody>\n</mujoco>\n")


def settle_run(engine: str, scene: str, quick: bool, h: float, iterations: int) -> dict:
    """One peer run of the dropped stack or the sphere pile: cost per step and per simulated second (the
    stepping call alone), drift of the top box (stack) or of the highest centre (pile) and the deepest
    contact over the last third of the run (the engine's own contact distances)."""
    return settle_scene(engine, scene, _new_scene(scene, quick), h, iterations)


def scene_numbers(sc, t_end: float) -> dict:
    """What a peer needs of a scene of :mod:`pbanim.contact.scenes` (its start, geometry, friction) and the
    run's duration: the dictionary :func:`settle_scene` reads."""
    return {"x0": np.array(sc.system.unpack(sc.system.state())[0], float), "N": sc.system.N, "t_end": float(t_end),
            "mu": sc.friction, "half": sc.info.get("half_extents"), "radius": sc.info.get("radius"),
            "L": sc.info.get("box_half")}


MJ_SOLVERS = ("newton", "cg", "pgs")


def settle_scene(engine: str, scene: str, S: dict, h: float, iterations: int, *, solver: str | None = None,
                 budget: float = float("inf"), options: dict | None = None) -> dict:
    """:func:`settle_run` on a scene given by :func:`scene_numbers` ("stack": boxes on the ground, "pile":
    spheres in the open box |x|, |y| ≤ L): cost of the stepping call alone per step and per simulated second;
    over the last third of the run the drift (top box / highest centre) and the deepest contact.

    ``solver``: MuJoCo's (one of :data:`MJ_SOLVERS`; None: its default, Newton). ``budget``: seconds of stepping
    after which the run stops; then ``over`` is True, ``t_reached`` the simulated time reached, cost the wall
    time per simulated second so far, and drift and penetration NaN (the scene has not settled).

    ``options``: the peer's own contact settings beyond step and iterations — MuJoCo: "solref" (time constant,
    damping ratio) and "solimp" (d₀, d_width, width) on every geom, "noslip" iterations; PyBullet: "erp" (its
    ERP and contact ERP), "substeps" (numSubSteps)."""
    o = dict(options or {})
    allowed = {"mujoco": {"solref", "solimp", "noslip"}, "pybullet": {"erp", "substeps"}}.get(engine, set())
    if set(o) - allowed:
        raise InvalidInput(f"options for {engine} are among {sorted(allowed)}, got {sorted(o)}")
    if engine not in ("pybullet", "mujoco"):
        raise InvalidInput(f"engine must be 'pybullet' or 'mujoco', got {engine!r}")
    if solver is not None and (engine != "mujoco" or solver not in MJ_SOLVERS):
        raise InvalidInput(f"solver is MuJoCo's, one of {MJ_SOLVERS}, got {solver!r} for {engine}")
    if not budget > 0:
        raise InvalidInput(f"budget must be a positive number of seconds, got {budget}")
    steps = _steps(S["t_end"], h)
    k0 = (2 * steps) // 3
    heights, pens, elapsed = [], [], 0.0
    if engine == "mujoco":
        import mujoco

        model = mujoco.MjModel.from_xml_string(_mjcf_new(scene, S, h, iterations, o))
        if "noslip" in o:
            model.opt.noslip_iterations = int(o["noslip"])
        if solver is not None:
            model.opt.solver = getattr(mujoco.mjtSolver, f"mjSOL_{solver.upper()}")
        data = mujoco.MjData(model)
        for k in range(steps):
            start = time.perf_counter()
            mujoco.mj_step(model, data)
            elapsed += time.perf_counter() - start
            z = data.xpos[1:, 2]
            heights.append(float(z[-1] if scene == "stack" else z.max()))
            pens.append(max(0.0, -float(np.min(data.contact.dist))) if data.ncon else 0.0)
            if elapsed > budget:
                break
        solver = _mj_solver(model).split(",")[0]
    else:
        import pybullet as pb

        cid = pb.connect(pb.DIRECT)
        try:
            kw = {"physicsClientId": cid}
            pb.setGravity(0.0, 0.0, -G, **kw)
            pb.setTimeStep(h, **kw)
            pb.setPhysicsEngineParameter(numSolverIterations=int(iterations), **kw)
            if "erp" in o:
                pb.setPhysicsEngineParameter(erp=float(o["erp"]), contactERP=float(o["erp"]), **kw)
            if "substeps" in o:
                pb.setPhysicsEngineParameter(numSubSteps=int(o["substeps"]), **kw)
            fr = float(np.sqrt(S["mu"]))                 # PyBullet multiplies the two frictions of a pair
            statics = [pb.createMultiBody(0.0, pb.createCollisionShape(pb.GEOM_PLANE, **kw), **kw)]
            if scene == "stack":
                shape = pb.createCollisionShape(pb.GEOM_BOX, halfExtents=list(map(float, S["half"])), **kw)
            else:
                shape = pb.createCollisionShape(pb.GEOM_SPHERE, radius=float(S["radius"]), **kw)
                L = float(S["L"])
                for p, e in (((-L - 0.05, 0, 0.5), (0.05, L + 0.1, 0.5)), ((L + 0.05, 0, 0.5), (0.05, L + 0.1, 0.5)),
                             ((0, -L - 0.05, 0.5), (L + 0.1, 0.05, 0.5)), ((0, L + 0.05, 0.5), (L + 0.1, 0.05, 0.5))):
                    wall = pb.createCollisionShape(pb.GEOM_BOX, halfExtents=list(e), **kw)
                    statics.append(pb.createMultiBody(0.0, wall, basePosition=list(p), **kw))
            ids = [pb.createMultiBody(1.0, shape, basePosition=x.tolist(), **kw) for x in S["x0"]]
            for i in statics + ids:
                pb.changeDynamics(i, -1, lateralFriction=fr, **kw)
            for k in range(steps):
                start = time.perf_counter()
                pb.stepSimulation(**kw)
                elapsed += time.perf_counter() - start
                z = [pb.getBasePositionAndOrientation(i, **kw)[0][2] for i in ids]
                heights.append(z[-1] if scene == "stack" else max(z))
                pens.append(max(0.0, -min((c[8] for c in pb.getContactPoints(**kw)), default=0.0)))
                if elapsed > budget:
                    break
        finally:
            pb.disconnect(cid)
        solver = "SI"
    top, done = np.array(heights), len(heights)
    if done < steps:                                   # over budget: stopped before the scene settled
        return {"per_step": elapsed / done, "cost": elapsed / (done * h), "drift": np.nan, "pen": np.nan,
                "solver": solver, "steps": done, "over": True, "t_reached": done * h}
    return {"per_step": elapsed / steps, "cost": elapsed / S["t_end"], "drift": float(np.abs(top[k0:] - top[k0]).max()),
            "pen": float(max(pens[k0:])), "solver": solver, "steps": steps, "over": False, "t_reached": steps * h}
