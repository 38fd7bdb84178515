"""Floor row of chapter 08 (characters): the SIMBICON biped's step against a hand-written loop of it.

One step of the walking biped is SIMBICON's control (the state machine, the balance feedback, stable PD
servos), the contact step (closed-form planar dynamics, the heel and toe points against the ground, the
contact modes of the last step tried first) and the integration q⁺ = q + h u⁺. ``pbanim`` runs
:func:`pbanim.control.simulate_walk` for 1 s at the chapter's h = 2 ms (500 steps, one recorded state);
``hand`` is the same step written out below on numpy arrays and Python floats, as one would write it for
this one character: the kernel's constant arrays (the path matrix, the link placements, masses and inertias
of :class:`~pbanim.articulated.planar.PlanarKernel`, read once: the model's data), then per step every
formula of the lecture by hand —

    φ = Φ q,  o = P (e^{iφ_λ} e) + D q,  c = o + e^{iφ} r_c,  J_c = i (c − o) ⊙ P_rev · R_v + D,
    H = Σ m J_cᴴ J_c + Φᵀ I_zz Φ,   C = Σ m J_cᴴ (J̇_c q̇ − g),
    (H + h K_d) u⁺ = H q̇ + h (τ − C) + Jᵀ z,   contact modes by one linear solve, switched until they hold,

the state machine, the servos, a fall check (torso past 1 rad, hips below half height). The two final
states agree to roundoff (the bench checks it).
"""

from __future__ import annotations

import numpy as np

from .floors import Floor

__all__ = ["FLOORS"]

H, T_END = 2e-3, 1.0
N_STEPS = round(T_END / H)


def _model():
    """The biped's constant arrays, its start and its gait's numbers."""
    from ..articulated.planar import PlanarKernel
    from ..control import WALK, simulate_walk
    from ..control.biped import biped_contact_points, planar_biped

    tree = planar_biped()
    k = PlanarKernel(tree)
    start = simulate_walk(WALK, H, H, servo="stable", record_every=1)
    pts = biped_contact_points(tree)
    return {"Phi": k.Phi, "P": k.P.astype(complex), "rooted": k.parent >= 0, "parent": k.parent, "ez": k._ez,
            "rcz": k._rcz, "Dz": k._Dz, "Pr": k.Pr, "Rv": k.Rv, "mass": k.mass, "Hrot": k._Hrot, "gz": k._gz,
            "links": np.array([lk for lk, _ in pts]), "r0z": np.array([p[0] + 1j * p[1] for _, p in pts]),
            "q0": start.q[0].copy(), "qd0": start.qd[0].copy(), "gait": WALK, "hip0": tree.joints[0].p[1]}


