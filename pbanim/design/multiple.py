"""Motion sketching by multiple shooting on a sliding time grid (chapter 10, part of :mod:`pbanim.design`).

The node states s₀ … s_{K−1} at times t₀ = 0 < t₁ < … < t_{K−1} are the unknowns, and the physics
becomes constraints — each segment, simulated from its node, must arrive at the next node:

    min_{s₀…s_{K−1}}  E    s.t.   C_goal = 0,   C_k = S(t_{k+1}; t_k, s_k) ⊖ s_{k+1} = 0,   gap(s_k) ≥ margin,

(⊖: differences of x and v, and of θ by log(q ⊗ q̄*), ω when the state has them, see
:func:`pbanim.design.shooting.state_names`). ∂C_k/∂s_k is the segment's ∂S/∂u; ∂C_k/∂s_{k+1} = −𝟙
(−J_l(r)⁻¹ R(Q) J_l(θ) on the orientation rows, r = log Q). The clearance rows keep every node outside
the planes (linear in x, so SLSQP's iterates satisfy them exactly).

Why it converges where single shooting does not: every segment sees at most one impact, so each C_k is
only mildly nonlinear in s_k; the start is the sketch itself (node positions and velocities fitted to
the sketched points around each node, with the known gravity: :func:`states_from_sketch`), so E is small
from the first iterate and only the continuity gaps have to close. The *sliding time grid* keeps it so:
the nodes start midway between the impacts the sketch shows (its local minima of clearance,
:func:`nodes_from_sketch`), and after each solve they slide to the midpoints between the impacts of the
solution, with the node states read off the segments — a node never sits on an impact.

==========  ===================  =======================================================
symbol      code                 meaning
==========  ===================  =======================================================
t_k         ``node_times``       node times (K,), t₀ = 0
s_k         ``z[d k : d k + d]`` node state, d = 6 (x, v) or 12 (x, θ, v, ω)
C_k         ``_continuity``      arrival mismatch of segment k (d,)
==========  ===================  =======================================================

Limiting cases: K = 1 is single shooting; nodes on the true motion give C_k = 0 at the start.

References: J. Popović, S. M. Seitz, M. Erdmann, "Motion sketching for control of rigid-body
simulations", ACM TOG 22(4) 2003 (§4.2 multiple shooting, §4.3 the sliding time grid); H. G. Bock &
K. J. Plitt, "A multiple shooting algorithm for direct solution of optimal control problems", IFAC 1984;
Ascher, Mattheij & Russell 1995, §4.3.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from ..contracts import Array, Flag, Int, Obj, Opt, Real, Seq, contract
from ..errors import InvalidInput, check_result
from ..rigid import quat_conjugate, quat_exp, quat_multiply, quat_to_matrix
from .control import _GOALS, _check_goals
from .scene import left_jacobian
from .shooting import (_SCENE, _SHOOT, ShootingResult, _goal_rows, _single_body, _sketch, _slsqp, clearance, record_step,
                       state_names)
from .specs import SketchPoints
from .simulate import quat_log, simulate

__all__ = ["multiple_shooting", "sketch_impacts", "nodes_from_sketch", "states_from_sketch", "refine_states"]


_TIMES = Array((None,))


@contract(scene=_SCENE, sketch=SketchPoints())
def sketch_impacts(scene, sketch) -> np.ndarray:
    """Times of the impacts a sketch shows: its points of locally least clearance against the planes."""
    pts = sorted(_sketch(sketch, -np.inf, np.inf), key=lambda p: p[0])
    if len(pts) < 3:
        raise InvalidInput(f"need at least 3 sketch points to see its impacts, got {len(pts)}")
    ts = np.array([t for t, _ in pts])
    gap = np.array([clearance(scene, x)[0].min() for _, x in pts])
    return ts[[i for i in range(1, len(pts) - 1) if gap[i] < gap[i - 1] and gap[i] <= gap[i + 1]]]


@contract(scene=_SCENE, sketch=SketchPoints(), t_end=Real(gt=0))
def nodes_from_sketch(scene, sketch, t_end: float) -> np.ndarray:
    """Node times: 0 and the midpoints between successive impacts the sketch shows (:func:`sketch_impacts`)."""
    _sketch(sketch, 0.0, t_end)
    hits = sketch_impacts(scene, sketch)
    return np.concatenate([[0.0], 0.5 * (hits[:-1] + hits[1:])])


@contract(scene=_SCENE, sketch=SketchPoints(), node_times=_TIMES, window=Real(gt=0),
          impacts=Opt(Array((None,), empty=True)))
def states_from_sketch(scene, sketch, node_times, window: float, impacts=None):
    """(x, v) at each node time: least-squares fit of x(t) = x_k + v_k (t − t_k) + ½ g (t − t_k)² (gravity
    known) to the sketch points within ``window`` of t_k that lie in the same flight (strictly between the
    sketch's impacts around t_k, default :func:`sketch_impacts`); the two nearest points if fewer."""
    pts = _sketch(sketch, -np.inf, np.inf)
    window = float(window)
    ts, X = np.array([t for t, _ in pts]), np.array([x for _, x in pts])
    if len(ts) < 2:
        raise InvalidInput(f"need at least 2 sketch points to fit node states, got {len(ts)}")
    hits = (sketch_impacts(scene, pts) if len(ts) >= 3 else np.zeros(0)) if impacts is None else \
        np.asarray(impacts, dtype=float).reshape(-1)
    out = []
    for tk in np.asarray(node_times, dtype=float).reshape(-1):
        lo = hits[hits <= tk].max(initial=-np.inf)
        hi = hits[hits > tk].min(initial=np.inf)
        near = np.flatnonzero((np.abs(ts - tk) <= window) & (ts > lo) & (ts < hi))
        if near.size < 2:
            inside = np.flatnonzero((ts > lo) & (ts < hi))
            pool = inside if inside.size >= 2 else np.arange(len(ts))
            near = pool[np.argsort(np.abs(ts[pool] - tk))[:2]]
        dt = ts[near] - tk
        A = np.stack([np.ones_like(dt), dt], axis=1)
        with np.errstate(all="ignore"):
            try:
                coef = np.linalg.lstsq(A, X[near] - 0.5 * dt[:, None] ** 2 * scene.gravity, rcond=None)[0]
            except np.linalg.LinAlgError:
                coef = np.full((2, 3), np.nan)          # named just below
        out.append(tuple(check_result(f"states_from_sketch: the fit at node time {tk:g}", coef[:2], "the node lies "
                                      "too far from the sketch for double precision")))
    return out


@contract(scene=_SCENE, sketch=SketchPoints(), node_times=_TIMES, states=Seq(Seq(Array((3,)), min_len=2, max_len=2)),
          t_end=Real(gt=0), h=Real(gt=0), max_nfev=Int(ge=1, le=10_000))
def refine_states(scene, sketch, node_times, states, t_end: float, *, h: float = 0.005, max_nfev: int = 20):
    """Each node's (x, v) refit by simulation: least squares (scipy ``least_squares``, analytic Jacobian)
    of the run from t_k over the sketch points up to the node after next, so the fit sees the impacts
    (a parabola through a few noisy points of a short flight can miss a wall the sketch clearly hits)."""
    from scipy.optimize import least_squares

    pts = _sketch(sketch, 0.0, t_end)
    nt = np.append(np.asarray(node_times, dtype=float).reshape(-1), t_end)
    out = []
    for k, (x, v) in enumerate(states):
        a, b = nt[k], nt[min(k + 2, len(nt) - 1)]
        sel = [(t, p) for t, p in pts if a < t <= b]
        if 3 * len(sel) < 6:
            out.append((x, v))
            continue
        ts = [t for t, _ in sel]
        P = np.concatenate([p for _, p in sel])
        hh, cache = record_step(scene, ["x0", "v0"], h, b - a), {}

        def run(s):
            if s.tobytes() not in cache:
                tr = simulate(scene, b, ["x0", "v0"], s, t0=a, times=ts, h=hh, warn=False, check_start=False)
                cache.clear()
                cache[s.tobytes()] = (np.concatenate([tr.position(0, t) for t in ts]) - P,
                                      np.vstack([tr.d_position(0, t) for t in ts]))
            return cache[s.tobytes()]

        res = least_squares(lambda s: run(s)[0], np.concatenate([x, v]), jac=lambda s: run(s)[1],
                            max_nfev=max_nfev)
        g = clearance(scene, res.x[:3])[0]
        out.append((res.x[:3], res.x[3:]) if np.all(g >= 0) else (x, v))
    return out


class _Segments:
    """The node states of multiple shooting and their segment simulations."""

    def __init__(self, scene, node_times, t_end, refs, h, times, names):
        self.scene, self.nodes, self.t_end, self.refs, self.h = scene, np.asarray(node_times), t_end, refs, h
        self.ends = np.append(self.nodes[1:], t_end)
        self.times, self.names = times, names
        self.d = 6 if len(names) == 2 else 12
        self.count = 0
        self.scenes = [self._scene(q) for q in refs]

    def _scene(self, ref):
        """The scene with the body's reference orientation ``ref`` (θ of a node is relative to it)."""
        new = object.__new__(type(self.scene))
        new.__dict__.update(self.scene.__dict__)
        new.bodies = [dataclasses.replace(self.scene.bodies[0], orientation=ref)]
        new.nominal = dict(self.scene.nominal)
        return new

    def simulate(self, z, k, sensitivities=True, times=None):
        a, b, d = self.nodes[k], self.ends[k], self.d
        if times is None:
            times = [t for t in self.times if (a < t or k == 0) and t <= b]
        return simulate(self.scenes[k], b, self.names, z[d * k:d * k + d], times=sorted(set(times) | {b}),
                        t0=a, h=record_step(self.scene, self.names, self.h, b - a), warn=False, check_start=False,
                        sensitivities=sensitivities)

    def segment_of(self, t):
        return int(np.clip(np.searchsorted(self.nodes, t, side="left") - 1, 0, len(self.nodes) - 1))

    def quat(self, z, k):
        return quat_multiply(quat_exp(z[12 * k + 3:12 * k + 6]), self.refs[k])

    def state_at(self, z, t):
        """(x, v) or (x, q, v, ω) at time t, read off the segment through t."""
        tr = self.simulate(z, self.segment_of(t), sensitivities=False, times=[t])
        v, w = tr.velocities(0, t)
        return (tr.position(0, t), v) if self.d == 6 else (tr.position(0, t), tr.orientation(0, t), v, w)


def _continuity(seg, z, trs):
    K, d = len(seg.nodes), seg.d
    rows, J = [], np.zeros((d * (K - 1), d * K))
    for k in range(K - 1):
        tr, t1, nxt, r0 = trs[k], seg.ends[k], d * k + d, d * k
        dv, dw = tr.d_velocities(0, t1)
        blk = slice(d * k, d * k + d)
        J[r0:r0 + 3, blk] = tr.d_position(0, t1)
        J[r0:r0 + d, nxt:nxt + d] = -np.eye(d)
        v, w = tr.velocities(0, t1)
        if d == 6:
            rows.append(np.concatenate([tr.position(0, t1), v]) - z[nxt:nxt + 6])
            J[r0 + 3:r0 + 6, blk] = dv
            continue
        Q = quat_multiply(tr.orientation(0, t1), quat_conjugate(seg.quat(z, k + 1)))
        r = quat_log(Q)
        rows.append(np.concatenate([tr.position(0, t1) - z[nxt:nxt + 3], r, v - z[nxt + 6:nxt + 9],
                                    w - z[nxt + 9:nxt + 12]]))
        Jli = np.linalg.inv(left_jacobian(r))
        J[r0 + 3:r0 + 6, blk] = Jli @ tr.d_orientation(0, t1)
        J[r0 + 6:r0 + 9, blk], J[r0 + 9:r0 + 12, blk] = dv, dw
        J[r0 + 3:r0 + 6, nxt + 3:nxt + 6] = -Jli @ quat_to_matrix(Q) @ left_jacobian(z[nxt + 3:nxt + 6])
    return (np.concatenate(rows) if rows else np.zeros(0)), J


def _unknowns(states, d):
    """Node unknowns z and reference orientations from (x, v) or (x, q, v, ω) tuples."""
    z, refs = [], []
    for s in states:
        if d == 6:
            x, v = s[0], s[-1] if len(s) == 2 else s[2]
            z.append(np.concatenate([x, v]))
            refs.append(np.array([1.0, 0, 0, 0]))
        else:
            if len(s) != 4:
                raise InvalidInput("node states need (x, q, v, ω) when orientations are unknowns")
            z.append(np.concatenate([s[0], np.zeros(3), s[2], s[3]]))
            refs.append(np.asarray(s[1], float))
    return np.concatenate(z), refs


@contract(scene=_SCENE, goals=_GOALS, t_end=Real(gt=0), node_times=Opt(_TIMES),
          initial_states=Opt(Seq(Seq(Array((None,)), min_len=2, max_len=4), min_len=1)), u0=Opt(Array((None,))),
          sketch=Opt(SketchPoints()), nodes=Int(ge=1, le=1000), slide=Flag(), max_slides=Int(ge=0, le=100),
          window=Real(gt=0), **_SHOOT)
def multiple_shooting(scene, goals, t_end, *, node_times=None, initial_states=None, u0=None, sketch=None,
                      nodes: int = 4, h: float = 0.005, maxiter: int = 100, tol: float = 1e-6, ftol: float = 1e-10,
                      margin: float = 1e-4, slide: bool = True, max_slides: int = 3, window: float = 0.15):
    """Multiple shooting (see the module docstring); returns a :class:`ShootingResult` whose ``u`` is the
    first node's state in the order of ``names`` (θ relative to the scene body's orientation).

    Start: ``initial_states`` (one (x, v) or (x, q, v, ω) per node) at ``node_times``; else, with a sketch,
    nodes from :func:`nodes_from_sketch` and states from :func:`states_from_sketch`; else the states of the
    single-shooting guess ``u0`` at ``nodes`` uniform node times.
    """
    _single_body(scene)
    goals = _check_goals(scene, goals, 0.0, t_end)
    pts = _sketch(sketch, 0.0, t_end)
    names = state_names(scene, goals)
    d = 6 if len(names) == 2 else 12
    times = sorted({g.time for g in goals} | {t for t, _ in pts})
    if node_times is None:
        node_times = nodes_from_sketch(scene, pts, t_end) if pts and initial_states is None else \
            np.linspace(0.0, t_end, int(nodes) + 1)[:-1]
    node_times = np.asarray(node_times, dtype=float).reshape(-1)
    if node_times[0] != 0.0 or np.any(np.diff(node_times) <= 0) or node_times[-1] >= t_end:
        raise InvalidInput(f"node_times must start at 0 and increase below t_end = {t_end}, got {node_times}")
    if initial_states is None:
        if pts:
            initial_states = states_from_sketch(scene, pts, node_times, window)
            if d == 6:
                initial_states = refine_states(scene, pts, node_times, initial_states, t_end, h=h)
        else:
            tr = simulate(scene, t_end, names, u0, times=list(node_times), h=h, warn=False, sensitivities=False)
            initial_states = [(tr.position(0, t), tr.orientation(0, t), *tr.velocities(0, t)) for t in node_times]
    if len(initial_states) != len(node_times):
        raise InvalidInput(f"initial_states must hold one state per node ({len(node_times)}), got {len(initial_states)}")
    z, refs = _unknowns(initial_states, d)
    hist, objs, total_sims, total_it = [], [], 0, 0
    for outer in range(max_slides + 1):
        seg = _Segments(scene, node_times, t_end, refs, h, times, names)
        K, cache = len(node_times), {}

        def run(zz):
            key = zz.tobytes()
            if key not in cache:
                trs = [seg.simulate(zz, k) for k in range(K)]
                seg.count += 1
                c, Jc = _continuity(seg, zz, trs)
                gc, gJ = [], []
                for g in goals:
                    k = seg.segment_of(g.time)
                    r, Jg = _goal_rows(g, trs[k])
                    row = np.zeros((3, d * K))
                    row[:, d * k:d * k + d] = Jg
                    gc.append(r), gJ.append(row)
                E, dE = 0.0, np.zeros(zz.size)
                for t, x in pts:
                    k = seg.segment_of(t)
                    dx = trs[k].position(0, t) - x
                    E += 0.5 * float(dx @ dx)
                    dE[d * k:d * k + d] += dx @ trs[k].d_position(0, t)
                cache.clear()
                cache[key] = (E, dE, np.concatenate([c, *gc]), np.vstack([Jc, *gJ]), trs)
            return cache[key]

        def clear(zz):
            rows = []
            for k in range(K):
                th = zz[d * k + 3:d * k + 6] if d == 12 else None
                rows.append(clearance(scene, zz[d * k:d * k + 3], th, refs[k], margin))
            return rows

        def clear_jac(zz):
            rows = clear(zz)
            J = np.zeros((sum(len(r[0]) for r in rows), zz.size))
            i = 0
            for k, (g, Jx, Jt) in enumerate(rows):
                J[i:i + len(g), d * k:d * k + 3] = Jx
                if d == 12:
                    J[i:i + len(g), d * k + 3:d * k + 6] = Jt
                i += len(g)
            return J

        res = _slsqp(lambda zz: run(zz)[0], lambda zz: run(zz)[1], lambda zz: run(zz)[2], lambda zz: run(zz)[3],
                     lambda zz: np.concatenate([r[0] for r in clear(zz)]), clear_jac, z, maxiter, ftol, hist, objs)
        z = res.x
        E, _, c, _, trs = run(z)
        total_sims += seg.count
        total_it += int(res.nit)
        viol = float(np.abs(c).max())
        impacts = sorted(i.t for tr in trs for i in tr.impacts)
        new_times = np.concatenate([[0.0], 0.5 * (np.array(impacts[:-1]) + np.array(impacts[1:]))])
        settled = len(new_times) == K and np.abs(new_times - node_times).max() < 0.25 * h + 1e-3
        if not slide or outer == max_slides or len(impacts) < 2 or not res.success or (settled and viol <= tol):
            break                 # slide only from a converged (physical) motion
        # slide: every node to a midpoint between two impacts; its state read off the segment through it
        states = [seg.state_at(z, t) for t in new_times]
        node_times = new_times
        z, refs = _unknowns(states, d)
    u = z[:d].copy()
    if d == 12:
        u[3:6] = quat_log(quat_multiply(seg.quat(z, 0), quat_conjugate(scene.bodies[0].orientation)))
    certified = all(tr.certified for tr in trs)
    ok = bool(res.success and viol <= tol and certified)
    msg = "converged: goals and continuity met" if ok else (f"not converged: constraints violated by {viol:.3e} "
                                                             f"(SLSQP: {res.message})"
                                                             + ("" if certified else "; a segment passes through an "
                                                                "obstacle"))
    return ShootingResult(u, ok, viol, E, total_it, total_sims, msg, hist, np.asarray(node_times), bool(res.success),
                          objs, names, len(impacts))
