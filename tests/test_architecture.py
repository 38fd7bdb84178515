"""The import rules of ARCHITECTURE.md, checked on the source (``ast``), not on a running interpreter.

Every ``.py`` file under ``pbanim/`` belongs to a *unit*: the first name below the package
(``pbanim/ode/solve.py`` → ``ode``, ``pbanim/cli.py`` → ``cli``). Each unit has a layer (``LAYERS``,
low → high) and

1. a module imports units of its own layer or of lower layers, never of a higher one;
2. a name with a leading underscore (not a dunder) is private to its unit: no other unit imports it, nor a
   module whose dotted path has a private component;
3. a unit missing from ``LAYERS`` fails: a new subpackage is placed in the table (and in ARCHITECTURE.md)
   when it is created;
4. nothing under ``pbanim/`` calls ``exec`` or ``eval``.

All ``import`` / ``from … import`` statements count, wherever they are (module level, inside functions —
the lazy imports —, under ``if TYPE_CHECKING``), and so does ``importlib.import_module("a.b")`` with a
literal name. ``chapters/`` (outside the package) is the top layer and may import only public names.
"""

from __future__ import annotations

import ast
from pathlib import Path

REPO = Path(__file__).resolve().parent.parent

# low → high; a module may import its own layer and the layers below it
LAYERS: dict[str, int] = {
    # 0: named errors, result records, small vector helpers
    "errors": 0, "results": 0, "geometry": 0, "derivatives": 0, "contracts": 0, "sparse_kernel": 0,
    # 1: integrators and the fixed-step driver; the LCP / QP core
    "ode": 1, "lcp": 1,
    # 2: the body protocol; Scene, Effect and the step pipeline
    "bodies": 2, "scene": 2,
    # 3: the systems
    "particles": 3, "rigid": 3, "fluids": 3,
    # 4: Lagrange multipliers, reduced coordinates and the Lagrangian, collision detection and impulses
    "constraints": 4, "reduced": 4, "lagrangian": 4, "collision": 4, "cloth": 4,
    # 5: resting contact and friction, articulated bodies
    "contact": 5, "articulated": 5,
    # 6: characters and controllers, motion design
    "control": 6, "design": 6,
    # 7: canonical systems with their exact answers (the oracles)
    "models": 7,
    # 8: work-precision sweeps, test assertions, figure styling and registry, GIF frames without redrawing what
    #    does not move, the engine comparison harness
    "accuracy": 8, "testing": 8, "plotting": 8, "plotting_gif": 8, "compare": 8,
    # 9: benchmark families, the command line, the course tools (assignments, grader), and the facade pbanim/__init__.py (it re-exports from the
    #    subpackages, so only the top layers may import ``pbanim`` itself)
    "bench": 9, "cli": 9, "course": 9, "__init__": 9,
    # 10: the lecture chapters, outside the package; public names only
    "chapters": 10,
}

# upward imports that the architecture asks for: the command line (the top of the package) finds the
# chapters and hands their figures to pbanim.plotting
ALLOWED_UPWARD: frozenset[tuple[str, str]] = frozenset({("cli", "chapters")})

# packages outside pbanim that are units of the table (imported as ``chapters`` / ``chapters.ch02_ode``)
CLIENTS = ("chapters",)


def _private(name: str) -> bool:
    return name.startswith("_") and not (name.startswith("__") and name.endswith("__"))


def _module_name(path: Path, base: Path) -> str:
    parts = list(path.relative_to(base).with_suffix("").parts)
    if parts[-1] == "__init__":
        parts.pop()
    return ".".join(parts)


def _imports(tree: ast.AST, module: str, is_package: bool):
    """(line, dotted module, imported names or None) for every import in ``tree``, relative ones resolved."""
    package = module if is_package else module.rpartition(".")[0]
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            for alias in node.names:
                yield node.lineno, alias.name, None
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                parts = package.split(".")
                base = parts[:len(parts) - (node.level - 1)] if node.level > 1 else parts
                target = ".".join(base + ([node.module] if node.module else []))
            else:
                target = node.module or ""
            yield node.lineno, target, [a.name for a in node.names]
        elif (isinstance(node, ast.Call) and node.args and isinstance(node.args[0], ast.Constant)
              and isinstance(node.args[0].value, str)
              and ((isinstance(node.func, ast.Attribute) and node.func.attr == "import_module")
                   or (isinstance(node.func, ast.Name) and node.func.id in ("import_module", "__import__")))):
            yield node.lineno, node.args[0].value, None


