"""Live sources: CSV lines on a text stream (stdin), a growing CSV file (tail), and real-time
pacing of a replay."""

from __future__ import annotations

import io
import itertools
import os
import sys
import time
from typing import Callable, Iterator, Sequence

import numpy as np

from leakdiag._validation import check_int, check_positive
from leakdiag.io.recording import RecordingError
from leakdiag.stream.chunks import TIME_COLUMN, ChunkSource, _rate_start, _select

__all__ = ["csv_lines", "tail_csv", "paced", "stdin_source"]

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
             idle_timeout_s: float | None = None, batch_lines: int = 1) -> ChunkSource:
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
    batch_lines : int, default 1
        Lines grouped per chunk (1 gives the lowest latency).

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

    src = csv_lines(_Lines(), channels, sample_rate, batch_lines)
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
