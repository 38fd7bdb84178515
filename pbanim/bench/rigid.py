"""``pbanim bench rigid``: throughput of many free bodies, and work-precision of the torque-free body.

1. Bodies per second for N = 1 … 10⁴ free bodies under gravity, one RK4 step (with renormalization), for
   * pbanim: ``RigidScene(RigidBodies, [RigidGravity()]).step(..., "rk4")``,
   * a hand-written vectorized numpy RK4 step (the same equations inline, no scene, no effects),
   * a hand-written per-body Python loop (RK4 on each body's 13-vector; small N only).
   Goal ``rigid-rk4-vs-handwritten``: pbanim's time per step ≤ 1.3× the hand-written vectorized step at
   the largest N.
2. Work-precision for the torque-free asymmetric body (ORACLES C1): error of body ω(t_end) against the
   Jacobi elliptic closed form vs wall time, for each integrator with and without renormalization and with
   the exponential map (RKMK).
3. What diagnostics cost (issue 28, point 2): one body under gravity, RK4, 1000 steps, µs per step with
   ``diagnostics=False``, ``"lazy"`` (the default) unread, ``"lazy"`` read once after the run (energies,
   momenta, ||q| − 1| from the recorded states) and ``True`` (computed at every recorded step), in
   alternating rounds; each column over the run without diagnostics.
"""

from __future__ import annotations

import numpy as np

from . import Goal, Report, Table, median_time

__all__ = ["run", "make_bodies", "handwritten_vectorized_step", "handwritten_loop_step", "throughput",
           "work_precision"]

G = np.array([0.0, 0.0, -9.81])


def make_bodies(N: int, seed: int = 0):
    """N free rigid boxes (1 × 2 × 3) with random masses, poses and velocities (seeded)."""
    from ..rigid import RigidBodies, box_inertia

    rng = np.random.default_rng(seed)
    return RigidBodies(rng.uniform(0.5, 2.0, N), box_inertia(1.0, [1.0, 2.0, 3.0]),
                       positions=rng.normal(size=(N, 3)), orientations=rng.normal(size=(N, 4)),
                       velocities=rng.normal(size=(N, 3)), angular_velocities=rng.normal(size=(N, 3)))


def handwritten_vectorized_step(y: np.ndarray, h: float, m: np.ndarray, inv_Ib: np.ndarray) -> np.ndarray:
    """RK4 + renormalization for N bodies under gravity, written directly in numpy (the baseline)."""
    N = m.size
    mg = m[:, None] * G

    def f(y):
        q = y[3 * N:7 * N].reshape(N, 4)
        P = y[7 * N:10 * N].reshape(N, 3)
        L = y[10 * N:].reshape(N, 3)
        w_, x_, y_, z_ = q.T
        s = 2.0 / (w_ * w_ + x_ * x_ + y_ * y_ + z_ * z_)
        R = np.empty((N, 3, 3))
        R[:, 0, 0] = 1 - s * (y_ * y_ + z_ * z_)
        R[:, 0, 1] = s * (x_ * y_ - w_ * z_)
        R[:, 0, 2] = s * (x_ * z_ + w_ * y_)
        R[:, 1, 0] = s * (x_ * y_ + w_ * z_)
        R[:, 1, 1] = 1 - s * (x_ * x_ + z_ * z_)
        R[:, 1, 2] = s * (y_ * z_ - w_ * x_)
        R[:, 2, 0] = s * (x_ * z_ - w_ * y_)
        R[:, 2, 1] = s * (y_ * z_ + w_ * x_)
        R[:, 2, 2] = 1 - s * (x_ * x_ + y_ * y_)
        om = np.einsum("nij,nj->ni", R, np.einsum("nij,nj->ni", inv_Ib, np.einsum("nji,nj->ni", R, L)))
        dy = np.empty_like(y)
        dy[:3 * N] = (P / m[:, None]).ravel()
        a, b, c = om.T
        dy[3 * N:7 * N] = 0.5 * np.column_stack([-a * x_ - b * y_ - c * z_, a * w_ + b * z_ - c * y_,
                                                 b * w_ + c * x_ - a * z_, c * w_ + a * y_ - b * x_]).ravel()
        dy[7 * N:10 * N] = mg.ravel()
        dy[10 * N:] = 0.0
        return dy

    k1 = f(y)
    k2 = f(y + h / 2 * k1)
    k3 = f(y + h / 2 * k2)
    k4 = f(y + h * k3)
    y1 = y + h / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
    q = y1[3 * N:7 * N].reshape(N, 4)
    q /= np.linalg.norm(q, axis=1, keepdims=True)
    return y1


