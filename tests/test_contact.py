"""Resting contact: assembly of d̈ = A f + b, the scene effect, a box on a plane, box stacks (ORACLES D4, D5)."""

import subprocess
import sys

import numpy as np
import pytest

from pbanim.contact import (RestingContact, assemble_particles, assemble_particles_loop, assemble_rigid,
                            assemble_rigid_loop, make_contacts, solve_lcp)
from pbanim.models.contact import box_on_plane, box_stack
from pbanim.particles import Gravity, ParticleSystem
from pbanim.rigid.bodies import RigidBodies
from pbanim.rigid.quat import quat_exp
from pbanim.scene import Scene


def _two_spinning_bodies(rng):
    q = quat_exp(rng.normal(size=(2, 3)))
    return RigidBodies([2.0, 3.0], [[1.0, 2.0, 2.5], [0.5, 0.7, 1.0]], positions=[[0.0, 0.0, 1.0], [0.2, -0.1, 0.0]],
                       orientations=q, velocities=rng.normal(size=(2, 3)), angular_velocities=rng.normal(size=(2, 3)))


def _forces(bodies, sc=None):
    y = bodies.state()
    Q = bodies.zero_forces()
    for e in (sc.forces if sc else []):
        e.bind(bodies)
        e.apply(0.0, y, Q)
    return y, Q


def test_rigid_assembly_loop_equals_vectorized():
    # Baraff's per-contact compute_aij loop and the vectorized J W Jᵀ agree (world contacts, body-body
    # contacts, spinning bodies: every term of A and b).  measured 4e-16, bound 1e-13
    rng = np.random.default_rng(0)
    bodies = _two_spinning_bodies(rng)
    y = bodies.state()
    Q = rng.normal(size=(2, 6))
    n = rng.normal(size=(5, 3))
    n /= np.linalg.norm(n, axis=1)[:, None]
    c = make_contacts([0, 0, 1, 0, 1], [1, -1, -1, 1, 0], rng.normal(size=(5, 3)), n)
    prob = assemble_rigid(bodies, y, c, Q)
    A, b = assemble_rigid_loop(bodies, y, c, Q)
    np.testing.assert_allclose(prob.A, A, atol=1e-13)
    np.testing.assert_allclose(prob.b, b, atol=1e-13)
    np.testing.assert_allclose(prob.A, prob.A.T, atol=1e-14)
    assert np.linalg.eigvalsh(prob.A).min() > -1e-12          # A = J W Jᵀ is PSD
    np.testing.assert_allclose(prob.J.toarray() @ np.ones(prob.J.shape[1]),
                               prob.rows.matvec(np.ones((3, 6))), atol=1e-13)


def test_particle_assembly_loop_equals_vectorized():
    # the same agreement for particles (2-D, sphere–sphere velocity term |Δv⊥|²/|Δx|).  measured 0, bound 1e-13
    rng = np.random.default_rng(1)
    ps = ParticleSystem(rng.normal(size=(4, 2)), rng.normal(size=(4, 2)), masses=[1.0, 2.0, 3.0, 4.0])
    y = ps.state()
    x = ps.unpack(y)[0]
    pairs = [(0, 1), (2, 3), (1, 2)]
    n = np.array([(x[a] - x[b]) / np.linalg.norm(x[a] - x[b]) for a, b in pairs] + [[0.0, 1.0]])
    c = make_contacts([p[0] for p in pairs] + [3], [p[1] for p in pairs] + [-1], np.zeros((4, 2)), n)
    Q = rng.normal(size=(4, 2))
    prob = assemble_particles(ps, y, c, Q)
    A, b = assemble_particles_loop(ps, y, c, Q)
    np.testing.assert_allclose(prob.A, A, atol=1e-13)
    np.testing.assert_allclose(prob.b, b, atol=1e-13)


def _free_motion(bodies, y, Q, h, steps):
    """RK4 on the free Newton–Euler equations with constant Q (no contact force)."""
    f = lambda yy: bodies.derivative(yy, Q)  # noqa: E731
    out = [y]
    for _ in range(steps):
        k1 = f(y)
        k2 = f(y + h / 2 * k1)
        k3 = f(y + h / 2 * k2)
        k4 = f(y + h * k3)
        y = y + h / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
        out.append(y)
    return out


