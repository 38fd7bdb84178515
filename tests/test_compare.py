"""Engines side by side (chapter 11): the pbanim side of every scene against its closed form, the harness's
rows and failures, the reports, the command line and the chapter's figure data (ORACLES K1–K9).

Nothing here needs the ``peers`` extra: peer rows are exercised through a patched import check and fake
engines; the peers themselves are tested in ``tests/test_compare_peers.py`` (skipped without them).
"""

import json
from types import SimpleNamespace

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from pbanim.cli import main
from pbanim.compare import (ENGINES, SCENES, Body, Engine, Joint, SceneSpec, Trace, Unsupported, check_names,
                            energy, energy_readable, joint_drift, run_compare, scene, top_precession)
from pbanim.compare import harness
from pbanim.compare.native import run_native
from pbanim.compare.peer_bullet import _check as bullet_check
from pbanim.compare.peer_mujoco import bounce_solref, mjcf
from pbanim.errors import InvalidInput
from pbanim.testing import order_fit

G = 9.81


@pytest.fixture(scope="module")
def native(figure_data):
    """The pbanim rows of the chapter's quick comparison (one run per session, shared with the figures):
    {scene: [rows by step, coarse first]}."""
    rows = [SimpleNamespace(**r) for r in figure_data("ch11_error_vs_cost")["rows"] if r["engine"] == "pbanim"]
    return {n: sorted((r for r in rows if r.scene == n), key=lambda r: -r.h) for n in dict.fromkeys(r.scene for r in rows)}


def test_every_scene_runs_in_pbanim(native):
    # ORACLES K9: one ok row per scene and step (pbanim is always installed)
    assert set(native) == set(SCENES) and len(SCENES) == 10
    for name, rows in native.items():
        assert [r.status for r in rows] == ["ok"] * len(rows), (name, [r.reason for r in rows])
        assert all(r.steps > 0 and r.wall > 0 for r in rows)


# -- the pbanim side of every scene against its closed form ---------------------------------------------
def test_free_flight_rk4_is_exact(native):
    # ORACLES K1: RK4 is exact on a parabola; measured 3.6e-15 and 7.4e-15 m, bound 1e-12 m
    for name in ("free_fall", "projectile"):
        assert max(r.error for r in native[name]) < 1e-12


@pytest.mark.parametrize("h", [1e-2, 5e-3])
def test_free_fall_symplectic_euler_is_off_by_g_h_t_over_2(h):
    # ORACLES K1: semi-implicit Euler xₙ = x(tₙ) + ½ g h tₙ exactly (the step map of PyBullet and MuJoCo);
    # measured deviation 3.6e-15 m, bound 1e-12 m
    sc = scene("free_fall")
    tr = run_native(sc.spec, h, 1.0, "symplectic_euler")
    g = np.asarray(sc.spec.gravity)
    t = tr.t[:, None]
    exact = np.asarray(sc.spec.bodies[0].x) + 0.5 * g * t * t
    assert np.abs(tr.x[:, 0] - (exact + 0.5 * g * h * t)).max() < 1e-12
    assert abs(sc.score(tr)["error"] - 0.5 * G * h * 1.0) < 1e-12


def test_bounce_apexes_are_exact(native):
    # ORACLES K2: apexes 1–3 at ε^(2k) h₀; measured 4.3e-15 relative, bound 1e-12
    for r in native["bounce"]:
        assert r.error < 1e-12 and abs(r.metrics["apex_1"] - 0.64) < 1e-12


def test_bounce_rests_by_the_zeno_time():
    # ORACLES K2: at rest no later than t∞ + h, no earlier than t∞ − 6εh/(1−ε) − 2ε·0.05/(g(1−ε)) − 2h
    # (measured t∞ − 0.0997 s at h = 4 ms; bound t∞ − 0.145 s)
    sc, h = scene("bounce"), 4e-3
    eps = sc.spec.params["restitution"]
    err = sc.score(run_native(sc.spec, h, sc.spec.duration))["rest_time_error"]
    assert -(6 * eps * h + 2 * eps * 0.05 / G) / (1 - eps) - 2 * h <= err <= h


