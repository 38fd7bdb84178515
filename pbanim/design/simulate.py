"""The simulation function q(t) = S(t, u) and its derivative ∂S/∂u (chapter 10, part of :mod:`pbanim.design`).

One call of :func:`simulate` runs the scene from the initial state y₀(u) through free flight and
impacts on a fixed time grid and, with ``sensitivities=True``, carries Φ = ∂y/∂u along:

    Φ(t₀) = ∂y₀/∂u,   Φ̇ = (∂f/∂y)Φ + ∂f/∂u in flight,   Φ⁺ = G(Φ⁻ + f⁻δτ) + G_u − f⁺δτ at impacts.

The grid is the driver's one step rule (:func:`pbanim.ode.driver.step_grid`) between breakpoints: the
start, every requested output time, the end. It does not depend on u, so S is a smooth function of u
as long as the sequence of impacts does not change. A step in which a gap changes sign is split at the
impact, located by Brent's method on the RK4 partial step (:func:`pbanim.ode.events.crossings`): the
augmented step runs to the impact, the jump is applied, and the step is finished from there. Scenes
of spheres (isotropic inertia, gravity only) fly in closed form instead (:mod:`pbanim.design.exact`):
the same grid and driver, but each step is the exact flight map and impact times are quadratic roots —
exact, and several times cheaper (``flight="auto"``, the default; ``"rk4"`` forces the general path).

What the result offers for design (:class:`~pbanim.design.Trajectory`): x_i(t), the orientation q_i(t),
their derivatives ∂x/∂u (3 × p) and the orientation's in the tangent space, δφ = 2 Ξ(q)ᵀ δq (3 × p), the
velocities v, ω and theirs, the impacts, and ``differentiable`` — False with a
:class:`~pbanim.design.GrazingImpactWarning` when an impact grazed (approach speed below ``graze_speed``),
two contacts fired at once, or a feature touched a plane or a body tangentially (a touch: no impulse).

**Results certify themselves** (:mod:`pbanim.design.rest`): a sphere whose bounces die out rests on its
plane (ORACLES D1; ``Trajectory.rests``), a contact that would have to rest where the model has no resting
contact is a :class:`~pbanim.design.RestingContactError`, and every recorded state is checked to lie outside
every plane and body (``Trajectory.clearance``, :class:`~pbanim.design.PenetrationError`): S(t, u) never
ends inside an obstacle. A step in which a gap dips below zero and comes back (a ceiling, a passing
sphere) is split at the hidden impact too (the Hermite cubic of (g, ġ) over the step finds the dip).

Limiting cases: no planes gives a parabola for x and torque-free rotation; ε = 1 keeps the kinetic
energy at every impact; a trajectory without impacts has ∂x(t)/∂v₀ = t 𝟙 (ORACLES H3).

References: Popović et al. SIGGRAPH 2000 §4 (S(t, u) and ∂S/∂u by simulation); Baraff 2001 notes §8
(stop at the collision, apply the impulse, restart).
"""

from __future__ import annotations

import warnings

import numpy as np
from scipy.optimize import minimize_scalar

from ..contracts import Array, Choice, Flag, Int, Obj, Opt, Real, contract, finite_result
from ..errors import InvalidInput, StepLimitExceeded, check_result
from ..ode.driver import drive, step_grid
from ..ode.events import crossings, make_events
from .exact import ExactFlight, exact_reason
from .flight import FlightModel, augmented_step, flight_rhs, plain_step, step_rate
from .impact import Features, apply_impact, gaps, saltation_post
from .lean_flight import one_body_gaps
from .rest import ContactState, clearance_of, gap_rates, hermite_dips, hermite_peak
from .scene import DesignScene, GrazingImpactWarning, PenetrationError, RestingContactError, TooManyImpacts
from .specs import ParameterNames, u_size
from .trajectory import Trajectory, _key

__all__ = ["Trajectory", "simulate", "quat_log"]

FLIGHTS = ("auto", "rk4", "exact")
_GRAZE_FLOOR = 1e-6     # an approach this slow is a double root at roundoff (an exact touch): grazing always


@contract(q=Array((4,), batch="first"), returns=finite_result)
def quat_log(q) -> np.ndarray:
    """The rotation vector of a unit quaternion (..., 4) → (..., 3), |angle| ≤ π (q and −q alike)."""
    q = np.asarray(q, dtype=float)
    q = np.where(q[..., :1] < 0, -q, q)
    s = np.linalg.norm(q[..., 1:], axis=-1, keepdims=True)
    ang = 2.0 * np.arctan2(s, q[..., :1])
    scale = np.where(s > 1e-12, ang / np.where(s > 1e-12, s, 1.0), 2.0 / np.maximum(q[..., :1], 1e-300))
    return scale * q[..., 1:]


