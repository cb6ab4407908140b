"""Chunked reading of recording files: Parquet, HDF5 and CSV, never loaded whole.

Memory stays proportional to the chunk size, so a recording of several GB streams through
(see ``docs/operations.md``, "Larger-than-memory recordings").
"""

from __future__ import annotations

import csv
import itertools
import os
import warnings
from typing import Callable, Iterator, Sequence

import numpy as np

from leakdiag._validation import check_int
from leakdiag.io.assemble import decimal_comma_hint
from leakdiag.io.checks import check_same_length, timestamps_error
from leakdiag.io.errors import CutLastRowWarning
from leakdiag.io.recording import RecordingError
from leakdiag.io.text import SEPARATOR_CANDIDATES, cut_last_row_words
from leakdiag.stream.chunks import (DEFAULT_CHUNK_SAMPLES, TIME_COLUMN, ChunkSource, TimeAxis,
                                    _check_unique, _extra_field, _ForwardFault, _json_dict,
                                    _rate_start, _select, _short_row)

__all__ = ["open_chunks", "open_recording", "CHUNKED_SUFFIXES", "PARQUET_HEADER_KEY",
           "HDF5_CHANNEL_GROUP"]

#: Key of the leakdiag JSON header in Parquet schema metadata (layout of :mod:`leakdiag.io`).
PARQUET_HEADER_KEY = b"leakdiag"
#: HDF5 group with one dataset per channel (layout of :mod:`leakdiag.io`).
HDF5_CHANNEL_GROUP = "channels"
#: Suffixes :func:`open_chunks` reads in chunks (:func:`open_recording` reads others whole).
CHUNKED_SUFFIXES = (".parquet", ".pq", ".h5", ".hdf5", ".csv")


def _finite(chunk: dict, chunks: Iterator[tuple[int, dict]], row0: int, path: str) -> None:
    """Refuse a non-finite sample of a chunk in the words of :func:`leakdiag.io.read_recording`
    (:func:`leakdiag.io.checks.check_channel_finite`: ``channel 'p1' has 1 non-finite
    value(s); first NaN at row 50000``): the rest of the file is read to count them, on this
    error path only. Until 2026-11-28 the stream said ``channel 'p1' is not finite at sample
    50000`` without the file, and batch added ``ValueError:`` (streams audit, finding 9)."""
    if all(np.isfinite(np.add.reduce(x)) for x in chunk.values()):
        return  # fast path: a finite sum means all are finite
    first: dict[str, tuple[int, float]] = {}  # channel -> first bad row and value
    count = dict.fromkeys(chunk, 0)

    def add(part: dict, r0: int) -> None:
        for c, x in part.items():
            bad = np.flatnonzero(~np.isfinite(x))
            if len(bad):
                first.setdefault(c, (r0 + int(bad[0]), float(x[bad[0]])))
                count[c] += len(bad)

    add(chunk, row0)
    for r0, rest in chunks:  # a later time or row fault is raised, as detect raises it
        add(rest, r0)
    c = next(c for c in chunk if c in first)  # detect names the first channel with one
    row, value = first[c]
    kind = "NaN" if np.isnan(value) else "inf"
    raise RecordingError(f"{path}: channel {c!r} has {count[c]} non-finite value(s); first "
                         f"{kind} at row {row}")


def _time_checked(chunks, axis: TimeAxis | None):
    """``(row0, chunk)`` of each chunk, its ``time`` (when the file has one) popped and checked
    against the sample rate over the whole file, not only the rows the rate was taken from."""
    row0 = 0
    for chunk in chunks:
        t = chunk.pop(TIME_COLUMN, None)
        n = len(t) if t is not None else len(next(iter(chunk.values()))) if chunk else 0
        if axis is not None and t is not None:
            try:
                axis.check_block(t, row0)
            except _ForwardFault as fault:
                if fault.row != row0 + n - 1:
                    raise
                # a gap at a chunk's last row: two rows swapped across the boundary are
                # named at the second, as within a chunk (the next chunk's first time)
                try:
                    nxt = next(chunks, None)
                except RecordingError:
                    nxt = None  # the next chunk's own fault comes later in the file
                t_next = None if nxt is None else nxt.get(TIME_COLUMN)
                raise axis.after_fault(fault, None if t_next is None or not len(t_next)
                                       else float(t_next[0]), row=row0 + n) from None
        yield row0, chunk
        row0 += n


def _checked(chunks, axis: TimeAxis | None, path: str, finite: bool):
    """Yield the channel chunks, their time checked (:func:`_time_checked`) and then their
    samples, with ``finite``, checked to be finite (:func:`_finite`), in the order of
    :func:`leakdiag.io.read_recording`; a chunk with a non-finite sample is yielded up to its
    first one, then the error raised."""
    try:
        timed = _time_checked(chunks, axis)
        for row0, chunk in timed:
            if finite:
                try:
                    _finite(chunk, timed, row0, path)
                except RecordingError:
                    # the rows before the first non-finite one are handed over first, as a
                    # followed file's lines are (a workflow audit, 2026-11-30: a NaN anywhere
                    # in a 65,536-row chunk left its good windows before it unjudged)
                    cut = min((int(np.flatnonzero(~np.isfinite(x))[0])
                               for x in chunk.values() if not np.isfinite(x).all()), default=0)
                    if cut:
                        yield {c: x[:cut] for c, x in chunk.items()}
                    raise
            yield chunk
    finally:
        chunks.close()  # the CSV reader and HDF5 file close also when the consumer stops early


