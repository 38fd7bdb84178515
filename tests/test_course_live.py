"""Live controls of the chapter notebooks (pbanim.course.widgets, pbanim.course.live_demos).

Every control's callback (``demo.redraw``) runs without any widget library and draws what the chapter's
closed form says: energy error orders on the Kepler orbit (ORACLES A3, A4), the Baumgarte error equation
(B2), apex heights ε^(2k) h₀ (D1), the PD servo's response and stability limit (F1), the Taylor–Green
implicit step (E1), Gauss–Newton drags (H5, H6). The notebooks are executed headless with nbclient when
it and ipykernel are installed; ``live`` without ipywidgets draws once.
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

from pbanim.course.notebook import percent_cells, write_notebook
from pbanim.course.widgets import DEMOS, get_demo, live, live_cells
from pbanim.errors import InvalidInput

REPO = Path(__file__).resolve().parent.parent
get_demo("ch02_step_size")                               # registers every demo
NAMES = sorted(DEMOS)


def _slope(errors, ratio=2.0):
    return float(np.polyfit(np.log([ratio**-k for k in range(len(errors))]), np.log(errors), 1)[0])


@pytest.mark.parametrize("name", NAMES)
def test_every_control_callback_draws_at_its_ends_and_defaults(name):
    d = get_demo(name)
    d.state.clear()
    for c in d.controls:
        for v in (c.options if c.kind == "choice" else (c.lo, c.hi, c.value)):
            fig, data = d.redraw(**{c.name: v})
            assert fig.axes and all(ax.has_data() for ax in fig.axes), (name, c.name, v)
            for key, val in data.items():
                if isinstance(val, np.ndarray) and val.dtype.kind == "f":
                    assert np.all(np.isfinite(val)), (name, c.name, v, key)
    assert d.png()[:8] == b"\x89PNG\r\n\x1a\n"
    d.state.clear()


def test_ch02_energy_errors_have_the_methods_orders():
    # ORACLES A3, A4: max |E − E*| over two orbits falls as h^p (fitted over T/100, T/200, T/400)
    d = get_demo("ch02_step_size")
    for method, order in (("rk4", 4), ("verlet", 2), ("symplectic_euler", 1)):
        errs = [np.max(np.abs(d.compute(d, method=method, steps=s)["dE"])) for s in (100, 200, 400)]
        assert abs(_slope(errs) - order) < 0.7, (method, errs)


@pytest.mark.parametrize("omega, zeta", [(10.0, 1.0), (5.0, 0.3), (1.0, 0.1), (20.0, 1.5)])
def test_ch03_bead_follows_the_baumgarte_error_equation(omega, zeta):
    # ORACLES B2: C̈ + 2ζω_b Ċ + ω_b² C = 0; RK4's error against the closed form falls as h⁴
    from pbanim.course.live_demos import _bead

    d = get_demo("ch03_baumgarte")
    errs = []
    for h in (0.02, 0.01):
        r = _bead(d, omega, zeta, h=h)
        errs.append(float(np.max(np.abs(r["C"] - r["C_exact"]))))
    assert r["C"][0] == pytest.approx(0.5 * (1.21 - 1.0), rel=1e-12)
    assert errs[1] < 1e-4 * abs(r["C"][0]) and abs(_slope(errs) - 4) < 0.8, errs


@pytest.mark.parametrize("eps", [0.2, 0.5, 0.95])
def test_ch06_apex_heights_scale_by_eps_squared(eps):
    # ORACLES D1: h_k = ε^(2k) h₀ to 1e-9 (events located; RK4 is exact in free flight)
    d = get_demo("ch06_restitution")
    r = d.redraw(restitution=eps)[1]
    assert len(r["k"]) >= 2
    np.testing.assert_allclose(r["apex"], eps ** (2 * r["k"]) * r["h0"], rtol=1e-9)


def test_ch08_push_response_converges_at_first_order_and_explicit_pd_has_its_limit():
    # ORACLES F1: semi-implicit Euler tracks m θ̈ + k_v θ̇ + k_p θ = 0 to O(h); explicit PD at critical damping
    # is stable iff h√k_p ≤ 2√2 − 2; implicit PD at every step
    d = get_demo("ch08_pd_push")
    errs = [np.max(np.abs((r := d.compute(d, kp=100.0, zeta=1.0, servo="explicit", h=h, push=1.0))["theta"]
                          - r["exact"])) for h in (1e-3, 5e-4, 2.5e-4)]
    assert abs(_slope(errs) - 1) < 0.1 and errs[-1] < 1e-3, errs
    limit = (2 * np.sqrt(2) - 2) / np.sqrt(1e4)
    below = d.compute(d, kp=1e4, zeta=1.0, servo="explicit", h=0.9 * limit, push=1.0)
    above = d.compute(d, kp=1e4, zeta=1.0, servo="explicit", h=1.1 * limit, push=1.0)
    assert not below["diverged"] and above["diverged"]
    assert below["h_max"] == pytest.approx(limit, rel=1e-9)
    assert np.all(np.isfinite(above["theta"])) and np.abs(above["theta"]).max() < 1e6 * 2
    assert not d.compute(d, kp=1e6, zeta=0.0, servo="implicit", h=0.1, push=5.0)["diverged"]


@pytest.mark.parametrize("nu", [1e-3, 0.05, 1.0])
def test_ch09_energy_decays_by_the_implicit_steps_factor(nu):
    # ORACLES E1: each step multiplies E by 1/(1 − νΔtλ)², to rtol 1e-12; the rate tends to e^(−4νt)
    d = get_demo("ch09_viscosity")
    r = d.compute(d, nu=nu)
    np.testing.assert_allclose(r["E"], r["E_step"], rtol=1e-12)
    if nu * 0.05 * 2 < 0.01:              # νΔt|λ| small: the rate is near the continuous 4νk² (k = 1)
        assert abs(np.log(r["E"][-1]) / r["t"][-1] + 4 * nu) < 0.05 * 4 * nu


def test_ch10_drag_redraws_are_gauss_newton_steps():
    # ORACLES H5, H6: repeated min-norm updates at one target reach it within 1e-6 in ≤ 6 updates
    d = get_demo("ch10_drag")
    d.state.clear()
    res = [d.compute(d, target_x=0.5, target_z=0.6)["residual"] for _ in range(7)]
    assert res[0] > 0.1 and res[6] < 1e-6 and all(b < a for a, b in zip(res[:5], res[1:6])), res
    far = d.compute(d, target_x=-1.0, target_z=0.15)      # a jump across the range: a halved step, no error
    assert np.isfinite(far["residual"])
    d.state.clear()


def test_bad_parameters_and_names_are_named_errors():
    d = get_demo("ch06_restitution")
    with pytest.raises(InvalidInput, match="restitution must be in"):
        d.redraw(restitution=1.5)
    with pytest.raises(InvalidInput, match="parameters must be among"):
        d.redraw(epsilon=0.5)
    with pytest.raises(InvalidInput, match="method must be one of"):
        get_demo("ch02_step_size").redraw(method="rk5")
    with pytest.raises(InvalidInput, match="did you mean 'ch09_viscosity'"):
        get_demo("ch09_viscosity_")


def test_live_without_ipywidgets_draws_once(monkeypatch):
    monkeypatch.setitem(sys.modules, "ipywidgets", None)       # import ipywidgets → ImportError
    out = live("ch09_viscosity")
    assert isinstance(out, bytes) and out[:4] == b"\x89PNG"


def test_live_with_ipywidgets_redraws_when_a_control_moves(monkeypatch):
    pytest.importorskip("ipywidgets")
    d = get_demo("ch06_restitution")
    calls = []
    real = d.png
    monkeypatch.setattr(d, "png", lambda **kw: calls.append(kw) or real(**kw))
    box = live("ch06_restitution")
    slider = box.children[1].children[0]
    slider.value = 0.5
    assert calls == [{"restitution": 0.8}, {"restitution": 0.5}]


def test_notebooks_get_a_live_cell_after_their_figure(tmp_path):
    import json

    for d in DEMOS.values():
        src = REPO / "chapters" / f"{d.chapter}.py"
        cells = json.loads(write_notebook(src, tmp_path).read_text())["cells"]
        k = next(i for i, c in enumerate(cells) if f'live("{d.name}")' in "".join(c["source"]))
        assert f'"{d.after}"' in "".join(cells[k - 2]["source"]) and cells[k - 1]["cell_type"] == "markdown"
    assert live_cells("ch01_particles", percent_cells("x = 1\n")) == percent_cells("x = 1\n")


def test_notebooks_execute_headless(tmp_path):
    # one kernel (seconds, not a kernel per chapter): chapter 06's whole notebook with its live cell, then the
    # live cells of the other chapters' notebooks, as written by `pbanim notebook`; not the cell that draws
    # every figure of the chapter (the figure tests run those)
    nbclient = pytest.importorskip("nbclient")
    pytest.importorskip("ipykernel")
    nbformat = pytest.importorskip("nbformat")
    books = {d.chapter: nbformat.read(str(write_notebook(REPO / "chapters" / f"{d.chapter}.py", tmp_path)),
                                      as_version=4) for d in DEMOS.values()}
    nb = books["ch06_collisions"]
    nb.cells = [c for c in nb.cells if "run_figure(" not in c.source]
    for chapter, book in books.items():
        if chapter != "ch06_collisions":
            nb.cells += [c for c in book.cells if c.cell_type == "code" and "live(" in c.source]
    nbclient.NotebookClient(nb, timeout=120, kernel_name="python3",
                            resources={"metadata": {"path": str(tmp_path)}}).execute()
    code = [c for c in nb.cells if c.cell_type == "code"]
    assert not [o for c in code for o in c.outputs if o.get("output_type") == "error"]
    for name in NAMES:
        outs = [o for c in code if f'live("{name}")' in c.source for o in c.outputs]
        assert any("application/vnd.jupyter.widget-view+json" in o.get("data", {}) or "image/png" in o.get("data", {})
                   for o in outs), name


def _shown(fig):
    """What a figure shows, drawn: per axes its title, limits, legend texts and every line's data."""
    fig.canvas.draw()
    out = []
    for ax in fig.axes:
        leg = ax.get_legend()
        out.append((ax.get_title(), ax.get_xlim(), ax.get_ylim(), [t.get_text() for t in leg.get_texts()] if leg else [],
                    [np.asarray(line.get_xydata(), float) for line in ax.get_lines()]))
    return out


