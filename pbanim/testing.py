"""Assertions for tests and graders: orders as slopes, conservation as ratios, gradients by FD.

Students' assignments are graded with these same functions, so each says in its message what was
measured and what was expected.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

import numpy as np

from .derivatives import central_jacobian
from .errors import InvalidInput
from .results import natural_map_residual

__all__ = ["fitted_order", "order_fit", "OrderFit", "assert_order", "assert_conserved", "check_grad", "assert_complementarity",
           "drift_ratio"]


@dataclass(frozen=True)
class OrderFit:
    """A fitted convergence order and the points it used and dropped.

    ``dropped`` lists (h, error, reason) for every point left out: outside the window (below it: the
    roundoff floor; above it: not yet in the asymptotic range).
    """

    order: float
    hs: np.ndarray
    errors: np.ndarray
    used: np.ndarray
    dropped: tuple

    def describe(self) -> str:
        kept = ", ".join(f"h={h:.3g}: {e:.3g}" for h, e in zip(self.hs[self.used], self.errors[self.used]))
        out = f"slope {self.order:.3f} from {int(self.used.sum())} points ({kept})"
        if self.dropped:
            out += "; dropped " + ", ".join(f"h={h:.3g}: {e:.3g} ({why})" for h, e, why in self.dropped)
        return out


def order_fit(hs, errors, window: tuple[float, float] = (1e-10, 1e-2)) -> OrderFit:
    """Least-squares slope of log(error) vs log(h) over the points with error inside ``window``.

    Refuses (:class:`~pbanim.errors.InvalidInput`) a NaN or infinite error (a diverged run is not a data
    point to drop), non-positive or non-finite steps, mismatched lengths, and fewer than 2 points in the
    window; reports every point it drops.
    """
    h = np.asarray(hs, dtype=float).ravel()
    e = np.asarray(errors, dtype=float).ravel()
    if h.size != e.size:
        raise InvalidInput(f"hs and errors must have the same length, got {h.size} and {e.size}")
    if not np.all(np.isfinite(h)) or np.any(h <= 0):
        raise InvalidInput(f"hs must be positive finite steps, got {h}")
    if not np.all(np.isfinite(e)) or np.any(e < 0):
        bad = np.flatnonzero(~np.isfinite(e) | (e < 0))
        raise InvalidInput(f"errors must be finite and >= 0, got {e[bad[0]]} at h = {h[bad[0]]:.3g} "
                           "(a method that diverged at some h has no order there: fix or shrink the steps)")
    lo, hi = window
    if not (0 <= lo < hi):
        raise InvalidInput(f"window must be (lo, hi) with 0 <= lo < hi, got {window}")
    used = (e >= lo) & (e <= hi)
    dropped = tuple((float(hh), float(ee), "below the window" if ee < lo else "above the window")
                    for hh, ee, u in zip(h, e, used) if not u)
    if used.sum() < 2:
        raise InvalidInput(f"need at least 2 errors inside the window {window} to fit an order, got {e}")
    slope, _ = np.polyfit(np.log(h[used]), np.log(e[used]), 1)
    return OrderFit(float(slope), h, e, used, dropped)


def fitted_order(hs, errors, window: tuple[float, float] = (1e-10, 1e-2)) -> float:
    """The slope of :func:`order_fit` (which refuses NaN errors and records dropped points).

    >>> h = np.array([0.1, 0.05, 0.025]); round(fitted_order(h, 3 * h**2), 6)
    2.0
    """
    return order_fit(hs, errors, window).order


def assert_order(hs, errors, order: float, tol: float = 0.15, window: tuple[float, float] = (1e-10, 1e-2)) -> float:
    """Assert the fitted convergence slope is within ``tol`` of ``order`` (ORACLES A3); return it.

    The message lists the points used and every point dropped, with the reason.
    """
    fit = order_fit(hs, errors, window)
    assert abs(fit.order - order) <= tol, f"fitted order {fit.order:.3f}, expected {order} ± {tol}: {fit.describe()}"
    return fit.order


def drift_ratio(series, early: float = 0.2, late: float = 0.2) -> float:
    """max|x − x₀| over the last ``late`` fraction divided by that over the first ``early`` fraction.

    Refuses (:class:`~pbanim.errors.InvalidInput`) fewer than 2 samples, NaN/Inf samples and fractions
    outside (0, 1].
    """
    s = np.asarray(series, dtype=float)
    if s.ndim == 0 or len(s) < 2 or s[0].size == 0:
        raise InvalidInput(f"series must hold at least 2 samples, got shape {s.shape}")
    if not np.all(np.isfinite(s)):
        raise InvalidInput(f"series must be finite, got {s[~np.isfinite(s)][0]} (a diverged run has no drift ratio)")
    for nm, f in (("early", early), ("late", late)):
        if not (isinstance(f, (int, float, np.integer, np.floating)) and 0 < f <= 1):
            raise InvalidInput(f"{nm} must be a fraction in (0, 1], got {f}")
    dev = np.abs(s - s[0])
    n = len(s)
    a = dev[1:max(2, int(early * n))].max()
    b = dev[min(n - 1, int((1 - late) * n)):].max()
    return float(b / a) if a > 0 else (0.0 if b == 0 else np.inf)


def assert_conserved(series, rtol: float, name: str = "quantity", atol: float = 0.0) -> float:
    """Assert max|x(t) − x(0)| ≤ atol + rtol·|x(0)| elementwise over time (axis 0); return the max rel error."""
    s = np.asarray(series, dtype=float)
    if s.ndim == 0 or len(s) == 0 or s[0].size == 0:
        raise InvalidInput(f"series must hold at least one sample, got shape {s.shape}")
    if not np.all(np.isfinite(s)):
        raise InvalidInput(f"series must be finite, got {s[~np.isfinite(s)][0]}; {name} diverged")
    for nm, tol in (("rtol", rtol), ("atol", atol)):
        if not (isinstance(tol, (int, float, np.integer, np.floating)) and np.isfinite(tol) and tol >= 0):
            raise InvalidInput(f"{nm} must be a finite number >= 0, got {tol}")
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
    Jfd = central_jacobian(f, x, eps, relative=True)
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
