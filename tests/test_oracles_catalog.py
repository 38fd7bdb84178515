"""Every oracle id cited in the repository has an entry in ORACLES.md, and nothing points outside the repo."""

import pathlib
import re

ROOT = pathlib.Path(__file__).resolve().parents[1]
SOURCES = [*sorted((ROOT / "pbanim").rglob("*.py")), *sorted((ROOT / "tests").rglob("*.py")),
           *sorted((ROOT / "chapters").rglob("*.py")), ROOT / "README.md", ROOT / "ARCHITECTURE.md"]
_ID = r"[A-Z]\d+(?:\s*[–-]\s*[A-Z]?\d+)?"                 # one id or a range: B1, D4–D9, I1-I5
_SEP = r"\s*(?:[,/+]|\band\b)\s*"                          # lists: "A1, A2", "G1/B7", "A8 + C1", "D6 and D7"
CITATION = re.compile(rf"ORACLES\s+({_ID}(?:{_SEP}{_ID})*)")
# README's chapter table cites ids in its "key tests (ORACLES id)" column as "(A7)", "(D1–D3)", "(... , G2;"
README_TABLE_ID = re.compile(rf"[(,]\s*({_ID})\s*[);]")
ENTRY = re.compile(r"^(?:#{2,4}\s+|\*\*)([A-Z]\d+)\b", flags=re.M)   # "### B1 — ..." (or "**B1 ...**")


def _expand(group: str) -> set[str]:
    ids = set()
    for part in re.split(_SEP, group):
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
    readme = (ROOT / "README.md").read_text(encoding="utf-8")
    for m in README_TABLE_ID.finditer(readme):
        for oid in _expand(m.group(1)):
            where.setdefault(oid, []).append("README.md")
    return where


def test_expand_reads_ranges_and_lists():
    assert _expand("D4–D9") == {f"D{k}" for k in range(4, 10)}
    assert _expand("A1, A2") == {"A1", "A2"}
    assert _expand("G1/I4") == {"G1", "I4"}
    assert _expand("A8 + C1") == {"A8", "C1"}
    assert _expand("I1-I5") == {f"I{k}" for k in range(1, 6)}
    assert CITATION.search("see ORACLES D1–D3, D10, G3 here").group(1) == "D1–D3, D10, G3"


def test_every_cited_oracle_has_an_entry():
    catalog = (ROOT / "ORACLES.md").read_text(encoding="utf-8")
    entries = set(ENTRY.findall(catalog))
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
