"""Numba kernels that compute every complete window inside a buffer (streaming path).

A kernel receives a buffer whose first sample is the first sample of a window, the number of
complete windows ``n_win`` in it, the step and the window size ``N``, and writes one value per
window into ``out``. Each window is computed on its own (two-pass mean, no running sums), so the
streaming result does not drift over hours of data and equals a per-window batch computation.

A window is *degenerate* when all its samples are equal (zero variance, Eq. 4.1/4.2) or all its
``l``-step differences are zero (Eq. 4.3); its value is NaN and the caller counts it.

The kernels only compute; the validating wrappers live in :mod:`leakdiag.stream.feature`.
"""

from __future__ import annotations

import numba
import numpy as np

__all__: list[str] = []


@numba.njit(cache=True)
def _window_mean_is_constant(x, s, window):
    """Return (mean, constant) of ``x[s:s+window]``."""
    total = 0.0
    lo = x[s]
    hi = x[s]
    for j in range(s, s + window):
        v = x[j]
        total += v
        if v < lo:
            lo = v
        elif v > hi:
            hi = v
    return total / window, lo == hi


@numba.njit(cache=True)
def _autocorrelation_windows(x, n_win, step, window, lag, out):
    """Eq. 4.1 for windows starting at ``0, step, ..., (n_win-1)*step`` of ``x``."""
    for m in range(n_win):
        s = m * step
        mean, constant = _window_mean_is_constant(x, s, window)
        if constant:
            out[m] = np.nan
            continue
        den = 0.0
        num = 0.0
        for j in range(s, s + window - lag):
            d = x[j] - mean
            den += d * d
            num += d * (x[j + lag] - mean)
        for j in range(s + window - lag, s + window):
            d = x[j] - mean
            den += d * d
        out[m] = num / den


@numba.njit(cache=True)
def _cross_correlation_windows(y, x, n_win, step, window, lag, out):
    """Eq. 4.2 (population variances) for windows of the pair ``(y, x)``."""
    for m in range(n_win):
        s = m * step
        my, cy = _window_mean_is_constant(y, s, window)
        mx, cx = _window_mean_is_constant(x, s, window)
        if cy or cx:
            out[m] = np.nan
            continue
        vy = 0.0
        vx = 0.0
        num = 0.0
        for j in range(s, s + window):
            dy = y[j] - my
            dx = x[j] - mx
            vy += dy * dy
            vx += dx * dx
            if j + lag < s + window:
                num += dy * (x[j + lag] - mx)
        vy /= window
        vx /= window
        out[m] = num / window / np.sqrt(vx * vy)


@numba.njit(cache=True)
def _metric_length_ratio_windows(x, n_win, step, window, ell, k, out):
    """Eq. 4.3 with the Euclidean norm (Eq. 4.4) over the channels (rows) of ``x``."""
    n_ch = x.shape[0]
    for m in range(n_win):
        s = m * step
        num = 0.0
        den = 0.0
        for j in range(s, s + window - ell):
            if n_ch == 1:
                num += abs(x[0, j + k] - x[0, j])
                den += abs(x[0, j + ell] - x[0, j])
            else:
                a = 0.0
                b = 0.0
                for c in range(n_ch):
                    da = x[c, j + k] - x[c, j]
                    db = x[c, j + ell] - x[c, j]
                    a += da * da
                    b += db * db
                num += np.sqrt(a)
                den += np.sqrt(b)
        out[m] = num / den if den > 0.0 else np.nan
