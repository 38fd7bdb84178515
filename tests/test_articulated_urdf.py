"""URDF as the format defines it, and nothing silent on bad input (chapter 08; issue 27; ORACLES I2, I7, G3).

Real robot files load: massless links and links without ``<inertial>``, links welded by fixed joints (merged
into their body), ``<limit>`` and continuous joints; every URDF of ``pybullet_data`` whose joints Pinocchio
and pbanim both model is checked against Pinocchio's RNEA, CRBA and ABA.
"""

import math
import os
import xml.etree.ElementTree as ET

import numpy as np
import pytest

from pbanim.articulated import (ArticulatedSystem, ArticulatedTree, Joint, Link, RigidJoint, SingularJointInertia, aba,
                                aba_batch, aba_fast, crba, crba_batch, kinetic_energy, load_urdf, rnea, rnea_batch)
from pbanim.articulated.contact import ArticulatedContact
from pbanim.errors import InvalidInput, NonFiniteResult, PbanimError, SingularChartError

INERTIAL = ('<inertial><origin xyz="{c}" rpy="{rpy}"/><mass value="{m}"/><inertia ixx="{i[0]}" ixy="0" ixz="0" '
            'iyy="{i[1]}" iyz="0" izz="{i[2]}"/></inertial>')


def _link(name, m=None, c="0 0 0", i=(0.1, 0.1, 0.1), rpy="0 0 0"):
    body = "" if m is None else INERTIAL.format(c=c, m=m, i=i, rpy=rpy)
    return f'<link name="{name}">{body}</link>'


def _joint(name, kind, parent, child, xyz="0 0 0", rpy="0 0 0", axis="0 0 1", extra=""):
    return (f'<joint name="{name}" type="{kind}"><parent link="{parent}"/><child link="{child}"/>'
            f'<origin xyz="{xyz}" rpy="{rpy}"/><axis xyz="{axis}"/>{extra}</joint>')


def _robot(*parts):
    return '<robot name="r">' + "".join(parts) + "</robot>"


# --- pybullet_data against Pinocchio ----------------------------------------------------------------------
def _one_dof_or_fixed(path) -> bool:
    try:
        root = ET.parse(path).getroot()
    except ET.ParseError:
        return False
    kinds = {j.get("type") for j in root.iter("joint") if j.find("parent") is not None}
    return kinds <= {"revolute", "continuous", "prismatic", "fixed"}


def _compare(pin, model, tree, seed):
    """Largest relative difference of RNEA, CRBA and ABA between Pinocchio's model and the tree at a random
    state (joints matched by name; a continuous joint is (cos θ, sin θ) in Pinocchio's q; its ABA has no
    joint damping, so −b q̇ goes into its τ)."""
    rng = np.random.default_rng(seed)
    q, qd, tau = rng.uniform(-1, 1, tree.nq), rng.normal(size=tree.nv), rng.normal(size=tree.nv)
    qp, vmap = pin.neutral(model), np.zeros(tree.nv, dtype=int)
    for i, name in enumerate(tree.joint_names):
        if tree.joints[i].kind == "fixed":
            continue
        jm = model.joints[model.getJointId(name)]
        k = tree._q_index[i].start
        vmap[tree._v_index[i].start] = jm.idx_v
        qp[jm.idx_q:jm.idx_q + jm.nq] = (math.cos(q[k]), math.sin(q[k])) if jm.nq == 2 else q[k]
    vp, tp, bp = np.zeros(model.nv), np.zeros(model.nv), np.zeros(model.nv)
    vp[vmap], tp[vmap], bp[vmap] = qd, tau, tree.arrays()["damping"]
    data = model.createData()
    M = pin.crba(model, data, qp)
    M = (np.triu(M) + np.triu(M, 1).T)[np.ix_(vmap, vmap)]
    pairs = [(rnea(tree, q, qd, tau), pin.rnea(model, data, qp, vp, tp)[vmap]), (crba(tree, q), M),
             (aba(tree, q, qd, tau), pin.aba(model, data, qp, vp, tp - bp * vp)[vmap])]
    return max(float(np.abs(a - b).max(initial=0.0)) / (1.0 + float(np.abs(b).max(initial=0.0))) for a, b in pairs)


