"""Tasks of the QP controller: a feature, a target, PD gains, a weight and a priority (chapter 08).

Each task asks one feature y of the character (:mod:`.qp_features`) to accelerate as a PD servo in feature
space would make it (de Lasa, Mordatch & Hertzmann 2010, section 4):

    ÿ* = ÿ_ref + k_p (ȳ − y) + k_d (ẏ_ref − ẏ)           (the desired feature acceleration)
    e(q̈) = J_y q̈ + J̇_y q̇ − ÿ*                          (linear in q̈: a least-squares row block of the QP)

=============  =====================================  ==================================================
kind           feature y                              target ȳ
=============  =====================================  ==================================================
``com``        centre of mass c (2,)                  a position (2,) [m]
``momentum``   angular momentum about c, L (1,)       L̄ [kg m²/s]; only k_d acts: L̇* = k_d (L̄ − L)
``point``      a point p on ``link`` at ``local``     a position (2,) [m] (an end effector, a hand, a foot)
``posture``    named joint coordinates θ              a dict name → angle [rad] (joint-space PD)
=============  =====================================  ==================================================

A 3-D character (:mod:`.qp_biped3d`) takes tasks with ``dim=3``: the centre of mass and points are 3-vectors,
the angular momentum L a 3-vector (its target too).

``weight`` w ≥ 0 scales the task's term w‖e‖² of the weighted QP; ``priority`` 0, 1, 2, … orders the
levels of the prioritized solve (0 first: it is never degraded by a later level). A task with k_p = k_d = 0
and no reference acceleration asks its feature not to accelerate.

Limiting cases: weight 0 removes the task from a weighted QP; all tasks at one priority level make the
prioritized solve equal to the weighted one (up to the final regularization level).

Bad input is refused by name: an unknown kind (:class:`UnknownTask`), a negative or non-finite weight or
gain, a target of the wrong shape, a priority that is not a non-negative integer (:class:`InvalidTask`).

References: M. de Lasa, I. Mordatch, A. Hertzmann, "Feature-Based Locomotion Controllers", SIGGRAPH 2010
(features and their PD targets, section 4); O. Khatib, "A unified approach for motion and force control of
robot manipulators: the operational space formulation", IEEE J. Robotics and Automation 1987.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace

import numpy as np

from ..contracts import Array, Choice, Either, Int, Opt, Real, Text, contract
from ..errors import InvalidInput
from .pd import UnknownJoint
from .qp_features import Centroidal, point_feature
from .specs import Mapping, named

__all__ = ["TASK_KINDS", "InvalidTask", "Task", "UnknownTask", "task_rows"]

TASK_KINDS = ("com", "momentum", "point", "posture")


class UnknownTask(InvalidInput):
    """A task kind, or a task name, that the controller does not know."""


class InvalidTask(InvalidInput):
    """A task with a bad weight, gain, priority or target (the message says which and what came in)."""


_TASK_GAIN = named(InvalidTask, Real(ge=0))
# a target: a 2-vector (com, point), a number (momentum) or a dict joint name -> angle (posture); which one
# the kind asks for is checked by the task itself
TARGET = Either(Array((None,)), Real(), Mapping(Text(), Real(), min_len=1))


@contract(kind=named(UnknownTask, Choice(TASK_KINDS)), target=named(InvalidTask, Opt(TARGET)), kp=_TASK_GAIN,
          kd=_TASK_GAIN, weight=_TASK_GAIN, priority=named(InvalidTask, Int(ge=0)), name=Text(), link=Int(ge=-1),
          local=named(InvalidTask, Array((3,))), acceleration=named(InvalidTask, Opt(Array((None,)))),
          velocity=named(InvalidTask, Opt(Array((None,)))), dim=named(InvalidTask, Int(ge=2, le=3)))
@dataclass(frozen=True)
class Task:
    """One objective of the QP controller (see the module docstring for the kinds and their targets).

    >>> Task("com", target=(0.05, 0.95), kp=100.0, kd=20.0).name
    'com'
    >>> Task("balance")
    Traceback (most recent call last):
    ...
    pbanim.control.qp_tasks.UnknownTask: Task: kind must be one of 'com', 'momentum', 'point', 'posture', got 'balance'
    """

    kind: str
    target: object = None
    kp: float = 0.0
    kd: float = 0.0
    weight: float = 1.0
    priority: int = 0
    name: str = ""
    link: int = -1                                   # point tasks: the link index and the point in its frame
    local: tuple = (0.0, 0.0, 0.0)
    acceleration: object = None                      # ÿ_ref, feed-forward (same shape as the feature)
    velocity: object = None                          # ẏ_ref (default zero)
    dim: int = 2                                     # the character's space: 2 (planar) or 3 (3-D, :mod:`.qp_biped3d`)
    _target: np.ndarray = field(default=None, init=False, repr=False, compare=False)

    def __post_init__(self):
        # the contract has checked each field alone (calls from outside; balance_tasks' values are checked by
        # its callers' contracts); what a field must be given the kind is checked here
        set_ = lambda k, v: object.__setattr__(self, k, v)
        set_("name", self.name or self.kind)
        set_("_target", _target_of(self.kind, self.target, self.name, self.dim))
        size = self.size
        for ref in ("acceleration", "velocity"):
            v = getattr(self, ref)
            arr = np.zeros(size) if v is None else np.array(v, dtype=float).reshape(-1)
            if arr.shape != (size,):
                raise InvalidTask(f"task {self.name!r}: {ref} must be {size} finite numbers (the feature's size), "
                                  f"got {v!r}")
            set_(ref, arr)
        set_("local", tuple(float(c) for c in np.asarray(self.local, dtype=float).reshape(-1)))

    @property
    def size(self) -> int:
        """Rows of the task (feature dimension)."""
        return len(self.target) if self.kind == "posture" else self._target.size

    @contract(target=named(InvalidTask, Opt(TARGET)))
    def with_target(self, target) -> Task:
        """A copy with a new target (validated like the original; a posture of another size drops its references)."""
        keep = self.kind != "posture" or (isinstance(target, dict) and len(target) == self.size)
        return replace(self, target=target, acceleration=self.acceleration if keep else None,
                       velocity=self.velocity if keep else None)

    @contract(weight=_TASK_GAIN)
    def with_weight(self, weight) -> Task:
        """A copy with a new weight (≥ 0, finite)."""
        return replace(self, weight=weight)


def _target_of(kind: str, target, name: str, dim: int = 2) -> np.ndarray:
    """ȳ as an array of the feature's size for a task of this kind, or :class:`InvalidTask` naming target."""
    if kind == "posture":
        if not isinstance(target, dict) or not target:
            raise InvalidTask(f"task {name!r}: target of a posture task must be a non-empty dict joint name -> "
                              f"angle [rad], got {target!r}")
        return np.array([float(v) for v in target.values()])
    if isinstance(target, dict):
        raise InvalidTask(f"task {name!r}: target of a {kind} task must be "
                          f"{'a number' if kind == 'momentum' else f'a {dim}-vector'}, got a dict")
    if kind == "momentum" and dim == 3:                # 3-D: L̄ a 3-vector (default zero)
        t = np.zeros(3) if target is None else np.array(target, dtype=float).reshape(-1)
        if t.shape != (3,):
            raise InvalidTask(f"task {name!r}: target of a 3-D momentum task must be a 3-vector L̄ [kg m²/s], got "
                              f"{target!r}")
        return t
    if kind == "momentum":
        t = np.array([0.0 if target is None else target], dtype=float).reshape(-1)
        if t.shape != (1,):
            raise InvalidTask(f"task {name!r}: target of a momentum task must be one number L̄ [kg m²/s], got "
                              f"{target!r}")
        return t
    t = None if target is None else np.array(target, dtype=float)
    if t is None or t.shape != (dim,):
        raise InvalidTask(f"task {name!r}: target of a {kind} task must be a finite {dim}-vector "
                          f"({'x, y' if dim == 2 else 'x, y, z'}) [m], got {target!r}")
    return t


