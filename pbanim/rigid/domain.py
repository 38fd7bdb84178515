"""What the arguments of chapter 05 must be: the specs the contract vocabulary lacks (part of :mod:`pbanim.rigid`).

:mod:`pbanim.contracts` says what a number or an array must be; a rigid body needs a little more:

===========================  =========================================================================
spec                         accepts
===========================  =========================================================================
``Vectors(n, nonzero=True)``  vectors of n entries (a quaternion q, an axis), none of them zero
``Vectors(n, below=r)``      vectors of norm |θ| < r (a rotation vector inside the domain of dexp⁻¹)
``Rotation()``               a rotation matrix R: RᵀR = E to 10⁻⁶ and det R = +1
``Inertia()``                an inertia tensor a body can have (:mod:`pbanim.rigid.admissible`)
``RigidState(system)``       a flat state y = [x, q, P, L] (13N) of a system, every q non-zero
``BodyIndices(size)``        body indices, −1 (the static world) too when ``world=True``
``Flags()``                  True / False, or one per body
``Counter()``                a list whose first item counts evaluations (incremented in place)
===========================  =========================================================================

The numeric helpers of the same checks live here too: :func:`row_norms` (|v| along the last axis without
overflow for entries near 10³⁰⁰ or underflow near 10⁻³⁰⁰) and :func:`tame` (such rows scaled in place);
:func:`certify` and :func:`certifier`, the ``returns=`` certificate of a contract (a result computed from
finite inputs must be finite, else :class:`~pbanim.errors.NonFiniteResult`; it runs on calls from outside the
package, and NaN in, NaN out is left to the stepping loop, which names it
:class:`~pbanim.errors.SimulationDiverged`).
"""

from __future__ import annotations

import math
import numbers

import numpy as np

from ..contracts import Array, Spec
from ..errors import check_result

__all__ = ["Vectors", "Rotation", "RigidState", "BodyIndices", "Flags", "Counter", "row_norms", "certify",
           "certifier", "tame"]

_ORTHO_TOL = 1e-6      # |RᵀR − E| accepted in a rotation matrix (single precision data passes)
_SAFE = (1e-290, 1e290)  # |v|² computed directly between these; scaled by max |vᵢ| outside
_MIN, _MAX = np.minimum.reduce, np.maximum.reduce


def row_norms(v: np.ndarray) -> np.ndarray:
    """|v| along the last axis, exact to roundoff for any finite v (scaled by max |vᵢ| when |v|² would
    overflow or underflow); NaN rows stay NaN.

    >>> row_norms(np.array([[3e300, 4e300, 0.0], [3e-300, 4e-300, 0.0]]))
    array([5.e+300, 5.e-300])
    """
    n2 = np.einsum("...i,...i->...", v, v)       # (einsum raises no overflow warning)
    if n2.size == 0 or (n2.min() > _SAFE[0] and n2.max() < _SAFE[1]):
        return np.sqrt(n2)
    with np.errstate(over="ignore", invalid="ignore"):
        s = np.abs(v).max(axis=-1)
        u = v / np.where(s > 0, s, 1.0)[..., None]
        return s * np.sqrt(np.einsum("...i,...i->...", u, u))


def tame(v: np.ndarray) -> np.ndarray:
    """Scale, in place, the rows of v whose |v|² would overflow or underflow to max |vᵢ| = 1 (no change to
    any other row, so a unit quaternion stays bit for bit); returns v."""
    n2 = np.einsum("...i,...i->...", v, v)       # (einsum raises no overflow warning)
    if n2.size == 0 or n2.min() > _SAFE[0] and n2.max() < _SAFE[1]:
        return v
    wild = ~((n2 > _SAFE[0]) & (n2 < _SAFE[1])) & (np.abs(v).max(axis=-1) > 0)
    if wild.any():
        v[wild] /= np.abs(v[wild]).max(axis=-1, keepdims=True)
    return v


def _finite(a) -> bool:
    if type(a) is not np.ndarray:
        if type(a) is float:
            return math.isfinite(a)
        a = np.asarray(a)
    if a.dtype.kind not in "fc":
        return True
    # NaN propagates through min and max, ±inf lands in one of them (and neither raises a warning)
    return a.size == 0 or math.isfinite(_MIN(a, None)) and math.isfinite(_MAX(a, None))


def certify(what: str, out, *inputs, detail: str = ""):
    """``out`` when it is finite; :class:`~pbanim.errors.NonFiniteResult` naming ``what`` when it is not
    although every one of ``inputs`` is (an overflow); ``out`` as it is when an input already was not
    finite (inside a stepping loop the driver names that :class:`~pbanim.errors.SimulationDiverged`)."""
    if _finite(out) or not all(_finite(i) for i in inputs):
        return out
    return check_result(what, out, detail)


