"""Planar contact with Coulomb friction by contact modes (the LCP core, for chapter 08's planar characters).

Per contact i the unknowns are the normal impulse zₙ ≥ 0 and the friction impulse zₜ; with w = A z + b,

    0 ≤ zₙ ⊥ wₙ ≥ 0,      |zₜ| ≤ μ zₙ,      wₜ = 0 while |zₜ| < μ zₙ,      zₜ = −μ zₙ sign(wₜ) when sliding.

In the plane the friction cone is exactly this interval, so a guess of every contact's *mode* (separate,
stick, slide along ±t) turns the problem into one linear solve; the guess is accepted when every condition
holds to roundoff. :func:`solve_planar_contact` starts from the previous step's modes, switches the modes whose
conditions fail (at most 3m + 3 rounds), and when that cycles lets projected Gauss–Seidel
(:func:`~pbanim.lcp.pgs_box_friction`) find the modes, which the same direct solve then polishes. While a
foot stays planted the first guess holds and a step costs one small factorization.
"""

from __future__ import annotations

import numpy as np

from .pivoting import _check
from .solve import pgs_box_friction
from .specs import LCP_ENTRIES
from ..contracts import Array, Indices, Int, Opt, Real, contract
from ..errors import InvalidInput

__all__ = ["solve_planar_contact", "SEPARATE", "STICK", "SLIDE_POS", "SLIDE_NEG"]

SEPARATE, STICK, SLIDE_POS, SLIDE_NEG = 0, 1, 2, 3        # SLIDE_POS: sliding along +t (friction −μ zₙ)


def _check_modes(A, b, z, modes, mu, tol) -> bool:
    w = A @ z + b
    scale = tol * (1.0 + np.abs(b).max(initial=0.0))
    zn, zt, wn, wt = z[0::2], z[1::2], w[0::2], w[1::2]
    sep = modes == SEPARATE
    stick = modes == STICK
    pos, neg = modes == SLIDE_POS, modes == SLIDE_NEG
    ok = np.all(wn[sep] >= -scale) and np.all(zn[~sep] >= -scale) and np.all(np.abs(wn[~sep]) <= scale)
    ok = ok and np.all(np.abs(zt[stick]) <= mu * zn[stick] + scale) and np.all(np.abs(wt[stick]) <= scale)
    return bool(ok and np.all(wt[pos] >= -scale) and np.all(wt[neg] <= scale))


def _switch_modes(w, z, modes, mu, eps):
    """One round of mode changes from the violated conditions (a touching contact pulls: separate; a
    separated one penetrates: stick; sticking beyond the cone: slide; a slide that reverses: stick)."""
    zn, zt, wn, wt = z[0::2], z[1::2], w[0::2], w[1::2]
    new = modes.copy()
    new[(modes == SEPARATE) & (wn < -eps)] = STICK
    new[(modes != SEPARATE) & (zn < -eps)] = SEPARATE
    over = (modes == STICK) & (np.abs(zt) > mu * zn + eps)
    new[over & (zt > 0)] = SLIDE_NEG
    new[over & (zt < 0)] = SLIDE_POS
    new[((modes == SLIDE_POS) & (wt < -eps)) | ((modes == SLIDE_NEG) & (wt > eps))] = STICK
    return new