def test_every_pybullet_urdf_pinocchio_loads_loads_and_matches_pinocchio():
    # ORACLES I2: RNEA, CRBA and ABA equal Pinocchio's (fixed base) to 1e-9 on every URDF of pybullet_data whose
    # joints are one-degree-of-freedom or fixed and that Pinocchio loads; the only refusals allowed are
    # inertias no body can have, named by link. Measured: 1091 files found, 1087 loaded by Pinocchio, 1077 by
    # pbanim, all 1077 matched (largest difference ~1e-15); the 10 refused break I1 + I2 >= I3 (xarm6 link2
    # and link3, mini_cheetah's thigh_fr, TwoJointRobot's link_1) by 0.1-4 %.
    pin = pytest.importorskip("pinocchio")
    pybullet_data = pytest.importorskip("pybullet_data")
    top = pybullet_data.getDataPath()
    paths = sorted(os.path.join(d, f) for d, _, fs in os.walk(top) for f in fs if f.endswith(".urdf"))
    counts = dict(found=0, pinocchio=0, pbanim=0, matched=0, refused=0)
    worst, refusals = 0.0, []
    for path in paths:
        if not _one_dof_or_fixed(path):
            continue
        counts["found"] += 1
        try:
            model = pin.buildModelFromUrdf(path)
        except Exception:  # noqa: BLE001 - Pinocchio's own parser refuses the file: not compared
            continue
        counts["pinocchio"] += 1
        try:
            tree = load_urdf(path)
        except PbanimError as exc:
            counts["refused"] += 1
            refusals.append((os.path.relpath(path, top), str(exc)))
            continue
        counts["pbanim"] += 1
        assert (tree.nv, len([j for j in tree.joints if j.kind != "fixed"])) == (model.nv, model.njoints - 1), path
        err = _compare(pin, model, tree, counts["pbanim"])
        worst = max(worst, err)
        counts["matched"] += err < 1e-9
        assert err < 1e-9, (path, err)
    print(f"pybullet_data URDFs: {counts}, largest difference {worst:.2e}")
    for rel, msg in refusals:
        assert isinstance(msg, str) and msg.startswith("<link name=") and "I1 + I2 >= I3" in msg, (rel, msg)
    assert counts["pinocchio"] > 1000
    assert counts["matched"] == counts["pbanim"] == counts["pinocchio"] - counts["refused"]
    assert counts["refused"] <= 10


# --- what real files contain --------------------------------------------------------------------------
def test_fixed_joints_merge_links_into_their_body_by_the_parallel_axis_theorem():
    # ORACLES I7: a body welded from parts equals one link with the composite inertia (masses add, weighted
    # centre of mass, parallel-axis inertia). The URDF: a massless root, a hinge to "arm", a weld to a
    # rotated, offset "hand", a massless "sensor" frame on it; the hand-built tree has one link.
    text = _robot(_link("base"), _link("arm", 2.0, "0 0 -0.5", (0.2, 0.2, 0.05)),
                  _link("hand", 1.0, "0.1 0 0", (0.01, 0.02, 0.03), rpy="0.3 0 0"), _link("sensor"),
                  _joint("hinge", "revolute", "base", "arm", axis="0 1 0",
                         extra='<limit lower="-1" upper="1" effort="5" velocity="2"/>'),
                  _joint("weld", "fixed", "arm", "hand", xyz="0 0 -1", rpy="0 0 0.5"),
                  _joint("mount", "fixed", "hand", "sensor", xyz="0.2 0 0"))
    tree = load_urdf(text)
    assert [lk.name for lk in tree.links] == ["base", "arm"] and tree.joint_names == ["<world>", "hinge"]
    assert set(tree.frames) == {"hand", "sensor"} and tree.frames["sensor"][0] == 1
    np.testing.assert_allclose(tree.frames["sensor"][2], [0.2 * math.cos(0.5), 0.2 * math.sin(0.5), -1.0], atol=1e-15)
    # the composite by hand: hand's centre of mass and inertia in arm's frame
    Rz = np.array([[math.cos(0.5), -math.sin(0.5), 0], [math.sin(0.5), math.cos(0.5), 0], [0, 0, 1]])
    Rx = np.array([[1, 0, 0], [0, math.cos(0.3), -math.sin(0.3)], [0, math.sin(0.3), math.cos(0.3)]])
    ch = np.array([0, 0, -1.0]) + Rz @ [0.1, 0, 0]
    Ih = Rz @ Rx @ np.diag([0.01, 0.02, 0.03]) @ Rx.T @ Rz.T
    ca = np.array([0, 0, -0.5])
    c = (2.0 * ca + 1.0 * ch) / 3.0

    def shift(I, m, d):
        return I + m * (d @ d * np.eye(3) - np.outer(d, d))

    I = shift(np.diag([0.2, 0.2, 0.05]), 2.0, ca - c) + shift(Ih, 1.0, ch - c)
    ref = ArticulatedTree()
    ref.add("arm", -1, "revolute", axis=[0, 1, 0], mass=3.0, com=c, inertia=I)
    assert tree.links[1].mass == 3.0
    np.testing.assert_allclose(tree.links[1].com, c, atol=1e-15)
    np.testing.assert_allclose(tree.links[1].inertia, I, atol=1e-14)
    q, qd = np.array([0.4]), np.array([-1.3])
    assert aba(tree, q, qd, [0.7]) == pytest.approx(aba(ref, q, qd, [0.7]), rel=3e-14)
    j = tree.joints[1]
    assert (j.kind, j.lower, j.upper, j.effort, j.velocity) == ("revolute", -1.0, 1.0, 5.0, 2.0)


