"""The discrete search over event sequences of several spheres (chapter 10, issue 30 point 3; part of
:mod:`pbanim.design`).

:mod:`pbanim.design.sequences` searches the planes one sphere hits; here the sequence says which bodies
hit which surfaces in which order, a surface being a plane or another sphere:

    σ = (e₁, …, e_K),   e_k = (a, "plane", j)  or  (a, "body", b), a < b,

each with a time guess τ̂_k. The same four steps:

1. **proposals from the sketches** (one sketch per body, x̄_i(t)) — for every body i and plane j the gap
   n_j·x̄_i − n_j·o_j − r_i, for every pair the gap |x̄_i − x̄_b| − r_i − r_b (body b's sketch read at body
   i's sample times, linearly), each with an event at its local minima within reach and at its reversals
   (:func:`pbanim.design.sequences._gap_touches`), merged in time order;
2. **moves** — first the moves the sketch asks for, counting per element (body and surface) the touches of
   step 1 (a minimum and a reversal less than 1.5 samples apart are one touch) against the sequence's
   events: an element touched more often is inserted at its touch farthest from its events, one with more
   events loses the event farthest from its touches, and a pair of the two gives a replace; each proposal
   is followed by these moves of its own, before the next proposal. Then the generic moves: insert any
   event (any body, any surface) between two events or at either end, delete one, replace one by another,
   swap two neighbours, nearest the worst-fitted sketch time first. Every event's time guess is moved to
   the sketch's touch of it within three samples. A body that hits
   a plane twice with no event of its own between, where gravity does not pull toward the plane, or a pair
   that collides twice with no event of either between (two free parabolas under one gravity: their
   separation moves on a straight line) is impossible: repaired, never solved;
3. **the continuous problem** with σ fixed — :class:`pbanim.design.body_flights.BodyFlights` (every body's
   parabolas between consecutive events of any body, the pair impulse frictionless with momentum conserved),
   E minimized with the goals as equalities (SLSQP, analytic Jacobians);
4. **the score** — each candidate replayed by :func:`pbanim.design.simulate` (the exact sphere flight,
   its sphere–plane and sphere–sphere impacts found as roots of the gaps: independent of the closed forms
   of step 3); ``success`` only when the replay shows the proposed sequence, the goals hold and SLSQP
   converged. The search loop is :func:`pbanim.design.sequences._search_loop`, the one-sphere search's, with
   one difference: the sequence a failed solve's replay shows is proposed after the sketches' own proposals
   (with several bodies a failed solve's replay strays far from the sketch: measured on the two-ball sketch of
   ORACLES L8, four replays in a row, each a worse sequence, before the sketch's second proposal).

==========  ====================  ==========================================================
symbol      code                  meaning
==========  ====================  ==========================================================
σ           ``BodySequence.events``  the events, in order
τ_k         ``BodySequence.times``   event times (guesses in a proposal, solved in a result)
u           ``result.u``          (x₀, v₀) of every body, body by body
E           ``objective``         the replay's distance to the sketches (m²)
==========  ====================  ==========================================================

Scope: B ≥ 1 spheres with isotropic inertia among static planes, frictionless impacts, one restitution ε
(no resting contact: a replay that comes to rest is not confirmed).

References: Popović, Seitz & Erdmann, ACM TOG 2003 (§7: the discrete structure left open); Posa, Cantu &
Tedrake, IJRR 2014; Bock & Plitt 1984.
"""

from __future__ import annotations

import operator
from dataclasses import dataclass

import numpy as np

from ..collision import Sphere
from ..contracts import Anything, Array, Int, Obj, Opt, Real, Seq, Text, contract
from ..errors import InvalidInput
from .body_flights import BodyFlights
from .control import _GOALS, _check_goals
from .scene import DesignScene
from .sequences import SequenceSearch, _gap_touches, _judge, _search_loop, _solve_fixed, _two_proposals
from .shooting import _sketch
from .specs import SketchPoints

__all__ = ["BodySequence", "propose_body_sequences", "solve_body_sequence", "search_body_sequences"]

_EVENTS = Seq(Anything("events (a, 'plane', j) or (a, 'body', b), checked against the scene by the callee"))


