"""Steps that use the Jacobian ∂f/∂y: implicit Euler, implicit midpoint (Newton), exponential Euler.

Implicit Euler and the implicit midpoint rule solve z = y₀ + θh f(t, z) (θ = 1 and ½) by simplified Newton
with the Newton matrix I − θhJ frozen at the step start (:func:`newton_solve`): for a linear force the
first iterate is exact, and it is Baraff & Witkin's linearized step (I − hJ)Δy = h f(y₀). The exponential
Rosenbrock–Euler step applies φ₁(hJ) = (e^(hJ) − I)(hJ)⁻¹ through one matrix exponential
(:func:`expm_small`). J comes from ``jac`` (dense, scipy.sparse, or a constant matrix), else from forward
differences (n extra evaluations).

References: Baraff & Witkin, "Large steps in cloth simulation", SIGGRAPH 1998; Hairer & Wanner, *Solving
ODEs II*, §IV.8 (simplified Newton); Hochbruck & Ostermann, "Exponential integrators", Acta Numerica 2010;
Higham, "The scaling and squaring method for the matrix exponential revisited", SIMAX 26, 2005.

Shared with the stiff adaptive methods (:mod:`pbanim.ode.rosenbrock`, :mod:`pbanim.ode.radau`):
:func:`jacobian`, :func:`time_derivative` and :func:`factor`, which returns a solver r ↦ (σI − J)⁻¹r
for one shift σ, reused for every stage and Newton iteration until h or J changes. For small dense
systems (n ≤ ``SMALL`` = 12) the reused "factorization" is the explicit inverse: one product per solve
instead of a LAPACK call whose Python overhead is ~10× its flops at n = 3 (the forward error,
κ(M)·ε‖x‖, is of the same order as the LU solve's; Golub & Van Loan, *Matrix Computations*, §3.5).
"""

from __future__ import annotations

from typing import Callable

import numpy as np
import scipy.linalg as sla
import scipy.sparse as sp

from .second_order import SecondOrderJacobian
from .signature import JAC, STEP, finite_step
from ..contracts import Array, Func, Int, Opt, Real, contract
from ..errors import ConvergenceError, InvalidInput, NonFiniteResult, check_result

_maxred = np.maximum.reduce     # np.max without its Python wrapper (the same reduction, NaN kept)

__all__ = ["newton_solve", "implicit_euler_step", "implicit_midpoint_step", "expm_small", "exponential_euler_step",
           "jacobian", "time_derivative", "factor", "SMALL"]


def _fd_jacobian(fun, t, z, f0):
    """Forward-difference Jacobian ∂f/∂y (n extra evaluations; batched: one (K, n, n) array)."""
    n = z.shape[-1]
    eps = np.sqrt(np.finfo(float).eps)
    dz = eps * np.maximum(1.0, np.abs(z))
    J = np.empty(z.shape + (n,))
    for j in range(n):
        zj = z.copy()
        zj[..., j] += dz[..., j]
        J[..., :, j] = (fun(t, zj) - f0) / dz[..., j, None]
    return J


def _jacobian(fun, t, z, f, jac):
    """J = ∂f/∂y at z: ``jac(t, z)``, a constant ``jac``, or forward differences; a sparse J only outside
    batch mode."""
    if jac is None:
        return _fd_jacobian(fun, t, z, f)
    J = jac(t, z) if callable(jac) else jac
    if sp.issparse(J) and z.ndim != 1:
        raise InvalidInput("jac must be a dense (K, n, n) array in batch mode, got a sparse matrix")
    return J


def _newton_matrix(fun, t, z, f, theta_h, jac, batch):
    """A solver for (I − θh J) Δ = r with J = ∂f/∂y at z (from ``jac`` or forward differences)."""
    J = _jacobian(fun, t, z, f, jac)
    n = z.shape[-1]
    if sp.issparse(J):
        lu = sp.linalg.splu(sp.csc_matrix(sp.identity(n, format="csc") - theta_h * J))
        return lu.solve
    M = np.eye(n) - theta_h * np.asarray(J, dtype=float)
    if batch:
        return lambda r: np.linalg.solve(M, r[..., None])[..., 0]
    lu = sla.lu_factor(M, check_finite=False)
    return lambda r: sla.lu_solve(lu, r, check_finite=False)


