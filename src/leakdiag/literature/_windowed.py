"""Windowed RMS and mean by prefix sums, on the Sec. 4.4 window grid.

Window ``m`` covers samples ``[m * step, m * step + N)`` with ``step = window_step(N, overlap)``;
see :mod:`leakdiag.features.windowing`. Private helpers shared by the literature methods.
"""

from __future__ import annotations

import numpy as np

from leakdiag._holds import holds
from leakdiag._validation import as_1d_float, check_int
from leakdiag.features._degenerate import warn_degenerate
from leakdiag.features.series import FeatureSeries
from leakdiag.features.windowing import window_starts, window_step, window_times

__all__ = ["windowed_rms", "windowed_mean", "check_channels", "channel_rms_feature",
           "check_finite_channels", "frozen_windows"]


def _window_sums(x: np.ndarray, window: int, overlap: float) -> tuple[np.ndarray, np.ndarray]:
    """Return (starts, sum of ``x`` over each window) using one prefix sum."""
    starts = window_starts(len(x), window, overlap)
    csum = np.zeros(len(x) + 1)
    np.cumsum(x, out=csum[1:])
    return starts, csum[starts + window] - csum[starts]


def windowed_rms(x, window: int, overlap: float) -> np.ndarray:
    """Root mean square of ``x`` over every complete window, via a prefix sum of squares.

    Parameters
    ----------
    x : array_like
        Signal, shape ``(n,)``.
    window : int
        Window size N in samples (>= 2).
    overlap : float
        Overlap in percent, ``[0, 100)``.

    Returns
    -------
    numpy.ndarray
        RMS per window, shape ``(n_windows,)``, same unit as ``x``.

    Raises
    ------
    ValueError
        If ``window < 2`` or the overlap is outside ``[0, 100)``.

    Notes
    -----
    The signal is first divided by its largest magnitude so that the prefix sum of squares stays
    of order ``n``; the rounding error of a window sum is then about ``n * eps`` relative to the
    whole signal's energy (about 1e-10 for an hour at 1 kHz), far below any feature change.
    Round-off cannot make a window sum negative: it is clipped at 0.

    Examples
    --------
    >>> windowed_rms([3.0, -3.0, 4.0, -4.0], window=2, overlap=50).tolist()
    [3.0, 3.5355339059327378, 4.0]
    """
    x = as_1d_float(x)
    window = check_int(window, "window", 2)
    scale = float(np.max(np.abs(x))) if len(x) else 0.0
    if scale == 0.0 or not np.isfinite(scale):
        scale = 1.0
    _, sums = _window_sums((x / scale) ** 2, window, overlap)
    return np.sqrt(np.clip(sums, 0.0, None) / window) * scale


def windowed_mean(x, window: int, overlap: float) -> np.ndarray:
    """Mean of ``x`` over every complete window, via a prefix sum.

    Parameters
    ----------
    x : array_like
        Signal, shape ``(n,)``.
    window : int
        Window size N in samples (>= 2).
    overlap : float
        Overlap in percent, ``[0, 100)``.

    Returns
    -------
    numpy.ndarray
        Mean per window, shape ``(n_windows,)``.

    Examples
    --------
    >>> windowed_mean([1.0, 2.0, 3.0, 4.0], window=2, overlap=50).tolist()
    [1.5, 2.5, 3.5]
    """
    x = as_1d_float(x)
    window = check_int(window, "window", 2)
    offset = float(np.mean(x)) if len(x) else 0.0
    _, sums = _window_sums(x - offset, window, overlap)
    return sums / window + offset


def frozen_windows(x, window: int, overlap: float, reach: int = 0) -> np.ndarray:
    """Windows overlapping a hold of one exact value at least a window long (a frozen channel).

    Parameters
    ----------
    x : array_like
        One channel, shape ``(n,)``.
    window : int
        Window size N in samples (>= 2); also the shortest hold that counts.
    overlap : float
        Overlap in percent, ``[0, 100)``.
    reach : int, default 0
        Samples by which a method's value at one sample depends on its neighbours (a filter's
        support): the hold counts as that much longer on each side.

    Returns
    -------
    numpy.ndarray of bool
        Per window of the Sec. 4.4 grid, shape ``(n_windows,)``.

    Notes
    -----
    A window whose samples are all equal (zero variance) lies in such a hold; so do the
    windows on either side that reach into it. Those are undefined too: part of their samples
    is a frozen value, not a measurement (a window half frozen has about 0.7 times the band
    RMS, dozens of healthy standard deviations under a structured excitation). A channel
    with noise never holds one value for a whole window (the simulator's 12-bit pressure
    channels hold at most 15 samples at 1 kHz), so no healthy window is lost.

    Examples
    --------
    >>> frozen_windows([1.0, 2.0, 3.0, 3.0, 3.0, 3.0, 4.0, 5.0], window=4, overlap=50).tolist()
    [True, True, True]
    >>> frozen_windows([1.0, 2.0, 3.0, 3.0, 3.0, 4.0, 5.0, 6.0], window=4, overlap=50).tolist()
    [False, False, False]
    >>> frozen_windows([3.0, 3.0, 3.0, 3.0, 4.0, 5.0, 6.0, 7.0, 8.0, 9.0], 4, 50).tolist()
    [True, True, False, False]
    >>> frozen_windows([3.0, 3.0, 3.0, 3.0, 4.0, 5.0, 6.0, 7.0, 8.0, 9.0], 4, 50, reach=2).tolist()
    [True, True, True, False]
    """
    x = as_1d_float(x)
    window = check_int(window, "window", 2)
    starts = window_starts(len(x), window, overlap)
    if len(x) == 0:
        return np.zeros(len(starts), dtype=bool)
    run0, lengths = holds(x)
    mark = np.zeros(len(x) + 1)
    for i0, m in zip(run0[lengths >= window], lengths[lengths >= window]):
        mark[max(0, i0 - reach) + 1:min(len(x), i0 + m + reach) + 1] = 1.0
    hits = np.cumsum(mark)
    return hits[starts + window] - hits[starts] > 0


