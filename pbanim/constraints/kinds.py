"""Constraint kinds for particles: C(q), J = ∂C/∂q and J̇q̇, each kind vectorized (chapter 03).

Every kind holds *many* constraints of one type (a whole chain, a whole cloth) and evaluates all of them
with array operations, never a Python loop per constraint. A kind describes its rows by *slots*: row r
touches particles ``slots[r, 0..k-1]`` (``-1`` = a fixed point of the world, which has W = 0), and its
Jacobian row is made of one ``dim``-vector per slot, ``G[s, r] = ∂C_r/∂x_{slots[r, s]}`` (slot-major, so
each slot's blocks are one contiguous (m, dim) array). From these blocks
:mod:`pbanim.constraints.assembly` builds J (scipy.sparse) and JWJᵀ with a sparsity pattern computed once.

=================  ==========================  ===================================  =====================
kind               C (one row)                 J blocks                              J̇q̇
=================  ==========================  ===================================  =====================
Distance (rod)     ½(|x_b − x_a|² − L²)        −d at a, +d at b (d = x_b − x_a)      |v_b − v_a|²
FixedPoint (nail)  x_{p,i} − p̄_i  (dim rows)   e_i at p                              0
OnCircle (bead)    ½(|x − c|² − R²)            (x − c)ᵀ                              |v|²
OnLine / OnPlane   n·(x − p̄)                   nᵀ                                    0
LinearCombination  Σ_j c_j x_{p_j, i_j} − d    c_j e_{i_j} at p_j                    0
Angle2D            ∠(x_a − x_b, x_c − x_b) − θ̄  ∓u⊥/|u|², w⊥/|w|² (2-D)                see :class:`Angle2D`
UserConstraint     C(x)                        your J(x)                             your J̇q̇(x, v)
=================  ==========================  ===================================  =====================

The quadratic forms (Witkin's) make J̇q̇ a sum of squares; their multiplier has units of force per length:
the rod tension is T = −λ L (negative λ pulls the ends together), the bead's normal force is −λ R.
"""

from __future__ import annotations

import numpy as np

from .base import DIM, N_PARTICLES, X, X0, Constraint, _as_index, _per_row, _square_finite
from .rows import _dot, _gather, _span, _take
from ..contracts import Array, Int, Opt, contract
from ..errors import InvalidInput, NonFiniteResult
from ..particles.specs import Direction, IndexArray, point, points
from ..particles.springs import row_norms

__all__ = ["Constraint", "Distance", "FixedPoint", "OnCircle", "OnLine", "OnPlane", "LinearCombination",
           "Angle2D"]


