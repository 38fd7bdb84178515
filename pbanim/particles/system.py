"""Particle systems and Witkin's force objects (chapter 01).

A particle system is N point masses; each force object adds its contribution to the generalized force
Q, and Newton's law for all particles at once is the first-order system

    ẋ = v,        v̇ = W Q(t, x, v),        W = M⁻¹ = diag(1/mᵢ) ⊗ I_dim,

stepped by any method of :mod:`pbanim.ode` on the flat state y = [x.ravel(), v.ravel()]. Force objects
(Witkin & Baraff's "force accumulator" design) are scene effects of phase "force" (see
:mod:`pbanim.scene`); they are vectorized over particles and springs: no Python loop per element.

=========================  ==========================================================================
force                      Qᵢ contribution and potential V
=========================  ==========================================================================
:class:`Gravity`           Qᵢ += mᵢ g                         V = −Σ mᵢ g·xᵢ
:class:`Drag`              Qᵢ += −k_d,ᵢ vᵢ                     (dissipative)
:class:`DampedSprings`     Q_a += f, Q_b −= f with f = −[k_s(l − r) + k_d l̇] d̂     V = ½ Σ k_s (l − r)²
:class:`AnchorSprings`     Qᵢ += −k_s (xᵢ − pᵢ) − k_d vᵢ        V = ½ Σ k_s |xᵢ − pᵢ|²  (pins to fixed points)
:class:`UserForce`         Q += F(t, x, v)                     V given by the user, if any
=========================  ==========================================================================

with d = x_a − x_b, l = |d|, d̂ = d/l, l̇ = (v_a − v_b)·d̂ and r the rest length.

Every force here (and a :class:`UserForce` given a ``jacobian``) provides ``jacobian(t, y)`` →
:class:`ForceJacobian` (sparse ∂Q/∂x, ∂Q/∂v), so :meth:`pbanim.scene.Scene.jac` can hand implicit methods
the exact state Jacobian. Gravity and drag also provide ``affine()`` (Q = c + d v per particle), which
lets :meth:`pbanim.scene.Scene.step` fold them into a single update v₁ = α v₀ + β.

User forces: pass ``UserForce(force)`` with ``force(t, x, v) -> (N, dim)`` (optionally ``potential(x)``
and ``jacobian(t, x, v)``), or subclass :class:`pbanim.scene.Effect` with ``name``, ``phase = "force"``,
``bind(system)`` and ``apply(t, y, Q)`` adding into Q in place (``system.unpack(y)`` gives x, v).

Notation
--------
==========  ================  ===================  ==================================================
symbol      code              shape                meaning
==========  ================  ===================  ==================================================
x, v        ``x, v``          (N, dim)             positions, velocities (views into y)
m, W        ``m, W``          (N,)                 masses, inverse masses W = 1/m
Q           ``Q``             (N, dim)             total generalized (applied) force
g           ``g``             (dim,)               gravitational acceleration
k_d         ``kd``            scalar or (N,)       viscous drag coefficient
(a, b)      ``pairs``         (S, 2)               spring end points
k_s, k_d    ``ks, kd``        (S,)                 spring stiffness and damping
r           ``rest``          (S,)                 spring rest lengths
∂Q/∂x       ``dQdx``          sparse (N·dim)²      force Jacobians (implicit methods, Baraff–Witkin 1998)
==========  ================  ===================  ==================================================

Limiting cases
--------------
* One particle under gravity and drag: v(t) = v_T + (v₀ − v_T) e^(−k t/m), v_T = m g / k (ORACLES A8
  without drag: free fall, exact for RK2+ and Verlet).
* Two masses on one undamped spring oscillate at ω = √(k (m₁ + m₂)/(m₁ m₂)) about their fixed centre of
  mass; internal forces conserve linear and angular momentum (ORACLES A7).
* k_s → ∞ makes the system stiff: explicit methods need h ω < 2 (ORACLES A2); implicit Euler with the
  analytic Jacobian stays bounded at any h.

References
----------
A. Witkin, D. Baraff, *Physically Based Modeling* (SIGGRAPH course notes 2001), "Particle System
Dynamics" and "Differential Equation Basics". D. Baraff, A. Witkin, "Large Steps in Cloth Simulation",
SIGGRAPH 1998 (implicit Euler with the spring Jacobians).
"""

