"""The lean step of velocity-level contact with a friction pyramid (chapter 07, issue 28 point 5).

:meth:`pbanim.contact.friction.TimeStepping.step` is the readable step of the Stewart–Trinkle LCP: a padded
state dictionary, per-contact rows (:class:`pbanim.contact.assembly.ContactRows`), three Delassus blocks
assembled by :func:`pbanim.contact.friction.velocity_lcp`, the checked :func:`pbanim.lcp.solve.solve_lcp` and
an update that computes the rotations again. For a small scene (at most :data:`DENSE_BODIES` rigid bodies,
friction μ > 0, Lemke's method) :class:`LeanFriction` takes the same step with what does not change from step
to step paid once (effects, the static masks, the inertias, W's diagonal, the blocks E of the pyramid for each
contact count) and, per step, with the rotations R of y computed once (on floats up to
:data:`~pbanim.contact.lean.FLOAT_BODIES` bodies):

    ũ = (W(P + hQ_v), I⁻¹(L + hQ_ω)),   J = [J_n; D] dense (m(k+1) × 6N),   G = J W Jᵀ (one product),
    A = [[G_nn, G_nd, 0], [G_ndᵀ, ½(G_dd + G_ddᵀ), E], [diag μ, −Eᵀ, 0]],   b = [J_n ũ + s⁺/h, D ũ, 0],
    z = [p_n, β, λ] by Lemke, warm started from the last step (:func:`pbanim.lcp.solve.lean_lemke`: the readable
    route and certificate, unchecked),   u⁺ = ũ + W Jᵀ [p_n, β],   then x, q, P, L as the readable update.

The contacts come from the scene's ``detect(y)`` and are checked every step, as in the readable step. The
arithmetic is the readable step's with the Delassus blocks and the products by J in another order, so the
trajectories are equal to roundoff (``tests/test_contact_lean_friction.py``, ORACLES D21).

=========  ===============  ===========  ==================================================
symbol     code             shape        meaning
=========  ===============  ===========  ==================================================
ũ          ``u``            (6N,)        free velocity (v, ω) per body
J          ``J``            (m(k+1), 6N) normal rows, then k friction rows per contact
k          ``k``            int          facets of the friction pyramid
z          ``sol.f``        (m(k+2),)    normal impulses, friction impulses, slip multipliers
=========  ===============  ===========  ==================================================

Limiting cases: no contact → ũ (free flight); a box at rest on a level plane → Σp_n = m g h, β = 0.
"""

from __future__ import annotations

import numpy as np

from .lean import FLOAT_BODIES, _cross, advance, free_velocity
from .specs import check_contacts
from ..contracts import Obj, contract, unchecked
from ..errors import InvalidInput
from ..lcp.solve import lean_lemke, solve_lcp

__all__ = ["LeanFriction", "lean_friction_applies", "DENSE_BODIES"]

_STEPPER = Obj("pbanim.contact.friction:TimeStepping")

#: at most this many bodies: J and W dense (the lean step's products are then a few small matrix products)
DENSE_BODIES = 8
#: the solver options the lean route passes on (any other option: the readable step)
_OPTIONS = {"max_iter", "pivot_tol", "polish"}


@contract(ts=_STEPPER)
def lean_friction_applies(ts) -> bool:
    """Whether a :class:`~pbanim.contact.friction.TimeStepping` can take the lean friction step: rigid bodies
    (at most :data:`DENSE_BODIES`), some μ > 0, Lemke's method with options the lean route knows."""
    return (ts.rigid and bool(np.any(ts.mu > 0)) and ts.solver == "lemke" and ts.system.N <= DENSE_BODIES
            and set(ts.solver_options) <= _OPTIONS)


