"""Baraff–Witkin conditions: every cloth force from one vector C(x) per element (lecture 12, §2).

Baraff & Witkin write each internal force of the cloth as a *condition* C(x) ∈ Rᵐ on a few particles that is
zero at rest, with the energy E = ½ k CᵀC and the (Rayleigh) damping force along ∂C/∂x:

    f_i = −k (∂C/∂x_i) C − k_d (∂C/∂x_i) Ċ,        Ċ = Σ_j (∂C/∂x_j) v_j,
    K_ij = ∂f_i/∂x_j = −k [(∂C/∂x_i)(∂C/∂x_j)ᵀ + C ∂²C/∂x_i∂x_j] − k_d [Ċ ∂²C/∂x_i∂x_j + (∂C/∂x_i)(Σ_l ∂²C/∂x_j∂x_l v_l)ᵀ],
    D_ij = ∂f_i/∂v_j = −k_d (∂C/∂x_i)(∂C/∂x_j)ᵀ.

So a condition kind supplies C, its gradient G = ∂C/∂x and its Hessian H = ∂²C/∂x² per element, and one kernel
(:func:`element_terms`) makes f, K and D of every kind (B&W drop the last damping term of K to keep it
symmetric; :meth:`pbanim.cloth.Cloth.jacobians` keeps it, so K is the exact derivative that the finite-difference
check sees, and the large-step and Newton solves drop it, since conjugate gradients need a symmetric matrix). The kinds:

===========  ====  =====  ====================================================  =====================================
kind         nv    m      C(x)                                                  ∂²C/∂x_i∂x_j
===========  ====  =====  ====================================================  =====================================
spring       2     1      |x_a − x_b| − r                                       c_i c_j P/|d|,  c = (1, −1)
stretch      3     2      a (|w_u| − 1, |w_v| − 1),  w_u = Σ cu_i x_i            a cu_i cu_j P_u/|w_u| (and v)
shear        3     1      a w_u · w_v                                           a (cu_i cv_j + cv_i cu_j) I
bend         4     1      θ − θ₀, the dihedral angle (:mod:`pbanim.cloth.bend`)  (9 × 9 in edge vectors, see there)
===========  ====  =====  ====================================================  =====================================

with P = I − ŵŵᵀ. [w_u w_v] = [x₁ − x₀, x₂ − x₀] [[Δu₁, Δu₂], [Δv₁, Δv₂]]⁻¹ is the deformation map of a
triangle, a its rest area in uv: stretch is a spring on the vector w_u (rest length 1) with the weights cu_i in
place of (1, −1), so the spring and the stretch condition share one kernel (:func:`weighted_spring`). The
chapter-01 springs (:class:`pbanim.particles.DampedSprings`) are the kind ``spring`` with k_d on l̇: the tests
check that both give one force and one Jacobian (ORACLES J1).

Notation
--------
=======  ===========  ==============  ===============================================
symbol   code         shape           meaning
=======  ===========  ==============  ===============================================
C, Ċ     ``C, Cd``    (E, m)          condition values and rates
G        ``G``        (E, m, q)       ∂C/∂x of the element's q = 3 nv coordinates
H        ``H``        (E, m, q, q)    ∂²C/∂x²
k, k_d   ``k, kd``    (E, m)          stiffness and damping per component
f_e      ``fe``       (E, q)          element forces;  K_e, D_e (E, q, q) blocks
=======  ===========  ==============  ===============================================

Limiting cases: at rest C = 0 and Ċ = 0, so f = 0 and K = −k GGᵀ (positive semi-definite −K); a rigid motion
keeps every C, so Σ_i f_i = 0 (momentum, ORACLES J2) and K annihilates translations.

References: D. Baraff, A. Witkin, "Large steps in cloth simulation", SIGGRAPH 1998, §4.1–4.3 (conditions,
stretch, shear, bend, damping) and §5.2 (the Jacobians); A. Witkin, D. Baraff, *Physically Based Modeling*,
SIGGRAPH course notes 2001 ("Constrained dynamics", energy functions of conditions).
"""

