"""Floor row of chapter 08 (articulated bodies): a 3-link chain in reduced coordinates, ABA and RK4.

``pbanim`` runs :meth:`pbanim.articulated.ArticulatedSystem.simulate` (its ABA is the world-frame kernel of
:mod:`pbanim.articulated.fast` on Python floats) for 2000 steps of RK4; ``hand`` is the same ABA and the same
RK4 written out below for this one chain, as one would write them from the chapter, in world coordinates
(Plücker coordinates at the world origin, so no link-to-link transforms of inertias): per link i

    S_i = (ẑ, o_i × ẑ),  v_i = v_λ + S_i q̇_i,  c_i = v_i ×ₘ S_i q̇_i,  I^A_i = I_i,  p^A_i = v_i ×* I_i v_i
    (leaves first)  U = I^A S,  D = Sᵀ U,  u = τ − Sᵀ p^A,
                    I^A_λ += I^A − U Uᵀ / D,  p^A_λ += p^A + (I^A − U Uᵀ / D) c + U u / D
    (root first)    a_i = a_λ + c_i,  q̈_i = (u − Uᵀ a_i) / D,  a_i += S_i q̈_i       (a_root = −g)

on Python floats (the chain's hinges all turn about z, its links are point masses: o_i, x_i from the
absolute angles), and RK4 on numpy arrays y = [q, q̇]. The two final states agree to roundoff (the bench
checks it).
"""

from __future__ import annotations

from math import cos, sin
from operator import mul

import numpy as np

from .floors import Floor

__all__ = ["FLOORS"]

N_LINKS, H, N_STEPS = 3, 1e-3, 2000
Q0, QD0 = np.array([0.9, -0.4, 0.3]), np.array([0.0, 0.5, -1.0])


def _chain():
    """The chain (unit lengths and masses, hinges about z, gravity −y) and its numbers for the hand loop:
    the joints' placements in their parents (x, y), the masses' positions in their links (x, y), masses, g."""
    from ..models.articulated import pendulum_chain

    tree = pendulum_chain(N_LINKS)
    for j, lk in zip(tree.joints, tree.links):
        assert j.kind == "revolute" and np.allclose(j.axis, [0, 0, 1]) and not np.any(lk.inertia)
    place = [(float(j.p[0]), float(j.p[1])) for j in tree.joints]
    com = [(float(lk.com[0]), float(lk.com[1])) for lk in tree.links]
    return tree, place, com, [lk.mass for lk in tree.links], -float(tree.gravity[1])