def _solve_modes(A, b, modes, mu):
    """z with the contact modes imposed (one linear solve), or None when that system is singular."""
    m = modes.size
    z = np.zeros(2 * m)
    rows = []                                            # equations w_r = 0
    for i, md in enumerate(modes):
        if md != SEPARATE:
            rows.append(2 * i)
        if md == STICK:
            rows.append(2 * i + 1)
    if not rows:
        return z
    # unknowns: the normal impulses of touching contacts and the tangential ones of sticking contacts;
    # a sliding contact's tangential impulse is ∓μ zₙ, folded into its normal column
    cols = np.array(rows)
    T = np.zeros((2 * m, cols.size))
    for c, r in enumerate(cols):
        T[r, c] = 1.0
        if r % 2 == 0 and modes[r // 2] in (SLIDE_POS, SLIDE_NEG):
            T[r + 1, c] = -mu if modes[r // 2] == SLIDE_POS else mu
    K = A[cols] @ T
    try:
        x = np.linalg.solve(K, -b[cols])
    except np.linalg.LinAlgError:
        return None
    return T @ x


@contract(A=Array(("n", "n"), **LCP_ENTRIES), b=Array(("n",), **LCP_ENTRIES), mu=Real(ge=0),
          guess=Opt(Indices(4, empty=True)), tol=Real(gt=0, lt=1), max_iter=Int(ge=1))
def solve_planar_contact(A: np.ndarray, b: np.ndarray, mu: float, guess=None, *, tol: float = 1e-9,
                         max_iter: int = 200) -> tuple[np.ndarray, np.ndarray, dict]:
    """Impulses z = (zₙ₁, zₜ₁, zₙ₂, …) of planar contacts with w = A z + b (see the module docstring).

    ``guess``: contact modes to try first (previous step's; one of SEPARATE, STICK, SLIDE_POS, SLIDE_NEG
    per contact). Modes are switched where a condition fails (at most 3m + 3 rounds); if that cycles,
    projected Gauss–Seidel finds the modes (at most ``max_iter`` sweeps). Returns (z, modes, info) with
    info["path"] "guess" (the modes held), "modes" (switched), "pgs+polish" or "pgs" (the polish failed;
    z is PGS's, with its residual), and info["success"]: whether z meets every condition of the module
    docstring (to ``tol``·(1 + ‖b‖∞) by the direct solves, to ``tol``·max(1, ‖b‖∞) by PGS's residual) —
    the certificate, False only on the "pgs" path when PGS stopped short of it.

    >>> z, modes, info = solve_planar_contact(np.eye(2), np.array([-1.0, 0.5]), 0.8)
    >>> z.tolist(), info["path"], info["success"]
    ([1.0, -0.5], 'modes', True)
    """
    A, b = _check(A, b)            # internal callers (the planar step) hand them over unchecked
    if b.size % 2:
        raise InvalidInput(f"solve_planar_contact: A and b must have 2 rows per contact (normal, tangent), got "
                           f"{b.size} rows")
    m = b.size // 2
    if guess is not None and len(guess) != m:
        raise InvalidInput(f"solve_planar_contact: guess must hold one mode per contact (m = {m}), got "
                           f"{len(guess)}")
    modes = np.array(guess if guess is not None else np.zeros(m, int))
    for it in range(3 * m + 3):                           # mode switching, a cap known before it starts
        z = _solve_modes(A, b, modes, mu)
        if z is None:
            break
        if _check_modes(A, b, z, modes, mu, tol):
            return z, modes, {"path": "guess" if it == 0 else "modes", "sweeps": it, "success": True}
        modes = _switch_modes(A @ z + b, z, modes, mu, tol * (1.0 + np.abs(b).max(initial=0.0)))
    # PGS on the 3-row form (a zero second tangent with unit diagonal), then polish its modes
    A3 = np.zeros((3 * m, 3 * m))
    b3 = np.zeros(3 * m)
    idx = np.arange(3 * m).reshape(m, 3)[:, :2].ravel()
    A3[np.ix_(idx, idx)] = A
    A3[2::3, 2::3] = np.eye(m)
    b3[idx] = b
    z3, res, sweeps = pgs_box_friction(A3, b3, mu, max_iter=max_iter, tol=tol)
    z = z3[idx]
    w = A @ z + b
    zn, zt, wt = z[0::2], z[1::2], w[1::2]
    modes = np.where(zn <= 1e-12 * (1 + zn.max(initial=0.0)), SEPARATE,
                     np.where(np.abs(zt) < mu * zn * (1 - 1e-6), STICK, np.where(wt > 0, SLIDE_POS, SLIDE_NEG)))
    zp = _solve_modes(A, b, modes, mu)
    if zp is not None and _check_modes(A, b, zp, modes, mu, tol):
        return zp, modes, {"path": "pgs+polish", "sweeps": sweeps, "success": True}
    return z, modes, {"path": "pgs", "sweeps": sweeps, "residual": res,
                      "success": bool(res <= tol * max(1.0, float(np.abs(b).max())))}