def test_incline_sticks_below_and_slides_above_tan_theta_mu(native):
    # ORACLES K3: stick s ≡ 0 (measured 9.7e-20 m, bound 1e-12); slide: fitted a exact (measured 3.7e-15,
    # bound 1e-12) and the displacement error is the step map's a h T / 2 (rtol 1e-9; measured 3.29e-4 m)
    assert max(r.error for r in native["incline_stick"]) < 1e-12
    sc = scene("incline_slide")
    a, T = sc.spec.params["acceleration"], sc.spec.time(True)
    assert a > 0 and not sc.spec.params["static"] and scene("incline_stick").spec.params["static"]
    for r in native["incline_slide"]:
        assert r.metrics["acceleration_error"] < 1e-12
        assert r.error == pytest.approx(0.5 * a * r.h * T, rel=1e-9)


def test_sliding_sphere_starts_rolling_at_2v0_over_7_mu_g(native):
    # ORACLES K4: v(t) exact at every step (measured 6e-15 m/s, bound 1e-12); rolling found within one
    # step of t* (measured 1.8e-3 s at h = 4e-3)
    p = scene("rolling").spec.params
    assert p["t_roll"] == pytest.approx(2 * p["v0"] / (7 * p["friction"] * G), rel=1e-15)
    for r in native["rolling"]:
        assert r.error < 1e-12 and r.metrics["v_final_error"] < 1e-12
        assert r.metrics["t_roll_error"] <= r.h


def test_chain_energy_error_is_fourth_order_and_joints_stay_closed(native):
    # ORACLES K5: RK4 energy error slope in [3.5, 4.5] (measured 3.98); joint drift at h = 4 ms measured
    # 2.0e-10 m over 0.15 s, bound 1e-9 m
    rows = native["chain"]
    fit = order_fit([r.h for r in rows], [r.error for r in rows], window=(1e-14, 1.0))
    assert 3.5 <= fit.order <= 4.5
    assert rows[0].h == 4e-3 and rows[0].metrics["joint_drift"] < 1e-9


def test_cradle_passes_the_velocity_to_the_last_ball(native):
    # ORACLES K6: final (0, …, 0, v₀) and energy kept; measured 0, bound 1e-12
    for r in native["cradle"]:
        assert r.error < 1e-12 and abs(r.metrics["energy_loss"]) < 1e-12


def test_cradle_impact_on_a_step_boundary_is_elastic():
    # ORACLES K6: gap 0.05 m at v₀ = 1 m/s puts the second impact at t = 0.1 s = 400 h, exactly on a step
    # boundary; before the fix the pair touching at the start of that step was stopped plastically (final
    # (0, 0.5, 0.5) v₀); expected (0, 0, 1) v₀ to 1e-12
    from pbanim.compare.scenes import cradle

    sc = cradle(gap=0.05)
    assert sc.score(run_native(sc.spec, 2.5e-4, sc.spec.duration))["error"] < 1e-12


def test_stack_stays_at_rest(native):
    # ORACLES K7: drift 0 (measured 0), penetration ≤ 1e-12 m (measured 1e-16), settling time 0
    for r in native["stack"]:
        assert r.error < 1e-12 and r.metrics["penetration"] < 1e-12 and r.metrics["settling_time"] == 0.0


def test_top_precession_root_and_fast_top_limit():
    # ORACLES K8: the slow root satisfies I₁′cosθ Ω² − I₃ω₃Ω + mgr = 0 (1e-12 relative) and tends to
    # mgr/(I₃ω₃) with relative difference ≈ I₁′cosθ mgr/(I₃ω₃)² (within 2× of it)
    m, r, I1, I3, th = 1.0, 0.1, 9e-4, 1.8e-3, 0.3
    with pytest.raises(InvalidInput, match="spin must exceed 112.3 rad/s"):
        top_precession(m, r, I1, I3, 50.0, th)      # 2√(I₁′cosθ mgr)/I₃ = 112.30 rad/s, computed by hand
    for spin in (150.0, 1e3, 1e4):
        Om = top_precession(m, r, I1, I3, spin, th)
        a, b, c = (I1 + m * r * r) * np.cos(th), I3 * spin, m * G * r
        assert abs(a * Om * Om - b * Om + c) < 1e-12 * c
        lead = a * c / b ** 2
        assert 0 < Om / (c / b) - 1 < 2 * lead


