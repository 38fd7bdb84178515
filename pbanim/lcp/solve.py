"""LCP and QP solvers for contact forces (chapter 07): one signature, a certificate every time.

The linear complementarity problem of resting contact (Baraff 1994, the lecture's three conditions)

    w = A f + b ≥ 0          (no inter-penetration: d̈ᵢ ≥ 0)
    f ≥ 0                    (no glue)
    fᵀ w = 0                 (a force vanishes where the contact breaks)

For a symmetric positive semidefinite A (frictionless contact, A = J W Jᵀ) it is the optimality
condition of the QP  min ½ fᵀAf + bᵀf  s.t. f ≥ 0  (w is the multiplier of f ≥ 0).

=========  ===========  ==========  =============================================================
symbol     code         shape       meaning
=========  ===========  ==========  =============================================================
A          ``A``        (m, m)      LCP matrix (J W Jᵀ for frictionless contact)
b          ``b``        (m,)        free relative acceleration (or velocity) of the contacts
f          ``f``        (m,)        contact force magnitudes (impulses at the velocity level)
w          ``w``        (m,)        A f + b: relative normal accelerations d̈
r          residual     scalar      natural-map residual ‖f − max(0, f − w)‖∞ (zero iff solved)
=========  ===========  ==========  =============================================================

Solvers (``solver=``): ``"qp"`` (qpsolvers; ProxQP by default through proxsuite's own box
constraints), ``"lemke"`` (complementary pivoting, Cottle–Pang–Stone §4.4, lexicographic
anti-cycling), ``"dantzig"`` (Baraff 1994's principal pivoting, Bland's rule for ties),
``"pgs"`` (projected Gauss–Seidel with warm start), ``"bpp"`` (the active-set route from a guessed
active set, :mod:`pbanim.lcp.active_set`: block principal pivoting, the Goldfarb–Idnani dual active set
for small or redundant problems; symmetric PSD A; a QP solve only when neither certifies). Limiting cases: b ≥ 0 gives f = 0 for every
solver; a single contact gives f = max(0, −b/A).

Every answer is judged by the natural-map residual computed from A and b (ORACLES D8), never by
the solver's own claim. A failed or infeasible problem raises :class:`~pbanim.errors.InfeasibleContact`
(``raise_on_failure=False`` returns ``success=False`` instead); ``fallback="lemke"`` retries with
another solver, explicitly and recorded in ``extra["fallback_from"]`` — never silently.

References: D. Baraff, "Fast contact force computation for nonpenetrating rigid bodies", SIGGRAPH 1994;
R. W. Cottle, J.-S. Pang, R. E. Stone, *The Linear Complementarity Problem* (1992), ch. 4;
K. G. Murty, *Linear Complementarity, Linear and Nonlinear Programming* (1988);
A. Bambade et al., "PROX-QP: Yet another quadratic programming solver for robotics and beyond", RSS 2022.
"""

from __future__ import annotations

import time
from typing import Any

import numpy as np

from .box import _box_residual, pgs_bounded, pgs_box_friction  # noqa: F401  (their import path)
from .pivoting import _check, _dantzig, _lemke, _polish, _scale, residual_threshold
from .qp import qp
from .pivoting import _MATRIX, _VECTOR
from .pivoting import _EPS1000
from .sweeps import WAVEFRONT_FROM, pgs_sweeps_wavefront
from .lean_solve import lean_lemke, lean_pgs  # noqa: F401  (their import path)
from .specs import JacobianRows, RowIndices, check_options, length_of
from ..contracts import Array, Choice, Flag, Int, Opt, Real, contract, finite_result
from ..errors import InfeasibleContact, InvalidInput, PbanimError
from ..results import ContactSolution, natural_map_residual

__all__ = ["solve_lcp", "LCP_SOLVERS", "residual_threshold"]  # lemke, dantzig, pgs, qp: via this module

LCP_SOLVERS = ("qp", "lemke", "dantzig", "pgs", "bpp")


