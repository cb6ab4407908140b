"""Checks of recording input: time axis, finiteness, length. Messages name file, channel and row."""

from __future__ import annotations

import re
from typing import Mapping, Sequence

import numpy as np

from leakdiag._validation import check_int
from leakdiag._validation import check_length as check_samples
from leakdiag.io.errors import RecordingError

__all__ = ["infer_sample_rate", "check_channel_finite", "check_length", "check_same_length",
           "UNIFORM_TIME_RTOL", "RESAMPLE_ADVICE", "MAX_GAP_INTERVALS", "GAP_ADVICE",
           "gap_words", "time_like_column", "refuse_time_like",
           "print_resolution", "SAME_RATE_RTOL", "same_rate", "given_rate_check", "timestamps_error", "rounds"]

#: Relative tolerance on sample intervals for a time axis to count as uniform.
UNIFORM_TIME_RTOL = 1e-3
#: Relative difference within which two sample rates are one rate: the tolerance at which a
#: time column and a given sample rate agree (docs/io.md). Rates estimated from time columns
#: carry their timestamps' jitter and print resolution: sub-microsecond jitter gave 1000.000067
#: Hz, which every rate check compared at 1e-9 refused as "1000 Hz differs from 1000 Hz"
#: (audit of users' recordings, 2026-11-27, finding 6). Windows and lags are counted in
#: samples, so a 0.1 % difference of rate does not change what a feature means.
SAME_RATE_RTOL = UNIFORM_TIME_RTOL


def same_rate(a: float, b: float) -> bool:
    """Whether two sample rates are one rate (within :data:`SAME_RATE_RTOL` of the larger).

    Parameters
    ----------
    a, b : float
        Sample rates, Hz.

    Returns
    -------
    bool

    Examples
    --------
    >>> same_rate(1000.0, 1000.000066689), same_rate(1000.0, 1002.0), same_rate(500.0, 1000.0)
    (True, False, False)
    """
    a, b = float(a), float(b)
    return abs(a - b) <= SAME_RATE_RTOL * max(abs(a), abs(b))


def given_rate_check(given: float, own: float, source: str, what: str) -> float:
    """The file's own sample rate, once a given one is checked against it.

    One rule for every reader, the whole-file one of ``detect`` and the chunked ones of
    ``monitor`` and ``batch`` (decision 2026-11-27, streams audit, finding 3; docs/io.md,
    "Time axis and sample rate"): a file's own rate (its header's, or its time column's) is
    what the samples are placed by; a given rate (``--sample-rate``, or ``sample_rate_hz`` in
    a column map) is a cross-check, accepted when it is :func:`same_rate` as the file's and
    refused otherwise, never preferred. Until then monitor stamped its windows at a given
    1000.9 Hz (0.09 % off: 3.2 s per hour), detect ignored it for a time column and refused it
    for a header by an exact comparison.

    Parameters
    ----------
    given : float
        The rate given, Hz.
    own : float
        The file's rate, Hz.
    source : str
        File name for messages.
    what : str
        Where ``own`` comes from (``"header"``, ``"time column 'time'"``).

    Returns
    -------
    float
        ``own``.

    Raises
    ------
    RecordingError
        When the two are not :func:`same_rate`, naming the file, both rates and ``what``.

    Examples
    --------
    >>> given_rate_check(1000.9, 1000.0, "a.csv", "time column 'time'")
    1000.0
    >>> given_rate_check(500.0, 1000.0, "a.csv", "header")
    Traceback (most recent call last):
    ...
    leakdiag.io.errors.RecordingError: a.csv: a sample rate of 500 Hz was given (--sample-rate,
    or sample_rate_hz in a column map), but the file's header says 1000 Hz (more than 0.1 %
    apart); leave the sample rate out (the file's own is used) or fix the file
    """
    if not same_rate(given, own):
        raise RecordingError(
            f"{source}: a sample rate of {float(given):g} Hz was given (--sample-rate, or "
            f"sample_rate_hz in a column map), but the file's {what} says {float(own):g} Hz "
            f"(more than {SAME_RATE_RTOL * 100:g} % apart); leave the sample rate out (the "
            "file's own is used) or fix the file")
    return float(own)