def _feature_body(feat, k) -> int:
    return int(feat.body[k]) if k < feat.n_plane else int(feat.pairs[k - feat.n_plane][0])


def _model(scene: DesignScene, d: dict, dm: np.ndarray, dIinv: np.ndarray) -> FlightModel:
    N = scene.N
    m = np.array([d[f"mass{i}"][0] for i in range(N)])
    Iinv = np.array([1.0 / d[f"inertia{i}"] for i in range(N)])
    dmT, dIT = dm.T.copy(), np.moveaxis(dIinv, 2, 0).copy()
    return FlightModel(N, 1.0 / m, m, Iinv, scene.gravity, -dmT / (m * m)[None], dmT, dIT)


@contract(scene=Obj(DesignScene), t_end=Real(), names=Opt(ParameterNames("scene")), u=Opt(Array((u_size(),))),
          times=Array((None,), scalar=True, empty=True), h=Real(gt=0), t0=Real(), sensitivities=Flag(),
          max_impacts=Int(ge=1), graze_speed=Real(ge=0), rest_speed=Real(ge=0), contact_tol=Real(gt=0, lt=1),
          penetration_tol=Real(gt=0), warn=Flag(), check_start=Flag(), flight=Choice(FLIGHTS),
          max_steps=Int(ge=1))
