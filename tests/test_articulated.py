"""Articulated trees in reduced coordinates: RNEA, CRBA, ABA, URDF (chapter 08; ORACLES I1–I5)."""

import numpy as np
import pytest

from pbanim.articulated import (ArticulatedSystem, ArticulatedTree, aba, aba_batch, bias_forces, crba, crba_batch,
                                load_urdf, rnea, rnea_batch)
from pbanim.articulated.spatial import crf, crm, force_transform, plucker, plucker_inverse, rotation, spatial_inertia
from pbanim.errors import InvalidInput
from pbanim.models.articulated import pendulum_chain, planar_biped, ragdoll, to_urdf, urdf_path


def random_tree(n, seed, floating=False, kinds=("revolute", "revolute", "prismatic", "fixed")):
    rng = np.random.default_rng(seed)
    tree = ArticulatedTree(gravity=rng.normal(size=3) * 5)
    for i in range(n):
        kind = "floating" if floating and i == 0 else (kinds[int(rng.integers(len(kinds)))] if i else "revolute")
        parent = -1 if i == 0 else int(rng.integers(0, i))
        R = np.linalg.qr(rng.normal(size=(3, 3)))[0]
        R *= np.sign(np.linalg.det(R))
        Q = np.linalg.qr(rng.normal(size=(3, 3)))[0]
        placed = kind != "floating"                    # a floating root moves from the world frame itself
        tree.add(f"l{i}", parent, kind, axis=rng.normal(size=3), R=R if placed else None,
                 p=rng.normal(size=3) if placed else np.zeros(3),
                 mass=rng.uniform(0.5, 2.0), com=0.3 * rng.normal(size=3),
                 inertia=Q @ np.diag(rng.uniform(0.5, 1.0, 3)) @ Q.T)
    return tree


def random_state(tree, seed, K=None):
    rng = np.random.default_rng(seed)
    shape = () if K is None else (K,)
    q = tree.neutral() + 0.5 * rng.normal(size=shape + (tree.nq,))
    for j, s in zip(tree.joints, tree._q_index):
        if j.kind == "floating":
            q[..., s.start:s.start + 4] /= np.linalg.norm(q[..., s.start:s.start + 4], axis=-1, keepdims=True)
    return q, rng.normal(size=shape + (tree.nv,)), rng.normal(size=shape + (tree.nv,))


# --- spatial algebra --------------------------------------------------------------------------------
def test_spatial_identities():
    rng = np.random.default_rng(0)
    axis = rng.normal(size=3)
    E = rotation(axis / np.linalg.norm(axis), 0.7)
    r, v, w, f = rng.normal(size=3), rng.normal(size=6), rng.normal(size=6), rng.normal(size=6)
    X = plucker(E, r)
    np.testing.assert_allclose(plucker_inverse(X) @ X, np.eye(6), atol=1e-14)
    np.testing.assert_allclose(force_transform(X), np.linalg.inv(X).T, atol=1e-14)
    assert (X @ v) @ (force_transform(X) @ f) == pytest.approx(v @ f, rel=1e-13)   # power is frame-free
    np.testing.assert_allclose(crm(v) @ v, 0.0, atol=1e-15)
    np.testing.assert_allclose(crf(v), -crm(v).T, atol=0)
    np.testing.assert_allclose(crm(v) @ w, -(crm(w) @ v), atol=1e-14)
    # ½ v̂ᵀ I v̂ = ½ m |v_c|² + ½ ωᵀ I_c ω, v_c = v + ω × c
    m, c, Ic = 2.0, rng.normal(size=3), np.diag([1.0, 2.0, 2.5])
    vc = v[3:] + np.cross(v[:3], c)
    assert 0.5 * v @ spatial_inertia(m, c, Ic) @ v == pytest.approx(0.5 * m * vc @ vc + 0.5 * v[:3] @ Ic @ v[:3])


# --- the algorithms ------------------------------------------------------------------------------------
@pytest.mark.parametrize("n, seed, floating", [(1, 0, False), (5, 1, False), (12, 2, True), (30, 3, False),
                                               (30, 4, True)])
