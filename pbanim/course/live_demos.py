"""The chapters' live demos (registered in :mod:`pbanim.course.widgets` on import).

==================  =========  ==============================  =========================================
demo                chapter    controls                        what is drawn (and its closed form)
==================  =========  ==============================  =========================================
ch02_step_size      02         method, steps per orbit         Kepler orbit e = 0.5 over two periods and
                                                               |E − E*| (A3, A4)
ch03_baumgarte      03         ω_b, ζ                          a bead started 10 % off its circle: C(t)
                                                               against C̈ + 2ζω_b Ċ + ω_b² C = 0 (B2)
ch06_restitution    06         ε                               bouncing ball: z(t) and apex heights against
                                                               ε^(2k) h₀ (D1)
ch08_pd_push        08         k_p, ζ, servo, h, push P        a servoed unit mass pushed at t = 0.2 s:
                                                               θ(t) against m θ̈ + k_v θ̇ + k_p θ = 0 and
                                                               the servo's largest stable step (F1)
ch09_viscosity      09         ν                               Taylor–Green vortex on 16²: E(t)/E₀ against
                                                               the implicit step's 1/(1 − νΔtλ)² (E1)
ch10_drag           10         target x, target z              a ball through two bounces at t = 2 s: one
                                                               min-norm update per redraw, as a drag (H5, H6)
==================  =========  ==============================  =========================================

Each ``compute(demo, **params)`` returns the data it draws (the tests check it against the closed form);
the scenes are sized so that a redraw takes under 0.2 s (``python -m pbanim.course.widgets``).
Axes fixed over the controls' whole range where a bound holds every value (ch03, ch09, ch10) let a redraw
reuse the drawn axes (new limits cost a full Agg draw, tick labels and all); ch02, ch06 (flight time ×5 over
ε) and ch08 (θ ∝ P/√k_p over six decades) follow their data.
``ch10_drag`` keeps the design parameters u between redraws in ``demo.state`` (a drag moves on from where
the last frame left it); another target restarts nothing, one more redraw at the same target is one more
Gauss–Newton step.
"""

from __future__ import annotations

import numpy as np

from ..errors import InvalidInput
from .widgets import Control, LiveDemo, register_demo

__all__: list[str] = []

G = 9.81
ZETA_LOW = 0.1          # the ζ slider's low end (ch03): the deepest undershoot of C over the controls' range
NU_HIGH = 1.0           # the ν slider's high end (ch09): the fastest decay the axes must hold


# -- chapter 02: step size and method on a Kepler orbit -------------------------------------------------
def _kepler(demo, method, steps):
    from ..models.ode import kepler
    from ..ode import solve

    kp = kepler(0.5)
    T = kp.period
    r = solve(kp.rhs, (0, 2 * T), kp.y0, method=method, h=T / steps, split=2)
    return {"t": r.t / T, "orbit": r.y[:2], "dE": kp.invariants["energy"](r.y) - kp.params["E"], "h": T / steps}


def _kepler_draw(fig, d, p):
    a, b = fig.subplots(1, 2)
    (orbit,) = a.plot(*d["orbit"], lw=0.8)
    a.plot(0, 0, "k*")
    a.set(aspect="equal", xlabel="x", ylabel="y")
    (err,) = b.semilogy(d["t"], np.abs(d["dE"]) + 1e-17, lw=0.8)
    b.set(xlabel="t / T", ylabel="|E − E*|", title="energy error (GM = a = 1)")
    arts = {"orbit": orbit, "err": err, "axes": (a, b)}
    _kepler_update(arts, d, p, rescale=False)
    return arts


def _kepler_update(arts, d, p, rescale=True):
    arts["orbit"].set_data(*d["orbit"])
    arts["err"].set_data(d["t"], np.abs(d["dE"]) + 1e-17)
    arts["axes"][0].set_title(f"{p['method']}, h = T/{p['steps']}")
    if rescale:
        _rescale(*arts["axes"])


def _rescale(*axes):
    """Limits from the artists' new data (as a first draw sets them)."""
    for ax in axes:
        ax.relim()
        ax.autoscale_view()


