"""Windowing of Sec. 4.4: window size N in samples, overlap in percent.

Conventions (documented in ``docs/features.md``):

* step ``= N - round(N * overlap / 100)``, at least 1 (Python's ``round``, half to even);
* window ``m`` covers samples ``[m * step, m * step + N)``; only complete windows are used;
* its timestamp is the time of its **last** sample, ``start_time + (m*step + N - 1) / sample_rate``:
  the moment the window's value can first be known (causal, as a monitor would see it).
"""

from __future__ import annotations

import numpy as np

from leakdiag._validation import check_int, check_overlap, check_positive

__all__ = ["window_step", "window_starts", "window_times", "window_first_times", "n_windows"]


def window_step(window: int, overlap: float) -> int:
    """Step between consecutive windows, ``N - round(N * overlap / 100)``, at least 1.

    Parameters
    ----------
    window : int
        Window size N in samples (>= 2).
    overlap : float
        Overlap in percent, ``0 <= overlap < 100``.

    Returns
    -------
    int
        Step in samples.

    Raises
    ------
    ValueError
        If ``window < 2`` or overlap outside ``[0, 100)``.

    Examples
    --------
    >>> window_step(200, 5)
    190
    >>> window_step(200, 99.9)
    1
    """
    window = check_int(window, "window", 2)
    overlap = check_overlap(overlap)
    return max(1, window - int(round(window * overlap / 100.0)))


def n_windows(n_samples: int, window: int, overlap: float) -> int:
    """Number of complete windows in ``n_samples`` samples.

    Parameters
    ----------
    n_samples : int
        Signal length.
    window : int
        Window size N in samples.
    overlap : float
        Overlap in percent.

    Returns
    -------
    int
        ``0`` if the signal is shorter than one window.

    Examples
    --------
    >>> n_windows(1000, 200, 50)
    9
    """
    step = window_step(window, overlap)
    if n_samples < window:
        return 0
    return (n_samples - window) // step + 1


def window_starts(n_samples: int, window: int, overlap: float) -> np.ndarray:
    """First sample index of every complete window.

    Parameters
    ----------
    n_samples : int
        Signal length.
    window : int
        Window size N in samples.
    overlap : float
        Overlap in percent.

    Returns
    -------
    numpy.ndarray
        int64 array of start indices.

    Examples
    --------
    >>> window_starts(10, 4, 50).tolist()
    [0, 2, 4, 6]
    """
    step = window_step(window, overlap)
    return np.arange(n_windows(n_samples, window, overlap), dtype=np.int64) * step


def window_times(starts: np.ndarray, window: int, sample_rate: float = 1.0,
                 start_time: float = 0.0) -> np.ndarray:
    """Timestamp of each window: the time of its last sample.

    Parameters
    ----------
    starts : numpy.ndarray
        Window start indices.
    window : int
        Window size N in samples.
    sample_rate : float, default 1.0
        Sample rate in Hz (1.0 gives time in samples).
    start_time : float, default 0.0
        Time of sample 0 in seconds.

    Returns
    -------
    numpy.ndarray
        float64 times in seconds.

    Examples
    --------
    >>> window_times(np.array([0, 2]), 4, sample_rate=2.0).tolist()
    [1.5, 2.5]
    """
    sample_rate = check_positive(sample_rate, "sample_rate")
    return start_time + (np.asarray(starts, dtype=np.float64) + (window - 1)) / sample_rate


def window_first_times(times, window: int, sample_rate: float,
                       start_time: float | None = None) -> np.ndarray:
    """Time of each window's first sample from its timestamp (its last sample's time).

    The one place where a window's first sample is placed in time (Sec. 4.4):
    :attr:`FeatureSeries.window_start` and the sweep grids use it, so that a window counts as
    before or after a leak onset the same way everywhere.

    Parameters
    ----------
    times : array_like
        Window timestamps in seconds (last sample of each window).
    window : int
        Window size N in samples.
    sample_rate : float
        Sample rate in Hz.
    start_time : float, optional
        Time of the recording's first sample, s. Given, each first sample's time is
        ``start_time + i / sample_rate`` with its sample index ``i`` (the timestamp's index,
        rounded, minus ``window - 1``): the time of that sample exactly as the recording
        places it, so that a window whose first sample is the onset's counts as after it.
        None: ``times - (window - 1) / sample_rate``, which can land one rounding below that
        sample (12.399 - 0.099 = 12.299999999999999 for a window starting at 12.3 s).

    Returns
    -------
    numpy.ndarray
        float64 times in seconds.

    Examples
    --------
    >>> window_first_times(np.array([1.5, 2.5]), 4, sample_rate=2.0).tolist()
    [0.0, 1.0]
    >>> float(window_first_times(np.array([12.399]), 100, 1000.0)[0])
    12.299999999999999
    >>> float(window_first_times(np.array([12.399]), 100, 1000.0, start_time=0.0)[0])
    12.3
    """
    times = np.asarray(times, dtype=np.float64)
    if start_time is None:
        return times - (window - 1) / sample_rate
    first = np.rint((times - start_time) * sample_rate) - (window - 1)
    return start_time + first / sample_rate