@contract(events=_EVENTS, times=Array((None,), empty=True), origin=Text())
@dataclass
class BodySequence:
    """An event sequence of several spheres: ``events[k]`` = (a, "plane", j) or (a, "body", b), a < b, at
    (about) ``times[k]``; ``origin`` says where it came from (``sketch``, ``reversals``, a move, ``replay``)."""

    events: tuple
    times: np.ndarray
    origin: str = "sketch"

    def __post_init__(self) -> None:
        ev = []
        for e in self.events:
            try:
                a, kind, o = e
                a, o = operator.index(a), operator.index(o)
            except (TypeError, ValueError):
                a, kind, o = -1, None, -1
            if kind not in ("plane", "body") or a < 0 or o < 0 or (kind == "body" and a >= o):
                raise InvalidInput(f"BodySequence: events are (a, 'plane', j) or (a, 'body', b) with a < b, got {e!r}")
            ev.append((int(a), str(kind), int(o)))
        self.events, self.times = tuple(ev), np.asarray(self.times, float).reshape(-1)
        if len(self.events) != self.times.size:
            raise InvalidInput(f"BodySequence: one time per event, got {len(self.events)} events and "
                               f"{self.times.size} times")

    def key(self) -> tuple:
        """The events (what a replay's sequence is compared with)."""
        return self.events


_SCENE = Obj(DesignScene)
_SKETCHES = Seq(SketchPoints(min_len=3), min_len=1)


def _check(scene, sketches):
    if not all(isinstance(b.shape, Sphere) for b in scene.bodies):
        raise InvalidInput("the event search designs spheres' flights: every body must be a Sphere")
    if len(sketches) != scene.N:
        raise InvalidInput(f"one sketch per body: {scene.N} bodies, {len(sketches)} sketches")


def _elements(scene):
    return [(i, "plane", j) for i in range(scene.N) for j in range(len(scene.planes))] + \
        [(i, "body", b) for i in range(scene.N) for b in range(i + 1, scene.N)]


def _touches(scene, sketches, reach_samples):
    """(minima, reversals): the (time, event) touches every body–plane and body–body gap of the sketches shows."""
    S = [sorted(_sketch(p, -np.inf, np.inf), key=lambda q: q[0]) for p in sketches]
    S = [(np.array([t for t, _ in p]), np.array([x for _, x in p])) for p in S]
    minima, reversals = [], []
    for i, (ts, X) in enumerate(S):
        for j, p in enumerate(scene.planes):
            lo, rev = _gap_touches(ts, X @ p.normal - p.normal @ scene.anchors[j] - scene.radius[i], reach_samples)
            minima += [(t, (i, "plane", j)) for t in lo]
            reversals += [(t, (i, "plane", j)) for t in rev]
        for b in range(i + 1, scene.N):
            tb, Xb = S[b]
            Xi = np.stack([np.interp(ts, tb, Xb[:, c]) for c in range(3)], axis=1)
            lo, rev = _gap_touches(ts, np.linalg.norm(X - Xi, axis=1) - scene.radius[i] - scene.radius[b],
                                   reach_samples)
            minima += [(t, (i, "body", b)) for t in lo]
            reversals += [(t, (i, "body", b)) for t in rev]
    return minima, reversals


@contract(scene=_SCENE, sketches=_SKETCHES, reach_samples=Real(gt=0))
def propose_body_sequences(scene, sketches, reach_samples: float = 1.5) -> list:
    """The sequences the sketches show (module docstring, step 1): gap minima within reach, and the gaps'
    reversals; at most two proposals, duplicates dropped."""
    _check(scene, sketches)
    minima, reversals = _touches(scene, sketches, reach_samples)
    return _two_proposals(minima, reversals, BodySequence)


def _names(scene):
    return [n for i in range(scene.N) for n in (f"x{i}", f"v{i}")]


def _replay(scene, u, t_end, sketches, goals):
    """The motion from u by :func:`pbanim.design.simulate` (exact flight): (events, times, E, goal residual,
    sound, per-sketch-point distances)."""
    from .simulate import simulate

    times = sorted({t for p in sketches for t, _ in p} | {g.time for g in goals} | {t_end})
    tr = simulate(scene, t_end, _names(scene), u, times=times, sensitivities=False, warn=False, check_start=False,
                  flight="exact")
    err = np.array([float(np.linalg.norm(tr.position(i, t) - x)) for i, p in enumerate(sketches) for t, x in p])
    viol = max((float(np.abs(tr.position(g.body, g.time) - g.target).max()) for g in goals), default=0.0)
    ev = tuple((i.body, "plane", i.other) if i.kind == "plane" else (min(i.body, i.other), "body", max(i.body, i.other))
               for i in tr.impacts)
    return ev, np.array([i.t for i in tr.impacts]), 0.5 * float(np.sum(err ** 2)), viol, \
        tr.certified and not tr.rests, err