class Vectors(Array):
    """Vectors of ``n`` entries along the last axis, each non-zero (``nonzero``) and of norm < ``below``."""

    def __init__(self, n: int, *, batch: str | None = None, nonzero: bool = False, below: float | None = None,
                 what: str = "") -> None:
        super().__init__((n,), batch=batch)
        self.n, self.nonzero, self.below, self.what = n, nonzero, below, what

    def describe(self, env=None) -> str:
        text = (f"{self.what} " if self.what else "") + super().describe(env)
        if self.nonzero:
            text += ", non-zero"
        if self.below is not None:
            text += f", of norm < {self.below:.6g}"
        return text

    def check(self, name, value, env):
        a = super().check(name, value, env)
        n = row_norms(a)
        if self.nonzero and not (n > 0).all():
            k = int(np.flatnonzero(~(n > 0))[0])
            raise env.fail(name, self.describe(env), value, "it is zero" if a.ndim == 1 else f"row {k} is zero")
        if self.below is not None and not (n < self.below).all():
            k = int(np.flatnonzero(~(n < self.below))[0])
            raise env.fail(name, self.describe(env), value, f"|{name}| = {float(n.flat[k]):.6g}"
                           + ("" if a.ndim == 1 else f" in row {k}"))
        return a

    def bad(self, env):
        a = self.example(env)
        out = super().bad(env)
        if self.nonzero:
            out.append(("zero", np.zeros_like(a)))
        if self.below is not None:
            out.append(("at the norm bound", np.full(self.n, self.below * (1 + 1e-12) / math.sqrt(self.n))))
        return out

    def edges(self, env):
        a = self.example(env)
        out = [(k, v) for k, v in super().edges(env) if not (
            self.nonzero and k == "zeros" or self.below is not None and k == "1e300 entries")]
        if self.nonzero:
            out.append(("tiny", a * 1e-300))
        if self.below is not None:
            out.append(("just below the norm bound", np.full(self.n, self.below * (1 - 1e-9) / math.sqrt(self.n))))
        return out


class Rotation(Array):
    """A rotation matrix (or a batch): RᵀR = E to 10⁻⁶, det R = +1."""

    def __init__(self, *, batch: str | None = None) -> None:
        super().__init__((3, 3), batch=batch)

    def describe(self, env=None) -> str:
        return super().describe(env) + f", a rotation (R^T R = E to {_ORTHO_TOL:g}, det R = +1)"

    def check(self, name, value, env):
        a = super().check(name, value, env)
        flat = a.reshape(-1, 3, 3)
        err = np.abs(np.swapaxes(flat, 1, 2) @ flat - np.eye(3)).max(axis=(1, 2))
        bad = ~(err <= _ORTHO_TOL) | (np.linalg.det(flat) <= 0)
        if bad.any():
            k = int(np.flatnonzero(bad)[0])
            where = "" if a.ndim == 2 else f" (matrix {k})"
            raise env.fail(name, self.describe(env), value, f"max |R^T R - E| = {err[k]:.3g}, det R = "
                           f"{np.linalg.det(flat[k]):.6g}{where}")
        return a

    def example(self, env):
        from .quat import quat_from_axis_angle, quat_to_matrix      # the package's one R(q)
        return quat_to_matrix(quat_from_axis_angle(np.array([1.0, 2.0, 2.0]), 0.7))

    def bad(self, env):
        R = self.example(env)
        return super().bad(env) + [("a reflection", R * [1.0, 1.0, -1.0]), ("scaled", 2.0 * R),
                                   ("zeros", np.zeros((3, 3)))]

    def edges(self, env):
        R = self.example(env)
        out = [("a nested list", R.tolist()), ("the identity", np.eye(3)), ("a half turn", np.diag([1.0, -1, -1]))]
        if self.batch:
            out.append(("a batch", np.stack([R, np.eye(3)])))
        return out


class RigidState(Array):
    """A flat state y = [x, q, P, L] of the system ``system`` refers to (its ``n_state`` entries, 13N), every
    quaternion q non-zero."""

    def __init__(self, system: str = "self") -> None:
        super().__init__((f"{system}.n_state",))

    def describe(self, env=None) -> str:
        return super().describe(env) + ", a state [x, q, P, L] with non-zero quaternions"

    @staticmethod
    def _quats(a: np.ndarray) -> np.ndarray:
        N = len(a) // 13
        return a[3 * N:7 * N].reshape(N, 4)

    def check(self, name, value, env):
        a = super().check(name, value, env)
        zero = np.abs(self._quats(a)).max(axis=1) == 0
        if zero.any():
            raise env.fail(name, self.describe(env), value, f"the quaternion of body {int(np.flatnonzero(zero)[0])} "
                           "is zero")
        return a

    def bad(self, env):
        a = self.example(env)
        self._quats(a)[:] = 0.0
        return super().bad(env) + [("a zero quaternion", a)]

    def edges(self, env):
        a = self.example(env)
        rest = np.zeros_like(a)
        self._quats(rest)[:, 0] = 1.0
        tiny = a.copy()
        self._quats(tiny)[:] *= 1e-300
        return [(k, v) for k, v in super().edges(env) if k != "zeros"] + [("at rest at the origin", rest),
                                                                           ("tiny quaternions", tiny)]


