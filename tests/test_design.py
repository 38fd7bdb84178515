"""Chapter 10: S(t, u), ∂S/∂u through impacts, min-norm edits (ORACLES H1–H6)."""

import warnings

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

from pbanim.collision import Box, Plane, Sphere
from pbanim.design import DesignBody, DesignScene, GrazingImpactWarning, TooManyImpacts, UnknownParameter, simulate
from pbanim.design.check import analytic_jacobian, fd_jacobian
from pbanim.design.control import (SingularMetric, edit, min_norm_update, orientation_goal, position_goal)
from pbanim.design.exact import first_impact, flight_map
from pbanim.design.impact import Features
from pbanim.design.flight import (FlightModel, flight_tangent, flight_tangent_readable)
from pbanim.design.multiple import multiple_shooting, sketch_impacts, states_from_sketch
from pbanim.design.shooting import clearance, single_shooting, state_names
from pbanim.testing import order_fit
from pbanim.errors import InvalidInput
from pbanim.rigid import RigidBodies, quat_from_axis_angle

G = 10.0


def ball(h0=1.0, eps=0.7, v=(0.0, 0.0, 0.0)):
    b = DesignBody(Sphere(0.1), position=[0, 0, h0 + 0.1], velocity=v)
    return DesignScene([b], [Plane([0, 0, 1])], gravity=[0, 0, -G], restitution=eps)


def tumbling_box(t_wall=True):
    b = DesignBody(Box([0.2, 0.15, 0.1]), mass=1.3, position=[0, 0, 1.0],
                   orientation=quat_from_axis_angle([1, 2, 3], 0.7), velocity=[1.0, 0.3, 2.0],
                   angular_velocity=[3.0, -2.0, 4.0])
    return DesignScene([b], [Plane([0, 0, 1]), Plane([-1, 0, 0.1], offset=-1.5)], restitution=0.6)


def test_dropped_ball_saltation_and_apex():
    # ORACLES H1: one bounce; dz(T)/dh0 and dz(T)/dε from the closed form; apex derivatives ε² and 2εh0
    eps, h0, T = 0.7, 1.0, 1.0
    tr = simulate(ball(h0, eps), T, ["x0", "v0", "restitution"], h=0.01)
    t1 = np.sqrt(2 * h0 / G)
    s, vp = T - t1, eps * G * t1
    dt1 = 1 / (G * t1)
    dz_dh0 = eps * G * dt1 * s - (vp - G * s) * dt1
    dz_deps = G * t1 * s
    J = tr.d_position(0, T)
    assert abs(tr.impacts[0].t - t1) < 1e-13                  # measured 0
    assert abs(J[2, 2] - dz_dh0) < 1e-12 * 10                 # measured 2e-15
    assert abs(J[2, 6] - dz_deps) < 1e-12 * 10
    # saltation S = [[−ε, 0], [−(1+ε)g/v⁻, −ε]] maps (δh, δv) just before to just after: via Φ(T) = Φ_after·S·Φ_before
    vminus = -G * t1
    S = np.array([[-eps, 0.0], [-(1 + eps) * G / vminus, -eps]])
    Phi_before = np.array([[1.0, t1], [0.0, 1.0]])            # free fall from 0 to t1 (exact for RK4)
    Phi_after = np.array([[1.0, s], [0.0, 1.0]])
    expect = Phi_after @ S @ Phi_before
    got = np.array([[J[2, 2], J[2, 5]], [0.0, 0.0]])
    m = tr.model
    dv, _ = tr.d_velocities(0, T)
    got[1] = [dv[2, 2], dv[2, 5]]
    assert np.abs(got - expect).max() < 1e-12                 # measured 4e-15
    # apex after the bounce: h1 = ε² h0
    apex_t = t1 + vp / G
    tr2 = simulate(ball(h0, eps), apex_t, ["x0", "restitution"], h=0.01)
    d = tr2.d_position(0, apex_t)
    assert abs(d[2, 0 + 2] - eps ** 2) < 1e-10                # dh1/dh0 = ε²; measured 1e-15
    assert abs(d[2, 3] - 2 * eps * h0) < 1e-10                # dh1/dε = 2εh0
    assert m.N == 1


