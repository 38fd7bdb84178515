"""Projected Gauss–Seidel with moving and fixed bounds: box friction, joint limits (chapters 07–08).

For w = A z + b, one sweep visits the rows in turn and moves each unknown to the value that zeroes its
own wᵢ, then projects it onto its bounds:

    zᵢ ← clip(zᵢ − wᵢ / Aᵢᵢ, loᵢ, hiᵢ),   w ← w + A₍:,ᵢ₎ Δzᵢ,

with [0, ∞) for a normal impulse (the LCP fᵢ ≥ 0 ⊥ wᵢ ≥ 0), [−μfᵢ, μfᵢ] for a tangential one (box
friction: the bounds move with the contact's own normal impulse) and given [loᵢ, hiᵢ] for joint limits
and motors. It is the sequential-impulse method of game engines; it converges for a symmetric positive
definite A (Gauss–Seidel on the QP), slowly when A is ill conditioned, and its residual after the sweep
budget is reported, never hidden. The plain LCP sweep (``pgs``, the chapter 07 assignment) is in
:mod:`pbanim.lcp.solve`; the colored, vectorized box-friction sweep is :mod:`pbanim.lcp.colored`.

The box-friction problem is not monotone (the bounds ±μfᵢ move with fᵢ), and for A positive definite
two solvers reach its answer in very different ways: PGS converges linearly at a rate set by how strongly
the rows are coupled (a ragdoll lying on a dozen redundant points stops at its sweep cap), while the active
set (:func:`pbanim.lcp.active_set.box_friction_active_set`) is exact once its guess of the states
sᵢ = (on/off, stick/+μf/−μf per tangent) is right but can cycle between two wrong guesses when a contact
slides. :func:`box_friction_handoff` uses each for what it does well: the active set from the caller's guess
(the contacts' states at the previous step); if it does not certify, PGS sweeps from zero in growing chunks
(10, 20, 40, …, at most ``max_iter`` sweeps in all) and after each chunk the active set from the state the
PGS iterate shows (:func:`box_state`). Each answer is certified by its own solver's residual at
tol·max(1, ‖b‖∞); after ``max_iter`` sweeps without it, the PGS iterate is returned flagged uncertified.

=========  ===========  ==========  =================================================
symbol     code         shape       meaning
=========  ===========  ==========  =================================================
z          ``f``/``z``  (m,)        impulses (normal; or [f, τ₁, τ₂] per contact)
w          ``w``        (m,)        A z + b
μ          ``mu``       (m/3,)      friction coefficient per contact
=========  ===========  ==========  =================================================

Limiting cases: a diagonal A is solved in one sweep; μ = 0 keeps the tangential impulses at zero.

References: K. G. Murty, *Linear Complementarity, Linear and Nonlinear Programming* (1988), ch. 9;
E. Catto, "Iterative dynamics with temporal coherence", GDC 2005; J. J. Júdice, F. M. Pires, Comput. Oper.
Res. 21 (1994) (block pivoting).
"""

from __future__ import annotations

import numpy as np

from .active_set import box_friction_active_set
from .box_lean import LEAN_ROWS, box_sweeps_floats, project_impulses
from .pivoting import _check, _scale
from .specs import LCP_ENTRIES
from ..contracts import Array, Int, Opt, Real, contract
from ..errors import InvalidInput

__all__ = ["pgs_box_friction", "pgs_bounded"]


def _contacts_of(env) -> int:
    """m = n/3 contacts of a box-friction problem with n = b.size rows (normal, two tangents each)."""
    return np.size(env.values["b"]) // 3


_SQUARE = Array(("n", "n"), **LCP_ENTRIES)
_RHS = Array(("n",), **LCP_ENTRIES)


@contract(A=_SQUARE, b=_RHS, mu=Array((_contacts_of,), ge=0, scalar=True), max_iter=Int(ge=1),
          tol=Real(gt=0, lt=1), warm_start=Opt(Array(("n",))))