def timestamps_error(source: str, column: str) -> RecordingError:
    """The refusal of a column of dates, times or durations (a Parquet ``timestamp``,
    ``date``, ``time`` or ``duration`` column) where numbers are read, in one wording for every
    reader (decision 2026-11-27, streams audit, finding 6: ``monitor`` and ``batch`` read a
    ``timestamp[ns]`` time column as nanoseconds taken as seconds, 1e-06 Hz, and ``detect``
    said it "holds text"). It is not converted: which origin and time zone are meant cannot
    be told, and seconds since 1970 in float64 keep only about 0.2 us.

    Parameters
    ----------
    source : str
        File name.
    column : str
        The column.

    Returns
    -------
    RecordingError
        Naming the file and the column, saying how to convert the column to seconds.

    Examples
    --------
    >>> print(timestamps_error("a.parquet", "time"))  # doctest: +ELLIPSIS
    a.parquet: column 'time' holds timestamps (dates, times or durations), not numbers: ...
    """
    return RecordingError(
        f"{source}: column {column!r} holds timestamps (dates, times or durations), not "
        f"numbers: leakdiag reads time as seconds (float64); convert the column, e.g. with "
        f"pandas df[{column!r}] = (df[{column!r}] - df[{column!r}].iloc[0]).dt.total_seconds() "
        f"for seconds from the first row")


#: End of the non-uniform time message; commands without ``--resample`` (monitor, batch) replace
#: it with advice they can follow.
RESAMPLE_ADVICE = ("resample it explicitly (--resample RATE_HZ; in Python, "
                   "leakdiag.io.read_recording(path, resample=RATE_HZ)) rather than let "
                   "leakdiag guess")
#: Longest interval, in median intervals, that resampling fills (leakdiag choice, 2026-11-28):
#: up to two missing samples between two kept ones. A longer interval is a gap: interpolating
#: it invents data that a detector reads as measured (a flow-balance audit, 2026-11-28: healthy
#: runs with a 0.2-s gap, resampled, read LEAK in 5 of 6; a 10-s gap on the EHA LEAK 1.0
#: L/min), so resampling refuses it and the non-uniform message advises cutting there instead.
MAX_GAP_INTERVALS = 3.0


def gap_words(dt, med: float, first_row: int = 1) -> str | None:
    """The first gap of a time axis in words (None without one): an interval longer than
    :data:`MAX_GAP_INTERVALS` median intervals, which resampling would fill with invented data.

    Parameters
    ----------
    dt : numpy.ndarray
        Intervals ``t[i] - t[i - 1]`` (s).
    med : float
        Their median (s).
    first_row : int, default 1
        Row of ``dt[0]``'s later sample.

    Returns
    -------
    str or None

    Examples
    --------
    >>> gap_words(np.array([1e-3, 1e-3, 0.2, 1e-3]), 1e-3)
    'a gap of 0.2 s before row 3 (about 199 missing samples at the median interval 0.001 s)'
    """
    big = np.flatnonzero(np.asarray(dt) > MAX_GAP_INTERVALS * med)
    if not len(big):
        return None
    i = int(big[0])
    return (f"a gap of {float(dt[i]):.6g} s before row {i + first_row} (about "
            f"{int(round(float(dt[i]) / med)) - 1} missing samples at the median interval "
            f"{med:.6g} s)")


GAP_ADVICE = ("resampling would invent the missing samples, which a detector reads as "
              "measured: cut the recording at the gap and judge the parts")


