"""``pbanim bench particles``: the cost of a scene step, against what numpy and the memory allow (ch01).

Measured in one run, so both sides of every ratio share the machine's load:

1. One :meth:`pbanim.scene.Scene.step` (symplectic Euler, gravity + drag, 3-D, random masses) at
   N = 10³ … 10⁶ against two hand-written numpy steps doing the same arithmetic on separate x, v arrays
   (F = m g − k_d v; v₁ = v + h W F; x₁ = x + h v₁): as written from the equations on (N, 3) arrays, and
   tuned on flat contiguous arrays; the goal uses the faster. And against the memory-bandwidth bound: one
   ``np.copyto`` of the state into a preallocated array (read y once, write it once) — no step can
   return a new state faster (``y.copy()``, which also allocates, is shown beside it).
2. Damped springs (S = 10⁵ random pairs among N = 2·10⁴ particles, 3-D): pbanim's force accumulation
   (:meth:`DampedSprings.apply`, scatter by ``np.bincount``) against the same spring forces scattered by
   the scipy.sparse incidence product Q = Bᵀ f, and ``np.add.at`` for reference.

3. What diagnostics cost when asked (issue 28, point 2): four particles, five damped springs and gravity,
   RK4, 1000 steps, per step: states only (``diagnostics=False``), the default (``"lazy"``: nothing computed
   during the run) not read and read after the run, and ``diagnostics=True`` (energies and momenta at every
   recorded time during the run), recording every step and every 10th; in alternating rounds.

4. For reference (no goal): one implicit Euler step of a stiff hanging net with the analytic sparse
   Jacobian (:meth:`pbanim.scene.Scene.jac`) against the finite-difference Jacobian the solver builds
   without it.

5. For reference (no goal): where a small scene stops stepping on floats (issue 28, point 1). Symplectic
   Euler on N particles in 2-D (a chain of damped springs, the first particle anchored, gravity), 1000
   steps: the float plan (:mod:`pbanim.particles.lean`) against the vectorized kick–drift into buffers, in
   alternating rounds, past the float plan's size (:data:`pbanim.particles.lean.FLOAT_MAX` coordinates) too.

Goals (issue 2, point 4): step ≤ 1.2× the numpy step at every N; ≤ 2.5× the copy at N = 10⁶;
springs ≤ 1.5× the sparse scatter; (issue 28) a run whose diagnostics are not read ≤ 1.1× a run that
records states only.
"""

from __future__ import annotations

import time

import numpy as np

from . import Goal, Report, Table, median_time

__all__ = ["run"]


def _interleaved(fns: dict, repeats: int, min_time: float) -> dict:
    """Median time of each callable, measured in alternation (one round of every candidate per repeat).

    The machine's load drifts; timing the candidates in turn within each round makes their ratios
    share it (the medians are those of :func:`pbanim.bench.median_time` per round).
    """
    times: dict = {k: [] for k in fns}
    for _ in range(max(1, repeats)):
        for k, fn in fns.items():
            times[k].append(median_time(fn, 1, min_time))
    return {k: float(np.median(v)) for k, v in times.items()}


def _gravity_drag(N: int, rng: np.random.Generator):
    from ..particles.system import Drag, Gravity, ParticleSystem
    from ..scene import Scene

    ps = ParticleSystem(rng.normal(size=(N, 3)), rng.normal(size=(N, 3)), rng.uniform(0.5, 2.0, N))
    return ps, Scene(ps, [Gravity(), Drag(0.3)])