def test_rnea_inverts_aba_and_aba_is_the_crba_solve(n, seed, floating):
    # ORACLES I1: RNEA(q, q̇, ABA(q, q̇, τ)) = τ; I2: ABA = H⁻¹(τ − C), H symmetric positive definite
    tree = random_tree(n, seed, floating)
    q, qd, tau = random_state(tree, seed + 100)
    qdd = aba(tree, q, qd, tau)
    scale = 1 + np.abs(tau).max()
    np.testing.assert_allclose(rnea(tree, q, qd, qdd), tau, atol=1e-11 * scale)   # measured ≤ 3e-14 … 2e-12
    H = crba(tree, q)
    np.testing.assert_array_equal(H, H.T)
    assert np.linalg.eigvalsh(H).min() > 0
    np.testing.assert_allclose(np.linalg.solve(H, tau - bias_forces(tree, q, qd)), qdd,
                               atol=1e-10 * (1 + np.abs(qdd).max()))


@pytest.mark.parametrize("floating", [False, True])
def test_batched_agrees_with_readable(floating):
    # ORACLES I5: the vectorized recursions equal the readable ones state by state
    tree = random_tree(10, 7, floating)
    q, qd, tau = random_state(tree, 8, K=16)
    for k in range(16):
        np.testing.assert_allclose(aba_batch(tree, q, qd, tau)[k], aba(tree, q[k], qd[k], tau[k]), atol=1e-12)
        np.testing.assert_allclose(rnea_batch(tree, q, qd, tau)[k], rnea(tree, q[k], qd[k], tau[k]), atol=1e-11)
        np.testing.assert_allclose(crba_batch(tree, q)[k], crba(tree, q[k]), atol=1e-13)


def test_chain_equals_the_reduced_coordinate_pendulum():
    # ORACLES G1/I4: the articulated chain (relative angles) and pbanim.reduced's n-link pendulum (absolute
    # angles, derived with sympy) have the same accelerations; θ = cumsum(q)
    from pbanim.models.reduced import n_link_pendulum

    L, m = np.array([1.0, 0.7, 0.5]), np.array([1.0, 2.0, 0.5])
    red = n_link_pendulum(3, lengths=L, masses=m).reduced()
    tree = pendulum_chain(3, L, m)
    rng = np.random.default_rng(5)
    for _ in range(5):
        th, thd = rng.normal(size=3), rng.normal(size=3)
        q, qd = np.concatenate([[th[0]], np.diff(th)]), np.concatenate([[thd[0]], np.diff(thd)])
        np.testing.assert_allclose(np.cumsum(aba(tree, q, qd, np.zeros(3))), red.rhs(0.0, np.concatenate([th, thd]))[3:],
                                   rtol=1e-12, atol=1e-12)


@pytest.mark.parametrize("floating", [False, True])
def test_energy_is_conserved_at_the_method_order(floating):
    # ORACLES I3 and A3: without damping or torques E = ½q̇ᵀHq̇ + V is conserved; RK4's energy error after
    # 1 s falls as h⁴ (or faster: measured slopes 4.3–4.5)
    tree = random_tree(4, 11, floating, kinds=("revolute",))
    q, qd, _ = random_state(tree, 12)
    sysm = ArticulatedSystem(tree, q, 0.5 * qd)
    hs = np.array([0.01, 0.005, 0.0025])
    err = []
    for h in hs:
        E = sysm.simulate(1.0, h, "rk4").diagnostics["energy"]
        err.append(abs(E[-1] - E[0]))
    slopes = np.diff(np.log(err)) / np.diff(np.log(hs))
    assert np.all(slopes > 3.7), slopes


def _readable_run(sysm, *args, **kw):
    """The run on the readable step (rhs through aba_fast and the driver's array assembly)."""
    sysm._lean_rhs = lambda: None
    try:
        return sysm.simulate(*args, **kw)
    finally:
        del sysm._lean_rhs


@pytest.mark.parametrize("seed, method, torque", [(3, "rk4", False), (5, "symplectic_euler", True),
                                                  (8, "midpoint", True)])
