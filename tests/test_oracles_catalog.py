"""Every oracle id cited in the repository has an entry in ORACLES.md, and nothing points outside the repo."""

import pathlib
import re

ROOT = pathlib.Path(__file__).resolve().parents[1]
SOURCES = [*sorted((ROOT / "pbanim").rglob("*.py")), *sorted((ROOT / "tests").rglob("*.py")),
           *sorted((ROOT / "chapters").rglob("*.py")), ROOT / "README.md", ROOT / "ARCHITECTURE.md"]
CITATION = re.compile(r"ORACLES\s+((?:[A-Z]\d+(?:\s*[–-]\s*[A-Z]?\d+)?)(?:\s*[,/]\s*[A-Z]\d+(?:\s*[–-]\s*[A-Z]?\d+)?)*)")


def _expand(group: str) -> set[str]:
    ids = set()
    for part in re.split(r"\s*[,/]\s*", group):
        m = re.fullmatch(r"([A-Z])(\d+)(?:\s*[–-]\s*([A-Z])?(\d+))?", part.strip())
        if not m:
            continue
        letter, lo, hi = m.group(1), int(m.group(2)), m.group(4)
        ids |= {f"{letter}{k}" for k in range(lo, (int(hi) if hi else lo) + 1)}
    return ids


def cited_ids() -> dict[str, list[str]]:
    where: dict[str, list[str]] = {}
    for path in SOURCES:
        for m in CITATION.finditer(path.read_text(encoding="utf-8")):
            for oid in _expand(m.group(1)):
                where.setdefault(oid, []).append(str(path.relative_to(ROOT)))
    return where


def test_expand_reads_ranges_and_lists():
    assert _expand("D4–D9") == {f"D{k}" for k in range(4, 10)}
    assert _expand("A1, A2") == {"A1", "A2"}
    assert _expand("G1/I4") == {"G1", "I4"}


def test_every_cited_oracle_has_an_entry():
    catalog = (ROOT / "ORACLES.md").read_text(encoding="utf-8")
    entries = set(re.findall(r"^\*\*([A-Z]\d+) ", catalog, flags=re.M))
    cited = cited_ids()
    assert len(cited) >= 30
    missing = {oid: files[:3] for oid, files in cited.items() if oid not in entries}
    assert not missing, f"cited but not in ORACLES.md: {missing}"


def test_nothing_points_outside_the_repository():
    forbidden = ["../" + "shared", "/" + "work" + "/", "/" + "tmp" + "/", "/" + "root" + "/"]
    offenders = []
    for path in [*SOURCES, ROOT / "ORACLES.md", ROOT / "pyproject.toml"]:
        text = path.read_text(encoding="utf-8")
        offenders += [f"{path.relative_to(ROOT)}: {s!r}" for s in forbidden if s in text]
    assert not offenders, offenders