def check_layers(root: Path, layers: dict[str, int] = LAYERS, clients: tuple[str, ...] = CLIENTS,
                 allowed: frozenset = ALLOWED_UPWARD, client_dirs: list[Path] = ()) -> list[str]:
    """The violations of the import rules in the package at ``root`` (a folder with ``__init__.py``).

    ``client_dirs`` are packages outside it (``chapters/``) checked as the layer of their name: private
    names and unknown units only. Returns one line per violation, ``path:line: what``.
    """
    root = Path(root)
    pkg = root.name
    base = root.parent
    out: list[str] = []

    def reached(dotted: str, names: list[str] | None):
        """(unit, module shown, names) an import reaches: ``from pbanim import ode, solve`` reaches the
        unit ode (module pbanim.ode) and the facade (name solve); nothing for numpy, scipy, the stdlib."""
        parts = dotted.split(".")
        if parts[0] in clients:
            return [(parts[0], dotted, names or [])]
        if parts[0] != pkg:
            return []
        if len(parts) > 1:
            return [(parts[1], dotted, names or [])]
        if names is None:
            return [("__init__", dotted, [])]
        out = []
        for n in names:
            if (root / f"{n}.py").is_file() or (root / n / "__init__.py").is_file():
                out.append((n, f"{dotted}.{n}", []))
            else:
                out.append(("__init__", dotted, [n]))
        return out

    def check_file(path: Path, unit: str, top: Path):
        rel = path.relative_to(top.parent).as_posix()
        module = _module_name(path, top.parent)
        try:
            tree = ast.parse(path.read_text(encoding="utf-8"), filename=str(path))
        except SyntaxError as exc:
            out.append(f"{rel}:{exc.lineno}: does not parse ({exc.msg})")
            return
        if unit not in layers:
            out.append(f"{rel}:1: unit {unit!r} is not in the layer table")
            return
        for line, target, names in _imports(tree, module, path.name == "__init__.py"):
            for dest, shown, what in reached(target, names):
                where = f"{rel}:{line}"
                if dest not in layers:
                    out.append(f"{where}: imports {shown!r}, whose unit {dest!r} is not in the layer table")
                    continue
                if dest == unit:
                    continue
                if layers[dest] > layers[unit] and (unit, dest) not in allowed:
                    out.append(f"{where}: {unit} (layer {layers[unit]}) imports {shown} ({dest}, layer {layers[dest]})")
                private = [p for p in shown.split(".")[1:] if _private(p)] + [n for n in what if _private(n)]
                if private:
                    out.append(f"{where}: {unit} imports private {', '.join(private)} from {shown} ({dest})")

    for path in sorted(root.rglob("*.py")):
        rel_parts = path.relative_to(root).parts
        unit = "__init__" if rel_parts == ("__init__.py",) else Path(rel_parts[0]).stem
        check_file(path, unit, root)
    for cdir in client_dirs:
        for path in sorted(Path(cdir).rglob("*.py")):
            check_file(path, Path(cdir).name, Path(cdir))
    return out


# ---------------------------------------------------------------------------------------------------
# the rules, on pbanim and chapters/
# ---------------------------------------------------------------------------------------------------
def test_imports_follow_the_layers():
    violations = check_layers(REPO / "pbanim", client_dirs=[REPO / "chapters"])
    assert not violations, "import rules of ARCHITECTURE.md broken:\n" + "\n".join(violations)


def test_every_unit_of_the_package_is_in_the_layer_table():
    units = {p.stem for p in (REPO / "pbanim").iterdir()
             if (p.suffix == ".py" and p.name != "__init__.py") or (p / "__init__.py").is_file()}
    assert units - set(LAYERS) == set(), f"place these in LAYERS (and ARCHITECTURE.md): {sorted(units - set(LAYERS))}"