from __future__ import annotations

from typing import Any

import numpy as np
import scipy.sparse as sp

from .forces import AnchorSprings, UserForce
from .specs import Buffer, IndexArray, point
from .springs import _per_spring as _per_particle
from .springs import DampedSprings, ForceJacobian, bilinear, spring_forces_loop
from ..bodies import Bodies
from ..contracts import Array, Int, Obj, Opt, Real, contract, finite_result
from ..scene import Effect
from ..errors import InvalidInput, as_floats, check_result

__all__ = ["ParticleSystem", "ForceJacobian", "Gravity", "Drag", "DampedSprings", "AnchorSprings", "UserForce",
           "spring_forces_loop"]

_POSITIONS = point("N")
_Y = Array(("self.n_state",))
_XV = Array(("self.N", "self.dim"))
_POINTS = Array(("k", 3), empty=True)
_T = Real()
_SYS_Y = Array(("self.system.n_state",))
_SYS_Q = Buffer(("self.system.N", "self.system.dim"))
_BODIES = IndexArray(("k",), size="self.N", world=True, empty=True, what="particle indices")


def _block_rows(env) -> int:
    """Rows hi − lo of kick_drift's force block (lo and hi checked together: 0 ≤ lo ≤ hi ≤ N)."""
    ps, lo, hi = env.values["self"], env.values.get("lo", 0), env.values.get("hi")
    hi = ps.N if hi is None else hi
    if not 0 <= lo <= hi <= ps.N:
        raise env.fail("lo and hi", f"0 <= lo <= hi <= N = {ps.N}", (lo, hi))
    return hi - lo


