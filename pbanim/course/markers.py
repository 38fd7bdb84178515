"""Solution markers: how an assignment is cut out of the reference code.

The reference modules mark the regions a student writes with two comment lines, nothing else (the code
between them is the reference solution and runs unchanged in pbanim)::

    def derivative(self, y, Q):
        \"\"\"dy/dt = [v, W Q].\"\"\"          ← the docstring stays in the starter
        # BEGIN SOLUTION ParticleSystem.derivative
        dy = np.empty_like(y)                  ← replaced by
        ...                                        raise NotImplementedError("ParticleSystem.derivative: …")
        # END SOLUTION

Rules, checked by :func:`find_regions` (a malformed file raises :class:`MarkerError`):

* ``# BEGIN SOLUTION <name>`` and ``# END SOLUTION`` are whole comment lines at the same indentation;
  regions do not nest; every BEGIN has its END; names are unique within a file.
* A region is the body of a function (after its docstring), its tail, or a block in its middle: the
  lines before BEGIN stay in the starter (set-up the student reads), the lines inside become one
  ``raise NotImplementedError`` at the marker's indentation, so the starter still parses and imports.
  A middle block must define the names the given code after it uses (e.g. ``apply_impact.event_time``
  in :mod:`pbanim.design.impact` defines δτ and the shifted tangents that the rest of the function uses).

:func:`starter_source` also rewrites the module's relative imports (``from ..scene import Effect``) to
absolute ones (``from pbanim.scene import Effect``): the starter is a stand-alone file in the student's
folder that uses the installed pbanim for everything it does not write itself. In the starter the
markers read ``# BEGIN STUDENT CODE <name>`` / ``# END STUDENT CODE``.

Limiting cases: a file without markers gives no regions (and an assignment on it is refused); a
region of one line is allowed. Reference: the marker convention of nbgrader (Jupyter's course tool),
with plain comments so that the reference stays ordinary, importable Python.
"""

from __future__ import annotations

import ast
import re
from dataclasses import dataclass

from ..errors import InvalidInput

__all__ = ["Region", "MarkerError", "BEGIN", "END", "find_regions", "starter_source", "absolute_imports",
           "solution_source", "region_owners"]

BEGIN = "# BEGIN SOLUTION"
END = "# END SOLUTION"
STUDENT_BEGIN = "# BEGIN STUDENT CODE"
STUDENT_END = "# END STUDENT CODE"
_BEGIN_RE = re.compile(r"^(?P<indent>[ \t]*)# BEGIN (?:SOLUTION|STUDENT CODE)[ \t]*(?P<name>\S*)[ \t]*$")
_END_RE = re.compile(r"^(?P<indent>[ \t]*)# END (?:SOLUTION|STUDENT CODE)[ \t]*$")


class MarkerError(InvalidInput):
    """The solution markers of a file are malformed (unbalanced, nested, mis-indented, unnamed)."""


@dataclass(frozen=True)
class Region:
    """One marked region: its name, the 1-based line numbers of its BEGIN and END lines, its indentation."""

    name: str
    begin: int
    end: int
    indent: str

    @property
    def body_lines(self) -> int:
        return self.end - self.begin - 1


def find_regions(source: str, filename: str = "<source>") -> list[Region]:
    """The marked regions of ``source`` in file order, or :class:`MarkerError` naming the line.

    >>> src = "def f(x):\\n    '''doc'''\\n    # BEGIN SOLUTION f\\n    return 2 * x\\n    # END SOLUTION\\n"
    >>> find_regions(src)
    [Region(name='f', begin=3, end=5, indent='    ')]
    """
    regions: list[Region] = []
    open_: tuple[int, str, str] | None = None
    for k, line in enumerate(source.splitlines(), 1):
        mb, me = _BEGIN_RE.match(line), _END_RE.match(line)
        if mb:
            if open_ is not None:
                raise MarkerError(f"{filename}:{k}: BEGIN inside the region {open_[2]!r} opened at line {open_[0]}; "
                                  "regions do not nest")
            if not mb["name"]:
                raise MarkerError(f"{filename}:{k}: BEGIN SOLUTION needs a name, e.g. '# BEGIN SOLUTION Gravity.apply'")
            open_ = (k, mb["indent"], mb["name"])
        elif me:
            if open_ is None:
                raise MarkerError(f"{filename}:{k}: END SOLUTION without a BEGIN")
            if me["indent"] != open_[1]:
                raise MarkerError(f"{filename}:{k}: END SOLUTION is indented {len(me['indent'])} columns, its BEGIN "
                                  f"(line {open_[0]}) {len(open_[1])}; put both at the body's indentation")
            regions.append(Region(open_[2], open_[0], k, open_[1]))
            open_ = None
    if open_ is not None:
        raise MarkerError(f"{filename}:{open_[0]}: region {open_[2]!r} has no END SOLUTION")
    names = [r.name for r in regions]
    dup = sorted({n for n in names if names.count(n) > 1})
    if dup:
        raise MarkerError(f"{filename}: region names must be unique, repeated: {dup}")
    return regions


