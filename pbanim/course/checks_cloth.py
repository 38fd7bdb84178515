"""Checks of ch12_cloth_spring (one spring's force and its Jacobians, as a large step needs them) — chapter 12.

In a copy of :mod:`pbanim.cloth.conditions` the student writes :meth:`SpringCondition.pair_terms`: for the
springs (a, b) of a cloth, with d = x_a − x_b, ŵ = d/|d|, u = v_a − v_b, C = |d| − r, Ċ = ŵ·u,
s = k C + k_d Ċ and the projector P = (𝟙 − ŵŵᵀ)/|d|,

    f_a = −s ŵ = −f_b,     B_K = −(k ŵŵᵀ + s P + k_d ŵ (P u)ᵀ),     B_D = −k_d ŵŵᵀ,

with the element blocks K_e = ∂f_e/∂x_e = c cᵀ ⊗ B_K and D_e = ∂f_e/∂v_e = c cᵀ ⊗ B_D (c = (1, −1)); with
``exact=False`` the symmetric B_K of the large step: s clamped at 0 in front of P and the last term left out.
The checks evaluate the student's function on springs of their own (no simulation) and compare with
closed forms and with centred differences of the student's own force (ORACLES J1, J8):

=======================  ==================================================================  ======
check                    oracle                                                              id
=======================  ==================================================================  ======
spring_force             f_a = −(k(|d| − r) + k_d ŵ·u) ŵ, f_b = −f_a (Newton's third law);   J1
                         undamped, f_a = −∂E/∂x_a of E = ½ k (|d| − r)² (centred differences)
stiffness_fd             K_e = c cᵀ ⊗ B_K equals centred differences of f_e in x (damped,    J1
                         moving springs: the unsymmetric k_d ŵ (P u)ᵀ term included)
damping_fd               D_e = c cᵀ ⊗ B_D equals differences of f_e in v (f is affine in v)  J1
string_tension           a spring at rest in velocity resists along ŵ by k and sideways by   J8
                         its tension over its length, T/L = k(L − r)/L; compressed, the large
                         step's B_K keeps k ŵŵᵀ alone (s clamped at 0)
=======================  ==================================================================  ======

Limiting cases: at rest length the sideways stiffness vanishes (a slack string has none); k_d = 0 gives
B_D = 0 and a symmetric B_K. Tolerances: the differences' own error, 1e-8 relative (J1).
"""

from __future__ import annotations

import numpy as np

from .registry import CheckFailed, Mutant, array, attr, check, close

CHECKS: list = []
_DELTA = float(np.finfo(float).eps) ** (1 / 3)          # the centred difference's step (relative)


def _springs(mod, k, kd, rest):
    """The student's SpringCondition on three disjoint springs (0, 1), (2, 3), (4, 5)."""
    return attr(mod, "SpringCondition")(np.array([[0, 1], [2, 3], [4, 5]]), rest, k, kd)


def _state(seed: int):
    rng = np.random.default_rng(seed)
    return rng.normal(size=(6, 3)), rng.normal(size=(6, 3))


def _terms(cond, x, v, exact=True, damped=True):
    out = cond.pair_terms(x, v, exact)
    if not isinstance(out, tuple) or len(out) != 3:
        raise CheckFailed(f"SpringCondition.pair_terms must return (f_e, B_K, B_D), got {type(out).__name__}")
    fe = array("pair_terms(...)[0] (f_e)", out[0], (3, 6))
    BK = array("pair_terms(...)[1] (B_K)", out[1], (3, 3, 3))
    BD = None
    if damped:
        BD = array("pair_terms(...)[2] (B_D)", out[2], (3, 3, 3))
    elif out[2] is not None:
        raise CheckFailed("pair_terms(...)[2] must be None for undamped springs (k_d = 0), got an array")
    return fe, BK, BD


