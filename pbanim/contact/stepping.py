"""Velocity-level contact with box friction, warm-started from the previous step (chapter 07).

The step of :class:`pbanim.contact.friction.TimeStepping` (Stewart–Trinkle / Anitescu–Potra) with the
friction pyramid aligned with two tangents t₁, t₂ per contact (three rows per contact, as game engines
and the box-friction PGS of :func:`pbanim.lcp.solve.pgs_box_friction` use):

    u⁺ = ũ + W Jᵀ z,   z = [fᵢ, τᵢ₁, τᵢ₂],   w = J u⁺ + [s⁺/h, 0, 0] = A z + b,   A = J W Jᵀ,
    0 ≤ fᵢ ⊥ w_fᵢ ≥ 0,   |τᵢⱼ| ≤ μ fᵢ  with  w_τᵢⱼ = 0 inside, sliding against w on the bound,

where s⁺ = s for a separation s > 0 (look-ahead) and erp·s for a penetration. J's rows are
[dᵀ, (r_a × d)ᵀ] on a and −[dᵀ, (r_b × d)ᵀ] on b for d ∈ {n, t₁, t₂} (:func:`pbanim.contact.assembly.rigid_rows`)
and A is built from them in one vectorized pass (:func:`pbanim.lcp.delassus`).

What makes it cheap while contacts persist (issue 14, part 4): every contact has a key from the
narrow phase; a contact found again starts from its previous state (on/off, stick/slide) and impulse,
matched by one binary search over the previous step's sorted keys. The rotations R of the step are
computed once and serve the narrow phase (a scene's ``detect.arrays(y, R)``, raw arrays without a second
validation), W = diag(1/m, R I⁻¹ Rᵀ) and the position update; A = J W Jᵀ comes from
:func:`pbanim.lcp.delassus` with the three rows of a contact as one block.
``solver="active_set"`` (:func:`pbanim.lcp.active_set.box_friction_active_set`) then solves one linear
system and confirms the guess — no exchanges in a resting stack; if the guess has not settled after
``max_iter`` rounds (or stops improving: sliding contacts in a dense pile make the problem non-monotone),
PGS runs from the persisted impulses, the step records the fallback, and the next 2, 4, … 64 steps
(doubling while it keeps failing) go to PGS directly (``stats["skipped"]``). ``solver="pgs"`` runs
``iterations`` Gauss–Seidel sweeps from the previous impulses (what sequential-impulse engines do); both
use the colored sweep :func:`pbanim.lcp.colored.pgs_box_friction_colored` (the readable sweep in color
order, :func:`pbanim.lcp.solve.pgs_box_friction` being the readable one).

=========  ===============  ===========  ==================================================
symbol     code             shape        meaning
=========  ===============  ===========  ==================================================
z          ``z``            (3m,)        normal and tangential impulses per contact
ũ          ``u``            (N+1, 6)     free velocity (v, ω) per body (last row: world)
erp        ``erp``          scalar       fraction of a penetration removed per step
μ          ``friction``     scalar       Coulomb coefficient (pyramid along t₁, t₂)
=========  ===============  ===========  ==================================================

Limiting cases: μ = 0 → the tangential rows stay zero and the normal rows are the frictionless LCP;
no contact → ũ; a box at rest on the ground → z_f = m g h / 4 per corner (up to the redundancy).

References: D. E. Stewart, J. C. Trinkle, IJNME 39 (1996); M. Anitescu, F. A. Potra, Nonlinear Dynamics
14 (1997); E. Catto, "Iterative dynamics with temporal coherence", GDC 2005 (warm starting).
"""

from __future__ import annotations

import time

import numpy as np

from .friction import TimeStepping
from ..collision.shapes import Contacts
from ..errors import InvalidInput, check_count, check_number
from ..geometry import tangent_basis
from ..lcp.active_set import box_friction_active_set, box_friction_residual
from ..lcp.box import box_state
from ..lcp.colored import color_groups, extend_colors, pgs_box_friction_colored
from ..lcp.rows import pgs_box_friction_rows
from ..ode.driver import MAX_STEPS, check_finite, drive, step_grid
from ..results import SimResult

__all__ = ["FrictionStepping", "STEPPING_SOLVERS", "ASSEMBLIES", "ROWS_FROM"]

