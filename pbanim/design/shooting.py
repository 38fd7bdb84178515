"""Motion sketching by single shooting, and what both shootings share (chapter 10, part of :mod:`pbanim.design`).

The deck's boundary value problem: find a motion that meets the goals and looks like the sketch,

    single shooting:    min_u  E[q(t)]   s.t.  C_goal[q(t)] = 0,   gap(s₀) ≥ 0,      q(t) = S(t, u),
    E = ½ Σ_j |x(t_j) − x̄_j|²   over the sketched points (t_j, x̄_j).

Single shooting has few unknowns (the initial state s₀ = (x, θ, v, ω) or any parameter selection u),
but the map u ↦ q(t) grows more nonlinear with every bounce: a small change of u early moves every later
impact (each saltation multiplies the sensitivity by about (1 + ε)g/|v⁻| · Δt), and a change of the
impact sequence bends E sharply. On long horizons with many bounces it crawls or stops at a wrong
bounce sequence; multiple shooting (:mod:`pbanim.design.multiple`) cuts the horizon where the sketch
says the impacts are and converges (ORACLES H8).

What both share, here: the *state unknowns* — (x, v) alone for a sphere with isotropic inertia when no
goal concerns its orientation (θ and ω then change nothing the problem sees: idle unknowns that leave
the KKT matrix singular), else (x, θ, v, ω), θ a rotation vector relative to a reference orientation,
q = exp(½θ) ⊗ q_ref —; the *clearance* constraints, linear in x (for a box: every vertex, through θ),

    gap_f(s) = n_j·(x + R(q) s_f − o_j) − r_f ≥ margin,   ∂gap/∂x = n_j,  ∂gap/∂θ = J_l(θ)ᵀ (R s_f × n_j),

which keep every iterate's states outside the planes (an iterate that starts inside a floor flies through
it: S is meaningless there); and the goal rows (positions, orientations as log(q ⊗ q̄*)).

==========  ==================  =======================================================
symbol      code                meaning
==========  ==================  =======================================================
s, u        ``u``, ``z``        a node state, the unknowns
E           ``objective``       sketch distance ½ Σ |x(t_j) − x̄_j|²  (m²)
C           ``violation``       max |goal and continuity residuals| (m, rad, m/s)
==========  ==================  =======================================================

Solved by SLSQP (scipy.optimize) with the analytic ∂S/∂u of :func:`pbanim.design.simulate`. ``success``
means all three: SLSQP converged (KKT conditions to ``ftol``), every constraint holds within ``tol``, and
the motion is certified (no recorded state inside an obstacle, :mod:`pbanim.design.rest`).

Limiting cases: without sketch points E = 0 and shooting is a root finder for the goals; one node is
single shooting.

References: J. Popović, S. M. Seitz, M. Erdmann, "Motion sketching for control of rigid-body simulations",
ACM TOG 22(4) 2003 (§4); Ascher, Mattheij & Russell 1995, §4.2 (single shooting and its instability);
D. Kraft, "A software package for sequential quadratic programming", DFVLR 1988 (SLSQP).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..collision import Sphere
from ..contracts import Array, Func, Int, Obj, Opt, Real, Seq, contract, finite_result
from ..errors import InvalidInput
from ..rigid import quat_conjugate, quat_exp, quat_multiply, quat_to_matrix
from .control import _GOALS, Goal, _check_goals
from .exact import exact_applies
from .impact import Features
from .scene import DesignScene, left_jacobian
from .simulate import quat_log, simulate
from .specs import ParameterNames, Quaternion, SketchPoints

__all__ = ["ShootingResult", "single_shooting", "sketch_objective", "state_names", "clearance", "record_step"]

FULL = ["x0", "theta0", "v0", "omega0"]
TRANSLATION = ["x0", "v0"]


@dataclass
class ShootingResult:
    """Outcome of a shooting solve.

    ``u``: the parameters (single) or the first node's state (multiple) in the order of ``names``;
    ``success``: converged *and* constraints within tol; ``history``: max |C| per SLSQP iterate;
    ``objectives``: E per iterate; ``simulations``: runs over the whole horizon (for multiple shooting
    one evaluation simulates every segment once: one horizon).
    """

    u: np.ndarray
    success: bool
    violation: float
    objective: float
    iterations: int
    simulations: int
    message: str
    history: list = field(default_factory=list)
    node_times: np.ndarray | None = None
    converged: bool = False
    objectives: list = field(default_factory=list)
    names: list = field(default_factory=list)
    impacts: int = 0


_SCENE = Obj(DesignScene)


@contract(points=SketchPoints(), tr_pos=Func())
def sketch_objective(points, tr_pos):
    """E = ½ Σ |x(t_j) − x̄_j|² for sketch points [(t_j, x̄_j)] and positions tr_pos(t)."""
    return 0.5 * sum(float(np.sum((tr_pos(t) - x) ** 2)) for t, x in points)


def _sketch(sketch, t0, t_end):
    pts = []
    for item in (sketch or []):
        if len(item) != 2:
            raise InvalidInput(f"sketch points must be (time, 3-vector) pairs, got {item!r}")
        t, x = item
        x = np.asarray(x, float).reshape(-1)
        if x.shape != (3,) or not np.all(np.isfinite(x)) or not t0 <= float(t) <= t_end:
            raise InvalidInput(f"sketch points must be (time in [{t0:g}, {t_end:g}], 3 finite numbers), got ({t}, {x})")
        pts.append((float(t), x))
    return pts


def _single_body(scene):
    if scene.N != 1:
        raise InvalidInput(f"shooting here designs one body's motion; the scene has {scene.N} bodies")


@contract(scene=_SCENE, goals=Seq(Obj(Goal)))
def state_names(scene, goals=()) -> list[str]:
    """The node state's parameter names: ``["x0", "v0"]`` for an isotropic sphere without orientation
    goals (its rotation is invisible to the problem), else ``["x0", "theta0", "v0", "omega0"]``."""
    b = scene.bodies[0]
    iso = isinstance(b.shape, Sphere) and np.ptp(b.inertia) <= 1e-12 * b.inertia[0]
    return TRANSLATION if iso and not any(g.kind == "orientation" for g in goals) else FULL


@contract(scene=_SCENE, x=Array((3,)), theta=Opt(Array((3,))), ref=Opt(Quaternion()), margin=Real(ge=0),
          returns=finite_result)
def clearance(scene, x, theta=None, ref=None, margin: float = 0.0):
    """(gap − margin (F,), ∂/∂x (F, 3), ∂/∂θ (F, 3)): every feature of body 0 against every plane, at
    position x and orientation exp(½θ) ⊗ ref (θ = 0, ref = the body's when not given)."""
    with np.errstate(all="ignore"):        # an overflow (|θ| ≈ 1e300) is named by the result's certificate
        return _clearance(scene, x, theta, ref, margin)


def _clearance(scene, x, theta, ref, margin):
    feat = Features(scene)
    b = scene.bodies[0]
    th = np.zeros(3) if theta is None else np.asarray(theta, float)
    q = quat_multiply(quat_exp(th), b.orientation if ref is None else ref)
    R = quat_to_matrix(q)
    sel = np.flatnonzero(feat.body == 0)
    n = np.array([p.normal for p in scene.planes]).reshape(-1, 3)[feat.plane[sel]]
    s_w = feat.off[sel] @ R.T
    g = np.einsum("fi,fi->f", n, x + s_w - feat.anchors[feat.plane[sel]]) - feat.rad[sel] - margin
    return g, n, np.cross(s_w, n) @ left_jacobian(th)


@contract(scene=_SCENE, names=ParameterNames("scene", empty=True), h=Real(gt=0), span=Real(gt=0))
def record_step(scene, names, h: float, span: float) -> float:
    """The grid step for runs whose recorded states nobody reads: the whole span when the flight is exact
    (the grid then only sets where states are recorded), else ``h`` (the RK4 step, which sets the accuracy)."""
    return max(h, span) if exact_applies(scene, names) else h


def _goal_rows(g, tr, body=0):
    if g.kind == "position":
        return tr.position(body, g.time) - g.target, tr.d_position(body, g.time)
    r = quat_log(quat_multiply(tr.orientation(body, g.time), quat_conjugate(g.target)))
    return r, np.linalg.solve(left_jacobian(r), tr.d_orientation(body, g.time))


def _slsqp(fun, jac, eq, eq_jac, ineq, ineq_jac, x0, maxiter, ftol, hist, objs):
    """scipy's SLSQP with equality and inequality constraints and a per-iterate record."""
    from scipy.optimize import minimize

    cons = [{"type": "eq", "fun": eq, "jac": eq_jac}]
    if ineq is not None:
        cons.append({"type": "ineq", "fun": ineq, "jac": ineq_jac})

    def cb(z):
        hist.append(float(np.abs(eq(z)).max()))
        objs.append(float(fun(z)))

    return minimize(fun, x0, jac=jac, method="SLSQP", constraints=cons, callback=cb,
                    options={"maxiter": int(maxiter), "ftol": float(ftol)})


_SHOOT = dict(h=Real(gt=0), maxiter=Int(ge=1, le=100_000), tol=Real(gt=0), ftol=Real(gt=0), margin=Real(ge=0))


@contract(scene=_SCENE, u0=Opt(Array((None,))), goals=_GOALS, t_end=Real(gt=0), names=Opt(ParameterNames("scene")),
          sketch=Opt(SketchPoints()), **_SHOOT)
def single_shooting(scene, u0, goals, t_end, *, names=None, sketch=None, h: float = 0.005, maxiter: int = 100,
                    tol: float = 1e-6, ftol: float = 1e-10, margin: float = 1e-4) -> ShootingResult:
    """Optimize u (default the body's initial state, :func:`state_names`; any parameter ``names``) so that
    the goals hold, the start clears the planes and the motion stays close to the sketch ``[(t, x̄), ...]``."""
    _single_body(scene)
    goals = _check_goals(scene, goals, 0.0, t_end)
    pts = _sketch(sketch, 0.0, t_end)
    names = scene.check_names(state_names(scene, goals) if names is None else names)
    sl = scene.slices(names)
    u0 = np.asarray(scene.vector(names) if u0 is None else u0, dtype=float).reshape(-1)
    if u0.size != sum(scene.size(k) for k in names):
        raise InvalidInput(f"single_shooting: u0 must hold {sum(scene.size(k) for k in names)} numbers for {names}, "
                           f"got {u0.size}")
    scene.values(names, u0)                                     # masses, moments, ε in range
    times = sorted({g.time for g in goals} | {t for t, _ in pts})
    cache, hist, objs, count = {}, [], [], [0]
    hh = record_step(scene, names, h, t_end)

    def run(u):
        key = u.tobytes()
        if key not in cache:
            count[0] += 1
            tr = simulate(scene, t_end, names, u, times=times, h=hh, warn=False, check_start=False)
            c, Jc = zip(*[_goal_rows(g, tr) for g in goals])
            E = sketch_objective(pts, lambda t: tr.position(0, t))
            dE = sum(((tr.position(0, t) - x) @ tr.d_position(0, t) for t, x in pts), np.zeros(u.size))
            cache.clear()
            cache[key] = (E, dE, np.concatenate(c), np.vstack(Jc), len(tr.impacts), tr.certified)
        return cache[key]

    ineq = ineq_jac = None
    if "x0" in sl:
        th = sl.get("theta0")

        def clear(u):
            return clearance(scene, u[sl["x0"]], None if th is None else u[th], margin=margin)

        ineq = lambda u: clear(u)[0]  # noqa: E731

        def ineq_jac(u):
            _, Jx, Jt = clear(u)
            J = np.zeros((Jx.shape[0], u.size))
            J[:, sl["x0"]] = Jx
            if th is not None:
                J[:, th] = Jt
            return J

    res = _slsqp(lambda u: run(u)[0], lambda u: run(u)[1], lambda u: run(u)[2], lambda u: run(u)[3], ineq,
                 ineq_jac, u0, maxiter, ftol, hist, objs)
    E, _, c, _, n_imp, certified = run(res.x)
    viol = float(np.abs(c).max())
    ok = bool(res.success and viol <= tol and certified)
    msg = "converged, goals met" if ok else (f"not converged: goals violated by {viol:.3e}, E = {E:.4g} after "
                                             f"{res.nit} iterations (SLSQP: {res.message})"
                                             + ("" if certified else "; the motion passes through an obstacle"))
    return ShootingResult(res.x, ok, viol, E, int(res.nit), count[0], msg, hist, None, bool(res.success), objs,
                          names, n_imp)
