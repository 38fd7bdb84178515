"""Damped springs between particle pairs, vectorized over springs, with their sparse Jacobians (ch01).

For a spring s joining particles a and b (Witkin & Baraff, "Particle System Dynamics"):

    d = x_a − x_b,   l = |d|,   d̂ = d / l,   l̇ = (v_a − v_b)·d̂
    f = −[k_s (l − r) + k_d l̇] d̂,        Q_a += f,   Q_b −= f,        V = ½ k_s (l − r)²

Equal and opposite forces along d̂: total linear and angular momentum are conserved (ORACLES A7).
The Jacobians used by implicit Euler (Baraff & Witkin 1998), with P = I − d̂d̂ᵀ:

    ∂f/∂x_a = −k_s [(1 − r/l) P + d̂d̂ᵀ] − (k_d / l) [d̂ (v_a − v_b)ᵀ P + l̇ P]  =: K_s
    ∂f/∂v_a = −k_d d̂d̂ᵀ                                                           =: D_s

and ∂f/∂x_b = −K_s, ∂f/∂v_b = −D_s, so each spring adds the 2×2 block pattern [[K, −K], [−K, K]] to
∂Q/∂x (and likewise D to ∂Q/∂v). Scatter of the (S, dim) spring forces into Q is one ``np.bincount``
per end over precomputed flat indices (at S = 10⁵ measured 3.2 ms, vs 29 ms for ``np.add.at`` and
2.7 ms for the sparse incidence product Bᵀf, which needs a matrix; the spring forces themselves cost
more than either — see ``pbanim bench particles``). :func:`spring_forces_loop` is the readable one-spring-at-a-time
version; the tests check that the two agree.

Notation
--------
=======  ==============  ==========  ===============================
symbol   code            shape       meaning
=======  ==============  ==========  ===============================
a, b     ``a, b``        (S,)        end-point particle indices
k_s      ``ks``          (S,)        stiffness (N/m)
k_d      ``kd``          (S,)        damping along the spring (N·s/m)
r        ``rest``        (S,)        rest length (m)
d, l     ``d, l``        (S, dim)    end-point difference, length
=======  ==============  ==========  ===============================

Limiting case: a zero-length spring (l = 0) exerts no force direction; such a spring contributes
f = −k_s(l − r)d̂ with d̂ := 0 (it is the user's job not to rest a spring at l = 0 with r > 0).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np
import scipy.sparse as sp

from .specs import Buffer, IndexArray, Matrix
from ..contracts import Array, Obj, Opt, Real, Text, contract, unchecked
from ..scene import Effect
from ..errors import InvalidInput, as_floats, check_result

__all__ = ["DampedSprings", "ForceJacobian", "spring_forces_loop"]

_SYSTEM = Obj("pbanim.particles.system:ParticleSystem")
_Y = Array(("self.system.n_state",))
_Q = Buffer(("self.system.N", "self.system.dim"))
_T = Real()
_PER_SPRING = Array(("S",), ge=0, scalar=True, empty=True)
#: Up to this many springs × particles, gathers and scatter are products with the dense incidence matrix.
DENSE_MAX = 4096


def _symbol(name: str):
    """A size read from a shape symbol bound earlier in the call (``"N"``: the rows of x)."""
    def size(env):
        return env.symbols[name]
    size.__name__ = name
    return size


def row_norms(d: np.ndarray) -> np.ndarray:
    """|dᵢ| of the rows of an (S, dim) array, scaled by the largest entry where |dᵢ|² overflows (a finite
    d never gives an infinite or NaN length; the plain sqrt(Σd²) is used where it is finite)."""
    with np.errstate(over="ignore"):
        length = np.sqrt(np.einsum("ij,ij->i", d, d))
    big = np.isinf(length) & np.isfinite(d).all(axis=1)
    if big.any():
        s = np.abs(d[big]).max(axis=1)
        u = d[big] / s[:, None]
        length[big] = s * np.sqrt(np.einsum("ij,ij->i", u, u))
    return length


def row_dot(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Row-wise dot products of (..., m, dim) arrays (broadcast), column by column: much faster than
    sum(axis=-1) or einsum for dim ≤ 3, and no BLAS call (whose threads stall on a busy machine). One
    contiguous product, then the column sums (a quarter faster than multiplying the strided columns one
    by one)."""
    p = a * b
    if p.shape[-1] == 1:
        return p[..., 0]
    out = p[..., 0] + p[..., 1]
    for k in range(2, p.shape[-1]):
        out += p[..., k]
    return out