register_demo(LiveDemo(
    "ch02_step_size", "ch02_ode", "kepler", "step size and method on a Kepler orbit (e = 0.5)",
    (Control("method", "method", "choice", "symplectic_euler",
             options=("euler", "symplectic_euler", "verlet", "midpoint", "rk4")),
     Control("steps", "steps per orbit", "int", 150, 40, 400)),
    _kepler, _kepler_draw, notes="Explicit Euler spirals out, the symplectic methods keep the energy error bounded.",
    update=_kepler_update))


# -- chapter 03: Baumgarte gains on a bead off its circle -----------------------------------------------
def baumgarte_closed_form(t, C0, Cd0, omega, zeta):
    """C(t) of C̈ + 2ζω Ċ + ω² C = 0 (under-, critically and over-damped)."""
    t = np.asarray(t, float)
    if abs(zeta - 1.0) < 1e-9:
        return (C0 + (Cd0 + omega * C0) * t) * np.exp(-omega * t)
    s = np.sqrt(complex(zeta * zeta - 1.0)) * omega
    r1, r2 = -zeta * omega + s, -zeta * omega - s
    a = (Cd0 - r2 * C0) / (r1 - r2)
    return np.real(a * np.exp(r1 * t) + (C0 - a) * np.exp(r2 * t))


def _bead(demo, omega_b, zeta, h=0.02, t_end=1.0, R=1.0):
    from ..constraints import Constraints
    from ..constraints.kinds import OnCircle
    from ..particles import Gravity, ParticleSystem
    from ..scene import Scene

    x0 = 1.1 * R * np.array([np.sin(1.0), -np.cos(1.0)])
    ps = ParticleSystem([x0], [[0.0, 0.0]], masses=1.0)
    eff = Constraints([OnCircle([0], [0.0, 0.0], R)], stabilization="baumgarte", natural_frequency=omega_b,
                      damping_ratio=zeta)
    res = Scene(ps, [Gravity(), eff]).simulate(t_end, h, "rk4")
    x = res.y[:2]
    C = 0.5 * (np.sum(x * x, 0) - R * R)
    return {"t": res.t, "x": x, "C": C, "C_exact": baumgarte_closed_form(res.t, C[0], 0.0, omega_b, zeta), "R": R,
            "limits": _bead_limits(R, 1.1 * R, t_end)}


def _bead_limits(R, r0, t_end, pad=0.05):
    """((xlim, ylim) of the bead, (xlim, ylim) of C(t)) for every ω_b and ζ ≥ ZETA_LOW (B2), padded: from rest at
    C₀ = ½(r₀² − R²) the error's energy ω_b²C² + Ċ² never grows (|C| ≤ C₀, |x| ≤ r₀), and C undershoots only
    underdamped, at most to −C₀ exp(−πζ/√(1 − ζ²)), deepest at ζ's low end."""
    C0 = 0.5 * (r0 * r0 - R * R)
    c_lo = -C0 * np.exp(-np.pi * ZETA_LOW / np.sqrt(1.0 - ZETA_LOW**2))
    lim = np.array([[-r0, r0], [-r0, r0], [0.0, t_end], [c_lo, C0]])
    lim += pad * (lim[:, 1:] - lim[:, :1]) * [-1.0, 1.0]
    return ((tuple(lim[0]), tuple(lim[1])), (tuple(lim[2]), tuple(lim[3])))


def _set_limits(axes, limits):
    for ax, (xl, yl) in zip(axes, limits):
        ax.set_xlim(xl)
        ax.set_ylim(yl)