def test_top_precesses_at_the_exact_rate_to_fourth_order(native):
    # ORACLES K8: measured 3.0e-4 (h = 2 ms) and 1.7e-5 (h = 1 ms) over 0.15 s, bounds 2e-3 and 1e-4
    err = {r.h: r.error for r in native["top"]}
    assert err[2e-3] < 2e-3 and err[1e-3] < 1e-4
    assert 3.5 < np.log2(err[2e-3] / err[1e-3]) < 4.5


# -- energy from a trace: the readable loop equals the vectorized one -------------------------------------
@settings(max_examples=25, deadline=None)
@given(st.integers(0, 2**31 - 1), st.integers(1, 4), st.integers(1, 6))
def test_energy_readable_matches_vectorized(seed, n, k):
    # measured ≤ 4e-16 relative, bound 1e-12
    rng = np.random.default_rng(seed)
    bodies = tuple(Body(f"b{i}", "sphere", (0.1,), rng.uniform(0.5, 2), rng.uniform(0.1, 1, 3), rng.normal(size=3))
                   for i in range(n))
    spec = SceneSpec("s", "s", bodies, rng.normal(size=3), 1.0, (0.1,), (0.1,))
    q = rng.normal(size=(k, n, 4))
    tr = Trace(np.arange(k) * 0.1, rng.normal(size=(k, n, 3)), q, rng.normal(size=(k, n, 3)), rng.normal(size=(k, n, 3)),
               0.0, k)
    a, b = energy(spec, tr), energy_readable(spec, tr)
    assert np.allclose(a, b, rtol=1e-12, atol=1e-12 * np.abs(b).max())


# -- translations written without the engines: MJCF text and the PyBullet checks -------------------------
def test_mujoco_bounce_spring_rebounds_at_epsilon():
    # ORACLES K2 (mapping): r̈ + b ṙ + k r = 0 with (k, b) from bounce_solref rebounds at exactly ε after
    # a half period π/ω_d = 10 h; measured 2e-16, bound 1e-12
    for eps in (0.3, 0.8, 0.99):
        k, b = (-x for x in bounce_solref(eps, 1e-3))
        zeta = b / (2 * np.sqrt(k))
        wd = np.sqrt(k) * np.sqrt(1 - zeta * zeta)
        assert abs(np.exp(-zeta * np.sqrt(k) * np.pi / wd) - eps) < 1e-12
        assert abs(np.pi / wd - 10e-3) < 1e-15
    text = mjcf(scene("bounce").spec, 2e-3)
    assert 'solref="-' in text and 'solimp="0.99 0.99 0.001"' in text and text.count("solref") == 2
    assert 'solref' not in mjcf(scene("stack").spec, 2e-3)           # ε = 0: MuJoCo's default contact


def test_mujoco_quaternion_order_and_inertia_are_written_as_the_scene_says():
    text = mjcf(scene("chain").spec, 1e-3)
    assert text.count('type="hinge"') == 3 and "freejoint" not in text and "<geom" not in text
    sc = scene("top").spec
    text = mjcf(sc, 1e-3)
    assert '<joint type="ball"/>' in text and 'pos="-0.0 -0.0 0.1"' in text and 'diaginertia="0.0009 0.0009 0.0018"' in text


def test_engines_refuse_what_they_cannot_express():
    # ORACLES K9: Bullet clamps the combined μ to 10; MuJoCo averages two geoms' solref; pbanim's contact
    # scenes have their own step map
    sc = scene("rolling").spec
    rough = SceneSpec(sc.name, sc.title, (Body("ball", "sphere", (0.1,), 1.0, (4e-3,) * 3, (0, 0, 0.1), friction=12.0),),
                      sc.gravity, sc.duration, sc.steps, sc.quick_steps, ground=True)
    with pytest.raises(Unsupported, match="clamps the combined friction coefficient to 10"):
        bullet_check(rough)
    cr = scene("cradle").spec
    mixed = SceneSpec(cr.name, cr.title, (cr.bodies[0], Body("b", "sphere", (0.1,), 1.0, (4e-3,) * 3, (1, 0, 0),
                                                              restitution=0.5)), cr.gravity, cr.duration, cr.steps,
                      cr.quick_steps)
    with pytest.raises(Unsupported, match="different restitutions"):
        mjcf(mixed, 1e-3)
    with pytest.raises(Unsupported, match="own step map"):
        run_native(scene("stack").spec, 1e-2, 0.1, "symplectic_euler")