@contract(scene=_SCENE, goals=_GOALS, t_end=Real(gt=0), sketches=_SKETCHES, sequence=Obj(BodySequence),
          maxiter=Int(ge=1, le=10_000), tol=Real(gt=0), ftol=Real(gt=0))
def solve_body_sequence(scene, goals, t_end, sketches, sequence, *, maxiter: int = 200, tol: float = 1e-6,
                        ftol: float = 1e-12) -> SequenceSearch:
    """The continuous problem with the event sequence fixed (step 3), then the replay (step 4); the result's
    ``u`` is (x₀, v₀) of every body, ``sequence`` the events the replay shows."""
    _check(scene, sketches)
    goals = _check_goals(scene, goals, 0.0, t_end)
    sk = [_sketch(p, 0.0, t_end) for p in sketches]
    if any(e[0] >= scene.N or (e[1] == "plane" and e[2] >= len(scene.planes)) or (e[1] == "body" and e[2] >= scene.N)
           for e in sequence.events):
        raise InvalidInput(f"sequence: events of known bodies and planes, got {sequence.events} for {scene.N} "
                           f"bodies and {len(scene.planes)} planes")
    fl = BodyFlights(scene, sequence.events, t_end, sk, goals)
    z, res = _solve_fixed(fl, sequence.times, t_end, maxiter, ftol)
    u = np.concatenate([np.concatenate([z[3 * i:3 * i + 3], z[3 * (scene.N + i):3 * (scene.N + i) + 3]])
                        for i in range(scene.N)])
    events, imp_t, E, viol, err, ok, msg = _judge(lambda: _replay(scene, u, t_end, sk, goals), sequence.key(), res,
                                                  tol, sum(len(p) for p in sk))
    return SequenceSearch(u, events, imp_t, ok, E, viol, E + viol, msg, [], 1, 1, err)


def _evidence(seq, touches):
    """The moves the sketch asks for (``touches``: element → the times the sketch touches it): for an element
    touched more often than the sequence has events of it, insert it at its touch farthest from the
    sequence's events of it; for one with more events than touches, delete its event farthest from its
    touches; for each such pair, both at once (a replace). [(time, sequence)]."""
    def own(e):
        return [k for k, f in enumerate(seq.events) if f == e]

    def far(ts, ref):
        return max(ts, key=lambda x: float(np.min(np.abs(np.asarray(ref) - x))) if len(ref) else 0.0)

    def insert(sq, e, t, origin):
        k = int(np.searchsorted(sq.times, t))
        return BodySequence(sq.events[:k] + (e,) + sq.events[k:], np.insert(sq.times, k, t), origin)

    short, extra = [], []
    for e in set(touches) | set(seq.events):
        te, mine = touches.get(e, []), own(e)
        if len(te) > len(mine):
            short.append((far(te, seq.times[mine]), e))
        elif len(mine) > len(te):
            extra.append(max(mine, key=lambda k: float(np.min(np.abs(np.asarray(te) - seq.times[k])))
                             if len(te) else 0.0))
    short.sort()
    out = [(t, insert(seq, e, t, "insert")) for t, e in short]
    for k in sorted(extra):
        dropped = BodySequence(seq.events[:k] + seq.events[k + 1:], np.delete(seq.times, k), "delete")
        out.append((float(seq.times[k]), dropped))
        out += [(t, insert(dropped, e, t, "replace")) for t, e in short]
    return out


def _neighbours(seq, elements, t_end, t_worst, touches=None):
    """First the moves the sketch asks for (:func:`_evidence`), then insert (every element, every gap and both ends),
    delete, replace, swap neighbours; each group nearest t_worst first."""
    evidence = _evidence(seq, touches or {})
    P, T = list(seq.events), list(seq.times)
    edges = [0.0] + T + [t_end]
    out = []
    for k in range(len(P) + 1):
        tm = 0.5 * (edges[k] + edges[k + 1])
        out += [(tm, BodySequence(tuple(P[:k] + [e] + P[k:]), np.array(T[:k] + [tm] + T[k:]), "insert"))
                for e in elements]
    for k in range(len(P)):
        out.append((T[k], BodySequence(tuple(P[:k] + P[k + 1:]), np.array(T[:k] + T[k + 1:]), "delete")))
        out += [(T[k], BodySequence(tuple(P[:k] + [e] + P[k + 1:]), np.array(T), "replace"))
                for e in elements if e != P[k]]
    for k in range(len(P) - 1):
        if P[k] != P[k + 1]:
            out.append((0.5 * (T[k] + T[k + 1]),
                        BodySequence(tuple(P[:k] + [P[k + 1], P[k]] + P[k + 2:]), np.array(T), "swap")))
    return [s for _, s in sorted(evidence, key=lambda m: abs(m[0] - t_worst)) +
            sorted(out, key=lambda m: abs(m[0] - t_worst))]