def test_b_is_second_derivative_of_separation_including_2ndot_term():
    # b = d̈ with f = 0 for a vertex (body-fixed on a) against a face (body-fixed on b, normal turning with b):
    # d(t) = n(t)·(p_a(t) − p_b(t)); compared with a central finite difference of d along the free motion
    # (RK4, step 1e-4).  Dropping the 2ṅ·(ṗ_a − ṗ_b) term changes b by O(1), so this catches it.
    # measured |b − d̈_FD| 9.5e-9 (b = 0.678), bound 1e-6·max(1, |b|)
    rng = np.random.default_rng(2)
    bodies = _two_spinning_bodies(rng)
    y0 = bodies.state()
    Q = rng.normal(size=(2, 6))
    p = np.array([0.3, 0.1, 0.6])
    n = np.array([0.2, -0.3, 0.9])
    n /= np.linalg.norm(n)
    R0 = bodies.rotations(y0)
    x0 = bodies.unpack(y0)[0]
    pa_body, pb_body, n_body = R0[0].T @ (p - x0[0]), R0[1].T @ (p - x0[1]), R0[1].T @ n
    h = 1e-4
    back = RigidBodies(bodies.mass, bodies.I_body)  # the same bodies run backwards: negate momenta, Q
    yb = y0.copy()
    yb[14:] *= -1
    fw = _free_motion(bodies, y0, Q, h, 1)
    bw = _free_motion(back, yb, Q * np.array([1, 1, 1, 1, 1, 1.0]), h, 1)

    def d(yy):
        R = bodies.rotations(yy)
        x = bodies.unpack(yy)[0]
        return (R[1] @ n_body) @ ((x[0] + R[0] @ pa_body) - (x[1] + R[1] @ pb_body))

    dd_fd = (d(fw[1]) - 2 * d(y0) + d(bw[1])) / h**2
    b = assemble_rigid(bodies, y0, make_contacts([0], [1], [p], [n]), Q).b[0]
    assert abs(b - dd_fd) < 1e-6 * max(1.0, abs(b)), (b, dd_fd)
    # the 2ṅ·(ṗ_a − ṗ_b) term is not negligible here (else the test would not see it)
    v, w = bodies.velocities(y0)
    term = 2 * np.cross(w[1], n) @ ((v[0] + np.cross(w[0], p - x0[0])) - (v[1] + np.cross(w[1], p - x0[1])))
    assert abs(term) > 1e-2


def test_box_on_plane_totals_all_solvers():
    # ORACLES D4: Σf = m g and Σ r×f = 0 for every solver; corner forces are NOT compared (indeterminate).
    # measured |Σf − mg| ≤ 7.0e-11 (pgs; 3.6e-15 direct), torque ≤ 1.2e-10 (pgs); bound 1e-9
    sc = box_on_plane(2.0)
    y, Q = _forces(sc.system, sc)
    prob = assemble_rigid(sc.system, y, sc.detect(y), Q)
    for solver in ("qp", "lemke", "dantzig", "pgs"):
        sol = solve_lcp(prob.A, prob.b, solver)
        QC = prob.generalized_force(sol.f, 1)
        assert abs(sol.f.sum() - sc.exact["total_force"]) < 1e-9 * sc.exact["total_force"]
        np.testing.assert_allclose(QC[0, :3], [0.0, 0.0, sc.exact["total_force"]], atol=1e-9)
        assert np.abs(QC[0, 3:]).max() < 1e-9                    # Σ r×f = 0


def test_box_on_plane_10k_steps_at_rest():
    # ORACLES D4: resting box, 10⁴ steps of h = 1 ms (symplectic Euler): no sinking, |v| < 1e-9, f = mg.
    # measured max |v| 0.0, drift 0.0, depth 0.0 (the Lemke forces cancel gravity to the last bit), force
    # total rel. error 0.0; bounds 1e-9 m/s, 1e-12 m, 1e-12 m, 1e-12
    sc = box_on_plane(2.0)
    eff = RestingContact(sc.detect, "lemke")
    res = Scene(sc.system, sc.forces + [eff]).simulate(10.0, 1e-3, record_every=500)
    assert res.nsteps == 10_000
    P = res.y[7:10]
    assert np.abs(P / 2.0).max() < 1e-9 and np.abs(res.y[10:13]).max() < 1e-9
    assert np.abs(res.y[2] - res.y[2, 0]).max() < 1e-12
    assert res.diagnostics["max_penetration"].max() < 1e-12
    np.testing.assert_allclose(res.diagnostics["contact_force_total"][1:], 2.0 * 9.81, rtol=1e-12)