# -- the harness: rows for every failure, bad names refused (ORACLES K9) ----------------------------------
def _fake(run):
    return Engine("fake", None, run)


def test_peer_rows_say_not_installed(monkeypatch):
    monkeypatch.setattr(harness, "have", lambda module: module is None)
    cmp = run_compare(["free_fall"], quick=True)
    by = {r.engine: r for r in cmp.rows if r.h == 1e-2}
    assert by["pbanim"].status == "ok"
    for e in ("pybullet", "mujoco"):
        assert by[e].status == "not installed" and e in by[e].reason and np.isnan(by[e].error)
    assert "not installed" in cmp.to_markdown()


def test_crash_nan_unsupported_and_wrong_start_are_rows_and_the_run_goes_on(monkeypatch):
    def crash(spec, h, t_end, option=None):
        raise RuntimeError("segfault-like")

    def nan(spec, h, t_end, option=None):
        tr = run_native(spec, h, t_end)
        tr.x[-1, 0, 2] = np.nan
        return tr

    def moved(spec, h, t_end, option=None):
        tr = run_native(spec, h, t_end)
        tr.x += 0.01
        return tr

    def refuse(spec, h, t_end, option=None):
        raise Unsupported("fake", "no such knob")

    fakes = {"crash": crash, "nan": nan, "moved": moved, "refuse": refuse}
    monkeypatch.setattr(harness, "ENGINES", {**ENGINES, **{k: _fake(f) for k, f in fakes.items()}})
    cmp = run_compare(["free_fall"], ["crash", "pbanim", "nan", "moved", "refuse"], steps=[1e-2])
    by = {r.engine: r for r in cmp.rows}
    assert by["crash"].status == "failed" and "RuntimeError: segfault-like" in by["crash"].reason
    assert by["nan"].status == "diverged" and "t = 1" in by["nan"].reason
    assert by["moved"].status == "failed" and "translation error" in by["moved"].reason
    assert by["refuse"].status == "unsupported" and by["refuse"].reason == "no such knob"
    assert by["pbanim"].status == "ok" and by["pbanim"].error < 1e-12
    md = cmp.to_markdown()
    assert "failed: RuntimeError: segfault-like" in md and "unsupported: no such knob" in md
    json.dumps(cmp.to_json(), allow_nan=False)                  # NaN written as null


@pytest.mark.parametrize("call, message", [
    (lambda: run_compare(["free_fal"]), "unknown scene 'free_fal' (did you mean 'free_fall'"),
    (lambda: run_compare(["free_fall"], ["bullet"]), "unknown engine 'bullet' (did you mean 'pybullet'"),
    (lambda: run_compare(["free_fall"], ["pbanim"], steps=[0.0]), "steps must be a float array of shape (any,) (finite, entries > 0"),
    (lambda: run_compare(["free_fall"], ["pbanim"], steps=[2.0], quick=True), "longer than scene 'free_fall'"),
    (lambda: run_compare("free_fall"), "scenes must be a list of names"),
    (lambda: scene("tops"), "name must be one of 'free_fall', 'projectile', 'bounce', 'incline_stick', 'incline_slide', "
                            "'rolling', 'chain', 'cradle', 'stack', 'top', got 'tops'; did you mean 'top'"),
])
def test_bad_names_and_steps_are_refused_before_running(call, message):
    with pytest.raises(InvalidInput) as info:
        call()
    assert message in str(info.value)


@settings(max_examples=30, deadline=None)
@given(st.text(min_size=1, max_size=12))
def test_unknown_names_always_raise_invalid_input(name):
    if name in SCENES:
        assert check_names("scene", [name], SCENES) == [name]
    else:
        with pytest.raises(InvalidInput, match="unknown scene"):
            check_names("scene", [name], SCENES)


