"""The contract vocabulary and the boundary check (pbanim.contracts; issue 27, point 1).

Each spec accepts what it declares and refuses the rest with an InvalidInput naming the argument, what was
expected and what came in; the check runs for calls from outside the package only; certificates of results
run on outside calls; the fuzzer's bad values are refused by the spec that made them and its edge values
accepted (the property the generated fuzz relies on), for every spec kind, with hypothesis.
"""

from __future__ import annotations

import math
import os
import subprocess
import sys
import textwrap

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import pbanim
from pbanim.contracts import (Anything, Array, Choice, Either, Flag, Func, Has, Index, Indices, Int, Obj, Opt,
                              PathLike, Real, Seq, Text, boundary_checks, contract, contract_of, finite_result,
                              unchecked)
from pbanim.contracts.specs import Env
from pbanim.errors import InvalidInput, NonFiniteResult


def env(**values):
    return Env("f", values)


# -- each spec: accepts its domain, refuses the rest, names the argument ---------------------------------
@pytest.mark.parametrize("spec, good, bad", [
    (Real(ge=0), [0.0, 1, 2.5, np.float32(3), np.array(4.0)], [-1e-300, math.nan, math.inf, "1", None, True, [1.0]]),
    (Real(gt=0, lt=1), [0.5, 1e-300], [0.0, 1.0, -0.1, math.nan]),
    (Real(finite=False), [math.inf, -math.inf, 0.0], [math.nan, "x"]),
    (Int(ge=1), [1, 2.0, np.int64(5)], [0, 1.5, math.nan, math.inf, True, "2", None]),
    (Int(ge=0, le=3), [0, 3], [-1, 4]),
    (Choice(["a", "b"]), ["a", "b"], ["c", None, 1, True]),
    (Flag(), [True, False, np.bool_(True)], [0, 1, "yes", None]),
    (Text(nonempty=True), ["x"], ["", None, 1.0]),
    (PathLike(), ["out.png", __import__("pathlib").Path("x")], ["", None, 1.0]),
    (Func(), [len, lambda: 0], [None, "f", 1.0]),
    (Obj(np.ndarray), [np.zeros(1)], [[0.0], None]),
    (Has("shape", "dtype"), [np.zeros(1)], [[0.0], None]),
    (Opt(Real(gt=0)), [None, 1.0], [0.0, math.nan]),
    (Either(Real(gt=0), Choice(["auto"])), [1.0, "auto"], [0.0, "manual", None]),
    (Seq(Real(ge=0), min_len=1), [[0.0], (1.0, 2.0)], [[], [-1.0], "ab", None]),
    (Array((2,)), [[1.0, 2.0], np.array([1, 2])], [[1.0], [1.0, math.nan], [[1.0, 2.0]], "12", None,
                                                    np.array([1 + 1j, 2]), np.array([True, False]), []]),
    (Array(("n", 3), ge=0), [np.zeros((4, 3))], [-np.ones((1, 3)), np.zeros((0, 3)), np.zeros(3)]),
    (Array((3,), batch="first"), [np.zeros(3), np.zeros((5, 3))], [np.zeros((2, 2, 3)), np.zeros(4)]),
    (Array((2,), scalar=True, gt=0), [1.0, [1.0, 2.0]], [0.0, [0.0, 1.0]]),
    (Array((None,), empty=True), [[], [1.0]], [[math.nan]]),
    (Array(None, nan=True), [[math.nan, math.inf]], ["x", None]),
])
def test_spec_accepts_its_domain_and_refuses_the_rest(spec, good, bad):
    for v in good:
        spec.check("arg", v, env())
    for v in bad:
        with pytest.raises(InvalidInput, match=r"^f: arg(\[\d+\])? must be "):
            spec.check("arg", v, env())