def _bead_draw(fig, d, p):
    a, b = fig.subplots(1, 2)
    th = np.linspace(0, 2 * np.pi, 200)
    a.plot(d["R"] * np.cos(th), d["R"] * np.sin(th), "k:", lw=0.8)
    (path,) = a.plot(*d["x"], lw=1)
    a.set(aspect="equal", xlabel="x (m)", ylabel="y (m)", title="the bead (RK4, h = 20 ms)")
    (C,) = b.plot(d["t"], d["C"], label="simulated C = ½(|x|² − R²)")
    (exact,) = b.plot(d["t"], d["C_exact"], "k--", lw=1, label="C̈ + 2ζω_b Ċ + ω_b² C = 0")
    b.set(xlabel="t (s)", ylabel="C (m²)", title=f"ω_b = {p['omega_b']:.3g} rad/s, ζ = {p['zeta']:.2f}")
    b.legend(fontsize=7)
    _set_limits((a, b), d["limits"])
    return {"path": path, "C": C, "exact": exact, "axes": (a, b)}


def _bead_update(arts, d, p):
    arts["path"].set_data(*d["x"])
    arts["C"].set_data(d["t"], d["C"])
    arts["exact"].set_data(d["t"], d["C_exact"])
    arts["axes"][1].set_title(f"ω_b = {p['omega_b']:.3g} rad/s, ζ = {p['zeta']:.2f}")
    _set_limits(arts["axes"], d["limits"])      # fixed over the sliders' range: the drawn axes are reused


register_demo(LiveDemo(
    "ch03_baumgarte", "ch03_constraints", "drift", "Baumgarte gains pull a bead back onto its circle",
    (Control("omega_b", "ω_b (rad/s)", "log", 10.0, 1.0, 20.0), Control("zeta", "ζ", "float", 1.0, ZETA_LOW, 2.0)),
    _bead, _bead_draw, notes="k_s = ω_b², k_d = 2ζω_b; ζ = 1 is the critically damped return.", update=_bead_update))


# -- chapter 06: restitution of a bouncing ball ------------------------------------------------------------
def _bounce(demo, restitution, bounces=6):
    from ..collision import simulate_collisions
    from ..models.collision import bouncing_ball

    bb = bouncing_ball(h0=1.0, restitution=restitution)
    T = 1.01 * float(bb.impact_times(bounces + 1))
    ev = simulate_collisions(bb.scene(), T, 0.01, toi="event")
    post = ev.y_events[0][:bounces]
    k = np.arange(1, len(post) + 1)
    return {"t": ev.t, "z": ev.y[1], "k": k, "apex": post[:, 1] + post[:, 3] ** 2 / (2 * bb.g),
            "apex_exact": bb.apex_heights(k), "h0": bb.h0}


def _bounce_draw(fig, d, p):
    a, b = fig.subplots(1, 2)
    (z,) = a.plot(d["t"], d["z"], lw=1)
    a.set(xlabel="t (s)", ylabel="z (m)", title=f"ε = {p['restitution']:.2f} (events located, RK4)")
    (exact,) = b.semilogy(d["k"], d["apex_exact"], "k-", label="ε^(2k) h₀")
    (apex,) = b.semilogy(d["k"], d["apex"], "o", label="simulated apex")
    b.set(xlabel="bounce k", ylabel="apex height (m)")
    b.legend(fontsize=7)
    return {"z": z, "exact": exact, "apex": apex, "axes": (a, b)}


def _bounce_update(arts, d, p):
    arts["z"].set_data(d["t"], d["z"])
    arts["exact"].set_data(d["k"], d["apex_exact"])
    arts["apex"].set_data(d["k"], d["apex"])
    arts["axes"][0].set_title(f"ε = {p['restitution']:.2f} (events located, RK4)")
    _rescale(*arts["axes"])


register_demo(LiveDemo(
    "ch06_restitution", "ch06_collisions", "bouncing_heights", "restitution of a bouncing ball",
    (Control("restitution", "ε", "float", 0.8, 0.2, 0.95),), _bounce, _bounce_draw,
    notes="Each bounce scales the speed by ε and the apex by ε².", update=_bounce_update))


# -- chapter 08: PD gains and a push ---------------------------------------------------------------------
def pd_push_closed_form(t, P, kp, kv, m=1.0):
    """θ(t) of m θ̈ + k_v θ̇ + k_p θ = 0 from θ = 0, θ̇ = P/m (a push P at t = 0)."""
    return baumgarte_closed_form(t, 0.0, P / m, np.sqrt(kp / m), kv / (2 * np.sqrt(kp * m)))


