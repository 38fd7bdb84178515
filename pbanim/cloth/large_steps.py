"""Large steps (Baraff & Witkin 1998): implicit Euler, linearized once, solved by filtered conjugate gradients.

Implicit Euler on the cloth, Δx = h(v₀ + Δv) and M Δv = h f(x₀ + Δx, v₀ + Δv), is linearized about the start,
f(x₀ + Δx, v₀ + Δv) ≈ f₀ + K Δx + D Δv, which leaves one linear system per step (B&W eq. (6)):

    (M − h D − h² K) Δv = h (f₀ + h K v₀ + K y),      x₁ = x₀ + h (v₀ + Δv) + y,

K = ∂f/∂x, D = ∂f/∂v at (x₀, v₀), and y the position correction of colliding particles (zero otherwise). It
is one Newton iteration of implicit Euler from the start point: exact for linear forces (ORACLES J3), L-stable,
no step limit from the stiffness there (a stretch mode of frequency ω is damped by 1/(1 + h²ω²) per step,
ORACLES A1). On the nonlinear cloth the one iteration is only as good as the linearization: a flat sheet has
no transverse stiffness, so at h = 0.1 s and k = 10⁶ one step lets gravity stretch its springs far beyond
what K predicted (the energy grows); :func:`newton_step` solves the step itself. K here is the symmetric
part B&W use (without the damping term k_d G(Hv)ᵀ), a compressed spring's −H left out so that A is positive
definite (:func:`pbanim.cloth.conditions.element_terms`). For a cloth of springs, A.data and f + K(h v₀ + y)
come from one pass over the springs without K or D (:mod:`pbanim.cloth.step_system`, equal to this
assembly to roundoff, ORACLES J10; at N = 64 ~4 ms against ~14 ms); other models take the readable path.

Constraints enter through B&W's *filter*: each particle's Δv lies in the subspace of its 3 × 3 projection
S_i (I: free, I − nnᵀ: in contact with normal n, 0: pinned) plus a prescribed part z_i (the velocity change
the constraint imposes), and the *modified preconditioned conjugate gradients* (B&W Fig. 2) keep every
iterate there:

    Δv = z;  δ₀ = S(b)ᵀ P⁻¹ S(b);  r = S(b − A Δv);  c = S(P⁻¹ r);  δ = rᵀc
    while δ > ε² δ₀:   q = S(A c);  α = δ/(cᵀq);  Δv += α c;  r −= α q;  s = P⁻¹ r;  δ' = δ;  δ = rᵀs;
                       c = S(s + (δ/δ') c)

with P = diag(A) (Jacobi), or P⁻¹ one V-cycle of aggregation multigrid (:mod:`pbanim.cloth.multigrid`,
``large_step(..., precond="multigrid")``: line Gauss–Seidel smoothing, the pins' couplings dropped;
``"multigrid-l1"``: ℓ1-Jacobi smoothing, the earlier default); the dot products avoid BLAS (a threaded BLAS dot of 10⁴ entries
waits milliseconds for a busy core). :func:`modified_pcg` returns the iterate with its iterations, its relative
preconditioned residual √(δ/δ₀) and whether it reached ε: a solve that stops at ``max_iter`` says so.

:func:`newton_step` iterates to the implicit Euler solution itself (a new K, D and CG solve per Newton
iteration, starting from the large step): what the large step approximates, and what XPBD converges to
(ORACLES J4). Momentum: internal forces have 1ᵀK = 1ᵀD = 0, so Σ mΔv = 1ᵀ(b − r) = −1ᵀr on a free cloth:
the momentum error of a step is the CG residual's sum (ORACLES J2).

Notation
--------
=====================  ==========  ==========================================
symbol                 code        meaning
=====================  ==========  ==========================================
M, K, D                ``K, D``    masses, ∂f/∂x, ∂f/∂v (sparse, 3N × 3N)
A = M − hD − h²K       ``A``       the system matrix (symmetric when D, K are)
S_i, z_i, y_i          ``S, z``    filter, prescribed Δv, position correction
ε                      ``tol``     CG tolerance (relative, preconditioned)
=====================  ==========  ==========================================

References: D. Baraff, A. Witkin, "Large steps in cloth simulation", SIGGRAPH 1998, §3 (the step), §5.3
(constraints, the filter, modified PCG); J. R. Shewchuk, "An introduction to the conjugate gradient method
without the agonizing pain" (1994), §12 (PCG).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .collide import contacts
from .lean_pcg import lean_pcg
from .multigrid import Multigrid
from .step_system import spring_system
from ..contracts import Array, Choice, Int, Obj, Opt, Real, contract
from ..errors import ConvergenceError, InvalidInput, SimulationDiverged

__all__ = ["PCGResult", "modified_pcg", "large_step", "newton_step", "PRECONDITIONERS"]

PRECONDITIONERS = ("jacobi", "multigrid", "multigrid-l1")

_CLOTH = Obj("pbanim.cloth.model:Cloth")
_STATE = Array(("cloth.n_state",))
_H = Real(gt=0, le=10.0)
_TOL = Real(gt=0, lt=1)


@dataclass
class PCGResult:
    """A filtered CG solve: the solution, iterations, relative preconditioned residual, reached tol or not."""

    x: np.ndarray
    iterations: int
    residual: float
    converged: bool
    tol: float


class _Filter:
    """S applied particle by particle: pinned rows zeroed, contact rows projected off their normal."""

    def __init__(self, N, pinned=(), contact=(), normals=None, S=None):
        self.N, self.S = N, S
        self.pinned = np.asarray(pinned, dtype=np.intp)
        self.contact = np.asarray(contact, dtype=np.intp)
        self.normals = np.zeros((0, 3)) if normals is None else normals

    def __call__(self, r):
        r = r.reshape(-1, 3)
        if self.S is not None:
            return np.einsum("nij,nj->ni", self.S, r).ravel()
        if len(self.contact):
            rc = r[self.contact]
            r[self.contact] = rc - np.einsum("ij,ij->i", rc, self.normals)[:, None] * self.normals
        r[self.pinned] = 0.0
        return r.ravel()


def _dot(a, b):
    """aᵀb without BLAS (a multi-threaded BLAS dot of 10⁴ entries waits ~ms for a busy core)."""
    return float(np.einsum("i,i->", a, b))


def _jacobi(A):
    dinv = 1.0 / A.diagonal()
    return lambda r: dinv * r


def _solve(cloth, A, b, filt, z, tol, max_iter, prec):
    """:func:`_pcg`, or its lean twin (:mod:`pbanim.cloth.lean_pcg`, the same iterates bit for bit) unless
    ``cloth.lean_path`` is False."""
    if not getattr(cloth, "lean_path", True) or filt.S is not None:
        return _pcg(A, b, filt, z, tol, max_iter, prec)
    x, it, res, ok = lean_pcg(A, b, filt, z, tol, max_iter, prec, _dot)
    return PCGResult(x, it, res, ok, tol)


def _pcg(A, b, filt, z, tol, max_iter, prec=None):
    """B&W's modified PCG (module docstring), preconditioned by ``prec`` (r ↦ P⁻¹r; None: Jacobi)."""
    pinv = _jacobi(A) if prec is None else prec
    x = np.zeros_like(b) if z is None else z.copy()
    fb = filt(b.copy())
    if z is None or not z.any():                               # r = S(b): δ₀ = δ, one P⁻¹ fewer
        r = fb.copy()
        c = filt(pinv(r))
        delta0 = delta = _dot(r, c)
    else:
        delta0 = _dot(fb, pinv(fb))
        r = filt(b - A @ x)
        c = filt(pinv(r))
        delta = _dot(r, c)
    if delta0 == 0.0 or delta <= tol * tol * delta0:
        res = 0.0 if delta0 == 0.0 else float(np.sqrt(max(delta, 0.0) / delta0))
        return PCGResult(x, 0, res, True, tol)
    it = 0
    for it in range(1, max_iter + 1):
        q = filt(A @ c)
        cq = _dot(c, q)
        if not cq > 0.0:                                       # A not positive definite on the subspace
            delta = np.inf
            break
        alpha = delta / cq
        x += alpha * c
        r -= alpha * q
        s = pinv(r)
        delta_old, delta = delta, _dot(r, s)
        if not np.isfinite(delta) or delta < 0.0:
            delta = np.inf
            break
        if delta <= tol * tol * delta0:
            break
        c = filt(s + (delta / delta_old) * c)
    res = float(np.sqrt(max(delta, 0.0) / delta0)) if np.isfinite(delta) else np.inf
    return PCGResult(x, it, res, res <= tol, tol)


