"""Argument specs of the LCP core that the shared vocabulary (:mod:`pbanim.contracts.specs`) lacks.

=========================  ======================================================================
spec                       accepts
=========================  ======================================================================
``RowIndices(size, rows)`` an ``Indices`` of shape (rows,) whose length binds the symbol ``rows``
                           (so that a row's body index and its Jacobian block have the same count)
``length_of(name)``        a size: the length of the argument ``name``
``JacobianRows(n)``        the rows (a, b, G_a, G_b) of a second Jacobian K (``delassus``'s
                           ``other``): body indices in 0 … n − 1 and two (k, d) float arrays
``SolverOptions(solver)``  a dict of options for the LCP solver named by the argument ``solver``
                           (the names and values :data:`LCP_OPTIONS` lists; ``"qp"`` also passes
                           its backend's own settings on)
=========================  ======================================================================

:func:`check_options` is the same check for ``solve_lcp(..., **opts)``, whose options a contract
cannot see (keyword arguments of any name).
"""

from __future__ import annotations

import numpy as np

from ..contracts import Array, Choice, Flag, Indices, Int, Obj, Opt, Real, Spec
from ..contracts.specs import Env, short
from ..errors import InvalidInput

__all__ = ["JacobianRows", "RowIndices", "SolverOptions", "length_of", "LCP_OPTIONS", "check_options", "LCP_ENTRIES",
           "LIMIT"]

#: largest |entry| of A and b: beyond it A f and the residual threshold overflow (no certificate possible)
LIMIT = 1e100
#: the entries of an LCP's A and b: finite and below :data:`LIMIT` in magnitude
LCP_ENTRIES = dict(ge=-LIMIT, le=LIMIT)


def length_of(name: str):
    """A size for a spec: the length of the argument ``name`` (e.g. the number of inverse-mass blocks Wb)."""
    return lambda env: len(env.values[name])


def _qp_backends():
    import qpsolvers          # lazy: only a QP option reads the list

    return qpsolvers.available_solvers


_COMMON = {"max_iter": Opt(Int(ge=1)), "polish": Flag()}
#: the options each solver of :func:`pbanim.lcp.solve_lcp` takes, with what each must be
LCP_OPTIONS = {
    "pgs": {**_COMMON, "omega": Real(gt=0, lt=2)},
    "lemke": {**_COMMON, "pivot_tol": Real(gt=0, lt=1)},
    "dantzig": {**_COMMON, "pivot_tol": Real(gt=0, lt=1)},
    "qp": {**_COMMON, "backend": Choice(_qp_backends), "eps_abs": Real(gt=0, lt=1), "native_box": Flag()},
    "bpp": {**_COMMON, "active": Opt(Array(None, empty=True)), "qp_fallback": Flag(), "rho_rel": Real(gt=0, lt=1),
            "refine": Int(ge=0, le=100), "cache": Opt(Obj(dict))},
}


def check_options(where: str, solver: str, opts: dict) -> dict:
    """``opts`` with each known option checked and converted; an option the solver does not take is
    refused by name (``"qp"`` passes unknown names on to its backend as that backend's settings)."""
    if not opts:
        return opts
    table = LCP_OPTIONS.get(solver, {})
    env = Env(where, opts)
    out = {}
    for k, v in opts.items():
        spec = table.get(k)
        if spec is not None:
            out[k] = spec.check(k, v, env)
        elif solver == "qp":
            out[k] = v
        else:
            raise InvalidInput(f"{where}: solver {solver!r} takes no option {k!r}; its options are "
                               f"{sorted(table)}")
    return out


class SolverOptions(Spec):
    """A dict of options for the solver named by the argument ``solver`` (see :data:`LCP_OPTIONS`)."""

    def __init__(self, solver: str = "solver") -> None:
        self.solver = solver
        self.size = f"${solver}"          # read by the contract: this spec refers to another argument

    def describe(self) -> str:
        return f"a dict of options of the solver {self.solver} (see pbanim.lcp.specs.LCP_OPTIONS)"

    def check(self, name, value, env):
        if not isinstance(value, dict) or not all(isinstance(k, str) for k in value):
            raise env.fail(name, self.describe(), value)
        solver = env.resolve(self.size)
        try:
            return check_options(env.where, solver, dict(value))
        except InvalidInput as exc:       # the message names the option; say which argument holds it
            raise env.fail(name, self.describe(), value, str(exc).split(": ", 1)[-1]) from None

    def example(self, env):
        return {}

    def bad(self, env):
        out = [("a string", "x"), ("a list", [1.0]), ("a NaN max_iter", {"max_iter": float("nan")}),
               ("a negative polish", {"polish": -1})]
        if env.resolve(self.size) != "qp":       # "qp" passes other names on to its backend
            out.append(("an unknown option", {"no_such_option": 1}))
        return out

    def edges(self, env):
        return [("max_iter 1", {"max_iter": 1})]