def infer_sample_rate(t: np.ndarray, source: str = "<input>", rtol: float = UNIFORM_TIME_RTOL,
                      column: str = "time") -> float:
    """Sample rate (Hz) of a uniform time axis in seconds.

    Parameters
    ----------
    t : numpy.ndarray
        Sample times in seconds.
    source : str
        File name for messages.
    rtol : float
        Allowed relative deviation of each interval from the median interval.
    column : str, default "time"
        Name of the time column, for messages.

    Returns
    -------
    float
        ``(len(t) - 1) / (t[-1] - t[0])`` rounded to 9 decimals (the median interval is used
        only to check uniformity).

    Raises
    ------
    RecordingError
        If ``t`` has fewer than 2 samples, NaN, is not strictly increasing, or is not uniform
        (the message suggests ``--resample``).

    Notes
    -----
    Each interval may differ from the median (or, when the timestamps are printed more coarsely
    than ``rtol`` of an interval, from the mean of the intervals near it) by ``rtol`` of it
    plus the timestamps' print resolution (:func:`print_resolution`, when at most
    :data:`MAX_PRINT_RESOLUTION` of an interval): a uniform 3-kHz file
    with timestamps to the microsecond has intervals of 333 and 334 us, 0.3 % apart, and was
    refused as non-uniform before 2026-11-27 (audit of users' recordings, finding 7).

    Examples
    --------
    >>> infer_sample_rate(np.arange(5) / 1000.0)
    1000.0
    >>> infer_sample_rate(np.round(np.arange(3000) / 3000.0, 6))  # 333 or 334 us
    3000.0
    """
    t = np.asarray(t, dtype=np.float64)
    if len(t) < 2:
        raise RecordingError(f"{source}: column {column!r} has {len(t)} sample(s); need at least 2")
    bad = np.flatnonzero(~np.isfinite(t))
    if len(bad):
        raise RecordingError(f"{source}: column {column!r} is not finite at row {int(bad[0])}")
    dt = np.diff(t)
    nonmono = np.flatnonzero(dt <= 0)
    if len(nonmono):
        i = int(nonmono[0]) + 1
        raise RecordingError(
            f"{source}: column {column!r} is not strictly increasing at row {i} "
            f"(t[{i - 1}]={float(t[i - 1])!r}, t[{i}]={float(t[i])!r})"
        )
    med = float(np.median(dt))
    q = print_resolution(t)
    if q > MAX_PRINT_RESOLUTION * med:  # too coarse to tell a gap from rounding: no allowance
        q = 0.0
    if q and not rounds(float((t[-1] - t[0]) / (len(t) - 1)), q, 2.0 / (len(t) - 1)):
        q = 0.0  # the interval is a whole number of q: printing rounds nothing, allow nothing
    ref = med
    if q > rtol * med:  # intervals printed coarsely (333 or 334 us): their mean is the interval
        near = dt[np.abs(dt - med) <= 2.0 * q + rtol * med]
        ref = float(near.mean())
    dev = np.flatnonzero(np.abs(dt - ref) > rtol * ref + q * (1.0 + 1e-6))
    if len(dev):
        i = int(dev[0]) + 1
        gap = gap_words(dt, med)
        raise RecordingError(
            f"{source}: column {column!r} is not uniformly sampled: interval before row {i} is "
            f"{float(dt[i - 1]):.6g} s, median {med:.6g} s ({len(dev)} irregular interval(s)); "
            + (RESAMPLE_ADVICE if gap is None else f"it has {gap}: {GAP_ADVICE}")
        )
    # Over a uniform axis the mean interval (span / intervals) is the most accurate estimate:
    # the median of differences of large time values carries their rounding error.
    return round(float((len(t) - 1) / (t[-1] - t[0])), 9)


#: The print resolution allowed for in a time column is at most this fraction of an interval:
#: coarser (ms timestamps at 600 Hz) cannot tell a missing row from rounding, and is checked
#: without the allowance (leakdiag choice, 2026-11-27).
MAX_PRINT_RESOLUTION = 0.25


def rounds(interval: float, q: float, tol: float = 1e-3) -> bool:
    """Whether times ``interval`` apart, printed at resolution ``q``, are rounded: the interval
    is not a whole number of ``q`` (a review, 2026-11-27: at 200 Hz with ms timestamps nothing
    is rounded, and allowing ``q`` there passed 4/6-ms jitter, 20 % of an interval).

    Parameters
    ----------
    interval, q : float
        The estimated sample interval and the print resolution (s).
    tol : float, default 1e-3
        How far from a whole number ``interval / q`` may be and still count as one: the
        interval's own error in units of ``q`` (``2 / (n - 1)`` for the span of ``n`` times
        printed at ``q``).

    Returns
    -------
    bool

    Examples
    --------
    >>> rounds(1 / 3000, 1e-6), rounds(0.005, 1e-3), rounds(0.005001, 1e-3, 0.002)
    (True, False, False)
    """
    k = interval / q
    return abs(k - round(k)) > max(tol, 1e-9)