@contract(fun=Func(), t=Real(), y0=STEP["y"], theta_h=Real(), jac=Opt(JAC), tol=Real(gt=0), max_iter=Int(ge=1, le=10_000))
def newton_solve(fun: Callable, t: float, y0: np.ndarray, theta_h: float, jac=None, tol: float = 1e-12,
                 max_iter: int = 20) -> np.ndarray:
    """Solve z = y₀ + θh f(t, z) by simplified Newton from z⁰ = y₀, with M = I − θh J frozen at y₀.

    ``jac(t, y)`` (dense or scipy.sparse, or a constant matrix) gives J = ∂f/∂y; without it a
    forward-difference Jacobian is used. For a linear f the first iterate is exact: it is Baraff's
    linearized implicit step Δy = (I − θhJ)⁻¹ θh f(y₀); the second iteration only confirms it.
    When the frozen matrix contracts slowly (a correction more than a tenth of the previous one, as on a
    hanging spring net without shear springs, where it contracts by only ~1/3 per iteration) J is
    re-evaluated at the current iterate and refactored, so Newton converges fast again (the contraction
    test follows Hairer & Wanner, *Solving ODEs II*, §IV.8).
    Converged when ‖Δz‖∞ ≤ tol·(1 + ‖z‖∞) (per trajectory in batch mode), or when the corrections stop
    shrinking once below 1e-8 relative (roundoff of an ill-conditioned I − θhJ); raises
    :class:`ConvergenceError` otherwise after ``max_iter`` iterations.
    """
    z = np.array(y0, dtype=float, copy=True)
    f = fun(t, z)
    batch = z.ndim == 2
    solve = _newton_matrix(fun, t, z, f, theta_h, jac, batch)
    refresh = None if jac is not None and not callable(jac) else (
        lambda t, z, f: _newton_matrix(fun, t, z, f, theta_h, jac, batch))
    return _iterate(fun, t, y0, z, f, theta_h, solve, refresh, tol, max_iter)[0]


def _iterate(fun, t, y0, z, f, theta_h, solve, refresh, tol, max_iter):
    """The iterations of :func:`newton_solve` from z (= y₀, written) with f = f(t, z) and the solver ``solve``
    of M; ``refresh(t, z, f)`` gives a new solver when the contraction is slow (None: M is kept). Returns
    (z, the solver in use at the end)."""
    res = prev = np.inf
    for it in range(1, max_iter + 1):
        dz = solve(y0 + theta_h * f - z)
        z += dz
        if not dz.size:
            return z, solve
        # relative Newton correction, per trajectory in batch mode
        res = float(_maxred(_maxred(np.abs(dz), axis=-1) / (1.0 + _maxred(np.abs(z), axis=-1)), axis=None))
        if not np.isfinite(res):
            break
        if res <= tol or (res <= 1e-8 and res >= prev):  # converged, or no progress at roundoff level
            return z, solve
        slow = res > 0.1 * prev
        prev = res
        f = fun(t, z)
        if slow and refresh is not None:
            solve = refresh(t, z, f)
    raise ConvergenceError("Newton (implicit step)", it, res, tol,
                           f"at t = {t:.6g}, θh = {theta_h:.3g}; reduce the step h")


@contract(**STEP, returns=finite_step)
def implicit_euler_step(fun: Callable, t: float, y: np.ndarray, h: float, split: int | None = None,
                        jac=None) -> np.ndarray:
    """Implicit (backward) Euler: y₁ = y₀ + h f(t + h, y₁), solved by Newton (:func:`newton_solve`).

    Order 1, L-stable: on ẍ = −ω²x the energy factor per step is 1/(1 + h²ω²) (ORACLES A1); stable for
    every h. With ``jac`` the Newton matrix is I − hJ (one LU per step); for a linear force one Newton
    iteration is Baraff & Witkin's linearized step (I − hJ)Δy = h f(y₀).

    >>> implicit_euler_step(lambda t, y: -y, 0.0, np.array([1.0]), 1.0)
    array([0.5])
    """
    return newton_solve(fun, t + h, y, h, jac)


