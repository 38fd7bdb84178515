"""Many pushes on one walk: the walk up to each push is simulated once and branched (chapter 08).

A push envelope asks the same walk many questions — impulses P at phases of one step — and every run is
the unpushed walk until its push lands. :func:`simulate_pushes` walks once without a push and, before
each step, keeps what that step may change (a snapshot: the state y, the machine's state, when it was
entered and the length of its trace, the length of the controller's history, the loop's bookkeeping, the
contact modes of the last step, the kinematics carried to the next step). After the step it asks, for
every push not yet placed, the question the pushed run asks inside that step (:func:`.walk.push_due`:
the machine in R0 or R1 of the push's step, its phase reached); the first step at which it holds is the
push's branch point. Each push then continues from the snapshot before that step, with fresh objects
built from it, and takes that step with the push: the same arithmetic as :func:`.walk.simulate_walk`
with ``push=`` from the start, so the same :class:`.walk.WalkResult` bit for bit (tested).

A push whose step never comes (the walk falls first, or ends) is never applied: its result is the
unpushed walk's, as a run with it would be.

**Stopping a recovered run** (``settle``, default None: every run to ``t_end``). An envelope asks only
"recovered or fell". With ``settle = n`` a pushed run stops, not fallen, at the end of the step in which the
n-th foot strike after its push lands with the torso upright (|φ| ≤ ``upright`` rad; the fall detector's
limit is 1 rad): ``WalkResult.settled`` is that time and the run's records end there. Everything up to
that step is the full run's, bit for bit. Measured on the chapter's envelope (70 pushes of 30–200 N s at
phases 0.1–0.9 of the 4th step, h = 2 ms, 7 s): every fallen run fell within 4 strikes after its push
(1.9 s at most), every recovered one walked 11–12 strikes to 7 s; n = 6 leaves a margin of two strikes
and gives every run the outcome of its full run (ORACLES F6, tested); n = 5 (the chapter's figure) gives the
same 70 outcomes, and n = 4 does not: −120 N s at phase 0.9 falls 0.12 s after its 4th strike, upright at it
(ORACLES F26, tested).
"""

from __future__ import annotations

import numpy as np

from ..contracts import Choice, Flag, Int, Obj, Opt, Real, Seq, contract
from ..ode.driver import MAX_STEPS
from .simbicon import WALK, Gait, Simbicon
from .biped import BIPED_JOINTS
from .walk import Push, Settled, WalkResult, _new_state, _run_walk, _walker, push_due

__all__ = ["simulate_pushes"]


class _Placed(Exception):
    """Ends the unpushed walk once every push has its branch point."""


@contract(gait=Obj(Gait), t_end=Real(gt=0), h=Real(gt=0), pushes=Seq(Obj(Push)),
          slope=Real(ge=-np.pi / 3, le=np.pi / 3), feedback=Flag(), servo=Choice(("explicit", "stable")),
          friction=Real(ge=0), record_every=Int(ge=1), max_steps=Int(ge=1), lean=Flag(), settle=Opt(Int(ge=1, le=1000)),
          upright=Real(gt=0, lt=1))
def simulate_pushes(gait: Gait = WALK, t_end: float = 20.0, h: float = 5e-4, pushes=(), *, slope: float = 0.0,
                    feedback: bool = True, servo: str = "explicit", friction: float = 0.9, record_every: int = 20,
                    max_steps: int = MAX_STEPS, lean: bool = True, settle: int | None = None,
                    upright: float = 0.5) -> list[WalkResult]:
    """``[simulate_walk(gait, t_end, h, push=p, …) for p in pushes]`` with the walk before each push
    simulated once (module docstring); the arguments are :func:`.walk.simulate_walk`'s. ``settle``, ``upright``:
    stop a pushed run as recovered at the ``settle``-th foot strike after its push with |φ| ≤ ``upright``
    (module docstring; None: every run to ``t_end``)."""
    args = (gait, t_end, h, slope, feedback, servo, friction, record_every, max_steps)
    pushes = list(pushes)
    base = _walker(*args)
    kernel, ground, stepper, ctrl, grid = base[:5]
    state = _new_state()
    records = ([0.0], [base[5].copy()], [base[6].copy()], [kernel.centre_of_mass(base[5])])
    pending = dict(enumerate(pushes))
    branch = {}                                 # push index -> (step index, snapshot, copies of the lists)
    fsm, counter = ctrl.fsm, [0]

    def wrap(advance):
        def watched(t, y, hh):
            k = counter[0]
            snap = (y, fsm.state, fsm.entered, len(fsm.trace), len(ctrl.history), state["events"],
                    dict(state["entries"]), dict(state["enter"]), state["step"], len(state["strikes"]),
                    state.get("lean_kin"), state.get("kin"), stepper.modes.copy(), len(records[0]))
            y1 = advance(t, y, hh)
            counter[0] = k + 1
            for i, p in list(pending.items()):
                if push_due(p, state, fsm.state, t):
                    branch[i] = (k, snap, list(fsm.trace[:snap[3]]), ctrl.history[:snap[4]],
                                 state["strikes"][:snap[9]], [r[:snap[13]] for r in records])
                    del pending[i]
            if not pending:
                raise _Placed
            return y1
        return watched, None

    try:
        unpushed = _run_walk(base, None, state, lean, record_every, records=records, wrap=wrap)
    except _Placed:
        unpushed = None
    return [_continue(args, p, branch[i], lean, record_every, settle, upright) if i in branch else unpushed
            for i, p in enumerate(pushes)]


def _continue(args: tuple, push: Push, point: tuple, lean: bool, record_every: int, settle: int | None = None,
              upright: float = 0.5) -> WalkResult:
    """The pushed walk from its branch point: fresh controller, stepper and bookkeeping set from the snapshot,
    the steps before the branch point skipped (neither taken nor recorded)."""
    k0, snap, trace, history, strikes, records = point
    (y, fsm_state, entered, _, _, events, entries, enter, step, _, lean_kin, kin, modes, _) = snap
    parts = _walker(*args)
    ctrl: Simbicon = parts[3]
    ctrl.fsm.state, ctrl.fsm.entered, ctrl.fsm.trace = fsm_state, entered, trace
    ctrl.history = history
    parts[2].modes[:] = modes
    state = {"events": events, "entries": dict(entries), "pushed": None, "strikes": strikes, "enter": dict(enter),
             "step": step}                                 # the dicts copied: branches of one snapshot share it
    if lean_kin is not None:
        state["lean_kin"] = lean_kin
    if kin is not None:
        state["kin"] = kin
    counter = [0]

    torso = BIPED_JOINTS["torso"]

    def wrap(advance):
        def skipping(t, yy, hh):
            k = counter[0]
            counter[0] = k + 1
            if k < k0:
                return y                                   # before the branch point: the saved state, untouched
            y1 = advance(t, yy, hh)
            pushed = state["pushed"]
            if (settle is not None and pushed is not None and abs(y1[torso]) <= upright
                    and sum(1 for ts, _ in state["strikes"] if ts > pushed) >= settle):
                state["settled"] = t + hh                  # recovered: the run ends here, not fallen
                raise Settled
            return y1
        return skipping, lambda: counter[0] > k0
    return _run_walk(parts, push, state, lean, record_every, records=records, wrap=wrap)