STEPPING_SOLVERS = ("active_set", "pgs")
ASSEMBLIES = ("auto", "dense", "rows")
#: from this many contacts ``assembly="auto"`` sweeps on velocities: a dense A of 3m × 3m costs O(m²) to build
#: and to store (m = 3000 contacts: 650 MB) where the rows cost O(m)
ROWS_FROM = 100


class FrictionStepping(TimeStepping):
    """Box-friction velocity-level time stepping with contact persistence (see the module docstring).

    Parameters
    ----------
    system : RigidBodies
    detect : callable ``detect(y) -> (Contacts, keys)`` — keys (m,) ints, stable while a contact persists
    forces : force effects (gravity, ...)
    friction : float ≥ 0
    solver : "active_set" (default) or "pgs"
    iterations : int — PGS sweeps per step (``solver="pgs"``), or the PGS budget after an active-set fallback
    max_iter : int — active-set rounds per step before the fallback
    tol : float — residual accepted from the active-set solve (relative to max(1, ‖b‖∞))
    warm_start : bool — start from the previous step's state and impulses (False: from scratch, for
        measuring what persistence buys)
    assembly : "auto" (default), "dense" or "rows" — for ``solver="pgs"``: build A = J W Jᵀ and sweep it
        (:func:`pbanim.lcp.colored.pgs_box_friction_colored`), or sweep on the bodies' velocities without A
        (:func:`pbanim.lcp.rows.pgs_box_friction_rows`: O(m) memory and work per sweep, equal to roundoff);
        "auto" takes the rows from :data:`ROWS_FROM` contacts on
    """

    def __init__(self, system, detect, forces=(), *, friction: float = 0.5, solver: str = "active_set",
                 iterations: int = 50, max_iter: int = 20, erp: float = 0.2, tol: float = 1e-9,
                 warm_start: bool = True, assembly: str = "auto") -> None:
        super().__init__(system, detect, forces, friction=0.0, solver="lemke", erp=erp, tol=tol)
        if not self.rigid:
            raise InvalidInput("FrictionStepping steps rigid bodies (RigidBodies), got particles")
        if solver not in STEPPING_SOLVERS:
            raise InvalidInput(f"solver must be one of {STEPPING_SOLVERS}, got {solver!r}")
        self.mu = check_number("friction", friction, low=0.0)
        self.solver = solver
        self.iterations = check_count("iterations", iterations, 1, 100_000)
        self.max_iter = check_count("max_iter", max_iter, 1, 10_000)
        self.warm = bool(warm_start)
        if assembly not in ASSEMBLIES:
            raise InvalidInput(f"assembly must be one of {ASSEMBLIES}, got {assembly!r}")
        self.assembly = assembly
        self._remember(np.zeros(0, np.int64), np.zeros((0, 3), dtype=int), np.zeros(0))   # previous step: sorted keys,
        # their state rows (on/off, stick/slide) and impulses
        self.stats = {"steps": 0, "contact_steps": 0, "rounds": 0, "fallbacks": 0, "skipped": 0, "persisted": 0,
                      "contacts": 0}
        self._failures, self._skip = 0, 0     # consecutive active-set failures; steps left that skip it
        self._colors = None                   # (keys, color groups, sorted (keys, colors, a, b)) of the last PGS solve

    def _warm(self, keys, b):
        """The previous step's state rows and impulses for the contacts found again (keys matched by one
        binary search over the previous step's sorted keys; the last of equal keys wins)."""
        m = keys.size
        z0 = np.zeros((m, 3))
        pk = self._prev_keys
        if not (self.warm and pk.size):
            return None, z0.ravel()
        state0 = np.zeros((m, 3), dtype=int)
        state0[:, 0] = b[0::3] < 0
        pos = np.searchsorted(pk, keys, side="right") - 1
        hit = np.flatnonzero(pk[pos] == keys)        # pos = −1 reads the last key: equal only if it is a hit
        hit = hit[pos[hit] >= 0]
        state0[hit] = self._prev_state[pos[hit]]
        z0[hit] = self._prev_z[pos[hit]]
        self.stats["persisted"] += hit.size
        return state0, z0.ravel()

    def _remember(self, keys, state, z):
        order = np.argsort(keys, kind="stable")
        self._prev_keys, self._prev_state, self._prev_z = keys[order], state[order], z.reshape(-1, 3)[order]

    def _pgs(self, A, b, keys, z0):
        """Colored PGS from the persisted impulses; the coloring (from the contacts' bodies) is kept while the
        contacts (keys) persist."""
        return pgs_box_friction_colored(A, b, self.mu, max_iter=self.iterations, tol=self.tol,
                                        warm_start=z0 if self.warm else None, colors=self._colors_of(keys),
                                        validate=False)

    def _colors_of(self, keys):
        """The contacts' coloring (from their bodies): a persisting contact (same key, same bodies) keeps its
        color, the new ones are colored around them (:func:`pbanim.lcp.colored.extend_colors`)."""
        if self._colors is not None and np.array_equal(self._colors[0], keys):
            return self._colors[1]
        a, b = self._bodies
        color = np.full(keys.size, -1, np.intp)
        if self._colors is not None and self._colors[2][0].size and keys.size:
            pk, pcol, pa, pb = self._colors[2]          # the last step's contacts, sorted by key
            pos = np.minimum(np.searchsorted(pk, keys), pk.size - 1)
            hit = (pk[pos] == keys) & (pa[pos] == a) & (pb[pos] == b)
            first = np.zeros(keys.size, dtype=bool)
            first[np.unique(keys, return_index=True)[1]] = True      # a repeated key: its first contact only
            hit &= first
            color[hit] = pcol[pos[hit]]
        color = extend_colors(a, b, color, static=[self.system.N])
        order = np.argsort(keys, kind="stable")
        self._colors = (keys.copy(), color_groups(color), (keys[order], color[order], a[order], b[order]))
        return self._colors[1]

    def _solve_rows(self, rows, Wb, u, bias, keys):
        """PGS on the bodies' velocities (``assembly`` "rows"): (z, residual, u⁺) without A."""
        r = rows
        _, z0 = self._warm(keys, r.matvec(u) + bias)
        z, res, sweeps, u_new = pgs_box_friction_rows(r.a, r.b, r.Ga, r.Gb, Wb, u, bias, self.mu, self._colors_of(keys),
                                                      max_iter=self.iterations, tol=self.tol,
                                                      warm_start=z0 if self.warm else None)
        self.stats["rounds"] += sweeps
        self._remember(keys, box_state(z, self.mu), z)
        return z, res, u_new

    def _solve(self, A, b, keys):
        state0, z0 = self._warm(keys, b)
        pgs = lambda: self._pgs(A, b, keys, z0)  # noqa: E731
        if self.solver == "active_set" and self._skip > 0:
            self._skip -= 1                      # the active set failed on a recent step: PGS alone for now
            self.stats["skipped"] += 1
            z, res, sweeps = pgs()
            state = None
        elif self.solver == "active_set":
            z, res, rounds, state = box_friction_active_set(A, b, self.mu, state=state0, max_iter=self.max_iter,
                                                            tol=self.tol)
            self.stats["rounds"] += rounds
            if res > self.tol * max(1.0, float(np.max(np.abs(b)))):
                self.stats["fallbacks"] += 1
                # the failed guess's iterate can be far off (a singular sliding system): restart PGS from the
                # persisted impulses instead; its residual is recorded for the step, never hidden. The next
                # 2, 4, … 64 steps (doubling while it keeps failing) skip the active set.
                z, res, sweeps = pgs()
                state = None
                self._failures += 1
                self._skip = min(2 ** self._failures, 64)
            else:
                self._failures = 0
        else:
            z, res, sweeps = pgs()
            self.stats["rounds"] += sweeps
            state = None
        if state is None:
            state = box_state(z, self.mu)
        self._remember(keys, state, z)
        return z, res

    def _contacts(self, y, R):
        """(a, b, point, normal, separation, keys, Contacts) of the step: through ``detect.arrays(y, R)`` when
        the scene's narrow phase offers it (:class:`pbanim.contact.scenes.SceneDetect`: the rotations of the
        step reused, no second validation of geometry valid by construction), else through ``detect(y)``."""
        fast = getattr(self.detect, "arrays", None)
        if fast is not None and getattr(self.detect, "bodies", None) is self.system:
            a, b, p, n, sep, keys = fast(y, R)
            contacts = object.__new__(Contacts)        # the record of the step, fields as Contacts stores them
            contacts.a, contacts.b, contacts.point, contacts.normal, contacts.depth = a, b, p, n, -sep
            contacts.radius = contacts.radius_b = np.zeros(a.size)
            return a, b, p, n, sep, keys, contacts
        out = self.detect(y)
        if not (isinstance(out, tuple) and len(out) == 2):
            raise InvalidInput("detect must return (Contacts, keys) for FrictionStepping")
        contacts, keys = out
        keys = np.asarray(keys, dtype=np.int64)
        m = len(contacts.a)
        if keys.shape != (m,):
            raise InvalidInput(f"detect returned {m} contacts but keys of shape {keys.shape}")
        return contacts.a, contacts.b, contacts.point, contacts.normal, -contacts.depth, keys, contacts

    def step(self, t: float, y: np.ndarray, h: float) -> np.ndarray:
        """One step t → t + h (``self.last_info``: contacts, impulses, residual, max penetration); the
        rotations of y are computed once and reused by the narrow phase, W and the position update."""
        s = self.system
        N = s.N
        R = s.rotations(y)
        Q = self._applied(t, y)
        u, Wb, rowfn, _ = self._kinematics(y, Q, h, R)
        ca, cb, point, normal, sep, keys, contacts = self._contacts(y, R)
        m = ca.size
        self.stats["steps"] += 1
        self.last_info = {"contacts": contacts, "m": m, "residual": 0.0,
                          "penetration": float(np.max(-sep, initial=0.0))}
        if m:
            self.stats["contact_steps"] += 1
            self.stats["contacts"] += m
            a = np.where(ca < 0, N, ca)
            b = np.where(cb < 0, N, cb)
            t1, t2 = tangent_basis(normal)
            D = np.stack([normal, t1, t2], axis=1).reshape(-1, 3)
            rows = rowfn(np.repeat(a, 3), np.repeat(b, 3), np.repeat(point, 3, axis=0), D)
            bias = np.zeros(3 * m)
            bias[0::3] = np.where(sep > 0, sep, self.erp * sep) / h
            self._bodies = (a, b)
            if self.solver == "pgs" and (self.assembly == "rows" or (self.assembly == "auto" and m >= ROWS_FROM)):
                z, res, u = self._solve_rows(rows, Wb, u, bias, keys)
            else:
                A = rows.gram(rows, Wb, block=3)
                A = 0.5 * (A + A.T)
                bb = rows.matvec(u) + bias
                z, res = self._solve(A, bb, keys)
                u = u + np.einsum("nij,nj->ni", Wb, rows.rmatvec(z))
            self.last_info.update(residual=res, normal_impulse=z[0::3])
        else:
            self._remember(keys, np.zeros((0, 3), dtype=int), np.zeros(0))
        return self._advance(y, u[:N], h, R)

    def simulate(self, t_end: float, h: float, *, y0: np.ndarray | None = None, record_every: int = 1,
                 max_steps: int = MAX_STEPS) -> SimResult:
        """Fixed steps through the one driver; diagnostics per recorded step: contact count, residual, the
        deepest penetration seen by the step's narrow phase; ``stats`` counts rounds, fallbacks, persisted contacts."""
        grid = step_grid(0.0, t_end, h, max_steps=max_steps, record_every=record_every)
        y = np.array(self.system.state() if y0 is None else y0, dtype=float, copy=True)
        check_finite(y, 0.0, 0, "initial state")
        ts, ys = [0.0], [y.copy()]
        diag = {"contact_count": [0.0], "contact_residual": [0.0], "max_penetration": [0.0]}

        def record(t1, y1):
            ts.append(t1)
            ys.append(y1.copy())
            diag["contact_count"].append(float(self.last_info.get("m", 0)))
            diag["contact_residual"].append(float(self.last_info.get("residual", 0.0)))
            diag["max_penetration"].append(float(self.last_info.get("penetration", 0.0)))

        start = time.perf_counter()
        drive(self.step, grid, y, record=record, record_every=record_every)
        wall = time.perf_counter() - start
        return SimResult(t=np.array(ts), y=np.array(ys).T, status=0, wall_time=wall, method=f"box-friction {self.solver}",
                         nsteps=grid.n_steps, diagnostics={k: np.array(v, dtype=float) for k, v in diag.items()})


def check_box_friction(A, b, mu, z) -> float:
    """The certificate of a box-friction answer (for tests and benchmarks): :func:`box_friction_residual`."""
    return box_friction_residual(z, np.asarray(A) @ z + b, mu)