def pgs_box_friction(A: np.ndarray, b: np.ndarray, mu, *, max_iter: int = 300, tol: float = 1e-8,
                     warm_start=None) -> tuple:
    """Projected Gauss–Seidel for contact with box friction; unknowns per contact i: (fᵢ, tᵢ₁, tᵢ₂).

    w = A z + b with z ordered [f₁, t₁₁, t₁₂, f₂, …]: fᵢ ≥ 0 ⊥ w_fᵢ ≥ 0 and each tangential impulse
    in [−μ fᵢ, μ fᵢ] with w = 0 inside (the friction pyramid aligned with (t₁, t₂)). Each row is clamped
    in turn, w updated incrementally; at most ``max_iter`` sweeps. Returns (z, residual, sweeps) with the
    residual the largest violation of those conditions (the caller decides what it accepts).
    ``warm_start`` (3m,): the previous impulses (contact persistence), projected onto the bounds first.
    """
    A, b = _check(A, b)
    n = b.size
    if n % 3:
        raise InvalidInput(f"pgs_box_friction: A and b must have 3 rows per contact (normal, two tangents), "
                           f"got {n} rows")
    mu = np.broadcast_to(np.asarray(mu, dtype=float), (n // 3,))
    diag = np.diag(A).copy()
    if not np.all(diag > 0):
        raise InvalidInput(f"pgs_box_friction: A must have a positive diagonal (add a little regularization), got "
                           f"min A_ii = {diag.min():.3g}")
    z = _warm_impulses(warm_start, n, mu)
    if n <= LEAN_ROWS:                 # the same sweep on floats: the same iterates, bit for bit (box_lean)
        return box_sweeps_floats(A, b, mu, diag, z, int(max_iter), tol * _scale(b))
    return _box_sweeps(A, b, mu, diag, z, int(max_iter), tol)


def _box_sweeps(A, b, mu, diag, z, max_iter: int, tol: float) -> tuple:
    """The readable sweep of :func:`pgs_box_friction` from its first iterate z (the reference of
    :func:`pbanim.lcp.box_lean.box_sweeps_floats`, which answers up to its ``LEAN_ROWS`` rows)."""
    n = b.size
    w = A @ z + b
    for sweep in range(1, int(max_iter) + 1):
        for r in range(n):
            i, kind = divmod(r, 3)
            lo, hi = (0.0, np.inf) if kind == 0 else (-mu[i] * z[3 * i], mu[i] * z[3 * i])
            new = min(max(z[r] - w[r] / diag[r], lo), hi)
            if new != z[r]:
                w += A[:, r] * (new - z[r])
                z[r] = new
        res = _box_residual(z, w, mu)
        if res <= tol * _scale(b):
            return z, res, sweep
    return z, _box_residual(z, w, mu), int(max_iter)


_BOUND = Array(("n",), finite=False, scalar=True)


@contract(A=_SQUARE, b=_RHS, lo=_BOUND, hi=_BOUND, max_iter=Int(ge=1), tol=Real(gt=0, lt=1))
def pgs_bounded(A: np.ndarray, b: np.ndarray, lo, hi, *, max_iter: int = 500, tol: float = 1e-10) -> tuple:
    """Projected Gauss–Seidel for the box-constrained problem w = A z + b, loᵢ ≤ zᵢ ≤ hiᵢ, with wᵢ ≥ 0 at
    zᵢ = loᵢ, wᵢ ≤ 0 at zᵢ = hiᵢ and wᵢ = 0 in between (joint limits: [0, ∞); motors: [−F, F]).

    Returns (z, residual, sweeps); at most ``max_iter`` sweeps (the caller decides what it accepts).
    """
    A, b = _check(A, b)
    n = b.size
    lo = np.broadcast_to(np.asarray(lo, dtype=float), (n,))
    hi = np.broadcast_to(np.asarray(hi, dtype=float), (n,))
    if not (np.all(lo <= hi) and np.all(lo < np.inf) and np.all(hi > -np.inf)):   # NaN fails too
        raise InvalidInput(f"pgs_bounded: lo and hi must satisfy lo <= hi with lo < inf and hi > -inf (a finite z "
                           f"in each box), got lo = {lo}, hi = {hi}")
    diag = np.diag(A).copy()
    if not np.all(diag > 0):
        raise InvalidInput(f"pgs_bounded: A must have a positive diagonal, got min A_ii = {diag.min():.3g}")
    z = np.clip(np.zeros(n), lo, hi)
    w = A @ z + b
    res = np.inf
    for sweep in range(1, int(max_iter) + 1):
        for r in range(n):
            new = min(max(z[r] - w[r] / diag[r], lo[r]), hi[r])
            if new != z[r]:
                w += A[:, r] * (new - z[r])
                z[r] = new
        free = (z > lo) & (z < hi)
        res = float(np.max(np.abs(np.where(free, w, np.where(z <= lo, np.minimum(w, 0), np.maximum(w, 0)))),
                           initial=0.0))
        if res <= tol * _scale(b):
            return z, res, sweep
    return z, res, int(max_iter)


def _warm_impulses(warm_start, n: int, mu: np.ndarray) -> np.ndarray:
    """The first iterate of a box-friction sweep: zero, or ``warm_start`` (3m,) projected onto the bounds
    (fᵢ ≥ 0, |τᵢⱼ| ≤ μfᵢ) — the previous step's impulses of persisting contacts."""
    z = np.zeros(n)
    if warm_start is not None:
        z = np.array(warm_start, dtype=float)
        if z.shape != (n,) or not np.all(np.isfinite(z)):
            raise InvalidInput(f"warm_start must be a finite array of shape ({n},), got shape {z.shape}")
        project_impulses(z, mu)
    return z


def _box_residual(z, w, mu) -> float:
    f, t = z[0::3], np.stack([z[1::3], z[2::3]], axis=1)
    wn, wt = w[0::3], np.stack([w[1::3], w[2::3]], axis=1)
    inside = np.abs(t) < (mu * f)[:, None] * (1 - 1e-12)
    r_n = np.abs(np.minimum(f, wn)) if f.size else np.zeros(0)
    r_t = np.where(inside, np.abs(wt), 0.0)
    return float(max(np.max(r_n, initial=0.0), np.max(r_t, initial=0.0)))


CHUNKS = (10, 20, 40, 80)       # PGS sweeps between two active-set attempts; then 160 each


def box_state(z: np.ndarray, mu: np.ndarray, rel: float = 1e-9) -> np.ndarray:
    """The states (m, 3) that impulses z (3m,) show: on where fᵢ > 0; a tangent at +1 (−1) where it lies on
    +μfᵢ (−μfᵢ) to ``rel`` relative, 0 (sticking) inside; an off contact's tangents 0."""
    f, t = z[0::3], np.stack([z[1::3], z[2::3]], axis=1)
    lim = (mu * f)[:, None] * (1 - rel)
    state = np.zeros((f.size, 3), dtype=int)
    state[:, 0] = f > 0
    state[:, 1:] = np.where(f[:, None] > 0, np.where(t >= lim, 1, np.where(t <= -lim, -1, 0)), 0)
    return state


def box_friction_handoff(A: np.ndarray, b: np.ndarray, mu: np.ndarray, *, state=None, max_iter: int = 300,
                         tol: float = 1e-8) -> tuple:
    """The box-friction impulses (see the module docstring). A (3m, 3m) positive definite, b (3m,), μ (m,),
    ``state`` (m, 3) the first guess (None: on where b_f < 0, sticking). Returns (z, residual, sweeps,
    state, certified): ``sweeps`` the PGS sweeps spent (0 when the first guess was right), ``state`` the
    active set's for the next step's guess (from z when PGS answered)."""
    n = b.size
    mu = np.broadcast_to(np.asarray(mu, dtype=float), (n // 3,))
    bar = tol * max(1.0, float(np.max(np.abs(b)))) if n else tol
    if state is not None:
        z, res, _, s = box_friction_active_set(A, b, mu, state=state, tol=tol)
        if res <= bar:
            return z, res, 0, s, True
    z, done, k = np.zeros(n), 0, 0
    while done < max_iter:
        chunk = min(CHUNKS[k] if k < len(CHUNKS) else 2 * CHUNKS[-1], max_iter - done)
        k += 1
        z, res, sweeps = pgs_box_friction(A, b, mu, max_iter=chunk, tol=tol, warm_start=z)
        done += sweeps
        if sweeps < chunk or res <= bar:                      # PGS itself reached tol
            return z, res, done, box_state(z, mu), True
        za, resa, _, s = box_friction_active_set(A, b, mu, state=box_state(z, mu), tol=tol)
        if resa <= bar:
            return za, resa, done, s, True
    return z, res, done, box_state(z, mu), False