def _pd(demo, kp, zeta, servo, h, push, t_push=0.2, t_end=2.0, m=1.0):
    from ..control.pd import largest_stable_step

    kv = 2 * zeta * np.sqrt(kp * m)
    n = int(np.ceil(t_end / h))                # h ≥ 1e-4 (the control's range): n ≤ 2e4 steps
    k_push = int(round(t_push / h))
    xs = np.zeros(n + 1)                       # at rest until the push
    xs[k_push + 1:] = _pd_states(kp, kv, h, servo, push / m, n - k_push, m)[:, 0]
    scale = 1e6 * max(1.0, abs(push) * h / m)
    bad = np.flatnonzero(~(np.abs(xs) < scale))
    if len(bad):                               # unstable: drawn up to the divergence
        xs = xs[:bad[0]]
    t = h * np.arange(len(xs))
    exact = np.where(t >= k_push * h, pd_push_closed_form(np.maximum(t - k_push * h, 0.0), push, kp, kv, m), 0.0)
    return {"t": t, "theta": xs, "exact": exact, "diverged": len(xs) < n + 1, "kv": kv,
            "h_max": largest_stable_step(kp, kv, m=m, servo=servo, h_max=10.0)}


def _pd_states(kp, kv, h, servo, v0, n, m=1.0) -> np.ndarray:
    """(θ, θ̇) after 1 … n steps of :func:`pbanim.control.pd.pd_step` from θ = 0, θ̇ = v0, as an (n, 2) array.

    The step is linear, s⁺ = A s, with A's columns the step of (1, 0) and (0, 1); the states are A s₀, then
    A^m times the first m states for m = 1, 2, 4, … (⌈log₂ n⌉ products instead of n steps: the plot's
    20 000 steps at h = 10⁻⁴ in a millisecond). Past an overflow the states are inf or NaN, as the loop's
    would be past the divergence the caller cuts at; before it they equal the step-by-step loop to roundoff
    (``tests/test_course_live.py``)."""
    from ..control.pd import pd_step

    A = np.array([pd_step(1.0, 0.0, h, kp, kv, m, servo), pd_step(0.0, 1.0, h, kp, kv, m, servo)], float).T
    S = np.empty((n, 2))
    S[0] = A @ np.array([0.0, v0])
    P, k = A, 1                                 # P = A^k; S[:k] known
    with np.errstate(over="ignore", invalid="ignore"):
        while k < n:                            # ⌈log₂ n⌉ rounds
            take = min(k, n - k)
            S[k:k + take] = S[:take] @ P.T
            P, k = P @ P, k + take
    return S


def _pd_draw(fig, d, p):
    ax = fig.subplots()
    (exact,) = ax.plot(d["t"], d["exact"], "k--", lw=1, label="exact servo (continuous time)")
    (theta,) = ax.plot(d["t"], d["theta"], lw=1, label=f"{p['servo']} PD, h = {p['h']:.2g} s")
    ax.set(xlabel="t (s)", ylabel="θ (rad)")
    arts = {"exact": exact, "theta": theta, "legend": ax.legend(fontsize=7), "axes": (ax,)}
    _pd_update(arts, d, p, rescale=False)
    return arts


def _pd_update(arts, d, p, rescale=True):
    ax = arts["axes"][0]
    arts["exact"].set_data(d["t"], d["exact"])
    arts["theta"].set_data(d["t"], d["theta"])
    label = f"{p['servo']} PD, h = {p['h']:.2g} s"
    arts["theta"].set_label(label)
    arts["legend"].get_texts()[1].set_text(label)
    state = "DIVERGED" if d["diverged"] else "stable"
    ax.set_title(f"k_p = {p['kp']:.3g}, k_v = {d['kv']:.3g}, push {p['push']:.2g} N s: {state} (largest stable "
                 f"h = {d['h_max']:.3g} s)")
    if rescale:
        ax.set_autoscaley_on(True)
        _rescale(ax)
    if d["diverged"]:
        ax.set_ylim(-5 * max(p["push"], 1e-3), 5 * max(p["push"], 1e-3))


