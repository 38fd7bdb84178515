"""Assertions for tests and graders: orders as slopes, conservation as ratios, gradients by FD.

Students' assignments are graded with these same functions, so each says in its message what was
measured and what was expected.
"""

from __future__ import annotations

from typing import Callable

import numpy as np

from .results import natural_map_residual

__all__ = ["fitted_order", "assert_order", "assert_conserved", "check_grad", "assert_complementarity",
           "drift_ratio"]


def fitted_order(hs, errors, window: tuple[float, float] = (1e-10, 1e-2)) -> float:
    """Least-squares slope of log(error) vs log(h), using only points with error inside ``window``.

    >>> h = np.array([0.1, 0.05, 0.025]); round(fitted_order(h, 3 * h**2), 6)
    2.0
    """
    hs = np.asarray(hs, dtype=float)
    errors = np.asarray(errors, dtype=float)
    keep = (errors >= window[0]) & (errors <= window[1]) & np.isfinite(errors)
    if keep.sum() < 2:
        raise ValueError(f"need at least 2 errors inside {window} to fit an order, got {errors}")
    slope, _ = np.polyfit(np.log(hs[keep]), np.log(errors[keep]), 1)
    return float(slope)


def assert_order(hs, errors, order: float, tol: float = 0.15, window: tuple[float, float] = (1e-10, 1e-2)) -> float:
    """Assert the fitted convergence slope is within ``tol`` of ``order`` (ORACLES A3); return it."""
    p = fitted_order(hs, errors, window)
    assert abs(p - order) <= tol, f"fitted order {p:.3f}, expected {order} ± {tol} (errors {np.asarray(errors)})"
    return p


def drift_ratio(series, early: float = 0.2, late: float = 0.2) -> float:
    """max|x − x₀| over the last ``late`` fraction divided by that over the first ``early`` fraction."""
    s = np.asarray(series, dtype=float)
    dev = np.abs(s - s[0])
    n = len(s)
    a = dev[1:max(2, int(early * n))].max()
    b = dev[int((1 - late) * n):].max()
    return float(b / a) if a > 0 else (0.0 if b == 0 else np.inf)


def assert_conserved(series, rtol: float, name: str = "quantity", atol: float = 0.0) -> float:
    """Assert max|x(t) − x(0)| ≤ atol + rtol·|x(0)| elementwise over time (axis 0); return the max rel error."""
    s = np.asarray(series, dtype=float)
    ref = s[0]
    dev = np.max(np.abs(s - ref), axis=0)
    scale = np.abs(ref)
    bound = atol + rtol * scale
    ok = np.all(dev <= bound)
    rel = float(np.max(dev / np.where(scale > 0, scale, 1.0)))
    assert ok, f"{name} not conserved: max deviation {np.max(dev):.3e} > {np.max(bound):.3e} (rel {rel:.3e})"
    return rel


def check_grad(f: Callable[[np.ndarray], np.ndarray], x, J, eps: float = 1e-6, rtol: float = 1e-6,
               atol: float = 1e-8) -> float:
    """Compare a Jacobian ``J`` (dense or sparse) of ``f`` at ``x`` with centred finite differences.

    Returns the max abs difference; raises AssertionError naming the worst entry.
    """
    x = np.asarray(x, dtype=float)
    J = J.toarray() if hasattr(J, "toarray") else np.asarray(J, dtype=float)
    f0 = np.atleast_1d(f(x))
    Jfd = np.empty((f0.size, x.size))
    for i in range(x.size):
        dx = np.zeros_like(x)
        dx[i] = eps * max(1.0, abs(x[i]))
        Jfd[:, i] = (np.atleast_1d(f(x + dx)) - np.atleast_1d(f(x - dx))).ravel() / (2 * dx[i])
    J = J.reshape(Jfd.shape)
    diff = np.abs(J - Jfd)
    bound = atol + rtol * np.abs(Jfd)
    if np.any(diff > bound):
        i, j = np.unravel_index(np.argmax(diff - bound), diff.shape)
        raise AssertionError(f"Jacobian mismatch at ({i}, {j}): analytic {J[i, j]:.6e}, "
                             f"finite difference {Jfd[i, j]:.6e}")
    return float(diff.max()) if diff.size else 0.0


def assert_complementarity(f, w, tol: float = 1e-10) -> float:
    """Assert f ≥ −tol, w ≥ −tol and the natural-map residual ≤ tol (ORACLES D8); return the residual."""
    f = np.asarray(f, dtype=float)
    w = np.asarray(w, dtype=float)
    r = natural_map_residual(f, w)
    assert r <= tol, f"natural-map residual {r:.3e} > {tol:.1e}"
    assert f.size == 0 or f.min() >= -tol, f"negative force {f.min():.3e}"
    assert w.size == 0 or w.min() >= -tol, f"penetrating acceleration {w.min():.3e}"
    return r
