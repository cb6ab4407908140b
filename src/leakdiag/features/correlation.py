"""Windowed autocorrelation (Eq. 4.1) and cross-correlation (Eq. 4.2) of thesis Sec. 4.1-4.2."""

from __future__ import annotations

import numpy as np

from leakdiag.features import _args
from leakdiag.features._kernels.blocksums import (
    autocorrelation_regular,
    autocorrelation_sorted,
    cross_correlation_regular,
    cross_correlation_sorted,
)
from leakdiag.features._degenerate import check_magnitude, warn_degenerate
from leakdiag.features._kernels.stepsums import (
    autocorrelation_steps_regular,
    cross_correlation_steps_regular,
    use_step_kernels,
)
from leakdiag.features.series import FeatureSeries

__all__ = ["autocorrelation", "cross_correlation", "autocorrelation_at", "cross_correlation_at"]


def _auto_values(x: np.ndarray, lag: int, starts: np.ndarray, window: int) -> np.ndarray:
    starts, order = _args.sort_starts(starts)
    values, n_bad = autocorrelation_sorted(x, lag, window, starts)
    check_magnitude(values, n_bad, [x], ["x"], 2, window)
    warn_degenerate(n_bad, len(values), "zero variance", stacklevel=4)
    return _args.unsort(values, order)


def _cross_values(y: np.ndarray, x: np.ndarray, lag: int, starts: np.ndarray,
                  window: int) -> np.ndarray:
    starts, order = _args.sort_starts(starts)
    values, n_bad = cross_correlation_sorted(y, x, lag, window, starts)
    check_magnitude(values, n_bad, [y, x], ["y", "x"], 2, window)
    warn_degenerate(n_bad, len(values), "zero variance", stacklevel=4)
    return _args.unsort(values, order)


def _check_pair(y, x, finite: bool = True) -> tuple[np.ndarray, np.ndarray]:
    y_arr = _args.signal_1d(y, "y", finite)
    x_arr = _args.signal_1d(x, "x", finite)
    if len(y_arr) != len(x_arr):
        raise ValueError(
            f"y and x must have the same length, got len(y)={len(y_arr)} and len(x)={len(x_arr)}"
        )
    return y_arr, x_arr


def autocorrelation(x, lag: int = 1, window: int = 200, overlap: float = 5.0,
                    sample_rate: float = 1.0, start_time: float = 0.0) -> FeatureSeries:
    r"""Windowed autocorrelation coefficient of one signal (thesis Eq. 4.1).

    Parameters
    ----------
    x : array_like or pandas.Series
        Signal, shape ``(n,)``, any real dtype (e.g. pressure in Pa).
    lag : int, default 1
        Lag :math:`\tau` in samples, ``1 <= lag < window``.
    window : int, default 200
        Window size N in samples, ``>= 2``.
    overlap : float, default 5.0
        Overlap of consecutive windows in percent, ``0 <= overlap < 100`` (Sec. 4.4).
    sample_rate : float, default 1.0
        Sample rate in Hz (1.0 gives timestamps in samples).
    start_time : float, default 0.0
        Time of sample 0 in seconds.

    Returns
    -------
    FeatureSeries
        ``values`` (dimensionless, one per window, NaN for zero-variance windows) and ``time``
        (s, time of each window's last sample); ``settings`` holds ``lag``; the geometry fields
        ``window``, ``overlap``, ``step``, ``channels``, ``sample_rate``, ``start_time`` are set.

    Raises
    ------
    ValueError
        If ``lag`` is outside ``[1, window)``, ``window < 2``, ``overlap`` outside ``[0, 100)``,
        the signal is shorter than one window, or it holds NaN/inf (the message names the first
        bad sample).
    TypeError
        If ``x`` is not numeric or ``lag``/``window`` are not integers.

    Warns
    -----
    DegenerateWindowWarning
        One warning counting the windows with zero variance (their values are NaN).

    Notes
    -----
    For the window of samples :math:`x_1..x_N` with mean :math:`\bar{x}` (Eq. 4.1):

    .. math:: ac_\tau = \frac{\sum_{j=1}^{N-\tau} (x_j - \bar{x})(x_{j+\tau} - \bar{x})}
              {\sum_{j=1}^{N} (x_j - \bar{x})^2}

    The numerator has :math:`N - \tau` terms, the denominator :math:`N`, so a perfectly
    correlated window gives about :math:`(N - \tau)/N`, not 1. Computed in O(n) for all windows
    with anchored block sums (:mod:`leakdiag.features._kernels.blocksums`), to about 1e-12 relative of
    a two-pass evaluation. :func:`autocorrelation_at` evaluates arbitrary window starts.

    References
    ----------
    Thesis Sec. 4.1, Eq. 4.1; windowing Sec. 4.4. Box, Jenkins and Reinsel (1994).

    Examples
    --------
    >>> fs = autocorrelation([1.0, 2.0, 3.0, 4.0], lag=1, window=4)
    >>> fs.values.tolist()   # (-1.5*-0.5 + -0.5*0.5 + 0.5*1.5) / 5
    [0.25]
    >>> t = np.arange(2000) / 1000.0
    >>> fs = autocorrelation(np.sin(2 * np.pi * 5 * t), lag=10, window=200, overlap=50,
    ...                      sample_rate=1000.0)
    >>> len(fs), fs.step, round(float(fs.values[0]), 3)
    (19, 100, 0.953)
    """
    x_arr = _args.signal_1d(x, "x", finite=False)  # checked with the kernel's help below
    window = _args.check_window(window)
    lag = _args.check_lag(lag, window)
    plan = _args.plan_windows(len(x_arr), window, overlap, sample_rate, start_time)
    return autocorrelation_planned(x_arr, lag, plan, _args.channel_names(x, "x"))


