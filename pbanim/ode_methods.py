"""Integrators as data: Butcher tableaux, split (symplectic) steps, implicit steps, the registry.

Every method advances ẏ = f(t, y) by one step h: ``step(fun, t, y, h, split=None, jac=None) -> y_new``,
on a state of shape (n,) or a batch (K, n) (``fun`` then receives (K, n) arrays). See :mod:`pbanim.ode`
for the lecture (equations, notation, stability limits, references).

Explicit Runge–Kutta methods (Euler, midpoint, RK4, the Dormand–Prince 5(4) pair) are :class:`Tableau`
objects run by one stepper, :func:`explicit_rk_step`; a tableau checks its own consistency
(ΣB = 1, rows of A sum to C, A strictly lower triangular) when it is built.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Callable

import numpy as np
import scipy.linalg as sla
import scipy.sparse as sp

from .errors import ConvergenceError

__all__ = ["Method", "Tableau", "METHODS", "TABLEAUX", "get_method", "explicit_rk_step", "euler_step",
           "midpoint_step", "rk4_step", "symplectic_euler_step", "verlet_step", "implicit_euler_step",
           "implicit_midpoint_step", "exponential_euler_step", "dopri5_step", "newton_solve",
           "expm_small"]


# ---------------------------------------------------------------------------------------------------
# Butcher tableaux
# ---------------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class Tableau:
    """An explicit Runge–Kutta method  kᵢ = f(t + cᵢh, y + h Σⱼ aᵢⱼ kⱼ),  y₁ = y + h Σᵢ bᵢ kᵢ.

    ``E`` (optional) holds b − b̂ of an embedded lower-order formula, so the local error estimate is
    h Σᵢ eᵢ kᵢ. Building a tableau checks ΣB = 1, Σⱼ aᵢⱼ = cᵢ and that A is strictly lower triangular.

    >>> TABLEAUX["rk4"].stages, TABLEAUX["dopri5"].order
    (4, 5)
    """

    name: str
    A: np.ndarray
    B: np.ndarray
    C: np.ndarray
    order: int
    E: np.ndarray | None = None
    rows: tuple = field(init=False, repr=False)

    def __post_init__(self):
        A, B, C = (np.asarray(x, dtype=float) for x in (self.A, self.B, self.C))
        s = len(B)
        if A.shape != (s, s) or C.shape != (s,):
            raise ValueError(f"tableau {self.name}: A must be ({s}, {s}) and C ({s},), got {A.shape}, {C.shape}")
        if abs(B.sum() - 1.0) > 1e-14:
            raise ValueError(f"tableau {self.name}: weights B must sum to 1, got {B.sum()!r}")
        if np.max(np.abs(A.sum(axis=1) - C)) > 1e-14:
            raise ValueError(f"tableau {self.name}: rows of A must sum to C")
        if np.any(np.triu(A) != 0):
            raise ValueError(f"tableau {self.name}: A must be strictly lower triangular (explicit method)")
        object.__setattr__(self, "A", A)
        object.__setattr__(self, "B", B)
        object.__setattr__(self, "C", C)
        # nonzero coefficients per stage, precomputed so the stepper skips the zeros
        rows = tuple(tuple((j, A[i, j]) for j in range(i) if A[i, j] != 0) for i in range(s))
        object.__setattr__(self, "rows", rows)

    @property
    def stages(self) -> int:
        return len(self.B)


def _frac(*xs):
    return np.array([float(x) for x in xs])


_F = lambda a, b: a / b  # noqa: E731  (readable rational coefficients)

TABLEAUX: dict[str, Tableau] = {
    "euler": Tableau("euler", np.zeros((1, 1)), _frac(1), _frac(0), 1),
    "midpoint": Tableau("midpoint", np.array([[0, 0], [0.5, 0]]), _frac(0, 1), _frac(0, 0.5), 2),
    "rk4": Tableau("rk4", np.array([[0, 0, 0, 0], [0.5, 0, 0, 0], [0, 0.5, 0, 0], [0, 0, 1, 0]]),
                   _frac(1 / 6, 1 / 3, 1 / 3, 1 / 6), _frac(0, 0.5, 0.5, 1), 4),
    # Dormand & Prince (1980), the 5(4) pair with the FSAL property (last row of A = B)
    "dopri5": Tableau(
        "dopri5",
        np.array([
            [0, 0, 0, 0, 0, 0, 0],
            [_F(1, 5), 0, 0, 0, 0, 0, 0],
            [_F(3, 40), _F(9, 40), 0, 0, 0, 0, 0],
            [_F(44, 45), _F(-56, 15), _F(32, 9), 0, 0, 0, 0],
            [_F(19372, 6561), _F(-25360, 2187), _F(64448, 6561), _F(-212, 729), 0, 0, 0],
            [_F(9017, 3168), _F(-355, 33), _F(46732, 5247), _F(49, 176), _F(-5103, 18656), 0, 0],
            [_F(35, 384), 0, _F(500, 1113), _F(125, 192), _F(-2187, 6784), _F(11, 84), 0]]),
        _frac(_F(35, 384), 0, _F(500, 1113), _F(125, 192), _F(-2187, 6784), _F(11, 84), 0),
        _frac(0, _F(1, 5), _F(3, 10), _F(4, 5), _F(8, 9), 1, 1), 5,
        E=_frac(_F(35, 384) - _F(5179, 57600), 0, _F(500, 1113) - _F(7571, 16695),
                _F(125, 192) - _F(393, 640), _F(-2187, 6784) + _F(92097, 339200),
                _F(11, 84) - _F(187, 2100), _F(-1, 40))),
}


def _make_rk_step(tab: Tableau) -> Callable:
    """Compile a tableau into a straight-line step function (zero coefficients dropped).

    The generated code is what one would write by hand for that tableau (``k1 = fun(t + c₁h, y +
    (a₁₀h)·k0)`` ...), so the registered steps cost no more than a hand-written loop; the readable
    loop over the tableau is :func:`explicit_rk_step`, and the tests check that the two agree.
    """
    def combo(pairs):  # Σ aⱼ kⱼ with equal coefficients grouped: (k0 + k3) * (h * a) + ...
        groups: dict = {}
        for j, a in pairs:
            groups.setdefault(float(a), []).append(f"k{j}")
        parts = [(f"({' + '.join(ks)})" if len(ks) > 1 else ks[0]) + f" * (h * {a!r})" for a, ks in groups.items()]
        return " + ".join(parts)

    lines = ["def step(fun, t, y, h, split=None, jac=None):", "    k0 = fun(t, y)"]
    for i in range(1, tab.stages):
        lines.append(f"    k{i} = fun(t + {float(tab.C[i])!r} * h, y + ({combo(tab.rows[i])}))")
    lines.append(f"    return y + ({combo([(i, b) for i, b in enumerate(tab.B) if b != 0])})")
    namespace: dict = {}
    exec(compile("\n".join(lines), f"<tableau {tab.name}>", "exec"), namespace)  # noqa: S102
    step = namespace["step"]
    step.__name__ = f"{tab.name}_step"
    step.source = "\n".join(lines)
    step.nfev = tab.stages  # right-hand-side evaluations per step
    return step


_RK_STEPS = {name: _make_rk_step(tab) for name, tab in TABLEAUX.items()}


def explicit_rk_step(tableau: Tableau | str, fun: Callable, t: float, y: np.ndarray, h: float) -> np.ndarray:
    """One step of an explicit Runge–Kutta method given by its Butcher tableau (or its name).

    Readable reference: the stage loop written out with the full A matrix (the registered steps run the
    same formula with the zero coefficients skipped).

    >>> f = lambda t, y: -y
    >>> float(explicit_rk_step("rk4", f, 0.0, np.array([1.0]), 0.1)[0])  # 1 − h + h²/2 − h³/6 + h⁴/24
    0.9048375
    """
    tab = TABLEAUX[tableau] if isinstance(tableau, str) else tableau
    y = np.asarray(y)
    K = np.zeros((tab.stages,) + y.shape, dtype=np.result_type(y, float))
    for i in range(tab.stages):
        yi = y + h * np.tensordot(tab.A[i, :i], K[:i], axes=1) if i else y
        K[i] = fun(t + tab.C[i] * h, yi)
    return y + h * np.tensordot(tab.B, K, axes=1)


def euler_step(fun: Callable, t: float, y: np.ndarray, h: float, split: int | None = None, jac=None) -> np.ndarray:
    """Explicit Euler: y₁ = y₀ + h f(t₀, y₀) (order 1; energy factor 1 + h²ω² on the oscillator).

    >>> euler_step(lambda t, y: -y, 0.0, np.array([1.0]), 0.1)
    array([0.9])
    """
    return y + h * fun(t, y)


euler_step.nfev = 1
midpoint_step = _RK_STEPS["midpoint"]
midpoint_step.__doc__ = """Explicit midpoint: k₁ = f(t, y), y₁ = y + h f(t + h/2, y + h/2 k₁) (order 2)."""
rk4_step = _RK_STEPS["rk4"]
rk4_step.__doc__ = """Classical Runge–Kutta 4: four stages, order 4, stable on the oscillator iff hω ≤ 2√2.

