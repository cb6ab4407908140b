"""Chunked reading of recording files: Parquet, HDF5 and CSV, never loaded whole.

Memory stays proportional to the chunk size, so a recording of several GB streams through
(see ``docs/operations.md``, "Larger-than-memory recordings").
"""

from __future__ import annotations

import os
from typing import Callable, Sequence

import numpy as np

from leakdiag._validation import check_int
from leakdiag.io.recording import RecordingError
from leakdiag.stream.chunks import (DEFAULT_CHUNK_SAMPLES, TIME_COLUMN, ChunkSource, TimeAxis,
                                    _json_dict, _rate_start, _select)

__all__ = ["open_chunks", "PARQUET_HEADER_KEY", "HDF5_CHANNEL_GROUP"]

#: Key of the leakdiag JSON header in Parquet schema metadata (layout of :mod:`leakdiag.io`).
PARQUET_HEADER_KEY = b"leakdiag"
#: HDF5 group with one dataset per channel (layout of :mod:`leakdiag.io`).
HDF5_CHANNEL_GROUP = "channels"


def _checked(chunks, axis: TimeAxis | None):
    """Yield the channel chunks; each chunk's ``time`` (when the file has one) is checked against
    the sample rate over the whole file, not only the rows the rate was taken from."""
    row0 = 0
    try:
        for chunk in chunks:
            t = chunk.pop(TIME_COLUMN, None)
            if axis is not None and t is not None:
                axis.check_block(t, row0)
                row0 += len(t)
            yield chunk
    finally:
        chunks.close()  # the CSV reader and HDF5 file close also when the consumer stops early


def _axis(has_time: bool, fs: float, path: str, header: dict) -> TimeAxis | None:
    basis = "from the file's header" if "sample_rate" in header else "from the first rows"
    return TimeAxis(fs, path, basis=basis) if has_time else None


def _parquet(path: str, channels, chunk_samples: int, sample_rate, start_time) -> ChunkSource:
    import pyarrow as pa
    import pyarrow.parquet as pq

    try:
        pf = pq.ParquetFile(path, pre_buffer=False)  # pre-buffering reads whole row groups ahead
    except (pa.ArrowException, OSError) as exc:
        raise RecordingError(f"{path}: unreadable as Parquet: {exc}") from None
    names = pf.schema_arrow.names
    chans = _select(names, channels, path)
    header = _json_dict((pf.schema_arrow.metadata or {}).get(PARQUET_HEADER_KEY, b""))
    t_head = None
    if TIME_COLUMN in names and pf.metadata.num_rows >= 2 and "sample_rate" not in header:
        first = next(pf.iter_batches(batch_size=4096, columns=[TIME_COLUMN]))
        t_head = first.column(0).to_numpy(zero_copy_only=False).astype(np.float64)
    fs, t0 = _rate_start(t_head, sample_rate, start_time, header, path)

    cols = chans + ([TIME_COLUMN] if TIME_COLUMN in names else [])

    def gen():
        for batch in pf.iter_batches(batch_size=chunk_samples, columns=cols):
            yield {c: np.ascontiguousarray(batch.column(i).to_numpy(zero_copy_only=False),
                                           dtype=np.float64) for i, c in enumerate(cols)}

    meta = dict(header.get("meta") or {})
    axis = _axis(TIME_COLUMN in names, fs, path, header)
    return ChunkSource(_checked(gen(), axis), fs, t0, chans, pf.metadata.num_rows, path, meta)


