"""Colliders for cloth particles: a sphere and the ground, as signed distances with their normals.

A collider answers, for every particle x_i, the signed distance φ(x_i) to its surface and the outward unit
normal n_i = ∇φ. A particle is in contact when φ(x_i) < thickness. The two cloth solvers use the same answer
in their own way:

* large steps (Baraff & Witkin 1998, §5.3): a particle in contact that approaches the surface (v·n < 0) is
  constrained along n by the filter S_i = I − n nᵀ, its velocity change along n prescribed by z_i = −(v·n) n
  (it stops approaching), and its position corrected by y_i = (thickness − φ) n (it is put back on the
  surface within the same step: Δx = h(v₀ + Δv) + y);
* XPBD (Macklin, Müller & Chentanez 2016): the inequality C_i(x) = φ(x_i) − thickness ≥ 0 is projected in
  every iteration, x_i += (thickness − φ) n when it is violated.

Friction is not modelled: the constrained particles slide freely along the surface (B&W's frictional
constraints, S_i = 0 while sticking, are left out of this lecture's reference).

=========  =======================  ===================================================
collider   φ(x)                      n(x)
=========  =======================  ===================================================
Sphere     |x − c| − r               (x − c)/|x − c|   (a particle at c: n = ẑ)
Ground     x_z − height              ẑ
=========  =======================  ===================================================

Reference: D. Baraff, A. Witkin, "Large steps in cloth simulation", SIGGRAPH 1998, §5.3 and §6 (collisions
as constraints on Δv, position alteration by y).
"""

from __future__ import annotations

import numpy as np

from ..contracts import Array, Real, contract, finite_result
from ..errors import check_result

__all__ = ["Sphere", "Ground"]

_POINTS = Array(("N", 3), empty=True)


class Sphere:
    """A fixed sphere of centre c and radius r (m).

    >>> s = Sphere([0.0, 0.0, 0.0], 0.5)
    >>> d, nrm = s.signed_distance(np.array([[0.0, 0.0, 1.0]]))
    >>> float(d[0]), nrm[0].tolist()
    (0.5, [0.0, 0.0, 1.0])
    """

    @contract(center=Array((3,), ge=-1e6, le=1e6), radius=Real(gt=0, le=1e6))
    def __init__(self, center, radius: float) -> None:
        self.center = np.asarray(center, dtype=float).copy()
        self.radius = float(radius)

    @contract(x=_POINTS, returns=finite_result)
    def signed_distance(self, x) -> tuple[np.ndarray, np.ndarray]:
        """φ (N,) and the outward normals n (N, 3) at the points x (N, 3)."""
        d = np.asarray(x, dtype=float) - self.center
        r = np.sqrt(np.einsum("ij,ij->i", d, d))
        with np.errstate(divide="ignore", invalid="ignore"):
            nrm = d / r[:, None]
        nrm[r == 0] = (0.0, 0.0, 1.0)
        return check_result("Sphere.signed_distance", r - self.radius, "a point is too far for |x − c|"), nrm

    def __repr__(self) -> str:
        return f"Sphere(center={self.center.tolist()}, radius={self.radius:g})"


class Ground:
    """The plane z = height (m), solid below.

    >>> float(Ground(-1.0).signed_distance(np.array([[3.0, 2.0, 0.5]]))[0][0])
    1.5
    """

    @contract(height=Real(ge=-1e6, le=1e6))
    def __init__(self, height: float = 0.0) -> None:
        self.height = float(height)

    @contract(x=_POINTS, returns=finite_result)
    def signed_distance(self, x) -> tuple[np.ndarray, np.ndarray]:
        """φ (N,) and the normals n = ẑ (N, 3) at the points x (N, 3)."""
        x = np.asarray(x, dtype=float)
        nrm = np.zeros_like(x)
        nrm[:, 2] = 1.0
        return x[:, 2] - self.height, nrm

    def __repr__(self) -> str:
        return f"Ground(height={self.height:g})"


def contacts(colliders, x, v, thickness):
    """The particles in contact with any collider, approaching or resting: (indices, normals, depths).

    For each particle the collider with the smallest φ decides; contact when φ < thickness and v·n ≤ 0.
    ``depths`` = thickness − φ ≥ 0 is the position correction along n.
    """
    if not colliders:
        return np.zeros(0, np.intp), np.zeros((0, 3)), np.zeros(0)
    best_d, best_n = None, None
    for c in colliders:
        d, nrm = c.signed_distance(x)
        if best_d is None:
            best_d, best_n = d, nrm
        else:
            closer = d < best_d
            best_d = np.where(closer, d, best_d)
            best_n = np.where(closer[:, None], nrm, best_n)
    approaching = np.einsum("ij,ij->i", v, best_n) <= 0.0
    idx = np.flatnonzero((best_d < thickness) & approaching)
    return idx, best_n[idx], thickness - best_d[idx]


def project(colliders, x, thickness) -> np.ndarray:
    """x with every particle inside a collider (φ < thickness) moved out along its normal (in place too)."""
    for c in colliders:
        d, nrm = c.signed_distance(x)
        inside = d < thickness
        if inside.any():
            x[inside] += (thickness - d[inside])[:, None] * nrm[inside]
    return x