def _differences(cond, x, v, wrt: str) -> np.ndarray:
    """∂f_e/∂(x_e or v_e) (3, 6, 6) by centred differences of the student's f_e (the springs are disjoint, so
    moving one local coordinate of every spring at once moves each spring's own coordinate only)."""
    el = cond.elements
    out = np.zeros((3, 6, 6))
    base = x if wrt == "x" else v
    step = _DELTA * max(1.0, float(np.max(np.abs(base))))
    for q in range(6):
        plus, minus = base.copy(), base.copy()
        plus[el[:, q // 3], q % 3] += step
        minus[el[:, q // 3], q % 3] -= step
        fp = _terms(cond, plus, v)[0] if wrt == "x" else _terms(cond, x, plus)[0]
        fm = _terms(cond, minus, v)[0] if wrt == "x" else _terms(cond, x, minus)[0]
        out[:, :, q] = (fp - fm) / (2 * step)
    return out


def _blocks(B: np.ndarray) -> np.ndarray:
    """c cᵀ ⊗ B for c = (1, −1): the (6, 6) element block of each 3 × 3 block."""
    return np.einsum("ij,ekl->eikjl", np.array([[1.0, -1.0], [-1.0, 1.0]]), B).reshape(-1, 6, 6)


@check(CHECKS, "spring_force", 25, "a damped spring pulls along its axis by k(|d| − r) + k_d ŵ·u, equal and "
       "opposite on its ends; undamped, f = −∂E/∂x", "J1", regions=("SpringCondition.pair_terms",))
def spring_force(mod):
    k, kd = np.array([50.0, 200.0, 10.0]), np.array([0.5, 2.0, 0.1])
    rest = np.array([0.8, 1.5, 0.3])
    x, v = _state(12)
    fe, _, _ = _terms(_springs(mod, k, kd, rest), x, v)
    d, u = x[0::2] - x[1::2], v[0::2] - v[1::2]
    L = np.linalg.norm(d, axis=1)
    w = d / L[:, None]
    fa = -(k * (L - rest) + kd * np.sum(w * u, axis=1))[:, None] * w
    close("f_a of three damped springs", fe[:, :3], fa, rtol=1e-13, unit="N",
          why="f_a = −(k C + k_d Ċ) ŵ with C = |d| − r, Ċ = ŵ·(v_a − v_b)")
    close("f_a + f_b (Newton's third law)", fe[:, :3] + fe[:, 3:], np.zeros((3, 3)), atol=1e-13 * np.abs(fa).max(),
          unit="N")
    cond = _springs(mod, k, 0.0, rest)
    f0 = _terms(cond, x, v, damped=False)[0]
    energy = lambda xx: 0.5 * np.sum(k * (np.linalg.norm(xx[0::2] - xx[1::2], axis=1) - rest) ** 2)  # noqa: E731
    grad = np.zeros((6, 3))
    for i in range(6):
        for j in range(3):
            xp, xm = x.copy(), x.copy()
            xp[i, j] += _DELTA
            xm[i, j] -= _DELTA
            grad[i, j] = (energy(xp) - energy(xm)) / (2 * _DELTA)
    close("undamped f vs −∂E/∂x (centred differences of E = ½k(|d| − r)²)", f0.reshape(3, 2, 3),
          -grad.reshape(3, 2, 3), rtol=1e-8, unit="N")
    return "f_a closed form (rtol 1e-13), f_b = −f_a, f = −∂E/∂x (rtol 1e-8)"


@check(CHECKS, "stiffness_fd", 30, "K_e = c cᵀ ⊗ B_K is the derivative of the spring forces in x (damped, moving)",
       "J1", regions=("SpringCondition.pair_terms",))
def stiffness_fd(mod):
    worst = 0.0
    for seed, rest in ((3, np.array([0.5, 2.5, 1.0])), (8, np.array([1.2, 0.1, 3.0]))):
        x, v = _state(seed)
        cond = _springs(mod, np.array([80.0, 30.0, 300.0]), np.array([1.0, 0.4, 3.0]), rest)
        _, BK, _ = _terms(cond, x, v)
        fd = _differences(cond, x, v, "x")
        # J1: 1e-8 relative (the difference's O(δ²) error, δ = ε^(1/3)); the reference: measured 2.1e-8 N/m,
        # 1e-10 relative to max |K_e| = 230 N/m
        worst = max(worst, close(f"K_e vs centred differences of f_e in x (seed {seed})", _blocks(BK), fd,
                                 rtol=1e-8, unit="N/m", why="B_K = −(k ŵŵᵀ + s P + k_d ŵ (P u)ᵀ), P = (𝟙 − ŵŵᵀ)/|d|"))
    return f"K_e = ∂f_e/∂x_e on six damped springs (max error {worst:.1e} N/m)"


@check(CHECKS, "damping_fd", 20, "D_e = c cᵀ ⊗ B_D is the derivative of the spring forces in v", "J1",
       regions=("SpringCondition.pair_terms",))
def damping_fd(mod):
    x, v = _state(5)
    cond = _springs(mod, np.array([40.0, 20.0, 90.0]), np.array([2.0, 0.7, 5.0]), np.array([1.0, 1.0, 1.0]))
    _, _, BD = _terms(cond, x, v)
    fd = _differences(cond, x, v, "v")
    # f is affine in v: the differences are exact but for roundoff (the reference: measured 1.0e-9 N s/m)
    err = close("D_e vs centred differences of f_e in v", _blocks(BD), fd, rtol=1e-8, unit="N s/m",
                why="B_D = −k_d ŵŵᵀ, acting on the relative velocity v_a − v_b")
    return f"D_e = ∂f_e/∂v_e (max error {err:.1e} N s/m)"


@check(CHECKS, "string_tension", 25, "a stretched spring resists sideways by T/L; the large step clamps a "
       "compressed one", "J8", public=False, regions=("SpringCondition.pair_terms",))
def string_tension(mod):
    k = np.array([100.0, 100.0, 100.0])
    x = np.zeros((6, 3))
    x[1], x[3], x[5] = [2.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 0.5]     # d along −x̂, −ŷ, −ẑ: |d| = 2, 1, 0.5
    L = np.array([2.0, 1.0, 0.5])
    rest = np.array([1.0, 1.0, 1.0])                                           # stretched, slack, compressed
    axes = np.eye(3)
    for exact in (True, False):
        _, BK, _ = _terms(_springs(mod, k, 0.0, rest), x, np.zeros((6, 3)), exact, damped=False)
        for e in range(3):
            T = k[e] * (L[e] - rest[e])                                        # the spring's tension
            sideways = T / L[e] if exact else max(T, 0.0) / L[e]
            want = -k[e] * np.outer(axes[e], axes[e]) - sideways * (np.eye(3) - np.outer(axes[e], axes[e]))
            close(f"B_K of a spring with |d| = {L[e]} m, r = 1 m ({'exact' if exact else 'large step'})", BK[e], want,
                  rtol=1e-13, unit="N/m", why="−k along ŵ; sideways −T/L (a string's restoring force), 0 when "
                  "slack, and for the large step a compressed spring's −T/L > 0 is dropped")
    return "B_K = −k ŵŵᵀ − (T/L)(𝟙 − ŵŵᵀ) stretched, slack and compressed, exact and clamped"


MUTANTS = (
    Mutant("geometric_stiffness_sign", "the geometric-stiffness term s P with the wrong sign",
           (("BK -= (s if exact else np.maximum(s, 0.0))[:, None, None] * P",
             "BK += (s if exact else np.maximum(s, 0.0))[:, None, None] * P"),),
           ("stiffness_fd", "string_tension")),
    Mutant("missing_projector", "the projector 𝟙 − ŵŵᵀ missing: P = 𝟙/|d|",
           (("P = (np.eye(3) - ww) / length[:, None, None]", "P = np.eye(3) / length[:, None, None]"),),
           ("stiffness_fd", "string_tension")),
    Mutant("transposed_damping_block", "the unsymmetric damping term transposed: k_d (P u) ŵᵀ",
           (("BK -= (kd[:, None] * w)[:, :, None] * np.einsum(\"eij,ej->ei\", P, u)[:, None, :]",
             "BK -= (kd[:, None] * w)[:, None, :] * np.einsum(\"eij,ej->ei\", P, u)[:, :, None]"),),
           ("stiffness_fd",)),
    Mutant("damping_on_absolute_velocity", "damping on v_a instead of the relative velocity v_a − v_b",
           (("d, u = x[el[:, 0]] - x[el[:, 1]], v[el[:, 0]] - v[el[:, 1]]",
             "d, u = x[el[:, 0]] - x[el[:, 1]], v[el[:, 0]]"),),
           ("spring_force", "damping_fd")),
    Mutant("unclamped_compression", "the large step keeps a compressed spring's −H (M − h²K may be indefinite)",
           (("(s if exact else np.maximum(s, 0.0))", "s"),),
           ("string_tension",)),
)