def test_message_says_which_argument_what_was_expected_and_what_came_in():
    @contract(k=Real(ge=0), x=Array(("n", 2)), m=Array(("n",), gt=0))
    def spring(k, x, m):
        return k

    with pytest.raises(InvalidInput, match=r"^.*spring: k must be a finite number >= 0, got -1.0$"):
        spring(-1.0, [[0.0, 0.0]], [1.0])
    # symbols are bound across the call: x fixes n = 1, so m of length 2 is refused, and the message says n
    with pytest.raises(InvalidInput, match=r"m must be a float array of shape \(n,\) \(n = 1\).* got "
                                           r"array\(\[1., 1.\]\); shape \(2,\)"):
        spring(1.0, [[0.0, 0.0]], np.ones(2))
    with pytest.raises(InvalidInput, match=r"x must be .* a batch of states is not accepted here"):
        spring(1.0, np.zeros((3, 1, 2)), [1.0])
    with pytest.raises(InvalidInput, match=r"method must be one of 'rk4', 'euler', got 'rk5'; did you mean 'rk4'\?"):
        contract(method=Choice(["rk4", "euler"]))(lambda method: method)("rk5")


def test_references_resolve_other_arguments_and_attributes():
    class System:
        N = 3

    @contract(system=Obj(System), i=Index("system.N"), x=Array(("system.N", 2)), ids=Indices("system.N"))
    def f(system, i, x, ids):
        return i

    s = System()
    assert f(s, 2, np.zeros((3, 2)), [0, 2]) == 2
    with pytest.raises(InvalidInput, match=r"i must be an index in 0 … 2, got 3"):
        f(s, 3, np.zeros((3, 2)), [0])
    with pytest.raises(InvalidInput, match=r"x must be a float array of shape \(3, 2\) \(system.N\)"):
        f(s, 0, np.zeros((2, 2)), [0])
    with pytest.raises(InvalidInput, match=r"ids must be indices in 0 … 2.*entries range over \[0, 3\]"):
        f(s, 0, np.zeros((3, 2)), [0, 3])


def test_converted_values_reach_the_function():
    @contract(k=Real(), n=Int(ge=0), x=Array((2,)))
    def f(k, n, x):
        return k, n, x

    k, n, x = f(np.float32(2), 3.0, [1, 2])
    assert type(k) is float and type(n) is int and x.dtype == float and x.shape == (2,)


def test_checks_run_at_the_boundary_only():
    # a call from a module of the package skips the check (the public function the user called checked
    # once); the same call from outside is checked; boundary_checks() forces it everywhere
    calls = []

    @contract(k=Real(ge=0))
    def f(k):
        calls.append(k)
        return k

    pkg = os.path.dirname(pbanim.__file__)
    inside = {}
    exec(compile("def g(f, k):\n    return f(k)\n", os.path.join(pkg, "inside_example.py"), "exec"), inside)  # noqa: S102
    assert inside["g"](f, -1.0) == -1.0                      # unchecked: from inside the package
    with pytest.raises(InvalidInput):
        f(-1.0)                                              # checked: from a test, outside
    with boundary_checks(), pytest.raises(InvalidInput):
        inside["g"](f, -1.0)
    assert unchecked(f)(-2.0) == -2.0 and unchecked(f) is f.__wrapped__


def test_contract_of_classes_methods_and_unknown_names():
    @contract(mass=Real(gt=0))
    class Body:
        def __init__(self, mass):
            self.mass = mass

        @contract(dt=Real(gt=0))
        def advance(self, dt):
            return dt

    assert contract_of(Body).specs.keys() == {"mass"}
    with pytest.raises(InvalidInput, match=r"Body: mass must be a finite number > 0, got 0.0"):
        Body(0.0)
    b = Body(1.0)
    with pytest.raises(InvalidInput, match=r"Body.advance: dt must be"):
        b.advance(-1.0)
    assert unchecked(b.advance)(-1.0) == -1.0            # a bound method: the raw function, same self
    with pytest.raises(TypeError, match="names \\['typo'\\], which are not among its parameters"):
        contract(typo=Real())(lambda k: k)
    with pytest.raises(TypeError, match="Anything needs a reason"):
        Anything("")