def _contact(A, b, mu, modes):
    """Impulses z = (zₙ, zₜ per contact) with w = A z + b: 0 ≤ zₙ ⊥ wₙ ≥ 0, |zₜ| ≤ μ zₙ, wₜ = 0 while
    sticking, zₜ = ∓μ zₙ sliding. Guess the modes (0 separate, 1 stick, 2 slide +t, 3 slide −t), solve,
    check, switch the failing ones; if that cycles, projected Gauss–Seidel and one polishing solve."""
    m = b.size // 2
    eps = 1e-9 * (1.0 + np.abs(b).max())

    def solve(modes):
        rows = [r for i, md in enumerate(modes) for r in ((2 * i,) if md >= 2 else (2 * i, 2 * i + 1) if md else ())]
        z = np.zeros(2 * m)
        if rows:
            T = np.zeros((2 * m, len(rows)))
            for c, r in enumerate(rows):
                T[r, c] = 1.0
                if r % 2 == 0 and modes[r // 2] >= 2:
                    T[r + 1, c] = -mu if modes[r // 2] == 2 else mu
            z = T @ np.linalg.solve(A[rows] @ T, -b[rows])
        return z, A @ z + b

    def holds(z, w, modes):
        z, w = z.tolist(), w.tolist()
        for i, md in enumerate(modes):
            zn, zt, wn, wt = z[2 * i], z[2 * i + 1], w[2 * i], w[2 * i + 1]
            if md == 0 and wn < -eps or md and (zn < -eps or abs(wn) > eps) or md == 1 and (
                    abs(zt) > mu * zn + eps or abs(wt) > eps) or md == 2 and wt < -eps or md == 3 and wt > eps:
                return False
        return True

    modes = list(modes)
    for _ in range(3 * m + 3):
        z, w = solve(modes)
        if holds(z, w, modes):
            return z, modes
        new, zl, wl = list(modes), z.tolist(), w.tolist()
        for i, md in enumerate(modes):
            zn, zt, wn, wt = zl[2 * i], zl[2 * i + 1], wl[2 * i], wl[2 * i + 1]
            if md == 0 and wn < -eps:
                new[i] = 1
            elif md and zn < -eps:
                new[i] = 0
            elif md == 1 and abs(zt) > mu * zn + eps:
                new[i] = 3 if zt > 0 else 2
            elif md == 2 and wt < -eps or md == 3 and wt > eps:
                new[i] = 1
        modes = new
    z = np.zeros(2 * m)
    for _ in range(200):
        z_old = z.copy()
        for i in range(m):
            n, s = 2 * i, 2 * i + 1
            z[n] = max(0.0, z[n] - (A[n] @ z + b[n]) / A[n, n])
            z[s] = min(max(z[s] - (A[s] @ z + b[s]) / A[s, s], -mu * z[n]), mu * z[n])
        if np.abs(z - z_old).max() <= 1e-12 * (1.0 + np.abs(z).max()):
            break
    w = A @ z + b
    modes = [0 if z[2 * i] <= 1e-12 * (1 + z[0::2].max()) else 1 if abs(z[2 * i + 1]) < mu * z[2 * i] * (1 - 1e-6)
             else 2 if w[2 * i + 1] > 0 else 3 for i in range(m)]
    zp, wp = solve(modes)
    return (zp, modes) if holds(zp, wp, modes) else (z, modes)


def simbicon_biped() -> Floor:
    """SIMBICON's walk with stable PD servos, h = 2 ms, 1 s (500 steps) from the walk's start."""
    from ..control import simulate_walk

    d = _model()
    g = d["gait"]
    Phi, P, rooted, parent, ez, rcz, Dz = (d[k] for k in ("Phi", "P", "rooted", "parent", "ez", "rcz", "Dz"))
    Pr, Rv, mass, Hrot, gz, links, r0z = (d[k] for k in ("Pr", "Rv", "mass", "Hrot", "gz", "links", "r0z"))
    MT, mu, erp, margin, cfm = mass.sum(), 0.9, 0.2, 0.01, 1e-6
    kp, kv, lim, dt = g.kp, g.kv, g.limit, g.dt
    # per state: stance hip, swing hip, stance ankle's link, the phase; joints: 3 + 3 per leg (hip, knee, ankle)
    legs = {"left": (3, 4, 5), "right": (6, 7, 8)}
    feet = {"left": 5, "right": 8}
    machine = {"R0": ("right", "left", g.phases[0], "R1"), "R1": ("right", "left", g.phases[1], "L0"),
               "L0": ("left", "right", g.phases[0], "L1"), "L1": ("left", "right", g.phases[1], "R0")}

    def pbanim():
        r = simulate_walk(g, T_END, H, servo="stable", record_every=N_STEPS)
        return np.concatenate([r.q[-1], r.qd[-1]])

    def hand():
        q, qd = d["q0"].copy(), d["qd0"].copy()
        state, entered, left, right, modes = "R0", 0.0, False, False, [0, 0, 0, 0]
        for k in range(N_STEPS):
            t = k * H
            if state[1] == "0" and t - entered >= dt - 1e-12 or state == "R1" and left or state == "L1" and right:
                state, entered = machine[state][3], t
            stance, swing, ph, _ = machine[state]
            # kinematics and the centres' Jacobians
            rot = np.exp(1j * (Phi @ q))
            w = np.where(rooted, rot[parent], 1.0) * ez
            zo = P @ w + Dz @ q
            zc = zo + rot * rcz
            Jz = (1j * (zc[:, None] - zo[None, :]) * Pr) @ Rv + Dz
            # SIMBICON: balance feedback, joint-space servos (stable PD), the torso through the stance hip
            dx = (mass @ zc).real / MT - zo[feet[stance]].real
            vx = (mass @ (Jz @ qd)).real / MT
            fb = ph.cd * dx + ph.cv * vx
            qs, qds = q.tolist(), qd.tolist()
            tau, kd = [0.0] * 9, [0.0] * 9
            for i, target, kind in ((legs[swing][1], ph.swk, "knee"), (legs[swing][2], ph.swa, "ankle"),
                                    (legs[stance][1], ph.stk, "knee"), (legs[stance][2], ph.sta, "ankle")):
                tau[i], kd[i] = kp[kind] * (target - qs[i] - H * qds[i]), kv[kind]
            sw, st = legs[swing][0], legs[stance][0]
            tau_torso = kp["torso"] * (ph.tor - qs[2]) - kv["torso"] * qds[2]
            tau[sw] = kp["hip"] * (ph.swh + fb - (qs[2] + qs[sw])) - kv["hip"] * (qds[2] + qds[sw])
            tau[st] = -tau_torso - tau[sw]
            tau = np.clip(tau, -lim, lim)
            # dynamics
            phid = Phi @ qd
            bias = -((P * np.where(rooted, phid[parent], 0.0) ** 2) @ w) - phid ** 2 * (zc - zo)
            JmT = Jz.conj().T * mass
            Hm = (JmT @ Jz).real + Hrot
            C = (JmT @ (bias - gz)).real
            # contact: the points near the ground, their rows, the impulses
            Mt = Hm + H * np.diag(kd)
            rhs = Hm @ qd + H * (tau - C)
            pz = zo[links] + rot[links] * r0z
            gap = pz.imag
            Jc = (1j * (pz[:, None] - zo[None, :]) * Pr[links]) @ Rv + Dz[links]
            near = np.flatnonzero(gap < margin + H * np.maximum(-(Jc @ qd).imag, 0.0) + H * H * 10.0)
            left = right = False
            if near.size:
                rows = np.empty((2 * near.size, 9))
                rows[0::2], rows[1::2] = Jc[near].imag, Jc[near].real
                sol = np.linalg.solve(Mt, np.column_stack([rhs, rows.T]))
                u, MinvJt = sol[:, 0], sol[:, 1:]
                A = rows @ MinvJt
                A += cfm * A.diagonal().max() * np.eye(A.shape[0])
                b = rows @ u
                b[0::2] += np.maximum(gap[near], 0.0) / H + erp * np.minimum(gap[near], 0.0) / H
                z, got = _contact(A, b, mu, [modes[i] for i in near.tolist()])
                u = u + MinvJt @ z
                modes, zl = [0, 0, 0, 0], z.tolist()
                for j, i in enumerate(near.tolist()):
                    modes[i] = got[j]
                    left, right = left or (i < 2 and zl[2 * j] > 0), right or (i >= 2 and zl[2 * j] > 0)
            else:
                u = np.linalg.solve(Mt, rhs)
                modes = [0, 0, 0, 0]
            q, qd = q + H * u, u
            if abs(q[2]) > 1.0 or d["hip0"] + q[1] < 0.5 * d["hip0"]:      # fell: the torso tipped, the hips dropped
                break
        return np.concatenate([q, qd])

    return Floor("biped", "SIMBICON biped walking 1 s (9 coordinates, 4 contact points)", "stable PD, contact step",
                 N_STEPS, pbanim, hand, tol=1e-8)


FLOORS = [simbicon_biped]
