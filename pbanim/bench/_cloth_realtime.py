"""``pbanim bench cloth``: large steps in real time — one simulated second of the N × N sheet at h = 1/60 s —
and the largest stable step of each method (:func:`largest_stable_step`).

The goal of issue 29: B&W's large steps at h = 1/60 s on N = 64 (12 288 unknowns) cost ≤ 1 s of wall time
per simulated second, i.e. ≤ 16.7 ms a step. Measured here directly: 60 steps from rest (the fall; with the
line-smoothed multigrid 4.5 CG iterations a step on average at CG tolerance 10⁻², against 46 with the
ℓ1-Jacobi cycle, which grew 1 → ~50 as the sheet bends), each tolerance timed in alternating rounds with
the ℓ1-Jacobi cycle at 10⁻² as the baseline, the median and the spread printed with the mean CG iterations.

The CG tolerance ε the step needs: the CG error is set against the step's own truncation error (step
doubling, :func:`cg_error_vs_truncation`); below 1 the solve is not what limits the step's
accuracy. Measured at N = 64 (multigrid, 6 steps into the fall; the step's truncation error 1.1·10⁻³ m in
x, 0.095 m/s in v): the state's distance from the step solved to 10⁻¹⁰ is 7.5·10⁻⁶ m / 4.5·10⁻⁴ m/s at
ε = 10⁻³ (7 iterations; 0.007 / 0.005 of the truncation error), 6.0·10⁻⁵ m / 3.6·10⁻³ m/s at 10⁻² (4; 0.055 /
0.038), 1.9·10⁻⁴ m / 0.012 m/s at 3·10⁻² (3; 0.18 / 0.12). The goal row runs at 10⁻² (printed in each run).

Tried and measured, not kept: a warm start of CG from the previous step's Δv (or its linear extrapolation)
raises the iterations (N = 64, ε = 10⁻³, steps 10–30: ~145 and ~175 against ~125 from z: B&W's stopping test
is relative to the filtered right-hand side, and the previous Δv is a worse start than the prescribed
part z); the multigrid hierarchy of an earlier step reused for 10 steps (the V-cycle of a stale A) takes
150–290 iterations against ~50 (ε = 10⁻²): the falling sheet's A changes too much from step to step.

The cost per step against N (:func:`step_costs`, one step ``WARM`` steps into the fall, both
preconditioners, XPBD 1 × 10 beside it) and the check of the benchmark's CG tolerance
(:func:`cg_error_vs_truncation`) live here too; :mod:`pbanim.bench.cloth` re-exports them.

The floor of this design at N = 64, printed by each run: the assembly of A and f + K u (one pass over the
springs, :mod:`pbanim.cloth.step_system`), the V-cycle's setup (the Galerkin products, 6 banded Cholesky
factors of the line colours: LAPACK's unblocked band factor costs ~0.7 ms per colour here, a call per
row), and per CG iteration one product with A (~470 000 stored entries) and one V-cycle (~4.7 fine
products in row blocks, 12 banded solves). Measured in CPU time at N = 64, 30 steps into the fall, the
earlier design against this one in alternating processes (load 13 on 2 cores): assembly 15.4–17.5 →
4.4–5.5 ms, setup 14.4–18.4 → 13.6–19.1 ms, V-cycle 6.3–7.6 → 5.9–7.6 ms, 4.9 CG iterations, a step
93–102 → 65–74 ms. The V-cycles (iterations + 1 for the start) are ~2/3 of a step: per iteration ~6
products with A (~0.4 ms each on a quiet machine) and 12 banded solves (~0.13 ms each), ~4 ms; at 5
iterations that is ~24 ms a step before the assembly (~4 ms) and the setup (~12 ms), so the ≤ 16.7 ms a
step of the 1 s goal is out of reach with this CG and V-cycle (it needs ≤ 1 iteration's work per step).

Tried and measured, not kept: the line factors and coarse levels reused for 2 (4) steps with the finest
level's A exact: 7 (18) of 60 CG solves broke down (the stale V-cycle no longer SPD).

The CG tolerance against the step's accuracy and cost (N = 64, :func:`cg_error_vs_truncation` 6 steps into
the fall, and 60 steps from rest with the line multigrid; one loaded process, load 10-14):

=========  =====================  ====================  ================
ε          CG / truncation x, v   mean CG iterations    CPU s per sim. s
=========  =====================  ====================  ================
10⁻³       0.007, 0.005           8.8                   7.40
10⁻²       0.058, 0.040           4.55                  4.62
3·10⁻²     0.146, 0.082           3.35                  3.72
10⁻¹       0.52, 0.26             2.05                  3.06
=========  =====================  ====================  ================

(N = 16: 0.035 / 0.35 in x at 10⁻² / 10⁻¹; N = 32: 0.055 / 0.16.) Baraff & Witkin stop at a loose residual;
every ε here keeps the solve's error below the step's own truncation error, 10⁻¹ by a factor 2 only, so
the goal row keeps 10⁻² (a factor 17) and the floor line also prints the cost at 10⁻¹'s 2 iterations: even
there the step is ~3× the 16.7 ms of the goal (ORACLES J11).

Measured and not kept: a sparse direct solve of the step's A in place of CG (exact, no iterations). At N = 64,
30 steps into the fall (A of 12 288 unknowns, 467 748 stored entries, one BLAS thread, CPU time, best of 3):
SuperLU (``scipy.sparse.linalg.splu``) with COLAMD takes 412 ms a factorization (5.7·10⁶ entries in L and U;
a solve 10.9 ms), with MMD on AᵀA 500 ms, and on A pre-ordered by a geometric nested dissection of the grid
(separators two nodes wide, for the bend springs) with the natural order and diagonal pivots 292 ms (4.7·10⁶
entries; a solve 9.1 ms): one factorization is ~17× the 16.7 ms a step of the goal, and its fill is the
nested-dissection bound of a 2-D grid with 3 unknowns a node, so no ordering brings it near.

Measured and not kept: a constant preconditioner with no per-step setup, P = (M + L_α) ⊗ I₃ (every
spring's block α ŵŵᵀ + γ(𝟙 − ŵŵᵀ) of A replaced by its isotropic bound α𝟙, α = h²k + hk_d, γ ≤ α; L_α the
α-weighted graph Laplacian, the Laplacian of projective dynamics / Liu et al. 2013; pins decoupled),
factored once by a band Cholesky of the N² scalar unknowns (N = 64: half-bandwidth 128, ~60 ms) and applied
as one band solve with 3 right-hand sides (1.5 ms; a sparse LU with minimum degree 2.4 ms). It is SPD and
M ⪯ A ⪯ P on the free coordinates (eigenvalues of P⁻¹A in (0.0016, 1] on a falling 8 × 8 sheet), and the
step with it equals the direct filtered solve to ~√κ ε (~23 ε). But the small eigenvalues are the sheet's
transverse modes (a flat sheet has γ ≈ 0 across), which the P⁻¹-norm stopping test under-weights: at N = 64
(60 steps from rest, 3 alternating rounds against the line multigrid at 10⁻², load 10-13)

=========  ===================  ===========  =============================  =====================
ε          CG / truncation x, v mean CG its  CPU s per sim. s (min–max)     multigrid 10⁻² same run
=========  ===================  ===========  =============================  =====================
10⁻¹       2.85, 2.71           3.9          1.41 (1.38–1.46)               13.1 (12.2–13.7)
10⁻²       1.17, 0.68           15.7         3.90 (3.84–5.45)               13.1 (12.2–13.7)
10⁻³       0.149, 0.091         80.0         15.8 (15.3–19.5)               13.3 (12.4–13.4)
3·10⁻⁴     0.087, 0.056         122.6        26.4 (24.9–27.4)               13.3 (12.4–13.4)
=========  ===================  ===========  =============================  =====================

(CPU seconds under that load are ~3× the quiet machine's: the multigrid row reads 4.6 there.) It is 3.4×
faster at 10⁻² only where its CG error exceeds the step's truncation error (1.17); at an accuracy of the
multigrid's order (10⁻³: 0.15, the multigrid's 3·10⁻² is 0.146 at 3.35 iterations) it is slower than the
multigrid at 10⁻² (0.058). On the ch12 drape (24 × 24 Baraff–Witkin sheet with contacts, CG to 10⁻⁴) it
needed ~90 iterations against Jacobi's ~250 and the line multigrid's ~15 and was no faster than Jacobi; the
line multigrid there (21.7 iterations a step over the 360 steps against 248) took 25.5 and 26.1 CPU s against
Jacobi's 26.4 (alternating, load ~12: the readable Baraff–Witkin assembly and the V-cycle's setup on a
24 × 24 grid take what the iterations save), and its frames differ from Jacobi's by up to 0.08 m (the contacts
amplify the 10⁻⁴ solves' differences), so the figure keeps Jacobi. Not kept; the floor of the goal stands (a step needs ≲ 1 V-cycle's work to reach 16.7 ms).

Measured and not kept (same results bit for bit, no faster): the V-cycle on scipy's CSR kernel into
preallocated buffers, the colours' rows and bands gathered by precomputed indices (the band column-major
with a zero sentinel, factored in place) and the lines read through strided views of the grid instead of
index arrays: setup 17.6 → 17.7 ms, V-cycle 7.0 → 7.2 ms, 60 steps 5.19 → 5.31 CPU s (medians of 3
alternating rounds, spreads 4.85–5.27 and 4.92–5.53 s, load 13-15). The parts are bound by their work,
not by calls: at N = 64 a colour's row product costs 0.15-0.18 ms in float64 and in float32 alike, its
band solve 0.13 ms (spbtrs 0.125), its band factor 0.6-0.7 ms (spbtrf the same), the gather of its rows
0.6 ms, the Galerkin product 1.2 ms, a product with the fine A 0.57 ms, the levels below the finest 0.47 ms
per cycle (all CPU time under load 11-14): a V-cycle is 10 colour products, 12 band solves, a fine product
and the coarse levels, ~5-7 ms; a setup 6 factors and 6 gathers, ~10-17 ms. The whole hierarchy (every level, every factor) built from the
previous step's A on every other step, an SPD V-cycle still: CG iterations 4.55 → 18.9 at ε = 10⁻² (4.4 →
10.9-11.7 CPU s per simulated second), 2.05 → 5.12 at 10⁻¹ (2.8-3.3 → 4.3-4.5 s), two rounds each. Two
colours per axis instead of three (the bend springs' couplings between lines of one colour left out of the
line blocks and their |a_ij| added to the blocks' diagonals, ℓ1-style, which keeps the sweep convergent):
CG iterations 4.55 → 4.72 at 10⁻², 2.05 → 1.95 at 10⁻¹, CPU s 4.98/5.57 → 4.85/5.16 and 3.55/3.89 →
3.48/3.69 (two alternating rounds): under 10 %, inside the spread.

Measured and not kept (N = 64, 30 steps into the fall, CG to 10⁻², one BLAS thread, idle machine; the line
multigrid there: 5 iterations, Δv within 0.096 m/s of the solve to 10⁻¹⁰):

* a preconditioner with no setup but the sheet's frames: per particle an orthonormal frame (t_u, t_w, n) from
  central differences of the grid, the two tangential components solved by a constant-coefficient operator
  of the flat sheet (m̄ + α_s L_axis + the shear and bend springs' Laplacians, diagonal in the 2-D cosine
  basis: one DCT pair, 0.50 ms a call with the rotations), the normal one by A's diagonal projected on n.
  22 iterations, and Δv within 0.85 m/s only (the mass alone on the normal: 99 iterations); matching the
  multigrid's error needs ε = 10⁻³ and 153 iterations. The hanging sheet's tension gives the normal direction
  a stiffness γ(𝟙 − ŵŵᵀ) concentrated at the pins, which no constant operator and no diagonal represents.
* a stale exact preconditioner: SuperLU of the free block of A at step 30, used for the steps 1, 2, 4, 8 later:
  38, 55, 158, 317 iterations; turned by each particle's frame rotation Q_i(t) Q_i(30)ᵀ: 41, 41, 67, 117.
  A is not a rotated copy of an earlier A: γ = h² s⁺/|d| follows the springs' tension s = k C + k_d Ċ, whose
  strain rates change from step to step, so no factorization or hierarchy can be amortised over steps (the
  reused hierarchies above agree).
* a cheaper product with A: 0.37 ms in CSR, 0.38 ms in 3 × 3 BSR, 0.38 ms in float32 (0.61 in BSR float32);
  its 467 748 values and indices are 5.6 MB, read at ~15 GB/s: the product is bound by memory, not by calls.

So per step the assembly (3.4 ms) and the hierarchy's setup (9.6 ms) alone leave 3.7 ms of the 16.7 ms
budget, less than one V-cycle (4.6 ms) and its product with A; and the loosest tolerance whose CG error stays
below the step's truncation error (10⁻¹, 2 iterations) measured 36.9 ms a step (2.21 CPU s per simulated
second, idle machine, 2026-11-29; 10⁻²: 3.39 s, and 2.69 s in another process under the profiler).

Profiled again (cProfile, N = 64, 30 steps 6 steps into the fall, CG to 10⁻², one BLAS thread): the V-cycles
(row-block products in the line sweeps and the band solves) are ~2/3 of a step, the setup (6 band factors,
Galerkin products) ~1/4, the one-pass assembly ~1/12; the filter and the contact search (no colliders) are
negligible. The lean PCG (:mod:`pbanim.cloth.lean_pcg`, the same iterates bit for bit) changes 60 steps
3.46 (3.35–3.59) → 3.35 (3.27–3.39) CPU s (alternating, load ~3): the CG's own work around the V-cycle is
small here. With two BLAS threads on a busy machine the coarsest level's Cholesky (192 × 192) alone took
~186 ms a setup (0.5–0.7 ms on one thread): the row is timed under ``one_blas_thread`` as every benchmark.
"""

