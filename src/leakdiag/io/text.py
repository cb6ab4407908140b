"""Delimited text files (CSV, TSV, ...): read any, write CSV."""

from __future__ import annotations

import os
import warnings
from dataclasses import dataclass, field
from pathlib import Path
from typing import Mapping

import numpy as np

from leakdiag.io.errors import CutLastRowWarning
from leakdiag.io.recording import Recording, RecordingError
from leakdiag.io.table import RawTable, repeated_names

__all__ = ["SEPARATOR_CANDIDATES", "TextTable", "detect_separator", "read_text", "write_csv"]

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
    if head[:2] in (b"\xff\xfe", b"\xfe\xff"):  # Excel's "Unicode text": UTF-16, not binary
        raise RecordingError(f"{source}: UTF-16 text (a byte-order mark; Excel's \"Unicode "
                             "text\"): leakdiag reads UTF-8 or Latin-1 text; save it as CSV "
                             "(UTF-8) or convert it (iconv -f UTF-16 -t UTF-8)")
    if b"\x00" in head:
        raise RecordingError(f"{source}: unreadable as text (binary data); is it another format?")
    cut = head.rfind(b"\n")
    complete = head if cut < 0 or len(head) < _SNIFF_BYTES else head[:cut + 1]
    try:
        text, encoding = complete.decode("utf-8-sig"), "utf-8-sig"
        if len(head) == _SNIFF_BYTES and not _rest_is_utf8(path, len(complete)):
            # a non-UTF-8 byte after the head (a degree sign in a note on row 1800 of a cp1252
            # export): the file is Latin-1 as documented, not an error at that byte (a
            # user-data audit, 2026-11-29)
            text, encoding = complete.decode("latin-1"), "latin-1"
    except UnicodeDecodeError:  # e.g. Windows DAQ exports with a degree sign in cp1252
        text, encoding = complete.decode("latin-1"), "latin-1"
    lines = [line.rstrip("\r") for line in text.split("\n") if line.strip()]
    return lines[:_SNIFF_LINES], encoding


def _rest_is_utf8(path: Path, start: int, block: int = 1 << 20) -> bool:
    """Whether the file from byte ``start`` on (a line start) decodes as UTF-8, read in blocks
    (about 1 ms per MB)."""
    import codecs

    dec = codecs.getincrementaldecoder("utf-8")()
    try:
        with open(path, "rb") as fh:
            fh.seek(start)
            while True:
                data = fh.read(block)
                if not data:
                    dec.decode(b"", final=True)
                    return True
                dec.decode(data)
    except UnicodeDecodeError:
        return False


def _field_counts(path: Path, sep: str, encoding: str) -> np.ndarray:
    """Number of fields of every data row, with the row numbering of ``pandas.read_csv``.

    Quoted fields are honoured as pandas' C parser does (``csv`` module, same dialect); a
    regular-expression separator splits the stripped line (pandas' Python parser). Lines that
    are empty or hold one blank field are skipped, as pandas skips them; the first row left is
    the header and is not returned.
    """
    import csv
    import re

    with open(path, encoding=encoding, newline="") as fh:
        if len(sep) == 1:
            rows = csv.reader(fh, delimiter=sep, skipinitialspace=True, strict=False)
        else:
            pat = re.compile(sep)
            rows = (pat.split(line.strip()) for line in fh)
        counts = np.fromiter((len(r) for r in rows if len(r) > 1 or (r and r[0].strip())),
                             dtype=np.int64)
    return counts[1:]


def extra_field_error(source: str, where: str, n: int, field: int, text: str
                      ) -> RecordingError:
    """The error for a row with a non-empty field after the header's ``n`` names (0-based
    ``field``): which column each of its values belongs to cannot be told.

    Examples
    --------
    >>> print(extra_field_error("a.csv", "row 0", 3, 3, "7"))  # doctest: +NORMALIZE_WHITESPACE
    a.csv: row 0 has more fields than the header (3 names): field 4 is '7'; which column each
    value belongs to cannot be told (a name missing in the header, or two lines run together?)
    """
    return RecordingError(
        f"{source}: {where} has more fields than the header ({n} names): field {field + 1} is "
        f"{text.strip()[:40]!r}; which column each value belongs to cannot be told (a name "
        f"missing in the header, or two lines run together?)")


