"""Small steps: XPBD (Macklin, Müller & Chentanez 2016) with substepping (Macklin et al. 2019) on the cloth.

XPBD moves positions. A step of size h predicts x̃ = x₀ + h v₀ + h² W f_ext, then Gauss–Seidel sweeps over the
constraints, each the condition C(x) of a cloth element (:mod:`pbanim.cloth.conditions`) with *compliance*
α = 1/k (its energy ½ α⁻¹ C² is the condition's ½ k C²: the same stiffness, no other mapping) and damping
β = k_d (γ = α β / h):

    Δλ = −(C + α̃ λ + γ G (x − x₀)) / ((1 + γ) G W Gᵀ + α̃),    x += W Gᵀ Δλ,   λ += Δλ,     α̃ = α/h²,

G = ∂C/∂x, W = M⁻¹ (0 for pinned particles); then v₁ = (x − x₀)/h. The element's m components are updated
together (the m × m system (diag(1 + γ) G W Gᵀ + diag(α̃)) Δλ = −(C + α̃λ + γ G Δx): one 3 × 3 solve per
Baraff–Witkin triangle). Elements are greedily coloured so that no two of one colour share a particle, and a
colour is one vectorized update (Gauss–Seidel between colours, exact within one).

What it converges to (ORACLES J4). At a fixed point of the sweeps C + α̃λ + γ G Δx = 0, and if
M(x − x̃) = G(x)ᵀλ held it would be M(x − x̃) = −h² Gᵀ(k C + k_d G v₁): **implicit Euler** of the damped cloth,
the solution :func:`pbanim.cloth.newton_step` computes. XPBD drops that first equation's residual (Macklin et
al. 2016, eq. (11): g = 0): the position moves by Σ_sweeps G(x_s)ᵀΔλ_s, not G(x)ᵀλ, so the sweeps settle a
little off implicit Euler (measured 2e-8 m for springs, 2e-7 m for the triangle conditions at h = 0.02 s on a
5 × 5 sheet, the gap shrinking with h). Substepping (n substeps of h/n with one sweep each, Macklin et al.
2019) trades the sweeps for smaller steps: the gap to n implicit Euler steps of h/n shrinks like n⁻¹ or
faster (fitted 1.1 and 1.5), and implicit Euler's own error is O(h/n), so the run converges to the cloth's
exact motion at order 1.

Collisions: after the sweeps each particle inside a collider is pushed out along its normal (the inequality
constraint φ(x) ≥ thickness, projected). Limiting cases: k → ∞ (α = 0) is PBD's hard constraint; one sweep
at a large h leaves the cloth stretchier than k says (the iteration count is part of the stiffness: the
lecture's "PBD stiffness depends on iterations"), which substepping removes.

References: M. Macklin, M. Müller, N. Chentanez, "XPBD: position-based simulation of compliant constrained
dynamics", MIG 2016 (eqs. (18), (26): compliance, damping); M. Macklin, K. Storey, M. Lu, P. Terdiman,
N. Chentanez, S. Jeschke, M. Müller, "Small steps in physics simulation", SCA 2019; M. Müller, B. Heidelberger,
M. Hennix, J. Ratcliff, "Position based dynamics", VRIPHYS 2006.
"""

from __future__ import annotations

import numpy as np

from .collide import project
from ..contracts import Array, Int, Obj, Real, contract
from ..errors import SimulationDiverged

__all__ = ["xpbd_step", "greedy_colors", "XPBD"]


def greedy_colors(elements: np.ndarray, n_points: int) -> list[np.ndarray]:
    """Element index sets such that no two elements of one set share a vertex (greedy, in element order)."""
    used = np.zeros(n_points, dtype=np.int64)              # bit c set: colour c touches the vertex
    color = np.empty(len(elements), dtype=np.intp)
    for e, el in enumerate(elements.tolist()):
        busy = 0
        for p in el:
            busy |= int(used[p])
        c = (~busy & (busy + 1)).bit_length() - 1             # the lowest free colour
        color[e] = c
        for p in el:
            used[p] |= 1 << c
    return [np.flatnonzero(color == c) for c in range(int(color.max()) + 1)] if len(color) else []


