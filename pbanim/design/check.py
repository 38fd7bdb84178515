"""∂S/∂u by finite differences, the independent check of the variational equations (chapter 10).

The centred difference of the simulation function along parameter k,

    D(δ) = (S(t, u + δe_k) − S(t, u − δe_k)) / 2δ = ∂S/∂u_k + δ²/6 ∂³S/∂u_k³ + O(δ⁴),

has an error O(δ²) from truncation and O(ε_mach |S|/δ) from roundoff (and from the event location,
whose tolerance is 1e-14·t). Richardson extrapolation cancels the δ² term,

    D_R = (4 D(δ/2) − D(δ)) / 3 = ∂S/∂u_k + O(δ⁴),

so a moderate δ (1e-3 relative) reaches 1e-9 accuracy without the roundoff of tiny steps — at four
simulations per parameter. Orientations are compared in the tangent space: the output is the rotation
vector log(q(u ± δe_k) ⊗ q(u)*), never the four quaternion components (ORACLES H2). Both sides must see
the same impacts; a difference that crosses a change of the impact sequence is meaningless, and is
refused (:class:`~pbanim.errors.InvalidInput` naming the parameter).

This module reuses pbanim's one finite-difference reference for the plain centred difference
(:func:`pbanim.derivatives.central_jacobian`).

References: Popović et al. SIGGRAPH 2000 §4 (derivatives checked against differences); L. F. Richardson,
"The deferred approach to the limit", 1927; Hairer, Nørsett & Wanner I, §II.9 (extrapolation).
"""

from __future__ import annotations

import numpy as np

from ..derivatives import central_jacobian
from ..contracts import Array, Flag, Obj, Opt, Real, Seq, contract
from ..errors import InvalidInput
from ..rigid import quat_conjugate, quat_multiply
from .scene import DesignScene
from .simulate import quat_log, simulate
from .specs import OutputTriples, ParameterNames, Quaternion, u_size
from .trajectory import Trajectory

__all__ = ["output_vector", "analytic_jacobian", "fd_jacobian", "fd_differences"]


@contract(tr=Obj(Trajectory), outputs=OutputTriples("tr"), reference=Opt(Seq(Opt(Quaternion()))))
def output_vector(tr, outputs, reference=None) -> np.ndarray:
    """Stack of positions and orientation rotation vectors (relative to ``reference`` quaternions: one per
    output, None where the output is a position)."""
    if reference is not None and len(reference) != len(outputs):
        raise InvalidInput(f"output_vector: reference must hold one quaternion (or None) per output, "
                           f"{len(outputs)}, got {len(reference)}")
    vals = []
    for k, (i, t, kind) in enumerate(outputs):
        if kind == "position":
            vals.append(tr.position(i, t))
        else:
            q = tr.orientation(i, t)
            ref = q if reference is None or reference[k] is None else reference[k]
            vals.append(quat_log(quat_multiply(q, quat_conjugate(ref))))
    return np.concatenate(vals)


@contract(tr=Obj(Trajectory), outputs=OutputTriples("tr"))
def analytic_jacobian(tr, outputs) -> np.ndarray:
    """∂(stacked outputs)/∂u from a trajectory simulated with sensitivities, (3·len(outputs), p)."""
    rows = [tr.d_position(i, t) if kind == "position" else tr.d_orientation(i, t) for i, t, kind in outputs]
    return np.vstack(rows)


@contract(scene=Obj(DesignScene), names=ParameterNames("scene"), u=Opt(Array((u_size(),))), t_end=Real(),
          outputs=OutputTriples("scene"), delta=Real(gt=0), richardson=Flag(), h=Real(gt=0), relative=Flag())
def fd_jacobian(scene, names, u, t_end, outputs, *, delta: float = 1e-4, richardson: bool = True,
                h: float = 0.005, relative: bool = True) -> np.ndarray:
    """∂(outputs)/∂u by centred differences of S (plain, or Richardson-extrapolated), (3·len(outputs), p).

    ``delta`` is the step (times max(1, |u_k|) when ``relative``). Every perturbed run must have the same
    number of impacts as the nominal one.
    """
    if not richardson:
        return fd_differences(scene, names, u, t_end, outputs, [delta], h=h, relative=relative)[0]
    D1, D2 = fd_differences(scene, names, u, t_end, outputs, [delta, delta / 2], h=h, relative=relative)
    return (4.0 * D2 - D1) / 3.0


@contract(scene=Obj(DesignScene), names=ParameterNames("scene"), u=Opt(Array((u_size(),))), t_end=Real(),
          outputs=OutputTriples("scene"), deltas=Seq(Real(gt=0), min_len=1, max_len=64), h=Real(gt=0), relative=Flag())
def fd_differences(scene, names, u, t_end, outputs, deltas, *, h: float = 0.005, relative: bool = True) -> list:
    """[D(δ) for δ in deltas]: the plain centred differences of :func:`fd_jacobian` at several steps, the
    nominal run S(t, u) (the orientation references and the impact count) simulated once for all of them."""
    u = np.asarray(scene.vector(names) if u is None else u, dtype=float)
    times = sorted({t for _, t, _ in outputs if t < t_end})
    base = simulate(scene, t_end, names, u, times=times, h=h, sensitivities=False, warn=False)
    refs = [base.orientation(i, t) if kind == "orientation" else None for i, t, kind in outputs]
    n_imp = len(base.impacts)

    def S(uu):
        tr = simulate(scene, t_end, names, uu, times=times, h=h, sensitivities=False, warn=False)
        if len(tr.impacts) != n_imp:
            k = int(np.flatnonzero(uu != u)[0]) if np.any(uu != u) else -1
            raise InvalidInput(f"finite difference along u[{k}] changed the number of impacts ({n_imp} → "
                               f"{len(tr.impacts)}); S is not smooth there: use a smaller delta")
        return output_vector(tr, outputs, refs)

    return [central_jacobian(S, u, eps=float(d), relative=relative) for d in deltas]