def _axis(has_time: bool, fs: float, path: str, header: dict) -> TimeAxis | None:
    basis = "from the file's header" if "sample_rate" in header else "from the time column"
    return TimeAxis(fs, path, basis=basis) if has_time else None


def _parquet(path: str, channels, chunk_samples: int, sample_rate, start_time,
             finite: bool = False) -> ChunkSource:
    import pyarrow as pa
    import pyarrow.parquet as pq

    try:
        pf = pq.ParquetFile(path, pre_buffer=False)  # pre-buffering reads whole row groups ahead
    except (pa.ArrowException, OSError) as exc:
        raise RecordingError(f"{path}: unreadable as Parquet: {exc}") from None
    names = pf.schema_arrow.names
    # a name twice: arrow returns both columns for it and the chunk's columns, taken by
    # position, would shift (the second p1 read as p2: an audit, 2026-11-27), as in a CSV
    repeated = _check_unique(names, channels, path)
    chans = _select(names, channels, path, repeated)
    header = _json_dict((pf.schema_arrow.metadata or {}).get(PARQUET_HEADER_KEY, b""))
    for c in chans + ([TIME_COLUMN] if TIME_COLUMN in names else []):
        if pa.types.is_temporal(pf.schema_arrow.field(c).type):  # not nanoseconds as seconds
            raise timestamps_error(path, c)
    t_head = span = None
    if TIME_COLUMN in names and "sample_rate" not in header:
        first = next(pf.iter_batches(batch_size=_HEAD_ROWS, columns=[TIME_COLUMN]), None)
        t_head = (np.empty(0) if first is None else
                  first.column(0).to_numpy(zero_copy_only=False).astype(np.float64))
        span = _parquet_span(pf, pa)
    fs, t0 = _rate_start(t_head, sample_rate, start_time, header, path, span)

    cols = chans + ([TIME_COLUMN] if TIME_COLUMN in names else [])

    def gen():
        # decoded in this thread: arrow's thread pool costs more than it saves on a chunk
        # (1,000 rows: 25 us a chunk without it, 95-155 us with it; 65,536 rows: the same wall
        # time, a third less CPU), and its threads would compete with the monitor's sidecar
        for batch in pf.iter_batches(batch_size=chunk_samples, columns=cols, use_threads=False):
            yield {c: np.ascontiguousarray(batch.column(i).to_numpy(zero_copy_only=False),
                                           dtype=np.float64) for i, c in enumerate(cols)}

    meta = dict(header.get("meta") or {})
    axis = _axis(TIME_COLUMN in names, fs, path, header)
    return ChunkSource(_checked(gen(), axis, path, finite), fs, t0, chans, pf.metadata.num_rows,
                       path, meta)


def _parquet_span(pf, pa) -> tuple[int, float] | None:
    """(rows, last time) of a Parquet file's time column, from its footer and its last row
    group that holds rows (:func:`leakdiag.stream.chunks._span_rate`); None if unreadable."""
    for g in range(pf.num_row_groups - 1, -1, -1):
        if pf.metadata.row_group(g).num_rows:
            try:
                col = pf.read_row_group(g, columns=[TIME_COLUMN], use_threads=False).column(0)
                return pf.metadata.num_rows, float(col[len(col) - 1].as_py())
            except (pa.ArrowException, TypeError, ValueError):
                return None  # the chunks name what is wrong with the time column
    return None


def _hdf5_names(f, h5py) -> list[str]:
    """Names of the 1-D datasets of an open HDF5 file not written by leakdiag, those in groups
    joined with ``/`` as :func:`leakdiag.io.read_recording` names them (``channels/p1``)."""
    names: list[str] = []
    f.visititems(lambda name, v: names.append(name) if isinstance(v, h5py.Dataset)
                 and v.ndim == 1 else None)
    return names