def test_box_on_plane_recovers_from_penetration():
    # Baumgarte stabilization (k_s = 400, k_d = 40: critically damped, ω = 20 rad/s): a box started 1 mm
    # deep is pushed out and ends at rest at zero depth; it never pops up above the plane by more than
    # roundoff (critical damping: no overshoot).  measured final depth 9.8e-11 m, |v| 1.7e-9 m/s, max height
    # −9.8e-11 m; bounds 1e-8 m, 1e-7 m/s, 1e-6 m
    sc = box_on_plane(1.0, margin=1e-3)
    y0 = sc.system.state()
    y0[2] -= 1e-3
    res = Scene(sc.system, sc.forces + [RestingContact(sc.detect, "qp")]).simulate(1.0, 1e-3, y0=y0,
                                                                                 record_every=50)
    z = res.y[2] - sc.half_extents[2]
    assert abs(z[-1]) < 1e-8 and abs(res.y[9, -1]) < 1e-7
    assert z.max() < 1e-6          # no pop-up


@pytest.mark.parametrize("n, ratio", [(3, 100.0), (3, 1000.0), (10, 100.0), (10, 1000.0)])
@pytest.mark.parametrize("solver", ["qp", "lemke", "dantzig"])
def test_stack_interface_forces_equal_weights(n, ratio, solver):
    # ORACLES D5: every interface carries the weight of the boxes above it (alternating masses 1 and r: each
    # interface is a 1:r ratio), to 1e-8 relative, for the direct QP and the pivoting methods.
    # measured ≤ 4.7e-12 relative (10 boxes, 1:1000, dantzig), bound 1e-8
    sc = box_stack(n, ratio)
    y, Q = _forces(sc.system, sc)
    c = sc.detect(y)
    prob = assemble_rigid(sc.system, y, c, Q)
    sol = solve_lcp(prob.A, prob.b, solver)
    per_interface = np.bincount(c.a, weights=sol.f, minlength=n)
    np.testing.assert_allclose(per_interface, sc.exact["weights_above"], rtol=1e-8)


def test_stack_pgs_reports_failure_on_mass_ratio():
    # ORACLES D5: PGS on a 10-box 1:1000 stack does not converge in 200 sweeps — it must say so
    # (success False, status "max_iter"), never return a silently wrong force set
    sc = box_stack(10, 1000.0)
    y, Q = _forces(sc.system, sc)
    prob = assemble_rigid(sc.system, y, sc.detect(y), Q)
    sol = solve_lcp(prob.A, prob.b, "pgs", max_iter=200, raise_on_failure=False)
    assert not sol.success and sol.status == "max_iter"


@pytest.mark.parametrize("solver", ["qp", "lemke"])
def test_stack_simulation_no_penetration_growth(solver):
    # ORACLES D5: a 10-box 1:1000 stack held for 300 steps: the top box does not move and no interface sinks.
    # measured top drift 1.2e-14 m, max depth 4.0e-14 m, residual 1.1e-10; bounds 1e-9 m, 1e-9 m, 1e-6
    sc = box_stack(10, 1000.0)
    res = Scene(sc.system, sc.forces + [RestingContact(sc.detect, solver)]).simulate(0.3, 1e-3, record_every=30)
    top_z = res.y[3 * 9 + 2]
    assert np.abs(top_z - top_z[0]).max() < 1e-9
    assert res.diagnostics["max_penetration"].max() < 1e-9
    assert res.diagnostics["contact_residual"].max() < 1e-6


def test_particle_resting_on_ground_2d():
    # a particle resting on the ground: f = m g exactly, no motion (the lecture's simplest resting contact)
    ps = ParticleSystem([[0.0, 0.0], [1.0, 0.0]], masses=[2.0, 5.0])
    ground = lambda y: make_contacts([0, 1], [-1, -1], y[:4].reshape(2, 2), [[0.0, 1.0]] * 2)  # noqa: E731
    res = Scene(ps, [Gravity(), RestingContact(ground, "dantzig")]).simulate(0.5, 0.01)
    assert np.abs(res.y[:, -1] - res.y[:, 0]).max() < 1e-15
    assert abs(res.diagnostics["contact_force_total"][-1] - 7.0 * 9.81) < 1e-12


