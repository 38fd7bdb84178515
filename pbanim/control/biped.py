"""The planar 7-link biped of the characters lecture (SIMBICON's 2-D model), in Python and as URDF.

It lives beside its controller; :mod:`pbanim.models.biped` and :func:`pbanim.models.articulated.planar_biped`
re-export it with the other canonical models (the URDF copy is ``pbanim/models/urdf/planar_biped.urdf``).

Seven links — torso, two thighs, two shins, two feet — on a planar base: the torso rides on two sliders
(x forward, y up) and a hinge about z, so q = (x, y, φ_torso, θ_lhip, θ_lknee, θ_lankle, θ_rhip, θ_rknee,
θ_rankle) and nine degrees of freedom, six of them actuated. Every hinge turns about +z: a positive hip
angle swings the thigh forward, a negative knee angle bends the knee, a positive ankle angle lifts the
toes, a positive torso angle leans it back. At q = 0 the biped stands straight, soles on y = 0.

================  ========  ==========  ===================  =================================================
link              mass kg   length m    I_zz kg m²           placement
================  ========  ==========  ===================  =================================================
torso             70        0.48        1.344 (rod)          hip at the base origin, centre 0.24 m above it
thigh (×2)        5         0.45        0.0844 (rod)         hangs from the hip
shin (×2)         4         0.42        0.0588 (rod)         hangs from the knee
foot (×2)         1         0.20        0.0035 (box)         ankle 0.05 m above the sole, 0.05 m from the heel
================  ========  ==========  ===================  =================================================

Masses and lengths are those of the 2-D biped of Yin, Loken & van de Panne, "SIMBICON: Simple Biped
Locomotion Control", SIGGRAPH 2007, as we read the paper (70/5/4/1 kg; 0.48/0.45/0.42/0.2 m; its Table 1
holds the gaits' control parameters, see :mod:`.simbicon`); the moments of inertia are ours (uniform rods
and a 0.2 × 0.05 box), as is the ankle placement.
Contact is by four points: heel and toe of each foot (:func:`biped_contact_points`).
"""

from __future__ import annotations

import numpy as np

from ..articulated.tree import ArticulatedTree
from ..errors import check_number

__all__ = ["planar_biped", "biped_contact_points", "BIPED_JOINTS", "BIPED_SEGMENTS", "standing_state"]

# (mass kg, length m) per segment
BIPED_SEGMENTS = {"torso": (70.0, 0.48), "thigh": (5.0, 0.45), "shin": (4.0, 0.42), "foot": (1.0, 0.20)}
ANKLE_HEIGHT, HEEL = 0.05, 0.05
# generalized coordinate of each named joint
BIPED_JOINTS = {"base_x": 0, "base_y": 1, "torso": 2, "left_hip": 3, "left_knee": 4, "left_ankle": 5,
                "right_hip": 6, "right_knee": 7, "right_ankle": 8}


def _rod(mass: float, length: float) -> np.ndarray:
    izz = mass * length * length / 12.0
    return np.array([izz, 1e-3 * izz + 1e-6, izz])          # about z (the hinge) and x; tiny about the rod


def planar_biped(g: float = 9.81) -> ArticulatedTree:
    """The 9-DOF planar biped (x forward, y up, hinges about z; see the module docstring)."""
    g = check_number("g", g, low=0.0)
    tree = ArticulatedTree(gravity=(0.0, -g, 0.0))
    mt, lt = BIPED_SEGMENTS["torso"]
    mh, lh = BIPED_SEGMENTS["thigh"]
    ms, ls = BIPED_SEGMENTS["shin"]
    mf, lf = BIPED_SEGMENTS["foot"]
    hip = lh + ls + ANKLE_HEIGHT
    tiny = dict(mass=1e-6, inertia=np.full(3, 1e-9))            # the base's slides carry no real mass
    bx = tree.add("base_x", -1, "prismatic", axis=[1, 0, 0], p=[0, hip, 0], **tiny)
    by = tree.add("base_y", bx, "prismatic", axis=[0, 1, 0], **tiny)
    torso = tree.add("torso", by, "revolute", axis=[0, 0, 1], mass=mt, com=[0, lt / 2, 0], inertia=_rod(mt, lt))
    for side in ("left", "right"):
        thigh = tree.add(f"{side}_thigh", torso, "revolute", axis=[0, 0, 1], mass=mh, com=[0, -lh / 2, 0],
                         inertia=_rod(mh, lh))
        shin = tree.add(f"{side}_shin", thigh, "revolute", axis=[0, 0, 1], p=[0, -lh, 0], mass=ms,
                        com=[0, -ls / 2, 0], inertia=_rod(ms, ls))
        izz = mf * (lf ** 2 + ANKLE_HEIGHT ** 2) / 12.0
        tree.add(f"{side}_foot", shin, "revolute", axis=[0, 0, 1], p=[0, -ls, 0], mass=mf,
                 com=[lf / 2 - HEEL, -ANKLE_HEIGHT / 2, 0], inertia=np.array([izz, izz, izz]))
    return tree


def biped_contact_points(tree: ArticulatedTree) -> list:
    """Heel and toe of each foot: [(left_foot, heel), (left_foot, toe), (right_foot, heel), (right_foot, toe)]."""
    lf = BIPED_SEGMENTS["foot"][1]
    names = [lk.name for lk in tree.links]
    out = []
    for side in ("left", "right"):
        i = names.index(f"{side}_foot")
        out += [(i, np.array([-HEEL, -ANKLE_HEIGHT, 0.0])), (i, np.array([lf - HEEL, -ANKLE_HEIGHT, 0.0]))]
    return out


def standing_state(lean: float = 0.0, speed: float = 0.0) -> tuple[np.ndarray, np.ndarray]:
    """(q, q̇): standing straight with the soles on the ground, the torso leaned by ``lean`` (rad, forward
    positive) and the whole body moving forward at ``speed`` (m/s)."""
    q = np.zeros(9)
    q[BIPED_JOINTS["torso"]] = -check_number("lean", lean, low=-1.0, high=1.0)
    q[BIPED_JOINTS["left_hip"]] = q[BIPED_JOINTS["right_hip"]] = -q[BIPED_JOINTS["torso"]]
    qd = np.zeros(9)
    qd[0] = check_number("speed", speed, low=-5.0, high=5.0)
    return q, qd