def autocorrelation_planned(x_arr: np.ndarray, lag: int, plan: _args.WindowPlan,
                            channels: tuple[str, ...]) -> FeatureSeries:
    """Eq. 4.1 on a checked signal over a checked window plan (the registry's batch path).

    Parameters
    ----------
    x_arr : numpy.ndarray
        Writeable C-contiguous float64 signal (its finiteness is checked here, cheaply).
    lag : int
        Checked lag, ``0 < lag < plan.window``.
    plan : WindowPlan
        The regular windows (:func:`leakdiag.features._args.plan_windows`).
    channels : tuple of str
        Channel name(s) recorded in the series.

    Returns
    -------
    FeatureSeries
        As :func:`autocorrelation`.
    """
    regular = (autocorrelation_steps_regular if use_step_kernels(plan.step, lag)
               else autocorrelation_regular)
    values, time, n_bad, n_nonfinite = regular(
        x_arr, lag, plan.window, plan.step, plan.n_windows, plan.sample_rate, plan.start_time)
    _args.finish_finite_check(x_arr, "x", n_nonfinite, plan)
    check_magnitude(values, n_bad, [x_arr], channels, 2, plan.window)
    warn_degenerate(n_bad, len(values), "zero variance", stacklevel=4)
    return FeatureSeries(time, values, "autocorrelation", {"lag": lag},
                         **plan.geometry(channels))


def cross_correlation(y, x, lag: int = 1, window: int = 100, overlap: float = 5.0,
                      sample_rate: float = 1.0, start_time: float = 0.0) -> FeatureSeries:
    r"""Windowed cross-correlation coefficient of two signals (thesis Eq. 4.2).

    Parameters
    ----------
    y : array_like or pandas.Series
        First signal, shape ``(n,)`` (e.g. ``p1`` in Pa); its sample ``j`` is paired with
        sample ``j + lag`` of ``x``.
    x : array_like or pandas.Series
        Second signal, same length as ``y`` (e.g. ``p2`` in Pa).
    lag : int, default 1
        Lag :math:`\tau` in samples, ``1 <= lag < window``.
    window : int, default 100
        Window size N in samples, ``>= 2``.
    overlap : float, default 5.0
        Overlap in percent, ``0 <= overlap < 100``.
    sample_rate : float, default 1.0
        Sample rate in Hz.
    start_time : float, default 0.0
        Time of sample 0 in seconds.

    Returns
    -------
    FeatureSeries
        Dimensionless values (NaN where ``x`` or ``y`` has zero variance in the window) and
        window times in s; settings and geometry as for :func:`autocorrelation`, ``channels``
        is ``(y name, x name)``.

    Raises
    ------
    ValueError
        As :func:`autocorrelation`, and if ``y`` and ``x`` differ in length.
    TypeError
        If an input is not numeric or ``lag``/``window`` are not integers.

    Warns
    -----
    DegenerateWindowWarning
        One warning counting the windows where ``x`` or ``y`` has zero variance.

    Notes
    -----
    With population variances :math:`\sigma^2 = \frac{1}{N}\sum (x_j - \bar{x})^2` over the
    window (Eq. 4.2):

    .. math:: cc_\tau = \frac{1}{N}
              \frac{\sum_{j=1}^{N-\tau} (y_j - \bar{y})(x_{j+\tau} - \bar{x})}
              {\sqrt{\sigma_x^2 \sigma_y^2}}

    The :math:`1/N` cancels against the population variances, so
    ``cross_correlation(x, x, ...)`` equals ``autocorrelation(x, ...)`` (Eq. 4.1).

    References
    ----------
    Thesis Sec. 4.2, Eq. 4.2; windowing Sec. 4.4.

    Examples
    --------
    >>> y = [1.0, 2.0, 3.0, 4.0]
    >>> x = [4.0, 3.0, 2.0, 1.0]
    >>> cross_correlation(y, x, lag=1, window=4).values.tolist()  # (1/4)(-1.25)/1.25
    [-0.25]
    """
    y_arr, x_arr = _check_pair(y, x, finite=False)  # checked with the kernel's help below
    window = _args.check_window(window)
    lag = _args.check_lag(lag, window)
    plan = _args.plan_windows(len(x_arr), window, overlap, sample_rate, start_time)
    channels = _args.channel_names(y, "y") + _args.channel_names(x, "x")
    return cross_correlation_planned(y_arr, x_arr, lag, plan, channels)


