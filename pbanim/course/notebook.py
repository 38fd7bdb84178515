"""Chapters as notebooks: jupytext's percent format read into a Jupyter notebook (nbformat 4).

A chapter file ``chapters/chNN_topic.py`` is an ordinary module *and* a notebook in the percent format
that Jupyter (with jupytext), VS Code and Spyder open as cells::

    # %% [markdown]
    # ## Figure: energy per integrator          ← a markdown cell: each line a comment "# text"
    # Explicit Euler gains (1 + h²ω²) per step.

    # %%
    @figure("ch01", "spring_energy", "...")    ← a code cell: everything up to the next "# %%"
    def spring_energy(ctx):
        ...

Rules of the format used here (a subset of jupytext's): a line ``# %%`` (optionally followed by a title
and ``[markdown]``) starts a cell; lines before the first marker form a code cell of their own; in a
markdown cell the leading ``# `` (or a lone ``#``) of each line is removed; blank lines at the ends of a
cell are dropped. :func:`percent_cells` parses, :func:`notebook_json` builds the notebook dict (cell ids
are ``cell-0``, ``cell-1``, … so the same file gives the same bytes), :func:`write_notebook` writes the
``.ipynb`` — through nbformat (validated) when it is installed (``pip install pbanim[notebook]``),
else as the same JSON written directly.

A chapter with live demos (:mod:`pbanim.course.widgets`: a slider for the step size, the gains, ε, ν…)
gets, after the figure each demo belongs to, a markdown cell and a code cell ``live("<demo>")``.

Limiting cases: a file without markers is one code cell; an empty cell is dropped.
Reference: the jupytext documentation, "The percent format"; the nbformat 4.5 JSON schema.
"""

from __future__ import annotations

import json
import re
from dataclasses import dataclass
from pathlib import Path

from ..errors import InvalidInput

__all__ = ["Cell", "percent_cells", "notebook_json", "write_notebook", "is_percent_script"]

_MARKER = re.compile(r"^# %%(?P<rest>.*)$")


@dataclass(frozen=True)
class Cell:
    kind: str      # "code" or "markdown"
    source: str


def _trim(lines: list[str]) -> list[str]:
    while lines and not lines[0].strip():
        lines = lines[1:]
    while lines and not lines[-1].strip():
        lines = lines[:-1]
    return lines


def percent_cells(text: str) -> list[Cell]:
    """The cells of a percent-format script, in order (empty cells dropped).

    >>> percent_cells("import x\\n# %% [markdown]\\n# # Title\\n#\\n# text\\n# %%\\ny = 1\\n")
    [Cell(kind='code', source='import x'), Cell(kind='markdown', source='# Title\\n\\ntext'), Cell(kind='code', source='y = 1')]
    """
    cells: list[Cell] = []
    kind, buf = "code", []

    def flush():
        lines = _trim(buf)
        if not lines:
            return
        if kind == "markdown":
            out = []
            for ln in lines:
                if ln.startswith("# "):
                    out.append(ln[2:])
                elif ln.strip() == "#":
                    out.append("")
                else:
                    raise InvalidInput(f"markdown cell line must be a comment '# …', got {ln!r}")
            lines = out
        cells.append(Cell(kind, "\n".join(lines)))

    for line in text.splitlines():
        m = _MARKER.match(line)
        if m:
            flush()
            kind, buf = ("markdown" if "[markdown]" in m["rest"] or "[md]" in m["rest"] else "code"), []
        else:
            buf.append(line)
    flush()
    return cells


def is_percent_script(text: str) -> bool:
    """True when the text has at least one ``# %%`` code cell and one markdown cell."""
    kinds = {c.kind for c in percent_cells(text)}
    return {"code", "markdown"} <= kinds and bool(re.search(r"^# %%", text, flags=re.M))


def notebook_json(cells: list[Cell], name: str = "") -> dict:
    """The nbformat-4.5 notebook (a dict) of ``cells``; deterministic (cell ids by position)."""
    def src(s: str) -> list[str]:
        lines = s.split("\n")
        return [ln + "\n" for ln in lines[:-1]] + [lines[-1]]

    out = []
    for k, c in enumerate(cells):
        cell = {"cell_type": c.kind, "id": f"cell-{k}", "metadata": {}, "source": src(c.source)}
        if c.kind == "code":
            cell.update(execution_count=None, outputs=[])
        out.append(cell)
    meta = {"kernelspec": {"display_name": "Python 3", "language": "python", "name": "python3"},
            "language_info": {"name": "python"},
            "jupytext": {"formats": "ipynb,py:percent"}}
    if name:
        meta["pbanim"] = {"source": name}
    return {"cells": out, "metadata": meta, "nbformat": 4, "nbformat_minor": 5}


def write_notebook(source: str | Path, out_dir: str | Path) -> Path:
    """Write ``<out_dir>/<stem>.ipynb`` from the percent-format script ``source``; return its path."""
    src = Path(source)
    if not src.is_file():
        raise InvalidInput(f"source must be a chapter file, got {str(source)!r} (not found)")
    text = src.read_text(encoding="utf-8")
    cells = percent_cells(text)
    if not cells:
        raise InvalidInput(f"{src.name} has no cells (an empty file)")
    from .widgets import live_cells

    cells = live_cells(src.stem, cells)          # a live demo's controls after its figure (pbanim.course.widgets)
    nb = notebook_json(cells, src.name)
    out = Path(out_dir)
    if out.exists() and not out.is_dir():
        raise InvalidInput(f"out_dir must be a folder, got the file {str(out_dir)!r}")
    out.mkdir(parents=True, exist_ok=True)
    path = out / f"{src.stem}.ipynb"
    try:
        import nbformat
    except ImportError:
        nbformat = None
    if nbformat is not None:
        node = nbformat.from_dict(nb)
        nbformat.validate(node)
        path.write_text(nbformat.writes(node) + "\n", encoding="utf-8")
    else:
        path.write_text(json.dumps(nb, indent=1, ensure_ascii=False) + "\n", encoding="utf-8")
    return path
