"""Checks of ch08_rnea_derivatives (analytical derivatives of RNEA and ABA, Carpentier & Mansard 2018) — chapter 08.

In a copy of :mod:`pbanim.articulated.derivatives` the student writes the differentiated recursions: the
forward pass (root to leaves) carries ∂v̂_i, ∂â_i, ∂f̂_i along q and q̇,

    ∂v̂_i = ⁱX_λ ∂v̂_λ + [q: (ⁱX_λ v̂_λ)× S_i;  q̇: S_i],
    ∂â_i = ⁱX_λ ∂â_λ + [q: (ⁱX_λ â_λ)× S_i;  q̇: v̂_i× S_i] − (S_i q̇_i)× ∂v̂_i,
    ∂f̂_i = I_i ∂â_i + (I_i v̂_i)‾ ∂v̂_i + v̂_i×* I_i ∂v̂_i                  (_rnea_derivatives.forward)

the backward pass (leaves to root) ∂τ_i = S_iᵀ ∂f̂_i and ∂f̂_λ += ⁱX_λᵀ ∂f̂_i + [q: ⁱX_λᵀ f̂_i‾ S_i]
(_rnea_derivatives.backward), and ABA's derivatives by the implicit-function theorem at q̈ = ABA(q, q̇, τ):
∂q̈/∂q = −H⁻¹ ∂τ/∂q, ∂q̈/∂q̇ = −H⁻¹(∂τ/∂q̇ + B), ∂q̈/∂τ = H⁻¹ (aba_derivatives.implicit). The checks compare
with centred differences of pbanim's own RNEA and ABA (which the student does not write) and with the
closed forms of a double pendulum (ORACLES L1):

=======================  ==================================================================  ======
check                    oracle                                                              id
=======================  ==================================================================  ======
rnea_dqd                 ∂τ/∂q̇ = centred differences of RNEA on a 3-D chain of four          L1
                         revolute joints (skew axes, random state)
rnea_dq                  ∂τ/∂q = centred differences of RNEA, same chain, two states          L1
double_pendulum          point masses m₁, m₂ on rods l₁, l₂: ∂τ/∂q and ∂τ/∂q̇ in closed form     L1
                         (from τ = H(q₂) q̈ + C(q₂, q̇) + g(q), written out in the check)
aba_implicit             ∂q̈/∂τ H = 𝟙 (H from CRBA); ∂q̈/∂q, ∂q̈/∂q̇ = centred differences of ABA   L1
                         with joint damping b
=======================  ==================================================================  ======

The differences use the step h = ε^(1/3) and L1's tolerance 200 h² (1 + max|∂|); the closed forms and the
identity 1e-12 relative (the reference: measured 4.2e-10 and 1.1e-9 against the differences' 2.7e-8 and 2.2e-7
bounds, 2.7e-10 for ABA's). Limiting cases: at q̇ = 0 the velocity terms vanish (a pendulum at rest has
∂τ/∂q̇ = 0); the chain is three-dimensional (skew axes) so that no term cancels by symmetry of a plane.
"""

from __future__ import annotations

import numpy as np

from .registry import CheckFailed, Mutant, array, attr, check, close

CHECKS: list = []
H_FD = float(np.finfo(float).eps) ** (1 / 3)            # the centred difference's step, ≈ 6.1e-6


def _chain(damping: float = 0.0):
    """Four links, each hanging from the one before by a revolute joint about a skew axis (3-D motion)."""
    from ..articulated import ArticulatedTree

    rng = np.random.default_rng(21)
    tree = ArticulatedTree(gravity=(0.0, 0.0, -9.81))
    for i in range(4):
        R = np.linalg.qr(rng.normal(size=(3, 3)))[0]
        R *= np.sign(np.linalg.det(R))
        Q = np.linalg.qr(rng.normal(size=(3, 3)))[0]
        tree.add(f"l{i}", i - 1, "revolute", axis=rng.normal(size=3), R=R, p=0.5 * rng.normal(size=3),
                 mass=rng.uniform(0.5, 2.0), com=0.3 * rng.normal(size=3),
                 inertia=Q @ np.diag(rng.uniform(0.2, 1.0, 3)) @ Q.T, damping=damping)
    return tree


def _state(seed: int):
    rng = np.random.default_rng(seed)
    return rng.normal(size=4), 1.5 * rng.normal(size=4), rng.normal(size=4)


