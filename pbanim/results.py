"""Result objects: named fields, never bare tuples.

``SimResult`` mirrors scipy's ``OdeResult`` (``t``, ``y`` of shape (n, len(t)), ``nfev``, ``njev``, ``nlu``,
``status``, ``message``, ``success``) so a student can compare a pbanim trajectory with
``scipy.integrate.solve_ivp`` field by field, and adds ``wall_time``, ``method`` and, for scenes,
per-step ``diagnostics`` (a dict of arrays aligned with ``t``).

``ContactSolution`` mirrors qpsolvers' ``Solution``: it carries the forces and computes its own
complementarity residuals from A and b, so a solution can always be checked, whatever solver made it.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from .contracts import Anything, Array, Func, contract

__all__ = ["SimResult", "ContactSolution", "natural_map_residual", "LazyDiagnostics"]


class LazyDiagnostics(dict):
    """The diagnostics of a run, computed from its recorded states the first time they are read.

    ``LazyDiagnostics(compute)``: ``compute()`` returns the dict of per-recorded-time series (energies, momenta,
    constraint error …). A run that records its states but nobody reads their energy pays nothing for it; a
    reader sees an ordinary dict (``res.diagnostics["energy"]``, ``in``, ``keys()``, iteration, ``len``).
    """

    @contract(compute=Func())
    def __init__(self, compute) -> None:
        super().__init__()
        self._compute = compute

    def _fill(self) -> None:
        if self._compute is not None:
            compute, self._compute = self._compute, None
            super().update(compute())

    @property
    def computed(self) -> bool:
        """Whether the series have been computed (read) yet."""
        return self._compute is None

    def __getitem__(self, key):
        self._fill()
        return super().__getitem__(key)

    def __contains__(self, key) -> bool:
        self._fill()
        return super().__contains__(key)

    def __iter__(self):
        self._fill()
        return super().__iter__()

    def __len__(self) -> int:
        self._fill()
        return super().__len__()

    def __repr__(self) -> str:
        self._fill()
        return super().__repr__()

    def __eq__(self, other) -> bool:
        self._fill()
        return super().__eq__(other)

    __hash__ = None

    @contract(key=Anything("a diagnostic's name (any hashable, as for a dict)"),
              default=Anything("what a missing name gives, as for a dict"))
    def get(self, key, default=None):
        self._fill()
        return super().get(key, default)

    def keys(self):
        self._fill()
        return super().keys()

    def items(self):
        self._fill()
        return super().items()

    def values(self):
        self._fill()
        return super().values()

    def copy(self) -> dict:
        self._fill()
        return dict(self)


@dataclass
class SimResult:
    """Outcome of :func:`pbanim.solve` or :meth:`pbanim.Scene.simulate`.

    Attributes
    ----------
    t : ndarray, shape (n_points,)
    y : ndarray, shape (n, n_points) — or (K, n, n_points) in batch mode
    nfev, njev, nlu : int
        Right-hand-side evaluations, Jacobian evaluations, LU factorizations.
    status : int
        0 reached the end, 1 a terminal event fired, -1 failed (see ``message``).
    message : str
    success : bool
        ``status >= 0``.
    wall_time : float
        Seconds spent in the solver loop (``time.perf_counter``).
    method : str
    t_events, y_events : list of ndarray, or None
        As in scipy: for each event, the times (and states) where it fired.
    nsteps, nrejected : int
        Accepted and rejected steps.
    diagnostics : dict[str, ndarray]
        Per-recorded-step diagnostics (energies, momenta, constraint error, λ, ...).
    """

    t: np.ndarray
    y: np.ndarray
    nfev: int = 0
    njev: int = 0
    nlu: int = 0
    status: int = 0
    message: str = "The solver successfully reached the end of the integration interval."
    wall_time: float = 0.0
    method: str = ""
    t_events: list | None = None
    y_events: list | None = None
    nsteps: int = 0
    nrejected: int = 0
    diagnostics: dict[str, np.ndarray] = field(default_factory=dict)

    @property
    def success(self) -> bool:
        return self.status >= 0

    def __repr__(self) -> str:  # short, like scipy's
        shape = getattr(self.y, "shape", None)
        return (f"SimResult(method={self.method!r}, status={self.status}, success={self.success}, "
                f"t=[{self.t[0] if len(self.t) else ''}..{self.t[-1] if len(self.t) else ''}] ({len(self.t)} points), "
                f"y.shape={shape}, nfev={self.nfev}, wall_time={self.wall_time:.3g}s)")


@contract(f=Array(("m",), empty=True), w=Array(("m",), empty=True))
def natural_map_residual(f: np.ndarray, w: np.ndarray) -> float:
    """‖f − max(0, f − w)‖∞ for the LCP w = A f + b ≥ 0, f ≥ 0, fᵀw = 0.

    Zero exactly at a solution, whatever the solution's uniqueness: the right judge of a
    complementarity answer (ORACLES D8).

    >>> natural_map_residual(np.array([1.0, 0.0]), np.array([0.0, 2.0]))
    0.0
    """
    f = np.asarray(f, dtype=float)
    w = np.asarray(w, dtype=float)
    if f.size == 0:
        return 0.0
    return float(np.abs(f - np.maximum(0.0, f - w)).max())


@dataclass
class ContactSolution:
    """Contact forces f for the LCP  w = A f + b ≥ 0,  f ≥ 0,  fᵀ w = 0, with their certificate.

    Attributes
    ----------
    f : ndarray, shape (m,)
        Contact force magnitudes (or impulses, for velocity-level schemes).
    solver : str
    status : str
        The solver's own status string.
    success : bool
    iterations : int
    time : float
        Seconds spent in the solver.
    A, b : ndarray
        The problem, kept so the residuals below are computed, not reported.
    extra : dict
        Anything solver-specific (friction parts, pivots, ...).
    """

    f: np.ndarray
    solver: str
    status: str
    success: bool
    iterations: int = 0
    time: float = 0.0
    A: np.ndarray | None = None
    b: np.ndarray | None = None
    extra: dict[str, Any] = field(default_factory=dict)

    def __post_init__(self) -> None:
        # the solution owns its arrays: the caller's A, b (and f) are never aliased, so nothing done to
        # the solution (certificates, warm starts) can change them, and changing them cannot change it
        self.f = np.array(self.f, dtype=float)
        self.A = None if self.A is None else np.array(self.A, dtype=float)
        self.b = None if self.b is None else np.array(self.b, dtype=float)

    @property
    def w(self) -> np.ndarray:
        """Relative normal accelerations (or velocities) w = A f + b."""
        return self.A @ self.f + self.b

    @property
    def residual(self) -> float:
        """Natural-map residual ‖f − max(0, f − w)‖∞."""
        return natural_map_residual(self.f, self.w)

    @property
    def min_f(self) -> float:
        return float(np.min(self.f)) if self.f.size else 0.0

    @property
    def min_w(self) -> float:
        return float(np.min(self.w)) if self.f.size else 0.0

    @property
    def complementarity(self) -> float:
        """|fᵀ w|."""
        return float(abs(self.f @ self.w)) if self.f.size else 0.0
