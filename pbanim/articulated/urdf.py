"""Loading a robot: URDF files to :class:`~pbanim.articulated.ArticulatedTree` (chapter 08).

URDF (the Unified Robot Description Format of ROS) describes a tree of ``<link>`` elements joined by
``<joint>`` elements. What this reader uses, with the standard library's XML parser:

* ``<link name>`` with an optional ``<inertial>``: ``<origin xyz rpy>`` (the centre of mass and the axes of
  the inertia tensor in the link frame), ``<mass value>``, ``<inertia ixx ixy ixz iyy iyz izz>``. A link
  without ``<inertial>`` is massless (a frame, a sensor mount, a root fixed to the world);
* ``<joint name type>`` with ``<parent link>``, ``<child link>``, ``<origin xyz rpy>`` (the joint frame in
  the parent link's frame; the child's link frame is the joint frame), ``<axis xyz>`` (in the joint
  frame, default x), ``<dynamics damping>``, ``<limit lower upper effort velocity>`` and ``<mimic>``; types
  ``revolute``, ``continuous`` (a revolute joint with no position limits: its angle is not wrapped),
  ``prismatic``, ``fixed`` and ``floating``.

Links welded by ``fixed`` joints are merged into one body, as Pinocchio does: masses add, the centre of
mass is the mass-weighted mean and the inertia about it is combined by the parallel-axis theorem,
I = Σ (R I_k Rᵀ + m_k(|d_k|² 1 − d_k d_kᵀ)) with d_k the offset of part k's centre of mass (ORACLES I7:
a weld equals its composite). The merged link's frame is kept in ``tree.frames[name]`` = (body, R, p).
A model in which a movable joint then moves no inertia (a massless leaf link) is refused by
:class:`~pbanim.articulated.dynamics.SingularJointInertia` naming that joint.

``<limit>``: revolute and prismatic joints get the position limits lower ≤ q ≤ upper (an attribute left
out, or lower > upper as some files write it, means no limit on that side: the format's default 0 would
weld the joint), and every joint its effort and velocity limits (module :mod:`.tree`). A ``<mimic>``
relation q_i = multiplier q_j + offset is kept in ``tree.mimic`` but not enforced (Pinocchio's default
too): the joints move independently.

The root link (the one that is no joint's child) hangs from the world by a fixed joint, or by a floating
joint with ``floating_base=True``; a ``floating`` joint from a fixed root (a file's "world" link) makes its
child a free body of the world. rpy = (roll, pitch, yaw) are fixed-axis rotations about x, then y, then
z: R = R_z(yaw) R_y(pitch) R_x(roll). A rotated inertial frame gives I_link = R I Rᵀ.

Anything else fails with :class:`~pbanim.errors.InvalidInput` naming the element: an unsupported joint
type, an ``<inertial>`` without ``<mass>`` or ``<inertia>``, a negative mass, an inertia no body can have
(not positive semi-definite, I₁ + I₂ < I₃), a joint naming a missing link, a link with two parents, a cycle,
several roots, malformed numbers.
"""

from __future__ import annotations

import math
import xml.etree.ElementTree as ET
from collections import deque

import numpy as np

from ..contracts import Array, Either, Flag, PathLike, Real, Text, contract
from ..errors import InvalidInput
from ..rigid.inertia import parallel_axis
from .dynamics import check_articulated_inertia
from ..rigid.admissible import Inertia
from .specs import UnitAxis, check_with
from .tree import ArticulatedTree

__all__ = ["load_urdf", "rpy_matrix"]

_TYPES = ("revolute", "continuous", "prismatic", "fixed", "floating")
_MASS, _INERTIA, _AXIS = Real(ge=0), Inertia(definite=False), UnitAxis()
_DAMPING, _RATE = Real(ge=0), Real(ge=0, finite=False)


@contract(rpy=Array((3,)))
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


def _number(el, attr: str, default: float, where: str) -> float:
    """One attribute as a float; ``inf`` and ``-inf`` are read too (limits), NaN is not."""
    text = el.get(attr) if el is not None else None
    if text is None:
        return default
    try:
        v = float(text)
    except ValueError:
        raise InvalidInput(f"{where}: {attr}={text!r} must be a number") from None
    if v != v:
        raise InvalidInput(f"{where}: {attr}={text!r} must be a number, not NaN")
    return v


def _origin(el, where):
    o = el.find("origin") if el is not None else None
    return _floats(o, "xyz", 3, [0, 0, 0], where), rpy_matrix(_floats(o, "rpy", 3, [0, 0, 0], where))