def step_table(sizes, repeats: int, rng: np.random.Generator):
    """Rows (N, scene, numpy, copy, ratios) for one gravity + drag step."""
    from ..scene import Scene

    h, kd = 1e-3, 0.3
    rows = []
    for N in sizes:
        ps, scene = _gravity_drag(N, rng)
        y = ps.state()
        s = ps.split
        x, v = y[:s].reshape(N, 3).copy(), y[s:].reshape(N, 3).copy()
        mg = ps.m[:, None] * np.array([0.0, 0.0, -9.81])
        W = ps.W[:, None]

        def numpy_step():
            # as one writes it from the equations: (N, 3) arrays, W as a column
            F = mg - kd * v
            v1 = v + h * (F * W)
            x1 = x + h * v1
            return x1, v1

        xf, vf, mgf, hWf = x.ravel().copy(), v.ravel().copy(), mg.ravel().copy(), h * np.repeat(ps.W, 3)

        def numpy_flat():
            # tuned: the same arithmetic on flat contiguous arrays, h W precomputed, in-place where free
            F = mgf - kd * vf
            F *= hWf
            v1 = vf + F
            F = np.multiply(v1, h, out=F)
            x1 = xf + F
            return x1, v1

        buf = np.empty_like(y)
        # agreement first: the steps compute the same state
        y1 = scene.step(0.0, y, h)
        err = 0.0
        for x1, v1 in (numpy_step(), numpy_flat()):
            err = max(err, float(np.max(np.abs(y1 - np.concatenate([x1.ravel(), v1.ravel()])))))
        min_time = 0.02 if N < 10**5 else 0.0
        unfolded = Scene(ps, scene.effects)
        unfolded.fold_affine = False  # the force phase effect by effect (zero Q, gravity, drag, kick-drift)
        err = max(err, float(np.max(np.abs(unfolded.step(0.0, y, h) - y1))))
        T = _interleaved({"scene": lambda: scene.step(0.0, y, h), "effects": lambda: unfolded.step(0.0, y, h),
                          "numpy": numpy_step, "flat": numpy_flat, "copy": lambda: np.copyto(buf, y),
                          "alloc": lambda: y.copy()}, repeats, min_time)
        t_scene, t_effects, t_numpy, t_flat, t_copy, t_alloc = (T[k] for k in ("scene", "effects", "numpy", "flat",
                                                                               "copy", "alloc"))
        best = min(t_numpy, t_flat)
        rows.append([N, t_scene, t_effects, t_numpy, t_flat, t_copy, t_alloc, t_scene / best, t_effects / best,
                     t_scene / t_copy, err])
    return rows


def spring_table(S: int, N: int, repeats: int, rng: np.random.Generator):
    from ..particles.system import DampedSprings, ParticleSystem
    from ..scene import Scene

    ps = ParticleSystem(rng.normal(size=(N, 3)), rng.normal(size=(N, 3)), 1.0)
    pairs = rng.integers(0, N, size=(S, 2))
    pairs[:, 1] = (pairs[:, 0] + 1 + rng.integers(0, N - 1, size=S)) % N      # a ≠ b
    springs = DampedSprings(pairs, stiffness=100.0, damping=0.5)
    Scene(ps, [springs])  # binds
    y = ps.state()
    Q = ps.zero_forces()
    BT = springs.incidence().T.tocsr()

    def pbanim_apply():
        Q.fill(0.0)
        springs.apply(0.0, y, Q)

    def sparse_apply():
        Q.fill(0.0)
        np.add(Q, BT @ springs.spring_forces(y), out=Q)

    def add_at_apply():
        Q.fill(0.0)
        springs.apply_add_at(0.0, y, Q)

    def forces_only():
        springs.spring_forces(y)

    pbanim_apply()
    Qa = Q.copy()
    sparse_apply()
    err = float(np.max(np.abs(Q - Qa)))
    T = _interleaved({"p": pbanim_apply, "s": sparse_apply, "a": add_at_apply, "f": forces_only}, repeats, 0.02)
    t_p, t_s, t_a, t_f = T["p"], T["s"], T["a"], T["f"]
    return [["pbanim (bincount scatter)", t_p, t_p / t_s, err], ["scipy.sparse Bᵀf", t_s, 1.0, 0.0],
            ["np.add.at", t_a, t_a / t_s, 0.0], ["spring forces f only (no scatter)", t_f, t_f / t_s, 0.0]], t_p / t_s