from __future__ import annotations

import time

import numpy as np

from . import median_time
from ..cloth import large_step, xpbd_step
from ..cloth.assembly import free_ode
from ..cloth.large_steps import PRECONDITIONERS
from ..cloth.step_system import spring_system
from ..contracts import Choice, Flag, Int, Real, Seq, contract, unchecked
from ..errors import PbanimError

_large_step, _xpbd_step = unchecked(large_step), unchecked(xpbd_step)

H = 1.0 / 60.0
CG_TOL = 1e-3            # large steps at h = 1/60: CG error ≤ 0.1× the step's truncation error (cg_error_vs_truncation)
RT_TOLS = (1e-2, 1e-3)   # CG tolerances of the N = 64 real-time row (the first is the goal's)
WARM = 6                 # steps into the fall where a step is timed (the first ones need few CG iterations)


def _sheet(n, stretch=1e3):
    from .cloth import sheet                            # the benchmark's sheet (imported when called: no cycle)
    return sheet(n, stretch)


def one_second(cloth, tol: float, precond: str = "multigrid") -> tuple[float, float, float]:
    """(wall s, CPU s of this process, mean CG iterations) of 60 large steps of h = 1/60 s from rest."""
    y, its = cloth.state(), 0
    start, cpu = time.perf_counter(), time.process_time()
    for _ in range(60):
        y, sol = _large_step(cloth, y, H, tol, 20000, precond)
        its += sol.iterations
    return time.perf_counter() - start, time.process_time() - cpu, its / 60.0


