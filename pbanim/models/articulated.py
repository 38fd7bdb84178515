"""Canonical articulated models of chapter 08, built in Python and shipped as URDF (ORACLES I1–I5).

============================  ==========================================================================
model                         what it is
============================  ==========================================================================
``pendulum_chain(n, ...)``    planar chain of n revolute joints about z, point masses at the link ends,
                              gravity −y: the same system as :func:`pbanim.models.reduced.n_link_pendulum`
                              (relative joint angles here, absolute angles there)
``ragdoll()``                 a floating pelvis with a torso, a head, two arms (shoulder, elbow) and two
                              legs (hip, knee), 11 links, 16 joint coordinates plus the floating base
``planar_biped()``            the 7-link planar biped of the characters lecture (SIMBICON's 2-D model;
                              :mod:`pbanim.models.biped`): the torso on a planar base (x, y slides and a
                              hinge), hips, knees and ankles about z
============================  ==========================================================================

The URDF copies live in ``pbanim/models/urdf/`` (:func:`urdf_path`); ``tests/test_articulated.py`` loads
them with :func:`pbanim.articulated.load_urdf` and checks that they give the same mass matrix and
accelerations as the Python builders. Lengths in m, masses in kg, inertias in kg m² (about the centre of
mass, link axes); the segment proportions follow common anthropometric tables (about 1.75 m, 70 kg).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ..articulated.tree import ArticulatedTree
from ..errors import InvalidInput, check_count, check_number
from .biped import planar_biped

__all__ = ["pendulum_chain", "rod_chain", "ragdoll", "ragdoll_contact_points", "ragdoll_down_stairs", "planar_biped", "urdf_path", "to_urdf", "box_inertia"]


def box_inertia(mass: float, size) -> np.ndarray:
    """Principal moments of a solid box of the given full side lengths (about its centre)."""
    a, b, c = (float(s) for s in size)
    return mass / 12.0 * np.array([b * b + c * c, a * a + c * c, a * a + b * b])


def urdf_path(name: str) -> Path:
    """The shipped URDF file of a model: ``"pendulum3"``, ``"ragdoll"`` or ``"planar_biped"``."""
    p = Path(__file__).with_name("urdf") / f"{name}.urdf"
    if not p.exists():
        names = sorted(f.stem for f in p.parent.glob("*.urdf"))
        raise InvalidInput(f"name must be one of {names}, got {name!r}")
    return p


def pendulum_chain(n: int = 3, lengths=1.0, masses=1.0, g: float = 9.81) -> ArticulatedTree:
    """n point masses on massless rods, joints about z, in the x–y plane (gravity −y)."""
    n = check_count("n", n)
    L = np.broadcast_to(np.asarray(lengths, dtype=float), (n,))
    m = np.broadcast_to(np.asarray(masses, dtype=float), (n,))
    tree = ArticulatedTree(gravity=(0.0, -g, 0.0))
    for i in range(n):
        tree.add(f"link{i}", i - 1, "revolute", axis=[0, 0, 1], p=[0.0, -L[i - 1], 0.0] if i else [0, 0, 0],
                 mass=m[i], com=[0.0, -L[i], 0.0], inertia=np.zeros((3, 3)))
    return tree


def rod_chain(n: int, length: float = 0.5, mass: float = 1.0, theta0: float = 0.9, g: float = 9.81,
              ks: float = 0.0, kd: float = 0.0, solver: str = "dense"):
    """n rods of a chain hung from the origin, released at rest at ``theta0``, both ways: returns
    (maximal RigidScene with hinge RigidJoints, its RigidBodies, the reduced ArticulatedSystem)."""
    from ..articulated.joints import RigidJoints
    from ..articulated.system import ArticulatedSystem
    from ..rigid import RigidBodies, RigidGravity, RigidScene, quat_from_axis_angle, quat_to_matrix

    n = check_count("n", n, 1, 10_000)
    L = check_number("length", length, low=0.0, low_open=True, high=1e6)
    m = check_number("mass", mass, low=0.0, low_open=True, high=1e100)
    Ic = np.diag([m * L * L / 12, 1e-3 * m * L * L, m * L * L / 12])
    R = quat_to_matrix(quat_from_axis_angle([0, 0, 1], theta0))
    x = [R @ [0, -L * (k + 0.5), 0] for k in range(n)]
    rb = RigidBodies(m, Ic, positions=x, orientations=[quat_from_axis_angle([0, 0, 1], theta0)] * n)
    joints = [dict(kind="hinge", a=0, b=-1, anchor_a=[0, L / 2, 0], anchor_b=[0, 0, 0], axis_a=[0, 0, 1])]
    joints += [dict(kind="hinge", a=i, b=i - 1, anchor_a=[0, L / 2, 0], anchor_b=[0, -L / 2, 0], axis_a=[0, 0, 1])
               for i in range(1, n)]
    scene = RigidScene(rb, [RigidGravity([0, -g, 0]), RigidJoints(joints, ks=ks, kd=kd, solver=solver)])
    tree = ArticulatedTree(gravity=(0, -g, 0))
    for i in range(n):
        tree.add(f"rod{i}", i - 1, "revolute", axis=[0, 0, 1], p=[0, -L, 0] if i else [0, 0, 0], mass=m,
                 com=[0, -L / 2, 0], inertia=Ic)
    q0 = np.zeros(n)
    q0[0] = theta0
    return scene, rb, ArticulatedSystem(tree, q0)


def _segment(tree, name, parent, kind, axis, p, mass, length, R=None, down=True, damping=0.0):
    """A limb segment hanging from its joint along −z (``down``) or rising along +z, box-shaped."""
    com = [0.0, 0.0, -0.5 * length if down else 0.5 * length]
    size = (0.1 * length + 0.04, 0.1 * length + 0.04, length)
    return tree.add(name, parent, kind, axis=axis, p=p, R=R, mass=mass, com=com, inertia=box_inertia(mass, size),
                    damping=damping)


def ragdoll(g: float = 9.81, damping: float = 0.0) -> ArticulatedTree:
    """A 70 kg ragdoll on a floating pelvis (z up); every joint a hinge (shoulders and hips about y), each
    with viscous ``damping`` (N m s/rad; 0 in the shipped URDF)."""
    tree = ArticulatedTree(gravity=(0.0, 0.0, -g))
    d = dict(damping=damping)
    pelvis = tree.add("pelvis", -1, "floating", mass=10.0, inertia=box_inertia(10.0, (0.3, 0.2, 0.15)))
    torso = _segment(tree, "torso", pelvis, "revolute", [0, 1, 0], [0, 0, 0.08], 25.0, 0.45, down=False, **d)
    _segment(tree, "head", torso, "revolute", [0, 1, 0], [0, 0, 0.5], 5.0, 0.25, down=False, **d)
    for side, y in (("left", 0.2), ("right", -0.2)):
        upper = _segment(tree, f"{side}_upper_arm", torso, "revolute", [0, 1, 0], [0, y, 0.42], 2.0, 0.3, **d)
        _segment(tree, f"{side}_forearm", upper, "revolute", [0, 1, 0], [0, 0, -0.3], 1.5, 0.28, **d)
    for side, y in (("left", 0.1), ("right", -0.1)):
        thigh = _segment(tree, f"{side}_thigh", pelvis, "revolute", [0, 1, 0], [0, y, -0.08], 7.0, 0.45, **d)
        _segment(tree, f"{side}_shin", thigh, "revolute", [0, 1, 0], [0, 0, -0.45], 4.0, 0.43, **d)
    return tree


def ragdoll_contact_points(tree: ArticulatedTree) -> list:
    """(link, point) pairs for ground contact: both ends of every segment (its centre of mass ± itself)."""
    pts = []
    for i, lk in enumerate(tree.links):
        c = np.asarray(lk.com, dtype=float)
        pts += [(i, np.zeros(3)), (i, 2.0 * c)] if np.any(c) else [(i, np.array([sx * 0.15, sy * 0.1, -0.075]))
                                                                  for sx in (-1, 1) for sy in (-1, 1)]
    return pts


def ragdoll_down_stairs(speed: float = 1.5, seed: int = 0):
    """(ArticulatedContact, Staircase): the damped ragdoll thrown forward at ``speed`` (m/s) over the top of
    a staircase (rise 0.15 m, run 0.35 m, 6 steps), friction 0.8 — chapter 08's falling-down-steps scene."""
    from ..articulated.contact import ArticulatedContact, Staircase
    from ..articulated.system import ArticulatedSystem
    from ..rigid.quat import quat_from_axis_angle

    tree = ragdoll(damping=3.0)
    q0 = tree.neutral()
    q0[:4] = quat_from_axis_angle([0, 1, 0], 0.3)
    q0[4:7] = [-0.1, 0, 1.1]
    q0[7:] = np.random.default_rng(seed).uniform(-0.3, 0.3, tree.nq - 7)
    qd0 = np.zeros(tree.nv)
    qd0[3] = check_number("speed", speed, low=0.0, high=100.0)          # forward, in the pelvis axes
    stairs = Staircase(rise=0.15, run=0.35, steps=6)
    return ArticulatedContact(ArticulatedSystem(tree, q0, qd0), ragdoll_contact_points(tree), friction=0.8,
                              terrain=stairs), stairs


