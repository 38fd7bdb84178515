"""The 3-D biped of the characters lecture (SIMBICON's 3-D model): pelvis, torso, thighs, shins, feet.

Axes: x forward, y to the left, z up (gravity −9.81 ẑ). The pelvis is the floating root (q: unit
quaternion w, x, y, z and position; q̇: the pelvis's angular and linear velocity in its own axes); the
torso is welded to it (a fixed joint: one trunk, as the planar biped's torso is one link — the stance-hip
rule then balances the whole trunk, see :mod:`.simbicon3d`). Each hip is a ball: three revolutes about
z (yaw), x (roll), −y (pitch), the first two through massless, zero-length links; each knee a hinge about
−y; each ankle a universal joint, −y (pitch) then x (roll). Sagittal joints turn about −y so that the
signs are the planar biped's and the paper's tables': a positive hip angle swings the thigh forward, a
negative knee angle bends the knee, a positive ankle angle lifts the toes. At q = neutral the biped stands
straight, soles on z = 0 (:func:`standing_state3d`). 6 + 2 × (3 + 1 + 2) = 18 velocity coordinates.

================  ========  =========================  =======================================================
segment           mass kg   size m                     placement
================  ========  =========================  =======================================================
pelvis            9.94      box 0.20 × 0.30 × 0.15     root; hips at (0, ±0.09, −0.075)
torso             37.52     box 0.25 × 0.36 × 0.70     welded on the pelvis top (z = +0.075), centre 0.30 above
thigh (×2)        7.00      rod 0.43, radius 0.06      hangs from the hip
shin (×2)         3.26      rod 0.43, radius 0.05      hangs from the knee
foot (×2)         1.02      box 0.25 × 0.10 × 0.06     ankle 0.06 above the sole, 0.06 in front of the heel
================  ========  =========================  =======================================================

Total mass 70 kg. These are **ours**: the 3-D section of Yin, Loken & van de Panne, "SIMBICON", SIGGRAPH
2007 gives its model's segments but we could not find its masses and lengths in a source we could read,
so the masses are Winter's segment fractions of a 70 kg body (foot 0.0145, shank 0.0465, thigh 0.100,
pelvis 0.142, the head, arms and trunk above it 0.536) and the lengths his fractions of a 1.75 m stature
(thigh 0.245, shank 0.246, foot 0.152 → 0.25; Winter, *Biomechanics and Motor Control of Human Movement*,
4th ed. 2009, Table 4.1); the inertias are those of the uniform boxes and rods. Contact is by the four
corners of each sole (:func:`biped3d_contact_points`).

Notation: q, q̇ generalized coordinates and velocities; M total mass; the oracle of the standing tests
(ORACLES F17): the total momentum changes by h M g plus the contact impulses in one step, and a biped
standing still carries M g on its soles.
"""

from __future__ import annotations

import numpy as np

from ..articulated.tree import ArticulatedTree
from ..articulated.specs import Tree
from ..contracts import Real, contract

__all__ = ["biped3d", "biped3d_contact_points", "standing_state3d", "BIPED3D_SEGMENTS", "BIPED3D_JOINTS",
           "PELVIS_HALF_HEIGHT", "HIP_OFFSET", "FOOT"]

M_BODY = 70.0
# (mass kg, (x, y, z) extents m) per segment; thigh and shin: (mass, (radius, radius, length))
BIPED3D_SEGMENTS = {"pelvis": (0.142 * M_BODY, (0.20, 0.30, 0.15)), "torso": (0.536 * M_BODY, (0.25, 0.36, 0.70)),
                    "thigh": (0.100 * M_BODY, (0.06, 0.06, 0.43)), "shin": (0.0465 * M_BODY, (0.05, 0.05, 0.43)),
                    "foot": (0.0145 * M_BODY, (0.25, 0.10, 0.06))}
PELVIS_HALF_HEIGHT = 0.075
HIP_OFFSET = 0.09                       # lateral distance of each hip from the pelvis centre
FOOT = {"length": 0.25, "width": 0.10, "ankle_height": 0.06, "heel": 0.06}
TORSO_COM = 0.30
SIDES = ("left", "right")
# per side, the actuated coordinates in q order: hip yaw, roll, pitch; knee; ankle pitch, roll
LEG_JOINTS = ("hip_z", "hip_x", "hip_y", "knee", "ankle_y", "ankle_x")
# index of each named joint in q̇ (the floating pelvis takes 0..5); in q add 1 (the quaternion has 4 numbers)
BIPED3D_JOINTS = {f"{s}_{j}": 6 + 6 * k + i for k, s in enumerate(SIDES) for i, j in enumerate(LEG_JOINTS)}
_PITCH = (0.0, -1.0, 0.0)