def test_dropping_event_time_term_is_wrong():
    # ORACLES H1: without the δτ terms the jump would be diag(1, −ε); the computed derivative differs from it
    eps, T = 0.7, 1.0
    J = simulate(ball(1.0, eps), T, ["x0"], h=0.01).d_position(0, T)
    t1 = np.sqrt(0.2)
    naive = 1.0                                                # diag(1, −ε): δh would pass through unchanged
    assert abs(J[2, 2] - naive) > 0.3 and t1 < T               # measured 0.40


@pytest.mark.parametrize("t_end, n_imp", [(0.5, 0), (0.68, 2)])
def test_tumbling_box_matches_richardson_fd(t_end, n_imp):
    # ORACLES H2: analytic ∂S/∂u vs centred FD + Richardson, quaternions in the tangent space
    s = tumbling_box()
    names = ["x0", "theta0", "v0", "omega0", "restitution", "mass0", "normal1"]
    tr = simulate(s, t_end, names)
    assert len(tr.impacts) == n_imp
    outs = [(0, t_end, "position"), (0, t_end, "orientation")]
    A = analytic_jacobian(tr, outs)
    F = fd_jacobian(s, names, None, t_end, outs, delta=1e-4)
    rel = np.abs(A - F).max() / np.abs(F).max()
    assert rel < 1e-6                                           # measured ≤ 1e-9 (2 impacts: 4e-11 abs)


def test_inertia_columns_match_fd():
    # ORACLES H2: inertia parameters (small moments: absolute FD step scaled to them)
    s = tumbling_box()
    tr = simulate(s, 0.66, ["inertia0"])
    outs = [(0, 0.66, "orientation"), (0, 0.66, "position")]
    F = fd_jacobian(s, ["inertia0"], None, 0.66, outs, delta=1e-6, relative=False)
    rel = np.abs(analytic_jacobian(tr, outs) - F).max() / np.abs(F).max()
    assert rel < 1e-6                                           # measured 3e-9


def test_free_flight_closed_form():
    # ORACLES H3: no impact: ∂x(t)/∂v0 = t𝟙, ∂x/∂x0 = 𝟙
    s = ball(5.0, v=(1.0, 0.0, 0.0))
    tr = simulate(s, 0.5, ["x0", "v0"])
    assert not tr.impacts
    J = tr.d_position(0, 0.5)
    assert np.abs(J - np.hstack([np.eye(3), 0.5 * np.eye(3)])).max() < 1e-14   # measured 0


def test_flight_tangent_readable_equals_matrix_and_rhs_equals_rigid():
    # ORACLES H3: the readable δ-formulas and the assembled matrix agree; f equals RigidBodies.derivative
    rng = np.random.default_rng(3)
    N, p = 2, 5
    y = rng.normal(size=13 * N)
    y[3 * N:7 * N] = (lambda q: (q / np.linalg.norm(q, axis=1, keepdims=True)).ravel())(rng.normal(size=(N, 4)))
    m = FlightModel(N, np.array([0.5, 2.0]), np.array([2.0, 0.5]), rng.uniform(1, 2, (N, 3)), np.array([0, 0, -9.81]),
                    rng.normal(size=(p, N)), rng.normal(size=(p, N)), rng.normal(size=(p, N, 3)))
    T = rng.normal(size=(p, 13 * N))
    f1, d1 = flight_tangent(m, y, T)
    f2, d2 = flight_tangent_readable(m, y, T)
    assert np.abs(d1 - d2).max() < 1e-12 and np.abs(f1 - f2).max() == 0.0
    rb = RigidBodies(mass=m.m, inertia=1.0 / m.Iinv)
    Q = np.zeros((N, 6))
    Q[:, :3] = m.m[:, None] * m.g
    assert np.abs(rb.derivative(y, Q) - f1).max() < 1e-13      # measured 2e-16