def test_result_certificates_run_on_outside_calls():
    @contract(x=Real(), returns=finite_result)
    def square(x):
        return x * x

    assert square(3.0) == 9.0
    with pytest.raises(NonFiniteResult, match="the result of .*square"):
        square(1e200)


# -- the fuzzer's side: bad values are refused, edges accepted, examples valid ------------------------------
SPECS = [Real(), Real(ge=0), Real(gt=0), Real(ge=0, le=1), Real(gt=-1, lt=1), Real(finite=False), Int(ge=0),
         Int(ge=1, le=10), Choice(["a", "b"]), Flag(), Text(), Text(nonempty=True), Array((3,)), Array(("n", 2), gt=0),
         Array((2,), batch="first"), Array((2,), batch="last"), Array((None,), empty=True), Array((2,), scalar=True),
         Array(None, ge=0, le=1), Opt(Real(gt=0)), Opt(Array((2,))), Seq(Real(ge=0), min_len=1),
         Either(Real(gt=0), Choice(["auto"])), Index(4), Indices(5)]


@pytest.mark.parametrize("spec", SPECS, ids=repr)
def test_fuzz_values_of_each_spec_behave_as_labelled(spec):
    e = env()
    spec.check("arg", spec.example(e), env(**{}))
    for label, v in spec.bad(e):
        with pytest.raises(InvalidInput, match=r"arg(\[\d+\])? must be"):
            spec.check("arg", v, env())
    for label, v in spec.edges(e):
        spec.check("arg", v, env())


@settings(max_examples=200, deadline=None)
@given(x=st.floats(allow_nan=True, allow_infinity=True), lo=st.floats(-1e6, 1e6), width=st.floats(0, 1e6))
def test_real_is_exactly_its_interval(x, lo, width):
    spec = Real(ge=lo, lt=lo + width) if width > 0 else Real(ge=lo)
    inside = math.isfinite(x) and x >= lo and (width == 0 or x < lo + width)
    if inside:
        assert spec.check("x", x, env()) == x
    else:
        with pytest.raises(InvalidInput):
            spec.check("x", x, env())


@settings(max_examples=100, deadline=None)
@given(shape=st.lists(st.integers(0, 3), min_size=0, max_size=3), bad=st.sampled_from([None, "nan", "inf"]))
def test_array_refuses_any_non_finite_entry_and_any_other_shape(shape, bad):
    spec = Array((2, 3))
    a = np.zeros(shape)
    if bad and a.size:
        a.flat[-1] = float(bad)
    ok = tuple(shape) == (2, 3) and bad is None
    if ok:
        spec.check("a", a, env())
    else:
        with pytest.raises(InvalidInput, match="a must be a float array of shape \\(2, 3\\)"):
            spec.check("a", a, env())


def test_array_never_refuses_finite_values_whose_sum_overflows():
    # entries are tested one by one (a sum of 1e308 + 1e308 would overflow although every entry is finite)
    Array((2,)).check("a", [1e308, 1e308], env())
    Array((2,), gt=0).check("a", [1e308, 1e308], env())


def test_import_cost_and_no_heavy_imports():
    # the contracts load numpy only; declaring them does not import the optional libraries
    code = "import sys, pbanim.contracts; print(sorted(m for m in ('sympy', 'qpsolvers', 'matplotlib') if m in sys.modules))"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    assert out.strip() == "[]"


def test_obj_resolves_a_class_named_by_string_lazily():
    spec = Obj("fractions:Fraction")
    import fractions

    spec.check("x", fractions.Fraction(1, 2), env())
    with pytest.raises(InvalidInput, match="x must be an instance of Fraction, got 0.5; a float"):
        spec.check("x", 0.5, env())


def test_docstring_example_of_the_package():
    import doctest

    import pbanim.contracts as c

    assert doctest.testmod(c).failed == 0


