"""Chunked sample sources: Parquet, HDF5 and CSV files read piece by piece, a growing CSV file
(tail), CSV lines on stdin, and an in-memory recording; plus real-time replay pacing.

Every source is a :class:`ChunkSource`: ``sample_rate``, ``start_time``, ``channels`` and an
iterator of ``{channel: float64 array}`` chunks. Files are never loaded whole, so a recording of
several GB streams through with memory bounded by the chunk size.
"""

from __future__ import annotations

import io
import itertools
import json
import os
import sys
import time
from dataclasses import dataclass, field
from typing import Callable, Iterable, Iterator, Sequence

import numpy as np

from leakdiag._validation import check_int, check_positive
from leakdiag.io.checks import infer_sample_rate
from leakdiag.io.recording import Recording, RecordingError

__all__ = ["ChunkSource", "open_chunks", "recording_chunks", "tail_csv", "csv_lines", "paced",
           "stdin_source",
           "DEFAULT_CHUNK_SAMPLES", "TIME_COLUMN"]

#: Samples per chunk when reading files (8 MB per float64 channel).
DEFAULT_CHUNK_SAMPLES = 1 << 20
#: Name of the time column (s) in tabular recordings.
TIME_COLUMN = "time"


@dataclass
class ChunkSource:
    """A stream of chunks with the sample rate and start time needed to stamp windows.

    Parameters
    ----------
    chunks : iterable of dict
        ``{channel: 1-D float64 array}`` per chunk, all channels the same length.
    sample_rate : float
        Sample rate in Hz.
    start_time : float
        Time of the first sample in seconds.
    channels : list of str
        Channel names present in every chunk.
    n_samples : int or None
        Total samples if known (for progress bars).
    source : str
        File name or description for messages.
    meta : dict
        Recording metadata found in the file (``onset``, ``leak_lpm``, ...), possibly empty.
    """

    chunks: Iterable[dict]
    sample_rate: float
    start_time: float
    channels: list[str]
    n_samples: int | None = None
    source: str = "<stream>"
    meta: dict = field(default_factory=dict)

    def __iter__(self) -> Iterator[dict]:
        return iter(self.chunks)


def _select(names: Sequence[str], channels: Sequence[str] | None, source: str) -> list[str]:
    avail = [n for n in names if n != TIME_COLUMN]
    if channels is None:
        return avail
    missing = [c for c in channels if c not in avail]
    if missing:
        raise RecordingError(f"{source}: missing channel(s) {missing}; available: {sorted(avail)}")
    return list(channels)


#: Key of the leakdiag JSON header in Parquet schema metadata (layout of :mod:`leakdiag.io`).
PARQUET_HEADER_KEY = b"leakdiag"
#: HDF5 group with one dataset per channel (layout of :mod:`leakdiag.io`).
HDF5_CHANNEL_GROUP = "channels"


def _json_dict(blob) -> dict:
    if isinstance(blob, bytes):
        blob = blob.decode("utf-8")
    try:
        d = json.loads(blob)
    except (TypeError, ValueError):
        return {}
    return d if isinstance(d, dict) else {}


def _rate_start(t_head: np.ndarray | None, sample_rate: float | None, start_time: float | None,
                header: dict, source: str) -> tuple[float, float]:
    """Sample rate and start time: explicit argument, else the file header, else the time column."""
    if sample_rate is None:
        sample_rate = header.get("sample_rate")
    if sample_rate is None and t_head is not None and len(t_head) >= 2:
        sample_rate = infer_sample_rate(t_head, source=source)
    if sample_rate is None:
        raise RecordingError(f"{source}: no 'time' column and no sample rate; pass sample_rate")
    if start_time is None:
        start_time = header.get("start_time")
    if start_time is None:
        start_time = float(t_head[0]) if t_head is not None and len(t_head) else 0.0
    return check_positive(sample_rate, "sample_rate"), float(start_time)


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

    def gen():
        for batch in pf.iter_batches(batch_size=chunk_samples, columns=chans):
            yield {c: np.ascontiguousarray(batch.column(i).to_numpy(zero_copy_only=False),
                                           dtype=np.float64) for i, c in enumerate(chans)}

    meta = dict(header.get("meta") or {})
    return ChunkSource(gen(), fs, t0, chans, pf.metadata.num_rows, path, meta)


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
    fs, t0 = _rate_start(t_head, sample_rate, start_time, header, path)

    def gen():
        with h5py.File(path, "r") as h:
            g = h[gname]
            for i0 in range(0, n, chunk_samples):
                yield {c: np.ascontiguousarray(g[c][i0:i0 + chunk_samples], dtype=np.float64)
                       for c in chans}

    return ChunkSource(gen(), fs, t0, chans, n, path, meta)


