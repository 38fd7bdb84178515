"""Differential control: goals, the min-norm update and the interactive loop (chapter 10).

The animator pins what a body should do — a position x_i(t) = x̄ or an orientation q_i(t) = q̄ at a
time t, for one or more bodies at one or more times — and the goals stack into one residual
δq = (x̄ − x_i(t), log(q̄ ⊗ q_i(t)*), ...) with rows A = ∂S/∂u. The deck's update

    min δuᵀ M δu   subject to   δq = A δu

has, with M = C Cᵀ (Cholesky) and B = A C⁻ᵀ = U Σ Vᵀ, the solution δu = C⁻ᵀ V Σ⁺ Uᵀ δq, and with the
damping λ (damped least squares, Levenberg/Wampler) Σ⁺ → σ/(σ² + λ²): when A loses rank (more goals
than parameters can meet, or directions S does not depend on) the damped update stays bounded instead of
dividing by σ ≈ 0. Repeated updates form a Gauss–Newton iteration on the goals; an interactive drag
moves the target a little each frame and makes one update per frame.

=========  ==============  ==========  ======================================================
symbol     code            shape       meaning
=========  ==============  ==========  ======================================================
A          ``A``           (m, p)      stacked goal rows of ∂S/∂u
δq         ``r``           (m,)        goal residuals (targets − current)
M          ``M``           (p, p)      SPD metric: which parameters are cheap to change
λ          ``damping``     scalar      damped-least-squares parameter (0: exact min-norm)
=========  ==============  ==========  ======================================================

Limiting cases: M = 𝟙 and λ = 0 give the pseudo-inverse step A⁺δq; a square invertible A gives
Newton's step A⁻¹δq; λ → ∞ gives the gradient direction Aᵀδq/λ².

Bad input: a goal time outside the simulated span, a target of the wrong size, a body that does not
exist, a metric M that is not symmetric positive definite — each a named error; a goal the iteration
cannot reach returns ``success=False`` with its residual. An edit reports success only when the trajectory
that meets the goals is certified (:mod:`pbanim.design.rest`: no state inside an obstacle; a ball that
comes to rest lies on the floor, so a target below the floor is unreachable and says so); a parameter
vector whose run has no certified value (:class:`~pbanim.design.UncertifiedTrajectory`: too many impacts,
a resting contact the model lacks) is a step refused, never an exception out of :func:`edit`.

References: Popović et al. SIGGRAPH 2000 §5 (differential update, interactive loop); C. W. Wampler,
"Manipulator inverse kinematic solutions based on vector formulations and damped least-squares
methods", IEEE SMC 1986; Nocedal & Wright, *Numerical Optimization*, §10.3 (Gauss–Newton).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..contracts import Array, Index, Int, Obj, Opt, Real, Seq, contract
from ..errors import InvalidInput, NonFiniteResult, check_result
from ..rigid import quat_conjugate, quat_multiply, quat_normalize
from .scene import DesignScene, UncertifiedTrajectory
from .simulate import quat_log, simulate
from .specs import ParameterNames, Quaternion, u_size

__all__ = ["Goal", "position_goal", "orientation_goal", "SingularMetric", "goal_system", "min_norm_update",
           "Update", "EditResult", "edit", "drag"]


class SingularMetric(InvalidInput):
    """The metric M of the update is not symmetric positive definite."""


@dataclass(frozen=True)
class Goal:
    """Body ``body`` at time ``time`` has ``kind`` ("position" or "orientation") equal to ``target``."""

    body: int
    time: float
    kind: str
    target: np.ndarray


@contract(body=Int(ge=0), time=Real(), target=Array((3,)))
def position_goal(body: int, time: float, target) -> Goal:
    """x_body(time) = target (3 numbers)."""
    return Goal(int(body), float(time), "position", np.array(target, dtype=float).reshape(3))


@contract(body=Int(ge=0), time=Real(), target=Quaternion())
def orientation_goal(body: int, time: float, target) -> Goal:
    """q_body(time) = target (a quaternion (w, x, y, z), normalized here)."""
    return Goal(int(body), float(time), "orientation", quat_normalize(np.array(target, dtype=float).reshape(4)))


def _check_goals(scene, goals, t0, t_end) -> list:
    goals = list(goals)
    if not goals or not all(isinstance(g, Goal) for g in goals):
        raise InvalidInput("goals must be a non-empty list of Goal (position_goal, orientation_goal)")
    for g in goals:
        if g.body >= scene.N:
            raise InvalidInput(f"goal body {g.body} does not exist; the scene has {scene.N} bodies")
        if not t0 <= g.time <= t_end:
            raise InvalidInput(f"goal time {g.time} lies outside the simulated span [{t0:g}, {t_end:g}]")
    return goals


_GOALS = Seq(Obj(Goal, what="a Goal (position_goal, orientation_goal)"), min_len=1)
_U = Opt(Array((u_size(),)))


@contract(scene=Obj(DesignScene), names=ParameterNames("scene"), u=_U, goals=_GOALS, t_end=Real(), h=Real(gt=0),
          t0=Real())
def goal_system(scene, names, u, goals, t_end, *, h: float = 0.005, t0: float = 0.0, **kw):
    """(r, A, trajectory): stacked residuals targets − S and their rows of ∂S/∂u at u."""
    goals = _check_goals(scene, goals, t0, t_end)
    tr = simulate(scene, t_end, names, u, times=sorted({g.time for g in goals}), h=h, t0=t0, **kw)
    r, A = [], []
    for g in goals:
        if g.kind == "position":
            r.append(g.target - tr.position(g.body, g.time))
            A.append(tr.d_position(g.body, g.time))
        else:
            r.append(quat_log(quat_multiply(g.target, quat_conjugate(tr.orientation(g.body, g.time)))))
            A.append(tr.d_orientation(g.body, g.time))
    return np.concatenate(r), np.vstack(A), tr


@dataclass
class Update:
    """One min-norm update: δu, the singular values of A C⁻ᵀ, the rank used and the damping."""

    du: np.ndarray
    sigma: np.ndarray
    rank: int
    damping: float
    rank_deficient: bool


@contract(A=Array(("m", "p")), r=Array(("m",)), M=Opt(Array(("p", "p"))), damping=Opt(Real(ge=0)),
          rcond=Real(gt=0, lt=1))
def min_norm_update(A, r, M=None, damping: float | None = None, rcond: float = 1e-9) -> Update:
    """δu = argmin δuᵀMδu subject to A δu = r (damped when A is rank-deficient or ``damping`` > 0).

    ``damping=None``: exact when A (in the metric) has full row rank, else damped with λ = √rcond·σ_max.

    >>> upd = min_norm_update(np.array([[1.0, 1.0]]), np.array([2.0]))
    >>> upd.du, upd.rank
    (array([1., 1.]), 1)
    """
    A, r = np.asarray(A, dtype=float), np.asarray(r, dtype=float)      # the contract checked shapes, finiteness
    p = A.shape[1]
    if M is None:
        C = np.eye(p)
    else:
        M = np.asarray(M, dtype=float)
        if not np.allclose(M, M.T, rtol=1e-10, atol=0):
            raise SingularMetric(f"min_norm_update: M must be symmetric, got asymmetry {np.abs(M - M.T).max():.3e}")
        try:
            C = np.linalg.cholesky(M)
        except np.linalg.LinAlgError:
            w = np.linalg.eigvalsh(M)
            raise SingularMetric(f"M must be positive definite (min eigenvalue {w.min():.3e}); a singular "
                                 "metric leaves some parameter changes free of cost") from None
        if np.linalg.cond(C) ** 2 > 1e14:
            raise SingularMetric(f"M is numerically singular (condition {np.linalg.cond(M):.3e})")
    with np.errstate(over="ignore", invalid="ignore"):
        B = np.linalg.solve(C, A.T).T                  # A C⁻ᵀ
        try:
            U, s, Vt = np.linalg.svd(check_result("min_norm_update: A C⁻ᵀ", B), full_matrices=False)
        except np.linalg.LinAlgError:
            raise NonFiniteResult("min_norm_update: the SVD of A C⁻ᵀ", "entries too large") from None
        smax = float(s[0]) if s.size else 0.0
        rank = int(np.sum(s > rcond * max(smax, 1e-300)))
        deficient = rank < min(A.shape[0], p) or smax == 0.0
        lam = (np.sqrt(rcond) * smax if deficient else 0.0) if damping is None else float(damping)
        if lam > 0:
            filt = s / (s * s + lam * lam)
        else:
            filt = np.where(s > rcond * max(smax, 1e-300), 1.0 / np.where(s > 0, s, 1.0), 0.0)
        z = Vt.T @ (filt * (U.T @ r))
        du = check_result("min_norm_update: δu", np.linalg.solve(C.T, z), "A, r or M too large for double precision")
    return Update(du, s, rank, float(lam), bool(deficient))


@dataclass
class EditResult:
    """Outcome of :func:`edit`: the parameters, whether every goal is met within ``tol``, and the history."""

    u: np.ndarray
    success: bool
    residual: float
    iterations: int
    message: str
    history: list = field(default_factory=list)       # (u, max |residual|) per iterate
    trajectory: object = None


@contract(scene=Obj(DesignScene), names=ParameterNames("scene"), u=_U, goals=_GOALS, t_end=Real(),
          M=Opt(Array((u_size(), u_size()))), tol=Real(gt=0), max_iter=Int(ge=1, le=10_000), damping=Opt(Real(ge=0)),
          h=Real(gt=0), max_halvings=Int(ge=0, le=60))
def edit(scene, names, u, goals, t_end, *, M=None, tol: float = 1e-6, max_iter: int = 20, damping=None,
         h: float = 0.005, max_halvings: int = 8, **kw) -> EditResult:
    """Repeat min-norm updates until every goal holds within ``tol`` (max-norm of the residual) on a
    certified trajectory.

    Each step is accepted when it lowers the residual, else halved (at most ``max_halvings`` times); a step
    whose run is refused (ε pushed out of [0, 1], an uncertified trajectory) counts as no decrease. A goal
    that cannot be met ends with ``success=False``, the residual and the reason — also when the start
    itself has no certified run (residual inf, the reason in ``message``).
    """
    u = np.array(scene.vector(names) if u is None else u, dtype=float).reshape(-1)
    try:
        r, A, tr = goal_system(scene, names, u, goals, t_end, h=h, **kw)
    except UncertifiedTrajectory as exc:
        return EditResult(u, False, np.inf, 0, f"the start has no certified run: {exc}", [(u.copy(), np.inf)], None)
    res = float(np.abs(r).max())
    hist = [(u.copy(), res)]
    for it in range(1, max_iter + 1):
        if res <= tol and tr.certified:
            return EditResult(u, True, res, it - 1, "goals met", hist, tr)
        du = min_norm_update(A, r, M, damping).du
        for _ in range(max_halvings + 1):
            try:
                cand = u + du
                r2, A2, tr2 = goal_system(scene, names, cand, goals, t_end, h=h, **kw)
                res2 = float(np.abs(r2).max()) if tr2.certified else np.inf
            except (InvalidInput, UncertifiedTrajectory):
                res2 = np.inf                  # e.g. ε pushed out of [0, 1], a run with no certified value
            if res2 < res:
                break
            du = 0.5 * du
        else:
            return EditResult(u, False, res, it, f"no step lowers the residual {res:.3e} (target unreachable "
                              "or S not smooth here)", hist, tr)
        u, r, A, tr, res = cand, r2, A2, tr2, res2
        hist.append((u.copy(), res))
    ok = res <= tol and tr.certified
    return EditResult(u, ok, res, max_iter, "goals met" if ok else f"residual {res:.3e} > tol {tol:.1e} after "
                      f"{max_iter} updates", hist, tr)


@contract(scene=Obj(DesignScene), names=ParameterNames("scene"), u=_U, body=Index("scene.N"), time=Real(),
          target=Array((3,)), t_end=Real(), frames=Int(ge=1, le=10_000), M=Opt(Array((u_size(), u_size()))),
          damping=Opt(Real(ge=0)), h=Real(gt=0))
def drag(scene, names, u, body: int, time: float, target, t_end, *, frames: int = 10, M=None, damping=None,
         h: float = 0.005, **kw) -> list:
    """The interactive loop: the mouse moves x_body(time) to ``target`` in ``frames`` equal moves, one
    min-norm update per frame (as the user drags); returns [(u, position reached)] per frame (frame 0:
    the start)."""
    u = np.array(scene.vector(names) if u is None else u, dtype=float).reshape(-1)
    end = position_goal(body, time, target).target
    r, A, tr = goal_system(scene, names, u, [position_goal(body, time, end)], t_end, h=h, **kw)
    start = x = tr.position(body, time)
    out = [(u.copy(), x.copy())]
    for k in range(1, frames + 1):
        u = u + min_norm_update(A, start + (end - start) * k / frames - x, M, damping).du
        r, A, tr = goal_system(scene, names, u, [position_goal(body, time, end)], t_end, h=h, **kw)
        x = tr.position(body, time)
        out.append((u.copy(), x.copy()))
    return out
