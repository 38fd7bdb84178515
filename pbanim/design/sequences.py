"""The discrete search over impact sequences (chapter 10, issue 30 point 3; part of :mod:`pbanim.design`).

Multiple shooting on a sliding grid (:mod:`pbanim.design.multiple`) takes the impact sequence the sketch
shows and keeps it: its nodes sit midway between the sketch's impacts and its node states are fitted to
the sketch points of one flight. When bounces come closer than about three sketch samples the sketch no
longer shows them one by one (two bounces between two samples, a flight with no sample inside) and the
sequence it starts from is wrong; no continuous iteration repairs a wrong sequence. Here the sequence is
a discrete unknown:

    σ = ((j₁, τ̂₁), …, (j_K, τ̂_K))     (the plane each impact of body 0 hits, in order, with a time guess),

and the search proposes sequences, solves the continuous problem with σ fixed, and keeps the best:

1. **proposals from the sketch** — for every plane j the sketched gap g_j(t_i) = n_j·x̄_i − n_j·o_j − r,
   an impact where it has a local minimum near the plane (below ``reach``, the distance the sketch moves
   along n_j in ``reach_samples`` samples, a median) or where its rate n_j·ẋ̄ turns from approaching to
   receding (a velocity reversal), merged in time order; a caller may give its own proposals;
2. **moves** — insert an impact on any plane between two impacts (or at either end), delete one, replace
   one's plane, swap the planes of two neighbours, tried nearest the sketch point the best candidate misses
   most: a local search that accepts the first improving move. A sequence that hits a plane twice in a row
   where gravity does not pull toward it (n_j·g ≥ 0) is impossible and never solved; a proposal like that
   is repaired (its possible neighbours nearest the fault are proposed instead);
3. **the continuous problem with σ fixed** — multiple shooting whose nodes *are* the impacts: flight k
   starts at τ_k (τ₀ = 0) from the state (a_k, b_k) just after the impact, x(t) = a_k + b_k s + ½ g s²,
   s = t − τ_k, and the unknowns (τ_k, a_k, b_k) obey

       a_{k−1} + b_{k−1}Δ + ½ gΔ² = a_k,   R_j (b_{k−1} + gΔ) = b_k,   n_j·a_k − n_j·o_j − r = 0,
       R_j = 𝟙 − (1 + ε) n_j n_jᵀ,  Δ = τ_k − τ_{k−1},  n_j·(b_{k−1} + gΔ) ≤ −v_min  (an approach),

   with the goals as equalities and E = ½ Σ |x(t_i) − x̄_i|² minimized (SLSQP, analytic Jacobians; the
   nodes slide with the impacts because the impact times are unknowns);
4. **the score** — every candidate is replayed by :func:`pbanim.design.simulate` (the exact flight,
   independent of the closed forms above) from its (a₀, b₀): its sequence is the one the replay shows (a
   different one is proposed next), its residual the replay's E plus the goal residual; ``success`` only
   when the replay shows the proposed sequence, the goals hold and SLSQP converged.

The number of continuous solves is capped before the search starts (``max_proposals``); the report
lists every sequence tried, its residual and whether the replay confirmed it.

==========  ===================  ==============================================================
symbol      code                 meaning
==========  ===================  ==============================================================
σ           ``Sequence.planes``  the planes hit, in order (body 0; several bodies: ``BodySequence``)
τ_k         ``Sequence.times``   impact times (guesses in a proposal, solved in a result)
a_k, b_k    ``z`` blocks         position at τ_k and velocity just after impact k (m, m/s)
E           ``objective``        sketch distance of the replayed motion (m²)
==========  ===================  ==============================================================

The search stops at a success whose RMS distance to the sketch is at most ``accept_rms``, at a local
minimum of the residual over the moves, or at the cap.

Limiting cases: K = 0 is single shooting of one parabola; a sketch with three or more samples per flight
gives the true sequence as its first proposal (ORACLES L4).

Scope: one sphere with isotropic inertia on static planes (the exact flight applies, frictionless
impacts). Several spheres, with impacts between them (which bodies, which surfaces, in which order):
:mod:`pbanim.design.body_sequences`, on the same search loop (:func:`_search_loop`).

References: J. Popović, S. M. Seitz, M. Erdmann, "Motion sketching for control of rigid-body
simulations", ACM TOG 22(4) 2003 (§4, and §7: the discrete structure of the impact sequence left open);
H. G. Bock & K. J. Plitt 1984 (multiple shooting); M. Posa, C. Cantu, R. Tedrake, "A direct method for
trajectory optimization of rigid bodies through contact", IJRR 2014 (impact times as unknowns).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..collision import Sphere
from ..contracts import Array, Int, Obj, Opt, Real, Seq, Text, contract
from ..errors import InvalidInput, PbanimError
from .control import _GOALS, _check_goals
from .scene import DesignScene
from .shooting import _sketch, _slsqp
from .sequence_flights import Flights, planes_of
from .specs import SketchPoints

__all__ = ["Sequence", "SequenceSearch", "propose_sequences", "solve_sequence", "search_sequences"]


@contract(planes=Seq(Int(ge=0)), times=Array((None,), empty=True), origin=Text())
@dataclass
class Sequence:
    """An impact sequence of body 0: ``planes[k]`` is hit at (about) ``times[k]``; ``origin`` says where it
    came from (``sketch``, ``reversals``, ``insert``, ``delete``, ``swap``)."""

    planes: tuple
    times: np.ndarray
    origin: str = "sketch"

    def __post_init__(self) -> None:
        self.planes, self.times = tuple(int(j) for j in self.planes), np.asarray(self.times, float).reshape(-1)
        if len(self.planes) != self.times.size:
            raise InvalidInput(f"Sequence: one time per impact, got {len(self.planes)} planes and "
                               f"{self.times.size} times")

    def key(self) -> tuple:
        """The planes as a tuple of ints (what a replay's sequence is compared with)."""
        return self.planes


@dataclass
class SequenceSearch:           # a record pbanim builds (search_sequences, solve_sequence) and users read
    """The outcome of :func:`search_sequences` (or of one :func:`solve_sequence`).

    ``u``: (x₀, v₀) of the best candidate; ``sequence``: its planes as the replay shows them; ``times``: its
    impact times; ``success``: the replay shows the proposed sequence, the goals hold within ``tol`` and
    SLSQP converged; ``objective``: the replay's E; ``errors``: its distance to each sketch point (m); ``violation``: max goal residual of the replay;
    ``tried``: one row per continuous solve (planes, origin, residual, confirmed, message), in order;
    ``proposals``: how many solves ran (≤ the cap given)."""

    u: np.ndarray
    sequence: tuple
    times: np.ndarray
    success: bool
    objective: float
    violation: float
    residual: float
    message: str
    tried: list = field(default_factory=list)
    proposals: int = 0
    cap: int = 0
    errors: np.ndarray = field(default_factory=lambda: np.zeros(0))


_SCENE = Obj(DesignScene)


def _check_scene(scene):
    if scene.N != 1 or not isinstance(scene.bodies[0].shape, Sphere) or not scene.planes:
        raise InvalidInput("the sequence search designs one sphere's flight among planes: the scene must hold one "
                           f"Sphere and at least one plane, got {scene.N} bodies and {len(scene.planes)} planes")


@contract(scene=_SCENE, sketch=SketchPoints(), reach_samples=Real(gt=0))
def propose_sequences(scene, sketch, reach_samples: float = 1.5) -> list:
    """The sequences the sketch shows: local minima of each plane's gap within reach of the plane, and the
    reversals of the normal velocity (approach → recede); at most two proposals, duplicates dropped."""
    _check_scene(scene)
    pts = sorted(_sketch(sketch, -np.inf, np.inf), key=lambda p: p[0])
    if len(pts) < 3:
        raise InvalidInput(f"need at least 3 sketch points to see impacts, got {len(pts)}")
    ts, X = np.array([t for t, _ in pts]), np.array([x for _, x in pts])
    n, off = planes_of(scene)
    G = X @ n.T - off                                       # (samples, planes) sketched gaps
    minima, reversals = [], []
    for j in range(len(off)):
        lo, rev = _gap_touches(ts, G[:, j], reach_samples)
        minima += [(t, j) for t in lo]
        reversals += [(t, j) for t in rev]
    return _two_proposals(minima, reversals, Sequence)


def _two_proposals(minima, reversals, make):
    """The proposals of the touches [(time, surface)]: the minima's, then the reversals' (if another), each
    ``make(surfaces in time order, times, origin)``."""
    out = []
    for origin, hits in (("sketch", minima), ("reversals", reversals)):
        hits.sort()
        seq = make(tuple(j for _, j in hits), np.array([t for t, _ in hits]), origin)
        if all(s.key() != seq.key() for s in out):
            out.append(seq)
    return out


def _gap_touches(ts, g, reach_samples):
    """The touches a sketched gap g(t_i) shows: (times of its local minima below ``reach``, times of its
    reversals from approaching to receding near zero), ``reach`` = ``reach_samples`` × the median |Δg| of a
    sample; each time by :func:`_touch_time`. A plane's gap or a pair's (:mod:`pbanim.design.body_sequences`)."""
    reach = reach_samples * np.median(np.abs(np.diff(g)))
    minima, reversals = [], []
    for i in range(1, len(ts) - 1):
        if g[i] <= g[i - 1] and g[i] < g[i + 1] and g[i] < reach:
            minima.append(_touch_time(ts, g, i))
        if g[i] - g[i - 1] < 0 < g[i + 1] - g[i] and min(g[i], g[i + 1]) < 2 * reach:
            reversals.append(_touch_time(ts, g, i))
    return minima, reversals


def _touch_time(ts, g, i):
    """The time the sketched gap reaches the plane near its minimum at sample i. Two hypotheses: the impact
    lies in (t_i, t_{i+1}) — the incoming line (i−1, i) and the outgoing (i+1, i+2) reach g = 0 inside it —
    or in (t_{i−1}, t_i) — lines (i−2, i−1) and (i, i+1); the one whose two zeros agree best, averaged."""
    n = len(ts)

    def zero(a, b):
        if a < 0 or b >= n:
            return None
        s = (g[b] - g[a]) / (ts[b] - ts[a])
        return ts[a] - g[a] / s if s != 0 else None

    best = None
    for (a, b), inc, out in (((i, i + 1), (i - 1, i), (i + 1, i + 2)), ((i - 1, i), (i - 2, i - 1), (i, i + 1))):
        if a < 0 or b >= n:
            continue
        zs = [z for z in (zero(*inc), zero(*out)) if z is not None]
        if not zs:
            continue
        t = float(np.clip(np.mean(zs), ts[a], ts[b]))
        miss = sum(abs(z - t) for z in zs) / len(zs) + sum(abs(z - np.clip(z, ts[a], ts[b])) for z in zs)
        if best is None or miss < best[0]:
            best = (miss, t)
    t = ts[i] if best is None else best[1]
    return float(np.clip(t, ts[max(i - 1, 0)] + 1e-6, ts[min(i + 1, n - 1)] - 1e-6))


def _replay(scene, u, t_end, pts, goals):
    """The motion from u = (x₀, v₀) by :func:`pbanim.design.simulate` (exact flight): (planes hit, impact
    times, E, max goal residual)."""
    from .simulate import simulate

    times = sorted({t for t, _ in pts} | {g.time for g in goals} | {t_end})
    tr = simulate(scene, t_end, ["x0", "v0"], u, times=times, sensitivities=False, warn=False, check_start=False,
                  flight="exact")
    err = np.array([float(np.linalg.norm(tr.position(0, t) - x)) for t, x in pts])
    E = 0.5 * float(np.sum(err ** 2))
    viol = max((float(np.abs(tr.position(0, g.time) - g.target).max()) for g in goals), default=0.0)
    planes = tuple(int(i.other) for i in tr.impacts if i.kind == "plane")
    return planes, np.array([i.t for i in tr.impacts]), E, viol, tr.certified and not tr.rests, err


@contract(scene=_SCENE, goals=_GOALS, t_end=Real(gt=0), sketch=SketchPoints(), sequence=Obj(Sequence),
          maxiter=Int(ge=1, le=10_000), tol=Real(gt=0), ftol=Real(gt=0))
def solve_sequence(scene, goals, t_end, sketch, sequence, *, maxiter: int = 200, tol: float = 1e-6,
                   ftol: float = 1e-12) -> SequenceSearch:
    """The continuous problem with the sequence fixed (module docstring, step 3), then the replay (step 4)."""
    _check_scene(scene)
    goals = _check_goals(scene, goals, 0.0, t_end)
    pts = _sketch(sketch, 0.0, t_end)
    if len(sequence.planes) != len(sequence.times) or any(not 0 <= j < len(scene.planes) for j in sequence.planes):
        raise InvalidInput(f"sequence: one known plane per impact time, got planes {sequence.planes} and "
                           f"{len(sequence.times)} times for {len(scene.planes)} planes")
    fl = Flights(scene, sequence.planes, t_end, pts, goals)
    z, res = _solve_fixed(fl, sequence.times, t_end, maxiter, ftol)
    u = z[:6].copy()
    planes, imp_t, E, viol, err, ok, msg = _judge(lambda: _replay(scene, u, t_end, pts, goals), sequence.key(), res,
                                                  tol, len(pts))
    return SequenceSearch(u, planes, imp_t, ok, E, viol, E + viol, msg, [], 1, 1, err)


def _solve_fixed(fl, times, t_end, maxiter, ftol):
    """SLSQP on a fixed-sequence problem ``fl`` (objective, equalities, inequalities with their Jacobians,
    each evaluated once per iterate) from ``fl.start`` at the time guesses: (z, SLSQP's result)."""
    times = np.sort(np.clip(np.asarray(times, float), 1e-3 * t_end, (1 - 1e-3) * t_end))
    z0 = fl.start(times)
    cache = {}

    def ev(z, which):
        key = (z.tobytes(), which)
        if key not in cache:
            cache[key] = {"f": fl.objective, "c": fl.equalities, "h": fl.inequalities}[which](z)
        return cache[key]

    with np.errstate(all="ignore"):
        res = _slsqp(lambda z: ev(z, "f")[0], lambda z: ev(z, "f")[1], lambda z: ev(z, "c")[0],
                     lambda z: ev(z, "c")[1], lambda z: ev(z, "h")[0], lambda z: ev(z, "h")[1], z0, maxiter, ftol,
                     [], [])
    return (res.x if np.all(np.isfinite(res.x)) else z0), res


def _judge(replay, key, res, tol, n_pts):
    """Step 4: ``replay()`` → (sequence, impact times, E, goal residual, sound, errors); a replay that fails (a
    start inside an obstacle, too many impacts) is an honest miss said in the message. Returns (sequence,
    times, E, goal residual, errors, success, message)."""
    try:
        seq, imp_t, E, viol, sound, err = replay()
    except PbanimError as exc:
        seq, imp_t, E, viol, sound, err = (), np.zeros(0), np.inf, np.inf, False, np.full(n_pts, np.inf)
        res.message = f"{res.message}; replay failed: {exc}"
    confirmed = seq == key and sound
    ok = bool(confirmed and res.success and viol <= tol)
    msg = ("replay confirms the sequence; goals met" if ok else
           f"replay {'confirms' if confirmed else 'shows ' + str(seq) + ' instead of'} the sequence, goal residual "
           f"{viol:.2e} (SLSQP: {res.message})")
    return seq, imp_t, E, viol, err, ok, msg


def _neighbours(seq, n_planes, t_end, t_worst):
    """Insert (every plane, every gap between impacts and the ends), delete, replace (each impact's plane by
    another), swap (each neighbour pair): ordered by how near the move's time lies to ``t_worst``."""
    P, T = list(seq.planes), list(seq.times)
    edges = [0.0] + T + [t_end]
    out = []
    for k in range(len(P) + 1):
        tm = 0.5 * (edges[k] + edges[k + 1])
        for j in range(n_planes):
            if (k == 0 or P[k - 1] != j) and (k == len(P) or P[k] != j):
                out.append((tm, Sequence(tuple(P[:k] + [j] + P[k:]), np.array(T[:k] + [tm] + T[k:]), "insert")))
    for k in range(len(P)):
        out.append((T[k], Sequence(tuple(P[:k] + P[k + 1:]), np.array(T[:k] + T[k + 1:]), "delete")))
        for j in range(n_planes):
            if j != P[k]:
                out.append((T[k], Sequence(tuple(P[:k] + [j] + P[k + 1:]), np.array(T), "replace")))
    for k in range(len(P) - 1):
        if P[k] != P[k + 1]:
            out.append((0.5 * (T[k] + T[k + 1]), Sequence(tuple(P[:k] + [P[k + 1], P[k]] + P[k + 2:]), np.array(T),
                                                         "swap")))
    return [s for _, s in sorted(out, key=lambda m: abs(m[0] - t_worst))]


@contract(scene=_SCENE, goals=_GOALS, t_end=Real(gt=0), sketch=SketchPoints(), max_proposals=Int(ge=1, le=1000),
          maxiter=Int(ge=1, le=10_000), tol=Real(gt=0), accept_rms=Real(ge=0), proposals=Opt(Seq(Obj(Sequence))))
def search_sequences(scene, goals, t_end, sketch, *, max_proposals: int = 40, maxiter: int = 200,
                     tol: float = 1e-6, accept_rms: float = 0.02, proposals=None) -> SequenceSearch:
    """The discrete search (module docstring): the proposals (default :func:`propose_sequences`; a caller may
    give its own, e.g. the previous design's sequence), then moves around the best candidate (by residual
    E + goal residual of its replay; its sequence is the one the replay shows), nearest the sketch point its
    replay misses most first, accepting the first move that lowers the residual by more than 1e-9 relative;
    the sequence a replay shows instead of the proposed one is proposed next. A sequence that hits a plane
    twice in a row where gravity does not pull toward it (n·g ≥ 0: nothing brings the body back) is never
    solved; such a proposal is repaired (its four possible neighbours nearest the fault are proposed). Stops at a confirmed success whose RMS distance to the sketch is ≤ ``accept_rms`` (m), when no
    move improves, or after ``max_proposals`` continuous solves (the cap, known before the search starts)."""
    _check_scene(scene)
    pts = _sketch(sketch, 0.0, t_end)
    ts = np.array([t for t, _ in pts])
    n, _ = planes_of(scene)
    returns = n @ scene.gravity < 0                      # planes gravity pulls the body back to

    def possible(seq):
        return all(a != b or returns[a] for a, b in zip(seq.planes[:-1], seq.planes[1:]))

    def fault(seq):
        bad = next(k for k in range(len(seq.planes) - 1) if seq.planes[k] == seq.planes[k + 1])
        return 0.5 * (seq.times[bad] + seq.times[bad + 1])

    pending = list(propose_sequences(scene, pts) if proposals is None else proposals)
    best, tried = _search_loop(pending, lambda seq: solve_sequence(scene, goals, t_end, pts, seq, maxiter=maxiter,
                                                                   tol=tol),
                               lambda seq, t: _neighbours(seq, len(scene.planes), t_end, t), possible, fault,
                               lambda key, times: Sequence(key, times, "replay"), ts, len(pts), t_end,
                               max_proposals, accept_rms, "planes")
    if best is None:
        return SequenceSearch(scene.vector(["x0", "v0"]), (), np.zeros(0), False, np.inf, np.inf, np.inf,
                              f"no proposal gave a motion ({len(tried)} tried); u is the scene's own (x0, v0)",
                              tried, len(tried), int(max_proposals))
    best.tried, best.proposals, best.cap = tried, len(tried), int(max_proposals)
    best.message += f"; best of {len(tried)} proposals (cap {max_proposals})"
    return best


def _search_loop(pending, solve, neighbours, possible, fault, make, ts, n_pts, t_end, max_proposals, accept_rms,
                 label, replay_first=True):
    """The search of :func:`search_sequences` on any kind of sequence: ``solve(seq)`` → a result with
    ``sequence, times, residual, objective, violation, success, errors``; ``neighbours(seq, t)`` the moves
    nearest t first; ``possible(seq)``; ``fault(seq)`` the time of an impossible sequence's first fault;
    ``make(key, times)`` the sequence a replay shows, proposed next (``replay_first``) or after the pending
    proposals. Returns (best or None, rows of the solves)."""
    seen, tried, best = set(), [], None

    def done():
        return best is not None and best.success and \
            np.sqrt(2.0 * best.objective / max(n_pts, 1)) <= accept_rms

    def consider(seq):
        nonlocal best
        seen.add(seq.key())
        r = solve(seq)
        tried.append({label: seq.key(), "origin": seq.origin, "residual": r.residual, "objective": r.objective,
                      "violation": r.violation, "confirmed": r.sequence == seq.key(), "success": r.success,
                      "replay": r.sequence})
        better = np.isfinite(r.residual) and (best is None or r.residual < best.residual * (1 - 1e-9))
        if better:
            best = r
        return better, r

    while len(tried) < max_proposals and not done():
        if pending:
            seq = pending.pop(0)
            if seq.key() not in seen and not possible(seq):
                seen.add(seq.key())             # repaired, not solved: its possible neighbours, nearest the fault first
                pending[:0] = [m for m in neighbours(seq, fault(seq)) if possible(m)][:4]
            elif seq.key() not in seen:
                _, r = consider(seq)
                if r.sequence != seq.key() and np.isfinite(r.residual):
                    pending.insert(0 if replay_first else len(pending), make(r.sequence, r.times))
            continue
        if best is None:
            break
        moved = False
        t_worst = float(ts[int(np.argmax(best.errors))]) if len(ts) else 0.5 * t_end
        for m in neighbours(make(best.sequence, best.times), t_worst):
            if len(tried) >= max_proposals:
                break
            if m.key() in seen or not possible(m):
                continue
            better, r = consider(m)
            if r.sequence != m.key() and r.sequence not in seen and np.isfinite(r.residual):
                pending.append(make(r.sequence, r.times))
            if better or pending:
                moved = True
                break
        if not moved:
            break                                 # a local minimum of the residual over the moves
    return best, tried