def test_a_joint_that_moves_no_inertia_is_named():
    # a massless leaf on a hinge, and a massless link between two hinges about one axis (its joint moves
    # nothing the next joint does not): D = SᵀI^A S = 0, refused by name (ABA would divide by zero)
    leaf = _robot(_link("base", 1.0), _link("arm", 1.0, "0 0 -0.5"), _link("tip"),
                  _joint("shoulder", "revolute", "base", "arm", axis="0 1 0"),
                  _joint("wrist", "revolute", "arm", "tip", axis="0 1 0"))
    with pytest.raises(SingularJointInertia, match="<joint name='wrist'> \\(revolute, above link 'tip'\\) moves no"):
        load_urdf(leaf)
    coaxial = _robot(_link("base", 1.0), _link("gimbal"), _link("arm", 1.0, "0 0 -0.5"),
                     _joint("a", "revolute", "base", "gimbal", axis="0 1 0"),
                     _joint("b", "continuous", "gimbal", "arm", axis="0 1 0"))
    with pytest.raises(SingularJointInertia, match="<joint name='a'>"):
        load_urdf(coaxial)
    # the same middle link with a second axis at right angles is fine (a universal joint)
    universal = coaxial.replace('<axis xyz="0 1 0"/></joint></robot>', '<axis xyz="1 0 0"/></joint></robot>')
    assert load_urdf(universal).nv == 2