def print_resolution(t) -> float:
    """The decimal resolution the times were printed at: the largest ``10**-k`` (k = 0..9) of
    which every time is a whole multiple, or 0.0 when none is (binary or finer times).

    Parameters
    ----------
    t : array_like
        Times (s).

    Returns
    -------
    float

    Examples
    --------
    >>> print_resolution([0.0, 0.000333, 0.000667]), print_resolution([0.0, 0.5, 1.0])
    (1e-06, 0.1)
    >>> print_resolution(np.arange(4) / 3.0)
    0.0
    """
    t = np.asarray(t, dtype=np.float64)
    if not len(t) or not np.isfinite(t).all():
        return 0.0
    slack = 1e-13 * float(np.abs(t).max())  # the float error of a printed decimal, s
    for k in range(10):
        q = 10.0 ** -k
        if np.all(np.abs(t / q - np.round(t / q)) <= 1e-6 + slack / q):
            return q
    return 0.0


def check_channel_finite(x: np.ndarray, channel: str, source: str = "<input>") -> None:
    """Raise if a channel holds NaN or inf, naming file, channel and first row.

    Parameters
    ----------
    x : numpy.ndarray
        Channel samples.
    channel : str
        Channel name.
    source : str
        File name.

    Raises
    ------
    RecordingError
        With the count and the first bad row.

    Examples
    --------
    >>> check_channel_finite(np.array([1.0, 2.0]), "p1")
    """
    bad = np.flatnonzero(~np.isfinite(x))
    if len(bad):
        kind = "NaN" if np.isnan(x[bad[0]]) else "inf"
        raise RecordingError(
            f"{source}: channel {channel!r} has {len(bad)} non-finite value(s); "
            f"first {kind} at row {int(bad[0])}"
        )


def check_same_length(lengths: Mapping[str, int], source: str = "<input>") -> None:
    """Raise if the columns read from a file differ in length, naming each with its length.

    One wording for every reader: :func:`leakdiag.io.read_recording` (time column and the
    channels read), :class:`~leakdiag.io.recording.Recording` and the chunked HDF5 reader of
    :func:`leakdiag.stream.open_chunks`, which checks before the first chunk.

    Parameters
    ----------
    lengths : mapping of str to int
        What each column is, as the message names it (``"time column 'time'"``, ``"p1"``) ->
        its number of samples, in the order to list them.
    source : str
        File name.

    Raises
    ------
    RecordingError
        If the lengths are not all equal.

    Examples
    --------
    >>> check_same_length({"p1": 3, "p2": 3}, "run.h5")
    >>> check_same_length({"time column 'time'": 2, "p1": 3}, "run.h5")
    Traceback (most recent call last):
    ...
    leakdiag.io.errors.RecordingError: run.h5: channels have different lengths (time column 'time'=2, p1=3)
    """
    if len(set(lengths.values())) > 1:
        desc = ", ".join(f"{label}={n}" for label, n in lengths.items())
        raise RecordingError(f"{source}: channels have different lengths ({desc})")


def check_length(rec, window: int, channel: str | None = None) -> None:
    """Raise if a recording is shorter than one analysis window.

    For feature callers: call it before windowing so the user sees the file and the window,
    not an empty feature series.

    Parameters
    ----------
    rec : Recording
        The recording.
    window : int
        Window length in samples (>= 1).
    channel : str, optional
        Channel the window runs over; it must exist and is named in the message.

    Raises
    ------
    RecordingError
        If ``rec`` has fewer than ``window`` samples, or lacks ``channel``.
    TypeError, ValueError
        If ``window`` is not an integer >= 1.

    Examples
    --------
    >>> from leakdiag.io.recording import Recording
    >>> rec = Recording({"p1": np.zeros(150)}, 1000.0, meta={"source": "run.csv"})
    >>> check_length(rec, 100, "p1")
    >>> check_length(rec, 200, "p1")
    Traceback (most recent call last):
    ...
    leakdiag.io.errors.RecordingError: run.csv: channel 'p1' has 150 samples (0.15 s), shorter than one window (window=200); use a smaller window or a longer recording
    """
    window = check_int(window, "window", 1)
    source = rec.meta.get("source", "<recording>")
    if channel is not None:
        rec.require(channel)
    what = f"channel {channel!r}" if channel is not None else "recording"
    try:
        check_samples(rec.n_samples, window, f"{source}: {what}", rec.sample_rate)
    except ValueError as exc:
        raise RecordingError(f"{exc}; use a smaller window or a longer recording") from None


