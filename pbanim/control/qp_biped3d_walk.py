"""Footsteps of the 3-D biped under the QP controller: one scripted step, or a few in a row (chapter 08, part 2).

A footstep plan is a list of (side, Δx): the foot ``side`` ("left" or "right") moves Δx m forward. The
script (:func:`_footsteps`) turns it into segments of the tasks' targets:

1. shift (T₀): c̄ moves from its start to ``inset`` m inside the first stance sole's centre;
2. per step, swing (T_w): the swing foot's four contact rows are released (``contacts=`` the stance sole's
   corners); its heel and toe centres (two point tasks) follow p̄(s) = p₀ + r(s) (Δx, 0, −2 mm) + b(s) (0, 0, z_c),
   r the minimum-jerk ramp 10s³ − 15s⁴ + 6s⁵, b = 16 s²(1 − s)² the lift; they end 2 mm into the ground;
3. between steps, land and shift (T_s): every corner within ``contact_tol`` is a contact again; c̄ moves to
   above the next stance sole;

a landed sole has its heel and toe tasks hold it at their planned end, 2 mm into the ground, until it swings
again (``press``): without it a sole landed on two corners is held by nothing on its free side (the
prioritized single step's foot tipped up 3.5 cm and slid 14 mm back and 2.3 cm sideways). Measured and not
kept: holding every sole on the ground (the stance sole from the start too) where it came down, z on the
ground: the prioritized step at h = 4 ms then ends on 5 corners, and the prioritized walk still fails;

4. after the last step, shift (T_f) c̄ to the middle of the final support polygon, then hold (T_h).

The step of :func:`simulate_step` is the plan [("left", ℓ)] with the phases (T₀, T_w, T_f, T_h); the walk of
:func:`simulate_qp_walk3d` is [("left", ℓ), ("right", 2ℓ), ("left", 2ℓ), …, (·, ℓ)]: the first and the last
step half a stride, the feet side by side at the end. Everything else (tasks, levels, contact step, fall test)
is :mod:`.qp_biped3d_run`'s.

**Measured** (ORACLES F21). The single step: see :mod:`.qp_biped3d_run`. Pushes in its last double support (h = 8 ms,
phases (0.6, 0.4, 0.6, 1.2) s, P at the torso at 1.2 s, mid-shift; recovered: up, 8 corners, c within 1 cm of c̄
over the last 0.3 s): weighted forward 20 N s (1.8 mm; 30: up, 25 mm off), lateral 20 N s (2.4 mm; 30: a sole
tipped, 6 corners); prioritized forward 20 N s (0.8 mm; 30: 3 corners), lateral not even 10 N s (c back to
0.2 mm, but a sole tipped: 6 corners). Prioritized stepping balances worse sideways than weighted here. The walk (defaults: 4 steps, ℓ = 0.1 m,
strides 0.2 m, phases (0.6, 0.4, 0.6, 0.6, 0.2) s), weighted, walks at h = 4, 8 and 10 ms: the soles 0.2957–0.2996 m
ahead (0.3 planned), lateral drift ≤ 8 mm, 8 of 8 corners at the end, 0.0896–0.0898 m/s from the first lift to
the last landing, QP residuals ≤ 7e-7 M g (CPU 17, 9.4 and 7.6 s for the 4.8 s). Longer steps fail: ℓ = 0.15
(strides 0.3 m) fell at 2.64 s with T_s = 0.3 s. **Prioritized walking fails**: with the levels of
:data:`~pbanim.control.qp_biped3d_run.STEP_LEVELS` (h = 8 ms) the QP at 1.61 s, in the shift onto the landed
left foot, is truly infeasible (an LP phase 1 leaves 107 of violation; feasible without the joint limits): the
left ankle's roll turns at −34 rad/s, and its limit row (θ + T θ̇ + ½T²θ̈ ≥ θ_min) asks 607 rad/s² of a foot
the contact rows hold still. The leg was whipped before the QP failed; with the swing foot at level 0 it fell
at 2.78 s, with the levels (0, 1, 1, 2) it was infeasible at 2.6 s. Why the prioritized levels whip the foot
here and not in the single step is not found.

Notation: c̄ the centre of mass's target; ℓ the step length; z_c the clearance; T the segments' durations.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from ..contracts import Array, Choice, Flag, Int, Real, contract
from .qp import MODES
from .qp_biped3d_run import STEP_LEVELS, Biped3DRun, _controller, _result, _run
from .qp_tasks import Task

__all__ = ["simulate_qp_walk3d", "simulate_step"]
_SIDES = {"left": slice(0, 4), "right": slice(4, 8)}
_SINK = np.array([0.0, 0.0, -0.002])          # a landing target 2 mm into the ground: the contact is taken


def _ramp(s: float) -> np.ndarray:
    """Minimum jerk r(s) = 10s³ − 15s⁴ + 6s⁵ and its first two derivatives in s (s clipped to [0, 1])."""
    s = min(max(s, 0.0), 1.0)
    return np.array([s**3 * (10 - 15 * s + 6 * s * s), 30 * s * s * (1 - s) ** 2, 60 * s * (1 - s) * (1 - 2 * s)])


def _bump(s: float) -> np.ndarray:
    """The lift b(s) = 16 s²(1 − s)² (1 at s = ½, flat at both ends) and its first two derivatives in s."""
    s = min(max(s, 0.0), 1.0)
    return 16.0 * np.array([s * s * (1 - s) ** 2, 2 * s * (1 - s) * (1 - 2 * s), 2 - 12 * s + 12 * s * s])


def _along(a, b, r: np.ndarray, T: float) -> tuple:
    """(position, velocity, acceleration) of a + r(s) (b − a) at the ramp values r (r, r', r'') of a phase T."""
    d = np.asarray(b, dtype=float) - np.asarray(a, dtype=float)
    return a + r[0] * d, r[1] / T * d, r[2] / (T * T) * d


def _segments(plan, soles: dict, com0, inset: float, T) -> list:
    """The segments (T, c̄ from, c̄ to, swing (side, Δx) or None, pressed sides) of a footstep plan (module
    docstring); ``soles``: each sole's centre at the start, moved as the plan moves it."""
    T0, Tw, Ts, Tf, Th = T
    x = {s: np.array(p, dtype=float) for s, p in soles.items()}

    def over(side):                                    # inset m inside the sole's centre, toward the other foot
        other = "right" if side == "left" else "left"
        return np.array([x[side][0], x[side][1] + inset * np.sign(x[other][1] - x[side][1]), com0[2]])

    segs, c, pressed = [], np.asarray(com0, dtype=float), set()
    for i, (side, dx) in enumerate(plan):
        stance = "right" if side == "left" else "left"
        segs.append((T0 if i == 0 else Ts, c, over(stance), None, frozenset(pressed)))
        c = over(stance)
        pressed.discard(side)
        segs.append((Tw, c, c, (side, float(dx)), frozenset(pressed)))
        x[side] = x[side] + [dx, 0.0, 0.0]
        pressed.add(side)
    middle = np.asarray(com0, dtype=float) + [0.5 * (x["left"][0] + x["right"][0] - soles["left"][0] - soles["right"][0]),
                                              0.0, 0.0]
    segs += [(Tf, c, middle, None, frozenset(pressed)), (Th, middle, middle, None, frozenset(pressed))]
    return segs


def _footsteps(plan, T, *, h, clearance, inset, mode, control_every, knee, friction, swing_weight, swing_priority,
               record_every, priorities, press, ok: str, push=None, push_time: float = 0.0) -> tuple:
    """Run the plan (module docstring): (the run, the controller, the soles' centres at the start)."""
    ctrl, q, qd, com0 = _controller(mode, knee, friction, priorities=priorities)
    kin = ctrl.world.kinematics(q)
    P, _ = ctrl.world.point_jacobians(kin, ctrl.links, ctrl.local)
    soles = {s: P[sl].mean(axis=0) for s, sl in _SIDES.items()}
    ends = {}                                           # task name → (side, start point, point in the foot)
    for side, sl in _SIDES.items():
        foot, idx = int(ctrl.links[sl][0]), np.arange(8)[sl]
        for part, k in (("heel", idx[:2]), ("toe", idx[2:])):
            ends[f"{side}_{part}"] = (side, P[k].mean(axis=0), ctrl.local[k].mean(axis=0))
            ctrl.tasks.append(Task("point", name=f"{side}_{part}", link=foot, local=ctrl.local[k].mean(axis=0),
                                   target=P[k].mean(axis=0), kp=200.0, kd=30.0, weight=0.0, priority=swing_priority,
                                   dim=3))
    ctrl.tasks = ctrl._checked(ctrl.tasks)
    tasks = {nm: ctrl.task(nm) for nm in ends}
    com_task = ctrl.task("com")
    segs = _segments(plan, soles, com0, inset, T)
    starts = np.concatenate([[0.0], np.cumsum([sg[0] for sg in segs])])
    at = {nm: p0.copy() for nm, (_, p0, _) in ends.items()}           # each point's planned place on the ground

    def script(t, q, qd, kin):
        k = min(int(np.searchsorted(starts, t, side="right")) - 1, len(segs) - 1)
        Tk, a, b, swing, pressed = segs[k]
        s = (t - starts[k]) / Tk
        r = _ramp(s)
        c, v, acc = _along(a, b, r, Tk) if not np.array_equal(a, b) else (b, np.zeros(3), np.zeros(3))
        ctrl._replace("com", replace(com_task, target=c, velocity=v, acceleration=acc))
        for nm, (side, _, _) in ends.items():
            base = at[nm] + sum(dx for sd, dx in (seg[3] for seg in segs[:k] if seg[3]) if sd == side) * np.array(
                [1.0, 0.0, 0.0])
            if swing is not None and swing[0] == side:     # lift and swing: 2 mm into the ground at the end
                bump, lift = _bump(s), np.array([0.0, 0.0, clearance])
                x, vx, ax = _along(base, base + [swing[1], 0.0, 0.0] + _SINK, r, Tk)
                new = replace(tasks[nm], weight=swing_weight, target=x + bump[0] * lift,
                              velocity=vx + bump[1] / Tk * lift, acceleration=ax + bump[2] / (Tk * Tk) * lift)
            elif side in pressed and press:                # landed: pressed flat at its planned end
                new = replace(tasks[nm], weight=swing_weight, target=base + _SINK, velocity=np.zeros(3),
                              acceleration=np.zeros(3))
            else:
                new = replace(tasks[nm], weight=0.0)
            ctrl._replace(nm, new)
        return np.arange(8)[_SIDES["right" if swing[0] == "left" else "left"]] if swing is not None else None

    push = None if push is None or not np.any(push) else np.asarray(push, dtype=float)
    rec, stop, wall = _run(ctrl, q, qd, starts[-1], h, control_every, script, push, push_time, record_every)
    res = _result(rec, stop, wall, ctrl, h, ok, starts[-1], {})
    res.extra = {"mode": mode, "start_com": com0, "plan": list(plan)}
    if res.q.size:
        P1, _ = ctrl.world.point_jacobians(ctrl.world.kinematics(res.q[-1]), ctrl.links, ctrl.local)
        moved = {s: P1[sl].mean(axis=0) - soles[s] for s, sl in _SIDES.items()}
        res.extra.update(moved=moved, corners=int(np.sum(np.abs(P1[:, 2]) <= ctrl.contact_tol)))
        if res.ok and res.extra["corners"] < 8:
            res.outcome, res.cause = "not on two feet", f"{res.extra['corners']} of 8 sole corners on the ground at the end"
    return res


_COMMON = dict(clearance=Real(ge=0, le=0.2), h=Real(ge=1e-3, le=0.01), inset=Real(ge=0, le=0.05), mode=Choice(MODES),
               control_every=Int(ge=1, le=100), knee=Real(ge=0, le=1.2), friction=Real(ge=0), swing_weight=Real(gt=0),
               swing_priority=Int(ge=0, le=10), record_every=Int(ge=1), priorities=Array((4,), ge=0, le=10),
               press=Flag())


@contract(length=Real(ge=0, le=0.5), phases=Array((4,), gt=0.05, le=2), push=Array((3,)), push_time=Real(ge=0),
          **_COMMON)
def simulate_step(length: float = 0.2, phases=(0.6, 0.4, 0.6, 0.2), clearance: float = 0.05, h: float = 4e-3, *,
                  inset: float = 0.02, mode: str = "weighted", control_every: int = 1, knee: float = 0.4,
                  friction: float = 0.9, swing_weight: float = 1.0, swing_priority: int = 1, record_every: int = 5,
                  priorities=STEP_LEVELS, press: bool = True, push=(0.0, 0.0, 0.0), push_time: float = 0.0) -> Biped3DRun:
    """One scripted step of the left foot, ``length`` m forward (module docstring: the plan [("left", ℓ)] in
    phases (T₀, T_w, T_f, T_h) = ``phases`` s; the centre of mass shifts to ``inset`` m inside the stance sole's
    centre; ``push`` N s at the torso at ``push_time`` s, as in :func:`~.qp_biped3d_run.simulate_stand3d`).
    ``extra``: the step length reached, the left sole's lateral drift, the corners in contact at the end."""
    T0, Tw, Tf, Th = (float(p) for p in phases)
    res = _footsteps([("left", length)], (T0, Tw, Tw, Tf, Th), h=h, clearance=clearance, inset=inset, mode=mode,
                     control_every=control_every, knee=knee, friction=friction, swing_weight=swing_weight,
                     swing_priority=swing_priority, record_every=record_every, priorities=priorities, press=press,
                     ok="stepped", push=push, push_time=push_time)
    if "moved" in res.extra:
        res.extra.update(length=float(res.extra["moved"]["left"][0]), drift=float(res.extra["moved"]["left"][1]),
                         target_length=float(length))
    return res


@contract(steps=Int(ge=2, le=8), length=Real(ge=0, le=0.3), phases=Array((5,), gt=0.05, le=2), **_COMMON)
def simulate_qp_walk3d(steps: int = 4, length: float = 0.1, phases=(0.6, 0.4, 0.6, 0.6, 0.2),
                       clearance: float = 0.05, h: float = 8e-3, *, inset: float = 0.02, mode: str = "weighted",
                       control_every: int = 1, knee: float = 0.4, friction: float = 0.9, swing_weight: float = 1.0,
                       swing_priority: int = 1, record_every: int = 5, priorities=STEP_LEVELS,
                       press: bool = True) -> Biped3DRun:
    """``steps`` steps in a row, feet alternating, left first (module docstring: ℓ = ``length``, strides 2ℓ
    between; ``phases`` (T₀, T_w, T_s, T_f, T_h) s). ``extra``: each sole's displacement (``moved``) and the
    plan's (``target``), the corners in contact at the end, ``speed`` the centre of mass's mean forward speed
    from the first lift to the last landing (m/s)."""
    plan = [("left" if i % 2 == 0 else "right", length if i in (0, steps - 1) else 2 * length) for i in range(steps)]
    T = tuple(float(p) for p in phases)
    res = _footsteps(plan, T, h=h, clearance=clearance, inset=inset, mode=mode, control_every=control_every, knee=knee,
                     friction=friction, swing_weight=swing_weight, swing_priority=swing_priority,
                     record_every=record_every, priorities=priorities, press=press, ok="walked")
    t0, t1 = T[0], T[0] + steps * T[1] + (steps - 1) * T[2]
    if res.t.size and res.t[-1] >= t1 - 1e-9:
        i0, i1 = np.argmin(np.abs(res.t - t0)), np.argmin(np.abs(res.t - t1))
        res.extra["speed"] = float((res.com[i1, 0] - res.com[i0, 0]) / (res.t[i1] - res.t[i0]))
    res.extra["target"] = {s: float(sum(dx for sd, dx in plan if sd == s)) for s in ("left", "right")}
    return res