# ---------------------------------------------------------------------------------------------
# Projected Gauss–Seidel (the bounded and box-friction sweeps: pbanim.lcp.box)
# ---------------------------------------------------------------------------------------------
def pgs(A: np.ndarray, b: np.ndarray, *, max_iter: int = 1000, tol: float = 1e-10,
        warm_start: np.ndarray | None = None, omega: float = 1.0, **_: Any) -> tuple[np.ndarray, str, int]:
    """Projected Gauss–Seidel (SOR with relaxation ``omega``): fᵢ ← max(0, fᵢ − ω wᵢ / Aᵢᵢ), sweep by sweep.

    Stops when the natural-map residual ≤ :func:`residual_threshold` ("converged"), else after ``max_iter``
    sweeps with status "max_iter" — it never claims a convergence it did not reach. Needs Aᵢᵢ > 0.
    """
    # BEGIN SOLUTION pgs
    m = b.size
    diag = np.diag(A).copy()
    if np.any(diag <= 0):
        i = int(np.flatnonzero(diag <= 0)[0])
        return np.zeros(m), f"zero_diagonal(A[{i},{i}] = {diag[i]:.3g})", 0
    f = np.zeros(m) if warm_start is None else np.maximum(np.array(warm_start, dtype=float), 0.0)
    absA = np.abs(A)
    if natural_map_residual(f, A @ f + b) <= residual_threshold(A, b, f, tol):
        return f, "converged", 0
    f, status, sweep, _, _ = sweeps_for(m)(A, b, f, diag, absA, tol * _scale(b), int(max_iter), omega)
    return f, status, sweep
    # END SOLUTION


def pgs_sweeps(A, b, f, diag, absA, tol_b: float, max_iter: int, omega: float = 1.0):
    """The sweeps of :func:`pgs` from f (in place), unchecked: (f, status, sweeps, residual,
    threshold) — the readable row loop.

    Each sweep fᵢ ← max(0, fᵢ − ω (Aᵢ·f + bᵢ)/Aᵢᵢ), then the stop test residual ≤ tol·max(1, ‖b‖∞) +
    1000 ε ‖|A| f‖∞ — the certificate of :func:`solve_lcp` itself (f ≥ 0, so |A||f| = |A| f):
    a "converged" answer has passed it, with these very numbers. The one sweep that :func:`pgs`
    and the lean contact step (:mod:`pbanim.contact.lean`) both run (from :data:`WAVEFRONT_FROM` rows by
    wavefronts, :func:`pgs_sweeps_wavefront`); ``diag`` = diag(A) > 0 and ``absA`` = |A| are the caller's.
    """
    m = b.size
    rows = [A[i] for i in range(m)]
    res = thresh = float("inf")
    for sweep in range(1, max_iter + 1):
        for i in range(m):
            fi = f[i] - omega * (rows[i] @ f + b[i]) / diag[i]
            f[i] = fi if fi > 0.0 else 0.0
        thresh = tol_b + _EPS1000 * float(np.max(absA @ f))
        res = float(np.abs(f - np.maximum(0.0, f - (A @ f + b))).max())
        if res <= thresh:
            return f, "converged", sweep, res, thresh
    return f, "max_iter", max_iter, res, thresh


def sweeps_for(m: int):
    """The sweeps for m rows: the readable row loop :func:`pgs_sweeps` (here, beside :func:`pgs`, so that the
    assignment's code is the one its sweeps run), or from :data:`~pbanim.lcp.sweeps.WAVEFRONT_FROM` rows the same
    iterates by wavefronts (:func:`pbanim.lcp.sweeps.pgs_sweeps_wavefront`, equal to roundoff)."""
    return pgs_sweeps_wavefront if m >= WAVEFRONT_FROM else pgs_sweeps


# ---------------------------------------------------------------------------------------------
# The Delassus matrix A = J W Kᵀ (collision impulses, resting contact, friction)
# ---------------------------------------------------------------------------------------------
_blocks = length_of("Wb")       # n: the inverse-mass blocks (bodies, the world included)
_ROWS = Array(("m", "d"), empty=True)