def _first_fault(scene, events):
    """Index k of the first impossible event (module docstring, step 2), or None."""
    returns = np.array([p.normal @ scene.gravity < 0 for p in scene.planes])
    last = {}                                     # body → its previous event
    for k, e in enumerate(events):
        bodies = (e[0],) if e[1] == "plane" else (e[0], e[2])
        if e[1] == "plane" and last.get(e[0]) == e and not returns[e[2]]:
            return k
        if e[1] == "body" and last.get(e[0]) == e and last.get(e[2]) == e:
            return k
        for i in bodies:
            last[i] = e
    return None


@contract(scene=_SCENE, goals=_GOALS, t_end=Real(gt=0), sketches=_SKETCHES, max_proposals=Int(ge=1, le=1000),
          maxiter=Int(ge=1, le=10_000), tol=Real(gt=0), accept_rms=Real(ge=0),
          proposals=Opt(Seq(Obj(BodySequence))))
def search_body_sequences(scene, goals, t_end, sketches, *, max_proposals: int = 40, maxiter: int = 200,
                          tol: float = 1e-6, accept_rms: float = 0.02, proposals=None) -> SequenceSearch:
    """The discrete search over event sequences of several spheres (module docstring): the proposals (default
    :func:`propose_body_sequences`), then moves around the best candidate, as
    :func:`pbanim.design.search_sequences` does for one sphere; at most ``max_proposals`` continuous solves
    (the cap, known before the search starts); the report's rows (``tried``) name each sequence ``events``."""
    _check(scene, sketches)
    sk = [_sketch(p, 0.0, t_end) for p in sketches]
    ts = np.array([t for p in sk for t, _ in p])
    elements = _elements(scene)
    touches, near = {}, 1.5 * float(np.median(np.diff(np.unique(ts)))) if len(ts) > 1 else 0.0
    for t, e in sorted(sum(_touches(scene, sk, 1.5), [])):           # a minimum and a reversal of one touch: once
        if not touches.get(e) or t - touches[e][-1] > near:
            touches.setdefault(e, []).append(t)

    def aligned(seq):                   # each event at the sketch's touch of it within three samples, if any
        t = seq.times.copy()
        for k, e in enumerate(seq.events):
            near3 = [x for x in touches.get(e, ()) if abs(x - t[k]) <= 2 * near]
            if near3:
                t[k] = min(near3, key=lambda x: abs(x - t[k]))
        return BodySequence(seq.events, t if np.all(np.diff(t) >= 0) else seq.times, seq.origin)

    def fault(seq):
        k = _first_fault(scene, seq.events)
        return 0.5 * (seq.times[k - 1] + seq.times[k]) if k else float(seq.times[0])

    pending = []                        # each proposal, then the inserts the sketch asks of it
    for p in (propose_body_sequences(scene, sk) if proposals is None else proposals):
        pending += [p] + [m for _, m in _evidence(aligned(p), touches)]
    best, tried = _search_loop(
        pending, lambda seq: solve_body_sequence(scene, goals, t_end, sk, seq, maxiter=maxiter, tol=tol),
        lambda seq, t: _neighbours(aligned(seq), elements, t_end, t, touches), lambda seq: _first_fault(scene, seq.events) is None,
        fault, lambda key, times: BodySequence(key, times, "replay"), ts, len(ts), t_end, max_proposals,
        accept_rms, "events", replay_first=False)
    if best is None:
        return SequenceSearch(scene.vector(_names(scene)), (), np.zeros(0), False, np.inf, np.inf, np.inf,
                              f"no proposal gave a motion ({len(tried)} tried); u is the scene's own (x0, v0)",
                              tried, len(tried), int(max_proposals))
    best.tried, best.proposals, best.cap = tried, len(tried), int(max_proposals)
    best.message += f"; best of {len(tried)} proposals (cap {max_proposals})"
    return best