def wall_per_simulated_second(cloth, tols=(1e-2, 1e-3), rounds: int = 3, precond: str = "multigrid",
                              baseline=()) -> dict:
    """{(tol, precond): (median CPU s, min, max, mean CG iterations, median wall s)} over ``rounds`` alternating
    rounds of ``precond`` at every tol and of each (tol, precond) of ``baseline`` (CPU seconds of this process:
    on an idle machine with one BLAS thread, the wall time)."""
    keys = [(t, precond) for t in tols] + [k for k in baseline if k not in [(t, precond) for t in tols]]
    runs: dict = {k: [] for k in keys}
    for _ in range(rounds):
        for t, pc in keys:
            runs[t, pc].append(one_second(cloth, t, pc))
    return {k: (float(np.median([c for _, c, _ in r])), min(c for _, c, _ in r), max(c for _, c, _ in r),
                float(np.mean([i for _, _, i in r])), float(np.median([w for w, _, _ in r])))
            for k, r in runs.items()}


def _cpu_median(fn, repeats: int = 5) -> float:
    """Median CPU seconds of this process over ``repeats`` calls of ``fn()`` (the row's own clock: on a shared
    machine the wall clock counts the other jobs, measured 4× the CPU time at load 10-14)."""
    times = []
    for _ in range(repeats):
        start = time.process_time()
        fn()
        times.append(time.process_time() - start)
    return float(np.median(times))