@contract(a=RowIndices(_blocks), b=RowIndices(_blocks), Ga=_ROWS, Gb=_ROWS, Wb=Array(("n", "d", "d")),
          other=Opt(JacobianRows(_blocks)), block=Int(ge=1), returns=finite_result)
def delassus(a, b, Ga, Gb, Wb, other=None, block: int = 1) -> np.ndarray:
    """A = J W Kᵀ, dense (m, k), from per-contact Jacobian rows, without forming J, W or K.

    Row i of J is ``Ga[i]`` (d,) on body ``a[i]`` and −``Gb[i]`` on body ``b[i]``; W is block diagonal
    with the blocks ``Wb`` (n, d, d) (the static world: a zero block, so it needs no special case).
    ``other = (a, b, Ga, Gb)`` are the rows of K (e.g. the force directions nᵢ − μ t̂ᵢ of sliding
    friction); by default K = J and A is symmetric positive semidefinite. Aᵢⱼ is nonzero only where
    contacts i and j share a body. Up to 150² entries: four masked products (G_a W H_aᵀ)∘[a = a′] − …;
    above, only the pairs of row groups sharing a body with a nonzero W block, O(Σ_bodies c²) small
    products (``block = g``: rows in groups of g on the same two bodies, e.g. a contact's normal and
    tangents). The readable loop over bodies is :func:`pbanim.contact.assembly.delassus_by_bodies`. A call
    from outside pbanim whose products overflow (rows or inverse masses near 10¹⁵⁰) is
    :class:`~pbanim.errors.NonFiniteResult`, never an A with inf or NaN.

    One particle (1/m = 0.5) on the ground (the world, body 1) with two contacts along z:

    >>> Wb = np.array([0.5, 0.0])[:, None, None] * np.eye(3)
    >>> G = np.array([[0.0, 0.0, 1.0], [0.0, 0.0, 1.0]])
    >>> delassus(np.array([0, 0]), np.array([1, 1]), G, G, Wb)
    array([[0.5, 0.5],
           [0.5, 0.5]])
    """
    with np.errstate(over="ignore", invalid="ignore"):    # an overflow is named by the result's certificate
        return _delassus(a, b, Ga, Gb, Wb, other, block)