#: A column name that reads as a time column although it is not exactly ``time``: ``Time``,
#: ``TIME``, ``time_s``, ``Time [s]``, ``time (ms)``, and ``t`` alone or with a time unit
#: (``t_s``, ``t [s]``, ``t (ms)``) (audit of users' recordings, 2026-11-27, finding 3). A lone
#: upper-case ``T`` is left out (a temperature), and so is ``t``/``T`` with anything else
#: (``T_oil``, ``t_amb``, ``T [degC]``: a review found them refused as time columns).
_TIME_LIKE = re.compile(
    r"^(?:time(?:[\s_\[(].*)?|t|t[\s_]*[\[(]?\s*(?:s|sec|secs|seconds?|ms|us|µs|ns)\s*[\])]?)$",
    re.IGNORECASE)


def time_like_column(names: Sequence[str]) -> str | None:
    """The first column name that reads as a time column but is not exactly ``time``.

    Parameters
    ----------
    names : sequence of str
        Column names of a file.

    Returns
    -------
    str or None
        None when a column is named exactly ``time`` (it is the time axis) or none reads as one.

    Examples
    --------
    >>> time_like_column(["Time", "p1"]), time_like_column(["p1", "Time [s]"])
    ('Time', 'Time [s]')
    >>> time_like_column(["time", "Time"]), time_like_column(["T", "p1", "timer"])
    (None, None)
    >>> time_like_column(["t_s", "p1"]), time_like_column(["T_oil", "t_amb", "T [degC]"])
    ('t_s', None)
    """
    names = [str(n).strip() for n in names]
    if "time" in names:
        return None
    for n in names:
        if n != "T" and _TIME_LIKE.match(n):
            return n
    return None


def time_advice(column: str) -> str:
    """How to make ``column`` the time axis, in CLI words and in a map's."""
    return (f"--col time={column} (--col time={column}:ms in milliseconds, "
            f"--col time={column}:samples for a sample counter with --sample-rate), or "
            f"time_column = {column!r} in a --map")


def refuse_time_like(names: Sequence[str], source: str) -> None:
    """Refuse a file read without a column map whose time column is not named exactly ``time``.

    Such a column is not the time axis: it would be read as a channel, and a ``--sample-rate``
    would place the samples instead of it, its own rate, gaps and jitter unchecked (a 500-Hz
    file was read at 1000 Hz without a word). Nothing is guessed: the message says how to name
    it the time column.

    Parameters
    ----------
    names : sequence of str
        Column names.
    source : str
        File name for the message.

    Raises
    ------
    RecordingError
        When :func:`time_like_column` finds one.

    Examples
    --------
    >>> refuse_time_like(["time", "p1"], "a.csv")
    >>> refuse_time_like(["Time", "p1"], "a.csv")
    Traceback (most recent call last):
    ...
    leakdiag.io.errors.RecordingError: a.csv: column 'Time' looks like a time column, but only a
    column named exactly 'time' is the time axis of a file read without a map (it would be read
    as a channel, and a sample rate would place the samples instead of it): say it is the time
    column with --col time=Time (--col time=Time:ms in milliseconds, --col time=Time:samples for
    a sample counter with --sample-rate), or time_column = 'Time' in a --map
    """
    col = time_like_column(names)
    if col is not None:
        raise RecordingError(
            f"{source}: column {col!r} looks like a time column, but only a column named exactly "
            "'time' is the time axis of a file read without a map (it would be read as a "
            "channel, and a sample rate would place the samples instead of it): say it is the "
            f"time column with {time_advice(col)}")
