"""The box-friction sweep of :func:`pbanim.lcp.pgs_box_friction` on Python floats (chapters 07–08).

A small contact problem (a ragdoll on stairs: a few to a few dozen rows) spends its time in the per-row
cost of NumPy scalars, not in arithmetic: each zᵢ ← clip(zᵢ − wᵢ / Aᵢᵢ, loᵢ, hiᵢ) on array elements
costs a few µs. This twin runs the same sweep on lists of floats — the same rows in the same order,
the same bounds (fᵢ ≥ 0, |τᵢⱼ| ≤ μᵢfᵢ), the same update w ← w + A₍:,ᵣ₎ Δzᵣ (a product and a sum per
entry, as NumPy does them) and the same residual — so its iterates, sweep count and residual are those
of the readable sweep bit for bit (tested in ``tests/test_box_lean.py``). The readable sweep answers
above :data:`LEAN_ROWS` rows, where one NumPy update of w costs less than a Python loop over it.
"""

from __future__ import annotations

from operator import add

import numpy as np

__all__: list = []      # internal: reached through pgs_box_friction (up to LEAN_ROWS rows)

LEAN_ROWS = 54          # rows up to which the float sweep is the faster one (measured: 2.7–3.5× at 6–12 rows,
                        # 2× at 30, even at 60, 0.65× at 96)


def project_impulses(z: np.ndarray, mu: np.ndarray) -> np.ndarray:
    """z (3m,) projected in place onto the box-friction bounds fᵢ ≥ 0, |τᵢⱼ| ≤ μᵢfᵢ, and returned: the sweep's
    first iterate from a warm start (the previous step's impulses of persisting contacts)."""
    f = np.maximum(z[0::3], 0.0)
    z[0::3] = f
    lim = mu * f
    nlim = -lim
    for t in (z[1::3], z[2::3]):                          # clip(τ, −μf, μf) = min(max(τ, −μf), μf), in place
        np.minimum(np.maximum(t, nlim, out=t), lim, out=t)
    return z


def box_sweeps_floats(A: np.ndarray, b: np.ndarray, mu: np.ndarray, diag: np.ndarray, z: np.ndarray,
                      max_iter: int, threshold: float) -> tuple:
    """Sweeps of :func:`pbanim.lcp.pgs_box_friction` from the first iterate ``z`` (3m,) (already on its
    bounds) until the box residual is ≤ ``threshold`` or ``max_iter`` sweeps ran. A (3m, 3m), b (3m,),
    μ (m,), diag = diag(A) > 0, all checked by the caller. Returns (z, residual, sweeps).

    One contact (fᵢ, τᵢ₁, τᵢ₂) at a time, its bounds read once; clip(x, lo, hi) = min(max(x, lo), hi) written
    as the two comparisons Python's max and min make (the first argument kept on ties), so the same floats
    (signed zeros included). A tangent row whose bound μᵢfᵢ is zero and whose impulse is zero is skipped:
    the clip onto [−0, 0] would return a zero, which the readable sweep does not write (Δz = 0)."""
    cols = A.T.tolist()                                # column r as a list: A₍:,ᵣ₎
    w = (A @ z + b).tolist()
    z, d_, mu_ = z.tolist(), diag.tolist(), mu.tolist()
    blocks = [(3 * i, 3 * i + 1, 3 * i + 2, m_i) for i, m_i in enumerate(mu_)]
    res, inf = 0.0, float("inf")
    for sweep in range(1, max_iter + 1):
        for r0, r1, r2, m_i in blocks:
            f = z[r0]
            new = f - w[r0] / d_[r0]
            if 0.0 > new:                              # fᵢ ≥ 0 (the upper bound ∞ never binds)
                new = 0.0
            if new != f:
                dz = new - f
                w = list(map(add, w, map(dz.__mul__, cols[r0])))
                z[r0] = f = new
            lim = m_i * f
            for r in (r1, r2):                         # |τᵢⱼ| ≤ μᵢ fᵢ
                zr = z[r]
                if lim == 0.0 and zr == 0.0:
                    continue
                new = zr - w[r] / d_[r]
                if -lim > new:
                    new = -lim
                if lim < new:
                    new = lim
                if new != zr:
                    dz = new - zr
                    w = list(map(add, w, map(dz.__mul__, cols[r])))
                    z[r] = new
        res = box_residual_floats(z, w, mu_, threshold if sweep < max_iter else inf)
        if res <= threshold:
            return np.array(z), res, sweep
    return np.array(z), res, int(max_iter)


def box_residual_floats(z: list, w: list, mu: list, stop: float = float("inf")) -> float:
    """The box residual of the readable sweep on floats: max over contacts of |min(fᵢ, w_fᵢ)| and of |w_τ| for
    each tangential impulse strictly inside its bounds (|τ| < μᵢfᵢ (1 − 10⁻¹²)); min and abs written as the
    comparisons they make. With ``stop``: the first partial maximum above it is returned (the sweep's exit test
    fails on it whatever the other rows hold; the sweep asks for the whole residual after its last sweep)."""
    out = 0.0
    for i, m_i in enumerate(mu):
        r = 3 * i
        f, v = z[r], w[r]
        if not v < f:                                  # min(fᵢ, w_fᵢ)
            v = f
        if v < 0.0:
            v = -v
        if v > out:
            out = v
            if v > stop:
                return out
        edge = m_i * f * (1 - 1e-12)
        for r in (r + 1, r + 2):
            if -edge < z[r] < edge:
                v = w[r]
                if v < 0.0:
                    v = -v
                if v > out:
                    out = v
                    if v > stop:
                        return out
    return out