def check_tasks(tasks, kernel, joints: dict, dim: int = 2) -> list:
    """The tasks as a list, names unique, of the character's space ``dim``, links and posture joints known
    (:class:`UnknownJoint` otherwise)."""
    tasks = list(tasks)
    names = [t.name for t in tasks if isinstance(t, Task)]
    if len(names) != len(tasks):
        bad = [type(t).__name__ for t in tasks if not isinstance(t, Task)]
        raise InvalidTask(f"tasks must be Task objects, got {bad}")
    dup = sorted({n for n in names if names.count(n) > 1})
    if dup:
        raise InvalidTask(f"task names must be unique; repeated: {dup} (give each a name=)")
    for t in tasks:
        if t.dim != dim:
            raise InvalidTask(f"task {t.name!r} is for a {t.dim}-D character (dim={t.dim}); this one is {dim}-D")
        if t.kind == "point" and not (0 <= t.link < kernel.n):
            raise InvalidTask(f"task {t.name!r}: link must be a link index in 0..{kernel.n - 1}, got {t.link}")
        if t.kind == "posture":
            unknown = sorted(set(t.target) - set(joints))
            if unknown:
                raise UnknownJoint(f"task {t.name!r} names joints {unknown} that the model does not have; it has "
                                   f"{list(joints)}")
    return tasks


def task_rows(task: Task, kernel, kin: dict, q: np.ndarray, qd: np.ndarray, cf: Centroidal,
              joints: dict) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(J_y (r, nv), J̇_y q̇ (r,), ÿ* (r,)): the task's error is e = J_y q̈ + J̇_y q̇ − ÿ*."""
    t = task
    if t.kind == "com":
        y, yd, J, bias = cf.com, cf.vcom, cf.J, cf.bias
    elif t.kind == "momentum":
        return cf.A[None, :], np.array([cf.L_bias]), t.acceleration + t.kd * (t._target - cf.L)
    elif t.kind == "point":
        y, yd, J, bias = point_feature(kernel, kin, qd, t.link, t.local)
    else:
        idx = np.array([joints[nm] for nm in t.target])
        J = np.zeros((idx.size, kernel.nv))
        J[np.arange(idx.size), idx] = 1.0
        y, yd, bias = q[idx], qd[idx], np.zeros(idx.size)
    return J, bias, t.acceleration + t.kp * (t._target - y) + t.kd * (t.velocity - yd)