def test_plotting_does_not_import_the_chapters():
    found = [(name, line, target) for name in ("plotting", "plotting_gif") for line, target, _ in
             _imports(ast.parse((REPO / "pbanim" / f"{name}.py").read_text(encoding="utf-8")), f"pbanim.{name}", False)
             if target.split(".")[0] == "chapters"]
    assert found == []


def test_no_exec_or_eval_in_the_package():
    calls = []
    for path in sorted((REPO / "pbanim").rglob("*.py")):
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if not isinstance(node, ast.Call):
                continue
            f = node.func
            if ((isinstance(f, ast.Name) and f.id in ("exec", "eval"))
                    or (isinstance(f, ast.Attribute) and f.attr in ("exec", "eval")
                        and isinstance(f.value, ast.Name) and f.value.id == "builtins")):
                calls.append(f"{path.relative_to(REPO).as_posix()}:{node.lineno}: {ast.unparse(f)}(…)")
    assert calls == [], "exec / eval in the package:\n" + "\n".join(calls)


# ---------------------------------------------------------------------------------------------------
# the checker catches what it should (a tiny fake package)
# ---------------------------------------------------------------------------------------------------
def _fake(tmp_path: Path, files: dict[str, str]) -> Path:
    root = tmp_path / "fakepkg"
    for rel, text in {"__init__.py": "", "ode/__init__.py": "", "contact/__init__.py": "",
                      "errors.py": "", **files}.items():
        p = root / rel
        p.parent.mkdir(parents=True, exist_ok=True)
        p.write_text(text)
    return root


def test_checker_reports_an_upward_import(tmp_path):
    root = _fake(tmp_path, {"ode/x.py": "import numpy\nimport fakepkg.contact\n"})
    assert check_layers(root) == ["fakepkg/ode/x.py:2: ode (layer 1) imports fakepkg.contact (contact, layer 5)"]


def test_checker_reports_lazy_and_relative_upward_imports(tmp_path):
    root = _fake(tmp_path, {"ode/x.py": "def f():\n    from ..contact import y\n    return y\n",
                            "ode/y.py": "from .. import contact\nfrom . import x\n"})
    v = check_layers(root)
    assert v == ["fakepkg/ode/x.py:2: ode (layer 1) imports fakepkg.contact (contact, layer 5)",
                 "fakepkg/ode/y.py:1: ode (layer 1) imports fakepkg.contact (contact, layer 5)"]


def test_checker_allows_downward_and_same_unit_private_imports(tmp_path):
    root = _fake(tmp_path, {"contact/x.py": "from ..ode import step\nfrom fakepkg.errors import E\n"
                                            "from ._impl import _helper\n",
                            "contact/_impl.py": "_helper = 1\n"})
    assert check_layers(root) == []


def test_checker_reports_private_names_across_units(tmp_path):
    root = _fake(tmp_path, {"contact/x.py": "from ..ode.methods import _RK_STEPS\nimport fakepkg.ode._impl\n"})
    assert check_layers(root) == [
        "fakepkg/contact/x.py:1: contact imports private _RK_STEPS from fakepkg.ode.methods (ode)",
        "fakepkg/contact/x.py:2: contact imports private _impl from fakepkg.ode._impl (ode)"]


def test_checker_reports_units_missing_from_the_table(tmp_path):
    root = _fake(tmp_path, {"newthing/__init__.py": "", "ode/x.py": "from fakepkg.elsewhere import z\n"})
    assert check_layers(root) == [
        "fakepkg/newthing/__init__.py:1: unit 'newthing' is not in the layer table",
        "fakepkg/ode/x.py:1: imports 'fakepkg.elsewhere', whose unit 'elsewhere' is not in the layer table"]


def test_checker_reports_private_names_in_client_packages(tmp_path):
    root = _fake(tmp_path, {})
    chapters = tmp_path / "chapters"
    chapters.mkdir()
    (chapters / "__init__.py").write_text("")
    (chapters / "ch01.py").write_text("from fakepkg.contact import run, _batch\n")
    assert check_layers(root, client_dirs=[chapters]) == [
        "chapters/ch01.py:1: chapters imports private _batch from fakepkg.contact (contact)"]