class JacobianRows(Spec):
    """The rows of a second Jacobian K as a tuple ``(a, b, G_a, G_b)``: row i is ``G_a[i]`` on body
    ``a[i]`` and −``G_b[i]`` on body ``b[i]``; indices in 0 … n − 1 (``n`` a reference to the number of
    inverse-mass blocks), ``G_a``, ``G_b`` finite (k, d) arrays with d the width of the other rows."""

    def __init__(self, n, d: str = "d") -> None:
        self.size, self.d = n, d

    def describe(self) -> str:
        return f"a tuple (a, b, G_a, G_b) of k rows: indices in 0 … {self.size} − 1, (k, {self.d}) float arrays"

    def check(self, name, value, env):
        if not isinstance(value, (tuple, list)) or len(value) != 4:
            raise env.fail(name, self.describe(), value)
        n = int(env.resolve(self.size))
        d = env.symbols.get(self.d)
        out = []
        for label, v in zip(("a", "b"), value[:2]):
            try:
                a = np.asarray(v)
            except (TypeError, ValueError):
                raise env.fail(name, self.describe(), value, f"its {label} are not indices") from None
            if a.dtype.kind == "f" and a.size and np.isfinite(a).all() and (a == np.round(a)).all():
                a = a.astype(np.intp)
            if a.ndim != 1 or a.size and (a.dtype.kind not in "iu" or a.min() < 0 or a.max() >= n):
                raise env.fail(name, self.describe(), value, f"its {label} are not indices in 0 … {n - 1}: "
                                                             f"{short(v)}")
            out.append(a.astype(np.intp))
        k = out[0].size
        if out[1].size != k:
            raise env.fail(name, self.describe(), value, f"a has {k} rows, b {out[1].size}")
        for label, v in zip(("G_a", "G_b"), value[2:]):
            g = Array((k, d), empty=True).check(f"{name} {label}", v, env)
            out.append(g)
        return tuple(out)

    def example(self, env):
        d = env.symbols.setdefault(self.d, 3)
        return (np.zeros(1, np.intp), np.zeros(1, np.intp), np.ones((1, d)), np.ones((1, d)))

    def bad(self, env):
        n = int(env.resolve(self.size))
        a, b, ga, gb = self.example(env)
        return [("None", None), ("a string", "x"), ("three items", (a, b, ga)),
                ("an index past the end", (a + n, b, ga, gb)), ("a NaN row", (a, b, ga * np.nan, gb)),
                ("rows of the wrong width", (a, b, np.ones((1, ga.shape[1] + 1)), gb))]


class RowIndices(Indices):
    """Body indices of contact rows: an ``Indices`` (into something of ``size`` items) of shape (``rows``,),
    whose length is bound to the symbol ``rows`` of the call (the row count of the Jacobian blocks)."""

    def __init__(self, size, rows: str = "m", *, empty: bool = True) -> None:
        super().__init__(size, (None,), empty=empty)
        self.rows = rows

    def describe(self) -> str:
        return super().describe().replace("(any,)", f"({self.rows},)")

    def check(self, name, value, env):
        a = super().check(name, value, env)
        want = env.symbols.setdefault(self.rows, a.size)
        if a.size != want:
            raise env.fail(name, self.describe(), value, f"{a.size} rows where {self.rows} = {want}")
        return a

    def example(self, env):
        n = int(env.resolve(self.size))
        return np.arange(env.symbols.setdefault(self.rows, 2)) % max(n, 1)

    def bad(self, env):
        a = self.example(env)
        return super().bad(env) + [("one row too many", np.append(a, 0))]