def _fd(fn, x):
    """Centred differences of fn at x along each coordinate (step H_FD), as columns."""
    E = np.eye(x.size)
    return np.array([fn(x + H_FD * e) - fn(x - H_FD * e) for e in E]).T / (2 * H_FD)


def _rnea_d(mod, tree, q, qd, qdd):
    out = attr(mod, "rnea_derivatives")(tree, q, qd, qdd)
    if not isinstance(out, tuple) or len(out) != 3:
        raise CheckFailed(f"rnea_derivatives must return (∂τ/∂q, ∂τ/∂q̇, H), got {type(out).__name__}")
    return (array("rnea_derivatives(...)[0] (∂τ/∂q)", out[0], (tree.nv, tree.nv)),
            array("rnea_derivatives(...)[1] (∂τ/∂q̇)", out[1], (tree.nv, tree.nv)))


def _fd_close(what, got, want, why=""):
    # L1: 200 h² (1 + max|∂|), the centred difference's own error
    return close(what, got, want, atol=200 * H_FD ** 2 * (1.0 + float(np.abs(want).max())), why=why)


@check(CHECKS, "rnea_dqd", 25, "∂τ/∂q̇ of RNEA equals its centred differences on a 3-D chain", "L1",
       regions=("_rnea_derivatives.forward", "_rnea_derivatives.backward"))
def rnea_dqd(mod):
    from ..articulated import rnea

    tree = _chain()
    q, qd, qdd = _state(1)
    _, dqd = _rnea_d(mod, tree, q, qd, qdd)
    err = _fd_close("∂τ/∂q̇ vs centred differences of RNEA", dqd, _fd(lambda x: rnea(tree, q, x, qdd), qd),
                    why="q̇ enters through ∂v̂_i = ⁱX_λ ∂v̂_λ + S_i and the velocity products of â_i and f̂_i")
    return f"∂τ/∂q̇ on a 4-link chain (max error {err:.1e})"


@check(CHECKS, "rnea_dq", 30, "∂τ/∂q of RNEA equals its centred differences on a 3-D chain", "L1",
       regions=("_rnea_derivatives.forward", "_rnea_derivatives.backward"))
def rnea_dq(mod):
    from ..articulated import rnea

    tree = _chain()
    worst = 0.0
    for seed in (2, 3):
        q, qd, qdd = _state(seed)
        dq, _ = _rnea_d(mod, tree, q, qd, qdd)
        worst = max(worst, _fd_close(f"∂τ/∂q vs centred differences of RNEA (state {seed})", dq,
                                     _fd(lambda x: rnea(tree, x, qd, qdd), q),
                                     why="∂ⁱX_λ/∂q_i = −S_i× ⁱX_λ: the parent's v̂, â moved by (ⁱX_λ v̂_λ)× S_i, and "
                                         "ⁱX_λᵀ f̂_i‾ S_i on the way back"))
    return f"∂τ/∂q on a 4-link chain, two states (max error {worst:.1e})"


@check(CHECKS, "double_pendulum", 20, "a double pendulum's ∂τ/∂q and ∂τ/∂q̇ in closed form", "L1", public=False,
       regions=("_rnea_derivatives.forward", "_rnea_derivatives.backward"))
def double_pendulum(mod):
    from ..models.articulated import pendulum_chain

    g, (m1, m2), (l1, l2) = 9.81, (1.5, 0.7), (1.2, 0.8)
    tree = pendulum_chain(2, lengths=[l1, l2], masses=[m1, m2], g=g)
    for q, qd, qdd in (((0.4, -0.9), (1.3, -0.6), (0.5, 2.0)), ((2.0, 0.7), (-0.8, 1.9), (-1.0, 0.3))):
        (q1, q2), (w1, w2), (a1, a2) = q, qd, qdd
        dq, dqd = _rnea_d(mod, tree, np.array(q), np.array(qd), np.array(qdd))
        s2, c2, c1, c12 = np.sin(q2), np.cos(q2), np.cos(q1), np.cos(q1 + q2)
        k = m2 * l1 * l2
        # τ₁ = H₁₁ a₁ + H₁₂ a₂ − k s₂ (2w₁w₂ + w₂²) + (m₁ + m₂) g l₁ sin q₁ + m₂ g l₂ sin(q₁ + q₂)
        # τ₂ = H₁₂ a₁ + m₂ l₂² a₂ + k s₂ w₁² + m₂ g l₂ sin(q₁ + q₂),  H₁₁ = m₁l₁² + m₂(l₁² + l₂² + 2l₁l₂c₂),
        # H₁₂ = m₂(l₂² + l₁l₂c₂): q₁ from the downward vertical, q₂ relative to the first rod
        want_dqd = np.array([[-2 * k * s2 * w2, -2 * k * s2 * (w1 + w2)], [2 * k * s2 * w1, 0.0]])
        want_dq = np.array([
            [(m1 + m2) * g * l1 * c1 + m2 * g * l2 * c12,
             -k * s2 * (2 * a1 + a2) - k * c2 * (2 * w1 * w2 + w2 ** 2) + m2 * g * l2 * c12],
            [m2 * g * l2 * c12, -k * s2 * a1 + k * c2 * w1 ** 2 + m2 * g * l2 * c12]])
        close(f"∂τ/∂q̇ at q = {q}", dqd, want_dqd, atol=1e-12 * (1 + np.abs(want_dqd).max()),
              why="the Coriolis terms −k s₂(2w₁w₂ + w₂²), k s₂ w₁² differentiated")
        close(f"∂τ/∂q at q = {q}", dq, want_dq, atol=1e-12 * (1 + np.abs(want_dq).max()),
              why="gravity g(q) and the q₂-dependence of H and C differentiated")
    return "∂τ/∂q and ∂τ/∂q̇ of a double pendulum exact at two states"


