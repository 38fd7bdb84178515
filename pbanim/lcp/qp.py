"""The contact QP  min ½ fᵀAf + bᵀf  s.t. f ≥ 0  through ProxQP or any qpsolvers backend (chapter 07).

For a symmetric positive semidefinite A the QP's optimality conditions are the contact LCP
w = A f + b ≥ 0, f ≥ 0, fᵀw = 0 (w is the multiplier of f ≥ 0), so any QP solver answers it; what the
answer is worth is judged afterwards by the natural-map residual (:func:`pbanim.lcp.solve_lcp`,
ORACLES D8), never by the backend's own status.

Every backend is asked for the accuracy the caller wants in its own terms (:data:`BACKEND_TOLERANCES`:
OSQP's ``eps_abs``, Clarabel's ``tol_gap_abs``, HiGHS's feasibility tolerances, ...): at their default
settings several stop at 10⁻³ … 10⁻⁶. A backend that cannot take the problem (quadprog and ECOS need a
positive *definite* A, and redundant contacts make it singular) raises its own exception; :func:`qp`
turns it into a status carrying the backend's message, and the certificate then reports the failure
(``success`` False, or :class:`~pbanim.errors.InfeasibleContact` naming the backend's message).

References: A. Bambade et al., "PROX-QP: Yet another quadratic programming solver for robotics and
beyond", RSS 2022; S. Caron et al., qpsolvers (a unified interface to QP solvers in Python).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from .pivoting import _polish
from ..errors import InvalidInput

__all__ = ["qp", "BACKEND_TOLERANCES", "BACKEND_ITERATIONS", "backend_settings", "backend_failure"]


def _eps(*names: str, rel: tuple = ()):
    """Settings with each absolute tolerance ``names`` at ε and each relative one ``rel`` at 0."""
    return lambda e: {**{n: e for n in names}, **{n: 0.0 for n in rel}}


#: how each qpsolvers backend is asked for an accuracy ε (its own option names); a backend missing
#: here runs at its defaults (the certificate still judges its answer)
BACKEND_TOLERANCES = {
    "proxqp": _eps("eps_abs", rel=("eps_rel",)),
    "osqp": lambda e: {"eps_abs": e, "eps_rel": 0.0, "max_iter": 20000},
    "piqp": _eps("eps_abs", rel=("eps_rel",)),
    "qpalm": _eps("eps_abs", rel=("eps_rel",)),
    "scs": _eps("eps_abs", rel=("eps_rel",)),
    "clarabel": _eps("tol_gap_abs", "tol_gap_rel", "tol_feas"),
    "cvxopt": _eps("abstol", "reltol", "feastol"),
    "ecos": _eps("abstol", "reltol", "feastol"),
    "daqp": _eps("primal_tol", "dual_tol"),
    "highs": _eps("primal_feasibility_tolerance", "dual_feasibility_tolerance"),
    "quadprog": lambda e: {},            # a dual active-set method: exact up to roundoff, no tolerance
}


#: each backend's name for its iteration cap (``max_iter=`` of :func:`qp` is passed on under it)
BACKEND_ITERATIONS = {"proxqp": "max_iter", "osqp": "max_iter", "clarabel": "max_iter", "piqp": "max_iter",
                      "qpalm": "max_iter", "scs": "max_iters", "ecos": "max_iters", "cvxopt": "maxiters",
                      "daqp": "iter_limit"}


def backend_settings(backend: str, eps: float) -> dict:
    """The options that ask ``backend`` for accuracy ``eps`` (empty for a backend not in the table).

    >>> backend_settings("osqp", 1e-9)["eps_abs"], backend_settings("cvxopt", 1e-9)["feastol"]
    (1e-09, 1e-09)
    """
    make = BACKEND_TOLERANCES.get(backend)
    return {} if make is None else make(float(eps))


def backend_failure(exc: BaseException) -> str:
    """A backend's exception as a status: its type and message (first 200 characters)."""
    text = " ".join(str(exc).split())
    return f"backend error {type(exc).__name__}: {text[:200]}"