def _hdf5(path: str, channels, chunk_samples: int, sample_rate, start_time,
          finite: bool = False) -> ChunkSource:
    """An HDF5 file in chunks, with the rule of :func:`leakdiag.io.read_recording`
    (:mod:`leakdiag.io.hdf5`): the root attributes are a header (``sample_rate``,
    ``start_time``, ``meta``) and the channels are the datasets of ``/channels`` only when the
    ``format`` attribute says leakdiag wrote the file. Any other file's channels are its
    datasets, named by their path (``p1`` at the root, ``channels/p1`` in a group), and its
    start and rate come from its ``time`` dataset or from the given sample rate, never from
    attributes another program wrote (an audit, 2026-11-27, finding 2: ``start_time=0`` on a
    ``time`` from 100 s moved every alarm by 100 s in monitor and batch, not in detect)."""
    import h5py

    from leakdiag.io.hdf5 import read_hdf5_header

    own = read_hdf5_header(path)  # None: not leakdiag's (also: unreadable, malformed, newer)
    f = h5py.File(path, "r")
    with f:
        if own is not None:
            group = f[HDF5_CHANNEL_GROUP]
            names = [k for k, v in group.items() if isinstance(v, h5py.Dataset) and v.ndim == 1]
            header = {k: float(own[k]) for k in ("sample_rate", "start_time")}
            meta = dict(own.get("meta") or {})
        else:
            group = f
            names = _hdf5_names(f, h5py)
            header, meta = {}, {}
        try:
            chans = _select(names, channels, path)
            if channels is None:  # by default the datasets at the root, as before
                chans = [c for c in chans if "/" not in c]
        except RecordingError as exc:
            if own is None and isinstance(f.get(HDF5_CHANNEL_GROUP), h5py.Group):
                raise RecordingError(
                    f"{exc}; the datasets of /{HDF5_CHANNEL_GROUP} are the channels only in a "
                    f"file leakdiag wrote (root attribute format = 'leakdiag-recording'), which "
                    f"this file does not say it is: give a column map (--map FILE or --col "
                    f"p1=COLUMN:UNIT)") from None
            raise
        if not chans:
            raise RecordingError(f"{path}: no 1-D channel datasets found")
        has_time = isinstance(f.get(TIME_COLUMN), h5py.Dataset)
        # every dataset read is as long as the others, checked before any chunk in the words
        # of read_recording (detect); the chunks run to the first channel's end
        check_same_length({**({f"time column {TIME_COLUMN!r}": len(f[TIME_COLUMN])}
                              if has_time else {}),
                           **{c: len(group[c]) for c in chans}}, path)
        t_head = span = None
        if "sample_rate" not in header and has_time:
            t_head = np.asarray(f[TIME_COLUMN][:_HEAD_ROWS], dtype=np.float64)
            n_t = len(f[TIME_COLUMN])
            span = (n_t, float(f[TIME_COLUMN][n_t - 1])) if n_t else None
        n = len(group[chans[0]])
        gname = group.name
    fs, t0 = _rate_start(t_head, sample_rate, start_time, header, path, span)

    def gen():
        with h5py.File(path, "r") as h:
            g = h[gname]
            for i0 in range(0, n, chunk_samples):
                out = {c: np.ascontiguousarray(g[c][i0:i0 + chunk_samples], dtype=np.float64)
                       for c in chans}
                if has_time:
                    out[TIME_COLUMN] = np.asarray(h[TIME_COLUMN][i0:i0 + chunk_samples],
                                                  dtype=np.float64)
                yield out

    axis = _axis(has_time, fs, path, header)
    return ChunkSource(_checked(gen(), axis, path, finite), fs, t0, chans, n, path, meta)


#: Options of every pandas read of a CSV file (its header, head and chunks), with the file's
#: separator and encoding (:func:`_csv_format`). :class:`_RowFields` splits the lines into rows
#: the same way: blank lines are skipped; ``#`` is data, as in :mod:`leakdiag.io` (no comments:
#: decision 2026-11-27, docs/io.md). ``index_col=False``: no column is taken as an index when
#: rows end in a separator.
_CSV_READ = {"index_col": False}


def _sniff_separator(path: str) -> tuple[str, str]:
    """Separator and encoding of a text file, as :func:`leakdiag.io.text.read_text` finds them
    (the separator is runs of blanks, ``r"\\s+"``; ``","`` for one column)."""
    from pathlib import Path

    from leakdiag.io.text import _sniff

    lines, encoding = _sniff(Path(path), path)
    if not lines:
        raise RecordingError(f"{path}: empty file: no header line and no data")
    return _separator(lines), encoding


def _separator(lines: list[str]) -> str:
    """The separator of text whose first non-blank lines (the header first) are ``lines``, as
    :func:`leakdiag.io.text.read_text` finds it (:func:`leakdiag.io.text.detect_separator`;
    ``","`` for one column); also for stdin (:func:`leakdiag.stream.live.csv_lines`)."""
    from leakdiag.io.text import detect_separator

    sep = detect_separator(lines)
    if len(sep) != 1 and all(len(line.split()) == 1 for line in lines):
        sep = ","  # one column: no separator at all
    return sep


def _csv_format(path: str) -> dict:
    """The separator and encoding of a CSV file, found as :func:`leakdiag.io.read_recording`
    finds them (:func:`leakdiag.io.text.detect_separator` on the first lines; UTF-8 with or
    without a BOM, else Latin-1), so that ``monitor`` and ``batch`` read the ``;`` or tab
    separated ``.csv`` that ``analyze`` and ``detect`` read (audit of users' recordings
    2026-11-27, finding 10).

    Raises
    ------
    RecordingError
        For fields separated by runs of blanks: the chunked reader splits on one character
        (:func:`open_recording` reads such a file whole instead).
    """
    sep, encoding = _sniff_separator(path)
    if len(sep) != 1:
        raise RecordingError(f"{path}: fields separated by blanks, not by one of "
                             f"{list(SEPARATOR_CANDIDATES)}; the chunked CSV reader needs one "
                             f"(leakdiag.io.read_recording reads it whole)")
    return {"sep": sep, "encoding": encoding}