def _check_extra_fields(path: Path, source: str, sep: str, encoding: str, n: int,
                        options: dict) -> None:
    """Refuse a row whose fields beyond the header's ``n`` are not all empty (pandas drops
    them with a warning); trailing separators (empty extra fields) are ignored (docs/io.md)."""
    import pandas as pd

    # pandas takes the width from the first data row (a wider later row is a parse error)
    extra = pd.read_csv(path, header=None, skiprows=1, dtype=str, keep_default_na=False,
                        **options).iloc[:, n:]
    filled = extra.apply(lambda col: col.str.strip().ne(""))
    rows = np.flatnonzero(filled.to_numpy().any(axis=1))
    if len(rows):
        i = int(rows[0])
        j = int(np.flatnonzero(filled.iloc[i].to_numpy())[0])
        raise extra_field_error(source, f"row {i}", n, n + j, str(extra.iat[i, j]))


#: Appended to the error for a short row whose first field starts with ``#``: no reader of
#: leakdiag takes ``#`` as a comment (docs/io.md, decision 2026-11-27).
COMMENT_HINT = ("; it starts with '#', and leakdiag reads no comment lines ('#' is data, as in "
                "an Excel '#N/A' cell): remove the line")


def cut_last_row_words(source: str, where: str, k: int, n: int) -> str:
    """What is said of a last row of ``k`` of ``n`` fields that is read
    (:class:`~leakdiag.io.errors.CutLastRowWarning`; :meth:`TextTable.check_rows` and the
    chunked reader of :mod:`leakdiag.stream.files`).

    Examples
    --------
    >>> cut_last_row_words("a.csv", "row 9", 4, 7)[:62]
    'a.csv: its last line, row 9, has 4 of 7 fields (the columns re'
    """
    return (f"{source}: its last line, {where}, has {k} of {n} fields (the columns read are "
            "complete, so it is read): the file ends in a cut line, as one cut while it was "
            "written or copied does; it may hold only part of the recording")


def short_row_error(source: str, where: str, k: int, n: int, read: dict[str, str],
                    pos: dict[str, int], more: str = "", first: object = None
                    ) -> RecordingError:
    """The error for a row of ``k`` of ``n`` fields (:meth:`TextTable.check_rows`, and the
    streaming readers of :mod:`leakdiag.stream`): the columns read that it lacks or cuts, or,
    when it ends after every column read, that a field missing anywhere shifts the values.

    Parameters
    ----------
    source : str
        File name.
    where : str
        The row (``"row 3"``, 0-based data row of a file) or line (``"line 5"`` of a stream).
    k, n : int
        Fields of the row and of the header.
    read : dict of str to str
        What a column is read as (``"time column"``, ``"channel 'p1'"``) -> its name.
    pos : dict of str to int
        Column name -> 0-based position in the header.
    more : str, optional
        Appended (how many rows are short like this).
    first : optional
        The row's first field: text starting with ``#`` adds :data:`COMMENT_HINT`.

    Returns
    -------
    RecordingError
        Naming the columns read that the row lacks or cuts (its last field may be cut).

    Examples
    --------
    >>> print(short_row_error("a.csv", "row 3", 3, 4, {"time column": "time", "channel 'p2'": "p2"},
    ...                       {"time": 0, "p2": 2}))
    a.csv: row 3 has 3 of 4 fields (truncated line?); column 'p2' (channel 'p2') is missing or cut
    >>> print(short_row_error("a.csv", "row 3", 3, 4, {"channel 'p1'": "p1"}, {"p1": 0}))
    a.csv: row 3 has 3 of 4 fields: a field is missing, and one missing before a column read shifts that column's value into another (a field missing at the end of the row cannot be told from one missing in the middle); fix or remove the row
    """
    hit = sorted({c for c in read.values() if pos[c] >= k - 1}, key=pos.get)
    desc = ", ".join(f"{c!r} ({', '.join(lab for lab, col in read.items() if col == c)})"
                     for c in hit)
    if not hit:  # it ends after every column read: where its field went missing is unknown
        return RecordingError(
            f"{source}: {where} has {k} of {n} fields: a field is missing, and one missing "
            "before a column read shifts that column's value into another (a field missing "
            "at the end of the row cannot be told from one missing in the middle); fix or "
            f"remove the row{more}"
            f"{COMMENT_HINT if isinstance(first, str) and first.lstrip().startswith('#') else ''}")
    return RecordingError(
        f"{source}: {where} has {k} of {n} fields (truncated line?); "
        f"{'column' if len(hit) == 1 else 'columns'} {desc} "
        f"{'is' if len(hit) == 1 else 'are'} missing or cut{more}"
        f"{COMMENT_HINT if isinstance(first, str) and first.lstrip().startswith('#') else ''}")