def to_urdf(tree: ArticulatedTree, name: str) -> str:
    """URDF text of a tree (a fixed root is written as the robot's root link; a floating or jointed root
    gets a massless ``world`` link only when its joint is not floating)."""
    from scipy.spatial.transform import Rotation

    # URDF requires <limit> on revolute and prismatic joints; pbanim does not read it (no limits here)
    limit = '<limit lower="-1e9" upper="1e9" effort="1e9" velocity="1e9"/>'
    j0 = tree.joints[0]
    if j0.kind == "floating" and (not np.allclose(j0.R, np.eye(3)) or np.any(j0.p != 0)):
        raise InvalidInput("tree: a floating root placed away from the world frame has no URDF form (URDF's "
                           "root link moves from the world frame itself)")
    out = [f'<robot name="{name}">']
    jointed_root = tree.joints[0].kind not in ("fixed", "floating")
    if jointed_root:
        out.append('  <link name="world_anchor"><inertial><mass value="1e-9"/><inertia ixx="1e-12" ixy="0" '
                   'ixz="0" iyy="1e-12" iyz="0" izz="1e-12"/></inertial></link>')
    for i, (lk, j) in enumerate(zip(tree.links, tree.joints)):
        I = [float(x) for x in lk.inertia.ravel()]
        out.append(f'  <link name="{lk.name}"><inertial><origin xyz="{_fmt(lk.com)}" rpy="0 0 0"/>'
                   f'<mass value="{float(lk.mass)!r}"/><inertia ixx="{I[0]!r}" ixy="{I[1]!r}" ixz="{I[2]!r}" '
                   f'iyy="{I[4]!r}" iyz="{I[5]!r}" izz="{I[8]!r}"/></inertial></link>')
        par = tree.parent[i]
        if par < 0 and not jointed_root:
            continue
        parent = "world_anchor" if par < 0 else tree.links[par].name
        rpy = Rotation.from_matrix(j.R).as_euler("xyz")                 # extrinsic x, y, z = URDF rpy
        out.append(f'  <joint name="{lk.name}_joint" type="{j.kind}"><parent link="{parent}"/>'
                   f'<child link="{lk.name}"/><origin xyz="{_fmt(j.p)}" rpy="{_fmt(rpy)}"/>'
                   f'<axis xyz="{_fmt(j.axis)}"/>{limit if j.kind in ("revolute", "prismatic") else ""}'
                   f'<dynamics damping="{float(tree.damping[i])!r}"/></joint>')
    out.append("</robot>")
    return "\n".join(out) + "\n"


def _fmt(v) -> str:
    return " ".join(repr(float(x)) for x in v)