#: Data rows read first, to take the sample rate from the time column.
_HEAD_ROWS = 4096


def _numeric(df, keys: dict[str, str], path: str, row0: int) -> dict:
    """Columns of a CSV chunk as float64 (``keys``: name -> column of ``df``); text names the
    file, channel and row."""
    import pandas as pd

    out = {}
    for c, key in keys.items():
        col = df[key]
        if not pd.api.types.is_numeric_dtype(col.dtype):
            num = pd.to_numeric(col, errors="coerce")
            bad = np.flatnonzero(num.isna().to_numpy() & col.notna().to_numpy())
            if len(bad):
                i = int(bad[0])
                raise RecordingError(f"{path}: channel {c!r} holds text, not numbers: row "
                                     f"{row0 + i} is {str(col.iloc[i])[:40]!r}"
                                     f"{decimal_comma_hint(col.iloc[i])}")
            col = num
        out[c] = np.ascontiguousarray(col.to_numpy(dtype=np.float64), dtype=np.float64)
    return out


def _parse_error(path: str, exc: Exception, sep: str) -> RecordingError:
    """A pandas parse error (e.g. a row with more fields than the first ones), worded as
    :func:`leakdiag.io.text.read_text` words it."""
    text = str(exc).strip()
    msg = text.splitlines()[-1] if text else type(exc).__name__
    return RecordingError(f"{path}: cannot parse as delimited text (separator "
                          f"{sep!r}): {msg}")


def _ends_quoted(line: str, quoted: bool, sep: str = ",") -> bool:
    """Whether a quoted field goes on to the next line after ``line`` (``quoted``: whether the
    line starts inside one), as pandas' C parser reads it."""
    state = 2 if quoted else 0  # 0 field start, 1 plain field, 2 quoted, 3 after a quote
    for c in line:
        if state == 2:
            if c == '"':
                state = 3
        elif state == 3 and c == '"':
            state = 2  # a doubled quote inside the quoted field
        elif c == sep:
            state = 0
        elif state == 0:
            state = 2 if c == '"' else 1
    return state == 2


def _field_counts(lines: Iterator[str], width: int, extras: dict, sep: str = ","
                  ) -> Iterator[int]:
    """The number of fields of each row (the header first), as pandas' C parser splits them.

    A line without quotes is one row of ``line.count(sep) + 1`` fields (blank lines are
    skipped); other lines go through the ``csv`` module (the C parser's dialect), a quoted field
    that goes on over several lines joined (as pandas reads them, a line ``""`` is a row of one
    field). ``#`` is data (no comments).
    A row with a non-empty field after the first ``width`` is yielded negated, and
    ``extras[row]`` is set to ``(field, text)`` (0-based data row, the header being row -1;
    0-based field).
    """
    row = -2
    for line in lines:
        if '"' not in line:
            if line.isspace():
                continue
            k = line.count(sep) + 1
            row += 1
            if k > width:
                fields = line.rstrip("\r\n").split(sep)
                j = next((j for j in range(width, k) if fields[j].strip()), None)
                if j is not None:
                    extras[row] = (j, fields[j])
                    k = -k
            yield k
            continue
        record, quoted = [], False
        while True:
            quoted = _ends_quoted(line, quoted, sep)
            record.append(line)
            if not quoted:
                break
            line = next(lines, None)
            if line is None:
                break
        for fields in csv.reader(record, delimiter=sep, strict=False):
            row += 1
            k = len(fields)
            j = next((j for j in range(width, k) if fields[j].strip()), None)
            if j is not None:
                extras[row] = (j, fields[j])
                k = -k
            yield k


class _RowFields:
    """The number of fields of each data row of a CSV file, counted line by line.

    pandas fills a missing field with NaN, as it fills an empty one; only a count of the fields
    tells them apart. The file is read again (:func:`_field_counts`), only as far as asked:
    :meth:`counts` moves forward with the chunks and starts again from the top only when asked
    for rows before its position. Rows that pandas and the count split differently are found
    at the end of the file (:meth:`rest`, then :meth:`_CsvRows.finish`).

    Parameters
    ----------
    path : str
        The CSV file.
    width : int
        Number of header names: fields after them are extra.
    fmt : dict
        Separator and encoding (:func:`_csv_format`).
    """

    def __init__(self, path: str, width: int, fmt: dict):
        self.path = path
        self.width = width
        self.fmt = fmt
        self.pos = 0  # data rows already counted
        self.header = 0  # fields of the header row
        self._fh = None
        self._counts: Iterator[int] | None = None
        self._extras: dict[int, tuple[int, str]] = {}

    def _open(self) -> None:
        self.close()
        self._fh = open(self.path, encoding=self.fmt["encoding"], errors="replace", newline="")
        self._counts = _field_counts(iter(self._fh), self.width, self._extras, self.fmt["sep"])
        self.header = abs(next(self._counts, 0))
        self.pos = 0

    @property
    def active(self) -> bool:
        """Whether the file is open (rows were counted)."""
        return self._counts is not None

    def _take(self, n: int) -> np.ndarray:
        try:
            return np.fromiter(itertools.islice(self._counts, n), dtype=np.int64)
        except csv.Error as exc:
            raise RecordingError(f"{self.path}: cannot check the rows for missing fields: "
                                 f"{exc}") from None

    def counts(self, row0: int, n: int) -> tuple[np.ndarray, tuple | None]:
        """Fields of data rows ``row0`` to ``row0 + n - 1`` (0-based).

        Parameters
        ----------
        row0, n : int
            First data row and number of rows.

        Returns
        -------
        counts : numpy.ndarray of int
            Fields per row; shorter than ``n`` if the file has fewer rows.
        extra : tuple or None
            ``(row, field, text)`` of the first of these rows with a non-empty field after the
            header's names (0-based field), or None.
        """
        if self._counts is None or row0 < self.pos:
            self._open()
        while self.pos < row0:
            skipped = len(self._take(min(row0 - self.pos, 1 << 16)))
            self._extras.clear()
            if not skipped:
                break
            self.pos += skipped
        counts = self._take(n)
        extra = None
        neg = np.flatnonzero(counts < 0)
        if len(neg):
            row = self.pos + int(neg[0])
            extra = (row, *self._extras[row])
            counts = np.abs(counts)
        self._extras.clear()
        self.pos += len(counts)
        return counts, extra

    def rest(self) -> int:
        """Count (and consume) the rows after the position."""
        n = 0
        while True:
            k = len(self._take(1 << 16))
            self._extras.clear()
            if not k:
                break
            n += k
        self.pos += n
        return n

    def close(self) -> None:
        """Close the file."""
        if self._fh is not None:
            self._fh.close()
        self._fh = self._counts = None


