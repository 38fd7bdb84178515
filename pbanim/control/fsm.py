"""Finite state machines for controllers: states with targets, timed and event-triggered transitions.

A character's controller is a small graph (the lecture's "PD + FSM"): each state holds the servo targets
of one phase of a motion, and a transition fires after a time spent in the state (``after=δt``) or on an
event the simulation reports (``on="right_foot_contact"``). SIMBICON's walk is four states — right
stance for δt, right stance until the left foot lands, left stance for δt, left stance until the right
foot lands — and a gait is nothing but the numbers in those states.

The machine checks itself when built: every transition starts and ends at a state that exists, every
state can be reached from the initial one, and no state is a dead end unless declared final. At run
time :meth:`StateMachine.update` fires at most one transition per call and keeps a trace of (time, state)
that tests and figures read.
"""

from __future__ import annotations

from dataclasses import dataclass

from ..contracts import Anything, Obj, Opt, Real, Seq, Text, contract
from ..errors import InvalidInput
from .specs import Mapping, Names, NotBefore, named

__all__ = ["Transition", "StateMachine", "InvalidMachine"]


class InvalidMachine(InvalidInput):
    """A state machine whose graph is wrong: an unknown state, an unreachable one, a dead end."""


_NAME = Text(nonempty=True)
_NOW = NotBefore("self.entered")            # a time of the run: not before the current state began


@contract(source=_NAME, target=_NAME, after=Opt(Real(gt=0)), on=Opt(_NAME))
@dataclass(frozen=True)
class Transition:
    """From state ``source`` to ``target`` after ``after`` seconds in ``source`` or on the event ``on``."""

    source: str
    target: str
    after: float | None = None
    on: str | None = None

    def __post_init__(self):
        if (self.after is None) == (self.on is None):
            raise InvalidMachine(f"transition {self.source!r} -> {self.target!r} needs exactly one trigger: "
                                 f"after=<seconds> or on=<event>, got after={self.after!r}, on={self.on!r}")


class StateMachine:
    """States (name → payload, e.g. a dict of targets), transitions and the initial state."""

    @contract(states=named(InvalidMachine, Mapping(_NAME, Anything("a state's payload: whatever the controller "
                                                                   "keeps per state (targets, a Phase)"), min_len=1)),
              transitions=named(InvalidMachine, Seq(Obj(Transition))), initial=named(InvalidMachine, _NAME),
              final=named(InvalidMachine, Names()))
    def __init__(self, states: dict, transitions, initial: str, final=()) -> None:
        self.states = dict(states)
        self.transitions = list(transitions)
        for tr in self.transitions:
            for end in (tr.source, tr.target):
                if end not in self.states:
                    raise InvalidMachine(f"transition {tr.source!r} -> {tr.target!r} names the unknown state "
                                         f"{end!r}; states are {sorted(self.states)}")
        if initial not in self.states:
            raise InvalidMachine(f"initial state {initial!r} is not one of {sorted(self.states)}")
        final = set(final)
        if final - set(self.states):
            raise InvalidMachine(f"final names the unknown states {sorted(final - set(self.states))}; states are "
                                 f"{sorted(self.states)}")
        reached, frontier = {initial}, [initial]
        while frontier:                                  # each state enters the frontier once: ≤ len(states)
            s = frontier.pop()
            for tr in self.transitions:
                if tr.source == s and tr.target not in reached:
                    reached.add(tr.target)
                    frontier.append(tr.target)
        unreachable = sorted(set(self.states) - reached)
        if unreachable:
            raise InvalidMachine(f"states {unreachable} are not reachable from the initial state {initial!r}")
        dead = sorted(s for s in self.states if s not in final and not any(t.source == s for t in self.transitions))
        if dead:
            raise InvalidMachine(f"states {dead} have no way out; declare them final=... if that is intended")
        self.initial = initial
        self.reset()

    @contract(t=Real())
    def reset(self, t: float = 0.0) -> None:
        """Back to the initial state at time t; the trace restarts."""
        self.state, self.entered = self.initial, float(t)
        self.trace: list[tuple[float, str]] = [(float(t), self.initial)]

    @property
    def payload(self):
        return self.states[self.state]

    @contract(t=_NOW)
    def time_in_state(self, t: float) -> float:
        """The time t − t_entered spent in the current state at time t."""
        return float(t) - self.entered

    @contract(t=_NOW, events=Names())
    def update(self, t: float, events=()) -> bool:
        """Fire the first transition out of the current state whose trigger holds at time t (an elapsed
        time or one of ``events``); True when the state changed. Time runs forward: t is not before the
        current state began."""
        ev = set(events)
        for tr in self.transitions:
            if tr.source != self.state:
                continue
            if (tr.after is not None and t - self.entered >= tr.after - 1e-12) or (tr.on is not None and tr.on in ev):
                self.state, self.entered = tr.target, float(t)
                self.trace.append((float(t), tr.target))
                return True
        return False

    @contract(t_end=_NOW)
    def intervals(self, t_end: float) -> list[tuple[float, float, str]]:
        """The trace as (start, end, state) intervals up to ``t_end`` (for shading figures; t_end is not
        before the last state began)."""
        out = []
        for k, (t0, s) in enumerate(self.trace):
            t1 = self.trace[k + 1][0] if k + 1 < len(self.trace) else float(t_end)
            out.append((t0, t1, s))
        return out