def diagnostics_table(steps: int, rounds: int):
    """Rows (variant, record_every, µs per step, / states only) and the lazy-not-read ratio (see item 3)."""
    from ._floor_particles import KD, KS, SQ_M, SQ_PAIRS, SQ_V, SQ_X, G
    from ..particles import DampedSprings, Gravity, ParticleSystem
    from ..scene import Scene

    scene = Scene(ParticleSystem(SQ_X, SQ_V, SQ_M), [Gravity(G), DampedSprings(SQ_PAIRS, KS, KD)])
    h = 1e-3
    variants = {"states only (diagnostics=False)": lambda r: scene.simulate(steps * h, h, "rk4", record_every=r,
                                                                           diagnostics=False),
                "lazy (default), not read": lambda r: scene.simulate(steps * h, h, "rk4", record_every=r),
                "lazy (default), read after the run": lambda r: dict(
                    scene.simulate(steps * h, h, "rk4", record_every=r).diagnostics),
                "diagnostics=True (during the run)": lambda r: scene.simulate(steps * h, h, "rk4", record_every=r,
                                                                             diagnostics=True)}
    rows, lazy_ratio = [], float("nan")
    for r in (1, 10):
        times: dict = {k: [] for k in variants}
        for _ in range(rounds):
            for k, fn in variants.items():
                start = time.perf_counter()
                fn(r)
                times[k].append((time.perf_counter() - start) / steps * 1e6)
        base = np.array(times["states only (diagnostics=False)"])
        for k, v in times.items():
            ratio = float(np.median(np.array(v) / base))
            rows.append([k, r, float(np.median(v)), ratio])
            if r == 1 and k == "lazy (default), not read":
                lazy_ratio = ratio
    return rows, lazy_ratio

def float_table(sizes, steps: int, rounds: int) -> list:
    """Rows (N, coordinates, plan a run takes, µs per step on floats, vectorized, floats / vectorized)."""
    from ..particles import AnchorSprings, DampedSprings, Gravity, ParticleSystem
    from ..particles.lean import FLOAT_MAX, FloatParticles
    from ..scene import Scene

    rows, h = [], 1e-3
    for N in sizes:
        x = np.stack([np.arange(N, dtype=float), np.zeros(N)], 1)
        v = np.stack([np.zeros(N), 0.1 * np.cos(np.arange(N))], 1)
        chain = np.stack([np.arange(N - 1), np.arange(1, N)], 1)
        runs = {}
        for plan in ("floats", "vectorized"):
            scene = Scene(ParticleSystem(x, v, np.linspace(1.0, 2.0, N)),
                          [Gravity(), AnchorSprings([0], None, 50.0)] + ([DampedSprings(chain, 50.0, 0.5)] if N > 1 else []))
            scene._floats = FloatParticles(scene) if plan == "floats" else None     # either plan at any size
            runs[plan] = scene
        times: dict = {k: [] for k in runs}
        for _ in range(rounds):
            for k, scene in runs.items():
                start = time.perf_counter()
                scene.simulate(steps * h, h, "symplectic_euler", diagnostics=False)
                times[k].append((time.perf_counter() - start) / steps * 1e6)
        ratio = float(np.median(np.array(times["floats"]) / np.array(times["vectorized"])))
        rows.append([N, 2 * N, "floats" if 2 * N <= FLOAT_MAX else "vectorized", float(np.median(times["floats"])),
                     float(np.median(times["vectorized"])), ratio])
    return rows


def implicit_table(n: int, repeats: int):
    """One implicit Euler step of an n × n stiff hanging net: analytic sparse Jacobian vs finite differences."""
    from ..models.particles import hanging_net
    from ..ode import get_method

    net = hanging_net(n, n, spacing=0.1, mass=0.01, stiffness=1e4)
    scene = net.scene()
    y = net.system.state()
    y[1::3] -= 1e-3  # off equilibrium, so Newton has work to do
    step = get_method("implicit_euler").step
    ya = step(scene.rhs, 0.0, y, 1e-2, jac=scene.jac)
    yf = step(scene.rhs, 0.0, y, 1e-2)
    T = _interleaved({"a": lambda: step(scene.rhs, 0.0, y, 1e-2, jac=scene.jac),
                      "f": lambda: step(scene.rhs, 0.0, y, 1e-2)}, repeats, 0.0)
    diff = float(np.max(np.abs(ya - yf)))
    return [[f"analytic sparse Scene.jac (n = {y.size})", T["a"], 1.0, diff],
            ["finite-difference dense Jacobian", T["f"], T["f"] / T["a"], 0.0]]


