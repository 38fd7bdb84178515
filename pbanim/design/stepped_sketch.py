"""Infeasible sketches: the nearest feasible motion, its residual, and which parts no motion can follow
(chapter 10, issue 30, point 4).

A sketch (times tᵢ, points pᵢ) asks for positions; the stepped S(t, u) of :mod:`pbanim.design.stepped_run`
gives only physical ones. The answer is the motion nearest the sketch in the metric

    E(u) = Σᵢ |x(tᵢ; u) − pᵢ|²      (m²; ``rms`` = √(E/N) m)

found by Gauss–Newton with backtracking (:func:`pbanim.design.stepped_design.design_contact` with one
position goal per sample: the min-norm update of an overdetermined system is the least-squares step). The
result is always a simulated motion, so it is feasible; the sketch is *followed* where |x(tᵢ) − pᵢ| ≤
``tol``. Where it is not, the sketch's own kinematics say why, from its second differences aᵢ (central,
non-uniform) and whether the sketched point is in contact (every feature's separation at pᵢ, the body in
its initial orientation, ≤ ``contact_gap``):

* in flight, a physical motion has a = g: a sketch with |a − g| > ``accel_tol`` — e.g. a ball that rises
  after losing contact (a_z > 0) — cannot be followed ("flight with a ≠ g");
* in contact with a plane, friction only decelerates sliding: a tangential acceleration along the motion
  (a_t·v_t > 0) or beyond μ|g| — a box that speeds up with no force — cannot ("accelerates with no force").

Samples the fit misses by more than ``tol`` are reported as time intervals with the reasons found in them
(or "the fitted motion misses it" when the sketch's kinematics are admissible there: a sketch that is
locally possible but not with the others). Never an exception (an error on the way is a note) and never a
success for a sketch the motion does not follow.

References: Popović, Seitz & Erdmann, ACM TOG 2003 §4 (the sketch as a least-squares goal); Nocedal &
Wright §10.3 (Gauss–Newton).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..contracts import Array, Int, Obj, Opt, Real, contract
from ..errors import InvalidInput, PbanimError
from ..rigid import quat_to_matrix
from .control import position_goal
from .stepped import ContactScene, frames
from .stepped_design import design_contact
from .stepped_run import ContactTrajectory

__all__ = ["SketchFit", "fit_sketch", "sketch_checks"]


@dataclass
class SketchFit:                # a record pbanim builds (fit_sketch) and users read
    """The motion nearest a sketch: ``u`` for ``names``, its ``trajectory`` (None only if no run could be
    made), ``distances`` |x(tᵢ) − pᵢ| per sample, ``rms`` (m), ``success`` (every sample within tol),
    ``infeasible`` [(t_start, t_end, reasons)] and notes."""

    u: np.ndarray
    names: list
    trajectory: ContactTrajectory | None
    distances: np.ndarray
    rms: float
    success: bool
    infeasible: list
    notes: list = field(default_factory=list)


@contract(scene=Obj(ContactScene), times=Array((None,), scalar=True), points=Array((None, 3)),
          accel_tol=Real(gt=0), contact_gap=Real(ge=0))
def sketch_checks(scene, times, points, *, accel_tol: float = 1.0, contact_gap: float = 0.01) -> list:
    """Per interior sample i (1 … N−2): the reason no motion can follow the sketch there, or None."""
    t, P = np.atleast_1d(np.asarray(times, dtype=float)), np.asarray(points, dtype=float)
    if t.size != P.shape[0] or t.size < 3 or np.any(np.diff(t) <= 0):
        raise InvalidInput(f"times: the sketch needs ≥ 3 samples at increasing times, one point each; got {t.size} times "
                           f"and {P.shape[0]} points")
    R = quat_to_matrix(scene.body.orientation)
    g, mu = scene.gravity, scene.friction
    out = [None]
    for i in range(1, t.size - 1):
        h0, h1 = t[i] - t[i - 1], t[i + 1] - t[i]
        v = (P[i + 1] - P[i - 1]) / (h0 + h1)
        a = 2 * ((P[i + 1] - P[i]) / h1 - (P[i] - P[i - 1]) / h0) / (h0 + h1)
        fr = frames(scene, P[i], R)
        k = int(np.argmin(fr.s))
        if fr.s[k] > contact_gap:
            bad = np.linalg.norm(a - g) > accel_tol
            out.append(f"flight with a ≠ g (a = {np.round(a, 2).tolist()} m/s²)" if bad else None)
            continue
        n = fr.D[k, 0]
        at, vt = a - (a @ n) * n, v - (v @ n) * n
        limit = mu * max(0.0, -(g @ n) + a @ n) + accel_tol
        speeds_up = at @ vt > accel_tol * max(np.linalg.norm(vt), 1e-12)
        out.append("accelerates with no force (friction only decelerates sliding)"
                   if speeds_up or np.linalg.norm(at) > limit else None)
    out.append(None)
    return out


@contract(scene=Obj(ContactScene), times=Array((None,), scalar=True), points=Array((None, 3)),
          names=Obj(list, tuple), u=Opt(Array((None,))), h=Real(gt=0), tol=Real(gt=0), max_iter=Int(ge=1),
          accel_tol=Real(gt=0), contact_gap=Real(ge=0))
def fit_sketch(scene, times, points, names, *, u=None, h: float = 0.01, tol: float = 0.01, max_iter: int = 10,
               accel_tol: float = 1.0, contact_gap: float = 0.01) -> SketchFit:
    """The feasible motion nearest the sketch (see the module), its residual and the infeasible parts."""
    t, P = np.atleast_1d(np.asarray(times, dtype=float)), np.asarray(points, dtype=float)
    if t.size != P.shape[0] or np.any(np.diff(t) <= 0) or t[0] < 0:
        raise InvalidInput(f"times: one increasing time ≥ 0 per sketch point, got {t.size} times for "
                           f"{P.shape[0]} points")
    notes = []
    try:
        reasons = sketch_checks(scene, t, P, accel_tol=accel_tol, contact_gap=contact_gap)
    except PbanimError as exc:
        reasons = [None] * t.size
        notes.append(f"the sketch's kinematics were not checked: {exc}")
    goals = [position_goal(0, ti, pi) for ti, pi in zip(t, P) if ti > 0]          # t = 0 is x0 itself
    names = list(names)
    u0 = scene.vector(names) if u is None else np.asarray(u, dtype=float)
    try:
        d = design_contact(scene, float(t[-1]), names, goals, u=u0, h=h, tol=1e-12, max_iter=max_iter)
    except PbanimError as exc:
        notes.append(f"no motion could be simulated from u: {exc}")
        return SketchFit(u0, names, None, np.full(t.size, np.inf), np.inf, False,
                         [(float(t[0]), float(t[-1]), ["no motion simulated"])], notes)
    tr = d.trajectory
    dist = np.array([np.linalg.norm((tr.position(ti) if ti > 0 else tr.y[0, :3]) - pi) for ti, pi in zip(t, P)])
    miss = dist > tol
    parts, i = [], 0
    while i < t.size:
        if not miss[i]:
            i += 1
            continue
        j = i
        while j + 1 < t.size and miss[j + 1]:
            j += 1
        why = sorted({r for r in reasons[max(i - 1, 0):j + 2] if r is not None}) or ["the fitted motion misses it"]
        parts.append((float(t[i]), float(t[j]), why))
        i = j + 1
    notes += [n for n in d.notes if "step(s) solved" in n]
    notes.append(f"nearest motion in E = Σ|x(tᵢ) − pᵢ|²: rms {np.sqrt(np.mean(dist ** 2)):.3e} m over {t.size} samples, "
                 f"{int(miss.sum())} beyond tol = {tol:g} m (Gauss–Newton stopped after {d.iterations} updates)")
    for r in sorted({r for r in reasons if r is not None}):
        if not any(r in p[2] for p in parts):
            notes.append(f"the sketch has a part no motion follows exactly ({r}) but the fit is within tol there")
    return SketchFit(d.u, names, tr, dist, float(np.sqrt(np.mean(dist ** 2))), bool(not miss.any()), parts, notes)