class _CsvRows:
    """Checks that the rows of a CSV file hold the columns read from them, chunk by chunk.

    The same rules as :meth:`leakdiag.io.text.TextTable.check_rows`, with the same messages: a
    data row with fewer fields than the header is refused (its last field may be cut: ``53``
    written as ``5``; a field missing in the middle shifts the values after it), except the
    file's last row when it ends after every column read (a file cut while written). A row with
    more fields than the header is refused unless its extra fields are empty (separators at
    the end of rows are ignored).

    Parameters
    ----------
    path : str
        The file.
    names : list of str
        The header's names by position.
    read : dict of str to str
        What a column is read as (``"time column"``, ``"channel 'p1'"``) -> its name.
    fmt : dict
        Separator and encoding (:func:`_csv_format`).

    Notes
    -----
    A missing field reads as NaN, so only a chunk whose last column (the *probe*) holds a NaN
    has its fields counted
    (:class:`_RowFields`): free for a file without empty cells there, otherwise the file is read
    a second time, once, as the chunks go.
    """

    def __init__(self, path: str, names: list[str], read: dict[str, str], fmt: dict):
        self.path = path
        self.n = len(names)
        self.read = read
        self.pos = {col: names.index(col) for col in read.values()}
        self.probe = self.n - 1  # any short row: where its field went missing is unknown;
        # the file's last row only if it ends at or before a column read (a file cut while it
        # was written keeps its read values)
        self.last_probe = min(max(self.pos.values(), default=-1) + 1, self.n - 1)
        self.fields = _RowFields(path, self.n, fmt)
        # a chunk's last row, short after the columns read, in a chunk that may not be the
        # file's last: (row, its error), raised when a later row comes
        self.pending: tuple[int, RecordingError] | None = None
        # the short last row read, (row, its fields): said once at the end (finish)
        self.cut: tuple[int, int] | None = None

    def first_row(self) -> int:
        """Check data row 0 for extra fields; return the fields of the widest rows pandas will
        take (the header's, or more when row 0 ends in separators)."""
        try:
            counts, extra = self.fields.counts(0, 1)
        finally:
            self.fields.close()
        if self.fields.header != self.n:
            raise RecordingError(
                f"{self.path}: cannot check the rows for missing fields: pandas reads {self.n} "
                f"header names, counting fields line by line finds {self.fields.header}; look "
                f"for odd lines (only quotes or blanks)")
        if extra is not None:
            raise self._extra(*extra)
        return max(self.n, int(counts[0])) if len(counts) else self.n

    def _extra(self, row: int, field: int, text: str) -> RecordingError:
        return _extra_field(self.path, f"row {row}", self.n, field, text)

    def check(self, df, row0: int, last: bool) -> None:
        """Raise if a row of the chunk ``df`` (data rows from ``row0``) is short or too long.

        Parameters
        ----------
        df : pandas.DataFrame
            The chunk, columns named by their 0-based position (``"0"``, ``"1"``, ...).
        row0 : int
            Data row of its first row.
        last : bool
            Whether it is the file's last chunk (for the count of short rows).

        Raises
        ------
        RecordingError
            Naming the file, the first short row, its field count and the columns read that
            it lacks or cuts; or the first row with a non-empty field after the header's.
        """
        if not self.read:
            return
        if self.pending is not None and row0 + len(df) - 1 > self.pending[0]:
            raise self.pending[1]  # a row came after it: not the file's last row
        wide = [c for c in df.columns if int(c) >= self.n]  # fields of rows ending in separators
        # a field beyond the header's counts when it is not empty after stripping blanks (as the
        # line counter and io's reader see it); pandas keeps "  " as text
        filled = df[wide].apply(lambda col: col.notna() & col.astype(str).str.strip().ne(""))
        extra_rows = (np.flatnonzero(filled.to_numpy().any(axis=1)) if wide
                      else np.empty(0, dtype=np.int64))
        blank = df[str(self.probe)].isna().to_numpy()
        if not blank.any() and not len(extra_rows):
            return
        counts, extra = self.fields.counts(row0, len(df))
        if len(counts) != len(df):
            raise RecordingError(
                f"{self.path}: cannot check the rows for missing fields: pandas reads "
                f"{'' if last else 'at least '}{row0 + len(df)} data rows, counting fields line "
                f"by line finds {row0 + len(counts)}; look for odd lines (only quotes or blanks)")
        short = np.flatnonzero(counts <= self.probe)
        if len(short) and short[-1] == len(df) - 1 and counts[-1] > self.last_probe:
            # the chunk's last row, cut after the columns read: read if it is the file's last
            # row (a file cut while it was written); in a full chunk that is not known yet
            if not last:
                first = df["0"].iloc[-1] if "0" in df.columns else None
                self.pending = (row0 + len(df) - 1, _short_row(
                    self.path, f"row {row0 + len(df) - 1}", int(counts[-1]), self.n,
                    self.read, self.pos, first=first))
            self.cut = (row0 + len(df) - 1, int(counts[-1]))
            short = short[:-1]
        first_short = row0 + int(short[0]) if len(short) else None
        if extra is not None and (first_short is None or extra[0] < first_short):
            raise self._extra(*extra)
        if first_short is None:
            if len(extra_rows):  # pandas saw a field that the count did not: name its value
                i = int(extra_rows[0])
                col = next(c for c in wide if filled[c].iloc[i])
                raise self._extra(row0 + i, int(col), str(df[col].iloc[i]))
            return
        more = ("" if len(short) == 1 else f"; {len(short)} rows are short like this" if last
                else f"; at least {len(short)} rows are short like this")
        first = df["0"].iloc[int(short[0])] if "0" in df.columns else None
        raise _short_row(self.path, f"row {first_short}", int(counts[short[0]]), self.n,
                         self.read, self.pos, more, first=first)

    def finish(self, n_rows: int) -> None:
        """At the end of the file: if rows were counted, pandas and the count must agree; a
        short last row read is said (:class:`~leakdiag.io.errors.CutLastRowWarning`)."""
        if self.cut is not None and self.cut[0] == n_rows - 1:
            warnings.warn(cut_last_row_words(self.path, f"row {self.cut[0]}", self.cut[1],
                                             self.n), CutLastRowWarning, stacklevel=2)
        if self.fields.active:
            self.fields.rest()
            if self.fields.pos != n_rows:
                raise RecordingError(
                    f"{self.path}: cannot check the rows for missing fields: pandas reads "
                    f"{n_rows} data rows, counting fields line by line finds "
                    f"{self.fields.pos}; look for odd lines (only quotes or blanks)")

    def close(self) -> None:
        """Close the file of the field count."""
        self.fields.close()


