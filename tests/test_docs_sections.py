"""Every numbered reference to a section of a page in docs/ names a section that exists.

A reference is ``docs/PAGE.md section N[.M]``, ``docs/PAGE.md N.M`` (with or without a comma,
the path in backticks or not) or, inside a page of docs/, ``section N[.M]`` (that page's own).
When a quoted title follows (``section 6, "Long runs"``, ``'Does the run level keep its
promise?'``, ``"A" and "B"``), the title must open a paragraph in bold or italics (``**Long
runs ...``), or stand in a heading, inside that section: the section runs from its heading to
the next heading of the same or a higher level. The references are read from README.md, every
page under docs/ and every module of src/leakdiag (strings, docstrings and comments, with
adjacent string literals joined as Python joins them, so a title split over two source lines
is read whole). Why: a docs audit of 2026-11-29 found run-level advice printed by ``detect``,
``fit`` and ``monitor`` citing "docs/detect.md section 2, 'Long runs'" after the text had moved
to section 6, and README citing 8.6 for a study in 8.7.
"""

import re
from functools import cache
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]

_NUM = r"(?P<num>\d+(?:\.\d+)*)(?![.\d]*\d)"
_TITLES = (r"(?:,? (?:\"(?P<t1>[^\"]+)\"|'(?P<t2>[^']+)')"
           r"(?: and (?:\"(?P<t3>[^\"]+)\"|'(?P<t4>[^']+)'))?)?")
#: ``docs/PAGE.md[,] section N`` or ``docs/PAGE.md[,] N.M`` (a bare ``N`` there is a count:
#: "docs/operations.md, 18 windows")
PAGED = re.compile(r"`?docs/(?P<page>[\w/]+\.md)`?(?P<sep>,? section |,? )" + _NUM + _TITLES)
#: ``section N`` inside a page of docs/: that page's own section (the thesis's are "Sec. N")
BARE = re.compile(r"\bsection " + _NUM + _TITLES)
HEADING = re.compile(r"^(#{1,6}) (?:(\d+(?:\.\d+)*)\.? )?", re.M)

#: References in files another change owns, stale when this test was written (2026-11-29):
#: strict, so the test fails once they are fixed and the entry must go.
KNOWN_STALE: set = set()  # (file, reference) pairs known to be stale, marked xfail


def _python_text(text: str) -> str:
    """Source text with adjacent string literals joined and comment lines run together."""
    text = re.sub(r"""(["'])\s*\n\s*(?:\+\s*)?[frbFRB]{0,2}(["'])""", "", text)
    text = re.sub(r"\n\s*#:?", " ", text)
    return re.sub(r"\s+", " ", text)


def _references() -> list[tuple[str, str, re.Match]]:
    """``(file, page referred to, match)`` for every reference in README, docs/ and src/."""
    files = [(f, _python_text(f.read_text(encoding="utf-8")), False)
             for f in sorted((ROOT / "src" / "leakdiag").rglob("*.py"))]
    files += [(f, re.sub(r"\s+", " ", f.read_text(encoding="utf-8")), f.parent != ROOT)
              for f in [ROOT / "README.md", *sorted((ROOT / "docs").rglob("*.md"))]]
    refs = []
    for f, text, in_docs in files:
        rel = f.relative_to(ROOT).as_posix()
        spans = []
        for m in PAGED.finditer(text):
            if "section" in m.group("sep") or "." in m.group("num"):
                spans.append(m.span())
                refs.append((rel, f"docs/{m.group('page')}", m))
        if in_docs:
            refs += [(rel, rel, m) for m in BARE.finditer(text)
                     if not any(a <= m.start() < b for a, b in spans)]
    return refs


@cache
def sections(page: str) -> dict[str, str]:
    """Numbered section -> its text (heading to the next heading of the same or higher level);
    headings inside code blocks do not count."""
    text = (ROOT / page).read_text(encoding="utf-8")
    blanked = re.sub(r"```.*?```", lambda m: re.sub(r"[^\n]", " ", m.group(0)), text,
                     flags=re.S)
    heads = [(m.start(), len(m.group(1)), m.group(2)) for m in HEADING.finditer(blanked)]
    out = {}
    for i, (pos, level, num) in enumerate(heads):
        if num is not None:
            end = next((p for p, lev, _ in heads[i + 1:] if lev <= level), len(text))
            out[num] = text[pos:end]
    return out


def title_in(body: str, title: str) -> bool:
    """Whether ``title`` opens a bold or italic paragraph, or stands in a heading, of ``body``."""
    words = r"\s+".join(map(re.escape, title.split()))
    return re.search(r"(?:\*|^#+ [^\n]*?)" + words, body, re.M) is not None


REFS = _references()


def _case(rel: str, page: str, m: re.Match):
    marks = ([pytest.mark.xfail(strict=True, reason="stale in a file another change owns")]
             if (rel, m.group(0)) in KNOWN_STALE else [])
    return pytest.param(page, m.group("num"),
                        [t for t in m.group("t1", "t2", "t3", "t4") if t],
                        id=f"{rel}:{m.group(0)[:70]}", marks=marks)


def test_the_references_are_found():
    found = {(rel, m.group(0)) for rel, _, m in REFS}
    assert ("src/leakdiag/cli/_words.py",
            "docs/detect.md section 6, 'Does the run level keep its promise?'") in found
    assert ("docs/detect.md", 'section 2, "Blind spans"') in found
    assert ("README.md", "docs/detect.md 8.7") in found
    assert KNOWN_STALE <= found
    assert len(REFS) > 80


@pytest.mark.parametrize("page, num, titles", [_case(*r) for r in REFS])
def test_a_referenced_section_exists_and_holds_its_title(page, num, titles):
    secs = sections(page)
    assert num in secs, f"{page} has no section {num}: it has {', '.join(secs)}"
    for title in titles:
        assert title_in(secs[num], title), f"{title!r} is not in {page} section {num}"


@pytest.mark.parametrize("title, num, inside", [
    ("Long runs", "6", True), ("Long runs", "2", False),
    ("Does the run level keep its promise?", "6", True),
    ("Blind spans", "2", True), ("Onset", "8.4", True), ("Default methods", "2", False),
])
def test_the_title_check_tells_sections_apart(title, num, inside):
    assert title_in(sections("docs/detect.md")[num], title) is inside


def test_sections_end_at_the_next_heading_of_their_level():
    secs = sections("docs/detect.md")
    assert secs["8"].startswith("## 8. ") and "### 8.7 " in secs["8"]
    assert secs["8.6"].startswith("### 8.6 ") and "### 8.7" not in secs["8.6"]
    assert "## 7." not in secs["6"] and "**Which runs are long" in secs["6"]
