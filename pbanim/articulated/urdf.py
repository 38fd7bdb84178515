"""Loading a robot: URDF files to :class:`~pbanim.articulated.ArticulatedTree` (chapter 08).

URDF (the Unified Robot Description Format of ROS) describes a tree of ``<link>`` elements joined by
``<joint>`` elements. What this reader uses, with the standard library's XML parser:

* ``<link name>`` with ``<inertial>``: ``<origin xyz rpy>`` (the centre of mass and the axes of the inertia
  tensor in the link frame), ``<mass value>``, ``<inertia ixx ixy ixz iyy iyz izz>``;
* ``<joint name type>`` with ``<parent link>``, ``<child link>``, ``<origin xyz rpy>`` (the joint frame in
  the parent link's frame; the child's link frame is the joint frame), ``<axis xyz>`` (in the joint
  frame, default x), optional ``<dynamics damping>``; types ``revolute`` and ``continuous`` (both a
  revolute joint here: limits are not read), ``prismatic``, ``fixed`` and ``floating``.

The root link (the one that is no joint's child) hangs from the world by a fixed joint, or by a floating
joint with ``floating_base=True``. rpy = (roll, pitch, yaw) are fixed-axis rotations about x, then y, then
z: R = R_z(yaw) R_y(pitch) R_x(roll). A rotated inertial frame gives I_link = R I Rᵀ.

Anything else fails with :class:`~pbanim.errors.InvalidInput` naming the element: an unsupported joint type,
a link without ``<inertial>`` or ``<mass>``, a joint naming a missing link, a link with two parents, a
cycle, several roots, malformed numbers.
"""

from __future__ import annotations

import xml.etree.ElementTree as ET
from collections import deque

import numpy as np

from ..errors import InvalidInput
from .tree import ArticulatedTree

__all__ = ["load_urdf", "rpy_matrix"]

_TYPES = {"revolute": "revolute", "continuous": "revolute", "prismatic": "prismatic", "fixed": "fixed",
          "floating": "floating"}


def rpy_matrix(rpy) -> np.ndarray:
    """R = R_z(yaw) R_y(pitch) R_x(roll)."""
    r, p, y = (float(a) for a in rpy)
    cr, sr, cp, sp, cy, sy = np.cos(r), np.sin(r), np.cos(p), np.sin(p), np.cos(y), np.sin(y)
    return np.array([[cy * cp, cy * sp * sr - sy * cr, cy * sp * cr + sy * sr],
                     [sy * cp, sy * sp * sr + cy * cr, sy * sp * cr - cy * sr],
                     [-sp, cp * sr, cp * cr]])


def _floats(el, attr: str, n: int, default, where: str) -> np.ndarray:
    text = el.get(attr) if el is not None else None
    if text is None:
        return np.array(default, dtype=float)
    try:
        vals = np.array([float(x) for x in text.split()])
    except ValueError:
        raise InvalidInput(f"{where}: {attr}={text!r} must be {n} number{'s' if n > 1 else ''}") from None
    if vals.shape != (n,) or not np.all(np.isfinite(vals)):
        raise InvalidInput(f"{where}: {attr}={text!r} must be {n} finite number{'s' if n > 1 else ''}")
    return vals


def _origin(el, where):
    o = el.find("origin") if el is not None else None
    return _floats(o, "xyz", 3, [0, 0, 0], where), rpy_matrix(_floats(o, "rpy", 3, [0, 0, 0], where))


def _inertial(link) -> tuple:
    name = link.get("name")
    where = f"<link name={name!r}>"
    inert = link.find("inertial")
    if inert is None or inert.find("mass") is None:
        raise InvalidInput(f"{where} has no <inertial> with a <mass>: every link of a dynamic model needs one")
    mass = _floats(inert.find("mass"), "value", 1, [np.nan], where + " <mass>")[0]
    com, R = _origin(inert, where + " <inertial><origin>")
    iel = inert.find("inertia")
    if iel is None:
        raise InvalidInput(f"{where} <inertial> has no <inertia>")
    c = {k: _floats(iel, k, 1, [0.0], where + " <inertia>")[0] for k in ("ixx", "ixy", "ixz", "iyy", "iyz", "izz")}
    I = np.array([[c["ixx"], c["ixy"], c["ixz"]], [c["ixy"], c["iyy"], c["iyz"]], [c["ixz"], c["iyz"], c["izz"]]])
    return mass, com, R @ I @ R.T