def absolute_imports(source: str, package: str) -> str:
    """``source`` with every relative import made absolute, as seen from the package ``package``
    (``"pbanim.particles"`` for ``pbanim/particles/system.py``); nothing else changes.

    >>> absolute_imports("from ..errors import InvalidInput\\nfrom .springs import f\\n", "pbanim.particles")
    'from pbanim.errors import InvalidInput\\nfrom pbanim.particles.springs import f\\n'
    """
    lines = source.splitlines(keepends=True)
    parts = package.split(".")
    for node in ast.walk(ast.parse(source)):
        if isinstance(node, ast.ImportFrom) and node.level:
            if node.level > len(parts):
                raise InvalidInput(f"line {node.lineno}: relative import goes above the package {package!r}")
            base = parts[:len(parts) - node.level + 1]
            target = ".".join(base + ([node.module] if node.module else []))
            k = node.lineno - 1
            new, n = re.subn(r"from\s+\.+\s*[\w.]*\s+import", f"from {target} import", lines[k], count=1)
            if n != 1:
                raise InvalidInput(f"line {node.lineno}: cannot rewrite the relative import {lines[k].strip()!r}")
            lines[k] = new
    return "".join(lines)


def starter_source(source: str, package: str, filename: str = "<source>") -> str:
    """The student's starter: each marked region replaced by ``raise NotImplementedError``, imports absolute.

    >>> src = "def f(x):\\n    '''Twice x.'''\\n    # BEGIN SOLUTION f\\n    return 2 * x\\n    # END SOLUTION\\n"
    >>> print(starter_source(src, "pbanim"), end="")
    def f(x):
        '''Twice x.'''
        # BEGIN STUDENT CODE f
        raise NotImplementedError("f: write this part (see the docstring and the README)")
        # END STUDENT CODE
    """
    regions = find_regions(source, filename)
    if not regions:
        raise MarkerError(f"{filename}: no '# BEGIN SOLUTION name' markers; nothing for a student to write")
    lines = absolute_imports(source, package).splitlines(keepends=True)
    for r in reversed(regions):
        stub = [f"{r.indent}{STUDENT_BEGIN} {r.name}\n",
                f'{r.indent}raise NotImplementedError("{r.name}: write this part (see the docstring and the README)")\n',
                f"{r.indent}{STUDENT_END}\n"]
        lines[r.begin - 1: r.end] = stub
    out = "".join(lines)
    try:
        ast.parse(out)
    except SyntaxError as exc:  # a marker placed where a bare raise is not a statement
        raise MarkerError(f"{filename}: the starter does not parse at line {exc.lineno} ({exc.msg}); "
                          "place markers around whole statements of a function body") from None
    return out


def solution_source(source: str, package: str, filename: str = "<source>") -> str:
    """The reference as a stand-alone file (imports absolute, markers kept): what scores 100%."""
    find_regions(source, filename)
    return absolute_imports(source, package)


def region_owners(source: str, filename: str = "<source>") -> dict:
    """{qualified name: its ``ast.FunctionDef``} of the innermost functions holding a marked region.

    >>> src = "class A:\\n    def f(self):\\n        # BEGIN SOLUTION A.f\\n        return 1\\n        # END SOLUTION\\n"
    >>> list(region_owners(src))
    ['A.f']
    """
    regions = find_regions(source, filename)
    spans: dict = {}

    def walk(node, prefix: str) -> None:
        for child in ast.iter_child_nodes(node):
            if isinstance(child, (ast.FunctionDef, ast.ClassDef)):
                qual = prefix + child.name
                if isinstance(child, ast.FunctionDef):
                    spans[qual] = child
                walk(child, qual + ".")
    walk(ast.parse(source), "")
    owners = {}
    for r in regions:
        best = [q for q, n in spans.items() if n.lineno < r.begin <= n.end_lineno]   # END may follow the last line
        if best:
            q = max(best, key=lambda q: spans[q].lineno)
            owners[q] = spans[q]
    return dict(sorted(owners.items()))
