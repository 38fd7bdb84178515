"""What the arguments of chapter 07 must be: systems, their states and forces, contacts among their bodies.

The specs of the shared vocabulary (:mod:`pbanim.contracts`) serve most arguments (a contact set's own
cross-field rules, unit normals among them, are :class:`~pbanim.collision.shapes.Contacts`'s); this module adds

=============================  ==================================================================
spec / helper                  accepts
=============================  ==================================================================
``ContactsOn(system)``         a :class:`~pbanim.collision.shapes.Contacts` among the bodies of the
                               argument ``system`` (indices −1 … N − 1, −1 the static world, never a
                               body with itself) in its dimension (3 for rigid bodies)
``state_of(ref)``              a shape entry: the length of the flat state of the system ``ref``
``RIGID``, ``PARTICLES``,      the systems contacts act on (rigid bodies, particles, either)
``BODIES``
``RigidState()``               the dict of per-body arrays :func:`~pbanim.contact.assembly.rigid_state`
                               returns (x (n, 3), ``Wb`` (n, 6, 6), ...)
``finite_parts``               a ``returns`` certificate: every array of the result (a record's fields,
                               a dict's values) finite, else :class:`~pbanim.errors.NonFiniteResult`
=============================  ==================================================================

:func:`check_contacts` is the same check for the contacts a user's ``detect(y)`` returns inside a step
(values that reach the assembly without passing a boundary).
"""

from __future__ import annotations

import numpy as np

from ..contracts import Obj, Spec
from ..errors import InvalidInput, NonFiniteResult

__all__ = ["ContactsOn", "RigidState", "state_of", "state_length", "check_contacts", "finite_parts", "RIGID",
           "PARTICLES", "BODIES"]

RIGID = Obj("pbanim.rigid.bodies:RigidBodies")
PARTICLES = Obj("pbanim.particles.system:ParticleSystem")
BODIES = Obj("pbanim.rigid.bodies:RigidBodies", "pbanim.particles.system:ParticleSystem",
             what="a RigidBodies or a ParticleSystem")


def state_length(system) -> int:
    """Length of the flat state of ``system``: its ``n_state``, else 13 N for rigid bodies (x, q, P, L)."""
    n = getattr(system, "n_state", None)
    if n is not None:
        return int(n)
    return 13 * int(system.N) if getattr(system, "kind", "") == "rigid" else int(system.state().size)


def state_of(ref: str):
    """A shape entry for a contract: the flat state length of the system the reference ``ref`` names."""
    return lambda env: state_length(env.resolve(ref))


def _dim(system) -> int:
    return 3 if getattr(system, "kind", "") == "rigid" else int(system.dim)


def _problem(contacts, system) -> str:
    """What is wrong with ``contacts`` for ``system`` ("" when nothing is)."""
    from ..collision.shapes import Contacts

    if not isinstance(contacts, Contacts):
        return f"a {type(contacts).__name__}, not a Contacts (pbanim.contact.make_contacts)"
    if not contacts.m:
        return ""
    N, d = int(system.N), _dim(system)
    if contacts.point.shape[1] != d:
        return f"{contacts.point.shape[1]}-D points for a {d}-D system"
    top = max(int(contacts.a.max()), int(contacts.b.max()))
    if top >= N:
        return f"it names body {top} of N = {N} (0 … {N - 1}, −1 the world)"
    same = np.flatnonzero(contacts.a == contacts.b)
    if same.size:
        return f"contact {int(same[0])} joins body {int(contacts.a[same[0]])} to itself"
    return ""


def check_contacts(where: str, name: str, contacts, system):
    """``contacts`` when it is a Contacts among the bodies of ``system`` in its dimension, else
    :class:`~pbanim.errors.InvalidInput` naming ``name`` (the argument, or ``detect`` for what it returned)."""
    problem = _problem(contacts, system)
    if problem:
        raise InvalidInput(f"{where}: {name} must be {ContactsOn('the system').describe()}; {problem}")
    return contacts