class Distance(Constraint):
    """Rods: C = ½(|x_b − x_a|² − L²) for each pair (a, b); b = −1 ties a to the fixed point ``anchors[r]``.

    Parameters
    ----------
    pairs : array_like of int, shape (m, 2)
        Particle indices (a, b); b (or a) may be −1 for a rod to a fixed world point.
    lengths : array_like, shape (m,) or scalar, optional
        Rest lengths L > 0 (default: the distances in the initial configuration, set at bind).
    anchors : array_like, shape (m, dim) or (dim,), optional
        World points for the −1 ends (rows without a −1 ignore it).

    Examples
    --------
    >>> import numpy as np
    >>> rod = Distance([[0, 1]], lengths=1.0)
    >>> x = np.array([[0.0, 0.0], [0.0, -2.0]]); v = np.array([[0.0, 0.0], [1.0, 0.0]])
    >>> rod.bind(2, 2); rod.value(x), rod.jdot_qdot(x, v)
    (array([1.5]), array([1.]))
    >>> rod.jacobian(x).toarray()
    array([[ 0.,  2.,  0., -2.]])
    """

    kind = "distance"
    opposite = True

    @contract(pairs=IndexArray(("m", 2), world=True, distinct="rows", empty=True),
              lengths=Opt(Array(("m",), gt=0, scalar=True, empty=True)), anchors=Opt(points("m")))
    def __init__(self, pairs, lengths=None, anchors=None) -> None:
        self.slots = _as_index(pairs, "pairs", 2)
        self.lengths_in = None if lengths is None else _per_row(lengths, (self.m,), "lengths")
        self.anchors_in = anchors

    @contract(N=N_PARTICLES, dim=DIM, x0=X0)
    def bind(self, N, dim, x0=None) -> None:
        super().bind(N, dim)
        anchors = np.zeros(dim) if self.anchors_in is None else self.anchors_in
        self.anchors = _per_row(anchors, (self.m, dim), "anchors")
        if self.anchors_in is None and np.any(self.slots < 0):
            raise InvalidInput("anchors must be given for rods to a fixed point (pairs containing -1)")
        if self.lengths_in is None:
            if x0 is None:
                raise InvalidInput("lengths must be given when no initial positions are known")
            a = _gather(x0, self.slots[:, 0], self.anchors)
            b = _gather(x0, self.slots[:, 1], self.anchors)
            self.lengths = row_norms(b - a)
            if np.any(self.lengths <= 0):
                raise InvalidInput(f"length must be positive, got {self.lengths.min()} (coincident particles)")
        else:
            self.lengths = self.lengths_in
        self._L2 = _square_finite(self.lengths, "lengths", "rods given or measured in x0")
        # rows with a fixed end: d is computed with index 0 in its place, then those (few) rows are redone
        fixed = self.slots < 0
        self._frows = np.flatnonzero(fixed.any(axis=1))
        self._fp = np.where(fixed[self._frows, 0], self.slots[self._frows, 1], self.slots[self._frows, 0])
        self._fsign = np.where(fixed[self._frows, 0], 1.0, -1.0)[:, None]  # d = ±(x_p − anchor)
        self._fanchor = self.anchors[self._frows]
        clip = np.maximum(self.slots, 0)
        self._ia, self._ib = clip[:, 0].copy(), clip[:, 1].copy()
        # a chain numbered along itself: the rows between particles are one block of rows whose ends are
        # consecutive particles, so d = x_b − x_a is a difference of two slices (no gathers)
        free = np.flatnonzero(~fixed.any(axis=1))
        self._spans = None
        if len(free) and free[-1] - free[0] + 1 == len(free):
            sa, sb = _span(self.slots[free, 0]), _span(self.slots[free, 1])
            if sa is not None and sb is not None:
                self._spans = (slice(int(free[0]), int(free[-1]) + 1), sa, sb)

    @contract(x=X, v=X)
    def evaluate(self, x, v):
        G = np.empty((2, self.m, x.shape[1]))
        d, w = G[1], np.empty((self.m, x.shape[1]))  # G = (−d, d): d is written in place
        if self._spans is not None:  # the other rows have a fixed end, filled below
            rows, sa, sb = self._spans
            np.subtract(x[sb], x[sa], out=d[rows])
            np.subtract(v[sb], v[sa], out=w[rows])
        elif len(self._frows) < len(d):      # every row with a fixed end (a pendulum) is written below alone
            np.subtract(_take(x, self._ib), _take(x, self._ia), out=d)
            np.subtract(_take(v, self._ib), _take(v, self._ia), out=w)
        if len(self._frows):
            d[self._frows] = self._fsign * (x[self._fp] - self._fanchor)
            w[self._frows] = self._fsign * v[self._fp]
        C = 0.5 * (_dot(d, d) - self._L2)
        np.negative(d, out=G[0])
        return C, G, _dot(w, w)

    @contract(x=X, lam=Array(("self.m",), empty=True))
    def tension(self, x: np.ndarray, lam: np.ndarray) -> np.ndarray:
        """Rod tensions T = −λ|x_b − x_a| (positive when the rod pulls its ends together)."""
        d = _gather(x, self.slots[:, 1], self.anchors) - _gather(x, self.slots[:, 0], self.anchors)
        with np.errstate(over="ignore"):
            return -np.asarray(lam) * row_norms(d)