def run(quick: bool = False) -> Report:
    """Run the particle benchmarks (``quick``: N ≤ 10⁵ and fewer springs, for the test suite's smoke run)."""
    rng = np.random.default_rng(1)
    sizes = [10**3, 10**4, 10**5] if quick else [10**3, 10**4, 10**5, 10**6]
    repeats = 3 if quick else 7
    rows = step_table(sizes, repeats, rng)
    rep = Report("particles")
    rep.tables.append(Table("one scene step, gravity + drag (symplectic Euler, 3-D), median seconds",
                            ["N", "scene.step", "unfolded", "numpy (N,3)", "numpy flat", "copyto(buf, y)",
                             "y.copy()", "scene/numpy", "unfolded/numpy", "scene/copyto", "max |Δy|"], rows))
    S, Ns = (10**4, 2000) if quick else (10**5, 2 * 10**4)
    srows, ratio = spring_table(S, Ns, repeats, rng)
    rep.tables.append(Table(f"damped springs: force accumulation, S = {S} springs, N = {Ns}, median seconds",
                            ["variant", "time", "/ sparse", "max |ΔQ|"], srows))
    drows, lazy_ratio = diagnostics_table(200 if quick else 1000, 3 if quick else 7)
    rep.tables.append(Table("what diagnostics cost: 4 particles, 5 damped springs, gravity, RK4 (µs per step, "
                            "medians of alternating rounds; ratio per round to states only)",
                            ["variant", "record_every", "µs / step", "/ states only"], drows))
    n = 6 if quick else 12
    rep.tables.append(Table(f"one implicit Euler step, {n}×{n} stiff hanging net (k_s = 1e4, h = 0.01), median seconds",
                            ["Jacobian", "time", "/ analytic", "max |Δy|"], implicit_table(n, 3 if quick else 5)))
    rep.tables.append(Table("small scenes, symplectic Euler (2-D, a chain of damped springs, anchor, gravity): "
                            "floats against the vectorized kick-drift (µs per step, medians of alternating rounds)",
                            ["N", "coordinates", "plan taken", "floats", "vectorized", "floats / vectorized"],
                            float_table([1, 2, 8, 16, 24] if quick else [1, 2, 4, 8, 12, 16, 24, 32],
                                        300 if quick else 1000, 3 if quick else 5)))
    for r in rows:
        rep.goals.append(Goal(f"particles-step-vs-numpy-N{r[0]:.0e}".replace("+0", ""), r[7], 1.2, "<=", "x",
                              "scene.step / faster of the two hand-written numpy steps"))
    big = rows[-1]
    rep.goals.append(Goal("particles-step-vs-bandwidth", big[9], 2.5, "<=", "x",
                          f"scene.step / np.copyto of the state into a preallocated array at N = {big[0]:.0e}"
                          + ("" if big[0] == 10**6 else " (quick mode; the goal is at N = 1e6)")))
    rep.goals.append(Goal("particles-springs-vs-sparse", ratio, 1.5, "<=", "x",
                          f"DampedSprings.apply / sparse incidence scatter at S = {S}"))
    rep.goals.append(Goal("particles-lazy-diagnostics-unread", lazy_ratio, 1.1, "<=", "x",
                          "a run with diagnostics='lazy' (the default) never read / diagnostics=False, record_every=1"))
    rep.notes.append("ratios < 1 are faster than the baseline; all timings share one run")
    rep.notes.append("scene.step folds the affine per-particle forces (gravity, drag) into v1 = alpha v0 + beta "
                     "per step size and sweeps cache-sized blocks (Scene.fold_affine; see pbanim.scene); 'unfolded' is the "
                     "same step with fold_affine = False: zero Q, gravity.apply, drag.apply, one kick-drift, "
                     "in preallocated buffers")
    return rep
