"""The :class:`ChunkSource`: a stream of ``{channel: array}`` chunks with its sample rate and
start time, plus helpers shared by the file and live sources, and :func:`recording_chunks`."""

from __future__ import annotations

import json
from dataclasses import dataclass, field
from typing import Iterable, Iterator, Sequence

import numpy as np

from leakdiag._validation import check_int, check_positive
from leakdiag.io.checks import (MAX_PRINT_RESOLUTION, UNIFORM_TIME_RTOL, given_rate_check,
                                infer_sample_rate, print_resolution, refuse_time_like, rounds)
from leakdiag.io.recording import Recording, RecordingError
from leakdiag.io.table import RawTable, repeated_names
from leakdiag.io.text import extra_field_error, short_row_error

__all__ = ["ChunkSource", "TimeAxis", "recording_chunks", "DEFAULT_CHUNK_SAMPLES", "TIME_COLUMN"]

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


class _ForwardFault(RecordingError):
    """A time after the previous one by the wrong interval (a gap or jitter), at time ``t``.
    Before it is raised, the next time value is looked at (:meth:`TimeAxis.after_fault`): when
    that one is not after ``t``, the two rows are swapped and are named as
    :func:`leakdiag.io.read_recording` names them."""

    def __init__(self, message: str, t: float, row: int | None = None):
        super().__init__(message)
        self.t = t
        self.row = row  # data row of a file's fault (None: a line of a stream)


class TimeAxis:
    """Checks streamed time values against the uniform grid of the sample rate, as
    :func:`leakdiag.io.read_recording` checks a whole time column: time going backwards, repeated
    times, gaps and jitter are errors naming the line (live) or data row (file chunks).

    Parameters
    ----------
    fs : float
        Sample rate (Hz) the intervals must match.
    source : str
        File name for messages.
    rtol : float, default UNIFORM_TIME_RTOL
        Tolerated relative deviation of an interval from ``1 / fs``.
    basis : str, default "from the first lines"
        Where ``fs`` came from (for messages).
    resolution : float, optional
        Print resolution of the times (s, :func:`leakdiag.io.checks.print_resolution`), allowed
        for in each interval as :func:`leakdiag.io.checks.infer_sample_rate` allows it (at most
        ``MAX_PRINT_RESOLUTION`` of an interval); default: found in each block of
        :meth:`check_block`, none for :meth:`check`.
    """

    def __init__(self, fs: float, source: str, rtol: float = UNIFORM_TIME_RTOL,
                 basis: str = "from the first lines", resolution: float | None = None):
        self.dt = 1.0 / fs
        self.fs = fs
        self.source = source
        self.rtol = rtol
        self.basis = basis
        self.resolution = resolution
        self.prev: float | None = None

    def _allowance(self, q: float | None) -> float:
        """Tolerated deviation of an interval from ``dt`` (s): ``rtol`` of it plus the print
        resolution ``q`` when at most ``MAX_PRINT_RESOLUTION`` of an interval."""
        # (the rate comes from the first lines: its interval known to a few hundredths of q)
        q = 0.0 if not q or q > MAX_PRINT_RESOLUTION * self.dt or not rounds(
            self.dt, q, 0.02) else q
        return self.rtol * self.dt + q * (1.0 + 1e-6)

    def _error(self, t: float, prev: float, *, line: int | None = None,
               row: int | None = None) -> RecordingError:
        """The error for time ``t`` after ``prev`` at ``line`` (live) or data ``row`` (file):
        time not increasing in the words of :func:`leakdiag.io.checks.infer_sample_rate`
        (detect's), else a gap or jitter."""
        step = t - prev
        where = f"line {line}" if row is None else f"row {row}"
        if step <= 0:  # going backwards or repeated (audit 2026-11-27: "is time goes backwards")
            at = (f"{where} (time {t!r} s after {prev!r} s)" if row is None
                  else f"row {row} (t[{row - 1}]={prev!r}, t[{row}]={t!r})")
            return RecordingError(f"{self.source}: column {TIME_COLUMN!r} is not strictly "
                                  f"increasing at {at}")
        what = "a gap" if step > 1.5 * self.dt else "jitter"
        return _ForwardFault(
            f"{self.source}: {where}: time {t!r} s after {prev!r} s is {what}: interval "
            f"{step:.6g} s, expected {self.dt:.6g} s ({self.fs:g} Hz {self.basis}, tolerance "
            f"{self.rtol:g} relative); the stream must be uniformly sampled", t, row)

    def after_fault(self, fault: RecordingError, t_next: float | None, *,
                    line: int | None = None, row: int | None = None) -> RecordingError:
        """The error to raise for ``fault``, once the time after it, ``t_next`` (None: the
        input ended), is known: a gap or jitter followed by a time not after it is two swapped
        rows (lines), named at the second as :func:`leakdiag.io.read_recording` names them
        ("not strictly increasing at row 50001", not "a gap" at row 50000; streams audit
        2026-11-27, finding 9), also across a chunk boundary and on a stream read line by line.

        Parameters
        ----------
        fault : RecordingError
            The error :meth:`check` or :meth:`check_block` raised.
        t_next : float or None
            The next time value (s).
        line, row : int, optional
            Line (live) or data row (file) of ``t_next``.

        Returns
        -------
        RecordingError
            ``fault``, or the error naming ``t_next``'s row or line.
        """
        if (isinstance(fault, _ForwardFault) and t_next is not None and np.isfinite(t_next)
                and t_next <= fault.t):
            return self._error(float(t_next), fault.t, line=line, row=row)
        return fault

    def check(self, t: float, lineno: int) -> None:
        """Check one time value (line ``lineno`` of a live stream).

        Parameters
        ----------
        t : float
            Time (s).
        lineno : int
            Line number for messages.

        Raises
        ------
        RecordingError
            When ``t`` is not finite or not one sample interval after the previous value.
        """
        if not np.isfinite(t):
            raise RecordingError(f"{self.source}: line {lineno}: time {t!r} is not finite")
        if self.prev is not None and abs(t - self.prev - self.dt) > self._allowance(
                self.resolution):
            raise self._error(t, self.prev, line=lineno)
        self.prev = t

    def check_block(self, t: np.ndarray, row0: int) -> None:
        """Check a chunk of a file's time column, whose first value is data row ``row0``.

        Parameters
        ----------
        t : numpy.ndarray
            Time values (s) of the chunk.
        row0 : int
            Data row (0-based) of ``t[0]``.

        Raises
        ------
        RecordingError
            Naming the first data row whose time is not finite or not one sample interval after
            the previous row's; a time not after the previous one is looked for first and
            named as :func:`leakdiag.io.read_recording` names it (two swapped rows: "not
            strictly increasing at row 50001", not "a gap" at row 50000), within the chunk. A
            gap or jitter at the chunk's last row is raised as :class:`_ForwardFault`, whose
            ``row`` lets the reader look at the next chunk's first time
            (:meth:`after_fault`) for a swap across the boundary.
        """
        t = np.asarray(t, dtype=np.float64)
        if not len(t):
            return
        bad = np.flatnonzero(~np.isfinite(t))
        if len(bad):
            raise RecordingError(f"{self.source}: row {row0 + int(bad[0])}: time "
                                 f"{float(t[bad[0]])!r} is not finite")
        full = t if self.prev is None else np.concatenate(([self.prev], t))
        off = 0 if self.prev is None else 1  # full[i] is data row row0 + i - off
        step = np.diff(full)
        err = np.abs(step - self.dt)
        # the allowance with the print resolution is never below the one without: the times'
        # resolution is looked for only when an interval exceeds that (the usual block passes)
        dev = np.flatnonzero(err > self._allowance(None))
        if len(dev):
            # a time not after the previous one fails that allowance (rtol < 1), so it is looked
            # for here only, first, as io checks the whole column: two swapped rows are not a gap
            back = np.flatnonzero(step <= 0)
            if len(back):
                i = int(back[0]) + 1
                raise self._error(float(full[i]), float(full[i - 1]), row=row0 + i - off)
            q = self.resolution if self.resolution is not None else print_resolution(full)
            dev = np.flatnonzero(err > self._allowance(q))
        if len(dev):
            i = int(dev[0]) + 1
            raise self._error(float(full[i]), float(full[i - 1]), row=row0 + i - off)
        self.prev = float(t[-1])