def _csv_names(path: str, fmt: dict) -> list[str]:
    """The header's names by position as written (stripped of blanks; an empty name at 0-based
    position ``j`` is ``Unnamed: j``), as :func:`leakdiag.io.text.read_text` names them:
    pandas' renaming of repeated names (``PG_1`` -> ``PG_1.1``) is not used."""
    import pandas as pd

    try:
        raw = pd.read_csv(path, header=None, nrows=1, dtype=str, keep_default_na=False,
                          **_CSV_READ, **fmt).iloc[0].tolist()
    except pd.errors.EmptyDataError:
        raise RecordingError(f"{path}: empty file: no header line and no data") from None
    except (pd.errors.ParserError, UnicodeDecodeError) as exc:
        raise _parse_error(path, exc, fmt["sep"]) from None
    return [str(r).strip() or f"Unnamed: {j}" for j, r in enumerate(raw)]


def _csv_read(path: str, fmt: dict, width: int, usecols, **options):
    """``pandas.read_csv`` of the data rows, columns named by position ("0", "1", ...)."""
    import pandas as pd

    try:
        return pd.read_csv(path, header=0, names=[str(j) for j in range(width)],
                           usecols=usecols, **_CSV_READ, **fmt, **options)
    except pd.errors.EmptyDataError:
        raise RecordingError(f"{path}: empty file: no header line and no data") from None
    except (pd.errors.ParserError, UnicodeDecodeError) as exc:
        raise _parse_error(path, exc, fmt["sep"]) from None


def _csv_frames(path: str, fmt: dict, chunk_samples: int, keys: dict[str, str], rows: _CsvRows,
                width: int, usecols):
    """Chunks of a CSV, rows checked; the readers are opened on first use and closed when the
    generator is closed (also when the consumer stops early on an error), so no file handle
    leaks."""
    import pandas as pd

    row0 = 0
    try:
        with _csv_read(path, fmt, width, usecols, chunksize=chunk_samples) as frames:
            while True:
                try:
                    df = next(frames)
                except StopIteration:
                    break
                except (pd.errors.ParserError, UnicodeDecodeError) as exc:
                    raise _parse_error(path, exc, fmt["sep"]) from None
                rows.check(df, row0, last=len(df) < chunk_samples)
                yield _numeric(df, keys, path, row0)
                row0 += len(df)
        rows.finish(row0)
    finally:
        rows.close()