@check(CHECKS, "aba_implicit", 25, "ABA's derivatives: ∂q̈/∂τ = H⁻¹ and centred differences of ABA (damped)",
       "L1", public=False, regions=("aba_derivatives.implicit", "_rnea_derivatives.forward",
                                    "_rnea_derivatives.backward"))
def aba_implicit(mod):
    from ..articulated import aba, crba

    tree = _chain(damping=0.3)
    q, qd, tau = _state(4)
    out = attr(mod, "aba_derivatives")(tree, q, qd, tau)
    if not isinstance(out, tuple) or len(out) != 3:
        raise CheckFailed(f"aba_derivatives must return (∂q̈/∂q, ∂q̈/∂q̇, ∂q̈/∂τ), got {type(out).__name__}")
    dq, dqd, dtau = (array(f"aba_derivatives(...)[{k}]", x, (4, 4)) for k, x in enumerate(out))
    close("∂q̈/∂τ · H (H from CRBA)", dtau @ crba(tree, q), np.eye(4), atol=1e-12, why="∂q̈/∂τ = H⁻¹")
    _fd_close("∂q̈/∂q̇ vs centred differences of ABA (joint damping b = 0.3)", dqd,
              _fd(lambda x: aba(tree, q, x, tau), qd), why="∂q̈/∂q̇ = −H⁻¹(∂τ/∂q̇ + B), B = diag(b)")
    err = _fd_close("∂q̈/∂q vs centred differences of ABA", dq, _fd(lambda x: aba(tree, x, qd, tau), q),
                    why="∂q̈/∂q = −H⁻¹ ∂τ/∂q at q̈ = ABA(q, q̇, τ)")
    return f"∂q̈/∂τ = H⁻¹, ∂q̈/∂q and ∂q̈/∂q̇ of a damped 4-link chain (max error {err:.1e})"


MUTANTS = (
    Mutant("motion_force_cross_swapped", "v̂×* I v̂ differentiated with the motion cross product v̂× in place of "
           "the force cross product v̂×* = −(v̂×)ᵀ",
           (("G = bar(h) - cv.T @ I", "G = bar(h) + cv @ I"),),
           ("rnea_dqd", "rnea_dq", "double_pendulum", "aba_implicit")),
    Mutant("missing_parent_velocity", "∂v̂_i/∂q_i without the moved parent velocity (ⁱX_λ v̂_λ)× S_i",
           (("dv_q[i][:, vi] += crm(vp) @ S", "dv_q[i][:, vi] += 0.0 * S"),),
           ("rnea_dq", "double_pendulum", "aba_implicit")),
    Mutant("backward_sign", "the moved transform's term in the backward pass with the wrong sign",
           (("df_q[lam][:, vi] += X.T @ bar(f[i]) @ S", "df_q[lam][:, vi] -= X.T @ bar(f[i]) @ S"),),
           ("rnea_dq", "double_pendulum", "aba_implicit")),
    Mutant("no_joint_damping", "ABA's joint damping B forgotten in ∂q̈/∂q̇ = −H⁻¹(∂τ/∂q̇ + B)",
           (("dqd = dqd + np.diag(tree.arrays()[\"damping\"])", "dqd = dqd"),),
           ("aba_implicit",)),
)
