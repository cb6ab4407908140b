"""Every dotted ``leakdiag.`` name that README.md and the pages of docs/ put in code quotes
imports or resolves as an attribute.

Why: a docs audit of 2026-11-29 found docs/detect.md naming ``leakdiag.stream.BlindSpans``,
which the package's facade did not export (the class lived in ``leakdiag.stream.blind`` only).
"""

import importlib
import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
PAGES = [ROOT / "README.md", *sorted((ROOT / "docs").rglob("*.md"))]
NAME = re.compile(r"`(leakdiag(?:\.[A-Za-z_]\w*)+)")


def resolve(dotted: str):
    """The object ``dotted`` names: the longest importable module prefix, then attributes
    (AttributeError if one is missing)."""
    parts = dotted.split(".")
    for i in range(len(parts), 0, -1):
        try:
            obj = importlib.import_module(".".join(parts[:i]))
        except ImportError:
            continue
        break
    for part in parts[i:]:
        obj = getattr(obj, part)
    return obj


NAMES = sorted({(m.group(1), p.relative_to(ROOT).as_posix())
                for p in PAGES for m in NAME.finditer(p.read_text(encoding="utf-8"))})


def test_names_are_found():
    assert ("leakdiag.stream.BlindSpans", "docs/detect.md") in NAMES
    assert len(NAMES) > 50


@pytest.mark.parametrize("dotted, page", NAMES, ids=[f"{p}:{n}" for n, p in NAMES])
def test_a_named_object_exists(dotted, page):
    try:
        resolve(dotted)
    except AttributeError as exc:
        pytest.fail(f"{page} names {dotted}, which does not resolve: {exc}")


def test_blind_spans_is_exported_by_the_stream_facade():
    import leakdiag.stream
    from leakdiag.stream.blind import BlindSpans

    assert leakdiag.stream.BlindSpans is BlindSpans
    assert "BlindSpans" in leakdiag.stream.__all__ and "BlindSpans" in dir(leakdiag.stream)


def test_detect_md_lists_every_fingerprint_part():
    """docs/detect.md names what the v5 resume key hashes; it lacked ``_holds.py`` (docs audit
    2026-11-29)."""
    from leakdiag.bench.v5_common import FINGERPRINT_PARTS

    text = re.sub(r"\s+", " ", (ROOT / "docs" / "detect.md").read_text(encoding="utf-8"))
    listed = re.search(r"the source of every package that can change a result \((.*?): "
                       r"`FINGERPRINT_PARTS` in `bench/v5_common.py`", text).group(1)
    assert sorted(re.findall(r"`([\w.]+)`", listed)) == sorted(FINGERPRINT_PARTS)
