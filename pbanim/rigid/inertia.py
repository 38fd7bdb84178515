"""Mass properties of rigid bodies: inertia tensors of primitives and closed meshes (chapter 05).

The inertia tensor about the centre of mass c of a body of density ρ occupying the volume Ω is

    I = ∫_Ω ρ (|r|² E − r rᵀ) dV,   r = x − c,          i.e.  I = tr(C) E − C,  C = ∫ ρ r rᵀ dV.

**Closed triangle meshes (divergence theorem).** Cone every outward triangle (a, b, c) to the origin:
the signed tetrahedra (0, a, b, c) cover Ω with multiplicity +1 inside and cancel outside, because
∫_Ω div F dV = ∮ F·n dA for the fields F = x/3, x x/4 ... reduces every volume integral to a sum over
faces. For one tetrahedron of signed volume V = det[a b c]/6 (a linear map of the unit simplex),

    ∫ dV = V,   ∫ x dV = V (a + b + c)/4,   ∫ x xᵀ dV = V/20 (a aᵀ + b bᵀ + c cᵀ + s sᵀ),  s = a + b + c,

the last from ∫_simplex uᵢuⱼ = (1 + δᵢⱼ)/120 · 6V. Summing over faces gives m, c and C about the origin;
C_c = C − m c cᵀ shifts it to the centre of mass (the parallel-axis theorem in covariance form).

**Parallel axis.** About a point at offset d from the centre of mass: I_d = I_c + m(|d|² E − d dᵀ).

**Admissible tensors.** I is symmetric positive definite and its principal moments satisfy the
triangle inequalities I₁ + I₂ ≥ I₃ (equality for a flat lamina), because Iᵢ + Iⱼ − Iₖ = 2∫ρ rₖ² dV ≥ 0.

===============  =====================  ===========
symbol           code                   shape
===============  =====================  ===========
m                ``mass``               scalar
I, I_c           ``inertia``            (3, 3)
c                ``com``                (3,)
d                ``offset``             (3,)
(a, b, c) faces  ``vertices[faces]``    (F, 3, 3)
===============  =====================  ===========

Limiting cases: a cylinder with h → 0 is a disc (I_axis = 2 I_transverse, the lamina equality); a capsule
with h = 0 is a sphere; a fine icosphere tends to 2/5 m r².

References: B. Mirtich, "Fast and accurate computation of polyhedral mass properties", JGT 1996;
D. Eberly, "Polyhedral mass properties (revisited)", 2002; Baraff 1997 course notes §2.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..contracts import Array, Flag, Index, Indices, Int, Opt, Real, Text, contract
from ..errors import InvalidInput
from .admissible import Inertia, inertia_defect
from .domain import certify

__all__ = ["MassProperties", "box_inertia", "sphere_inertia", "cylinder_inertia", "capsule_inertia",
           "mesh_mass_properties", "parallel_axis", "validate_inertia", "principal_axes", "box_mesh",
           "icosphere_mesh"]

_POS = Real(gt=0)
_AXIS = Index(3)


def _representable(who: str, inertia: np.ndarray, args: str) -> np.ndarray:
    """Refuse an inertia whose moments overflowed to inf or underflowed to 0 (parameters far off scale)."""
    d = np.diagonal(inertia, axis1=-2, axis2=-1)
    if not (np.all(np.isfinite(inertia)) and np.all(d > 0)):
        raise InvalidInput(f"{who}({args}) has moments {d.tolist()} that are not finite and > 0 (the parameters "
                           "overflow or underflow double precision); use units that keep them moderate")
    return inertia


@contract(mass=_POS, extents=Array((3,), gt=0))
def box_inertia(mass: float, extents) -> np.ndarray:
    """Inertia about the centre of a solid box with full side lengths ``extents`` = (a, b, c).

    I = m/12 · diag(b² + c², a² + c², a² + b²).

    >>> box_inertia(12.0, [1.0, 2.0, 3.0])
    array([[13.,  0.,  0.],
           [ 0., 10.,  0.],
           [ 0.,  0.,  5.]])
    """
    m, e = float(mass), np.asarray(extents, dtype=float)
    with np.errstate(over="ignore", under="ignore", invalid="ignore"):
        a2, b2, c2 = e * e
        I = m / 12.0 * np.diag([b2 + c2, a2 + c2, a2 + b2])
    return _representable("box_inertia", I, f"{mass}, {extents}")


@contract(mass=_POS, radius=_POS, hollow=Flag())
def sphere_inertia(mass: float, radius: float, hollow: bool = False) -> np.ndarray:
    """Solid sphere 2/5 m r² E (thin hollow shell: 2/3 m r² E).

    >>> float(sphere_inertia(5.0, 1.0)[0, 0])
    2.0
    """
    m, r = np.float64(mass), np.float64(radius)
    with np.errstate(over="ignore", under="ignore", invalid="ignore"):
        I = (2.0 / 3.0 if hollow else 0.4) * m * r * r * np.eye(3)
    return _representable("sphere_inertia", I, f"{mass}, {radius}")


def _axis_diag(axial: float, transverse: float, axis: int) -> np.ndarray:
    d = np.full(3, transverse)
    d[axis] = axial
    return np.diag(d)


@contract(mass=_POS, radius=_POS, height=_POS, axis=_AXIS)
def cylinder_inertia(mass: float, radius: float, height: float, axis: int = 2) -> np.ndarray:
    """Solid cylinder about its centre: axial ½ m r², transverse m(3r² + h²)/12.

    >>> np.diag(cylinder_inertia(12.0, 1.0, 2.0))
    array([7., 7., 6.])
    """
    m, r, h = np.float64(mass), np.float64(radius), np.float64(height)
    with np.errstate(over="ignore", under="ignore", invalid="ignore"):
        I = _axis_diag(0.5 * m * r * r, m * (3 * r * r + h * h) / 12.0, axis)
    return _representable("cylinder_inertia", I, f"{mass}, {radius}, {height}")


@contract(mass=_POS, radius=_POS, height=Real(ge=0), axis=_AXIS)
def capsule_inertia(mass: float, radius: float, height: float, axis: int = 2) -> np.ndarray:
    """Solid capsule (cylinder of length ``height`` capped by two hemispheres of ``radius``), uniform density.

    With m_c = m·πr²h/V and m_s = m·(4/3)πr³/V (V the total volume): axial m_c r²/2 + 2/5 m_s r²;
    transverse m_c(3r² + h²)/12 + m_s(2r²/5 + h²/4 + 3hr/8) (each hemisphere's centroid sits 3r/8 from its
    flat face). ``height = 0`` gives a sphere.

    >>> np.allclose(capsule_inertia(2.0, 0.5, 0.0), sphere_inertia(2.0, 0.5))
    True
    """
    m, r, h = np.float64(mass), np.float64(radius), np.float64(height)
    with np.errstate(over="ignore", under="ignore", invalid="ignore", divide="ignore"):
        # volume fractions from the ratio h/r (no r³ that overflows or underflows on its own)
        fc = np.pi * h / (np.pi * h + 4.0 / 3.0 * np.pi * r) if h > 0 else np.float64(0.0)
        mc, ms = m * fc, m * (1.0 - fc)
        axial = 0.5 * mc * r * r + 0.4 * ms * r * r
        trans = mc * (3 * r * r + h * h) / 12.0 + ms * (0.4 * r * r + h * h / 4.0 + 3.0 * h * r / 8.0)
        I = _axis_diag(axial, trans, axis)
    return _representable("capsule_inertia", I, f"{mass}, {radius}, {height}")


@contract(mass=_POS, com=Array((3,)), inertia=Inertia(), volume=_POS)
@dataclass(frozen=True)
class MassProperties:
    """Mass, centre of mass and inertia about the centre of mass of a solid."""

    mass: float
    com: np.ndarray
    inertia: np.ndarray
    volume: float


def _check_closed(faces: np.ndarray, n_vertices: int) -> None:
    """Every directed edge must occur once and its reverse once (closed, consistently oriented)."""
    e = np.concatenate([faces[:, [0, 1]], faces[:, [1, 2]], faces[:, [2, 0]]])
    key = e[:, 0].astype(np.int64) * n_vertices + e[:, 1]
    rkey = e[:, 1].astype(np.int64) * n_vertices + e[:, 0]
    uniq, counts = np.unique(key, return_counts=True)
    if np.any(counts > 1):
        raise InvalidInput("faces must be consistently oriented: a directed edge appears "
                         f"{int(counts.max())} times; flip the offending faces")
    missing = ~np.isin(rkey, uniq)
    if np.any(missing):
        i = int(np.flatnonzero(missing)[0])
        raise InvalidInput(f"mesh must be closed: edge {tuple(int(v) for v in e[i])} has no opposite edge; "
                         "close the holes (mass properties need a watertight surface)")


@contract(vertices=Array((None, 3)), faces=Indices(lambda env: len(env.values["vertices"]), (None, 3)),
          density=_POS, mass=Opt(_POS))
def mesh_mass_properties(vertices, faces, density: float = 1.0, mass: float | None = None) -> MassProperties:
    """Mass properties of the solid bounded by a closed, outward-oriented triangle mesh.

    Parameters
    ----------
    vertices : array (V, 3)
    faces : int array (F, 3), counter-clockwise seen from outside
    density : float
        Used unless ``mass`` is given (then density = mass / volume).

    The result certifies itself: a mesh that passes the closedness and volume checks but bounds no solid
    (an inverted part away from the rest) gives an inertia no body has, refused by name.

    Examples
    --------
    >>> v, f = box_mesh([1.0, 2.0, 3.0])
    >>> mp = mesh_mass_properties(v + 5.0, f, mass=12.0)
    >>> mp.volume, mp.com
    (6.0, array([5., 5., 5.]))
    >>> np.allclose(mp.inertia, box_inertia(12.0, [1.0, 2.0, 3.0]))
    True
    """
    V = np.asarray(vertices, dtype=float)
    F = np.asarray(faces)
    _check_closed(F, len(V))
    a, b, c = V[F[:, 0]], V[F[:, 1]], V[F[:, 2]]
    vol = np.einsum("ij,ij->i", a, np.cross(b, c)) / 6.0          # signed tetra volumes (F,)
    volume = float(vol.sum())
    if volume <= 0:
        raise InvalidInput(f"mesh volume must be positive, got {volume:.6g}; orient faces outward "
                         "(counter-clockwise seen from outside)")
    s = a + b + c
    first = (vol[:, None] * s).sum(axis=0) / 4.0
    second = np.einsum("f,fi,fj->ij", vol, a, a) + np.einsum("f,fi,fj->ij", vol, b, b) \
        + np.einsum("f,fi,fj->ij", vol, c, c) + np.einsum("f,fi,fj->ij", vol, s, s)
    second /= 20.0
    rho = float(mass) / volume if mass is not None else float(density)
    m = rho * volume
    com = first / volume
    C = rho * second - m * np.outer(com, com)
    C = 0.5 * (C + C.T)
    inertia = np.trace(C) * np.eye(3) - C
    certify("mesh_mass_properties: m, c and I", np.concatenate([[m], com, inertia.ravel()]), V,
            detail=f"volume {volume:.3g}, mass {m:.3g}")
    found = inertia_defect(inertia[None], definite=False)   # the certificate: a solid has an admissible I
    if found is not None:
        raise InvalidInput(f"mesh_mass_properties: faces must bound a solid (closed, outward, not inverted or "
                           f"self-intersecting anywhere), got a mesh whose inertia no body has: {found[1]}; look "
                           "for an inverted or overlapping part")
    return MassProperties(mass=float(m), com=com, inertia=inertia, volume=volume)


@contract(inertia=Inertia(batch=True, definite=False), mass=Array((None,), ge=0, scalar=True),
          offset=Array((3,), batch="first"))
def parallel_axis(inertia, mass: float, offset) -> np.ndarray:
    """Inertia about a point at ``offset`` d from the centre of mass: I_c + m(|d|² E − d dᵀ).

    Broadcasts over leading axes of ``inertia`` (..., 3, 3), ``mass`` (...) and ``offset`` (..., 3).

    >>> parallel_axis(np.zeros((3, 3)), 2.0, [0.0, 0.0, 3.0])   # a point mass 3 from the axis
    array([[18.,  0.,  0.],
           [ 0., 18.,  0.],
           [ 0.,  0.,  0.]])
    """
    I = np.asarray(inertia, dtype=float)
    m = np.asarray(mass, dtype=float)
    d = np.asarray(offset, dtype=float)
    with np.errstate(over="ignore", invalid="ignore"):
        try:
            dd = np.sum(d * d, axis=-1)[..., None, None]
            out = I + m[..., None, None] * (dd * np.eye(3) - d[..., :, None] * d[..., None, :])
        except ValueError:
            raise InvalidInput(f"inertia {I.shape}, mass {m.shape} and offset {d.shape} do not broadcast "
                               "together") from None
    return certify("parallel_axis: I_c + m(|d|² E − d dᵀ)", out, I, m, d, detail=f"mass {mass}, offset {offset}")


@contract(inertia=Inertia(batch=True, definite=False))
def principal_axes(inertia) -> tuple[np.ndarray, np.ndarray]:
    """Principal moments (ascending) and axes: I = A diag(moments) Aᵀ, A a proper rotation (det +1).

    >>> moments, A = principal_axes(np.diag([3.0, 1.0, 2.0]))
    >>> moments
    array([1., 2., 3.])
    """
    I = np.asarray(inertia, dtype=float)
    with np.errstate(over="ignore", invalid="ignore"):
        w, A = np.linalg.eigh(0.5 * I + 0.5 * np.swapaxes(I, -1, -2))
    certify("principal_axes: the eigen-decomposition of inertia", w, I, detail=f"max |I| = {np.abs(I).max():.3g}")
    certify("principal_axes: the eigen-decomposition of inertia", A, I)
    A = A * np.where(np.linalg.det(A) < 0, -1.0, 1.0)[..., None, None]
    return w, A


@contract(inertia=Array((3, 3), batch="first"), name=Text(nonempty=True))
def validate_inertia(inertia, name: str = "inertia") -> np.ndarray:
    """Check that inertia tensor(s) (..., 3, 3) are symmetric positive definite and satisfy the triangle
    inequality I₁ + I₂ ≥ I₃ of their principal moments; return them as float arrays.

    Raises
    ------
    ValueError
        Naming the offending tensor, its values and the fix.

    >>> validate_inertia(np.diag([1.0, 1.0, 3.0]))
    Traceback (most recent call last):
    ...
    pbanim.errors.InvalidInput: inertia must be an inertia a body can have (symmetric, positive definite, I1 + I2 >= I3), got [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 3.0]]; principal moments [1. 1. 3.] violate the triangle inequality I1 + I2 >= I3 (1 + 1 < 3); no mass distribution has these moments — check the axes or units
    """
    I = np.asarray(inertia, dtype=float)
    if I.shape[-2:] != (3, 3):
        raise InvalidInput(f"{name} must have shape (3, 3) or (N, 3, 3), got {I.shape}")
    flat = I.reshape(-1, 3, 3)
    label = lambda k: name if flat.shape[0] == 1 else f"{name}[{k}]"  # noqa: E731
    finite = np.all(np.isfinite(flat), axis=(1, 2))
    if not finite.all():
        k = int(np.flatnonzero(~finite)[0])
        raise InvalidInput(f"{label(k)} must be finite, got {flat[k].tolist()}")
    found = inertia_defect(flat)
    if found is not None:
        k, detail = found
        raise InvalidInput(f"{label(k)} must be an inertia a body can have (symmetric, positive definite, "
                           f"I1 + I2 >= I3), got {flat[k].tolist()}; {detail}")
    return I


@contract(extents=Array((3,), gt=0))
def box_mesh(extents) -> tuple[np.ndarray, np.ndarray]:
    """Vertices (8, 3) and outward faces (12, 3) of a box centred at the origin.

    >>> v, f = box_mesh([2.0, 2.0, 2.0]); v.shape, f.shape
    ((8, 3), (12, 3))
    """
    e = 0.5 * np.asarray(extents, dtype=float)
    v = np.array([[sx, sy, sz] for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)], dtype=float) * e
    # quads (outward, counter-clockwise from outside) on the faces x=-, x=+, y=-, y=+, z=-, z=+
    quads = [(0, 1, 3, 2), (4, 6, 7, 5), (0, 4, 5, 1), (2, 3, 7, 6), (0, 2, 6, 4), (1, 5, 7, 3)]
    f = np.array([t for a, b, c, d in quads for t in ((a, b, c), (a, c, d))])
    return v, f


@contract(radius=_POS, subdivisions=Int(ge=0, le=7))
def icosphere_mesh(radius: float = 1.0, subdivisions: int = 2) -> tuple[np.ndarray, np.ndarray]:
    """A closed icosphere (vertices on the sphere of ``radius``), 20·4ˢ outward faces.

    >>> v, f = icosphere_mesh(1.0, 1); len(f)
    80
    """
    t = (1 + np.sqrt(5)) / 2
    v = np.array([[-1, t, 0], [1, t, 0], [-1, -t, 0], [1, -t, 0], [0, -1, t], [0, 1, t], [0, -1, -t],
                  [0, 1, -t], [t, 0, -1], [t, 0, 1], [-t, 0, -1], [-t, 0, 1]], dtype=float)
    f = np.array([[0, 11, 5], [0, 5, 1], [0, 1, 7], [0, 7, 10], [0, 10, 11], [1, 5, 9], [5, 11, 4],
                  [11, 10, 2], [10, 7, 6], [7, 1, 8], [3, 9, 4], [3, 4, 2], [3, 2, 6], [3, 6, 8],
                  [3, 8, 9], [4, 9, 5], [2, 4, 11], [6, 2, 10], [8, 6, 7], [9, 8, 1]])
    verts = list(v / np.linalg.norm(v, axis=1, keepdims=True))
    for _ in range(int(subdivisions)):
        cache: dict = {}

        def mid(i, j):
            key = (min(i, j), max(i, j))
            if key not in cache:
                p = verts[i] + verts[j]
                verts.append(p / np.linalg.norm(p))
                cache[key] = len(verts) - 1
            return cache[key]

        new = []
        for a, b, c in f:
            ab, bc, ca = mid(a, b), mid(b, c), mid(c, a)
            new += [[a, ab, ca], [b, bc, ab], [c, ca, bc], [ab, bc, ca]]
        f = np.array(new)
    return float(radius) * np.array(verts), f