def test_limits_continuous_joints_and_mimic_are_read():
    text = _robot(_link("base", 1.0), _link("a", 1.0, "0 0 -0.5"), _link("b", 1.0, "0 0 -0.5"),
                  _link("c", 1.0, "0 0 -0.5"), _link("d", 1.0, "0.1 0 0"),
                  _joint("ja", "revolute", "base", "a", axis="1 0 0",
                         extra='<limit lower="-0.5" upper="2" effort="30" velocity="4"/>'),
                  _joint("jb", "continuous", "a", "b", xyz="0 0 -1", axis="1 0 0",
                         extra='<limit lower="-1" upper="1" effort="10" velocity="3"/>'),
                  _joint("jc", "prismatic", "b", "c", xyz="0 0 -1",
                         extra='<limit lower="1" upper="-1" effort="7" velocity="1"/>'
                               '<mimic joint="ja" multiplier="2" offset="0.1"/>'),
                  _joint("jd", "revolute", "c", "d", axis="0 1 0", extra='<limit effort="1" velocity="1"/>'))
    tree = load_urdf(text)
    ja, jb, jc, jd = tree.joints[1:]
    assert (ja.kind, ja.lower, ja.upper, ja.effort, ja.velocity) == ("revolute", -0.5, 2.0, 30.0, 4.0)
    # continuous: its own kind, no position limits (a file's lower/upper are not read), effort kept
    assert (jb.kind, jb.lower, jb.upper, jb.effort) == ("continuous", -math.inf, math.inf, 10.0)
    assert (jc.lower, jc.upper, jc.effort) == (-math.inf, math.inf, 7.0)         # lower > upper: no limit
    assert (jd.lower, jd.upper) == (-math.inf, math.inf)                         # left out: no limit
    assert tree.mimic == {"jc": ("ja", 2.0, 0.1)}
    assert tree.limited() == [(0, 0, -0.5, 2.0)]
    # a continuous joint is a revolute joint for the dynamics, whatever its angle (not wrapped)
    rev = load_urdf(text.replace('type="continuous"', 'type="revolute"'))
    q, qd, tau = np.array([0.3, 7.0, 0.2, -0.4]), np.array([0.5, -1.0, 0.3, 2.0]), np.array([0.1, 0.0, 0.0, 0.2])
    np.testing.assert_allclose(aba(tree, q, qd, tau), aba(rev, q, qd, tau), rtol=0, atol=1e-13)
    np.testing.assert_allclose(aba_fast(tree, q, qd, tau), aba(rev, q, qd, tau), rtol=0, atol=1e-12)
    with pytest.raises(InvalidInput, match="limits\\) apply to revolute and prismatic joints, got a continuous"):
        Joint("continuous", lower=-1.0, upper=1.0)


def test_a_floating_joint_from_the_world_link_is_a_free_body():
    # a file's massless "world" root with a floating joint to the robot: a free body (it falls at g); a floating
    # joint anywhere else is refused by name
    text = _robot(_link("world"), _link("base", 2.0, "0.1 0 0"), _link("arm", 1.0, "0 0 -0.3"),
                  _joint("free", "floating", "world", "base", xyz="0 0 1"),
                  _joint("hinge", "revolute", "base", "arm", axis="0 1 0"))
    tree = load_urdf(text)
    assert tree.parent == [-1, -1, 1] and (tree.nq, tree.nv) == (8, 7)
    qdd = aba(tree, tree.neutral(), np.zeros(7), np.zeros(7))
    np.testing.assert_allclose(qdd[3:6], [0.0, 0.0, -9.81], atol=1e-12)       # the body frame is the world's
    with pytest.raises(InvalidInput, match="<joint name='loose'>: a floating joint must hang from the fixed root"):
        load_urdf(text.replace("</robot>", _link("tip", 1.0) + _joint("loose", "floating", "arm", "tip") + "</robot>"))


def test_joint_stops_hold_in_contact_stepping():
    # a pendulum released at 0.4 rad with its hinge limited to [−0.2, 0.5]: the stop at −0.2 holds it (the
    # free swing reaches −0.4 after half a period, ~1 s); the stop is a frictionless contact on the joint.
    # The smooth integration (ArticulatedSystem) does not hold stops: it reports how far past it went
    def pendulum(lower, upper=0.5):
        tree = ArticulatedTree(gravity=(0.0, -9.81, 0.0))
        tree.add("rod", -1, "revolute", axis=[0, 0, 1], mass=1.0, com=[0, -1.0, 0], lower=lower, upper=upper)
        return ArticulatedSystem(tree, [0.4])

    def run(lower):
        ac = ArticulatedContact(pendulum(lower), [(0, [0.0, 10.0, 0.0])], normal=(0.0, 1.0, 0.0), offset=-100.0)
        return ac, ac.simulate(1.2, 2e-3).y[0]

    _, free = run(-math.inf)
    ac, held = run(-0.2)
    assert free.min() == pytest.approx(-0.4, abs=2e-3)
    assert held.min() > -0.2 - 2e-3 and held.max() < 0.4 + 1e-9
    assert ac.limited == [(0, 0, -0.2, 0.5)]
    res = pendulum(-0.2).simulate(1.2, 2e-3, "rk4")
    assert res.diagnostics["limit_excursion"].max() == pytest.approx(0.2, abs=1e-3)
    assert res.diagnostics["limit_excursion"][0] == 0.0
    assert "limit_excursion" not in pendulum(-math.inf, math.inf).simulate(0.01, 2e-3, "rk4").diagnostics