class ParticleSystem(Bodies):
    """N point masses in 2-D or 3-D: the mechanical-system protocol of :mod:`pbanim.scene` and the body
    protocol of :mod:`pbanim.bodies` (u = v, W = 1/m per particle; points move with their particle).

    Parameters
    ----------
    positions : array_like, shape (N, dim), dim ∈ {2, 3}
    velocities : array_like, shape (N, dim), optional
        Zero if omitted.
    masses : float or array_like, shape (N,)
        Positive masses.

    Examples
    --------
    >>> ps = ParticleSystem([[0.0, 0.0], [1.0, 0.0]], [[0.0, 1.0], [0.0, -1.0]], masses=[1.0, 3.0])
    >>> ps.N, ps.dim, ps.split
    (2, 2, 4)
    >>> y = ps.state(); x, v = ps.unpack(y); x.shape
    (2, 2)
    >>> ps.linear_momentum(y), ps.kinetic_energy(y)
    (array([ 0., -2.]), 2.0)
    """

    @contract(positions=_POSITIONS, velocities=Opt(_POSITIONS), masses=Array(("N",), gt=0, scalar=True))
    def __init__(self, positions: Any, velocities: Any = None, masses: Any = 1.0) -> None:
        x = as_floats("positions", positions, ndmin=2)
        v = np.zeros_like(x) if velocities is None else as_floats("velocities", velocities, ndmin=2)
        if v.shape != x.shape:      # one condition on two arguments (the contract checks each alone)
            raise InvalidInput(f"ParticleSystem: velocities must have the shape of positions {x.shape}, got {v.shape}")
        m = as_floats("masses", masses)
        # values built inside pbanim (models, reduced coordinates) arrive unchecked: the contract once more
        if x.ndim != 2 or x.shape[1] not in (2, 3) or not len(x) or m.shape not in ((), (len(x),)) or not (
                np.isfinite(x).all() and np.isfinite(v).all() and np.isfinite(m).all() and (m > 0).all()):
            raise InvalidInput(f"ParticleSystem: positions and velocities must be finite arrays of shape (N, 2) or "
                               f"(N, 3) and masses positive and finite, got shapes {x.shape} and {v.shape} and "
                               f"masses {m.ravel()[:4]}")
        m = np.broadcast_to(m, (x.shape[0],)).copy()
        self.x0, self.v0, self.m = x, v, m
        self.N, self.dim = x.shape
        self.split = self.N * self.dim
        with np.errstate(over="ignore"):
            self.W = 1.0 / m
        if not np.all(np.isfinite(self.W)):
            raise InvalidInput(f"ParticleSystem: masses must be positive, got {m[~np.isfinite(self.W)][0]}, too small "
                               "for its inverse 1/m to be finite; use a larger mass (or other units)")
        self._Wflat = np.repeat(self.W, self.dim)  # W per component: flat operands keep numpy's loops long
        self._h_cached, self._hW = None, None

    # -- state -----------------------------------------------------------------------------------
    @property
    def n_state(self) -> int:
        """Length of the flat state y = [x, v]: 2·N·dim."""
        return 2 * self.split

    def state(self) -> np.ndarray:
        """A fresh flat state y = [x.ravel(), v.ravel()]."""
        return np.concatenate([self.x0.ravel(), self.v0.ravel()])

    @contract(x=_XV, v=_XV)
    def pack(self, x: Any, v: Any) -> np.ndarray:
        """Flat state from positions and velocities of shape (N, dim)."""
        return np.concatenate([np.asarray(x, float).reshape(-1), np.asarray(v, float).reshape(-1)])

    @contract(y=_Y)
    def unpack(self, y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Views x, v of shape (N, dim) into a flat state y."""
        return y[: self.split].reshape(self.N, self.dim), y[self.split:].reshape(self.N, self.dim)

    def zero_forces(self) -> np.ndarray:
        return np.zeros((self.N, self.dim))

    @contract(y=_Y, Q=_XV)
    def derivative(self, y: np.ndarray, Q: np.ndarray) -> np.ndarray:
        """dy/dt = [v, W Q]."""
        # BEGIN SOLUTION ParticleSystem.derivative
        dy = np.empty_like(y)
        dy[: self.split] = y[self.split:]
        np.multiply(Q.reshape(-1), self._Wflat, out=dy[self.split:])
        return dy
        # END SOLUTION

    @contract(y=_Y, Q=Buffer((_block_rows, "self.dim")), h=Real(gt=0), out=Buffer(("self.n_state",), finite=False),
              lo=Int(ge=0), hi=Opt(Int(ge=0)))
    def kick_drift(self, y: np.ndarray, Q: np.ndarray, h: float, out: np.ndarray, lo: int = 0,
                   hi: int | None = None) -> np.ndarray:
        """Symplectic Euler for particles lo:hi from their force Q (shape (hi − lo, dim), overwritten).

        Writes v₁ = v₀ + (h W) Q and x₁ = x₀ + h v₁ into ``out``: the kick-then-drift of
        :func:`pbanim.ode.symplectic_euler_step` on :meth:`derivative` (equal to roundoff; h W is cached
        per h), in four passes with no temporaries — the lean path of :meth:`pbanim.scene.Scene.step`.
        """
        # BEGIN SOLUTION ParticleSystem.kick_drift
        hi = self.N if hi is None else hi
        if h != self._h_cached:
            self._hW, self._h_cached = h * self._Wflat, h
        s, d = self.split, self.dim
        i, j = lo * d, hi * d
        a = np.multiply(Q.reshape(-1), self._hW[i:j], out=Q.reshape(-1))
        vo = out[s + i: s + j]
        np.add(y[s + i: s + j], a, out=vo)
        np.multiply(vo, h, out=a)
        np.add(y[i:j], a, out=out[i:j])
        return out
        # END SOLUTION

    def _float_plan(self, scene):
        """The float symplectic Euler of a small scene (:mod:`pbanim.particles.lean`; :func:`~pbanim.scene.plans.float_plan`)."""
        from .lean import float_plan
        return float_plan(scene)

    # -- diagnostics -------------------------------------------------------------------------------
    @contract(y=_Y)
    def kinetic_energy(self, y: np.ndarray) -> float:
        """T = ½ Σ mᵢ |vᵢ|²."""
        _, v = self.unpack(y)
        return float(0.5 * np.einsum("i,ij,ij->", self.m, v, v))

    @contract(y=_Y)
    def linear_momentum(self, y: np.ndarray) -> np.ndarray:
        """P = Σ mᵢ vᵢ, shape (dim,) (±inf when it exceeds the double range, never NaN)."""
        _, v = self.unpack(y)
        return bilinear(np.matmul, self.m, v)

    @contract(y=_Y)
    def angular_momentum(self, y: np.ndarray) -> np.ndarray:
        """L = Σ xᵢ × mᵢ vᵢ about the origin: shape (3,) in 3-D, (1,) (the z part) in 2-D (±inf when it
        exceeds the double range, never NaN)."""
        x, v = self.unpack(y)
        return bilinear(self._moment, x, v)

    def _moment(self, x: np.ndarray, v: np.ndarray) -> np.ndarray:
        p = self.m[:, None] * v
        if self.dim == 2:
            return np.array([np.sum(x[:, 0] * p[:, 1] - x[:, 1] * p[:, 0])])
        return np.cross(x, p).sum(axis=0)

    # -- body protocol (pbanim.bodies): u = v, Wᵢ = Iᵈ/mᵢ, an impulse j on particle i adds j/mᵢ to vᵢ ---------
    kind = "particles"

    @property
    def dof(self) -> int:
        return self.dim

    @contract(y=_Y)
    def generalized_velocity(self, y: np.ndarray) -> np.ndarray:
        return self.unpack(y)[1]

    @contract(y=_Y)
    def inverse_mass_blocks(self, y: np.ndarray) -> np.ndarray:
        return self.W[:, None, None] * np.eye(self.dim)

    @contract(y=_Y, G=_XV)
    def apply_inverse_mass(self, y: np.ndarray, G: np.ndarray) -> np.ndarray:
        return self.W[:, None] * np.asarray(G, dtype=float)

    @contract(y=_Y, body_idx=_BODIES, points_world=_POINTS)
    def point_velocity(self, y: np.ndarray, body_idx, points_world) -> np.ndarray:
        i = np.asarray(body_idx, dtype=np.intp)
        v3 = np.zeros((self.N + 1, 3))
        v3[:self.N, :self.dim] = self.unpack(y)[1]
        return v3[np.where(i < 0, self.N, i)]

    @contract(y=_Y, body_idx=_BODIES, points_world=_POINTS, impulses=_POINTS)
    def apply_impulses(self, y: np.ndarray, body_idx, points_world, impulses) -> np.ndarray:
        i = np.asarray(body_idx, dtype=np.intp)
        j = np.asarray(impulses, dtype=float).reshape(-1, 3)
        dv = np.zeros((self.N + 1, 3))
        W = np.append(self.W, 0.0)
        k = np.where(i < 0, self.N, i)
        np.add.at(dv, k, W[k, None] * j)
        y_new = np.array(y, dtype=float, copy=True)
        y_new[self.split:] += dv[:self.N, :self.dim].ravel()
        return check_result("apply_impulses", y_new, "the velocity change overflows the double range")

    @contract(y=_Y)
    def center_of_mass(self, y: np.ndarray) -> np.ndarray:
        """Σ mᵢ xᵢ / Σ mᵢ, shape (dim,)."""
        x, _ = self.unpack(y)
        w = self.m / self.m.max()
        return bilinear(np.matmul, w, x) / w.sum()


class Gravity(Effect):
    """Uniform gravity: Qᵢ += mᵢ g; potential V = −Σ mᵢ g·xᵢ.

    Parameters
    ----------
    g : array_like, shape (dim,), optional
        Default (0, −9.81) in 2-D, (0, 0, −9.81) in 3-D (m/s²).

    Examples
    --------
    >>> from pbanim.scene import Scene
    >>> ps = ParticleSystem([[0.0, 0.0]], masses=2.0)
    >>> Scene(ps, [Gravity([0.0, -10.0])]).forces(0.0, ps.state())
    array([[  0., -20.]])
    """

    name = "gravity"
    phase = "force"
    linear = True       # Q = c + K_x x + K_v v, constant: a small scene steps by its linear map

    @contract(g=Opt(point()))
    def __init__(self, g: Any = None) -> None:
        self.g_in = g

    @contract(system=Obj(ParticleSystem))
    def bind(self, system: Any) -> None:
        dim = system.dim
        g = (np.array([0.0, -9.81] if dim == 2 else [0.0, 0.0, -9.81]) if self.g_in is None
             else as_floats("g", self.g_in))
        if g.shape != (dim,):
            raise InvalidInput(f"g must have shape ({dim},) for a {dim}-D system, got {g.shape}")
        if not np.all(np.isfinite(g)):
            raise InvalidInput(f"g must be finite, got {g}")
        self.g, self.system = g, system
        self._mg = system.m[:, None] * g

    @contract(t=_T, y=_SYS_Y, Q=_SYS_Q)
    def apply(self, t: float, y: np.ndarray, Q: np.ndarray) -> None:
        # BEGIN SOLUTION Gravity.apply
        Q += self._mg
        # END SOLUTION

    def affine(self) -> tuple[np.ndarray, None]:
        """Q = c + d v with c = m g, d = 0 (lets :class:`pbanim.scene.Scene` fold it into one update)."""
        return self._mg, None

    @contract(y=_SYS_Y, returns=finite_result)     # huge coordinates of mixed signs: inf − inf
    def potential_energy(self, y: np.ndarray) -> float:
        # BEGIN SOLUTION Gravity.potential_energy
        x, _ = self.system.unpack(y)
        return float(-np.sum(self._mg * x))
        # END SOLUTION

    @contract(t=_T, y=_SYS_Y)
    def jacobian(self, t: float, y: np.ndarray) -> ForceJacobian:
        return ForceJacobian(None, None)

    @contract(t=_T, y=_SYS_Y)
    def diagnostics(self, t: float, y: np.ndarray) -> dict[str, float]:
        return {"V_gravity": self.potential_energy(y)}


class Drag(Effect):
    """Viscous drag Qᵢ += −k_d,ᵢ vᵢ (Witkin's "viscous drag"; dissipates T at rate Σ k_d |vᵢ|²).

    Parameters
    ----------
    damping : float or array_like, shape (N,)
        Drag coefficient k_d ≥ 0 (N·s/m), one for all particles or one each.

    Examples
    --------
    >>> from pbanim.scene import Scene
    >>> ps = ParticleSystem([[0.0, 0.0]], [[2.0, 0.0]])
    >>> Scene(ps, [Drag(0.5)]).forces(0.0, ps.state())
    array([[-1., -0.]])
    """

    name = "drag"
    phase = "force"
    linear = True       # Q = c + K_x x + K_v v, constant: a small scene steps by its linear map

    @contract(damping=Array((None,), ge=0, scalar=True))
    def __init__(self, damping: Any = 0.1) -> None:
        self.damping_in = damping

    @contract(system=Obj(ParticleSystem))
    def bind(self, system: Any) -> None:
        self.system = system
        self.kd = _per_particle(self.damping_in, system.N, "damping", "use a drag coefficient k_d >= 0")
        self._kdflat = np.repeat(self.kd, system.dim)
        self._scalar = bool(np.all(self.kd == self.kd[0]))
        self._k0 = float(self.kd[0])

    @contract(t=_T, y=_SYS_Y, Q=_SYS_Q)
    def apply(self, t: float, y: np.ndarray, Q: np.ndarray) -> None:
        # BEGIN SOLUTION Drag.apply
        _, v = self.system.unpack(y)
        if self._scalar:
            Q -= self._k0 * v
        elif Q.flags.c_contiguous and v.flags.c_contiguous:   # flat operands: long numpy loops
            Qf = Q.reshape(-1)
            Qf -= self._kdflat * v.reshape(-1)
        else:
            Q -= self.kd[:, None] * v
        # END SOLUTION

    def affine(self) -> tuple[None, np.ndarray]:
        """Q = c + d v with c = 0, d = −k_d (lets :class:`pbanim.scene.Scene` fold it into one update)."""
        return None, -self.kd

    @contract(t=_T, y=_SYS_Y)
    def jacobian(self, t: float, y: np.ndarray) -> ForceJacobian:
        n = self.system.N * self.system.dim
        return ForceJacobian(None, sp.diags(-np.repeat(self.kd, self.system.dim), shape=(n, n), format="csr"))
