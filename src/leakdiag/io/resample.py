"""Explicit resampling of a non-uniform time axis onto a uniform grid (linear interpolation)."""

from __future__ import annotations

from typing import Mapping

import numpy as np

from leakdiag._validation import check_positive
from leakdiag.io.checks import GAP_ADVICE, MAX_GAP_INTERVALS, gap_words
from leakdiag.io.recording import RecordingError

__all__ = ["uniform_grid", "resample_linear"]

# Slack (in samples) so that a grid point falling on the last sample up to rounding is kept.
_GRID_SLACK = 1e-9


def uniform_grid(t_start: float, t_end: float, sample_rate: float) -> np.ndarray:
    """Uniform sample times ``t_start + k / sample_rate`` that lie within ``[t_start, t_end]``.

    Parameters
    ----------
    t_start, t_end : float
        First and last source sample time in seconds.
    sample_rate : float
        Target rate in Hz.

    Returns
    -------
    numpy.ndarray
        ``floor((t_end - t_start) * sample_rate) + 1`` times in seconds.

    Examples
    --------
    >>> uniform_grid(0.0, 1.0, 4.0).tolist()
    [0.0, 0.25, 0.5, 0.75, 1.0]
    """
    n = int(np.floor((t_end - t_start) * sample_rate + _GRID_SLACK)) + 1
    return t_start + np.arange(n) / sample_rate


def resample_linear(t: np.ndarray, channels: Mapping[str, np.ndarray], sample_rate: float,
                    source: str = "<input>",
                    max_gap_intervals: float | None = MAX_GAP_INTERVALS
                    ) -> tuple[float, dict[str, np.ndarray]]:
    """Linearly interpolate channels sampled at times ``t`` onto a uniform grid.

    Parameters
    ----------
    t : numpy.ndarray
        Source sample times in seconds, strictly increasing (need not be uniform).
    channels : dict of str to numpy.ndarray
        Channel samples, each the length of ``t``.
    sample_rate : float
        Target rate in Hz.
    source : str
        File name for messages.
    max_gap_intervals : float or None, default :data:`~leakdiag.io.checks.MAX_GAP_INTERVALS`
        Longest source interval, in median intervals, that is interpolated; a longer one (a
        gap) is refused. None: no limit.

    Returns
    -------
    start_time : float
        ``t[0]``, the first grid time in seconds.
    channels : dict of str to numpy.ndarray
        Interpolated samples on :func:`uniform_grid` ``(t[0], t[-1], sample_rate)``.

    Raises
    ------
    RecordingError
        If ``sample_rate`` is not positive, ``t`` has fewer than 2 samples, is not
        strictly increasing or has a gap (the row is named).

    Notes
    -----
    Linear interpolation, no anti-alias filter: resampling to a rate well below the source
    rate aliases content above the new Nyquist frequency. Choose a target rate close to the
    median source rate.

    Examples
    --------
    >>> t = np.array([0.0, 0.1, 0.3, 0.4])
    >>> start, out = resample_linear(t, {"x": 10 * t}, 10.0)
    >>> start, out["x"].round(12).tolist()
    (0.0, [0.0, 1.0, 2.0, 3.0, 4.0])
    """
    try:
        sample_rate = check_positive(sample_rate, "resample")
    except (TypeError, ValueError) as exc:
        raise RecordingError(f"{source}: {exc}") from None
    t = np.asarray(t, dtype=np.float64)
    if len(t) < 2:
        raise RecordingError(f"{source}: cannot resample {len(t)} sample(s); need at least 2")
    bad = np.flatnonzero(np.diff(t) <= 0)
    if len(bad):
        i = int(bad[0]) + 1
        raise RecordingError(
            f"{source}: time is not strictly increasing at row {i} "
            f"(t[{i - 1}]={float(t[i - 1])!r}, t[{i}]={float(t[i])!r}); "
            f"resampling needs increasing times"
        )
    if max_gap_intervals is not None:
        dt = np.diff(t)
        med = float(np.median(dt))
        big = np.flatnonzero(dt > max_gap_intervals * med)
        if len(big):
            gap = gap_words(dt, med) if max_gap_intervals == MAX_GAP_INTERVALS else (
                f"an interval of {float(dt[big[0]]):.6g} s before row {int(big[0]) + 1}")
            raise RecordingError(
                f"{source}: cannot resample across {gap} (more than {max_gap_intervals:g} "
                f"median intervals): {GAP_ADVICE}")
    grid = uniform_grid(t[0], t[-1], sample_rate)
    return float(t[0]), {name: np.interp(grid, t, np.asarray(v, dtype=np.float64))
                         for name, v in channels.items()}
