"""Parquet recordings: one float64 column per channel plus ``time``; header in schema metadata."""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from leakdiag.io.header import decode_header, encode_header
from leakdiag.io.recording import Recording, RecordingError
from leakdiag.io.table import RawTable, repeated_names

__all__ = ["HEADER_KEY", "read_parquet", "read_parquet_header", "write_parquet"]

#: Schema-metadata key holding the JSON header (see :mod:`leakdiag.io.header`).
HEADER_KEY = b"leakdiag"


def write_parquet(rec: Recording, path: str | os.PathLike) -> None:
    """Write a recording as Parquet with units and metadata in the schema metadata.

    Parameters
    ----------
    rec : Recording
        The recording.
    path : str or path-like
        Output file.

    Raises
    ------
    RecordingError
        If a channel is named ``time`` or the metadata is not JSON-serialisable.

    Notes
    -----
    Columns: ``time`` (s, for other tools) and the channels, all float64. The schema metadata
    key ``leakdiag`` holds the JSON header (sample rate, start time, channel order, units,
    meta), which :func:`read_parquet` uses so that everything round-trips exactly.

    Examples
    --------
    >>> import tempfile, pathlib
    >>> p = pathlib.Path(tempfile.mkdtemp()) / "a.parquet"
    >>> write_parquet(Recording({"p1": np.array([1.0, 2.0])}, 2.0, meta={"onset": 0.5}), p)
    >>> read_parquet(p).header["meta"]
    {'onset': 0.5}
    """
    import pyarrow as pa
    import pyarrow.parquet as pq

    if "time" in rec.channels:
        raise RecordingError(f"{path}: a channel named 'time' collides with the time column")
    header = encode_header(rec, str(path))
    table = pa.table({"time": rec.time, **rec.channels})
    table = table.replace_schema_metadata({HEADER_KEY: header.encode("utf-8")})
    pq.write_table(table, path)


def read_parquet(path: str | os.PathLike) -> RawTable:
    """Read a Parquet file into a :class:`RawTable`.

    Parameters
    ----------
    path : str or path-like
        The file.

    Returns
    -------
    RawTable
        Numeric columns as float64 (nulls become NaN), other columns as object arrays; the
        leakdiag header if present.

    Raises
    ------
    RecordingError
        If the file is not Parquet or has no rows.

    Notes
    -----
    A column name the file holds more than once is not read: the table lists it in
    ``duplicates``, and reading it is refused naming the file, the name and its positions, as
    for a CSV header (:meth:`leakdiag.io.table.RawTable.require_unique`).

    Examples
    --------
    >>> import tempfile, pathlib
    >>> p = pathlib.Path(tempfile.mkdtemp()) / "a.parquet"
    >>> write_parquet(Recording({"p1": np.array([1.0, 2.0])}, 2.0), p)
    >>> read_parquet(p).names
    ['time', 'p1']
    """
    import pyarrow as pa
    import pyarrow.parquet as pq

    source = str(path)
    try:
        repeated = repeated_names(pq.read_schema(Path(path)).names)
        # a name twice: arrow's dataset reader (read_table) refuses it with a multi-line dump
        # of the schema (streams audit 2026-11-27, finding 9); the file reader reads it, and
        # the repeated columns are left out as a CSV's are (RawTable.duplicates)
        table = (pq.ParquetFile(Path(path)).read() if repeated else pq.read_table(Path(path)))
    except (pa.ArrowException, OSError) as exc:
        raise RecordingError(f"{source}: unreadable as Parquet: {_first_line(exc)}") from None
    if table.num_rows == 0:
        raise RecordingError(f"{source}: has columns ({', '.join(table.column_names)}) "
                             f"but no rows")
    header = _header(table.schema, source)
    columns: dict[str, np.ndarray] = {}
    for j, name in enumerate(table.column_names):
        if name in repeated:
            continue
        col = table.column(j)
        t = col.type
        if pa.types.is_floating(t) or pa.types.is_integer(t) or pa.types.is_decimal(t):
            values = col.cast(pa.float64()).to_numpy(zero_copy_only=False)
            columns[name] = np.array(values, dtype=np.float64)
        else:
            columns[name] = np.array(col.to_pylist(), dtype=object)
    table = RawTable(columns, source, header, duplicates=repeated)
    if header is not None and repeated:  # a leakdiag header reads its channels and time
        for name in ("time", *header.get("channels", ())):
            table.require_unique(name, "time column" if name == "time" else f"channel {name!r}")
    return table


def _first_line(exc: Exception) -> str:
    """An arrow error in one line: its first (arrow appends the schema, line by line)."""
    text = str(exc).strip()
    return text.splitlines()[0] if text else type(exc).__name__


def _header(schema, source: str) -> dict | None:
    """The leakdiag header of a Parquet schema (None when another program wrote the file)."""
    meta = schema.metadata or {}
    return decode_header(meta[HEADER_KEY], source) if HEADER_KEY in meta else None


def read_parquet_header(path: str | os.PathLike) -> dict | None:
    """The leakdiag header of a Parquet file, read from its footer without its data.

    Parameters
    ----------
    path : str or path-like
        The file.

    Returns
    -------
    dict or None
        The header (:func:`leakdiag.io.header.decode_header`), or None for a file that another
        program wrote (no ``leakdiag`` key in its schema metadata).

    Raises
    ------
    RecordingError
        If the file is not Parquet, or its leakdiag header is malformed or of a newer version
        (as :func:`read_parquet` says).

    Examples
    --------
    >>> import tempfile, pathlib
    >>> p = pathlib.Path(tempfile.mkdtemp()) / "a.parquet"
    >>> write_parquet(Recording({"p1": np.array([1.0, 2.0])}, 2.0, units={"p1": "counts"}), p)
    >>> read_parquet_header(p)["units"]
    {'p1': 'counts'}
    """
    import pyarrow as pa
    import pyarrow.parquet as pq

    source = str(path)
    try:
        schema = pq.read_schema(Path(path))
    except (pa.ArrowException, OSError) as exc:
        raise RecordingError(f"{source}: unreadable as Parquet: {exc}") from None
    return _header(schema, source)