def test_grazing_impact_is_reported():
    # ORACLES H4: a ball that barely touches: S is not differentiable, a named warning and a flag
    b = DesignBody(Sphere(0.1), position=[0, 0, 0.1 + 2e-8], velocity=[1.0, 0, 0])
    s = DesignScene([b], [Plane([0, 0, 1])], gravity=[0, 0, -10.0])
    with pytest.warns(GrazingImpactWarning):
        tr = simulate(s, 0.1, ["x0"])
    assert not tr.differentiable and tr.impacts[0].grazing


def test_edit_reaches_target_in_few_updates():
    # ORACLES H5: a bouncing ball reaches a position target at t = 2 within 1e-6 in ≤ 6 updates
    b = DesignBody(Sphere(0.1), position=[0, 0, 1.0], velocity=[1.0, 0.3, 2.0])
    s = DesignScene([b], [Plane([0, 0, 1]), Plane([-1, 0, 0], offset=-2.0)], restitution=0.8)
    res = edit(s, ["x0", "v0"], None, [position_goal(0, 2.0, [0.5, 1.2, 0.6])], 2.0, h=0.02)
    assert res.success and res.residual < 1e-6 and res.iterations <= 6   # measured 3e-8 after 4
    with warnings.catch_warnings():              # driven toward the floor the ball comes to rest: grazing impacts
        warnings.simplefilter("ignore", GrazingImpactWarning)
        res2 = edit(s, ["x0", "v0"], None, [position_goal(0, 2.0, [0.5, 1.2, -3.6])], 2.0, h=0.02)
    assert not res2.success and res2.residual > 1.0            # below the floor: unreachable, says so


def test_edit_several_goals_position_and_orientation():
    # ORACLES H5: two times and an orientation goal on the tumbling box (no impact in the span)
    s = tumbling_box()
    goals = [position_goal(0, 0.3, [0.35, 0.1, 1.3]), orientation_goal(0, 0.45, quat_from_axis_angle([0, 0, 1], 1.0)),
             position_goal(0, 0.45, [0.5, 0.1, 1.0])]
    res = edit(s, ["x0", "theta0", "v0", "omega0"], None, goals, 0.45)
    assert res.success and res.residual < 1e-6                # measured 1e-12 after 4


def test_min_norm_update_properties():
    # ORACLES H6: the constraint holds, δu is the M-norm minimizer, rank deficiency gets damped
    rng = np.random.default_rng(0)
    A, r = rng.normal(size=(3, 7)), rng.normal(size=3)
    Mh = rng.normal(size=(7, 7))
    M = Mh @ Mh.T + 7 * np.eye(7)
    du = min_norm_update(A, r, M).du
    assert np.abs(A @ du - r).max() < 1e-12
    Z = np.linalg.svd(A)[2][3:].T                               # null space of A
    assert np.abs(Z.T @ M @ du).max() < 1e-10                   # optimality: Mδu ⊥ null(A)
    Ad = np.vstack([A, A[0]])                                   # dependent rows
    upd = min_norm_update(Ad, np.append(r, r[0] + 1.0))
    assert upd.rank_deficient and upd.damping > 0 and np.all(np.isfinite(upd.du))
    with pytest.raises(SingularMetric):
        min_norm_update(A, r, np.diag([1.0] * 6 + [0.0]))


def test_bad_input_named_errors():
    # ORACLES H6 (G3): times outside the span, wrong target size, unknown names
    s = ball()
    with pytest.raises(InvalidInput, match="times must lie"):
        simulate(s, 1.0, ["x0"], times=[1.5])
    with pytest.raises(UnknownParameter, match="does not exist"):
        simulate(s, 1.0, ["x7"])
    with pytest.raises(InvalidInput, match=r"target must be a float array of shape \(3,\).*got \[1.0, 2.0\]"):
        position_goal(0, 0.5, [1.0, 2.0])
    with pytest.raises(InvalidInput, match="outside the simulated span"):
        edit(s, ["x0"], None, [position_goal(0, 2.0, [0, 0, 1.0])], 1.0)
    with pytest.raises(InvalidInput, match="penetrates"):
        simulate(s, 1.0, ["x0"], [0, 0, 0.05])