VALID = {"mass": {2.0}, "size": {2.0}, "restitution": {0.0}, "friction": {0.0, 2.0}, "quat": {-1.0},
         "x": {-1.0, 2.0, 0.0}}


@settings(max_examples=30, deadline=None)
@given(st.sampled_from(sorted(VALID)), st.sampled_from([np.nan, np.inf, -1.0, 2.0, 0.0]))
def test_body_validation_names_the_argument(field, value):
    # a scene's numbers are checked where they come in: the message names the field
    kw = dict(name="b", shape="sphere", size=(0.1,), mass=1.0, inertia=(1.0, 1.0, 1.0), x=(0, 0, 0))
    kw[field] = {"size": (value,), "quat": (value, 0, 0, 0), "x": (value, 0, 0)}.get(field, value)
    if value in VALID[field]:
        Body(**kw)
    else:
        with pytest.raises(InvalidInput, match=rf"(Body(.__init__)?: |body 'b': ){field} must be"):
            Body(**kw)


@pytest.mark.parametrize("make, message", [
    (lambda b: SceneSpec("s", "s", (), (0, 0, -G), 1.0, (0.1,), (0.1,)), "bodies must be a list of at least 1 of (an instance of Body), got ()"),
    (lambda b: SceneSpec("s", "s", (b,), (0, 0), 1.0, (0.1,), (0.1,)), "gravity must be a float array of shape (3,)"),
    (lambda b: SceneSpec("s", "s", (b,), (0, 0, -G), 1.0, (2.0,), (0.1,)), "steps must be positive steps ≤ duration"),
    (lambda b: SceneSpec("s", "s", (b,), (0, 0, -G), 1.0, (0.1,), ()), "quick_steps must be a float array of shape (any,) (finite, entries > 0, not empty), got ()"),
    (lambda b: SceneSpec("s", "s", (b,), (0, 0, -G), np.nan, (0.1,), (0.1,)), "duration must be a finite number"),
    (lambda b: SceneSpec("s", "s", (b,), (0, 0, -G), 1.0, (0.1,), (0.1,), joints=(Joint("ball", 1, -1, (0, 0, 0),
                                                                                       (0, 0, 0)),)),
     "joint body index 1 out of range"),
    (lambda b: Joint("slider", 0, -1, (0, 0, 0), (0, 0, 0)), "kind must be one of 'hinge', 'ball', got 'slider'"),
    (lambda b: Body("b", "cone", (0.1,), 1.0, (1, 1, 1), (0, 0, 0)), "shape must be one of"),
    (lambda b: Body("b", "sphere", (0.1,), 1.0, (1, 0, 1), (0, 0, 0)), "inertia must be a float array of shape (3,) (finite, entries > 0, not empty), got (1, 0, 1)"),
    (lambda b: Trace(np.zeros(2), np.zeros((2, 1, 3)), np.zeros((1, 1, 4)), np.zeros((2, 1, 3)),
                     np.zeros((2, 1, 3)), 0.0, 1), "trace q must have shape (2, N, 4)"),
])
def test_scene_description_is_validated(make, message):
    body = Body("b", "sphere", (0.1,), 1.0, (4e-3,) * 3, (0, 0, 1))
    with pytest.raises(InvalidInput) as info:
        make(body)
    assert message in str(info.value)


# -- the command line --------------------------------------------------------------------------------------
def test_cli_compare_writes_markdown_and_json(tmp_path, capsys):
    md, js = tmp_path / "c.md", tmp_path / "c.json"
    assert main(["compare", "free_fall", "--engines", "pbanim", "--quick", "--markdown", str(md), "--json", str(js)]) == 0
    data = json.loads(js.read_text())
    rows = data["scenes"]["free_fall"]["rows"]
    # the quick sweep (10 ms, 5 ms), then the peers' own steps beside it (1/240 s, 2 ms): ORACLES K1, RK4 exact
    assert [r["h"] for r in rows] == [1e-2, 5e-3, 1 / 240, 2e-3]
    assert [r["sweep"] for r in rows] == [True, True, False, False]
    assert [r["status"] for r in rows] == ["ok"] * 4 and max(r["error"] for r in rows) < 1e-12
    for r in rows:                                  # cost per simulated second = cost per step / h
        assert r["s_per_sim_s"] == pytest.approx(1e-6 * r["us_per_step"] / r["h"], rel=1e-12)
    text = md.read_text()
    assert "| free_fall |" in text and "ok" in capsys.readouterr().out
    assert "ms/sim s" in text and "At the peers' own steps" in text and "0.004167 (own)" in text
    assert main(["compare", "free_fal"]) == 2
    assert "did you mean 'free_fall'" in capsys.readouterr().err