def _select(names: Sequence[str], channels: Sequence[str] | None, source: str,
            repeated: Sequence[str] = ()) -> list[str]:
    """The channels to read: ``channels``, or every name but ``time``; ``repeated`` names (more
    than once in a header, see :func:`_check_unique`) are not readable and are only listed."""
    if TIME_COLUMN not in names:  # a 'Time' column is not ignored for a sample rate (as io)
        refuse_time_like(names, source)
    avail = [n for n in names if n != TIME_COLUMN and n not in repeated]
    if channels is None:
        return avail
    missing = [c for c in channels if c not in avail]
    if missing:
        also = (f"; in the header more than once (not readable): {list(repeated)}" if repeated
                else "")
        raise RecordingError(f"{source}: missing channel(s) {missing}; available: "
                             f"{sorted(avail)}{also}")
    return list(channels)


_repeated = repeated_names  # the header's repeated names, as io reads them


def _check_unique(names: Sequence[str], channels: Sequence[str] | None, source: str) -> dict:
    """Refuse to read a column whose name a CSV header holds more than once.

    Which of the columns is meant cannot be told, so reading one is an error worded as in
    :meth:`leakdiag.io.table.RawTable.require_unique`; a repeated name that is not read is
    harmless. The ``time`` column is read whenever the header has one; without ``channels``
    every column is read.

    Parameters
    ----------
    names : sequence of str
        The header's names by position (stripped of blanks).
    channels : sequence of str or None
        The channels asked for (None: all).
    source : str
        File name for messages.

    Returns
    -------
    dict of str to list of int
        The repeated names and their 0-based positions.

    Raises
    ------
    RecordingError
        Naming the column, what it is read as and its positions (counting from 1).

    Examples
    --------
    >>> _check_unique(["time", "p1", "junk", "junk"], ["p1"], "a.csv")
    {'junk': [2, 3]}
    >>> _check_unique(["time", "p1", "p1"], ["p1"], "a.csv")
    Traceback (most recent call last):
    ...
    leakdiag.io.errors.RecordingError: a.csv: column 'p1' (channel 'p1') appears 2 times in the
    header, at fields 2 and 3 (counting from 1); which one is meant cannot be told: rename the
    others
    """
    repeated = _repeated(names)
    table = RawTable({}, source, duplicates=repeated)
    if channels is None:
        table.require_all_unique(TIME_COLUMN, "without a channel list every column is read - "
                                 "give the channels to read")
        return repeated
    for c in channels:
        table.require_unique(c, f"channel {c!r}")
    table.require_unique(TIME_COLUMN, "time column")
    return repeated