class FixedPoint(Constraint):
    """Nails: x_p = p̄ for each listed particle (dim rows per particle, C = x_{p,i} − p̄_i).

    >>> import numpy as np
    >>> nail = FixedPoint([1], points=[[0.0, 1.0]]); nail.bind(2, 2)
    >>> nail.value(np.array([[5.0, 5.0], [0.5, 1.0]]))
    array([0.5, 0. ])
    """

    kind = "fixed_point"

    @contract(particles=IndexArray(("P",), empty=True), points=Opt(points("P")))
    def __init__(self, particles, points=None) -> None:
        self.particles = _as_index(particles, "particles")
        self.points_in = points

    @contract(N=N_PARTICLES, dim=DIM, x0=X0)
    def bind(self, N, dim, x0=None) -> None:
        self.slots = np.repeat(self.particles, dim)[:, None]
        super().bind(N, dim)
        if self.points_in is None:
            if x0 is None:
                raise InvalidInput("points must be given when no initial positions are known")
            pts = x0[self.particles]
        else:
            pts = _per_row(self.points_in, (len(self.particles), dim), "points")
        self.points = np.array(pts, float).ravel()
        self._axis = np.tile(np.arange(dim), len(self.particles))
        self._G = np.eye(dim)[self._axis][None]

    @contract(x=X, v=X)
    def evaluate(self, x, v):
        C = x[self.particles].ravel() - self.points
        return C, self._G, np.zeros(self.m)


class OnCircle(Constraint):
    """Beads on circles (spheres in 3-D): C = ½(|x − c|² − R²), J = (x − c)ᵀ, J̇q̇ = |v|² (ORACLES B1).

    >>> import numpy as np
    >>> bead = OnCircle([0], center=[0.0, 0.0], radius=1.0); bead.bind(1, 2)
    >>> bead.jdot_qdot(np.array([[0.0, -1.0]]), np.array([[2.0, 0.0]]))
    array([4.])
    """

    kind = "on_circle"

    @contract(particles=IndexArray(("m",), empty=True), center=points("m"),
              radius=Array(("m",), gt=0, scalar=True, empty=True))
    def __init__(self, particles, center, radius) -> None:
        self.slots = _as_index(particles, "particles")[:, None]
        self.radius = _per_row(radius, (self.m,), "radius")
        self._R2 = _square_finite(self.radius, "radius", "C = ½(|x − c|² − R²)")
        self.center_in = np.asarray(center, float)

    @contract(N=N_PARTICLES, dim=DIM, x0=X0)
    def bind(self, N, dim, x0=None) -> None:
        super().bind(N, dim)
        self.center = _per_row(self.center_in, (self.m, dim), "center")
        self._p = self.slots[:, 0]

    @contract(x=X, v=X)
    def evaluate(self, x, v):
        r = _take(x, self._p) - self.center
        vv = _take(v, self._p)
        C = 0.5 * (_dot(r, r) - self._R2)
        return C, r[None], _dot(vv, vv)


class _Affine(Constraint):
    """Rows n·x_p − d = 0 with constant normals (OnLine, OnPlane): J constant, J̇q̇ = 0."""

    def _set(self, particles, normals, offsets) -> None:
        self.slots = particles[:, None]
        self._n = normals
        self._d = offsets

    @contract(x=X, v=X)
    def evaluate(self, x, v):
        C = _dot(_take(x, self.slots[:, 0]), self._n) - self._d
        return C, self._n[None], np.zeros(self.m)


def _unit(a, name: str) -> np.ndarray:
    """a/|a|, scaled first by the largest |entry| (no overflow of |a|² for a finite a)."""
    a = np.asarray(a, float)
    big = np.abs(a).max(initial=0.0) if a.ndim == 1 else 0.0
    if not (np.isfinite(big) and big > 0):
        raise InvalidInput(f"{name} must be a non-zero finite vector, got {a.tolist()}")
    a = a / big
    return a / np.linalg.norm(a)


