"""Motion sketching: single and multiple shooting (chapter 10, part of :mod:`pbanim.design`).

The deck's boundary value problem: find a motion that meets the goals and looks like the sketch,

    single shooting:    min_u  E[q(t)]   s.t.  C_goal[q(t)] = 0,          q(t) = S(t, u),
    multiple shooting:  min_{s₀…s_K}  E   s.t.  C_goal = 0,  C_c(s_k, s_k₊₁) = S(t_k₊₁; t_k, s_k) ⊖ s_k₊₁ = 0,

with E = ½ Σ_j |x(t_j) − x̄_j|² over the sketched points and the node states s_k = (x, θ, v, ω) (θ a
rotation vector relative to the node's reference orientation; ⊖ compares orientations by log(q ⊗ q̄*)).
Single shooting has the few unknowns u but a map u ↦ q(T) that grows more nonlinear with every bounce:
a small change of u early moves every later impact, and a change of the impact sequence makes S jump.
Multiple shooting cuts the horizon into segments that each see at most one impact, starts from the
sketch (every node where the sketch says), and lets the continuity constraints — the physics — close the
gaps. A *sliding time grid* re-places the nodes between solves at the midpoints between successive
impacts, so the nodes follow the impacts and no segment boundary sits on one.

Both are solved by SLSQP (scipy.optimize) with the analytic ∂S/∂u of :func:`pbanim.design.simulate`;
continuity Jacobians: ∂C_c/∂s_k from the segment's sensitivities, ∂C_c/∂s_k₊₁ = −𝟙 (and
−J_l(r)⁻¹ R(Q) J_l(θ) for the orientation rows, r = log Q).

Limiting cases: one node is single shooting; with every node on the true motion the continuity
residuals vanish at the start.

References: J. Popović, S. M. Seitz, M. Erdmann, "Motion sketching for control of rigid-body simulations",
ACM TOG 22(4) 2003 (§4 single and multiple shooting, sliding time grid); Ascher, Mattheij & Russell 1995,
§4.3 (multiple shooting); Bock & Plitt 1984 (multiple shooting for optimal control).
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field

import numpy as np

from ..errors import InvalidInput, check_count, check_number
from ..rigid import quat_conjugate, quat_exp, quat_multiply, quat_to_matrix
from .control import _check_goals
from .scene import left_jacobian
from .simulate import quat_log, simulate

__all__ = ["ShootingResult", "single_shooting", "multiple_shooting", "sketch_objective"]

STATE = ["x0", "theta0", "v0", "omega0"]


@dataclass
class ShootingResult:
    """Outcome of a shooting solve: the body's initial state u = (x, θ, v, ω), success, the history of the
    constraint violation (max |C| per SLSQP iterate) and the number of simulations."""

    u: np.ndarray
    success: bool
    violation: float
    objective: float
    iterations: int
    simulations: int
    message: str
    history: list = field(default_factory=list)
    node_times: np.ndarray | None = None


def sketch_objective(points, tr_pos):
    """E = ½ Σ |x(t_j) − x̄_j|² for sketch points [(t_j, x̄_j)] and positions tr_pos(t)."""
    return 0.5 * sum(float(np.sum((tr_pos(t) - x) ** 2)) for t, x in points)


def _sketch(sketch, t0, t_end):
    pts = []
    for t, x in (sketch or []):
        x = np.asarray(x, float).reshape(-1)
        if x.shape != (3,) or not t0 <= float(t) <= t_end:
            raise InvalidInput(f"sketch points must be (time in [{t0:g}, {t_end:g}], 3-vector), got ({t}, {x})")
        pts.append((float(t), x))
    return pts


def _single_body(scene):
    if scene.N != 1:
        raise InvalidInput(f"shooting here designs one body's motion; the scene has {scene.N} bodies")


def _goal_rows(g, tr, J_orient):
    if g.kind == "position":
        return tr.position(0, g.time) - g.target, tr.d_position(0, g.time)
    r = quat_log(quat_multiply(tr.orientation(0, g.time), quat_conjugate(g.target)))
    return r, np.linalg.solve(left_jacobian(r), J_orient(g.time))


def single_shooting(scene, u0, goals, t_end, *, names=STATE, sketch=None, h: float = 0.005, maxiter: int = 100,
                    tol: float = 1e-6) -> ShootingResult:
    """Optimize u (default the body's initial state (x, θ, v, ω); any parameter ``names``) so that the goals
    hold and the motion stays close to the sketch (``[(t, x̄), ...]``); SLSQP with analytic gradients."""
    from scipy.optimize import minimize

    _single_body(scene)
    goals = _check_goals(scene, goals, 0.0, t_end)
    pts = _sketch(sketch, 0.0, t_end)
    times = sorted({g.time for g in goals} | {t for t, _ in pts})
    cache, hist, count = {}, [], [0]

    def run(u):
        key = u.tobytes()
        if key not in cache:
            count[0] += 1
            tr = simulate(scene, t_end, names, u, times=times, h=h, warn=False, check_start=False)
            c, Jc = zip(*[_goal_rows(g, tr, lambda t: tr.d_orientation(0, t)) for g in goals])
            E = sketch_objective(pts, lambda t: tr.position(0, t))
            dE = sum(((tr.position(0, t) - x) @ tr.d_position(0, t) for t, x in pts), np.zeros(u.size))
            cache.clear()
            cache[key] = (E, dE, np.concatenate(c), np.vstack(Jc))
        return cache[key]

    names = scene.check_names(names)
    u0 = np.asarray(scene.vector(names) if u0 is None else u0, dtype=float)
    res = minimize(lambda u: run(u)[0], u0, jac=lambda u: run(u)[1], method="SLSQP",
                   constraints=[{"type": "eq", "fun": lambda u: run(u)[2], "jac": lambda u: run(u)[3]}],
                   options={"maxiter": check_count("maxiter", maxiter), "ftol": 1e-12},
                   callback=lambda u: hist.append(float(np.abs(run(u)[2]).max())))
    E, _, c, _ = run(res.x)
    viol = float(np.abs(c).max())
    ok = bool(viol <= tol)
    return ShootingResult(res.x, ok, viol, E, int(res.nit), count[0],
                          ("goals met" if ok else f"goals violated by {viol:.3e} (SLSQP: {res.message})"), hist)


class _Segments:
    """The node states of multiple shooting and their segment simulations."""

    def __init__(self, scene, node_times, t_end, refs, h, times):
        self.scene, self.nodes, self.t_end, self.refs, self.h = scene, np.asarray(node_times), t_end, refs, h
        self.ends = np.append(self.nodes[1:], t_end)
        self.times = times
        self.count = 0

    def segment_scene(self, k):
        b = dataclasses.replace(self.scene.bodies[0], orientation=self.refs[k])
        new = object.__new__(type(self.scene))
        new.__dict__.update(self.scene.__dict__)
        new.bodies = [b]
        new.nominal = dict(self.scene.nominal)
        return new

    def simulate(self, z):
        K = len(self.nodes)
        trs = []
        for k in range(K):
            a, b = self.nodes[k], self.ends[k]
            ts = [t for t in self.times if a < t <= b] + [b]
            self.count += 1
            trs.append(simulate(self.segment_scene(k), b, STATE, z[12 * k:12 * k + 12], times=sorted(set(ts)),
                                t0=a, h=self.h, warn=False, check_start=False))
        return trs

    def segment_of(self, t):
        return int(min(np.searchsorted(self.nodes, t, side="left") - 1, len(self.nodes) - 1)) if t > self.nodes[0] else 0

    def quat(self, z, k):
        return quat_multiply(quat_exp(z[12 * k + 3:12 * k + 6]), self.refs[k])


def _continuity(seg, z, trs):
    K = len(seg.nodes)
    rows, J = [], np.zeros((12 * (K - 1), 12 * K))
    for k in range(K - 1):
        tr, t1 = trs[k], seg.ends[k]
        q_end, q_next = tr.orientation(0, t1), seg.quat(z, k + 1)
        Q = quat_multiply(q_end, quat_conjugate(q_next))
        r = quat_log(Q)
        v, w = tr.velocities(0, t1)
        rows.append(np.concatenate([tr.position(0, t1) - z[12 * k + 12:12 * k + 15], r,
                                    v - z[12 * k + 18:12 * k + 21], w - z[12 * k + 21:12 * k + 24]]))
        Jli = np.linalg.inv(left_jacobian(r))
        dv, dw = tr.d_velocities(0, t1)
        blk = slice(12 * k, 12 * k + 12)
        J[12 * k:12 * k + 3, blk] = tr.d_position(0, t1)
        J[12 * k + 3:12 * k + 6, blk] = Jli @ tr.d_orientation(0, t1)
        J[12 * k + 6:12 * k + 9, blk], J[12 * k + 9:12 * k + 12, blk] = dv, dw
        nxt = 12 * k + 12
        J[12 * k:12 * k + 3, nxt:nxt + 3] = -np.eye(3)
        J[12 * k + 3:12 * k + 6, nxt + 3:nxt + 6] = -Jli @ quat_to_matrix(Q) @ left_jacobian(z[nxt + 3:nxt + 6])
        J[12 * k + 6:12 * k + 9, nxt + 6:nxt + 9] = -np.eye(3)
        J[12 * k + 9:12 * k + 12, nxt + 9:nxt + 12] = -np.eye(3)
    return (np.concatenate(rows) if rows else np.zeros(0)), J


def _node_states(scene, trajs_or_states):
    """Node unknowns z and references from a list of (x, q, v, ω) states."""
    z, refs = [], []
    for x, q, v, w in trajs_or_states:
        z.append(np.concatenate([x, np.zeros(3), v, w]))
        refs.append(np.asarray(q, float))
    return np.concatenate(z), refs


def multiple_shooting(scene, goals, t_end, *, nodes: int = 4, initial_states=None, u0=None, sketch=None,
                      h: float = 0.005, maxiter: int = 100, tol: float = 1e-6, slide: bool = True,
                      max_slides: int = 3) -> ShootingResult:
    """Multiple shooting on ``nodes`` segments (sliding the nodes to the impacts between solves).

    ``initial_states``: one (x, q, v, ω) per node, e.g. read off the sketch; default: the states of the
    single-shooting guess ``u0`` (the body's initial state) at uniform node times. Returns the initial
    state u = (x, θ, v, ω) of the first node (θ relative to the scene body's orientation).
    """
    from scipy.optimize import minimize

    _single_body(scene)
    goals = _check_goals(scene, goals, 0.0, t_end)
    pts = _sketch(sketch, 0.0, t_end)
    nodes = check_count("nodes", nodes)
    tol = check_number("tol", tol, low=0.0, low_open=True)
    times = sorted({g.time for g in goals} | {t for t, _ in pts})
    node_times = np.linspace(0.0, t_end, nodes + 1)[:-1]
    if initial_states is None:
        tr = simulate(scene, t_end, STATE, u0, times=list(node_times), h=h, warn=False, sensitivities=False)
        initial_states = [(tr.position(0, t), tr.orientation(0, t), *tr.velocities(0, t)) for t in node_times]
    elif len(initial_states) != nodes:
        raise InvalidInput(f"initial_states must hold one (x, q, v, ω) per node ({nodes}), got {len(initial_states)}")
    z, refs = _node_states(scene, initial_states)
    hist, total_sims, total_it = [], 0, 0
    for outer in range(max_slides + 1):
        seg = _Segments(scene, node_times, t_end, refs, h, times)
        cache = {}

        def run(zz):
            key = zz.tobytes()
            if key not in cache:
                trs = seg.simulate(zz)
                c, Jc = _continuity(seg, zz, trs)
                K = len(seg.nodes)
                gc, gJ = [], []
                for g in goals:
                    k = seg.segment_of(g.time)
                    r, Jg = _goal_rows(g, trs[k], lambda t: trs[k].d_orientation(0, t))
                    row = np.zeros((3, 12 * K))
                    row[:, 12 * k:12 * k + 12] = Jg
                    gc.append(r), gJ.append(row)
                E, dE = 0.0, np.zeros(zz.size)
                for t, x in pts:
                    k = seg.segment_of(t)
                    d = trs[k].position(0, t) - x
                    E += 0.5 * float(d @ d)
                    dE[12 * k:12 * k + 12] += d @ trs[k].d_position(0, t)
                cache.clear()
                cache[key] = (E, dE, np.concatenate([c, *gc]), np.vstack([Jc, *gJ]), trs)
            return cache[key]

        res = minimize(lambda zz: run(zz)[0], z, jac=lambda zz: run(zz)[1], method="SLSQP",
                       constraints=[{"type": "eq", "fun": lambda zz: run(zz)[2], "jac": lambda zz: run(zz)[3]}],
                       options={"maxiter": check_count("maxiter", maxiter), "ftol": 1e-12},
                       callback=lambda zz: hist.append(float(np.abs(run(zz)[2]).max())))
        z = res.x
        E, _, c, _, trs = run(z)
        total_sims += seg.count
        total_it += int(res.nit)
        viol = float(np.abs(c).max())
        impacts = sorted(i.t for tr in trs for i in tr.impacts)
        if not slide or outer == max_slides or len(impacts) < 2:
            break
        new_times = np.array([0.0] + [0.5 * (a + b) for a, b in zip(impacts[:-1], impacts[1:])])
        if len(new_times) == len(node_times) and np.abs(new_times - node_times).max() < 1e-3 and viol <= tol:
            break
        # slide: every node to the midpoint between two impacts; new node states read off the segments
        states = []
        for t in new_times:
            k = seg.segment_of(t)
            tk = simulate(seg.segment_scene(k), seg.ends[k], STATE, z[12 * k:12 * k + 12], t0=seg.nodes[k],
                          times=[t], h=h, sensitivities=False, warn=False, check_start=False)
            states.append((tk.position(0, t), tk.orientation(0, t), *tk.velocities(0, t)))
        node_times = new_times
        z, refs = _node_states(scene, states)
    q0 = seg.quat(z, 0)
    theta0 = quat_log(quat_multiply(q0, quat_conjugate(scene.bodies[0].orientation)))
    u = np.concatenate([z[:3], theta0, z[6:12]])
    ok = bool(viol <= tol)
    return ShootingResult(u, ok, viol, E, total_it, total_sims,
                          "goals and continuity met" if ok else f"constraints violated by {viol:.3e} "
                          f"(SLSQP: {res.message})", hist, np.asarray(node_times))