def _delassus(a, b, Ga, Gb, Wb, other, block) -> np.ndarray:
    oa, ob, Ha, Hb = (a, b, Ga, Gb) if other is None else other
    m, k, g, (n, d) = a.size, oa.size, int(block), (Wb.shape[0], Ga.shape[1])
    if m * k <= 150 * 150:
        WKa = np.einsum("nij,nj->ni", Wb[oa], Ha)
        WKb = np.einsum("nij,nj->ni", Wb[ob], Hb)
        out = (Ga @ WKa.T) * (a[:, None] == oa[None, :])
        out -= (Ga @ WKb.T) * (a[:, None] == ob[None, :])
        out -= (Gb @ WKa.T) * (b[:, None] == oa[None, :])
        out += (Gb @ WKb.T) * (b[:, None] == ob[None, :])
        return out
    if m % g or k % g or any(np.any(e.reshape(-1, g) != e[::g, None]) for e in (a, b, oa, ob)):
        raise InvalidInput(f"block = {g} needs groups of {g} consecutive rows on the same two bodies, got "
                           f"a = {a.tolist()[:12]}…, b = {b.tolist()[:12]}…")
    live = Wb.reshape(n, -1).any(axis=1)               # the world's zero block pairs with nothing
    ej, ek = np.concatenate([a[::g], b[::g]]), np.concatenate([oa[::g], ob[::g]])   # group ends: a then b
    rj, rk = np.tile(np.arange(m // g), 2), np.tile(np.arange(k // g), 2)
    G = np.concatenate([Ga.reshape(-1, g, d), -Gb.reshape(-1, g, d)])
    lj, lk = np.flatnonzero(live[ej]), np.flatnonzero(live[ek])
    ej, rj, G, ek, rk = ej[lj], rj[lj], G[lj], ek[lk], rk[lk]
    WH = np.concatenate([Ha.reshape(-1, g, d), -Hb.reshape(-1, g, d)])[lk] @ np.swapaxes(Wb[ek], 1, 2)  # (W h)ᵀ
    count = np.bincount(ek, minlength=n)
    rep = count[ej]                                    # each J end pairs with every K end on its body
    e1 = np.repeat(np.arange(ej.size), rep)
    e2 = np.argsort(ek, kind="stable")[np.repeat(np.cumsum(count)[ej] - np.cumsum(rep), rep) + np.arange(e1.size)]
    val = G[e1] @ np.swapaxes(WH[e2], 1, 2)            # (pairs, g, g)
    idx = ((g * rj[e1])[:, None, None] + np.arange(g)[:, None]) * k + (g * rk[e2])[:, None, None] + np.arange(g)
    return np.bincount(idx.ravel(), weights=val.ravel(), minlength=m * k).reshape(m, k)


#: at most this many contacts, the route starts with the dual active set (one cheap rank-one round per held
#: contact) rather than block principal pivoting (one factorization per round); measured crossover between
#: m = 30 (dual 1.2x faster) and m = 100 (bpp 2x faster) in ``pbanim bench contact``'s QP table
DUAL_FIRST = 64


def _bpp_route(A: np.ndarray, b: np.ndarray, *, max_iter: int = 4, qp_fallback: bool = True,
               **opts: Any) -> tuple[np.ndarray, str, int]:
    """The active-set route for a symmetric PSD A (``solver="bpp"``), each step certified before it is trusted.

    m > :data:`DUAL_FIRST`: block principal pivoting (:func:`pbanim.lcp.active_set.bpp`) for at most
    ``max_iter`` exchange rounds, handing over at the first sign of degeneracy (a singular A_FF with a
    wrong guess, or a round that does not reduce the infeasible count: redundant stacks make it cycle) to
    the Goldfarb–Idnani dual active set (:func:`pbanim.lcp.active_set.dual_active_set`, which keeps its held
    rows independent and cannot cycle on redundancy). m ≤ :data:`DUAL_FIRST`: the dual active set first.
    Either starts from the guess (``active``, the support of ``warm_start``, or {bᵢ < 0}). Only if no
    active-set answer passes the certificate does the QP run (as ``solver="qp"`` does, polish included). The status says which route answered ("solved", "bpp→dual", "bpp→qp:<status>",
    "dual→qp:<status>")."""
    from .active_set import bpp, dual_active_set

    tol = opts.get("tol", 1e-10)
    if opts.get("active") is not None:
        guess = np.asarray(opts["active"], dtype=bool)
    elif opts.get("warm_start") is not None:
        guess = np.asarray(opts["warm_start"], dtype=float) > 0
    else:
        guess = b < 0
    if b.size <= DUAL_FIRST:
        f, status, iters = dual_active_set(A, b, tol=tol, start=guess)
        route = "dual"
    else:
        f, status, iters = bpp(A, b, max_iter=max_iter, handoff=True, **opts)
        route = "bpp"
        if status != "solved" and qp_fallback:
            f, st1, it1 = dual_active_set(A, b, tol=tol, start=guess)
            iters += it1
            if st1 == "solved":                  # certified by dual_active_set itself
                return f, "bpp→dual", iters
    if status == "solved" or not qp_fallback:
        return f, status, iters
    g, st2, it2 = qp(A, b, tol=tol)                       # the "qp" solver's own route, polish included
    return g, f"{route}→qp:{st2}", iters + it2


_IMPL = {"lemke": _lemke, "dantzig": _dantzig, "pgs": pgs, "qp": qp, "bpp": _bpp_route}


@contract(A=_MATRIX, b=_VECTOR, solver=Choice(LCP_SOLVERS), tol=Real(gt=0, lt=1), raise_on_failure=Flag(),
          fallback=Opt(Choice(LCP_SOLVERS)), warm_start=Opt(Array(("m",), empty=True)), validate=Flag())
def solve_lcp(A, b, solver: str = "qp", *, tol: float = 1e-10, raise_on_failure: bool = True,
              fallback: str | None = None, warm_start=None, validate: bool = True, **opts: Any) -> ContactSolution:
    """Solve the LCP  w = A f + b ≥ 0, f ≥ 0, fᵀw = 0  and certify the answer.

    Parameters
    ----------
    A : array_like, shape (m, m)
    b : array_like, shape (m,)
    solver : {"qp", "lemke", "dantzig", "pgs", "bpp"}
        ``"qp"`` needs a symmetric PSD A (frictionless contact); the pivoting methods also take the
        non-symmetric matrices of friction; ``"pgs"`` needs Aᵢᵢ > 0.
    tol : float
        Success iff the natural-map residual ≤ tol·max(1, ‖b‖∞) + 1000 ε ‖|A||f|‖∞
        (:func:`residual_threshold`; ``extra["threshold"]`` holds the value used).
    raise_on_failure : bool
        Raise :class:`~pbanim.errors.InfeasibleContact` on failure (default) or return ``success=False``.
    fallback : str, optional
        Another solver to try when this one fails (explicit; recorded in ``extra["fallback_from"]``).
    validate : bool
        Check that A is symmetric PSD for ``"qp"`` (an eigenvalue computation); callers that assemble
        A = J W Jᵀ themselves (the scene effect) skip it.
    warm_start : array_like, optional
        A previous answer: PGS starts from it, the QP uses it as initial guess, and the pivoting
        methods first try its support as the active set (kept only if it certifies). A guess whose
        natural-map residual is larger than f = 0's is dropped (``extra["warm_start_dropped"]``).
    **opts
        Solver options (:data:`pbanim.lcp.specs.LCP_OPTIONS`, checked; an option the solver does not take
        is refused by name): ``max_iter``, ``polish`` (all), ``omega`` (pgs), ``pivot_tol`` (pivoting),
        ``backend``, ``eps_abs``, ``native_box`` (qp; other names go to the backend as its settings),
        ``active``, ``qp_fallback``, ``rho_rel``, ``refine``, ``cache`` (bpp).

    A backend's own exception (quadprog or ECOS refusing the singular A of redundant contacts) or a
    numerical failure inside a route is not raised bare: it becomes the status ("backend error …"), the
    certificate fails, and the failure is :class:`~pbanim.errors.InfeasibleContact` naming it — or, with
    ``raise_on_failure=False``, a solution with ``success`` False, that status and the residual of f = 0.

    Returns
    -------
    ContactSolution
        ``f``, ``status``, ``success``, ``iterations``, ``time``, and the residuals computed from A, b.

    Examples
    --------
    >>> sol = solve_lcp([[2.0, 1.0], [1.0, 2.0]], [-1.0, 1.0], solver="lemke")
    >>> sol.f.round(12).tolist(), sol.success, sol.residual < 1e-12
    ([0.5, 0.0], True, True)
    >>> solve_lcp([[-1.0]], [-1.0], solver="dantzig")
    Traceback (most recent call last):
    ...
    pbanim.errors.InfeasibleContact: contact solver 'dantzig' failed: status infeasible, residual 1.000e+00...
    """
    A, b = _check(A, b)         # internal callers (effects, joints, collisions) reach here unchecked
    m = b.size
    opts = check_options("solve_lcp", solver, opts)
    if solver in ("qp", "bpp") and m:
        # symmetry is always checked (O(m²); a non-symmetric A can keep a QP backend busy for minutes);
        # definiteness (an O(m³) eigenvalue computation) only with validate=True
        asym = float(np.abs(A - A.T).max())
        if asym > 1e-12 * max(1.0, float(np.abs(A).max())):
            raise InvalidInput(f"solve_lcp: A must be symmetric for solver={solver!r} (max |A − Aᵀ| = {asym:.3g}); "
                               "use solver='lemke' for friction or other non-symmetric LCPs")
        if validate and np.linalg.eigvalsh(A).min() < -1e-10 * max(1.0, float(np.max(np.abs(A)))):
            raise InvalidInput(f"solve_lcp: A must be positive semidefinite for solver={solver!r} (the QP is then "
                               "convex); use solver='lemke' for an indefinite LCP")
    start = time.perf_counter()
    f, status, iters, extra = None, "", 0, {}
    if warm_start is not None:
        warm_start = np.asarray(warm_start, dtype=float)
        if warm_start.shape != (m,) or not np.isfinite(warm_start).all():     # from an internal caller
            raise InvalidInput(f"solve_lcp: warm_start must be a finite array of shape ({m},), got shape "
                               f"{warm_start.shape}")
        with np.errstate(over="ignore", invalid="ignore"):
            worse = not natural_map_residual(warm_start, A @ warm_start + b) <= natural_map_residual(np.zeros(m), b)
        if worse:       # a guess worse than f = 0 (10³⁰⁰ forces kept ProxQP busy for minutes): start cold
            warm_start, extra["warm_start_dropped"] = None, True
        elif solver in ("lemke", "dantzig") and np.any(warm_start > 0):
            g = _polish(A, b, np.where(warm_start > 0, 1.0, 0.0) * np.maximum(warm_start, 0), tol)
            if natural_map_residual(g, A @ g + b) <= residual_threshold(A, b, g, tol):
                f, status, extra["warm_start_hit"] = g, "solved", True
    if f is None:
        kw = dict(opts)
        if solver in ("pgs", "qp", "bpp"):
            kw.update(tol=tol, warm_start=warm_start)
        polish = kw.pop("polish", True)
        if solver == "qp":
            kw["polish"] = polish
        if m == 0:                 # no contacts: nothing to solve on any route
            f, status, iters = np.zeros(0), "solved", 0
        else:
            try:
                f, status, iters = _IMPL[solver](A, b, **kw)
            except (PbanimError, NotImplementedError):     # a starter's body left to write: said as such
                raise
            except (ArithmeticError, RuntimeError, ValueError, np.linalg.LinAlgError) as exc:
                # a numerical failure inside a route (an SVD that does not converge): a status, judged below
                f, status, iters = np.zeros(m), f"error {type(exc).__name__}: {' '.join(str(exc).split())[:200]}", 0
        if polish and solver in ("lemke", "dantzig") and status == "solved":
            g = _polish(A, b, f, tol)  # one least-squares solve on the support: removes pivoting roundoff
            extra["polished"] = g is not f
            f = g
    elapsed = time.perf_counter() - start
    sol = ContactSolution(f=np.asarray(f, dtype=float), solver=solver, status=status, success=False,
                          iterations=iters, time=elapsed, A=A, b=b, extra=extra)
    # success is the certificate, whatever the solver's own status (kept in ``status``)
    finite = bool(np.isfinite(sol.f).all())
    thresh = residual_threshold(A, b, sol.f, tol) if finite else tol
    extra["threshold"] = thresh
    sol.success = bool(finite and sol.residual <= thresh)
    if not sol.success and fallback is not None and fallback != solver:
        other = solve_lcp(A, b, fallback, tol=tol, raise_on_failure=raise_on_failure, warm_start=None)
        other.extra["fallback_from"] = {"solver": solver, "status": status, "residual": sol.residual}
        other.time += elapsed
        return other
    if not sol.success and raise_on_failure:
        raise InfeasibleContact(solver, status, sol.residual,
                                f"m = {m} contacts, tol {thresh:.1e}; pass raise_on_failure=False to inspect "
                                "the best iterate, or fallback='lemke'")
    return sol
