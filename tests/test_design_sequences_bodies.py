"""Chapter 10, issue 30 point 3 for several bodies: the search over event sequences of two spheres (ORACLES L8).

Ball 0 is thrown at ball 1 (both in flight), they collide twice, then both bounce on the floor and a wall:
twelve events in 1.25 s, some 37 ms apart on a sketch sampled every 50 ms. The sketch's first proposal (its
gaps' minima) misses a floor bounce between a wall bounce and the second collision; the search finds the true
sequence, and its motion is checked here by an independent replay (an event-driven flight written below:
parabolas, plane roots and the pair's root of a quadratic, not pbanim's simulator)."""

import numpy as np
import pytest

from pbanim.collision import Plane, Sphere
from pbanim.design import DesignBody, DesignScene, simulate
from pbanim.design.body_flights import BodyFlights, pair_impulse
from pbanim.design.body_sequences import BodySequence, propose_body_sequences, search_body_sequences
from pbanim.design.control import position_goal

T, DT, SIGMA, R, EPS = 1.25, 0.05, 0.005, 0.05, 0.9
PLANES = [([0.0, 0.0, 1.0], 0.0), ([-1.0, 0.0, 0.0], -0.4)]            # floor z ≥ 0, wall x ≤ 0.4
G = np.array([0.0, 0.0, -9.81])


def two_balls(v0=(3.0, 0.0, 1.0), v1=(0.0, 0.0, 1.2)):
    return DesignScene([DesignBody(Sphere(R), position=(-0.4, 0.0, 0.35), velocity=v0),
                        DesignBody(Sphere(R), position=(0.1, 0.0, 0.3), velocity=v1)],
                       [Plane(n, offset=o) for n, o in PLANES], restitution=EPS)


def _first_root(c, b, a):
    """The smallest s > 1e-12 with c + b s + a s² = 0 (inf if none)."""
    if a == 0:
        return -c / b if b != 0 and -c / b > 1e-12 else np.inf
    d = b * b - 4 * a * c
    if d < 0:
        return np.inf
    return min((s for s in ((-b - np.sqrt(d)) / (2 * a), (-b + np.sqrt(d)) / (2 * a)) if s > 1e-12), default=np.inf)


def replay(u, t_end, times):
    """Independent exact replay of two equal unit-mass balls: each event the earliest approaching root of a
    plane gap (quadratic) or of |d|² − (2R)² (d moves on a line: one gravity for both), v⁺ by the reflection
    or the equal-mass pair impulse. Returns (positions (len(times), 2, 3), events)."""
    x, v = np.array([u[0:3], u[6:9]], float), np.array([u[3:6], u[9:12]], float)
    t, events, out, pending = 0.0, [], {}, sorted(times)
    for _ in range(1000):
        best = (np.inf, None)
        for i in range(2):
            for j, (n, o) in enumerate(PLANES):
                n = np.array(n)
                s = _first_root(n @ x[i] - o - R, n @ v[i], 0.5 * (n @ G))
                if s < best[0] and n @ (v[i] + G * s) < 0:
                    best = (s, (i, "plane", j))
        d, w = x[0] - x[1], v[0] - v[1]
        s = _first_root(d @ d - 4 * R * R, 2 * d @ w, w @ w)
        if s < best[0] and (d + w * s) @ w < 0:
            best = (s, (0, "body", 1))
        s_hit = min(best[0], t_end - t)
        while pending and pending[0] <= t + s_hit:
            s = pending.pop(0) - t
            out[round(t + s, 9)] = x + v * s + 0.5 * G * s * s
        if best[0] > t_end - t:
            break
        s, e = best
        x, v, t = x + v * s + 0.5 * G * s * s, v + G * s, t + s
        if e[1] == "plane":
            n = np.array(PLANES[e[2]][0])
            v[e[0]] = v[e[0]] - (1 + EPS) * (n @ v[e[0]]) * n
        else:
            n = (x[0] - x[1]) / np.linalg.norm(x[0] - x[1])
            j = 0.5 * (1 + EPS) * (n @ (v[0] - v[1]))
            v[0], v[1] = v[0] - j * n, v[1] + j * n
        events.append(e)
    return np.array([out[round(tt, 9)] for tt in sorted(times)]), tuple(events)


@pytest.fixture(scope="module")
def sketch():
    ts = list(np.round(np.arange(0.0, T + 1e-9, DT), 10))
    true = two_balls()
    u = np.concatenate([true.nominal["x0"], true.nominal["v0"], true.nominal["x1"], true.nominal["v1"]])
    X, events = replay(u, T, ts)
    rng = np.random.default_rng(1)
    sk = [[(t, X[k, b] + SIGMA * rng.normal(size=3)) for k, t in enumerate(ts)] for b in range(2)]
    goals = [position_goal(b, T, X[-1, b]) for b in range(2)]
    return sk, goals, events, u, two_balls(v0=(2.5, 0.0, 0.5), v1=(0.0, 0.0, 0.8))


def _check_motion(res, sk, goals, events):
    ts = [t for t, _ in sk[0]]
    X, seen = replay(res.u, T, ts)
    E = 0.5 * float(sum(np.sum((X[:, b] - np.array([x for _, x in sk[b]])) ** 2) for b in range(2)))
    noise = 0.5 * 2 * len(ts) * 3 * SIGMA ** 2
    assert seen == events == res.sequence
    assert E < 2 * noise and abs(E - res.objective) < 1e-9
    assert max(np.abs(X[-1, g.body] - g.target).max() for g in goals) < 1e-8