@pytest.mark.parametrize("name", NAMES)
def test_an_updated_figure_shows_what_a_new_one_shows(name):
    # a redraw updates the figure built at the first one (set_data, titles, limits); at every control's ends
    # and default it shows what a figure built from the same data shows: the same lines, titles and legend
    # texts, and limits that hold the new figure's (the limits before are kept when the new ones lie inside
    # them and span at least half of them: the drawn axes are reused)
    d = get_demo(name)
    d.state.clear()
    d._built = None
    first, _ = d.frame()
    for c in d.controls:
        for v in (c.options if c.kind == "choice" else (c.lo, c.hi, c.value)):
            fig, data = d.frame(**{c.name: v})
            assert fig is first
            fresh, _ = d.build(data, d.params(**{c.name: v}))
            for ax, (ta, xa, ya, la, da), (tb, xb, yb, lb, db) in zip(fig.axes, _shown(fig), _shown(fresh)):
                assert ta == tb and la == lb, (name, c.name, v)
                for (lim_a, lim_b), log in zip(((xa, xb), (ya, yb)), (ax.get_xscale() == "log", ax.get_yscale() == "log")):
                    (a0, a1), (b0, b1) = sorted(np.log10(lim_a) if log else lim_a), sorted(np.log10(lim_b) if log else lim_b)
                    tol = 1e-9 * (b1 - b0)
                    assert a0 <= b0 + tol and b1 - tol <= a1 and b1 - b0 >= 0.5 * (a1 - a0) - tol, \
                        (name, c.name, v, lim_a, lim_b)
                assert len(da) == len(db)
                for a, b in zip(da, db):
                    np.testing.assert_array_equal(a, b)
    d.state.clear()