class XPBD:
    """The per-cloth data of the XPBD solver: colours, compliances, inverse masses (built once)."""

    def __init__(self, cloth) -> None:
        self.cloth = cloth
        N = cloth.sheet.n_particles
        w = 1.0 / cloth.sheet.masses
        w[cloth.pinned] = 0.0
        self.w = w
        self.wdof = np.repeat(w, 3)
        self.gacc = np.where(w[:, None] > 0, cloth.gravity, 0.0)
        self.kinds = []
        for c in cloth.conditions:
            active = c.k > 0
            with np.errstate(divide="ignore"):
                alpha = np.where(active, 1.0 / np.where(active, c.k, 1.0), 1.0)
                beta_ratio = np.where(active, c.kd / np.where(active, c.k, 1.0), 0.0)   # k_d/k = β
            self.kinds.append((c, greedy_colors(c.elements, N), alpha, beta_ratio, active))

    def step(self, x, v, h, substeps, iterations):
        """Advance (x, v) (N, 3) by h in ``substeps`` substeps of ``iterations`` sweeps (in place, returned)."""
        hs = h / substeps
        cloth = self.cloth
        for _ in range(substeps):
            v += hs * self.gacc
            x0 = x.copy()
            x += hs * v
            lams = [np.zeros((len(c), c.m)) for c, *_ in self.kinds]
            for _ in range(iterations):
                for (c, colors, alpha, ratio, active), lam in zip(self.kinds, lams):
                    for sel in colors:
                        self._solve(c, sel, x, x0, hs, alpha[sel], ratio[sel], active[sel], lam)
            if cloth.colliders:
                moved = x.copy()
                project(cloth.colliders, moved, cloth.thickness)
                x[self.w > 0] = moved[self.w > 0]
            v[:] = (x - x0) / hs
        return x, v

    def _solve(self, c, sel, x, x0, hs, alpha, ratio, active, lam):
        el = c.elements[sel]
        C, G, _ = c.evaluate(x, sel, hessian=False)               # (E, m), (E, m, q)
        G = G * active[:, :, None]
        at = alpha / (hs * hs)
        gamma = ratio / hs                                         # γ = α β / h with α = 1/k, β = k_d
        dofs = c.dofs[sel]
        W = self.wdof[dofs]                                        # (E, q)
        dx = (x - x0).reshape(-1)[dofs]
        rhs = -(C + at * lam[sel] + gamma * np.einsum("emq,eq->em", G, dx))
        rhs = np.where(active, rhs, 0.0)
        if c.m == 1:
            denom = (1.0 + gamma[:, 0]) * np.einsum("eq,eq,eq->e", G[:, 0], W, G[:, 0]) + at[:, 0]
            dlam = (rhs[:, 0] / denom)[:, None]
        else:
            A = np.einsum("emq,eq,enq->emn", G, W, G) * (1.0 + gamma)[:, :, None]
            A[:, np.arange(c.m), np.arange(c.m)] += at
            dlam = np.linalg.solve(A, rhs[:, :, None])[:, :, 0]
        lam[sel] += dlam
        x[el] += (W * np.einsum("emq,em->eq", G, dlam)).reshape(len(sel), c.nv, 3)


@contract(cloth=Obj("pbanim.cloth.model:Cloth"), y=Array(("cloth.n_state",)), h=Real(gt=0, le=10.0),
          substeps=Int(ge=1, le=10_000), iterations=Int(ge=1, le=10_000))
def xpbd_step(cloth, y, h: float, substeps: int = 1, iterations: int = 10) -> np.ndarray:
    """One XPBD step of size h: ``substeps`` substeps of ``iterations`` colour sweeps; the full state y₁.

    SimulationDiverged when y₁ is not finite (a degenerate element or an overflow).
    """
    y1 = _xpbd_step(cloth, y, h, substeps, iterations)
    if not np.isfinite(y1).all():
        raise SimulationDiverged(0.0, 0, "cloth state", f"the XPBD step at h = {h:g} overflowed")
    return y1


def _xpbd_step(cloth, y, h, substeps, iterations):
    solver = getattr(cloth, "_xpbd", None)
    if solver is None:
        solver = cloth._xpbd = XPBD(cloth)
    n = cloth.n
    x, v = y[:n].reshape(-1, 3).copy(), y[n:].reshape(-1, 3).copy()
    with np.errstate(all="ignore"):
        solver.step(x, v, h, substeps, iterations)
    return np.concatenate([x.ravel(), v.ravel()])