def test_replay_below_agrees_with_simulate_and_the_pair_impulse_conserves_momentum(sketch):
    # ORACLES L8: two exact simulators of the same scene agree to roundoff; the pair impulse keeps
    # m_a v_a + m_b v_b to roundoff and reverses the relative normal velocity scaled by ε.
    sk, goals, events, u, _ = sketch
    ts = [0.3, 0.7, T]
    X, ev = replay(u, T, ts)
    tr = simulate(two_balls(), T, ["x0", "v0", "x1", "v1"], times=ts, sensitivities=False, flight="exact")
    seen = tuple((i.body, "plane", i.other) if i.kind == "plane" else (0, "body", 1) for i in tr.impacts)
    assert seen == ev and len(ev) == 12 and ev.count((0, "body", 1)) == 2
    assert np.abs(X - np.array([[tr.position(b, t) for b in range(2)] for t in ts])).max() < 1e-10
    rng = np.random.default_rng(3)
    for _ in range(5):
        va, vb, d = rng.normal(size=(3, 3))
        ma, mb, eps = rng.uniform(0.2, 5.0), rng.uniform(0.2, 5.0), rng.uniform(0.0, 1.0)
        p, _ = pair_impulse(va, vb, d, ma, mb, eps)
        n = d / np.linalg.norm(d)
        mom = ma * va + mb * vb
        assert np.abs(ma * p[:3] + mb * p[3:] - mom).max() <= 8 * np.finfo(float).eps * np.abs(mom).max() + 1e-15
        assert abs((p[:3] - p[3:]) @ n + eps * (va - vb) @ n) <= 8 * np.finfo(float).eps * np.abs(va - vb).max()
        assert np.abs(np.cross(p[:3] - va, n)).max() < 1e-14        # the impulse is along n only


def test_event_jacobians_equal_central_differences(sketch):
    # ORACLES L8: objective, equalities (with two pair impacts) and inequalities: analytic Jacobians equal
    # central differences (δ = 1e-6) to 1e-6 relative.
    sk, goals, events, u, guess = sketch
    fl = BodyFlights(guess, events[:5], T, sk, goals)
    z = fl.start([0.13, 0.22, 0.32, 0.36, 0.5]) + 1e-3 * np.random.default_rng(0).normal(size=fl.size)
    d = 1e-6
    for fn in (lambda zz: (np.atleast_1d(fl.objective(zz)[0]), fl.objective(zz)[1][None]), fl.equalities,
               fl.inequalities):
        J = fn(z)[1]
        F = np.array([(fn(z + d * e)[0] - fn(z - d * e)[0]) / (2 * d) for e in np.eye(fl.size)]).T
        assert J.shape == F.shape and np.abs(J - F).max() <= 1e-6 * max(1.0, np.abs(F).max())


def test_search_finds_two_balls_sequence_the_sketch_misses(sketch, figure_data):
    # ORACLES L8 (the chapter's figure ch10_two_ball_search runs the search on the same sketch): the sketch's
    # first proposal misses a floor bounce 37 ms before the second collision; the search's sequence is the
    # true one (12 events), replayed independently: goals to 1e-8, E within the noise, at most 4 solves.
    sk, goals, events, u, guess = sketch
    d = figure_data("ch10_two_ball_search")
    assert d["events"] == events and np.abs(d["u_true"] - u).max() == 0.0
    props = propose_body_sequences(guess, sk)
    assert props[0].key() == d["first_proposal"] != events and len(props[0].key()) < len(events)

    class Res:                                  # the figure's result, read as the search's
        u, sequence, objective = d["u"], d["sequence"], d["objective"]
    assert d["success"] and d["sequence"] == events and 1 <= d["proposals"] <= d["cap"] == 4
    assert d["tried"][0][1] == props[0].key() and not d["tried"][0][2] and d["tried"][-1][1] == events
    _check_motion(Res, sk, goals, events)
    assert np.abs(d["u"] - u).max() < 0.05


def test_an_insert_move_adds_a_missing_collision(sketch):
    # ORACLES L8: a given sequence without the second collision (a motion with it exists: its replay
    # confirms it, far from the sketch) is repaired by the move that inserts the pair event the sketch
    # shows; the cap bounds the solves.
    sk, goals, events, u, guess = sketch
    tr = simulate(two_balls(), T, ["x0", "v0", "x1", "v1"], sensitivities=False, flight="exact")
    times = np.array([i.t for i in tr.impacts])
    given = BodySequence(events[:3] + events[4:], np.delete(times, 3) + 0.01, "given")
    res = search_body_sequences(guess, goals, T, sk, proposals=[given], max_proposals=3, maxiter=100)
    assert res.success and res.sequence == events and res.proposals <= 3
    assert res.tried[0]["objective"] > 100 * res.objective and res.tried[-1]["origin"] == "insert"
    _check_motion(res, sk, goals, events)


def test_a_wall_bounce_where_the_sketch_shows_a_floor_bounce_is_replaced(sketch):
    # ORACLES L8: a given sequence with ball 1 on the wall where the sketch shows it on the floor has one
    # event too many of one element and one too few of another; the replace the sketch asks for is the
    # true sequence (the given one is impossible, a wall twice in a row: never solved).
    sk, goals, events, u, guess = sketch
    tr = simulate(two_balls(), T, ["x0", "v0", "x1", "v1"], sensitivities=False, flight="exact")
    k = 2
    assert events[k] == (1, "plane", 0) and events[k - 1] == (1, "plane", 1)
    given = BodySequence(events[:k] + ((1, "plane", 1),) + events[k + 1:], np.array([i.t for i in tr.impacts]),
                         "given")
    res = search_body_sequences(guess, goals, T, sk, proposals=[given], max_proposals=2, maxiter=100)
    assert res.success and res.sequence == events and res.proposals <= 2
    assert all(row["events"] != given.key() for row in res.tried) and res.tried[-1]["origin"] == "replace"
    _check_motion(res, sk, goals, events)
