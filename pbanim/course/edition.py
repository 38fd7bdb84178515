"""``pbanim course student-edition OUT/``: a wheel of pbanim without the solutions of the assignments.

A student who installs the full reference has every solution one import away
(``pbanim.constraints.effect.solve_multipliers`` *is* the answer to ch03_constraints) and the code of the
grader's hidden checks beside it. The student edition is the same package with, for each chosen assignment

* every marked region of its reference module replaced by one ``raise NotImplementedError`` naming the
  region and the assignment (the markers stay, so ``pbanim assignment make`` still cuts the starter, and
  the grader still reads the signatures);
* the functions of its hidden checks removed from the checks module, with the private helpers only they
  used, and its mutants (typical bugs written as edits *of the solution text*) emptied;

and a file ``pbanim/course/_edition.py`` saying so (:func:`edition_info`; the registry then accepts an
assignment whose public checks are worth less than 100 points). Everything else — the other modules,
the chapters and their figures — is copied unchanged; what calls a removed region raises the
``NotImplementedError`` naming the assignment.

The wheel is written directly (it is a zip: the package files, ``METADATA``, ``WHEEL``,
``entry_points.txt`` and ``RECORD`` with each file's sha256), from the installed package itself, so an
instructor needs no source tree and no build tools; entries carry a fixed date, so the same reference and
choice give the same bytes. Its version is ``<version>+<tag>`` (PEP 440 local label: ``+student``).

``keep_hidden=True`` builds the grading edition that :mod:`pbanim.course.gradescope` ships to the platform:
solutions removed (a submission that imports pbanim's own solution gets ``NotImplementedError``), hidden
checks kept.

Limiting cases: no assignment chosen is refused; an assignment name not registered is refused by name;
a region of one line becomes the one ``raise`` line as in the starter.
"""

from __future__ import annotations

import ast
import base64
import hashlib
import importlib
import importlib.metadata
import importlib.util
import sys
import zipfile
from pathlib import Path

import types

from ..contracts import Flag, Obj, Opt, PathLike, Seq, Text, contract
from ..errors import InvalidInput
from .markers import END, find_regions, region_owners
from .registry import ASSIGNMENT, Assignment, get_assignment

__all__ = ["build_edition", "edition_source", "strip_checks", "edition_info", "edition_files", "substitute_student"]

_DATE = (2020, 1, 1, 0, 0, 0)          # fixed entry date: reproducible wheels
_SKIP_DIRS = {"__pycache__"}


def edition_info() -> dict:
    """What this installation is: ``{}`` for the full reference, else the edition's record
    ({"tag", "assignments", "hidden_checks"})."""
    try:
        from ._edition import EDITION      # only an edition has this file
    except ImportError:
        return {}
    return dict(EDITION)


@contract(assignment=Obj(Assignment), mod=Obj(types.ModuleType))
def substitute_student(assignment, mod) -> list[str]:
    """In an edition without ``assignment``'s solution, put the student's functions where pbanim's removed
    ones were, so that pbanim's own code (a scene, a projection) runs on the student's: a method ``A.f``
    is set on pbanim's class ``A``; a function ``f`` replaces every module attribute of pbanim (and the
    chapters) bound to pbanim's ``f``. Returns the names replaced; nothing happens in the full reference.
    Called in the check's own (forked) process, after the student's module is loaded."""
    if assignment.name not in edition_info().get("assignments", ()):
        return []
    ref = sys.modules.get(assignment.module) or importlib.import_module(assignment.module)
    done = []
    for qual in region_owners(Path(assignment.reference_path()).read_text(encoding="utf-8"), assignment.filename):
        head, _, tail = qual.partition(".")
        ours, theirs = getattr(ref, head, None), getattr(mod, head, None)
        if ours is None or theirs is None or ours is theirs:
            continue
        if tail:
            if "." in tail or not isinstance(ours, type) or tail not in getattr(theirs, "__dict__", {}):
                continue
            setattr(ours, tail, theirs.__dict__[tail])
        else:
            for m in list(sys.modules.values()):
                if getattr(m, "__name__", "").partition(".")[0] in ("pbanim", "chapters") and \
                        getattr(m, head, None) is ours:
                    setattr(m, head, theirs)
        done.append(qual)
    return done