def simulate(scene: DesignScene, t_end: float, names=None, u=None, *, times=(), h: float = 0.005,
             t0: float = 0.0, sensitivities: bool = True, max_impacts: int = 100, graze_speed: float = 1e-3,
             rest_speed: float = 1e-3, contact_tol: float = 1e-9, penetration_tol: float = 1e-6,
             warn: bool = True, check_start: bool = True, flight: str = "auto",
             max_steps: int = 100_000) -> Trajectory:
    """Run q(t) = S(t, u) from t0 to t_end (and ∂S/∂u when ``sensitivities``).

    Parameters
    ----------
    scene : DesignScene
    t_end : float (after t0)
    names : list of parameter names (default: position, orientation, velocities of every body)
    u : vector of their values (default: the scene's nominal values)
    times : output times in [t0, t_end] where S and ∂S/∂u are kept (the end is always one)
    h : RK4 step; impacts split steps at their located times
    max_impacts : cap on the impacts (:class:`TooManyImpacts` beyond)
    graze_speed : an impact approaching slower is grazing (S not differentiable there); below 1e-6, the
        roundoff of an exactly grazing touch, always
    rest_speed : a sphere touching a plane that presses it in, with normal speed at most this, rests on it
        (ORACLES D1, D10; :mod:`pbanim.design.rest`); 0 switches resting off (bounces then accumulate)
    contact_tol : touching tolerance, relative to max(1, |x|∞)
    penetration_tol : the certificate's tolerance, a length in the scene's units
    check_start : refuse an initial state that penetrates, and raise :class:`PenetrationError` when the
        certificate fails (``False``: shooting iterates may start inside, they fly on; the result then says
        ``certified``)
    flight : ``"rk4"`` (the general RK4 flight), ``"exact"`` (the closed form of :mod:`pbanim.design.exact`:
        spheres, isotropic inertia, no inertia parameter; else :class:`InvalidInput`) or ``"auto"`` (exact
        when the scene allows it); the grid h then only sets where states are recorded
    max_steps : cap on the grid steps, checked before the first (:class:`~pbanim.errors.StepLimitExceeded`)

    >>> from pbanim.collision import Plane, Sphere
    >>> from pbanim.design import DesignBody, DesignScene
    >>> s = DesignScene([DesignBody(Sphere(0.1), position=[0, 0, 1.1])], [Plane([0, 0, 1])], gravity=[0, 0, -10])
    >>> tr = simulate(s, 1.0, ["x0", "restitution"])
    >>> round(tr.impacts[0].t, 12)                           # √(2·1/10)
    0.447213595499
    """
    names = [f"{k}{i}" for i in range(scene.N) for k in ("x", "theta", "v", "omega")] if names is None else names
    names = scene.check_names(names)
    u = scene.vector(names) if u is None else u
    d = scene.values(names, u)
    t0, t_end, h = float(t0), float(t_end), float(h)
    if not t_end > t0:
        raise InvalidInput(f"simulate: t_end must be after t0 = {t0:g}, got {t_end!r}")
    if flight not in FLIGHTS:                                   # from inside: a shooting's choice
        raise InvalidInput(f"flight must be 'auto', 'rk4' or 'exact', got {flight!r}")
    out_times = np.asarray(times, dtype=float).reshape(-1)
    bad = out_times[~((out_times >= t0) & (out_times <= t_end))]
    if bad.size:
        raise InvalidInput(f"simulate: times must lie in the simulated span [{t0:g}, {t_end:g}], got {bad[0]!r}")
    breaks = np.unique(np.concatenate([[t0, t_end], out_times]))
    grids = [step_grid(a, b, h, max_steps=max_steps) for a, b in zip(breaks[:-1], breaks[1:])]
    if sum(g.n_steps for g in grids) > max_steps:
        raise StepLimitExceeded(h, t_end - t0, sum(g.n_steps for g in grids), max_steps)
    sl = scene.slices(names)
    p = sum(s.stop - s.start for s in sl.values())
    y, Phi, dm, dIinv = scene._initial_state(d, sl, p)
    model = _model(scene, d, dm, dIinv)
    N, n = scene.N, y.size
    T = Phi.T.copy() if sensitivities else None
    nrm = np.array([d[f"normal{j}"] / np.linalg.norm(d[f"normal{j}"]) for j in range(len(scene.planes))]).reshape(-1, 3)
    dn = np.zeros((p, len(scene.planes), 3))
    for j in range(len(scene.planes)):
        if f"normal{j}" in sl:
            nu = d[f"normal{j}"]
            dn[sl[f"normal{j}"], j] = ((np.eye(3) - np.outer(nrm[j], nrm[j])) / np.linalg.norm(nu)).T
    deps = np.zeros(p)
    if "restitution" in sl:
        deps[sl["restitution"]] = 1.0
    eps = float(d["restitution"][0])
    feat = Features(scene)
    g_start = gaps(feat, y, N, nrm)
    if check_start and np.any(g_start < -contact_tol * max(1.0, float(np.abs(y[:3 * N]).max()))):
        k = int(np.argmin(g_start))
        raise InvalidInput(f"the initial state penetrates: feature {k} (body {_feature_body(feat, k)}) has gap "
                           f"{g_start[k]:.3e} < 0; start every body outside the planes and the other bodies")
    with np.errstate(over="ignore", invalid="ignore", divide="ignore"):   # an overflow is named below
        contacts = ContactState(scene, model, feat, nrm, dn, eps, rest_speed, contact_tol)
        impacts: list = []

        def impulse(k, t, yy, TT):
            """An impulse at an instant another impact (or the start) already fixed: no impact-time term."""
            y2, T2, imp, _ = apply_impact(model, feat, k, t, yy, TT, nrm, dn, eps, deps, locate=False)
            return y2, T2, imp

        def resolve(k, te, ye, Te, rate):
            """Apply the impact of feature k at te, then settle every contact touching at te."""
            if Te is not None and contacts.on:      # a resting sphere's rate has no normal part
                rate = contacts.project_rows(flight_rhs(model, ye) if rate is None else rate.copy())
            yy, TT, imp, dtau = apply_impact(model, feat, k, te, ye, Te, nrm, dn, eps, deps, rate=rate)
            imp.grazing = imp.grazing or imp.speed < max(graze_speed, _GRAZE_FLOOR)
            impacts.append(imp)
            if len(impacts) > max_impacts:
                raise TooManyImpacts(max_impacts, te)
            yy, TT, extra = contacts.settle(te, yy, TT, impulse, hit=k)
            imp.simultaneous = imp.simultaneous or bool(extra)
            return yy, TT, dtau

        y, T, first = contacts.settle(t0, y, T, impulse)        # touching at the start: impacts, rests, touches
        for imp in first:
            imp.simultaneous = True                              # an impact at t0: one-sided in u
            impacts.append(imp)
        reason = exact_reason(scene, model)
        if flight == "exact" and reason:
            raise InvalidInput(f"flight='exact' needs spheres with isotropic inertia and no inertia parameter: {reason}")
        use_exact = flight == "exact" or (flight == "auto" and not reason)
        if use_exact:
            exact = ExactFlight(model, feat, nrm, resolve, t0, y, T, contacts, max_impacts)
            advance = exact.advance                             # the exact path drives the state alone
        else:
            advance = _rk4_path(model, feat, nrm, contacts, resolve, impulse, n, p, sensitivities, max_impacts)
        pack = (lambda yy, TT: np.concatenate([yy, TT.ravel()]) if TT is not None else yy)

        ts, ys = [t0], [y.copy()]
        outputs = {}
        if _key(t0) in {_key(v) for v in out_times}:
            outputs[_key(t0)] = (y.copy(), None if T is None else T.copy())
        Y = y.copy() if use_exact else pack(y, T)
        nsteps = 0

        def record(t1, Y1):
            ts.append(t1)
            ys.append(Y1[:n].copy())

        for b, grid in zip(breaks[1:], grids):
            _, Y, k, _ = drive(advance, grid, Y, record=record)
            nsteps += k
            yy, TT = exact.current(b) if use_exact else (Y[:n], Y[n:].reshape(p, n) if sensitivities else None)
            outputs[_key(b)] = (yy.copy(), None if TT is None else check_result("∂S/∂u", TT.copy()))
        return _certified(feat, nrm, N, ts, ys, outputs, impacts, contacts, names, model, nsteps,
                          "exact" if use_exact else "rk4", penetration_tol, check_start, warn)