@contract(A=Obj("scipy.sparse:sparray", "scipy.sparse:spmatrix", what="a square scipy.sparse matrix"),
          b=Array((None,)), S=Opt(Array((None, 3, 3))), z=Opt(Array((None,))), tol=_TOL,
          max_iter=Int(ge=1, le=100_000))
def modified_pcg(A, b, S=None, z=None, tol: float = 1e-6, max_iter: int = 1000) -> PCGResult:
    """Solve A Δv = b for Δv in the filtered subspace (S_i blocks (N, 3, 3), prescribed part z), B&W Fig. 2.

    A should be symmetric positive definite on the filtered subspace (M − hD − h²K of a stretched cloth is);
    ``converged`` is False when ``max_iter`` ran out before the residual reached ``tol``.

    >>> import scipy.sparse as sp
    >>> r = modified_pcg(sp.diags([2.0, 4.0, 8.0]).tocsr(), np.array([2.0, 4.0, 8.0]))
    >>> r.x.tolist(), r.converged
    ([1.0, 1.0, 1.0], True)
    """
    n = len(b)
    if A.shape != (n, n) or n % 3:
        raise InvalidInput(f"modified_pcg: A must be {n} × {n} and b of 3N entries, got A {A.shape}, b ({n},)")
    if z is not None and len(z) != n:
        raise InvalidInput(f"modified_pcg: z (the prescribed part) must have the {n} entries of b, got {len(z)}")
    if S is not None and S.shape[0] != n // 3:
        raise InvalidInput(f"modified_pcg: S must hold one 3 × 3 filter per particle ({n // 3}), got {S.shape}")
    if not np.isfinite(A.data).all() or np.any(A.diagonal() <= 0):
        raise InvalidInput("modified_pcg: A must be finite with a positive diagonal (the Jacobi preconditioner)")
    with np.errstate(all="ignore"):
        out = _pcg(A.tocsr(), b, _Filter(n // 3, S=S), None if z is None else z.copy(), tol, max_iter)
    if not np.isfinite(out.x).all():
        raise ConvergenceError("modified PCG", out.iterations, np.inf, tol, "the iterates overflowed (is A SPD?)")
    return out


def _constraints(cloth, x, v):
    """The filter, z and y of a step: pins (S = 0, Δv = −v) and contacts (S = I − nnᵀ, stop approaching)."""
    idx, nrm, depth = contacts(cloth.colliders, x, v, cloth.thickness)
    filt = _Filter(len(x), cloth.pinned, idx, nrm)
    z = np.zeros(cloth.n)
    z.reshape(-1, 3)[cloth.pinned] = -v[cloth.pinned]
    z.reshape(-1, 3)[idx] = -np.einsum("ij,ij->i", v[idx], nrm)[:, None] * nrm
    ycorr = np.zeros(cloth.n)
    ycorr.reshape(-1, 3)[idx] = depth[:, None] * nrm
    return filt, z, ycorr, len(idx)


def _system(cloth, kdata, ddata, h):
    data = -(h * h) * kdata
    if ddata is not None:
        data -= h * ddata
    data[cloth.pattern.diag] += cloth.mass3
    return cloth.pattern.matrix(data)


def _preconditioner(cloth, A, precond):
    """r ↦ P⁻¹r for the system A of the cloth: None for Jacobi (both PCGs form r / diag A), or a multigrid
    V-cycle (hierarchy built once per cloth): "multigrid" smooths by line Gauss–Seidel with the pins' couplings dropped, "multigrid-l1" by ℓ1-Jacobi
    (additive on the finest level). A V-cycle whose line blocks are not positive definite (A not SPD) is
    replaced by Jacobi: the CG then still runs with an SPD preconditioner."""
    if precond == "jacobi":
        return None
    cache = cloth.__dict__.setdefault("_multigrid", {})
    mg = cache.get(precond)
    if mg is None:
        mg = cache[precond] = (Multigrid(cloth.pattern, cloth.sheet.n, pinned=cloth.pinned) if precond == "multigrid"
                               else Multigrid(cloth.pattern, cloth.sheet.n, smoother="l1-jacobi"))
    try:
        mg.setup(A.data)
    except np.linalg.LinAlgError:
        return None
    return mg


def _large_step(cloth, y, h, tol, max_iter, precond="jacobi"):
    """One B&W step on the full state: (y₁, PCGResult, contacts)."""
    n = cloth.n
    x, v = y[:n].reshape(-1, 3), y[n:].reshape(-1, 3)
    with np.errstate(all="ignore"):
        filt, z, ycorr, nc = _constraints(cloth, x, v)
        fast = spring_system(cloth)
        if fast is not None:                                   # one pass over the springs (ORACLES J10)
            data, g = fast.terms(x, v, h * y[n:] + ycorr, h)
            A, b = cloth.pattern.matrix(data), h * g
        else:
            f, kdata, ddata = cloth._all(x, v, exact=False)
            A = _system(cloth, kdata, ddata, h)
            b = h * (f + cloth.pattern.matrix(kdata) @ (h * y[n:] + ycorr))
        sol = _solve(cloth, A, b, filt, z, tol, max_iter, _preconditioner(cloth, A, precond))
        y1 = np.empty_like(y)
        y1[n:] = y[n:] + sol.x
        y1[:n] = y[:n] + h * y1[n:] + ycorr
    return y1, sol, nc


def _newton_step(cloth, y, h, tol, max_iter, cg_tol, cg_iter, precond="jacobi"):
    """Implicit Euler by Newton from the large step: (y₁, Newton iterations, CG iterations)."""
    n = cloth.n
    y1, sol, _ = _large_step(cloth, y, h, cg_tol, cg_iter, precond)
    cg = sol.iterations
    x, v = y[:n].reshape(-1, 3), y[n:].reshape(-1, 3)
    with np.errstate(all="ignore"):
        filt, _, ycorr, _ = _constraints(cloth, x, v)
        dv = y1[n:] - y[n:]
        fast, zero = spring_system(cloth), np.zeros(n)
        for it in range(1, max_iter + 1):
            v1 = y[n:] + dv
            x1 = y[:n] + h * v1 + ycorr
            if fast is not None:
                data, f = fast.terms(x1.reshape(-1, 3), v1.reshape(-1, 3), zero, h)
                A = cloth.pattern.matrix(data)
            else:
                f, kdata, ddata = cloth._all(x1.reshape(-1, 3), v1.reshape(-1, 3), exact=False)
                A = _system(cloth, kdata, ddata, h)
            g = filt(h * f - cloth.mass3 * dv)                  # −(residual) of M Δv = h f(x₁, v₁)
            step = _solve(cloth, A, g, filt, None, cg_tol, cg_iter, _preconditioner(cloth, A, precond))
            cg += step.iterations
            dv += step.x
            size = float(np.max(np.abs(step.x))) if len(step.x) else 0.0
            if not np.isfinite(size):
                break
            if size <= tol * (1.0 + float(np.max(np.abs(y[n:] + dv)))):
                out = np.empty_like(y)
                out[n:] = y[n:] + dv
                out[:n] = y[:n] + h * out[n:] + ycorr
                return out, it, cg
    raise ConvergenceError("Newton (implicit Euler, cloth)", max_iter, size, tol, f"at h = {h:g}; reduce h")


@contract(cloth=_CLOTH, y=_STATE, h=_H, tol=_TOL, max_iter=Int(ge=1, le=100_000),
          precond=Choice(PRECONDITIONERS))
def large_step(cloth, y, h: float, tol: float = 1e-4, max_iter: int = 2000, precond: str = "jacobi"):
    """One Baraff–Witkin large step of the cloth from the full state y: (y₁, :class:`PCGResult`).

    ``precond``: "jacobi" (B&W's P = diag A), "multigrid" (a V-cycle of aggregation multigrid smoothed by
    line Gauss–Seidel, :mod:`pbanim.cloth.multigrid`: 2–4 CG iterations to 10⁻² at N = 16…64 on the
    benchmark's sheet where Jacobi needs 46–300) or "multigrid-l1" (ℓ1-Jacobi smoothing: 22–47); with a
    V-cycle the stopping test is the residual in its P⁻¹-norm. Raises SimulationDiverged when y₁ is not finite; a
    CG solve that stopped at ``max_iter`` is returned with ``converged`` False (the caller decides: the
    benchmark and chapter 12 count or report them).
    """
    y1, sol, _ = _large_step(cloth, y, h, tol, max_iter, precond)
    if not np.isfinite(y1).all():
        raise SimulationDiverged(0.0, 0, "cloth state", f"the large step at h = {h:g} overflowed")
    return y1, sol


@contract(cloth=_CLOTH, y=_STATE, h=_H, tol=_TOL, max_iter=Int(ge=1, le=200), cg_tol=_TOL,
          cg_iter=Int(ge=1, le=100_000), precond=Choice(PRECONDITIONERS))
def newton_step(cloth, y, h: float, tol: float = 1e-9, max_iter: int = 30, cg_tol: float = 1e-10,
                cg_iter: int = 5000, precond: str = "jacobi"):
    """One implicit Euler step solved by Newton (ConvergenceError past ``max_iter``): (y₁, Newton iterations);
    every CG solve preconditioned by ``precond`` (as in :func:`large_step`)."""
    y1, it, _ = _newton_step(cloth, y, h, tol, max_iter, cg_tol, cg_iter, precond)
    if not np.isfinite(y1).all():
        raise SimulationDiverged(0.0, 0, "cloth state", f"the Newton step at h = {h:g} overflowed")
    return y1, it