def test_the_lean_step_is_the_readable_step_bit_for_bit(seed, method, torque):
    # ORACLES I5: the lean path (ẏ on floats through the ABA sweep, bound once per run) is aba_fast's and
    # rhs's arithmetic operation for operation: the same states bit for bit, with damping, prismatic and
    # fixed joints and a torque callable
    tree = random_tree(5, seed)
    tree.damping[:] = [0.3] * tree.n
    q, qd, _ = random_state(tree, seed + 1)
    tau = (lambda t, q, qd: np.sin(t) - 0.5 * qd) if torque else None
    lean = ArticulatedSystem(tree, q, qd, tau).simulate(0.3, 2e-3, method, record_every=7)
    readable = _readable_run(ArticulatedSystem(tree, q, qd, tau), 0.3, 2e-3, method, record_every=7)
    assert np.array_equal(lean.y, readable.y) and np.array_equal(lean.t, readable.t)
    assert lean.nfev == readable.nfev


def test_the_lean_step_hands_a_state_it_cannot_take_to_the_readable_step():
    # a q̈ that overflows: the readable step's named error, not a NaN state
    from pbanim.errors import NonFiniteResult

    sysm = ArticulatedSystem(pendulum_chain(3), [0.1, 0.2, 0.3], [1e152, -1e152, 1e152])
    with np.errstate(over="ignore", invalid="ignore"):
        with pytest.raises(NonFiniteResult, match="aba_fast") as lean:
            sysm.simulate(0.01, 1e-3, "rk4")
        with pytest.raises(NonFiniteResult) as readable:
            _readable_run(sysm, 0.01, 1e-3, "rk4")
    assert str(lean.value) == str(readable.value)


def test_energy_is_computed_when_read_from_the_recorded_states():
    # ORACLES I3: the energy series read lazily (from the recorded states at once, energy_batch) equals the
    # one computed at the recorded times during the run to roundoff; a run nobody asks pays nothing; False: none
    for tree in (pendulum_chain(4), random_tree(4, 11, True, kinds=("revolute",))):
        q, qd, _ = random_state(tree, 2)
        sysm = ArticulatedSystem(tree, q, 0.5 * qd)
        lazy = sysm.simulate(0.2, 1e-3, "rk4", record_every=20)
        assert not lazy.diagnostics.computed
        during = sysm.simulate(0.2, 1e-3, "rk4", record_every=20, diagnostics=True)
        E, E0 = lazy.diagnostics["energy"], during.diagnostics["energy"]
        assert lazy.diagnostics.computed and E.shape == E0.shape == lazy.t.shape
        assert np.allclose(E, E0, rtol=0, atol=1e-12 * (1 + np.abs(E0).max()))
        assert dict(sysm.simulate(0.2, 1e-3, "rk4", diagnostics=False).diagnostics) == {}


# --- URDF -------------------------------------------------------------------------------------------
def _permutation(py, u):
    """Index maps from the loaded tree's q, q̇ (breadth-first) into the Python builder's (depth-first)."""
    by_name = {lk.name: i for i, lk in enumerate(py.links)}
    qp, vp = [], []
    for lk in u.links:
        if lk.name in by_name:
            j = by_name[lk.name]
            qp += range(py._q_index[j].start, py._q_index[j].stop)
            vp += range(py._v_index[j].start, py._v_index[j].stop)
    return np.array(qp, int), np.array(vp, int)


@pytest.mark.parametrize("name, build, kw", [
    ("pendulum3", lambda: pendulum_chain(3, [1.0, 0.7, 0.5], [1.0, 2.0, 0.5]), dict(gravity=(0, -9.81, 0))),
    ("ragdoll", ragdoll, dict(floating_base=True)),
    ("planar_biped", planar_biped, dict(gravity=(0, -9.81, 0)))])
def test_shipped_urdf_equals_the_python_model(name, build, kw):
    py = build()
    u = load_urdf(str(urdf_path(name)), **kw)
    qp, vp = _permutation(py, u)
    assert (py.nq, py.nv) == (u.nq, u.nv) and len(vp) == py.nv
    q, qd, tau = random_state(py, 3)
    np.testing.assert_allclose(crba(u, q[qp]), crba(py, q)[np.ix_(vp, vp)], atol=1e-12)
    np.testing.assert_allclose(aba(u, q[qp], qd[vp], tau[vp]), aba(py, q, qd, tau)[vp], atol=1e-9)