@dataclass
class TextTable(RawTable):
    """A :class:`RawTable` read from delimited text, which can check its rows for missing fields.

    Parameters
    ----------
    columns, source, header, duplicates
        As in :class:`RawTable`.
    fields : list of str
        The header's column names by position (duplicates included).
    path : pathlib.Path, optional
        The file, re-read by :meth:`check_rows` only if a row may be short.
    separator : str, default ","
        Field separator (one character, or a regular expression such as ``r"\\s+"``).
    encoding : str, default "utf-8"
        Text encoding of the file.
    by_position : list of numpy.ndarray
        The parsed column at each header position (duplicates included): a missing field
        reads as NaN (numbers) or None (text).

    Examples
    --------
    >>> import tempfile, pathlib
    >>> p = pathlib.Path(tempfile.mkdtemp()) / "cut.csv"
    >>> _ = p.write_text("time,p1,p2\\n0,1,10\\n1,2,20\\n2,3")
    >>> table = read_text(p)
    >>> table.columns["p2"]
    array([10., 20., nan])
    >>> table.check_rows({"time column": "time", "channel 'p1'": "p1"})
    Traceback (most recent call last):
    ...
    leakdiag.io.errors.RecordingError: ...cut.csv: row 2 has 2 of 3 fields (truncated line?);
    column 'p1' (channel 'p1') is missing or cut
    """

    fields: list[str] = field(default_factory=list)
    path: Path | None = None
    separator: str = ","
    encoding: str = "utf-8"
    by_position: list[np.ndarray] = field(default_factory=list, repr=False)

    def check_rows(self, columns: Mapping[str, str]) -> None:
        """Raise if a data row has fewer fields than the header (a truncated line, or a field
        missing anywhere in the row).

        A row with fewer fields than the header has no value for the columns after its last
        field, and its last field may itself be cut short (``53`` written as ``5``). A row that
        ends after every column read is refused too: its missing field may be in the middle,
        which shifts every later value into the column before it (a user-data audit,
        2026-11-29: a real file's row without its ``Temp_3`` field read PG_2 as p1 and PG_3 as
        p2). Until then such a row was read, as if fields went missing only at the end. The
        file's *last* row is the exception: one that ends after every column read is read, as
        a file cut while it was written (its missing fields are at its end).

        Parameters
        ----------
        columns : dict of str to str
            What a column is read as (``"channel 'p1'"``, ``"time column"``) -> column name;
            names that are not in the header are ignored (reported elsewhere).

        Raises
        ------
        RecordingError
            Naming the file, the first short row (0-based data row, as every row number of
            :mod:`leakdiag.io`), its field count and the columns read that it lacks or cuts.

        Notes
        -----
        Missing fields parse as NaN, so only when the last column holds NaN is the file scanned
        again to count the fields of each row.
        """
        pos = {name: self.fields.index(name) for name in columns.values() if name in self.fields}
        if not pos:
            return
        n = len(self.fields)
        # a row with k < n fields lacks the last field, whose value reads NaN; it is refused
        # (where in the row its field went missing cannot be told), except the file's last
        # row when it ends after every column read (a file cut while it was written)
        probe, last_probe = n - 1, min(max(pos.values()) + 1, n - 1)
        values = self.by_position[probe]
        blank = (np.isnan(values) if values.dtype != object
                 else np.fromiter((v is None for v in values), dtype=bool, count=len(values)))
        if not blank.any():
            return
        counts = _field_counts(self.path, self.separator, self.encoding)
        if len(counts) != len(values):
            raise RecordingError(
                f"{self.source}: cannot check the rows for missing fields: pandas reads "
                f"{len(values)} data rows, counting fields line by line finds {len(counts)}; "
                f"look for odd lines (only quotes or blanks)"
            )
        short = np.flatnonzero(counts <= probe)
        if len(short) and short[-1] == len(counts) - 1 and counts[-1] > last_probe:
            short = short[:-1]  # the last row, cut after the columns read: read, and said
            if not len(short):
                warnings.warn(cut_last_row_words(self.source, f"row {len(counts) - 1}",
                                                 int(counts[-1]), n), CutLastRowWarning,
                              stacklevel=2)
        if not len(short):
            return
        more = f"; {len(short)} rows are short like this" if len(short) > 1 else ""
        i = int(short[0])
        raise short_row_error(self.source, f"row {i}", int(counts[i]), n, dict(columns), pos,
                              more, first=self.by_position[0][i])