def floor_per_step(cloth, its: float) -> tuple[float, str]:
    """(the least time of one multigrid step here, its parts): assembly + V-cycle setup + its × (A product +
    V-cycle), each part timed on its own in CPU time, as the row (median of 5), at the state 30 steps into
    the fall. The filter and the contact search are left out (a pinned sheet without colliders: ~0.01 ms)."""
    y = cloth.state()
    for _ in range(30):
        y = _large_step(cloth, y, H, 1e-2, 20000, "multigrid")[0]
    n = cloth.n
    x, v, u = y[:n].reshape(-1, 3), y[n:].reshape(-1, 3), H * y[n:]
    system = spring_system(cloth)
    if system is not None:                                  # what the step assembles: A.data and f + K u
        t_asm = _cpu_median(lambda: system.terms(x, v, u, H), repeats=5)
    else:
        jacobians = unchecked(cloth.jacobians)
        t_asm = _cpu_median(lambda: jacobians(y), repeats=5)
    mg = cloth._multigrid["multigrid"]                      # set up by the last step on its own SPD A
    A = mg.A[0]
    data = A.data.copy()
    t_setup = _cpu_median(lambda: mg.setup(data), repeats=5)
    r = np.random.default_rng(0).standard_normal(cloth.n)
    t_mv = _cpu_median(lambda: A @ r, repeats=5)
    t_pc = _cpu_median(lambda: mg(r), repeats=5)
    total = t_asm + t_setup + its * (t_mv + t_pc) + t_pc
    loose = t_asm + t_setup + 2 * (t_mv + t_pc) + t_pc      # CG to 10⁻¹: 2 iterations (module docstring)
    return total, (f"assembly of A and f + K u {1e3 * t_asm:.1f} ms + V-cycle setup {1e3 * t_setup:.1f} ms + {its:.0f} CG "
                   f"iterations (+1 for the start) × ({1e3 * t_mv:.2f} ms A product [{A.nnz} entries] + {1e3 * t_pc:.2f} ms "
                   f"V-cycle: line Gauss–Seidel, ~4 fine A products in row blocks) "
                   f"= {1e3 * total:.1f} ms a step, {60 * total:.2f} s per simulated second; at CG 1e-1 (2 iterations, "
                   f"CG error ~0.5× the step's truncation error) {1e3 * loose:.1f} ms, {60 * loose:.2f} s: the goal's "
                   f"16.7 ms a step is exceeded by the setup and three V-cycles alone")