def test_urdf_rpy_and_rotated_inertial_frames():
    # a link whose inertial frame is rotated by rpy: I_link = R I Rᵀ (and the joint origin's rpy too)
    b = random_tree(3, 21)
    a = load_urdf(to_urdf(b, "r"), gravity=b.gravity)
    q, qd, tau = random_state(b, 1)
    np.testing.assert_allclose(aba(a, q, qd, tau), aba(b, q, qd, tau), atol=1e-10)
    rotated = ('<robot name="x"><link name="a"><inertial><origin xyz="0 0 0" rpy="0 0 1.5707963267948966"/>'
               '<mass value="1"/><inertia ixx="1" ixy="0" ixz="0" iyy="2" iyz="0" izz="3"/></inertial></link>'
               '</robot>')
    np.testing.assert_allclose(load_urdf(rotated).links[0].inertia, np.diag([2.0, 1.0, 3.0]), atol=1e-12)


LINK = '<link name="{0}"><inertial><mass value="1"/><inertia ixx="1" ixy="0" ixz="0" iyy="1" iyz="0" izz="1"/></inertial></link>'


@pytest.mark.parametrize("body, match", [
    (LINK.format("a") + LINK.format("b") + '<joint name="j" type="planar"><parent link="a"/><child link="b"/></joint>',
     "<joint name='j'>: joint type 'planar' is not supported"),
    ('<link name="a"><inertial><inertia ixx="1" ixy="0" ixz="0" iyy="1" iyz="0" izz="1"/></inertial></link>',
     "<link name='a'> <inertial> needs a <mass> and an <inertia>"),
    (LINK.format("a") + '<joint name="j" type="fixed"><parent link="a"/><child link="zz"/></joint>',
     "<joint name='j'>: child link 'zz' is not a <link>"),
    (LINK.format("a") + LINK.format("b") + '<joint name="j" type="fixed"><parent link="a"/><child link="b"/></joint>'
     '<joint name="k" type="fixed"><parent link="b"/><child link="a"/></joint>', "one root, found roots \\[\\]"),
    (LINK.format("a") + LINK.format("b"), "one root, found roots \\['a', 'b'\\]"),
    (LINK.format("a").replace('value="1"', 'value="-1"'), "<link name='a'> <mass>: value must be a finite number >= 0, "
                                                         "got -1.0"),
    (LINK.format("a") + LINK.format("b") + '<joint name="j" type="revolute"><parent link="a"/><child link="b"/>'
     '<axis xyz="0 0 0"/></joint>', "<joint name='j'> <axis>: xyz must be a non-zero finite 3-vector .* it is zero"),
    (LINK.format("a").replace('izz="1"', 'izz="3"'),
     "<link name='a'> <inertia>: .* violate the triangle inequality I1 \\+ I2 >= I3"),
])
def test_bad_urdf_is_named(body, match):
    with pytest.raises(InvalidInput, match=match):
        load_urdf(f'<robot name="x">{body}</robot>')


def test_bad_tree_input_is_named():
    t = ArticulatedTree()
    with pytest.raises(InvalidInput, match="parent must be −1 .* got 3"):
        t.add("a", 3, "revolute", mass=1.0)
    with pytest.raises(InvalidInput, match="kind must be one of .* got 'ball'"):
        t.add("a", -1, "ball", mass=1.0)
    with pytest.raises(InvalidInput, match="add: inertia must be .* got \\[1.0, 1.0, 3.0\\]; .* violate the triangle"):
        t.add("a", -1, "revolute", mass=1.0, inertia=[1.0, 1.0, 3.0])
    with pytest.raises(InvalidInput, match="the tree has no links"):
        crba(t, np.zeros(0))
    t.add("a", -1, "revolute", mass=1.0, com=[1.0, 0, 0])
    with pytest.raises(InvalidInput, match="aba: q must be .* got \\[nan\\]; it has NaN"):
        aba(t, [np.nan], [0.0], [0.0])