@contract(**STEP, returns=finite_step)
def implicit_midpoint_step(fun: Callable, t: float, y: np.ndarray, h: float, split: int | None = None,
                           jac=None) -> np.ndarray:
    """Implicit midpoint: y₁ = y₀ + h f(t + h/2, (y₀ + y₁)/2).

    Computed as an implicit Euler half step to the midpoint z, then y₁ = 2z − y₀. Order 2, A-stable,
    symplectic for every Hamiltonian (also non-separable H(q, p), e.g. reduced coordinates with M(q)),
    and it conserves every quadratic invariant (energy of linear systems, angular momentum) exactly.

    >>> implicit_midpoint_step(lambda t, y: np.array([y[1], -y[0]]), 0.0, np.array([1.0, 0.0]), 2.0)
    array([ 0., -1.])
    """
    z = newton_solve(fun, t + 0.5 * h, y, 0.5 * h, jac)
    return 2.0 * z - y


def _pade13():
    """Coefficients b_k ∝ (26 − k)! / (k! (13 − k)!) of the [13/13] Padé approximant of eˣ, b₁₃ = 1."""
    from math import factorial

    c = [factorial(26 - k) / (factorial(k) * factorial(13 - k)) for k in range(14)]
    return [ck / c[13] for ck in c]


_B13 = _pade13()
_THETA13 = 5.371920351148152  # ‖A‖₁ below which [13/13] Padé is accurate to double precision (Higham 2005)


@contract(A=Array(("n", "n"), batch="first"))
def expm_small(A: np.ndarray) -> np.ndarray:
    """e^A for small dense matrices (batched over leading axes): scaling and squaring with [13/13] Padé.

    A is scaled by 2⁻ˢ so that max(‖A⁴‖^¼, ‖A⁵‖^⅕) ≤ θ₁₃ = 5.37, r₁₃(A/2ˢ) = (V − U)⁻¹(V + U) is formed from
    even/odd powers, then squared s times (Higham, SIMAX 26, 2005; Al-Mohy & Higham, SIMAX 31, 2009).
    Within ~10⁻¹¹ relative of 50-digit mpmath on stiff-spring matrices (``scipy.linalg.expm``, which trims
    the squarings further, gets ~10⁻¹³) at a dozen small matrix products: for the 3×3 matrices of one
    integrator step it is ~30× cheaper than ``scipy.linalg.expm``'s norm estimation.

    >>> bool(np.allclose(expm_small(np.array([[0.0, np.pi], [-np.pi, 0.0]])), -np.eye(2)))
    True
    """
    A = np.asarray(A, dtype=float)
    if not np.isfinite(A).all():
        raise NonFiniteResult("expm_small", "its matrix A has NaN or inf entries (a Jacobian that overflowed?)")
    norm1 = lambda M: float(np.max(np.sum(np.abs(M), axis=-2))) if M.size else 0.0  # noqa: E731
    norm = norm1(A)
    s1 = max(0, int(np.ceil(np.log2(norm / _THETA13)))) if norm > _THETA13 else 0
    A = A / np.ldexp(1.0, s1)
    A2 = A @ A
    A4 = A2 @ A2
    # fewer squarings for non-normal A (a stiff spring's [[0, 1], [−ω², −c]]): scale by
    # α₄ = max(‖A⁴‖^¼, ‖A⁵‖^⅕) ≤ ‖A‖ instead of ‖A‖ (Al-Mohy & Higham, SIMAX 31, 2009)
    alpha = max(norm1(A4) ** 0.25, norm1(A4 @ A) ** 0.2)
    s = max(0, s1 + (int(np.ceil(np.log2(alpha / _THETA13))) if alpha > 0 else -s1))
    if s != s1:
        f = np.ldexp(1.0, s1 - s)       # a float64: an overflow is inf (named below), not a Python error
        A, A2, A4 = A * f, A2 * f**2, A4 * f**4
    A6 = A4 @ A2
    b = _B13
    eye = np.broadcast_to(np.eye(A.shape[-1]), A.shape)
    U = A @ (A6 @ (b[13] * A6 + b[11] * A4 + b[9] * A2) + b[7] * A6 + b[5] * A4 + b[3] * A2 + b[1] * eye)
    V = A6 @ (b[12] * A6 + b[10] * A4 + b[8] * A2) + b[6] * A6 + b[4] * A4 + b[2] * A2 + b[0] * eye
    with np.errstate(all="ignore"):     # an overflow is named below
        E = np.linalg.solve(V - U, V + U)
        for _ in range(s):
            E = E @ E
    return check_result("expm_small", E, f"‖A‖₁ = {norm:.3g}")


