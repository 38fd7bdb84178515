"""Tables of a comparison: markdown for people, JSON for programs (``pbanim compare --markdown/--json``).

Per scene, one markdown table with a row per (engine, step h):

    | engine | h (s) | error (the scene's measure and unit) | other metrics | wall (s) | µs/step | ms/sim s | status |

(ms/sim s: wall milliseconds per simulated second, = µs per step / h / 1000; a row at a peer's own step
outside the sweep is marked "(own)"), one summary table over all scenes, one column per engine, each cell
"error at the finest step · observed order p · µs per step · ms per simulated second" (or the row's
status: *not installed*, *unsupported*, …), and one table at the peers' own steps (PyBullet's 1/240 s,
MuJoCo's 2 ms): per scene and step, each engine's "error · ms per simulated second" — what each engine
costs for the same motion at the step its users take. The JSON holds the same rows with every number (NaN
written as ``null``), the date, the mode and the versions.

Limiting cases: a comparison with no rows gives the header and an empty summary; a row that did not run
shows its status and reason instead of numbers.

References: A. Boeing, T. Bräunl, GRAPHITE 2007 (their tables: error and cost per engine and scene).
"""

from __future__ import annotations

import json
import math
from pathlib import Path

from ..contracts import Obj, Opt, PathLike, contract

_CMP = Obj("pbanim.compare.harness:Comparison")

__all__ = ["markdown", "as_json", "summary_markdown", "own_steps_markdown", "write"]


def _num(x: float, digits: int = 3) -> str:
    if x is None or (isinstance(x, float) and not math.isfinite(x)):
        return "—"
    return f"{x:.{digits}g}"


def _esc(text: str) -> str:
    return str(text).replace("|", "\\|")


def _ms(s_per_sim_s: float) -> str:
    """Wall ms per simulated second."""
    return _num(1e3 * s_per_sim_s, 2) if s_per_sim_s is not None and math.isfinite(s_per_sim_s) else "—"


@contract(cmp=_CMP)
def summary_markdown(cmp) -> str:
    """The summary table: one line per scene, one column per engine."""
    engines = list(dict.fromkeys(r.engine for r in cmp.rows))
    lines = ["| scene | error measure | " + " | ".join(engines) + " |",
             "| --- | --- | " + " | ".join("---" for _ in engines) + " |"]
    by = {(s["scene"], s["engine"]): s for s in cmp.summary()}
    for name, sc in cmp.scenes.items():
        cells = []
        for e in engines:
            s = by.get((name, e))
            if s is None:
                cells.append("—")
            elif s["status"] != "ok":
                cells.append(_esc(s["status"]))
            else:
                order = f" · p {s['order']:.2g}" if s["order"] is not None else ""
                cells.append(f"{_num(s['error'], 2)} (h {s['h']:g}{order} · {_num(s['us_per_step'], 2)} µs/step · "
                             f"{_ms(s['s_per_sim_s'])} ms/sim s)")
        lines.append(f"| {name} | {_esc(sc.error_name)} | " + " | ".join(cells) + " |")
    return "\n".join(lines)


@contract(cmp=_CMP)
def own_steps_markdown(cmp) -> str:
    """At the peers' own steps: one line per (scene, step), one column per engine, "error · ms/sim s"
    (empty string when no row ran at those steps)."""
    from .harness import OWN_STEPS

    engines = list(dict.fromkeys(r.engine for r in cmp.rows))
    by = {(s["scene"], s["engine"]): s["own"] for s in cmp.summary()}
    lines = []
    for name in cmp.scenes:
        for peer, h in OWN_STEPS.items():
            cells = []
            for e in engines:
                o = by.get((name, e), {}).get(peer)
                if o is None:
                    cells.append("—")
                elif o["status"] != "ok":
                    cells.append(_esc(o["status"]))
                else:
                    cells.append(f"{_num(o['error'], 2)} · {_ms(o['s_per_sim_s'])} ms/sim s")
            if any(c != "—" for c in cells):
                lines.append(f"| {name} | {h:.4g} ({peer}'s) | " + " | ".join(cells) + " |")
    if not lines:
        return ""
    return "\n".join(["| scene | h (s) | " + " | ".join(engines) + " |",
                      "| --- | --- | " + " | ".join("---" for _ in engines) + " |"] + lines)


@contract(cmp=_CMP)
def markdown(cmp) -> str:
    """The whole report: header (date, mode, versions), the summary, one table per scene."""
    vers = ", ".join(f"{k} {v}" for k, v in cmp.versions.items())
    out = [f"# pbanim compare — {cmp.date}", "",
           f"Mode: {'quick' if cmp.quick else 'full'}. Versions: {vers}.", "",
           "## Summary (finest step of each sweep)", "", summary_markdown(cmp), ""]
    own = own_steps_markdown(cmp)
    if own:
        out += ["## At the peers' own steps (error · wall ms per simulated second)", "", own, ""]
    for name, sc in cmp.scenes.items():
        out += [f"## {name} — {sc.spec.title}", "", f"Exact answer: {sc.spec.notes}.", "",
                f"| engine | h (s) | {_esc(sc.error_name)} | other metrics | wall (s) | µs/step | ms/sim s | status |",
                "| --- | --- | --- | --- | --- | --- | --- | --- |"]
        for r in cmp.rows_of(name):
            metrics = ", ".join(f"{k} {_num(v)}" for k, v in r.metrics.items()) or "—"
            status = r.status if r.status == "ok" else f"{r.status}: {r.reason}"
            h = f"{r.h:.4g}" + ("" if r.sweep else " (own)")
            out.append(f"| {r.engine} | {h} | {_num(r.error)} | {_esc(metrics)} | {_num(r.wall)} | "
                       f"{_num(r.us_per_step)} | {_ms(r.s_per_sim_s)} | {_esc(status)} |")
        settings = dict.fromkeys(f"{r.engine}: {r.settings}" for r in cmp.rows_of(name) if r.settings)
        if settings:
            out += [""] + [f"- {_esc(s)}" for s in settings]
        out.append("")
    return "\n".join(out)


@contract(cmp=_CMP)
def as_json(cmp) -> dict:
    """The comparison as plain JSON types (NaN → null)."""
    def clean(v):
        if isinstance(v, float):
            return v if math.isfinite(v) else None
        if isinstance(v, dict):
            return {k: clean(x) for k, x in v.items()}
        if isinstance(v, (list, tuple)):
            return [clean(x) for x in v]
        return v

    return clean({"date": cmp.date, "quick": cmp.quick, "versions": cmp.versions,
                  "scenes": {n: {"title": sc.spec.title, "error_name": sc.error_name, "exact": sc.spec.notes,
                                 "params": {k: v for k, v in sc.spec.params.items() if isinstance(v, (int, float, str))},
                                 "rows": [r.to_json() for r in cmp.rows_of(n)]}
                             for n, sc in cmp.scenes.items()},
                  "summary": cmp.summary()})


@contract(cmp=_CMP, markdown_path=Opt(PathLike()), json_path=Opt(PathLike()))
def write(cmp, markdown_path=None, json_path=None) -> list[Path]:
    """Write the markdown and/or JSON report; returns the paths written."""
    out = []
    if markdown_path:
        p = Path(markdown_path)
        p.write_text(markdown(cmp) + "\n", encoding="utf-8")
        out.append(p)
    if json_path:
        p = Path(json_path)
        p.write_text(json.dumps(as_json(cmp), indent=1, ensure_ascii=False) + "\n", encoding="utf-8")
        out.append(p)
    return out