from __future__ import annotations

import numpy as np

__all__ = ["Conditions", "SpringCondition", "TriangleCondition", "element_terms", "weighted_spring",
           "element_dofs"]


def element_dofs(elements: np.ndarray) -> np.ndarray:
    """Global coordinates (E, 3 nv) of the vertices of each element, vertex-major (x, y, z per vertex)."""
    return (elements[:, :, None] * 3 + np.arange(3)).reshape(len(elements), -1)


def element_terms(C, G, H, Ve, k, kd, jacobians=True, exact=True, psd=None):
    """f_e, K_e, D_e of a kind from C (E, m), G (E, m, q), H (E, m, q, q) and element velocities Ve (E, q).

    K_e = −Σ_m [k GGᵀ + (k C + k_d Ċ) H + k_d G (H v)ᵀ],  D_e = −Σ_m k_d GGᵀ (module docstring); with
    ``jacobians=False`` only f_e (then H may be None); with ``exact=False`` the K_e that conjugate gradients
    need: without its one unsymmetric term k_d G (H v)ᵀ (Baraff & Witkin §5.2), and with the coefficient
    k C + k_d Ċ of H clamped at 0 for the components whose H is positive semi-definite (``psd`` (m,) bools:
    springs and stretch; a compressed spring's −H would make M − h²K indefinite, Choi & Ko 2002).
    """
    Cd = np.einsum("emq,eq->em", G, Ve)
    s = k * C
    damped = bool(np.any(kd))
    if damped:
        s = s + kd * Cd
    fe = -np.einsum("em,emq->eq", s, G)
    if not jacobians:
        return fe, None, None
    Gk = G * k[:, :, None]
    Ke = -np.einsum("emq,emr->eqr", Gk, G)
    sH = s if exact or psd is None else np.where(psd, np.maximum(s, 0.0), s)
    Ke -= np.einsum("em,emqr->eqr", sH, H)
    De = None
    if damped:
        Gd = G * kd[:, :, None]
        De = -np.einsum("emq,emr->eqr", Gd, G)
        if exact:
            HV = np.einsum("emrs,es->emr", H, Ve)              # ∂Ċ/∂x = H v
            Ke -= np.einsum("emq,emr->eqr", Gd, HV)
    return fe, Ke, De


def weighted_spring(w, c, a, rest, hessian=True):
    """C, G, H of C = a (|w| − rest) for w = Σ_i c_i x_i (E, 3), weights c (E, nv), scale a (E,).

    G_i = a c_i ŵ, H_ij = a c_i c_j (I − ŵŵᵀ)/|w|; a spring is c = (1, −1), a = 1. Returns C (E,), G (E, 3nv),
    H (E, 3nv, 3nv) (None without ``hessian``). A zero-length w has no direction: its G and H are NaN (a
    degenerate element, named by the caller's finiteness check).
    """
    length = np.sqrt(np.einsum("ij,ij->i", w, w))
    with np.errstate(divide="ignore", invalid="ignore"):
        what = w / length[:, None]
    C = a * (length - rest)
    G = ((a[:, None] * c)[:, :, None] * what[:, None, :]).reshape(len(w), -1)
    if not hessian:
        return C, G, None
    with np.errstate(divide="ignore", invalid="ignore"):
        P = (np.eye(3) - what[:, :, None] * what[:, None, :]) / length[:, None, None]
    cc = a[:, None, None] * c[:, :, None] * c[:, None, :]
    H = np.einsum("eij,ekl->eikjl", cc, P).reshape(len(w), G.shape[1], G.shape[1])
    return C, G, H