def test_effect_rejects_bad_input():
    # G3: bad arguments are named, with their value
    sc = box_on_plane()
    with pytest.raises(ValueError, match="detect must be a callable"):
        RestingContact(None)
    with pytest.raises(ValueError, match="solver must be one of"):
        RestingContact(sc.detect, "simplex")
    with pytest.raises(ValueError, match="stabilization must be one of"):
        RestingContact(sc.detect, stabilization="projection")
    with pytest.raises(ValueError, match="stiffness must be a finite number >= 0, got -1.0"):
        RestingContact(sc.detect, stiffness=-1.0)
    with pytest.raises(ValueError, match="RestingContact needs a system implementing the body protocol .*; object lacks kind, N, dof"):
        RestingContact(sc.detect).bind(object())
    with pytest.raises(ValueError, match="mass_ratio must be positive"):
        box_stack(3, -1.0)
    with pytest.raises(ValueError, match="pattern must be one of"):
        box_stack(3, 10.0, pattern="random")


def test_no_effect_no_assembly_no_qpsolvers():
    # a scene without the resting-contact effect assembles no A and never imports qpsolvers/proxsuite;
    # a scene with it (qp) does
    code = ("import sys; from pbanim.models.contact import box_on_plane; from pbanim.scene import Scene; "
            "sc = box_on_plane(); Scene(sc.system, sc.forces).simulate(0.01, 1e-3); "
            "print(any(m in sys.modules for m in ('qpsolvers', 'proxsuite')))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "False"
    sc = box_on_plane()
    eff = RestingContact(sc.detect, "lemke")
    Scene(sc.system, sc.forces).simulate(0.01, 1e-3)
    assert eff.solves == 0
    Scene(sc.system, sc.forces + [eff]).simulate(0.01, 1e-3)
    assert eff.solves > 0


# ---------------------------------------------------------------------------------------------
# chapter figures (quick mode) and the benchmark smoke run
# ---------------------------------------------------------------------------------------------
def test_figure_stack_forces(figure_data):
    # ORACLES D5 in the figure: direct solvers match the weights above to 1e-8; PGS, when it fails, says so
    d = figure_data("ch07_stack_forces")
    for solver in ("qp", "lemke", "dantzig"):
        assert d[f"success_{solver}"] and d[f"rel_err_{solver}"] < 1e-8
    assert d["success_pgs"] or d["rel_err_pgs"] > 1e-8          # never a silent wrong answer


def test_figure_incline(figure_data):
    # ORACLES D6 in the figure: every angle matches the analytic acceleration and friction (measured 2e-13)
    d = figure_data("ch07_incline_stick_slip")
    np.testing.assert_allclose(d["acceleration"], d["acceleration_exact"], atol=1e-9)
    np.testing.assert_allclose(d["friction"], d["friction_exact"], atol=1e-9)
    static = np.tan(d["angles"]) <= d["friction_coefficient"]
    assert static.any() and (~static).any()                    # both regimes are shown


def test_figure_solver_residual_time(figure_data):
    # the accuracy-vs-cost figure: direct solvers reach the 1e-10 certificate; PGS's residual decreases overall
    d = figure_data("ch07_solver_residual_time")
    for solver in ("qp", "lemke", "dantzig", "bpp"):              # bpp: the active-set route (ORACLES D15)
        assert d[f"{solver}_residual"] < 1e-10
    r = d["pgs_residual"]
    assert r[-1] < r[0] and np.all(np.diff(d["pgs_time"]) > 0)
    assert d["qp_eps_residual"][-1] < d["qp_eps_residual"][0]   # tighter eps_abs, smaller residual


def test_figure_gifs(figure_data):
    # the settling GIFs: the stack ends at its resting heights (within the erp-corrected depth) at rest;
    # the spheres stay inside the box, never sink more than 1% of a radius, and come to rest
    d = figure_data("ch07_stack_settling")
    np.testing.assert_allclose(d["final_heights"], d["rest_heights"], atol=1e-3)
    assert d["max_penetration"] < 1e-3 and d["final_speed"] < 1e-2
    assert any(p.suffix == ".gif" for p in figure_data.files("ch07_stack_settling"))
    s = figure_data("ch07_sphere_pile")
    assert s["max_penetration"] < 0.01 * s["radius"]
    assert np.all(s["final_z"] >= s["radius"] * 0.99)
    assert np.all(np.abs(s["final_x"]) <= s["box_half"]) and np.all(np.abs(s["final_y"]) <= s["box_half"])
    assert s["kinetic_energy"][-1] < 1e-3 * s["kinetic_energy"].max()
    assert any(p.suffix == ".gif" for p in figure_data.files("ch07_sphere_pile"))


def test_bench_smoke():
    # the whole quick benchmark runs once, in tests/test_contact_peers.py (no-peer path); here the QP table of
    # issue 14 part 5 alone: every pbanim solve certifies to 1e-10 (ORACLES D12), the ratio is a table column
    from pbanim.bench import Report
    from pbanim.bench.contact import _qp_table

    rep = Report("contact")
    worst = _qp_table(True, rep)
    tab = rep.tables[0]
    assert np.isfinite(worst) and len(tab.rows) == 6
    assert all(r[3] <= 1e-10 and r[4] > 0 and r[7] > 0 for r in tab.rows)


def test_symplectic_euler_solves_resting_contact_once_per_step():
    # the drift of symplectic Euler needs no forces: with RestingContact the scene solves once per step
    # (at the kick) and the trajectory equals the generic two-evaluation step's (a particle sliding
    # on the ground next to one falling freely, and a 3-box stack at rest).  measured 0 difference, bound 1e-12
    ps = ParticleSystem([[0.0, 0.0, 0.0], [0.0, 0.0, 1.0]], [[0.7, -0.2, 0.0], [0.0, 0.0, 0.0]], masses=2.0)

    def ground(y):   # particle 0 only
        return make_contacts([0], [-1], [y[:3]], [[0.0, 0.0, 1.0]], [max(0.0, -y[2])])

    sc = box_stack(3, 10.0)
    fast_runs = []
    for system, detect, forces in ((ps, ground, [Gravity(np.array([0.0, 0.0, -9.81]))]),
                                   (sc.system, sc.detect, sc.forces)):
        runs = []
        for drift_free in (True, False):
            eff = RestingContact(detect, "lemke")
            eff.drift_free = drift_free
            res = Scene(system, forces + [eff]).simulate(0.05, 1e-3, record_every=10)
            runs.append((res, eff.solves))
        (fast, n_fast), (generic, n_generic) = runs
        assert n_fast == fast.nsteps == 50 and n_generic == 2 * generic.nsteps
        assert fast.nfev == 50 and generic.nfev == 100
        np.testing.assert_allclose(fast.y, generic.y, rtol=0, atol=1e-12)
        fast_runs.append(fast)
    part, stack = fast_runs
    assert part.y[0, -1] > 0.03 and abs(stack.y[0, -1]) < 1e-12          # the particle slid; the stack stays
    # the falling particle: the drift uses v₁, so z after k steps is 1 − g h² k (k + 1) / 2
    k = np.round(part.t / 1e-3)
    np.testing.assert_allclose(part.y[5], 1.0 - 9.81 * 1e-6 * k * (k + 1) / 2, rtol=0, atol=1e-13)


def test_with_collision_chapter_manifolds():
    # integration with pbanim.collision: box–plane and box–box manifolds from the narrow phase feed the
    # resting-contact LCP directly; two stacked boxes (1 kg on 100 kg): interface forces = weights above
    # (ORACLES D5), for every direct solver.  measured ≤ 3.1e-14 rel. (dantzig), bound 1e-8
    from pbanim.collision import Plane, box_box, box_plane
    from pbanim.collision.shapes import Contacts

    sc = box_stack(2, 100.0, pattern="light_top")
    bodies, h = sc.system, sc.half_extents

    eps = 1e-6   # box_box has no margin: query with the upper box lowered by eps, then undo the shift

    def detect(y):
        x, R = bodies.unpack(y)[0], bodies.rotations(y)
        bb = box_box(x[1] - [0, 0, eps], R[1], h, x[0], R[0], h, a=1, b=0)
        bb = Contacts(bb.a, bb.b, bb.point + [0, 0, eps / 2], bb.normal, bb.depth - eps)
        return Contacts.concatenate([box_plane(x[:1], R[:1], h, Plane(), a=0, b=-1, margin=eps), bb])

    y, Q = _forces(bodies, sc)
    c = detect(y)
    assert np.all(c.normal[c.a == 1] @ [0, 0, 1.0] > 0.999)       # normals from b (lower) to a (upper)
    prob = assemble_rigid(bodies, y, c, Q)
    for solver in ("qp", "lemke", "dantzig"):
        sol = solve_lcp(prob.A, prob.b, solver)
        np.testing.assert_allclose(np.bincount(c.a, weights=sol.f, minlength=2), sc.exact["weights_above"], rtol=1e-8)
    res = Scene(bodies, sc.forces + [RestingContact(detect, "qp")]).simulate(0.1, 1e-3, record_every=20)
    assert np.abs(res.y[5] - res.y[5, 0]).max() < 1e-9           # the top box does not move
