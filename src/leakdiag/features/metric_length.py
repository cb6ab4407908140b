"""Windowed ratio of metric lengths (fractal number) of thesis Sec. 4.3, Eq. 4.3-4.4."""

from __future__ import annotations

import math

import numba
import numpy as np

from leakdiag.features import _args
from leakdiag.features._blocksums import safe_ratio
from leakdiag.features._degenerate import warn_degenerate
from leakdiag.features.series import FeatureSeries

__all__ = ["metric_length_ratio", "metric_length_ratio_at"]


@numba.njit(cache=True)
def _step_lengths(x, step, n_terms):  # pragma: no cover - compiled
    """``||x[j + step] - x[j]||`` for ``j < n_terms``: Euclidean norm over channels (Eq. 4.4)."""
    n_ch = x.shape[1]
    out = np.empty(n_terms)
    if n_ch == 1:
        for j in range(n_terms):
            out[j] = abs(x[j + step, 0] - x[j, 0])
    else:
        for j in range(n_terms):
            acc = 0.0
            for c in range(n_ch):
                d = x[j + step, c] - x[j, c]
                acc += d * d
            out[j] = math.sqrt(acc)
    return out


@numba.njit(cache=True)
def _window_sums2(t1, t2, m_len, starts):  # pragma: no cover - compiled
    """Sums of ``t1`` and ``t2`` over ``[s, s + m_len)`` for each sorted start ``s``.

    Same block layout as :mod:`leakdiag.features._blocksums` (blocks of ``m_len`` terms,
    suffix sums for the block holding ``s``, lazy prefix sums for the next one), so each window
    sum adds at most two partial sums of at most ``m_len`` non-negative terms: relative error
    of a few ulps times ``m_len``, independent of the signal length.
    """
    n_terms = t1.shape[0]
    g1 = np.empty(m_len)
    g2 = np.empty(m_len)
    f1 = np.empty(m_len)
    f2 = np.empty(m_len)
    n_win = starts.shape[0]
    out1 = np.empty(n_win)
    out2 = np.empty(n_win)
    b0 = 0
    e = -1
    f_b0 = -1
    f_len = 0
    r1 = 0.0
    r2 = 0.0
    for w in range(n_win):
        s = starts[w]
        if s >= b0 + m_len or e < 0:
            b0 = (s // m_len) * m_len
            e = min(b0 + m_len, n_terms)
            a1 = 0.0
            a2 = 0.0
            for j in range(e - 1, s - 1, -1):
                a1 += t1[j]
                a2 += t2[j]
                g1[j - b0] = a1
                g2[j - b0] = a2
        i0 = s - b0
        v1 = g1[i0]
        v2 = g2[i0]
        n1 = m_len - (e - s)
        if n1 > 0:
            if f_b0 != e:
                f_b0 = e
                f_len = 0
                r1 = 0.0
                r2 = 0.0
            while f_len < n1:
                r1 += t1[e + f_len]
                r2 += t2[e + f_len]
                f1[f_len] = r1
                f2[f_len] = r2
                f_len += 1
            v1 += f1[n1 - 1]
            v2 += f2[n1 - 1]
        out1[w] = v1
        out2[w] = v2
    return out1, out2


def _ratio_values(x2: np.ndarray, l_step: int, k_step: int, starts: np.ndarray,
                  window: int) -> np.ndarray:
    order = None
    if starts.size > 1 and not bool(np.all(starts[1:] >= starts[:-1])):
        order = np.argsort(starts, kind="stable")
        starts = np.ascontiguousarray(starts[order])
    n_terms = len(x2) - l_step  # Eq. 4.3: both sums run over the same N - l terms
    num, den = _window_sums2(_step_lengths(x2, k_step, n_terms), _step_lengths(x2, l_step, n_terms),
                             window - l_step, starts)
    values, n_bad = safe_ratio(num, den)
    warn_degenerate(n_bad, len(values), "zero metric length at step l (Eq. 4.3 denominator)",
                    stacklevel=4)
    if order is not None:
        out = np.empty_like(values)
        out[order] = values
        values = out
    return values


def metric_length_ratio(x, lag_ratio="83:3", window: int = 500, overlap: float = 5.0,
                        sample_rate: float = 1.0, start_time: float = 0.0) -> FeatureSeries:
    r"""Windowed ratio of metric lengths (fractal number) of one or more signals (Eq. 4.3).

    Parameters
    ----------
    x : array_like, pandas.Series or pandas.DataFrame
        Signal, shape ``(n,)``, or several channels, shape ``(n, c)`` (samples x channels, e.g.
        ``p1`` and ``p2`` in Pa); with several channels the Euclidean norm over channels
        (Eq. 4.4) measures each step.
    lag_ratio : str or tuple of int, default "83:3"
        ``"l:k"`` (or ``(l, k)``): the long and the short sampling step in samples,
        ``l > k >= 1`` and ``l < window``.
    window : int, default 500
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
        Dimensionless ratio per window (NaN where the denominator is zero) and window times in
        s; ``params`` holds ``lag_ratio`` (``"l:k"``), ``l``, ``k``, ``window``, ``overlap``,
        ``step``, ``channels``, ``sample_rate``, ``start_time``.

    Raises
    ------
    ValueError
        If ``lag_ratio`` is malformed or breaks ``l > k >= 1``, ``l < window``; bad ``window``
        or ``overlap``; signal shorter than one window; NaN/inf in the input.
    TypeError
        If ``x`` is not numeric.

    Warns
    -----
    DegenerateWindowWarning
        One warning counting windows whose denominator is zero (constant, or periodic with
        period ``l``).

    Notes
    -----
    For the window :math:`x_1..x_N` (Eq. 4.3, both sums over the same :math:`N - l` terms):

    .. math:: F = \frac{\sum_{j=1}^{N-l} \lVert x_{j+k} - x_j \rVert}
              {\sum_{j=1}^{N-l} \lVert x_{j+l} - x_j \rVert}

    with the Euclidean norm :math:`\lVert v \rVert = \sqrt{\sum_c v_c^2}` (Eq. 4.4). A ramp
    gives exactly ``k / l``; white noise gives about 1.

    References
    ----------
    Thesis Sec. 4.3, Eq. 4.3-4.4; Mamishev et al. (1996); Huang and Hsieh (1998).

    Examples
    --------
    >>> ramp = np.arange(1000.0)
    >>> fs = metric_length_ratio(ramp, lag_ratio="83:3", window=500, overlap=50)
    >>> fs.values.round(6).tolist() == [round(3 / 83, 6)] * 3
    True
    >>> fs.params["lag_ratio"], fs.params["step"]
    ('83:3', 250)
    """
    x2 = _args.signal_2d(x, "x")
    window = _args.check_window(window)
    l_step, k_step = _args.parse_lag_ratio(lag_ratio, window)
    plan = _args.plan_windows(len(x2), window, overlap, sample_rate, start_time)
    values = _ratio_values(x2, l_step, k_step, plan.starts, window)
    params = {"lag_ratio": f"{l_step}:{k_step}", "l": l_step, "k": k_step, "window": window,
              "overlap": plan.overlap, "step": plan.step,
              "channels": _args.channel_names(x, "x", x2.shape[1]),
              "sample_rate": float(sample_rate), "start_time": float(start_time)}
    return FeatureSeries(plan.time, values, "metric_length_ratio", params)


def metric_length_ratio_at(x, lag_ratio, starts, window: int) -> np.ndarray:
    """Eq. 4.3 for arbitrary window starts: the low-level entry point for sweeps.

    Parameters
    ----------
    x : array_like
        Signal ``(n,)`` or ``(n, c)``.
    lag_ratio : str or tuple of int
        ``"l:k"`` or ``(l, k)``.
    starts : array_like of int
        Window starts, ``0 <= start <= n - window``, any order.
    window : int
        Window size N in samples.

    Returns
    -------
    numpy.ndarray
        float64, one ratio per start (same order), NaN where the denominator is zero.

    Raises
    ------
    ValueError
        As :func:`metric_length_ratio`, and for a start out of range.

    Warns
    -----
    DegenerateWindowWarning
        One warning counting windows with a zero denominator.

    Notes
    -----
    Cost O(n + len(starts)); for an overlap grid evaluate ``np.arange(n - window + 1)`` once
    and slice by step.

    Examples
    --------
    >>> x = [0.0, 1.0, 3.0, 6.0, 10.0]
    >>> metric_length_ratio_at(x, (2, 1), [1, 0], 4).round(4).tolist()  # 5/12, 3/8
    [0.4167, 0.375]
    """
    x2 = _args.signal_2d(x, "x")
    window = _args.check_window(window)
    l_step, k_step = _args.parse_lag_ratio(lag_ratio, window)
    _args.check_length(len(x2), window)
    starts = _args.check_starts(starts, len(x2), window)
    return _ratio_values(x2, l_step, k_step, starts, window)
