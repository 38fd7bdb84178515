"""Sparse assembly on a fixed pattern: K, D and the Newton matrices of a cloth without building a matrix per step.

Every element of a condition kind couples its nv particles, so K = ∂f/∂x and D = ∂f/∂v have one 3 × 3 block
per pair of particles that share an element, and that set of pairs never changes. The pattern is computed
once (the union over kinds, plus the diagonal, in CSR order); each kind keeps the position in the CSR data of
every entry of its element blocks, so one step's assembly is a single ``np.bincount`` per kind,

    K.data = Σ_kinds bincount(map_kind, K_e.ravel()),     A.data = M.diag − h D.data − h² K.data,

and a matrix is wrapped around the data (``csr_matrix((data, indices, indptr))``: no sorting, no duplicate
summation). Building the same K from (row, col, value) triplets each step costs ~20× more at n = 64
(scipy sorts ~10⁶ triplets).

Pair kinds (springs) go further: a spring's K_e = c cᵀ ⊗ B with c = (1, −1) and one 3 × 3 B, so the kind
hands over B (E, 3, 3) alone; its two off-diagonal blocks (a, b), (b, a) are −B (no other element touches
them), each particle's diagonal block Σ_e B is a sparse incidence times B, and the data is one gather from
[−B, Σ B, 0] by a precomputed index (:meth:`Pattern._pair_scatter`).

For the first-order ODE of the free particles (pinned ones removed; y = [x_F, v_F], n_F coordinates each) the
Jacobian is J = [[0, I], [W K_FF, W D_FF]] (W = M⁻¹): :class:`FreeJacobian` precomputes its CSR pattern and
the gather that fills it from K.data and D.data, so ``jac(t, y)`` for pbanim's and scipy's stiff solvers is
one ``take`` and two scalings.

The same gather gives the two blocks alone for the stiff solvers' half-size stage systems: a stage system
(σI − J)(p, u) = (r₁, r₂) of RODAS4 or Radau IIA reduces to (σ²I − σ W D_FF − W K_FF) u = σ r₂ + W K_FF r₁
(:mod:`pbanim.ode.second_order`), M times it σ²M − σD − K, Baraff & Witkin's A = M − hD − h²K with h = 1/σ,
divided by h². :func:`second_order_jac` hands the blocks (W K_FF, W D_FF) to :func:`pbanim.ode.solve` as a
:class:`~pbanim.ode.second_order.SecondOrderJacobian`; they equal the full J of :meth:`Cloth.jac` entry for
entry (ORACLES J1, J7). In the grid order the free coordinates' S is banded (half-bandwidth ≈ 6N, the bend
springs two rows apart): up to ``BANDED_LU_MAX`` it is factored by LAPACK's banded LU.

Notation: n = 3N coordinates; q = 3 nv per element; ``maps[c]`` (E_c·q²,) data positions of kind c; n_F free
coordinates (3 × free particles), W = M⁻¹ of each entry's row.

Limiting cases: a kind with no elements adds nothing (its map is empty); the diagonal is always in the
pattern, so M − hD − h²K has a place for every mass even where no element reaches (an isolated particle);
no pins (n_F = 3N) keeps the whole pattern; undamped (D = 0) gives W D_FF with the pattern of W K_FF and zero
entries, so the stage matrix is σ²I − W K_FF.

References: Baraff & Witkin, "Large steps in cloth simulation", SIGGRAPH 1998, §3; Hairer & Wanner,
*Solving ODEs II*, §IV.8 (the stage systems).
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp

from ..contracts import Obj, contract, unchecked
from ..sparse_kernel import csr_product
from ..ode.second_order import SecondOrderJacobian

__all__ = ["Pattern", "FreeJacobian", "second_order_jac", "free_ode"]

BANDED_LU_MAX = 200      # stage systems with a half-bandwidth up to this use a banded LU (measured, one factor
                         # of the falling sheet's S, CPU: N = 16, b = 98: 6.2 ms vs SuperLU 6.4; N = 24, b = 146:
                         # 17 vs 35 ms; N = 32, b = 194: ~3× faster); wider bands keep SuperLU

_CC = np.array([[1.0, -1.0], [-1.0, 1.0]])                 # c cᵀ of a pair element, c = (1, −1)


class Pattern:
    """The CSR pattern (n × n) of the union of element blocks and the diagonal, and each kind's data map.

    Built once per cloth: the keys r·n + c of every block entry, made unique and sorted (CSR order); each
    kind's entries are found in them by ``searchsorted``."""

    def __init__(self, n: int, dof_lists, pair_kinds=None) -> None:
        self.n = n
        keys = [np.arange(n, dtype=np.int64) * (n + 1)]
        per = []
        for dofs in dof_lists:
            d = dofs.astype(np.int64)
            k = (d[:, :, None] * n + d[:, None, :]).ravel()
            per.append(k)
            keys.append(k)
        uniq = np.unique(np.concatenate(keys))
        rows = uniq // n
        self.indices = (uniq - rows * n).astype(np.int32)
        self.indptr = np.concatenate([[0], np.cumsum(np.bincount(rows, minlength=n))]).astype(np.int32)
        self.rows = rows.astype(np.int32)
        self.nnz = len(uniq)
        self.maps = [np.searchsorted(uniq, k).astype(np.intp) for k in per]
        self.diag = np.searchsorted(uniq, keys[0]).astype(np.intp)
        self.pairs = [None] * len(self.maps)
        self.pair_kinds = []
        self.reduced = [pair_kinds is not None and pair_kinds[c] is not None for c in range(len(self.maps))]
        if pair_kinds is not None:
            self._pair_scatter(pair_kinds)

    def _pair_scatter(self, pair_kinds) -> None:
        """The gather of pair kinds (nv = 2, K_e = c cᵀ ⊗ B with c = (1, −1)) from one 3 × 3 B per element.

        The off-diagonal blocks (a, b) and (b, a) of a pair element both hold −B (no other element of any kind
        touches them: checked here, else the kind keeps the general path, ``pairs[c]`` None); the diagonal
        blocks hold Σ_e B over the elements at a particle, a sparse incidence (particles × elements) times the
        B of all pair kinds (E, 9). So the pair part of the data is one gather ``src[gather]`` from
        src = [−B of every pair kind, the diagonal sums, 0] (a gather writes its output in order: ~3× faster
        here than scattering the same entries)."""
        counts = np.bincount(np.concatenate([m for m in self.maps]), minlength=self.nnz)
        kinds, starts, elems, gather_parts = [], [0], [], []
        for c, elements in enumerate(pair_kinds):
            if elements is None or len(elements) == 0:
                continue
            E = len(elements)
            blk = self.maps[c].reshape(E, 2, 3, 2, 3)
            off = np.stack([blk[:, 0, :, 1, :], blk[:, 1, :, 0, :]], axis=1)       # (E, 2, 3, 3)
            if counts[off].max() > 1:                          # shared with another element: general path
                continue
            kinds.append(c)
            elems.append(elements)
            gather_parts.append((off, starts[-1] + np.arange(9 * E).reshape(E, 1, 3, 3)))
            starts.append(starts[-1] + 9 * E)
        self.pair_kinds, self.pair_starts = kinds, starts
        if not kinds:
            return
        el = np.concatenate(elems)
        E = len(el)
        touched, inv = np.unique(el.ravel(), return_inverse=True)
        self.incidence = sp.csr_matrix((np.ones(2 * E), (inv, np.repeat(np.arange(E), 2))),
                                       shape=(len(touched), E))
        first = np.zeros(len(touched), np.intp)
        first[inv] = np.arange(2 * E)                          # an (element, side) at each particle
        maps = np.concatenate([self.maps[c].reshape(-1, 2, 3, 2, 3) for c in kinds])
        dpos = maps[first // 2, first % 2, :, first % 2, :]   # (T, 3, 3)
        n_src = starts[-1] + 9 * len(touched) + 1
        gather = np.full(self.nnz, n_src - 1, np.intp)         # the last src entry is 0
        for off, src in gather_parts:
            gather[off] = src                                  # broadcast over the two blocks
        gather[dpos] = starts[-1] + np.arange(9 * len(touched)).reshape(-1, 3, 3)
        self.gather, self.pair_mask = gather, gather < n_src - 1
        for c in kinds:
            self.pairs[c] = True

    def data(self, blocks) -> np.ndarray:
        """CSR data of Σ_kinds of the element blocks ``blocks[c]`` (E_c, q, q) (None: nothing from that kind; a
        vector (nnz,): that kind's data already scattered, as :mod:`.lean_terms` gives them); a pair kind
        (``pair_kinds``) passes its reduced blocks B (E_c, 3, 3), K_e = c cᵀ ⊗ B."""
        out = None
        if self.pair_kinds:
            B = np.concatenate([blocks[c].reshape(-1, 9) if blocks[c] is not None else
                                np.zeros(((self.pair_starts[i + 1] - self.pair_starts[i]) // 9, 9))
                                for i, c in enumerate(self.pair_kinds)])
            out = np.concatenate([np.negative(B).ravel(), (self.incidence @ B).ravel(), [0.0]])[self.gather]
        for m, b, pair, reduced in zip(self.maps, blocks, self.pairs, self.reduced):
            if b is None or pair is not None:
                continue
            if b.ndim == 1:                                    # already this kind's data
                add = b
            else:
                if reduced:                                    # reduced blocks of a pair kind: expand c cᵀ ⊗ B
                    b = np.einsum("ij,ekl->eikjl", _CC, b).reshape(len(b), 6, 6)
                add = np.bincount(m, b.ravel(), minlength=self.nnz)
            out = add if out is None else out + add
        return np.zeros(self.nnz) if out is None else out

    def matrix(self, data) -> sp.csr_matrix:
        """The n × n CSR matrix with this pattern and ``data``."""
        return sp.csr_matrix((data, self.indices, self.indptr), shape=(self.n, self.n))


class FreeJacobian:
    """J = [[0, I], [W K_FF, W D_FF]] (2 n_F × 2 n_F) of the free coordinates, filled from K.data and D.data."""

    def __init__(self, pattern: Pattern, free: np.ndarray, winv: np.ndarray) -> None:
        keep = free[pattern.rows] & free[pattern.indices]
        self.sub = np.flatnonzero(keep)                           # positions in K.data, row-major
        fidx = np.cumsum(free) - 1
        nf = int(free.sum())
        self.nf = nf
        r = fidx[pattern.rows[self.sub]]
        c = fidx[pattern.indices[self.sub]].astype(np.int32)
        count = np.bincount(r, minlength=nf)
        start = np.concatenate([[0], np.cumsum(count)])[:-1]    # first sub entry of each free row
        offset = np.arange(len(self.sub)) - start[r]
        base = nf + 2 * start[r]                                 # J row nf + r starts after the identity rows
        nnz = nf + 2 * len(self.sub)
        indices = np.empty(nnz, np.int32)
        indices[:nf] = nf + np.arange(nf)
        kpos, dpos = base + offset, base + count[r] + offset
        indices[kpos], indices[dpos] = c, c + nf
        self.kpos, self.dpos = kpos, dpos
        self.ff_indices = c                                     # K_FF alone (CSR), for :meth:`blocks`
        self.ff_indptr = np.concatenate([[0], np.cumsum(count)]).astype(np.int32)
        self.indices = indices
        self.indptr = np.concatenate([np.arange(nf + 1), nf + 2 * np.cumsum(count)]).astype(np.int32)
        self.w = winv[free][r]                                  # W of each entry's row
        self.shape = (2 * nf, 2 * nf)

    def matrix(self, kdata, ddata) -> sp.csr_matrix:
        """J from the full K.data and D.data (D None: undamped)."""
        data = np.empty(len(self.indices))
        data[:self.nf] = 1.0
        data[self.kpos] = self.w * kdata[self.sub]
        data[self.dpos] = 0.0 if ddata is None else self.w * ddata[self.sub]
        return sp.csr_matrix((data, self.indices, self.indptr), shape=self.shape)

    def blocks(self, kdata, ddata) -> tuple[sp.csc_matrix, sp.csc_matrix]:
        """(W K_FF, W D_FF) (n_F × n_F, CSC) from the full K.data and D.data (D None: undamped, zeros)."""
        def block(data):
            return sp.csr_matrix((self.w * data[self.sub], self.ff_indices, self.ff_indptr),
                                 shape=(self.nf, self.nf)).tocsc()
        return block(kdata), block(np.zeros_like(kdata) if ddata is None else ddata)


class _SpringPass:
    """f, K.data and D.data of a spring cloth in one pass over all its springs (the stacked springs of
    :class:`pbanim.cloth.step_system.SpringStepSystem`), for the free ODE's ``rhs`` and ``jac``.

    With d = x_a − x_b, Δv = v_a − v_b, ŵ = d/|d|, s = k(|d| − r) + k_d ŵ·Δv and (PΔv)ⱼ = (Δvⱼ − ŵⱼ ŵ·Δv)/|d|:
    f_a = −s ŵ = −f_b, and the exact blocks of :meth:`SpringCondition.pair_terms`, component by component,

        −B_K,ij = (k − s/|d|) ŵᵢŵⱼ + (s/|d|) δᵢⱼ + k_d ŵᵢ (PΔv)ⱼ,       −B_D,ij = k_d ŵᵢŵⱼ,

    stored component-major (9, E); the pattern's gather (re-indexed once to that layout) places them, and
    the W K_FF, W D_FF of the stage systems are gathered straight in CSC order (one ``take`` each)."""

    def __init__(self, cloth, system) -> None:
        s, pat, fj = system, cloth.pattern, cloth._jac_free
        self.a, self.b, self.k, self.kd, self.rest, self.damped = s.a, s.b, s.k, s.kd, s.rest, s.damped
        self.signed, self.fext, self.incidence = s.signed, s.fext, s.incidence
        self._signed_product = csr_product(s.signed)           # Σ_e ±(force of e), one column at a time
        E, T = s.E, s.T
        self.E = E
        g = pat.gather.copy()                                  # reads [−B (E, 9), Σ B (T, 9), 0]
        off, dg = g < 9 * E, (g >= 9 * E) & (g < 9 * E + 9 * T)
        e, q = np.divmod(g[off], 9)
        g[off] = q * E + e
        t, q = np.divmod(g[dg] - 9 * E, 9)
        g[dg] = 9 * E + q * T + t
        g[g >= 9 * E + 9 * T] = 9 * E + 9 * T                 # the last source entry is 0
        self.gather, self.n_src = g, 9 * E + 9 * T + 1
        nf = fj.nf
        order = sp.csr_matrix((np.arange(len(fj.sub), dtype=float), fj.ff_indices, fj.ff_indptr),
                              shape=(nf, nf)).tocsc()           # CSR position of each CSC entry
        perm = order.data.astype(np.intp)
        self.ff_gather, self.ff_w = g[fj.sub[perm]], fj.w[perm]
        self.ff_indices, self.ff_indptr = order.indices, order.indptr
        self.nf, self.coords = nf, np.flatnonzero(cloth.free)
        self.x0, self.winv = cloth.sheet.x0.ravel().copy(), cloth.winv[cloth.free]
        self.N = cloth.n // 3

    def _state(self, yf):
        """(6, N) component-major [x; v] of the full state of y_F (pins at rest)."""
        X = np.empty((2, 3 * self.N))
        X[0], X[1] = self.x0, 0.0
        X[0, self.coords], X[1, self.coords] = yf[:self.nf], yf[self.nf:]
        return X.reshape(2, self.N, 3).transpose(0, 2, 1).reshape(6, self.N)

    def pass_(self, yf, jacobians):
        """(f (n,), src_K, src_D) — the sources of the pattern's gather (None without ``jacobians``)."""
        X = self._state(yf)
        dX = np.take(X, self.a, axis=1) - np.take(X, self.b, axis=1)          # (6, E): d, Δv
        d, dv = dX[:3], dX[3:]
        length = np.sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2])
        inv = 1.0 / length
        w = d * inv
        s = self.k * (length - self.rest)
        wdv = w[0] * dv[0] + w[1] * dv[1] + w[2] * dv[2] if self.damped else None
        if self.damped:
            s += self.kd * wdv
        fe = w * -s                                            # (3, E): the force at each spring's first end
        F = np.empty((3, self.N))
        for i in range(3):                                     # what signed @ fe.T computes, column by column
            self._signed_product(fe[i], F[i])                  # (the same sums, bit for bit), without the
        f = (F.T + self.fext).ravel()                          # operator's dispatch (~25 µs a call)
        if not jacobians:
            return f, None, None
        E = self.E
        sl = s * inv
        ck = self.k - sl
        srcK, srcD = np.empty(self.n_src), np.empty(self.n_src) if self.damped else None
        BK = srcK[:9 * E].reshape(9, E)
        pv = (dv - w * wdv) * inv if self.damped else None
        for i in range(3):
            for j in range(3):
                r = BK[3 * i + j]
                np.multiply(ck * w[i], w[j], out=r)
                if i == j:
                    r += sl
                if self.damped:
                    r += self.kd * w[i] * pv[j]
                    np.multiply(self.kd * w[i], w[j], out=srcD[(3 * i + j) * E:(3 * i + j + 1) * E])
        for src in (srcK, srcD) if self.damped else (srcK,):
            neg = src[:9 * E].reshape(9, E)
            src[9 * E:-1] = (self.incidence @ neg.T).T.ravel()
            np.negative(src[9 * E:-1], out=src[9 * E:-1])        # the diagonal blocks Σ B = −Σ(−B)
            src[-1] = 0.0
        return f, srcK, srcD

    def rhs(self, t, yf):
        out = np.empty_like(yf)
        out[:self.nf] = yf[self.nf:]
        out[self.nf:] = self.pass_(yf, False)[0][self.coords] * self.winv
        return out

    def blocks(self, yf):
        """(W K_FF, W D_FF) as CSC data on the shared pattern (``ff_indices``, ``ff_indptr``)."""
        _, srcK, srcD = self.pass_(yf, True)
        kx = self.ff_w * np.take(srcK, self.ff_gather)
        kv = self.ff_w * np.take(srcD, self.ff_gather) if srcD is not None else np.zeros_like(kx)
        return kx, kv

    def jac(self, t, yf, fj):
        """The full J = [[0, I], [W K_FF, W D_FF]] (CSR) of :class:`FreeJacobian` ``fj``."""
        _, srcK, srcD = self.pass_(yf, True)
        return fj.matrix(np.take(srcK, self.gather), None if srcD is None else np.take(srcD, self.gather))


_SpringPass.rhs.autonomous = True     # f does not depend on t: pbanim's Rosenbrock skips its ∂f/∂t difference


def _spring_pass(cloth):
    """The cloth's :class:`_SpringPass` (built once, kept on the cloth), or None when the cloth is not all
    springs (:func:`pbanim.cloth.step_system.spring_system`)."""
    cached = cloth.__dict__.get("_spring_pass", False)
    if cached is False:
        from .step_system import spring_system
        system = spring_system(cloth)
        cached = cloth.__dict__["_spring_pass"] = None if system is None else _SpringPass(cloth, system)
    return cached


@contract(cloth=Obj("pbanim.cloth.model:Cloth"))
def free_ode(cloth):
    """(rhs, jac) of the cloth's free ODE ẏ_F = [v_F, W_F f_F]: :meth:`Cloth.rhs` and :meth:`Cloth.jac` (the
    full sparse J), for a cloth of springs from one pass over all springs (:class:`_SpringPass`), equal to
    them to roundoff (ORACLES J11); the same two functions serve pbanim's and scipy's solvers.

    >>> from pbanim.cloth import Cloth, Sheet
    >>> cloth = Cloth(Sheet(4), stretch=1e3, damping=1e-3)
    >>> rhs, jac = free_ode(cloth)
    >>> yf = cloth.free_state(cloth.state())
    >>> bool(np.allclose(rhs(0.0, yf), cloth.rhs(0.0, yf), rtol=0, atol=1e-12))
    True
    """
    sp_ = _spring_pass(cloth)
    if sp_ is None:
        return unchecked(cloth.rhs), unchecked(cloth.jac)
    fj = cloth._jac_free
    return sp_.rhs, lambda t, yf: sp_.jac(t, yf, fj)


@contract(cloth=Obj("pbanim.cloth.model:Cloth"))
def second_order_jac(cloth):
    """``jac(t, y_F)`` → :class:`SecondOrderJacobian` (W K_FF, W D_FF) of the cloth's free ODE (module docstring);
    for a cloth of springs from one pass over all springs (:func:`free_ode`), the blocks gathered in CSC order
    and the banded LU's placement of their entries computed once.

    >>> from pbanim.cloth import Cloth, Sheet
    >>> cloth = Cloth(Sheet(4), stretch=1e3, damping=1e-3)
    >>> yf = cloth.free_state(cloth.state())
    >>> J = second_order_jac(cloth)(0.0, yf)
    >>> float(abs(J.tocsr() - cloth.jac(0.0, yf)).max()) < 1e-9
    True
    """
    fj = cloth._jac_free
    rows = np.repeat(np.arange(fj.nf), np.diff(fj.ff_indptr))
    half = int(np.abs(rows - fj.ff_indices).max()) if len(rows) else 0
    band = half if half <= BANDED_LU_MAX else None              # grid order: the band of the bend springs
    lean = _spring_pass(cloth)
    if lean is not None:
        shape, idx, ptr = (fj.nf, fj.nf), lean.ff_indices, lean.ff_indptr
        plan = []                                               # the band placement of the first J, for all

        def jac(t, yf):
            with np.errstate(all="ignore"):
                kx, kv = lean.blocks(yf)
            J = SecondOrderJacobian(sp.csc_matrix((kx, idx, ptr), shape=shape),
                                    sp.csc_matrix((kv, idx, ptr), shape=shape), band=band)
            if plan:
                J.plan = plan[0]
            elif band is not None:
                plan.append(J.band_plan())
            return J
        return jac
    blocks = fj.blocks

    def jac(t, yf):
        x, v = cloth._split(yf)
        with np.errstate(all="ignore"):
            _, kd, dd = cloth._all(x, v)
        return SecondOrderJacobian(*blocks(kd, dd), band=band)
    return jac