class Conditions:
    """E elements of one kind, each with m condition components on nv particles, stiffness and damping per
    component (k, k_d of shape (E, m)). Subclasses define :meth:`evaluate`; the rest is shared."""

    kind = "conditions"
    nv = 0
    m = 0
    psd = None          # (m,) bools: components whose ∂²C/∂x² is positive semi-definite

    def __init__(self, elements, k, kd) -> None:
        self.elements = np.asarray(elements, dtype=np.intp).reshape(-1, self.nv)
        E = len(self.elements)
        self.k = np.broadcast_to(np.asarray(k, dtype=float), (E, self.m)).copy()
        self.kd = np.broadcast_to(np.asarray(kd, dtype=float), (E, self.m)).copy()
        self.dofs = element_dofs(self.elements)

    def __len__(self) -> int:
        return len(self.elements)

    def evaluate(self, x, sel=None, hessian=True):
        """C (E, m), G (E, m, q) and H (E, m, q, q) (None without ``hessian``) at positions x (N, 3), for the
        elements ``sel`` (an index array) or all."""
        raise NotImplementedError

    def energy(self, x) -> float:
        """½ Σ k C² over the elements."""
        C = self.evaluate(x, hessian=False)[0]
        return float(0.5 * np.sum(self.k * C * C))

    def terms(self, x, v, jacobians=True, exact=True):
        """Element forces f_e (E, q) and blocks K_e, D_e (E, q, q) at (x, v) (D_e None when undamped;
        ``exact=False``: the symmetric K_e of :func:`element_terms`)."""
        C, G, H = self.evaluate(x, hessian=jacobians)
        Ve = v.reshape(-1)[self.dofs]
        return element_terms(C, G, H, Ve, self.k, self.kd, jacobians, exact, self.psd)

    def forces(self, x, v) -> np.ndarray:
        """f (N·3,) of this kind alone (element forces summed into the particles)."""
        fe = self.terms(x, v, jacobians=False)[0]
        return np.bincount(self.dofs.ravel(), fe.ravel(), minlength=x.size)


class SpringCondition(Conditions):
    """Springs as a condition: C = |x_a − x_b| − r per pair (a, b), energy ½ k C², damping k_d on Ċ = l̇."""

    kind, nv, m = "spring", 2, 1
    psd = np.array([True])

    def __init__(self, pairs, rest, k, kd) -> None:
        super().__init__(pairs, np.reshape(k, (-1, 1)) if np.ndim(k) else k,
                         np.reshape(kd, (-1, 1)) if np.ndim(kd) else kd)
        self.rest = np.broadcast_to(np.asarray(rest, dtype=float), (len(self),)).copy()
        self._c = np.broadcast_to(np.array([1.0, -1.0]), (len(self), 2))
        self._one = np.ones(len(self))

    def pair_terms(self, x, v, exact=True):
        """f_e (E, 6) and the 3 × 3 blocks B_K, B_D (E, 3, 3) with K_e = c cᵀ ⊗ B_K, D_e = c cᵀ ⊗ B_D,
        c = (1, −1) (B_D None when undamped): :meth:`terms` of a spring in a quarter of the numbers.

        With ŵ = d/|d|, d = x_a − x_b, u = v_a − v_b, P = (I − ŵŵᵀ)/|d| and s = k C + k_d Ċ (Ċ = ŵ·u):
        f_a = −s ŵ = −f_b,  B_K = −(k ŵŵᵀ + s P + k_d ŵ (P u)ᵀ),  B_D = −k_d ŵŵᵀ (``exact=False``: s clamped
        at 0 in front of P and the unsymmetric last term left out, as in :func:`element_terms`)."""
        # BEGIN SOLUTION SpringCondition.pair_terms
        el = self.elements
        d, u = x[el[:, 0]] - x[el[:, 1]], v[el[:, 0]] - v[el[:, 1]]
        length = np.sqrt(np.einsum("ij,ij->i", d, d))
        with np.errstate(divide="ignore", invalid="ignore"):
            w = d / length[:, None]
            k, kd = self.k[:, 0], self.kd[:, 0]
            damped = bool(np.any(kd))
            s = k * (length - self.rest)
            if damped:
                s = s + kd * np.einsum("ij,ij->i", w, u)
            fa = -s[:, None] * w
            ww = w[:, :, None] * w[:, None, :]
            P = (np.eye(3) - ww) / length[:, None, None]
        BK = ww * -k[:, None, None]
        BK -= (s if exact else np.maximum(s, 0.0))[:, None, None] * P
        BD = None
        if damped:
            BD = ww * -kd[:, None, None]
            if exact:
                BK -= (kd[:, None] * w)[:, :, None] * np.einsum("eij,ej->ei", P, u)[:, None, :]
        return np.concatenate([fa, -fa], axis=1), BK, BD
        # END SOLUTION

    def evaluate(self, x, sel=None, hessian=True):
        el = self.elements if sel is None else self.elements[sel]
        one, c, rest = (self._one, self._c, self.rest) if sel is None else (self._one[sel], self._c[sel],
                                                                          self.rest[sel])
        C, G, H = weighted_spring(x[el[:, 0]] - x[el[:, 1]], c, one, rest, hessian)
        return C[:, None], G[:, None, :], None if H is None else H[:, None]