@contract(source=Text(), assignment=Text(nonempty=True), filename=Text())
def edition_source(source: str, assignment: str, filename: str = "<source>") -> str:
    """``source`` with each marked region's body replaced by a ``raise NotImplementedError`` naming the
    region and ``assignment``; the marker lines and everything else unchanged (relative imports too).

    >>> src = "def f(x):\\n    '''Twice x.'''\\n    # BEGIN SOLUTION f\\n    return 2 * x\\n    # END SOLUTION\\n"
    >>> print(edition_source(src, "hw0"), end="")
    def f(x):
        '''Twice x.'''
        # BEGIN SOLUTION f
        raise NotImplementedError("f is not in the student edition of pbanim: it is what you write in assignment hw0 (pbanim assignment make hw0 DIR)")
        # END SOLUTION
    """
    regions = find_regions(source, filename)
    if not regions:
        raise InvalidInput(f"{filename}: no solution markers, nothing to remove")
    lines = source.splitlines(keepends=True)
    for r in reversed(regions):
        msg = (f"{r.name} is not in the student edition of pbanim: it is what you write in assignment "
               f"{assignment} (pbanim assignment make {assignment} DIR)")
        lines[r.begin: r.end - 1] = [f'{r.indent}raise NotImplementedError("{msg}")\n']
    out = "".join(lines)
    ast.parse(out)
    assert out.count(END) == len(regions)
    return out


def _top_level(tree) -> dict:
    return {n.name: n for n in tree.body if isinstance(n, (ast.FunctionDef, ast.ClassDef))}


def _cut(lines: list[str], node) -> None:
    first = min([node.lineno] + [d.lineno for d in getattr(node, "decorator_list", [])])
    lines[first - 1: node.end_lineno] = [""] * (node.end_lineno - first + 1)


@contract(source=Text(), functions=Seq(Text(nonempty=True)), empty=Seq(Text(nonempty=True)))
def strip_checks(source: str, functions, empty: tuple = ()) -> str:
    """``source`` without the top-level functions ``functions`` (decorators included), with each
    top-level assignment to a name in ``empty`` made an empty tuple, and without the private top-level
    functions (``_name``) no longer used by what remains.

    >>> src = "A = []\\n@deco(A)\\ndef hidden(m):\\n    return _h()\\n\\ndef _h():\\n    return 1\\n\\nM = (1, 2)\\n"
    >>> print(strip_checks(src, ["hidden"], ("M",)).strip())
    A = []
    M = ()
    """
    lines = source.splitlines(keepends=True)
    tree = ast.parse(source)
    tops = _top_level(tree)
    missing = set(functions) - set(tops)
    if missing:
        raise InvalidInput(f"strip_checks: no top-level functions {sorted(missing)}")
    for name in functions:
        _cut(lines, tops[name])
    for node in tree.body:
        if isinstance(node, (ast.Assign, ast.AnnAssign)):
            targets = node.targets if isinstance(node, ast.Assign) else [node.target]
            names = [t.id for t in targets if isinstance(t, ast.Name)]
            if names and names[0] in empty:
                lines[node.lineno - 1: node.end_lineno] = [f"{names[0]} = ()\n"] + [""] * (node.end_lineno - node.lineno)
    out = "".join(lines)
    for _ in range(len(tops)):              # cap: each round removes at least one helper or stops
        tree = ast.parse(out)
        used = {n.id for n in ast.walk(tree) if isinstance(n, ast.Name)}
        used |= {n.attr for n in ast.walk(tree) if isinstance(n, ast.Attribute)}
        dead = [n for name, n in _top_level(tree).items()
                if name.startswith("_") and isinstance(n, ast.FunctionDef) and name not in used]
        if not dead:
            break
        lines = out.splitlines(keepends=True)
        for n in dead:
            _cut(lines, n)
        out = "".join(lines)
    return out


def _module_file(module: str) -> Path:
    spec = importlib.util.find_spec(module)
    if spec is None or spec.origin is None:
        raise InvalidInput(f"module {module} is not installed")
    return Path(spec.origin)


