"""Windowed ratio of metric lengths (fractal number) of thesis Sec. 4.3, Eq. 4.3-4.4."""

from __future__ import annotations

import math

import numba
import numpy as np

from leakdiag._validation import parse_lag_ratio
from leakdiag.features import _args
from leakdiag.features._kernels.chunks import CHUNK, NO_STARTS, fill_times
from leakdiag.features._degenerate import warn_degenerate
from leakdiag.features._kernels.stepsums import metric_steps_regular, use_step_kernels
from leakdiag.features.series import FeatureSeries

__all__ = ["metric_length_ratio", "metric_length_ratio_at"]


@numba.njit(cache=True, error_model="numpy")
def _metric_eval(gk, gl, hk, hl, out, o0, cnt):  # pragma: no cover - compiled
    """Eq. 4.3 from the tail/head sums of ``cnt`` windows, written to ``out[o0:o0+cnt]``."""
    bad = 0
    nf = 0  # windows whose sums are not finite: NaN or inf in the input
    for t in range(cnt):
        den = gl[t] + hl[t]
        ok = den > 0.0
        out[o0 + t] = (gk[t] + hk[t]) / den if ok else np.nan
        bad += 0 if ok else 1
        nf += 0 if den - den == 0.0 else 1
    return bad, nf


@numba.njit(cache=True, error_model="numpy")
def _metric_core(x, l_step, k_step, window, starts, step, out):  # pragma: no cover - compiled
    """Eq. 4.3 for windows ``s_k = k * step`` (``step > 0``) or sorted ``starts`` (``step = 0``).

    Sums over ``j = s .. s+N-l-1`` of ``||x_{j+k} - x_j||`` and ``||x_{j+l} - x_j||`` (Euclidean
    norm over the channels of ``x``, shape ``(n, c)``, Eq. 4.4), each split into the tail of the
    block of ``M = N - l`` terms holding ``s`` and the head of the next block, grown window by
    window as in :mod:`leakdiag.features._kernels.blocksums` (backward for tails, forward for heads).
    The terms are non-negative, so no anchor is needed: a window sum adds two partial sums of at
    most ``M`` terms of the window itself (relative error a few ulps times ``M``). The terms are
    computed on the fly (an inner function, which Numba inlines), never stored for the signal.
    Returns the numbers of windows with a zero denominator and of windows whose sums are not
    finite (NaN/inf input).
    """
    n_ch = x.shape[1]

    def step_length(j, lag):
        if n_ch == 1:
            return abs(x[j + lag, 0] - x[j, 0])
        acc = 0.0
        for c in range(n_ch):
            d = x[j + lag, c] - x[j, c]
            acc += d * d
        return math.sqrt(acc)

    mm = window - l_step
    n_win = out.shape[0]
    kc = max(1, min(CHUNK, n_win))
    gk = np.empty(kc)
    gl = np.empty(kc)
    hk = np.empty(kc)
    hl = np.empty(kc)
    n_bad = 0
    n_nonfinite = 0
    for k0 in range(0, n_win, kc):
        k1 = min(k0 + kc, n_win)
        e = -1
        p = 0
        ak = 0.0
        al = 0.0
        for w in range(k1 - 1, k0 - 1, -1):
            s = w * step if step > 0 else starts[w]
            if e < 0 or s < e - mm:
                e = (s // mm + 1) * mm
                p = e
                ak = 0.0
                al = 0.0
            j = p - 1
            while j >= s:  # from the block end down: the same order for any step
                ak += step_length(j, k_step)
                al += step_length(j, l_step)
                j -= 1
            p = s
            gk[w - k0] = ak
            gl[w - k0] = al
        e = -1
        q = 0
        ak = 0.0
        al = 0.0
        for w in range(k0, k1):
            s = w * step if step > 0 else starts[w]
            if e < 0 or s >= e:
                e = (s // mm + 1) * mm
                q = e
                ak = 0.0
                al = 0.0
            j = q
            while j < s + mm:
                ak += step_length(j, k_step)
                al += step_length(j, l_step)
                j += 1
            q = s + mm
            hk[w - k0] = ak
            hl[w - k0] = al
        b, f = _metric_eval(gk, gl, hk, hl, out, k0, k1 - k0)
        n_bad += b
        n_nonfinite += f
    return n_bad, n_nonfinite


@numba.njit(cache=True)
def _metric_sorted(x, l_step, k_step, window, starts):  # pragma: no cover - compiled
    """Eq. 4.3 for sorted valid starts: ``(values, n_zero_denominator)``."""
    out = np.empty(starts.shape[0])
    n_bad, _ = _metric_core(x, l_step, k_step, window, starts, 0, out)
    return out, n_bad


@numba.njit(cache=True)
def _metric_regular(x, l_step, k_step, window, step, n_win, sample_rate, start_time):  # pragma: no cover - compiled
    """Eq. 4.3 for the windows ``s_k = k * step``: ``(values, times, n_zero_denominator,
    n_nonfinite)``, the last counting windows whose sums are not finite (NaN/inf input)."""
    buf = np.empty((2, n_win))
    n_bad, n_nonfinite = _metric_core(x, l_step, k_step, window, NO_STARTS, step, buf[0])
    fill_times(buf[1], step, window, sample_rate, start_time)
    return buf[0], buf[1], n_bad, n_nonfinite


_DEGENERATE = "zero metric length at step l (Eq. 4.3 denominator)"


def _ratio_values(x2: np.ndarray, l_step: int, k_step: int, starts: np.ndarray,
                  window: int) -> np.ndarray:
    starts, order = _args.sort_starts(starts)
    values, n_bad = _metric_sorted(x2, l_step, k_step, window, starts)
    warn_degenerate(n_bad, len(values), _DEGENERATE, stacklevel=4)
    return _args.unsort(values, order)


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
        s; ``settings`` holds ``lag_ratio`` (``"l:k"``), ``l``, ``k``; the geometry fields
        ``window``, ``overlap``, ``step``, ``channels``, ``sample_rate``, ``start_time`` are set.

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
    >>> fs.settings["lag_ratio"], fs.step
    ('83:3', 250)
    """
    x2 = _args.signal_2d(x, "x", finite=False)  # checked with the kernel's help below
    window = _args.check_window(window)
    lag_ratio = parse_lag_ratio(lag_ratio, window)
    plan = _args.plan_windows(len(x2), window, overlap, sample_rate, start_time)
    return metric_length_planned(x2, lag_ratio, plan, _args.channel_names(x, "x", x2.shape[1]))


def metric_length_planned(x2: np.ndarray, lag_ratio: tuple[int, int], plan: _args.WindowPlan,
                          channels: tuple[str, ...]) -> FeatureSeries:
    """Eq. 4.3-4.4 on a checked signal over a checked window plan (the registry's batch path).

    Parameters
    ----------
    x2 : numpy.ndarray
        Writeable C-contiguous float64 signal, shape ``(n, c)``.
    lag_ratio : tuple of int
        Checked ``(l, k)``, ``l > k >= 1``, ``l < plan.window``.
    plan : WindowPlan
        The regular windows.
    channels : tuple of str
        Channel names.

    Returns
    -------
    FeatureSeries
        As :func:`metric_length_ratio`.
    """
    l_step, k_step = lag_ratio
    window = plan.window
    if x2.shape[1] == 1 and use_step_kernels(plan.step):
        values, time, n_bad, n_nonfinite = metric_steps_regular(
            x2.reshape(-1), l_step, k_step, window, plan.step, plan.n_windows, plan.sample_rate,
            plan.start_time)
    else:
        values, time, n_bad, n_nonfinite = _metric_regular(
            x2, l_step, k_step, window, plan.step, plan.n_windows, plan.sample_rate,
            plan.start_time)
    # Eq. 4.3 reads [s, s + N - l + k) and [s + l, s + N) of a window: a gap when 2l - k > N
    _args.finish_finite_check(x2, "x", n_nonfinite, plan,
                              reads_every_sample=2 * l_step - k_step <= window)
    warn_degenerate(n_bad, len(values), _DEGENERATE, stacklevel=4)
    settings = {"lag_ratio": f"{l_step}:{k_step}", "l": l_step, "k": k_step}
    return FeatureSeries(time, values, "metric-length", settings, **plan.geometry(channels))


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
    l_step, k_step = parse_lag_ratio(lag_ratio, window)
    starts = _args.check_starts(starts, len(x2), window)
    return _ratio_values(x2, l_step, k_step, starts, window)