# --- the batched twins and the one-state functions refuse alike ------------------------------------------
def test_batched_variants_give_the_one_state_named_errors():
    # issue 27: the same bad input gives the same named error one state at a time or in a batch (never NaN)
    spin = ArticulatedTree()                                 # a point mass on its own axis: D = 0
    spin.add("bead", -1, "revolute", axis=[0, 0, 1], mass=1.0, com=[0, 0, 1.0])
    z = np.zeros(1)
    for f in (lambda: aba(spin, z, z, z), lambda: aba_fast(spin, z, z, z),
              lambda: aba_batch(spin, z[None], z[None], z[None])):
        with pytest.raises(SingularChartError, match="joint 0.*zero articulated inertia"):
            f()
    tree = ArticulatedTree()
    tree.add("a", -1, "revolute", axis=[1, 0, 0], mass=1.0, com=[0, 0, -1.0])
    tree.add("b", 0, "revolute", axis=[1, 0, 0], p=[0, 0, -1.0], mass=1.0, com=[0, 0, -1.0])
    q, huge = np.zeros(2), np.full(2, 1e300)                 # ω² overflows in the velocity products
    for f in (lambda: rnea(tree, q, huge, q), lambda: rnea_batch(tree, q[None], huge[None], q[None]),
              lambda: aba(tree, q, huge, q), lambda: aba_fast(tree, q, huge, q),
              lambda: aba_batch(tree, q[None], huge[None], q[None]), lambda: kinetic_energy(tree, q, huge)):
        with pytest.raises(NonFiniteResult):
            f()
    for f in (aba, aba_fast, aba_batch, rnea, rnea_batch):
        with pytest.raises(InvalidInput, match=f"{f.__name__}: q must be .* it has NaN"):
            f(tree, [np.nan, 0.0], q, q)
    with pytest.raises(InvalidInput, match="crba_batch: q must be .* it has NaN"):
        crba_batch(tree, [[np.nan, 0.0]])


# --- records that were built without a check ------------------------------------------------------------
@pytest.mark.parametrize("make, match", [
    (lambda: Joint("revolute", axis=[0, 0, 0]), "Joint: axis must be a non-zero finite 3-vector"),
    (lambda: Joint("revolute", R=2 * np.eye(3)), "Joint: R must be .* rotation"),
    (lambda: Joint("revolute", lower=1.0, upper=0.0), "Joint: lower must be <= upper"),
    (lambda: Link("a", -1.0, np.zeros(3), np.eye(3)), "Link: mass must be a finite number >= 0, got -1.0"),
    (lambda: Link("a", 1.0, np.zeros(3), np.diag([1.0, 1.0, 3.0])), "Link: inertia must be .* I1 \\+ I2 >= I3"),
    (lambda: RigidJoint("hinge", 0, 0, np.zeros(3), np.zeros(3), [0, 0, 1.0], [0, 0, 1.0]),
     "RigidJoint: a and b must be two different bodies"),
    (lambda: RigidJoint("hinge", 0, -1, [np.nan, 0, 0], np.zeros(3), [0, 0, 1.0], [0, 0, 1.0]),
     "RigidJoint: anchor_a must be .* NaN"),
])
def test_records_check_their_fields(make, match):
    # ORACLES G3: Joint, Link and RigidJoint accepted a zero axis, a scaled "rotation", a negative mass, an
    # impossible inertia, a joint of a body to itself and NaN anchors (found by the contract fuzz)
    with pytest.raises(InvalidInput, match=match):
        make()


def test_a_massless_link_is_a_link():
    # mass 0 is a link (a frame); a tree of massless links on movable joints is refused by name at load and
    # by ABA's pivot at run time
    t = ArticulatedTree()
    assert t.add("frame", -1, "fixed", mass=0.0) == 0
    t.add("arm", 0, "revolute", axis=[0, 1, 0], mass=0.0)
    with pytest.raises(SingularChartError, match="joint 1"):
        aba(t, [0.3], [0.0], [0.0])
    assert np.all(crba(t, [0.3]) == 0.0)