class ContactsOn(Spec):
    """A Contacts among the bodies of the argument ``system`` (see :func:`check_contacts`)."""

    def __init__(self, system: str = "system") -> None:
        self.system = system
        self.size = f"{system}.N"           # read by the contract: this spec refers to another argument

    def describe(self) -> str:
        return f"a Contacts among the bodies of {self.system} (indices −1 … N − 1, in its dimension)"

    def check(self, name, value, env):
        problem = _problem(value, env.resolve(self.system))
        if problem:
            raise env.fail(name, self.describe(), value, problem)
        return value

    def example(self, env):
        from ..collision.shapes import Contacts

        d = _dim(env.resolve(self.system))
        return Contacts([0], [-1], [np.zeros(d)], [np.eye(d)[-1]], [0.0])

    def bad(self, env):
        from ..collision.shapes import Contacts

        system = env.resolve(self.system)
        N, d = int(system.N), _dim(system)
        up = np.eye(d)[-1]
        return [("None", None), ("a string", "x"), ("a number", 1.0),
                ("a body past the end", Contacts([N], [-1], [np.zeros(d)], [up], [0.0])),
                ("a body with itself", Contacts([0], [0], [np.zeros(d)], [up], [0.0])),
                ("the wrong dimension", Contacts([0], [-1], [np.zeros(5 - d)], [np.eye(5 - d)[-1]], [0.0]))]

    def edges(self, env):
        from ..collision.shapes import Contacts

        d = _dim(env.resolve(self.system))
        return [("no contacts", Contacts(np.zeros(0, int), np.zeros(0, int), np.zeros((0, d)), np.zeros((0, d)),
                                         np.zeros(0)))]


def finite_parts(value, where: str, arguments=None):
    """A ``returns`` certificate (:func:`pbanim.contracts.contract`): every float array and number of the
    result — itself, the items of a tuple, list or dict, the array fields of a pbanim record — is finite,
    else :class:`~pbanim.errors.NonFiniteResult` naming the function (finite inputs too large for double
    precision: the products overflowed)."""
    if isinstance(value, (tuple, list)):
        parts = list(value)
    elif isinstance(value, dict):
        parts = list(value.values())
    elif type(value).__module__.startswith("pbanim") and hasattr(value, "__dict__"):
        parts = list(vars(value).values())
    else:
        parts = [value]
    for v in parts:
        if type(v).__module__.startswith("pbanim") and hasattr(v, "__dict__") and v is not value:
            finite_parts(v, where)
        elif isinstance(v, float) and not np.isfinite(v) or isinstance(v, np.ndarray) and v.dtype.kind in "fc" \
                and not np.isfinite(v).all():
            raise NonFiniteResult(f"the result of {where}")
    return value


class RigidState(Spec):
    """The per-body arrays of :func:`~pbanim.contact.assembly.rigid_state`: a dict with ``x`` (n, 3) and the
    other keys it returns, all finite (n = N + 1: the world padded last)."""

    KEYS = ("x", "v", "omega", "L", "inv_mass", "Iinv", "Wb")

    def describe(self) -> str:
        return "the dict of rigid_state(bodies, y) (keys x, v, omega, L, inv_mass, Iinv, Wb; finite)"

    def check(self, name, value, env):
        if not isinstance(value, dict):
            raise env.fail(name, self.describe(), value)
        missing = [k for k in self.KEYS if k not in value]
        if missing:
            raise env.fail(name, self.describe(), value, f"it lacks {', '.join(missing)}")
        x = value["x"]
        if not (isinstance(x, np.ndarray) and x.ndim == 2 and x.shape[1] == 3 and len(x) >= 1) or not all(
                isinstance(value[k], np.ndarray) and len(value[k]) == len(x) and np.isfinite(value[k]).all()
                for k in self.KEYS):
            raise env.fail(name, self.describe(), value, "its arrays are not finite, or not one row per body")
        return value

    def bad(self, env):
        return [("None", None), ("a string", "x"), ("an empty dict", {})]