def handwritten_loop_step(y: np.ndarray, h: float, m: np.ndarray, inv_Ib: np.ndarray) -> np.ndarray:
    """The same step one body at a time in plain Python/numpy (what students write first)."""
    N = m.size
    x, q, P, L = (y[:3 * N].reshape(N, 3), y[3 * N:7 * N].reshape(N, 4), y[7 * N:10 * N].reshape(N, 3),
                  y[10 * N:].reshape(N, 3))
    out = [np.empty((N, 3)), np.empty((N, 4)), np.empty((N, 3)), np.empty((N, 3))]
    for i in range(N):
        Ibi, mi = inv_Ib[i], m[i]

        def f(s):
            qq = s[3:7] / np.linalg.norm(s[3:7])
            w_, a_, b_, c_ = qq
            R = np.array([[1 - 2 * (b_ * b_ + c_ * c_), 2 * (a_ * b_ - w_ * c_), 2 * (a_ * c_ + w_ * b_)],
                          [2 * (a_ * b_ + w_ * c_), 1 - 2 * (a_ * a_ + c_ * c_), 2 * (b_ * c_ - w_ * a_)],
                          [2 * (a_ * c_ - w_ * b_), 2 * (b_ * c_ + w_ * a_), 1 - 2 * (a_ * a_ + b_ * b_)]])
            om = R @ Ibi @ R.T @ s[10:13]
            u = s[3:7]
            qd = 0.5 * np.array([-om @ u[1:], om[0] * u[0] + om[1] * u[3] - om[2] * u[2],
                                 om[1] * u[0] + om[2] * u[1] - om[0] * u[3], om[2] * u[0] + om[0] * u[2] - om[1] * u[1]])
            return np.concatenate([s[7:10] / mi, qd, mi * G, np.zeros(3)])

        s = np.concatenate([x[i], q[i], P[i], L[i]])
        k1 = f(s)
        k2 = f(s + h / 2 * k1)
        k3 = f(s + h / 2 * k2)
        k4 = f(s + h * k3)
        s1 = s + h / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
        s1[3:7] /= np.linalg.norm(s1[3:7])
        out[0][i], out[1][i], out[2][i], out[3][i] = s1[:3], s1[3:7], s1[7:10], s1[10:]
    return np.concatenate([o.ravel() for o in out])


def throughput(Ns, loop_max: int, repeats: int, h: float = 1e-3) -> list[list]:
    """Rows (N, pbanim bodies/s, vectorized bodies/s, loop bodies/s, ratio pbanim/vectorized) + agreement."""
    from ..rigid import RigidGravity, RigidScene

    rows = []
    for N in Ns:
        rb = make_bodies(N)
        scene = RigidScene(rb, [RigidGravity(G)])
        y = rb.state()
        ya = scene.step(0.0, y, h, "rk4")
        yb = handwritten_vectorized_step(y, h, rb.mass, rb.inv_I_body)
        agree = float(np.abs(ya - yb).max())
        min_time = 0.02
        t_pb = median_time(lambda: scene.step(0.0, y, h, "rk4"), repeats, min_time)
        t_vec = median_time(lambda: handwritten_vectorized_step(y, h, rb.mass, rb.inv_I_body), repeats, min_time)
        if N <= loop_max:
            t_loop = median_time(lambda: handwritten_loop_step(y, h, rb.mass, rb.inv_I_body), 1 if N > 100 else repeats)
            agree = max(agree, float(np.abs(handwritten_loop_step(y, h, rb.mass, rb.inv_I_body) - ya).max()))
        else:
            t_loop = np.nan
        rows.append([N, N / t_pb, N / t_vec, N / t_loop if np.isfinite(t_loop) else np.nan, t_pb / t_vec, agree])
    return rows


def work_precision(quick: bool, t_end: float | None = None, repeats: int = 1) -> list:
    """Rows of ``pbanim.accuracy.sweep`` for (method, quaternions) variants × steps h (ORACLES C1)."""
    from ..accuracy import sweep
    from ..models.rigid import torque_free_body
    from ..rigid import RigidScene

    body = torque_free_body((1.0, 2.0, 3.0), (1.0, 0.1, 2.0))
    rb = body.bodies(orientation=[0.3, 0.5, -0.2, 0.8])
    t_end = (2.0 if quick else 10.0) if t_end is None else t_end
    exact = body.omega(t_end)[0]
    methods = ["euler", "rk4"] if quick else ["euler", "symplectic_euler", "midpoint", "verlet", "rk4",
                                              "implicit_midpoint"]
    modes = ["renormalize", "none", "exponential"]
    variants = [(m, q) for m in methods for q in modes]
    hs = [0.1, 0.05, 0.025] if quick else [0.2, 0.1, 0.05, 0.025, 0.0125, 0.00625]
    scenes = {q: RigidScene(rb, quaternions=q) for q in modes}

    def run(variant, h):
        method, mode = variant
        res = scenes[mode].simulate(t_end, h, method=method, diagnostics=False, record_every=10 ** 9)
        return rb.body_angular_velocity(res.y[:, -1])[0], res.nfev

    params = {v: (hs[:-2] if v[0] == "implicit_midpoint" else hs) for v in variants}
    return sweep(run, variants, params, lambda w: float(np.abs(w - exact).max()), repeats=repeats)