def _same_dims(where: str, point, name: str, other) -> None:
    """``point`` and the direction ``other`` in one space (each is a 2- or 3-vector by its contract)."""
    if np.shape(point) != np.shape(other):
        raise InvalidInput(f"{where}: point and {name} must have one length (2 or 3), got {np.shape(point)} and "
                           f"{np.shape(other)}")


class OnPlane(_Affine):
    """Particles on a plane (a line in 2-D): n·(x − p̄) = 0, one row per particle.

    >>> import numpy as np
    >>> c = OnPlane([0], point=[0.0, 1.0], normal=[0.0, 2.0]); c.bind(1, 2)
    >>> c.value(np.array([[3.0, 1.5]]))
    array([0.5])
    """

    kind = "on_plane"

    @contract(particles=IndexArray(("m",), empty=True), point=point(), normal=Direction())
    def __init__(self, particles, point, normal) -> None:
        _same_dims("OnPlane", point, "normal", normal)
        self.particles = _as_index(particles, "particles")
        self.point, self.normal = np.asarray(point, float), _unit(normal, "normal")
        self.slots = self.particles[:, None]

    @contract(N=N_PARTICLES, dim=DIM, x0=X0)
    def bind(self, N, dim, x0=None) -> None:
        if self.normal.shape != (dim,) or self.point.shape != (dim,):
            raise InvalidInput(f"point and normal must have shape ({dim},), got {self.point.shape}, {self.normal.shape}")
        _per_row(self.point, (dim,), "point")
        p = self.particles
        self._set(p, np.tile(self.normal, (len(p), 1)), np.full(len(p), self.normal @ self.point))
        super().bind(N, dim)


class OnLine(_Affine):
    """Beads on a straight wire through p̄ along a: n_k·(x − p̄) = 0 for the dim − 1 normals n_k ⟂ a."""

    kind = "on_line"

    @contract(particles=IndexArray(("m",), empty=True), point=point(), direction=Direction())
    def __init__(self, particles, point, direction) -> None:
        _same_dims("OnLine", point, "direction", direction)
        self.particles = _as_index(particles, "particles")
        self.point, self.direction = np.asarray(point, float), _unit(direction, "direction")
        self.slots = np.repeat(self.particles, len(self.direction) - 1)[:, None]

    @contract(N=N_PARTICLES, dim=DIM, x0=X0)
    def bind(self, N, dim, x0=None) -> None:
        if self.direction.shape != (dim,) or self.point.shape != (dim,):
            raise InvalidInput(f"point and direction must have shape ({dim},), got {self.point.shape}, "
                             f"{self.direction.shape}")
        _per_row(self.point, (dim,), "point")
        # orthonormal complement of the direction: the last dim−1 columns of a full QR
        Qm, _ = np.linalg.qr(self.direction[:, None], mode="complete")
        normals = Qm[:, 1:].T
        p = self.particles
        self._set(np.repeat(p, dim - 1), np.tile(normals, (len(p), 1)), np.tile(normals @ self.point, len(p)))
        super().bind(N, dim)


class LinearCombination(Constraint):
    """Rows Σ_j c_rj x[p_rj, i_rj] − d_r = 0 on particle coordinates (k terms per row).

    ``particles``, ``axes``, ``coefficients`` have shape (m, k); ``offsets`` shape (m,).
    ORACLES B4 uses it for x = 0, y = 0, x + y = 0 on one particle.
    """

    kind = "linear"

    @contract(particles=IndexArray(("m", "k")), axes=IndexArray(("m", "k"), size=3, what="axes"),
              coefficients=Array(("m", "k")), offsets=Array(("m",), scalar=True))
    def __init__(self, particles, axes, coefficients, offsets=0.0) -> None:
        self.slots = np.array(particles, dtype=np.int64, ndmin=2)
        self.axes = np.array(axes, dtype=np.int64, ndmin=2)
        self.coef = np.array(coefficients, dtype=float, ndmin=2)
        if not (self.slots.shape == self.axes.shape == self.coef.shape):
            raise InvalidInput(f"particles, axes and coefficients must have one shape (m, k), got "
                             f"{self.slots.shape}, {self.axes.shape}, {self.coef.shape}")
        self.offsets = _per_row(offsets, (self.m,), "offsets")

    @contract(N=N_PARTICLES, dim=DIM, x0=X0)
    def bind(self, N, dim, x0=None) -> None:
        super().bind(N, dim)
        if np.any((self.axes < 0) | (self.axes >= dim)):
            raise InvalidInput(f"axes must be in [0, {dim - 1}], got {self.axes[(self.axes < 0) | (self.axes >= dim)][0]}")
        self._G = np.ascontiguousarray((self.coef[:, :, None] * np.eye(dim)[self.axes]).transpose(1, 0, 2))

    @contract(x=X, v=X)
    def evaluate(self, x, v):
        C = np.sum(self.coef * x[self.slots, self.axes], axis=1) - self.offsets
        return C, self._G, np.zeros(self.m)