@contract(assignments=Seq(ASSIGNMENT, min_len=1), keep_hidden=Flag())
def edition_files(assignments, keep_hidden: bool = False) -> dict[Path, str]:
    """{installed file: its edition text} for the files the chosen assignments change."""
    changed: dict[Path, str] = {}
    hidden: dict[Path, set] = {}
    empty: dict[Path, set] = {}
    for name in assignments:
        a = get_assignment(name)
        ref = Path(a.reference_path())
        changed[ref] = edition_source(changed.get(ref) or ref.read_text(encoding="utf-8"), a.name, a.filename)
        for c in a.checks:
            mod = sys.modules[c.func.__module__]
            path = Path(mod.__file__)
            hidden.setdefault(path, set())
            if not c.public and not keep_hidden:
                hidden[path].add(c.func.__name__)
            muts = [k for k, v in vars(mod).items() if k.endswith("MUTANTS") and tuple(v) == a.mutants]
            empty.setdefault(path, set()).update(muts)
    for path in hidden:
        changed[path] = strip_checks(path.read_text(encoding="utf-8"), hidden[path], tuple(empty.get(path, ())))
    return changed


def _record_hash(data: bytes) -> str:
    return "sha256=" + base64.urlsafe_b64encode(hashlib.sha256(data).digest()).rstrip(b"=").decode()


def _metadata(version: str) -> str:
    meta = importlib.metadata.metadata("pbanim")
    out = ["Metadata-Version: 2.1", "Name: pbanim", f"Version: {version}",
           f"Summary: {meta.get('Summary', '')} (edition without the assignments' solutions)",
           f"Requires-Python: {meta.get('Requires-Python', '>=3.10')}"]
    out += [f"Provides-Extra: {e}" for e in meta.get_all("Provides-Extra") or []]
    out += [f"Requires-Dist: {r}" for r in meta.get_all("Requires-Dist") or []]
    return "\n".join(out) + "\n"


@contract(out_dir=PathLike(), assignments=Opt(Seq(ASSIGNMENT, min_len=1)), keep_hidden=Flag(), tag=Text(nonempty=True))
def build_edition(out_dir, assignments: list[str] | None = None, *, keep_hidden: bool = False,
                  tag: str = "student") -> Path:
    """Write the edition wheel of ``assignments`` (default: every ready one) into ``out_dir``; return its path."""
    from . import assignments as registered

    names = sorted(registered(ready_only=True)) if assignments is None else sorted(set(assignments))
    if not tag.isalnum():
        raise InvalidInput(f"tag must be letters and digits (a PEP 440 local label), got {tag!r}")
    changed = edition_files(names, keep_hidden)
    info = {"tag": tag, "assignments": tuple(names), "hidden_checks": keep_hidden}
    version = f"{importlib.metadata.version('pbanim').split('+')[0]}+{tag}"
    files: dict[str, bytes] = {}
    for pkg in ("pbanim", "chapters"):
        spec = importlib.util.find_spec(pkg)
        if spec is None or not spec.submodule_search_locations:
            continue
        root = Path(list(spec.submodule_search_locations)[0])
        for p in sorted(root.rglob("*")):
            rel = p.relative_to(root)
            if p.is_dir() or _SKIP_DIRS & set(rel.parts) or p.suffix in (".pyc", ".pyo") or p.name == "_edition.py":
                continue
            files[f"{pkg}/{rel.as_posix()}"] = (changed[p].encode() if p in changed else p.read_bytes())
    files["pbanim/course/_edition.py"] = (f'"""This installation is an edition of pbanim (see pbanim.course.edition).'
                                          f'"""\n\nEDITION = {info!r}\n').encode()
    dist = f"pbanim-{version}.dist-info"
    files[f"{dist}/METADATA"] = _metadata(version).encode()
    files[f"{dist}/WHEEL"] = b"Wheel-Version: 1.0\nGenerator: pbanim.course.edition\nRoot-Is-Purelib: true\nTag: py3-none-any\n"
    files[f"{dist}/entry_points.txt"] = b"[console_scripts]\npbanim = pbanim.cli:main\n"
    record = "".join(f"{k},{_record_hash(v)},{len(v)}\n" for k, v in files.items()) + f"{dist}/RECORD,,\n"
    files[f"{dist}/RECORD"] = record.encode()
    out = Path(out_dir)
    if out.exists() and not out.is_dir():
        raise InvalidInput(f"out_dir must be a folder, got the file {str(out_dir)!r}")
    out.mkdir(parents=True, exist_ok=True)
    path = out / f"pbanim-{version}-py3-none-any.whl"
    with zipfile.ZipFile(path, "w", zipfile.ZIP_DEFLATED) as z:
        for k, v in files.items():
            zi = zipfile.ZipInfo(k, _DATE)
            zi.compress_type = zipfile.ZIP_DEFLATED
            zi.external_attr = 0o644 << 16
            z.writestr(zi, v)
    return path
