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

from dataclasses import dataclass
from typing import Any

import numpy as np
import scipy.sparse as sp

from ..scene import Effect
from ..errors import InvalidInput, as_floats

__all__ = ["DampedSprings", "AnchorSprings", "ForceJacobian", "spring_forces_loop"]


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


def spring_forces_loop(x: np.ndarray, v: np.ndarray, pairs: np.ndarray, ks: np.ndarray, kd: np.ndarray,
                       rest: np.ndarray) -> np.ndarray:
    """Readable reference: the force of every spring, one spring at a time (a Python loop).

    Returns Q of shape (N, dim). Use :class:`DampedSprings` in simulations; this is for reading and for
    checking the vectorized version.

    >>> x = np.array([[0.0, 0.0], [2.0, 0.0]]); v = np.zeros_like(x)
    >>> spring_forces_loop(x, v, np.array([[0, 1]]), np.array([10.0]), np.array([0.0]), np.array([1.0]))
    array([[ 10.,   0.],
           [-10.,   0.]])
    """
    Q = np.zeros_like(x, dtype=float)
    for s, (a, b) in enumerate(pairs):
        d = x[a] - x[b]
        length = np.sqrt(d @ d)
        if length == 0.0:
            continue
        dhat = d / length
        ldot = (v[a] - v[b]) @ dhat
        f = -(ks[s] * (length - rest[s]) + kd[s] * ldot) * dhat
        Q[a] += f
        Q[b] -= f
    return Q


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

    def __init__(self, pairs: Any, stiffness: Any = 1.0, damping: Any = 0.0, rest_length: Any = None,
                 name: str = "springs") -> None:
        p = np.asarray(pairs)
        if p.size == 0:
            p = p.reshape(0, 2)
        if p.ndim != 2 or p.shape[1] != 2:
            raise InvalidInput(f"pairs must have shape (S, 2), got {p.shape}")
        if p.dtype.kind not in "iu":
            if p.dtype.kind != "f" or not np.all(p == np.round(p)):
                raise InvalidInput(f"pairs must be integer particle indices, got dtype {p.dtype}")
        self.pairs = p.astype(np.intp)
        self.S = self.pairs.shape[0]
        self.stiffness_in, self.damping_in, self.rest_in, self.name = stiffness, damping, rest_length, name

    def bind(self, system: Any) -> None:
        N, dim, S = system.N, system.dim, self.S
        a, b = self.pairs[:, 0], self.pairs[:, 1]
        bad = (self.pairs < 0) | (self.pairs >= N)
        if bad.any():
            s = int(np.argwhere(bad)[0, 0])
            raise InvalidInput(f"pairs must index particles in [0, {N}), got {self.pairs[s].tolist()} "
                             f"at spring {s}")
        if np.any(a == b):
            s = int(np.flatnonzero(a == b)[0])
            raise InvalidInput(f"pairs must join two different particles, got {self.pairs[s].tolist()} at spring {s}")
        self.system, self.a, self.b = system, a, b
        self.ks = _per_spring(self.stiffness_in, S, "stiffness", "use a spring stiffness k_s >= 0")
        self.kd = _per_spring(self.damping_in, S, "damping", "use a spring damping k_d >= 0")
        if self.rest_in is None:
            d = system.x0[a] - system.x0[b]
            self.rest = np.sqrt(np.einsum("ij,ij->i", d, d))
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

    # -- geometry ----------------------------------------------------------------------------------
    def _geometry(self, y: np.ndarray):
        x, v = self.system.unpack(y)
        d = x[self.a] - x[self.b]
        length = np.sqrt(np.einsum("ij,ij->i", d, d))
        safe = np.where(length > 0, length, 1.0)
        dhat = d / safe[:, None]
        dhat[length == 0] = 0.0
        dv = v[self.a] - v[self.b]
        return d, length, dhat, dv

    def spring_forces(self, y: np.ndarray) -> np.ndarray:
        """f of every spring on its end a, shape (S, dim).

        Written as f = −c d with c = [k_s (l − r) + k_d (v_a − v_b)·d / l] / l, so d̂ is never formed:
        (S, dim) work is two gathers per end, two row dots and one scaling.
        """
        x, v = self.system.unpack(y)
        d = np.take(x, self.a, axis=0)
        d -= np.take(x, self.b, axis=0)
        length = np.sqrt(np.einsum("ij,ij->i", d, d))
        with np.errstate(divide="ignore", invalid="ignore"):
            inv = 1.0 / length
            c = self.ks * (length - self.rest)
            if self._damped:
                dv = np.take(v, self.a, axis=0)
                dv -= np.take(v, self.b, axis=0)
                c += self.kd * np.einsum("ij,ij->i", dv, d) * inv
            c *= inv
        if not np.all(np.isfinite(c)):
            c[length == 0] = 0.0       # a zero-length spring has no direction: no force
        d *= -c[:, None]
        return d

    def apply(self, t: float, y: np.ndarray, Q: np.ndarray) -> None:
        f = self.spring_forces(y).ravel()
        n = self._n
        dQ = np.bincount(self._ia, f, minlength=n)
        dQ -= np.bincount(self._ib, f, minlength=n)
        Q += dQ.reshape(Q.shape)

    def apply_add_at(self, t: float, y: np.ndarray, Q: np.ndarray) -> None:
        """Same as :meth:`apply`, scattering with ``np.add.at`` (kept for the benchmark's comparison)."""
        f = self.spring_forces(y)
        np.add.at(Q, self.a, f)
        np.add.at(Q, self.b, -f)

    def incidence(self) -> sp.csr_matrix:
        """Signed incidence matrix B (S × N): +1 at (s, a_s), −1 at (s, b_s); Q = Bᵀ f."""
        S = self.S
        return sp.csr_matrix((np.r_[np.ones(S), -np.ones(S)], (np.r_[np.arange(S), np.arange(S)],
                                                                np.r_[self.a, self.b])), shape=(S, self.system.N))

    # -- energy and Jacobians ----------------------------------------------------------------------
    def lengths(self, y: np.ndarray) -> np.ndarray:
        return self._geometry(y)[1]

    def potential_energy(self, y: np.ndarray) -> float:
        """V = ½ Σ k_s (l − r)²."""
        ext = self.lengths(y) - self.rest
        return float(0.5 * np.sum(self.ks * ext * ext))

    def diagnostics(self, t: float, y: np.ndarray) -> dict[str, float]:
        ext = self.lengths(y) - self.rest
        return {f"V_{self.name}": float(0.5 * np.sum(self.ks * ext * ext)),
                f"{self.name}_max_strain": float(np.max(np.abs(ext) / np.where(self.rest > 0, self.rest, 1.0)))
                if self.S else 0.0}

    def _assemble(self, blocks: np.ndarray) -> sp.csr_matrix:
        data = np.concatenate([blocks, blocks, -blocks, -blocks]).ravel()
        return sp.csr_matrix((data, (self._jrows, self._jcols)), shape=(self._n, self._n))

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