def _rk4_path(model, feat, nrm, contacts, resolve, impulse, n, p, sensitivities, max_impacts):
    """``advance(t, Y, h)`` of the general path: one RK4 grid step of (y, Φᵀ), split at every impact; δτ of
    an impact enters the sub-step after it as −rate·δτ; resting spheres are projected after every step."""
    N = model.N

    def step(yy, TT, hk, dtau):
        if TT is None:
            return contacts.project(plain_step(model, yy, hk), None)
        y1, T1 = augmented_step(model, yy, TT, hk)
        if dtau is not None:
            T1 -= np.outer(dtau, contacts.project_rows(step_rate(model, yy, hk)))
        return contacts.project(y1, T1)

    def partial(yy, s0=0.0):
        return lambda s: contacts.project(plain_step(model, yy, s0 + s))[0]

    last = [None, None, None, None]      # (y₁, G, g(y₁), ġ(y₁)) of the last step tried: the next step's start
    lean = one_body_gaps(feat, model, nrm)   # one body on planes: its gaps and rates on floats (ORACLES H10)
    gap = lean[0] if lean else (lambda yy: gaps(feat, yy, N, nrm))
    rates = (lambda yy, G: lean[1](yy)) if lean else (lambda yy, G: gap_rates(feat, model, yy, nrm, G)[0])

    def _at_start(yy, G):
        """(g, ġ) at the step's start: those of the last step's end when it is this state under the same
        gravity (the same function of the same numbers), else computed."""
        y_end, G_end, g_end, d_end = last
        if y_end is not None and np.array_equal(y_end, yy) and np.array_equal(G_end, G):
            return g_end, d_end
        return gap(yy), rates(yy, G)

    def gap_fn(k):
        return make_events([lambda tt, yv: float(gap(yv)[k])])

    def event(t, yy, y1, hk, tol0):
        """The first impact in the step, (t_e, feature), or None, or "settle" (a touching contact sinks);
        the tangent touches before it are recorded."""
        skip = contacts.mask()
        G = contacts.gravity()
        g0, d0 = _at_start(yy, G)
        g1, d1 = gap(y1), rates(y1, G)
        last[:] = [y1.copy(), G.copy(), g1, d1]
        found, touches = [], []
        hit = np.flatnonzero((g0 > tol0) & (g1 <= 0) & ~skip)
        if hit.size:
            evs = make_events([(lambda tt, yv, k=k: float(gap(yv)[k])) for k in hit])
            te, _, ev = crossings(evs, g0[hit], t, yy, t + hk, y1, hk, partial(yy))[0]
            found.append((te, int(hit[evs.index(ev)])))
        for k in hermite_dips(np.where(skip, -np.inf, g0), d0, g1, d1, hk, tol0):
            # the gap dips inside the step: a touch, or in and out; the true minimum along the partial step
            low = minimize_scalar(lambda s: float(gap(partial(yy)(s))[k]), bounds=(0.0, hk),
                                  method="bounded", options={"xatol": 1e-9 * hk})
            s, gk = float(low.x), float(low.fun)
            ys = partial(yy)(s)
            if gk < 0:
                found.append((crossings(gap_fn(k), [g0[k]], t, yy, t + s, ys, s, partial(yy))[0][0], int(k)))
            elif gk <= tol0:
                touches.append((t + s, int(k)))
        for k in np.flatnonzero((np.abs(g0) <= tol0) & (g1 < -tol0) & ~skip):   # touching, then inside
            s = hermite_peak(g0[k], d0[k], g1[k], d1[k], hk)
            ys = partial(yy)(s)
            gk = float(gap(ys)[k])
            if gk <= tol0:
                return "settle"
            found.append((crossings(gap_fn(k), [gk], t + s, ys, t + hk, y1, hk - s, partial(yy, s))[0][0], int(k)))
        te, k = min(found) if found else (np.inf, -1)
        for tt, kk in touches:
            if tt < te:
                contacts.touch(kk, tt)
        return (te, k) if found else None

    def advance(t, Y, hk):
        yy, TT = Y[:n], (Y[n:].reshape(p, n) if sensitivities else None)
        t1 = t + hk
        dtau, resettled = None, False
        for _ in range(4 * max_impacts + 4):
            y1, T1 = step(yy, TT, t1 - t, dtau)
            ev = event(t, yy, y1, t1 - t, contacts.tol(yy))
            if ev is None:
                return np.concatenate([y1, T1.ravel()]) if T1 is not None else y1
            if ev == "settle":
                if resettled:
                    raise RestingContactError(f"at t = {t:.6g} a touching contact sinks in and no impulse or "
                                              "rest holds it: resting contact of this kind is not in the model")
                yy, TT, _ = contacts.settle(t, yy, TT, impulse)
                resettled = True
                continue
            te, k = ev
            ye, Te = step(yy, TT, te - t, dtau)
            yy, TT, dtau = resolve(k, te, ye, Te, None if TT is None else step_rate(model, yy, te - t))
            t, resettled = te, False
            if t1 - t <= 1e-14 * max(1.0, abs(t1)):
                TT = None if TT is None else saltation_post(model, yy, TT, dtau)
                yy, TT = contacts.project(yy, TT)
                return np.concatenate([yy, TT.ravel()]) if TT is not None else yy
        raise TooManyImpacts(4 * max_impacts, t)

    return advance


