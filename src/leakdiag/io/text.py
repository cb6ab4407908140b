"""Delimited text files (CSV, TSV, ...): read any, write CSV."""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from leakdiag.io.recording import Recording, RecordingError
from leakdiag.io.table import RawTable

__all__ = ["SEPARATOR_CANDIDATES", "detect_separator", "read_text", "write_csv"]

#: Separators tried by :func:`detect_separator`, in order of preference on a tie.
SEPARATOR_CANDIDATES = ("\t", ",", ";", "|")

_SNIFF_LINES = 5
_SNIFF_BYTES = 1 << 16


def detect_separator(lines: list[str]) -> str:
    """Guess the field separator from the first lines of a text file.

    Parameters
    ----------
    lines : list of str
        The header line and a few data lines.

    Returns
    -------
    str
        The candidate of :data:`SEPARATOR_CANDIDATES` that occurs most often in the header
        and at least once in every given line, or ``r"\\s+"`` (runs of blanks) if none does.

    Examples
    --------
    >>> detect_separator(["time\\tp1\\tp2", "0\\t1\\t2"])
    '\\t'
    >>> detect_separator(["time,p1", "0,1e5"])
    ','
    >>> detect_separator(["time p1", "0 1"])
    '\\\\s+'
    """
    best, best_count = None, 0
    for sep in SEPARATOR_CANDIDATES:
        count = lines[0].count(sep) if lines else 0
        if count > best_count and all(sep in line for line in lines[1:]):
            best, best_count = sep, count
    return best if best is not None else r"\s+"


def _sniff(path: Path, source: str) -> tuple[list[str], str]:
    """First non-blank lines and the encoding: UTF-8 (BOM allowed), else Latin-1."""
    try:
        with open(path, "rb") as fh:
            head = fh.read(_SNIFF_BYTES)
    except OSError as exc:
        raise RecordingError(f"{source}: cannot open: {exc.strerror}") from None
    if b"\x00" in head:
        raise RecordingError(f"{source}: unreadable as text (binary data); is it another format?")
    cut = head.rfind(b"\n")
    complete = head if cut < 0 or len(head) < _SNIFF_BYTES else head[:cut + 1]
    try:
        text, encoding = complete.decode("utf-8-sig"), "utf-8-sig"
    except UnicodeDecodeError:  # e.g. Windows DAQ exports with a degree sign in cp1252
        text, encoding = complete.decode("latin-1"), "latin-1"
    lines = [line.rstrip("\r") for line in text.split("\n") if line.strip()]
    return lines[:_SNIFF_LINES], encoding


def read_text(path: str | os.PathLike, separator: str | None = None) -> RawTable:
    """Read a delimited text file with one header row into a :class:`RawTable`.

    Parameters
    ----------
    path : str or path-like
        The file.
    separator : str, optional
        Field separator; None = :func:`detect_separator`.

    Returns
    -------
    RawTable
        One column per header name (names stripped of blanks): float64 where every value is a
        number or empty (NaN), object (text) otherwise. Trailing separators at the end of rows
        (empty trailing fields) are ignored.

    Raises
    ------
    RecordingError
        Empty file, header without data rows, unparsable text (rows with more fields than the
        header), or a binary file. Text that is not UTF-8 is read as Latin-1.

    Examples
    --------
    >>> import tempfile, pathlib
    >>> p = pathlib.Path(tempfile.mkdtemp()) / "a.csv"
    >>> _ = p.write_text("time,p1\\n0,1\\n0.5,2\\n")
    >>> read_text(p).columns["p1"]
    array([1., 2.])
    """
    import pandas as pd

    path = Path(path)
    source = str(path)
    lines, encoding = _sniff(path, source)
    if not lines:
        raise RecordingError(f"{source}: file is empty")
    sep = separator if separator is not None else detect_separator(lines)
    try:
        df = pd.read_csv(path, sep=sep, index_col=False, skipinitialspace=True,
                         encoding=encoding, engine="c" if len(sep) == 1 else "python")
    except pd.errors.EmptyDataError:
        raise RecordingError(f"{source}: file is empty") from None
    except (pd.errors.ParserError, UnicodeDecodeError, ValueError) as exc:
        msg = str(exc).strip().splitlines()[-1] if str(exc).strip() else type(exc).__name__
        raise RecordingError(f"{source}: cannot parse as delimited text "
                             f"(separator {sep!r}): {msg}") from None
    if len(df) == 0:
        raise RecordingError(f"{source}: has a header ({', '.join(map(str, df.columns))}) "
                             f"but no data rows")
    columns: dict[str, np.ndarray] = {}
    for col in df.columns:
        s = df[col]
        name = str(col).strip()
        if pd.api.types.is_numeric_dtype(s) and not pd.api.types.is_bool_dtype(s):
            columns[name] = s.to_numpy(dtype=np.float64, na_value=np.nan)
        else:
            columns[name] = s.to_numpy(dtype=object, na_value=None)
    return RawTable(columns, source)


def write_csv(rec: Recording, path: str | os.PathLike) -> None:
    """Write a recording as CSV: a ``time`` column (s) and one column per channel.

    Parameters
    ----------
    rec : Recording
        The recording.
    path : str or path-like
        Output file.

    Raises
    ------
    RecordingError
        If a channel is named ``time``.

    Notes
    -----
    Values are written (by Arrow's CSV writer) with the shortest text that reads back to the
    same float64, so channels round-trip exactly (except that ``-0.0`` in a column of whole
    numbers reads back as ``0.0``). CSV holds no units or metadata: channels are assumed to be
    in SI units when read back, and the sample rate is re-derived from the time column. Use
    Parquet or HDF5 to keep units and metadata.

    Examples
    --------
    >>> import tempfile, pathlib
    >>> p = pathlib.Path(tempfile.mkdtemp()) / "a.csv"
    >>> write_csv(Recording({"p1": np.array([1.0, 2.0])}, sample_rate=2.0), p)
    >>> p.read_text().splitlines()
    ['time,p1', '0,1', '0.5,2']
    """
    import pyarrow as pa
    import pyarrow.csv as pacsv

    if "time" in rec.channels:
        raise RecordingError(f"{path}: a channel named 'time' collides with the time column")
    bad = [n for n in rec.channels if any(c in n for c in ',"\r\n')]
    if bad:
        raise RecordingError(f"{path}: channel name(s) {bad} cannot be CSV header names")
    table = pa.table({"time": rec.time, **rec.channels})
    with open(path, "wb") as fh:
        fh.write((",".join(table.column_names) + "\n").encode("utf-8"))
        pacsv.write_csv(table, fh, pacsv.WriteOptions(include_header=False))
