"""Plain per-window reference implementations, written straight from the thesis equations.

Slow on purpose: one NumPy evaluation per window, two-pass (mean first, then deviations), no
shared sums. The fast features must agree with these. Degenerate windows (constant window, or a
zero Eq. 4.3 denominator) give NaN here too; a window counts as constant when all its samples are
equal, which is what makes the variance exactly zero.

The window mean is computed in two passes (``m = mean(w)``, then ``m += mean(w - m)``): the
plain ``mean(w)`` of 5 + 1e-6 noise is off by ~1e-15 absolute, i.e. 1e-9 of the spread, and that
alone moves Eq. 4.1 by up to 1e-9 relative (checked against exact rational arithmetic in
``test_reference_vs_exact``).
"""

from __future__ import annotations

import numpy as np

from leakdiag.features.windowing import window_starts


def starts_of(n: int, window: int, overlap: float) -> np.ndarray:
    return window_starts(n, window, overlap)


def window_mean(w: np.ndarray) -> float:
    """Mean with one correction pass (see module docstring)."""
    m = np.mean(w)
    return float(m + np.mean(w - m))


def autocorrelation_window(w: np.ndarray, lag: int) -> float:
    """Eq. 4.1 on one window."""
    w = np.asarray(w, dtype=np.float64)
    if np.all(w == w[0]):
        return np.nan
    d = w - window_mean(w)
    n = len(w)
    return float(np.sum(d[: n - lag] * d[lag:]) / np.sum(d * d))


def cross_correlation_window(wy: np.ndarray, wx: np.ndarray, lag: int) -> float:
    """Eq. 4.2 on one window, population variances."""
    wy = np.asarray(wy, dtype=np.float64)
    wx = np.asarray(wx, dtype=np.float64)
    if np.all(wy == wy[0]) or np.all(wx == wx[0]):
        return np.nan
    n = len(wx)
    dy = wy - window_mean(wy)
    dx = wx - window_mean(wx)
    var_x = np.sum(dx * dx) / n
    var_y = np.sum(dy * dy) / n
    return float((1.0 / n) * np.sum(dy[: n - lag] * dx[lag:]) / np.sqrt(var_x * var_y))


def metric_length_ratio_window(w: np.ndarray, l_step: int, k_step: int) -> float:
    """Eq. 4.3 on one window (rows = samples, columns = channels; Eq. 4.4 Euclidean norm)."""
    w = np.asarray(w, dtype=np.float64)
    if w.ndim == 1:
        w = w[:, None]
    n = len(w)
    m = n - l_step
    num = np.sum(np.sqrt(np.sum((w[k_step : k_step + m] - w[:m]) ** 2, axis=1)))
    den = np.sum(np.sqrt(np.sum((w[l_step : l_step + m] - w[:m]) ** 2, axis=1)))
    if den == 0:
        return np.nan
    return float(num / den)


def moments_window(w: np.ndarray) -> tuple[float, float, float, float]:
    """Eq. 4.11-4.14 on one window: mean, population variance, skewness, kurtosis."""
    w = np.asarray(w, dtype=np.float64)
    n = len(w)
    mean = window_mean(w)
    if np.all(w == w[0]):
        return mean, 0.0, np.nan, np.nan
    d = w - mean
    var = float(np.sum(d**2) / n)
    s = np.sqrt(np.sum(d**2) / (n - 1))
    skew = float(np.sum(d**3) / ((n - 1) * s**3))
    kurt = float(np.sum(d**4) / ((n - 1) * s**4))
    return mean, var, skew, kurt


def autocorrelation_ref(x, lag: int, window: int, overlap: float) -> np.ndarray:
    x = np.asarray(x, dtype=np.float64)
    return np.array([autocorrelation_window(x[s : s + window], lag)
                     for s in starts_of(len(x), window, overlap)])


def cross_correlation_ref(y, x, lag: int, window: int, overlap: float) -> np.ndarray:
    y = np.asarray(y, dtype=np.float64)
    x = np.asarray(x, dtype=np.float64)
    return np.array([cross_correlation_window(y[s : s + window], x[s : s + window], lag)
                     for s in starts_of(len(x), window, overlap)])


def metric_length_ratio_ref(x, l_step: int, k_step: int, window: int, overlap: float) -> np.ndarray:
    x = np.asarray(x, dtype=np.float64)
    return np.array([metric_length_ratio_window(x[s : s + window], l_step, k_step)
                     for s in starts_of(len(x), window, overlap)])


def moments_ref(x, window: int, overlap: float) -> np.ndarray:
    """Array of shape (windows, 4): mean, variance, skewness, kurtosis."""
    x = np.asarray(x, dtype=np.float64)
    return np.array([moments_window(x[s : s + window])
                     for s in starts_of(len(x), window, overlap)]).reshape(-1, 4)
