"""Windowed features of thesis Chapter 4 (Eq. 4.1-4.4, 4.11-4.14).

Public functions return a :class:`FeatureSeries` (one value per window, timestamped at the
window's last sample), except :func:`moments` (a tidy DataFrame). The ``*_at`` functions evaluate
arbitrary window starts in O(n + m) and are the building blocks for sweeps and streaming checks.
See ``docs/features.md``.
"""

from leakdiag.features._degenerate import DegenerateWindowWarning
from leakdiag.features.correlation import (
    autocorrelation,
    autocorrelation_at,
    cross_correlation,
    cross_correlation_at,
)
from leakdiag.features.metric_length import metric_length_ratio, metric_length_ratio_at
from leakdiag.features.moments import MOMENT_COLUMNS, moments, moments_at
from leakdiag.features.series import FeatureSeries
from leakdiag.features.windowing import n_windows, window_starts, window_step, window_times

__all__ = [
    "FeatureSeries",
    "DegenerateWindowWarning",
    "autocorrelation",
    "cross_correlation",
    "metric_length_ratio",
    "moments",
    "autocorrelation_at",
    "cross_correlation_at",
    "metric_length_ratio_at",
    "moments_at",
    "MOMENT_COLUMNS",
    "window_step",
    "window_starts",
    "window_times",
    "n_windows",
]