register_demo(LiveDemo(
    "ch08_pd_push", "ch08_characters", "pd_stability_map", "PD gains, servo and step: a servoed mass pushed",
    (Control("kp", "k_p (N m/rad)", "log", 100.0, 1.0, 1e6), Control("zeta", "ζ", "float", 1.0, 0.0, 2.0),
     Control("servo", "servo", "choice", "explicit", options=("explicit", "stable", "implicit")),
     Control("h", "h (s)", "log", 0.005, 1e-4, 0.1), Control("push", "push P (N s)", "float", 1.0, 0.0, 5.0)),
    _pd, _pd_draw, figsize=(9.0, 3.2),
    notes="Explicit PD diverges past its largest stable step; stable and implicit PD do not.", update=_pd_update))


# -- chapter 09: viscosity of a Taylor–Green vortex ---------------------------------------------------------
def _tg(demo, nu, n=16, h=0.05, t_end=1.0):
    from ..fluids import Diffusion, FluidScene, Grid, Projection, taylor_green

    g = Grid((n, n), 2 * np.pi / n, "periodic")
    res = FluidScene(g, [Diffusion(nu, "fft"), Projection("fft")], u=taylor_green(g)).simulate(t_end, h)
    e = res.diagnostics["kinetic_energy"]
    lam = 2 * (2 * np.cos(g.dx) - 2) / g.dx**2
    steps = np.round(res.t / h)
    return {"t": res.t, "E": e / e[0], "E_step": (1 - nu * h * lam) ** (-2 * steps), "E_exact": np.exp(-4 * nu * res.t),
            "limits": _tg_limits(t_end)}


def _tg_limits(t_end, pad=0.05):
    """(xlim, ylim) for every ν: E/E₀ in [e^(−4ν_max t_end), 1], padded (in decades): the energy never grows, and
    the implicit step decays slower than e^(−4νt) (1/(1 + x) ≥ e^(−x), the grid's |λ| ≤ 2k²)."""
    lo = -4.0 * NU_HIGH * t_end / np.log(10.0)          # log10 of the lowest E/E₀
    return ((-pad * t_end, (1 + pad) * t_end), (10 ** (lo + pad * lo), 10 ** (-pad * lo)))


def _tg_draw(fig, d, p):
    ax = fig.subplots()
    (E,) = ax.semilogy(d["t"], d["E"], "o", ms=3, label="simulated (16², Δt = 0.05, FFT)")
    (exact,) = ax.semilogy(d["t"], d["E_exact"], "k--", lw=1, label="e^(−4νk²t)")
    ax.set(xlabel="t (s)", ylabel="E / E₀", title=f"Taylor–Green vortex, ν = {p['nu']:.3g} m²/s")
    ax.legend(fontsize=7)
    _set_limits((ax,), (d["limits"],))
    return {"E": E, "exact": exact, "axes": (ax,)}


def _tg_update(arts, d, p):
    arts["E"].set_data(d["t"], d["E"])
    arts["exact"].set_data(d["t"], d["E_exact"])
    arts["axes"][0].set_title(f"Taylor–Green vortex, ν = {p['nu']:.3g} m²/s")
    _set_limits(arts["axes"], (d["limits"],))  # fixed over the slider's range: the drawn axes are reused


register_demo(LiveDemo(
    "ch09_viscosity", "ch09_fluids", "taylor_green_decay", "viscosity of a Taylor–Green vortex",
    (Control("nu", "ν (m²/s)", "log", 0.05, 1e-3, NU_HIGH),), _tg, _tg_draw, figsize=(6.0, 3.4),
    notes="Only viscosity acts: the energy decays as e^(−4νk²t).", update=_tg_update))