def cross_correlation_planned(y_arr: np.ndarray, x_arr: np.ndarray, lag: int,
                              plan: _args.WindowPlan, channels: tuple[str, ...]
                              ) -> FeatureSeries:
    """Eq. 4.2 on checked signals over a checked window plan (the registry's batch path).

    Parameters
    ----------
    y_arr, x_arr : numpy.ndarray
        Writeable C-contiguous float64 signals of equal length.
    lag : int
        Checked lag, ``0 < lag < plan.window``.
    plan : WindowPlan
        The regular windows.
    channels : tuple of str
        ``(y name, x name)``.

    Returns
    -------
    FeatureSeries
        As :func:`cross_correlation`.
    """
    regular = (cross_correlation_steps_regular if use_step_kernels(plan.step, lag)
               else cross_correlation_regular)
    values, time, n_bad, n_nonfinite = regular(
        y_arr, x_arr, lag, plan.window, plan.step, plan.n_windows, plan.sample_rate,
        plan.start_time)
    _args.finish_finite_check(y_arr, "y", n_nonfinite, plan)
    _args.finish_finite_check(x_arr, "x", n_nonfinite, plan)
    check_magnitude(values, n_bad, [y_arr, x_arr], channels, 2, plan.window)
    warn_degenerate(n_bad, len(values), "zero variance", stacklevel=4)
    return FeatureSeries(time, values, "cross-correlation", {"lag": lag},
                         **plan.geometry(channels))


def autocorrelation_at(x, lag: int, starts, window: int) -> np.ndarray:
    """Eq. 4.1 for arbitrary window starts: the low-level entry point for sweeps.

    Parameters
    ----------
    x : array_like
        Signal, shape ``(n,)``.
    lag : int
        Lag in samples, ``1 <= lag < window``.
    starts : array_like of int
        First sample of each window, ``0 <= start <= n - window``, any order, repeats allowed.
    window : int
        Window size N in samples.

    Returns
    -------
    numpy.ndarray
        float64, one value per start (same order), NaN for zero-variance windows.

    Raises
    ------
    ValueError
        Bad ``lag``/``window``, a start out of range, a signal shorter than one window, NaN/inf.

    Warns
    -----
    DegenerateWindowWarning
        One warning counting zero-variance windows.

    Notes
    -----
    Cost O(n + len(starts)) whatever the window and the spacing of the starts. For a grid over
    overlaps at fixed ``(lag, window)``, evaluate every start once,
    ``all_ = autocorrelation_at(x, lag, np.arange(n - window + 1), window)``, and take
    ``all_[::step]`` for each overlap's step (:func:`leakdiag.features.window_step`).

    Examples
    --------
    >>> autocorrelation_at([1.0, 2.0, 3.0, 4.0, 0.0], 1, [1, 0], 4).round(6).tolist()
    [-0.321429, 0.25]
    """
    x_arr = _args.signal_1d(x, "x")
    window = _args.check_window(window)
    lag = _args.check_lag(lag, window)
    starts = _args.check_starts(starts, len(x_arr), window)
    return _auto_values(x_arr, lag, starts, window)


def cross_correlation_at(y, x, lag: int, starts, window: int) -> np.ndarray:
    """Eq. 4.2 for arbitrary window starts (see :func:`autocorrelation_at`).

    Parameters
    ----------
    y, x : array_like
        Signals of equal length ``n``; ``y_j`` pairs with ``x_{j+lag}``.
    lag : int
        Lag in samples, ``1 <= lag < window``.
    starts : array_like of int
        Window starts, ``0 <= start <= n - window``.
    window : int
        Window size N in samples.

    Returns
    -------
    numpy.ndarray
        float64, one value per start, NaN where ``x`` or ``y`` has zero variance.

    Raises
    ------
    ValueError
        As :func:`autocorrelation_at`, and if ``y`` and ``x`` differ in length.

    Warns
    -----
    DegenerateWindowWarning
        One warning counting degenerate windows.

    Examples
    --------
    >>> cross_correlation_at([1.0, 2.0, 3.0, 4.0], [1.0, 2.0, 3.0, 4.0], 1, [0], 4).tolist()
    [0.25]
    """
    y_arr, x_arr = _check_pair(y, x)
    window = _args.check_window(window)
    lag = _args.check_lag(lag, window)
    starts = _args.check_starts(starts, len(x_arr), window)
    return _cross_values(y_arr, x_arr, lag, starts, window)
