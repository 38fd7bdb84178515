"""The cloth's free-particle ODE Jacobian in blocks, for the stiff ODE solvers' half-size stage systems.

The ODE of the free particles (:meth:`pbanim.cloth.Cloth.rhs`) is ẏ_F = [v_F, W_F f_F(x, v)], so

    J = [[0, I], [W K_FF, W D_FF]],      K = ∂f/∂x,  D = ∂f/∂v,  W = M⁻¹      (lecture 12 notation),

and a stage system (σI − J)(p, u) = (r₁, r₂) of RODAS4 or Radau IIA reduces to one n_F × n_F system in the
velocities, (σ²I − σ W D_FF − W K_FF) u = σ r₂ + W K_FF r₁ (:mod:`pbanim.ode.second_order`): M times it is
σ²M − σD − K, Baraff & Witkin's A = M − hD − h²K with h = 1/σ, divided by h². :func:`second_order_jac` hands
the two blocks to :func:`pbanim.ode.solve` as a :class:`~pbanim.ode.second_order.SecondOrderJacobian`,
filled from K.data and D.data on the pattern by a precomputed gather (the free rows and columns of the
full pattern: no sparse slicing per step). It equals the full J of :meth:`Cloth.jac` entry for entry
(ORACLES J1, J7).

Notation
--------
==========  ============  =======================================
symbol      code          meaning
==========  ============  =======================================
K_FF, D_FF  ``kd, dd``    ∂f/∂x, ∂f/∂v on the free coordinates
W           ``w``         M⁻¹ of each entry's row
n_F         ``nf``        free coordinates (3 × free particles)
==========  ============  =======================================

Limiting cases: no pins (n_F = 3N) keeps the whole pattern; undamped (D = 0) gives Jv with the pattern
of Jx and zero entries, so S = σ²I − Jx.

References: Baraff & Witkin, "Large steps in cloth simulation", SIGGRAPH 1998, §3; Hairer & Wanner,
*Solving ODEs II*, §IV.8.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp

from .model import Cloth
from ..contracts import Obj, contract
from ..ode.second_order import SecondOrderJacobian

__all__ = ["second_order_jac"]


class _FreeBlocks:
    """The CSR pattern of K_FF (rows and columns of the free coordinates) and its gather from K.data."""

    def __init__(self, cloth: Cloth) -> None:
        pat, free = cloth.pattern, cloth.free
        keep = free[pat.rows] & free[pat.indices]
        self.sub = np.flatnonzero(keep)                       # positions in K.data, row-major
        fidx = np.cumsum(free) - 1
        nf = cloth.nf
        r = fidx[pat.rows[self.sub]]
        self.indices = fidx[pat.indices[self.sub]].astype(np.int32)
        self.indptr = np.concatenate([[0], np.cumsum(np.bincount(r, minlength=nf))]).astype(np.int32)
        self.w = cloth.winv[free][r]
        self.shape = (nf, nf)

    def matrix(self, data) -> sp.csc_matrix:
        out = sp.csr_matrix((self.w * data[self.sub], self.indices, self.indptr), shape=self.shape)
        return out.tocsc()


@contract(cloth=Obj(Cloth))
def second_order_jac(cloth: Cloth):
    """``jac(t, y_F)`` → :class:`SecondOrderJacobian` (W K_FF, W D_FF) of the cloth's free ODE (module docstring).

    >>> from pbanim.cloth import Sheet
    >>> cloth = Cloth(Sheet(4), stretch=1e3, damping=1e-3)
    >>> yf = cloth.free_state(cloth.state())
    >>> J = second_order_jac(cloth)(0.0, yf)
    >>> float(abs(J.tocsr() - cloth.jac(0.0, yf)).max())
    0.0
    """
    blocks = _FreeBlocks(cloth)

    def jac(t, yf):
        x, v = cloth._split(yf)
        with np.errstate(all="ignore"):
            _, kd, dd = cloth._all(x, v)
        jv = blocks.matrix(np.zeros_like(kd) if dd is None else dd)
        return SecondOrderJacobian(blocks.matrix(kd), jv)
    return jac
