"""S(t, u) and ∂S/∂u of a body stepped through contact, its result and its independent replay (chapter 10).

:func:`simulate_contact` runs the velocity-level contact step of :mod:`pbanim.design.stepped_sim` on the one
step grid of the suite (:func:`pbanim.ode.driver.step_grid`, :func:`pbanim.ode.driver.drive`) and carries
the tangent rows T = (∂S/∂u)ᵀ in (δx, δφ, δP, δL) through every step. Its :class:`ContactTrajectory` says,
per step and per contact, which linear system the derivative came from (separating, sticking, sliding:
``modes``), and where the derivative stops holding: the nearest predicted switch of every parameter
(``switches``) and ``at_switch`` when one is within ``switch_tol`` — a one-sided ∂S/∂u is flagged, never
silent.

**Rest.** A body that stops comes to rest *by the step law*: a touching contact pressed in has w_n = 0,
so s⁺ = s + h v_n⁺ = 0 at every step and the body stays on the surface (no event, no Zeno). With
restitution ε > 0 (:class:`~pbanim.design.stepped.ContactScene`) a contact approaching faster than
v_rest = 3|g|h bounces (v_n⁺ = −ε ũ_n); slower approaches are plastic, which ends the bounces of a ball
near the Zeno time t∞ = √(2h₀/g)(1 + ε)/(1 − ε) (ORACLES L3) instead of accumulating them.

**The certificate.** Every recorded state keeps every feature's separation ≥ −``penetration_tol`` (a
corner of a tumbling box can dip by the rotation's second-order term ~ h²|ω|²|c| within a step).
:func:`replay_chapter7` replays u in chapter 07's own stepper (:class:`pbanim.contact.FrictionStepping`,
chapter 07's narrow phase for planes): the independent replay designs certify against (ORACLES L2).

References: chapter 07 (:mod:`pbanim.contact`); Popović et al. SIGGRAPH 2000 §4 (S and ∂S/∂u).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..contracts import Array, Flag, Int, Obj, Opt, Real, contract
from ..errors import InvalidInput
from ..ode.driver import drive, step_grid
from ..rigid import quat_to_matrix
from .stepped import ContactScene, frames
from .stepped_sim import MODES, SWITCH_KINDS, contact_step, nearest_switch
from .scene import PenetrationError
from ..geometry import skew

__all__ = ["ContactTrajectory", "Switch", "simulate_contact", "replay_chapter7"]


@dataclass
class Switch:                   # a record pbanim builds (simulate_contact) and users read
    """The nearest predicted switch along parameter ``index`` (``name`` its block): at u_k + ``delta``
    (``value``), in the step starting at ``t``, of ``contact`` (feature index), what changes (``kind``)."""

    index: int
    name: str
    delta: float
    value: float
    t: float
    contact: int
    kind: str


@dataclass
class ContactTrajectory:        # a record pbanim builds (simulate_contact) and users read
    """S(t, u) stepped through contact: the grid states ``y`` (K, 13) = [x, q, P, L] at times ``t``, the
    outputs {time: (y, T (p, 12) or None)}, ``modes`` (K − 1, m) per step and feature (0 separating,
    1 sticking, 2 sliding), ``switches`` (one :class:`Switch` per parameter), ``at_switch``, ``clearance``
    (least separation over the run), ``certified``, ``residual`` (largest LCP residual) and notes."""

    t: np.ndarray
    y: np.ndarray
    outputs: dict
    names: list
    u: np.ndarray
    modes: np.ndarray
    switches: list
    at_switch: bool
    consistent: bool
    clearance: float
    certified: bool
    residual: float
    mass: float
    inertia: np.ndarray
    notes: list = field(default_factory=list)

    @property
    def differentiable(self) -> bool:
        """∂S/∂u is two-sided: no switch within ``switch_tol`` and every active-set system consistent."""
        return not self.at_switch and self.consistent

    def _out(self, t):
        key = round(float(t), 12)
        if key not in self.outputs:
            raise InvalidInput(f"ContactTrajectory: t must be an output time, one of {sorted(self.outputs)}, got {t!r}")
        return self.outputs[key]

    def _T(self, t):
        T = self._out(t)[1]
        if T is None:
            raise InvalidInput("this trajectory was simulated with sensitivities=False; no ∂S/∂u to give")
        return T

    @contract(t=Real())
    def position(self, t) -> np.ndarray:
        """x at an output time."""
        return self._out(t)[0][:3].copy()

    @contract(t=Real())
    def orientation(self, t) -> np.ndarray:
        """q at an output time."""
        return self._out(t)[0][3:7].copy()

    @contract(t=Real())
    def velocities(self, t):
        """(v, ω) at an output time."""
        y = self._out(t)[0]
        R = quat_to_matrix(y[3:7])
        return y[7:10] / self.mass, R @ ((R.T @ y[10:13]) / self.inertia)

    @contract(t=Real())
    def d_position(self, t) -> np.ndarray:
        """∂x(t)/∂u (3, p)."""
        return self._T(t)[:, :3].T.copy()

    @contract(t=Real())
    def d_orientation(self, t) -> np.ndarray:
        """∂φ(t)/∂u (3, p), φ the world rotation vector of δq."""
        return self._T(t)[:, 3:6].T.copy()

    @contract(t=Real())
    def d_velocities(self, t):
        """(∂v/∂u, ∂ω/∂u), each (3, p)."""
        y, T = self._out(t)[0], self._T(t)
        R = quat_to_matrix(y[3:7])
        Iw_inv = R @ (R.T / self.inertia[:, None])
        w = Iw_inv @ y[10:13]
        dw = T[:, 3:6] @ (-skew(w) + Iw_inv @ skew(y[10:13])).T + T[:, 9:12] @ Iw_inv.T
        return (T[:, 6:9] / self.mass).T, dw.T

    def positions(self) -> np.ndarray:
        """x on the whole grid (K, 3)."""
        return self.y[:, :3]

    def mode_counts(self) -> dict:
        """{mode name: number of (step, contact) pairs in it}."""
        return {name: int(np.sum(self.modes == k)) for k, name in enumerate(MODES)}


_SCENE = Obj(ContactScene)


def _names(scene, names):
    return ["x0", "theta0", "v0", "omega0"] if names is None else scene.check_names(names)


@contract(scene=_SCENE, t_end=Real(), names=Opt(Obj(list, tuple, str)), u=Opt(Array((None,))),
          times=Array((None,), scalar=True, empty=True), h=Real(gt=0), t0=Real(), sensitivities=Flag(),
          tol=Real(gt=0, lt=1e-3), penetration_tol=Real(gt=0), switch_tol=Real(ge=0), max_steps=Int(ge=1))
def simulate_contact(scene, t_end: float, names=None, u=None, *, times=(), h: float = 0.005, t0: float = 0.0,
                     sensitivities: bool = True, tol: float = 1e-9, penetration_tol: float = 1e-4,
                     switch_tol: float = 1e-9, max_steps: int = 100_000) -> ContactTrajectory:
    """q(t) = S(t, u) by the velocity-level contact step from t0 to t_end, and ∂S/∂u (see the module).

    ``names`` default ``["x0", "theta0", "v0", "omega0"]`` (add ``"friction"`` for μ); ``times`` output times
    (the end is always one); ``switch_tol``: a switch predicted within switch_tol·max(1, |u_k|) of u makes the
    run ``at_switch``. A recorded state deeper than ``penetration_tol`` raises :class:`PenetrationError`.

    >>> from pbanim.collision import Plane, Sphere
    >>> from pbanim.design import DesignBody
    >>> s = ContactScene(DesignBody(Sphere(0.1), position=[0, 0, 0.1], velocity=[1.0, 0, 0]), [Plane()])
    >>> tr = simulate_contact(s, 0.5, ["v0"])
    >>> tr.mode_counts()["sliding"] > 0, tr.differentiable
    (True, True)
    """
    names = _names(scene, names)
    u = scene.vector(names) if u is None else np.asarray(u, dtype=float).reshape(-1)
    t0, t_end = float(t0), float(t_end)
    if not t_end > t0:
        raise InvalidInput(f"simulate_contact: t_end must be after t0 = {t0:g}, got {t_end!r}")
    out_t = np.asarray(times, dtype=float).reshape(-1)
    if np.any((out_t < t0) | (out_t > t_end)):
        raise InvalidInput(f"simulate_contact: times must lie in [{t0:g}, {t_end:g}], got {out_t.tolist()}")
    breaks = np.unique(np.concatenate([[t0, t_end], out_t]))
    grids = [step_grid(a, b, h, max_steps=max_steps) for a, b in zip(breaks[:-1], breaks[1:])]
    if sum(g.n_steps for g in grids) > max_steps:
        raise InvalidInput(f"simulate_contact: {sum(g.n_steps for g in grids)} steps > max_steps = {max_steps}")
    y, T, mu, dmu = scene.initial(names, u)
    T = T if sensitivities else None
    p = dmu.size
    ts, ys, modes, carry = [t0], [y.copy()], [], {"state": None, "res": 0.0, "ok": True, "loose": 0}
    best = [np.full(p, np.inf), np.full(p, np.inf), [None] * p]
    outputs = {}
    if round(t0, 12) in {round(float(v), 12) for v in out_t}:
        outputs[round(t0, 12)] = (y.copy(), None if T is None else T.copy())

    def advance(t, Y, hk):
        yy, TT = Y[:13], (Y[13:].reshape(p, 12) if sensitivities else None)
        y1, T1, info = contact_step(scene, yy, TT, mu, dmu, hk, carry["state"], tol)
        carry["state"], carry["res"] = info.state, max(carry["res"], info.residual)
        carry["loose"] += not info.solved
        modes.append(info.modes)
        if TT is not None:
            carry["ok"] = carry["ok"] and info.consistent
            dist, val, k = nearest_switch(info)
            for i in np.flatnonzero(dist < best[0]):
                c, kind = info.labels[k[i]]
                best[0][i], best[1][i], best[2][i] = dist[i], val[i], (t, int(c), SWITCH_KINDS[kind])
        return y1 if T1 is None else np.concatenate([y1, T1.ravel()])

    def record(t1, Y1):
        ts.append(t1)
        ys.append(Y1[:13].copy())

    Y = y if T is None else np.concatenate([y, T.ravel()])
    with np.errstate(over="ignore", invalid="ignore"):
        for b, grid in zip(breaks[1:], grids):
            _, Y, _, _ = drive(advance, grid, Y, record=record)
            outputs[round(float(b), 12)] = (Y[:13].copy(), Y[13:].reshape(p, 12).copy() if sensitivities else None)
    return _finish(scene, names, u, ts, ys, outputs, modes, best, carry, p, penetration_tol, switch_tol)


def _finish(scene, names, u, ts, ys, outputs, modes, best, carry, p, penetration_tol, switch_tol):
    Y = np.array(ys)
    clear = min(float(frames(scene, yy[:3], quat_to_matrix(yy[3:7])).s.min()) for yy in Y)
    notes = []
    if clear < -penetration_tol:
        raise PenetrationError(f"the stepped S(t, u) is not certified: a feature lies {-clear:.3e} inside an "
                               f"obstacle (penetration_tol = {penetration_tol:g}); use a smaller h")
    label = [f"{k}[{j}]" for k in names for j in range(scene.size(k))]
    switches, at = [], False
    for i in range(p):
        where = best[2][i]
        if where is None:
            continue
        t, c, kind = where
        switches.append(Switch(i, label[i], float(best[1][i]), float(u[i] + best[1][i]), float(t), c, kind))
        if best[0][i] <= switch_tol * max(1.0, abs(u[i])):
            at = True
            notes.append(f"∂S/∂u is one-sided in {label[i]}: a contact switch ({kind}, feature {c}, step at "
                         f"t = {t:.6g}) sits at {label[i]} = {u[i] + best[1][i]:.12g} (distance {best[0][i]:.2e})")
    if carry["loose"]:
        notes.append(f"{carry['loose']} step(s) solved their contact problem only to residual {carry['res']:.1e} "
                     "(no active set certified to tol: a degenerate contact): ∂S/∂u there is approximate")
    if not carry["ok"]:
        notes.append("an active-set system was inconsistent or a step's solve was loose (a degenerate contact "
                     "configuration): ∂S/∂u not exact")
    mode_arr = np.array(modes, dtype=np.int8).reshape(len(modes), -1)
    return ContactTrajectory(np.array(ts), Y, outputs, names, u, mode_arr, switches, at, carry["ok"], clear, True,
                             carry["res"], scene.mass, scene.inertia.copy(), notes)


@contract(scene=_SCENE, t_end=Real(gt=0), names=Opt(Obj(list, tuple, str)), u=Opt(Array((None,))), h=Real(gt=0))
def replay_chapter7(scene, t_end: float, names=None, u=None, *, h: float = 0.005) -> np.ndarray:
    """The states (K, 13) of u replayed by chapter 07's :class:`pbanim.contact.FrictionStepping` (its box
    friction, its active-set solver and warm start, its driver; chapter 07's box–plane narrow phase
    :func:`pbanim.contact.scenes.box_plane_contacts` with every corner a candidate), on the same grid."""
    from ..contact.scenes import box_plane_contacts
    from ..contact.stepping import FrictionStepping
    from ..collision.shapes import Contacts
    from ..rigid import RigidBodies, RigidGravity

    names = _names(scene, names)
    u = scene.vector(names) if u is None else np.asarray(u, dtype=float).reshape(-1)
    y0, _, mu, _ = scene.initial(names, u)
    bodies = RigidBodies(scene.mass, scene.inertia, positions=[y0[:3]], orientations=[y0[3:7]],
                         velocities=[y0[7:10] / scene.mass])
    half = None if scene.sphere else scene.body.shape.half_extents

    def detect(yy):
        x, q = yy[:3], yy[3:7]
        R = quat_to_matrix(q)
        pts, nrm, sep, keys = [], [], [], []
        for j, (n, o) in enumerate(zip(scene.plane_n, scene.plane_o)):
            if half is None:
                pts.append([x - scene.radius * n]), sep.append([n @ x - o - scene.radius]), keys.append([j])
                nrm.append([n])
            else:
                _, p, s, f = box_plane_contacts(x[None], R[None], half, n, o, np.inf, plane_id=j)
                pts.append(p), sep.append(s), keys.append(f), nrm.append(np.tile(n, (len(s), 1)))
        if scene.boxes:
            fr = frames(scene, x, R)
            k = np.flatnonzero(fr.kind == 2)
            n = fr.D[k, 0]
            pts.append(x + fr.r[k]), sep.append(fr.s[k]), keys.append(1000 + k), nrm.append(n)
        P, Nn, Sp = np.vstack(pts), np.vstack(nrm), np.concatenate(sep)
        c = Contacts(a=np.zeros(len(Sp), np.intp), b=np.full(len(Sp), -1, np.intp), point=P, normal=Nn, depth=-Sp)
        return c, np.concatenate(keys).astype(np.int64)

    ts = FrictionStepping(bodies, detect, [RigidGravity(scene.gravity)], friction=mu, erp=scene.erp, tol=1e-9)
    res = ts.simulate(t_end, h, y0=np.concatenate([y0[:7], y0[7:10], y0[10:]]))
    return res.y.T
