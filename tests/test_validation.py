"""Pinned defects of issue #13 ("Nothing silent"): each bad input below raises a named error.

The fuzz suite (tests/test_fuzz.py) searches at random; these are the explicit cases it or the issue found.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

import pbanim
from pbanim.collision import Collisions, Plane, Sphere, check_restitution
from pbanim.constraints import (Constraints, Distance, OnCircle, OnLine, baumgarte_gains, gains_from_erp_cfm,
                                gains_from_mujoco, solve_multipliers)
from pbanim.contact import RestingContact, TimeStepping, make_contacts
from pbanim.errors import InvalidInput, PbanimError, StepLimitExceeded, check_count, check_number
from pbanim.ode.driver import step_grid
from pbanim.particles import AnchorSprings, DampedSprings, Drag, Gravity, ParticleSystem
from pbanim.scene import Scene
from pbanim.testing import assert_conserved, drift_ratio

NAN, INF = float("nan"), float("inf")


def _bind(effect, system=None):
    system = system or ParticleSystem([[0.0, 0.0], [1.0, 0.0]])
    return Scene(system, [effect])


# -- stiffness, damping and gains --------------------------------------------------------------------------
@pytest.mark.parametrize("bad", [NAN, INF, -INF, -1.0])
def test_spring_stiffness_and_damping_refuse_nan_inf_and_negative(bad):
    with pytest.raises(InvalidInput, match=f"stiffness must be .*entries >= 0.*got {bad}"):
        _bind(DampedSprings([[0, 1]], stiffness=bad))
    with pytest.raises(InvalidInput, match=f"damping must be .*entries >= 0.*got {bad}"):
        _bind(DampedSprings([[0, 1]], damping=bad))
    with pytest.raises(InvalidInput, match="damping"):
        _bind(Drag(bad))
    with pytest.raises(InvalidInput, match="damping"):
        AnchorSprings([0], damping=bad)
    with pytest.raises(InvalidInput, match="stiffness"):
        pbanim.RigidSprings([0], [[0, 0, 0]], [-1], [[0, 0, 1]], stiffness=bad)
    with pytest.raises(InvalidInput, match="damping"):
        pbanim.RigidSprings([0], [[0, 0, 0]], [-1], [[0, 0, 1]], stiffness=1.0, damping=bad)
    with pytest.raises(InvalidInput, match="stiffness"):
        RestingContact(lambda y: None, stiffness=bad)
    with pytest.raises(InvalidInput, match="damping"):
        RestingContact(lambda y: None, damping=bad)
    with pytest.raises(InvalidInput, match="ks must be a finite number >= 0"):
        Constraints([Distance([[0, 1]])], stabilization="baumgarte", ks=bad, kd=1.0)


def test_rigid_spring_rest_length_nan_refused():
    rb = pbanim.RigidBodies(1.0, [1.0, 1.0, 1.0])
    with pytest.raises(InvalidInput, match="RigidSprings.__init__: rest_length must be .*entries >= 0.*got nan"):
        pbanim.RigidScene(rb, [pbanim.RigidSprings([0], [[0, 0, 0]], [-1], [[0, 0, 1]], 1.0, rest_length=NAN)])


@pytest.mark.parametrize("call", [lambda: baumgarte_gains(1e300), lambda: gains_from_mujoco(5e-324, 1.0),
                                  lambda: gains_from_erp_cfm(0.5, 5e-324, 5e-324),
                                  lambda: gains_from_erp_cfm(0.5, 1.0, INF)])
def test_gains_that_overflow_or_divide_by_zero_are_refused(call):
    with pytest.raises(InvalidInput):      # was inf gains, or a bare ZeroDivisionError
        call()


# -- masses, radii, restitution ---------------------------------------------------------------------------
def test_tiny_mass_with_infinite_inverse_refused():
    with pytest.raises(InvalidInput, match="too small for its inverse"):
        ParticleSystem([[0.0, 0.0]], masses=5e-324)


@pytest.mark.parametrize("radius", [-1.0, NAN, INF, [0.1, 0.2, 0.3]])
def test_collision_radius_refused(radius):
    ps = ParticleSystem([[0.0, 1.0], [1.0, 1.0]])
    with pytest.raises(InvalidInput, match="radius"):
        Scene(ps, [Collisions(obstacles=[Plane([0, 1])], radius=radius)])


def test_nan_restitution_is_refused_not_zero():
    with pytest.raises(InvalidInput, match="check_restitution: restitution must be a finite number >= 0 and <= 1, got nan"):
        check_restitution(NAN)
    with pytest.raises(InvalidInput, match="Collisions.__init__: restitution must be .*, got nan"):
        Collisions(obstacles=[Plane([0, 1])], restitution=NAN)


@pytest.mark.parametrize("shape", [lambda: Sphere(1e300).inertia(1e300), lambda: pbanim.Capsule(1.0, 1e308).inertia(1.0),
                                   lambda: pbanim.Box([1e300, 1e300, 1.0]).inertia(1e10)])
def test_shape_inertia_overflow_refused(shape):
    with pytest.raises(InvalidInput, match="overflow"):
        shape()


def test_box_half_extents_of_wrong_length_refused():
    with pytest.raises(InvalidInput, match=r"Box.__init__: half_extents must be a float array of shape \(3,\).* got \[1.0, 1.0, 1.0, 1.0\]"):
        pbanim.Box([1.0, 1.0, 1.0, 1.0])


def test_inertia_helpers_refuse_overflow_and_bad_axis():
    from pbanim.rigid import capsule_inertia, cylinder_inertia, parallel_axis, principal_axes, sphere_inertia

    with pytest.raises(InvalidInput, match="not finite and > 0"):
        sphere_inertia(1e300, 1e300)
    with pytest.raises(InvalidInput, match="not finite and > 0"):
        capsule_inertia(1.0, 1e200, 1.0)          # was a bare OverflowError (r ** 3)
    with pytest.raises(InvalidInput, match="cylinder_inertia: axis must be an index in 0 … 2, got 0.0"):
        cylinder_inertia(1.0, 1.0, 1.0, axis=0.0)  # was a bare IndexError
    with pytest.raises(InvalidInput, match=r"parallel_axis: offset must be .*got \[\]; shape \(0,\)"):
        parallel_axis(np.eye(3), 1.0, [])
    with pytest.raises(InvalidInput, match="parallel_axis: mass must be .*entries >= 0.*got -1.0"):
        parallel_axis(np.eye(3), -1.0, [1.0, 0.0, 0.0])
    with pytest.raises(InvalidInput, match="principal_axes: inertia must be .*it has NaN or inf entries"):
        principal_axes(np.full((3, 3), NAN))


# -- contacts: geometry and normals ------------------------------------------------------------------------
def test_zero_contact_normal_refused():
    with pytest.raises(InvalidInput, match="unit normals"):
        make_contacts([0], [-1], [[0.0, 0.0, 0.0]], [[0.0, 0.0, 0.0]])


@pytest.mark.parametrize("field", ["point", "depth", "normal"])
def test_nan_contact_geometry_refused_not_read_as_no_contact(field):
    args = {"point": [[0.0, 0.0, 0.0]], "normal": [[0.0, 0.0, 1.0]], "depth": [0.1]}
    args[field] = np.full_like(np.asarray(args[field], float), NAN)
    with pytest.raises(InvalidInput, match=f"make_contacts: {field} must be a float array .*\\(finite\\), got "
                                           f"array\\(\\[.*nan.*; it has NaN or inf entries"):
        make_contacts([0], [-1], args["point"], args["normal"], args["depth"])


def test_contact_fields_of_mismatched_size_refused():
    with pytest.raises(InvalidInput, match="point must hold 2-D or 3-D points .*got shape \\(1, 1\\)"):
        make_contacts([0], [-1], [[1.0]], [[1.0]])
    with pytest.raises(InvalidInput, match="normal must be a float array of shape \\(m, d\\) \\(m = 1, d = 3\\)"):
        make_contacts([0], [-1], [[1.0, 0.0, 0.0]], [[1.0, 0.0]])
    c = make_contacts([0, 0], [-1, -1], [[0, 0, 0]] * 2, [[0, 0, 1.0]] * 2)
    with pytest.raises(InvalidInput, match="Contacts.select: mask must be a bool array with one entry per contact.*"
                                           "got array\\(\\[ True, False, True\\]\\)"):
        c.select(np.array([True, False, True]))


def test_3d_plane_in_2d_particle_scene_refused_at_bind():
    ps = ParticleSystem([[0.0, 1.0]])
    with pytest.raises(InvalidInput, match="3-D plane .* 2-D particle scene"):
        Scene(ps, [Gravity(), Collisions(obstacles=[Plane([0, 0, 1])])])
    with pytest.raises(InvalidInput, match="centre"):
        Collisions(obstacles=[(Sphere(1.0), [0.0, 0.0, 0.0, 0.0])])


# -- constraints: indices and lengths ------------------------------------------------------------------------
def test_distance_index_and_length_arrays_of_wrong_size_refused():
    with pytest.raises(InvalidInput, match="pairs must be an integer array of shape \\(m, 2\\).*got \\[\\[0, 1, 2\\]\\]"):
        Distance([[0, 1, 2]])
    with pytest.raises(InvalidInput, match="lengths must be a float array of shape \\(m,\\).*m = 1.*got \\[1.0, 2.0\\]"):
        Distance([[0, 1]], lengths=[1.0, 2.0])
    with pytest.raises(InvalidInput, match="pairs must be .*got \\[\\[0, 1.5\\]\\]; entries are not integers"):
        Distance([[0, 1.5]])
    with pytest.raises(InvalidInput, match="anchors must be .*got \\[\\[0.0, 0.0, 0.0\\], \\[1.0, 1.0, 1.0\\]\\]"):
        Distance([[0, -1]], lengths=1.0, anchors=[[0.0, 0.0, 0.0], [1.0, 1.0, 1.0]])   # 2 anchors for 1 rod
    d = Distance([[0, -1]], lengths=1.0, anchors=[0.0, 0.0, 0.0])
    with pytest.raises(InvalidInput, match="anchors"):
        d.bind(2, 2)        # a 3-D anchor in a 2-D system
    with pytest.raises(InvalidInput, match="radius"):
        OnCircle([0, 1], [0.0, 0.0], [1.0, 2.0, 3.0])
    with pytest.raises(InvalidInput, match="direction"):
        OnLine([0], [0.0, 0.0], 1.0)


def test_constraints_with_no_rows_solve_to_nothing():
    ps = ParticleSystem([[0.0, 0.0]])
    for solver in ("auto", "kkt", "witkin-cg", "witkin-sparse"):
        assert solve_multipliers([Distance(np.zeros((0, 2), int), 1.0)], ps, ps.state(), solver=solver).lam.size == 0


# -- counts, step caps, overflow ---------------------------------------------------------------------------
@pytest.mark.parametrize("value", [0, -1, 2.5, NAN, INF, "3", None, True])
def test_counts_refuse_zero_nan_inf_and_non_integers(value):
    with pytest.raises(InvalidInput, match="must be a positive integer"):
        step_grid(0.0, 1.0, 0.1, max_steps=value)
    with pytest.raises(InvalidInput, match="must be a positive integer"):
        step_grid(0.0, 1.0, 0.1, record_every=value)
    ps = ParticleSystem([[0.0, 0.0]])
    with pytest.raises(InvalidInput, match="check_every must be a positive integer"):
        Scene(ps, [Gravity()]).simulate(0.1, 0.01, check_every=value)   # 0 was a ZeroDivisionError path


def test_solve_max_steps_inf_is_not_an_overflow_error():
    with pytest.raises(InvalidInput, match="max_steps"):
        pbanim.solve(lambda t, y: -y, (0.0, 1.0), [1.0], h=0.1, max_steps=INF)
    with pytest.raises(StepLimitExceeded):
        pbanim.solve(lambda t, y: -y, (0.0, 1e300), [1.0], h=1e-300)


def test_check_helpers():
    assert check_count("n", 3.0) == 3 and check_count("m", 0, 0) == 0
    assert check_number("x", "2.5") == 2.5
    with pytest.raises(InvalidInput, match="stiffness must be a finite number >= 0, got nan"):
        check_number("stiffness", NAN, low=0.0)
    with pytest.raises(InvalidInput, match="erp must be a finite number > 0 and <= 1, got 0"):
        check_number("erp", 0, low=0.0, low_open=True, high=1.0)


# -- empty inputs ---------------------------------------------------------------------------------------------
@pytest.mark.parametrize("series", [[], [1.0], np.zeros((0, 3)), [1.0, NAN]])
def test_drift_ratio_refuses_empty_short_and_nan_series(series):
    with pytest.raises(InvalidInput, match="series"):
        drift_ratio(series)


@pytest.mark.parametrize("series", [[], np.zeros((0, 2)), [NAN]])
def test_assert_conserved_refuses_empty_and_nan_series(series):
    with pytest.raises(InvalidInput, match="series"):
        assert_conserved(series, 1e-9)


def test_drift_ratio_tiny_late_fraction_keeps_one_sample():
    assert drift_ratio([1.0, 2.0, 3.0], late=1e-300) == 2.0   # last sample |3 − 1| over first |2 − 1|


def _no_contacts(y):
    return make_contacts(np.zeros(0, int), np.zeros(0, int), np.zeros((0, 3)), np.zeros((0, 3)), np.zeros(0))


@pytest.mark.parametrize("solver", ["qp", "lemke", "pgs"])
def test_resting_contact_with_no_contacts_at_all(solver):
    ps = ParticleSystem([[0.0, 0.0, 1.0]])
    res = Scene(ps, [Gravity(), RestingContact(_no_contacts, solver)]).simulate(0.1, 0.01)
    assert np.all(np.isfinite(res.y)) and res.diagnostics["contact_count"].max() == 0
    res = Scene(ps, [Gravity(), RestingContact(lambda y: None, solver)]).simulate(0.1, 0.01)
    assert np.all(np.isfinite(res.y))


@pytest.mark.parametrize("rigid", [False, True])
def test_time_stepping_with_no_contacts_at_all(rigid):
    system = pbanim.RigidBodies(1.0, [1.0, 1.0, 1.0]) if rigid else ParticleSystem([[0.0, 0.0, 1.0]])
    g = pbanim.RigidGravity() if rigid else Gravity()
    res = TimeStepping(system, _no_contacts, [g], friction=0.5).simulate(0.1, 0.01)
    assert np.all(np.isfinite(res.y)) and res.diagnostics["contact_count"].max() == 0


def test_time_stepping_friction_per_contact_of_wrong_count():
    ps = ParticleSystem([[0.0, 0.0, 0.0]])
    floor = lambda y: make_contacts([0], [-1], [y[:3]], [[0.0, 0.0, 1.0]], [-y[2]])  # noqa: E731
    ts = TimeStepping(ps, floor, [Gravity()], friction=[0.1, 0.2])
    with pytest.raises(InvalidInput, match="friction has 2 values but detect returned 1 contacts"):
        ts.simulate(0.02, 0.01)


def test_reduced_system_u0_of_wrong_size_is_named():
    from pbanim.models.reduced import n_link_chart

    q, J, Jd = n_link_chart([1.0, 1.0])
    with pytest.raises(InvalidInput, match="u0"):
        pbanim.ReducedSystem(q, J, Jd, u0=np.zeros(3))
    with pytest.raises(InvalidInput, match="u0"):
        pbanim.ReducedSystem(q, J, Jd, u0=[])


def test_model_constructors_refuse_inf_counts_and_scales():
    from pbanim.models import constrained, contact

    with pytest.raises(InvalidInput, match="n must be a positive integer, got inf"):
        constrained.hanging_chain(INF)
    with pytest.raises(InvalidInput, match="spread"):
        constrained.random_chain(3, np.random.default_rng(0), spread=1e300)
    with pytest.raises(InvalidInput, match="m must be an integer ≥ 0"):
        contact.trivial_lcp(-1)
    with pytest.raises(InvalidInput, match="box_half"):
        contact.sphere_pour(5, box_half=INF)


def test_icosphere_subdivisions_capped():
    from pbanim.rigid import icosphere_mesh

    with pytest.raises(InvalidInput, match="icosphere_mesh: subdivisions must be an integer >= 0 and <= 7, got 50"):
        icosphere_mesh(1.0, 50)          # 20·4⁵⁰ faces: was an endless run


def test_rigid_bodies_without_bodies_is_named():
    with pytest.raises(InvalidInput, match="mass"):       # was a bare IndexError (m_in[0])
        pbanim.RigidBodies([], [1.0, 1.0, 1.0])


def test_errors_are_pbanim_errors():
    assert issubclass(InvalidInput, PbanimError) and issubclass(InvalidInput, ValueError)
    assert math.isfinite(check_number("h", 1e-3, low=0.0, low_open=True))


def test_baumgarte_stability_limit_upper_is_bounded():
    from pbanim.constraints import baumgarte_stability_limit

    with pytest.raises(InvalidInput, match="upper must be a finite number > 0.001 and <= 1e\\+06"):
        baumgarte_stability_limit("rk4", 1.0, upper=INF)   # the bisection now has a cap known up front
    assert abs(baumgarte_stability_limit("symplectic_euler", 1.0) - (2 * math.sqrt(2) - 2)) < 1e-9


def test_batch_of_zero_initial_conditions_refused():
    with pytest.raises(InvalidInput, match="y0"):
        pbanim.solve(lambda t, y: y, (0.0, 1.0), np.zeros((0, 1)), method="dopri5")


def test_text_where_numbers_go_is_named():
    # a student passing a string (or another non-number) gets InvalidInput naming the argument, never
    # numpy's "could not convert string to float"
    ps = pbanim.ParticleSystem([[0.0, 1.0]])
    cases = {
        "y0": lambda: pbanim.solve(lambda t, y: -y, (0, 1), "abc", h=0.1),
        "h": lambda: pbanim.solve(lambda t, y: -y, (0, 1), [1.0], h="x"),
        "t_span": lambda: pbanim.solve(lambda t, y: -y, "ab", [1.0], h=0.1),
        "g": lambda: pbanim.Scene(ps, [pbanim.Gravity("x")]),
        "t_end": lambda: pbanim.Scene(ps, []).simulate("x", 0.1),
        "normal": lambda: pbanim.Plane("abc"),
        "A": lambda: pbanim.solve_lcp("a", "b"),
        "a must be": lambda: pbanim.make_contacts("a", [-1], [[0, 0, 0]], [[0, 0, 1]]),
        "restitution": lambda: pbanim.Collisions(obstacles=[pbanim.Plane([0, 1])], restitution="x"),
        "positions": lambda: pbanim.ParticleSystem("abc"),
        "mass": lambda: pbanim.RigidBodies("a", [1.0, 1.0, 1.0]),
    }
    for name, call in cases.items():
        with pytest.raises(InvalidInput, match=name):
            call()