class BodyIndices(Spec):
    """Integer body indices of shape (k,) into a system of ``size`` bodies (a reference, or None: checked
    when the effect is bound); ``world=True`` admits −1, the static world. ``symbol`` ties k to the other
    arguments' shapes (``Array(("k", 3))``)."""

    def __init__(self, size=None, *, world: bool = False, symbol: str | None = None, empty: bool = False) -> None:
        self.size, self.world, self.symbol, self.empty = size, world, symbol, empty

    def describe(self) -> str:
        lo = -1 if self.world else 0
        hi = f"{self.size} − 1" if isinstance(self.size, str) else "N − 1"
        return (f"an integer array of shape ({self.symbol or 'k'},) of body indices in {lo} … {hi}"
                + (" (−1: the static world)" if self.world else "") + ("" if self.empty else ", not empty"))

    def check(self, name, value, env):
        if value is None or isinstance(value, (str, bytes, bool, np.bool_)):
            raise env.fail(name, self.describe(), value)
        try:
            a = np.asarray(value)
        except (TypeError, ValueError):
            raise env.fail(name, self.describe(), value) from None
        if a.ndim != 1:
            raise env.fail(name, self.describe(), value, f"it has {a.ndim} axes, not 1")
        if a.size == 0:
            if not self.empty:
                raise env.fail(name, self.describe(), value, "it is empty")
            a = a.astype(np.intp)
        if a.dtype.kind == "f" and np.isfinite(a).all() and (a == np.round(a)).all():
            a = a.astype(np.intp)
        if a.dtype.kind not in "iu":
            raise env.fail(name, self.describe(), value, "entries are not integers")
        lo = -1 if self.world else 0
        n = None if self.size is None else int(env.resolve(self.size))
        if a.size and (a.min() < lo or n is not None and a.max() >= n):
            raise env.fail(name, self.describe(), value, f"entries range over [{a.min()}, {a.max()}]"
                           + ("" if n is None else f", N = {n}"))
        if self.symbol:
            want = env.symbols.get(self.symbol)
            if want is None:
                env.symbols[self.symbol] = len(a)
            elif want != len(a):
                raise env.fail(name, self.describe(), value, f"{len(a)} indices, the other arguments have "
                               f"{self.symbol} = {want}")
        return a.astype(np.intp, copy=False)

    def _k(self, env) -> int:
        return env.symbols.setdefault(self.symbol, 2) if self.symbol else 2

    def example(self, env):
        n = 1 if self.size is None else max(int(env.resolve(self.size)), 1)
        return np.arange(self._k(env)) % n

    def bad(self, env):
        a = self.example(env)
        out = [("None", None), ("a string", "0"), ("fractions", a + 0.5), ("NaN", np.full(a.shape, np.nan)),
               ("below the range", np.full_like(a, -2 if self.world else -1)), ("two axes", a[None])]
        if self.size is not None:
            out.append(("past the end", np.full_like(a, int(env.resolve(self.size)))))
        if not self.empty:
            out.append(("empty", np.zeros(0, dtype=int)))
        return out

    def edges(self, env):
        a = self.example(env)
        out = [("a list", a.tolist())]
        if self.world:
            out.append(("the world", np.full_like(a, -1)))
        if self.size is not None:
            out.append(("the last", np.full_like(a, int(env.resolve(self.size)) - 1)))
        return out


class Flags(Spec):
    """True or False, or a 1-D list or array of them (one per body)."""

    def describe(self) -> str:
        return "True or False, or one of them per body (a 1-D bool array)"

    def check(self, name, value, env):
        if isinstance(value, (bool, np.bool_)):
            return bool(value)
        a = np.asarray(value) if isinstance(value, (list, tuple, np.ndarray)) else None
        if a is None or a.dtype != bool or a.ndim != 1 or a.size == 0:
            raise env.fail(name, self.describe(), value)
        return a

    def example(self, env):
        return False

    def bad(self, env):
        return [("None", None), ("a string", "yes"), ("a number", 1.0), ("numbers", [1.0, 0.0]), ("empty", []),
                ("two axes", [[True]])]

    def edges(self, env):
        return [("True", True)]


class Counter(Spec):
    """A list whose first item is an int, incremented in place (a count of evaluations)."""

    def describe(self) -> str:
        return "a list whose first item is an integer count (incremented in place)"

    def check(self, name, value, env):
        if not (isinstance(value, list) and value and isinstance(value[0], numbers.Integral)
                and not isinstance(value[0], bool)):
            raise env.fail(name, self.describe(), value)
        return value

    def example(self, env):
        return [0]

    def bad(self, env):
        return [("a tuple", (0,)), ("empty", []), ("a string", "x"), ("a float count", [0.5]), ("a number", 1)]


def certifier(what: str, argument: str | None = None):
    """A ``returns=`` certificate for :func:`pbanim.contracts.contract` (run on calls from outside the package
    only: the step loop pays nothing): the result (each item of a tuple), or the argument ``argument`` that
    the call wrote into, passes :func:`certify` against the arguments."""
    def certificate(out, where, arguments):
        inputs = tuple(v for k, v in arguments.items() if k != "self")
        for o in ((arguments[argument],) if argument else out if isinstance(out, tuple) else (out,)):
            certify(what, o, *inputs)
        return out
    return certificate