@contract(sizes=Seq(Int(ge=2, le=256), min_len=1, max_len=8), repeats=Int(ge=1, le=20),
          precond=Choice(PRECONDITIONERS), tol=Real(gt=0, lt=1))
def step_costs(sizes=(16, 32, 64), repeats: int = 2, precond: str = "jacobi", tol: float = CG_TOL) -> dict:
    """{N: (large step s, its CG iterations, XPBD 1 × 10 s)} at h = 1/60 s, medians of ``repeats`` steps from
    the state ``WARM`` steps into the fall (the CG iterations of that step counted), CG to ``tol`` with
    ``precond``."""
    out = {}
    for n in sizes:
        cloth = _sheet(n)
        y = cloth.state()
        for _ in range(WARM):
            y = _large_step(cloth, y, 1.0 / 60.0, tol, 20000, precond)[0]
        its = _large_step(cloth, y, 1.0 / 60.0, tol, 20000, precond)[1].iterations
        t_ls = median_time(lambda: _large_step(cloth, y, 1.0 / 60.0, tol, 20000, precond), repeats=repeats)
        _xpbd_step(cloth, y, 1.0 / 60.0, 1, 10)                       # colouring once
        t_x = median_time(lambda: _xpbd_step(cloth, y, 1.0 / 60.0, 1, 10), repeats=repeats)
        out[n] = (t_ls, its, t_x)
    return out