def load_urdf(source: str, *, floating_base: bool = False, gravity=(0.0, 0.0, -9.81)) -> ArticulatedTree:
    """Build an :class:`ArticulatedTree` from a URDF file path or an XML string (see the module docstring).

    Links are numbered breadth-first from the root; ``tree.links[i].name`` is the URDF link name and
    ``tree.joint_names[i]`` the joint above it ("<world>" for the root).
    """
    text = str(source)
    try:
        root = ET.fromstring(text) if text.lstrip().startswith("<") else ET.parse(text).getroot()
    except ET.ParseError as exc:
        raise InvalidInput(f"source is not well-formed URDF XML: {exc}") from None
    except OSError as exc:
        raise InvalidInput(f"source: cannot read the URDF file {text!r}: {exc.strerror}") from None
    if root.tag != "robot":
        raise InvalidInput(f"source: the root element must be <robot>, got <{root.tag}>")
    links = {}
    for lk in root.findall("link"):
        name = lk.get("name")
        if not name or name in links:
            raise InvalidInput(f"<link name={name!r}>: every link needs a unique name")
        links[name] = lk
    children: dict[str, list] = {n: [] for n in links}
    parent_of: dict[str, str] = {}
    for j in root.findall("joint"):
        jname, jtype = j.get("name"), j.get("type")
        where = f"<joint name={jname!r}>"
        if jtype not in _TYPES:
            raise InvalidInput(f"{where}: joint type {jtype!r} is not supported; supported: {sorted(_TYPES)}")
        pel, cel = j.find("parent"), j.find("child")
        p, c = (pel.get("link") if pel is not None else None), (cel.get("link") if cel is not None else None)
        for role, ln in (("parent", p), ("child", c)):
            if ln not in links:
                raise InvalidInput(f"{where}: {role} link {ln!r} is not a <link> of the robot")
        if c in parent_of:
            raise InvalidInput(f"{where}: link {c!r} already has the parent {parent_of[c]!r} (a link has one parent)")
        parent_of[c] = p
        children[p].append(j)
    roots = [n for n in links if n not in parent_of]
    if len(roots) != 1:
        raise InvalidInput(f"source: the links must form one tree with one root, found roots {roots} "
                           "(none: a cycle)")
    tree = ArticulatedTree(gravity=gravity)
    tree.joint_names = []
    index = {}
    mass, com, I = _inertial(links[roots[0]])
    index[roots[0]] = tree.add(roots[0], -1, "floating" if floating_base else "fixed", mass=mass, com=com, inertia=I)
    tree.joint_names.append("<world>")
    queue = deque([roots[0]])
    while queue:                                  # each link is queued once: at most len(links) rounds
        name = queue.popleft()
        for j in children[name]:
            child = j.find("child").get("link")
            where = f"<joint name={j.get('name')!r}>"
            p, R = _origin(j, where + " <origin>")
            axis = _floats(j.find("axis"), "xyz", 3, [1.0, 0.0, 0.0], where + " <axis>")
            dyn = j.find("dynamics")
            damping = _floats(dyn, "damping", 1, [0.0], where + " <dynamics>")[0]
            mass, com, I = _inertial(links[child])
            index[child] = tree.add(child, index[name], _TYPES[j.get("type")], axis=axis, R=R, p=p, mass=mass,
                                    com=com, inertia=I, damping=damping)
            tree.joint_names.append(j.get("name"))
            queue.append(child)
    if len(index) != len(links):
        missing = sorted(set(links) - set(index))
        raise InvalidInput(f"source: links {missing} are not reachable from the root {roots[0]!r} (a cycle)")
    return tree