>>> float(rk4_step(lambda t, y: np.ones_like(y) * t**3, 0.0, np.zeros(1), 1.0)[0])  # exact on cubics
0.25
"""


def dopri5_step(fun: Callable, t: float, y: np.ndarray, h: float, split: int | None = None, jac=None) -> np.ndarray:
    """One fixed step of the fifth-order Dormand–Prince formula (no error control; see :func:`pbanim.solve`)."""
    return _RK_STEPS["dopri5"](fun, t, y, h)


dopri5_step.nfev = 7


def _split(y: np.ndarray, split: int | None) -> int:
    n = y.shape[-1]
    return n // 2 if split is None else int(split)


def symplectic_euler_step(fun: Callable, t: float, y: np.ndarray, h: float, split: int | None = None,
                          jac=None) -> np.ndarray:
    """Symplectic Euler, kick then drift: v₁ = v₀ + h a(q₀, v₀); q₁ = q₀ + h q̇(q₀, v₁).

    ``split`` = number of position components q at the front of y (default n // 2). On ẍ = −ω²x it
    conserves H̃ = E − ½hω²xv exactly and is stable iff hω < 2 (ORACLES A1, A2).

    >>> symplectic_euler_step(lambda t, y: np.array([y[1], -y[0]]), 0.0, np.array([1.0, 0.0]), 0.1)
    array([ 0.99, -0.1 ])
    """
    s = _split(y, split)
    k = fun(t, y)
    y1 = np.array(y, dtype=np.result_type(y, float), copy=True)
    y1[..., s:] += h * k[..., s:]
    k2 = fun(t, y1)
    y1[..., :s] = y[..., :s] + h * k2[..., :s]
    return y1


symplectic_euler_step.nfev = 2


def verlet_step(fun: Callable, t: float, y: np.ndarray, h: float, split: int | None = None, jac=None) -> np.ndarray:
    """Velocity Verlet: v½ = v₀ + h/2 a(q₀); q₁ = q₀ + h q̇(v½); v₁ = v½ + h/2 a(q₁, v½).

    Order 2, symplectic and time-reversible for separable H = T(v) + V(q); on ẍ = −ω²x it conserves
    ½v² + ½ω²(1 − h²ω²/4)x² exactly (ORACLES A1).

    >>> verlet_step(lambda t, y: np.array([y[1], -y[0]]), 0.0, np.array([1.0, 0.0]), 0.1)
    array([ 0.995    , -0.0997500])
    """
    s = _split(y, split)
    half = 0.5 * h
    y1 = np.array(y, dtype=np.result_type(y, float), copy=True)
    y1[..., s:] += half * fun(t, y)[..., s:]
    y1[..., :s] += h * fun(t + half, y1)[..., :s]
    y1[..., s:] += half * fun(t + h, y1)[..., s:]
    return y1


verlet_step.nfev = 3


# ---------------------------------------------------------------------------------------------------
# implicit steps: Newton on  z − y₀ − θh f(t + θh, z) = 0
# ---------------------------------------------------------------------------------------------------
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


def newton_solve(fun: Callable, t: float, y0: np.ndarray, theta_h: float, jac=None, tol: float = 1e-12,
                 max_iter: int = 20) -> np.ndarray:
    """Solve z = y₀ + θh f(t, z) by (simplified) Newton from z⁰ = y₀, with M = I − θh J frozen at y₀.

    ``jac(t, y)`` (dense or scipy.sparse, or a constant matrix) gives J = ∂f/∂y; without it a
    forward-difference Jacobian is used. For a linear f the first iterate is exact: it is Baraff's
    linearized implicit step Δy = (I − θhJ)⁻¹ θh f(y₀); the second iteration only confirms it.
    Converged when ‖Δz‖∞ ≤ tol·(1 + ‖z‖∞) (per trajectory in batch mode), or when the corrections stop
    shrinking once below 1e-8 relative (roundoff of an ill-conditioned I − θhJ); raises
    :class:`ConvergenceError` otherwise after ``max_iter`` iterations.
    """
    z = np.array(y0, dtype=float, copy=True)
    f = fun(t, z)
    if jac is None:
        J = _fd_jacobian(fun, t, z, f)
    else:
        J = jac(t, z) if callable(jac) else jac
    batch = z.ndim == 2
    n = z.shape[-1]
    if sp.issparse(J):
        if batch:
            raise ValueError("jac must be a dense (K, n, n) array in batch mode, got a sparse matrix")
        lu = sp.linalg.splu(sp.csc_matrix(sp.identity(n, format="csc") - theta_h * J))
        solve = lu.solve
    else:
        J = np.asarray(J, dtype=float)
        M = np.eye(n) - theta_h * J
        if batch:
            solve = lambda r: np.linalg.solve(M, r[..., None])[..., 0]  # noqa: E731
        else:
            lu = sla.lu_factor(M, check_finite=False)
            solve = lambda r: sla.lu_solve(lu, r, check_finite=False)  # noqa: E731
    res = prev = np.inf
    for it in range(1, max_iter + 1):
        dz = solve(y0 + theta_h * f - z)
        z += dz
        if not dz.size:
            return z
        # relative Newton correction, per trajectory in batch mode
        res = float(np.max(np.max(np.abs(dz), axis=-1) / (1.0 + np.max(np.abs(z), axis=-1))))
        if not np.isfinite(res):
            break
        if res <= tol or (res <= 1e-8 and res >= prev):  # converged, or no progress at roundoff level
            return z
        prev = res
        f = fun(t, z)
    raise ConvergenceError("Newton (implicit step)", it, res, tol,
                           f"at t = {t:.6g}, θh = {theta_h:.3g}; reduce the step h")


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
    norm1 = lambda M: float(np.max(np.sum(np.abs(M), axis=-2))) if M.size else 0.0  # noqa: E731
    norm = norm1(A)
    s1 = max(0, int(np.ceil(np.log2(norm / _THETA13)))) if norm > _THETA13 else 0
    A = A / 2.0**s1
    A2 = A @ A
    A4 = A2 @ A2
    # fewer squarings for non-normal A (a stiff spring's [[0, 1], [−ω², −c]]): scale by
    # α₄ = max(‖A⁴‖^¼, ‖A⁵‖^⅕) ≤ ‖A‖ instead of ‖A‖ (Al-Mohy & Higham, SIMAX 31, 2009)
    alpha = max(norm1(A4) ** 0.25, norm1(A4 @ A) ** 0.2)
    s = max(0, s1 + (int(np.ceil(np.log2(alpha / _THETA13))) if alpha > 0 else -s1))
    if s != s1:
        f = 2.0 ** (s1 - s)
        A, A2, A4 = A * f, A2 * f**2, A4 * f**4
    A6 = A4 @ A2
    b = _B13
    eye = np.broadcast_to(np.eye(A.shape[-1]), A.shape)
    U = A @ (A6 @ (b[13] * A6 + b[11] * A4 + b[9] * A2) + b[7] * A6 + b[5] * A4 + b[3] * A2 + b[1] * eye)
    V = A6 @ (b[12] * A6 + b[10] * A4 + b[8] * A2) + b[6] * A6 + b[4] * A4 + b[2] * A2 + b[0] * eye
    E = np.linalg.solve(V - U, V + U)
    for _ in range(s):
        E = E @ E
    return E


def exponential_euler_step(fun: Callable, t: float, y: np.ndarray, h: float, split: int | None = None,
                           jac=None) -> np.ndarray:
    """Exponential (Rosenbrock–)Euler: y₁ = y₀ + h φ₁(hJ) f(t, y₀), J = ∂f/∂y(t, y₀), φ₁(z) = (eᶻ − 1)/z.

    Order 2 for autonomous problems with the exact Jacobian (Hochbruck & Ostermann, Acta Numerica 2010);
    **exact** for linear constant-coefficient systems (a linear damped spring: y₁ = e^(hJ) y₀ at any h);
    stability region the whole left half-plane. φ₁(hJ)·hf is read off one matrix exponential of the
    augmented matrix [[hJ, hf], [0, 0]] (:func:`expm_small` or ``scipy.linalg.expm``, batched over K;
    ``expm_multiply`` for a sparse J). Without ``jac`` a forward-difference Jacobian is used.

    >>> y = exponential_euler_step(lambda t, y: np.array([y[1], -y[0]]), 0.0, np.array([1.0, 0.0]), np.pi,
    ...                            jac=lambda t, y: np.array([[0.0, 1.0], [-1.0, 0.0]]))
    >>> bool(np.allclose(y, [-1.0, 0.0]))   # half a period of the oscillator in one exact step
    True
    """
    f = fun(t, y)
    J = (jac(t, y) if callable(jac) else jac) if jac is not None else _fd_jacobian(fun, t, y, f)
    n = y.shape[-1]
    if sp.issparse(J):
        if y.ndim != 1:
            raise ValueError("jac must be a dense (K, n, n) array in batch mode, got a sparse matrix")
        from scipy.sparse.linalg import expm_multiply

        aug = sp.bmat([[h * J, sp.csc_matrix((h * f)[:, None])], [None, sp.csc_matrix((1, 1))]], format="csc")
        e = np.zeros(n + 1)
        e[n] = 1.0
        return y + expm_multiply(aug, e)[:n]
    aug = np.zeros(y.shape[:-1] + (n + 1, n + 1))
    aug[..., :n, :n] = h * np.asarray(J, dtype=float)
    aug[..., :n, n] = h * f
    return y + (expm_small(aug) if n < 32 else sla.expm(aug))[..., :n, n]


# ---------------------------------------------------------------------------------------------------
# the registry
# ---------------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class Method:
    """A registered integrator: its properties (data) and its step function.

    ``implicit`` means the step uses the Jacobian ∂f/∂y (Newton iterations, or matrix functions for the
    exponential integrator): a scene passes its analytic Jacobian to these methods.
    """

    name: str
    order: int
    symplectic: bool
    implicit: bool
    adaptive: bool
    step: Callable
    description: str = ""


METHODS: dict[str, Method] = {m.name: m for m in [
    Method("euler", 1, False, False, False, euler_step, "explicit Euler"),
    Method("midpoint", 2, False, False, False, midpoint_step, "explicit midpoint (RK2)"),
    Method("rk4", 4, False, False, False, rk4_step, "classical Runge–Kutta 4"),
    Method("symplectic_euler", 1, True, False, False, symplectic_euler_step, "symplectic Euler (kick then drift)"),
    Method("verlet", 2, True, False, False, verlet_step, "velocity Verlet"),
    Method("implicit_euler", 1, False, True, False, implicit_euler_step, "implicit Euler (Newton)"),
    Method("implicit_midpoint", 2, True, True, False, implicit_midpoint_step, "implicit midpoint (Newton)"),
    Method("exponential_euler", 2, False, True, False, exponential_euler_step,
           "exponential Rosenbrock–Euler (uses ∂f/∂y; exact for linear springs)"),
    Method("dopri5", 5, False, False, True, dopri5_step, "adaptive Dormand–Prince 5(4)"),
]}


def get_method(name: str) -> Method:
    """Look up a method by name, with a clear error listing the known names.

    >>> get_method("verlet").order
    2
    """
    try:
        return METHODS[name]
    except (KeyError, TypeError):
        raise ValueError(f"method must be one of {sorted(METHODS)} or 'scipy:<solve_ivp method>', "
                         f"got {name!r}") from None
