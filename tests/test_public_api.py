"""Stable public import paths and the curated top level (issue 12, points 2 and 7).

``tests/data/public_names_before_subpackages.json`` is the frozen list of every public name of every
public module as it stood before the package was split into subpackages (taken from the last flat
release, commit ce42e42): course material imports these, so each must keep resolving.
"""

import importlib
import json
import pathlib
import re
import subprocess
import sys

import pytest

import pbanim

ROOT = pathlib.Path(__file__).resolve().parents[1]
FROZEN = json.loads((ROOT / "tests" / "data" / "public_names_before_subpackages.json").read_text())


@pytest.mark.parametrize("module", sorted(FROZEN))
def test_every_name_importable_before_the_move_still_imports(module):
    mod = importlib.import_module(module)
    missing = [n for n in FROZEN[module] if not hasattr(mod, n)]
    assert not missing, f"{module} lost {missing}"


def test_legacy_top_level_names_are_the_subpackage_objects():
    # a name resolved lazily from pbanim is the very object of its subpackage, not a copy
    from pbanim import collision, constraints, ode, rigid

    assert pbanim.quat_multiply is rigid.quat_multiply
    assert pbanim.solve_lambda is constraints.solve_lambda
    assert pbanim.rk4_step is ode.rk4_step
    assert pbanim.solve_lcp_small is collision.solve_lcp_small
    with pytest.raises(AttributeError, match="module 'pbanim' has no attribute 'no_such_name'"):
        pbanim.no_such_name  # noqa: B018
    from pbanim import rigid_quat  # a module of the flat layout
    assert rigid_quat.skew is rigid.skew


def test_top_level_is_curated():
    # a few dozen names, each a class, function or constant a course uses; no module among them
    assert 20 <= len(pbanim.__all__) <= 50
    assert len(set(pbanim.__all__)) == len(pbanim.__all__)
    for name in pbanim.__all__:
        assert not isinstance(getattr(pbanim, name), type(pbanim)), name
    for name in ("solve", "METHODS", "Scene", "ParticleSystem", "RigidBodies", "SimResult", "SimulationDiverged"):
        assert name in pbanim.__all__


def test_import_pbanim_makes_no_internal_module_an_attribute():
    # run in a fresh interpreter: only the subpackages the top level imports on purpose are attributes,
    # and the heavy optional libraries are not loaded
    code = ("import sys, types, pbanim; "
            "print(sorted(n for n, v in vars(pbanim).items() if isinstance(v, types.ModuleType) and not n.startswith('_'))); "
            "print(sorted(m for m in ('sympy', 'qpsolvers', 'proxsuite', 'matplotlib') if m in sys.modules))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout.split("\n")
    modules = eval(out[0])  # a printed list of str
    assert set(modules) <= {"errors", "results", "derivatives", "geometry", "contracts", "ode", "scene", "bodies", "particles",
                            "constraints", "reduced", "rigid", "collision", "contact", "lcp"}, modules
    assert not {"bench", "cli", "plotting", "models", "testing", "accuracy"} & set(modules)
    assert eval(out[1]) == []


def _readme_names():
    text = (ROOT / "README.md").read_text()
    names = set()
    for block in re.findall(r"```python\n(.*?)```", text, flags=re.S):
        for mod, items in re.findall(r"^from (pbanim[\w.]*) import ([\w, ()]+)$", block, flags=re.M):
            names |= {(mod, n.strip()) for n in items.strip("()").split(",") if n.strip()}
    for dotted in re.findall(r"`(pbanim(?:\.\w+)+)", text):
        parts = dotted.split(".")
        names.add((".".join(parts[:-1]), parts[-1]))
    return sorted(names)


def test_readme_lists_public_names():
    assert len(_readme_names()) >= 10


@pytest.mark.parametrize("module, name", _readme_names())
def test_every_public_name_in_the_readme_imports(module, name):
    try:   # a dotted path in the README may name a module (pbanim.rigid) or a name in one
        importlib.import_module(f"{module}.{name}")
        return
    except ModuleNotFoundError:
        pass
    assert hasattr(importlib.import_module(module), name), f"README names {module}.{name}"


def test_readme_examples_run(tmp_path):
    # the code a newcomer copies first must run as printed (blocks run in order, in one fresh process, in a
    # scratch folder: the first example saves energy.png)
    import os

    text = (ROOT / "README.md").read_text()
    code = "\n".join(re.findall(r"```python\n(.*?)```", text, flags=re.S))
    assert "Scene" in code and "solve" in code
    env = dict(os.environ, MPLBACKEND="Agg")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, cwd=tmp_path, timeout=120,
                         env=env)
    assert out.returncode == 0, out.stderr
    assert "('gravity', 'drag', 'integrate')" in out.stdout
    assert "energy drift 1.06e-02 J" in out.stdout and (tmp_path / "energy.png").stat().st_size > 1000
