"""docs/io.md's "Public API" table lists each name's parameters as the code has them.

Why: a docs audit of 2026-11-29 found the table without ``read_recording``'s ``channels=``,
``ColumnMap``'s ``machine`` and ``resample_linear``'s ``max_gap_intervals``. A ``**kwargs`` in
the code may be spelled out in the table (``build_column_map``'s file options).
"""

import inspect
import re
from pathlib import Path

import pytest

import leakdiag.io

PAGE = Path(__file__).resolve().parents[1] / "docs" / "io.md"
_ROW = re.compile(r"^\| `(\w+)` \| `\((.*?)\)(?: ->[^`]*)?` \|", re.M)


def documented_parameters(signature: str) -> list[str]:
    """Parameter names of a table cell's ``(a, b=1, *, c=(1, 2))`` (``*`` dropped).

    >>> documented_parameters("t, channels, sample_rate, source='<input>', x=(1, 2)")
    ['t', 'channels', 'sample_rate', 'source', 'x']
    """
    parts, depth, cur = [], 0, ""
    for ch in signature:
        depth += (ch in "([{") - (ch in ")]}")
        if ch == "," and depth == 0:
            parts.append(cur)
            cur = ""
        else:
            cur += ch
    parts.append(cur)
    return [p.split("=")[0].strip() for p in parts if p.strip() not in ("", "*")]


def _rows() -> list[tuple[str, str]]:
    text = PAGE.read_text(encoding="utf-8").split("## Public API", 1)[1].split("\n## ", 1)[0]
    return _ROW.findall(text)


ROWS = _rows()


def test_the_table_is_read():
    names = [n for n, _ in ROWS]
    assert {"read_recording", "ColumnMap", "resample_linear", "to_si"} <= set(names)
    assert documented_parameters("t, x=(1, 2), *, y=None") == ["t", "x", "y"]


@pytest.mark.parametrize("name, signature", ROWS, ids=[n for n, _ in ROWS])
def test_a_row_lists_the_parameters_of_the_code(name, signature):
    params = inspect.signature(getattr(leakdiag.io, name)).parameters.values()
    named = [p.name for p in params if p.kind not in (p.VAR_KEYWORD, p.VAR_POSITIONAL)]
    doc = documented_parameters(signature)
    if any(p.kind is p.VAR_KEYWORD for p in params):  # its keywords may be spelled out
        doc = doc[:len(named)]
    assert doc == named, f"docs/io.md lists {name}({', '.join(doc)}); the code has {named}"