def qp(A: np.ndarray, b: np.ndarray, *, backend: str = "proxqp", eps_abs: float = 1e-9,
       max_iter: int | None = None, warm_start: np.ndarray | None = None, native_box: bool = True,
       polish: bool = True, tol: float = 1e-10, **opts: Any) -> tuple[np.ndarray, str, int]:
    """The contact QP through qpsolvers (``backend`` = any name in ``qpsolvers.available_solvers``).

    With ``backend="proxqp"`` and ``native_box=True`` (default) proxsuite's dense ProxQP is called with
    its own box constraints ``l_box = 0`` (qpsolvers would turn the bound into a dense inequality
    block); otherwise ``qpsolvers.solve_problem`` with ``lb = 0``, the backend's tolerance options at
    ``eps_abs`` (:func:`backend_settings`; ``opts`` override them) and ``max_iter`` under the backend's own
    name (:data:`BACKEND_ITERATIONS`; refused by name for a backend without one). Needs a symmetric positive
    semidefinite A. ``polish`` re-solves on the active set {fᵢ > wᵢ} (like OSQP's polishing) and keeps
    the result only when that lowers the natural-map residual: with the default ``eps_abs = 1e-9`` this
    reaches the 1e-10 certificate at a fraction of the iterations that ``eps_abs = 1e-12`` alone needs.

    Returns ``(f, status, iterations)``. A backend's exception (quadprog on a singular A: "matrix P is
    not positive definite") is returned as the status ``"backend error <type>: <message>"`` with f = 0,
    for the caller's certificate to judge — never raised bare.
    """
    import qpsolvers  # lazy: never imported unless a QP is solved

    if backend not in qpsolvers.available_solvers:    # internal callers reach here unchecked
        raise InvalidInput(f"backend must be an installed qpsolvers solver, one of "
                           f"{qpsolvers.available_solvers}, got {backend!r}")
    m = b.size
    x0 = None if warm_start is None else np.maximum(np.asarray(warm_start, dtype=float), 0.0)
    native = backend == "proxqp" and native_box
    if max_iter is not None and not native and backend not in BACKEND_ITERATIONS:
        raise InvalidInput(f"solve_lcp: max_iter is not an option of the QP backend {backend!r} (it has no "
                           f"iteration cap pbanim knows); leave max_iter unset, got {max_iter}")
    try:
        if native:
            import proxsuite

            res = proxsuite.proxqp.dense.solve(A, b, None, None, None, None, None, l_box=np.zeros(m),
                                               u_box=np.full(m, np.inf), x=x0, eps_abs=eps_abs, eps_rel=0.0,
                                               max_iter=max_iter or 10000, **opts)
            f = np.asarray(res.x, dtype=float).copy()
            status, iters = str(res.info.status).split(".")[-1], int(res.info.iter)
        else:
            kw = {**backend_settings(backend, eps_abs), **opts}
            if max_iter is not None or backend == "proxqp":
                kw[BACKEND_ITERATIONS[backend]] = max_iter or 10000
            sol = qpsolvers.solve_problem(qpsolvers.Problem(A, b, lb=np.zeros(m)), solver=backend, initvals=x0, **kw)
            f = np.zeros(m) if sol.x is None else np.asarray(sol.x, dtype=float).copy()
            info = sol.extras.get("info") if isinstance(sol.extras, dict) else None
            status = str(getattr(info, "status", "found" if sol.found else "not_found")).split(".")[-1]
            iters = int(getattr(info, "iter", 0))
    except Exception as exc:  # noqa: BLE001 - a backend's own refusal or failure becomes a status
        return np.zeros(m), backend_failure(exc), 0
    if not np.all(np.isfinite(f)):
        return np.where(np.isfinite(f), f, 0.0), status, iters
    f = np.maximum(f, 0.0)
    if polish:  # also after a max-iteration stop: the certificate, not the status, decides success
        f = _polish(A, b, f, tol)
    return f, status, iters