class AnchorSprings(Effect):
    """Zero-rest-length damped springs pinning particles to fixed world points (Witkin's "mouse spring").

    Qᵢ += −k_s (xᵢ − pᵢ) − k_d vᵢ for each anchored particle i; V = ½ Σ k_s |xᵢ − pᵢ|². Local (the force
    on i depends on i only) and linear, so its Jacobians are constant diagonals.

    Parameters
    ----------
    indices : array_like of int, shape (A,)
        Anchored particles (distinct, in [0, N)).
    points : array_like, shape (A, dim), optional
        Anchor points; default the particles' initial positions.
    stiffness, damping : float
        k_s > 0, k_d ≥ 0.

    Examples
    --------
    >>> from pbanim.particles import ParticleSystem
    >>> from pbanim.scene import Scene
    >>> ps = ParticleSystem([[1.0, 0.0], [5.0, 5.0]])
    >>> Scene(ps, [AnchorSprings([0], [[0.0, 0.0]], stiffness=3.0)]).forces(0.0, ps.state())
    array([[-3., -0.],
           [ 0.,  0.]])
    """

    phase = "force"

    def __init__(self, indices: Any, points: Any = None, stiffness: float = 1e3, damping: float = 0.0,
                 name: str = "anchors") -> None:
        self.idx = np.atleast_1d(np.asarray(indices)).astype(np.intp)
        self.points_in, self.name = points, name
        self.ks = float(stiffness)
        self.kd = float(damping)
        if not (np.isfinite(self.ks) and self.ks > 0):
            raise InvalidInput(f"stiffness must be positive and finite, got {stiffness}")
        if not (np.isfinite(self.kd) and self.kd >= 0):
            raise InvalidInput(f"damping must be finite and >= 0, got {damping}")

    def bind(self, system: Any) -> None:
        N, dim = system.N, system.dim
        if np.any((self.idx < 0) | (self.idx >= N)) or len(np.unique(self.idx)) != len(self.idx):
            raise InvalidInput(f"indices must be distinct particle indices in [0, {N}), got {self.idx.tolist()}")
        p = system.x0[self.idx] if self.points_in is None else np.asarray(self.points_in, float)
        if p.shape != (len(self.idx), dim):
            raise InvalidInput(f"points must have shape ({len(self.idx)}, {dim}), got {p.shape}")
        self.system, self.points = system, p.copy()
        n = N * dim
        diag = np.zeros((N, dim))
        diag[self.idx] = 1.0
        self._Kx = sp.diags(-self.ks * diag.ravel(), shape=(n, n), format="csr")
        self._Kv = sp.diags(-self.kd * diag.ravel(), shape=(n, n), format="csr") if self.kd > 0 else None

    def apply(self, t: float, y: np.ndarray, Q: np.ndarray) -> None:
        x, v = self.system.unpack(y)
        Q[self.idx] -= self.ks * (x[self.idx] - self.points) + self.kd * v[self.idx]

    def potential_energy(self, y: np.ndarray) -> float:
        x, _ = self.system.unpack(y)
        e = x[self.idx] - self.points
        return float(0.5 * self.ks * np.sum(e * e))

    def diagnostics(self, t: float, y: np.ndarray) -> dict[str, float]:
        return {f"V_{self.name}": self.potential_energy(y)}

    def jacobian(self, t: float, y: np.ndarray) -> ForceJacobian:
        return ForceJacobian(self._Kx, self._Kv)