def _csv_span(path: str, fmt: dict, width: int, key: str,
              chunk_samples: int) -> tuple[int, float] | None:
    """(rows, last time) of a CSV's time column, read alone in chunks with the options of the
    chunks (:func:`leakdiag.stream.chunks._span_rate`): one pass over the file, with memory of
    one chunk of one column; None when it does not parse (the chunks name what is wrong)."""
    import pandas as pd

    n, last = 0, None
    try:  # parsed by pandas as the chunks are (Python's float() can differ in the last bit)
        with _csv_read(path, fmt, width, [key],
                       chunksize=max(chunk_samples, 1 << 16)) as frames:
            for df in frames:
                if len(df):
                    n += len(df)
                    last = df[key].iloc[-1:]
    except (RecordingError, pd.errors.ParserError, UnicodeDecodeError, ValueError):
        return None
    if last is None or not pd.api.types.is_numeric_dtype(last.dtype):
        return None  # text: the chunks name it
    return n, float(last.iloc[0])


def _csv(path: str, channels, chunk_samples: int, sample_rate, start_time,
         finite: bool = False) -> ChunkSource:
    fmt = _csv_format(path)
    names = _csv_names(path, fmt)
    repeated = _check_unique(names, channels, path)
    chans = _select(names, channels, path, repeated)
    has_time = TIME_COLUMN in names
    read = {**({"time column": TIME_COLUMN} if has_time else {}),
            **{f"channel {c!r}": c for c in chans}}
    rows = _CsvRows(path, names, read, fmt)
    width = rows.first_row()
    keys = {c: str(names.index(c)) for c in read.values()}
    # pandas checks that no row has more fields than the first rows only when every column is
    # read (not with usecols); the probe column is read for the short-row check
    needed = {*rows.pos.values(), rows.probe}
    usecols = None if len(needed) >= len(names) else sorted(needed)
    head = _csv_read(path, fmt, width, usecols, nrows=_HEAD_ROWS)
    if head.empty:
        raise RecordingError(f"{path}: header only, no data rows")
    try:
        rows.check(head, 0, last=len(head) < _HEAD_ROWS)
    finally:
        rows.close()
    t_head = (_numeric(head, {TIME_COLUMN: keys[TIME_COLUMN]}, path, 0)[TIME_COLUMN]
              if has_time else None)
    span = (_csv_span(path, fmt, width, keys[TIME_COLUMN], chunk_samples)
            if has_time and len(head) == _HEAD_ROWS else None)
    fs, t0 = _rate_start(t_head, sample_rate, start_time, {}, path, span)
    keys = {c: keys[c] for c in chans + ([TIME_COLUMN] if has_time else [])}
    # its length when known without another pass: the time column's span, or the head alone
    n = span[0] if span is not None else (len(head) if len(head) < _HEAD_ROWS else None)
    return ChunkSource(_checked(_csv_frames(path, fmt, chunk_samples, keys, rows, width, usecols),
                                _axis(has_time, fs, path, {}), path, finite), fs, t0, chans, n,
                       path, {})


def open_chunks(path: str | os.PathLike, channels: Sequence[str] | None = None,
                chunk_samples: int = DEFAULT_CHUNK_SAMPLES, sample_rate: float | None = None,
                start_time: float | None = None, finite: bool = False) -> ChunkSource:
    """Open a Parquet (``.parquet``/``.pq``), HDF5 (``.h5``/``.hdf5``) or CSV file in chunks.

    Parameters
    ----------
    path : str or path-like
        Recording file with a ``time`` column (s) and one column/dataset per channel.
    channels : sequence of str, optional
        Channels to read (default: all but ``time``).
    chunk_samples : int, default 2**20
        Samples per chunk.
    sample_rate : float, optional
        Sample rate in Hz; default: from the file metadata, else from the ``time`` column.
    start_time : float, optional
        Time of sample 0 in s; default: the first ``time`` value, else 0.
    finite : bool, default False
        Refuse a NaN or inf sample of a channel read, while iterating, in the words of
        :func:`leakdiag.io.read_recording` (``run.csv: channel 'p1' has 2 non-finite
        value(s); first NaN at row 5000``, the rest of the file read to count them);
        :func:`open_recording` sets it. Without it an empty CSV cell is a NaN sample.

    Returns
    -------
    ChunkSource

    Raises
    ------
    FileNotFoundError
        If the file does not exist.
    RecordingError
        For an unknown suffix, a missing channel or no way to get the sample rate. For a CSV
        also, with the rules and words of :func:`leakdiag.io.read_recording`: a column read
        whose name the header repeats, and a row cut short at or before the last column read
        (a truncated line) or with a non-empty field after the header's; rows are 0-based data
        rows. The first 4096 rows are checked when the file is opened, later rows as their
        chunk is read.

    Notes
    -----
    Parquet is read with ``pyarrow.parquet.ParquetFile.iter_batches``, HDF5 by slicing the
    channel datasets (at the root or in a ``channels`` group), CSV with ``pandas.read_csv``
    and ``chunksize``; memory stays proportional to ``chunk_samples``. A CSV's separator (tab,
    ``,``, ``;`` or ``|``) and encoding are found as :func:`leakdiag.io.read_recording` finds
    them; fields separated by runs of blanks are refused. CSV header names are taken as written
    (stripped of blanks), ``#`` is data (no comments, as in :mod:`leakdiag.io`) and rows ending
    in a separator are read in their columns. See ``docs/operations.md``, "CSV rows and header",
    for the checks, their cost and their known limit (with some columns left out, a later row
    with extra fields is not seen).

    Examples
    --------
    >>> import tempfile, pathlib, pandas as pd
    >>> p = pathlib.Path(tempfile.mkdtemp()) / "r.csv"
    >>> pd.DataFrame({"time": np.arange(5) / 100.0, "p1": np.arange(5.0)}).to_csv(p, index=False)
    >>> src = open_chunks(p, chunk_samples=2)
    >>> src.sample_rate, [len(c["p1"]) for c in src]
    (100.0, [2, 2, 1])
    """
    path = os.fspath(path)
    if not os.path.exists(path):
        raise FileNotFoundError(f"{path}: no such file")
    chunk_samples = check_int(chunk_samples, "chunk_samples", 1)
    suffix = os.path.splitext(path)[1].lower()
    readers: dict[str, Callable] = {".parquet": _parquet, ".pq": _parquet, ".h5": _hdf5,
                                    ".hdf5": _hdf5, ".csv": _csv}
    if suffix not in readers:
        raise RecordingError(f"{path}: unknown file type {suffix!r}; use one of {sorted(readers)}")
    return readers[suffix](path, channels, chunk_samples, sample_rate, start_time, finite)