@contract(n=Int(ge=4, le=256), tol=Real(gt=0, lt=1), precond=Choice(PRECONDITIONERS))
def cg_error_vs_truncation(n: int, tol: float = CG_TOL, precond: str = "jacobi") -> tuple[float, float]:
    """(CG error / local truncation error) in x and in v of one large step at h = 1/60 s, ``WARM`` steps into
    the fall: the CG error against the same step solved to 10⁻¹⁰, the truncation error estimated by step
    doubling (the step of h against two of h/2, both solved to 10⁻¹⁰). Below 1: the solve is not what
    limits the step's accuracy."""
    cloth, h = _sheet(n), 1.0 / 60.0
    y = cloth.state()
    for _ in range(WARM):
        y = _large_step(cloth, y, h, tol, 20000, precond)[0]
    tight = _large_step(cloth, y, h, 1e-10, 50000, "multigrid")[0]
    half = _large_step(cloth, _large_step(cloth, y, h / 2, 1e-10, 50000, "multigrid")[0], h / 2, 1e-10, 50000,
                       "multigrid")[0]
    y1 = _large_step(cloth, y, h, tol, 20000, precond)[0]
    k = cloth.n
    return tuple(float(np.abs(y1[s] - tight[s]).max() / np.abs(half[s] - tight[s]).max())
                 for s in (slice(None, k), slice(k, None)))


def _stable(step, y, v0: int, h, t_end=0.2):
    """Whether ``step(y, h)`` runs the state y (its velocities from entry ``v0`` on) for ``t_end`` s without a
    non-finite state, a :class:`~pbanim.errors.PbanimError` or a speed above 20 m/s."""
    with np.errstate(all="ignore"):
        for _ in range(max(1, int(round(t_end / h)))):
            try:
                y = step(y, h)
            except PbanimError:                          # SimulationDiverged: a non-finite state
                return False
            if not np.isfinite(y).all() or np.abs(y[v0:]).max(initial=0.0) > 20.0:
                return False
    return True


def _free_symplectic(f, nf: int):
    """Symplectic Euler on the free state [x_F, v_F] (``f`` its right-hand side), in place: the step the search
    runs through the full state, without a full state made and split again each step (the pinned particles
    rest at their places, at rest: finite, below the speed bound; the same verdict, ORACLES J16)."""
    def step(yf, h):
        a = f(0.0, yf)[nf:]
        yf[nf:] += h * a
        yf[:nf] += h * yf[nf:]
        return yf
    return step


@contract(method=Choice(("large steps", "XPBD", "symplectic Euler")), stretch=Real(gt=0, le=1e9),
          n=Int(ge=2, le=64), lean=Flag())