# -- chapter 10: dragging a bouncing ball --------------------------------------------------------------------
def _drag(demo, target_x, target_z, T=2.0, h=0.02):
    from ..collision import Plane, Sphere
    from ..design import DesignBody, DesignScene, UncertifiedTrajectory
    from ..design.control import goal_system, min_norm_update, position_goal

    names = ["x0", "v0"]
    st = demo.state
    if "scene" not in st:
        st["scene"] = DesignScene([DesignBody(Sphere(0.1), position=(0.0, 0.0, 1.0), velocity=(1.0, 0.0, 2.0))],
                                  [Plane([0, 0, 1]), Plane([-1, 0, 0], offset=-2.0)], restitution=0.8)
        st["u"] = np.array(st["scene"].vector(names), dtype=float)
        st["run"] = None
    target = np.array([target_x, 0.0, target_z])
    goal = [position_goal(0, T, target)]
    du = np.zeros_like(st["u"])
    if st["run"] is not None:                 # one min-norm update from the last frame's rows
        A, x = st["run"]
        du = min_norm_update(A, target - x).du
    for k in range(9):                        # a step whose run is refused (a ball started in the floor,
        try:                                  # an uncertified run) is halved, at most 8 times, as in edit
            r, A, tr = goal_system(st["scene"], names, st["u"] + du / 2**k, goal, T, h=h)
            break
        except (InvalidInput, UncertifiedTrajectory):
            if k == 8:
                raise
    st["u"] = st["u"] + du / 2**k
    x = tr.position(0, T)
    st["run"] = (A, x)
    P = tr.positions(0)
    return {"path": P[:, [0, 2]], "reached": x, "target": target, "residual": float(np.max(np.abs(target - x)))}


def _drag_draw(fig, d, p):
    ax = fig.subplots()
    (path,) = ax.plot(*d["path"].T, lw=1)
    (reached,) = ax.plot(d["reached"][0], d["reached"][2], "k.", label="the ball at t = 2 s")
    (target,) = ax.plot(d["target"][0], d["target"][2], "r*", ms=10, label="dragged target")
    walls = (ax.axvline(2.0, color="gray"), ax.axhline(0.0, color="gray"))
    ax.set(xlabel="x (m)", ylabel="z (m)", title=f"one min-norm update per redraw: |residual| = {d['residual']:.1e} m")
    ax.legend(fontsize=7)
    _drag_limits(ax, d)
    return {"path": path, "reached": reached, "target": target, "walls": walls, "axes": (ax,)}


# [[x_min, z_min], [x_max, z_max]]: the targets (x ≥ −1, z ≤ 2), floor, wall x = 2, the paths' apexes (≤ 3.2 m)
DRAG_BOX = np.array([[-1.0, 0.0], [2.0, 3.5]])


def _drag_limits(ax, d):
    """DRAG_BOX grown to hold the path, the ball and the target, with 5 % margins (the walls left out)."""
    pts = np.vstack([d["path"], d["reached"][[0, 2]], d["target"][[0, 2]], DRAG_BOX])
    lo, hi = pts.min(0), pts.max(0)
    pad = 0.05 * np.maximum(hi - lo, 1e-9)
    _set_limits((ax,), [((lo[0] - pad[0], hi[0] + pad[0]), (lo[1] - pad[1], hi[1] + pad[1]))])


def _drag_update(arts, d, p):
    arts["path"].set_data(*d["path"].T)
    arts["reached"].set_data([d["reached"][0]], [d["reached"][2]])
    arts["target"].set_data([d["target"][0]], [d["target"][2]])
    arts["axes"][0].set_title(f"one min-norm update per redraw: |residual| = {d['residual']:.1e} m")
    _drag_limits(arts["axes"][0], d)


register_demo(LiveDemo(
    "ch10_drag", "ch10_design", "edit_sequence", "dragging a bouncing ball: one update per move",
    (Control("target_x", "target x (m)", "float", 1.0, -1.0, 1.8), Control("target_z", "target z (m)", "float", 0.6,
                                                                          0.15, 2.0)),
    _drag, _drag_draw, figsize=(6.0, 3.6), notes="Each redraw is one min-norm update of (x₀, v₀) from the last frame.",
    update=_drag_update))