def _csv_frames(frames, chans: list[str]):
    for df in frames:
        yield {c: np.ascontiguousarray(df[c].to_numpy(), dtype=np.float64) for c in chans}


def _csv(path: str, channels, chunk_samples: int, sample_rate, start_time) -> ChunkSource:
    import pandas as pd

    head = pd.read_csv(path, nrows=4096, comment="#")
    chans = _select(list(head.columns), channels, path)
    t_head = head[TIME_COLUMN].to_numpy(np.float64) if TIME_COLUMN in head else None
    fs, t0 = _rate_start(t_head, sample_rate, start_time, {}, path)
    frames = pd.read_csv(path, chunksize=chunk_samples, usecols=chans, comment="#",
                         dtype=np.float64)
    return ChunkSource(_csv_frames(frames, chans), fs, t0, chans, None, path, {})


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


def recording_chunks(rec: Recording, chunk_samples: int = DEFAULT_CHUNK_SAMPLES,
                     channels: Sequence[str] | None = None) -> ChunkSource:
    """Replay an in-memory :class:`Recording` as chunks (views, no copy).

    Parameters
    ----------
    rec : Recording
        The recording.
    chunk_samples : int, default 2**20
        Samples per chunk.
    channels : sequence of str, optional
        Channels to include (default: all).

    Returns
    -------
    ChunkSource

    Examples
    --------
    >>> rec = Recording({"p1": np.arange(5.0)}, sample_rate=10.0)
    >>> [c["p1"].tolist() for c in recording_chunks(rec, 3)]
    [[0.0, 1.0, 2.0], [3.0, 4.0]]
    """
    chunk_samples = check_int(chunk_samples, "chunk_samples", 1)
    source = rec.meta.get("source", "<recording>")
    chans = _select(rec.channel_names, channels, source)
    n = rec.n_samples

    def gen():
        for i0 in range(0, n, chunk_samples):
            yield {c: rec.channels[c][i0:i0 + chunk_samples] for c in chans}

    return ChunkSource(gen(), rec.sample_rate, rec.start_time, chans, n, source, dict(rec.meta))


def _parse_lines(lines: list[str], header: list[str], cols: list[int], chans: list[str]) -> dict:
    rows = []
    for line in lines:
        fields = line.split(",")
        if len(fields) != len(header):
            raise RecordingError(f"CSV line has {len(fields)} fields, header has {len(header)}: "
                                 f"{line.strip()[:80]!r}")
        try:
            rows.append([float(fields[i]) for i in cols])
        except ValueError as exc:
            raise RecordingError(f"CSV line {line.strip()[:80]!r}: {exc}") from None
    arr = np.array(rows, dtype=np.float64).reshape(len(rows), len(cols))
    return {c: np.ascontiguousarray(arr[:, i]) for i, c in enumerate(chans)}


