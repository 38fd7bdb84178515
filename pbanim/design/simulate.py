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

What the result offers for design: x_i(t), the orientation q_i(t), their derivatives ∂x/∂u (3 × p) and
the orientation's in the tangent space, δφ = 2 Ξ(q)ᵀ δq (3 × p), the velocities v, ω and theirs, the
impacts, and ``differentiable`` — False with a :class:`~pbanim.design.GrazingImpactWarning` when an
impact grazed (approach speed below ``graze_speed``) or two contacts fired at once.

Limiting cases: no planes gives a parabola for x and torque-free rotation; ε = 1 keeps the kinetic
energy at every impact; a trajectory without impacts has ∂x(t)/∂v₀ = t 𝟙 (ORACLES H3).

References: Popović et al. SIGGRAPH 2000 §4 (S(t, u) and ∂S/∂u by simulation); Baraff 2001 notes §8
(stop at the collision, apply the impulse, restart).
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass, field

import numpy as np

from ..errors import InvalidInput, as_floats, check_count, check_number
from ..ode.driver import drive, step_grid
from ..ode.events import crossings, make_events
from .flight import FlightModel, augmented_step, omega_tangent, plain_step, rotation_tangent, step_rate
from .exact import ExactFlight, exact_reason
from .impact import Features, Impact, apply_impact, gaps, saltation_post
from .scene import DesignScene, GrazingImpactWarning, TooManyImpacts

__all__ = ["Trajectory", "simulate", "quat_log"]


def quat_log(q) -> np.ndarray:
    """The rotation vector of a unit quaternion (..., 4) → (..., 3), |angle| ≤ π (q and −q alike)."""
    q = np.asarray(q, dtype=float)
    q = np.where(q[..., :1] < 0, -q, q)
    s = np.linalg.norm(q[..., 1:], axis=-1, keepdims=True)
    ang = 2.0 * np.arctan2(s, q[..., :1])
    scale = np.where(s > 1e-12, ang / np.where(s > 1e-12, s, 1.0), 2.0 / np.maximum(q[..., :1], 1e-300))
    return scale * q[..., 1:]