@contract(**STEP, returns=finite_step)
def exponential_euler_step(fun: Callable, t: float, y: np.ndarray, h: float, split: int | None = None,
                           jac=None) -> np.ndarray:
    """Exponential (Rosenbrock–)Euler: y₁ = y₀ + h φ₁(hJ) f + h² φ₂(hJ) v, J = ∂f/∂y, v = ∂f/∂t at (t, y₀).

    φ₁(z) = (eᶻ − 1)/z, φ₂(z) = (eᶻ − 1 − z)/z². This is the exponential Euler step of the autonomous
    system (y, t)' = (f, 1), so it is order 2 also when f depends on t (forced springs, moving anchors);
    without the v term it would be order 1 there (Hochbruck & Ostermann, Acta Numerica 2010, §2.4 and
    ORACLES A3). **Exact** for linear constant-coefficient systems (a linear damped spring: y₁ = e^(hJ) y₀
    at any h); stability region the whole left half-plane. Both φ terms are read off one matrix exponential
    of the augmented matrix [[hJ, hv, hf], [0, 0, h], [0, 0, 0]] (:func:`expm_small` or
    ``scipy.linalg.expm``, batched over K; ``expm_multiply`` for a sparse J). v is a forward difference
    in t (one more evaluation of f), skipped for a right-hand side that declares ``fun.autonomous = True``;
    without ``jac`` J is a forward difference too.

    >>> y = exponential_euler_step(lambda t, y: np.array([y[1], -y[0]]), 0.0, np.array([1.0, 0.0]), np.pi,
    ...                            jac=lambda t, y: np.array([[0.0, 1.0], [-1.0, 0.0]]))
    >>> bool(np.allclose(y, [-1.0, 0.0]))   # half a period of the oscillator in one exact step
    True
    """
    f = fun(t, y)
    J = _jacobian(fun, t, y, f, jac)
    # columns after J: [h v, h f] with the t row (0, h), or just h f for a declared time-independent f
    cols = [h * f]
    if not getattr(fun, "autonomous", False):
        dt = np.sqrt(np.finfo(float).eps) * max(1.0, abs(t))
        cols.insert(0, h * (fun(t + dt, y) - f) / dt)
    n, p = y.shape[-1], len(cols)
    if sp.issparse(J):
        from scipy.sparse.linalg import expm_multiply

        top = sp.hstack([h * J] + [sp.csc_matrix(np.asarray(c, dtype=float).reshape(-1, 1)) for c in cols])
        tail = sp.csc_matrix((p, n + p))
        if p == 2:
            tail = sp.csc_matrix(([h], ([0], [n + 1])), shape=(p, n + p))
        aug = sp.vstack([top, tail], format="csc")
        e = np.zeros(n + p)
        e[-1] = 1.0
        return y + expm_multiply(aug, e)[:n]
    aug = np.zeros(y.shape[:-1] + (n + p, n + p))
    aug[..., :n, :n] = h * np.asarray(J, dtype=float)
    for i, c in enumerate(cols):
        aug[..., :n, n + i] = c
    if p == 2:
        aug[..., n, n + 1] = h
    return y + (expm_small(aug) if n < 32 else sla.expm(aug))[..., :n, -1]