def test_a_module_of_the_package_is_recognised_wherever_it_is_installed(tmp_path):
    # the inside/outside test uses the package's own folder, not a fixed path
    code = textwrap.dedent("""
        import pbanim.contracts.declare as d, pbanim, os
        assert d._PKG == os.path.dirname(os.path.abspath(pbanim.__file__)) + os.sep
        print("ok")
    """)
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True, cwd=tmp_path)
    assert out.stdout.strip() == "ok"


def test_call_checked_checks_a_call_made_from_inside_the_package():
    # the command line is a module of the package; what it passes comes from the user
    from pbanim.contracts import call_checked

    @contract(k=Real(ge=0), returns=finite_result)
    def f(k):
        return k * 1e300

    @contract(mass=Real(gt=0))
    class Body:
        def __init__(self, mass):
            self.mass = mass

        @contract(dt=Real(gt=0))
        def advance(self, dt):
            return dt

        @classmethod
        @contract(n=Int(ge=1))
        def many(cls, n):
            return [cls(1.0) for _ in range(n)]

    pkg = os.path.dirname(pbanim.__file__)
    inside = {}
    exec(compile("def g(call, f, *a):\n    return call(f, *a)\n", os.path.join(pkg, "cli_example.py"), "exec"), inside)  # noqa: S102
    with pytest.raises(InvalidInput, match="k must be"):
        inside["g"](call_checked, f, -1.0)
    with pytest.raises(NonFiniteResult):
        inside["g"](call_checked, f, 1e10)
    with pytest.raises(InvalidInput, match="Body: mass must be"):
        inside["g"](call_checked, Body, 0.0)
    with pytest.raises(InvalidInput, match="advance: dt must be"):
        inside["g"](call_checked, Body(1.0).advance, 0.0)
    assert inside["g"](call_checked, Body(1.0).advance, 2.0) == 2.0
    assert contract_of(Body.__dict__["many"]) is not None       # a classmethod carries its contract
    with pytest.raises(InvalidInput, match="many: n must be a positive integer"):
        Body.many(0)


@pytest.mark.parametrize("kind", ["particles", "rigid", "constraints"])
def test_a_run_from_user_code_checks_its_arguments_once_and_no_step_pays(kind, monkeypatch):
    # the boundary is the call the user makes: simulate checks its arguments once; the functions the step
    # loop calls (the stages, the integrator, the system) are called from inside the package and check nothing
    from pbanim.contracts.declare import Contract
    from pbanim.particles import DampedSprings, Gravity, ParticleSystem
    from pbanim.scene import Scene

    if kind == "rigid":
        from pbanim.rigid import RigidBodies, RigidGravity, RigidScene
        scene = RigidScene(RigidBodies([1.0], [1.0, 2.0, 3.0], angular_velocities=[[1.0, 2.0, 0.5]]),
                           [RigidGravity()])
    elif kind == "constraints":
        from pbanim.constraints import Constraints, Distance
        ps = ParticleSystem([[1.0, 0.0], [2.0, 0.0]], masses=1.0)
        scene = Scene(ps, [Gravity(), Constraints([Distance([[-1, 0], [0, 1]], anchors=[0.0, 0.0])],
                                                  stabilization="baumgarte", ks=10.0, kd=5.0)])
    else:
        ps = ParticleSystem(np.arange(12.0).reshape(4, 3), masses=1.0)
        scene = Scene(ps, [Gravity(), DampedSprings([[0, 1], [1, 2], [2, 3]], 10.0, 0.1)])
    count = [0]
    original = Contract.check

    def counting(self, args, kwargs):
        count[0] += 1
        return original(self, args, kwargs)

    monkeypatch.setattr(Contract, "check", counting)
    scene.simulate(0.05, 1e-3, "rk4", diagnostics=False)        # 50 steps, 200 evaluations of the forces
    assert count[0] == 1