def _hdf5(path: str, channels, chunk_samples: int, sample_rate, start_time) -> ChunkSource:
    import h5py

    try:
        f = h5py.File(path, "r")
    except OSError as exc:
        raise RecordingError(f"{path}: unreadable as HDF5: {exc}") from None
    with f:
        group = f[HDF5_CHANNEL_GROUP] if isinstance(f.get(HDF5_CHANNEL_GROUP), h5py.Group) else f
        names = [k for k, v in group.items() if isinstance(v, h5py.Dataset) and v.ndim == 1]
        chans = _select(names, channels, path)
        if not chans:
            raise RecordingError(f"{path}: no 1-D channel datasets found")
        header = {k: float(f.attrs[k]) for k in ("sample_rate", "start_time") if k in f.attrs}
        meta = _json_dict(f.attrs["meta"]) if "meta" in f.attrs else {}
        t_head = None
        if "sample_rate" not in header and TIME_COLUMN in f:
            t_head = np.asarray(f[TIME_COLUMN][:4096], dtype=np.float64)
        n = len(group[chans[0]])
        gname = group.name
        has_time = isinstance(f.get(TIME_COLUMN), h5py.Dataset)
    fs, t0 = _rate_start(t_head, sample_rate, start_time, header, path)

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
    return ChunkSource(_checked(gen(), axis), fs, t0, chans, n, path, meta)


def _numeric(df, chans: list[str], path: str, row0: int) -> dict:
    """Channels of a CSV chunk as float64; text names the file, channel and row."""
    import pandas as pd

    out = {}
    for c in chans:
        col = df[c]
        if not pd.api.types.is_numeric_dtype(col.dtype):
            num = pd.to_numeric(col, errors="coerce")
            bad = np.flatnonzero(num.isna().to_numpy() & col.notna().to_numpy())
            if len(bad):
                i = int(bad[0])
                raise RecordingError(f"{path}: channel {c!r} holds text, not numbers: row "
                                     f"{row0 + i} is {str(col.iloc[i])[:40]!r}")
            col = num
        out[c] = np.ascontiguousarray(col.to_numpy(dtype=np.float64), dtype=np.float64)
    return out


def _csv_frames(path: str, chunk_samples: int, chans: list[str]):
    """Chunks of a CSV; the reader is opened on first use and closed when the generator is closed
    (also when the consumer stops early on an error), so no file handle leaks."""
    import pandas as pd

    row0 = 0
    with pd.read_csv(path, chunksize=chunk_samples, usecols=chans, comment="#") as frames:
        for df in frames:
            yield _numeric(df, chans, path, row0)
            row0 += len(df)


def _csv(path: str, channels, chunk_samples: int, sample_rate, start_time) -> ChunkSource:
    import pandas as pd

    try:
        head = pd.read_csv(path, nrows=4096, comment="#")
    except pd.errors.EmptyDataError:
        raise RecordingError(f"{path}: empty file: no header line and no data") from None
    except (pd.errors.ParserError, UnicodeDecodeError) as exc:
        raise RecordingError(f"{path}: unreadable as CSV: {exc}") from None
    if head.empty:
        raise RecordingError(f"{path}: header only, no data rows")
    chans = _select(list(head.columns), channels, path)
    t_head = (_numeric(head, [TIME_COLUMN], path, 0)[TIME_COLUMN] if TIME_COLUMN in head
              else None)
    fs, t0 = _rate_start(t_head, sample_rate, start_time, {}, path)
    cols = chans + ([TIME_COLUMN] if TIME_COLUMN in head else [])
    return ChunkSource(_checked(_csv_frames(path, chunk_samples, cols), _axis(
        TIME_COLUMN in head, fs, path, {})), fs, t0, chans, None, path, {})


def open_chunks(path: str | os.PathLike, channels: Sequence[str] | None = None,
                chunk_samples: int = DEFAULT_CHUNK_SAMPLES, sample_rate: float | None = None,
                start_time: float | None = None) -> ChunkSource:
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

    Returns
    -------
    ChunkSource

    Raises
    ------
    FileNotFoundError
        If the file does not exist.
    RecordingError
        For an unknown suffix, a missing channel or no way to get the sample rate.

    Notes
    -----
    Parquet is read with ``pyarrow.parquet.ParquetFile.iter_batches``, HDF5 by slicing the
    channel datasets (at the root or in a ``channels`` group), CSV with ``pandas.read_csv``
    and ``chunksize``; memory stays proportional to ``chunk_samples``.

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
    return readers[suffix](path, channels, chunk_samples, sample_rate, start_time)