@settings(max_examples=20, deadline=None)
@given(st.floats(0.2, 2.0), st.floats(0.0, 1.0), st.floats(-2.0, 2.0))
def test_property_energy_never_grows_and_derivatives_finite(h0, eps, vx):
    # ORACLES H4: impacts never add energy (ε ≤ 1); ∂S/∂u is finite or flagged
    s = ball(h0, eps, v=(vx, 0.0, 0.0))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", GrazingImpactWarning)
        tr = simulate(s, 1.0, ["x0", "v0", "restitution"], h=0.02, max_impacts=400)
    z, vz = tr.y[:, 2], tr.y[:, 9]
    E = 0.5 * vz ** 2 + G * z
    assert np.all(np.diff(E) <= 1e-9 * (1 + E[0]))
    assert np.all(np.isfinite(tr.d_position(0, 1.0))) or not tr.differentiable


# ---- chapter 10 figures (quick mode), each checked against its oracle


def test_figure_s_across_impact(figure_data):
    # ORACLES H4: where the impact count before T changes, ∂z/∂v₀z jumps (S not differentiable there);
    # on each side it is smooth (neighbouring differences small against the jump)
    d = figure_data("ch10_s_across_impact")
    assert len(np.unique(d["impacts"])) >= 2
    k = np.flatnonzero(np.diff(d["impacts"]) != 0)[0]
    jump = abs(d["dz"][k + 1] - d["dz"][k])
    same = np.diff(d["dz"])[np.diff(d["impacts"]) == 0]
    assert jump > 0.5 and jump > 5 * np.abs(same).max()           # measured 0.86 vs 0.055


def test_figure_derivative_vs_fd_step(figure_data):
    # ORACLES H2: the best Richardson difference agrees with the analytic derivative to 1e-6 relative
    d = figure_data("ch10_derivative_vs_fd_step")
    assert d["impacts"] == 2
    assert d["richardson"].min() / d["scale"] < 1e-8             # measured 3e-12
    assert d["plain"][-1] > 10 * d["richardson"][-1]              # large δ: extrapolation wins


def test_figure_edit_sequence(figure_data):
    # ORACLES H5: the drag ends near the target; the edit reaches it within 1e-6 in ≤ 6 updates
    d = figure_data("ch10_edit_sequence")
    assert np.abs(d["reached"][-1] - d["target"]).max() < 0.05     # measured 9e-3 after 4 frames
    assert d["edit_success"] and d["edit_residuals"][-1] < 1e-6 and d["edit_iterations"] <= 6


def test_figure_die_toss(figure_data):
    # ORACLES H5: position and orientation goals at once: the −x face points up at T
    d = figure_data("ch10_die_toss")
    assert d["success"] and d["impacts"] >= 1
    assert abs(d["face_up"][2] - 1.0) < 1e-9 and np.abs(d["position"] - [0.5, 0, 1.6]).max() < 1e-6


def test_figure_ball_into_target(figure_data):
    # ORACLES H5: the ball reaches the target after its bounces
    d = figure_data("ch10_ball_into_target")
    assert d["success"] and d["residual"] < 1e-6 and min(d["impacts"]) >= 1