def _inertial(link) -> tuple:
    """(mass, centre of mass, inertia about it) in the link frame; zeros for a link without <inertial>."""
    where = f"<link name={link.get('name')!r}>"
    inert = link.find("inertial")
    if inert is None:
        return 0.0, np.zeros(3), np.zeros((3, 3))
    if inert.find("mass") is None or inert.find("inertia") is None:
        raise InvalidInput(f"{where} <inertial> needs a <mass> and an <inertia> (the format requires both)")
    mel = inert.find("mass")
    if mel.get("value") is None:
        raise InvalidInput(f"{where} <mass> has no value")
    mass = check_with(_MASS, where + " <mass>", "value", _number(mel, "value", math.nan, where + " <mass>"))
    com, R = _origin(inert, where + " <inertial><origin>")
    iel = inert.find("inertia")
    c = {k: _floats(iel, k, 1, [0.0], where + " <inertia>")[0] for k in ("ixx", "ixy", "ixz", "iyy", "iyz", "izz")}
    I = np.array([[c["ixx"], c["ixy"], c["ixz"]], [c["ixy"], c["iyy"], c["iyz"]], [c["ixz"], c["iyz"], c["izz"]]])
    check_with(_INERTIA, where + " <inertia>", "the tensor", I)
    return mass, com, R @ I @ R.T


def _combine(parts) -> tuple:
    """(mass, centre of mass, inertia about it) of rigidly joined parts, each (m, c, I) in one frame."""
    if len(parts) == 1:
        return parts[0]
    m = np.array([p[0] for p in parts])
    total = float(m.sum())
    if total == 0.0:
        return 0.0, np.zeros(3), sum(p[2] for p in parts)
    cs = np.array([p[1] for p in parts])
    com = m @ cs / total
    I = parallel_axis(np.array([p[2] for p in parts]), m, cs - com).sum(axis=0)
    return total, com, 0.5 * (I + I.T)


def _parse(source) -> ET.Element:
    text = str(source)
    try:
        root = ET.fromstring(text) if text.lstrip().startswith("<") else ET.parse(text).getroot()
    except ET.ParseError as exc:
        raise InvalidInput(f"load_urdf: source is not well-formed URDF XML: {exc}") from None
    except OSError as exc:
        raise InvalidInput(f"load_urdf: source: cannot read the URDF file {text!r}: {exc.strerror}") from None
    if root.tag != "robot":
        raise InvalidInput(f"load_urdf: source: the root element must be <robot>, got <{root.tag}>")
    return root


def _joint(j, links) -> dict:
    """One <joint> element read and checked: name, type, parent, child, placement, axis, damping, limits."""
    jname, jtype = j.get("name"), j.get("type")
    where = f"<joint name={jname!r}>"
    if jtype not in _TYPES:
        raise InvalidInput(f"{where}: joint type {jtype!r} is not supported; supported: {sorted(_TYPES)}")
    pel, cel = j.find("parent"), j.find("child")
    p, c = (pel.get("link") if pel is not None else None), (cel.get("link") if cel is not None else None)
    for role, ln in (("parent", p), ("child", c)):
        if ln not in links:
            raise InvalidInput(f"{where}: {role} link {ln!r} is not a <link> of the robot")
    xyz, R = _origin(j, where + " <origin>")
    out = dict(name=jname, type=jtype, parent=p, child=c, p=xyz, R=R, axis=np.array([1.0, 0.0, 0.0]),
               damping=0.0, lower=-math.inf, upper=math.inf, effort=math.inf, velocity=math.inf)
    if jtype in ("revolute", "continuous", "prismatic"):
        out["axis"] = check_with(_AXIS, where + " <axis>", "xyz",
                                 _floats(j.find("axis"), "xyz", 3, [1.0, 0.0, 0.0], where + " <axis>"))
    dyn = j.find("dynamics")
    out["damping"] = check_with(_DAMPING, where + " <dynamics>", "damping", _number(dyn, "damping", 0.0, where))
    lim = j.find("limit")
    if lim is not None:
        w = where + " <limit>"
        out["effort"] = check_with(_RATE, w, "effort", _number(lim, "effort", math.inf, w))
        out["velocity"] = check_with(_RATE, w, "velocity", _number(lim, "velocity", math.inf, w))
        lo, hi = _number(lim, "lower", -math.inf, w), _number(lim, "upper", math.inf, w)
        if jtype in ("revolute", "prismatic") and lo <= hi:       # lower > upper: no limit (as pybullet)
            out["lower"], out["upper"] = lo, hi
    mim = j.find("mimic")
    if mim is not None:
        out["mimic"] = (mim.get("joint"), _number(mim, "multiplier", 1.0, where + " <mimic>"),
                        _number(mim, "offset", 0.0, where + " <mimic>"))
    return out


