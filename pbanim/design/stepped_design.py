"""Designs that need contact: goals met through sliding, rolling and resting (chapter 10, issue 30).

The deck's differential control, δu = argmin δuᵀMδu subject to (∂S/∂u) δu = δq (the min-norm update of
:func:`pbanim.design.control.min_norm_update`), run on the stepped S(t, u) of
:mod:`pbanim.design.stepped_run`, whose ∂S/∂u goes through the complementarity system of every step. S is
piecewise smooth in u (a kink wherever a step's contact changes its mode), so each Gauss–Newton step is
accepted only when the goal residual ‖δq‖ falls (halved up to ``backtracks`` times otherwise; then the
steepest-descent step Jᵀδq at its Cauchy length is tried the same way):

    u ← u + α δu,   α ∈ {1, ½, ¼, …},   ‖δq(u + αδu)‖ < ‖δq(u)‖.

A trial that fails can lie past a kink: S is continuous, but ∂S/∂u jumps where a step's contact changes its
mode, and near the goal the derivative of u's piece mispredicts the far one (a die 3.5e-6 m from its place,
the kink 7 % of the step away, the far piece's ∂x/∂v₀ half of the near one's: backtracking then creeps, 10 %
per update). The first trial that fails in an update is therefore also a base: Gauss–Newton from it with its
own derivative (the far piece's, from the trial's run; one run more), kept when the residual falls
(``cross``; the kink-crossing step, ORACLES L9; by default only for goals met exactly, no more rows than
parameters: in a least-squares fit the far piece's minimizer need not lie on that piece):

    u ← u_t + δu_t,   u_t = u + α δu,   (∂S/∂u)(u_t) δu_t = δq(u_t) (min-norm),   ‖δq‖ < ‖δq(u)‖.

Goals are positions x(t) = target (:func:`pbanim.design.control.position_goal`, body 0), and optionally
*rest* at t_end (|v| and |ω| ≤ ``rest_tol``: a box that slides and stops, a die that stops rolling) and a
*face*: the body axis ``face`` (0..5: +x, −x, +y, −y, +z, −z in the body frame) pointing down at t_end.
Which face a tumbling cube lands on is a discrete outcome (S's derivative along a resting face is zero),
so the face is met by the cube's symmetry: with a cube's shape and isotropic inertia, starting from
R₀g (g a rotation of the cube's symmetry group, g f = a for the wanted face f and the face a it lands on)
gives the same motion in the world with the body labels permuted, R(t)g; the face relabelled, the
position goal is rechecked by a fresh run (roundoff can grow through the impacts; Gauss–Newton resumes).

=========  ===================  =========================================================================
symbol     code                 meaning
=========  ===================  =========================================================================
δq         ``residual``         target − x(t) stacked over the goals (its norm reported)
M          ``M``                metric of the update (SPD), default 𝟙
α          ``backtracks``       step fraction (halvings allowed per update)
u_t        ``cross``            a failed trial u + αδu, the base of the kink-crossing step
g          ``face``             the cube symmetry applied to the initial orientation (θ₀) for the face
=========  ===================  =========================================================================

References: Popović et al. SIGGRAPH 2000 §5 (differential control); Nocedal & Wright, *Numerical
Optimization* §3.1 (backtracking), §10.3 (Gauss–Newton); de Avila Belbute-Peres et al. 2018.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from itertools import permutations, product

import numpy as np

from ..collision import Box
from ..contracts import Array, Flag, Int, Obj, Opt, Real, Seq, contract, unchecked
from ..errors import InvalidInput, PbanimError
from ..rigid import matrix_to_quat, quat_multiply, quat_conjugate, quat_to_matrix
from .control import Goal, min_norm_update
from .simulate import quat_log
from .stepped import ContactScene
from .stepped_run import ContactTrajectory, simulate_contact

__all__ = ["ContactDesign", "design_contact", "down_face", "FACES"]

#: body axes of a box's faces, in the order of ``face``
FACES = np.array([[1.0, 0, 0], [-1, 0, 0], [0, 1, 0], [0, -1, 0], [0, 0, 1], [0, 0, -1]])


@dataclass
class ContactDesign:            # a record pbanim builds (design_contact) and users read
    """What :func:`design_contact` found: ``u`` for ``names``, ``residual`` ‖δq‖, ``success`` (goals within
    ``tol``, at rest and on the face when asked, on a run whose contact problems were all solved), the
    ``trajectory`` of u, ``history`` (‖δq‖ per update), ``face`` down at the end and notes."""

    u: np.ndarray
    names: list
    residual: float
    success: bool
    iterations: int
    trajectory: ContactTrajectory
    history: list
    at_rest: bool
    face: int | None
    notes: list = field(default_factory=list)


@contract(tr=Obj(ContactTrajectory), t=Real())
def down_face(tr, t) -> int:
    """The face (index into ``FACES``) whose axis points most nearly down (−z) at output time t."""
    R = quat_to_matrix(tr.orientation(t))
    return int(np.argmax(FACES @ (R.T @ np.array([0.0, 0.0, -1.0]))))


def _cube_symmetry(a: int, f: int) -> np.ndarray:
    """A proper rotation g of the cube (a signed permutation, det +1) with g·FACES[f] = FACES[a]."""
    for perm in permutations(range(3)):
        for signs in product((1.0, -1.0), repeat=3):
            g = np.zeros((3, 3))
            g[range(3), perm] = signs
            if np.linalg.det(g) > 0 and np.allclose(g @ FACES[f], FACES[a]):
                return g
    raise AssertionError("the cube's symmetry group maps every face to every face")


def _residual(tr, goals, comp) -> np.ndarray:
    return np.concatenate([(g.target - tr.position(g.time))[comp] for g in goals])


@contract(scene=Obj(ContactScene), t_end=Real(gt=0), names=Obj(list, tuple), goals=Seq(Obj(Goal)),
          u=Opt(Array((None,))), rest=Flag(), face=Opt(Int(ge=0, le=5)), M=Opt(Array((None, None))),
          h=Real(gt=0), tol=Real(gt=0), rest_tol=Real(gt=0), max_iter=Int(ge=1), backtracks=Int(ge=0),
          components=Seq(Int(ge=0, le=2)), kicks=Int(ge=0), kick=Real(ge=0), seed=Int(ge=0), cross=Opt(Flag()))
def design_contact(scene, t_end: float, names, goals, *, u=None, rest: bool = False, face=None, M=None,
                   h: float = 0.01, tol: float = 1e-6, rest_tol: float = 1e-6, max_iter: int = 20,
                   backtracks: int = 8, components=(0, 1, 2), kicks: int = 0, kick: float = 0.1,
                   seed: int = 0, cross=None) -> ContactDesign:
    """Find u (blocks ``names``) so that the stepped motion meets ``goals`` (position goals of body 0 at
    times in (0, t_end]), comes to rest at t_end (``rest``) and lies on ``face`` (a cube: its initial
    orientation ``theta0`` is then part of the answer, appended to names); ``components`` the coordinates of
    each goal that count (e.g. (0, 1): where a ball passes over a cup, at whatever height); ``kicks``: when
    no step lowers the residual (the goal lies across a jump of S, e.g. a die that tips over one more edge or
    not), restart up to ``kicks`` times from the best u moved by ``kick``·max(|u|, 0.1)·N(0, 1) (seeded), the
    best answer kept — the discrete layer over which piece of S the answer lies on; ``cross``: when a trial
    fails, try Gauss–Newton from it with its own ∂S/∂u (the far side of a kink; the first failing trial of each
    update, one run more); None: when the goals count no more rows than u has parameters (goals met exactly,
    as the die's), not for a least-squares fit (more rows: the far piece's minimizer need not lie on it, e.g.
    a sketch fit); False: the search without it. Never raises for a goal it cannot meet: ``success``
    False with the residual reached and notes.

    >>> from pbanim.collision import Box, Plane
    >>> from pbanim.design import DesignBody
    >>> from pbanim.design.control import position_goal
    >>> s = ContactScene(DesignBody(Box([0.2, 0.1, 0.05]), position=[0, 0, 0.05], velocity=[1.0, 0, 0]),
    ...                  [Plane()], friction=0.4)
    >>> d = design_contact(s, 0.8, ["v0"], [position_goal(0, 0.8, [0.3, 0.1, 0.05])], rest=True)
    >>> d.success, d.residual < 1e-6
    (True, True)
    """
    names = scene.check_names(names)
    if face is not None:
        if "theta0" in names:
            raise InvalidInput("design_contact: with face given, theta0 is the answer's (leave it out of names)")
        he, I = scene.body.shape, scene.inertia
        if not (isinstance(he, Box) and np.ptp(he.half_extents) == 0 and np.ptp(I) <= 1e-12 * I.max()):
            raise InvalidInput("design_contact: face needs a cube with isotropic inertia (a die)")
    if any(g.kind != "position" or g.body != 0 or not 0 < g.time <= t_end for g in goals):
        raise InvalidInput(f"design_contact: goals must be position goals of body 0 at times in (0, {t_end:g}]")
    u = scene.vector(names) if u is None else np.asarray(u, dtype=float).reshape(-1).copy()
    comp = sorted(set(int(c) for c in components))
    if not comp:
        raise InvalidInput("design_contact: components must name at least one coordinate (0, 1, 2)")
    times = sorted({float(g.time) for g in goals if g.time < t_end})
    upd = unchecked(min_norm_update)
    theta = np.zeros(3)
    run_names = names + (["theta0"] if face is not None else [])

    def run(uu, sens=True):
        full = np.concatenate([uu, theta]) if face is not None else uu
        return simulate_contact(scene, t_end, run_names, full, times=times, h=h, sensitivities=sens)

    tr = run(u)
    r = _residual(tr, goals, comp)
    history, notes, it = [float(np.linalg.norm(r))], [], 0
    relabelled = False
    rng, best = np.random.default_rng(seed), (np.inf, 0, u, tr, r, theta)
    for it in range(1, max_iter + 1):
        if history[-1] <= tol:
            if face is None or relabelled:
                break
            theta, relabelled = _relabel(scene, tr, theta, face), True   # the face by the cube's symmetry
            tr = run(u)
            r = _residual(tr, goals, comp)
            history.append(float(np.linalg.norm(r)))
            continue
        p = u.size
        J = np.vstack([tr.d_position(g.time)[comp, :p] for g in goals])
        gd = J.T @ r                                   # steepest descent, at its Cauchy length, when the
        Jg = J @ gd                                    # Gauss–Newton step meets a kink it cannot get past
        cauchy = gd * (gd @ gd) / (Jg @ Jg) if Jg @ Jg > 0 else gd
        ok, crossed = False, not (J.shape[0] <= p if cross is None else cross)
        for kind, du in (("Gauss–Newton", upd(J, r, M).du), ("steepest descent", cauchy)):
            alpha = 1.0
            for _ in range(backtracks + 1):
                try:
                    trial = run(u + alpha * du)
                except PbanimError as exc:    # a start inside an obstacle, an unsolved contact problem
                    notes.append(f"update {it}: {kind} α = {alpha:g} refused ({exc}); halved")
                    alpha *= 0.5
                    continue
                rt = _residual(trial, goals, comp)
                if np.linalg.norm(rt) < history[-1]:
                    u, tr, r, ok = u + alpha * du, trial, rt, True
                    break
                if not crossed:                # the first step that fails: Gauss–Newton on its own piece
                    crossed = True
                    got = _cross(run, goals, comp, upd, M, u + alpha * du, trial, rt, history[-1], p)
                    if got is not None:
                        (u, tr, r), ok = got, True
                        notes.append(f"update {it}: {kind} α = {alpha:g} crossed a kink (Gauss–Newton from "
                                     f"the far piece)")
                        break
                alpha *= 0.5
            if ok:
                break
        if not ok:
            notes.append(f"update {it}: no fraction of the Gauss–Newton or the steepest-descent step lowered "
                         f"the residual {history[-1]:.3e} (a kink of S or a local minimum)")
            best = min(best, (history[-1], it, u, tr, r, theta), key=lambda b: b[0])
            moved = False
            while kicks > 0 and not moved:
                kicks -= 1
                trial_u = best[2] + kick * np.maximum(np.abs(best[2]), 0.1) * rng.standard_normal(best[2].size)
                try:
                    tr, u, theta = run(trial_u), trial_u, best[5]
                    moved = True
                except PbanimError as exc:
                    notes.append(f"update {it}: a kick was refused ({exc})")
            if not moved:
                break
            r = _residual(tr, goals, comp)
            notes.append(f"update {it}: kicked to a new start (residual {np.linalg.norm(r):.3e})")
            history.append(float(np.linalg.norm(r)))
            relabelled = False
            continue
        history.append(float(np.linalg.norm(r)))
        if face is not None and history[-1] > tol:
            relabelled = False
    if best[0] < history[-1]:                       # a kick led nowhere better: the best answer found
        _, _, u, tr, r, theta = best
        history.append(best[0])
    return _finish(scene, tr, names, u, theta, face, goals, rest, tol, rest_tol, history, notes, it, t_end)


def _cross(run, goals, comp, upd, M, ut, trial, rt, res, p):
    """The kink-crossing step: the trial point u_t = u + α δu failed (‖δq(u_t)‖ ≥ ‖δq(u)‖) because a kink of S
    lies between u and u_t, where a step's contact changes its mode and ∂S/∂u jumps. Gauss–Newton from u_t
    with u_t's own derivative (the far piece's J_t, computed by the trial's run):

        u ← u_t + δu_t,   δu_t = argmin δuᵀMδu  subject to  J_t δu = δq(u_t),

    accepted only when ‖δq‖ < ``res`` (the current residual). Returns (u, trajectory, δq) or None."""
    Jt = np.vstack([trial.d_position(g.time)[comp, :p] for g in goals])
    try:
        ut2 = ut + upd(Jt, rt, M).du
        tr2 = run(ut2)
    except PbanimError:
        return None
    r2 = _residual(tr2, goals, comp)
    return (ut2, tr2, r2) if np.linalg.norm(r2) < res else None


def _relabel(scene, tr, theta, face):
    """θ₀ so that the same motion ends on ``face``: R₀ → R₀ g with g·f = a (a: the face down now)."""
    a = down_face(tr, tr.t[-1])
    g = _cube_symmetry(a, face)
    q0 = quat_multiply(matrix_to_quat(quat_to_matrix(tr.y[0, 3:7]) @ g), quat_conjugate(scene.body.orientation))
    return quat_log(q0)


def _finish(scene, tr, names, u, theta, face, goals, rest, tol, rest_tol, history, notes, it, t_end):
    v, w = tr.velocities(t_end)
    at_rest = bool(max(np.abs(v).max(), np.abs(w).max()) <= rest_tol)
    got = down_face(tr, t_end) if isinstance(scene.body.shape, Box) else None
    ok = history[-1] <= tol
    if rest and not at_rest:
        notes.append(f"not at rest at t_end: |v| = {np.abs(v).max():.2e}, |ω| = {np.abs(w).max():.2e} > {rest_tol:g}")
    if face is not None and got != face:
        notes.append(f"the body ends on face {got}, not {face}")
    loose = [n for n in tr.notes if "residual" in n]
    notes += loose
    success = ok and (at_rest or not rest) and (face is None or got == face)
    if not ok:
        notes.append(f"goal residual {history[-1]:.3e} > tol = {tol:g} after {it} updates")
    names_out = list(names) + (["theta0"] if face is not None else [])
    u_out = np.concatenate([u, theta]) if face is not None else u.copy()
    return ContactDesign(u_out, names_out, history[-1], bool(success), it, tr, history, at_rest, got, notes)