# -- the chapter's figures ---------------------------------------------------------------------------------
def test_figure_trajectories_pbanim_follows_the_exact_curve(figure_data):
    # ORACLES K1–K8 on the drawn curves: pbanim within each scene's bound of the exact observable
    data = figure_data("ch11_trajectories")
    bounds = {"free_fall": 1e-12, "projectile": 1e-12, "bounce": 1e-12, "incline_stick": 1e-12,
              "incline_slide": 1e-3, "rolling": 1e-12, "chain": 5e-9, "stack": 1e-12, "top": 1e-3}
    for name, bound in bounds.items():
        c = data[name]["pbanim"]
        # measured: 7e-15, 7e-15, 3e-15 (bounce), 4e-20, 1.6e-4 (= a h T/2), 6e-15, 5.3e-10 J, 0, ~1e-5 rad
        assert np.abs(c["y"] - c["exact_at_t"]).max() < bound, name
    cradle = data["cradle"]["pbanim"]
    assert cradle["y"][-1] == pytest.approx(1.0, abs=1e-12) and cradle["y"][0] == 0.0
    assert data["installed"]["pbanim"]


def test_figure_error_vs_cost_rows(figure_data):
    # ORACLES K9: every pbanim row ok, every peer row ok or not installed; K1: the peers' free fall is
    # first order (slope 1 ± 0.05, measured 1.000) when they are installed
    data = figure_data("ch11_error_vs_cost")
    statuses = {(r["engine"], r["status"]) for r in data["rows"]}
    assert {s for e, s in statuses if e == "pbanim"} == {"ok"}
    assert {s for e, s in statuses if e != "pbanim"} <= {"ok", "not installed"}
    for e in ("pybullet", "mujoco"):
        if (e, "ok") in statuses:
            assert abs(data["orders"][f"free_fall/{e}"] - 1.0) < 0.05
    assert data["orders"]["chain/pbanim"] > 3.5


# -- issue 27: nothing silent ------------------------------------------------------------------------------
def test_a_trace_of_another_scene_is_refused_not_broadcast():
    # a 1-body trace scored against the 3-rod chain used to broadcast to E = [0, 0] without a word
    tr = Trace(np.zeros(2), np.zeros((2, 1, 3)), np.tile([1.0, 0, 0, 0], (2, 1, 1)), np.zeros((2, 1, 3)),
               np.zeros((2, 1, 3)), 0.0, 1)
    for f in (energy, energy_readable, joint_drift):
        with pytest.raises(InvalidInput, match=f"{f.__name__}: tr must hold the scene's 3 bodies, got 1"):
            f(scene("chain").spec, tr)
    bad = Trace(np.zeros(2), np.full((2, 1, 3), np.nan), np.tile([1.0, 0, 0, 0], (2, 1, 1)), np.zeros((2, 1, 3)),
                np.zeros((2, 1, 3)), 0.0, 1)
    with pytest.raises(InvalidInput, match="energy: tr must be finite, got a non-finite state at t = 0"):
        energy(scene("free_fall").spec, bad)


def test_comparison_names_and_orders_are_never_silent():
    cmp = run_compare(["free_fall"], ["pbanim"], quick=True, steps=[0.05, 0.025])
    # a misspelt scene used to give [] (rows_of) and nan (order); an exact engine's order is None, not NaN
    with pytest.raises(InvalidInput, match=r"rows_of: scene must be one of the scenes of this comparison "
                                           r"\['free_fall'\], got 'free_fal'"):
        cmp.rows_of("free_fal")
    with pytest.raises(InvalidInput, match=r"order: engine must be one of the engines .*got 'mujoco'"):
        cmp.order("free_fall", "mujoco")
    assert cmp.order("free_fall", "pbanim") is None          # RK4 is exact on free fall (ORACLES K1)
    assert "· p " not in cmp.to_markdown().split("## free_fall")[0].split("| free_fall |")[1]