# --- against Pinocchio (optional: pip install -e ".[pinocchio]") --------------------------------------------
def _to_pinocchio(tree, floating):
    pin = pytest.importorskip("pinocchio")
    xml = to_urdf(tree, "t")
    model = pin.buildModelFromXML(xml, pin.JointModelFreeFlyer()) if floating else pin.buildModelFromXML(xml)
    model.gravity.linear = np.asarray(tree.gravity, dtype=float)
    qmap, vmap = np.zeros(tree.nq, int), np.zeros(tree.nv, int)   # our index → Pinocchio's
    for i, (lk, j) in enumerate(zip(tree.links, tree.joints)):
        qs, vs = tree._q_index[i], tree._v_index[i]
        if j.kind == "fixed":
            continue
        if j.kind == "floating":                 # ours: (w, x, y, z, p), (ω, v); Pinocchio: (p, x, y, z, w), (v, ω)
            jid = 1
            iq, iv = model.joints[jid].idx_q, model.joints[jid].idx_v
            qmap[qs] = [iq + 6, iq + 3, iq + 4, iq + 5, iq, iq + 1, iq + 2]
            vmap[vs] = [iv + 3, iv + 4, iv + 5, iv, iv + 1, iv + 2]
            continue
        jid = model.getJointId(f"{lk.name}_joint")
        qmap[qs], vmap[vs] = model.joints[jid].idx_q, model.joints[jid].idx_v
    return pin, model, qmap, vmap


@pytest.mark.parametrize("n, seed, floating", [(1, 31, False), (7, 32, False), (15, 33, True), (30, 34, False),
                                               (30, 35, True)])
def test_agrees_with_pinocchio(n, seed, floating):
    # RNEA, CRBA and ABA equal Pinocchio's on random trees of 1–30 links (skipped without pinocchio)
    tree = random_tree(n, seed, floating)
    pin, model, qmap, vmap = _to_pinocchio(tree, floating)
    data = model.createData()
    q, qd, tau = random_state(tree, seed)
    qp, vp, tp = np.zeros(model.nq), np.zeros(model.nv), np.zeros(model.nv)
    qp[qmap], vp[vmap], tp[vmap] = q, qd, tau
    scale = 1 + np.abs(tau).max()
    np.testing.assert_allclose(pin.rnea(model, data, qp, vp, tp)[vmap], rnea(tree, q, qd, tau), atol=1e-10 * scale * 10)
    M = pin.crba(model, data, qp)
    M = np.triu(M) + np.triu(M, 1).T
    np.testing.assert_allclose(M[np.ix_(vmap, vmap)], crba(tree, q), atol=1e-10 * (1 + np.abs(M).max()))
    np.testing.assert_allclose(pin.aba(model, data, qp, vp, tp)[vmap], aba(tree, q, qd, tau),
                               atol=1e-10 * (1 + np.abs(aba(tree, q, qd, tau)).max()))


def test_bench_articulated_smoke():
    # the benchmark runs and prints its goals (measured only with Pinocchio; never timed here)
    from pbanim.bench import run_bench

    rep = run_bench("articulated", quick=True)
    assert [g.id for g in rep.goals] == ["articulated-batched-aba-vs-pinocchio", "articulated-aba-vs-pinocchio"]
    rows = rep.tables[0].rows
    assert [r[0] for r in rows] == [2, 5, 10]
    agree = [r[7] for r in rows if np.isfinite(r[7])]
    assert all(r[4] > 0 and r[5] > 0 for r in rows)
    assert all(a < 1e-10 for a in agree)


def test_floor_row_of_the_chain_is_equal_work():
    # pbanim bench floors, row "joints": the hand-written ABA + RK4 loop computes what ArticulatedSystem's
    # run computes (ORACLES I5: the same q̈ by another writing of the ABA), to roundoff over 2000 steps
    from pbanim.bench._floor_articulated import chain_rk4

    fl = chain_rk4()
    a, b = fl.pbanim(), fl.hand()
    assert a.shape == b.shape == (6,) and np.abs(a - b).max() <= fl.tol * max(1.0, np.abs(b).max())
    assert "joints:" in fl.notes[0]
