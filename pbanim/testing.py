"""Assertions for tests and graders: orders as slopes, conservation as ratios, gradients by FD.

Students' assignments are graded with these same functions, so each says in its message what was
measured and what was expected.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

import numpy as np

from .derivatives import central_jacobian
from .contracts import Anything, Array, Either, Func, Obj, Real, Text, contract
from .errors import InvalidInput, check_result
from .results import natural_map_residual

__all__ = ["fitted_order", "order_fit", "OrderFit", "assert_order", "assert_conserved", "check_grad", "assert_complementarity",
           "drift_ratio"]


_STEPS = Array((None,), gt=0)
_ERRORS = Array((None,), ge=0)
_WINDOW = Array((2,), ge=0)

@contract(order=Real(finite=False), hs=Array((None,)), errors=Array((None,)), used=Anything("a boolean mask over hs"),
          dropped=Anything("a tuple of (h, error, reason) triples"))
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


@contract(hs=_STEPS, errors=_ERRORS, window=_WINDOW)
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
    if not (np.all(np.isfinite(h)) and np.all(np.isfinite(e)) and np.all(h > 0) and np.all(e >= 0)):
        # internal callers (the engine comparison, the grader) reach here without the boundary check
        bad = int(np.flatnonzero(~(np.isfinite(h) & np.isfinite(e) & (h > 0) & (e >= 0)))[0])
        raise InvalidInput(f"order_fit: (h, error) = ({h[bad]:.3g}, {e[bad]}) is not a positive step with a finite "
                           "error >= 0 (a method that diverged at some h has no order there)")
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


@contract(hs=_STEPS, errors=_ERRORS, window=_WINDOW)
def fitted_order(hs, errors, window: tuple[float, float] = (1e-10, 1e-2)) -> float:
    """The slope of :func:`order_fit` (which refuses NaN errors and records dropped points).

    >>> h = np.array([0.1, 0.05, 0.025]); round(fitted_order(h, 3 * h**2), 6)
    2.0
    """
    return order_fit(hs, errors, window).order


@contract(hs=_STEPS, errors=_ERRORS, order=Real(gt=0), tol=Real(gt=0), window=_WINDOW)
def assert_order(hs, errors, order: float, tol: float = 0.15, window: tuple[float, float] = (1e-10, 1e-2)) -> float:
    """Assert the fitted convergence slope is within ``tol`` of ``order`` (ORACLES A3); return it.

    The message lists the points used and every point dropped, with the reason.
    """
    fit = order_fit(hs, errors, window)
    assert abs(fit.order - order) <= tol, f"fitted order {fit.order:.3f}, expected {order} ± {tol}: {fit.describe()}"
    return fit.order


@contract(series=Array(None), early=Real(gt=0, le=1), late=Real(gt=0, le=1))
def drift_ratio(series, early: float = 0.2, late: float = 0.2) -> float:
    """max|x − x₀| over the last ``late`` fraction divided by that over the first ``early`` fraction.

    Refuses (:class:`~pbanim.errors.InvalidInput`) fewer than 2 samples, NaN/Inf samples and fractions
    outside (0, 1].
    """
    s = np.asarray(series, dtype=float)
    if s.ndim == 0 or len(s) < 2 or s[0].size == 0:
        raise InvalidInput(f"series must hold at least 2 samples, got shape {s.shape}")
    dev = np.abs(s - s[0])
    n = len(s)
    a = dev[1:max(2, int(early * n))].max()
    b = dev[min(n - 1, int((1 - late) * n)):].max()
    return float(b / a) if a > 0 else (0.0 if b == 0 else np.inf)


@contract(series=Array(None), rtol=Real(ge=0), name=Text(), atol=Real(ge=0))
def assert_conserved(series, rtol: float, name: str = "quantity", atol: float = 0.0) -> float:
    """Assert max|x(t) − x(0)| ≤ atol + rtol·|x(0)| elementwise over time (axis 0); return the max rel error."""
    s = np.asarray(series, dtype=float)
    if s.ndim == 0 or len(s) == 0 or s[0].size == 0:
        raise InvalidInput(f"series must hold at least one sample, got shape {s.shape}")
    ref = s[0]
    dev = np.max(np.abs(s - ref), axis=0)
    scale = np.abs(ref)
    bound = atol + rtol * scale
    ok = np.all(dev <= bound)
    rel = float(np.max(dev / np.where(scale > 0, scale, 1.0)))
    assert ok, f"{name} not conserved: max deviation {np.max(dev):.3e} > {np.max(bound):.3e} (rel {rel:.3e})"
    return rel


@contract(f=Func(), x=Array(None), J=Either(Array(None), Obj("scipy.sparse:sparray", "scipy.sparse:spmatrix", what="a scipy.sparse matrix")), eps=Real(gt=0), rtol=Real(ge=0), atol=Real(ge=0))
def check_grad(f: Callable[[np.ndarray], np.ndarray], x, J, eps: float = 1e-6, rtol: float = 1e-6,
               atol: float = 1e-8) -> float:
    """Compare a Jacobian ``J`` (dense or sparse) of ``f`` at ``x`` with centred finite differences.

    Returns the max abs difference; raises AssertionError naming the worst entry.
    """
    x = np.asarray(x, dtype=float)
    J = J.toarray() if hasattr(J, "toarray") else np.asarray(J, dtype=float)
    Jfd = central_jacobian(f, x, eps, relative=True)
    if J.size != Jfd.size:
        raise InvalidInput(f"check_grad: J must have f(x).size × x.size = {Jfd.shape} entries, got shape {J.shape}")
    J = J.reshape(Jfd.shape)
    check_result("check_grad: the finite differences of f", Jfd, f"eps = {eps:g}")
    diff = np.abs(J - Jfd)
    bound = atol + rtol * np.abs(Jfd)
    if np.any(diff > bound):
        i, j = np.unravel_index(np.argmax(diff - bound), diff.shape)
        raise AssertionError(f"Jacobian mismatch at ({i}, {j}): analytic {J[i, j]:.6e}, "
                             f"finite difference {Jfd[i, j]:.6e}")
    return float(diff.max()) if diff.size else 0.0


@contract(f=Array(("m",), empty=True), w=Array(("m",), empty=True), tol=Real(ge=0))
def assert_complementarity(f, w, tol: float = 1e-10) -> float:
    """Assert f ≥ −tol, w ≥ −tol and the natural-map residual ≤ tol (ORACLES D8); return the residual."""
    f = np.asarray(f, dtype=float)
    w = np.asarray(w, dtype=float)
    r = natural_map_residual(f, w)
    assert r <= tol, f"natural-map residual {r:.3e} > {tol:.1e}"
    assert f.size == 0 or f.min() >= -tol, f"negative force {f.min():.3e}"
    assert w.size == 0 or w.min() >= -tol, f"penetrating acceleration {w.min():.3e}"
    return r