def test_figure_shooting(figure_data):
    # ORACLES H8: one start s₀, a noisy sketch of six impacts in 4 s: single shooting converges to another
    # impact sequence far from the sketch; multiple shooting recovers the sketched motion to the noise level
    d = figure_data("ch10_shooting")
    assert d["multiple_success"] and d["multiple_violation"] < 1e-6        # measured 1e-11
    assert d["multiple_impacts"] == d["true_impacts"] == 6
    assert d["multiple_objective"] < 2 * d["noise_E"]                      # measured 0.039 vs ½·40·3σ² = 0.054
    assert d["multiple_goal_error"] < 1e-8                                 # one full run from u; measured 4e-12
    assert d["multiple_v0_error"] < 0.05                                   # measured 0.007 m/s
    assert d["single_impacts"] != d["true_impacts"]                        # measured 5
    assert d["single_objective"] > 30 * d["multiple_objective"]            # measured 4.05 vs 0.039 (105×)
    assert d["single_v0_error"] > 0.2                                      # measured 0.42 m/s


# ---- exact flight of spheres (ORACLES H7)


def two_spheres():
    b = [DesignBody(Sphere(0.1), mass=1.5, position=[0, 0, 1.0], velocity=[1.0, 0.3, 2.0], angular_velocity=[3, -2, 5]),
         DesignBody(Sphere(0.15), mass=0.7, position=[0.8, 0.1, 0.5], velocity=[-1.0, 0.0, 3.0])]
    return DesignScene(b, [Plane([0, 0, 1]), Plane([-1, 0, 0.1], offset=-2.0)], restitution=0.8)


NAMES2 = ["x0", "theta0", "v0", "omega0", "mass0", "x1", "v1", "restitution", "normal1"]


def test_exact_flight_matches_rk4_to_its_error():
    # ORACLES H7: same impacts (a sphere pair, floor, tilted wall), positions and ∂x/∂u to roundoff (RK4 is
    # exact on parabolas), orientations and ∂φ/∂u to the RK4 error, which falls as h⁴
    s, T = two_spheres(), 1.7
    ex = simulate(s, T, NAMES2, flight="exact")
    assert ex.flight == "exact" and [i.kind for i in ex.impacts] == ["pair"] + ["plane"] * 4
    errs = []
    for h in (0.02, 0.01):
        rk = simulate(s, T, NAMES2, h=h, flight="rk4")
        assert rk.flight == "rk4" and len(rk.impacts) == len(ex.impacts)
        assert max(abs(a.t - b.t) for a, b in zip(rk.impacts, ex.impacts)) < 1e-12     # measured 1e-15
        for i in (0, 1):
            assert np.abs(rk.position(i, T) - ex.position(i, T)).max() < 1e-12         # measured 5e-15
            assert np.abs(rk.d_position(i, T) - ex.d_position(i, T)).max() < 1e-11     # measured 3e-14
        errs.append(max(np.abs(rk.d_orientation(0, T) - ex.d_orientation(0, T)).max(),
                        np.abs(rk.orientation(0, T) - ex.orientation(0, T)).max()))
    assert errs[0] < 1e-5                                   # measured 1.4e-6 at h = 0.02
    assert order_fit([0.02, 0.01], errs).order > 3.5       # measured 4.0


def test_exact_flight_matches_richardson_fd():
    # ORACLES H2, H7: the closed-form sensitivities equal Richardson differences of the closed-form S
    s, T = two_spheres(), 1.7
    outs = [(0, T, "position"), (0, T, "orientation"), (1, T, "position")]
    A = analytic_jacobian(simulate(s, T, NAMES2), outs)
    F = fd_jacobian(s, NAMES2, None, T, outs, delta=1e-4)
    assert np.abs(A - F).max() / np.abs(F).max() < 1e-8    # measured 1.6e-11


def test_exact_flight_refused_where_it_does_not_apply():
    # ORACLES H7: boxes, anisotropic spheres and inertia parameters take the RK4 path; "exact" is refused by name
    with pytest.raises(InvalidInput, match="not a sphere"):
        simulate(tumbling_box(), 0.3, ["x0"], flight="exact")
    with pytest.raises(InvalidInput, match="inertia parameter"):
        simulate(ball(), 0.3, ["inertia0"], flight="exact")
    assert simulate(ball(), 0.3, ["inertia0"]).flight == "rk4"
    with pytest.raises(InvalidInput, match="flight must be"):
        simulate(ball(), 0.3, ["x0"], flight="euler")