def largest_stable_step(method: str, stretch: float = 1e3, n: int = 8, lean: bool = True) -> float:
    """The largest h = 0.1 · 2⁻ʲ (j = 0 … 14) at which ``method`` runs the sheet for 0.2 s without blowing up
    (symplectic Euler on the free state unless ``lean`` is False: :func:`_free_symplectic`, the same answer)."""
    cloth = _sheet(n, stretch)
    f = free_ode(cloth)[0]                       # Cloth.rhs in one pass over the springs (ORACLES J11)
    free_state, full_state = unchecked(cloth.free_state), unchecked(cloth.full_state)
    free_step = _free_symplectic(f, cloth.nf)
    if lean and method == "symplectic Euler":
        y0, v0, step = free_state(cloth.state()), cloth.nf, free_step
    else:
        y0, v0 = cloth.state(), cloth.n
        step = {"large steps": lambda y, h: _large_step(cloth, y, h, 1e-6, 20000)[0],
                "XPBD": lambda y, h: _xpbd_step(cloth, y, h, 1, 10),
                "symplectic Euler": lambda y, h: full_state(free_step(free_state(y), h))}[method]
    for j in range(15):
        h = 0.1 * 2.0 ** -j
        if _stable(step, y0.copy(), v0, h):
            return h
    return 0.0



def realtime_goal(rep, cloth) -> None:
    """The N = 64 real-time row of ``pbanim bench cloth`` (module docstring): 60 large steps of h = 1/60 s from
    rest with the line multigrid at each CG tolerance of ``RT_TOLS`` and the ℓ1-Jacobi cycle at the first,
    alternating rounds; the goal at ``RT_TOLS[0]`` with its CG error / truncation error and its floor."""
    from . import Goal
    rt = wall_per_simulated_second(cloth, RT_TOLS, 3, baseline=[(RT_TOLS[0], "multigrid-l1")])
    for (tol, pc), (med, lo, hi, its, wall) in rt.items():
        rep.notes.append(f"N = 64, h = 1/60 s, {pc}, CG to {tol:g}: one simulated second (60 steps from "
                         f"rest) takes {med:.2f} CPU s (median of 3 alternating rounds, {lo:.2f}–{hi:.2f}; "
                         f"wall {wall:.2f} s), {its:.1f} CG iterations a step on average")
    base = rt[RT_TOLS[0], "multigrid-l1"][0]
    rt = {t: rt[t, "multigrid"] for t in RT_TOLS}
    rep.notes.append(f"N = 64, CG to {RT_TOLS[0]:g}: line-smoothed multigrid / ℓ1-Jacobi multigrid (the earlier "
                     f"default), CPU s per simulated second, medians of the same alternating rounds: "
                     f"{rt[RT_TOLS[0]][0] / base:.2f}")
    small = wall_per_simulated_second(_sheet(32), RT_TOLS[:1], 3)[RT_TOLS[0], "multigrid"]
    rep.notes.append(f"N = 32 (3 072 unknowns), the same h, multigrid and CG tolerance: one simulated second takes "
                     f"{small[0]:.2f} CPU s (median of 3 rounds, {small[1]:.2f}–{small[2]:.2f}), {small[3]:.1f} CG "
                     f"iterations a step: {'within' if small[0] <= 1.0 else 'over'} real time on this machine")
    ex, ev = cg_error_vs_truncation(cloth.sheet.n, RT_TOLS[0], "multigrid")
    floor, parts = floor_per_step(cloth, rt[RT_TOLS[0]][3])
    rep.goals.append(Goal("large_steps_N64_wall_per_simulated_s", rt[RT_TOLS[0]][0], 1.0, "<=", " s",
                          f"h = 1/60 s, multigrid, CG to {RT_TOLS[0]:g} (CG error / truncation error {ex:.2f} "
                          f"in x, {ev:.2f} in v: below 1), CPU s of this process, spread {rt[RT_TOLS[0]][1]:.2f}–"
                          f"{rt[RT_TOLS[0]][2]:.2f} s, wall {rt[RT_TOLS[0]][4]:.2f} s; floor of this design here: "
                          f"{parts} — {60 * floor:.1f}× the 1 s goal's 16.7 ms a step; not meetable in numpy/scipy "
                          "with this CG"))