def _diagnostics_cost(steps: int, rounds: int, h: float = 1e-3) -> list:
    """Rows (mode, µs per step, ratio to diagnostics=False) for one body under gravity, RK4 (see point 3)."""
    import time

    from ..rigid import RigidBodies, RigidGravity, RigidScene

    rb = RigidBodies(2.0, [1.0, 2.0, 3.0], positions=[[0.0, 0.0, 1.0]], orientations=[[0.3, 0.5, -0.2, 0.8]],
                     velocities=[[1.0, 0.0, 2.0]], angular_velocities=[[1.0, 0.1, 2.0]])
    scene = RigidScene(rb, [RigidGravity(G)])
    modes = {"False": lambda: scene.simulate(steps * h, h, "rk4", diagnostics=False),
             "lazy, unread": lambda: scene.simulate(steps * h, h, "rk4"),
             "lazy, read": lambda: scene.simulate(steps * h, h, "rk4").diagnostics["energy"],
             "True": lambda: scene.simulate(steps * h, h, "rk4", diagnostics=True)}
    times: dict = {name: [] for name in modes}
    for _ in range(rounds):
        for name, fn in modes.items():
            start = time.perf_counter()
            fn()
            times[name].append((time.perf_counter() - start) / steps * 1e6)
    base = np.array(times["False"])
    return [[name, float(np.median(t)), float(np.median(np.array(t) / base))] for name, t in times.items()]


def run(quick: bool = False) -> Report:
    """Run the rigid-body benchmarks and return the report (``quick``: small sizes, the test suite's smoke run)."""
    rep = Report("rigid")
    Ns = [1, 10, 100, 1000] if quick else [1, 10, 100, 1000, 10000]
    rows = throughput(Ns, loop_max=100 if quick else 1000, repeats=3 if quick else 5)
    rep.tables.append(Table("free bodies under gravity, one RK4 step + renormalization (bodies per second)",
                            ["N", "pbanim", "hand vectorized", "hand loop", "pbanim/vectorized time", "max |Δy|"],
                            rows))
    wp = work_precision(quick, repeats=1 if quick else 3)
    rep.tables.append(Table("torque-free body (ORACLES C1): error of ω(t_end) vs wall time",
                            ["method", "quaternions", "h", "error", "wall time [s]", "nfev"],
                            [[r.variant[0], r.variant[1], r.param, r.error, r.wall_time, r.nfev] for r in wp]))
    cost = _diagnostics_cost(200 if quick else 1000, 3 if quick else 7)
    rep.tables.append(Table("what diagnostics cost: one body under gravity, RK4 (µs per step, medians of "
                            "alternating rounds)", ["diagnostics", "µs per step", "× diagnostics=False"], cost))
    big = rows[-1]
    rep.goals.append(Goal("rigid-rk4-vs-handwritten", big[4], 1.3, "<=", "x",
                          f"pbanim RK4 step time / hand-written vectorized step, N = {big[0]}"))
    loop_rows = [r for r in rows if np.isfinite(r[3])]
    speed = loop_rows[-1][1] / loop_rows[-1][3]
    rep.goals.append(Goal("rigid-vectorized-vs-loop", speed, 10.0, ">=", "x",
                          f"pbanim bodies/s over the per-body Python loop, N = {loop_rows[-1][0]}"))
    agree = max(r[5] for r in rows)
    rep.goals.append(Goal("rigid-baselines-agree", agree, 1e-12, "<=", "",
                          "max |y_pbanim − y_baseline| after one step (same arithmetic)"))
    rk4 = {r.variant[1]: r for r in wp if r.variant[0] == "rk4" and r.param == 0.025}
    rep.notes.append("RK4 at h = 0.025: error " + ", ".join(f"{k} {v.error:.2e}" for k, v in rk4.items()))
    rep.notes.append("symplectic_euler is first order here: with L̇ = 0 the kick is trivial and its drift "
                     "q̇ = ½(0, ω(q))⊗q depends on q itself (explicit Euler on q); verlet is the rigid-body "
                     "splitting of pbanim.rigid.splitting (exact-axis free rotation), second order")
    return rep
