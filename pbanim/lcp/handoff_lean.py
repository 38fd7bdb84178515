"""The box-friction hand-off of :func:`pbanim.lcp.box.box_friction_handoff` with its active set on floats.

In a stepping simulation the contacts' states sᵢ (on/off; sticking, or sliding at ±μfᵢ per tangent) rarely
change from one step to the next, so the hand-off's first guess — the last step's states — is almost always
right and its first active-set round certifies: one solve on the unknowns

    U = {fᵢ : sᵢ on} ∪ {τᵢⱼ : sᵢ on, sticking},   the sliding τᵢⱼ = ±μfᵢ mapped onto their fᵢ (columns P),
    (A_U P + ρ𝟙) Δ = −(A_U P x + b_U)   (proximal refinement; Cholesky when nothing slides, LU otherwise),

then w = A z + b, the states z and w show (fᵢ ≥ −θ stays on, w_fᵢ < −θ comes on, a sticking τ past μfᵢ + θ
slides, a sliding τ whose w pushes back sticks; θ = 0.1·tol·max(1, ‖b‖∞)) and the residual against
tol·max(1, ‖b‖∞). The library makes each round with a dozen array calls (index sets, stacks, ``np.where``
chains) and the hand-off's PGS chunks read their states by arrays too. Here the solve is made by the same
LAPACK calls on the same arrays (so its bits) and the state test, the residual and the PGS iterate's states
(:func:`~pbanim.lcp.box.box_state`) on lists of floats — the same comparisons, products and maxima as
:func:`pbanim.lcp.active_set.box_friction_active_set`, :func:`~pbanim.lcp.active_set.box_friction_residual`
and the hand-off make, in their order; the PGS chunks are the library's own sweep. So the answer, residual,
sweep count, states and certificate are the library's bit for bit (``tests/test_handoff_lean.py``, ORACLES
I14); what changes is the cost of a round (measured on the 3-D walk's problems of 12–24 rows: ~5× less).
"""

from __future__ import annotations

import numpy as np
from scipy.linalg.lapack import dgetrf, dgetrs, dpotrf, dpotrs

from ..contracts import unchecked
from .box import CHUNKS, pgs_box_friction

__all__: list = []      # internal: the lean contact step of the 3-D biped calls it (pbanim.control.biped3d_lean)

_TINY = float(np.finfo(float).tiny)
RHO_REL, REFINE, ROUNDS, PATIENCE = 1e-10, 3, 30, 3      # box_friction_active_set's defaults, as the hand-off calls it
_pgs = unchecked(pgs_box_friction)


def handoff_floats(A: np.ndarray, b: np.ndarray, mu: float, state: list, *, max_iter: int, tol: float) -> tuple:
    """:func:`~pbanim.lcp.box.box_friction_handoff` (A, b, μ𝟙, state) → (z, residual, sweeps, state, certified),
    ``state`` a list of m (on, s₁, s₂) int triples and the returned state such a list. A (3m, 3m) positive
    definite, b (3m,) with m ≥ 1, one μ ≥ 0 for every contact, all the caller's own (no checks)."""
    big = _big(b)
    bar = tol * big
    z, res, _, s = _active_set(A, b, mu, [tuple(x) for x in state], tol, big)
    if res <= bar:
        return z, res, 0, s, True
    m = len(state)
    mus = np.full(m, mu)
    z, done, k = np.zeros(b.size), 0, 0
    while done < max_iter:                                 # the hand-off's PGS chunks (its cap: max_iter sweeps)
        chunk = min(CHUNKS[k] if k < len(CHUNKS) else 2 * CHUNKS[-1], max_iter - done)
        k += 1
        z, res, sweeps = _pgs(A, b, mus, max_iter=chunk, tol=tol, warm_start=z)
        done += sweeps
        if sweeps < chunk or res <= bar:
            return z, res, done, _box_state(z.tolist(), mu), True
        za, resa, _, s = _active_set(A, b, mu, _box_state(z.tolist(), mu), tol, big)
        if resa <= bar:
            return za, resa, done, s, True
    return z, res, done, _box_state(z.tolist(), mu), False


def _big(b) -> float:
    """max(1, ‖b‖∞)."""
    big = 1.0
    for x in b.tolist():
        if x < 0.0:
            x = -x
        if x > big:
            big = x
    return big


def _active_set(A, b, mu: float, s: list, tol: float, big: float) -> tuple:
    """box_friction_active_set(A, b, μ𝟙, state=s, tol=tol) → (z, residual, rounds, state): its rounds, its stop
    on an unchanged state or on ``PATIENCE`` rounds without a better residual, at most ``ROUNDS`` rounds."""
    thr = 0.1 * tol * big
    rho = RHO_REL * max(float(A.diagonal().max()), _TINY)
    best, worse = float("inf"), 0
    z = np.zeros(b.size)
    zl, w = z.tolist(), b.tolist()
    it = 0
    for it in range(1, ROUNDS + 1):
        z = _solve(A, b, mu, s, rho)
        zl, w = z.tolist(), (A @ z + b).tolist()
        new = _states(zl, w, mu, s, thr)
        if new == s:
            break
        res = _residual(zl, w, mu)
        if res < best:
            best, worse = res, 0
        else:
            worse += 1
            if worse >= PATIENCE:
                break
        s = new
    return z, _residual(zl, w, mu), it, s


