"""Checks of ch10_contact_sensitivity (∂S/∂u through one velocity-level contact step, on its active set) — chapter 10.

In a copy of :mod:`pbanim.design.stepped_sim` the student writes the linear system that the tangent δz of the
contact impulses z = (λ, τ₁, τ₂) solves on the step's active set (contact_step.active_set): one row per
impulse component, K δz = r with

==============  =========================================  ==============================================
contact mode    rows of K                                  r
==============  =========================================  ==============================================
separating      δλ = δτ₁ = δτ₂ = 0 (identity rows)          0
sticking        the rows of A (w_n = w_τ₁ = w_τ₂ = 0)       −δw|_z, w's change at fixed z
sliding τⱼ      the normal row of A;  δτⱼ − σⱼ μ δλ         −δw_n|_z;  σⱼ λ δμ
==============  =========================================  ==============================================

solved in least squares (``dz``, rows (p, 3m), one per parameter; δw|_z is ``dwz``). Everything else of the
step is given: the contact solve itself (chapter 07), δw|_z and the smooth map from δz to the state's tangent.
The checks run the student's step on a sphere (radius ρ, mass m, I = ⅖mρ²) at a plane, in the three modes,
and compare its tangents T⁺ (rows: x, P, L, φ of the start state and μ) with centred differences of the same
step (its forward part is given) where the active set is constant, and with closed forms (ORACLES L2, L6):

=======================  ==================================================================  ======
check                    oracle                                                              id
=======================  ==================================================================  ======
sliding_fd               T⁺ = centred differences of the step, a sphere sliding both ways     L2
                         (σ₁ = −1, σ₂ = +1) with μ = 0.2
sticking_fd              T⁺ = centred differences of the step, a sphere that sticks (μ = 0.8)  L2
sliding_closed_form      sliding: ∂P⁺_t/∂μ = σ λ t, ∂P⁺_t/∂P_t = 𝟙 (the cone's bound does not   L6
                         depend on the speed), ∂P⁺_t/∂P_n = −σ μ, with λ = m(v_n⁺ − ũ_n)
sticking_closed_form     sticking: the contact point stops, P⁺_t = P_t − (2/7) m v_c:            L6
                         ∂P⁺_t/∂P_t = 5/7, ∂L⁺/∂P_t = (2/7) ρ n × ·, ∂P⁺_n/∂x_n = −m erp/h
separating               flying clear: T⁺ = the free flight's [δx + h δP/m, δφ + h δL/I, δP, δL]  L2
=======================  ==================================================================  ======

Tolerances: the differences, 1e-8 relative to max|T⁺| (on a fixed active set the step is smooth and nearly
linear: no Richardson needed, the error is the difference's roundoff, measured 7e-13 relative; L2's bound for
a whole run is 1e-6); the closed forms 3κ̄ with κ̄ = 10⁻⁶ (1 + mρ²/I) = 3.5e-6, the relative change of the
impulses by the compliance κ = 10⁻⁶ max Aᵢᵢ that the step adds (measured 3.5e-6). Limiting cases: μ = 0
makes τ = 0 and the sliding rows δτⱼ = 0; a separating contact has no rows but its identity.
"""

from __future__ import annotations

import numpy as np

from .registry import CheckFailed, Mutant, array, attr, check, close

CHECKS: list = []
G, RHO, M, H_STEP = 9.81, 0.1, 2.0, 0.01
INERTIA = 0.4 * M * RHO ** 2
DELTA = float(np.finfo(float).eps) ** (1 / 3)
KAPPA = 1e-6 * (1 + M * RHO ** 2 / INERTIA)     # the compliance's relative effect on the impulses (max Aᵢᵢ = 3.5/m)


def _scene():
    from ..collision import Plane, Sphere
    from ..design.scene import DesignBody
    from ..design.stepped import ContactScene

    return ContactScene(DesignBody(Sphere(RHO), mass=M), [Plane([0, 0, 1])], gravity=[0, 0, -G])


def _state(gap: float, v, omega) -> np.ndarray:
    """[x, q, P, L] of the sphere with its lowest point ``gap`` above the plane (negative: penetrating)."""
    return np.concatenate([[0.3, -0.2, RHO + gap], [1.0, 0, 0, 0], M * np.asarray(v, float),
                           INERTIA * np.asarray(omega, float)])


def _step(mod, scene, y, mu, T=None, dmu=None):
    out = attr(mod, "contact_step")(scene, y, T, mu, dmu, H_STEP)
    if not isinstance(out, tuple) or len(out) != 3:
        raise CheckFailed(f"contact_step must return (y⁺, T⁺, StepInfo), got {type(out).__name__}")
    return out