@dataclass
class Trajectory:
    """S(t, u) on the grid, and ∂S/∂u at the output times.

    Attributes
    ----------
    t : (K,) grid times;  y : (K, 13N) states [x, q, P, L]
    outputs : dict time → (y, Φᵀ (p, 13N)) at the requested output times and the end
    impacts : list of Impact;  differentiable : bool
    names, N, model, nsteps
    flight : "exact" (closed-form sphere flight) or "rk4" — the path that computed it
    """

    t: np.ndarray
    y: np.ndarray
    outputs: dict
    impacts: list
    names: list
    N: int
    model: FlightModel
    nsteps: int
    differentiable: bool = True
    notes: list = field(default_factory=list)
    flight: str = "rk4"

    def _out(self, t):
        key = _key(t)
        if key not in self.outputs:
            raise InvalidInput(f"time {t} is not an output time of this trajectory; pass it in times= "
                               f"(have {sorted(self.outputs)})")
        return self.outputs[key]

    def _body(self, i):
        if isinstance(i, bool) or not isinstance(i, (int, np.integer)) or not 0 <= i < self.N:
            raise InvalidInput(f"body must be an index in [0, {self.N}), got {i!r}")
        return int(i)

    def position(self, i: int, t: float) -> np.ndarray:
        i = self._body(i)
        return self._out(t)[0][3 * i:3 * i + 3].copy()

    def orientation(self, i: int, t: float) -> np.ndarray:
        i, N = self._body(i), self.N
        return self._out(t)[0][3 * N + 4 * i:3 * N + 4 * i + 4].copy()

    def d_position(self, i: int, t: float) -> np.ndarray:
        """∂x_i(t)/∂u, shape (3, p)."""
        i = self._body(i)
        return self._sens(t)[:, 3 * i:3 * i + 3].T.copy()

    def d_orientation(self, i: int, t: float) -> np.ndarray:
        """∂φ_i(t)/∂u (3, p): the world rotation vector of δq, δφ = 2 Ξ(q)ᵀ δq / |q|²."""
        i, N = self._body(i), self.N
        y, T = self._out(t)[0], self._sens(t)
        q = y[3 * N + 4 * i:3 * N + 4 * i + 4]
        return rotation_tangent(q[None], T[:, None, 3 * N + 4 * i:3 * N + 4 * i + 4])[:, 0].T

    def velocities(self, i: int, t: float) -> tuple[np.ndarray, np.ndarray]:
        """(v_i, ω_i) at an output time."""
        i, N, m = self._body(i), self.N, self.model
        y = self._out(t)[0]
        from ..rigid import quat_to_matrix
        R = quat_to_matrix(y[3 * N + 4 * i:3 * N + 4 * i + 4])
        L = y[10 * N + 3 * i:10 * N + 3 * i + 3]
        return m.W[i] * y[7 * N + 3 * i:7 * N + 3 * i + 3], R @ (m.Iinv[i] * (R.T @ L))

    def d_velocities(self, i: int, t: float) -> tuple[np.ndarray, np.ndarray]:
        """(∂v_i/∂u, ∂ω_i/∂u), each (3, p)."""
        i, N, m = self._body(i), self.N, self.model
        y, T = self._out(t)[0], self._sens(t)
        from ..rigid import quat_to_matrix
        q, P, L = y[3 * N + 4 * i:3 * N + 4 * i + 4], y[7 * N + 3 * i:7 * N + 3 * i + 3], y[10 * N + 3 * i:10 * N + 3 * i + 3]
        R = quat_to_matrix(q)
        Lb = R.T @ L
        w = R @ (m.Iinv[i] * Lb)
        dphi = self.d_orientation(i, t).T
        sub = FlightModel(1, m.W[i:i + 1], m.m[i:i + 1], m.Iinv[i:i + 1], m.g, m.dW[:, i:i + 1], m.dm[:, i:i + 1],
                          m.dIinv[:, i:i + 1])
        dw = omega_tangent(sub, R[None], L[None], Lb[None], w[None], dphi[:, None], T[:, None, 10 * N + 3 * i:10 * N + 3 * i + 3])[:, 0]
        dv = m.W[i] * T[:, 7 * N + 3 * i:7 * N + 3 * i + 3] + m.dW[:, i:i + 1] * P[None]
        return dv.T, dw.T

    def _sens(self, t):
        T = self._out(t)[1]
        if T is None:
            raise InvalidInput("this trajectory was simulated with sensitivities=False; no ∂S/∂u to give")
        return T

    def positions(self, i: int) -> np.ndarray:
        """x_i on the whole grid, (K, 3)."""
        i = self._body(i)
        return self.y[:, 3 * i:3 * i + 3]


def _key(t) -> float:
    return round(float(t), 12)


def _feature_body(feat, k) -> int:
    return int(feat.body[k]) if k < feat.n_plane else int(feat.pairs[k - feat.n_plane][0])


def _model(scene: DesignScene, d: dict, dm: np.ndarray, dIinv: np.ndarray) -> FlightModel:
    N = scene.N
    m = np.array([d[f"mass{i}"][0] for i in range(N)])
    Iinv = np.array([1.0 / d[f"inertia{i}"] for i in range(N)])
    dmT, dIT = dm.T.copy(), np.moveaxis(dIinv, 2, 0).copy()
    return FlightModel(N, 1.0 / m, m, Iinv, scene.gravity, -dmT / (m * m)[None], dmT, dIT)


