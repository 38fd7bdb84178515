"""Assembly of J, J̇q̇ and JWJᵀ for a set of constraint kinds, and the chain/tree structure (chapter 03).

A :class:`ConstraintSet` compiles the topology of its constraints **once**: the sparsity pattern of J
(rows × q), the pattern of A = JWJᵀ (two rows interact iff they touch a common particle), and the map
from *pairs of Jacobian blocks at a common particle* to entries of A:

    A_rs = Σ_{p touched by rows r and s}  W_p · G_{r,p} · G_{s,p}          (G = ∂C_r/∂x_p, a dim-vector)

Each step then only refills the values with array operations (no Python loop per constraint).

Structure (Baraff 1996). Let the bipartite graph have a node per particle and a node per constraint row,
with an edge when a row touches a particle. If that graph is a forest (a chain, a tree, a hanging net
without loops), eliminating rows leaves-first (reverse breadth-first order from a root particle) is a
*perfect elimination order* of A: the rows still un-eliminated next to a row all share its parent
particle, so they already form a clique and Gaussian elimination creates no fill. The LDLᵀ factorization
then costs O(Σ_p deg(p)²) = O(n) for bounded degree. A chain ordered this way is tridiagonal, and
LAPACK's ``dptsv`` solves it in O(n) with no overhead; a bounded-bandwidth order uses banded Cholesky;
other trees use a zero-fill sparse LDLᵀ in the perfect order.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp
from scipy.sparse import csgraph

from .base import DIM, N_PARTICLES
from .check import UserConstraint
from .kinds import Constraint
from .rows import _dot, _span
from ..contracts import Array, Flag, Obj, Opt, Seq, Spec, contract, unchecked

__all__ = ["ConstraintSet", "Assembly", "Structure"]


@dataclass
class Structure:
    """The constraint graph's shape: ``kind`` "chain" (tridiagonal in ``order``), "banded", "tree", or
    "general" (has loops, or user constraints); ``order`` is the leaves-first row order (None if general);
    a chain numbered from its root keeps 0, …, m−1 (``natural``: its row 0 hangs from the world, a leaf)."""

    kind: str
    bandwidth: int = -1
    order: np.ndarray | None = None
    natural: bool = False  # order is 0, …, m−1 (a chain numbered along itself): no gathers

    @property
    def linear(self) -> bool:
        return self.kind in ("chain", "banded", "tree")


@dataclass
class Assembly:
    """Everything one evaluation needs: C, Ċ = Jq̇, J̇q̇ (m,), J (sparse m × n), and the block values."""

    C: np.ndarray
    Jdv: np.ndarray
    J: sp.csr_matrix
    v: np.ndarray                   # q̇ (flat), for Ċ
    vals: tuple | None = None  # (diag (m,), off (pairs,)): W_p G·G of A = JWJᵀ (blocks mode)
    JT: sp.spmatrix | None = None  # Jᵀ (CSC on J's own arrays for built-in kinds; CSR otherwise)
    _Cdot: np.ndarray | None = None

    @property
    def Cdot(self) -> np.ndarray:
        """Ċ = J q̇ (computed on first use)."""
        if self._Cdot is None:
            self._Cdot = self.J @ self.v
        return self._Cdot


def _pattern(r1: np.ndarray, r2: np.ndarray, m: int, fmt: str = "csr"):
    """Pattern of a symmetric m×m matrix from half pairs (r1, r2): (matrix, pos(r1,r2), pos(r2,r1))."""
    key = np.concatenate([r1 * m + r2, r2 * m + r1])
    uniq, inv = np.unique(key, return_inverse=True)
    rows, cols = uniq // m, uniq % m
    indptr = np.concatenate([[0], np.cumsum(np.bincount(rows, minlength=m))])
    mat = sp.csr_matrix((np.zeros(len(uniq)), cols, indptr), shape=(m, m))
    h = len(r1)
    return mat, inv[:h], inv[h:]


_X = Array(("self.N", "self.dim"))


class _AssemblyOf(Spec):
    """An :class:`Assembly` made by the set the method is called on (``self``: m rows, n coordinates), with
    the JWJᵀ block values and the structure the method reads (a cross-argument condition, so a spec of its
    own: it runs at the boundary only, never in the solver's loop)."""

    size = "self"      # it reads the call's self: a reference, so the contract binds every argument

    def __init__(self, needs: tuple = ()) -> None:
        self.needs = tuple(needs)

    def describe(self) -> str:
        what = "an Assembly of this ConstraintSet (from its assemble)"
        return what + (f", with pairs=True and a structure among {list(self.needs)}" if self.needs else "")

    def check(self, name, value, env):
        cs = env.values["self"]
        if not isinstance(value, Assembly):
            raise env.fail(name, self.describe(), value)
        if value.C.shape != (cs.m,) or value.J.shape != (cs.m, cs.n):
            raise env.fail(name, self.describe(), value, f"it has {value.J.shape[0]} rows and {value.J.shape[1]} "
                           f"columns, the set {cs.m} and {cs.n}")
        if self.needs and value.vals is None:
            raise env.fail(name, self.describe(), value, "it has no block values (pairs=False or user kinds)")
        if self.needs and cs.structure.kind not in self.needs:
            raise env.fail(name, self.describe(), value, f"this set's structure is {cs.structure.kind!r}")
        return value

    def example(self, env):
        cs = env.values["self"]
        x = np.zeros((cs.N, cs.dim))
        return cs.assemble(x + np.arange(cs.N)[:, None], x)

    def bad(self, env):
        return [("None", None), ("a string", "asm"), ("an array", np.zeros(3))]


class ConstraintSet:
    """Many constraint kinds on one particle system, assembled together.

    Parameters
    ----------
    constraints : sequence of Constraint
    N, dim : int
        Particle count and dimension.
    W : array_like, shape (N,)
        Inverse masses.
    x0 : ndarray, shape (N, dim), optional
        Initial positions (used for default rest lengths / nail points).

    Examples
    --------
    >>> import numpy as np
    >>> from pbanim.constraints.kinds import Distance
    >>> x0 = np.array([[0.0, -1.0], [0.0, -2.0], [0.0, -3.0]])
    >>> cs = ConstraintSet([Distance([[0, -1], [1, 0], [2, 1]], anchors=[0.0, 0.0])], 3, 2, np.ones(3), x0)
    >>> cs.m, cs.structure.kind
    (3, 'chain')
    >>> cs.assemble(x0, np.zeros_like(x0)).C
    array([0., 0., 0.])
    """

    @contract(constraints=Seq(Obj(Constraint), min_len=1), N=N_PARTICLES, dim=DIM, W=Array(("$N",), gt=0),
              x0=Opt(Array(("$N", "$dim"))))
    def __init__(self, constraints, N: int, dim: int, W, x0: np.ndarray | None = None) -> None:
        self.constraints = list(constraints)
        for c in self.constraints:
            c.bind(N, dim, x0)
        # each kind's evaluate, unchecked (the step loop's own calls); None for user kinds (read row by row)
        self._evaluate = [None if isinstance(c, UserConstraint) else unchecked(c.evaluate) for c in self.constraints]
        self.N, self.dim = int(N), int(dim)
        self.W = np.asarray(W, float)
        self.Wq = np.repeat(self.W, dim)
        self.n = self.N * self.dim
        sizes = [c.m for c in self.constraints]
        self.offsets = np.concatenate([[0], np.cumsum(sizes)])
        self.m = int(self.offsets[-1])
        self.blocks = not any(isinstance(c, UserConstraint) for c in self.constraints)
        self.assemblies = 0  # how many times J was assembled (a scene without constraints never does)
        if self.blocks:
            self._compile()
        else:
            self.structure = Structure("general")

    # -- topology, once ----------------------------------------------------------------------------
    def _compile(self) -> None:
        dim, m = self.dim, self.m
        rows, parts, blocks, goff = [], [], [], 0
        for c, off in zip(self.constraints, self.offsets):
            st = c.slots.T.ravel()  # slot-major, like G (k, m, dim)
            flat = np.flatnonzero(st >= 0)
            rows.append(off + flat % c.m)
            parts.append(st[flat])
            blocks.append(goff + flat)
            goff += c.slots.size
        # entry e (a block at a particle, fixed points left out) is row gb[e] of all kinds' G stacked
        # (k·m, dim): every gather below indexes that stack directly, so no block is copied twice
        er, ep, gb = np.concatenate(rows), np.concatenate(parts), np.concatenate(blocks)
        E = len(er)
        # J pattern (CSR) and where each block component lands in J.data
        jr = np.repeat(er, dim)
        jc = (ep[:, None] * dim + np.arange(dim)).ravel()
        order = np.lexsort((jc, jr))
        indptr = np.concatenate([[0], np.cumsum(np.bincount(jr, minlength=m))])
        self._J = sp.csr_matrix((np.zeros(E * dim), jc[order], indptr), shape=(m, self.n))
        gflat = (gb[:, None] * dim + np.arange(dim)).ravel()  # entry component → stacked G, flattened
        self._Jperm = gflat[order]
        # when each row touches a particle at most once, a row's dim columns per block are adjacent in J:
        # J.data is then a gather of whole blocks (rows of G), not of single numbers
        bperm = order[::dim] // dim
        same = np.array_equal(order, (bperm[:, None] * dim + np.arange(dim)).ravel())
        self._Jblocks = gb[bperm] if same else None
        # Jᵀ is J's own arrays read as CSC (n × m): Q_C = Jᵀλ adds each column's entries in row order from 0,
        # the sums a CSR copy of Jᵀ forms, bit for bit, with no gather of J's values per step (only J.data
        # is handed over)
        self._JT = sp.csc_matrix((self._J.data, self._J.indices, self._J.indptr), shape=(self.n, m))
        # diagonal of A: A_rr = Σ_e∈r W_e|G_e|², summed per row (entries are sorted by row)
        Wpad = np.r_[self.W, 0.0]  # index −1 (a fixed point) has W = 0
        # per kind, W of each slot as (k, m); a kind with opposite blocks needs |G|² once: (W_a + W_b) |G_0|²
        self._Wslots = [Wpad[c.slots].T.sum(axis=0, keepdims=True) if c.opposite
                        else np.ascontiguousarray(Wpad[c.slots].T) for c in self.constraints]
        # off-diagonal: pairs (i < j) of distinct blocks at a common particle, all pairs in each group
        s = np.argsort(ep, kind="stable")
        ps = ep[s]
        starts = np.flatnonzero(np.r_[True, ps[1:] != ps[:-1]])
        counts = np.diff(np.r_[starts, E])
        after = np.repeat(starts, counts) + np.repeat(counts, counts) - np.arange(E) - 1  # blocks after me
        i_idx = np.repeat(np.arange(E), after)
        j_idx = i_idx + 1 + (np.arange(len(i_idx)) - np.repeat(np.cumsum(after) - after, after))
        self._ei, self._ej = s[i_idx], s[j_idx]
        self._pw = self.W[ep[self._ei]]
        r1, r2 = er[self._ei], er[self._ej]
        # a chain numbered along itself pairs rows r, r + 1 at their common particle for every r: the
        # pairs' blocks are two runs of consecutive rows of G, read as slices, not gathers
        self._gi, self._gj = gb[self._ei], gb[self._ej]
        self._gis, self._gjs = _span(self._gi), _span(self._gj)
        rows_all = np.arange(m)
        self._A, pos1, pos2 = _pattern(np.r_[rows_all, r1], np.r_[rows_all, r2], m)
        self._pdiag, self._pos1, self._pos2 = pos1[:m], pos1[m:], pos2[m:]
        self.structure = self._structure(er, ep, r1, r2)

    def _structure(self, er, ep, r1, r2) -> Structure:
        m, N = self.m, self.N
        edges = np.unique(er * N + ep)
        er_u, ep_u = edges // N, edges % N
        # bipartite graph: rows 0..m-1, particles m..m+N-1, and a super-root m+N
        g = sp.coo_matrix((np.ones(len(edges)), (er_u, m + ep_u)), shape=(m + N + 1, m + N + 1))
        ncomp, labels = csgraph.connected_components(g, directed=False)
        used = np.zeros(m + N + 1, bool)
        used[:m] = True
        used[m + ep_u] = True
        comps = np.unique(labels[used])
        if len(edges) != used.sum() - len(comps) or np.any(np.bincount(er_u, minlength=m) == 0):
            return Structure("general")
        # one root particle per component (its lowest index), all hung from the super-root
        plab = labels[m + ep_u]
        _, first = np.unique(plab, return_index=True)
        roots = m + ep_u[first]
        sup = m + N
        g2 = sp.coo_matrix((np.ones(len(edges) + len(roots)),
                            (np.r_[er_u, np.full(len(roots), sup)], np.r_[m + ep_u, roots])),
                           shape=(m + N + 1, m + N + 1)).tocsr()
        bfs = csgraph.breadth_first_order(g2, sup, directed=False, return_predecessors=False)
        order = bfs[bfs < m][::-1]  # rows, leaves first
        if len(order) != m:
            return Structure("general")
        inv = np.empty(m, np.int64)
        inv[order] = np.arange(m)
        a, b = inv[r1], inv[r2]
        bw = int(np.max(np.abs(a - b), initial=0))
        if bw <= 1 and np.array_equal(order, np.arange(m)[::-1]):
            # a path has a leaf at each end, and A stays tridiagonal in the reversed order: eliminating
            # from the far end (row 0 hangs from the world, so it is a leaf too) is as free of fill
            order = order[::-1].copy()
            inv[order] = np.arange(m)
            a, b = inv[r1], inv[r2]
        lo, hi = np.maximum(a, b), np.minimum(a, b)
        self._band_pos = (lo - hi) * m + hi          # lower band storage ab[i - j, j]
        self._band_mult = np.where(a == b, 2.0, 1.0)  # two blocks of one row at one particle
        self._inv = inv
        self._e_src = False  # chain: how e (the sub-diagonal) is read off the pair values
        if bw <= 1:
            kind = "chain"
            if len(hi) == m - 1 and np.all(lo - hi == 1) and len(np.unique(hi)) == m - 1:
                self._e_src = None if np.array_equal(hi, np.arange(m - 1)) else np.argsort(hi)
        elif bw <= 16:
            kind = "banded"
        else:
            kind = "tree"
            self._Ap, pp1, pp2 = _pattern(np.r_[np.arange(m), a], np.r_[np.arange(m), b], m)
            self._ppdiag, self._ppos1, self._ppos2 = pp1[:m], pp1[m:], pp2[m:]
        return Structure(kind, bw, order, natural=bool(np.array_equal(order, np.arange(m))))

    # -- per step ----------------------------------------------------------------------------------
    @contract(x=_X, v=_X, pairs=Flag())
    def assemble(self, x: np.ndarray, v: np.ndarray, pairs: bool = True) -> Assembly:
        """C, Ċ, J̇q̇ and J at (x, v) of shape (N, dim); ``pairs`` also computes the JWJᵀ block values."""
        self.assemblies += 1
        out = [None if f is None else f(x, v) for f in self._evaluate]
        if self.blocks:
            one = len(out) == 1  # a single kind: its (fresh) arrays are used as they are
            C = out[0][0] if one else np.concatenate([o[0] for o in out])
            Jdv = out[0][2] if one else np.concatenate([o[2] for o in out])
            Gs = [o[1].reshape(-1, self.dim) for o in out]
            Gf = Gs[0] if one else np.concatenate(Gs)  # all kinds' blocks, fixed points included
            J, JT = self._J, self._JT
            gflat = Gf.ravel()
            J.data = np.take(gflat, self._Jperm) if self._Jblocks is None else \
                np.take(Gf, self._Jblocks, axis=0).ravel()
            JT.data = J.data
            vals = None
            if pairs:
                diags = []
                for o, Ws in zip(out, self._Wslots):  # A_rr = Σ_slots W_p |G_{r,p}|²
                    G = o[1]
                    dk = Ws[0] * _dot(G[0], G[0])
                    for j in range(1, len(Ws)):
                        dk += Ws[j] * _dot(G[j], G[j])
                    diags.append(dk)
                diag = diags[0] if one else np.concatenate(diags)
                Gi = Gf[self._gis] if self._gis is not None else np.take(Gf, self._gi, axis=0)
                Gj = Gf[self._gjs] if self._gjs is not None else np.take(Gf, self._gj, axis=0)
                off = _dot(Gi, Gj)
                off *= self._pw
                vals = (diag, off)
        else:
            Cs, Js, Jds = [], [], []
            for c, o in zip(self.constraints, out):
                if o is None:
                    Cs.append(c.value(x))
                    Js.append(c.jacobian(x))
                    Jds.append(c.jdot_qdot(x, v))
                else:
                    Cs.append(o[0])
                    Jds.append(o[2])
                    Js.append(c.jacobian(x))
            C, Jdv = np.concatenate(Cs), np.concatenate(Jds)
            J, vals = sp.vstack(Js, format="csr"), None
            JT = J.T.tocsr()
        return Assembly(C=C, Jdv=Jdv, J=J, v=v.ravel(), vals=vals, JT=JT)

    @contract(asm=_AssemblyOf())
    def matrix(self, asm: Assembly) -> sp.csr_matrix:
        """A = JWJᵀ (sparse) from an assembly."""
        if asm.vals is None:
            return (asm.J @ sp.diags(self.Wq) @ asm.J.T).tocsr()
        diag, off = asm.vals
        nnz = self._A.nnz
        data = np.bincount(self._pdiag, diag, minlength=nnz)
        data += np.bincount(self._pos1, off, minlength=nnz)
        data += np.bincount(self._pos2, off, minlength=nnz)
        A = self._A.copy()
        A.data = data
        return A

    @contract(asm=_AssemblyOf(("chain", "banded", "tree")))
    def bands(self, asm: Assembly) -> np.ndarray:
        """A in lower band storage of the leaves-first order: ab[i − j, j] = A[order[i], order[j]]."""
        b, m = self.structure.bandwidth, self.m
        diag, off = asm.vals
        ab = np.bincount(self._band_pos, off * self._band_mult, minlength=(b + 1) * m) if len(off) else \
            np.zeros((b + 1) * m)
        ab[:m] += diag if self.structure.natural else np.take(diag, self.structure.order)
        return ab.reshape(b + 1, m)

    @contract(asm=_AssemblyOf(("chain",)))
    def tridiagonal(self, asm: Assembly) -> tuple[np.ndarray, np.ndarray]:
        """A chain's A in the leaves-first order as its diagonal (m,) and sub-diagonal (m − 1,); when each
        sub-diagonal entry is one pair value W_p G_{r,p}·G_{s,p}, these are read off without a bincount
        (read only: they may be the assembly's own arrays)."""
        if self._e_src is False:
            ab = self.bands(asm)
            return ab[0], ab[1, :-1]
        diag, off = asm.vals
        d = diag if self.structure.natural else np.take(diag, self.structure.order)
        return d, (off if self._e_src is None else np.take(off, self._e_src))

    @contract(asm=_AssemblyOf(("tree",)))
    def permuted_matrix(self, asm: Assembly) -> sp.csc_matrix:
        """A in the leaves-first order (tree structure), CSC (A is symmetric)."""
        diag, off = asm.vals
        nnz = self._Ap.nnz
        data = np.bincount(self._ppdiag, np.take(diag, self.structure.order), minlength=nnz)
        data += np.bincount(self._ppos1, off, minlength=nnz)
        data += np.bincount(self._ppos2, off, minlength=nnz)
        return sp.csc_matrix((data, self._Ap.indices, self._Ap.indptr), shape=self._Ap.shape)