def _certified(feat, nrm, N, ts, ys, outputs, impacts, contacts, names, model, nsteps, flight, penetration_tol,
               check_start, warn) -> Trajectory:
    """The Trajectory, with its certificate (every recorded state outside every obstacle) and its notes."""
    outs = sorted(outputs.items())
    Y = np.vstack([np.array(ys)] + [o[1][0][None] for o in outs])
    tall = list(ts) + [k for k, _ in outs]
    clear, ks, kf = clearance_of(feat, Y, N, nrm)
    notes = list(contacts.notes)
    certified = bool(clear >= -penetration_tol)
    if not certified:
        msg = (f"S(t, u) is not certified: at t = {tall[ks]:.6g} feature {kf} (body {_feature_body(feat, kf)}) "
               f"lies {-clear:.3e} inside an obstacle (penetration_tol = {penetration_tol:g})")
        if check_start:
            raise PenetrationError(msg)
        notes.append(msg + "; the run started inside (check_start=False)")
    bad_i = [i for i in impacts if i.grazing or i.simultaneous]
    smooth = not bad_i and not contacts.touches and contacts.smooth
    if bad_i:
        notes.append(f"S(t, u) is not differentiable here: {len(bad_i)} impact(s) grazing or simultaneous, first at "
                     f"t = {bad_i[0].t:.6g} (approach speed {bad_i[0].speed:.3g} m/s)")
    if contacts.touches:
        tc = contacts.touches[0]
        notes.append(f"S(t, u) is not differentiable here: {len(contacts.touches)} tangent touch(es) (no impulse), "
                     f"first at t = {tc.t:.6g} ({tc.kind} of body {tc.body} and {tc.other})")
    for r in contacts.rests:
        notes.append(f"body {r.body} rests on plane {r.plane} from t = {r.t:.6g} (bounces of normal speed "
                     f"{r.speed:.3g} dropped; Zeno time {r.zeno_time:.6g}): after that ∂S/∂u is the resting "
                     "derivative (its normal rows zero)")
    if not smooth and warn:
        first = next(m for m in notes if "not differentiable" in m)
        warnings.warn(first, GrazingImpactWarning, stacklevel=4)
    return Trajectory(np.array(ts), np.array(ys), outputs, impacts, names, N, model, nsteps, smooth, notes, flight,
                      list(contacts.rests), list(contacts.touches), clear, certified)
