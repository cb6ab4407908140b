"""Windowed statistical moments of thesis Sec. 4.7 (Eq. 4.11-4.14), the stationarity check."""

from __future__ import annotations

import numba
import numpy as np

from leakdiag.features import _args
from leakdiag.features._kernels.chunks import CHUNK, NO_STARTS, UINT, fill_times
from leakdiag.features._degenerate import check_magnitude, warn_degenerate
from leakdiag.features._kernels.stepsums import moments_steps_regular, use_step_kernels
from leakdiag.features._kernels.values import moment_values
from leakdiag.features.series import FeatureSeries

__all__ = ["moments", "moments_at", "MOMENT_NAMES", "MOMENT_COLUMNS", "to_frame"]

#: The four moments of Eq. 4.11-4.14, in the order :func:`moments` returns them.
MOMENT_NAMES = ("mean", "variance", "skewness", "kurtosis")
#: Columns of :func:`to_frame` applied to the moments: the window time, then the moments.
MOMENT_COLUMNS = ("time",) + MOMENT_NAMES


@numba.njit(cache=True, error_model="numpy")
def _moment_eval(g1, g2, g3, g4, anchor, h1, h2, h3, h4, fn, out, o0, cnt):  # pragma: no cover - compiled
    """Eq. 4.11-4.14 from the tail/head power sums of ``cnt`` windows into ``out[:, o0:o0+cnt]``."""
    inv = 1.0 / fn
    bad = 0
    nf = 0  # windows whose sums are not finite: NaN or inf in the input
    for t in range(cnt):
        m, v, sk, ku, b, f = moment_values(g1[t] + h1[t], g2[t] + h2[t], g3[t] + h3[t],
                                           g4[t] + h4[t], anchor[t], fn, inv)
        out[0, o0 + t] = m
        out[1, o0 + t] = v
        out[2, o0 + t] = sk
        out[3, o0 + t] = ku
        bad += b
        nf += f
    return bad, nf