class LeanFriction:
    """The rigid step with a friction pyramid of a :class:`~pbanim.contact.friction.TimeStepping`, bound once
    (see the module docstring); ``step(t, y, h)`` sets the stepper's ``last`` and ``last_info`` as its readable
    step does."""

    @contract(ts=_STEPPER)
    def __init__(self, ts) -> None:
        from .friction import friction_directions

        s = ts.system
        N = s.N
        self.ts, self.N, self.k = ts, N, ts.facets
        self.applies = [unchecked(e.apply) for e in ts.forces]
        self.directions = unchecked(friction_directions)
        self.rotations = unchecked(ts.system.rotations)
        self.solve = unchecked(solve_lcp)
        self.opts = dict(ts.solver_options)
        self.floats = N <= FLOAT_BODIES
        self.inv_mass = s.inv_mass
        self.Ib_inv, self.Ib = s.inv_I_body, s.I_body
        self.m_live = np.where(s.static, 0.0, s.mass)[:, None]
        self.live = ~s.static[:, None]
        self.W = np.zeros((6 * N, 6 * N))                    # dense W, the diagonal 1/m set once
        idx = np.arange(N)
        for c in range(3):
            self.W[6 * idx + c, 6 * idx + c] = s.inv_mass
        self.ang = (6 * idx[:, None, None] + 3 + np.arange(3)[:, None], 6 * idx[:, None, None] + 3 + np.arange(3))
        self.xp = np.zeros((N + 1, 3))                       # padded centres (the world at 0)
        self.zero = np.zeros((N, 6))
        self._pyramid: dict[int, np.ndarray] = {}            # m → the A template with E and −Eᵀ placed
        self._last_normal, self._last_d = None, None         # the last step's normals and friction directions

    def _template(self, m: int):
        """The LCP matrix's constant blocks for m contacts: E (mk × m, ones down each contact's k rows) and −Eᵀ
        placed, the rest zero (filled per step on a copy)."""
        got = self._pyramid.get(m)
        if got is None:
            k = self.k
            mk = m * k
            E = np.kron(np.eye(m), np.ones((k, 1)))
            A0 = np.zeros((m * (k + 2), m * (k + 2)))
            A0[m:m + mk, m + mk:] = E
            A0[m + mk:, m:m + mk] = -E.T
            got = self._pyramid[m] = A0
        return got

    def _directions(self, normal):
        """The k friction directions of each contact, (mk, 3): those of the last step when the normals are the
        same numbers (a box sliding on a plane), else :func:`pbanim.contact.friction.friction_directions`."""
        last = self._last_normal
        if last is not None and last.shape == normal.shape and np.array_equal(last, normal):
            return self._last_d
        d = self.directions(normal, self.k, self.ts.tangent).reshape(-1, 3)
        self._last_normal, self._last_d = np.array(normal, dtype=float), d
        return d

    def step(self, t: float, y: np.ndarray, h: float) -> np.ndarray:
        ts, N, k = self.ts, self.N, self.k
        s = ts.system
        x, q, R, Rt, Iinv, u = free_velocity(self, t, y, h)
        contacts = ts._detect(y)
        if contacts is not None:
            check_contacts("TimeStepping", "detect(y)", contacts, s)
        m = 0 if contacts is None else len(contacts.a)
        ts.last_info = {"contacts": contacts, "m": m}
        if m:
            a = np.where(np.asarray(contacts.a) < 0, N, contacts.a)
            b = np.where(np.asarray(contacts.b) < 0, N, contacts.b)
            try:
                mu = np.broadcast_to(ts.mu, (m,))
            except ValueError:
                raise InvalidInput(f"friction has {ts.mu.size} values but detect returned {m} contacts at "
                                   f"t = {t:.6g}; give one μ, or one per contact") from None
            point, normal = contacts.point, contacts.normal
            sep = -np.asarray(contacts.depth, dtype=float)
            bias = np.where(sep > 0, sep, ts.erp * sep) / h
            d = self._directions(normal)                                        # (mk, 3)
            D = np.concatenate([normal, d])                                     # rows: normals, then k per contact
            ra = np.concatenate([a, np.repeat(a, k)])
            rb = np.concatenate([b, np.repeat(b, k)])
            pts = np.concatenate([point, np.repeat(point, k, axis=0)])
            xp = self.xp
            xp[:N] = x
            n_rows = D.shape[0]
            J = np.zeros((n_rows, 6 * N + 6))                                   # the world's six columns dropped
            rows = np.arange(n_rows)[:, None]
            J[rows, 6 * ra[:, None] + np.arange(3)] = D
            J[rows, 6 * ra[:, None] + 3 + np.arange(3)] = _cross(pts - xp[ra], D)
            J[rows, 6 * rb[:, None] + np.arange(3)] -= D
            J[rows, 6 * rb[:, None] + 3 + np.arange(3)] -= _cross(pts - xp[rb], D)
            J = J[:, :6 * N]
            W = self.W
            W[self.ang] = Iinv
            JW = J @ W
            G = JW @ J.T
            mk = m * k
            A = self._template(m).copy()
            A[:m, :m], A[:m, m:m + mk] = G[:m, :m], G[:m, m:]
            Gdd = G[m:, m:]
            A[m:m + mk, :m], A[m:m + mk, m:m + mk] = G[:m, m:].T, 0.5 * (Gdd + Gdd.T)
            A[m + mk:, :m] = np.diag(mu)
            Ju = J @ u[:N].ravel()
            bb = np.zeros(m * (k + 2))
            bb[:m] = Ju[:m] + bias
            bb[m:m + mk] = Ju[m:]
            last = ts.last
            ws = last.f if (last is not None and last.f.size == bb.size) else None
            sol = lean_lemke(A, bb, ws, ts.tol, **self.opts)
            if sol is None:                                  # not certified: the readable call names it, or returns it
                sol = self.solve(A, bb, "lemke", tol=ts.tol, warm_start=ws,
                                 raise_on_failure=not ts.accept_unconverged, **self.opts)
            ts.last = sol
            z = sol.f[:m + mk]
            imp_n = (z[:m] @ J[:m]).reshape(N, 6)
            fric = (z[m:] @ J[m:]).reshape(N, 6)
            imp = imp_n + fric
            u[:N] += (W @ imp.ravel()).reshape(N, 6)
            ts.last_info.update(normal_impulse=sol.f[:m], impulse=imp, friction_impulse=fric)
        else:
            ts.last = None
        return advance(self, x, q, R, Rt, u, h)