def bilinear(f, a: np.ndarray, b: np.ndarray):
    """f(a, b) for f bilinear (a momentum Σ m v, an angular momentum Σ x × m v): where the plain value is not
    finite although a and b are, f(a/sa, b/sb)·sa·sb with sa, sb the largest |entries|: ±inf when the true
    value exceeds the double range, never a NaN from inf − inf."""
    with np.errstate(over="ignore", invalid="ignore"):
        out = f(a, b)
    if np.isfinite(out).all() or not (np.isfinite(a).all() and np.isfinite(b).all()):
        return out
    sa, sb = float(np.abs(a).max(initial=0.0)) or 1.0, float(np.abs(b).max(initial=0.0)) or 1.0
    with np.errstate(over="ignore"):
        return f(a / sa, b / sb) * sa * sb


@contract(dQdx=Opt(Matrix(("n", "n"), sparse=True)), dQdv=Opt(Matrix(("n", "n"), sparse=True)))
@dataclass
class ForceJacobian:
    """∂Q/∂x and ∂Q/∂v of one force effect, sparse (N·dim, N·dim); ``None`` means identically zero."""

    dQdx: sp.spmatrix | None
    dQdv: sp.spmatrix | None


def _per_spring(value: Any, S: int, name: str, fix: str) -> np.ndarray:
    """Broadcast a scalar or (S,) parameter (per spring, or per particle) to (S,), validated finite and ≥ 0."""
    a = as_floats(name, value)
    if a.ndim > 1 or (a.ndim == 1 and a.shape[0] != S):
        raise InvalidInput(f"{name} must be a scalar or have shape ({S},), got shape {a.shape}")
    a = np.broadcast_to(a, (S,)).copy()
    bad = ~np.isfinite(a) | (a < 0)
    if bad.any():
        raise InvalidInput(f"{name} must be finite and >= 0, got {a[bad][0]}; {fix}")
    return a


@contract(x=Array(("N", "dim")), v=Array(("N", "dim")), pairs=IndexArray(("S", 2), size=_symbol("N"), distinct="rows",
                                                                         empty=True),
          ks=Array(("S",), ge=0, empty=True), kd=Array(("S",), ge=0, empty=True), rest=Array(("S",), ge=0, empty=True))
def spring_forces_loop(x: np.ndarray, v: np.ndarray, pairs: np.ndarray, ks: np.ndarray, kd: np.ndarray,
                       rest: np.ndarray) -> np.ndarray:
    """Readable reference: the force of every spring, one spring at a time (a Python loop).

    Returns Q of shape (N, dim). Use :class:`DampedSprings` in simulations; this is for reading and for
    checking the vectorized version. A spring of length 0 has no direction d̂ and exerts no force.

    >>> x = np.array([[0.0, 0.0], [2.0, 0.0]]); v = np.zeros_like(x)
    >>> spring_forces_loop(x, v, np.array([[0, 1]]), np.array([10.0]), np.array([0.0]), np.array([1.0]))
    array([[ 10.,   0.],
           [-10.,   0.]])
    """
    Q = np.zeros_like(x, dtype=float)
    for s, (a, b) in enumerate(pairs):
        d = x[a] - x[b]
        length = math.hypot(*d)     # scaled: no overflow of |d|² for a finite d
        if length == 0.0:
            continue
        dhat = d / length
        ldot = (v[a] - v[b]) @ dhat
        f = -(ks[s] * (length - rest[s]) + kd[s] * ldot) * dhat
        Q[a] += f
        Q[b] -= f
    return check_result("spring_forces_loop", Q, "a spring force overflows the double range")