_short_row = short_row_error  # one wording with io


_extra_field = extra_field_error  # one wording with io


def _json_dict(blob) -> dict:
    if isinstance(blob, bytes):
        blob = blob.decode("utf-8")
    try:
        d = json.loads(blob)
    except (TypeError, ValueError):
        return {}
    return d if isinstance(d, dict) else {}


def _span_rate(head_rate: float, t_head: np.ndarray, span: tuple[int, float] | None) -> float:
    """The rate of a whole time column by :func:`leakdiag.io.checks.infer_sample_rate`'s rule,
    ``(n - 1) / (t[-1] - t[0])`` rounded to 9 decimals, from its first rows ``t_head`` (whose
    rate is ``head_rate``) and ``span = (n, t[-1])``: a file streamed in chunks gets the rate
    ``detect`` reads (until 2026-11-28 the first 4096 rows' own: 3000 Hz where detect read
    2999.999833 Hz from times printed to 5 decimals; streams audit 2026-11-27, finding 8).
    The span's rate is taken only when it lies within what the first rows can tell: their
    largest distance from the grid of their own rate (print rounding, clock jitter), twice,
    over their span. Otherwise the rest of the column is not on the first rows' grid (a row
    missing or added, a last time that is not a number): the first rows' rate is kept, and the
    chunk check names the row (a gap is then "expected 0.001 s (1000 Hz", not the 999.833 Hz
    of a 6-s file missing one row). A clock whose rate drifts within the tolerances keeps the
    first rows' rate as before (a difference from detect's in the 7th digit or beyond)."""
    if span is None:
        return head_rate
    n, t_last = span
    t0 = float(t_head[0])
    if n <= len(t_head) or not np.isfinite(t_last) or not t_last > t0:
        return head_rate
    whole = round(float((n - 1) / (float(t_last) - t0)), 9)
    head_span = float(t_head[-1]) - t0
    res = float(np.max(np.abs(t_head - t0 - np.arange(len(t_head)) / head_rate)))
    tol = 2.0 * res / head_span + 1e-9 / head_rate + 1e-12  # relative; 1e-9 Hz: the rounding
    return whole if abs(whole - head_rate) <= tol * head_rate else head_rate


def _rate_start(t_head: np.ndarray | None, sample_rate: float | None, start_time: float | None,
                header: dict, source: str,
                span: tuple[int, float] | None = None) -> tuple[float, float]:
    """Sample rate and start time: the file header's, else the time column's (its first rows,
    checked, and with ``span`` = (rows, last time) the whole column's: :func:`_span_rate`),
    else the explicit argument.

    The file's own rate is used; an explicit rate is a cross-check, accepted within 0.1 % of it
    and refused otherwise, in the words of :func:`leakdiag.io.read_recording`
    (:func:`leakdiag.io.checks.given_rate_check`), never silently preferred (until 2026-11-27
    a rate within 0.1 % stamped the windows, 3.2 s an hour off the file's times: streams audit,
    finding 3). A time column with fewer than 2 values and no rate from elsewhere is refused in
    io's words (``column 'time' has 1 sample(s); need at least 2``), not as a missing time
    column.
    """
    own = header.get("sample_rate")
    what = "header"
    if own is None and t_head is not None:
        if len(t_head) >= 2:
            own = _span_rate(infer_sample_rate(t_head, source=source), t_head, span)
            what = f"time column {TIME_COLUMN!r}"
        elif sample_rate is None:
            infer_sample_rate(t_head, source=source)  # raises: too few values for a rate
    if sample_rate is not None and own is not None:
        sample_rate = given_rate_check(sample_rate, own, source, what)
    if sample_rate is None:
        sample_rate = own
    if sample_rate is None:
        raise RecordingError(f"{source}: no 'time' column and no sample rate in the file: give "
                             "the sample rate (--sample-rate, or sample_rate_hz in a column map)")
    if start_time is None:
        start_time = header.get("start_time")
    if start_time is None:
        start_time = float(t_head[0]) if t_head is not None and len(t_head) else 0.0
    return check_positive(sample_rate, "sample_rate"), float(start_time)


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
