"""The control QP's optimum from a guessed active set, and its KKT residual on the lean path (:mod:`.qp_lean`).

For the QP of :mod:`.qp` in the scaled unknowns x̃ (min ½ x̃ᵀQx̃ + gᵀx̃, A x̃ = b, G x̃ ≤ u, l ≤ x̃ ≤ ũ; strictly
convex: the regularization ε > 0) the optimum solves, for the set W of rows that hold with equality,

    [Q  Aᵀ  Wᵀ] [x̃]   [−g]
    [A  0   0 ] [y] = [ b]          with z ≥ 0 on an upper side, z ≤ 0 on a lower one, and every other row
    [W  0   0 ] [z]   [ w]          holding (the KKT conditions; W then is the active set)

so a guess of W (the last control step's) is one linear solve and a check. :class:`ActiveSet` makes it, with
at most a few rounds of the primal active-set step (a held row with a wrong-signed multiplier let go, else the
most violated row held); :func:`kkt_lean` is :func:`~.qp_solve.kkt_residual` for these blocks.

Notation as in :mod:`.qp`; y, z the multipliers of the equalities and of the inequalities.
"""

from __future__ import annotations

from math import isfinite

import numpy as np

from .qp_solve import kkt_residual

try:                            # the gufunc np.linalg.solve calls, without its per-call checks (same LAPACK)
    from numpy.linalg._umath_linalg import solve1 as _solve_one
except ImportError:             # pragma: no cover - another numpy: the public function, same arithmetic
    _solve_one = np.linalg.solve

__all__ = []


class ActiveSet:
    """The QP's optimum from the active set of the previous step: Q̃ x̃ + g̃ + Ãᵀy + W̃ᵀz = 0, Ã x̃ = b, W̃ x̃ = w
    (W̃ the cone rows and bounds active at the last answer, on their sides), one solve of the KKT matrix,
    kept only when the inactive rows hold to the solver's eps_abs and the active multipliers have their signs
    (z ≥ 0 on an upper side, ≤ 0 on a lower one, exactly): then x̃ is the optimum (the QP is strictly convex) and
    ProxQP is not called. Carries ``x``, ``y``, ``z`` and ``info`` like ProxQP's results."""

    class info:
        status, iter = "ACTIVE_SET_CERTIFIED", 0

    def __init__(self, x, y, z):
        self.x, self.y, self.z = x, y, z

    @staticmethod
    def remember(Lay, z, nc, lbs, ubs) -> None:
        """Keep the rows ProxQP's multipliers z (cone rows, then bounds) say are active, for the next step."""
        z = np.asarray(z)
        zc, zb = z[:nc], z[nc:]
        rows = np.flatnonzero(zc > 0.0)
        lo = (zb < 0.0) & np.isfinite(lbs)
        # a point whose two cone rows are held has fₙ = fₜ = 0: its bound fₙ ≥ 0 is then a dependent row (the
        # KKT matrix singular), let go
        held = np.zeros(nc, bool)
        held[rows] = True
        both = np.flatnonzero(held[0::2] & held[1::2])
        lo[lbs.size - nc + 2 * both] = False
        Lay["guess"] = (rows, np.flatnonzero((zb > 0.0) & np.isfinite(ubs)), np.flatnonzero(lo))

    @staticmethod
    def solve(Lay, Q, g, A, b, G, u, lbs, ubs, tol, rounds: int = 4):
        """The optimum from the remembered active set, corrected for at most ``rounds`` solves (a row whose
        multiplier has the wrong sign let go, else the most violated row held: the primal active-set step);
        None when no round certifies an answer (the caller asks ProxQP)."""
        guess = Lay.get("guess")
        if guess is None:
            return None
        rows, up, lo = (list(a) for a in guess)
        N, neq = Q.shape[0], A.shape[0]
        for _ in range(rounds):                           # a cap known before the loop starts
            out = ActiveSet._round(Q, g, A, b, G, u, lbs, ubs, tol, rows, up, lo)
            if out is None:
                return None
            x, sol, zr, zu, zl = out
            # the signs exactly: the regularization ε ‖x̃‖² gives some multipliers of size ε |x̃| ~ 1e-11, and a
            # wrong sign there (a row held that should be let go) is an answer off by the same free direction
            worst = min([(z, 0, i) for i, z in enumerate(zr.tolist())] + [(z, 1, i) for i, z in enumerate(zu.tolist())]
                        + [(-z, 2, i) for i, z in enumerate(zl.tolist())], default=(0.0, 0, 0))
            if worst[0] < 0.0:
                (rows, up, lo)[worst[1]].pop(worst[2])
                continue
            viol = G @ x - u
            viol[rows] = -np.inf
            over, under = x - ubs, lbs - x
            over[up], under[lo] = -np.inf, -np.inf
            cands = [(viol.max(initial=-np.inf), 0), (over.max(), 1), (under.max(), 2)]
            v, which = max(cands)
            if v > tol:
                (rows, up, lo)[which].append(int(np.argmax((viol, over, under)[which])))
                continue
            if not np.abs(A @ x - b).max(initial=0.0) <= tol:
                return None
            Lay["guess"] = (np.array(rows, dtype=int), np.array(up, dtype=int), np.array(lo, dtype=int))
            zc, zb = np.zeros(G.shape[0]), np.zeros(N)
            zc[rows], zb[up], zb[lo] = zr, zu, zl
            return ActiveSet(x, sol[N:N + neq], np.concatenate([zc, zb]))
        return None

    @staticmethod
    def _round(Q, g, A, b, G, u, lbs, ubs, tol, rows, up, lo):
        """(x̃, the KKT solution, z of the held cone rows, upper bounds, lower bounds) with those rows held as
        equalities; None when the KKT matrix is singular or the answer not finite."""
        N, neq = Q.shape[0], A.shape[0]
        nr, nu = len(rows), len(up)
        k = nr + nu + len(lo)
        n = N + neq + k
        K = np.zeros((n, n))
        K[:N, :N] = Q
        K[:N, N:N + neq] = A.T
        K[N:N + neq, :N] = A
        W = K[N + neq:, :N]
        W[:nr] = G[rows]
        W[np.arange(nr, k), up + lo] = 1.0
        K[:N, N + neq:] = W.T
        rhs = np.concatenate([-g, b, u[rows], ubs[up], lbs[lo]])
        sol = _solve_one(K, rhs)
        if not isfinite(float(sol.sum())):
            return None
        z = sol[N + neq:]
        return sol[:N], sol, z[:nr], z[nr:nr + nu], z[nr + nu:]


def kkt_lean(Q, g, A, b, G, u, lb, ub, x, y, zc, zb) -> float:
    """:func:`~.qp_solve.kkt_residual` of min ½xᵀQx + gᵀx s.t. A x = b, G x ≤ u (its lower sides −∞),
    lb ≤ x ≤ ub, with the multipliers y, z_G, z_box: these blocks handed to it."""
    return kkt_residual(Q, g, A, b, x, y, ((G, np.full(u.shape, -np.inf), u, zc), (None, lb, ub, zb)))