def _box(mass: float, ext) -> np.ndarray:
    a, b, c = ext
    return mass / 12.0 * np.array([b * b + c * c, a * a + c * c, a * a + b * b])


def _rod(mass: float, ext) -> np.ndarray:
    r, _, length = ext
    side = mass * (3 * r * r + length * length) / 12.0
    return np.array([side, side, 0.5 * mass * r * r])


def leg_length() -> float:
    """Hip to sole, standing straight: thigh + shin + ankle height (m)."""
    return BIPED3D_SEGMENTS["thigh"][1][2] + BIPED3D_SEGMENTS["shin"][1][2] + FOOT["ankle_height"]


@contract(g=Real(ge=0))
def biped3d(g: float = 9.81) -> ArticulatedTree:
    """The 3-D biped (module docstring): links pelvis, torso, then per side the hip's two massless links,
    thigh, shin, the ankle's massless link and the foot; 18 velocity coordinates."""
    tree = ArticulatedTree(gravity=(0.0, 0.0, -float(g)))
    mp, ep = BIPED3D_SEGMENTS["pelvis"]
    pelvis = tree.add("pelvis", -1, "floating", mass=mp, inertia=_box(mp, ep))
    mt, et = BIPED3D_SEGMENTS["torso"]
    tree.add("torso", pelvis, "fixed", p=[0, 0, PELVIS_HALF_HEIGHT], mass=mt, com=[0, 0, TORSO_COM],
             inertia=_box(mt, et))
    mh, eh = BIPED3D_SEGMENTS["thigh"]
    ms, es = BIPED3D_SEGMENTS["shin"]
    mf, ef = BIPED3D_SEGMENTS["foot"]
    for side in SIDES:
        y = HIP_OFFSET if side == "left" else -HIP_OFFSET
        a = tree.add(f"{side}_hip_z", pelvis, "revolute", axis=[0, 0, 1], p=[0, y, -PELVIS_HALF_HEIGHT], mass=0.0)
        b = tree.add(f"{side}_hip_x", a, "revolute", axis=[1, 0, 0], mass=0.0)
        thigh = tree.add(f"{side}_thigh", b, "revolute", axis=_PITCH, mass=mh, com=[0, 0, -eh[2] / 2],
                         inertia=_rod(mh, eh))
        shin = tree.add(f"{side}_shin", thigh, "revolute", axis=_PITCH, p=[0, 0, -eh[2]], mass=ms,
                        com=[0, 0, -es[2] / 2], inertia=_rod(ms, es))
        c = tree.add(f"{side}_ankle_y", shin, "revolute", axis=_PITCH, p=[0, 0, -es[2]], mass=0.0)
        tree.add(f"{side}_foot", c, "revolute", axis=[1, 0, 0], mass=mf,
                 com=[FOOT["length"] / 2 - FOOT["heel"], 0, -FOOT["ankle_height"] / 2], inertia=_box(mf, ef))
    return tree


@contract(tree=Tree())
def biped3d_contact_points(tree: ArticulatedTree) -> list:
    """The four sole corners of each foot, left foot first: (link, point in the foot's frame) for the heel's
    two corners (y = +w/2, −w/2), then the toe's."""
    names = [lk.name for lk in tree.links]
    x0, x1 = -FOOT["heel"], FOOT["length"] - FOOT["heel"]
    w, z = FOOT["width"] / 2, -FOOT["ankle_height"]
    out = []
    for side in SIDES:
        i = names.index(f"{side}_foot")
        out += [(i, np.array([x, y, z])) for x in (x0, x1) for y in (w, -w)]
    return out


@contract(height=Real(ge=-0.5, le=0.5), speed=Real(ge=-3, le=3), clearance=Real(ge=0, le=0.1))
def standing_state3d(height: float = 0.0, speed: float = 0.0, clearance: float = 1e-4):
    """(q, q̇): standing straight, soles ``clearance`` above the ground z = ``height``, moving forward (+x) at
    ``speed`` m/s."""
    tree_q = np.zeros(7 + 12)
    tree_q[0] = 1.0
    tree_q[6] = height + clearance + leg_length() + PELVIS_HALF_HEIGHT
    qd = np.zeros(18)
    qd[3] = speed                                     # the pelvis's own x axis is the world's (identity quaternion)
    return tree_q, qd