def test_the_pd_demo_states_are_the_servo_steps_to_roundoff():
    # ORACLES F1's step, taken 20 000 times at h = 1e-4 as A^m times the first m states (⌈log₂ n⌉ products):
    # the step-by-step loop of pd_step to 4 ulps × steps of the largest |state| (measured 1.3e-14 relative)
    from pbanim.control.pd import pd_step
    from pbanim.course.live_demos import _pd_states

    for servo, kp, kv, h, n in (("explicit", 100.0, 20.0, 1e-4, 20000), ("stable", 1e4, 200.0, 0.011, 300),
                                ("implicit", 1e6, 0.0, 0.1, 20)):
        S = _pd_states(kp, kv, h, servo, 1.0, n)
        x, v, ref = 0.0, 1.0, []
        for _ in range(n):
            x, v = pd_step(x, v, h, kp, kv, 1.0, servo)
            ref.append((x, v))
        ref = np.array(ref)
        assert np.abs(S - ref).max() <= 4 * np.finfo(float).eps * n * np.abs(ref).max(), servo


def test_ch03_fixed_limits_hold_every_bead_the_sliders_can_show():
    # ORACLES B2: started at rest with C₀, the error C̈ + 2ζω_b Ċ + ω_b² C = 0 keeps |C| ≤ C₀ (its energy
    # ω_b²C² + Ċ² does not grow), so |x| ≤ 1.1 R; underdamped it undershoots to −C₀ exp(−πζ/√(1 − ζ²)) once, the
    # deepest at ζ's low end. The axes fixed from that bound hold the simulated bead and C at the sliders' ends
    # and inside, and the bound is tight: at ω_b = 20, ζ = 0.1 the undershoot reaches it within 2 % of C₀
    d = get_demo("ch03_baumgarte")
    (om, ze) = d.controls
    lows = []
    for omega in (om.lo, 3.0, om.value, om.hi):
        for zeta in (ze.lo, 0.5, 1.0, ze.hi):
            data = d.compute(d, omega_b=omega, zeta=zeta)
            (bx, by), (tx, cy) = data["limits"]
            C0 = data["C"][0]
            assert np.isclose(C0, 0.5 * (1.21 - 1.0) * data["R"] ** 2, rtol=1e-12)
            for v, (lo, hi) in ((data["x"][0], bx), (data["x"][1], by), (data["t"], tx), (data["C"], cy)):
                assert lo <= v.min() and v.max() <= hi, (omega, zeta)
            lows.append(data["C"].min())
    want = -C0 * np.exp(-np.pi * ze.lo / np.sqrt(1.0 - ze.lo**2))
    assert abs(min(lows) - want) <= 0.02 * C0, (min(lows), want)