def csv_lines(stream, channels: Sequence[str] | None = None, sample_rate: float | None = None,
              batch_lines: int = 1) -> ChunkSource:
    """CSV lines from a text stream (e.g. stdin): a header line, then one sample per line.

    Blank lines and lines starting with ``#`` are skipped.

    Parameters
    ----------
    stream : file-like
        Text stream; read line by line as it arrives.
    channels : sequence of str, optional
        Channels to use (default: all columns but ``time``).
    sample_rate : float, optional
        Sample rate in Hz; default: from the first two ``time`` values.
    batch_lines : int, default 1
        Lines grouped per chunk (1 gives the lowest latency).

    Returns
    -------
    ChunkSource

    Raises
    ------
    RecordingError
        If the stream is empty or the rate cannot be known.

    Examples
    --------
    >>> s = io.StringIO("time,p1\\n0.0,1\\n0.5,2\\n1.0,4\\n")
    >>> src = csv_lines(s)
    >>> src.sample_rate, [c["p1"].tolist() for c in src]
    (2.0, [[1.0], [2.0], [4.0]])
    """
    batch_lines = check_int(batch_lines, "batch_lines", 1)
    header_line = stream.readline()
    if not header_line.strip():
        raise RecordingError("<stdin>: empty input; expected a CSV header line")
    header = [h.strip() for h in header_line.split(",")]
    chans = _select(header, channels, "<stdin>")
    cols = [header.index(c) for c in chans]
    pending: list[str] = []
    if sample_rate is None or TIME_COLUMN in header:
        while len(pending) < 2:
            line = stream.readline()
            if not line:
                break
            if line.strip() and not line.startswith("#"):
                pending.append(line)
    t_head = None
    if TIME_COLUMN in header and len(pending) >= 1:
        t_head = np.array([float(p.split(",")[header.index(TIME_COLUMN)]) for p in pending])
    fs, t0 = _rate_start(t_head, sample_rate, None, {}, "<stdin>")

    def gen():
        buf: list[str] = []
        for line in itertools.chain(pending, iter(stream.readline, "")):
            if line.strip() and not line.startswith("#"):
                buf.append(line)
            if len(buf) >= batch_lines:
                yield _parse_lines(buf, header, cols, chans)
                buf = []
        if buf:
            yield _parse_lines(buf, header, cols, chans)

    return ChunkSource(gen(), fs, t0, chans, None, "<stdin>", {})


def tail_csv(path: str | os.PathLike, channels: Sequence[str] | None = None,
             sample_rate: float | None = None, poll_s: float = 0.05,
             idle_timeout_s: float | None = None) -> ChunkSource:
    """Follow a CSV file that grows (like ``tail -f``): yield complete new lines as they appear.

    Parameters
    ----------
    path : str or path-like
        CSV file with a header line.
    channels : sequence of str, optional
        Channels to use.
    sample_rate : float, optional
        Sample rate in Hz; default: from the ``time`` column.
    poll_s : float, default 0.05
        Seconds between checks for new data.
    idle_timeout_s : float, optional
        Stop after this many seconds without new data (default: follow forever).

    Returns
    -------
    ChunkSource
        One chunk per batch of complete lines read; a partial last line waits for its newline.
    """
    path = os.fspath(path)
    poll_s = check_positive(poll_s, "poll_s")
    f = open(path, encoding="utf-8")

    def wait_line() -> str:
        idle = 0.0
        partial = ""
        while True:
            line = f.readline()
            if line:
                partial += line
                if partial.endswith("\n"):
                    return partial
                continue
            if idle_timeout_s is not None and idle >= idle_timeout_s:
                return partial
            time.sleep(poll_s)
            idle += poll_s

    class _Lines:
        def readline(self) -> str:
            return wait_line()

    src = csv_lines(_Lines(), channels, sample_rate)
    src.source = path

    inner = src.chunks

    def gen():
        try:
            yield from inner
        finally:
            f.close()

    src.chunks = gen()
    return src


def paced(source: ChunkSource, speed: float | None, clock: Callable[[], float] = time.monotonic,
          sleep: Callable[[float], None] = time.sleep) -> Iterator[dict]:
    """Deliver chunks no faster than real time multiplied by ``speed``.

    Parameters
    ----------
    source : ChunkSource
        Chunks to replay.
    speed : float or None
        1.0 is real time, 10.0 ten times faster; None delivers as fast as possible.
    clock, sleep : callable
        Time functions (injectable for tests).

    Yields
    ------
    dict
        The chunks; chunk ``i`` is released when the wall clock reaches the stream time of its
        last sample divided by ``speed``.
    """
    if speed is None:
        yield from source
        return
    speed = check_positive(speed, "speed")
    t0 = clock()
    done = 0
    for chunk in source:
        n = len(next(iter(chunk.values()))) if chunk else 0
        done += n
        due = t0 + done / source.sample_rate / speed
        delay = due - clock()
        if delay > 0:
            sleep(delay)
        yield chunk


def stdin_source(channels: Sequence[str] | None = None,
                 sample_rate: float | None = None) -> ChunkSource:  # pragma: no cover - thin
    """CSV lines from ``sys.stdin``, one chunk per line (see :func:`csv_lines`).

    Parameters
    ----------
    channels : sequence of str, optional
        Channels to use.
    sample_rate : float, optional
        Sample rate in Hz; default: from the ``time`` column.

    Returns
    -------
    ChunkSource
    """
    return csv_lines(sys.stdin, channels, sample_rate)