# ---------------------------------------------------------------------------------------------------
# Jacobians and reusable factorizations for the stiff adaptive methods
# ---------------------------------------------------------------------------------------------------

#: systems up to this size are solved through the explicit inverse of M
SMALL = 12


def jacobian(fun, t, y, f, jac):
    """J = ∂f/∂y at (t, y): ``jac(t, y)``, a constant ``jac`` (array or sparse), or forward differences."""
    if jac is None:
        return _fd_jacobian(fun, t, y, f)
    J = jac(t, y) if callable(jac) else jac
    if isinstance(J, SecondOrderJacobian):       # [[0, I], [Jx, Jv]] in blocks: solved at half size
        if J.shape != (y.shape[-1],) * 2 or y.ndim != 1:
            raise InvalidInput(f"jac returned a SecondOrderJacobian of shape {J.shape} for y of shape {y.shape}")
        return J
    if sp.issparse(J):
        if y.ndim != 1:
            raise InvalidInput("jac must be a dense (K, n, n) array in batch mode, got a sparse matrix")
        return sp.csc_matrix(J)
    J = np.asarray(J, dtype=float)
    n = y.shape[-1]
    if J.shape[-2:] != (n, n):
        raise InvalidInput(f"jac must return an ({n}, {n}) matrix (∂f/∂y), got shape {J.shape}")
    return J


def time_derivative(fun, t, y, f):
    """∂f/∂t at (t, y) by a forward difference (one evaluation), or 0 if ``fun.autonomous`` says so."""
    if getattr(fun, "autonomous", False):
        return None
    dt = np.sqrt(np.finfo(float).eps) * max(1.0, abs(t))
    return (fun(t + dt, y) - f) / dt


def stage_solver(sigma, J, t, h):
    """:func:`factor` for one fixed step called by a user: a singular σI − J (σ = 1/(hγ) overflows for a
    tiny h, or J has an eigenvalue at σ) is :class:`~pbanim.errors.SimulationDiverged` at t naming h."""
    try:
        return factor(sigma, J)
    except (np.linalg.LinAlgError, RuntimeError) as exc:
        from ..errors import SimulationDiverged
        raise SimulationDiverged(t, 0, "the stage matrix σI − J", f"it is singular at h = {h:g} ({exc}); "
                                 "use another step") from None


def factor(sigma, J):
    """A solver r ↦ (σI − J)⁻¹ r for a real or complex shift σ; batched over leading axes of a dense J; a
    :class:`~pbanim.ode.second_order.SecondOrderJacobian` through its n × n Schur complement."""
    if isinstance(J, SecondOrderJacobian):
        return J.factor(sigma)
    if sp.issparse(J):
        n = J.shape[0]
        lu = sp.linalg.splu(sp.csc_matrix(sigma * sp.identity(n, format="csc", dtype=complex if np.iscomplexobj(sigma) else float) - J))
        return lu.solve
    n = J.shape[-1]
    if J.ndim == 2 and n == 2:          # closed form: no LAPACK call for the 2 × 2 case (Van der Pol, springs)
        a, b, c, d = sigma - J[0, 0], -J[0, 1], -J[1, 0], sigma - J[1, 1]
        det = a * d - b * c
        if det == 0 or not np.isfinite(det):
            raise np.linalg.LinAlgError("singular matrix: σI − J has determinant 0")
        return (np.array([[d, -b], [-c, a]]) / det).dot
    M = -J.astype(np.result_type(J, sigma))
    idx = np.arange(n)
    M[..., idx, idx] += sigma
    if M.ndim > 2:                       # a batch (K, n, n): one inverse per trajectory
        Minv = np.linalg.inv(M)
        return lambda r: np.einsum("kij,kj->ki", Minv, r)
    if n <= SMALL:
        Minv = np.linalg.inv(M)
        return Minv.dot
    lu = sla.lu_factor(M, check_finite=False)
    return lambda r: sla.lu_solve(lu, r, check_finite=False)
