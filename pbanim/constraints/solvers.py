"""Solvers for the Lagrange multipliers λ: Witkin's JWJᵀλ = r (dense, sparse, CG), the KKT saddle point,
and Baraff's linear-time elimination for chains and trees (chapter 03).

Every solver has one signature and returns a :class:`ConstraintSolution`. With c = −J̇q̇ − k_s C − k_d Ċ
(the C̈ the constraints ask for):

    Witkin:  (J W Jᵀ) λ = c − J W Q                    KKT:  [[M, −Jᵀ], [J, 0]] [q̈; λ] = [Q; c]

and Q_C = Jᵀλ, q̈ = W (Q + Q_C). Both give the same q̈ and λ when J has full row rank (ORACLES B5).

Redundant constraints (J rank deficient): λ is not unique but Jᵀλ is. Direct solvers detect a
vanishing pivot (|pivot| < 1e-13 · the largest diagonal entry) and fall back to the **minimum-norm**
λ = A⁺ r computed from the eigen-decomposition of A = JWJᵀ (eigenvalues below 1e-12·max treated as
zero); CG started at λ = 0 converges to the same minimum-norm answer. If r has a component in the
null space of A (‖P_null r‖ > 1e-9 ‖r‖), no λ exists: :class:`~pbanim.errors.SingularConstraintError`
names the dependent rows and the residual (ORACLES B4).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import scipy.linalg as sla
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from ..contracts import Array, Choice, Flag, Int, Obj, Opt, Real, contract
from ..errors import ConvergenceError, InvalidInput, NonFiniteResult, SingularConstraintError, check_result
from ..particles.specs import IndexArray, Matrix

__all__ = ["ConstraintSolution", "SOLVERS", "solve_lambda", "min_norm_lambda", "eliminate_readable",
           "EliminationResult"]

SOLVERS = ("auto", "witkin-dense", "witkin-sparse", "witkin-cg", "kkt", "linear")
_PIVOT = 1e-13
_DENSE_AUTO = 64  # "auto" uses the dense solve below this many rows when the structure is general


@dataclass
class ConstraintSolution:
    """λ and what follows from it.

    Attributes
    ----------
    lam : ndarray (m,)          Lagrange multipliers λ.
    Q_C : ndarray (n,)          constraint force Jᵀλ (flat, like q).
    qdd : ndarray (n,)          accelerations q̈ = W (Q + Q_C).
    solver : str                the solver that ran ("auto" resolved).
    iterations : int            CG iterations (0 for direct solvers).
    residual : float            ‖JWJᵀλ − r‖ / max(‖r‖, tiny) (KKT: of the saddle-point system);
                                computed on first access from the stored problem.
    rank_deficient : bool       the minimum-norm fallback was used (redundant constraints).
    """

    lam: np.ndarray
    Q_C: np.ndarray
    qdd: np.ndarray
    solver: str
    iterations: int = 0
    rank_deficient: bool = False
    _residual: float | None = field(default=None, repr=False)
    _problem: tuple | None = field(default=None, repr=False)

    @property
    def residual(self) -> float:
        if self._residual is None:
            J, W, r = self._problem
            self._residual = _rel(J @ (W * self.Q_C) - r, r)
        return self._residual


def _norm(a: np.ndarray) -> float:
    # not np.linalg.norm: its BLAS dot goes multi-threaded on long vectors, slow on a busy machine
    return float(np.sqrt(np.add.reduce(a * a)))


def _rel(res: np.ndarray, r: np.ndarray) -> float:
    return _norm(res) / max(_norm(r), 1e-300)


def _finite(a: np.ndarray) -> bool:
    """Every entry finite (one reduction; the entrywise test only when the sum is not finite)."""
    return bool(np.isfinite(np.add.reduce(a, axis=None)) or np.isfinite(a).all())


def _checked_rhs(r: np.ndarray, c: np.ndarray, Q: np.ndarray) -> np.ndarray:
    """r = c − JWQ of every solver (the lean chain's too), or NonFiniteResult (a NaN state, an overflow)."""
    if _finite(r):
        return r
    raise NonFiniteResult("the right-hand side r = c − JWQ of JWJᵀλ = r",
                          f"max |c| = {np.abs(c).max(initial=0.0):g}, max |Q| = {np.abs(Q).max(initial=0.0):g}")


def _symbol(name: str):
    def size(env):
        return env.symbols[name]
    size.__name__ = name
    return size


@contract(A=Matrix(("m", "m")), r=Array(("m",), empty=True), tol=Real(gt=0))
def min_norm_lambda(A, r: np.ndarray, tol: float = 1e-9) -> np.ndarray:
    """Minimum-norm λ = A⁺r for symmetric PSD A; raise SingularConstraintError if r ∉ range(A).

    >>> min_norm_lambda(np.array([[1.0, 1.0], [1.0, 1.0]]), np.array([2.0, 2.0]))    # a rod given twice
    array([1., 1.])
    """
    if A.shape[0] > 4000:
        sol = spla.lsmr(sp.csr_matrix(A), r, atol=1e-15, btol=1e-15, maxiter=20 * A.shape[0])[0]
        res = A @ sol - r
        if _rel(res, r) > tol:
            rows = np.flatnonzero(np.abs(res) > tol * max(np.abs(r).max(), 1e-300))
            raise SingularConstraintError(rows, float(np.linalg.norm(res)), "detected by LSMR")
        return sol
    Ad = A.toarray() if sp.issparse(A) else np.asarray(A, float)
    if not _finite(Ad):     # JWJᵀ assembled inside pbanim from a finite J that overflowed
        raise NonFiniteResult("A = JWJᵀ", "the constraint Jacobian's entries are too large")
    ev, U = np.linalg.eigh(0.5 * (Ad + Ad.T))
    big = ev > 1e-12 * max(ev.max(initial=0.0), 1e-300)
    coef = U.T @ r
    null = ~big
    if null.any():
        rn = U[:, null] @ coef[null]
        if np.linalg.norm(rn) > tol * max(np.linalg.norm(r), 1e-300):
            support = np.abs(U[:, null]) > 1e-6
            conflicting = support[:, np.abs(coef[null]) > tol * max(np.linalg.norm(r), 1e-300)]
            rows = np.flatnonzero(conflicting.any(axis=1)) if conflicting.size else np.flatnonzero(support.any(axis=1))
            raise SingularConstraintError(rows, float(np.linalg.norm(rn)),
                                          "the right-hand side has a component along a dependent combination")
    return U[:, big] @ (coef[big] / ev[big])


def _cho_dense(A: np.ndarray):
    """Cholesky factor of a dense A, returned as a solve function r ↦ A⁻¹r (None if a pivot vanishes)."""
    try:
        c, low = sla.cho_factor(A, lower=True, check_finite=False)
    except np.linalg.LinAlgError:
        return None
    d = np.diag(c) ** 2
    if np.any(d < _PIVOT * np.diag(A)):  # pivot vs its own row: scale-free (masses, lengths)
        return None
    return lambda r: sla.cho_solve((c, low), r, check_finite=False)


def _scaled(A, d: np.ndarray):
    """D A D of a CSC matrix with D = diag(d), entry by entry: a_ij·d_i·d_j rounded as (a_ij·d_i)·d_j, the
    product that sp.diags(d) @ A @ sp.diags(d) forms, with its pattern (sorted, exact zeros dropped), bit for
    bit, without the two sparse products' index work."""
    A = sp.csc_matrix(A, copy=True)
    A.sort_indices()
    cols = np.repeat(np.arange(A.shape[1]), np.diff(A.indptr))
    A.data = A.data * d[A.indices] * d[cols]
    A.eliminate_zeros()
    return A


def _splu(A, scale: np.ndarray | None = None, **kw):
    """Sparse LU factor as a solve function; with ``scale`` = D it factors D A D (unit-sized pivots for a
    non-singular system, so a vanishing pivot means dependent rows whatever the masses and lengths) and
    solves by r ↦ D·(DAD)⁻¹D r. None when a pivot vanishes."""
    A = sp.csc_matrix(A)
    if scale is not None:
        A = _scaled(A, scale)
    try:
        lu = spla.splu(A, **kw)
    except RuntimeError:  # "Factor is exactly singular"
        return None
    u = np.abs(lu.U.diagonal())
    if u.size and u.min() < _PIVOT * u.max():
        return None
    return lu.solve if scale is None else (lambda r: scale * lu.solve(scale * r))


def _refined(solve, r: np.ndarray, J, JT, W: np.ndarray) -> np.ndarray:
    """λ = A⁻¹r plus one step of iterative refinement, the residual taken in factored form r − J(W(Jᵀλ)).

    Forming A = JWJᵀ rounds away the structure that makes a hanging chain's statics well conditioned
    (its rows sum to ~0, so κ(A) reaches 1e9 at masses 1:1000); the factored residual keeps it, and one
    fixed-precision refinement step (Skeel 1980) brings the tensions from ~κε down to a few ε (ORACLES B3).
    """
    lam = solve(r)  # a fresh array (every solve function returns one)
    WQ_C = JT @ lam
    WQ_C *= W
    lam += solve(r - J @ WQ_C)
    return lam


def _jacobi(diag: np.ndarray) -> np.ndarray:
    return 1.0 / np.sqrt(np.where(diag > 0, diag, 1.0))


def _linear(cset, asm):
    """Baraff's leaves-first elimination as a solve function r ↦ λ: tridiagonal LDLᵀ (dpttrf/dpttrs),
    banded Cholesky, or zero-fill sparse LDLᵀ in the leaves-first order. None when a pivot vanishes."""
    st = cset.structure
    order = st.order
    if st.kind == "chain" and st.bandwidth == 0:  # uncoupled rows: A is diagonal
        d = cset.bands(asm)[0]
        if np.any(d <= 0) or (d.size and d.min() < _PIVOT * d.max()):
            return None
        core = lambda rp: rp / d  # noqa: E731
    elif st.kind == "chain":
        d, e = cset.tridiagonal(asm)
        thr = _PIVOT * d
        D, E, info = sla.lapack.dpttrf(d, e)  # copies d and e (they may be the assembly's arrays)
        # dpttrf factors A = L D Lᵀ: a vanishing pivot D_i means dependent rows (redundant constraints)
        if info != 0 or np.any(D < thr):
            return None
        core = lambda rp: sla.lapack.dpttrs(D, E, rp)[0]  # noqa: E731
    elif st.kind == "banded":
        ab = cset.bands(asm)
        try:
            cb = sla.cholesky_banded(ab, lower=True, check_finite=False)
        except np.linalg.LinAlgError:
            return None
        if np.any(cb[0] ** 2 < _PIVOT * ab[0]):
            return None
        core = lambda rp: sla.cho_solve_banded((cb, True), rp, check_finite=False)  # noqa: E731
    else:
        Ap = cset.permuted_matrix(asm)
        core = _splu(Ap, _jacobi(Ap.diagonal()), permc_spec="NATURAL", diag_pivot_thresh=0.0,
                     options={"SymmetricMode": True})
        if core is None:
            return None
    if st.natural:
        return core

    def solve(r):
        lam = np.empty_like(r)
        lam[order] = core(np.take(r, order))
        return lam

    return solve


def _cg(J, JT, W, r, tol, max_iter, x0=None):
    m = J.shape[0]
    if not np.any(r):
        return np.zeros(m), 0, 0.0
    op = spla.LinearOperator((m, m), matvec=lambda y: J @ (W * (JT @ y)), dtype=float)
    it = [0]

    def cb(_):
        it[0] += 1

    lam, info = spla.cg(op, r, x0=x0, rtol=tol, atol=0.0, maxiter=max_iter, callback=cb)
    res = _rel(J @ (W * (JT @ lam)) - r, r)
    if info != 0 or not np.isfinite(res) or res > 10 * tol:
        raise ConvergenceError("witkin-cg", it[0], res, tol, f"m = {m} rows")
    return lam, it[0], res


@dataclass
class EliminationResult:
    """λ from :func:`eliminate_readable`, and the number of fill-in entries the elimination created."""

    lam: np.ndarray
    fill: int


@contract(A=Matrix(("m", "m")), r=Array(("m",)), order=IndexArray(("m",), size=_symbol("m"), distinct="all",
                                                                    what="row indices"))
def eliminate_readable(A, r: np.ndarray, order) -> EliminationResult:
    """Gaussian elimination of A λ = r one row at a time, in the given order (readable reference of the
    "linear" solver; Baraff 1996).

    Rows are dicts {column: value}. Eliminating row i subtracts (A_ji/A_ii)·row_i from every later row j
    that touches it; an entry that did not exist before is *fill*. For a tree in leaves-first order
    (``ConstraintSet.structure.order``) there is none, so the cost is O(Σ deg²) = O(n).

    >>> import numpy as np
    >>> A = np.array([[2.0, -1, 0], [-1, 2, -1], [0, -1, 2]])      # a chain: tridiagonal
    >>> res = eliminate_readable(A, np.array([1.0, 0, 1]), [2, 1, 0])
    >>> res.lam, res.fill
    (array([1., 1., 1.]), 0)
    """
    A = sp.csr_matrix(A)
    m = A.shape[0]
    rows = [dict(zip(A.indices[A.indptr[i]:A.indptr[i + 1]].tolist(), A.data[A.indptr[i]:A.indptr[i + 1]].tolist()))
            for i in range(m)]
    b = np.array(r, float)
    order = [int(i) for i in order]
    pos = {i: k for k, i in enumerate(order)}
    fill = 0
    for i in order:  # forward elimination
        piv = rows[i].get(i, 0.0)
        if piv == 0.0:
            raise InvalidInput(f"eliminate_readable: A must be non-singular in this order (no pivoting here), got a "
                               f"zero pivot at row {i}; redundant rows need min_norm_lambda")
        later = [k for k in rows[i] if pos[k] > pos[i]]
        for j in later:
            f = rows[j][i] / piv
            for k in later:
                if k not in rows[j]:
                    fill += 1
                rows[j][k] = rows[j].get(k, 0.0) - f * rows[i][k]
            b[j] -= f * b[i]
    lam = np.zeros(m)
    for i in reversed(order):  # back substitution
        lam[i] = (b[i] - sum(a * lam[k] for k, a in rows[i].items() if pos[k] > pos[i])) / rows[i][i]
    return EliminationResult(check_result("eliminate_readable", lam, "a pivot is too small for this A"), fill)


def certified(sol: ConstraintSolution, where: str = "", arguments=None) -> ConstraintSolution:
    """``sol`` when λ and q̈ are finite (a finite right-hand side can still overflow through a tiny pivot): the
    certificate of a call from outside the package (inside a run, the stepping loop names a non-finite state)."""
    if not (_finite(sol.lam) and _finite(sol.qdd)):
        raise NonFiniteResult(f"λ or q̈ from the {sol.solver!r} solve", "JWJᵀ is too badly conditioned or its "
                              "entries too large for double precision")
    return sol


@contract(J=Matrix(("m", "n")), W=Array(("n",), gt=0), Q=Array(("n",)), c=Array(("m",), empty=True),
          solver=Choice(SOLVERS), cset=Opt(Obj("pbanim.constraints.assembly:ConstraintSet")),
          asm=Opt(Obj("pbanim.constraints.assembly:Assembly")), A=Opt(Matrix(("m", "m"))), tol=Real(gt=0),
          max_iter=Opt(Int(ge=1)), lean=Flag(), returns=certified)
def solve_lambda(J, W, Q, c, solver: str = "witkin-sparse", *, cset=None, asm=None, A=None,
                 tol: float = 1e-12, max_iter: int | None = None, lean: bool = True) -> ConstraintSolution:
    """Solve for λ with a named solver (see the module docstring).

    Parameters
    ----------
    J : sparse or dense (m, n)
        Constraint Jacobian.
    W, Q : array_like (n,)
        Inverse masses per coordinate (W = M⁻¹ is diagonal for particles) and the applied generalized force.
    c : array_like (m,)
        Desired C̈: −J̇q̇ − k_s C − k_d Ċ.
    solver : {"witkin-dense", "witkin-sparse", "witkin-cg", "kkt", "linear", "auto"}
        "linear" and "auto" need ``cset``/``asm`` (a :class:`~pbanim.constraints.assembly.ConstraintSet`
        whose structure is a chain or tree).
    tol, max_iter : CG's relative tolerance and iteration cap (default 10·m + 100).
    lean : False runs the readable "linear" solver on a chain, not its lean twin (``chain_lean``, bit for bit).

    Examples
    --------
    >>> import numpy as np
    >>> J = np.array([[0.0, -1.0]])                 # a particle at (0, -1) on a unit circle
    >>> sol = solve_lambda(J, np.ones(2), np.array([0.0, -9.81]), np.array([-1.0]), "witkin-dense")
    >>> round(float(sol.lam[0]), 12), sol.qdd.round(12)
    (-10.81, array([0., 0.]))
    """
    W = np.asarray(W, float)
    Q = np.asarray(Q, float).ravel()
    c = np.asarray(c, float)
    J = J if sp.issparse(J) else sp.csr_matrix(np.atleast_2d(np.asarray(J, float)))
    m = J.shape[0]
    if cset is not None and (cset.m, cset.n) != J.shape:
        raise InvalidInput(f"solve_lambda: cset must be the constraint set J was assembled from, got one of "
                           f"{cset.m} rows and {cset.n} coordinates for J of shape {J.shape}")
    blocks = asm is not None and asm.vals is not None      # the linear solver reads JWJᵀ's block values
    if solver == "auto":
        if cset is not None and cset.structure.linear and blocks:
            solver = "linear"
        else:
            solver = "witkin-dense" if m <= _DENSE_AUTO else "witkin-sparse"
    if solver == "linear" and (cset is None or not cset.structure.linear or not blocks):
        kind = "general" if cset is None else cset.structure.kind
        raise InvalidInput(f"solver 'linear' needs chain- or tree-structured constraints of built-in kinds (cset, "
                           f"and asm assembled with pairs=True); this set's structure is {kind!r}; use 'auto', "
                           "'witkin-sparse' or 'kkt'")
    if solver == "linear" and lean and J is asm.J:
        from . import chain_lean  # on first use (it loads the sparse kernel, not loaded with pbanim)
        out = chain_lean.chain_lambda(cset, asm, J, W, Q, c) if chain_lean.applies(cset, asm) else None
        if out is not None:
            return ConstraintSolution(*out[:3], "linear", 0, False, None, (J, W, out[3]))
    JT = asm.JT if (asm is not None and asm.JT is not None) else J.T.tocsr()
    r = _checked_rhs(c - J @ (W * Q), c, Q)
    it, deficient = 0, False
    if solver == "kkt":
        K = sp.bmat([[sp.diags(1.0 / W), -JT], [J, None]], format="csc")
        rhs = np.concatenate([Q, c])
        # scaled by D = diag(W^½, 1/√(JWJᵀ)_rr): the M block becomes I, the Schur block has unit diagonal
        kkt = _splu(K, np.concatenate([np.sqrt(W), _jacobi(J.multiply(J) @ W)]))
        if kkt is not None:
            z = kkt(rhs)
            qdd, lam = z[: len(Q)], z[len(Q):]
            return ConstraintSolution(lam, JT @ lam, qdd, "kkt", 0, False, _rel(K @ z - rhs, rhs))
        lam, deficient = None, True
    elif solver == "witkin-cg":
        lam, it, res = _cg(J, JT, W, r, tol, max_iter or 10 * m + 100)
    else:
        if A is None and solver != "linear":
            A = cset.matrix(asm) if (cset is not None and asm is not None) else (J @ sp.diags(W) @ J.T).tocsr()
        if solver == "witkin-dense":
            solve = _cho_dense(A.toarray() if sp.issparse(A) else A)
        elif solver == "witkin-sparse":
            solve = _splu(A, _jacobi(A.diagonal()))
        else:
            solve = _linear(cset, asm)
        lam = None if solve is None else _refined(solve, r, J, JT, W)
        deficient = lam is None
    if lam is None:
        lam = min_norm_lambda((J @ sp.diags(W) @ J.T).tocsr() if A is None else A, r)
    Q_C = JT @ lam
    qdd = Q + Q_C
    qdd *= W
    return ConstraintSolution(lam, Q_C, qdd, solver, it, deficient, res if solver == "witkin-cg" else None,
                              (J, W, r))