def _perp(u: np.ndarray) -> np.ndarray:
    return np.stack([-u[:, 1], u[:, 0]], axis=1)


class Angle2D(Constraint):
    """Bending angles in 2-D: C = θ(u, w) − θ̄ with u = x_a − x_b, w = x_c − x_b, θ the signed angle u → w.

    J blocks: ∂θ/∂x_a = −u⊥/|u|², ∂θ/∂x_c = w⊥/|w|², ∂θ/∂x_b = −(both); u⊥ = (−u_y, u_x).
    J̇q̇ = 2(u⊥·u̇)(u·u̇)/|u|⁴ − 2(w⊥·ẇ)(w·ẇ)/|w|⁴.  C is wrapped to (−π, π].
    """

    kind = "angle"

    @contract(triples=IndexArray(("m", 3), distinct="rows", empty=True), angles=Array(("m",), scalar=True, empty=True))
    def __init__(self, triples, angles) -> None:
        self.slots = _as_index(triples, "triples", 3)
        self.angles = _per_row(angles, (self.m,), "angles")

    @contract(N=N_PARTICLES, dim=Int(ge=2, le=2), x0=X0)
    def bind(self, N, dim, x0=None) -> None:
        if dim != 2:    # a 3-D system binds its kinds from inside pbanim: the contract did not see it
            raise InvalidInput(f"Angle2D needs a 2-D system, got dim = {dim}")
        super().bind(N, dim)

    @contract(x=X, v=X)
    def evaluate(self, x, v):
        a, b, c = self.slots.T
        u, w = x[a] - x[b], x[c] - x[b]
        du, dw = v[a] - v[b], v[c] - v[b]
        uu, ww = np.einsum("ij,ij->i", u, u), np.einsum("ij,ij->i", w, w)
        if not (uu.all() and ww.all()) or np.isinf(uu).any() or np.isinf(ww).any():
            self._undefined(x, uu, ww)
        th = np.arctan2(u[:, 0] * w[:, 1] - u[:, 1] * w[:, 0], np.einsum("ij,ij->i", u, w))
        C = np.angle(np.exp(1j * (th - self.angles)))
        ga, gc = -_perp(u) / uu[:, None], _perp(w) / ww[:, None]
        G = np.stack([ga, -ga - gc, gc])
        up, wp = _perp(u), _perp(w)
        jd = (2 * np.einsum("ij,ij->i", up, du) * np.einsum("ij,ij->i", u, du) / uu ** 2
              - 2 * np.einsum("ij,ij->i", wp, dw) * np.einsum("ij,ij->i", w, dw) / ww ** 2)
        return C, G, jd

    def _undefined(self, x, uu, ww):
        """The angle at row r has no direction (an arm of length 0) or its arms overflow: a named error."""
        zero = np.flatnonzero((uu == 0) | (ww == 0))
        if zero.size:
            r = int(zero[0])
            raise InvalidInput(f"Angle2D.evaluate: x puts two particles of the angle {self.slots[r].tolist()} (row "
                               f"{r}) at one point: the angle, and J, are undefined there")
        raise NonFiniteResult("Angle2D's |u|² and |w|²", "the arms of an angle are longer than 1e154")