@settings(max_examples=25, deadline=None)
@given(st.floats(0.05, 2.0), st.floats(-3.0, 3.0), st.floats(-3.0, 4.0), st.floats(0.0, 1.0), st.floats(0.0, 0.3))
def test_property_exact_impacts_equal_rk4(z0, vx, vz, eps, tilt):
    # ORACLES H7: the quadratic-root impact times and the states equal the RK4 run's (Brent on exact parabolas)
    b = DesignBody(Sphere(0.1), position=[0, 0, 0.1 + z0], velocity=[vx, 0.0, vz])
    s = DesignScene([b], [Plane([0, 0, 1]), Plane([-1, 0, tilt], offset=-1.0)], gravity=[0, 0, -G], restitution=eps)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", GrazingImpactWarning)
        try:
            rk = simulate(s, 1.0, ["x0"], h=0.02, flight="rk4", sensitivities=False, max_impacts=30)
        except TooManyImpacts:                                     # Zeno: both must say so
            with pytest.raises(TooManyImpacts):
                simulate(s, 1.0, ["x0"], h=0.02, flight="exact", sensitivities=False, max_impacts=30)
            return
        ex = simulate(s, 1.0, ["x0"], h=0.02, flight="exact", sensitivities=False, max_impacts=30)
    if any(i.speed < 1e-2 for i in ex.impacts):
        return                                       # grazing: RK4 may step over a touch the roots see
    te = [i.t for i in ex.impacts]
    # RK4 sees an impact only at a step's end: a flight shorter than two steps can hide inside one step
    k = next((k for k in range(1, len(te)) if te[k] - te[k - 1] < 0.04), len(te))
    assert np.abs(np.array([i.t for i in rk.impacts[:k]]) - te[:k]).max(initial=0.0) < 1e-10   # measured 1e-15
    if k == len(te) == len(rk.impacts):
        assert np.abs(rk.y[:, :3] - ex.y[:, :3]).max() < 1e-9      # measured ≤ 1e-13


@settings(max_examples=25, deadline=None)
@given(st.floats(-2, 2), st.floats(0.5, 3), st.floats(-3, 3), st.floats(-3, 3), st.floats(0.0, 0.5))
def test_property_flight_map_is_a_flow(x, z, vx, wz, tau):
    # ORACLES H7: the closed-form flight composes (φ_a ∘ φ_b = φ_{a+b}) for the state and the sensitivities
    s = DesignScene([DesignBody(Sphere(0.2), position=[x, 0, z], velocity=[vx, 1.0, 0.0],
                                angular_velocity=[0.3, 0.0, wz])], [], gravity=[0, 0, -G])
    tr = simulate(s, 0.1, ["x0", "theta0", "v0", "omega0", "mass0"], times=[0.1])
    y, T = tr.outputs[0.1]
    y2, T2 = flight_map(tr.model, *flight_map(tr.model, y, T, tau), 0.5 - tau)
    y1, T1 = flight_map(tr.model, y, T, 0.5)
    assert np.abs(y2 - y1).max() < 1e-12 and np.abs(T2 - T1).max() < 1e-11
    assert first_impact(Features(s), tr.model, y, np.zeros((0, 3)), 10.0, 1e-9) is None   # no planes: no impact


# ---- shooting machinery (ORACLES H8)


def test_clearance_and_state_names():
    # ORACLES H8: the clearance rows are the vertex gaps, their θ-Jacobian equals central differences
    s = tumbling_box()
    th, x = np.array([0.2, -0.1, 0.3]), np.array([0.1, 0.2, 0.6])
    g, Jx, Jt = clearance(s, x, th)
    assert g.shape == (16,) and np.allclose(Jx[:8], [0, 0, 1])
    from pbanim.derivatives import central_jacobian
    F = central_jacobian(lambda t: clearance(s, x, t)[0], th, eps=1e-6)
    assert np.abs(F - Jt).max() < 1e-8                                # measured 3e-10
    assert abs(clearance(ball(1.0), [0, 0, 0.5])[0][0] - 0.4) < 1e-15   # n·x − offset − r
    assert state_names(ball()) == ["x0", "v0"] and state_names(s) == ["x0", "theta0", "v0", "omega0"]
    assert state_names(ball(), [orientation_goal(0, 0.5, [1, 0, 0, 0])])[1] == "theta0"