def test_joints_and_tops_that_mean_nothing_are_refused():
    with pytest.raises(InvalidInput, match="a and b must differ, got a = b = 0"):
        Joint("ball", 0, 0, (0, 0, 0), (0, 0, 0))
    with pytest.raises(InvalidInput, match=r"a hinge's axis must be a non-zero vector, got \(0.0, 0.0, 0.0\)"):
        Joint("hinge", 0, -1, (0, 0, 0), (0, 0, 0), (0, 0, 0))
    # a negative spin at r = 0 used to return NaN (0/0)
    with pytest.raises(InvalidInput, match="top_precession: spin must be a finite number > 0, got -1.0"):
        top_precession(1.0, 0.0, 1.0, 1.0, -1.0, 0.3)
    assert top_precession(1.0, 0.0, 1.0, 1.0, 1.0, 0.3) == 0.0


def test_a_run_of_too_many_steps_is_refused_before_it_starts():
    with pytest.raises(InvalidInput, match=r"steps: h = 1e-09 s needs 5e\+08 steps for scene 'free_fall'"):
        run_compare(["free_fall"], ["pbanim"], quick=True, steps=[1e-9])


# -- issue 28: the cost of the same motion -----------------------------------------------------------------
def test_cost_per_simulated_second_is_cost_per_step_over_h():
    # a row's wall seconds per simulated second is its µs per step / h (the same motion at another step costs
    # steps × per-step cost); the rows at the peers' own steps stay out of the sweep's order and finest step
    cmp = run_compare(["free_fall"], ["pbanim"], quick=True)
    sweep, own = cmp.rows_of("free_fall", "pbanim", True), cmp.rows_of("free_fall", "pbanim", False)
    assert [r.h for r in sweep] == [1e-2, 5e-3] and [r.h for r in own] == [1 / 240, 2e-3]
    for r in sweep + own:
        assert r.steps == int(np.ceil(0.5 / r.h - 1e-9)) and r.wall > 0
        assert r.s_per_sim_s == pytest.approx(r.us_per_step * 1e-6 / r.h, rel=1e-12)
        assert r.s_per_sim_s == pytest.approx(r.wall / (r.steps * r.h), rel=1e-12)
    (line,) = cmp.summary()
    assert line["h"] == 5e-3 and line["s_per_sim_s"] == sweep[1].s_per_sim_s
    assert set(line["own"]) == {"pybullet", "mujoco"}
    assert line["own"]["pybullet"]["h"] == 1 / 240 and line["own"]["mujoco"]["s_per_sim_s"] == own[1].s_per_sim_s
    # ORACLES K1: RK4 is exact on free fall at the peers' steps too
    assert max(o["error"] for o in line["own"].values()) < 1e-12
    # the markdown's cell: 1e3 × s per simulated s (ms), to the 2 digits it prints
    table = harness.Comparison(cmp.rows, cmp.scenes, True, {}, "d").to_markdown()
    assert f"{1e3 * own[1].s_per_sim_s:.2g} ms/sim s" in table.split("At the peers' own steps")[1]


def test_own_steps_can_be_left_out_and_explicit_steps_run_alone():
    assert [r.h for r in run_compare(["free_fall"], ["pbanim"], quick=True, own_steps=False).rows] == [1e-2, 5e-3]
    cmp = run_compare(["free_fall"], ["pbanim"], quick=True, steps=[0.05])
    assert [(r.h, r.sweep) for r in cmp.rows] == [(0.05, True)] and cmp.summary()[0]["own"] == {}
    assert "At the peers' own steps" not in cmp.to_markdown()
    # a step already in the sweep (2 ms in the full sweep) is not run twice: it counts as the sweep's row
    assert harness.OWN_STEPS["mujoco"] in SCENES["free_fall"]().spec.steps