def test_ch09_fixed_limits_hold_every_decay_the_slider_can_show():
    # ORACLES E1: E/E₀ of the implicit step, (1 − νΔtλ)^(−2n), lies between e^(−4νt) and 1, so the axes fixed at
    # ν's high end, [e^(−4 ν_max t_end), 1], hold every ν; tight: at ν_max the last point lies above it by the
    # implicit step's lag, (1 − ν_maxΔtλ)^(−2n) against e^(−4ν_max t): 0.10 decade at Δt = 0.05
    d = get_demo("ch09_viscosity")
    (nu,) = d.controls
    for v in (nu.lo, 0.01, nu.value, 0.3, nu.hi):
        data = d.compute(d, nu=v)
        (tx, ey) = data["limits"]
        assert tx[0] <= data["t"].min() and data["t"].max() <= tx[1], v
        assert ey[0] <= data["E"].min() and data["E"].max() <= ey[1], v
        np.testing.assert_allclose(data["E"], data["E_step"], rtol=1e-10)
    assert 0.0 < np.log10(data["E"][-1] / np.exp(-4 * nu.hi * data["t"][-1])) <= 0.15


@pytest.mark.parametrize("name", ["ch03_baumgarte", "ch09_viscosity", "ch10_drag"])
def test_moving_a_slider_over_its_range_keeps_the_drawn_axes(name):
    # the cause of the slowest redraws was new limits at each value (a full draw: tick labels rendered again);
    # with limits fixed over the controls' range the background drawn first is reused at every end and default
    d = get_demo(name)
    d.state.clear()
    d._built = None
    d.frame()
    bg = d._built["bg"]
    for c in d.controls:
        for v in (c.lo, c.hi, c.value):
            fig, _ = d.frame(**{c.name: v})
            assert d._built["bg"] is bg, (name, c.name, v, _shown(fig)[0][1:3])
    d.state.clear()