def chain_rk4() -> Floor:
    """Three point masses on unit rods, RK4 at h = 1 ms, 2000 steps (2 s) from a swinging start."""
    from ..articulated import ArticulatedSystem

    tree, place, com, mass, g = _chain()
    system = ArticulatedSystem(tree, q0=Q0, qd0=QD0)
    n = N_LINKS

    def pbanim():
        return system.simulate(N_STEPS * H, H, "rk4", record_every=N_STEPS, diagnostics=False).y[:, -1]

    def aba(q, qd):
        # kinematics: joint origins o_i and mass positions x_i in the world (the plane z = 0)
        ox = oy = phi = 0.0
        S, c, IA, pA = [], [], [], []
        vp = (0.0,) * 6
        for i in range(n):
            px, py = place[i]
            cp, sp = cos(phi), sin(phi)
            ox, oy = ox + cp * px - sp * py, oy + sp * px + cp * py
            phi += q[i]
            cq, sq = cos(phi), sin(phi)
            xx, xy = ox + cq * com[i][0] - sq * com[i][1], oy + sq * com[i][0] + cq * com[i][1]
            s = (0.0, 0.0, 1.0, oy, -ox, 0.0)                   # (ẑ, o × ẑ)
            w = qd[i]
            vj = tuple(w * e for e in s)
            vi = tuple(a + b for a, b in zip(vp, vj))
            # c = v ×ₘ vJ = (ω × ω_J, ω × v_J + v × ω_J)
            a0, a1, a2, a3, a4, a5 = vi
            b0, b1, b2, b3, b4, b5 = vj
            ci = (a1 * b2 - a2 * b1, a2 * b0 - a0 * b2, a0 * b1 - a1 * b0,
                  a1 * b5 - a2 * b4 + a4 * b2 - a5 * b1, a2 * b3 - a0 * b5 + a5 * b0 - a3 * b2,
                  a0 * b4 - a1 * b3 + a3 * b1 - a4 * b0)
            # a point mass m at x = (xx, xy, 0): I = [[m x̃ x̃ᵀ, m x̃], [m x̃ᵀ, m 1]] (x̃ the cross-product matrix)
            m = mass[i]
            mx, my, mxy = m * xx, m * xy, m * xx * xy
            I6 = [[my * xy, -mxy, 0.0, 0.0, 0.0, my], [-mxy, mx * xx, 0.0, 0.0, 0.0, -mx],
                  [0.0, 0.0, mx * xx + my * xy, -my, mx, 0.0], [0.0, 0.0, -my, m, 0.0, 0.0],
                  [0.0, 0.0, mx, 0.0, m, 0.0], [my, -mx, 0.0, 0.0, 0.0, m]]
            # p = v ×* (I v): the momentum h = I v, then (ω × h_n + v × h_f, ω × h_f)
            hv = [sum(map(mul, row, vi)) for row in I6]
            pi = (a1 * hv[2] - a2 * hv[1] + a4 * hv[5] - a5 * hv[4], a2 * hv[0] - a0 * hv[2] + a5 * hv[3] - a3 * hv[5],
                  a0 * hv[1] - a1 * hv[0] + a3 * hv[4] - a4 * hv[3], a1 * hv[5] - a2 * hv[4],
                  a2 * hv[3] - a0 * hv[5], a0 * hv[4] - a1 * hv[3])
            S.append(s), c.append(ci), IA.append(I6), pA.append(pi)
            vp = vi
        U, D, u = [None] * n, [0.0] * n, [0.0] * n
        for i in reversed(range(n)):
            s, Ia, pa = S[i], IA[i], pA[i]
            Ui = [sum(map(mul, row, s)) for row in Ia]
            Di = sum(map(mul, s, Ui))
            ui = -sum(map(mul, s, pa))                            # τ = 0
            U[i], D[i], u[i] = Ui, Di, ui
            if i > 0:
                Ud = [x / Di for x in Ui]
                Ra = [[a - ur * uk for a, uk in zip(row, Ui)] for row, ur in zip(Ia, Ud)]   # I^A − U Uᵀ/D
                ci = c[i]
                IA[i - 1] = [[a + b for a, b in zip(rp, ra)] for rp, ra in zip(IA[i - 1], Ra)]
                pA[i - 1] = [p0 + p1 + sum(map(mul, ra, ci)) + ur * ui for p0, p1, ra, ur in zip(pA[i - 1], pa, Ra, Ud)]
        qdd, ap = [0.0] * n, (0.0, 0.0, 0.0, 0.0, g, 0.0)      # a_root = −g
        for i in range(n):
            ai = tuple(a + b for a, b in zip(ap, c[i]))
            x = (u[i] - sum(map(mul, U[i], ai))) / D[i]
            qdd[i] = x
            ap = tuple(a + x * e for a, e in zip(ai, S[i]))
        return qdd

    def f(y):
        q, qd = y[:n].tolist(), y[n:].tolist()
        return np.array(qd + aba(q, qd))

    def hand():
        y = np.concatenate([Q0, QD0])
        for _ in range(N_STEPS):
            k1 = f(y)
            k2 = f(y + 0.5 * H * k1)
            k3 = f(y + 0.5 * H * k2)
            k4 = f(y + H * k3)
            y = y + H / 6.0 * (k1 + 2.0 * k2 + 2.0 * k3 + k4)
        return y

    note = _kernel_note(system, tree)
    return Floor("joints", "3-link chain in reduced coordinates (point masses, hinges about z)", "ABA, rk4", N_STEPS,
                 pbanim, hand, tol=1e-10, notes=[note])


def _kernel_note(system, tree, steps: int = 200, rounds: int = 3) -> str:
    """What pbanim's RK4 step costs beyond its four ABA sweeps (the kernel alone on the same states, called
    directly), in alternating rounds: the run's own overhead per step."""
    import time

    from ..articulated.fastkernel import sweep
    from ..articulated.fastplan import plan_for

    P = plan_for(tree)
    q, qd, tau, fx = Q0.tolist(), QD0.tolist(), [0.0] * N_LINKS, [None] * N_LINKS
    trig = [(cos(x), sin(x)) for x in q]
    pivot = lambda D, i, floor: 1.0 / D                    # noqa: E731 (the chain's pivots are far from zero)
    run, kern = [], []
    for _ in range(rounds):
        start = time.perf_counter()
        system.simulate(steps * H, H, "rk4", record_every=steps, diagnostics=False)
        run.append((time.perf_counter() - start) / steps)
        start = time.perf_counter()
        for _ in range(4 * steps):
            sweep(P, q, qd, tau, trig, fx, pivot)
        kern.append((time.perf_counter() - start) / steps)
    r, k = float(np.median(run)) * 1e6, float(np.median(kern)) * 1e6
    return (f"joints: pbanim's RK4 step {r:.0f} µs, of which its four ABA sweeps (the float kernel called directly) "
            f"{k:.0f} µs: {r - k:.0f} µs a step ({(r - k) / r:.0%}) is the run around the kernel")


FLOORS = [chain_rk4]