class TriangleCondition(Conditions):
    """Baraff–Witkin stretch (two components) and shear (one) per triangle: C = a (|w_u| − 1, |w_v| − 1,
    w_u·w_v), with w_u, w_v the columns of the deformation map and a the rest area in uv (module docstring).

    ``k`` and ``kd`` are (E, 3): stretch along u, stretch along v, shear.
    """

    kind, nv, m = "triangle", 3, 3
    psd = np.array([True, True, False])

    def __init__(self, triangles, uv, k, kd) -> None:
        super().__init__(triangles, k, kd)
        t = self.elements
        du = uv[t[:, 1:], 0] - uv[t[:, :1], 0]                  # (E, 2): Δu₁, Δu₂
        dv = uv[t[:, 1:], 1] - uv[t[:, :1], 1]
        det = du[:, 0] * dv[:, 1] - du[:, 1] * dv[:, 0]
        self.area = 0.5 * np.abs(det)
        # [w_u w_v] = [Δx₁ Δx₂] B,  B = [[Δu₁, Δu₂], [Δv₁, Δv₂]]⁻¹;  w = Σ_i c_i x_i with c₀ = −c₁ − c₂
        b11, b12, b21, b22 = dv[:, 1] / det, -du[:, 1] / det, -dv[:, 0] / det, du[:, 0] / det
        self.cu = np.stack([-(b11 + b21), b11, b21], axis=1)
        self.cv = np.stack([-(b12 + b22), b12, b22], axis=1)

    def evaluate(self, x, sel=None, hessian=True):
        el, cu, cv, a = (self.elements, self.cu, self.cv, self.area) if sel is None else (
            self.elements[sel], self.cu[sel], self.cv[sel], self.area[sel])
        X = x[el]                                               # (E, 3 vertices, 3)
        wu = np.einsum("ei,eij->ej", cu, X)
        wv = np.einsum("ei,eij->ej", cv, X)
        E = len(el)
        Cu, Gu, Hu = weighted_spring(wu, cu, a, 1.0, hessian)
        Cv, Gv, Hv = weighted_spring(wv, cv, a, 1.0, hessian)
        Cs = a * np.einsum("ij,ij->i", wu, wv)
        Gs = (a[:, None, None] * (cu[:, :, None] * wv[:, None, :] + cv[:, :, None] * wu[:, None, :])).reshape(E, 9)
        C = np.stack([Cu, Cv, Cs], axis=1)
        G = np.stack([Gu, Gv, Gs], axis=1)
        if not hessian:
            return C, G, None
        sym = a[:, None, None] * (cu[:, :, None] * cv[:, None, :] + cv[:, :, None] * cu[:, None, :])
        Hs = np.einsum("eij,kl->eikjl", sym, np.eye(3)).reshape(E, 9, 9)
        return C, G, np.stack([Hu, Hv, Hs], axis=1)