def _blank_separated(path: str) -> bool:
    """Whether ``path`` is a ``.csv`` whose fields are separated by runs of blanks (read whole,
    as :func:`leakdiag.io.read_recording` reads it, not in chunks)."""
    if os.path.splitext(path)[1].lower() != ".csv" or not os.path.exists(path):
        return False
    try:
        return len(_sniff_separator(path)[0]) != 1
    except RecordingError:
        return False  # open_chunks says what is wrong


def open_recording(path: str | os.PathLike, channels: Sequence[str] | None = None,
                   chunk_samples: int = DEFAULT_CHUNK_SAMPLES, sample_rate: float | None = None,
                   column_map=None) -> tuple[ChunkSource, dict[str, str] | None]:
    """A recording file's chunks and the units of its channels, as ``monitor`` and ``batch``
    judge it.

    Without a column map, a Parquet, HDF5 or CSV file (separated by one character) is read in
    chunks (:func:`open_chunks`)
    and its samples stay in the units its leakdiag header states
    (:func:`leakdiag.io.recording_units`). Another file, or any file with a column map, is
    read whole with :func:`leakdiag.io.read_recording` (in SI units, or ``counts``) and
    replayed in chunks.

    Parameters
    ----------
    path : str or path-like
        Recording file.
    channels : sequence of str, optional
        Channels to read (default: all).
    chunk_samples : int, default 2**20
        Samples per chunk.
    sample_rate : float, optional
        Sample rate in Hz, when the file has no time column in seconds.
    column_map : optional
        Column map (:func:`leakdiag.io.load_column_map` accepts it).

    Returns
    -------
    source : ChunkSource
        Its ``source`` is ``path`` as given.
    units : dict of str to str, or None
        Channel -> unit of the samples; None where the file states none (a plain CSV, a
        file another program wrote: SI is assumed, as the readers assume it).

    Raises
    ------
    RecordingError
        As :func:`open_chunks`, :func:`leakdiag.io.recording_units` and
        :func:`leakdiag.io.read_recording` raise it.

    Examples
    --------
    >>> import tempfile, pathlib
    >>> from leakdiag.io import Recording, write_recording
    >>> p = pathlib.Path(tempfile.mkdtemp()) / "r.parquet"
    >>> rec = Recording({"p1": np.arange(5.0)}, 100.0, units={"p1": "counts"})
    >>> src, units = open_recording(write_recording(rec, p), chunk_samples=2)
    >>> units, [len(c["p1"]) for c in src]
    ({'p1': 'counts'}, [2, 2, 1])
    """
    from leakdiag.io import read_recording, recording_units
    from leakdiag.stream.chunks import recording_chunks

    path = os.fspath(path)
    if (column_map is None and os.path.splitext(path)[1].lower() in CHUNKED_SUFFIXES
            and not _blank_separated(path)):
        return (open_chunks(path, channels, chunk_samples, sample_rate, finite=True),
                recording_units(path))
    # only the channels asked for are read and checked, as detect reads a file (a NaN in a
    # column the detector does not read made monitor and batch refuse a file detect judged:
    # a user-data audit, 2026-11-29)
    rec = read_recording(path, column_map, sample_rate=sample_rate,
                         channels=None if channels is None else list(channels))
    rec.meta["source"] = path
    return recording_chunks(rec, chunk_samples, channels), dict(rec.units)