def simulate(scene: DesignScene, t_end: float, names=None, u=None, *, times=(), h: float = 0.005,
             t0: float = 0.0, sensitivities: bool = True, max_impacts: int = 100, graze_speed: float = 1e-3,
             contact_tol: float = 1e-9, warn: bool = True, check_start: bool = True,
             flight: str = "auto") -> Trajectory:
    """Run q(t) = S(t, u) from t0 to t_end (and ∂S/∂u when ``sensitivities``).

    Parameters
    ----------
    scene : DesignScene
    t_end : float
    names : list of parameter names (default: position, orientation, velocities of every body)
    u : vector of their values (default: the scene's nominal values)
    times : output times in [t0, t_end] where S and ∂S/∂u are kept (the end is always one)
    h : RK4 step; impacts split steps at their located times
    check_start : refuse an initial state that penetrates (``False``: shooting iterates may, they fly on)
    flight : ``"rk4"`` (the general RK4 flight), ``"exact"`` (the closed form of :mod:`pbanim.design.exact`:
        spheres, isotropic inertia, no inertia parameter; else :class:`InvalidInput`) or ``"auto"`` (exact
        when the scene allows it); the grid h then only sets where states are recorded

    >>> from pbanim.collision import Plane, Sphere
    >>> from pbanim.design import DesignBody, DesignScene
    >>> s = DesignScene([DesignBody(Sphere(0.1), position=[0, 0, 1.1])], [Plane([0, 0, 1])], gravity=[0, 0, -10])
    >>> tr = simulate(s, 1.0, ["x0", "restitution"])
    >>> round(tr.impacts[0].t, 12)                           # √(2·1/10)
    0.447213595499
    """
    if not isinstance(scene, DesignScene):
        raise InvalidInput(f"scene must be a DesignScene, got {type(scene).__name__}")
    names = [f"{k}{i}" for i in range(scene.N) for k in ("x", "theta", "v", "omega")] if names is None else names
    names = scene.check_names(names)
    u = scene.vector(names) if u is None else u
    d = scene.values(names, u)
    t0 = check_number("t0", t0)
    t_end = check_number("t_end", t_end, low=t0, low_open=True)
    h = check_number("h", h, low=0.0, low_open=True)
    max_impacts = check_count("max_impacts", max_impacts)
    if flight not in ("auto", "rk4", "exact"):
        raise InvalidInput(f"flight must be 'auto', 'rk4' or 'exact', got {flight!r}")
    out_times = as_floats("times", times, ndmin=1).reshape(-1)
    bad = out_times[~((out_times >= t0) & (out_times <= t_end))]
    if bad.size:
        raise InvalidInput(f"times must lie in the simulated span [{t0:g}, {t_end:g}], got {bad[0]!r}")
    sl = scene.slices(names)
    p = sum(s.stop - s.start for s in sl.values())
    y, Phi, dm, dIinv = scene.initial_state(d, sl, p)
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
    impacts: list[Impact] = []
    notes: list[str] = []

    def pack(y, T):
        return np.concatenate([y, T.ravel()]) if T is not None else y

    def unpack(Y):
        return Y[:n], (Y[n:].reshape(p, n) if sensitivities else None)

    def step(yy, TT, hk):
        if TT is None:
            return plain_step(model, yy, hk), None
        return augmented_step(model, yy, TT, hk)

    def resolve(k, te, ye, Te, rate):
        """Apply the impact of feature k at te (and any contact touching at the same instant)."""
        yy, TT, imp, dtau = apply_impact(model, feat, k, te, ye, Te, nrm, dn, eps, deps, rate=rate)
        g_e = gaps(feat, ye, N, nrm)
        tol = contact_tol * max(1.0, float(np.abs(ye[:3 * N]).max()))
        for kk in np.flatnonzero(np.abs(g_e) <= tol):
            if kk == k:
                continue          # touching at the same instant: resolve it too; S is not smooth here
            yy2, TT2, imp2, _ = apply_impact(model, feat, int(kk), te, yy, TT, nrm, dn, eps, deps, locate=False)
            if imp2.speed > 0:
                yy, TT = yy2, TT2
                imp.simultaneous = True
        imp.grazing = imp.speed < graze_speed
        impacts.append(imp)
        if len(impacts) > max_impacts:
            raise TooManyImpacts(max_impacts, te)
        return yy, TT, dtau

    def rk4_advance(t, Y, hk):
        """One grid step, split at every impact; δτ of an impact enters the sub-step after it as −rate·δτ."""
        yy, TT = unpack(Y)
        t1 = t + hk
        dtau = None
        g0 = gaps(feat, yy, N, nrm)
        tol0 = contact_tol * max(1.0, float(np.abs(yy[:3 * N]).max()))   # just-touching features do not re-fire
        for _ in range(4 * max_impacts + 4):
            y1, T1 = step(yy, TT, t1 - t)
            g1 = gaps(feat, y1, N, nrm)
            hit = np.flatnonzero((g0 > tol0) & (g1 <= 0))
            if hit.size == 0:
                if dtau is not None:
                    T1 -= np.outer(dtau, step_rate(model, yy, t1 - t))
                return pack(y1, T1)
            evs = make_events([(lambda tt, yv, k=k: float(gaps(feat, yv, N, nrm)[k])) for k in hit])
            found = crossings(evs, g0[hit], t, yy, t1, y1, t1 - t, lambda s: plain_step(model, yy, s))
            te, _, ev = found[0]
            k = int(hit[evs.index(ev)])
            ye, Te = step(yy, TT, te - t)
            rate = None
            if TT is not None:
                rate = step_rate(model, yy, te - t)
                if dtau is not None:
                    Te -= np.outer(dtau, rate)
            yy, TT, dtau = resolve(k, te, ye, Te, rate)
            t = te
            g0 = gaps(feat, yy, N, nrm)
            if t1 - t <= 1e-14 * max(1.0, abs(t1)):
                return pack(yy, None if TT is None else saltation_post(model, yy, TT, dtau))
        raise TooManyImpacts(4 * max_impacts, t)

    reason = exact_reason(scene, model)
    if flight == "exact" and reason:
        raise InvalidInput(f"flight='exact' needs spheres with isotropic inertia and no inertia parameter: {reason}")
    use_exact = flight == "exact" or (flight == "auto" and not reason)
    exact = ExactFlight(model, feat, nrm, resolve, t0, y, T, contact_tol, max_impacts) if use_exact else None
    advance = exact.advance if use_exact else rk4_advance   # the exact path drives the state alone

    breaks = np.unique(np.concatenate([[t0, t_end], out_times]))
    ts, ys = [t0], [y.copy()]
    outputs = {}
    if _key(t0) in {_key(v) for v in out_times}:
        outputs[_key(t0)] = (y.copy(), None if T is None else T.copy())
    Y = y.copy() if use_exact else pack(y, T)
    nsteps = 0

    def record(t1, Y1):
        ts.append(t1)
        ys.append(Y1[:n].copy())

    for a, b in zip(breaks[:-1], breaks[1:]):
        grid = step_grid(a, b, h)
        _, Y, k, _ = drive(advance, grid, Y, record=record)
        nsteps += k
        yy, TT = exact.current(b) if use_exact else unpack(Y)
        outputs[_key(b)] = (yy.copy(), None if TT is None else TT.copy())
    smooth = not any(i.grazing or i.simultaneous for i in impacts)
    if not smooth:
        bad_i = [i for i in impacts if i.grazing or i.simultaneous]
        msg = (f"S(t, u) is not differentiable here: {len(bad_i)} impact(s) grazing or simultaneous, first at "
               f"t = {bad_i[0].t:.6g} (approach speed {bad_i[0].speed:.3g} m/s)")
        notes.append(msg)
        if warn:
            warnings.warn(msg, GrazingImpactWarning, stacklevel=2)
    return Trajectory(np.array(ts), np.array(ys), outputs, impacts, names, N, model, nsteps, smooth, notes,
                      "exact" if use_exact else "rk4")