@settings(max_examples=25, deadline=None)
@given(st.floats(-2, 2), st.floats(0.5, 3), st.floats(-2, 2), st.floats(-3, 3), st.floats(0.2, 0.8))
def test_property_states_from_sketch_exact_on_a_flight(x, z, vx, vz, tk):
    # ORACLES H8: on noise-free points of one flight the gravity-aware fit returns the exact node state
    g = np.array([0, 0, -G])
    x0, v0 = np.array([x, 0.3, z]), np.array([vx, 0.0, vz])
    sketch = [(t, x0 + v0 * t + 0.5 * g * t * t) for t in np.linspace(0, 1, 11)]
    s = DesignScene([DesignBody(Sphere(0.1), position=[0, 0, 5.0])], [], gravity=g)
    (xk, vk), = states_from_sketch(s, sketch, [tk], 0.25, impacts=[])
    assert np.abs(xk - (x0 + v0 * tk + 0.5 * g * tk * tk)).max() < 1e-9
    assert np.abs(vk - (v0 + g * tk)).max() < 1e-9


def test_shooting_bad_input_and_unreachable_goal():
    # ORACLES H8 (G3): node times, node states and sketch points are checked; an unreachable goal says so
    s = ball(1.0, v=(0.5, 0, 1.0))
    goal = [position_goal(0, 1.0, [0.5, 0.0, 0.5])]
    with pytest.raises(InvalidInput, match="node_times"):
        multiple_shooting(s, goal, 1.0, node_times=[0.2, 0.5])
    with pytest.raises(InvalidInput, match="one state per node"):
        multiple_shooting(s, goal, 1.0, node_times=[0.0, 0.5], initial_states=[(np.zeros(3), np.zeros(3))])
    with pytest.raises(InvalidInput, match="sketch points"):
        single_shooting(s, None, goal, 1.0, sketch=[(0.5, [1.0, 2.0])])
    with pytest.raises(InvalidInput, match="at least 3"):
        sketch_impacts(s, [(0.1, [0, 0, 1.0])])
    res = single_shooting(s, None, [position_goal(0, 1.0, [0.5, 0.0, -2.0])], 1.0, maxiter=20)
    assert not res.success and res.violation > 1.0 and "not converged" in res.message   # below the floor


def test_multiple_shooting_root_finding_from_a_perturbed_motion():
    # ORACLES H8: nodes on a perturbed motion, no sketch: continuity and the goal close to 1e-6; the nodes
    # slide to the midpoints between the solution's impacts
    s = ball(1.0, eps=0.8, v=(0.5, 0.0, 1.0))
    goal = [position_goal(0, 1.6, [1.0, 0.0, 0.6])]
    res = multiple_shooting(s, goal, 1.6, nodes=3, u0=[0, 0, 1.1, 0.6, 0.0, 1.2], maxiter=50)
    assert res.success and res.violation < 1e-6                    # measured 1e-13
    tr = simulate(s, 1.6, res.names, res.u, times=[1.6])
    assert np.abs(tr.position(0, 1.6) - [1.0, 0.0, 0.6]).max() < 1e-6
    hits = [i.t for i in tr.impacts]
    assert len(res.node_times) == len(hits) and np.allclose(res.node_times[1:], 0.5 * (np.array(hits[:-1]) + hits[1:]),
                                                             atol=1e-3)


def test_design_benchmark_smoke_run_prints_its_goals():
    from pbanim.bench import format_report, run_bench

    text = format_report(run_bench("design", quick=True))
    assert "goal design-analytic-vs-fd:" in text and "goal design-update-ms:" in text