def _solve(A, b, mu: float, s: list, rho: float) -> np.ndarray:
    """z of the guess s: the library's index sets, matrices and LAPACK calls (module docstring)."""
    n = b.size
    cf, ct, slide = [], [], []
    for i, (on, s1, s2) in enumerate(s):
        if on:
            cf.append(3 * i)
            for j, sj in ((1, s1), (2, s2)):
                if sj:
                    slide.append((3 * i + j, len(cf) - 1, sj * mu))     # τ = ±μ f: the column of f, ±μ
                else:
                    ct.append(3 * i + j)
    z = np.zeros(n)
    if not cf:
        return z
    unk = np.array(cf + ct)
    rhs = -b[unk]
    if not slide:                                          # A's principal block: Cholesky (LU if it fails)
        M = A[unk[:, None], unk]
    else:                                                  # columns mapped by P: LU
        nf = len(cf)
        P = np.zeros((n, unk.size))
        P[cf, np.arange(nf)] = 1.0
        P[ct, nf + np.arange(len(ct))] = 1.0
        r_, c_, v_ = zip(*slide)
        P[list(r_), list(c_)] = v_
        M = A[unk] @ P
    K = M.copy()
    K.flat[::K.shape[0] + 1] += rho
    info = 1
    if not slide:
        L, info = dpotrf(K, lower=1, clean=0)
    if info == 0:
        solve = lambda r: dpotrs(L, r, lower=1)[0]                      # noqa: E731
    else:
        lu, piv, info = dgetrf(K)
        if info < 0:
            raise np.linalg.LinAlgError(f"LU factorization failed (LAPACK info {info})")
        solve = lambda r: dgetrs(lu, piv, r)[0]                         # noqa: E731
    x = solve(rhs)
    stop = 1e-14 * max(1.0, abs(rhs).max())
    for _ in range(REFINE):
        r = rhs - M @ x
        if abs(r).max() <= stop:
            break
        x += solve(r)
    if slide:
        return P @ x
    z[unk] = x
    return z


def _states(zl: list, w: list, mu: float, s: list, thr: float) -> list:
    """The states z and w show from the guess s (box_friction_active_set's update)."""
    new = []
    for i, (on, s1, s2) in enumerate(s):
        r = 3 * i
        f = zl[r]
        on1 = int(f >= -thr) if on else int(w[r] < -thr)
        if not on1:
            new.append((0, 0, 0))
            continue
        lim = mu * f
        nt = []
        for k, sk in ((r + 1, s1), (r + 2, s2)):
            t, wt = zl[k], w[k]
            if sk == 0:
                nt.append(1 if t > lim + thr else -1 if t < -lim - thr else 0)
            elif sk == 1 and wt > thr or sk == -1 and wt < -thr:
                nt.append(0)
            else:
                nt.append(sk)
        new.append((1, nt[0], nt[1]))
    return new


def _residual(zl: list, w: list, mu: float) -> float:
    """box_friction_residual: max of |f − max(0, f − w_f)|, |τ − clip(τ − w_τ, −μf⁺, μf⁺)|, |τ| − μf⁺ (f⁺ = max(f, 0))."""
    res = 0.0
    for r in range(0, len(zl), 3):
        f, wn = zl[r], w[r]
        lp = mu * (f if f > 0.0 else 0.0)
        v = f - wn
        if v < 0.0:
            v = 0.0
        v = abs(f - v)
        if v > res:
            res = v
        for k in (r + 1, r + 2):
            t = zl[k]
            c = t - w[k]
            if c < -lp:
                c = -lp
            if c > lp:
                c = lp
            v = abs(t - c)
            if v > res:
                res = v
            v = abs(t) - lp
            if v > res:
                res = v
    return res


def _box_state(zl: list, mu: float, rel: float = 1e-9) -> list:
    """box_state: on where f > 0; a tangent at +1 (−1) where it lies on +μf (−μf) to ``rel``, else 0."""
    out = []
    for r in range(0, len(zl), 3):
        f = zl[r]
        if not f > 0:
            out.append((0, 0, 0))
            continue
        lim = mu * f * (1 - rel)
        t1, t2 = zl[r + 1], zl[r + 2]
        out.append((1, 1 if t1 >= lim else -1 if t1 <= -lim else 0, 1 if t2 >= lim else -1 if t2 <= -lim else 0))
    return out