@numba.njit(cache=True, error_model="numpy")
def _moment_core(x, window, starts, step, out):  # pragma: no cover - compiled
    """Mean, variance (Eq. 4.12), skewness and kurtosis per window into the rows of ``out``.

    Windows ``s_k = k * step`` (``step > 0``) or the sorted ``starts`` (``step = 0``). The
    anchored block sums of :mod:`leakdiag.features._kernels.blocksums` (blocks of N samples; tail and
    head of each window summed about the block's last sample ``x[e - 1]``, a sample of the
    window), shifted exactly to the window mean by the binomial expansion. Returns the numbers
    of constant windows and of windows whose sums are not finite (NaN/inf input).
    """
    nn = window
    n_win = out.shape[1]
    kc = max(1, min(CHUNK, n_win))
    g1 = np.empty(kc)
    g2 = np.empty(kc)
    g3 = np.empty(kc)
    g4 = np.empty(kc)
    anchor = np.empty(kc)
    h1 = np.empty(kc)
    h2 = np.empty(kc)
    h3 = np.empty(kc)
    h4 = np.empty(kc)
    n_bad = 0
    n_nonfinite = 0
    for k0 in range(0, n_win, kc):
        k1 = min(k0 + kc, n_win)
        # ---- tails [s, e), backward
        e = -1
        p = 0
        ct = 0.0
        a1 = 0.0
        a2 = 0.0
        a3 = 0.0
        a4 = 0.0
        for k in range(k1 - 1, k0 - 1, -1):
            s = k * step if step > 0 else starts[k]
            if e < 0 or s < e - nn:
                e = (s // nn + 1) * nn
                p = e
                ct = x[e - 1]
                a1 = 0.0
                a2 = 0.0
                a3 = 0.0
                a4 = 0.0
            j = p - 1
            while j >= s:  # from the block end down: the same order for any step
                d = x[UINT(j)] - ct
                dd = d * d
                a1 += d
                a2 += dd
                a3 += dd * d
                a4 += dd * dd
                j -= 1
            p = s
            t = k - k0
            g1[t] = a1
            g2[t] = a2
            g3[t] = a3
            g4[t] = a4
            anchor[t] = ct
        # ---- heads [e, s + N) about the same anchor x[e - 1], forward
        e = -1
        q = 0
        a1 = 0.0
        a2 = 0.0
        a3 = 0.0
        a4 = 0.0
        for k in range(k0, k1):
            s = k * step if step > 0 else starts[k]
            if e < 0 or s >= e:
                e = (s // nn + 1) * nn
                q = e
                ct = x[e - 1]
                a1 = 0.0
                a2 = 0.0
                a3 = 0.0
                a4 = 0.0
            j = q
            while j < s + nn:
                d = x[UINT(j)] - ct
                dd = d * d
                a1 += d
                a2 += dd
                a3 += dd * d
                a4 += dd * dd
                j += 1
            q = s + nn
            t = k - k0
            h1[t] = a1
            h2[t] = a2
            h3[t] = a3
            h4[t] = a4
        b, f = _moment_eval(g1, g2, g3, g4, anchor, h1, h2, h3, h4, float(nn), out, k0, k1 - k0)
        n_bad += b
        n_nonfinite += f
    return n_bad, n_nonfinite


@numba.njit(cache=True)
def _moments_regular(x, window, step, n_win, sample_rate, start_time):  # pragma: no cover - compiled
    """Rows ``time, mean, variance, skewness, kurtosis`` of one ``(5, n_win)`` array, the count
    of constant windows and the count of windows whose sums are not finite."""
    buf = np.empty((5, n_win))
    n_bad, n_nonfinite = _moment_core(x, window, NO_STARTS, step, buf[1:])
    fill_times(buf[0], step, window, sample_rate, start_time)
    return buf, n_bad, n_nonfinite


@numba.njit(cache=True)
def _moments_sorted(x, window, starts):  # pragma: no cover - compiled
    """Shape ``(4, len(starts))``: mean, variance, skewness, kurtosis for sorted starts; NaN count."""
    out = np.empty((4, starts.shape[0]))
    n_bad, _ = _moment_core(x, window, starts, 0, out)
    return out, n_bad


def _moment_rows(x: np.ndarray, starts: np.ndarray, window: int) -> np.ndarray:
    starts, order = _args.sort_starts(starts)
    rows, n_bad = _moments_sorted(x, window, starts)
    check_magnitude(rows, n_bad, [x], ["x"], 4, window)
    warn_degenerate(n_bad, len(starts), "zero variance (skewness and kurtosis)", stacklevel=4)
    return _args.unsort(rows, order)


def moments(x, window: int = 400, overlap: float = 50.0, sample_rate: float = 1.0,
            start_time: float = 0.0):
    r"""Windowed mean, variance, skewness and kurtosis (thesis Sec. 4.7, Eq. 4.11-4.14).

    Parameters
    ----------
    x : array_like or pandas.Series
        Signal, shape ``(n,)`` (e.g. pressure in Pa).
    window : int, default 400
        Window size N in samples, ``>= 2`` (the thesis uses 400).
    overlap : float, default 50.0
        Overlap in percent, ``0 <= overlap < 100`` (the thesis uses 50).
    sample_rate : float, default 1.0
        Sample rate in Hz.
    start_time : float, default 0.0
        Time of sample 0 in seconds.

    Returns
    -------
    tuple of FeatureSeries
        Four series on the same windows, named and ordered as :data:`MOMENT_NAMES`: ``mean``
        (unit of ``x``), ``variance`` (unit squared, population, divide by N), ``skewness`` and
        ``kurtosis`` (dimensionless, NaN for a constant window); time in s (last sample of
        the window). Each has ``settings={"moment": name}`` and the window geometry.
        :func:`to_frame` makes one DataFrame of them.

    Raises
    ------
    ValueError
        Bad ``window``/``overlap``, a signal shorter than one window, NaN/inf in ``x``.
    TypeError
        If ``x`` is not numeric.

    Warns
    -----
    DegenerateWindowWarning
        One warning counting constant windows (variance 0, skewness and kurtosis NaN).

    Notes
    -----
    With :math:`\bar{x}` the window mean (Eq. 4.11), :math:`\sigma^2 = \sum (x_j-\bar{x})^2/N`
    (Eq. 4.12) and the sample standard deviation :math:`s = \sqrt{\sum (x_j-\bar{x})^2/(N-1)}`:

    .. math:: \mathrm{skewness} = \frac{\sum_{j=1}^{N} (x_j - \bar{x})^3}{(N-1) s^3}, \qquad
              \mathrm{kurtosis} = \frac{\sum_{j=1}^{N} (x_j - \bar{x})^4}{(N-1) s^4}

    The printed Eq. 4.13 has a square in the numerator; a square over :math:`(N-1)s^3` is not
    dimensionless and is always positive, so the cube (the standard definition) is used, with
    the thesis's :math:`(N-1)s^3` denominator. Kurtosis is not excess kurtosis (about 3 for
    Gaussian data), as printed. See ``docs/features.md``.

    References
    ----------
    Thesis Sec. 4.7, Eq. 4.11-4.14; Challis and Kitney (1991).

    Examples
    --------
    >>> series = moments([1.0, 2.0, 3.0, 10.0], window=4, overlap=0)
    >>> [(fs.name, round(float(fs.values[0]), 4)) for fs in series]
    [('mean', 4.0), ('variance', 12.5), ('skewness', 0.8818), ('kurtosis', 1.6728)]
    >>> to_frame(series).round(4).iloc[0].tolist()
    [3.0, 4.0, 12.5, 0.8818, 1.6728]
    """
    x_arr = _args.signal_1d(x, "x", finite=False)  # checked with the kernel's help below
    window = _args.check_window(window)
    plan = _args.plan_windows(len(x_arr), window, overlap, sample_rate, start_time)
    return moments_planned(x_arr, plan, _args.channel_names(x, "x"))


def moments_planned(x_arr: np.ndarray, plan: _args.WindowPlan, channels: tuple[str, ...]
                    ) -> tuple[FeatureSeries, ...]:
    """Eq. 4.11-4.14 on a checked signal over a checked window plan (the registry's batch path).

    Parameters
    ----------
    x_arr : numpy.ndarray
        Writeable C-contiguous float64 signal.
    plan : WindowPlan
        The regular windows.
    channels : tuple of str
        Channel name.

    Returns
    -------
    tuple of FeatureSeries
        As :func:`moments`.
    """
    window = plan.window
    regular = moments_steps_regular if use_step_kernels(plan.step) else _moments_regular
    buf, n_bad, n_nonfinite = regular(x_arr, window, plan.step, plan.n_windows,
                                      plan.sample_rate, plan.start_time)
    _args.finish_finite_check(x_arr, "x", n_nonfinite, plan)
    check_magnitude(buf, n_bad, [x_arr], channels, 4, window)
    warn_degenerate(n_bad, plan.n_windows, "zero variance (skewness and kurtosis)", stacklevel=4)
    # one (5, m) block: row 0 the times, rows 1-4 the moments (views, no copy)
    geometry = plan.geometry(channels)
    return tuple(FeatureSeries(buf[0], buf[i + 1], name, {"moment": name}, **geometry)
                 for i, name in enumerate(MOMENT_NAMES))


def to_frame(series) -> "pandas.DataFrame":
    """Series on the same windows as one tidy DataFrame (``time`` and one column per series).

    Parameters
    ----------
    series : sequence of FeatureSeries
        Series with equal times (e.g. the four of :func:`moments`).

    Returns
    -------
    pandas.DataFrame
        Columns ``time`` then each series' name; ``df.attrs`` holds the first series' geometry
        (``window``, ``overlap``, ``step``, ``channels``, ``sample_rate``, ``start_time``).

    Raises
    ------
    ValueError
        If the series are empty or their times differ.

    Examples
    --------
    >>> list(to_frame(moments(np.arange(8.0), window=4, overlap=0)).columns)
    ['time', 'mean', 'variance', 'skewness', 'kurtosis']
    """
    import pandas as pd

    series = tuple(series)
    if not series:
        raise ValueError("to_frame needs at least one FeatureSeries")
    time = np.asarray(series[0].time)
    for fs in series[1:]:
        if np.shape(fs.time) != time.shape or not np.array_equal(fs.time, time):
            raise ValueError(f"series {fs.name!r} is not on the windows of {series[0].name!r}")
    df = pd.DataFrame({"time": time, **{fs.name: np.asarray(fs.values) for fs in series}})
    df.attrs.update(series[0].geometry())
    return df


def moments_at(x, starts, window: int) -> np.ndarray:
    """Eq. 4.11-4.14 for arbitrary window starts.

    Parameters
    ----------
    x : array_like
        Signal, shape ``(n,)``.
    starts : array_like of int
        Window starts, ``0 <= start <= n - window``, any order.
    window : int
        Window size N in samples.

    Returns
    -------
    numpy.ndarray
        Shape ``(len(starts), 4)``: mean, variance, skewness, kurtosis per start.

    Raises
    ------
    ValueError
        Bad ``window``, a start out of range, a signal shorter than one window, NaN/inf.

    Warns
    -----
    DegenerateWindowWarning
        One warning counting constant windows.

    Examples
    --------
    >>> moments_at([5.0, 1.0, 2.0, 3.0, 10.0], [1], 4).round(4).tolist()
    [[4.0, 12.5, 0.8818, 1.6728]]
    """
    x_arr = _args.signal_1d(x, "x")
    window = _args.check_window(window)
    starts = _args.check_starts(starts, len(x_arr), window)
    return np.ascontiguousarray(_moment_rows(x_arr, starts, window).T)