def check_channels(channels) -> tuple[str, ...]:
    """Pressure channel names of a method's parameters as a non-empty tuple.

    Parameters
    ----------
    channels : sequence of str
        Channel names (a bare string is refused: it would be read letter by letter).

    Returns
    -------
    tuple of str
        ``tuple(channels)``.

    Raises
    ------
    ValueError
        If ``channels`` is a string or empty.

    Examples
    --------
    >>> check_channels(["p1", "p2"])
    ('p1', 'p2')
    """
    if isinstance(channels, str) or len(channels) == 0:
        raise ValueError(f"channels={channels!r} must be a non-empty tuple of names")
    return tuple(channels)


def check_finite_channels(recording, channels, what: str) -> None:
    """Refuse a recording whose channels hold NaN or inf, naming the recording, the channel and
    the first bad sample.

    One non-finite sample would otherwise spread: a prefix sum or an EMD block carries it into
    every later window, which then reads as undefined (and is blamed on a stuck sensor).

    Parameters
    ----------
    recording : leakdiag.io.Recording
        Holds ``channels``.
    channels : sequence of str
        Channels the method reads.
    what : str
        The method, for the message (e.g. ``"the wavelet feature"``).

    Raises
    ------
    leakdiag.io.RecordingError
        For the first channel with a non-finite sample: its name, count, the first index and
        its time.

    Examples
    --------
    >>> from leakdiag.io.recording import Recording
    >>> rec = Recording({"p1": [1.0, 2.0, float("nan"), 4.0]}, sample_rate=10.0,
    ...                 meta={"source": "run.csv"})
    >>> check_finite_channels(rec, ("p1",), "the FFT band feature")
    Traceback (most recent call last):
    ...
    leakdiag.io.errors.RecordingError: run.csv: channel 'p1' has 1 non-finite value(s); \
first NaN at row 2; the FFT band feature needs finite samples: fill or cut the gap
    """
    from leakdiag.io.checks import check_channel_finite
    from leakdiag.io.errors import RecordingError

    source = recording.meta.get("source", "<recording>")
    for ch in channels:
        try:  # io's check and wording (file, channel, count, first row)
            check_channel_finite(np.asarray(recording[ch], dtype=np.float64), ch, source)
        except RecordingError as exc:
            raise RecordingError(f"{exc}; {what} needs finite samples: fill or cut the "
                                 "gap") from None


def channel_rms_feature(recording, channels, window: int, overlap: float, rms_of, name: str,
                        params: dict, reach: int = 0) -> FeatureSeries:
    """Root of the per-window mean squares summed over channels, as a feature series.

    Parameters
    ----------
    recording : leakdiag.io.Recording
        Holds ``channels`` (the caller has checked them).
    channels : tuple of str
        Channels, summed in this order.
    window : int
        Window size N in samples.
    overlap : float
        Overlap in percent.
    rms_of : callable
        ``rms_of(signal) -> ndarray``: the windowed RMS of one channel on the Sec. 4.4 grid.
    name : str
        Feature name.
    params : dict
        The feature's ``params``.
    reach : int, default 0
        Samples by which ``rms_of`` looks beyond a sample (:func:`frozen_windows`).

    Returns
    -------
    FeatureSeries
        :math:`\\sqrt{\\sum_c \\mathrm{rms}_c^2}` per window, timestamped at each window's
        last sample; NaN in a window that overlaps a hold of one exact value at least a window
        long in any channel (:func:`frozen_windows`), with one counted
        :class:`~leakdiag.features.DegenerateWindowWarning`.

    Raises
    ------
    leakdiag.io.RecordingError
        If a channel holds NaN or inf (:func:`check_finite_channels`).

    Examples
    --------
    >>> from leakdiag.io.recording import Recording
    >>> rec = Recording({"p1": [3.0, -3.0, 3.0, -3.0], "p2": [4.0, -4.0, 4.0, -4.0]},
    ...                 sample_rate=1.0)
    >>> rms = lambda x: windowed_rms(x, 2, 0.0)
    >>> channel_rms_feature(rec, ("p1", "p2"), 2, 0.0, rms, "demo", {}).values.tolist()
    [5.0, 5.0]
    """
    check_finite_channels(recording, channels, f"the {name} feature")
    ms = None
    frozen = None
    for ch in channels:
        r = rms_of(recording[ch])
        ms = r**2 if ms is None else ms + r**2
        f = frozen_windows(recording[ch], window, overlap, reach)
        frozen = f if frozen is None else frozen | f
    values = np.where(frozen, np.nan, np.sqrt(ms))
    warn_degenerate(int(frozen.sum()), len(values),
                    "a channel frozen (one value held for at least a window, e.g. a stuck sensor)",
                    stacklevel=4)
    starts = window_starts(recording.n_samples, window, overlap)
    times = window_times(starts, window, recording.sample_rate, recording.start_time)
    return FeatureSeries(times, values, name, params, window=window, overlap=overlap,
                         step=window_step(window, overlap), channels=tuple(channels),
                         sample_rate=recording.sample_rate, start_time=recording.start_time)
