"""Which inertia tensors a body can have: the test, once, and the spec that applies it (chapter 05).

An inertia tensor about the centre of mass, I = ∫ρ (|r|² E − r rᵀ) dV, is

* symmetric;
* positive definite (semi-definite for a point mass, or a rod about its own axis: ``definite=False``);
* and its principal moments satisfy the triangle inequalities I₁ + I₂ ≥ I₃ (equality for a flat lamina),
  because Iᵢ + Iⱼ − Iₖ = 2∫ρ rₖ² dV ≥ 0.

A tensor that fails one of these belongs to no mass distribution: it is a typo, wrong axes or wrong
units, and a simulation with it is not a rigid body (an asymmetric tensor does not even conserve
energy). :func:`inertia_defect` is the test; :class:`Inertia` (the contract of every inertia argument of
:mod:`pbanim.rigid`) and :func:`pbanim.rigid.validate_inertia` (for tensors computed inside pbanim) both
call it. Asymmetry and the triangle inequality are judged with the slack 10⁻¹⁰ relative to the largest
entry; the eigenvalues of I/max|Iᵢⱼ| are computed, so tensors near 10³⁰⁰ or 10⁻³⁰⁰ are judged too.

>>> inertia_defect(np.diag([1.0, 1.0, 3.0])[None])
(0, 'principal moments [1. 1. 3.] violate the triangle inequality I1 + I2 >= I3 (1 + 1 < 3); no mass distribution has these moments — check the axes or units')
>>> inertia_defect(np.diag([0.0, 1.0, 1.0])[None], definite=False) is None     # a thin rod
True
"""

from __future__ import annotations

import math

import numpy as np

from ..contracts import Spec

__all__ = ["Inertia", "inertia_defect"]

_REL_TOL = 1e-10       # asymmetry and triangle-inequality slack, relative to the largest entry


def inertia_defect(flat: np.ndarray, definite: bool = True) -> tuple[int, str] | None:
    """The first inadmissible tensor of a stack (K, 3, 3) of finite tensors, as (index, what is wrong),
    or None when every one could be the inertia of a body (see the module docstring)."""
    scale = np.maximum(np.abs(flat).max(axis=(1, 2)), np.finfo(float).tiny)
    asym = np.abs(flat - np.swapaxes(flat, 1, 2)).max(axis=(1, 2))
    bad = asym > _REL_TOL * scale
    if bad.any():
        k = int(np.flatnonzero(bad)[0])
        return k, f"it is not symmetric (max |I - I^T| = {asym[k]:.3g})"
    with np.errstate(over="ignore", under="ignore", invalid="ignore"):
        w = np.linalg.eigvalsh(flat / scale[:, None, None]) * scale[:, None]     # ascending, no overflow
    low = w[:, 0] <= 0 if definite else w[:, 0] < -_REL_TOL * scale
    if low.any():
        k = int(np.flatnonzero(low)[0])
        return k, (f"principal moments {w[k]} are not all {'> 0' if definite else '>= 0'}; every moment of a "
                   f"{'solid body' if definite else 'body'} is {'> 0' if definite else '>= 0'}")
    tri = w[:, 0] + w[:, 1] < w[:, 2] - _REL_TOL * scale
    if tri.any():
        k = int(np.flatnonzero(tri)[0])
        a, b, c = w[k]
        return k, (f"principal moments {w[k]} violate the triangle inequality I1 + I2 >= I3 ({a:.6g} + {b:.6g} < "
                   f"{c:.6g}); no mass distribution has these moments — check the axes or units")
    return None


class Inertia(Spec):
    """An admissible inertia tensor (3, 3) (``batch``: or a stack (K, 3, 3)); ``moments=True`` also takes
    principal moments (3,) (or (K, 3)), read as diag(I₁, I₂, I₃); a (3, 3) array is always one tensor."""

    def __init__(self, *, batch: bool = False, moments: bool = False, definite: bool = True) -> None:
        self.batch, self.moments, self.definite = batch, moments, definite

    def describe(self) -> str:
        shapes = "(3, 3)" + (" or (K, 3, 3)" if self.batch else "")
        if self.moments:
            shapes += ", or principal moments (3,)" + (" or (K, 3)" if self.batch else "")
        kind = "positive definite" if self.definite else "positive semi-definite"
        return (f"an inertia tensor of shape {shapes}: finite, symmetric, {kind}, with principal moments "
                "I1 + I2 >= I3")

    def tensors(self, a: np.ndarray) -> np.ndarray | None:
        """The stack (K, 3, 3) that ``a`` stands for, or None when its shape is none of the accepted."""
        if a.shape == (3, 3) or self.batch and a.ndim == 3 and a.shape[1:] == (3, 3) and len(a):
            return a.reshape(-1, 3, 3)
        if self.moments and (a.shape == (3,) or self.batch and a.ndim == 2 and a.shape[1] == 3 and len(a)):
            m = a.reshape(-1, 3)
            return m[:, :, None] * np.eye(3)
        return None

    def check(self, name, value, env):
        try:
            a = None if value is None or isinstance(value, (str, bytes)) else np.asarray(value, dtype=float)
        except (TypeError, ValueError):
            a = None
        flat = None if a is None else self.tensors(a)
        if flat is None:
            raise env.fail(name, self.describe(), value, "" if a is None else f"shape {a.shape}")
        if not np.isfinite(flat).all():
            raise env.fail(name, self.describe(), value, "it has NaN or inf entries")
        found = inertia_defect(flat, self.definite)
        if found is not None:
            k, detail = found
            raise env.fail(name, self.describe(), value, detail if len(flat) == 1 else f"tensor {k}: {detail}")
        return a

    def example(self, env):
        return np.diag([1.0, 2.0, 2.5])

    def bad(self, env):
        I = self.example(env)
        skew, nan, inf = I.copy(), I.copy(), I.copy()
        skew[0, 1], nan[1, 1], inf[2, 2] = 0.5, np.nan, np.inf
        out = [("None", None), ("a string", "1.0"), ("NaN", nan), ("inf", inf), ("empty", np.zeros(0)),
               ("not symmetric", skew), ("negative", -I), ("triangle violated", np.diag([1.0, 1.0, 3.0])),
               ("wrong shape", np.eye(2)), ("two extra axes", I[None, None])]
        if self.definite:
            out.append(("singular", np.diag([0.0, 1.0, 1.0])))
        if not self.batch:
            out.append(("a batch", np.stack([I, I])))
        return out

    def edges(self, env):
        I = self.example(env)
        out = [("a nested list", I.tolist()), ("a lamina", np.diag([1.0, 1.0, 2.0])), ("huge", 1e300 * I),
               ("tiny", 1e-300 * I), ("rotated", _rotated(I))]
        if not self.definite:
            out += [("zeros", np.zeros((3, 3))), ("a rod", np.diag([0.0, 1.0, 1.0]))]
        if self.batch:
            out.append(("a batch", np.stack([I, 2 * I])))
        if self.moments:
            out.append(("moments", np.diag(I).copy()))
        return out


def _rotated(I: np.ndarray) -> np.ndarray:
    c, s = math.cos(0.6), math.sin(0.6)
    R = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
    return R @ I @ R.T