def _tangents(mod, scene, y, mu, mode: int):
    """T⁺ (13, 12) of the student's step for the 12 state directions (x, φ, P, L) and μ, after checking the
    contact's mode (0 separating, 1 sticking, 2 sliding)."""
    T = np.vstack([np.eye(12), np.zeros((1, 12))])
    dmu = np.zeros(13)
    dmu[12] = 1.0
    _, T1, info = _step(mod, scene, y, mu, T, dmu)
    modes = np.asarray(getattr(info, "modes", [-1]))
    if modes.tolist() != [mode]:
        raise CheckFailed(f"the step's contact mode is {modes.tolist()}, expected [{mode}] (given code: do not change "
                          "the contact solve)")
    return array("contact_step(...)[1] (T⁺)", T1, (13, 12))


def _rotvec(q) -> np.ndarray:
    """The rotation vector of a unit quaternion (w, v)."""
    w, v = q[0], np.asarray(q[1:])
    s = float(np.linalg.norm(v))
    return v * (2.0 * np.arctan2(s, w) / s if s > 0 else 2.0)


def _differences(mod, scene, y, mu) -> np.ndarray:
    """Centred differences (13, 12) of the step's y⁺ in the tangent coordinates, along the 12 state
    directions (the rotation as q ← exp(δφ) ⊗ q) and μ."""
    from ..rigid import quat_exp, quat_multiply

    def moved(k, d):
        yy = y.copy()
        if k == 12:
            return yy, mu + d
        e = np.zeros(3)
        e[k % 3] = d
        if 3 <= k < 6:
            yy[3:7] = quat_multiply(quat_exp(e), y[3:7])
        else:
            off = {0: 0, 2: 7, 3: 10}[k // 3]
            yy[off:off + 3] += e
        return yy, mu

    out = np.zeros((13, 12))
    for k in range(13):
        (yp, mp), (ym, mm) = moved(k, DELTA), moved(k, -DELTA)
        a = array("contact_step(...)[0] (y⁺)", _step(mod, scene, yp, mp)[0], (13,))
        b = array("contact_step(...)[0] (y⁺)", _step(mod, scene, ym, mm)[0], (13,))
        rel = quat_multiply(a[3:7], b[3:7] * np.array([1.0, -1.0, -1.0, -1.0]))      # q⁺(+δ) ⊗ q⁺(−δ)⁻¹
        out[k] = np.concatenate([a[:3] - b[:3], _rotvec(rel), a[7:10] - b[7:10], a[10:] - b[10:]]) / (2 * DELTA)
    return out


def _fd_check(mod, mu, y, mode, label):
    scene = _scene()
    T1 = _tangents(mod, scene, y, mu, mode)
    fd = _differences(mod, scene, y, mu)
    # the difference's roundoff: 1e-8 relative to max |T⁺| (the reference: measured 2.8e-11 of 40, 7e-13 relative)
    return close(f"T⁺ vs centred differences of the step ({label})", T1, fd, atol=1e-8 * np.abs(fd).max(),
                 why="on a fixed active set: sticking rows A δz = −δw|_z, sliding rows δτⱼ − σⱼμ δλ = σⱼλ δμ")


_SLIDING = (-1e-4, [1.0, -0.5, -0.2], [0.5, 1.0, -2.0])       # gap, v, ω: slides along t₁ = x̂ (σ = −1), t₂ = ŷ (+1)
_STICKING = (-1e-4, [0.02, -0.01, -0.2], [0.1, 0.2, 0.0])


@check(CHECKS, "sliding_fd", 25, "a sliding sphere's step tangents equal its centred differences", "L2",
       regions=("contact_step.active_set",))
def sliding_fd(mod):
    err = _fd_check(mod, 0.2, _state(*_SLIDING), 2, "sliding, μ = 0.2")
    return f"T⁺ of a sliding step (max error {err:.1e})"


@check(CHECKS, "sticking_fd", 25, "a sticking sphere's step tangents equal its centred differences", "L2",
       regions=("contact_step.active_set",))
def sticking_fd(mod):
    err = _fd_check(mod, 0.8, _state(*_STICKING), 1, "sticking, μ = 0.8")
    return f"T⁺ of a sticking step (max error {err:.1e})"


@check(CHECKS, "sliding_closed_form", 20, "sliding: the friction impulse is σμλ, so ∂P⁺_t/∂μ = σλ, ∂P⁺_t/∂P_t = 𝟙, "
       "∂P⁺_t/∂P_n = −σμ", "L6", public=False, regions=("contact_step.active_set",))
def sliding_closed_form(mod):
    mu, erp = 0.2, 0.2
    gap, v, _ = _SLIDING
    T1 = _tangents(mod, _scene(), _state(*_SLIDING), mu, 2)
    sigma = np.array([-1.0, 1.0])                                # friction opposes the slip along x̂ and ŷ
    lam = M * (-erp * gap / H_STEP - (v[2] - G * H_STEP))        # v_n⁺ = −erp s/h, ũ_n = v_n − g h
    close("∂P⁺_t/∂μ", T1[12, 6:8], sigma * lam, rtol=3 * KAPPA, unit="kg m/s",
          why="τⱼ = σⱼ μ λ on the cone's bound: its μ-derivative is σⱼ λ")
    close("∂P⁺_t/∂P_t", T1[6:8, 6:8], np.eye(2), atol=3 * KAPPA,
          why="a sliding impulse does not depend on the slip speed")
    close("∂P⁺_t/∂P_n", T1[8, 6:8], -sigma * mu, atol=3 * KAPPA,
          why="∂λ/∂P_n = −1 (the normal row prescribes v_n⁺), so ∂τⱼ/∂P_n = −σⱼ μ")
    return f"σλ, 𝟙 and −σμ columns exact to the compliance (λ = {lam:.4f} N s)"


@check(CHECKS, "sticking_closed_form", 15, "sticking: the contact point stops, P⁺_t = P_t − (2/7) m v_c", "L6",
       public=False, regions=("contact_step.active_set",))
def sticking_closed_form(mod):
    erp = 0.2
    T1 = _tangents(mod, _scene(), _state(*_STICKING), 0.8, 1)
    # p_t = −(2/7) m v_c with v_c = v_t + (ω × r)_t, r = −ρ n: the sphere's tangential effective mass
    # m/(1 + mρ²/I) = 2m/7
    want_P = np.diag([5 / 7, 5 / 7, 0.0])                       # rows δP_x, δP_y, δP_z; columns P⁺
    close("∂P⁺/∂P", T1[6:9, 6:9], want_P, atol=3 * KAPPA, why="2/7 of the contact point's momentum goes into rolling; "
          "the normal row prescribes v_n⁺")
    want_L = (2 / 7) * RHO * np.array([[0.0, 1.0, 0.0], [-1.0, 0.0, 0.0]])   # L⁺ = L + r × p_t
    close("∂L⁺/∂P_t", T1[6:8, 9:12], want_L, atol=3 * KAPPA * RHO, unit="m")
    close("∂P⁺_n/∂x_n", T1[2, 8], -M * erp / H_STEP, rtol=3 * KAPPA, unit="kg/s",
          why="a penetration s is pushed out at v_n⁺ = −erp s/h")
    return "5/7, (2/7)ρ n× and −m erp/h exact to the compliance"


@check(CHECKS, "separating", 15, "a sphere flying clear of the plane: the free flight's tangents", "L2", public=False,
       regions=("contact_step.active_set",))
def separating(mod):
    T1 = _tangents(mod, _scene(), _state(0.5, [1.0, 0.5, -0.3], [0.0, 0.0, 0.0]), 0.5, 0)
    want = np.zeros((13, 12))
    want[:12] = np.eye(12)
    want[6:9, 0:3] = H_STEP / M * np.eye(3)                    # δx⁺ = δx + h δP/m
    want[9:12, 3:6] = H_STEP / INERTIA * np.eye(3)             # δφ⁺ = δφ + h I⁻¹ δL (ω = 0)
    close("T⁺ in free flight", T1, want, atol=1e-12 * np.abs(want).max(), why="no contact: δz = 0")
    return "free-flight tangents exact"


MUTANTS = (
    Mutant("sliding_as_sticking", "a sliding tangent given the sticking row w_τ = 0 as well",
           (("eq[j::3] = on & (st[:, j] == 0)", "eq[j::3] = on"),),
           ("sliding_fd", "sliding_closed_form")),
    Mutant("cone_direction_dropped", "the sliding row δτⱼ − μ δλ without the direction σⱼ",
           (("K[3 * ci + 1 + cj, 3 * ci] = -sig * mu", "K[3 * ci + 1 + cj, 3 * ci] = -mu"),),
           ("sliding_fd", "sliding_closed_form")),
    Mutant("no_friction_derivative", "the sliding row's σⱼλ δμ term forgotten",
           (("rhs[:, 3 * ci + 1 + cj] = np.outer(dmu, sig * z[3 * ci])", "rhs[:, 3 * ci + 1 + cj] = 0.0"),),
           ("sliding_fd", "sliding_closed_form")),
    Mutant("rhs_sign", "A δz = +δw|_z: the sticking and normal rows with the wrong sign",
           (("rhs[:, eq] = -dwz[:, eq]", "rhs[:, eq] = dwz[:, eq]"),),
           ("sliding_fd", "sticking_fd", "sliding_closed_form", "sticking_closed_form")),
)