def read_text(path: str | os.PathLike, separator: str | None = None) -> TextTable:
    """Read a delimited text file with one header row into a :class:`TextTable`.

    Parameters
    ----------
    path : str or path-like
        The file.
    separator : str, optional
        Field separator; None = :func:`detect_separator`.

    Returns
    -------
    TextTable
        One column per header name (names stripped of blanks; an empty name at 0-based
        position ``j`` becomes ``Unnamed: j``): float64 where every value is a number or empty
        (NaN), object (text) otherwise. A missing field of a short row reads as empty: call
        :meth:`TextTable.check_rows` with the columns you use. Names that occur more than once
        are left out of ``columns`` and listed in ``duplicates``. Trailing separators at the
        end of rows (empty trailing fields) are ignored.

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
    options = dict(sep=sep, index_col=False, skipinitialspace=True, encoding=encoding,
                   engine="c" if len(sep) == 1 else "python")
    try:
        # the header as written: pandas renames repeated names ("PG_1" -> "PG_1.1")
        raw = pd.read_csv(path, header=None, nrows=1, dtype=str, keep_default_na=False,
                          **options).iloc[0].tolist()
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always", pd.errors.ParserWarning)
            df = pd.read_csv(path, **options)
        if any(issubclass(w.category, pd.errors.ParserWarning) for w in caught):
            # rows with more fields than the header: pandas drops the extra ones
            _check_extra_fields(path, source, sep, encoding, len(raw), options)
    except pd.errors.EmptyDataError:
        raise RecordingError(f"{source}: file is empty") from None
    except RecordingError:
        raise
    except (pd.errors.ParserError, UnicodeDecodeError, ValueError) as exc:
        msg = str(exc).strip().splitlines()[-1] if str(exc).strip() else type(exc).__name__
        raise RecordingError(f"{source}: cannot parse as delimited text "
                             f"(separator {sep!r}): {msg}") from None
    if len(df) == 0:
        raise RecordingError(f"{source}: has a header ({', '.join(map(str, df.columns))}) "
                             f"but no data rows")
    if len(raw) != len(df.columns):
        raise RecordingError(f"{source}: the header has {len(raw)} names but pandas read "
                             f"{len(df.columns)} columns (separator {sep!r})")
    names = [str(r).strip() or str(c).strip() for r, c in zip(raw, df.columns)]
    by_position = []
    for j in range(len(names)):
        s = df.iloc[:, j]
        if pd.api.types.is_numeric_dtype(s) and not pd.api.types.is_bool_dtype(s):
            by_position.append(s.to_numpy(dtype=np.float64, na_value=np.nan))
        else:
            by_position.append(s.to_numpy(dtype=object, na_value=None))
    duplicates = repeated_names(names)
    columns = {name: by_position[j] for j, name in enumerate(names) if name not in duplicates}
    return TextTable(columns, source, duplicates=duplicates, fields=names, path=path,
                     separator=sep, encoding=encoding, by_position=by_position)


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
