"""Windowed statistical moments of thesis Sec. 4.7 (Eq. 4.11-4.14), the stationarity check."""

from __future__ import annotations

import numba
import numpy as np

from leakdiag.features import _args
from leakdiag.features._blocksums import block_of
from leakdiag.features._degenerate import warn_degenerate

__all__ = ["moments", "moments_at", "MOMENT_COLUMNS"]

#: Columns of the :func:`moments` DataFrame.
MOMENT_COLUMNS = ("time", "mean", "variance", "skewness", "kurtosis")


@numba.njit(cache=True)
def _shift(s1, s2, s3, s4, n, d):  # pragma: no cover - compiled
    """Given sums of ``(x - c)^p`` (p = 1..4) over ``n`` samples, sums of ``(x - c + d)^p``."""
    d2 = d * d
    m2 = s2 + 2.0 * d * s1 + n * d2
    m3 = s3 + 3.0 * d * s2 + 3.0 * d2 * s1 + n * d2 * d
    m4 = s4 + 4.0 * d * s3 + 6.0 * d2 * s2 + 4.0 * d2 * d * s1 + n * d2 * d2
    return m2, m3, m4


@numba.njit(cache=True)
def _moment_sums(x, window, starts):  # pragma: no cover - compiled
    """Per window: mean, variance (Eq. 4.12), skewness and kurtosis; and the NaN count.

    Anchored block sums as in :mod:`leakdiag.features._blocksums` (blocks of N
    samples; suffix sums anchored at the block's last sample, prefix sums at the next block's
    first, ``f[0] = 0``), shifted exactly to the window mean by the binomial expansion.
    ``starts`` must be sorted.
    """
    m_len = window
    fm = float(m_len)
    inv_m = 1.0 / fm
    g = np.empty((m_len, 4))
    f = np.empty((m_len, 4))
    n_win = starts.shape[0]
    mean = np.empty(n_win)
    var = np.empty(n_win)
    skew = np.empty(n_win)
    kurt = np.empty(n_win)
    n_bad = 0
    w = 0
    while w < n_win:
        b0, w_end = block_of(starts, w, m_len)
        e = b0 + m_len
        a0 = x[e - 1]
        t1 = 0.0
        t2 = 0.0
        t3 = 0.0
        t4 = 0.0
        for j in range(e - 1, starts[w] - 1, -1):
            d = x[j] - a0
            dd = d * d
            t1 += d
            t2 += dd
            t3 += dd * d
            t4 += dd * dd
            i = j - b0
            g[i, 0] = t1
            g[i, 1] = t2
            g[i, 2] = t3
            g[i, 3] = t4
        need = starts[w_end - 1] - b0
        a1 = x[e] if need > 0 else a0
        t1 = 0.0
        t2 = 0.0
        t3 = 0.0
        t4 = 0.0
        f[0, 0] = 0.0
        f[0, 1] = 0.0
        f[0, 2] = 0.0
        f[0, 3] = 0.0
        for i in range(need):
            d = x[e + i] - a1
            dd = d * d
            t1 += d
            t2 += dd
            t3 += dd * d
            t4 += dd * dd
            f[i + 1, 0] = t1
            f[i + 1, 1] = t2
            f[i + 1, 2] = t3
            f[i + 1, 3] = t4
        da = a1 - a0
        for k in range(w, w_end):
            i = starts[k] - b0
            fi = float(i)
            off = (g[i, 0] + f[i, 0] + fi * da) * inv_m
            p2, p3, p4 = _shift(g[i, 0], g[i, 1], g[i, 2], g[i, 3], fm - fi, -off)
            q2, q3, q4 = _shift(f[i, 0], f[i, 1], f[i, 2], f[i, 3], fi, da - off)
            mean[k] = a0 + off
            c2 = p2 + q2
            if c2 > 0.0:
                s2 = c2 / (fm - 1.0)  # sample variance s^2 (Eq. 4.13-4.14)
                var[k] = c2 / fm  # Eq. 4.12, population variance
                skew[k] = (p3 + q3) / ((fm - 1.0) * s2 * np.sqrt(s2))
                kurt[k] = (p4 + q4) / ((fm - 1.0) * s2 * s2)
            else:
                var[k] = 0.0
                skew[k] = np.nan
                kurt[k] = np.nan
                n_bad += 1
        w = w_end
    return mean, var, skew, kurt, n_bad


def _moment_columns(x: np.ndarray, starts: np.ndarray, window: int,
                    assume_sorted: bool = False) -> tuple[np.ndarray, ...]:
    order = None
    if not assume_sorted and starts.size > 1 and not bool(np.all(starts[1:] >= starts[:-1])):
        order = np.argsort(starts, kind="stable")
        starts = np.ascontiguousarray(starts[order])
    *columns, n_bad = _moment_sums(x, window, starts)
    warn_degenerate(n_bad, len(starts), "zero variance (skewness and kurtosis)", stacklevel=4)
    if order is not None:
        for col in columns:
            col[order] = col.copy()
    return tuple(columns)


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
    pandas.DataFrame
        One row per window, columns ``time`` (s, last sample of the window), ``mean`` (unit of
        ``x``), ``variance`` (unit squared, population, divide by N), ``skewness`` and
        ``kurtosis`` (dimensionless, NaN for a constant window). ``df.attrs`` holds the settings
        (``window``, ``overlap``, ``step``, ``channels``, ``sample_rate``, ``start_time``).

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
    >>> df = moments([1.0, 2.0, 3.0, 10.0], window=4, overlap=0)
    >>> df.round(4).iloc[0].tolist()
    [3.0, 4.0, 12.5, 0.8818, 1.6728]
    """
    import pandas as pd

    x_arr = _args.signal_1d(x, "x")
    window = _args.check_window(window)
    plan = _args.plan_windows(len(x_arr), window, overlap, sample_rate, start_time)
    mean, variance, skew, kurt = _moment_columns(x_arr, plan.starts, window, assume_sorted=True)
    df = pd.DataFrame({"time": plan.time, "mean": mean, "variance": variance, "skewness": skew,
                       "kurtosis": kurt}, copy=False)  # fresh arrays: no 5-column copy
    df.attrs.update(plan.settings(_args.channel_names(x, "x"), sample_rate, start_time))
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
    return np.column_stack(_moment_columns(x_arr, starts, window))