@contract(source=Either(Text(nonempty=True), PathLike()), floating_base=Flag(), gravity=Array((3,)))
def load_urdf(source, *, floating_base: bool = False, gravity=(0.0, 0.0, -9.81)) -> ArticulatedTree:
    """Build an :class:`ArticulatedTree` from a URDF file path or an XML string (see the module docstring).

    Bodies are numbered breadth-first from the root; ``tree.links[i].name`` is the URDF name of the body's
    first link, ``tree.joint_names[i]`` the joint above it ("<world>" for the root), ``tree.frames`` the
    links merged into bodies by fixed joints and ``tree.mimic`` the mimic relations.
    """
    root = _parse(source)
    links = {}
    for lk in root.findall("link"):
        name = lk.get("name")
        if not name or name in links:
            raise InvalidInput(f"<link name={name!r}>: every link needs a unique name")
        links[name] = lk
    children: dict[str, list] = {n: [] for n in links}
    parent_of: dict[str, str] = {}
    for j in root.findall("joint"):
        jt = _joint(j, links)
        if jt["child"] in parent_of:
            raise InvalidInput(f"<joint name={jt['name']!r}>: link {jt['child']!r} already has the parent "
                               f"{parent_of[jt['child']]!r} (a link has one parent)")
        parent_of[jt["child"]] = jt["parent"]
        children[jt["parent"]].append(jt)
    roots = [n for n in links if n not in parent_of]
    if len(roots) != 1:
        raise InvalidInput(f"load_urdf: source: the links must form one tree with one root, found roots {roots} "
                           "(none: a cycle)")
    return _build(links, children, roots[0], floating_base, gravity)


def _build(links, children, root_name, floating_base, gravity) -> ArticulatedTree:
    """Bodies breadth-first from the root: a movable joint starts a body, a fixed one welds its child into the
    body of its parent (placement composed, inertia merged); then the tree, then the inertia check."""
    bodies = [dict(name=root_name, parent=-1, kind="floating" if floating_base else "fixed", joint=None,
                   parts=[_inertial(links[root_name])])]
    place = {root_name: (0, np.eye(3), np.zeros(3))}          # link → (body, R, p): its frame in the body's
    frames, mimic = {}, {}
    queue = deque([root_name])
    while queue:                                  # each link is queued once: at most len(links) rounds
        name = queue.popleft()
        b, Rb, pb = place[name]
        for jt in children[name]:
            child = jt["child"]
            R, p = Rb @ jt["R"], pb + Rb @ jt["p"]            # the joint frame in body b's frame
            m, c, I = _inertial(links[child])
            if jt["type"] == "fixed":
                place[child] = (b, R, p)
                frames[child] = (b, R, p)
                bodies[b]["parts"].append((m, p + R @ c, R @ I @ R.T))
            else:
                place[child] = (len(bodies), np.eye(3), np.zeros(3))
                bodies.append(dict(name=child, parent=b, kind=jt["type"], joint=jt, R=R, p=p, parts=[(m, c, I)]))
                if "mimic" in jt:
                    mimic[jt["name"]] = jt["mimic"]
            queue.append(child)
    if len(place) != len(links):
        missing = sorted(set(links) - set(place))
        raise InvalidInput(f"load_urdf: source: links {missing} are not reachable from the root {root_name!r} "
                           "(a cycle)")
    tree = ArticulatedTree(gravity=np.asarray(gravity, dtype=float))
    for bd in bodies:
        mass, com, I = _combine(bd["parts"])
        jt = bd["joint"]
        if jt is None:
            tree.add(bd["name"], -1, bd["kind"], mass=mass, com=com, inertia=I, joint="<world>")
            continue
        parent = bd["parent"]
        if jt["type"] == "floating":            # from a fixed root (a "world" link): a free body of the world
            if parent != 0 or floating_base:
                raise InvalidInput(f"<joint name={jt['name']!r}>: a floating joint must hang from the fixed root "
                                   "link (the world); for a free root use floating_base=True")
            parent = -1
        tree.add(bd["name"], parent, jt["type"], axis=jt["axis"], R=bd["R"], p=bd["p"], mass=mass, com=com,
                 inertia=I, damping=jt["damping"], lower=jt["lower"], upper=jt["upper"], effort=jt["effort"],
                 velocity=jt["velocity"], joint=jt["name"])
    tree.frames, tree.mimic = frames, mimic
    check_articulated_inertia(tree)
    return tree