class DampedSprings(Effect):
    """S damped springs at once, from an index array of pairs (vectorized; sparse Jacobians).

    Parameters
    ----------
    pairs : array_like of int, shape (S, 2)
        End-point particle indices (a, b), a ≠ b, in [0, N).
    stiffness : float or array_like, shape (S,)
        k_s ≥ 0 (N/m).
    damping : float or array_like, shape (S,)
        k_d ≥ 0 (N·s/m), damping of the length rate l̇ only (no drag on rigid motion).
    rest_length : float or array_like, shape (S,), optional
        r ≥ 0 (m); default: the lengths at the system's initial positions (a net at rest).
    name : str
        Stage name in ``scene.pipeline``.

    Examples
    --------
    >>> from pbanim.particles import ParticleSystem
    >>> from pbanim.scene import Scene
    >>> ps = ParticleSystem([[0.0, 0.0], [2.0, 0.0]])
    >>> springs = DampedSprings([[0, 1]], stiffness=10.0, damping=0.0, rest_length=1.0)
    >>> scene = Scene(ps, [springs]); scene.forces(0.0, ps.state())
    array([[ 10.,   0.],
           [-10.,   0.]])
    >>> springs.potential_energy(ps.state())
    5.0
    """

    phase = "force"
    nan_safe = True     # a NaN state gives NaN forces, never an exception (a run checks its states in blocks)

    @contract(pairs=IndexArray(("S", 2), distinct="rows", empty=True), stiffness=_PER_SPRING, damping=_PER_SPRING,
              rest_length=Opt(_PER_SPRING), name=Text(nonempty=True))
    def __init__(self, pairs: Any, stiffness: Any = 1.0, damping: Any = 0.0, rest_length: Any = None,
                 name: str = "springs") -> None:
        self.pairs = np.asarray(pairs, dtype=np.intp).reshape(-1, 2)
        self.S = self.pairs.shape[0]
        self.stiffness_in, self.damping_in, self.rest_in, self.name = stiffness, damping, rest_length, name

    @contract(system=_SYSTEM)
    def bind(self, system: Any) -> None:
        N, dim, S = system.N, system.dim, self.S
        a, b = self.pairs[:, 0], self.pairs[:, 1]
        bad = (self.pairs < 0) | (self.pairs >= N)
        if bad.any():
            s = int(np.argwhere(bad)[0, 0])
            raise InvalidInput(f"pairs must index particles in [0, {N}), got {self.pairs[s].tolist()} "
                             f"at spring {s}")
        self.system, self.a, self.b = system, a, b
        self._unpack = unchecked(system.unpack)     # the step loop's own calls pay no argument check
        self.ks = _per_spring(self.stiffness_in, S, "stiffness", "use a spring stiffness k_s >= 0")
        self.kd = _per_spring(self.damping_in, S, "damping", "use a spring damping k_d >= 0")
        if self.rest_in is None:
            self.rest = row_norms(system.x0[a] - system.x0[b])
        else:
            self.rest = _per_spring(self.rest_in, S, "rest_length", "use a rest length r >= 0")
        self._damped = bool(np.any(self.kd > 0))
        # flat scatter indices: Q.ravel()[a*dim + k] += f[:, k], Q.ravel()[b*dim + k] −= f[:, k]
        k = np.arange(dim)
        self._ia = (a[:, None] * dim + k).ravel()
        self._ib = (b[:, None] * dim + k).ravel()
        self._n = N * dim
        # Jacobian pattern: for each spring the blocks (a,a) +K, (b,b) +K, (a,b) −K, (b,a) −K
        ra, rb = a[:, None] * dim + k, b[:, None] * dim + k            # (S, dim)
        rows = np.stack([ra, rb, ra, rb])[:, :, :, None] + 0 * k        # (4, S, dim, dim)
        cols = np.stack([ra, rb, rb, ra])[:, :, None, :] + 0 * k[:, None]
        self._jrows, self._jcols = rows.ravel(), cols.ravel()
        # a few springs (S·N ≤ DENSE_MAX): the gathers x_a − x_b and the scatter Σ ±f are products with the dense
        # signed incidence matrix B (S × N), two calls instead of six (the same sums: an exact x_a − x_b, and
        # each Q_i summed over its springs in another order, equal to roundoff)
        self._B = self._Bt = None
        if 0 < S * N <= DENSE_MAX and getattr(system, "split", None) == N * dim == np.size(system.state()) // 2:
            self._B = self.incidence().toarray()
            self._Bt = np.ascontiguousarray(self._B.T)
            self._xv = (2, N, dim)       # y = [x, v] as one (2, N, dim) array: d and ḋ in one product

    # -- geometry ----------------------------------------------------------------------------------
    def _geometry(self, y: np.ndarray):
        x, v = self.system.unpack(y)
        d = x[self.a] - x[self.b]
        length = row_norms(d)
        safe = np.where(length > 0, length, 1.0)
        dhat = d / safe[:, None]
        dhat[length == 0] = 0.0
        dv = v[self.a] - v[self.b]
        return d, length, dhat, dv

    @contract(y=_Y)
    def spring_forces(self, y: np.ndarray) -> np.ndarray:
        """f of every spring on its end a, shape (S, dim) (see :meth:`_forces`)."""
        return self._forces(y)

    def _forces(self, y: np.ndarray) -> np.ndarray:
        """f of every spring on its end a, shape (S, dim), for the step loop (no argument check).

        Written as f = −c d with c = [k_s (l − r) + k_d (v_a − v_b)·d / l] / l, so d̂ is never formed:
        (S, dim) work is two gathers per end, two row dots and one scaling. A spring of length 0 (ends at one
        point, whatever its rest length) has no direction and exerts no force; where l² overflows, c is
        taken from the scaled length (the force is then ±inf at worst, never NaN).
        """
        B = self._B
        with np.errstate(divide="ignore", invalid="ignore", over="ignore"):    # one context for the whole call
            if B is not None:
                D = B @ y.reshape(self._xv)        # (2, S, dim): d = x_a − x_b and ḋ = v_a − v_b, exact
                d, dv = D[0], D[1]
                dots = row_dot(D, d)               # |d|² and ḋ·d, one product
                length = np.sqrt(dots[0])
            else:
                x, v = self._unpack(y)
                d = np.take(x, self.a, axis=0)
                d -= np.take(x, self.b, axis=0)
                length = np.sqrt(row_dot(d, d))
            inv = 1.0 / length
            c = self.ks * (length - self.rest)
            if self._damped:
                if B is None:
                    dv = np.take(v, self.a, axis=0)
                    dv -= np.take(v, self.b, axis=0)
                c += self.kd * (row_dot(dv, d) if B is None else dots[1]) * inv
            c *= inv
            if not math.isfinite(np.add.reduce(c)):    # a zero length, an overflow (or a sum past the range)
                c[length == 0] = 0.0       # a zero-length spring has no direction: no force
                big = np.isinf(length)
                if big.any():              # |d|² overflowed: c = k_s (1 − r/l) + k_d (Δv·d̂)/l from the scaled l
                    lb = row_norms(d[big])
                    cb = self.ks[big] * (1.0 - self.rest[big] / lb)
                    if self._damped:
                        cb += self.kd[big] * (np.einsum("ij,ij->i", dv[big], d[big] / lb[:, None]) / lb)
                    c[big] = cb
            d *= -c[:, None]
        return d

    @contract(t=_T, y=_Y, Q=_Q)
    def apply(self, t: float, y: np.ndarray, Q: np.ndarray) -> None:
        if self._Bt is not None:
            Q += self._Bt @ self._forces(y)
            return
        f = self._forces(y).ravel()
        n = self._n
        dQ = np.bincount(self._ia, f, minlength=n)
        dQ -= np.bincount(self._ib, f, minlength=n)
        Q += dQ.reshape(Q.shape)

    @contract(t=_T, y=_Y, Q=_Q)
    def apply_add_at(self, t: float, y: np.ndarray, Q: np.ndarray) -> None:
        """Same as :meth:`apply`, scattering with ``np.add.at`` (kept for the benchmark's comparison)."""
        f = self._forces(y)
        np.add.at(Q, self.a, f)
        np.add.at(Q, self.b, -f)

    def incidence(self) -> sp.csr_matrix:
        """Signed incidence matrix B (S × N): +1 at (s, a_s), −1 at (s, b_s); Q = Bᵀ f."""
        S = self.S
        return sp.csr_matrix((np.r_[np.ones(S), -np.ones(S)], (np.r_[np.arange(S), np.arange(S)],
                                                                np.r_[self.a, self.b])), shape=(S, self.system.N))

    # -- energy and Jacobians ----------------------------------------------------------------------
    @contract(y=_Y)
    def lengths(self, y: np.ndarray) -> np.ndarray:
        return self._geometry(y)[1]

    @contract(y=_Y)
    def potential_energy(self, y: np.ndarray) -> float:
        """V = ½ Σ k_s (l − r)²."""
        ext = self.lengths(y) - self.rest
        return float(0.5 * np.sum(self.ks * ext * ext))

    @contract(t=_T, y=_Y)
    def diagnostics(self, t: float, y: np.ndarray) -> dict[str, float]:
        ext = self.lengths(y) - self.rest
        return {f"V_{self.name}": float(0.5 * np.sum(self.ks * ext * ext)),
                f"{self.name}_max_strain": float(np.max(np.abs(ext) / np.where(self.rest > 0, self.rest, 1.0)))
                if self.S else 0.0}

    def _assemble(self, blocks: np.ndarray) -> sp.csr_matrix:
        data = np.concatenate([blocks, blocks, -blocks, -blocks]).ravel()
        return sp.csr_matrix((data, (self._jrows, self._jcols)), shape=(self._n, self._n))

    @contract(t=_T, y=_Y)
    def jacobian(self, t: float, y: np.ndarray):
        """∂Q/∂x and ∂Q/∂v as sparse (N·dim)² matrices (a :class:`pbanim.particles.ForceJacobian`)."""
        _, length, dhat, dv = self._geometry(y)
        dim = self.system.dim
        eye = np.eye(dim)
        ddT = dhat[:, :, None] * dhat[:, None, :]
        P = eye - ddT
        safe = np.where(length > 0, length, 1.0)
        ratio = np.where(length > 0, self.rest / safe, 0.0)
        K = -self.ks[:, None, None] * ((1.0 - ratio)[:, None, None] * P + ddT)
        dQdv = None
        if self._damped:
            ldot = np.einsum("ij,ij->i", dv, dhat)
            dvP = np.einsum("sj,sjk->sk", dv, P)                    # (v_a − v_b)ᵀ P
            K -= (self.kd / safe)[:, None, None] * (dhat[:, :, None] * dvP[:, None, :] + ldot[:, None, None] * P)
            dQdv = self._assemble(-self.kd[:, None, None] * ddT)
        return ForceJacobian(self._assemble(K), dQdv)
