"""Plain per-window reference implementations, written straight from the thesis equations.

Slow on purpose: one NumPy evaluation per window, two-pass (mean first, then deviations), no
shared sums. The fast features must agree with these. Degenerate windows (constant window, or a
zero Eq. 4.3 denominator) give NaN here too; a window counts as constant when all its samples are
equal, which is what makes the variance exactly zero.

Each window is first shifted by its own first sample (``w - w[0]``; Eq. 4.1-4.2 and 4.12-4.14
are invariant to it, and for samples within a factor 2 of each other the subtraction is exact),
then its mean is computed in two passes (``m = mean(w)``, then ``m += mean(w - m)``). Without
this, the double nearest to the mean of 8.6e6 + kPa noise, or of two nearly equal samples, is off
by up to half an ulp of 8.6e6 (1e-9 Pa), which alone moves Eq. 4.1 by ~1e-9 relative: the
reference would be the less accurate side (checked against exact rational arithmetic in
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


def _shifted(w) -> np.ndarray:
    w = np.asarray(w, dtype=np.float64)
    return w - w[0]


def autocorrelation_window(w: np.ndarray, lag: int) -> float:
    """Eq. 4.1 on one window."""
    w = _shifted(w)
    if np.all(w == 0):
        return np.nan
    d = w - window_mean(w)
    n = len(w)
    return float(np.sum(d[: n - lag] * d[lag:]) / np.sum(d * d))


def cross_correlation_window(wy: np.ndarray, wx: np.ndarray, lag: int) -> float:
    """Eq. 4.2 on one window, population variances."""
    wy = _shifted(wy)
    wx = _shifted(wx)
    if np.all(wy == 0) or np.all(wx == 0):
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
    mean = float(w[0] + window_mean(w - w[0]))
    if np.all(w == w[0]):
        return mean, 0.0, np.nan, np.nan
    w = _shifted(w)
    d = w - window_mean(w)
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
